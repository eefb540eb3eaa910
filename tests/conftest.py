"""Shared layouts and paths for the tests."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from rail_mj.layout import layout_from_dict

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
DATA = ROOT / "tests" / "data"  # layouts and profile files of the tests alone
SHIPPED = sorted(p for p in MODELS.glob("*/*.toml") if p.stem == p.parent.name)
# Shipped models on coned wheels (the others have [profiles]).
CONED = [p for p in SHIPPED if "[profiles]" not in p.read_text()]

# Manchester benchmark wheelset (docs/manchester-coach.md).
WHEELSET = {
    "mass": 1813.0,
    "inertia": [1120.0, 112.0, 1120.0],
    "rolling_radius": 0.46,
    "contact_half_spacing": 0.75,
    "conicity": 0.15,
}
BOGIE_FRAME = {"mass": 2615.0, "inertia": [1722.0, 1476.0, 3067.0]}


# The [profiles] table of the standard track: new S1002 on 60E1 at 1:40, 1435/1360.
PROFILES_TOML = """
[profiles]
wheel = "s1002"
rail = "60e1"
rail_inclination = 0.025
track_gauge = 1.435
flange_back_spacing = 1.360
"""


def linear_text(name: str) -> str:
    """A shipped layout's TOML with linear creep and no flange contact: the classical model."""
    lines = (MODELS / name / f"{name}.toml").read_text().splitlines(keepends=True)
    drop = ("law =", "friction =", "[flange]", "wheel_load =")
    return "".join(line for line in lines if not line.startswith(drop))


def free_wheelset(r0: float, b: float, lam: float, f11=10e6, f22=9e6):
    """One wheelset with no suspension at all, under a body held over the centreline."""
    return layout_from_dict(
        {
            "name": "free-wheelset",
            "wheelset": {**WHEELSET, "rolling_radius": r0, "contact_half_spacing": b, "conicity": lam},
            "creep": {"f11": f11, "f22": f22},
            "primary": {"lateral_stiffness": 0.0, "yaw_stiffness": 0.0},
            "carbody": {"fixed": True, "wheelset_positions": [0.0]},
        }
    )


def free_truck(positions, lam=0.15, f11=10e6, f22=9e6, primary=1e9):
    """A bogie frame with (very stiff) primary suspension and no secondary stiffness."""
    return layout_from_dict(
        {
            "name": "free-truck",
            "wheelset": {**WHEELSET, "conicity": lam},
            "creep": {"f11": f11, "f22": f22},
            "primary": {"lateral_stiffness": primary, "yaw_stiffness": primary},
            "bogie": {**BOGIE_FRAME, "wheelset_positions": list(positions)},
            "secondary": {"lateral_stiffness": 0.0, "yaw_stiffness": 0.0},
            "carbody": {"fixed": True, "bogie_positions": [0.0]},
        }
    )


def passive_forces(model, callback, qpos, qvel) -> np.ndarray:
    """qfrc_passive of `model` at (qpos, qvel) with `callback` installed (a Python creep
    callback or the native one): the creep forces, plus the suspension springs and dampers."""
    from rail_mj.simulation.callback import installed

    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:] = qpos, qvel
    with installed(callback):
        mujoco.mj_forward(model, data)
    return data.qfrc_passive.copy()


@pytest.fixture(autouse=True)
def _no_mujoco_log_in_repo(tmp_path, monkeypatch):
    """MuJoCo writes MUJOCO_LOG.TXT into the working directory when it warns."""
    monkeypatch.chdir(tmp_path)


def assert_callbacks_agree(vehicle, speed: float, seed: int, samples: int, position: float, rate: float) -> None:
    """At random states (positions and rates normal with these scales), the native and the
    Python creep callbacks give one qfrc_passive to 1e-9 of its largest entry: both call one
    compiled law; only the kinematics and J^T are written twice."""
    from rail_mj.simulation import native
    from rail_mj.simulation.callback import CreepForces

    model = vehicle.model
    native.set_speed(model, speed)
    python = CreepForces(model, vehicle.wheelset_names, speed)
    rng = np.random.default_rng(seed)
    for _ in range(samples):
        qpos, qvel = rng.normal(scale=position, size=model.nq), rng.normal(scale=rate, size=model.nv)
        forces = [passive_forces(model, callback, qpos, qvel) for callback in (python, native.callback())]
        scale = np.max(np.abs(forces[0]))
        assert scale > 0
        np.testing.assert_allclose(forces[1], forces[0], rtol=0, atol=1e-9 * scale)


@pytest.fixture(scope="session")
def standard():
    """The contact table of new S1002 on 60E1 at 1:40, 1435/1360, -10 to +10 mm (rail_mj.contact.
    geometry): a few seconds to build, so once per test process, and read-only."""
    from rail_mj.contact.geometry import Track, contact_table
    from rail_mj.contact.profiles import rail_60e1, s1002

    table = contact_table(Track(s1002(), rail_60e1()))
    for column in table.columns.values():
        column.setflags(write=False)
    return table


def worn_coach_copy(folder: Path) -> tuple[Path, Path]:
    """The worn coach's layout and its wheel profile file copied into `folder`, as a user's own:
    (layout, wheel profile file)."""
    worn = MODELS / "manchester-coach-worn"
    (folder / "assets").mkdir()
    wheel = folder / "assets" / "s1002_worn.csv"
    wheel.write_bytes((worn / "assets" / "s1002_worn.csv").read_bytes())
    layout = folder / "coach.toml"
    layout.write_text((worn / "manchester-coach-worn.toml").read_text())
    return layout, wheel


def harmonic(x: np.ndarray, t: np.ndarray, omega: float) -> complex:
    """The complex amplitude c of the component Re(c*exp(i*omega*t)) of samples x(t), least squares
    (beside a constant)."""
    basis = np.column_stack([np.cos(omega * t), -np.sin(omega * t), np.ones_like(t)])
    c, *_ = np.linalg.lstsq(basis, x, rcond=None)
    return complex(c[0], c[1])


def measured_track_file(tmp_path: Path, x: np.ndarray, channels: dict) -> str:
    """A straight track as long as `x` reaches, its irregularities measured: `channels` (m) at `x`,
    written as the measured CSV is read (rail_mj.track.irregularities)."""
    from rail_mj.track.irregularities import channels_csv

    (tmp_path / "measured.csv").write_bytes(channels_csv(x, channels))
    path = tmp_path / "track.toml"
    path.write_text(f'[[section]]\nkind = "straight"\nlength = {x[-1]}\n\n[irregularities]\nfile = "measured.csv"\n')
    return str(path)
