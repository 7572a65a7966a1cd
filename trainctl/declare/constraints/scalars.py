# Constraint types of single values: numbers with bounds, integers and flags.
"""The constraint types of one value: :class:`Number` (bounds, finiteness),
:class:`Integer` and :class:`Flag`, and the common numbers :data:`FINITE`,
:data:`POSITIVE` and :data:`NONNEGATIVE`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, replace
from typing import Any

from pydantic import GetCoreSchemaHandler
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.constraints.rule import Rule
from trainctl.declare.violations import Violation

__all__ = ["FINITE", "NONNEGATIVE", "POSITIVE", "Flag", "Integer", "Number"]


def _fmt(x: float) -> str:
    return f"{x:g}"


def _real(value: Any) -> Any:
    """Integers (not bools) become floats; too large ones become +-inf."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        try:
            return float(value)
        except OverflowError:
            return math.inf if int(value) > 0 else -math.inf
    return value


def _integral(value: Any) -> Any:
    """NumPy integers become ints; everything else is left to the int check."""
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, int)):
        return int(value)
    return value


@dataclass(frozen=True)
class Number(Rule):
    """A real number (not a bool), finite unless ``allow_inf``, within bounds.

    Parameters
    ----------
    gt : float or None
        Exclusive lower bound (None: none).
    ge : float or None
        Inclusive lower bound (None: none).
    le : float or None
        Inclusive upper bound (None: none).
    allow_inf : bool
        Accept inf, meaning what ``inf`` says.
    inf : str
        What an infinite value means, for messages (e.g. "no limit").
    why : str
        Why the bounds are where they are, added to a message about a value
        outside them.

    Examples
    --------
    >>> Number(gt=0, le=1).want(), Number(ge=0, allow_inf=True).want(python=True)
    ('a number in (0, 1]', 'a number >= 0, or inf for no limit')
    """

    gt: float | None = None
    ge: float | None = None
    le: float | None = None
    allow_inf: bool = False
    inf: str = "no limit"
    why: str = ""
    """Why the bounds are where they are: a sentence added to a message about a value
    outside them (limits of what trainctl can compute, :mod:`trainctl.declare.limits`)."""

    def _range(self) -> str:
        low = self.gt if self.gt is not None else self.ge
        if self.le is not None and low is not None:
            if self.gt is not None:
                return f" in ({_fmt(low)}, {_fmt(self.le)}]"
            return f" from {_fmt(low)} to {_fmt(self.le)}"
        if self.gt is not None:
            return f" > {_fmt(self.gt)}"
        if self.ge is not None:
            return f" >= {_fmt(self.ge)}"
        return f" <= {_fmt(self.le)}" if self.le is not None else ""

    def want(self, *, python: bool = False, finite: bool = False) -> str:
        """What a valid value is; ``finite`` (or a Python caller) says "finite".

        Parameters
        ----------
        python : bool
            Word it for a Python caller: "a finite number ...".
        finite : bool
            Say "finite" for a scenario file too (the value given was inf or
            nan).

        Returns
        -------
        str
            E.g. ``"a finite number > 0"``; with ``allow_inf``, the range
            followed by ``", or inf for "`` and :attr:`inf`, never "finite".
        """
        if self.allow_inf:
            return f"a number{self._range()}, or inf for {self.inf}"
        return f"a {'finite ' if finite or python else ''}number{self._range()}"

    def plural(self) -> str:
        """Items of an array, e.g. ``"numbers >= 0"``.

        Returns
        -------
        str
            ``"numbers"`` followed by the range of the bounds.
        """
        return f"numbers{self._range()}"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Strict float with bounds; ints widen, nan and inf fail unless allowed.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here (the check needs no other type's schema).

        Returns
        -------
        pydantic_core.CoreSchema
            A strict float schema with ``gt``, ``ge`` and ``le``, refusing nan
            and inf unless ``allow_inf`` (then nan still fails any bound),
            behind a conversion of integers (not bools) to floats (too large
            ones to +-inf).
        """
        number = core_schema.float_schema(
            gt=self.gt, ge=self.ge, le=self.le, allow_inf_nan=self.allow_inf, strict=True
        )
        return core_schema.no_info_before_validator_function(_real, number)

    def for_file(self) -> Number:
        """Files give finite numbers only (an omitted limit means no limit).

        Returns
        -------
        Number
            A copy of this rule with ``allow_inf`` False.
        """
        return replace(self, allow_inf=False)

    def _side(self, error_type: str) -> Number:
        """A hard limit (with ``why``) names the bound that failed: the upper one, or else
        the lower one (type and finiteness errors too); other rules their whole range."""
        if not self.why:
            return self
        if error_type == "less_than_equal":
            return replace(self, gt=None, ge=None)
        return replace(self, le=None) if self.gt is not None or self.ge is not None else self

    def _explained(self, error_type: str) -> bool:
        """Whether ``why`` explains the bound that failed: any upper bound, and a lower
        bound other than the plain sign conditions > 0 and >= 0 (which need no reason)."""
        if error_type == "less_than_equal":
            return True
        return (self.gt, self.ge) not in ((0, None), (None, 0), (None, None))

    def explain(self, error_type: str, value: Any) -> Violation:
        """Type, finiteness or bound; a quoted number gets a hint, a bound its reason.

        Parameters
        ----------
        error_type : str
            The pydantic error type of the failed core check, e.g.
            ``"float_type"``, ``"finite_number"`` or ``"less_than_equal"``.
        value : object
            The value given.

        Returns
        -------
        Violation
            ``"must be "`` and what is wanted: with ``why`` set, only the bound
            that failed (for a wrong type or a value that is not finite, the
            lower bound if there is one), else the whole range; "finite" for
            inf or nan (got as a float). ``why`` is the hint for a value outside a bound it
            explains; a string gets the file hint to write numbers without
            quotes.
        """
        finite = error_type == "finite_number" or (
            isinstance(_real(value), float) and not math.isfinite(_real(value))
        )
        value_error = error_type != "float_type"
        side = self._side(error_type)
        return Violation(
            text=f"must be {side.want(finite=finite)}",
            python_text=f"must be {side.want(python=True)}",
            got=_real(value) if finite else value,
            hint=f" {self.why}" if self.why and value_error and not finite
            and self._explained(error_type) else "",
            file_hint=" Write numbers without quotes." if isinstance(value, str) else "",
            value=value_error,
            finite=finite,
        )


@dataclass(frozen=True)
class Integer(Rule):
    """An integer (not a bool or float) >= ``ge``.

    Parameters
    ----------
    ge : int
        Smallest allowed value.
    le : int or None
        Largest allowed value (None: no upper bound).
    why : str
        Why the bounds are where they are (see :class:`Number`).

    Examples
    --------
    >>> Integer(ge=1).want()
    'an integer >= 1'
    """

    ge: int = 0
    le: int | None = None
    why: str = ""
    """Why the bounds are where they are (see :class:`Number`)."""

    def _range(self) -> str:
        return f" >= {self.ge}" if self.le is None else f" from {self.ge} to {self.le}"

    def want(self, *, python: bool = False) -> str:
        """``"an integer >= ge"`` or ``"an integer from ge to le"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller; the wording is the same.

        Returns
        -------
        str
            ``"an integer"`` followed by the range of the bounds.
        """
        return f"an integer{self._range()}"

    def plural(self) -> str:
        """``"integers >= ge"``.

        Returns
        -------
        str
            ``"integers"`` followed by the range of the bounds.
        """
        return f"integers{self._range()}"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Strict int; NumPy integers are accepted.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here (the check needs no other type's schema).

        Returns
        -------
        pydantic_core.CoreSchema
            A strict int schema with ``ge`` and ``le``, behind a conversion of
            NumPy integers to int (bools and floats fail).
        """
        integer = core_schema.int_schema(ge=self.ge, le=self.le, strict=True)
        return core_schema.no_info_before_validator_function(_integral, integer)

    def explain(self, error_type: str, value: Any) -> Violation:
        """Type or bound (the one that failed, with its reason).

        Parameters
        ----------
        error_type : str
            The pydantic error type of the failed core check, e.g.
            ``"int_type"``, ``"greater_than_equal"`` or ``"less_than_equal"``.
        value : object
            The value given.

        Returns
        -------
        Violation
            ``"must be an integer <= le"`` for a value above ``le``, else
            ``"must be an integer >= ge"``; a wrong value (not a wrong type)
            gets ``why`` as its hint.
        """
        side = replace(self, le=None) if error_type != "less_than_equal" else self
        violation = super(Integer, side).explain(error_type, value)
        if error_type == "less_than_equal":
            violation = replace(violation, text=f"must be an integer <= {self.le}",
                                python_text=f"must be an integer <= {self.le}")
        if self.why and violation.value:
            return replace(violation, hint=f" {self.why}")
        return violation


@dataclass(frozen=True)
class Flag(Rule):
    """A boolean (TOML ``true`` / ``false``).

    Examples
    --------
    Strict: 1 is not a boolean.

    >>> from typing import Annotated
    >>> from pydantic import TypeAdapter, ValidationError
    >>> flag = TypeAdapter(Annotated[bool, Flag()])
    >>> flag.validate_python(True)
    True
    >>> try:
    ...     flag.validate_python(1)
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["ctx"]["violation"].text)
    must be true or false
    >>> Flag().doc_type(), Flag().want(python=True)
    ('boolean', 'True or False')
    """

    def want(self, *, python: bool = False) -> str:
        """``"true or false"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller: ``"True or False"``.

        Returns
        -------
        str
            ``"true or false"``, or ``"True or False"`` for Python.
        """
        return "True or False" if python else "true or false"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Strict bool.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here (the check needs no other type's schema).

        Returns
        -------
        pydantic_core.CoreSchema
            A strict bool schema (1 and ``"true"`` fail).
        """
        return core_schema.bool_schema(strict=True)

    def doc_type(self) -> str:
        """``"boolean"``.

        Returns
        -------
        str
            ``"boolean"``.
        """
        return "boolean"


FINITE = Number()
"""A finite number."""

POSITIVE = Number(gt=0)
"""A finite number > 0."""

NONNEGATIVE = Number(ge=0)
"""A finite number >= 0."""
