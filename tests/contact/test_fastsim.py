"""Kalker's FASTSIM as the creep law "fastsim" (docs/creep.md, section 6): the linear theory's
slopes as the grid refines, the friction bound, symmetries, the law in a run, and `rail-mj creep`."""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest
from conftest import linear_text, passive_forces

from rail_mj.analysis.stability import Stability
from rail_mj.cli import main
from rail_mj.contact.creep import (
    FASTSIM,
    FASTSIM_ELEMENTS,
    FASTSIM_STRIPS,
    LINEAR,
    ContactParameters,
    _fastsim,
    contact_forces,
    fastsim,
    patch_forces,
)
from rail_mj.contact.hertz import contact_patch, ellipse_patch, slender_coefficients
from rail_mj.layout import LayoutError, layout_from_dict
from rail_mj.numerics import NUMERIC_ELLIPSE
from rail_mj.simulation import native
from rail_mj.simulation.callback import CreepForces
from rail_mj.simulation.runner import simulate
from rail_mj.vehicle.spec import Vehicle

# The reference case of docs/contact.md: a 10 t wheel, r0 0.46 m, rail crown 0.30 m, steel.
PATCH = contact_patch(98.1e3, 0.46, 0.30, young_modulus=210e9, poisson_ratio=0.28)
MU = 0.3
LIMIT = MU * PATCH.normal_load  # mu*N
F = PATCH.creep_coefficients
ELLIPSE = (PATCH.a, PATCH.b, PATCH.normal_load, MU, PATCH.shear_modulus, PATCH.C["C11"], PATCH.C["C22"], PATCH.C["C23"])
TINY = 1e-10  # a creepage far inside the stick range: FASTSIM is exactly linear there


def slopes(n: int, patch=PATCH) -> dict:
    """FASTSIM's force per unit creepage on an n x n grid, over Kalker's linear coefficient."""
    args = (
        patch.a,
        patch.b,
        patch.normal_load,
        MU,
        patch.shear_modulus,
        patch.C["C11"],
        patch.C["C22"],
        patch.C["C23"],
    )
    f = patch.creep_coefficients
    fx = _fastsim(*args, TINY, 0.0, 0.0, n, n)
    fy = _fastsim(*args, 0.0, TINY, 0.0, n, n)
    fs = _fastsim(*args, 0.0, 0.0, TINY, n, n)
    return {
        "C11": -fx[0] / TINY / f["f11"],
        "C22": -fy[1] / TINY / f["f22"],
        "C23": -fs[1] / TINY / f["f23"],
        "Mz_eta": fy[2] / TINY,
        "Mz_phi": fs[2] / TINY,
        "cross": (fx[1], fx[2], fy[0], fs[0]),
    }


@pytest.mark.parametrize(
    "patch",
    [
        PATCH,
        ellipse_patch(50e3, 3e-3, 7.5e-3, shear_modulus=80e9, poisson_ratio=0.25),
        ellipse_patch(50e3, 12e-3, 0.5e-3, shear_modulus=80e9, poisson_ratio=0.28),  # a flange's, a/b 24
    ],
    ids=["a/b 1.33", "a/b 0.4", "a/b 24"],
)
def test_small_creepage_slopes_converge_to_kalkers(patch):
    """The flexibilities L1, L2, L3 are chosen so that the simplified theory has Kalker's C11,
    C22 and C23. On the grid (tractions at element centres, exact along each strip) the
    longitudinal and lateral slopes are too large by exactly 1/(2*n^2) (the midpoint rule
    across the strips on 1 - y^2/b^2); C23's error also falls as about 1/n^2:
    2.9 %, 0.65 %, 0.15 %, 0.036 % at n = 5, 10, 20, 40, whatever the ellipse's shape."""
    errors = []
    for n in (5, 10, 20, 40):
        s = slopes(n, patch)
        assert s["C11"] - 1 == pytest.approx(0.5 / n**2, rel=1e-6)
        assert s["C22"] - 1 == pytest.approx(0.5 / n**2, rel=1e-6)
        assert 0 < s["C23"] - 1 < 1.5 / n**2
        assert s["cross"] == (0.0, 0.0, 0.0, 0.0)  # xi gives no Fy or Mz, eta and spin no Fx
        errors.append(s["C23"] - 1)
    assert errors == sorted(errors, reverse=True)  # each refinement closer
    assert errors[2] < 2e-3 and errors[3] < 4e-4  # the default 20 x 20 grid, and 40 x 40
    assert FASTSIM_STRIPS == FASTSIM_ELEMENTS == 20


def test_spin_moment_slopes_are_the_simplified_theorys():
    """One flexibility L3 for spin gives FASTSIM its own moments (not Kalker's f23, f33):
    Mz = +(3*pi/32)*G*C22*a^2*b*eta and Mz = -(32/(15*pi))*G*C23*sqrt(a*b)*b^3*phi in the
    limit, here 0.754*f23 and 0.831*f33. The grid approaches them as 1/n^2 too:
    at 20 x 20 within 0.3 % and 0.7 %, at 80 x 80 within 0.02 % and 0.05 %."""
    G, a, b, C = PATCH.shear_modulus, PATCH.a, PATCH.b, PATCH.C
    eta_limit = 3 * math.pi / 32 * G * C["C22"] * a * a * b
    phi_limit = -32 / (15 * math.pi) * G * C["C23"] * math.sqrt(a * b) * b**3
    assert eta_limit / F["f23"] == pytest.approx(0.754, abs=1e-3)
    assert phi_limit / F["f33"] == pytest.approx(-0.831, abs=1e-3)
    for n, tolerance in ((20, (3e-3, 7e-3)), (80, (2e-4, 5e-4))):
        s = slopes(n)
        assert s["Mz_eta"] == pytest.approx(eta_limit, rel=tolerance[0])
        assert s["Mz_phi"] == pytest.approx(phi_limit, rel=tolerance[1])


def _creepages(rng, n):
    """Creepages from far inside the stick range to full sliding, with spin."""
    size = np.exp(rng.uniform(np.log(1e-6), np.log(0.3), n))
    angle = rng.uniform(0, 2 * np.pi, n)
    spin = rng.choice([0.0, 1.0], n) * rng.normal(0.0, 3.0, n)
    return size * np.cos(angle), size * np.sin(angle), spin


def test_never_above_the_friction_limit_and_reaching_it():
    """|(Fx, Fy)| <= mu*N always (the pressure is scaled so that its sum over the grid is N,
    so the bound holds to round-off, 1e-12), and far into sliding it is mu*N exactly:
    with Kalker's parabolic pressure FASTSIM slides everywhere from a finite creepage
    (xi = 32*mu*N/(3*pi*G*a*b*C11) = 0.70 % here, eta the same with C22, 0.77 %; on the
    20 x 20 grid 3 % sooner)."""
    xi, eta, phi = _creepages(np.random.default_rng(3), 400)
    fx, fy, _mz = fastsim(*ELLIPSE, xi, eta, phi)
    assert np.all(np.hypot(fx, fy) <= LIMIT * (1 + 1e-12))
    full_slide = 32 * LIMIT / (3 * math.pi * PATCH.shear_modulus * PATCH.a * PATCH.b * PATCH.C["C22"])
    assert full_slide == pytest.approx(0.0077, abs=1e-4)
    for creepage in (full_slide, 0.05, 1.0, 1e6):
        for direction in ((1, 0), (0, 1), (0.6, -0.8)):
            fx, fy, _ = _fastsim(*ELLIPSE, creepage * direction[0], creepage * direction[1], 0.0, 20, 20)
            assert math.hypot(fx, fy) == pytest.approx(LIMIT, rel=1e-12)
    # Rising steadily towards it: 41 % of mu*N at xi = 0.1 %, 85 % at 0.3 %, 98.7 % at 0.5 %.
    curve = -fastsim(*ELLIPSE, np.array([0.001, 0.003, 0.005]), 0.0, 0.0)[0] / LIMIT
    np.testing.assert_allclose(curve, [0.410, 0.855, 0.987], atol=2e-3)


def test_forces_oppose_the_creepages():
    """Fx against xi, Fy against eta, and spin (phi > 0, the wheel turning nose-left) pushes
    the wheel to the right (Fy < 0, Kalker's -f23*phi) with a moment against it, from
    the stick range to full sliding. At large spin the sliding becomes a rotation about
    the centre: Fy falls again (to 0.07 mu*N at 1000 rad/m) and the moment saturates."""
    for s in (1e-6, 1e-3, 1e-1):
        assert _fastsim(*ELLIPSE, s, 0.0, 0.0, 20, 20)[0] < 0
        assert _fastsim(*ELLIPSE, 0.0, s, 0.0, 20, 20)[1] < 0
    for phi in (1e-3, 0.1, 1.0, 10.0, 1000.0):
        fx, fy, mz = _fastsim(*ELLIPSE, 0.0, 0.0, phi, 20, 20)
        assert fy < 0 and mz < 0 and fx == 0.0
        assert abs(fy) <= LIMIT
    assert -_fastsim(*ELLIPSE, 0.0, 0.0, 1000.0, 20, 20)[1] / LIMIT == pytest.approx(0.067, abs=2e-3)


def test_symmetries():
    """Reversing every creepage reverses every force exactly; mirroring the contact across
    the rolling direction (eta, phi -> -eta, -phi) keeps Fx and reverses Fy and Mz; Fx is odd
    in xi alone."""
    xi, eta, phi = _creepages(np.random.default_rng(11), 200)
    fx, fy, mz = fastsim(*ELLIPSE, xi, eta, phi)
    reversed_ = fastsim(*ELLIPSE, -xi, -eta, -phi)
    for got, want in zip(reversed_, (fx, fy, mz)):
        np.testing.assert_array_equal(got, -want)
    mirrored = fastsim(*ELLIPSE, xi, -eta, -phi)
    np.testing.assert_allclose(mirrored[0], fx, rtol=1e-12, atol=1e-12 * LIMIT)
    np.testing.assert_allclose(mirrored[1], -fy, rtol=1e-12, atol=1e-12 * LIMIT)
    np.testing.assert_allclose(mirrored[2], -mz, rtol=1e-12, atol=1e-12 * LIMIT * PATCH.a)
    along = fastsim(*ELLIPSE, xi, 0.0, 0.0)
    np.testing.assert_array_equal(fastsim(*ELLIPSE, -xi, 0.0, 0.0)[0], -along[0])


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="fastsim: a must be a positive number"):
        fastsim(-1e-3, *ELLIPSE[1:], 0.001, 0.0, 0.0)
    with pytest.raises(ValueError, match="n_strips and n_elements"):
        fastsim(*ELLIPSE, 0.001, 0.0, 0.0, n_strips=0)
    with pytest.raises(ValueError, match="fastsim law needs friction_limit finite and > 0"):
        ContactParameters.broadcast(1, r0=0.46, b=0.75, conicity=0.15, f11=1e7, f22=1e7, law=FASTSIM)
    with pytest.raises(ValueError, match="fastsim law needs semi_axis_a finite and > 0"):
        ContactParameters.broadcast(
            1, r0=0.46, b=0.75, conicity=0.15, f11=1e7, f22=1e7, law=FASTSIM, friction_limit=LIMIT
        )


def _wheelset(law: int, **ellipse) -> ContactParameters:
    return ContactParameters.broadcast(1, r0=0.46, b=0.75, conicity=0.15, law=law, friction_limit=LIMIT, **F, **ellipse)


def test_the_wheelset_law_is_linear_at_small_creepage():
    """Through the one wheelset law (the kernel and the native callback): each wheel's
    FASTSIM forces at its own creepages. At small states the lateral force and the creep
    couple are the linear law's to 0.15 % (the grid's slopes above); the spin moment is
    FASTSIM's own."""
    fast = _wheelset(
        FASTSIM,
        semi_axis_a=PATCH.a,
        semi_axis_b=PATCH.b,
        normal_force=PATCH.normal_load,
        shear_modulus=PATCH.shear_modulus,
        c11=PATCH.C["C11"],
        c22=PATCH.C["C22"],
        c23=PATCH.C["C23"],
    )
    linear = _wheelset(LINEAR)
    rng = np.random.default_rng(5)
    for _ in range(10):
        state = [np.array([v]) for v in rng.normal(0.0, [1e-7, 1e-8, 1e-6, 1e-6])]
        a, b = contact_forces(fast, *state, 30.0), contact_forces(linear, *state, 30.0)
        assert a.creep_lateral[0] == pytest.approx(b.creep_lateral[0], rel=2e-3)
        assert a.creep_couple[0] == pytest.approx(b.creep_couple[0], rel=2e-3)
    # Far into sliding each wheel carries mu*N: sliding sideways, Sigma Y is 2*mu*N.
    sideways = contact_forces(fast, np.zeros(1), np.zeros(1), np.array([3.0]), np.zeros(1), 30.0)
    assert sideways.creep_lateral[0] == pytest.approx(-2 * LIMIT, rel=1e-12)


def fastsim_layout(law: str = "fastsim"):
    """The Manchester coach on the reference rail and wheel ([contact]), with `law`."""
    text = linear_text("manchester-coach").replace(
        "[creep]\nf11 = 10.0e6\nf22 = 9.0e6\nf23 = 0.0\nf33 = 0.0\n",
        "[contact]\nyoung_modulus = 210e9\npoisson_ratio = 0.28\nrail_transverse_radius = 0.30\n",
    )
    if law != "linear":
        text += f'\n[creep]\nlaw = "{law}"\nfriction = {MU}\n'
    return layout_from_dict(tomllib.loads(text))


def test_fastsim_needs_the_contact_ellipse():
    text = linear_text("manchester-coach").replace("f33 = 0.0\n", 'f33 = 0.0\nlaw = "fastsim"\nfriction = 0.3\n')
    with pytest.raises(LayoutError, match=r'creep.law: "fastsim" needs a \[contact\] table') as e:
        layout_from_dict(tomllib.loads(text))
    assert "\n" not in str(e.value)


def test_the_model_carries_the_ellipse_and_both_callbacks_agree():
    """The ellipse travels in the model (six significant figures, the shear modulus in GPa),
    and the native callback gives the Python callback's forces to round-off, on and off
    saturation."""
    layout = fastsim_layout()
    model = Vehicle(layout).model
    patch = contact_patch(layout.wheelset.wheel_load, 0.46, 0.30, young_modulus=210e9, poisson_ratio=0.28)
    np.testing.assert_allclose(
        model.numeric(NUMERIC_ELLIPSE).data,
        [
            patch.a,
            patch.b,
            patch.normal_load,
            patch.shear_modulus / 1e9,
            patch.C["C11"],
            patch.C["C22"],
            patch.C["C23"],
        ],
        rtol=5e-6,
    )
    native.set_speed(model, 47.0)
    python = CreepForces(model, [f"wheelset{i + 1}" for i in range(4)], 47.0)
    rng = np.random.default_rng(2)
    for scale in (1e-5, 3e-3):
        qpos, qvel = rng.normal(scale=scale, size=model.nq), rng.normal(scale=30 * scale, size=model.nv)
        forces = [passive_forces(model, callback, qpos, qvel) for callback in (python, native.callback())]
        np.testing.assert_allclose(forces[1], forces[0], rtol=0, atol=1e-9 * np.max(np.abs(forces[0])))


def test_a_fastsim_run_is_near_the_linear_law_at_small_amplitude():
    """The coach from 0.5 mm at 40 m/s (below its critical speed): FASTSIM's run follows the
    linear law's to 1 % of the amplitude (0.2 % measured; the spin moments differ, above),
    and its eigenvalue critical speed is the linear law's to 0.5 % (78.66 against 78.62 m/s)."""
    runs = {
        law: simulate(fastsim_layout(law), speed=40.0, distance=40.0, initial_lateral=0.0005)
        for law in ("linear", "fastsim")
    }
    amplitude = np.max(np.abs(runs["linear"].y))
    assert np.max(np.abs(runs["fastsim"].y - runs["linear"].y)) < 0.01 * amplitude
    speeds = [Stability(fastsim_layout(law)).critical_speed().critical_speed for law in ("linear", "fastsim")]
    assert speeds[1] == pytest.approx(speeds[0], rel=5e-3)


# --- rail-mj creep ---------------------------------------------------------------------

CLI = [
    "creep",
    "--semi-axes",
    PATCH.a,
    PATCH.b,
    "--normal-force",
    PATCH.normal_load,
    "--shear-modulus",
    PATCH.shear_modulus,
    "--poisson",
    0.28,
    "--friction",
    MU,
]


def creep_cli(capsys, *extra):
    status = main([str(a) for a in CLI + list(extra)])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.mark.parametrize("law", ["linear", "shen-hedrick-elkins", "polach", "fastsim"])
def test_cli_json_agrees_with_the_api(law, capsys):
    creepages = (0.001, -0.0005, 0.3)
    status, out, err = creep_cli(capsys, "--creepages", *creepages, "--law", law, "--json")
    assert status == 0, err
    result = json.loads(out)
    assert {
        "fx_n",
        "fy_n",
        "mz_nm",
        "C11",
        "C22",
        "C23",
        "C33",
        "law",
        "semi_axis_a_m",
        "semi_axis_b_m",
        "normal_force_n",
        "friction",
        "shear_modulus_pa",
        "poisson_ratio",
        "xi",
        "eta",
        "phi_rad_per_m",
    } <= set(result)
    assert result["C11"] == PATCH.C["C11"] and result["f11"] == F["f11"]
    expected = patch_forces(PATCH, law, *creepages, MU)
    assert (result["fx_n"], result["fy_n"], result["mz_nm"]) == expected
    if law == "fastsim":
        assert expected == tuple(float(v) for v in fastsim(*ELLIPSE, *creepages))
    elif law == "linear":
        assert expected[0] == pytest.approx(-F["f11"] * 0.001, rel=1e-12)
    else:
        assert math.hypot(*expected[:2]) <= LIMIT


def test_cli_prints_a_readable_result(capsys):
    status, out, err = creep_cli(capsys, "--creepages", 0.001, 0, 0, "--law", "fastsim")
    assert status == 0 and err == ""
    assert "Fx = -12" in out and "kN" in out and "mu*N" in out and "C11 4.549" in out


@pytest.mark.parametrize(
    "change, fragment",
    [
        (["--semi-axes", -0.007, 0.005], "--semi-axes must be between"),
        (["--semi-axes", 7.0, 5.0], "check the units"),
        (["--semi-axes", 0.0005, 0.007], "outside Kalker's table"),
        (["--semi-axes", "nan", 0.005], "--semi-axes must be finite"),
        (["--poisson", 0.6], "--poisson must be between 0 and 0.5"),
        (["--friction", 0], "--friction must be a positive number"),
        (["--friction", "inf"], "--friction must be a positive number"),
        (["--friction", 3], "--friction must be between 0 and 2"),
        (["--normal-force", -1], "--normal-force must be positive"),
        (["--creepages", 0, "nan", 0], "--creepages must be finite"),
        (["--creepages", 2, 0, 0], "within +/-1"),
    ],
)
def test_cli_bad_input_fails_in_one_line(change, fragment, capsys):
    argv = CLI + ["--creepages", 0.001, 0, 0, "--law", "fastsim"] + change  # the last value given wins
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    lines = [line for line in err.strip().splitlines() if not line.startswith("rail-mj: warning: ")]
    assert status == 2 and len(lines) == 1 and lines[0].startswith("rail-mj: error: ") and fragment in lines[0]


def test_cli_takes_a_flanges_slender_ellipse(capsys):
    """A flange's patch, a/b = 24, beyond Kalker's table: `creep` takes it, with the slender
    coefficients (docs/contact.md), and the linear law is -f11*xi with f11 = G*a*b*C11."""
    a, b, n, g = 12e-3, 0.5e-3, 50e3, 80e9
    argv = ["creep", "--semi-axes", a, b, "--normal-force", n, "--shear-modulus", g, "--poisson", 0.28]
    status = main([str(v) for v in argv + ["--creepages", 0.001, 0, 0, "--law", "linear", "--json"]])
    captured = capsys.readouterr()
    assert status == 0 and captured.err == ""
    result = json.loads(captured.out)
    expected = slender_coefficients(a / b, 0.28)
    assert {k: result[k] for k in expected} == expected
    assert result["fx_n"] == pytest.approx(-g * a * b * expected["C11"] * 0.001, rel=1e-12)


def test_cli_needs_friction_for_a_saturating_law(capsys):
    argv = [str(a) for a in CLI[:-2] + ["--creepages", 0.001, 0, 0]]
    assert main(argv + ["--law", "linear"]) == 0
    assert main(argv + ["--law", "fastsim"]) == 2
    assert "--friction: missing" in capsys.readouterr().err
