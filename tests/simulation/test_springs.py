"""The block's springs: a flat train on straight track is stepped without its tendons, its
suspension summed in the native callback (rail_mj.vehicle.block.spring_rows), and so is a nested
planar vehicle's flat twin (rail_mj.vehicle.spec.Vehicle.stepped)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import DATA, MODELS, passive_forces

from rail_mj.layout import load_layout
from rail_mj.simulation import native
from rail_mj.simulation.run import Request, Run
from rail_mj.simulation.runner import prepare, simulate
from rail_mj.simulation.stepping import Pack, Running, _undamped
from rail_mj.track import load_track
from rail_mj.vehicle import block
from rail_mj.vehicle.block import NativeError
from rail_mj.vehicle.spec import Vehicle

TRAIN = MODELS / "two-coaches" / "two-coaches.toml"


def _stepped(layout, speed: float) -> Pack:
    return Pack([Running(0, prepare(Request(layout, speed, 100.0, 0.002)))], alone=True)


def test_a_train_is_stepped_without_tendons_and_feels_the_same_forces():
    """At random states the stepped model's qfrc_passive (creep forces and the block's springs,
    all from the callback) is the train's own model's (MuJoCo's tendon springs and dampers
    plus the callback's creep forces) to 1e-12 of its largest entry: one formula, -k L - c dL/dt
    with L the tendon's sum of coefficients times coordinates, summed in another order."""
    layout = load_layout(TRAIN)
    own = Vehicle(layout)
    pack = _stepped(layout, 47.0)
    stepped = pack.model
    assert own.model.ntendon > 0 and stepped.ntendon == 0 and stepped.nv == own.model.nv
    native.set_speed(own.model, 47.0)
    rng = np.random.default_rng(3)
    for _ in range(10):
        qpos, qvel = rng.normal(scale=0.005, size=own.model.nq), rng.normal(scale=0.1, size=own.model.nv)
        reference = passive_forces(own.model, native.callback(), qpos, qvel)
        mine = np.zeros(stepped.nv)
        mine[pack.places[0].qvel] = passive_forces(stepped, native.callback(), qpos, qvel)[pack.places[0].qvel]
        scale = np.max(np.abs(reference))
        assert scale > 0
        np.testing.assert_allclose(mine, reference, rtol=0, atol=1e-12 * scale)


def test_a_train_run_follows_its_tendon_model_to_round_off(monkeypatch):
    """The two coaches at 60 m/s over 300 m from the 2 mm start, stepped with the springs in the
    callback and (the property turned off) with MuJoCo's tendons: the same trajectory to
    1e-15 m (round-off of sums taken in another order; 1.2e-18 m measured over 1 km)."""
    layout = load_layout(TRAIN)
    fast = simulate(layout, 60.0, 300.0)
    monkeypatch.setattr(Vehicle, "springs_in_callback", property(lambda self: False))
    slow = simulate(layout, 60.0, 300.0)
    assert np.max(np.abs(fast.y)) > 1e-4  # it moves
    np.testing.assert_allclose(fast.y, slow.y, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fast.psi, slow.psi, rtol=0, atol=1e-15)


def test_only_a_train_on_straight_track_leaves_its_springs_to_the_callback():
    """A nested planar vehicle has no tendons to leave (its flat twin, which steps it, does:
    below); a spatial one's carry its wheel loads and bump stops, read by MuJoCo's sensors: it
    keeps its own model's form. On a curve a train's tendons stay too (its curve stages read them)."""
    assert Vehicle(load_layout(TRAIN)).springs_in_callback
    assert not Vehicle(load_layout(TRAIN), load_track(MODELS / "tracks" / "curve-600.toml")).springs_in_callback
    for name in ("manchester-coach", "manchester-coach-spatial"):
        assert not Vehicle(load_layout(MODELS / name / f"{name}.toml")).springs_in_callback


def _one_tendon(springlength: float = 0.0, **settings) -> mujoco.MjModel:
    """A body on a slide with a tendon t on it: a spring of 1 N/m at `springlength`, `settings`
    set on the tendon."""
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="b")
    body.add_joint(name="j", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0])
    body.add_geom(size=[0.1, 0, 0])
    tendon = spec.add_tendon(name="t", stiffness=[1.0, 0, 0], springlength=[springlength, springlength])
    tendon.wrap_joint("j", 1.0)
    for name, value in settings.items():
        setattr(tendon, name, value)
    return spec.compile()


def test_a_tendon_that_is_not_a_centred_linear_spring_is_refused():
    """spring_rows reads a tendon as -k L - c dL/dt about L = 0: a spring length elsewhere (or a
    deadband) would be another force, so it is refused by name, not summed wrongly."""
    model = _one_tendon(0.1)
    with pytest.raises(NativeError, match="tendon t: not centred"):
        block.spring_rows(model, model)
    model = _one_tendon()
    assert block.spring_rows(model, model) == [(1.0, 0.0, [(0, 1.0)])]


@pytest.mark.parametrize(
    ("settings", "what"),
    [
        ({"limited": mujoco.mjtLimited.mjLIMITED_TRUE, "range": [-0.1, 0.1]}, "limited"),
        ({"frictionloss": 0.5}, "friction loss"),
        ({"armature": 0.5}, "armature"),
    ],
)
def test_a_tendon_that_makes_a_constraint_or_inertia_is_refused(settings, what):
    """A limited or friction-loss tendon is a constraint and a tendon's armature an inertia: the
    stepped model, without tendons and with its constraint stages off, would drop them."""
    model = _one_tendon(**settings)
    with pytest.raises(NativeError, match=f"tendon t: {what}, not a block spring"):
        block.spring_rows(model, model)


NESTED = ("manchester-coach", "bogie", "wagon")  # a car body on bogies; a bogie; wheelsets hung from a car body


def _layout(name: str):
    """A shipped layout, or "uneven": the coach with its bogies and axles placed unevenly (no
    fore-and-aft symmetry, which would hide a wrong sign of an arm behind swapped wheelsets)."""
    if name != "uneven":
        return load_layout(MODELS / name / f"{name}.toml")
    import tomllib

    from rail_mj.layout.reader import layout_from_dict

    data = tomllib.loads((MODELS / "manchester-coach" / "manchester-coach.toml").read_text())
    data["carbody"]["bogie_positions"] = [10.5, -8.0]
    data["bogie"]["wheelset_positions"] = [1.5, -1.1]
    return layout_from_dict(data, source="uneven coach")


@pytest.mark.parametrize("name", (*NESTED, "uneven"))
def test_a_nested_planar_vehicle_steps_as_its_flat_twin(name):
    """Its own model (the MJCF) stays nested; what steps is a twin with the same bodies and joints,
    in the same order, each body on the world, the suspension summed in the callback. The twin's
    kinematics is the nested one linearised, so the vehicle linearised about the centred state is
    the same system in other coordinates: the same eigenvalues, to round-off of the two
    eigen-solutions (1e-9 of the largest)."""
    layout = _layout(name)
    vehicle = Vehicle(layout)
    twin = vehicle.stepped
    own = vehicle.model
    assert twin is not vehicle and twin.springs_in_callback and not vehicle.springs_in_callback
    assert np.any(own.body_parentid[vehicle.wheelset_ids] != 0)  # nested
    assert np.all(twin.model.body_parentid[1:] == 0)  # flat
    assert [own.joint(j).name for j in range(own.njnt)] == [twin.model.joint(j).name for j in range(own.njnt)]
    assert [own.body(b).name for b in range(own.nbody)] == [twin.model.body(b).name for b in range(own.nbody)]
    from rail_mj.simulation.linear import state_matrix

    for v in (vehicle, twin):
        native.set_speed(v.model, 50.0)
    nested, flat = (np.sort_complex(np.linalg.eigvals(state_matrix(v.model))) for v in (vehicle, twin))
    np.testing.assert_allclose(flat, nested, rtol=0, atol=1e-9 * np.max(np.abs(nested)))


@pytest.mark.parametrize("name", (*NESTED, "uneven"))
def test_states_pass_between_the_forms_as_the_nested_kinematics_says(name):
    """`to_stepped` gives each body's absolute lateral position and yaw, as MuJoCo's kinematics of
    the nested model places it, to second order in the coordinates (a*psi^2/2 with a the
    largest arm, 9.5 m: under 1e-8 m at 1e-5); `from_stepped` undoes it to round-off."""
    vehicle = Vehicle(_layout(name))
    own, twin = vehicle.model, vehicle.stepped.model
    rng = np.random.default_rng(5)
    qpos, qvel = rng.normal(scale=1e-5, size=own.nq), rng.normal(scale=1e-3, size=own.nv)
    flat_qpos, flat_qvel = vehicle.to_stepped((qpos, qvel))
    back = vehicle.from_stepped((flat_qpos, flat_qvel))
    np.testing.assert_allclose(back[0], qpos, rtol=0, atol=1e-13 * np.max(np.abs(qpos)))
    np.testing.assert_allclose(back[1], qvel, rtol=0, atol=1e-13 * np.max(np.abs(qvel)))
    data = mujoco.MjData(own)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(own, data)
    for j in range(twin.njnt):
        body = int(own.jnt_bodyid[j])
        if own.joint(j).name.endswith("_lateral"):
            placed = data.xpos[body, 1]
        else:
            placed = np.arctan2(data.xmat[body, 3], data.xmat[body, 0])
        assert abs(flat_qpos[j] - placed) < 1e-8


def test_a_run_continued_from_its_final_state_goes_on_as_one_run():
    """A run's final_state is its own (nested) vehicle's coordinates, converted from the twin that
    stepped; continued from it, the coach follows the one long run to round-off."""
    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    whole = simulate(layout, 60.0, 120.0)
    first = simulate(layout, 60.0, 60.0)
    assert len(first.final_state[0]) == Vehicle(layout).model.nq
    rest = simulate(layout, 60.0, 60.0, state=first.final_state)
    k = len(first.t) - 1  # the continued run's first sample is the first run's last
    n = min(len(rest.t), len(whole.t) - k)
    assert np.max(np.abs(whole.y[k : k + n])) > 1e-4  # still moving
    np.testing.assert_allclose(rest.y[:n], whole.y[k : k + n], rtol=0, atol=1e-15)


def test_a_run_s_final_state_is_in_its_own_nested_coordinates():
    """The coach after 60 m at 60 m/s (still moving: its state about 1e-4): its final_state is the
    nested model's, the one the same run on a straight track file (which steps the nested model)
    ends in, to the two forms' difference (7e-11 measured), not the twin's absolute coordinates,
    which differ from them by the state's own size."""
    from rail_mj.track import Track

    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    flat = simulate(layout, 60.0, 60.0)
    nested = simulate(layout, 60.0, 60.0, track=Track.straight(200.0))
    model = nested.vehicle.model
    own = flat.vehicle.model
    columns = [model.joint(own.joint(j).name).qposadr[0] for j in range(own.njnt)]
    qpos = nested.final_state[0][columns]
    assert np.max(np.abs(qpos)) > 1e-5
    assert np.max(np.abs(Vehicle(layout).to_stepped((qpos, qpos))[0] - qpos)) > 1e-5  # the forms differ
    np.testing.assert_allclose(flat.final_state[0], qpos, rtol=0, atol=1e-9)


def test_mujocos_damper_stage_is_skipped_only_where_it_has_nothing_to_add():
    """A flat twin (its dampers the callback's) is stepped with mjDSBL_DAMPER, the nested model
    (its dampers MuJoCo's, on its joints) without; and skipping the stage changes no bit: the coach's
    twin stepped 2000 steps from the 2 mm start with the flag and without it, states equal, and
    the callback (which MuJoCo's passive stage skips when springs are off too) at work."""
    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    damper = int(mujoco.mjtDisableBit.mjDSBL_DAMPER)
    flat = _stepped(layout, 60.0)
    assert flat.model.opt.disableflags & damper
    nested = Vehicle(layout).model
    assert np.any(nested.dof_damping) and not _undamped(nested)
    states = []
    for flags in (flat.model.opt.disableflags, flat.model.opt.disableflags & ~damper):
        flat.model.opt.disableflags = flags
        data = mujoco.MjData(flat.model)
        mujoco.mj_setState(flat.model, data, flat.state, flat.STATE)
        with native.installed():
            mujoco.mj_step(flat.model, data, nstep=2000)
        states.append(np.concatenate([data.qpos, data.qvel]))
    # From 2 mm down to 3e-5 m in 2 s: the callback's creep damping and springs acted (without
    # them nothing pulls the bodies back).
    assert 0.0 < np.max(np.abs(states[0][: flat.model.nq])) < 1e-4
    assert np.array_equal(states[0], states[1])


@pytest.mark.parametrize("name", NESTED)
def test_a_flat_twins_record_read_from_its_state_is_mujocos_kinematics(name):
    """A flat twin has no sensors: each sample's poses and wheelset rates are read from its state
    (JointSensors). At random states they are MuJoCo's own kinematics of the twin: every body's
    xpos, exactly (its place at rest plus its slide); its xquat to 1 ulp (MuJoCo normalises the
    hinge's turn); each wheelset's lateral velocity and yaw rate, its frame sensors' quantities
    (mj_objectVelocity in the world frame), to 1e-15 of their size."""
    layout = load_layout(MODELS / name / f"{name}.toml")
    twin = Vehicle(layout).stepped
    model = twin.model
    assert twin.flat and model.nsensor == 0 and twin.sensors.from_state
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    states = np.zeros((5, mujoco.mj_stateSize(model, Pack.STATE)))
    n = model.nbody
    pos = np.zeros((5, n, 3))
    rates = np.zeros((5, twin.n_wheelsets, 2))
    for k in range(5):
        data.qpos[:] = rng.normal(scale=0.01, size=model.nq)
        data.qvel[:] = rng.normal(scale=0.1, size=model.nv)
        mujoco.mj_getState(model, data, states[k], Pack.STATE)
    yaw = np.zeros((5, n))  # as a record starts: the world's column marked, to be left as it is
    yaw[:, 0] = np.nan
    twin.sensors.poses(states, pos, yaw)
    yaw[:, 0] = 0.0  # the world's, as a record starts
    # The quaternions a Run of these samples makes of them (Run.body_quat, from body_yaw).
    quat = Run(twin, 30.0, 1e-3, np.arange(5.0), pos, None, rates, body_yaw=yaw).body_quat
    yaw[:, 0] = np.nan
    twin.sensors.rates(states, rates)
    velocity, matrix = np.zeros(6), np.zeros(9)
    for k in range(5):
        mujoco.mj_setState(model, data, states[k], Pack.STATE)
        mujoco.mj_forward(model, data)
        assert np.array_equal(pos[k], data.xpos)
        np.testing.assert_allclose(quat[k], data.xquat, rtol=0, atol=2.3e-16)
        # Each body's yaw angle (Run.body_yaw, what psi reads): its orientation's, to an ulp of the
        # largest (rad, ~0.03 here), 0 for any body without a yaw joint; the world's left as it was.
        for b in range(1, n):
            mujoco.mju_quat2Mat(matrix, data.xquat[b])
            assert abs(yaw[k, b] - np.arctan2(matrix[3], matrix[0])) <= 4 * np.spacing(0.05)
        assert np.isnan(yaw[k, 0])
        for i, body in enumerate(twin.wheelset_ids):
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, body, velocity, 0)
            expected = (velocity[4], velocity[2])
            np.testing.assert_allclose(rates[k, i], expected, rtol=1e-15, atol=1e-15 * np.max(np.abs(expected)))


def test_vehicles_with_and_without_gravity_are_never_packed_together():
    """A packed model has one gravity: a spatial coach with gravity and the same coach without it,
    in one batch in either order, each come out as `simulate` steps it on its own, to the bit."""
    import dataclasses

    from rail_mj.simulation.batch import simulate_many

    with_gravity = load_layout(DATA / "manchester-coach-spatial.toml")
    spatial = dataclasses.replace(with_gravity.spatial, gravity=False, gravitational_stiffness=False, gyroscopic=False)
    without = dataclasses.replace(with_gravity, spatial=spatial)
    for first, second in ((without, with_gravity), (with_gravity, without)):
        runs = simulate_many([Request(first, 30.0, 60.0, 0.002), Request(second, 30.0, 40.0, 0.002)])
        for layout, run, distance in zip((first, second), runs, (60.0, 40.0), strict=True):
            assert np.array_equal(run.body_pos, simulate(layout, 30.0, distance, initial_lateral=0.002).body_pos)
