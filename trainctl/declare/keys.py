# Declaring settings once: SI field, constraint, file key, unit, converter, default, doc.
"""Settings classes whose every field is declared once.

A field of a settings class is annotated with its SI type, a
:class:`~trainctl.declare.constraints.Rule` and a :class:`Key`: the one-line
documentation, the scenario-file key with its unit and the converter to SI.
From that one declaration come the validation of objects built in Python
(this module: :func:`settings` raises :class:`~trainctl.exceptions.ModelError`)
and the scenario-file table, its error messages, its documentation and its
JSON Schema (:mod:`trainctl.scenario`).

Examples
--------
>>> from trainctl.scenario import ModelSettings
>>> ModelSettings(speed=25, sample_time=0.5).speed
25.0
>>> ModelSettings(speed=-1.0, sample_time=0.5)
Traceback (most recent call last):
...
trainctl.exceptions.ModelError: ModelSettings: 'speed' must be a finite number > 0 (got -1.0).
"""

from __future__ import annotations

import functools
import re
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Annotated, Any, TypeVar, dataclass_transform

import pydantic
from pydantic import ConfigDict, GetJsonSchemaHandler, TypeAdapter, ValidationError
from pydantic.fields import FieldInfo
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema, ErrorDetails

from trainctl.declare.constraints import ERROR_TYPE, NOTHING, Rule, Violation
from trainctl.declare.violations import suggest
from trainctl.exceptions import ModelError

__all__ = ["Alt", "Key", "check_fields", "declared_fields", "first_error", "python_error",
           "render_refs", "settings"]

_T = TypeVar("_T")
_SIGNATURE_ERRORS = {
    "missing": "missing required argument",
    "missing_keyword_only_argument": "missing required argument",
    "unexpected_keyword_argument": "unexpected argument",
    "unexpected_positional_argument": "takes keyword arguments only; unexpected",
    "extra_forbidden": "unexpected argument",
}
_UNKNOWN = frozenset({"extra_forbidden", "unexpected_keyword_argument"})
"""Error types of an unknown name: reported first (a misspelt name also shows
up as a missing one)."""
_REF = re.compile(r"\{(\w+)\}")


@dataclass(frozen=True)
class Alt:
    """One of several alternative file keys for one field ("exactly one of").

    Parameters
    ----------
    key : str
        The file key (``"a.b"`` for key ``b`` of the sub-table ``a``).
    unit : str
        Unit of the file value.
    to_si : callable or None
        Converter of the file value to SI (applied to each item of an array).
    sets : mapping
        Other fields this choice fixes (e.g. the unit the user chose).
    si_text : str
        The conversion in words for the documentation ("" = derived).

    Examples
    --------
    A simulation's reference speeds may be given in km/h or in m/s; the
    km/h alternative converts 72 km/h to 72 / 3.6 = 20 m/s:

    >>> from trainctl.scenario.settings import SimulationSettings
    >>> fields = {f.name: f for f in declared_fields(SimulationSettings)}
    >>> alts = fields["reference_speeds"].key.one_of
    >>> [(alt.key, alt.unit) for alt in alts]
    [('reference.speeds_kmh', 'km/h'), ('reference.speeds', 'm/s')]
    >>> alts[0].to_si(72.0), alts[1].to_si is None
    (20.0, True)
    """

    key: str
    unit: str = ""
    to_si: Callable[..., Any] | None = None
    sets: Mapping[str, Any] = field(default_factory=dict)
    si_text: str = ""


@dataclass(frozen=True)
class Key:
    """How a settings field appears in scenario files, and its documentation.

    Parameters
    ----------
    doc : str
        One line of documentation.
    file : str or None
        The file key (``"a.b"`` inside the sub-table ``a``); None for the
        field name, "" for a field that files do not set directly.
    unit : str
        Unit of the file value ("" if dimensionless).
    to_si : callable or None
        Converter of the file value to SI (``trainctl.units``); None if the
        file value is already the stored value.
    si_unit : str
        Unit of the stored value, when a converter changes it.
    omitted : str
        What an omitted optional key means (e.g. ``"no limit"``).
    hint : str
        Sentences appended to a message about a wrong value of this key.
    one_of : tuple of Alt
        Alternative file keys, exactly one of which must be given.
    si_text : str
        The conversion in words for the documentation ("" = derived).
    vector : bool
        ``to_si`` takes the whole array (e.g. three Davis coefficients) rather
        than each item.

    Examples
    --------
    >>> from trainctl.units import kmh_to_ms
    >>> key = Key("Speed limit", file="limit_kmh", unit="km/h", to_si=kmh_to_ms,
    ...           si_unit="m/s", omitted="no limit")
    >>> key.describe()
    'Speed limit [km/h]; omit for no limit.'
    >>> key.to_si(90.0)  # 90 / 3.6 = 25 m/s
    25.0
    """

    doc: str
    file: str | None = None
    unit: str = ""
    to_si: Callable[..., Any] | None = None
    si_unit: str = ""
    omitted: str = ""
    hint: str = ""
    one_of: tuple[Alt, ...] = ()
    si_text: str = ""
    vector: bool = False

    def describe(self) -> str:
        """The documentation line with the unit and what omitting the key means.

        Returns
        -------
        str
            ``doc``, then the file unit in brackets (if any), then ``"; omit
            for "`` and ``omitted`` (if set), ending with a full stop.
        """
        unit = f" [{self.unit}]" if self.unit else ""
        omitted = f"; omit for {self.omitted}" if self.omitted else ""
        return f"{self.doc}{unit}{omitted}."

    def __get_pydantic_json_schema__(
        self, schema: CoreSchema, handler: GetJsonSchemaHandler
    ) -> JsonSchemaValue:
        """Title, description and unit of the key in the JSON Schema."""
        value = handler(schema)
        if self.doc:
            value.update(title=self.doc, description=self.describe())
        if self.unit:
            value["unit"] = self.unit
        return value


@dataclass(frozen=True)
class DeclaredField:
    """A field of a settings class or file table with its declaration."""

    name: str
    info: FieldInfo
    rule: Rule | None
    key: Key | None

    @property
    def required(self) -> bool:
        """True when the field has no default."""
        return self.info.is_required()

    @property
    def default(self) -> Any:
        """The default value (None when required)."""
        return self.info.get_default(call_default_factory=True)


def declared_fields(cls: type) -> Iterator[DeclaredField]:
    """The fields of a pydantic model or dataclass with their Rule and Key.

    Parameters
    ----------
    cls : type
        A pydantic model or pydantic dataclass.

    Yields
    ------
    DeclaredField
        In declaration order.

    Examples
    --------
    The cruise speed of :class:`~trainctl.scenario.ModelSettings` is
    required and read from the file key ``speed_kmh``; the linearisation
    has a default:

    >>> from trainctl.scenario import ModelSettings
    >>> speed, linearisation = list(declared_fields(ModelSettings))[:2]
    >>> speed.name, speed.required, speed.key.file, speed.key.unit
    ('speed', True, 'speed_kmh', 'km/h')
    >>> linearisation.name, linearisation.required, linearisation.default
    ('linearisation', False, 'jacobian')
    """
    fields: dict[str, FieldInfo] = getattr(cls, "__pydantic_fields__", None) or {}
    for name, info in fields.items():
        rule = next((m for m in info.metadata if isinstance(m, Rule)), None)
        key = next((m for m in info.metadata if isinstance(m, Key)), None)
        yield DeclaredField(name, info, rule, key)


@dataclass_transform(kw_only_default=True, frozen_default=True)
def settings(cls: type[_T]) -> type[_T]:
    """Make ``cls`` a frozen, keyword-only pydantic dataclass of settings.

    Construction validates every field through its declared rule and the
    class's model validators; a violation raises
    :class:`~trainctl.exceptions.ModelError` (a wrong or missing argument
    name, :class:`TypeError`), worded by :func:`python_error`.

    Parameters
    ----------
    cls : type
        The class body: annotated fields, validators, methods.

    Returns
    -------
    type
        The settings class.

    Examples
    --------
    :class:`~trainctl.scenario.ModelSettings` is made by ``@settings``: its
    fields are converted (the int 25 becomes 25.0 m/s), keyword-only and
    frozen, and a bad value is a ``ModelError``:

    >>> from trainctl.scenario import ModelSettings
    >>> model = ModelSettings(speed=25, sample_time=0.5)
    >>> model.speed, model.sample_time  # [m/s], [s]
    (25.0, 0.5)
    >>> ModelSettings(25, 0.5)
    Traceback (most recent call last):
        ...
    TypeError: ModelSettings: missing required argument 'speed'.
    >>> try:
    ...     ModelSettings(speed=-25.0, sample_time=0.5)
    ... except ModelError as exc:
    ...     print(exc)
    ModelSettings: 'speed' must be a finite number > 0 (got -25.0).
    >>> ModelSettings(speed=25, sample_tim=0.5)
    Traceback (most recent call last):
        ...
    TypeError: ModelSettings: unexpected argument 'sample_tim'. Did you mean 'sample_time'?
    >>> import dataclasses
    >>> try:
    ...     model.speed = 30.0
    ... except dataclasses.FrozenInstanceError:
    ...     print("frozen")
    frozen
    """
    made = pydantic.dataclasses.dataclass(
        frozen=True, kw_only=True, config=ConfigDict(extra="forbid")
    )(cls)
    init = made.__init__

    @functools.wraps(init)
    def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
        try:
            init(self, *args, **kwargs)
        except ValidationError as exc:
            raise python_error(made.__name__, exc) from None

    made.__init__ = __init__  # type: ignore[method-assign]
    return typing.cast(type[_T], made)


def first_error(exc: ValidationError) -> ErrorDetails:
    """The error to report: the first one, preferring unknown keys and arguments.

    A misspelt argument is both unknown and, under its right name, missing:
    the unknown name is the one to report.

    Parameters
    ----------
    exc : pydantic.ValidationError
        All errors of one validation.

    Returns
    -------
    pydantic_core.ErrorDetails
        One of them.

    Examples
    --------
    The unknown key is reported even though the bad number comes first:

    >>> from pydantic import BaseModel, ConfigDict
    >>> class Doc(BaseModel):
    ...     model_config = ConfigDict(extra="forbid")
    ...     dt: float
    >>> try:
    ...     Doc.model_validate({"dt": "fast", "x": 1})
    ... except ValidationError as exc:
    ...     print([e["type"] for e in exc.errors()], first_error(exc)["loc"])
    ['float_parsing', 'extra_forbidden'] ('x',)
    """
    errors = exc.errors()
    return next((e for e in errors if e["type"] in _UNKNOWN), errors[0])


def render_refs(text: str, name: Callable[[str], str | None]) -> str:
    """Replace ``{field}`` references in ``text`` by ``name(field)``.

    Parameters
    ----------
    text : str
        A message with ``{field}`` references.
    name : callable
        The displayed name of a field (None: the reference is left as it is).

    Returns
    -------
    str
        The message with the references replaced.

    Examples
    --------
    >>> render_refs("must be less than {duration}", lambda f: repr(f))
    "must be less than 'duration'"
    """

    def sub(match: re.Match[str]) -> str:
        found = name(match.group(1))
        return match.group(0) if found is None else found

    return _REF.sub(sub, text)


def violation_of(error: ErrorDetails) -> Violation:
    """The trainctl violation of a pydantic error (a generic one for others)."""
    ctx = error.get("ctx") or {}
    violation = ctx.get("violation")
    if error["type"] == ERROR_TYPE and isinstance(violation, Violation):
        return violation
    return Violation(text=f"is invalid: {error['msg']}", got=error.get("input", NOTHING))


def python_path(loc: Sequence[str | int]) -> str:
    """``('neighbourhood', 0, 1)`` -> ``"'neighbourhood'[0][1]"``."""
    parts = [f"[{p}]" if isinstance(p, int) else f"[{p!r}]" for p in loc[1:]]
    return (repr(loc[0]) if loc else "") + "".join(parts)


def python_error(owner: str, exc: ValidationError,
                 prefix: Sequence[str | int] = ()) -> Exception:
    """Word a validation error of a settings class built in Python.

    Parameters
    ----------
    owner : str
        The class name, the message's first word.
    exc : pydantic.ValidationError
        The error.
    prefix : sequence of str or int
        Field (and item indices) the validated value belongs to, when it was
        checked alone.

    Returns
    -------
    Exception
        :class:`~trainctl.exceptions.ModelError` for a wrong value,
        :class:`TypeError` for a wrong or missing argument name.

    Examples
    --------
    A value checked alone gets its field name from ``prefix``:

    >>> from trainctl.declare.constraints import POSITIVE
    >>> try:
    ...     TypeAdapter(Annotated[float, POSITIVE]).validate_python(-2.0)
    ... except ValidationError as exc:
    ...     error = python_error("Car", exc, prefix=("mass",))
    >>> type(error).__name__, str(error)
    ('ModelError', "Car: 'mass' must be a finite number > 0 (got -2.0).")
    """
    error = first_error(exc)
    loc = (*prefix, *error["loc"])
    if error["type"] in _SIGNATURE_ERRORS:
        hint = ""
        if error["type"] in _UNKNOWN and error["loc"]:
            missing = [str(e["loc"][-1]) for e in exc.errors()
                       if e["type"] in ("missing", "missing_keyword_only_argument") and e["loc"]]
            hint = suggest(str(error["loc"][-1]), missing)
        return TypeError(f"{owner}: {_SIGNATURE_ERRORS[error['type']]} "
                         f"{python_path(loc)}.{hint}")
    v = violation_of(error)
    text = render_refs(v.python_text or v.text, repr)
    got = "" if v.got is NOTHING and not v.got_text else f" (got {v.got_text or repr(v.got)})"
    where = f"{python_path(loc)} " if loc else ""
    return ModelError(f"{owner}: {where}{text}{got}.{v.hint}")


@functools.cache
def _adapter(rule: Rule) -> TypeAdapter[Any]:
    return TypeAdapter(Annotated[Any, rule])


def check_fields(owner: str, obj: object, rules: Mapping[str, Rule]) -> None:
    """Check attributes of ``obj`` against rules (a plain dataclass's ``__post_init__``).

    Parameters
    ----------
    owner : str
        The message's first words, e.g. ``"Vehicle 'T'"``.
    obj : object
        The object whose attributes are checked.
    rules : mapping of str to Rule
        Attribute name to rule.

    Raises
    ------
    ModelError
        For the first attribute that breaks its rule, worded by :func:`python_error`.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from trainctl.declare.constraints import POSITIVE
    >>> check_fields("Car", SimpleNamespace(mass=-1.0), {"mass": POSITIVE})
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: Car: 'mass' must be a finite number > 0 (got -1.0).
    """
    for name, rule in rules.items():
        try:
            _adapter(rule).validate_python(getattr(obj, name))
        except ValidationError as exc:
            raise python_error(owner, exc, prefix=(name,)) from None
