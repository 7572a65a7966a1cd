# Constraint types of words: printable text, a choice among names, a list of names.
"""The constraint types of text: :class:`Text` (printable, bounded length),
:class:`Choice` (one of given names) and :class:`NameList` (a list of them).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from pydantic import GetCoreSchemaHandler
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.constraints.rule import Rule
from trainctl.declare.violations import Violation, raise_at, suggest
from trainctl.naming import _UNPRINTABLE_CLASS
from trainctl.naming import UNPRINTABLE as UNPRINTABLE

__all__ = ["UNPRINTABLE", "Choice", "NameList", "Text"]


def _or(items: Sequence[str]) -> str:
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " or " + items[-1]


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
