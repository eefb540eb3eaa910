"""Parameter studies: one layout, many variants and speeds, a table of results.

A sweep is a list of cases: every combination of the `grid` values (layout keys such as
`primary.yaw_stiffness`), with the `sets` applied to all, and for `method="run"` every
speed as well. Runs are stepped many at a time (rail_mj.simulation.batch.simulate_many: eight
vehicles to a MuJoCo model, a model on each thread), each with exactly the result it
would have alone, and each row is summarised as its run ends; critical speeds are
computed a case a thread (`run_case`). Every row is a function of its case alone, so
any executor gives the same rows: this machine's cores by default, or a Dask cluster.
Finished rows are appended to a journal beside the output as they come;
the same sweep started again keeps them and runs only the rest, and the output is written
whole at the end, sorted by case.

Example:

    >>> table = sweep("models/wheelset/wheelset.toml", speeds=(40.0, 80.0, 3), method="run",
    ...               distance=200.0)
    >>> table["speed_m_per_s"].tolist(), table["status"].tolist()
    ([40.0, 60.0, 80.0], ['ok', 'ok', 'diverged'])
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import functools
import hashlib
import itertools
import json
import logging
import math
import operator
import os
import queue
import threading
import time
import tomllib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import CancelledError, ThreadPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from rail_mj.files import is_special, read_input, staged
from rail_mj.layout import Layout, LayoutError, layout_from_dict
from rail_mj.practice import INITIAL_LATERAL
from rail_mj.studies.span import GRID, SEARCH, SWEEP, Span, SpanError
from rail_mj.track import Track

METHODS = ("run", "eigen", "time", "nonlinear", "curving")
# The keys of a curving sweep's curve (--set, --grid): its radius (m, + left) and cant (m, the outer
# rail over the inner), not the layout's.
CURVE_KEYS = ("track.radius", "track.cant")
# A run sweep's keys of the track's generated irregularities (rail_mj.track.irregularities): each
# case's realisation (seed), track quality (spectrum) and multiplier (scale).
IRREGULARITY_KEYS = ("irregularities.seed", "irregularities.spectrum", "irregularities.scale")
DEFAULT_DISTANCE = 1000.0  # m a run
DEFAULT_INITIAL_LATERAL = INITIAL_LATERAL  # m, as `rail-mj run`
STATUSES = ("ok", "diverged", "refused", "failed")

# The result columns of each method, after the case's parameters and speed.
RESULTS = {
    "run": (
        "max_abs_lateral_m",
        "final_abs_lateral_m",
        "growth_rate_per_s",
        "frequency_hz",
        "wavelength_m",
        "decayed",
        "flange_contact",
        "hunting",
        "hunting_rms_n",
        "hunting_limit_n",
    ),
    "critical": ("critical_speed_m_per_s", "frequency_hz", "mode", "linear_critical_speed_m_per_s", "outcome", "note"),
    # The steady state on the curve (rail_mj.analysis.curving.steady_curving): the leading wheelset's
    # lateral displacement and angle of attack, and over every wheel the largest Y/Q and T-gamma.
    "curving": (
        "cant_deficiency_mm",
        "leading_lateral_m",
        "leading_angle_of_attack_rad",
        "max_y_over_q",
        "max_wear_number_n",
    ),
}


# A run on irregular track adds its ride and on-track quantities (rail_mj.analysis.ride, en14363.on_track):
# the largest over the floor points of N_MV and Wz, over the wheels of Y/Q's 99.85 % percentile (2 m),
# over the wheelsets of |Sigma Y|'s (2 m), and the deepest unloading dQ/Q0's 0.15 % percentile.
RIDE_RESULTS = ("n_mv", "wz_lateral", "wz_vertical", "y_over_q_p99_85", "sum_y_p99_85_n", "unloading_p0_15")


def _results(method: str, irregular: bool = False) -> tuple[str, ...]:
    """The result columns of a method's rows (`irregular`: runs on irregular track)."""
    out = RESULTS[method if method in ("run", "curving") else "critical"]
    return out + RIDE_RESULTS if irregular and method == "run" else out


def _on_rails(case: Case) -> bool:
    return case.track is not None and case.track.irregularities is not None


TAIL = ("status", "message", "wall_time_s", "case_key")


class SweepError(ValueError):
    """A sweep that cannot be planned (bad key, range or output); one line."""


# --- planning --------------------------------------------------------------------------


def values_of(text: str, what: str) -> list[float]:
    """`A:B:N` (N values from A to B, evenly) or `A:B:N:log` (geometrically): a GRID span."""
    try:
        return Span.parse(text, GRID, what).values()
    except SpanError as e:
        raise SweepError(str(e)) from None


def parse_assignment(text: str, what: str) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise SweepError(f"{what} must be key=value with a layout key such as primary.yaw_stiffness, got {text!r}")
    return key.strip(), value.strip()


def toml_value(text: str) -> Any:
    """A value as TOML reads it (a number, a quoted string, true/false, a list), or the bare
    text as a string (`law=polach`)."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):
        return text


def with_value(data: dict, key: str, value: Any) -> dict:
    """A copy of a parsed layout with `key` (dotted: `primary.yaw_stiffness`) set; tables
    on the way are made (`flange.stiffness` on a layout without [flange]). In an array of
    tables a number picks one (`coupling.1.yaw_damping`, from 1) and `*` every one
    (`coupling.*.yaw_damping`, every inter-car element of a train)."""
    data = copy.deepcopy(data)
    _set(data, key, key.split("."), value)
    return data


def _set(node: Any, key: str, parts: list[str], value: Any) -> None:
    *tables, name = parts
    for k, table in enumerate(tables):
        if isinstance(node, list):
            if table == "*":
                for item in node:
                    _set(item, key, tables[k + 1 :] + [name], value)
                return
            if not (table.isdigit() and 1 <= int(table) <= len(node)):
                raise SweepError(f"{key}: {table!r} must number one of the {len(node)} entries (from 1), or be *")
            node = node[int(table) - 1]
        else:
            node = node.setdefault(table, {})
        if not isinstance(node, (dict, list)):
            raise SweepError(f"{key}: {table} is not a table in the layout")
    if isinstance(node, list):
        raise SweepError(f"{key}: {tables[-1] if tables else key} holds several tables: pick one (.1) or all (.*)")
    node[name] = value


@dataclasses.dataclass(frozen=True)
class Case:
    """One computation of a sweep: a variant of the layout, at one speed (runs) or over the
    speed range (critical speeds)."""

    index: int
    method: str
    layout: dict  # the parsed layout with the sets and this case's grid values
    source: str  # the layout file, for messages
    params: dict  # grid key -> value
    speed: float | None  # m/s (run)
    speeds: tuple[float, float, int]  # the range: A, B, N
    distance: float  # m (run)
    recording: str | None = None  # .rrd path (run), or None
    track: Track | None = None  # a curved track the runs follow (rail_mj.track), or None: straight
    track_text: str | None = None  # its file's text, what the result depends on
    curve: dict[str, float] | None = None  # a curving case's track.radius and track.cant
    irregular: dict[str, Any] | None = None  # a run case's irregularities.* values, its track's

    @property
    def run_speed(self) -> float:
        """The speed of a run (method "run"), which every run case has."""
        assert self.speed is not None, f"case {self.index}: a {self.method} case has no speed"
        return self.speed

    @functools.cached_property
    def key(self) -> str:
        """What determines the result: changes if the layout, method or case does (worked out
        once: it reads the profile files)."""
        what: list[object]
        if self.method == "run":  # a run: its layout, speed and distance (and track, if any)
            what = [self.method, self.layout, self.params, self.speed, self.distance]
            if self.track_text is not None:
                what.append(self.track_text)
            if self.irregular:
                what.append(self.irregular)
        elif self.method == "curving":  # a steady state: its layout, curve and speed
            what = [self.method, self.layout, self.params, self.curve, self.speed]
        else:  # a critical speed: its layout and the range searched
            what = [self.method, self.layout, self.params, self.speeds]
        files = self._files_read()
        if files:  # a layout without profile files keeps the key it had
            what.append(files)
        text = json.dumps(what, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def _files_read(self) -> dict[str, str]:
        """The digest of each profile file the case's layout reads: the layout names the file,
        and a resumed sweep must not mix results from its old and new contents."""
        from rail_mj.contact.pair import STANDARD_PROFILES

        profiles = self.layout.get("profiles")
        out: dict[str, str] = {}
        if not isinstance(profiles, dict):
            return out
        base = Path(self.source).parent
        for kind in ("wheel", "rail"):
            name = profiles.get(kind)
            if not isinstance(name, str) or name.lower() in STANDARD_PROFILES[kind]:
                continue
            try:
                out[kind] = hashlib.sha256(read_input(base / name)).hexdigest()
            except OSError as e:  # the case fails on it too, and says so
                out[kind] = f"unreadable: {e}"
        return out


LayoutLike = str | Path | Layout | Mapping[str, Any]
SpeedsLike = tuple[float, float, int] | str
Assignments = Iterable[str] | Mapping[str, Any]


def _layout_data(layout: LayoutLike) -> tuple[dict, Path]:
    """The parsed layout a sweep varies, and the file relative paths in it are read from:
    a layout file's path; a `Layout` read from one (rail_mj.load_layout: it is read again, and
    must be what that file gives); or the parsed TOML itself, a dict (paths from the current
    folder)."""
    if isinstance(layout, Mapping):
        return copy.deepcopy(dict(layout)), Path("<layout>")
    path = Path(layout.source) if isinstance(layout, Layout) else Path(layout)
    if isinstance(layout, Layout) and not path.is_file():
        raise SweepError(
            f"a Layout not read from a file ({layout.source}) cannot be swept: give the dict it was made from"
            if layout.source == Layout.source
            else f"the file this Layout was read from, {layout.source}, is not there from {Path.cwd()}: "
            f"sweep the file by its path"
        )
    try:
        data = tomllib.loads(read_input(path).decode("utf-8"))
    except (OSError, UnicodeDecodeError) as e:
        raise SweepError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    except tomllib.TOMLDecodeError as e:
        raise SweepError(f"{path}: not valid TOML: {e}") from None
    except RecursionError:
        raise SweepError(f"{path}: not a layout: its arrays or tables are nested too deeply to read") from None
    if isinstance(layout, Layout):
        try:
            same = layout_from_dict(data, source=str(path)) == layout
        except LayoutError:
            same = False
        if not same:
            raise SweepError(
                f"this Layout is not what {path} gives (changed since it was read, or the file was): "
                f"sweep the file, or the dict of the layout wanted"
            )
    return data, path


def _assignments(given: Assignments, what: str, parse: Callable[[str], Any]) -> list[tuple[str, Any]]:
    """(key, value) pairs from `key=value` texts (each value read by `parse`, as the command line
    does) or a mapping of keys to Python values (taken as they are)."""
    if isinstance(given, Mapping):
        return [(str(k), v) for k, v in given.items()]
    if isinstance(given, str):
        raise SweepError(f"{what}: give a list of key=value texts or a dict, got the text {given!r}")
    return [(key, parse(value)) for key, value in (parse_assignment(text, what) for text in given)]


def _grid_values(key: str, value: Any) -> list[float]:
    """A grid's values: an `A:B:N[:log]` text, or a sequence of numbers."""
    what = f"--grid {key}"
    if isinstance(value, str):
        return values_of(value, what)
    try:
        values = [float(v) for v in value]
    except (TypeError, ValueError):
        raise SweepError(f"{what}: give A:B:N or a list of numbers, got {value!r}") from None
    if not values or not all(math.isfinite(v) for v in values):
        raise SweepError(f"{what}: give at least one finite number, got {value!r}")
    if len(set(values)) != len(values):  # two cases of one key: a resumed sweep would keep one
        raise SweepError(f"{what}: a value is given twice in {value!r}")
    return values


def _speeds(speeds: SpeedsLike) -> tuple[float, float, int]:
    if isinstance(speeds, str):
        try:
            span = Span.parse(speeds, SWEEP, "speeds")
        except SpanError as e:
            raise SweepError(str(e)) from None
        return span.a, span.b, span.n
    try:
        a, b, n = speeds
        return float(a), float(b), operator.index(n)
    except (TypeError, ValueError):
        raise SweepError(f"speeds: give (A, B, N) with N a whole number, or 'A:B:N', got {speeds!r}") from None


def plan(
    layout_path: LayoutLike,
    speeds: SpeedsLike,
    sets: Assignments = (),
    grids: Assignments = (),
    method: str = "run",
    distance: float = DEFAULT_DISTANCE,
    recordings: str | Path | None = None,
    track: str | Path | None = None,
    held_at_once: int | None = 1,
) -> list[Case]:
    """Every case of a sweep, in order: grid points (first key slowest), then speeds. `track`: a
    track file (rail_mj.track) every run follows from its start. A plan of more than MAX_CASES
    cases is refused, and so is one whose `held_at_once` longest runs (those stepped together in
    this process; None: on a cluster, none here) have records that need more than this machine's
    memory."""
    if method not in METHODS:
        raise SweepError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    the_track, track_text = _track(track, method)
    a, b, n = _speeds(speeds)
    try:
        span = Span.of(a, b, n, SWEEP, "speeds")
        if method not in ("run", "curving"):
            span.check(SEARCH, "speeds")
    except SpanError as e:
        raise SweepError(str(e)) from None
    if not (math.isfinite(distance) and distance > 0):
        raise SweepError(f"distance must be a positive number, got {distance}")
    data, path = _layout_data(layout_path)
    curve: dict[str, float] = {}  # a curving sweep's curve keys given with --set
    irregular: dict[str, Any] = {}  # a run sweep's irregularities keys given with --set
    for key, value in _assignments(sets, "--set", toml_value):
        if key in CURVE_KEYS:
            curve[key] = _curve_value(key, value, method)
            continue
        if key in IRREGULARITY_KEYS:
            irregular[key] = _irregularity_value(key, value, the_track, method)
            continue
        data = with_value(data, key, value)
    axes: list[tuple[str, list[Any]]] = []
    for key, value in _assignments(grids, "--grid", str):
        if key in (k for k, _ in axes):
            raise SweepError(f"--grid {key} is given twice")
        if key in IRREGULARITY_KEYS:
            axes.append((key, _irregularity_grid(key, value, the_track, method)))
            continue
        axes.append((key, _grid_values(key, value)))
    try:  # the base layout (sets applied) must hold before any case runs
        base = layout_from_dict(data, source=str(path))
    except LayoutError as e:
        raise SweepError(str(e)) from None
    if method == "nonlinear" and (base.flange is None or base.creep.law == "linear"):
        raise SweepError(
            f"{path}: the nonlinear critical speed needs [flange] and a saturating creep "
            f"law (set them with --set, or in the layout)"
        )
    for key, values in axes:  # a key the layout does not know fails the sweep, not each case
        if key in IRREGULARITY_KEYS:
            continue
        if key in CURVE_KEYS:
            for v in values:
                _curve_value(key, v, method)
            continue
        try:
            layout_from_dict(with_value(data, key, values[0]), source=str(path))
        except LayoutError as e:
            if "unknown key" in str(e) or "must be a table" in str(e):
                raise SweepError(f"--grid {key}: {e}") from None
    if method == "curving" and "track.radius" not in curve and "track.radius" not in (k for k, _ in axes):
        raise SweepError("--method curving needs the curve's radius: --set track.radius=R or --grid track.radius=A:B:N")
    run_speeds = _run_speeds(span) if method in ("run", "curving") else [None]
    n_points = math.prod(len(v) for _, v in axes)
    _check_size(n_points, run_speeds)
    if method == "run" and held_at_once:
        _check_memory(n_points, run_speeds, distance, base.n_wheelsets, held_at_once)
    points = [dict(zip([k for k, _ in axes], combo)) for combo in itertools.product(*[v for _, v in axes])]
    cases: list[Case] = []
    for point in points:
        variant = data
        for key, grid_value in point.items():
            if key not in CURVE_KEYS and key not in IRREGULARITY_KEYS:
                variant = with_value(variant, key, grid_value)
        on_curve = {**curve, **{k: v for k, v in point.items() if k in CURVE_KEYS}}
        on_rails = {**irregular, **{k: v for k, v in point.items() if k in IRREGULARITY_KEYS}}
        case_track = _irregular_track(the_track, on_rails) if on_rails else the_track
        for speed in run_speeds:
            index = len(cases)
            recording = (
                str(Path(recordings) / f"case-{index:05d}.rrd") if recordings is not None and method == "run" else None
            )
            cases.append(
                Case(
                    index,
                    method,
                    variant,
                    str(path),
                    point,
                    speed,
                    (a, b, n),
                    distance,
                    recording,
                    case_track,
                    track_text,
                    on_curve or None,
                    on_rails or None,
                )
            )
    return cases


def _track(path: str | Path | None, method: str) -> tuple[Track | None, str | None]:
    """The sweep's track, checked, and its file's text (None, None: straight track)."""
    if path is None:
        return None, None
    if method != "run":
        raise SweepError(f"--track is for runs (--method run); the {method} critical speed is on straight track")
    from rail_mj.track import TrackError, load_track

    try:
        track = load_track(path)
    except TrackError as e:
        raise SweepError(str(e)) from None
    return track, read_input(path).decode("utf-8")  # read and checked by load_track just before


# A sweep of a million cases is a day of one core's work at 0.1 s a case, and its plan alone
# about 1 GB (a layout's variant per grid point): more is a mistake in a span, not a study.
MAX_CASES = 1_000_000


def _check_size(n_points: int, run_speeds: Sequence[float | None]) -> None:
    n_cases = n_points * len(run_speeds)
    if n_cases > MAX_CASES:
        raise SweepError(
            f"{n_cases:.3g} cases ({n_points:.3g} grid points x {len(run_speeds)} speed"
            f"{'s' * (len(run_speeds) != 1)}) is more than the {MAX_CASES:,} a sweep may have: "
            f"use fewer values in the grid or the speeds"
        )


def memory_bytes() -> int:
    """This machine's physical memory, bytes."""
    return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def records_floor(n_wheelsets: int, distance: float, speed: float) -> float:
    """A lower bound on the bytes of a run's record: a sample a step, at least
    distance/speed/MAX_TIMESTEP of them, each of t, every body's position and quaternion and
    each wheelset's two rates and two loads, with at least a body per wheelset and the world
    (rail_mj.simulation.stepping._records)."""
    from rail_mj.simulation.timestep import MAX_TIMESTEP

    floats_per_sample = 1 + 7 * (n_wheelsets + 1) + 4 * n_wheelsets
    return 8.0 * floats_per_sample * distance / speed / MAX_TIMESTEP


def _check_memory(
    n_points: int, run_speeds: Sequence[float | None], distance: float, n_wheelsets: int, held: int
) -> None:
    """Refuse runs whose records cannot be held: a sweep steps `held` runs at once, the longest
    first, each keeping its whole record until it ends (then only its row is kept), so it needs
    at least the records_floor of its `held` longest runs."""
    from rail_mj.simulation.timestep import MAX_TIMESTEP

    floors = sorted((records_floor(n_wheelsets, distance, float(v)) for v in run_speeds if v is not None), reverse=True)
    longest = [f for f in floors for _ in range(n_points)][:held]
    need, have = sum(longest), memory_bytes()
    if need > have:
        raise SweepError(
            f"the runs' records need at least {need / 2**30:.3g} GB ({len(longest)} runs of {distance:g} m stepped "
            f"at once, a sample every {MAX_TIMESTEP * 1e3:g} ms or more often), more than this machine's "
            f"{have / 2**30:.3g} GB: shorten the distance, use fewer workers, or a Dask scheduler"
        )


def _run_speeds(span: Span) -> list[float]:
    """Every speed a run is made at: the span's N values, checked as a grid (A != B for N > 1)."""
    try:
        return span.check(GRID, "--speeds").values()
    except SpanError as e:
        raise SweepError(str(e)) from None


# --- one case ----------------------------------------------------------------------------


def run_case(case: Case) -> dict:
    """The row of one case. Never raises: a case that cannot be computed is a row whose
    status says why (refused: bad input; diverged: the run left the rails or blew up;
    failed: anything else, a bug to report)."""

    def compute() -> dict:
        layout = layout_from_dict(case.layout, source=case.source)
        if case.method == "run":
            return _run(case, layout)
        return _curving(case, layout) if case.method == "curving" else _critical(case, layout)

    return _row(case, compute)


def tasks(cases: list[Case], packs_per_task: int = 1) -> list[list[Case]]:
    """The units of work of a Dask cluster: runs in the order of their duration,
    `packs_per_task` models of PACK vehicles at a time (rail_mj.simulation.batch.simulate_many steps
    them together); every other case alone. Packing changes no result (each run is the one
    `simulate` gives, bit for bit), so executors may cut the work as suits them."""
    from rail_mj.simulation.batch import PACK

    size = PACK * packs_per_task
    runs = sorted((c for c in cases if c.method == "run"), key=lambda c: (c.distance / c.run_speed, c.index))
    return [runs[k : k + size] for k in range(0, len(runs), size)] + [[c] for c in cases if c.method != "run"]


def run_task(cases: list[Case], threads: int = 1) -> list[dict]:
    """The rows of a task (see `tasks`), runs stepped on `threads` threads. Never raises."""
    if len(cases) == 1:
        return [run_case(cases[0])]
    return list(run_rows(cases, threads))


def run_rows(cases: list[Case], threads: int = 1) -> Iterator[dict]:
    """The rows of run cases as their runs end, in any order: the runs stepped together
    (rail_mj.simulation.batch.simulate_many on `threads` threads), each row summarised by the thread
    that stepped its run, while the others step on. Never raises; closing the iterator
    stops the runs still going."""
    from rail_mj.simulation.batch import simulate_many
    from rail_mj.simulation.run import Request

    owners, requests = [], []
    for case in cases:
        try:
            layout = layout_from_dict(case.layout, source=case.source)
            requests.append(
                Request(
                    layout,
                    case.run_speed,
                    case.distance,
                    DEFAULT_INITIAL_LATERAL,
                    track=case.track,
                    stream=_stream(case, layout),
                )
            )
            owners.append((case, layout))
        except (LayoutError, ValueError):
            yield run_case(case)  # says why its layout is refused
    rows: queue.SimpleQueue = queue.SimpleQueue()
    stop = threading.Event()

    def finished(k: int, outcome, seconds: float) -> None:
        case, layout = owners[k]
        rows.put(_row(case, lambda: _summarise_run(case, layout, outcome), seconds))

    def step() -> None:
        try:
            simulate_many(requests, threads, finished=finished, stop=stop, keep=False)
        except Exception:
            rows.put(False)
        rows.put(None)

    stepping = threading.Thread(target=step, name="rail-mj-sweep", daemon=True)
    stepping.start()
    given = set()
    try:
        while (row := rows.get()) is not None:
            if row is False:
                for case, _ in owners:
                    if case.index not in given:
                        given.add(case.index)
                        yield run_case(case)
            elif row["case"] not in given:
                given.add(row["case"])
                yield row
    finally:  # closed early (Ctrl-C): the threads stop after their chunk
        stop.set()
        stepping.join()


def _row(case: Case, compute: Callable[[], dict], extra_time: float = 0.0) -> dict:
    """A case's row from `compute`, which may raise: status and message say what happened."""
    from rail_mj.simulation.run import RunRefused, SimulationError

    started = time.perf_counter()
    row = {"case": case.index, **case.params, "speed_m_per_s": case.speed}
    row.update(dict.fromkeys(_results(case.method, _on_rails(case))))
    try:
        row.update(compute())
        status, message = "ok", ""
    except RunRefused as e:
        status, message = "refused", str(e)
    except SimulationError as e:
        status, message = "diverged", str(e)
    except (LayoutError, ValueError) as e:
        status, message = "refused", str(e)
    except Exception as e:
        status, message = "failed", f"{type(e).__name__}: {' '.join(str(e).split())}"
    row.update(
        status=status, message=message, wall_time_s=time.perf_counter() - started + extra_time, case_key=case.key
    )
    return row


def _run(case: Case, layout) -> dict:
    from rail_mj.simulation.runner import simulate

    run = simulate(layout, case.run_speed, case.distance, DEFAULT_INITIAL_LATERAL, track=case.track)
    return _summarise_run(case, layout, run)


def _stream(case: Case, layout):
    """How a run case's samples are summarised as it is stepped (rail_mj.analysis.streaming), when
    its row is all that is kept of it: on straight track, without a recording; else None."""
    if case.track is not None or case.recording is not None:
        return None
    from rail_mj.analysis.streaming import Summarised

    return Summarised.stream(layout, case.run_speed)


def _summarise_run(case: Case, layout, run) -> dict:
    """The row's results of a run, or of what was kept of it as it was stepped (a dict:
    rail_mj.analysis.streaming); or raise what the run raised."""
    if isinstance(run, Exception):
        raise run
    if isinstance(run, dict):
        result, largest = run, [w["max_abs_lateral_m"] for w in run["wheelsets"]]
    else:
        from rail_mj.analysis import summary

        result, largest = summary(run), [float(np.max(np.abs(run.y)))]
    wheelsets = result["wheelsets"]
    lasting = max(wheelsets + result["frames"], key=_lasting)
    hunting = result["hunting"]
    if case.recording is not None:
        from rail_mj.output.recording import write_recording

        write_recording(run, case.recording)
    return {
        "max_abs_lateral_m": max(w["max_abs_lateral_m"] for w in wheelsets),
        "final_abs_lateral_m": lasting["final_abs_lateral_m"],
        "growth_rate_per_s": lasting["growth_rate_per_s"],
        "frequency_hz": lasting["frequency_hz"],
        "wavelength_m": lasting["wavelength_m"],
        "decayed": result["decayed"],
        "flange_contact": max(largest) > layout.wheelset.flangeway_clearance,
        "hunting": None if hunting is None else hunting["hunting"],
        "hunting_rms_n": None if hunting is None else max(hunting["max_rms_n"]),
        "hunting_limit_n": None if hunting is None else hunting["limit_n"],
        **_ride_results(result),
    }


def _ride_results(result: dict) -> dict:
    """A run's RIDE_RESULTS from its summary (none off irregular track)."""
    if "sections" not in result:
        return {}
    points = (result.get("ride") or {}).get("points", [])

    def largest(values) -> float | None:
        found = [v for v in values if v is not None]
        return max(found) if found else None

    wheelsets = [w for s in result["sections"] for w in s["wheelsets"]]
    wheels = [w[side] for w in wheelsets for side in ("left", "right")]
    unloading = [u["p0_15"] for u in (w["unloading"] for w in wheels) if u is not None and u["p0_15"] is not None]
    return {
        "n_mv": largest(p["n_mv"] for p in points),
        "wz_lateral": largest(p["wz_lateral"] for p in points),
        "wz_vertical": largest(p["wz_vertical"] for p in points),
        "y_over_q_p99_85": largest(w["y_over_q"]["p99_85"] for w in wheels),
        "sum_y_p99_85_n": largest(
            max(abs(w["sum_y_n"]["p0_15"]), abs(w["sum_y_n"]["p99_85"]))
            for w in wheelsets
            if w["sum_y_n"]["p0_15"] is not None
        ),
        "unloading_p0_15": min(unloading) if unloading else None,
    }


# Which body's motion names a run's growth rate and frequency: the one that outlives the rest,
# among those that do not decay (growing or sustained) before those that do, wheelsets before
# frames (a car body can grow alone, under wheelsets that settled: rail_mj.analysis.motion).
_LASTING = {"growing": 2, "sustained": 2, "not oscillating": 1, "decaying": 1}


def _lasting(body: dict) -> tuple:
    return (_LASTING.get(body["motion"], 0), "wheelset" in body, body["final_abs_lateral_m"])


def _irregularity_value(key: str, value: Any, track: Track | None, method: str) -> Any:
    """An irregularities.* value, checked: a whole seed >= 0, a known spectrum's name, a scale >= 0; a
    run sweep on a track with generated irregularities."""
    from rail_mj.track.irregularities import SPECTRA

    if method != "run":
        raise SweepError(f"{key} is for runs (--method run) on a track with [irregularities]")
    if track is None or track.irregularities is None:
        raise SweepError(f"{key} needs --track FILE with [irregularities] (a spectrum) to vary")
    if track.irregularities.spectrum is None:
        raise SweepError(
            f"{key}: {track.source}'s irregularities are measured ({track.irregularities.file}): nothing to vary"
        )
    name = key.partition(".")[2]
    if name == "spectrum":
        if not isinstance(value, str) or value not in SPECTRA:
            raise SweepError(f"{key}: must be one of {', '.join(SPECTRA)}, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
        raise SweepError(f"{key}: must be a number >= 0, got {value!r}")
    if name == "seed":
        if value != int(value):
            raise SweepError(f"{key}: must be a whole number, got {value!r}")
        return int(value)
    return float(value)


def _irregularity_grid(key: str, value: Any, track: Track | None, method: str) -> list[Any]:
    """A grid of irregularities.* values: seeds and scales as A:B:N (or a list), spectra as names
    separated by commas (or a list)."""
    if key == "irregularities.spectrum":
        names = [v.strip() for v in value.split(",")] if isinstance(value, str) else list(value)
        values = [_irregularity_value(key, v, track, method) for v in names]
    else:
        values = [_irregularity_value(key, v, track, method) for v in _grid_values(key, value)]
    if len(set(values)) != len(values):
        raise SweepError(f"--grid {key}: a value is given twice in {value!r}")
    return values


def _irregular_track(track: Track | None, values: dict[str, Any]) -> Track | None:
    """The sweep's track with a case's irregularities.* values."""
    assert track is not None and track.irregularities is not None  # checked by _irregularity_value
    change = {key.partition(".")[2]: v for key, v in values.items()}
    return dataclasses.replace(track, irregularities=dataclasses.replace(track.irregularities, **change))


def _curve_value(key: str, value: Any, method: str) -> float:
    """A curving sweep's track.radius or track.cant, checked against the table of practice."""
    from rail_mj.practice import RANGES

    if method != "curving":
        raise SweepError(f"{key} is a key of --method curving, not of {method}")
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SweepError(f"{key} must be a number, got {value!r}")
    error = RANGES[key].check(abs(value) if key == "track.radius" else value)
    if error:
        raise SweepError(f"{key} {error}")
    return float(value)


def _curving(case: Case, layout) -> dict:
    from rail_mj.analysis.curving import steady_curving

    curve = case.curve or {}
    radius, cant = curve["track.radius"], curve.get("track.cant", 0.0)
    # The cant is the outer rail's, on the side the curve turns away from (as `rail-mj curving`).
    result = steady_curving(layout, radius, case.run_speed, cant if radius > 0 else -cant)
    wheelsets = result["wheelsets"]
    quotients = [q for w in wheelsets for q in w["y_over_q"] if q is not None]
    return {
        "cant_deficiency_mm": result["cant_deficiency_mm"],
        "leading_lateral_m": wheelsets[0]["lateral_m"],
        "leading_angle_of_attack_rad": wheelsets[0]["angle_of_attack_rad"],
        "max_y_over_q": max(quotients) if quotients else None,
        "max_wear_number_n": max(t for w in wheelsets for t in w["wear_number_n"]),
    }


def _critical(case: Case, layout) -> dict:
    vmin, vmax, points = case.speeds
    if case.method == "eigen":
        from rail_mj.analysis.stability import Stability

        result = Stability(layout).critical_speed(vmin, vmax, points)
    elif case.method == "time":
        from rail_mj.analysis.stability import time_critical_speed

        result = time_critical_speed(layout, vmin, vmax, points)
    else:
        from rail_mj.analysis.bifurcation import nonlinear_critical_speed

        result, _ = nonlinear_critical_speed(layout, vmin, vmax)
    return {
        "critical_speed_m_per_s": result.critical_speed,
        "frequency_hz": result.frequency,
        "mode": result.mode,
        "linear_critical_speed_m_per_s": result.linear_critical_speed,
        "outcome": result.outcome,
        "note": result.note,
    }


# --- executing and keeping the rows ------------------------------------------------------


def columns_of(cases: list[Case]) -> list[str]:
    method = cases[0].method if cases else "run"
    params = list(cases[0].params) if cases else []
    irregular = bool(cases) and _on_rails(cases[0])
    return ["case", *params, "speed_m_per_s", *_results(method, irregular), *TAIL]


def _kind(value) -> str | None:
    """A JSON value's kind as a table column holds it (None: a missing value, any column's)."""
    if value is None:
        return None
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int | float):
        return "number"
    if isinstance(value, str):
        return "text"
    if isinstance(value, list) and all(_kind(v) in (None, "number") for v in value):
        return "numbers"
    return "other"


def _row_problem(row, kinds: dict[str, str]) -> str | None:
    """Why a journal line is not a row (None: it is one, and `kinds` learns its columns' kinds)."""
    if not isinstance(row, dict):
        return f"is {type(row).__name__}, not a row"
    if not isinstance(row.get("case_key"), str) or _kind(row.get("case")) != "number":
        return "has no case and case key"
    found = {column: _kind(value) for column, value in row.items()}
    for column, kind in found.items():
        if kind == "other" or (kind is not None and kinds.get(column, kind) != kind):
            return f"has {column} of another kind than the other rows'"
    kinds.update({c: k for c, k in found.items() if k is not None})
    return None


class Journal:
    """Rows as they finish, one JSON line each, flushed and synced: a sweep killed at any
    moment loses only the cases in flight. Beside the output: `<output>.journal`."""

    def __init__(self, output: Path):
        self.path = output.with_name(output.name + ".journal")

    def read(self, set_aside: list[str] | None = None) -> list[dict]:
        """The rows; a line that is not one (not JSON, not UTF-8, not an object with a case's key,
        a value of another kind than the earlier rows' in its column) is left out, its case runs
        again, and `set_aside` is told which line and why."""
        if not self.path.exists():
            return []
        rows: list[dict] = []
        kinds: dict[str, str] = {}
        lines = self.path.read_bytes().split(b"\n")
        for k, raw in enumerate(lines):
            if not raw.strip():
                continue
            try:
                row = json.loads(raw.decode("utf-8"))
                problem = _row_problem(row, kinds)
            except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
                if k == len(lines) - 1:  # cut short by a kill mid-write: that case runs again
                    continue
                problem = "is not a JSON line"
            if problem is not None:
                if set_aside is not None:
                    set_aside.append(f"{self.path}: line {k + 1} {problem}: set aside, its case runs again")
                continue
            rows.append(row)
        return rows

    def __enter__(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.file = open(self.path, "a+b")
        self.file.seek(0)
        text = self.file.read()
        if text and not text.endswith(b"\n"):  # a line cut short by a kill: drop it, its case runs again
            self.file.truncate(text.rfind(b"\n") + 1)
        self.file.seek(0, os.SEEK_END)
        return self

    def append(self, row: dict) -> None:
        self.file.write((json.dumps(row) + "\n").encode())
        self.file.flush()
        os.fsync(self.file.fileno())

    def __exit__(self, *exc):
        self.file.close()

    def remove(self) -> None:
        self.path.unlink(missing_ok=True)


def read_table(path: Path) -> list[dict]:
    """The rows of a written sweep output (CSV or Parquet)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    try:
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq  # a CSV's sweep goes without (a fifth of pyarrow's import)

            return pq.read_table(path).to_pylist()
        options = pacsv.ConvertOptions(strings_can_be_null=True, column_types={"case_key": pa.string()})
        return pacsv.read_csv(path, convert_options=options).to_pylist()
    except (pa.ArrowException, OSError) as e:
        raise SweepError(
            f"{path}: not a sweep table that can be read ({' '.join(str(e).split())[:200]}); "
            f"write to a new file or delete it"
        ) from None


def to_table(rows: list[dict], columns: list[str]):
    """A pyarrow table of the rows, sorted by case, in `columns` order: the table pa.table makes
    of them, each column's type inferred alike."""
    import pyarrow as pa

    rows = sorted(rows, key=lambda r: r["case"])
    return pa.Table.from_arrays([_column([r.get(c) for r in rows]) for c in columns], names=columns)


def _column(values: list):
    """The pyarrow array pa.array makes of a row's column of Python values (None, bool, int,
    float, str), built from its buffers: pa.array asks pyarrow's pandas shim about every input,
    which imports pandas, a quarter of a second of a sweep's CPU that writes no DataFrame. Any
    other mix of values is left to pa.array."""
    import numpy as np
    import pyarrow as pa

    n = len(values)
    valid = np.array([v is not None for v in values], dtype=bool)
    given = [v for v in values if v is not None]
    kinds = {type(v) for v in given}
    nulls = None if valid.all() else pa.py_buffer(np.packbits(valid, bitorder="little"))
    if not given:
        return pa.nulls(n)
    if kinds == {bool}:
        bits = np.packbits(np.array([v is True for v in values], dtype=bool), bitorder="little")
        return pa.Array.from_buffers(pa.bool_(), n, [nulls, pa.py_buffer(bits)])
    if kinds == {int} and all(-(2**63) <= v < 2**63 for v in given):
        numbers = np.array([0 if v is None else v for v in values], dtype=np.int64)
        return pa.Array.from_buffers(pa.int64(), n, [nulls, pa.py_buffer(numbers)])
    # An int among floats: pa.array takes it as float64 where it is exact there (|v| <= 2**53) and
    # refuses the column otherwise, as it is then left to do.
    if kinds == {float} or (kinds == {int, float} and all(-(2**53) <= v <= 2**53 for v in given if type(v) is int)):
        numbers = np.array([0.0 if v is None else v for v in values], dtype=np.float64)
        return pa.Array.from_buffers(pa.float64(), n, [nulls, pa.py_buffer(numbers)])
    if kinds == {str}:
        encoded = [b"" if v is None else v.encode() for v in values]
        offsets = np.zeros(n + 1, dtype=np.int64)
        np.cumsum([len(e) for e in encoded], out=offsets[1:])
        if offsets[-1] < 2**31:
            return pa.Array.from_buffers(
                pa.string(), n, [nulls, pa.py_buffer(offsets.astype(np.int32)), pa.py_buffer(b"".join(encoded))]
            )
    return pa.array(values)


def write_table(table, path: Path) -> None:
    import pyarrow.csv as pacsv

    with staged([path]) as (tmp,):
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq

            pq.write_table(table, tmp)
        else:
            pacsv.write_csv(table, tmp)


def sweep(layout: LayoutLike, speeds: SpeedsLike, **options: Any):
    """`sweep_table` as a pandas DataFrame, one row per case, for a notebook: `layout` a file,
    a `Layout` read from one or the parsed dict; `speeds` (A, B, N) or "A:B:N"; `sets` and
    `grids` lists of `key=value` texts as on the command line or dicts of Python values
    (`grids={"primary.yaw_stiffness": [1e6, 2e6]}` or `"1e6:1e7:5:log"`). Columns as the
    sweep table's (`speed_m_per_s`, `status`, ...); None becomes NaN in number columns."""
    return sweep_table(layout, speeds, **options).to_pandas()


def sweep_table(
    layout_path: LayoutLike,
    speeds: SpeedsLike,
    *,
    sets: Assignments = (),
    grids: Assignments = (),
    method: str = "run",
    distance: float = DEFAULT_DISTANCE,
    workers: int | None = None,
    scheduler: str | None = None,
    out: str | Path | None = None,
    recordings: str | Path | None = None,
    progress: Callable[[int, int, dict], None] | None = None,
    track: str | Path | None = None,
    warn: Callable[[str], None] | None = None,
):
    """Run a sweep (see `plan`) and return its table (pyarrow), one row per case.

    `workers` threads (default: every core), or the Dask scheduler at `scheduler`. With
    `out` (.csv or .parquet) rows already there or in its journal are kept and not run
    again; the table is written there at the end. `progress(done, total, row)` is told
    each finished row. `track`: a track file every run follows (rail_mj.track; runs only).
    `warn` is told each journal line set aside (not a row: its case runs again).
    """
    from rail_mj.simulation.batch import PACK

    held = None if scheduler is not None else PACK * (workers or os.cpu_count() or 1)
    cases = plan(layout_path, speeds, sets, grids, method, distance, recordings, track, held_at_once=held)
    columns = columns_of(cases)
    output = Path(out) if out is not None else None
    if output is not None and output.suffix not in (".csv", ".parquet"):
        raise SweepError(f"-o {output}: the output must end in .csv or .parquet")
    if output is not None and (is_special(output) or output.is_dir()):
        raise SweepError(f"-o {output}: a sweep keeps its table in a regular file (it resumes from it)")
    kept: dict[str, dict] = {}
    set_aside: list[str] = []  # journal lines that are no rows, for `warn`
    journal: Journal | None = None  # beside the output, if there is one
    if output is not None:
        journal = Journal(output)
        wanted = {c.key: c for c in cases}
        for where, rows in (
            (output, read_table(output) if output.exists() else []),
            (journal.path, journal.read(set_aside)),
        ):
            for row in rows:
                if row.get("case_key") not in wanted:
                    raise SweepError(
                        f"{where} holds results of another sweep (case {row.get('case')}); "
                        f"write to a new file or delete it"
                    )
                if row.get("status") != "failed":  # a failure is a bug, perhaps mended since: again
                    kept[row["case_key"]] = {**row, "case": wanted[row["case_key"]].index}
    for line in set_aside:
        if warn is not None:
            warn(line)
    todo = [c for c in cases if c.key not in kept]
    if recordings is not None and todo and method == "run":
        Path(recordings).mkdir(parents=True, exist_ok=True)
    rows = list(kept.values())
    done = len(rows)
    executing = _execute(todo, workers, scheduler)
    first = next(executing, None)  # reach the cluster (or fail) before the journal is made
    with journal if journal is not None and first is not None else contextlib.nullcontext():
        for row in itertools.chain([first] if first is not None else [], executing):
            rows.append(row)
            if journal is not None:
                journal.append(row)
            done += 1
            if progress is not None:
                progress(done, len(cases), row)
    table = to_table(rows, columns)
    if output is not None:
        write_table(table, output)
    if journal is not None:
        journal.remove()
    return table


def _execute(cases: list[Case], workers: int | None, scheduler: str | None):
    """Rows as cases finish, in any order: on local threads, or on a Dask cluster."""
    if not cases:
        return
    if scheduler is not None:
        yield from _on_cluster(cases, scheduler)
        return
    threads = workers or os.cpu_count() or 1
    # Runs: all at once, packs on every thread, a row as each run ends; critical speeds: a
    # thread each.
    runs = [c for c in cases if c.method == "run"]
    if runs:
        yield from run_rows(runs, threads)
    pool = ThreadPoolExecutor(max_workers=threads)
    try:
        pending = [pool.submit(run_case, case) for case in cases if case.method != "run"]
        for done in as_completed(pending):
            yield done.result()
    finally:  # interrupted (Ctrl-C): the queued cases are dropped, not waited for
        pool.shutdown(wait=False, cancel_futures=True)


# How long a cluster may keep a sweep waiting before it is given up, with the journal kept:
# to answer the first call (a Dask scheduler answers in milliseconds; a service that is not
# one, or a host that swallows the connection, never does), and to have no worker at all (an
# adaptive cluster starts its first workers within this).
CONNECT_TIMEOUT = 10.0  # s
WORKERLESS_TIMEOUT = 60.0  # s
POLL = 1.0  # s between looks at the cluster while no case finishes


def _connect(scheduler: str):
    """A Dask client of `scheduler`, or SweepError within CONNECT_TIMEOUT. The client is made
    on a thread of its own: its `timeout` bounds the TCP connection, not the handshake, which
    a silent server or one that speaks another protocol holds forever."""
    try:
        from distributed import Client
    except ImportError:
        raise SweepError("--scheduler needs Dask: pip install 'rail-mj[cluster]'") from None
    made: dict[str, Any] = {}

    def connect() -> None:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
            if late.is_set():  # given up on meanwhile: not left open behind the user's back
                client.close()
            made["client"] = client
        except BaseException as e:  # MemoryError too: a foreign protocol read as a frame length
            made["error"] = e

    late = threading.Event()
    thread = threading.Thread(target=connect, name="rail-mj-connect", daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT + 1.0)
    where = f"--scheduler {scheduler!r}"
    if thread.is_alive():
        late.set()
        raise SweepError(f"{where}: nothing there answered as a Dask scheduler within {CONNECT_TIMEOUT:g} s")
    if "error" in made:
        e = made["error"]
        if isinstance(e, MemoryError):
            raise SweepError(f"{where}: it answered, but not as a Dask scheduler") from None
        if isinstance(e, (OSError, TimeoutError, ValueError)):
            raise SweepError(f"{where}: cannot reach it ({' '.join(str(e).split())})") from None
        raise SweepError(f"{where}: not a Dask scheduler ({type(e).__name__}: {' '.join(str(e).split())})") from None
    return made["client"]


class ClusterError(SweepError):
    """A cluster that failed the sweep (not the user's input): the rows so far are journalled."""


@contextlib.contextmanager
def _quiet_dask():
    """Dask's own ERROR lines and tracebacks (a lost scheduler, a reconnection) held back:
    what stops the sweep is said once, in its one line."""
    names = [n for n in list(logging.root.manager.loggerDict) if n.split(".")[0] in ("distributed", "tornado")]
    loggers = [logging.getLogger(name) for name in ["distributed", "tornado", *names]]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


def _any_worker(client) -> bool:
    try:  # one worker's details are enough to know (Dask 2025 and later; all of them before)
        info = client.scheduler_info(n_workers=1)
    except TypeError:
        info = client.scheduler_info()
    return bool(info.get("workers"))


def _on_cluster(cases: list[Case], scheduler: str) -> Iterator[dict]:
    """Rows as a Dask cluster finishes its tasks. A cluster that fails ends the sweep in one
    ClusterError, the rows so far journalled: no worker for WORKERLESS_TIMEOUT, the scheduler
    lost, a worker that died under the same task as often as Dask allows (out of memory, say)."""
    from distributed import KilledWorker, wait

    where = f"--scheduler {scheduler!r}"
    with _quiet_dask():
        client = _connect(scheduler)
        try:
            pending = set(client.map(run_task, tasks(cases), pure=False))  # a pack a task, a task a thread
            workerless_since: float | None = None
            while pending:
                with contextlib.suppress(TimeoutError):  # Dask's wait raises when nothing finished
                    wait(pending, timeout=POLL, return_when="FIRST_COMPLETED")
                done = {f for f in pending if f.done()}
                pending -= done
                for future in done:
                    yield from future.result()
                if done:
                    workerless_since = None
                    continue
                if client.status != "running":
                    raise ClusterError(f"{where}: the scheduler went away (the client is {client.status})")
                now = time.monotonic()
                if _any_worker(client):
                    workerless_since = None
                elif workerless_since is None:
                    workerless_since = now
                elif now - workerless_since > WORKERLESS_TIMEOUT:
                    raise ClusterError(f"{where}: the cluster has had no worker for {WORKERLESS_TIMEOUT:g} s")
        except CancelledError:
            raise ClusterError(f"{where}: the scheduler went away (it cancelled the sweep's tasks)") from None
        except KilledWorker as e:
            raise ClusterError(
                f"{where}: workers died running one task as often as Dask allows, out of memory perhaps "
                f"({' '.join(str(e).split())[:200]})"
            ) from None
        except (OSError, TimeoutError) as e:  # the scheduler unreachable in scheduler_info
            raise ClusterError(f"{where}: the scheduler went away ({' '.join(str(e).split())[:200]})") from None
        except Exception as e:  # run_task never raises for a case: what fails is the cluster (rail_mj
            # missing on a worker, a result that cannot travel)
            why = " ".join(str(e).split())[:200]
            raise ClusterError(f"{where}: a task failed on the cluster: {type(e).__name__}: {why}") from None
        finally:
            with contextlib.suppress(Exception):
                client.close(timeout=CONNECT_TIMEOUT)


def summarise(table) -> dict:
    """What a sweep found: cases by status, and for runs, per variant, every range of speeds
    where the motion does not decay (growth at the speed, or a run that left the rails; first
    and last speed of each range, m/s) and the bracket where it first stops decaying (the last
    stable speed below the lowest range and that range's first; None when the lowest speed run
    is unstable already, or none is). Stability can come in windows: a freight wagon's car body
    unstable at low speed, stable above, its bogies hunting higher still. Cases that failed or
    were refused say nothing of stability and are left out. `table`: `sweep_table`'s, or
    `sweep`'s DataFrame."""
    if not hasattr(table, "to_pylist"):  # a DataFrame: NaN back to the table's None
        import pyarrow as pa

        table = pa.Table.from_pandas(table, preserve_index=False)
    rows = table.to_pylist()
    result = {
        "cases": len(rows),
        "by_status": {s: sum(r["status"] == s for r in rows) for s in STATUSES},
        "wall_time_s": float(sum(r["wall_time_s"] for r in rows)),
    }
    if rows and "n_mv" in rows[0]:  # on irregular track: the forced motion's growth says nothing of stability
        result["over_seeds"] = _over_seeds(table.column_names, rows)
    elif rows and "growth_rate_per_s" in rows[0]:
        params = [
            c
            for c in table.column_names
            if c not in ("case", "speed_m_per_s") and c not in RESULTS["run"] and c not in TAIL
        ]
        groups: dict[tuple, list[dict]] = {}
        for r in rows:
            if r["status"] in ("ok", "diverged"):
                groups.setdefault(tuple(r[p] for p in params), []).append(r)
        brackets = []
        for key, group in groups.items():
            group.sort(key=lambda r: r["speed_m_per_s"])
            speeds = [r["speed_m_per_s"] for r in group]
            unstable = [r["status"] == "diverged" or (r["growth_rate_per_s"] or 0) > 0 for r in group]
            ranges: list[list[float]] = []
            for k, u in enumerate(unstable):
                if u and (k == 0 or not unstable[k - 1]):
                    ranges.append([speeds[k], speeds[k]])
                elif u:
                    ranges[-1][1] = speeds[k]
            first = next((k for k, u in enumerate(unstable) if u), None)
            bracket = [speeds[first - 1], speeds[first]] if first else None
            brackets.append(
                {
                    **dict(zip(params, key)),
                    "critical_speed_bracket_m_per_s": bracket,
                    "unstable_m_per_s": ranges,
                    "speeds_m_per_s": [speeds[0], speeds[-1]],
                }
            )
        result["brackets"] = brackets
    return result


# The quantities `_over_seeds` takes the mean and spread of.
OVER_SEEDS = ("n_mv", "wz_lateral", "wz_vertical", "y_over_q_p99_85", "sum_y_p99_85_n")


def _over_seeds(columns, rows: list[dict]) -> list[dict]:
    """Per variant and speed (every parameter but irregularities.seed), the mean and the sample
    standard deviation over its seeds (its realisations of the track) of N_MV, Wz, Y/Q and Sigma Y, of the
    cases that ran (`seeds`: how many; one seed: spread None)."""
    params = [c for c in columns if c not in ("case", "irregularities.seed") and c not in RESULTS["run"]]
    params = [c for c in params if c not in RIDE_RESULTS and c not in TAIL]
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["status"] == "ok":
            groups.setdefault(tuple(r[p] for p in params), []).append(r)
    out = []
    for key, group in groups.items():
        entry: dict[str, Any] = {**dict(zip(params, key)), "seeds": len(group)}
        for q in OVER_SEEDS:
            values = np.array([r[q] for r in group if r[q] is not None], dtype=float)
            entry[f"{q}_mean"] = float(values.mean()) if values.size else None
            entry[f"{q}_spread"] = float(values.std(ddof=1)) if values.size > 1 else None
        out.append(entry)
    return out


# A bracket's own entries; the rest name its variant's parameters.
BRACKET_KEYS = ("critical_speed_bracket_m_per_s", "unstable_m_per_s", "speeds_m_per_s")


def describe(bracket: dict) -> str:
    """One line of a `summarise` bracket: where the motion does not decay, and where it first stops."""
    low, high = bracket["speeds_m_per_s"]
    ranges = bracket["unstable_m_per_s"]
    if not ranges:
        return f"the motion decays at every speed run ({low:g} to {high:g} m/s)"

    def span(a: float, b: float) -> str:
        text = f"{a:g} m/s" if a == b else f"{a:g} to {b:g} m/s"
        ends = [e for e, at in (("the lowest", a == low), ("the highest", b == high)) if at]
        return text + (f" ({' and '.join(ends)} speed run)" if ends else "")

    spans = [span(a, b) for a, b in ranges]
    text = "the motion does not decay at " + ", ".join(spans[:-1]) + (" and " if len(spans) > 1 else "") + spans[-1]
    first = bracket["critical_speed_bracket_m_per_s"]
    if first is not None:
        text += f"; it first stops decaying between {first[0]:g} and {first[1]:g} m/s"
    if len(ranges) > 1:
        text += "; stability comes in windows"
    return text
