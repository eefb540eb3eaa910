"""Stability analysis against the closed forms of docs/creep.md (section numbers below are its own) and an
independent planar state-space model (tests/validation/planar.py)."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest
from conftest import CONED, MODELS, SHIPPED, free_truck
from planar import closed_form_critical_speed, planar_eigenvalues
from scipy.optimize import linear_sum_assignment

from rail_mj.analysis.stability import Stability, time_critical_speed
from rail_mj.cli import main
from rail_mj.layout import layout_from_dict, load_layout
from rail_mj.simulation.callback import CreepForces, installed


def restrained(m, Iz, ky, kpsi, f11, f22, lam, r0, b):
    return layout_from_dict(
        {
            "name": "restrained",
            "wheelset": {
                "mass": m,
                "inertia": [Iz, 100.0, Iz],
                "rolling_radius": r0,
                "contact_half_spacing": b,
                "conicity": lam,
            },
            "creep": {"f11": f11, "f22": f22},
            "primary": {"lateral_stiffness": ky, "yaw_stiffness": kpsi},
            "carbody": {"fixed": True, "wheelset_positions": [0.0]},
        }
    )


CASES = [
    # m, Iz, ky, kpsi, f11, f22, lam, r0, b
    (1813, 1120, 0.0, 2e6, 10e6, 10e6, 0.1, 0.46, 0.75),  # checked: 57.50 m/s, 4.866 Hz
    (1250, 700, 1e6, 5e6, 8e6, 6e6, 0.2, 0.45, 0.75),  # checked: 82.75 m/s, 9.431 Hz
    (1500, 900, 3e5, 1e6, 12e6, 9e6, 0.05, 0.50, 0.75),
    (1813, 1120, 2e6, 8e6, 10e6, 9e6, 0.15, 0.46, 0.75),
]


@pytest.mark.parametrize("case", CASES)
def test_restrained_wheelset_critical_speed_matches_closed_form(case):
    vc, fc = closed_form_critical_speed(*case)  # section 4: Vc^2 = P*Q/(P^2*lam/(b*r0) - (m*kpsi - Iz*ky)^2/4)
    assert math.isfinite(vc)
    result = Stability(restrained(*case)).critical_speed(vmin=5.0, vmax=2.5 * vc)
    # Brent's method stops within CRITICAL_XTOL = 1e-4 of the crossing.
    assert result.critical_speed == pytest.approx(vc, rel=2e-4)
    assert result.frequency == pytest.approx(fc, rel=2e-4)  # omega_c^2 = Q/P
    assert result.mode == "wheelset 1 (wheelset hunting)"


def test_the_checked_cases_give_the_published_numbers():
    for case, (vc, fc) in zip(CASES, [(57.50, 4.866), (82.75, 9.431)]):
        result = Stability(restrained(*case)).critical_speed(5.0, 150.0)
        assert round(result.critical_speed, 2) == vc and round(result.frequency, 3) == fc


def test_stable_everywhere_says_so(capsys):
    # Manchester wheelset on its stiff primary: P^2*lam/(b*r0) < (m*kpsi - Iz*ky)^2/4.
    case = (1813, 1120, 7.768e6, 62.78e6, 10e6, 9e6, 0.15, 0.46, 0.75)
    assert closed_form_critical_speed(*case)[0] == math.inf
    result = Stability(restrained(*case)).critical_speed(5.0, 150.0)
    assert result.critical_speed is None and "stable over the whole range" in result.note


def match(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Relative distance between the two root sets, paired one to one."""
    cost = np.abs(a[:, None] - b[None, :])
    i, j = linear_sum_assignment(cost)
    return cost[i, j] / np.abs(b[j])


@pytest.mark.parametrize("name", ["bogie", "manchester-coach", "wagon"])
@pytest.mark.parametrize("speed", [3.0, 30.0, 79.0, 140.0])
def test_eigenvalues_match_the_planar_model(name, speed):
    layout = load_layout(MODELS / name / f"{name}.toml")
    ours = Stability(layout).eigenvalues(speed)
    reference = planar_eigenvalues(layout, speed)
    assert len(ours) == len(reference) == 4 * Stability(layout).model.nv // 2
    # Central differences are exact for the linear law: agreement to round-off,
    # far inside the 1 % the issue asks for.
    assert np.max(match(ours, reference)) < 1e-6


def test_linearisation_agrees_with_mujoco_transition_derivatives():
    """mjd_transitionFD (which includes the passive callback; it does not support RK4)
    gives the discrete map of one semi-implicit Euler step, whose eigenvalues are
    exp(lambda*dt) of ours to first order: log(mu)/dt = lambda*(1 + O(lambda*dt))."""
    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    s = Stability(layout)
    speed, dt = 70.0, 1e-5
    lam = s.eigenvalues(speed)
    model = s.model
    model.opt.timestep = dt
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    data = mujoco.MjData(model)
    nv = model.nv
    A = np.zeros((2 * nv, 2 * nv))
    with installed(CreepForces(model, s.vehicle.wheelset_names, speed)):
        mujoco.mjd_transitionFD(model, data, 1e-7, True, A, None, None, None)
    discrete = np.log(np.linalg.eigvals(A).astype(complex)) / dt
    slow = lam[np.abs(lam) < 100.0]  # the body and hunting modes: |lambda|*dt < 1e-3
    assert len(slow) >= 6
    distance = np.min(np.abs(slow[:, None] - discrete[None, :]), axis=1) / np.abs(slow)
    assert np.max(distance) < 1e-3


def test_mode_names_identify_primary_hunting_of_a_stiff_bogie():
    """Very stiff primary suspension: the wheelsets move with the frame, the lowest
    mode is the rigid truck's kinematic one (section 3), and it is named primary hunting."""
    layout = free_truck([1.28, -1.28], primary=1e9)
    s = Stability(layout)
    speed = 5.0
    r0, b, lam, a = 0.46, 0.75, 0.15, 1.28
    rigid = 2 * math.pi * math.sqrt(r0 * b / lam * (1 + 9e6 / 10e6 * a**2 / b**2))
    slowest = min((m for m in s.modes(speed) if m.oscillatory and m.damping_ratio < 0.5), key=lambda m: m.frequency)
    # 1e9 primary springs are 50-100x the creep stiffnesses (rigid to ~0.1 %), and the
    # inertia correction at 5 m/s is ~1e-4: 0.5 % leaves margin for both.
    assert slowest.frequency == pytest.approx(speed / rigid, rel=5e-3)
    assert slowest.name.startswith("bogie 1 frame") and slowest.name.endswith("(primary hunting)")


def test_mode_names_identify_secondary_hunting_under_an_immovable_frame():
    """A frame a thousand times heavier hardly moves: each wheelset hunts on its own
    primary suspension like the restrained wheelset of section 4, and the critical
    mode is named secondary hunting."""
    case = CASES[0]
    m, Iz, ky, kpsi, f11, f22, lam, r0, b = case
    layout = layout_from_dict(
        {
            "name": "heavy-frame",
            "wheelset": {
                "mass": m,
                "inertia": [Iz, 100.0, Iz],
                "rolling_radius": r0,
                "contact_half_spacing": b,
                "conicity": lam,
            },
            "creep": {"f11": f11, "f22": f22},
            "primary": {"lateral_stiffness": ky, "yaw_stiffness": kpsi},
            "bogie": {"mass": 1e7, "inertia": [1e7, 1e7, 1e7], "wheelset_positions": [1.28, -1.28]},
            "secondary": {"lateral_stiffness": 1e6, "yaw_stiffness": 1e8, "lateral_damping": 1e6, "yaw_damping": 1e7},
            "carbody": {"fixed": True, "bogie_positions": [0.0]},
        }
    )
    result = Stability(layout).critical_speed(5.0, 150.0)
    vc, _fc = closed_form_critical_speed(*case)
    assert result.critical_speed == pytest.approx(vc, rel=1e-2)  # the frame moves a little
    assert result.mode in ("wheelset 1 (secondary hunting)", "wheelset 2 (secondary hunting)")


def test_shipped_bogie_has_both_hunting_modes():
    modes = Stability(load_layout(MODELS / "bogie" / "bogie.toml")).modes(60.0)
    names = [m.name for m in modes if m.oscillatory]
    assert any("(primary hunting)" in n for n in names)
    assert any("(secondary hunting)" in n for n in names)
    for m in modes:
        assert sum(m.participation.values()) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("layout_path", CONED, ids=lambda p: p.stem)
def test_time_domain_critical_speed_agrees_with_eigenvalues(layout_path):
    """Coned wheels: the same linear model both ways. (On profiles the eigen method
    linearises at 3 mm and the runs feel the whole tables: they need not agree.)"""
    layout = load_layout(layout_path)
    eigen = Stability(layout).critical_speed(5.0, 150.0)
    # The time method brackets the crossing itself, on a grid that does not contain it.
    lo, hi = 0.75 * eigen.critical_speed, 1.3 * eigen.critical_speed
    result = time_critical_speed(layout, lo, hi, points=4, duration=10.0, rtol=5e-3)
    # The 3 %: growth rates from 5 s of peaks, with neighbouring modes beating.
    assert result.critical_speed == pytest.approx(eigen.critical_speed, rel=0.03)
    assert result.frequency == pytest.approx(eigen.frequency, rel=0.03)
    assert result.mode == eigen.mode


def test_cli_critical_speed_json(capsys):
    status = main(["critical-speed", str(MODELS / "wheelset" / "wheelset.toml"), "--json"])
    assert status == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "eigen" and out["mode"] == "wheelset 1 (wheelset hunting)"
    assert out["critical_speed"] == pytest.approx(57.50, abs=0.01)
    assert out["frequency"] == pytest.approx(4.866, abs=0.001)


def test_cli_eigen_json(capsys):
    status = main(["eigen", str(MODELS / "manchester-coach" / "manchester-coach.toml"), "--speed", "90", "--json"])
    assert status == 0
    out = json.loads(capsys.readouterr().out)
    assert out["stable"] is False  # above the 79.3 m/s critical speed
    first = out["modes"][0]
    assert first["real"] > 0 and "(primary hunting)" in first["name"]
    assert set(first) >= {"frequency_hz", "damping_ratio", "real", "imag", "participation"}


def test_cli_root_locus_writes_plot_and_csv(tmp_path, capsys):
    png = tmp_path / "locus.png"
    status = main(["root-locus", str(MODELS / "bogie" / "bogie.toml"), "--speeds", "10:120:12", "-o", str(png)])
    assert status == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size > 20_000  # three labelled panels of points, not a blank figure
    lines = (tmp_path / "locus.csv").read_text().splitlines()
    assert lines[0] == "speed_m_per_s,mode,frequency_hz,damping_ratio,real,imag"
    # 6 dof (frame and two wheelsets, lateral and yaw) give up to 6 oscillatory modes a
    # speed; at least 4 stay oscillatory at every speed here (two become aperiodic at most).
    speeds = {float(line.split(",")[0]) for line in lines[1:]}
    assert len(speeds) == 12 and len(lines) - 1 >= 12 * 4
    vc = Stability(load_layout(MODELS / "bogie" / "bogie.toml")).critical_speed(10.0, 120.0).critical_speed
    assert f"critical speed {vc:.2f} m/s" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["critical-speed", "LAYOUT", "--vmin", "50", "--vmax", "10"], "--vmin"),
        (["eigen", "LAYOUT", "--speed", "-1"], "--speed"),
        (["root-locus", "LAYOUT", "--speeds", "10:5:3", "-o", "x.png"], "--speeds"),
        (["root-locus", "LAYOUT", "--speeds", "abc", "-o", "x.png"], "--speeds"),
    ],
)
def test_cli_stability_bad_arguments(argv, fragment, tmp_path, capsys):
    argv = [str(MODELS / "bogie" / "bogie.toml") if a == "LAYOUT" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and fragment in err
    assert list(tmp_path.iterdir()) == []


def test_lower_conicity_raises_the_bogie_critical_speed():
    """The Shinkansen's change from 1:20 to 1:40 (seed, 'The stable bogie')."""
    import dataclasses

    base = load_layout(MODELS / "bogie" / "bogie.toml")
    speeds = [
        Stability(dataclasses.replace(base, wheelset=dataclasses.replace(base.wheelset, conicity=lam)))
        .critical_speed(5.0, 300.0)
        .critical_speed
        for lam in (0.15, 0.05, 0.025)
    ]
    assert speeds[0] < speeds[1] < speeds[2]


def test_time_method_counts_derailing_runs_as_growing():
    # 400 m/s is far above the restrained wheelset's 57.5 m/s: it leaves the rails.
    result = time_critical_speed(
        load_layout(MODELS / "wheelset" / "wheelset.toml"), 400.0, 1000.0, points=3, duration=5.0
    )
    assert result.critical_speed is None and "already grows at 400" in result.note


@pytest.mark.parametrize(
    "argv, status, fragment",
    [
        (["critical-speed", "LAYOUT", "--method", "time", "--vmin", "1e-4", "--vmax", "1"], 3, "too slow"),
        (["eigen", "BROKEN", "--speed", "30"], 2, "not a rigid body"),
        (["critical-speed", "BROKEN"], 2, "not a rigid body"),
        (["critical-speed", "BROKEN", "--method", "time"], 2, "not a rigid body"),
        (["root-locus", "BROKEN", "--speeds", "10:20:3", "-o", "x.png"], 2, "not a rigid body"),
    ],
)
def test_cli_stability_failures_are_one_line(argv, status, fragment, tmp_path, capsys):
    broken = tmp_path / "broken.toml"
    broken.write_text(
        (MODELS / "wheelset" / "wheelset.toml")
        .read_text()
        .replace("inertia = [1120.0, 112.0, 1120.0]", "inertia = [1.0, 1.0, 1120.0]")
    )  # A + B < C
    argv = [
        str(MODELS / "wheelset" / "wheelset.toml") if a == "LAYOUT" else str(broken) if a == "BROKEN" else a
        for a in argv
    ]
    assert main(argv) == status
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and fragment in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["broken.toml"]


@pytest.mark.parametrize("layout_path", SHIPPED, ids=lambda p: p.stem)
def test_state_matrix_in_speed_is_the_linearisation_at_that_speed(layout_path):
    """A(V) = A0 + D/V + G*V from three linearisations equals MuJoCo linearised at V itself
    (finite differences: round-off near 1e-8 of the largest entry, so 1e-6)."""
    stability = Stability(load_layout(layout_path))
    for speed in (3.0, 27.0, 81.0, 240.0):
        fitted, direct = stability.state_matrix(speed), stability.state_matrix_at(speed)
        np.testing.assert_allclose(fitted, direct, rtol=0, atol=1e-6 * np.max(np.abs(direct)))
