"""Output files appear whole or not at all: written to temporary names beside their
final paths, then renamed into place together."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

# Read once: os.umask can only be read by setting it, which would race other threads.
_UMASK = os.umask(0o022)
os.umask(_UMASK)


class OutputError(OSError):
    """An output that could not be written; the message names the user's path."""


@contextlib.contextmanager
def staged(paths):
    """Yield a temporary path for each of `paths`; when the block succeeds, rename every
    one into place, and otherwise remove them all, so no output is left half-written
    and none of a set is written without the others."""
    finals = [Path(p) for p in paths]
    temps: list[Path] = []
    try:
        for final in finals:
            try:
                final.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(dir=final.parent, prefix=f".{final.name}.", suffix=".tmp")
                os.fchmod(fd, 0o666 & ~_UMASK)  # mkstemp makes owner-only files
                os.close(fd)
            except OSError as e:
                raise OutputError(f"cannot write {final}: {e.strerror or e}") from None
            temps.append(Path(tmp))
        yield temps
        for tmp, final in zip(temps, finals):
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())  # the data is on disk before the name points at it
            try:
                os.replace(tmp, final)
            except OSError as e:
                raise OutputError(f"cannot write {final}: {e.strerror or e}") from None
    except BaseException as error:
        for tmp in temps:
            tmp.unlink(missing_ok=True)
        if isinstance(error, OSError) and not isinstance(error, OutputError):
            names = {str(t): str(f) for t, f in zip(temps, finals)}
            where = names.get(str(error.filename), error.filename or "output")
            raise OutputError(f"cannot write {where}: {error.strerror or error}") from None
        raise


def atomic_write(path, data: bytes) -> None:
    with staged([path]) as (tmp,):
        tmp.write_bytes(data)
