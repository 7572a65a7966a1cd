# Shared constraint types: each rule enforced by pydantic and worded once.
"""Constraint types shared by the settings classes and the scenario schema.

A constraint is a :class:`Rule` used as ``typing.Annotated`` metadata:
pydantic enforces it (its core schemas check the type, the bounds and
finiteness) and the rule words it, once: ``must be a number > 0``. The same
rule checks a value written in a scenario file (the scenario package turns a
failure into a :class:`~trainctl.exceptions.ScenarioError` with the key
path) and a value passed to a settings class from Python (a
:class:`~trainctl.exceptions.ModelError`, see :mod:`trainctl.declare.keys`).

A failed rule raises a pydantic error of type ``"trainctl"`` whose context
holds a :class:`~trainctl.declare.violations.Violation`: the predicate, the value
given and a hint. Rules that span several fields (model validators) raise the
same kind of error with :func:`~trainctl.declare.violations.raise_at`; both are
re-exported here.

Examples
--------
>>> from typing import Annotated
>>> from pydantic import TypeAdapter, ValidationError
>>> positive = TypeAdapter(Annotated[float, Number(gt=0)])
>>> positive.validate_python(3)
3.0
>>> try:
...     positive.validate_python(-1.0)
... except ValidationError as exc:
...     print(exc.errors()[0]["ctx"]["violation"].text)
must be a number > 0

The package, by job: :mod:`~trainctl.declare.constraints.rule` (the base class),
:mod:`~trainctl.declare.constraints.scalars` (numbers, integers, flags),
:mod:`~trainctl.declare.constraints.text` (text, choices, name lists) and
:mod:`~trainctl.declare.constraints.arrays` (arrays).
"""

from trainctl.declare.constraints.arrays import Array
from trainctl.declare.constraints.rule import Rule
from trainctl.declare.constraints.scalars import (
    FINITE,
    NONNEGATIVE,
    POSITIVE,
    Flag,
    Integer,
    Number,
)
from trainctl.declare.constraints.text import UNPRINTABLE, Choice, NameList, Text
from trainctl.declare.violations import ERROR_TYPE as ERROR_TYPE
from trainctl.declare.violations import NOTHING as NOTHING
from trainctl.declare.violations import Violation as Violation
from trainctl.declare.violations import fail as fail
from trainctl.declare.violations import raise_at as raise_at
from trainctl.declare.violations import suggest as suggest

__all__ = ["FINITE", "NONNEGATIVE", "NOTHING", "POSITIVE", "UNPRINTABLE", "Array", "Choice",
           "Flag", "Integer", "NameList", "Number", "Rule", "Text", "Violation", "fail", "raise_at",
           "suggest"]
