"""Output files that appear whole or not at all, and never destroy what is there.

A regular file is written to a temporary name beside it, then renamed into place with
the rest of its set (a failure leaves none of them). A symbolic link is written through
to its target, the same way, and stays a link. A special file (a FIFO, a device, a
socket) cannot be renamed over without destroying it, so it is written through in
place once the data is complete; `-` is standard output, written the same way.
Special files and standard output are written before any regular file is renamed into
place, so a failure there still leaves none of the regular files.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import stat
import sys
import tempfile
from pathlib import Path

STDOUT = "-"

# Read once: os.umask can only be read by setting it, which would race other threads.
_UMASK = os.umask(0o022)
os.umask(_UMASK)


# The largest input any command reads: a layout is a few kB, a measured profile or a track's
# design geometry a few MB at most. Past it the file is not one of rail-mj's (/dev/zero, say).
MAX_INPUT = 256 * 2**20  # bytes


def read_input(path: str | os.PathLike) -> bytes:
    """An input file's bytes: a regular file (a FIFO would block, a device need not end) of at
    most MAX_INPUT bytes; OSError with a one-line strerror otherwise."""
    info = os.stat(path)
    if not stat.S_ISREG(info.st_mode):
        raise OSError(errno.EINVAL, "not a regular file (a folder, a FIFO or a device)")
    with open(path, "rb") as source:
        data = source.read(MAX_INPUT + 1)
    if len(data) > MAX_INPUT:
        raise OSError(errno.EFBIG, f"larger than {MAX_INPUT >> 20} MB, more than any input of rail-mj's")
    return data


class OutputError(OSError):
    """An output that could not be written; the message names the user's path."""


def is_special(path) -> bool:
    """Whether `path` is standard output or an existing file that is not a regular file
    or a folder (following links): a FIFO, a device or a socket, written through in place."""
    if str(path) == STDOUT:
        return True
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


def _destination(path: Path) -> Path:
    """Where a regular output really goes: a symbolic link's final target (so the link
    survives and what it points at is replaced), else the path itself. A link that
    points in a circle is an error, never replaced."""
    if not path.is_symlink():
        return path
    try:
        return Path(os.path.realpath(path, strict=True))
    except FileNotFoundError:  # a dangling link: its target is made
        return Path(os.path.realpath(path))
    except (OSError, RuntimeError) as e:
        raise OutputError(f"cannot write {path}: a symbolic link that does not resolve ({e})") from None


def _stage(final: Path, special: bool) -> Path:
    """A new, empty temporary file: beside the destination, so that renaming it into place
    is atomic, or for a special file in the system's temporary folder."""
    if not special:
        final.parent.mkdir(parents=True, exist_ok=True)
    where = None if special else final.parent
    fd, tmp = tempfile.mkstemp(dir=where, prefix=f".{final.name}.", suffix=".tmp")
    os.fchmod(fd, 0o666 & ~_UMASK)  # mkstemp makes owner-only files
    os.close(fd)
    return Path(tmp)


def _write_through(tmp: Path, final: str) -> None:
    """Copy a finished temporary file into standard output or a special file. A FIFO must
    have its reader already: nothing waits forever for one."""
    with open(tmp, "rb") as source:
        if final == STDOUT:
            sys.stdout.flush()
            shutil.copyfileobj(source, sys.stdout.buffer)
            sys.stdout.buffer.flush()
            return
        try:
            fd = os.open(final, os.O_WRONLY | os.O_NONBLOCK)
        except OSError as e:
            if e.errno == errno.ENXIO:
                raise OutputError(f"cannot write {final}: a FIFO with no reader (start the reader first)") from None
            raise
        os.set_blocking(fd, True)  # the reader is there: write at its pace
        with os.fdopen(fd, "wb") as sink:
            shutil.copyfileobj(source, sink)


@contextlib.contextmanager
def staged(paths):
    """Yield a temporary path for each of `paths`; when the block succeeds, put every
    one in place (see the module docstring), and otherwise remove them all, so no output
    is left half-written and none of a set is written without the others."""
    finals = [str(p) for p in paths]
    special = [is_special(p) for p in finals]
    destinations = [Path(p) if s else _destination(Path(p)) for p, s in zip(finals, special)]
    temps: list[Path] = []
    try:
        for final, dest, spec in zip(finals, destinations, special):
            try:
                temps.append(_stage(dest, spec))
            except OSError as e:
                raise OutputError(f"cannot write {final}: {e.strerror or e}") from None
        yield temps
        for tmp, final, spec in zip(temps, finals, special):
            if spec:
                try:
                    _write_through(tmp, final)
                except BrokenPipeError:
                    raise  # the reader went away (`| head`): theirs to decide, not an error here
                except OutputError:
                    raise
                except OSError as e:
                    raise OutputError(f"cannot write {final}: {e.strerror or e}") from None
        for tmp, final, dest, spec in zip(temps, finals, destinations, special):
            if spec:
                continue
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())  # the data is on disk before the name points at it
            try:
                os.replace(tmp, dest)
            except OSError as e:
                raise OutputError(f"cannot write {final}: {e.strerror or e}") from None
        for tmp, spec in zip(temps, special):
            if spec:
                tmp.unlink(missing_ok=True)
    except BaseException as error:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        if isinstance(error, OSError) and not isinstance(error, (OutputError, BrokenPipeError)):
            names = {str(t): f for t, f in zip(temps, finals)}
            where = names.get(str(error.filename), error.filename or "output")
            raise OutputError(f"cannot write {where}: {error.strerror or error}") from None
        raise


def atomic_write(path, data: bytes) -> None:
    with staged([path]) as (tmp,):
        tmp.write_bytes(data)
