"""The output layer of every command: how a file the user names is written.

Every writer of transgen (results, matrices, figures, scenarios, sweep tables) goes through
:func:`atomic_path` (one file) and :func:`output_set` (files that appear together). What the
user's name points at decides how:

* a regular file, or a name that does not exist yet: the data is written to a temporary file in
  the same folder and renamed over the name only when complete (a failed or interrupted run never
  leaves a half-written file, and an existing file is replaced whole or not at all);
* a symbolic link: it is followed; the target is written atomically beside the target and the
  link is kept;
* a character device (``/dev/null``, a terminal), a FIFO, ``-`` or ``/dev/stdout``, ``/dev/stderr``,
  ``/dev/fd/N``: the data is written through it, in place (opened for writing, never replaced,
  never created). It is first written in full to a temporary file, so that nothing reaches the
  stream when the run fails. A FIFO with no reader is an error, not a hang;
* a folder, a socket, a block device: refused.

While a command of the command line runs (:func:`command_scope`), the files it reads are noted
(:func:`note_input`) and an output that is one of them (same resolved path or same device and
inode) is refused, exit 2, unless ``--force``.

Temporary files are named ``.transgen~PID.START.TOKEN.NAME``: the writer's process id and its
start time (from ``/proc``). A temporary file whose writer is no longer running (a run killed by
SIGKILL or a power cut) is stale, and the next write into that folder by any transgen command
removes it (:func:`remove_stale`). Temporaries of a live process are removed when it ends with
an exception, Ctrl-C or SIGTERM (the command line turns SIGTERM into :class:`Terminated`).

Every message names the user's path, never the temporary file.
"""
from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import secrets
import stat
import sys
import tempfile
from pathlib import Path

from .errors import TransgenError

__all__ = ["atomic_path", "output_set", "command_scope", "note_input", "check_not_input", "is_stream",
           "remove_stale", "remove_temporaries", "messages_stream", "OutputError", "OutputRefused", "Terminated", "TEMP_PREFIX",
           "is_temporary"]

#: the start of the name of every temporary file transgen writes
TEMP_PREFIX = ".transgen~"

_STREAM_FDS = {"-": 1, "/dev/stdout": 1, "/dev/stderr": 2}


class OutputError(TransgenError, OSError):
    """An output that could not be written (a full disk, a read-only folder, a FIFO nobody
    reads): exit 1. The message names the user's path."""

    def __str__(self) -> str:
        return str(self.strerror)


class OutputRefused(TransgenError, ValueError):
    """An output that must not be written (it is one of the command's inputs, a folder): exit 2."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (or SIGHUP) turned into an exception so that temporary files are removed and the
    command exits with ``128 + signum`` (143 for SIGTERM)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


# ------------------------------------------------------------------------ temporaries and liveness

_LIVE: set[str] = set()  # the temporary files of this process not yet renamed or removed
_CLEANED: set[str] = set()  # the folders searched for stale temporaries by this process


def _start_time(pid: int) -> str | None:
    """The start time of process ``pid`` in clock ticks since boot (``/proc/PID/stat`` field 22),
    None where there is no /proc or no such process."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            data = fh.read()
    except OSError:
        return None
    fields = data[data.rfind(b")") + 2:].split()
    return fields[19].decode() if len(fields) > 19 else None


_OWN: tuple[int, str] | None = None


def _own() -> tuple[int, str]:
    """(pid, start time) of this process (recomputed after a fork)."""
    global _OWN
    pid = os.getpid()
    if _OWN is None or _OWN[0] != pid:
        _OWN = (pid, _start_time(pid) or "0")
    return _OWN


def is_temporary(name: str) -> bool:
    """Whether ``name`` (a file name) is a temporary file of transgen."""
    return name.startswith(TEMP_PREFIX)


def _writer_alive(name: str) -> bool:
    """Whether the process that wrote the temporary file ``name`` may still be running (unknown
    names count as alive: never removed)."""
    try:
        pid_text, start = name[len(TEMP_PREFIX):].split(".", 2)[:2]
        pid = int(pid_text)
    except ValueError:
        return True
    if (pid, start) == _own():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        pass
    now = _start_time(pid)
    return now is None or start == "0" or now == start  # a reused pid has another start time


def remove_stale(folder: str | Path) -> list[Path]:
    """Remove the temporary files in ``folder`` whose writer no longer runs; return them. Done
    once per folder and process by :func:`atomic_path`."""
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if is_temporary(entry.name) and not _writer_alive(entry.name):
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed


def _clean_once(folder: str) -> None:
    if folder not in _CLEANED:
        _CLEANED.add(folder)
        remove_stale(folder)


def remove_temporaries() -> None:
    """Remove every temporary file of this process (the command line calls it when it ends)."""
    for tmp in list(_LIVE):
        _discard(tmp)


def _discard(tmp: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(tmp)
    _LIVE.discard(tmp)


def _new_temporary(folder: str, name: str, suffix: str) -> str:
    pid, start = _own()
    base = name[:80] if name.endswith(suffix) else name[:80] + suffix  # the suffix last: it selects the format
    tmp = os.path.join(folder, f"{TEMP_PREFIX}{pid}.{start}.{secrets.token_hex(4)}.{base}")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # the umask applies, as for any new file
    os.close(fd)
    _LIVE.add(tmp)
    return tmp


# ---------------------------------------------------------------------------------- the inputs

#: (resolved paths, (st_dev, st_ino) pairs, force) of the running command, None outside one
_INPUTS: contextvars.ContextVar[tuple[set, set, bool] | None] = contextvars.ContextVar("transgen_inputs", default=None)


@contextlib.contextmanager
def command_scope(force: bool = False):
    """The block of one command: the files it reads (:func:`note_input`) are refused as its
    outputs unless ``force``."""
    token = _INPUTS.set((set(), set(), force))
    try:
        yield
    finally:
        _INPUTS.reset(token)


def note_input(path: str | Path) -> None:
    """Note that the running command reads ``path`` (a no-op outside :func:`command_scope`)."""
    scope = _INPUTS.get()
    if scope is None:
        return
    with contextlib.suppress(OSError, ValueError, RuntimeError):
        scope[0].add(os.path.realpath(path))
        st = os.stat(path)
        scope[1].add((st.st_dev, st.st_ino))


def _same_as_input(path: str) -> bool:
    scope = _INPUTS.get()
    if scope is None or scope[2]:
        return False
    if os.path.realpath(path) in scope[0]:
        return True
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return False
    return stat.S_ISREG(st.st_mode) and (st.st_dev, st.st_ino) in scope[1]


def check_not_input(path: str | Path, option: str | None = None) -> None:
    """Raise :class:`OutputRefused` when ``path`` is a file the running command reads."""
    if _same_as_input(str(path)):
        where = f"{option} {path}" if option else str(path)
        raise OutputRefused(f"{where} is one of the command's input files: writing it would destroy it; "
                            f"name another output (or give --force to overwrite it)")


# ---------------------------------------------------------------------------------- the writing

def is_stream(path: str | Path) -> bool:
    """Whether ``path`` is written through in place rather than replaced: ``-``, the standard
    streams, ``/dev/fd/N``, an existing character device or FIFO (links followed)."""
    return _stream_fd(str(path)) is not None or _kind(str(path)) in ("chr", "fifo")


def messages_stream(*paths) -> object:
    """Where a command prints its ``wrote ...`` lines: standard error when one of ``paths`` is
    standard output (the data goes there), else standard output."""
    return sys.stderr if any(p is not None and _stream_fd(str(p)) == 1 for p in paths) else sys.stdout


def _stream_fd(path: str) -> int | None:
    if path in _STREAM_FDS:
        return _STREAM_FDS[path]
    for head in ("/dev/fd/", "/proc/self/fd/"):
        if path.startswith(head) and path[len(head):].isdigit():
            return int(path[len(head):])
    return None


def _kind(real: str) -> str | None:
    """What ``real`` is: None (missing), "reg", "dir", "chr", "fifo", "blk", "sock"."""
    try:
        mode = os.stat(real).st_mode
    except (OSError, ValueError):
        return None
    for test, name in ((stat.S_ISREG, "reg"), (stat.S_ISDIR, "dir"), (stat.S_ISCHR, "chr"),
                       (stat.S_ISFIFO, "fifo"), (stat.S_ISBLK, "blk")):
        if test(mode):
            return name
    return "sock"


def _os_error(exc: OSError, path: str) -> OutputError:
    if exc.errno == errno.ENXIO:
        why = "no process is reading this FIFO"
    else:
        why = exc.strerror or str(exc)
    return OutputError(exc.errno or 0, f"cannot write {path}: {why}")


def _copy_to_fd(tmp: str, fd: int) -> None:
    with open(tmp, "rb") as src:
        while chunk := src.read(1 << 20):
            view = memoryview(chunk)
            while view:
                view = view[os.write(fd, view):]


def _write_stream(tmp: str, user: str, real: str, fd_number: int | None) -> None:
    """Write the finished temporary file through the stream ``real`` (or the descriptor)."""
    if fd_number in (1, 2):  # through sys.stdout (sys.stderr), which may be replaced (pytest, a notebook)
        stream = sys.stdout if fd_number == 1 else sys.stderr
        stream.flush()
        buffer = getattr(stream, "buffer", None)
        with open(tmp, "rb") as src:
            while chunk := src.read(1 << 20):
                if buffer is not None:
                    buffer.write(chunk)
                else:
                    stream.write(chunk.decode("utf-8", "replace"))
        (buffer or stream).flush()
        return
    if fd_number is not None:
        try:
            fd = os.dup(fd_number)
        except OSError as exc:
            raise _os_error(exc, user) from None
    else:
        try:
            fd = os.open(real, os.O_WRONLY | os.O_NONBLOCK | os.O_NOCTTY)  # a FIFO with no reader: ENXIO, not a hang
            os.set_blocking(fd, True)
        except OSError as exc:
            raise _os_error(exc, user) from None
    try:
        _copy_to_fd(tmp, fd)
    except BrokenPipeError:
        if fd_number is None:
            raise OutputError(errno.EPIPE, f"cannot write {user}: the reader of the FIFO went away") from None
        raise
    except OSError as exc:
        raise _os_error(exc, user) from None
    finally:
        os.close(fd)


def _commit(tmp: str, user: str, real: str, stream: int | str | None) -> None:
    """Put the complete temporary file ``tmp`` in place of the user's path."""
    try:
        if stream is None:
            os.replace(tmp, real)
            _LIVE.discard(tmp)
        else:
            _write_stream(tmp, user, real, stream if isinstance(stream, int) else None)
    except OutputError:
        raise
    except OSError as exc:
        if isinstance(exc, BrokenPipeError) and isinstance(stream, int):
            raise
        raise _os_error(exc, user) from None
    finally:
        if stream is not None or tmp in _LIVE:
            _discard(tmp)


#: the files of the innermost :func:`output_set` block: (temporary path, user path, real path, stream)
_PENDING: contextvars.ContextVar[list | None] = contextvars.ContextVar("transgen_pending_outputs", default=None)


def _target(path: str) -> tuple[str, int | str | None]:
    """(real path, stream) of the user's ``path``: stream None (replace the file), a file
    descriptor number or "node" (write through the device or FIFO)."""
    fd = _stream_fd(path)
    if fd is not None:
        return path, fd
    real = os.path.realpath(path)  # a symbolic link: its target is written, the link kept
    kind = _kind(real)
    if kind in ("chr", "fifo"):
        return real, "node"
    if kind == "dir":
        raise OutputRefused(f"{path} is a folder: name a file to write")
    if kind in ("blk", "sock"):
        raise OutputRefused(f"{path} is a {'block device' if kind == 'blk' else 'socket'}: transgen "
                            f"writes files, FIFOs and character devices only")
    return real, None


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str | None = None):
    """Yield a temporary path to write the output ``path`` into; when the block succeeds, put it
    in place of ``path`` (see the module's docstring: renamed over a file, written through a
    device or FIFO), else delete it. Inside an :func:`output_set` block that waits for the end of
    the block. ``suffix`` ends the temporary file's name (default: that of ``path``; it selects
    the format of some writers). Raises :class:`OutputRefused` (exit 2) for an input of the
    command or a folder, :class:`OutputError` (exit 1) when the file cannot be written."""
    user = str(path)
    check_not_input(user)
    real, stream = _target(user)
    suffix = suffix if suffix is not None else Path(user).suffix
    if stream is None:
        folder = os.path.dirname(real) or "."
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            raise _os_error(exc, user) from None
    else:
        folder = tempfile.gettempdir()
    _clean_once(folder)
    try:
        tmp = _new_temporary(folder, os.path.basename(real) or "output", suffix)
    except OSError as exc:
        raise _os_error(exc, user) from None
    try:
        try:
            yield Path(tmp)
        except OSError as exc:  # the writer failed (a full disk): the user's path, not the temporary
            if isinstance(exc, OutputError):
                raise
            raise _os_error(exc, user) from None
        pending = _PENDING.get()
        if pending is None:
            _commit(tmp, user, real, stream)
        else:
            pending.append((tmp, user, real, stream))
    except BaseException:
        _discard(tmp)
        raise


@contextlib.contextmanager
def output_set():
    """All files written through :func:`atomic_path` inside the block appear together or not at
    all: each is written to its temporary file, and only when the whole block succeeds are they
    put in place (files first renamed, then the streams written); an exception (an error,
    Ctrl-C, or SIGTERM turned into one by the command line) deletes every one of them."""
    pending: list = []
    token = _PENDING.set(pending)
    try:
        yield
    except BaseException:
        for tmp, *_ in pending:
            _discard(tmp)
        raise
    finally:
        _PENDING.reset(token)
    try:
        for item in sorted(pending, key=lambda p: p[3] is not None):  # the renames cannot block: first
            _commit(*item)
    finally:
        for tmp, *_ in pending:
            if tmp in _LIVE:
                _discard(tmp)
