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
import functools
import hashlib
import os
import re
import shutil
import signal
import stat
import sys
import tempfile
import threading
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
    """An output that could not be written; the message names the user's path, `errno`
    is the cause's (ENOSPC for a full disk), None where no system call failed."""

    def __init__(self, message: str, cause: int | None = None) -> None:
        super().__init__(message)
        self.errno = cause

    def __str__(self) -> str:
        return str(self.args[0])


# Failures of the machine, not of the request: no room left where the output goes.
NO_ROOM = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})


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


def _alive(pid: int) -> bool:
    """Whether a process `pid` exists (one of another user's counts: it may be writing)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True
    return True


_CLEANED: set[Path] = set()  # folders looked through for stale temporary files, this process
# What `_stage` names a temporary file: `.NAME.PID.XXXXXXXX.tmp`, mkstemp's eight characters.
_TEMPORARY = re.compile(r"\..+\.(\d+)\.[a-z0-9_]{8}\.tmp")


def remove_stale(folder: Path) -> None:
    """Remove the temporary files in `folder` left by writers that were killed (SIGKILL, a
    crash): those named as `_stage` names them whose process is gone. A live process's are
    kept, whoever it is: a second writer may be at work. Once a process for each folder: a
    sweep's thousands of recordings do not list their folder a thousand times. (A process id
    means nothing on another host: in a folder shared by machines a live writer's file may be
    removed; its rename then fails, and says so.)"""
    if folder in _CLEANED:
        return
    _CLEANED.add(folder)
    try:
        names = os.listdir(folder)
    except OSError:
        return
    for name in names:
        match = _TEMPORARY.fullmatch(name)
        if match is not None and not _alive(int(match.group(1))):
            with contextlib.suppress(OSError):
                if stat.S_ISREG(os.lstat(folder / name).st_mode):
                    os.unlink(folder / name)


def _stage(final: Path, special: bool) -> Path:
    """A new, empty temporary file: beside the destination, so that renaming it into place
    is atomic, or for a special file in the system's temporary folder. Its name carries the
    writer's process id, so that the next writer can tell a killed one's from a live one's."""
    if not special:
        final.parent.mkdir(parents=True, exist_ok=True)
        remove_stale(final.parent)
    where = None if special else final.parent
    fd, tmp = tempfile.mkstemp(dir=where, prefix=f".{final.name}.{os.getpid()}.", suffix=".tmp")
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


# The signals a user sends to stop a command: held back while a set of outputs is renamed
# into place (microseconds), so that Ctrl-C or a kill leaves the old set or the new one.
_HELD = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def _uninterrupted():
    """Defer the signals of _HELD to the end of the block, then act on them as before."""
    if threading.current_thread() is not threading.main_thread():
        yield  # only the main thread may set handlers; it is the one they interrupt
        return
    if any(signal.getsignal(n) is None for n in _HELD):  # a handler set from C: not ours to move
        yield
        return
    arrived: list[int] = []
    before = {n: signal.signal(n, lambda number, frame: arrived.append(number)) for n in _HELD}
    try:
        yield
    finally:
        for held, handler in before.items():
            signal.signal(held, handler)
        for number in arrived:
            signal.raise_signal(number)


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
                raise OutputError(f"cannot write {final}: {e.strerror or e}", e.errno) from None
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
                    raise OutputError(f"cannot write {final}: {e.strerror or e}", e.errno) from None
        for tmp, spec in zip(temps, special):
            if not spec:
                with open(tmp, "rb+") as f:
                    os.fsync(f.fileno())  # the data is on disk before the name points at it
        with _uninterrupted():
            for tmp, final, dest, spec in zip(temps, finals, destinations, special):
                if spec:
                    continue
                try:
                    os.replace(tmp, dest)
                except OSError as e:
                    raise OutputError(f"cannot write {final}: {e.strerror or e}", e.errno) from None
        for tmp, spec in zip(temps, special):
            if spec:
                tmp.unlink(missing_ok=True)
    except BaseException as error:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        if isinstance(error, OSError) and not isinstance(error, (OutputError, BrokenPipeError)):
            # A write's error names no file: with one output it is that one.
            names = {str(t): f for t, f in zip(temps, finals)}
            unnamed = finals[0] if len(finals) == 1 else " or ".join(finals)
            where = names.get(str(error.filename), error.filename or unnamed)
            raise OutputError(f"cannot write {where}: {error.strerror or error}", error.errno) from None
        raise


def atomic_write(path, data: bytes) -> None:
    with staged([path]) as (tmp,):
        tmp.write_bytes(data)


# --- what is computed once and kept between commands -----------------------------------------


@functools.lru_cache(maxsize=1)
def sources_digest() -> str:
    """A hash of every source file of the package: what a kept result was computed by (not the
    modules written into its caches, under __pycache__: rail_mj.simulation.native's cfunc)."""
    here = Path(__file__).resolve().parent
    sources = []
    for folder, subfolders, names in os.walk(here):
        subfolders[:] = [f for f in subfolders if f != "__pycache__"]  # its caches: thousands of files
        sources += [Path(folder, name) for name in names if name.endswith(".py")]
    digest = hashlib.sha256()
    for source in sorted(sources):
        digest.update(source.relative_to(here).as_posix().encode() + source.read_bytes())
    return digest.hexdigest()[:16]


def cache_folder(kind: str) -> Path:
    """Where results of `kind` ("numba", "contact") are kept between commands: a folder named
    by the package's sources, so that no edit anywhere can leave a stale one in use, beside the
    sources (rail_mj/__pycache__) or, for a read-only installed package, in the user's cache
    ($XDG_CACHE_HOME/rail-mj or ~/.cache/rail-mj). Not made here."""
    here = Path(__file__).resolve().parent
    base = here / "__pycache__"
    if not os.access(here, os.W_OK):
        base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "rail-mj"
    return base / f"{kind}-{sources_digest()}"


def cached_arrays(kind: str, key: str) -> dict | None:
    """The arrays kept under `key` (a hash of everything they depend on), or None: never kept,
    or unreadable (a half-written or damaged file is computed again, and replaced)."""
    import numpy as np

    path = cache_folder(kind) / f"{key}.npz"
    try:  # the file opened here: np.load leaves its own open when the archive is damaged
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as data:
            return {name: data[name] for name in data.files}
    except Exception:  # only a cache: whatever is wrong with the file, compute again
        return None


def keep_arrays(kind: str, key: str, arrays: dict) -> None:
    """Keep `arrays` (name -> numpy array) under `key`, whole or not at all (a file written beside
    and renamed, so that processes computing the same key at once do not clash). A cache that
    cannot be written (a read-only or full disk) is no error: the result is computed again."""
    import numpy as np

    folder = cache_folder(kind)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with staged([folder / f"{key}.npz"]) as (tmp,), open(tmp, "wb") as f:
            np.savez(f, **arrays)
    except OSError:
        pass
