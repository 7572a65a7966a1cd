# Reading input files without ever blocking: a pipe, socket or device given as a file is refused.
"""Inputs are regular files: checked before a read that could block.

A named pipe given as a scenario file (or planted in a saved run or a
sweep store) would block ``open`` until a writer appears, and a device
(``/dev/zero``, a terminal) streams or waits. :func:`read_regular` opens
with ``O_NONBLOCK`` and checks the opened descriptor, so neither the open nor
the read can wait; :func:`require_regular` checks a path with :func:`os.stat`
before a library opens it itself (``numpy.load``). Both raise
:class:`NotRegularFileError`, an :class:`OSError` whose ``strerror`` says what
the path is, so a caller's ``except OSError`` words it with the path.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

__all__: list[str] = []


class NotRegularFileError(OSError):
    """A path that names a pipe, socket or device where a regular file is read."""


def node_kind(mode: int) -> str:
    """``"a named pipe"``, ``"a socket"``, ... for a file mode (``st_mode``)."""
    if stat.S_ISFIFO(mode):
        return "a named pipe"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode):
        return "a character device"
    if stat.S_ISBLK(mode):
        return "a block device"
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    return "a special file"


def _refuse(mode: int, path: str | os.PathLike[str]) -> OSError:
    if stat.S_ISDIR(mode):
        return IsADirectoryError(errno.EISDIR, "Is a directory", os.fspath(path))
    return NotRegularFileError(errno.EINVAL, f"{node_kind(mode)}, not a regular file: trainctl "
                               "reads its inputs only from regular files",
                               os.fspath(path))


def require_regular(path: str | os.PathLike[str]) -> None:
    """Raise :class:`NotRegularFileError` unless ``path`` is a regular file (links followed).

    A missing path is left to the caller's open (``FileNotFoundError``).
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return
    if not stat.S_ISREG(mode):
        raise _refuse(mode, path)


def read_regular(path: str | os.PathLike[str], limit: int | None = None) -> bytes:
    """The bytes of a regular file (at most ``limit`` + 1 of them), never blocking on the open.

    Raises :class:`NotRegularFileError` for a pipe, socket or device,
    :class:`IsADirectoryError` for a directory, and the open's own :class:`OSError` otherwise
    (``FileNotFoundError``, ``PermissionError``).
    """
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        require_regular(path)  # a socket cannot be opened at all (ENXIO): say what it is
        raise
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise _refuse(mode, path)
        os.set_blocking(fd, True)
        with os.fdopen(os.dup(fd), "rb") as handle:
            return handle.read() if limit is None else handle.read(limit + 1)
    finally:
        os.close(fd)


def read_regular_text(path: Path) -> str:
    """:func:`read_regular` decoded as UTF-8 (``UnicodeDecodeError`` when it is not)."""
    return read_regular(path).decode("utf-8")
