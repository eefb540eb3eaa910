"""The run summary covers every body and the flanges, and the README's claims are read from it."""

from __future__ import annotations

import json
import re

import numpy as np
import pyarrow as pa
import pytest
from conftest import DATA, MODELS, ROOT

from rail_mj.analysis import Stability, summary
from rail_mj.cli import main
from rail_mj.layout import load_layout
from rail_mj.simulation.runner import simulate
from rail_mj.studies.sweep import describe, summarise, sweep_table

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
FREIGHT = DATA / "freight-window.toml"


def _episodes(on: np.ndarray) -> list[tuple[int, int]]:
    """(first, last + 1) of each run of True in `on`."""
    padded = np.concatenate([[False], on, [False]]).astype(int)
    edges = np.nonzero(np.diff(padded))[0]
    return list(zip(edges[::2], edges[1::2]))


def test_flange_contact_is_counted_timed_and_its_largest_force_found():
    """Against the samples themselves: a strike is a stretch of |y| past the flangeway
    clearance; the largest flange force is the flange's lateral force at its largest there."""
    run = simulate(load_layout(COACH), 85.0, 300.0, 0.002)
    flange = summary(run)["flange_contact"]
    clearance = run.layout.wheelset.flangeway_clearance
    force = np.abs(run.contact_forces().flange_lateral)
    episodes, largest, first = 0, 0.0, None
    for i in range(run.n_wheelsets):
        for a, b in _episodes(np.abs(run.y[:, i]) > clearance):
            episodes += 1
            largest = max(largest, float(force[a:b, i].max()))
            first = min(first or (a, i), (a, i))
    assert flange["strikes"] == episodes > 0
    assert sum(flange["strikes_per_wheelset"]) == episodes
    assert flange["largest_flange_force_n"] == largest
    assert flange["first_strike"]["t_s"] == run.t[first[0]]
    assert flange["first_strike"]["wheelset"] == first[1] + 1
    assert flange["first_strike"]["rail"] == ("left" if run.y[first[0], first[1]] > 0 else "right")
    # The flange (15 MN/m past 8 mm) carries tens of kN in a 13 mm limit cycle, not a bare creep force.
    assert 20e3 < largest < 200e3


def test_a_layout_without_flanges_has_no_flange_contact_to_report():
    layout = load_layout(MODELS / "wagon" / "wagon.toml")
    assert summary(simulate(layout, 20.0, 50.0, 0.002))["flange_contact"] is None


def test_the_readmes_claims_are_what_the_summary_says():
    """'within 55 m the leading wheelset strikes its flanges' at 85 m/s; 'dies within 32 m at the
    wheelsets and 63 m at the car body' at 40 m/s: each number the summary's, rounded up to the metre."""
    readme = " ".join(ROOT.joinpath("README.md").read_text().split())
    strike = int(re.search(r"within (\d+) m the leading wheelset strikes its flanges", readme).group(1))
    wheelsets, body = map(
        int, re.search(r"dies within (\d+) m at the wheelsets and (\d+) m at the car body", readme).groups()
    )
    hunting = summary(simulate(load_layout(COACH), 85.0, 200.0, 0.002))
    first = hunting["flange_contact"]["first_strike"]
    assert first["wheelset"] == 1 and strike - 1 < first["x_m"] <= strike
    stable = summary(simulate(load_layout(COACH), 40.0, 300.0, 0.002))
    assert stable["decayed"] and not stable["growing"] and not stable["sustained"]
    assert stable["flange_contact"]["strikes"] == 0
    assert wheelsets - 1 < max(w["decayed_by_m"] for w in stable["wheelsets"]) <= wheelsets
    carbody = next(f for f in stable["frames"] if f["body"] == "carbody")
    assert body - 1 < carbody["decayed_by_m"] <= body


def test_a_growing_car_body_is_named_with_its_mode_s_growth_and_frequency():
    """The freight wagon at 10 m/s: its car body's lateral mode is unstable (eigen). The summary
    names the car body as growing, at the eigenvalue's growth rate and frequency: the run is
    linear (2 mm on cones, creep well short of saturation), so to the few per cent that the peak
    fit over a 0.35 Hz motion with the other modes still in it allows."""
    layout = load_layout(FREIGHT)
    mode = Stability(layout).modes(10.0)[0]
    assert mode.name == "car body lateral" and mode.eigenvalue.real > 0
    result = summary(simulate(layout, 10.0, 1000.0, 0.002))
    assert "carbody" in result["growing"] and not result["decayed"]
    carbody = next(f for f in result["frames"] if f["body"] == "carbody")
    assert carbody["motion"] == "growing" and carbody["coordinate"] == "lateral"
    assert carbody["growth_rate_per_s"] == pytest.approx(mode.eigenvalue.real, rel=0.05)
    assert carbody["frequency_hz"] == pytest.approx(mode.frequency, rel=0.01)
    assert {f["body"] for f in result["frames"]} == {"bogie1", "bogie2", "carbody"}


def test_the_cli_summary_names_every_body_and_the_flanges(capsys):
    assert main(["run", str(COACH), "--speed", "85", "--distance", "200"]) == 0
    out = capsys.readouterr().out
    for body in ("bogie1", "bogie2", "carbody"):
        assert re.search(rf"^{body}\s+\d", out, re.M), out
    assert "flange contact: " in out and "first wheelset 1" in out
    assert main(["run", str(COACH), "--speed", "85", "--distance", "200", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [f["body"] for f in data["frames"]] == ["bogie1", "bogie2", "carbody"]
    assert data["flange_contact"]["strikes"] > 0


def _table(rows: list[tuple[float, str, float | None]]) -> pa.Table:
    return pa.Table.from_pylist(
        [
            {"case": k, "speed_m_per_s": v, "growth_rate_per_s": g, "status": s, "wall_time_s": 0.0}
            for k, (v, s, g) in enumerate(rows)
        ]
    )


def test_a_sweep_reports_every_speed_range_where_the_motion_does_not_decay():
    windows = _table(
        [(10, "ok", 0.01), (20, "ok", 0.002), (30, "ok", -0.01), (35, "failed", None), (40, "ok", -0.02)]
        + [(45, "ok", 0.5), (50, "diverged", None)]
    )
    bracket = summarise(windows)["brackets"][0]
    assert bracket["unstable_m_per_s"] == [[10, 20], [45, 50]]
    assert bracket["critical_speed_bracket_m_per_s"] is None  # unstable at the lowest speed run
    text = describe(bracket)
    assert "10 to 20 m/s (the lowest speed run)" in text and "45 to 50 m/s (the highest speed run)" in text
    assert "windows" in text
    once = summarise(_table([(50, "ok", -0.1), (55, "ok", -0.01), (60, "ok", 0.1)]))["brackets"][0]
    assert once["unstable_m_per_s"] == [[60, 60]] and once["critical_speed_bracket_m_per_s"] == [55, 60]
    assert "first stops decaying between 55 and 60 m/s" in describe(once)
    stable = summarise(_table([(50, "ok", -0.1), (60, "ok", -0.01)]))["brackets"][0]
    assert describe(stable) == "the motion decays at every speed run (50 to 60 m/s)"


def test_the_freight_wagons_windows_show_in_a_run_sweep():
    """Runs at 10, 50 and 90 m/s: the car body grows at 10 (the wheelsets' motion with it), the
    motion decays at 50 (the car body's slowly: -0.004 1/s), the bogies hunt at 90; the summary
    gives both ranges."""
    table = sweep_table(str(FREIGHT), (10.0, 90.0, 3), distance=500.0, workers=2)
    rows = sorted(table.to_pylist(), key=lambda r: r["speed_m_per_s"])
    assert [r["growth_rate_per_s"] > 0 for r in rows] == [True, False, True]
    assert rows[0]["frequency_hz"] == pytest.approx(0.35, abs=0.01)  # the car body's mode
    assert summarise(table)["brackets"][0]["unstable_m_per_s"] == [[10.0, 10.0], [90.0, 90.0]]


def test_local_maxima_are_scipy_find_peaks():
    """The summary's own peak finder (scipy.signal costs half a second to import) picks the
    samples scipy.signal.find_peaks does, flat tops and ends included: signals rounded to
    half-units so that plateaus of every length occur."""
    from scipy.signal import find_peaks

    from rail_mj.analysis.motion import local_maxima

    rng = np.random.default_rng(19)
    for n in (0, 1, 2, 3, 4, 7, 60, 2000):
        for _ in range(50):
            s = np.round(2.0 * rng.normal(size=n)) / 2.0
            assert np.array_equal(local_maxima(s), find_peaks(s)[0])
