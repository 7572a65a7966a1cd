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
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from pydantic import GetCoreSchemaHandler, GetJsonSchemaHandler, ValidationError
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.violations import ERROR_TYPE as ERROR_TYPE
from trainctl.declare.violations import NOTHING as NOTHING
from trainctl.declare.violations import Violation as Violation
from trainctl.declare.violations import fail as fail
from trainctl.declare.violations import raise_at as raise_at
from trainctl.declare.violations import suggest as suggest
from trainctl.naming import _UNPRINTABLE_CLASS
from trainctl.naming import UNPRINTABLE as UNPRINTABLE

__all__ = ["FINITE", "NONNEGATIVE", "NOTHING", "POSITIVE", "UNPRINTABLE", "Array", "Choice",
           "Flag", "Integer", "NameList", "Number", "Rule", "Text", "Violation", "fail", "raise_at",
           "suggest"]


def _fmt(x: float) -> str:
    return f"{x:g}"


def _or(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " or " + items[-1]


class Rule:
    """Base class: Annotated metadata that pydantic enforces and trainctl words.

    Subclasses give the core schema that checks a value (:meth:`schema`) and
    the phrase that names what is allowed (:meth:`want`).

    Examples
    --------
    A rule of one's own needs the phrase and the core schema; the wording of
    the failure follows from :meth:`want`:

    >>> from typing import Annotated
    >>> from pydantic import TypeAdapter, ValidationError
    >>> class Even(Rule):
    ...     def want(self, *, python=False):
    ...         return "an even integer"
    ...     def schema(self, handler):
    ...         return core_schema.int_schema(strict=True, multiple_of=2)
    >>> Even().doc_type()
    'even integer'
    >>> even = TypeAdapter(Annotated[int, Even()])
    >>> even.validate_python(4)
    4
    >>> try:
    ...     even.validate_python(3)
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["ctx"]["violation"].text)
    must be an even integer
    """

    def want(self, *, python: bool = False) -> str:
        """What a valid value is, e.g. ``"a number > 0"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller rather than for a scenario file (e.g.
            ``True or False`` instead of ``true or false``).

        Returns
        -------
        str
            A noun phrase with its article that completes "must be ...".

        Raises
        ------
        NotImplementedError
            Always: each subclass gives its own phrase.
        """
        raise NotImplementedError

    def plural(self) -> str:
        """The items of an array of such values, e.g. ``"numbers >= 0"``.

        Returns
        -------
        str
            The phrase that completes "an array of 3 ..."; here :meth:`want`
            unchanged, subclasses give a plural.
        """
        return self.want()

    def doc_type(self) -> str:
        """The type column of the documentation, e.g. ``"number > 0"`` (Markdown).

        Returns
        -------
        str
            :meth:`want` without its leading article "a" or "an".
        """
        want = self.want()
        return want.split(" ", 1)[1] if want.startswith(("a ", "an ")) else want

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """The pydantic core schema that performs the check.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``; a
            rule made of other rules (:class:`Array`) builds their schemas with it.

        Returns
        -------
        pydantic_core.CoreSchema
            The schema that checks the type, the bounds and finiteness; its
            failures are worded by :meth:`explain`.

        Raises
        ------
        NotImplementedError
            Always: each subclass gives its own schema.
        """
        raise NotImplementedError

    def for_file(self) -> Rule:
        """The rule for a scenario file (TOML values; no inf, no shortcuts).

        Returns
        -------
        Rule
            This rule itself; subclasses return a stricter copy where files
            allow less than Python callers.
        """
        return self

    def explain(self, error_type: str, value: Any) -> Violation:
        """The violation for a failed check of pydantic type ``error_type``.

        Parameters
        ----------
        error_type : str
            The pydantic error type of the failed core check, e.g.
            ``"greater_than"`` or ``"float_type"``; one ending in ``_type``
            means a value of the wrong type.
        value : object
            The value given.

        Returns
        -------
        Violation
            ``"must be "`` followed by :meth:`want` (worded for files and for
            Python callers), with ``value`` as the value got; its ``value`` flag
            is False for a wrong type.
        """
        return Violation(
            text=f"must be {self.want()}",
            python_text=f"must be {self.want(python=True)}",
            got=value,
            value=not error_type.endswith("_type"),
        )

    def check(self, value: Any, info: core_schema.ValidationInfo | None) -> Any:
        """Checks pydantic cannot express, after :meth:`schema` passed.

        Parameters
        ----------
        value : object
            The value as :meth:`schema` returned it (converted, e.g. to a tuple).
        info : pydantic_core.core_schema.ValidationInfo or None
            pydantic's validation info; its ``context`` is the validation
            context (None: no info).

        Returns
        -------
        object
            The value to keep; here ``value`` unchanged.
        """
        return value

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> CoreSchema:
        """Wrap :meth:`schema` so that failures carry this rule's wording."""

        def wrap(value: Any, inner: Any, info: core_schema.ValidationInfo) -> Any:
            try:
                result = inner(value)
            except ValidationError as exc:
                error = exc.errors()[0]
                if error["loc"] or error["type"] == ERROR_TYPE:
                    raise
                raise fail(self.explain(error["type"], value)) from None
            return self.check(result, info)

        return core_schema.with_info_wrap_validator_function(wrap, self.schema(handler))

    def __get_pydantic_json_schema__(
        self, schema: CoreSchema, handler: GetJsonSchemaHandler
    ) -> JsonSchemaValue:
        """The JSON Schema of the inner check, plus :meth:`json_extra`."""
        return {**handler(schema), **self.json_extra()}

    def json_extra(self) -> dict[str, Any]:
        """JSON Schema keywords the core schema does not give.

        Returns
        -------
        dict of str to object
            Keywords added to the JSON Schema of the core schema; empty here.
        """
        return {}


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


@dataclass(frozen=True)
class Text(Rule):
    """A string without control characters; optionally with a non-space character, or on one line.

    Control characters (C0 and C1, DEL; a line feed and a tab are text) and
    the bidirectional-text controls (U+202A..U+202E, U+2066..U+2069, ...) are
    refused: a name reaches HTML pages and terminals, where a NUL, an escape
    sequence or a right-to-left override would corrupt or forge what is shown
    (see :data:`UNPRINTABLE`).

    Parameters
    ----------
    nonblank : bool
        Require at least one character that is not white space.
    single_line : bool
        Refuse line breaks.

    Examples
    --------
    >>> from typing import Annotated
    >>> from pydantic import TypeAdapter, ValidationError
    >>> def problem(rule, value):
    ...     try:
    ...         TypeAdapter(Annotated[str, rule]).validate_python(value)
    ...     except ValidationError as exc:
    ...         return exc.errors()[0]["ctx"]["violation"].text
    >>> problem(Text(nonblank=True), "  "), problem(Text(single_line=True), "a\\nb")
    ('must be a non-empty string', 'must be a single line')
    >>> both = Text(nonblank=True, single_line=True)
    >>> problem(both, "a\\nb"), problem(both, " "), problem(both, " \\n "), problem(both, "a b")
    ('must be a single line', 'must be a non-empty string', 'must be a non-empty string', None)
    >>> problem(Text(), 3), problem(Text(nonblank=True), "CRH2") is None
    ('must be a string', True)
    >>> problem(Text(), "red \\x1b[31m"), problem(both, "abc\\u202e")
    ('must not contain control characters', 'must not contain control characters')
    >>> problem(Text(), "two\\nlines\\tand a tab") is None
    True
    """

    nonblank: bool = False
    single_line: bool = False

    def want(self, *, python: bool = False) -> str:
        """``"a string"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller; the wording is the same.

        Returns
        -------
        str
            ``"a string"``.
        """
        return "a string"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Strict str with the pattern of the options.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here (the check needs no other type's schema).

        Returns
        -------
        pydantic_core.CoreSchema
            A strict str schema; with ``nonblank`` its pattern asks for a
            character that is not white space, with ``single_line`` it refuses
            line breaks, with both it asks for both.
        """
        other = _UNPRINTABLE_CLASS + (r"\n" if self.single_line else "")
        mark = rf"[^\s{_UNPRINTABLE_CLASS}]" if self.nonblank else ""
        pattern = rf"^[^{other}]*{mark}[^{other}]*$" if mark else rf"^[^{other}]*$"
        return core_schema.str_schema(strict=True, pattern=pattern)

    def explain(self, error_type: str, value: Any) -> Violation:
        """A wrong type, a blank string or a line break.

        Parameters
        ----------
        error_type : str
            The pydantic error type of the failed core check;
            ``"string_pattern_mismatch"`` for a blank string or a line break.
        value : object
            The value given.

        Returns
        -------
        Violation
            ``"must be a string"`` for a wrong type, else ``"must not contain
            control characters"``, ``"must be a non-empty string"``
            (``nonblank``, a blank value) or ``"must be a single line"``.
        """
        if error_type != "string_pattern_mismatch":
            return super().explain(error_type, value)
        bad = UNPRINTABLE.search(value) if isinstance(value, str) else None
        if bad is not None:
            return Violation(
                text="must not contain control characters", got=value,
                hint=f" Character {bad.start() + 1} is U+{ord(bad.group()):04X}; remove it (a TOML "
                     "escape such as \\u001b stands for that character).")
        blank = not isinstance(value, str) or not value.strip()
        text = ("must be a non-empty string" if self.nonblank and (blank or not self.single_line)
                else "must be a single line")
        return Violation(text=text, got=value)


@dataclass(frozen=True)
class Choice(Rule):
    """One string out of a fixed vocabulary, with a near-miss suggestion.

    Parameters
    ----------
    options : tuple of str
        The accepted strings.
    hint : str
        A sentence added to the message about a string outside ``options``.

    Examples
    --------
    >>> Choice(("u", "du")).want(), Choice(("u", "du")).want(python=True)
    ("one of 'u', 'du'", "one of ('u', 'du')")
    """

    options: tuple[str, ...]
    hint: str = ""

    def want(self, *, python: bool = False) -> str:
        """``"one of 'a', 'b'"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller: the options as a tuple,
            ``"one of ('a', 'b')"``.

        Returns
        -------
        str
            ``"one of "`` followed by the quoted options.
        """
        if python:
            return f"one of {self.options!r}"
        return "one of " + ", ".join(repr(o) for o in self.options)

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """A literal of the options (a string never equals a bool or number).

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here (the check needs no other type's schema).

        Returns
        -------
        pydantic_core.CoreSchema
            A literal schema of ``options``.
        """
        return core_schema.literal_schema(list(self.options))

    def doc_type(self) -> str:
        """The options as TOML strings quoted for Markdown, joined by commas and "or".

        Returns
        -------
        str
            E.g. ``'`"u"` or `"du"`'``.
        """
        return _or([f'`"{o}"`' for o in self.options])

    def explain(self, error_type: str, value: Any) -> Violation:
        """Lists the options and suggests the closest.

        Parameters
        ----------
        error_type : str
            The pydantic error type of the failed core check (e.g.
            ``"literal_error"``).
        value : object
            The value given.

        Returns
        -------
        Violation
            ``"must be one of ..."`` with a "Did you mean" suggestion for a near
            miss followed by ``hint``; its ``value`` flag is True for a string
            only (anything else is a wrong type).
        """
        return replace(
            super().explain(error_type, value),
            hint=suggest(value, self.options) + self.hint,
            value=isinstance(value, str),
        )


@dataclass(frozen=True)
class NameList(Rule):
    """A non-empty array of distinct names from a vocabulary, order kept.

    ``options`` may be a callable that reads the vocabulary from the
    validation context (e.g. the strategies of the families in a scenario).
    From Python a single name stands for a one-item tuple.

    Parameters
    ----------
    options : tuple of str or callable
        The vocabulary, or a function of the validation context returning it.
    noun : str
        What one name is called in messages and documentation.
    hint : str or callable
        A sentence added to the message about an unknown name, or a function
        of that name returning one.
    single : bool
        Accept a bare string for a one-item tuple (from Python; files must
        write an array).

    Examples
    --------
    >>> from typing import Annotated
    >>> from pydantic import TypeAdapter, ValidationError
    >>> names = TypeAdapter(Annotated[tuple, NameList(("centralised", "ndmpc"), noun="strategy")])
    >>> names.validate_python("ndmpc"), names.validate_python(["ndmpc", "centralised"])
    (('ndmpc',), ('ndmpc', 'centralised'))
    >>> for bad in (["ndmpc", "ndmpc"], ["nmdpc"]):
    ...     try:
    ...         names.validate_python(bad)
    ...     except ValidationError as exc:
    ...         print(exc.errors()[0]["ctx"]["violation"].text)
    must not repeat an earlier strategy
    must be one of 'centralised', 'ndmpc'
    """

    options: tuple[str, ...] | Callable[[dict[str, Any] | None], tuple[str, ...]]
    noun: str = "name"
    hint: str | Callable[[object], str] = ""
    single: bool = True

    def names(self, context: dict[str, Any] | None = None) -> tuple[str, ...]:
        """The vocabulary (for ``context``).

        Parameters
        ----------
        context : dict of str to object or None
            The validation context, passed to ``options`` when it is a callable
            (None: no context, e.g. for the documentation).

        Returns
        -------
        tuple of str
            The allowed names.
        """
        return self.options if isinstance(self.options, tuple) else self.options(context)

    def want(self, *, python: bool = False, context: dict[str, Any] | None = None) -> str:
        """``"a non-empty array of distinct names from 'a', 'b'"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller; the wording is the same.
        context : dict of str to object or None
            The validation context the vocabulary is read from (see
            :meth:`names`).

        Returns
        -------
        str
            The phrase, listing the allowed names quoted.
        """
        names = ", ".join(repr(o) for o in self.names(context))
        return f"a non-empty array of distinct names from {names}"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """A non-empty tuple (lists accepted); a bare string from Python.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here (the check needs no other type's schema).

        Returns
        -------
        pydantic_core.CoreSchema
            A tuple schema of at least one item of any type; with ``single``, a
            bare string becomes a one-item tuple first. The items are checked
            by :meth:`check`.
        """
        items = core_schema.tuple_schema([core_schema.any_schema()], variadic_item_index=0,
                                         min_length=1)
        if not self.single:
            return items
        return core_schema.no_info_before_validator_function(
            lambda v: (v,) if isinstance(v, str) else v, items
        )

    def for_file(self) -> NameList:
        """Files must write an array.

        Returns
        -------
        NameList
            A copy of this rule with ``single`` False.
        """
        return replace(self, single=False)

    def check(self, value: Any, info: core_schema.ValidationInfo | None) -> Any:
        """Each item is a known name, listed once.

        Parameters
        ----------
        value : tuple of object
            The non-empty tuple :meth:`schema` returned.
        info : pydantic_core.core_schema.ValidationInfo or None
            pydantic's validation info; its ``context`` gives the vocabulary
            (None: no context).

        Returns
        -------
        tuple of str
            ``value`` unchanged.

        Raises
        ------
        pydantic.ValidationError
            At the index of the first item that is not a known name (with a
            suggestion and ``hint``) or that repeats an earlier one.
        """
        context = info.context if info is not None else None
        names = self.names(context)
        for i, item in enumerate(value):
            if not isinstance(item, str) or item not in names:
                hint = self.hint(item) if callable(self.hint) else self.hint
                raise_at((i,), Choice(names, hint=hint).explain("literal_error", item), item)
            if item in value[:i]:
                text = f"must not repeat an earlier {self.noun}"
                raise_at((i,), Violation(text=text, got_text=f"{item!r} again",
                                         hint=f" List each {self.noun} once."), item)
        return value

    def explain(self, error_type: str, value: Any) -> Violation:
        """Not an array, or an empty one.

        Parameters
        ----------
        error_type : str
            The pydantic error type of the failed core check; every failure is
            worded the same.
        value : object
            The value given.

        Returns
        -------
        Violation
            ``"must be "`` followed by :meth:`want` (without context), with
            ``value`` as the value got.
        """
        return Violation(text=f"must be {self.want()}", got=value)

    def doc_type(self) -> str:
        """The type column of an array of names: the allowed names quoted for Markdown.

        Returns
        -------
        str
            ``"non-empty array of distinct "`` followed by the names (at most
            six) joined by commas and "or", or by ``noun`` and ``"names"``.
        """
        names = self.names()
        return "non-empty array of distinct " + (
            _or([f'`"{o}"`' for o in names]) if len(names) <= 6 else f"{self.noun} names"
        )

    def json_extra(self) -> dict[str, Any]:
        """Items from the vocabulary, unique.

        Returns
        -------
        dict of str to object
            ``items`` as an ``enum`` of the names (read without context) and
            ``uniqueItems`` True.
        """
        return {"items": {"enum": list(self.names())}, "uniqueItems": True}


@dataclass(frozen=True)
class Array(Rule):
    """An array of values that each follow ``item``; stored as a tuple.

    Parameters
    ----------
    item : Rule
        The rule every element follows.
    length : int or None
        The exact number of elements; None: any number, at least one.
    extra : dict
        Further JSON Schema keywords declared with the array.

    Examples
    --------
    >>> Array(Number(ge=0), length=3).want()
    'an array of 3 numbers >= 0'
    """

    item: Rule
    length: int | None = None
    extra: dict[str, Any] = field(default_factory=dict, compare=False)

    def want(self, *, python: bool = False) -> str:
        """``"an array of 3 numbers >= 0"`` or ``"a non-empty array of ..."``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller; the wording is the same (the item's
            :meth:`Rule.plural`).

        Returns
        -------
        str
            The phrase, with the number of items when ``length`` is set.
        """
        if self.length is not None:
            return f"an array of {self.length} {self.item.plural()}"
        return f"a non-empty array of {self.item.plural()}"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """A tuple (lists accepted) of the item rule, of the given length.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``,
            used to build the schema of the item rule.

        Returns
        -------
        pydantic_core.CoreSchema
            A tuple schema whose items follow ``item``, with exactly ``length``
            items, or at least one when ``length`` is None.
        """
        item = self.item.__get_pydantic_core_schema__(Any, handler)
        return core_schema.tuple_schema(
            [item], variadic_item_index=0, min_length=self.length or 1, max_length=self.length
        )

    def for_file(self) -> Array:
        """The item rule for files.

        Returns
        -------
        Array
            A copy of this rule whose ``item`` is the item rule's
            :meth:`Rule.for_file`.
        """
        return replace(self, item=self.item.for_file())

    def json_extra(self) -> dict[str, Any]:
        """Extra keywords declared with the array.

        Returns
        -------
        dict of str to object
            A copy of ``extra``.
        """
        return dict(self.extra)


FINITE = Number()
"""A finite number."""

POSITIVE = Number(gt=0)
"""A finite number > 0."""

NONNEGATIVE = Number(ge=0)
"""A finite number >= 0."""
