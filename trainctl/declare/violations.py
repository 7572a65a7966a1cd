# Rule violations: what went wrong with one value, carried inside a pydantic error.
"""The words of a rule violation, carried by a pydantic error of type ``"trainctl"``.

A rule (:mod:`trainctl.declare.constraints`) or a validator that checks several
fields raises :func:`fail` or :func:`raise_at` with a :class:`Violation`:
what must hold, the value given and a hint, before the key path is known.
:func:`trainctl.declare.keys.python_error` words it for Python callers,
:mod:`trainctl.scenario.errors` for scenario files.

Examples
--------
>>> suggest("tustn", ("zoh", "tustin"))
" Did you mean 'tustin'?"
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, NoReturn

from pydantic import ValidationError
from pydantic_core import InitErrorDetails, PydanticCustomError

__all__ = ["ERROR_TYPE", "NOTHING", "Violation", "fail", "raise_at", "suggest"]

NOTHING: Any = type("Nothing", (), {"__repr__": lambda self: "NOTHING"})()
"""Marker: no value to show in a message's ``(got ...)`` clause."""

ERROR_TYPE = "trainctl"
"""The pydantic error type of every trainctl rule violation."""


@dataclass(frozen=True)
class Violation:
    """The words of one rule violation, before the key path is known.

    Parameters
    ----------
    text : str
        What must hold, e.g. ``"must be a number > 0"``; ``{name}`` refers to
        the field ``name`` of the same table (rendered as its key path).
    got : object
        The value shown in ``(got ...)``; :data:`NOTHING` for no clause.
    got_text : str
        Literal text for the ``(got ...)`` clause instead of ``got``.
    hint : str
        Sentences after the message (how to fix it).
    python_text : str
        ``text`` for Python callers when the wording differs ("" = same).
    file_hint : str
        A hint shown for scenario files only.
    value : bool
        True when the key's own hint applies (a wrong value, not a wrong type);
        False otherwise.
    finite : bool
        True when the value is not finite (a key that may be omitted says so).
    where : bool
        False when ``text`` is the whole message, without the key path in
        front (``{name}`` references are still rendered).

    Examples
    --------
    >>> v = Violation("must be a number > 0", got=-3.0, hint="Use a positive mass.")
    >>> v.text, v.got, v.value
    ('must be a number > 0', -3.0, True)
    """

    text: str
    got: Any = NOTHING
    got_text: str = ""
    hint: str = ""
    python_text: str = ""
    file_hint: str = ""
    value: bool = True
    finite: bool = False
    where: bool = True


def fail(violation: Violation) -> PydanticCustomError:
    """The pydantic error carrying ``violation`` (raise it in a validator).

    Parameters
    ----------
    violation : Violation
        What is wrong.

    Returns
    -------
    pydantic_core.PydanticCustomError
        An error of type ``"trainctl"`` with the violation in its context.

    Examples
    --------
    >>> error = fail(Violation("must be a number > 0", got=-3.0))
    >>> error.type, error.message()
    ('trainctl', 'must be a number > 0')
    >>> error.context["violation"].got
    -3.0
    """
    context = {"text": violation.text, "violation": violation}
    return PydanticCustomError(ERROR_TYPE, "{text}", context)


def raise_at(loc: Sequence[str | int], violation: Violation, value: Any = None) -> NoReturn:
    """Raise ``violation`` at ``loc`` below the value being validated.

    Parameters
    ----------
    loc : sequence of str or int
        Field names and item indices, relative to the value or model.
    violation : Violation
        What is wrong.
    value : object
        The offending input.

    Raises
    ------
    pydantic.ValidationError
        Always.

    Examples
    --------
    >>> try:
    ...     raise_at(("vehicles", 1, "mass"), Violation("must be a number > 0"), -3.0)
    ... except ValidationError as error:
    ...     detail = error.errors()[0]
    >>> detail["type"], detail["loc"], detail["input"]
    ('trainctl', ('vehicles', 1, 'mass'), -3.0)
    """
    detail = InitErrorDetails(type=fail(violation), loc=tuple(loc), input=value)
    raise ValidationError.from_exception_data(ERROR_TYPE, [detail])


def suggest(word: object, choices: Iterable[str]) -> str:
    """A "Did you mean" sentence for a near miss, or "".

    Parameters
    ----------
    word : object
        What was given (not a string: no suggestion).
    choices : iterable of str
        The accepted words.

    Returns
    -------
    str
        The sentence naming the closest choice, or "" when none is close.

    Examples
    --------
    >>> suggest("zho", ("zoh", "tustin"))
    " Did you mean 'zoh'?"
    >>> suggest("euler", ("zoh", "tustin"))  # nothing close: no sentence
    ''
    """
    if not isinstance(word, str):
        return ""
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" Did you mean {close[0]!r}?" if close else ""
