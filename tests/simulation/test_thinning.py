"""A run asked to keep fewer samples than its steps (a long run's way to fit in memory): the steps
are the same, and each sample kept is the full record's at its time, bit for bit."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import MODELS

from rail_mj.cli import main
from rail_mj.layout import load_layout
from rail_mj.simulation import stepping
from rail_mj.simulation.batch import simulate_many
from rail_mj.simulation.run import Request
from rail_mj.simulation.runner import prepare, simulate

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
S1002 = MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml"


def _arrays(run):
    return [run.body_pos, run.body_quat, run.wheelset_rates, run.axle_loads]


def _is_thinned_from(thin, full, same_end: bool = True) -> None:
    """Every sample of `thin` is `full`'s at its step; with `same_end` (the run's steps a whole
    number of its samples' spacing) the two end in the same state."""
    every = round((thin.t[1] - thin.t[0]) / (full.t[1] - full.t[0]))
    k = np.arange(len(thin.t)) * every  # the times agree to round-off (i*every*dt against (i*every)*dt)
    assert np.allclose(full.t[k], thin.t, rtol=1e-13, atol=0)
    for a, b in zip(_arrays(thin), _arrays(full)):
        assert np.array_equal(a, b[k], equal_nan=True)
    if same_end:
        assert all(np.array_equal(a, b) for a, b in zip(thin.final_state, full.final_state))


@pytest.mark.parametrize("path,interval", [(COACH, 0.005), (S1002, 0.004)])
def test_a_sample_kept_is_the_full_records_and_the_run_ends_where_it_would(path, interval):
    """The coach at its 1 ms step and on profiles at 0.579 ms (every 7th step kept: 4.05 ms),
    against a record of every step."""
    layout = load_layout(path)
    prepared = prepare(Request(layout, 50.0, 150.0))
    dt, n_steps = prepared.timestep, prepared.n_steps
    full = simulate(layout, 50.0, 150.0, sample_interval=dt)
    assert len(full.t) == n_steps + 1
    thin = simulate(layout, 50.0, 150.0, sample_interval=interval)
    every = round(interval / dt)
    assert thin.t[1] == pytest.approx(every * dt, rel=1e-12)
    assert len(thin.t) == -(-n_steps // every) + 1
    _is_thinned_from(thin, full)
    assert thin.x[-1] >= 150.0 - 1e-9  # its last sample at or past the distance


def test_runs_of_different_cadences_stepped_together_are_each_the_run_alone():
    """Packs hold runs of one timestep and one sample interval: mixed requests are sorted out,
    and every result is the one `simulate` gives, on one thread and on two."""
    layout = load_layout(COACH)
    requests = [Request(layout, v, 120.0, sample_interval=s) for v in (40.0, 50.0, 60.0) for s in (None, 0.003)]
    alone = [simulate(layout, r.speed, 120.0, sample_interval=r.sample_interval) for r in requests]
    for threads in (1, 2):
        for got, want in zip(simulate_many(requests, threads=threads), alone):
            assert np.array_equal(got.t, want.t) and np.array_equal(got.body_pos, want.body_pos)


def test_sample_rate_on_the_command_line(tmp_path, capsys):
    """--sample-rate N keeps N a second (said in the summary's first line, in the JSON and in a
    warning: nothing is low-passed before the summary reads them); a bad value is one line and
    exit 2, nothing written."""
    out = tmp_path / "r.csv"
    argv = ["run", str(COACH), "--speed", "50", "--distance", "60"]
    assert main([*argv, "--sample-rate", "250", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out.splitlines()[0].endswith(", a sample every 4 ms)")
    (warning,) = captured.err.strip().splitlines()
    assert warning.startswith("rail-mj: warning: the summary reads one sample every 4 ms (--sample-rate)")
    rows = out.read_text().splitlines()
    n_steps = prepare(Request(load_layout(COACH), 50.0, 60.0)).n_steps  # at 1 ms: four a sample
    assert len(rows) - 1 == -(-n_steps // 4) + 1
    assert main([*argv, "--json"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["sample_interval_s"] == pytest.approx(1e-3) and not captured.err
    for bad in ("0", "-5", "nan", "auto", "often"):
        assert main([*argv, "--sample-rate", bad, "--out", str(tmp_path / "x.csv")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--sample-rate must be full or a positive number" in err[0]
    assert not (tmp_path / "x.csv").exists()


def test_a_bad_sample_interval_is_refused():
    layout = load_layout(COACH)
    for bad in (0.0, -1e-3, math.nan, math.inf):
        with pytest.raises(ValueError, match="sample interval must be a positive number"):
            simulate(layout, 50.0, 10.0, sample_interval=bad)


def test_a_run_is_stepped_in_chunks_of_steps_whatever_it_keeps(monkeypatch):
    """A sample a second on the coach's 1 ms step (every 1000th kept): the chunks (each step's
    state and sensors held in a buffer) are still CHECK_EVERY samples' worth of steps at 1 ms,
    the divergence checks as often, and the last chunk ends one step past the last sample (a
    step's sensors are read before it integrates): nothing stepped is thrown away. Its samples
    are the full record's, and its steps not a whole number of intervals (20.4 s), the run ends
    at the first kept sample past the distance."""
    layout = load_layout(COACH)
    chunks = []
    call = stepping.Roller.__call__

    def counted(self, model, data, start, nstep, unbiased=False):
        chunks.append(nstep)
        return call(self, model, data, start, nstep, unbiased)

    monkeypatch.setattr(stepping.Roller, "__call__", counted)
    thin = simulate(layout, 50.0, 1020.0, sample_interval=1.0)
    assert thin.timestep == pytest.approx(1e-3, rel=1e-12)  # the coach's step: a chunk of CHECK_EVERY of them
    assert max(chunks) == stepping.CHECK_EVERY and sum(chunks) == 21 * 1000 + 1
    assert len(thin.t) == 22 and thin.x[-1] == pytest.approx(1050.0, rel=1e-12)  # 21 s: past 20.4 s
    monkeypatch.setattr(stepping.Roller, "__call__", call)
    full = simulate(layout, 50.0, 1050.0)
    _is_thinned_from(thin, full)


def test_an_interval_too_long_for_the_run_is_refused(tmp_path, capsys):
    """Ten intervals at least: the run ends at the first kept sample at or past its distance, so
    at most a tenth further. On the command line, one line and exit 2, nothing written."""
    layout = load_layout(COACH)
    with pytest.raises(ValueError, match=r"sample interval 0.2 s is longer than a tenth of the run \(1.2 s\)"):
        simulate(layout, 50.0, 60.0, sample_interval=0.2)
    assert len(simulate(layout, 50.0, 60.0, sample_interval=0.12).t) == 11
    out = tmp_path / "r.csv"
    for rate in ("5", "1e-6", "1e-300"):
        assert (
            main(["run", str(COACH), "--speed", "50", "--distance", "60", "--sample-rate", rate, "--out", str(out)])
            == 2
        )
        (err,) = capsys.readouterr().err.strip().splitlines()
        assert "is longer than a tenth of the run (1.2 s)" in err
    assert not out.exists()
