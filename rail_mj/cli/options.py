"""What every `rail-mj` command shares: its failures and exit statuses, the layout it reads,
the checks of its speeds, ranges and outputs, and its one-line progress.

Exit status: 0 success; 1 standard output's reader gone; 2 bad input (layout, arguments,
output path); 3 a run that cannot be done or that diverged, or a full disk (rail_mj.cli.main).
Every failure is one line on stderr (`Failure`), and so
is every warning (a legal value far outside railway practice: rail_mj.layout.practice).
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
from pathlib import Path

import click

from rail_mj.files import NO_ROOM, STDOUT, is_special, read_input, staged
from rail_mj.layout import Layout, LayoutError, load_layout
from rail_mj.practice import RANGES
from rail_mj.studies.span import Rules, Span, SpanError

EXIT_BAD_INPUT = 2
EXIT_RUN_FAILED = 3


class Failure(Exception):
    """What stops a command: its one line for stderr and the exit status."""

    def __init__(self, message: str, status: int):
        super().__init__(message)
        self.status = status


@contextlib.contextmanager
def written(paths):
    """`rail_mj.files.staged` for a command: the outputs appear all together or not at all,
    and a failure is one line, exit 3 when the disk is full (the machine's fault, not the
    request's), else 2. A reader of standard output gone away (`| head`) is left to `main`,
    which ends quietly, as Unix tools do."""
    try:
        with staged(paths) as temps:
            yield temps
    except BrokenPipeError:
        raise
    except OSError as e:
        raise output_failure(e, str(e)) from None


def output_failure(error: OSError, message: str) -> Failure:
    """The Failure of an output that could not be written: exit 3 when the disk is full."""
    return Failure(message, EXIT_RUN_FAILED if error.errno in NO_ROOM else EXIT_BAD_INPUT)


def tables_of(path: str) -> set[str]:
    """The top-level tables a layout file has, read without checking it (empty when it cannot
    be read: `layout_of` then says why): for a command to refuse what it cannot do before the
    layout's contact tables are built."""
    import tomllib

    try:
        data = tomllib.loads(read_input(path).decode("utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError, RecursionError):
        return set()
    return {k for k, v in data.items() if isinstance(v, dict)}


def layout_of(path: str) -> Layout:
    """The checked layout; its warnings, one line each, on stderr (and on a terminal, before the
    first command of an installation, that it compiles: `compiling_note`)."""
    try:
        layout = load_layout(path)
    except LayoutError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    for warning in layout.warnings:
        warn(warning)
    note = compiling_note() if sys.stderr.isatty() else None
    if note is not None:
        click.echo(f"rail-mj: {note}", err=True)
    return layout


def compiling_note() -> str | None:
    """What to tell a user whose command will compile the contact law and the native callback
    first (numba's cache for these sources is empty: a new installation, or edited sources),
    else None. Said on a terminal only: pipes and tests read stderr for errors and warnings."""
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if folder is None:  # rail_mj sets it on import (rail_mj._numba_cache_dir); else numba's default
        return None
    path = Path(folder)
    if path.is_dir() and any(path.rglob("*.nbi")):
        return None
    return "compiling the contact law and the native callback, once for this installation (10 to 20 s)"


def positive_rate(text: str, option: str, words: str) -> float:
    """A positive, finite number of samples per second from `option`'s text, or a one-line
    refusal naming the `words` it also takes."""
    try:
        rate = float(text)
    except ValueError:
        rate = math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise Failure(
            f"{option} must be {words} or a positive number of samples per second, got {text!r}", EXIT_BAD_INPUT
        )
    return rate


def sample_interval_of(text: str) -> float | None:
    """--sample-rate: None (full: every millisecond, rail_mj.simulation.stepping.SAMPLE_INTERVAL)
    or 1/rate s, or a one-line refusal."""
    return None if text == "full" else 1.0 / positive_rate(text, "--sample-rate", "full")


def track_of(path: str | None):
    """The checked track of --track (rail_mj.track), its warnings on stderr; None without one."""
    if path is None:
        return None
    from rail_mj.track import TrackError, load_track

    try:
        track = load_track(path)
    except TrackError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
    for warning in track.warnings:
        warn(warning)
    return track


def warn(text: str) -> None:
    click.echo(f"rail-mj: warning: {text}", err=True)


def warn_deficiency(where: str, deficiency_mm: float) -> None:
    """A warning for a cant deficiency (or excess) beyond practice (RANGES, track.cant_deficiency)."""
    warning = RANGES["track.cant_deficiency"].warning(round(deficiency_mm))
    if warning:
        warn(f"{where}: cant deficiency {warning}")


def check_speed(option: str, value: float) -> float:
    """A forward speed from the command line: positive, and not beyond any railway."""
    return check_positive(option, value, "speed")


def check_positive(option: str, value: float, key: str) -> float:
    """A positive number from the command line within RANGES[key], with a warning outside
    railway practice."""
    if not (math.isfinite(value) and value > 0):
        raise Failure(f"{option} must be a positive number, got {value}", EXIT_BAD_INPUT)
    error = RANGES[key].check(value)
    if error:
        raise Failure(f"{option} {error}", EXIT_BAD_INPUT)
    warning = RANGES[key].warning(value)
    if warning:
        warn(f"{option}: {warning}")
    return value


def check_speed_range(vmin: float, vmax: float) -> None:
    if not (math.isfinite(vmin) and math.isfinite(vmax) and 0 < vmin < vmax):
        raise Failure(f"need 0 < --vmin < --vmax, got {vmin} and {vmax}", EXIT_BAD_INPUT)
    error = RANGES["speed"].check(vmax)
    if error:
        raise Failure(f"--vmax {error}", EXIT_BAD_INPUT)


@contextlib.contextmanager
def status_line(label: str):
    """A one-line progress display on a terminal's stderr (nothing elsewhere): yields the
    function that shows a new status, or None."""
    if not sys.stderr.isatty():
        yield None
        return
    width = 0

    def show(text: str) -> None:
        nonlocal width
        line = f"{label}: {text}"
        click.echo("\r" + line.ljust(width), err=True, nl=False)
        width = len(line)

    try:
        yield show
    finally:
        if width:
            click.echo("\r" + " " * width + "\r", err=True, nl=False)


def uses_stdout(*paths) -> bool:
    return any(p == STDOUT for p in paths)


def csv_beside(out: str, csv_path: str | None, what: str) -> str:
    """--csv, or else the plot `out` with .csv for its name (standard output for `-o -`);
    `what` names the two for the one standard output they cannot share."""
    csv_path = csv_path or (STDOUT if out == STDOUT else str(Path(out).with_suffix(".csv")))
    if csv_path == STDOUT and out == STDOUT:
        raise Failure(f"-o - needs --csv FILE: {what} cannot both go to standard output", EXIT_BAD_INPUT)
    return csv_path


def check_outputs(
    layout: str | None, outputs: list[tuple[str, str | None]], folders: bool = False, source: str = "the layout file"
) -> None:
    """Refuse, before any work, outputs that cannot or must not be written: a folder
    given for a file, the input (`layout`, called `source`) itself, two outputs on one path
    (or on standard output), an unwritable place. `-` is standard output; a FIFO or a
    device is written through."""
    try:
        _check_output_paths(layout, outputs, folders, source)
    except (OSError, RuntimeError) as e:  # a link in a circle, a path too long ...
        raise Failure(f"cannot use the output path: {e}", EXIT_BAD_INPUT) from None


def check_profile_outputs(layout, outputs: list[tuple[str, str | None]], folders: bool = False) -> None:
    """`check_outputs` against the profile files a layout reads ([profiles] wheel and rail given
    as files, not standard names): no output may be one of them."""
    profiles = layout.profiles
    if profiles is None:
        return
    from rail_mj.contact.pair import STANDARD_PROFILES

    for kind, name in (("wheel", profiles.wheel), ("rail", profiles.rail)):
        if name not in STANDARD_PROFILES[kind]:
            check_outputs(name, outputs, folders, source=f"the {kind} profile file")


def _check_output_paths(layout: str | None, outputs: list[tuple[str, str | None]], folders: bool, source: str) -> None:
    seen = {Path(layout).resolve(): source} if layout is not None else {}
    on_stdout = None
    for option, path in outputs:
        if path is None:
            continue
        if path == STDOUT:
            if folders:
                raise Failure(f"{option} -: needs a folder, not standard output", EXIT_BAD_INPUT)
            if on_stdout:
                raise Failure(f"{option} -: standard output already takes {on_stdout}", EXIT_BAD_INPUT)
            on_stdout = option
            continue
        target = Path(path)
        if not folders and target.is_dir():
            raise Failure(f"{option} {path}: is a folder, expected a file name", EXIT_BAD_INPUT)
        real = target.resolve()
        if real in seen:
            raise Failure(f"{option} {path}: would overwrite {seen[real]}", EXIT_BAD_INPUT)
        if is_special(path):  # a FIFO or a device: written through, never replaced
            if not os.access(path, os.W_OK):
                raise Failure(f"{option} {path}: cannot write to it", EXIT_BAD_INPUT)
            continue
        seen[real] = option
        existing = real.parent if not folders else real
        while not existing.exists():
            existing = existing.parent
        if not existing.is_dir() or not os.access(existing, os.W_OK):
            raise Failure(f"{option} {path}: cannot write in {existing}", EXIT_BAD_INPUT)


def check_finite(option: str, *values: float) -> None:
    if not all(math.isfinite(v) for v in values):
        shown = " ".join(f"{v:g}" for v in values)
        raise Failure(f"{option} must be finite, got {shown}", EXIT_BAD_INPUT)


def span_of(option: str, text: str, rules: Rules) -> Span:
    """An `A:B:N[:log]` option read and checked by its rules (rail_mj.studies.span)."""
    try:
        return Span.parse(text, rules, option)
    except SpanError as e:
        raise Failure(str(e), EXIT_BAD_INPUT) from None
