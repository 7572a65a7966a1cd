# Rules of the MPC family's structured keys: neighbourhoods and cooperative weights.
"""The neighbourhood and cooperative-weights rules of :class:`ControllerSettings`.

Both values depend on the number of coaches; when the validation context
gives it (``n_coaches``, a scenario file), the length and the coach indices
are checked too; from Python, :meth:`ControllerSettings.neighbourhoods` and
:meth:`ControllerSettings.cooperative_weight_vector` check them for a given
``n`` with the same rules.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import GetCoreSchemaHandler, TypeAdapter, ValidationInfo
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.constraints import Array, Number, Rule, Violation, fail, raise_at, suggest

__all__ = ["NEIGHBOURHOODS", "CooperativeWeightsRule", "NeighbourhoodRule", "coaches"]

NEIGHBOURHOODS = ("adjacent", "all", "self")
"""Named neighbourhoods (an explicit array per coach is also accepted)."""

_WEIGHT_SUM_TOL = 1e-9


def coaches(info: ValidationInfo | None) -> int | None:
    """The number of coaches from the validation context, if known.

    Parameters
    ----------
    info : pydantic.ValidationInfo or None
        The validation info, whose context may name the train.

    Returns
    -------
    int or None
        The number of coaches, or None without a context.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> coaches(None), coaches(SimpleNamespace(context={"n_coaches": 3}))
    (None, 3)
    """
    context = info.context if info is not None else None
    return context.get("n_coaches") if isinstance(context, dict) else None


class NeighbourhoodRule(Rule):
    """A named neighbourhood, or one array of distinct coach indices per coach.

    Examples
    --------
    >>> rule = NeighbourhoodRule()
    >>> rule.check("adjacent", None), rule.check([[0, 1], [0, 1]], None)
    ('adjacent', ((0, 1), (0, 1)))
    >>> try:
    ...     rule.check([[1], [1]], None)  # coach 0 must weigh its own outputs
    ... except ValueError as exc:
    ...     print(type(exc).__name__)
    ValidationError
    """

    def want(self, *, python: bool = False, n: int | None = None) -> str:
        """The named kinds or an array of ``n`` arrays of coach indices.

        Parameters
        ----------
        python : bool
            Phrase for a Python caller rather than a scenario file (the
            phrase is the same for both).
        n : int or None
            The number of coaches, when known (it is then named).

        Returns
        -------
        str
            E.g. ``"one of 'adjacent', 'all', 'self' or an array of 4 arrays of
            coach indices, one per coach"``.
        """
        arrays = f"an array of {n} arrays" if n else "an array of arrays"
        names = ", ".join(repr(k) for k in NEIGHBOURHOODS)
        return f"one of {names} or {arrays} of coach indices, one per coach"

    def doc_type(self) -> str:
        """The named kinds or the explicit form, as TOML.

        Returns
        -------
        str
            The type column of the documentation (Markdown).
        """
        return ('`"adjacent"`, `"all"`, `"self"` or an array of n arrays of distinct coach '
                "indices (entry i contains i)")

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Anything; :meth:`check` decides.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            Pydantic's handler of the annotated type (unused).

        Returns
        -------
        pydantic_core.CoreSchema
            A schema accepting any value.
        """
        return core_schema.any_schema()

    def check(self, value: Any, info: ValidationInfo | None) -> Any:
        """Kind, length (one entry per coach), indices, entry i containing i.

        Parameters
        ----------
        value : object
            The value given: a name of :data:`NEIGHBOURHOODS`, or one array of
            coach indices (0-based) per coach.
        info : pydantic.ValidationInfo or None
            The validation info; its context's ``n_coaches``, when given,
            fixes the number of entries and the largest index.

        Returns
        -------
        str or tuple of tuple of int
            The name, or the coach indices of each entry.

        Raises
        ------
        pydantic_core.PydanticCustomError
            If the value is neither a name nor a non-empty array (of one entry
            per coach, when their number is known).
        pydantic.ValidationError
            If an entry is not an array of distinct coach indices containing
            its own index.
        """
        n = coaches(info)
        if isinstance(value, str) and value in NEIGHBOURHOODS:
            return value
        if isinstance(value, str) or not isinstance(value, list | tuple) or not value or (
            n is not None and len(value) != n
        ):
            train = f"; the train has {n} coaches." if n is not None else "."
            raise fail(Violation(
                text=f"must be {self.want(n=n)}", got=value,
                hint=suggest(value, NEIGHBOURHOODS)
                or f" Entry i lists the coaches whose outputs coach i weighs{train}",
            ))
        return tuple(self._entry(i, members, n) for i, members in enumerate(value))

    @staticmethod
    def _entry(i: int, members: Any, n: int | None) -> tuple[int, ...]:
        if not isinstance(members, list | tuple):
            raise_at((i,), Violation(text="must be an array of coach indices", got=members))
        for k, j in enumerate(members):
            if isinstance(j, bool) or not isinstance(j, int) or j < 0 or (n and j >= n):
                span = f"from 0 to {n - 1}" if n else ">= 0"
                raise_at((i, k), Violation(text=f"must be a coach index {span}", got=j,
                                           hint=" Indices count from 0, head coach first."), j)
        if len(set(members)) != len(members):
            raise_at((i,), Violation(text="must list distinct coach indices",
                                     got_text=repr(list(members))), members)
        if i not in members:
            raise_at((i,), Violation(text=f"must contain its own coach index {i}",
                                     got_text=repr(list(members)),
                                     hint=" Every coach weighs its own outputs."), members)
        return tuple(int(j) for j in members)

    def json_extra(self) -> dict[str, Any]:
        """A named kind or an array of arrays of indices.

        Returns
        -------
        dict of str to object
            The JSON Schema ``anyOf`` of the names and the explicit form.
        """
        entry = {"type": "array", "items": {"type": "integer", "minimum": 0},
                 "uniqueItems": True}
        return {"anyOf": [{"enum": list(NEIGHBOURHOODS)},
                          {"type": "array", "items": entry, "minItems": 1}]}


_POSITIVE_WEIGHTS: TypeAdapter[tuple[float, ...]] = TypeAdapter(
    Annotated[tuple[float, ...], Array(Number(gt=0))]
)


class CooperativeWeightsRule(Rule):
    """``"uniform"``, or one weight > 0 per coach, summing to 1 (within 1e-9).

    Examples
    --------
    >>> rule = CooperativeWeightsRule()
    >>> rule.check("uniform", None), rule.check([0.25, 0.75], None)
    ('uniform', (0.25, 0.75))
    >>> try:
    ...     rule.check([0.5, 0.6], None)  # sums to 1.1
    ... except ValueError as exc:
    ...     print(exc)
    must sum to 1 within 1e-9
    """

    def want(self, *, python: bool = False, n: int | None = None) -> str:
        """``'uniform'`` or an array of ``n`` numbers > 0 summing to 1.

        Parameters
        ----------
        python : bool
            Phrase for a Python caller rather than a scenario file (the
            phrase is the same for both).
        n : int or None
            The number of coaches, when known (it is then named).

        Returns
        -------
        str
            E.g. ``"'uniform' or an array of 4 numbers > 0 summing to 1, one
            per coach"``.
        """
        count = f"{n} " if n else ""
        return f"'uniform' or an array of {count}numbers > 0 summing to 1, one per coach"

    def doc_type(self) -> str:
        """The name or the explicit form, as TOML.

        Returns
        -------
        str
            The type column of the documentation (Markdown).
        """
        return '`"uniform"` or an array of n numbers > 0 summing to 1 (±1e-9)'

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Anything; :meth:`check` decides.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            Pydantic's handler of the annotated type (unused).

        Returns
        -------
        pydantic_core.CoreSchema
            A schema accepting any value.
        """
        return core_schema.any_schema()

    def check(self, value: Any, info: ValidationInfo | None) -> Any:
        """The name, or positive weights of the right count summing to 1.

        Parameters
        ----------
        value : object
            The value given: ``"uniform"`` or one weight [-] per coach.
        info : pydantic.ValidationInfo or None
            The validation info; its context's ``n_coaches``, when given,
            fixes the number of weights.

        Returns
        -------
        str or tuple of float
            ``"uniform"``, or the weights [-], each > 0, summing to 1 within 1e-9.

        Raises
        ------
        pydantic_core.PydanticCustomError
            If the value is neither ``"uniform"`` nor a non-empty array of the
            right count, or if the weights do not sum to 1.
        pydantic.ValidationError
            If a weight is not a number > 0.
        """
        n = coaches(info)
        if value == "uniform":
            return value
        if isinstance(value, str) or not isinstance(value, list | tuple) or not value or (
            n is not None and len(value) != n
        ):
            raise fail(Violation(text=f"must be {self.want(n=n)}", got=value,
                                 hint=suggest(value, ("uniform",))))
        weights = _POSITIVE_WEIGHTS.validate_python(value)
        total = math.fsum(weights)
        if abs(total - 1.0) > _WEIGHT_SUM_TOL:
            raise fail(Violation(text="must sum to 1 within 1e-9", got_text=f"sum {total!r}",
                                 hint=" Divide each weight by the sum, or use 'uniform'."))
        return weights

    def json_extra(self) -> dict[str, Any]:
        """The name or an array of positive numbers.

        Returns
        -------
        dict of str to object
            The JSON Schema ``anyOf`` of ``"uniform"`` and the array of weights.
        """
        weights = {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0},
                   "minItems": 1}
        return {"anyOf": [{"const": "uniform"}, weights]}
