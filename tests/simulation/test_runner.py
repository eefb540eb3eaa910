"""The headless runner and the `rail-mj run` command."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import MODELS, SHIPPED, free_truck

from rail_mj.cli import main
from rail_mj.layout import load_layout
from rail_mj.simulation import native
from rail_mj.simulation.batch import simulate_many
from rail_mj.simulation.callback import CreepForces
from rail_mj.simulation.run import Request, RunRefused, SimulationError
from rail_mj.simulation.runner import simulate
from rail_mj.simulation.timestep import MAX_TIMESTEP, STEP_FRACTION, stable_timestep
from rail_mj.vehicle.spec import Vehicle

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
WHEELSET = MODELS / "wheelset" / "wheelset.toml"


def test_runs_are_deterministic():
    layout = load_layout(COACH)
    a = simulate(layout, speed=45.0, distance=40.0, initial_lateral=0.002, initial_yaw=0.001)
    b = simulate(layout, speed=45.0, distance=40.0, initial_lateral=0.002, initial_yaw=0.001)
    assert np.array_equal(a.y, b.y) and np.array_equal(a.psi, b.psi) and np.array_equal(a.t, b.t)


@pytest.mark.parametrize("speed", [2.0, 100.0])
def test_timestep_is_chosen_from_layout_and_speed(speed):
    """Slow runs need small steps, fast ones do not; both run with no flags. The step
    resolves the fastest rates that the layout alone predicts: the wheelset's lateral
    creep damping 2*f22/(m*V) and yaw creep damping 2*f11*b^2/(Iz*V) (docs/creep.md, section 2), and
    the primary yaw spring's natural frequency sqrt(kpsi/Iz)."""
    layout = load_layout(COACH)
    vehicle = Vehicle(layout)
    dt = stable_timestep(vehicle, CreepForces(vehicle.model, vehicle.wheelset_names, speed))
    w, c, p = layout.wheelset, layout.creep, layout.primary
    rates = [
        2 * c.f22 / (w.mass * speed),
        2 * c.f11 * w.contact_half_spacing**2 / (w.inertia[2] * speed),
        (p.yaw_stiffness / w.inertia[2]) ** 0.5,
    ]
    # These diagonal rates are the fastest eigenvalues to within the coupling between
    # lateral, yaw and the frame (a few %): the step fits them, and is not needlessly small.
    assert dt <= MAX_TIMESTEP
    assert dt * max(rates) <= 1.1 * STEP_FRACTION
    assert dt == MAX_TIMESTEP or dt * max(rates) >= 0.5 * STEP_FRACTION
    run = simulate(layout, speed=speed, distance=min(4.0, speed), initial_lateral=0.002)
    # The run linearises with the native callback, the same forces to round-off (1e-16):
    # the fastest eigenvalue, and so the step, agree to far better than 1e-9.
    assert run.timestep == pytest.approx(dt, rel=1e-9) and np.all(np.isfinite(run.y))
    # A short, sub-critical run does not grow: 2 mm start, any overshoot well under 25 %.
    assert np.max(np.abs(run.y)) < 0.0025


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


def test_a_flat_vehicle_is_linearised_on_its_flanges():
    """On profiles the step is set by the linearisation with the whole vehicle pressed into the
    flanges: about that state, each coordinate moved from where it is there. A flat (spatial)
    vehicle shifts every lateral coordinate, so one moved from zero instead would linearise its
    wheelsets on the centred contact and miss the flange. The spatial coach's flange rates are its
    own (its wheel loads come from its suspension and Nadal's balance): 930 rad/s against 300
    centred, so the 1 ms cap holds, with which a 90 m/s flange-hunting run agrees with one at
    0.25 ms to 0.1 % in amplitude and 3e-4 in frequency (measured)."""
    from rail_mj.simulation.linear import state_matrix
    from rail_mj.simulation.timestep import table_header

    steps = []
    for name in ("manchester-coach-s1002", "manchester-coach-spatial"):
        vehicle = Vehicle(load_layout(MODELS / name / f"{name}.toml"))
        native.set_speed(vehicle.model, 60.0)
        steps.append(stable_timestep(vehicle))
    assert steps[0] < 0.7 * MAX_TIMESTEP  # the flange's rate sets the planar coach's
    shift = vehicle.layout.wheelset.flangeway_clearance - 0.5 * table_header(vehicle.model)[1]
    pressed = np.zeros(vehicle.model.nq)
    pressed[vehicle.root_lateral_dofs] = shift
    rate = lambda qpos0: np.max(np.abs(np.linalg.eigvals(state_matrix(vehicle.model, None, qpos0=qpos0))))  # noqa: E731
    assert rate(pressed) > 2.5 * rate(None)  # linearised on the flanges, not on the centred contact


def test_impossibly_slow_run_is_refused_naming_the_limit():
    with pytest.raises(RunRefused, match=r"too slow.*2\*f22/V.*timestep.*limit"):
        simulate(load_layout(COACH), speed=1e-4, distance=100.0, initial_lateral=0.0)
    with pytest.raises(RunRefused, match="too slow"):  # steps overflow to inf
        simulate(load_layout(COACH), speed=1e-300, distance=100.0, initial_lateral=0.0)


def test_hunting_without_flange_contact_stops_with_a_reason():
    # The restrained wheelset's closed-form critical speed is 57.5 m/s (docs/creep.md, section 4).
    with pytest.raises(SimulationError, match="above this vehicle's critical speed") as e:
        simulate(load_layout(WHEELSET), speed=75.0, distance=3000.0, initial_lateral=0.002)
    partial = e.value.run
    assert partial is not None and np.all(np.isfinite(partial.y))
    assert np.max(np.abs(partial.y[:, 0])) > 0.07


def test_three_axle_bogie_runs():
    run = simulate(free_truck([1.8, 0.0, -1.8], primary=5e6), speed=20.0, distance=20.0, initial_lateral=0.002)
    assert run.y.shape[1] == 3 and np.all(np.isfinite(run.y))


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_cli_run_writes_csv_and_json_summary(layout_path, tmp_path, capsys):
    out = tmp_path / "run.csv"
    status = main(
        [
            "run",
            str(layout_path),
            "--speed",
            "30",
            "--distance",
            "25",
            "--initial-lateral",
            "0.003",
            "--out",
            str(out),
            "--json",
        ]
    )
    assert status == 0
    result = json.loads(capsys.readouterr().out)
    layout = load_layout(layout_path)
    n = layout.n_wheelsets
    header = out.read_text().splitlines()[0].split(",")
    # t, x, y1, psi1, ... first; the forces and the frames' motion after them (test_recording).
    assert header[: 2 + 2 * n] == ["t", "x"] + [f"{k}{i}" for i in range(1, n + 1) for k in ("y", "psi")]
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    run = simulate(layout, speed=30.0, distance=25.0, initial_lateral=0.003)
    # %.10g in the CSV: 10 significant figures.
    np.testing.assert_allclose(data[:, 0], run.t, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(data[:, 2 : 2 + 2 * n : 2], run.y, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(data[:, 3 : 3 + 2 * n : 2], run.psi, rtol=1e-9, atol=1e-15)
    assert data[0, 2] == 0.003
    assert len(result["wheelsets"]) == n
    for w in result["wheelsets"]:
        assert set(w) >= {"max_abs_lateral_m", "growth_rate_per_s", "wavelength_m", "frequency_hz"}
        # Sub-critical at 30 m/s: the 3 mm start is the largest |y|, give or take overshoot.
        assert 0.003 <= w["max_abs_lateral_m"] < 0.0045


def test_cli_reports_divergence_in_one_line_and_writes_nothing(tmp_path, capsys):
    out, rrd = tmp_path / "run.csv", tmp_path / "run.rrd"
    status = main(["run", str(WHEELSET), "--speed", "75", "--distance", "3000", "--out", str(out), "--rrd", str(rrd)])
    err = capsys.readouterr().err
    assert status == 3
    assert len(err.strip().splitlines()) == 1 and "left the rails" in err
    assert not out.exists() and not rrd.exists() and list(tmp_path.iterdir()) == []


def test_outputs_never_overwrite_the_layout(tmp_path, capsys):
    layout = tmp_path / "coach.toml"
    layout.write_text(COACH.read_text())
    assert main(["run", str(layout), "--speed", "30", "--distance", "5", "--out", str(layout)]) == 2
    assert "would overwrite the layout file" in capsys.readouterr().err
    assert layout.read_text() == COACH.read_text()


def test_a_failed_output_takes_the_other_with_it(tmp_path, capsys):
    """Both outputs or neither: --rrd into a place no file can be made (/proc) fails
    after the CSV was staged, and the CSV must not appear."""
    out = tmp_path / "run.csv"
    status = main(
        ["run", str(WHEELSET), "--speed", "30", "--distance", "5", "--out", str(out), "--rrd", "/proc/run.rrd"]
    )
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1
    assert "/proc/run.rrd" in err and ".tmp" not in err
    assert list(tmp_path.iterdir()) == []


def test_small_wheels_generate_and_run(tmp_path):
    """A 1:10 roller-rig scale wheelset: r0 = 46 mm."""
    text = WHEELSET.read_text().replace("rolling_radius = 0.46", "rolling_radius = 0.046")
    layout = tmp_path / "small.toml"
    layout.write_text(text)
    assert main(["generate", str(layout), "-o", str(tmp_path / "gen")]) == 0
    assert main(["run", str(layout), "--speed", "10", "--distance", "5", "--json"]) == 0


def _same_outcome(a, b) -> bool:
    """Two results of a run alike bit for bit: Runs (every array, the final state), or
    exceptions of one type and message with the same partial run."""
    if isinstance(a, Exception) or isinstance(b, Exception):
        return (
            type(a) is type(b)
            and str(a) == str(b)
            and (getattr(a, "run", None) is None) == (getattr(b, "run", None) is None)
            and (getattr(a, "run", None) is None or _same_outcome(a.run, b.run))
        )
    arrays = ("t", "body_pos", "body_quat", "wheelset_rates")
    return (
        a.speed == b.speed
        and a.timestep == b.timestep
        and all(np.array_equal(getattr(a, name), getattr(b, name)) for name in arrays)
        and (a.final_state is None) == (b.final_state is None)
        and (a.final_state is None or all(np.array_equal(x, y) for x, y in zip(a.final_state, b.final_state)))
    )


def test_many_runs_together_are_each_the_run_alone():
    """simulate_many packs runs eight to a model on two threads; a run that ends gives its
    place to the next of the same vehicle, and half-empty models are packed again with the
    runs going continuing where they were. None of it changes a result: each is the one
    `simulate` gives, bit for bit, or the error it raises (refused, derailed, diverged)."""
    coach, wheelset = load_layout(COACH), load_layout(WHEELSET)
    blown_up = np.zeros(14)
    blown_up[1] = 1e150  # a car-body yaw rate that overflows: diverged, in a pack, then alone
    requests = [Request(coach, speed, 60.0, 0.002) for speed in np.linspace(20.0, 100.0, 21)] + [
        Request(wheelset, 75.0, 200.0, 0.002),
        Request(wheelset, 40.0, 30.0, 0.001, 0.0005),
        Request(coach, 50.0, 20.0, state=(np.zeros(14), blown_up)),
        Request(coach, -1.0, 10.0),
        Request(free_truck([1.8, 0.0, -1.8], primary=5e6), 20.0, 20.0, 0.002),
    ]
    told = {}
    many = simulate_many(requests, threads=2, finished=lambda k, result, seconds: told.setdefault(k, result))
    assert sorted(told) == list(range(len(requests))) and all(told[k] is many[k] for k in told)
    kinds = set()
    for request, result in zip(requests, many):
        try:
            alone = simulate(
                request.layout,
                request.speed,
                request.distance,
                request.initial_lateral,
                request.initial_yaw,
                state=request.state,
            )
        except (ValueError, SimulationError) as e:
            alone = e
        assert _same_outcome(result, alone), request
        kinds.add(type(alone).__name__)
    assert kinds == {"Run", "Derailed", "SimulationError", "ValueError"}


def test_the_batch_queue_holds_only_what_the_threads_can_take_next():
    """A prepared vehicle holds its compiled model: `put` waits while `limit` wait, and a full
    queue of mixed timesteps hands out what it has instead of waiting for more of one."""
    import threading
    from types import SimpleNamespace

    from rail_mj.simulation.batch import _Queue

    queue = _Queue(limit=2)
    a, b = SimpleNamespace(cadence=(0.001, 1)), SimpleNamespace(cadence=(0.002, 1))
    queue.put(0, a)
    queue.put(1, b)
    third = threading.Thread(target=queue.put, args=(2, a), daemon=True)
    third.start()
    third.join(0.3)
    assert third.is_alive()  # waits: two already wait
    assert queue.take(2) == [(0, a)]  # two of a's timestep asked, one there and the queue full
    third.join(5.0)
    assert not third.is_alive()
    queue.close()
    assert queue.take(2) == [(1, b)] and queue.take(2) == [(2, a)] and queue.take(2) == []
