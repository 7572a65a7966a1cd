# The constraint type of arrays: shape and per-element rules.
"""The constraint type :class:`Array`: a numeric array of a given shape whose
elements each satisfy a rule.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from pydantic import GetCoreSchemaHandler
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.constraints.rule import Rule

__all__ = ["Array"]


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
    >>> from trainctl.declare.constraints.scalars import Number
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
