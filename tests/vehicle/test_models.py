"""Generated models: every shipped and generated model loads and steps without a
MuJoCo warning, generation is deterministic, and models/ is up to date."""

from __future__ import annotations

import sys

import mujoco
import numpy as np
import pytest
from conftest import MODELS, ROOT, SHIPPED, free_truck

from rail_mj.layout import layout_from_dict, load_layout
from rail_mj.simulation.callback import CreepForces, installed
from rail_mj.vehicle.mjcf import generate, generated_files
from rail_mj.vehicle.spec import Vehicle

sys.path.insert(0, str(ROOT / "tools"))
import regenerate_models


def step_without_warnings(model: mujoco.MjModel, n_wheelsets: int, speed=30.0, steps=2000):
    data = mujoco.MjData(model)
    data.qpos[:] = 0.001  # every joint disturbed: all springs and creep forces act
    forces = CreepForces(model, [f"wheelset{i + 1}" for i in range(n_wheelsets)], speed)
    model.opt.timestep = 2e-4
    with installed(forces):
        mujoco.mj_step(model, data, nstep=steps)
    assert [w.number for w in data.warning] == [0] * len(data.warning)
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    assert np.max(np.abs(data.qpos)) < 0.05  # stable at 30 m/s: nothing ran away


def test_the_shipped_layouts_are_there():
    assert {p.stem for p in SHIPPED} == {
        "wheelset",
        "bogie",
        "wagon",
        "manchester-coach",
        "manchester-coach-s1002",
        "manchester-coach-worn",
        "manchester-coach-spatial",
        "articulated-set",
        "two-coaches",
    }


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_model_files_load_and_step(layout_path):
    layout = load_layout(layout_path)
    for xml in (layout_path.parent / f"{layout.name}.xml", layout_path.parent / "scene.xml"):
        model = mujoco.MjModel.from_xml_path(str(xml))
        step_without_warnings(model, layout.n_wheelsets)


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_models_folder_is_up_to_date(layout_path):
    # Regenerate with: python tools/regenerate_models.py
    assert regenerate_models.stale_files(layout_path) == []


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_generation_is_deterministic_and_matches_the_in_memory_model(layout_path, tmp_path):
    layout = load_layout(layout_path)
    generate(layout, tmp_path / "a")
    generate(layout, tmp_path / "b")
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    assert files and all((tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes() for f in files)
    # The written MJCF is the same model the runner compiles in memory.
    written = mujoco.MjModel.from_xml_path(str(tmp_path / "a" / f"{layout.name}.xml"))
    memory = Vehicle(layout).model
    for field in (
        "body_mass",
        "body_inertia",
        "body_pos",
        "body_ipos",
        "jnt_stiffness",
        "dof_damping",
        "jnt_type",
        "jnt_axis",
        "numeric_data",
    ):
        np.testing.assert_array_equal(getattr(written, field), getattr(memory, field), err_msg=field)


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_vehicles_of_one_layout_are_compiled_once_and_each_owns_its_model(layout_path):
    from rail_mj.vehicle import spec
    from rail_mj.vehicle.block import set_speed

    layout = load_layout(layout_path)
    spec._compiled_once.cache_clear()
    first, second = Vehicle(layout), Vehicle(layout)
    assert spec._compiled_once.cache_info()[:2] == (1, 1)  # (hits, misses): one compile for both
    assert first.model is not second.model and first.spec is not second.spec
    fresh_spec, fresh = spec.compiled(layout)
    set_speed(first.model, 42.0)
    first.model.opt.timestep = 0.5
    first.spec.option.timestep = 0.5
    for field in ("numeric_data", "body_mass", "body_pos", "jnt_axis", "tendon_stiffness", "sensor_type"):
        np.testing.assert_array_equal(getattr(second.model, field), getattr(fresh, field), err_msg=field)
    assert not np.array_equal(first.model.numeric_data, fresh.numeric_data)  # set_speed wrote only its own
    assert second.spec.to_xml() == fresh_spec.to_xml()
    third = Vehicle(layout)  # after the first's were changed: still the compiled layout's
    assert third.model.opt.timestep == fresh.opt.timestep != 0.5
    assert third.spec.option.timestep == fresh_spec.option.timestep
    np.testing.assert_array_equal(third.model.numeric_data, fresh.numeric_data)


def test_every_element_is_named():
    model = Vehicle(load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")).model
    for kind, count in (
        (mujoco.mjtObj.mjOBJ_BODY, model.nbody),
        (mujoco.mjtObj.mjOBJ_JOINT, model.njnt),
        (mujoco.mjtObj.mjOBJ_GEOM, model.ngeom),
        (mujoco.mjtObj.mjOBJ_MESH, model.nmesh),
    ):
        start = 1 if kind == mujoco.mjtObj.mjOBJ_BODY else 0  # the world body is unnamed
        assert all(mujoco.mj_id2name(model, kind, i) for i in range(start, count)), kind


def test_suspension_is_in_the_mjcf():
    """Primary and secondary springs and dampers are joint stiffness and damping."""
    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    model = Vehicle(layout).model
    j = model.joint("wheelset3_yaw")
    assert j.stiffness[0] == layout.primary.yaw_stiffness
    assert model.joint("bogie2_lateral").stiffness[0] == layout.secondary.lateral_stiffness
    assert model.dof_damping[model.joint("bogie1_lateral").dofadr[0]] == layout.secondary.lateral_damping
    assert model.dof_damping[model.joint("wheelset1_lateral").dofadr[0]] == layout.primary.lateral_damping


def test_three_axle_bogie_generates_and_steps(tmp_path):
    layout = free_truck([1.8, 0.0, -1.8], primary=5e6)
    files = generated_files(layout)
    assert set(files) >= {"free-truck.xml", "scene.xml"}
    generate(layout, tmp_path)
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "scene.xml"))
    assert model.nv == 2 + 3 * 2
    step_without_warnings(model, 3)


def test_wheelset_bodies_sit_where_the_layout_puts_them():
    layout = layout_from_dict(
        {
            "name": "two-bogies",
            "wheelset": {
                "mass": 1500.0,
                "inertia": [900.0, 100.0, 900.0],
                "rolling_radius": 0.45,
                "contact_half_spacing": 0.75,
                "conicity": 0.1,
            },
            "creep": {"f11": 8e6, "f22": 7e6},
            "primary": {"lateral_stiffness": 5e6, "yaw_stiffness": 20e6},
            "bogie": {"mass": 2000.0, "inertia": [1500.0, 1400.0, 2500.0], "wheelset_positions": [1.2, 0.0, -1.2]},
            "secondary": {"lateral_stiffness": 3e5, "yaw_stiffness": 3e5},
            "carbody": {"mass": 40000.0, "inertia": [6e4, 2e6, 2e6], "bogie_positions": [8.0, -8.0]},
        }
    )
    vehicle = Vehicle(layout)
    data = mujoco.MjData(vehicle.model)
    mujoco.mj_kinematics(vehicle.model, data)
    np.testing.assert_allclose(data.xpos[vehicle.wheelset_ids, 0], [9.2, 8.0, 6.8, -6.8, -8.0, -9.2])
    np.testing.assert_allclose(data.xpos[vehicle.wheelset_ids, 2], 0.45)


def _world_box(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest corner of a geom's bounding box in the world."""
    g = model.geom(name).id
    centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)])
    corners = data.geom_xpos[g] + (centre + signs * half) @ data.geom_xmat[g].reshape(3, 3).T
    return corners.min(axis=0), corners.max(axis=0)


def test_the_coach_is_drawn_as_a_coach_on_outside_frame_bogies():
    """Side frames outside the wheels, the body over everything under it, a coach's outline,
    and no drawn part that collides or weighs anything."""
    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    model = Vehicle(layout).model
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    _wheel_low, wheel_high = _world_box(model, data, "wheelset1_left_wheel")
    frame_low, frame_high = _world_box(model, data, "bogie1_side_left")
    assert frame_low[1] > wheel_high[1]  # the frame's inner face clears the wheel
    # ... and reaches over both wheelsets, end to end.
    assert frame_high[0] >= wheel_high[0] - 1e-3
    assert frame_low[0] <= _world_box(model, data, "wheelset2_left_wheel")[0][0] + 1e-3
    carbody = model.body("carbody").id
    boxes = {model.geom(g).name: _world_box(model, data, model.geom(g).name) for g in range(model.ngeom)}
    body = [boxes[model.geom(g).name] for g in range(model.ngeom) if model.geom_bodyid[g] == carbody]
    low, high = np.min([lo for lo, _ in body], axis=0), np.max([hi for _, hi in body], axis=0)
    under = max(boxes[model.geom(g).name][1][2] for g in range(model.ngeom) if model.geom_bodyid[g] != carbody)
    assert low[2] == pytest.approx(under)  # the secondary springs reach up to the underframe
    np.testing.assert_allclose(high - low, [19.0 + 2 * 2.75 + 0.04, 2.8 + 0.04, 3.9 - low[2]])
    assert 1.0 < low[2] < 1.3 and high[2] == pytest.approx(3.9)
    assert not model.geom_contype.any() and not model.geom_conaffinity.any()
    np.testing.assert_array_equal(
        model.body_mass[1:], [layout.carbody.mass] + ([layout.bogie.mass] + [layout.wheelset.mass] * 2) * 2
    )


def test_a_layout_with_contact_writes_an_mjcf_that_reads_back(tmp_path):
    """[contact] puts the Hertz ellipse and the shear modulus in the model (the fastsim
    law): the written MJCF still reads back to the model in memory, every number (MuJoCo's
    writer drops entries below 1e-12 of a numeric's largest; generate refuses to lose any)."""
    import tomllib

    from rail_mj.layout import layout_from_dict

    data = tomllib.loads((MODELS / "manchester-coach" / "manchester-coach.toml").read_text())
    for key in ("f11", "f22", "f23", "f33"):
        data["creep"].pop(key)
    data["creep"]["law"] = "fastsim"
    data["contact"] = {"young_modulus": 210e9, "poisson_ratio": 0.28, "rail_transverse_radius": 0.3}
    layout = layout_from_dict(data, "coach-with-contact")
    generate(layout, tmp_path)
    written = mujoco.MjModel.from_xml_path(str(tmp_path / f"{layout.name}.xml"))
    np.testing.assert_array_equal(written.numeric_data, Vehicle(layout).model.numeric_data)
    assert written.numeric("rail_mj/wheel").data[3] == 0.008  # the flangeway clearance survives
