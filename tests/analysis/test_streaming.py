"""A run summarised as it is stepped (rail_mj.analysis.streaming) says what the full summary of
its record says, bit for bit: the same numbers from a few events a coordinate instead of every
sample."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import MODELS

from rail_mj.analysis import summary
from rail_mj.analysis.motion import decayed_at, local_maxima, oscillation
from rail_mj.analysis.streaming import Coordinate, Summarised
from rail_mj.layout import load_layout
from rail_mj.simulation.batch import simulate_many
from rail_mj.simulation.run import Request
from rail_mj.simulation.runner import simulate
from rail_mj.studies import sweep


def _equal(streamed, full, path: str = "") -> list[str]:
    """Where two summaries' values differ (exactly; nan equal to nan); `full` may have more keys."""
    if isinstance(streamed, dict):
        return [d for k in streamed for d in _equal(streamed[k], full[k], f"{path}.{k}")]
    if isinstance(streamed, list):
        assert len(streamed) == len(full), path
        return [d for i, (a, b) in enumerate(zip(streamed, full)) for d in _equal(a, b, f"{path}[{i}]")]
    same = streamed == full or (isinstance(full, float) and math.isnan(full) and math.isnan(streamed))
    return [] if same else [f"{path}: {streamed!r} != {full!r}"]


@pytest.mark.parametrize(
    "name,speed,distance,lateral",
    [
        ("manchester-coach", 40.0, 400.0, 0.002),  # every body decays
        ("manchester-coach", 90.0, 600.0, 0.002),  # a limit cycle on the flanges, EN 14363 hunting
        ("manchester-coach", 60.0, 150.0, 0.0),  # at rest
        ("manchester-coach-s1002", 70.0, 300.0, 0.002),  # profiles: a sustained motion
        ("manchester-coach-spatial", 60.0, 200.0, 0.002),  # a spatial vehicle's frames, roll
        ("two-coaches", 60.0, 300.0, 0.002),  # a train: six frames
    ],
)
def test_a_streamed_run_says_what_its_full_summary_says(name, speed, distance, lateral):
    layout = load_layout(MODELS / name / f"{name}.toml")
    full = summary(simulate(layout, speed, distance, initial_lateral=lateral))
    request = Request(layout, speed, distance, lateral, stream=Summarised.stream(layout, speed))
    (streamed,) = simulate_many([request])
    assert len(streamed["frames"]) == len(full["frames"]) > 0
    assert not _equal({k: streamed[k] for k in ("wheelsets", "frames", "decayed", "hunting")}, full)
    assert streamed["max_abs_lateral_m"] == max(w["max_abs_lateral_m"] for w in full["wheelsets"])


def _chunks(s: np.ndarray, rng) -> list[int]:
    """Random cuts of 1 to 40 samples."""
    cuts = np.cumsum(rng.integers(1, 40, size=len(s)))
    return [0, *cuts[cuts < len(s)].tolist(), len(s)]


@pytest.mark.parametrize("seed", range(6))
def test_a_coordinate_cut_anywhere_keeps_the_events_of_any_window(seed):
    """Signals with flat tops, exact zeros and a decay, given in random pieces: the crossings,
    peaks, growth rate and decay time of the whole run, its first part and its second half are
    motion's own of those slices (its functions on the arrays), exactly."""
    rng = np.random.default_rng(seed)
    n, interval = 1500, 1e-3
    t = np.arange(n) * interval
    s = np.exp(-2.0 * t) * np.sin(2 * np.pi * 7.0 * t + seed) * (1.0 if seed % 2 else 1e-3)
    s = np.round(s, (2 if seed % 2 else 5) + seed % 3)  # flat tops and bottoms, and zeros, at the chosen rounding
    s[900:] *= 0.01 * (seed > 2)  # decayed, or stopped dead
    coordinate = Coordinate(n, interval)
    cuts = _chunks(s, rng)
    for a, b in zip(cuts[:-1], cuts[1:]):
        coordinate.add(a, t[a:b].copy(), s[a:b].copy())
    assert coordinate.largest == np.max(np.abs(s))
    assert coordinate.late == np.max(np.abs(s[t >= t[-1] / 2]))
    assert coordinate.final == np.max(np.abs(s[t >= 0.9 * t[-1]]))
    ended = coordinate.decayed_at()
    want = decayed_at(t, s)
    assert (ended is None and want is None) or (ended is not None and ended[0] == want)
    assert len(local_maxima(s)) > 5
    for first, stop in ((0, n), (0, 700), (n // 2, n), (3, 4), (0, 901)):
        got, expected = coordinate.oscillation(first, stop), oscillation(t[first:stop], s[first:stop])
        assert np.array_equal(got, expected, equal_nan=True), (first, stop, got, expected)


def test_a_sweep_streams_its_rows_and_they_are_the_full_summarys(monkeypatch, tmp_path):
    """The sweep's rows from streamed runs (straight track, no recording) against the rows it
    makes from each run's whole record (streaming turned off): equal, field by field."""
    layout = MODELS / "manchester-coach" / "manchester-coach.toml"
    streamed = sweep.sweep_table(layout, (30.0, 110.0, 5), distance=300.0).to_pylist()
    monkeypatch.setattr(sweep, "_stream", lambda case, layout: None)
    full = sweep.sweep_table(layout, (30.0, 110.0, 5), distance=300.0).to_pylist()
    assert {r["status"] for r in full} == {"ok"} and any(r["hunting"] for r in full)
    for a, b in zip(streamed, full, strict=True):
        a.pop("wall_time_s"), b.pop("wall_time_s")
        assert a == b


@pytest.mark.parametrize("seed", range(6))
def test_a_coordinates_kernel_keeps_what_numpy_keeps_bit_for_bit(seed):
    """The C kernel of `Coordinate.add` against its numpy form, on the signals above (flat tops,
    zeros, a decay) cut at random: every number kept equal, and the same types."""
    from rail_mj.analysis.streaming import _library

    assert _library() is not None  # gcc is here: the kernel, not its fallback, is what is tested
    rng = np.random.default_rng(100 + seed)
    n, interval = 1500, 1e-3
    t = np.arange(n) * interval
    s = np.round(np.exp(-2.0 * t) * np.sin(2 * np.pi * 7.0 * t + seed), 2 + seed % 3)
    s[900:] *= 0.01 * (seed > 2)
    kernel, numpy_ = Coordinate(n, interval), Coordinate(n, interval)
    cuts = _chunks(s, rng)
    for a, b in zip(cuts[:-1], cuts[1:]):
        kernel.add(a, t[a:b].copy(), s[a:b].copy())
        numpy_.add(a, t[a:b].copy(), s[a:b].copy(), native=False)
        assert (kernel.largest, kernel.late, kernel.final) == (numpy_.largest, numpy_.late, numpy_.final)
        assert kernel._last == numpy_._last and kernel._move == numpy_._move
    for mine, theirs in ((kernel.stairs, numpy_.stairs), *zip(kernel.crossings, numpy_.crossings, strict=True)):
        for x, y in zip(mine, theirs, strict=True):
            assert x.dtype == y.dtype and np.array_equal(x, y)
    for peak in (True, False):
        assert len(kernel.tops[peak]) == len(numpy_.tops[peak]) > 0
        for mine, theirs in zip(kernel.tops[peak], numpy_.tops[peak], strict=True):
            for x, y in zip(mine, theirs, strict=True):
                assert x.dtype == y.dtype and np.array_equal(x, y)


def test_a_flat_twins_pieces_carry_yaw_angles_and_the_records_quaternions():
    """A flat twin's pieces carry each body's yaw angle (Run.body_yaw, what psi reads), and
    their quaternions, made from those angles when read (Run.body_quat), are the full
    record's, bit for bit: every body a turn about z, (cos psi/2, 0, 0, sin psi/2)."""
    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    full = simulate(layout, 40.0, 200.0, 0.002)
    pieces: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = []

    class Keep:
        def add(self, piece, start):
            assert piece.body_yaw is not None
            pieces.append((start, piece.body_quat.copy(), piece.psi.copy(), piece.body_pos.copy()))

        def finish(self, final_state):
            return len(pieces)

    (count,) = simulate_many([Request(layout, 40.0, 200.0, 0.002, stream=lambda n, interval: Keep())])
    assert count == len(pieces) > 1
    for start, quat, psi, pos in pieces:
        rows = slice(start, start + len(quat))
        assert np.array_equal(pos, full.body_pos[rows]) and np.array_equal(psi, full.psi[rows])
        assert np.array_equal(quat, full.body_quat[rows])
    ids = full.vehicle.wheelset_ids
    turn = np.stack([np.cos(full.psi / 2), 0 * full.psi, 0 * full.psi, np.sin(full.psi / 2)], axis=-1)
    assert np.array_equal(full.body_quat[:, ids], turn) and np.any(full.psi != 0.0)
