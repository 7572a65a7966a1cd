# The settings schema of the radio network: delays, losses, interruption windows and noise.
"""The settings of the radio network (:class:`NetworkSettings`) with their rules,
and the interruption windows (:class:`Interruption`).
"""

from __future__ import annotations

import numbers
from typing import Annotated, Any

from pydantic import TypeAdapter, ValidationError, ValidationInfo, model_validator
from pydantic_core import CoreSchema, InitErrorDetails, core_schema

from trainctl.declare.constraints import Array, Number, Rule, Violation, fail, raise_at
from trainctl.declare.keys import Key, python_error, settings
from trainctl.models.graphs import REFERENCE

__all__ = ["Interruption", "NetworkSettings"]

Sender = int | str
"""A sender: a vehicle index (0-based) or :data:`REFERENCE`."""

Link = tuple[int, Sender]
"""A link ``(receiver, sender)``: the receiver hears the sender."""


def _integral(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


class LinksRule(Rule):
    """``"all"``, or a non-empty array of distinct ``[receiver, sender]`` pairs.

    Receivers are vehicle indices (from 0); a sender is a vehicle index or
    ``"reference"``. With the number of vehicles in the validation context
    (``n_vehicles``) the indices are checked against the train.
    """

    def want(self, *, python: bool = False) -> str:
        """What a valid value is."""
        return ("'all' or a non-empty array of [receiver, sender] pairs (vehicle indices "
                "from 0; sender 'reference' for the reference)")

    def doc_type(self) -> str:
        """The type column of the documentation."""
        return '`"all"` or array of `[receiver, sender]` pairs'

    def schema(self, handler: Any) -> CoreSchema:
        """Anything; :meth:`check` does the work."""
        return core_schema.any_schema()

    def check(self, value: Any, info: ValidationInfo | None) -> Any:
        """The pairs as a tuple of tuples (``"all"`` as is)."""
        if value == "all":
            return "all"
        if not isinstance(value, list | tuple) or not value:
            raise fail(Violation(text=f"must be {self.want()}", got=value))
        context = info.context if info is not None and isinstance(info.context, dict) else {}
        n = context.get("n_vehicles")
        pairs: list[Link] = []
        for k, pair in enumerate(value):
            if not isinstance(pair, list | tuple) or len(pair) != 2:
                raise_at((k,), Violation(text="must be a [receiver, sender] pair", got=pair,
                                         hint=" Write e.g. [1, 0]: vehicle 1 hears vehicle 0."),
                         pair)
            receiver = int(_vehicle_index((k, 0), pair[0], n, "receiver", reference=False))
            sender = _vehicle_index((k, 1), pair[1], n, "sender", reference=True)
            if receiver == sender:
                raise_at((k,), Violation(
                    text="must join two different vehicles", got=list(pair),
                    hint=" No vehicle hears itself."), pair)
            if (receiver, sender) in pairs:
                raise_at((k,), Violation(
                    text="must not repeat an earlier pair", got_text=f"{list(pair)} again",
                    hint=" List each link once."), pair)
            pairs.append((receiver, sender))
        return tuple(pairs)

    def json_extra(self) -> dict[str, Any]:
        """``"all"`` or an array of pairs."""
        index = {"type": "integer", "minimum": 0}
        pair = {"type": "array", "minItems": 2, "maxItems": 2,
                "prefixItems": [index, {"anyOf": [index, {"const": REFERENCE}]}]}
        return {"anyOf": [{"const": "all"}, {"type": "array", "minItems": 1, "items": pair}]}


def _vehicle_index(loc: tuple[int, int], value: Any, n: int | None, role: str, *,
                   reference: bool) -> Sender:
    """A receiver's or sender's index, checked (against ``n`` vehicles when known)."""
    if reference and value == REFERENCE:
        return REFERENCE
    span = f"from 0 to {n - 1}" if n is not None else ">= 0"
    want = f"the {role}: a vehicle index {span}" + (" or 'reference'" if reference else "")
    train = f" The train has {n} vehicle{'s' if n != 1 else ''}, numbered from 0." \
        if n is not None else ""
    if not _integral(value) or value < 0 or (n is not None and value >= n):
        hint = train if _integral(value) else (
            " The reference only sends; it is never a receiver." if value == REFERENCE
            else train)
        raise_at(loc, Violation(text=f"must be {want}", got=value, hint=hint),
                 value)
    return int(value)


_LINKS = LinksRule()
_LINKS_ADAPTER: TypeAdapter[Any] = TypeAdapter(Annotated[Any, _LINKS])
_TIME = Number(ge=0)
_DELAY = Number(ge=0)
_NOISE = Number(ge=0)


class ProbabilityRule(Rule):
    """A probability in [0, 1): a number >= 0 and < 1."""

    def want(self, *, python: bool = False) -> str:
        """``"a number in [0, 1)"``."""
        return f"a {'finite ' if python else ''}number in [0, 1)"

    def schema(self, handler: Any) -> CoreSchema:
        """Strict float in [0, 1); integers widen."""
        number = core_schema.float_schema(ge=0.0, lt=1.0, strict=True, allow_inf_nan=False)
        return core_schema.no_info_before_validator_function(
            lambda v: float(v) if _integral(v) else v, number)

    def explain(self, error_type: str, value: Any) -> Violation:
        """Out of [0, 1) or not a number; 1 gets a hint."""
        violation = super().explain(error_type, value)
        if error_type == "less_than":
            return Violation(text=violation.text, python_text=violation.python_text, got=value,
                             hint=" A link that loses every message is no link: use an "
                             "interruption window for an outage.")
        return violation


@settings
class Interruption:
    """An outage window: links that carry nothing over ``[start, end)``.

    A message is blocked when the link is down at any moment of its transit
    (``t_sent < end`` and ``t_arrival >= start``).

    Parameters
    ----------
    start : float
        Start of the outage [s], >= 0.
    end : float
        End of the outage [s], > ``start``; the window is ``[start, end)``.
    links : "all" or tuple of (int, int or str)
        ``"all"``: every link, the reference's included; else the blocked
        links as ``(receiver, sender)`` pairs, vehicles numbered from 0 head
        first, sender ``"reference"`` for the reference. A pair that is not
        a link of the graph blocks nothing.

    Examples
    --------
    >>> Interruption(start=100.0, end=130.0, links=[[1, 0], [0, "reference"]]).links
    ((1, 0), (0, 'reference'))
    >>> Interruption(start=5.0, end=4.0)
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: Interruption: 'end' must be greater than 'start' = 5.0 s \
(got 4.0). The window is [start, end).
    """

    start: Annotated[float, _TIME, Key("Start of the outage", unit="s")]
    end: Annotated[float, _TIME, Key("End of the outage (> start): the window is [start, end)",
                                     unit="s")]
    links: Annotated[str | tuple[tuple[int, Sender], ...], _LINKS, Key(
        "Links cut: 'all', or [receiver, sender] pairs (vehicles from 0, head first; sender "
        "'reference' for the reference)")] = "all"

    @model_validator(mode="after")
    def _window(self) -> Interruption:
        if not self.end > self.start:
            raise_at(("end",), Violation(
                text=f"must be greater than {{start}} = {self.start!r} s", got=self.end,
                hint=" The window is [start, end)."), self.end)
        return self

    def blocks(self, link: Link) -> bool:
        """True when the window cuts ``link`` = ``(receiver, sender)``.

        Parameters
        ----------
        link : tuple of (int, int or str)
            ``(receiver, sender)``: the receiving vehicle (0-based) and the
            sending vehicle (0-based) or ``"reference"``.

        Returns
        -------
        bool
            True when :attr:`links` is ``"all"`` or lists ``link``; the times of
            the window are not considered.
        """
        return self.links == "all" or link in self.links


class WindowsRule(Rule):
    """One ``[network.interruption]`` table or an array of them, as Interruption objects."""

    model = Interruption

    def want(self, *, python: bool = False) -> str:
        """``"a table or an array of tables"`` (Python: a sequence of Interruption)."""
        if python:
            return "a sequence of Interruption objects (or of dicts with their fields)"
        return "a table or an array of tables (start, end, links)"

    def schema(self, handler: Any) -> CoreSchema:
        """Anything; :meth:`check` validates the windows."""
        return core_schema.any_schema()

    def check(self, value: Any, info: ValidationInfo | None) -> Any:
        """The windows as a tuple of :class:`Interruption`."""
        context = info.context if info is not None else None
        single = isinstance(value, dict | Interruption)
        if not single and not isinstance(value, list | tuple):
            raise fail(Violation(text=f"must be {self.want()}", got=value))
        items = [value] if single else list(value)
        for i, item in enumerate(items):
            unknown = [k for k in item if k not in _WINDOW_KEYS] if isinstance(item, dict) else []
            if unknown:  # worded as an unknown key of a table, with a suggestion
                loc = (unknown[0],) if single else (i, unknown[0])
                raise ValidationError.from_exception_data("Interruption", [InitErrorDetails(
                    type="extra_forbidden", loc=loc, input=item[unknown[0]])])
        if single:
            return (TypeAdapter(Interruption).validate_python(value, context=context),)
        return TypeAdapter(tuple[Interruption, ...]).validate_python(items, context=context)

    def json_extra(self) -> dict[str, Any]:
        """One window, or an array of windows."""
        table = TypeAdapter(Interruption).json_schema()
        return {"anyOf": [table, {"type": "array", "items": table}]}


_WINDOW_KEYS = ("start", "end", "links")
_WINDOWS = WindowsRule()


@settings
class NetworkSettings:
    """Delays, losses, noise and outages of the radio links between the vehicles.

    Give at most one of ``delay_s`` (constant) and ``delay_range_s``
    (uniform per message); with neither, messages arrive when sent.

    Parameters
    ----------
    delay_s : float or None
        Constant delay of every message [s], >= 0.
    delay_range_s : tuple of float or None
        ``(lo, hi)`` [s], 0 <= lo <= hi: each message's delay is drawn
        uniformly in [lo, hi].
    loss_probability : float
        Probability that a message is lost [-], 0 <= p < 1, independently per
        message.
    communication_noise_std : float
        Standard deviation of the Gaussian noise added to every transmitted
        value, in the value's unit (m/s for speeds), >= 0.
    reference_noise_std : float or None
        The same for the reference's messages (the broadcast command) [value's
        unit], >= 0; None: ``communication_noise_std``.
    interruptions : tuple of Interruption
        Outage windows (file: ``[[network.interruption]]``); none by default.

    Examples
    --------
    >>> s = NetworkSettings(delay_range_s=(0.0, 2.0), loss_probability=0.05,
    ...                     communication_noise_std=1.0)
    >>> s.delay_bounds(), s.noise_std("reference"), s.noise_std(2)
    ((0.0, 2.0), 1.0, 1.0)
    >>> NetworkSettings(delay_range_s=(2.0, 1.0))
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: NetworkSettings: 'delay_range_s' must be [lo, hi] with \
lo <= hi (got [2.0, 1.0]).
    """

    delay_s: Annotated[Annotated[float, _DELAY] | None, Key(
        "Constant delay of every message (not with delay_range_s)", unit="s",
        omitted="no delay, or delay_range_s")] = None
    delay_range_s: Annotated[Annotated[tuple[float, ...], Array(_DELAY, length=2)] | None, Key(
        "Delay drawn uniformly in [lo, hi] for each message (not with delay_s)", unit="s",
        omitted="the constant delay_s")] = None
    loss_probability: Annotated[float, ProbabilityRule(), Key(
        "Probability that a message is lost, independently per message")] = 0.0
    communication_noise_std: Annotated[float, _NOISE, Key(
        "Standard deviation of the Gaussian noise added to every transmitted value",
        unit="value's unit, m/s for speeds")] = 0.0
    reference_noise_std: Annotated[Annotated[float, _NOISE] | None, Key(
        "Standard deviation of the noise on the reference's messages",
        unit="value's unit, m/s for speeds", omitted="communication_noise_std")] = None
    interruptions: Annotated[tuple[Interruption, ...], _WINDOWS, Key(
        "Outage windows: nothing sent or arriving on their links while they last",
        file="interruption", omitted="no outage")] = ()

    @model_validator(mode="after")
    def _delays(self) -> NetworkSettings:
        if self.delay_s is not None and self.delay_range_s is not None:
            raise_at(("delay_range_s",), Violation(
                text="cannot be combined with {delay_s}",
                got_text=f"delay_s = {self.delay_s!r} and delay_range_s = "
                f"{list(self.delay_range_s)!r}",
                hint=" Give a constant delay_s or a random delay_range_s = [lo, hi], not both.",
                value=False))
        if self.delay_range_s is not None:
            lo, hi = self.delay_range_s
            if lo > hi:
                raise_at(("delay_range_s",), Violation(
                    text="must be [lo, hi] with lo <= hi", got_text=f"[{lo!r}, {hi!r}]"),
                    self.delay_range_s)
        return self

    def delay_bounds(self) -> tuple[float, float]:
        """The delay range ``(lo, hi)`` [s]: equal bounds for a constant delay.

        Returns
        -------
        tuple of float
            ``delay_range_s`` when given; else ``(delay_s, delay_s)``, or
            ``(0.0, 0.0)`` without a delay [s].
        """
        if self.delay_range_s is not None:
            return float(self.delay_range_s[0]), float(self.delay_range_s[1])
        delay = 0.0 if self.delay_s is None else float(self.delay_s)
        return delay, delay

    def noise_std(self, sender: Sender) -> float:
        """The noise standard deviation on ``sender``'s messages [value's unit].

        Parameters
        ----------
        sender : int or str
            A vehicle index (0-based) or ``"reference"``.

        Returns
        -------
        float
            ``reference_noise_std`` for the reference when it is given, else
            ``communication_noise_std`` [value's unit, m/s for speeds].
        """
        if sender == REFERENCE and self.reference_noise_std is not None:
            return float(self.reference_noise_std)
        return float(self.communication_noise_std)

    def check_vehicles(self, n: int) -> None:
        """Check the interruption links against a formation of ``n`` vehicles.

        Parameters
        ----------
        n : int
            Vehicles [-], >= 1.

        Raises
        ------
        ModelError
            If a link names a vehicle index outside 0 .. n-1.

        Examples
        --------
        >>> NetworkSettings(interruptions=[Interruption(start=0.0, end=1.0, links=[[4, 0]])]
        ...                 ).check_vehicles(4)
        Traceback (most recent call last):
        ...
        trainctl.exceptions.ModelError: NetworkSettings: 'interruptions'[0]['links'][0][0] \
must be the receiver: a vehicle index from 0 to 3 (got 4). The train has 4 vehicles, \
numbered from 0.
        """
        for w, window in enumerate(self.interruptions):
            try:
                _LINKS_ADAPTER.validate_python(window.links, context={"n_vehicles": int(n)})
            except ValidationError as exc:
                raise python_error("NetworkSettings", exc,
                                   prefix=("interruptions", w, "links")) from None
