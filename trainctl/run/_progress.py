# A terminal progress bar for long runs (tqdm); silent when stderr is not a terminal.
"""Progress bar on stderr, drawn by tqdm.

Shown only when the stream is a terminal (so logs, pipes and CI stay clean).
:meth:`Progress.advance` may be called from any thread (e.g. a future's
done-callback; tqdm serialises its updates). While a long simulation runs,
nothing calls :meth:`advance`, so a small ticker thread asks tqdm to redraw
twice a second and the elapsed time keeps moving.

Examples
--------
>>> import io
>>> with Progress(3, stream=io.StringIO()) as bar:   # not a terminal: draws nothing
...     bar.advance("analysis")
>>> bar.done
1
"""

from __future__ import annotations

import os
import sys
import threading
from types import TracebackType
from typing import TextIO

from tqdm import tqdm

__all__ = ["Progress"]

BAR_FORMAT = "[{bar:24}] {n_fmt}/{total_fmt} {desc} {elapsed}"
"""Counted bar, the current step's label, the elapsed time."""

_DRAWING = threading.Lock()
"""Held by a bar's thread while it redraws, and around every fork of this process: a pool
worker forked from it (:mod:`trainctl.run.pool`) while the thread was drawing would start
with the locks of tqdm and of the stream held by a thread it does not have."""

if hasattr(os, "register_at_fork"):
    os.register_at_fork(before=_DRAWING.acquire, after_in_parent=_DRAWING.release,
                        after_in_child=_DRAWING.release)


class Progress:
    """A counted progress bar.

    Parameters
    ----------
    total : int
        Number of steps, >= 0.
    stream : text stream or None
        Where to draw (default ``sys.stderr``).
    enabled : bool or None
        Force on or off; None draws only when ``stream.isatty()``.
    """

    def __init__(self, total: int, *, stream: TextIO | None = None,
                 enabled: bool | None = None) -> None:
        self.total = max(0, int(total))
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self._bar = tqdm(total=self.total, file=self.stream, disable=not enabled, leave=False,
                         bar_format=BAR_FORMAT, ascii="-#", mininterval=0.0,
                         dynamic_ncols=True)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._done = 0

    @property
    def done(self) -> int:
        """Steps counted so far."""
        return self._done

    @property
    def label(self) -> str:
        """The current step's label."""
        return str(self._bar.desc)

    def __enter__(self) -> Progress:
        if self.enabled:
            self._thread = threading.Thread(target=self._tick, name="trainctl-progress",
                                            daemon=True)
            self._thread.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def set_label(self, label: str) -> None:
        """Describe the step in progress."""
        self._bar.set_description_str(label)

    def advance(self, label: str = "", steps: int = 1) -> None:
        """Count ``steps`` finished steps; ``label`` names the next one (or the last done)."""
        with self._lock:
            step = min(steps, self.total - self._done) if self.total else steps
            self._done += max(0, step)
        if label:
            self._bar.set_description_str(label, refresh=False)
        self._bar.update(max(0, step))

    def close(self) -> None:
        """Stop redrawing and clear the bar's line."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        self._bar.close()

    def _tick(self) -> None:
        while not self._stop.wait(0.5):
            with _DRAWING:
                self._bar.refresh()
