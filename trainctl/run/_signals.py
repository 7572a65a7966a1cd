# The command's process: prompt answers to signals, a time budget, and C chatter kept off stdout.
"""Process-level guards of the ``trainctl`` command.

:func:`signal_guard`
    SIGTERM and SIGHUP unwind like Ctrl-C (:class:`Interrupted`, a
    ``KeyboardInterrupt``, so temporary files are removed and worker
    processes terminated; the exit status is 128 + the signal,
    :func:`exit_status`: 130 SIGINT, 143 SIGTERM, 129 SIGHUP); a time budget raises
    :class:`BudgetExceeded` (also a ``KeyboardInterrupt``, so library code
    that catches ``Exception`` cannot swallow it). A watchdog thread hears
    every signal through :func:`signal.set_wakeup_fd`, even while the main
    thread sits in a long C call (a large SVD, a solver) where Python
    cannot run its handlers: if the main thread has not unwound within
    :data:`GRACE` seconds, the watchdog terminates the worker processes and
    ends the process itself. Either way the command answers within a second.
:func:`quiet_c_stdout`
    Compiled solvers print to file descriptor 1 whatever their settings
    (OSQP 1.x: "Polishing not needed - no active set detected at optimal
    point"). Around a command, descriptor 1 goes to ``/dev/null`` and
    ``sys.stdout`` to the real standard output, so only the command's own
    output reaches stdout. One redirection per command, rather than one per
    solve: the fast MPC path stays free of per-step system calls, and any C
    library's chatter is caught, in worker processes too
    (:func:`silence_c_stdout`, their initializer).
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["GRACE", "BudgetExceeded", "Interrupted", "at_forced_stop", "exit_status",
           "quiet_c_stdout", "signal_guard", "silence_c_stdout"]

GRACE = 0.7
"""Seconds the main thread gets to unwind after a signal before the watchdog ends the process."""

_HANGUP = getattr(signal, "SIGHUP", None)
_UNWIND_SIGNALS = tuple(s for s in (signal.SIGTERM, _HANGUP) if s is not None)
"""Signals that unwind like Ctrl-C (:class:`Interrupted`), besides SIGINT itself."""
_STOP_SIGNALS = (signal.SIGINT, *_UNWIND_SIGNALS, signal.SIGALRM)

_AT_FORCED_STOP: list[Callable[[], None]] = []
"""Called, in order, before the watchdog ends the process (:func:`at_forced_stop`)."""


def at_forced_stop(callback: Callable[[], None]) -> None:
    """Call ``callback`` before the watchdog ends a process stuck in C code.

    :mod:`trainctl.run.pool` registers its ``terminate_workers`` on import, so
    that no worker process outlives the command (a pool exists only once that
    module is imported); this module, below the pool, does not import it.

    Parameters
    ----------
    callback : callable
        Called without arguments; registered once however often it is given.

    Examples
    --------
    >>> import trainctl.run.pool as pool
    >>> pool.terminate_workers in _AT_FORCED_STOP
    True
    """
    if callback not in _AT_FORCED_STOP:
        _AT_FORCED_STOP.append(callback)


class Interrupted(KeyboardInterrupt):
    """A stop signal other than SIGINT (SIGTERM, SIGHUP), raised like Ctrl-C.

    A ``KeyboardInterrupt``, so every ``finally`` and cleanup that Ctrl-C
    runs runs too; it carries the signal for the exit status
    (:func:`exit_status`: 128 + the signal number, as a shell reports it).

    Examples
    --------
    >>> import signal
    >>> Interrupted(signal.SIGTERM).signum == signal.SIGTERM
    True
    """

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = int(signum)


def exit_status(exc: BaseException) -> int:
    """The exit status of a command ended by ``exc``: 128 + the signal (130 for Ctrl-C).

    Examples
    --------
    >>> import signal
    >>> exit_status(KeyboardInterrupt()), exit_status(Interrupted(signal.SIGTERM))
    (130, 143)
    >>> exit_status(Interrupted(signal.SIGHUP))
    129
    """
    return 128 + int(getattr(exc, "signum", signal.SIGINT))


class BudgetExceeded(KeyboardInterrupt):
    """The run outlived its time budget (``--max-time``); raised by SIGALRM."""

    def __init__(self, seconds: float) -> None:
        super().__init__(seconds)
        self.seconds = seconds


def _raise_interrupt(signum: int, frame: Any) -> None:
    raise Interrupted(signum)


@contextlib.contextmanager
def signal_guard(*, max_time: float = math.inf, on_force: str = "interrupted") -> Iterator[None]:
    """SIGTERM and SIGHUP as Ctrl-C, an optional wall-clock budget and a watchdog, for the block.

    Parameters
    ----------
    max_time : float
        Seconds after which :class:`BudgetExceeded` is raised in the main
        thread (``math.inf``: none).
    on_force : str
        Words printed by the watchdog when it ends the process.

    Yields
    ------
    None

    Notes
    -----
    Only in the main thread (signals cannot be handled elsewhere); in other
    threads the block runs unguarded.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.signal(signum, _raise_interrupt) for signum in _UNWIND_SIGNALS}
    if math.isfinite(max_time):

        def expired(signum: int, frame: Any) -> None:
            raise BudgetExceeded(max_time)

        previous[signal.SIGALRM] = signal.signal(signal.SIGALRM, expired)
        signal.setitimer(signal.ITIMER_REAL, max_time)
    watchdog = _Watchdog(on_force)
    try:
        yield
    finally:
        if signal.SIGALRM in previous:
            signal.setitimer(signal.ITIMER_REAL, 0)
        watchdog.stop()
        for signum, handler in previous.items():
            signal.signal(signum, handler)


class _Watchdog:
    """A thread woken by every signal (wakeup fd) that ends a process stuck in C code."""

    def __init__(self, words: str) -> None:
        self.words = words
        self.stopped = threading.Event()
        self.read_fd, self.write_fd = os.pipe()
        os.set_blocking(self.write_fd, False)
        self.previous_fd = signal.set_wakeup_fd(self.write_fd, warn_on_full_buffer=False)
        self.thread = threading.Thread(target=self._watch, name="trainctl-watchdog", daemon=True)
        self.thread.start()

    def _watch(self) -> None:
        while True:
            try:
                data = os.read(self.read_fd, 64)
            except OSError:
                return
            if self.stopped.is_set() or not data:
                return
            heard = {signum for signum in data if signum in _STOP_SIGNALS}
            if heard and not self.stopped.wait(GRACE):
                self._force(heard)

    def _force(self, heard: set[int]) -> None:
        for callback in _AT_FORCED_STOP:
            callback()
        budget = heard == {signal.SIGALRM}
        words = ("error: stopped: the run outlived its time budget (--max-time)" if budget
                 else f"{self.words} (the computation did not stop in time; ended it)")
        with contextlib.suppress(OSError):
            os.write(2, f"\ntrainctl: {words}\n".encode())
        # the first stop signal heard, in the order SIGINT, SIGTERM, SIGHUP
        stop = next((s for s in _STOP_SIGNALS if s in heard and s != signal.SIGALRM), None)
        os._exit(2 if stop is None else 128 + int(stop))

    def stop(self) -> None:
        self.stopped.set()
        signal.set_wakeup_fd(self.previous_fd)
        with contextlib.suppress(OSError):
            os.write(self.write_fd, b"\0")
        self.thread.join(timeout=1.0)
        for fd in (self.read_fd, self.write_fd):
            with contextlib.suppress(OSError):
                os.close(fd)


def _flush_c_stdio() -> None:
    """Flush the C library's stdio buffers (``fflush(NULL)``), where available."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        ctypes.CDLL(None).fflush(None)


@contextlib.contextmanager
def quiet_c_stdout() -> Iterator[None]:
    """Send descriptor 1 to ``/dev/null`` for the block; ``sys.stdout`` keeps the real stdout.

    When ``sys.stdout`` writes to descriptor 1 it is rebound, for the block,
    to a duplicate of the original descriptor; a replaced ``sys.stdout``
    (pytest's capture, a notebook) is left alone. C code that prints to
    descriptor 1 prints into ``/dev/null``; its buffered output is flushed
    there before the descriptor is restored.

    Yields
    ------
    None
    """
    try:
        sys.stdout.flush()
        _flush_c_stdio()
        saved = os.dup(1)
    except (AttributeError, OSError, ValueError):  # no usable stdout: nothing to protect
        yield
        return
    original = sys.stdout
    rebind = _writes_to_fd1(original)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.close(null)
    if rebind:
        line = bool(getattr(original, "line_buffering", False))
        sys.stdout = open(os.dup(saved), "w", encoding=original.encoding,
                          errors=original.errors, buffering=1 if line else -1)
    try:
        yield
    finally:
        _flush_c_stdio()
        if rebind:
            with contextlib.suppress(OSError, ValueError):
                sys.stdout.close()
            sys.stdout = original
        os.dup2(saved, 1)
        os.close(saved)


def _writes_to_fd1(stream: Any) -> bool:
    try:
        return bool(stream.fileno() == 1)
    except (AttributeError, OSError, ValueError):
        return False


def silence_c_stdout() -> None:
    """Point descriptor 1 of this process at ``/dev/null`` for good (pool workers)."""
    with contextlib.suppress(OSError):
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, 1)
        os.close(null)
