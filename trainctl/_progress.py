# A terminal progress bar for long runs; silent when stderr is not a terminal.
"""Minimal progress bar on stderr.

Shown only when the stream is a terminal (so logs, pipes and CI stay clean).
A background thread redraws it twice a second so that the elapsed time moves
while a long simulation runs; :meth:`Progress.advance` may be called from any
thread (e.g. a future's done-callback).

Examples
--------
>>> import io
>>> with Progress(3, stream=io.StringIO()) as bar:   # not a terminal: draws nothing
...     bar.advance("analysis")
>>> bar.done
1
"""

from __future__ import annotations

import shutil
import sys
import threading
import time
from types import TracebackType
from typing import TextIO

__all__ = ["Progress"]


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
        self.done = 0
        self.label = ""
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self._start = time.monotonic()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

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
        with self._lock:
            self.label = label
            self._draw()

    def advance(self, label: str = "", steps: int = 1) -> None:
        """Count ``steps`` finished steps; ``label`` names the next one (or the last done)."""
        with self._lock:
            self.done = min(self.total, self.done + steps) if self.total else self.done + steps
            if label:
                self.label = label
            self._draw()

    def close(self) -> None:
        """Stop redrawing and clear the bar's line."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        if self.enabled:
            with self._lock:
                self.stream.write("\r\033[K")
                self.stream.flush()

    def _tick(self) -> None:
        while not self._stop.wait(0.5):
            with self._lock:
                self._draw()

    def _draw(self) -> None:
        if not self.enabled or self._stop.is_set():
            return
        width = shutil.get_terminal_size((80, 20)).columns
        elapsed = time.monotonic() - self._start
        fraction = self.done / self.total if self.total else 0.0
        bar_width = 24
        filled = int(round(bar_width * fraction))
        head = f"[{'#' * filled}{'-' * (bar_width - filled)}] {self.done}/{self.total} "
        tail = f" {elapsed:5.1f} s"
        room = max(0, width - len(head) - len(tail) - 1)
        label = self.label if len(self.label) <= room else self.label[: max(0, room - 1)] + "…"
        self.stream.write("\r\033[K" + head + label + tail)
        self.stream.flush()
