"""The headless runner and the `rail-mj run` command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import MODELS, SHIPPED, free_truck
from rail_mj.cli import main
from rail_mj.forces import CreepForces
from rail_mj.layout import load_layout
from rail_mj.model import Vehicle
from rail_mj.runner import (MAX_TIMESTEP, STEP_FRACTION, SimulationError, linear_system,
                            simulate, stable_timestep)

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
WHEELSET = MODELS / "wheelset" / "wheelset.toml"


def test_runs_are_deterministic():
    layout = load_layout(COACH)
    a = simulate(layout, speed=45.0, distance=40.0, initial_lateral=0.002, initial_yaw=0.001)
    b = simulate(layout, speed=45.0, distance=40.0, initial_lateral=0.002, initial_yaw=0.001)
    assert np.array_equal(a.y, b.y) and np.array_equal(a.psi, b.psi) and np.array_equal(a.t, b.t)


@pytest.mark.parametrize("speed", [2.0, 100.0])
def test_timestep_is_chosen_from_layout_and_speed(speed):
    """Slow runs need small steps (creep damping 2*f22/V), fast ones do not; both run
    with no flags and the step resolves every linear mode: dt*|lambda|max <= STEP_FRACTION."""
    layout = load_layout(COACH)
    vehicle = Vehicle(layout)
    forces = CreepForces(vehicle.model, vehicle.wheelset_names, speed)
    dt = stable_timestep(vehicle, forces)
    rate = np.max(np.abs(np.linalg.eigvals(linear_system(vehicle, forces))))
    assert dt <= MAX_TIMESTEP and dt * rate <= STEP_FRACTION * (1 + 1e-12)
    run = simulate(layout, speed=speed, distance=min(4.0, speed), initial_lateral=0.002)
    assert run.timestep == dt and np.all(np.isfinite(run.y))
    assert np.max(np.abs(run.y)) < 0.0025  # a short, sub-critical run does not run away


def test_slow_runs_take_smaller_steps():
    layout = load_layout(COACH)
    steps = []
    for speed in (2.0, 4.0):
        vehicle = Vehicle(layout)
        steps.append(stable_timestep(vehicle, CreepForces(vehicle.model, vehicle.wheelset_names, speed)))
    # The creep damping rate 2*f22/(V*m) sets the step at low speed: dt scales with V
    # (to 5 %: the suspension's own rates add a little).
    assert steps[1] < MAX_TIMESTEP
    assert steps[0] == pytest.approx(steps[1] * 2.0 / 4.0, rel=0.05)


def test_impossibly_slow_run_is_refused_naming_the_limit():
    with pytest.raises(SimulationError, match=r"too slow.*2\*f22/V.*timestep.*limit"):
        simulate(load_layout(COACH), speed=1e-4, distance=100.0)


def test_hunting_without_flange_contact_stops_with_a_reason():
    # The restrained wheelset's closed-form critical speed is 57.5 m/s (reference sheet, 4).
    with pytest.raises(SimulationError, match="above this vehicle's critical speed") as e:
        simulate(load_layout(WHEELSET), speed=75.0, distance=3000.0, initial_lateral=0.002)
    partial = e.value.run
    assert partial is not None and np.all(np.isfinite(partial.y))
    assert np.max(np.abs(partial.y[:, 0])) > 0.07


def test_three_axle_bogie_runs():
    run = simulate(free_truck([1.8, 0.0, -1.8], primary=5e6), speed=20.0, distance=20.0,
                   initial_lateral=0.002)
    assert run.y.shape[1] == 3 and np.all(np.isfinite(run.y))


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_cli_run_writes_csv_and_json_summary(layout_path, tmp_path, capsys):
    out = tmp_path / "run.csv"
    status = main(["run", str(layout_path), "--speed", "30", "--distance", "25",
                   "--initial-lateral", "0.003", "--out", str(out), "--json"])
    assert status == 0
    result = json.loads(capsys.readouterr().out)
    layout = load_layout(layout_path)
    n = layout.n_wheelsets
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["t", "x"] + [f"{k}{i}" for i in range(1, n + 1) for k in ("y", "psi")]
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    run = simulate(layout, speed=30.0, distance=25.0, initial_lateral=0.003)
    # %.10g in the CSV: 10 significant figures.
    np.testing.assert_allclose(data[:, 0], run.t, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(data[:, 2::2], run.y, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(data[:, 3::2], run.psi, rtol=1e-9, atol=1e-15)
    assert data[0, 2] == 0.003
    assert len(result["wheelsets"]) == n
    for w in result["wheelsets"]:
        assert set(w) >= {"max_abs_lateral_m", "growth_rate_per_s", "wavelength_m", "frequency_hz"}
        assert w["max_abs_lateral_m"] == pytest.approx(0.003, rel=0.5)


def test_cli_reports_divergence_in_one_line_and_writes_nothing(tmp_path, capsys):
    out, rrd = tmp_path / "run.csv", tmp_path / "run.rrd"
    status = main(["run", str(WHEELSET), "--speed", "75", "--distance", "3000",
                   "--out", str(out), "--rrd", str(rrd)])
    err = capsys.readouterr().err
    assert status == 3
    assert len(err.strip().splitlines()) == 1 and "left the rails" in err
    assert not out.exists() and not rrd.exists() and list(tmp_path.iterdir()) == []
