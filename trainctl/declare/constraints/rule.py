# The base of every constraint type: Annotated metadata that pydantic enforces and trainctl words.
"""The base class :class:`Rule` of the constraint types: its core schema, its wording
and its check of a value.
"""

from __future__ import annotations

from typing import Any

from pydantic import GetCoreSchemaHandler, GetJsonSchemaHandler, ValidationError
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.violations import ERROR_TYPE, Violation, fail

__all__ = ["Rule"]


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
