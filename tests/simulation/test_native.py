"""The native creep callback against the Python one, across threads and from an MJCF alone."""

from __future__ import annotations

import ctypes

import mujoco
import numpy as np
import pytest
from conftest import DATA, MODELS, SHIPPED, assert_callbacks_agree
from mujoco import rollout

from rail_mj.layout import load_layout
from rail_mj.simulation import native
from rail_mj.simulation.runner import simulate
from rail_mj.vehicle.mjcf import generate
from rail_mj.vehicle.spec import Vehicle


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_native_and_python_callbacks_give_the_same_forces(layout_path):
    """Random states, on and off the flanges: qfrc_passive agrees to 1e-9 relative (both
    call one compiled law; only the kinematics and J^T are written twice)."""
    assert_callbacks_agree(Vehicle(load_layout(layout_path)), 47.0, seed=7, samples=25, position=0.012, rate=0.3)


def test_native_and_python_runs_follow_the_same_trajectory():
    """The shipped bogie hunting onto its flanges (Polach, flange contact): 1e-9 m apart."""
    layout = load_layout(SHIPPED[0].parent.parent / "bogie" / "bogie.toml")
    a = simulate(layout, 90.0, 60.0, 0.002)
    b = simulate(layout, 90.0, 60.0, 0.002, python_callback=True)
    assert np.max(np.abs(a.y)) > 0.008  # on the flanges
    np.testing.assert_allclose(a.y, b.y, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.psi, b.psi, rtol=0, atol=1e-9)


def test_threads_give_bit_identical_results():
    """Many speeds stepped at once on two threads, each vehicle's speed in its own model:
    every trajectory equals the one-thread result bit for bit."""
    vehicle = Vehicle(load_layout(SHIPPED[0].parent.parent / "manchester-coach" / "manchester-coach.toml"))
    models = []
    for speed in np.linspace(40.0, 100.0, 6):
        model = mujoco.MjModel.from_xml_string(vehicle.spec.to_xml(), vehicle.spec.assets)
        native.set_speed(model, float(speed))
        model.opt.timestep = 5e-4
        models.append(model)
    data = mujoco.MjData(models[0])
    data.qpos[vehicle.root_lateral_dofs] = 0.004
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    start = np.empty(mujoco.mj_stateSize(models[0], spec))
    mujoco.mj_getState(models[0], data, start, spec)
    with native.installed():
        one, _ = rollout.rollout(models, [mujoco.MjData(models[0])], np.tile(start, (6, 1)), nstep=2000)
        two, _ = rollout.rollout(models, [mujoco.MjData(m) for m in models[:2]], np.tile(start, (6, 1)), nstep=2000)
    assert np.array_equal(one, two)
    lateral = one[:, -1, 1 + vehicle.root_lateral_dofs[0]]
    assert len(set(lateral.tolist())) == 6  # the speeds really differ


def test_a_generated_mjcf_alone_runs_natively(tmp_path):
    """The block travels in the MJCF (six significant figures, like every number in it):
    the model read back from the written files gives the same forces."""
    layout = load_layout(SHIPPED[0].parent.parent / "bogie" / "bogie.toml")
    generate(layout, tmp_path)
    loaded = mujoco.MjModel.from_xml_path(str(tmp_path / "bogie.xml"))
    built = Vehicle(layout).model
    np.testing.assert_array_equal(loaded.numeric_data, built.numeric_data)
    for model in (loaded, built):
        native.set_speed(model, 30.0)
    forces = []
    for model in (loaded, built):
        data = mujoco.MjData(model)
        data.qpos[:] = 0.009
        with native.installed():
            mujoco.mj_forward(model, data)
        forces.append(data.qfrc_passive.copy())
    assert np.any(forces[0]) and np.array_equal(forces[0], forces[1])


def test_a_model_without_the_block_is_refused():
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(native.NativeError, match="rail_mj/native"):
        native.set_speed(model, 30.0)


def test_struct_offsets_are_checked_against_the_live_arrays(monkeypatch):
    """Declarations that do not match the installed MuJoCo (here one shifted by a field)
    stop the native callback with a message, before it could read the wrong memory."""
    from mujoco.introspect import structs

    real = native._struct("mjData", structs.STRUCTS)
    shifted = type("mjData", (ctypes.Structure,), {"_fields_": [("extra", ctypes.c_double)] + real._fields_})
    monkeypatch.setitem(native._LAYOUTS, "mjData", shifted)
    with pytest.raises(native.NativeError, match=r"mjData\.qvel is not where"):
        native._offsets()


def test_the_callback_is_kept_in_a_library_named_by_mujocos_offsets_and_loaded_without_numba():
    """The callback's library in the cache folder is named by this MuJoCo's version and struct
    offsets (rail_mj.compiled), needs nothing but libm, and a second process steps a run with
    it, summary and contact forces included, without importing numba."""
    import subprocess
    import sys

    from rail_mj.simulation import native

    assert native.native().kind == "library"
    assert native.library_path().is_file()
    code = (
        "import sys; from rail_mj.layout import load_layout; from rail_mj.simulation import simulate; "
        f"run = simulate(load_layout({str(MODELS / 'bogie' / 'bogie.toml')!r}), 30.0, 50.0); "
        "run.guiding_forces(); from rail_mj.analysis import filters; "
        "filters.sosfiltfilt(filters.butterworth_sos(2, 2.0, 100.0), run.y); "
        "print('numba' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


@pytest.mark.slow  # numba compiles the kernel in the test (10 to 20 s)
def test_the_library_gives_numbas_forces_bit_for_bit():
    """The library's machine code is numba's, compiled for this CPU: the same forces as numba's
    cfunc of the same kernel, to the bit, on a coach displaced and yawing."""
    from rail_mj.layout import load_layout
    from rail_mj.simulation import native
    from rail_mj.vehicle.spec import Vehicle

    vehicle = Vehicle(load_layout(MODELS / "manchester-coach" / "manchester-coach.toml"))
    native.set_speed(vehicle.model, 50.0)
    forces = []
    passive, _ = native._cfuncs(native._offsets())
    for pointer in (native.native().passive, native._PASSIVE(passive.address)):
        data = mujoco.MjData(vehicle.model)
        data.qpos[:] = 0.003 * np.sin(np.arange(vehicle.model.nq) + 1.0)
        data.qvel[:] = 0.05 * np.cos(np.arange(vehicle.model.nv) + 1.0)
        mujoco.set_mjcb_passive(pointer)
        try:
            mujoco.mj_forward(vehicle.model, data)
        finally:
            mujoco.set_mjcb_passive(None)
        forces.append(data.qfrc_passive.copy())
    assert np.any(forces[0] != 0.0)
    np.testing.assert_array_equal(forces[0], forces[1])


def test_a_first_command_on_a_terminal_is_told_it_compiles(tmp_path, monkeypatch):
    from rail_mj.cli.options import compiling_note

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    assert "compiling" in compiling_note()
    (tmp_path / "numba" / "x").mkdir(parents=True)
    (tmp_path / "numba" / "x" / "law.nbi").write_bytes(b"")
    assert compiling_note() is None


@pytest.mark.parametrize(
    "layout_path", [MODELS / "manchester-coach" / "manchester-coach.toml", DATA / "manchester-coach-spatial.toml"]
)
def test_the_curve_cache_changes_no_bit(layout_path):
    """On a curve the callback keeps what the track's geometry gives a vehicle at one station and
    speed in mjData.userdata (rail_mj.numerics.CACHE_KEY): a run with it and the same model without
    room for it (every call computing afresh) follow the same trajectory bit for bit, through the
    transition into the curve (the cache's entries change at every step there) and, after a reset,
    again (a reset clears its key, as it zeroes userdata)."""
    from rail_mj.track import load_track

    track = load_track(MODELS / "tracks" / "curve-600.toml")
    vehicle = Vehicle(load_layout(layout_path), track)
    cached = vehicle.model
    assert cached.nuserdata > 2 * cached.ntendon  # the copies, then the vehicle's cache
    spec = vehicle.spec.copy()
    spec.nuserdata = 0
    afresh = spec.compile()
    native.set_speed(cached, 40.0)
    native.set_speed(afresh, 40.0)
    odometer = cached.joint("odometer")
    trajectories = []
    with native.installed():
        for model in (cached, afresh):
            data = mujoco.MjData(model)
            runs = []
            for _ in range(2):
                mujoco.mj_resetData(model, data)
                data.qpos[vehicle.root_lateral_dofs] = 0.002
                data.qpos[odometer.qposadr[0]] = 180.0  # 20 m before the transition
                data.qvel[odometer.dofadr[0]] = 40.0
                states = []
                for _ in range(10):
                    mujoco.mj_step(model, data, nstep=100)  # 4 m a sample, into the transition
                    states.append(np.concatenate([data.qpos, data.qvel, data.qfrc_passive]))
                runs.append(np.array(states))
            trajectories.append(runs)
    (with_cache, again), (without, _) = trajectories
    assert np.array_equal(with_cache, without)
    assert np.array_equal(with_cache, again)
    assert np.ptp(with_cache[:, vehicle.root_lateral_dofs[0]]) > 1e-4  # the vehicle moved: not a trivial match


def test_the_guiding_sensors_numbers_are_mujocos():
    """The callback finds the clock and guiding sensors by MuJoCo's numbers for their types."""
    from rail_mj.numerics import SENSOR_CLOCK, SENSOR_USER

    assert (int(mujoco.mjtSensor.mjSENS_CLOCK), int(mujoco.mjtSensor.mjSENS_USER)) == (SENSOR_CLOCK, SENSOR_USER)


@pytest.mark.parametrize(
    "name,speed",
    [
        ("manchester-coach", 60.0),  # the flat twin, creep alone
        ("manchester-coach", 100.0),  # hunting onto the flanges
        ("manchester-coach-s1002", 70.0),  # profiles
        ("manchester-coach-spatial", 60.0),  # a spatial vehicle: its wheel loads from its suspension
    ],
)
def test_the_recorded_guiding_forces_are_the_laws_at_each_sample(name, speed):
    """A natively stepped run keeps each wheelset's Sigma Y as the callback applied it at the
    state each step starts from (rail_mj.numerics.GUIDING_SENSOR): the law evaluated again from
    the run's record gives the same at every sample, the first included, to 2e-15 of the largest
    (round-off: the record's yaw is its quaternion's, the callback's its rotation matrix's). The
    Python callback records none: its runs evaluate the law again."""
    from rail_mj.layout import load_layout
    from rail_mj.simulation import simulate

    layout = load_layout(MODELS / name / f"{name}.toml")
    run = simulate(layout, speed, 300.0)
    assert run.guiding is not None and run.guiding.shape == run.y.shape
    again = run.contact_forces().lateral
    scale = np.max(np.abs(again))
    assert scale > 1e3
    np.testing.assert_allclose(run.guiding, again, rtol=0, atol=2e-15 * scale)
    assert np.array_equal(run.guiding_forces(), run.guiding)
    slow = simulate(layout, speed, 20.0, python_callback=True)
    assert slow.guiding is None
    np.testing.assert_allclose(slow.guiding_forces(), run.guiding[: len(slow.t)], rtol=0, atol=1e-9 * scale)


@pytest.mark.parametrize("name", ["manchester-coach", "two-coaches", "manchester-coach-spatial"])
def test_a_yaw_summed_from_the_hinges_is_the_rotations(name, monkeypatch):
    """Where every hinge between a wheelset and the world turns it about z (a planar vehicle's,
    nested or flat), the callback reads its yaw as their angles' sum (YAW_HINGE), not atan2 of its
    rotation: the forces agree with atan2's to 1e-13 of the largest at random states, a wheelset
    spun past pi (atan2's range, kept) included. The flags change nowhere else in the block."""
    from conftest import passive_forces

    from rail_mj.vehicle import block, spec

    layout = load_layout(MODELS / name / f"{name}.toml")
    try:
        spec._compiled_once.cache_clear()
        vehicles = [Vehicle(layout), Vehicle(layout).stepped]
        monkeypatch.setattr(block, "YAW_HINGE", block.HINGE)  # every hinge flagged a plain hinge
        spec._compiled_once.cache_clear()
        spec._flat_twin.cache_clear()
        plain = [Vehicle(layout), Vehicle(layout).stepped]
    finally:
        monkeypatch.undo()
        spec._compiled_once.cache_clear()
        spec._flat_twin.cache_clear()
    rng = np.random.default_rng(3)
    for summed, turned in zip(vehicles, plain, strict=True):
        a, b = summed.model.numeric_data, turned.model.numeric_data
        changed = np.flatnonzero(a != b)
        assert np.all(a[changed] == 2.0) and np.all(b[changed] == 1.0)
        yaw = [summed.model.joint(f"{w}_yaw").qposadr[0] for w in summed.wheelset_names]
        chains = [block.joint_chain(summed.model, int(b)) for b in summed.wheelset_ids]
        assert len(changed) == sum(c[2::3].count(2.0) for c in chains) >= len(yaw)  # their hinges, nothing else
        for model in (summed.model, turned.model):
            native.set_speed(model, 47.0)
        for k in range(10):
            qpos = rng.normal(scale=0.01, size=summed.model.nq)
            qvel = rng.normal(scale=0.3, size=summed.model.nv)
            if k == 0:
                qpos[yaw[0]] = 3.5  # spun round: past pi
            forces = [passive_forces(v.model, native.callback(), qpos, qvel) for v in (summed, turned)]
            scale = np.max(np.abs(forces[1]))
            assert scale > 0
            np.testing.assert_allclose(forces[0], forces[1], rtol=0, atol=1e-13 * scale)


_CHAIN_XML = """<mujoco><worldbody>{before}
  <body name="parent" pos="1 0.5 0.4" {parent}><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
    <joint name="lateral" type="slide" axis="0 1 0"/>{parent_hinge}
    <body name="wheelset" pos="0.3 0 0.1" {own}><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>
      <joint name="slide" type="slide" axis="0 1 0"/>{own_hinge}
    </body>
  </body></worldbody></mujoco>"""
_Z = '<joint name="{}" type="hinge" axis="0 0 1" pos="0.2 -0.1 0"/>'
_TURNED = 'quat="0.9961946980917455 0 0 0.08715574274765817"'  # 10 degrees about z


@pytest.mark.parametrize(
    "case, parts, summed",
    [
        ("hinges about z", {"parent_hinge": _Z.format("p"), "own_hinge": _Z.format("w")}, True),
        (
            "a parent built turned",
            {"parent": _TURNED, "parent_hinge": _Z.format("p"), "own_hinge": _Z.format("w")},
            False,
        ),
        ("a hinge about x", {"parent_hinge": '<joint type="hinge" axis="1 0 0"/>', "own_hinge": _Z.format("w")}, False),
        ("a reference angle", {"own_hinge": '<joint type="hinge" axis="0 0 1" ref="0.2"/>'}, False),
        (
            "a ball joint before (qpos and dof addresses differ)",
            {
                "before": '<body><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/><joint type="ball"/></body>',
                "own_hinge": _Z.format("w"),
            },
            False,
        ),
        ("slides alone on a body built turned", {"own": _TURNED}, False),
    ],
)
def test_the_callbacks_yaw_is_the_hinges_sum_only_where_they_all_turn_the_body_about_z(case, parts, summed):
    """joint_chain flags a chain's hinges YAW_HINGE only where every body on it is square to its
    parent, every hinge turns about z from a reference of 0 and its qpos is its dof; the callback's
    yaw of the body (kernel._wheelset_motion) is then their angles' sum, else atan2 of its rotation,
    which is what a body built turned, or one on slides alone, needs. Either way its yaw, lateral
    velocity and yaw rate are MuJoCo's own kinematics, to round-off (1e-15 of their size)."""
    from rail_mj.numerics import YAW_HINGE
    from rail_mj.simulation.kernel import _wheelset_motion
    from rail_mj.vehicle.block import joint_chain

    values = {"before": "", "parent": "", "parent_hinge": "", "own": "", "own_hinge": "", **parts}
    model = mujoco.MjModel.from_xml_string(_CHAIN_XML.format(**values))
    body = model.body("wheelset").id
    chain = np.asarray(joint_chain(model, body), dtype=np.float64)
    flags = chain[2::3]
    hinges = [int(model.jnt_type[int(j)]) == mujoco.mjtJoint.mjJNT_HINGE for j in chain[0::3]]
    assert all((f == YAW_HINGE) == (summed and h) for f, h in zip(flags, hinges, strict=True)), case
    data = mujoco.MjData(model)
    rng = np.random.default_rng(11)
    velocity, matrix = np.zeros(6), np.zeros(9)
    for _ in range(5):
        data.qpos[:] = model.qpos0 + rng.normal(scale=0.3, size=model.nq)
        data.qvel[:] = rng.normal(scale=0.5, size=model.nv)
        mujoco.mj_normalizeQuat(model, data.qpos)
        mujoco.mj_forward(model, data)
        psi, vy, wz = _wheelset_motion(
            chain, len(chain) // 3, data.qpos, data.qvel, data.xpos.ravel(), data.xmat.ravel(),
            data.xanchor.ravel(), data.xaxis.ravel(), body,
        )  # fmt: skip
        mujoco.mju_quat2Mat(matrix, data.xquat[body])
        assert abs(psi - np.arctan2(matrix[3], matrix[0])) <= 1e-15 * max(1.0, abs(psi)), case
        mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_XBODY, body, velocity, 0)
        np.testing.assert_allclose((vy, wz), (velocity[4], velocity[2]), rtol=0, atol=1e-15 * np.abs(velocity).max())
