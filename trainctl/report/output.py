# Where command output goes: regular files replaced atomically, devices and pipes written through.
"""Output targets of ``trainctl report -o`` and ``export -o``, classified before anything runs.

A target is one of:

``"file"``
    A regular file (or a path that does not exist yet): written to a
    temporary file beside it and renamed over it (:func:`write_text_atomic`),
    so a reader never sees a partial file. A symbolic link to a regular file
    keeps the link; the file it points to is replaced, keeping its
    permissions, owner and group (a file whose owner cannot be kept, one
    owned by another user when trainctl does not run as root, is refused).
    A failed write (a full disk) names the file and leaves it as it was.
``"stream"``
    The null device (``/dev/null``), or a named pipe that another process
    reads: opened without blocking and written through, never replaced or
    created. A pipe nobody reads is refused (exit 2), never waited on.
``"fd"``
    ``-`` or an alias of an open descriptor (``/dev/stdout``,
    ``/dev/fd/N``, ``/proc/self/fd/N``): written to that descriptor
    (standard output through ``sys.stdout``).

A path ending in ``/`` (or an existing directory) names a directory: the
file is written inside it under the command's default name. Anything else
(another character device such as ``/dev/full`` or a terminal, a block
device, a socket, a directory where a file is needed) is refused with
:class:`OutputError` before the command does any work.

Examples
--------
>>> output_target("-").kind, output_target("/dev/null").kind
('fd', 'stream')
>>> target = output_target("reports/", default_name="crh2-dmpc.html")
>>> target.kind, target.path.parent.name, target.path.name
('file', 'reports', 'crh2-dmpc.html')
"""

from __future__ import annotations

import errno
import os
import re
import secrets
import stat
import sys
from dataclasses import dataclass
from pathlib import Path

from trainctl._files import node_kind
from trainctl.exceptions import TrainctlError

__all__ = ["OutputError", "OutputTarget", "output_target", "write_output", "write_text_atomic"]

_FD_ALIAS = re.compile(r"^/(?:dev|proc/self|proc/(?P<pid>\d+))/fd/(?P<fd>\d+)$")
_STD_ALIAS = {"/dev/stdin": 0, "/dev/stdout": 1, "/dev/stderr": 2}
_ACCEPTED = ("regular files, directories, /dev/null, pipes read by another process, or '-' "
             "for standard output")


class OutputError(TrainctlError, ValueError):
    """An output path that cannot be written as asked (a socket, a directory for a file, ...).

    Examples
    --------
    A directory where a file is needed:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     try:
    ...         output_target(tmp)
    ...     except OutputError as error:
    ...         print(type(error).__name__, str(error).endswith("give a file path with -o"))
    OutputError True
    """


@dataclass(frozen=True)
class OutputTarget:
    """A classified output destination.

    Parameters
    ----------
    path : pathlib.Path
        Where to write: the file (symbolic links resolved), the device or
        pipe, or the descriptor alias (``/dev/stdout`` for ``-``).
    kind : {"file", "stream", "fd"}
        How it is written (see the module docstring).
    display : str
        The path as the user gave it (``-`` for standard output).
    fd : int
        The descriptor of an ``"fd"`` target (-1 otherwise).
    exists : bool
        True when a ``"file"`` target already exists.

    Examples
    --------
    ``-`` is standard output, written through its descriptor:

    >>> target = output_target("-")
    >>> target.kind, target.fd, target.is_stdout, str(target), target.path.as_posix()
    ('fd', 1, True, '-', '/dev/stdout')
    """

    path: Path
    kind: str
    display: str
    fd: int = -1
    exists: bool = False

    @property
    def is_stdout(self) -> bool:
        """True when the output goes to standard output (status lines then go to stderr)."""
        return self.kind == "fd" and self.fd == 1

    def __fspath__(self) -> str:
        """The path, so a target can be passed where a path is expected."""
        return os.fspath(self.path)

    def __str__(self) -> str:
        """The path as the user gave it."""
        return self.display


def output_target(path: str | os.PathLike[str] | OutputTarget, *,
                  default_name: str | None = None) -> OutputTarget:
    """Classify an output path (nothing is written).

    Parameters
    ----------
    path : str, os.PathLike or OutputTarget
        ``-``, a file, a directory (``dir/``), a device, a pipe.
    default_name : str or None
        File name used inside a directory; None when a directory is not
        accepted.

    Returns
    -------
    OutputTarget
        The classified target (an OutputTarget is returned unchanged).

    Raises
    ------
    OutputError
        For a directory without ``default_name``, a path ending in ``/``
        that is not a directory, a broken symbolic link, a block device, a
        socket or another kind of node.

    Examples
    --------
    A directory takes the default name; a new file is a ``"file"`` target
    that does not exist yet:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     inside = output_target(tmp + "/", default_name="crh2-dmpc.html")
    ...     new = output_target(Path(tmp) / "r.html")
    >>> inside.path.name, inside.kind, new.kind, new.exists
    ('crh2-dmpc.html', 'file', 'file', False)
    """
    if isinstance(path, OutputTarget):
        return path
    text = os.fspath(path)
    if text == "-":
        return OutputTarget(Path("/dev/stdout"), "fd", "-", fd=1)
    target = Path(text)
    if text.endswith(("/", os.sep)) or target.is_dir():
        if default_name is None:
            raise OutputError(f"{text}: is a directory; give a file path with -o")
        if target.exists() and not target.is_dir():
            raise OutputError(f"{text}: is not a directory (a path ending in '/' names one)")
        target = target / default_name
        text = os.fspath(target)
    return _classify(target, text)


def _classify(target: Path, text: str) -> OutputTarget:
    fd = _fd_alias(target)
    if fd is not None:
        return OutputTarget(target, "fd", text, fd=fd)
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        if os.path.lexists(target):
            raise OutputError(f"{text}: is a broken symbolic link; remove it or give another "
                              "path") from None
        return OutputTarget(target, "file", text)
    except NotADirectoryError:
        raise OutputError(f"{text}: a parent of this path is not a directory") from None
    if stat.S_ISREG(mode):
        real = Path(os.path.realpath(target))
        _check_owner(real, text)
        return OutputTarget(real, "file", text, exists=True)
    if stat.S_ISFIFO(mode) or _is_null_device(target):
        return OutputTarget(target, "stream", text)
    if stat.S_ISDIR(mode):
        raise OutputError(f"{text}: is a directory; give a file path with -o")
    raise OutputError(f"{text}: is {node_kind(mode)}; trainctl writes only to {_ACCEPTED}")


def _is_null_device(path: Path) -> bool:
    """The null device (``/dev/null`` or a node of its device number)."""
    try:
        st, null = os.stat(path), os.stat(os.devnull)
    except OSError:
        return False
    return stat.S_ISCHR(st.st_mode) and stat.S_ISCHR(null.st_mode) and st.st_rdev == null.st_rdev


def _check_owner(real: Path, text: str) -> None:
    """Refuse a file whose owner a replacement could not keep (not ours, not root)."""
    euid = os.geteuid() if hasattr(os, "geteuid") else 0
    owner = os.stat(real).st_uid
    if euid != 0 and owner != euid:
        shown = text if os.fspath(real) == os.path.abspath(text) else f"{text} (-> {real})"
        raise OutputError(f"{shown}: belongs to another user (uid {owner}); replacing it would "
                          "make it yours, so trainctl refuses. Write to another path, or ask "
                          "its owner to remove it first.")


def _fd_alias(path: Path) -> int | None:
    """The descriptor a path stands for (``/dev/stdout``, ``/dev/fd/3``, ...), or None."""
    hop = os.path.abspath(path)
    for _ in range(40):
        if hop in _STD_ALIAS:
            return _STD_ALIAS[hop]
        match = _FD_ALIAS.match(hop)
        if match and (match["pid"] is None or int(match["pid"]) == os.getpid()):
            return int(match["fd"])
        if not os.path.islink(hop):
            return None
        hop = os.path.normpath(os.path.join(os.path.dirname(hop), os.readlink(hop)))
    return None


def write_output(text: str, target: str | os.PathLike[str] | OutputTarget) -> Path:
    """Write ``text`` (UTF-8) to an output target, each kind its way.

    Parameters
    ----------
    text : str
        The content.
    target : str, os.PathLike or OutputTarget
        Classified with :func:`output_target` when not already.

    Returns
    -------
    pathlib.Path
        The path written (``/dev/stdout`` for ``-``).

    Raises
    ------
    OutputError
        For a target that is refused (see :func:`output_target`).

    Examples
    --------
    >>> write_output("", "/dev/null").as_posix()
    '/dev/null'
    """
    target = output_target(target)
    if target.kind == "fd":
        try:
            _write_fd(text, target.fd)
        except OSError as exc:  # a full disk or a closed pipe behind the descriptor
            where = "standard output" if target.is_stdout else f"descriptor {target.fd}"
            raise OutputError(f"{target}: cannot write to {where} ({exc.strerror or exc}); the "
                              "output is incomplete.") from None
    elif target.kind == "stream":
        _write_stream(text, target)
    else:
        write_text_atomic(text, target.path)
    return target.path


def _write_stream(text: str, target: OutputTarget) -> None:
    """Write through a pipe or the null device; opening never blocks (O_NONBLOCK)."""
    flags = os.O_WRONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(target.path, flags)
    except OSError as exc:
        if exc.errno == errno.ENXIO:
            raise OutputError(f"{target}: is a named pipe that no process is reading; nothing "
                              "was written. Start its reader first, or give a file.") from None
        raise OutputError(f"{target}: cannot open it for writing ({exc.strerror or exc}); "
                          "nothing was written.") from None
    try:
        mode = os.fstat(fd).st_mode
        if not (stat.S_ISFIFO(mode) or _is_null_device(target.path)):
            raise OutputError(f"{target}: changed into {node_kind(mode)} before it was "
                              f"written; trainctl writes only to {_ACCEPTED}")
        os.set_blocking(fd, True)  # the reader is there: wait for it like any pipe writer
        data = memoryview(text.encode("utf-8"))
        while data:
            data = data[os.write(fd, data):]
    except OSError as exc:
        raise OutputError(f"{target}: cannot write to it ({exc.strerror or exc}); the output "
                          "is incomplete.") from None
    finally:
        os.close(fd)


def _write_fd(text: str, fd: int) -> None:
    stream = {1: sys.stdout, 2: sys.stderr}.get(fd)
    if stream is not None:
        stream.write(text)
        stream.flush()
        return
    data = memoryview(text.encode("utf-8"))
    while data:
        data = data[os.write(fd, data):]


def write_text_atomic(text: str, path: str | os.PathLike[str]) -> Path:
    """Write ``text`` (UTF-8) to the regular file ``path`` atomically.

    The text goes to a temporary file in the destination directory, which is
    then renamed over ``path`` with :func:`os.replace`; readers never see a
    partial file, and on error (a full disk, an interrupt) nothing is left
    behind and an existing file is unchanged. Missing parent directories are
    created. A symbolic link is followed (the link stays, its regular file is
    replaced); an existing file keeps its permissions, owner and group.

    Parameters
    ----------
    text : str
        File content.
    path : str or os.PathLike
        Destination file.

    Returns
    -------
    pathlib.Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputError
        If ``path`` exists and is not a regular file (a device, a pipe, a
        directory): those are never replaced (see :func:`write_output`); if
        the file's owner cannot be kept; if the write fails (the message
        names the file and the reason, e.g. no space left on the device).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = write_text_atomic("hi", Path(tmp) / "sub" / "a.txt")
    ...     out.read_text(encoding="utf-8")
    'hi'
    """
    given = Path(path)
    target = Path(os.path.realpath(given)) if os.path.lexists(given) else given
    old = None
    if target.exists():
        old = os.stat(target)
        if not stat.S_ISREG(old.st_mode):
            raise OutputError(f"{given}: is not a regular file; it is never replaced (write "
                              "through devices and pipes with write_output)")
        _check_owner(target, os.fspath(given))
    target.parent.mkdir(parents=True, exist_ok=True)
    data = text.encode("utf-8")
    tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    try:
        # os.open honours the umask (unlike mkstemp's 0600), so a new file gets the
        # permissions a plain open() would give it.
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as exc:
        raise OutputError(f"{given}: cannot write the file ({exc.strerror or exc} in "
                          f"{target.parent}); nothing was written.") from None
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        if old is not None:
            _keep_owner_and_mode(tmp, old)
        os.replace(tmp, target)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        kept = "it is unchanged" if old is not None else "nothing was written"
        raise OutputError(f"{given}: cannot write the file ({exc.strerror or exc}); "
                          f"{kept}.") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return given


def _keep_owner_and_mode(tmp: Path, old: os.stat_result) -> None:
    """Give the new file the replaced one's owner, group and permissions (chown first:
    it clears the set-id bits that chmod then restores)."""
    new = os.stat(tmp)
    if (new.st_uid, new.st_gid) != (old.st_uid, old.st_gid):
        os.chown(tmp, old.st_uid, old.st_gid)
    os.chmod(tmp, stat.S_IMODE(old.st_mode))
