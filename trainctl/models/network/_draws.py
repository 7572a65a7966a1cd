# A network's random draws for a whole run at once, as the generator gives them call by call.
"""The draws of :meth:`Network.send` over a whole run, without a call per send.

Each send of a sender heard by w vehicles draws ``random((w, 2))`` then
``standard_normal(w)`` from the network's ``default_rng`` (PCG64), so a run
of K samples makes K x (senders) x 2 calls, ~0.4 s for the 9 000 samples
of a heavy-haul run; the batch (:mod:`trainctl.sim.batch`) needs them for
every run. :func:`draws` takes the generator's raw 64-bit stream in one call
and decodes it as numpy's ``Generator`` does:

- a uniform double is ``(r >> 11) * 2**-53`` (one word);
- a normal is numpy's ziggurat: one word r, layer ``r & 0xff``, sign bit 8,
  magnitude ``rabs = (r >> 9) & (2**52 - 1)``; when ``rabs < k[layer]`` (about
  99 % of draws) it is ``±rabs * w[layer]`` from that one word, else the
  slow path (wedge or tail) draws more words: such a draw is taken from a
  copy of the generator advanced to that word (``PCG64.advance``), and the
  words it used are skipped.

The tables w and k are numpy's own, measured from numpy itself
(:func:`_ziggurat`: an MT19937 generator set to give chosen words; w[layer]
is the normal of the word with rabs = 1, k[layer] the least rabs whose draw
takes more than one word), and a self-check against the generator's own
calls must pass before :func:`draws` is used (else it returns None and the
caller draws call by call).
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

__all__ = ["draws", "draws_by_calls"]

Array = NDArray[np.float64]

_MASK52 = (1 << 52) - 1
_TO_DOUBLE = 1.0 / 9007199254740992.0
_CHUNK = 256
"""Normal draws checked per vectorised look for the next slow-path one."""


def draws_by_calls(rng: np.random.Generator, widths: Sequence[int], K: int
                   ) -> tuple[Array, Array]:
    """The draws made call by call: per sample, per width w, ``random((w, 2))`` then
    ``standard_normal(w)``; u (K, W, 2), z (K, W) with W = Σ w."""
    W = sum(widths)
    u = np.empty((K, W, 2))
    z = np.empty((K, W))
    spans = np.cumsum([0, *widths])
    pairs = [(int(spans[m]), int(spans[m + 1])) for m in range(len(widths)) if widths[m]]
    random, normal = rng.random, rng.standard_normal
    for k in range(K):
        uk, zk = u[k], z[k]
        for a, b in pairs:
            uk[a:b] = random((b - a, 2))
            zk[a:b] = normal(b - a)
    return u, z


def draws(seed: int | np.random.SeedSequence, widths: Sequence[int], K: int
          ) -> tuple[Array, Array] | None:
    """:func:`draws_by_calls` of ``default_rng(seed)``, decoded from its raw stream
    (module docstring); None when numpy's generator is not the one measured."""
    tables = _ziggurat()
    if tables is None:
        return None
    return _decode(seed, widths, K, tables)


def _decode(seed: int | np.random.SeedSequence, widths: Sequence[int], K: int,
            tables: tuple[Array, NDArray[np.uint64]]) -> tuple[Array, Array] | None:
    """Every word decoded both ways at once; then, slow normal by slow normal, the
    generator's own value and the shift of the later draws by the extra words it used."""
    wi, fast_below = tables
    widths = [int(w) for w in widths if w]
    W = sum(widths)
    bits = np.random.default_rng(seed).bit_generator
    if not isinstance(bits, np.random.PCG64):
        return None
    start = bits.state
    # the kind of every draw in order: per sample, per width, 2w uniforms then w normals
    step = np.concatenate([np.r_[np.zeros(2 * w, dtype=bool), np.ones(w, dtype=bool)]
                           for w in widths]) if widths else np.zeros(0, dtype=bool)
    kinds = np.tile(step, K)
    total = kinds.size
    normal_ops = np.flatnonzero(kinds)
    raw = bits.random_raw(total + total // 16 + 64)
    layer = (raw & np.uint64(0xFF)).astype(np.intp)
    rabs = (raw >> np.uint64(9)) & np.uint64(_MASK52)
    slow_word = ~(rabs < fast_below[layer])
    live = np.random.PCG64()
    live.state = start
    gen = np.random.Generator(live)
    at = 0                              # the live copy's word
    # (first op, offset) of each stretch of draws, and the slow normals' values by op
    stretches: list[tuple[int, int]] = [(0, 0)]
    resolved: dict[int, float] = {}
    off, j = 0, 0                       # offset of the words; next normal op to check
    while j < normal_ops.size:
        window = normal_ops[j : j + _CHUNK]
        words = window + off
        if words[-1] + 66 >= raw.size:
            return None                 # more slow draws than the words taken (not seen)
        hits = slow_word[words]
        if not hits.any():
            j += window.size
            continue
        h = int(np.argmax(hits))
        op, p = int(window[h]), int(words[h])
        if p < at:
            live.state, at = start, 0
        live.advance(p - at)
        resolved[op] = float(gen.standard_normal())
        after = live.random_raw(2)
        used = _words_used(raw, p, after)
        if used is None:
            return None
        at = p + used + 2
        off += used - 1
        stretches.append((op + 1, off))
        j += h + 1
    firsts = np.array([f for f, _ in stretches] + [total])
    offsets = np.repeat(np.array([o for _, o in stretches]), np.diff(firsts))
    word = np.arange(total) + offsets
    r = raw[word]
    u = (r[~kinds] >> np.uint64(11)).astype(np.float64) * _TO_DOUBLE
    rn = r[kinds]
    magnitude = rabs[word[kinds]].astype(np.float64) * wi[layer[word[kinds]]]
    negative = ((rn >> np.uint64(8)) & np.uint64(1)).astype(bool)
    z = np.where(negative, -magnitude, magnitude)
    if resolved:
        ops = np.fromiter(resolved, dtype=np.intp, count=len(resolved))
        z[np.searchsorted(normal_ops, ops)] = np.fromiter(resolved.values(), dtype=float,
                                                          count=len(resolved))
    return u.reshape(K, W, 2), z.reshape(K, W)


def _words_used(raw: NDArray[np.uint64], p: int, after: NDArray[np.uint64]) -> int | None:
    """How many words the draw starting at word p used: where the two words drawn after
    it sit in ``raw`` (None: not within 64 words)."""
    for used in range(1, 65):
        a = p + used
        if a + 2 > raw.size:
            return None
        if raw[a] == after[0] and raw[a + 1] == after[1]:
            return used
    return None


def _untemper(y: int) -> int:
    """The MT19937 state word whose tempered output is ``y`` (32 bits)."""
    y ^= y >> 18
    y ^= (y << 15) & 0xEFC60000
    t = y
    for _ in range(5):
        t = y ^ ((t << 7) & 0x9D2C5680)
    y = t & 0xFFFFFFFF
    t = y
    for _ in range(3):
        t = y ^ (t >> 11)
    return t & 0xFFFFFFFF


class _Probe:
    """An MT19937 generator set to give chosen 64-bit words, and numpy's normal of them."""

    MARK = 0x5DEECE66DDEADBEE
    """The word set after the probed one: drawn next when the normal used one word."""

    def __init__(self) -> None:
        self.bits = np.random.MT19937(0)
        self.gen = np.random.Generator(self.bits)
        self.key = np.array(self.bits.state["state"]["key"], dtype=np.uint32)
        a, b = 0x01234567, 0x89ABCDEF
        self.key[0], self.key[1] = _untemper(a), _untemper(b)
        self._set()
        word = int(self._word())
        self.high_first = word == (a << 32 | b)
        if not self.high_first and word != (b << 32 | a):
            raise ValueError("MT19937 words are not what they were set to")
        self._put(2, self.MARK)

    def _word(self) -> int:
        return int(self.gen.integers(0, 2**64 - 1, endpoint=True, dtype=np.uint64))

    def _put(self, at: int, word: int) -> None:
        hi, lo = word >> 32, word & 0xFFFFFFFF
        first, second = (hi, lo) if self.high_first else (lo, hi)
        self.key[at], self.key[at + 1] = _untemper(first), _untemper(second)

    def _set(self) -> None:
        self.bits.state = {"bit_generator": "MT19937", "state": {"key": self.key, "pos": 0}}

    def normal(self, word: int) -> tuple[float, bool]:
        """numpy's standard normal of ``word``, and whether it used that word only."""
        self._put(0, word)
        self._set()
        x = float(self.gen.standard_normal())
        return x, self._word() == self.MARK


@lru_cache(maxsize=1)
def _ziggurat() -> tuple[Array, NDArray[np.uint64]] | None:
    """numpy's ziggurat tables (w per layer, a lower bound of k per layer), measured,
    self-checked.

    w[layer] is the normal of the word with rabs = 1. k is bracketed per layer
    by two probes about the ziggurat's k = 2**52 w[layer-1] / w[layer] (the
    ratio of the layers' edges; binary search where they do not bracket it),
    and the fast path is taken as k - 1e-6 relative: a magnitude in the
    bracket is decoded by the generator itself (:func:`_decode`), as slow.
    """
    try:
        probe = _Probe()
    except (ValueError, KeyError, TypeError):
        return None
    wi = np.zeros(256)
    fast_below = np.zeros(256, dtype=np.uint64)

    def fast(layer: int, rabs: int) -> bool:
        return probe.normal(layer | (rabs << 9))[1]

    for layer in range(256):
        x, ok = probe.normal(layer | (1 << 9))  # rabs = 1, positive
        if not ok:
            continue  # every draw of this layer takes the slow path
        wi[layer] = x
        lo, hi = 1, 1 << 52   # fast at lo; slow at hi (rabs < 2**52)
        if layer >= 2 and wi[layer - 1] > 0.0:
            guess = float(wi[layer - 1] / wi[layer]) * 2.0**52
            a, b = int(guess * (1.0 - 1e-6)), int(guess * (1.0 + 1e-6)) + 1
            if 1 <= a < b <= _MASK52 and fast(layer, a) and not fast(layer, b):
                lo, hi = a, b
        if (lo, hi) == (1, 1 << 52):
            if fast(layer, _MASK52):
                lo = hi = 1 << 52
            while hi - lo > 1:
                mid = (lo + hi) // 2
                lo, hi = (mid, hi) if fast(layer, mid) else (lo, mid)
        fast_below[layer] = np.uint64(lo + 1)   # rabs <= lo: the fast path
    tables = (wi, fast_below)
    # the self-check: the decoded draws of a few thousand samples are the generator's
    widths = (4, 1, 2, 0, 3)
    for seed in (np.random.SeedSequence([12345, 1]), 7):
        got = _decode(seed, widths, 3000, tables)
        want = draws_by_calls(np.random.default_rng(seed), widths, 3000)
        if got is None or not all(np.array_equal(a, b) for a, b in zip(got, want, strict=True)):
            return None
    return tables
