# A read-only mapping: the frozen tables of a scenario ([expected], controllers, its document).
"""A read-only, hashable, picklable mapping (:class:`FrozenMapping`)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import Any, Generic, NoReturn, TypeVar

__all__ = ["FrozenMapping"]

_V = TypeVar("_V")


class FrozenMapping(Mapping[str, _V], Generic[_V]):
    """A read-only, hashable, picklable mapping with string keys, in insertion order.

    Parameters
    ----------
    items : mapping or iterable of (str, value) pairs
        The content, copied.

    Examples
    --------
    >>> import pickle
    >>> m = FrozenMapping({"sampling": "pass", "feasibility": "warn"})
    >>> m["sampling"], list(m), len(m)
    ('pass', ['sampling', 'feasibility'], 2)
    >>> try:
    ...     m["sampling"] = "fail"
    ... except TypeError:
    ...     print("read-only")
    read-only
    >>> hash(m) == hash(FrozenMapping([("feasibility", "warn"), ("sampling", "pass")]))
    True
    >>> pickle.loads(pickle.dumps(m)) == m
    True
    """

    __slots__ = ("_data",)
    _data: dict[str, _V]

    def __init__(self, items: Mapping[str, _V] | Iterable[tuple[str, _V]] = ()) -> None:
        object.__setattr__(self, "_data", dict(items))

    def __setattr__(self, name: str, value: Any) -> NoReturn:
        raise AttributeError(f"{type(self).__name__} is read-only")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (tuple(self._data.items()),))

    def __getitem__(self, key: str) -> _V:
        return self._data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __hash__(self) -> int:
        return hash(frozenset(self._data.items()))

    def __repr__(self) -> str:
        return repr(self._data)
