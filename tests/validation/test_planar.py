"""Checks of the independent planar model (tests/validation/planar.py) against closed forms.

Every formula is from the physics notes docs/creep.md (its section numbers given next to each
check) and docs/frames.md, never from rail_mj's own model.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from planar import (
    closed_form_critical_speed,
    planar_eigenvalues,
    planar_matrices,
    planar_state_matrix,
)
from scipy.optimize import brentq

from rail_mj.layout import layout_from_dict

# --- layouts -----------------------------------------------------------------


def single_wheelset(m, Iz, ky, kpsi, f11, f22, lam, r0, b, cy=0.0, cpsi=0.0, f23=0.0, f33=0.0):
    """One wheelset sprung to a fixed body (the section-2/4 setting)."""
    return layout_from_dict(
        {
            "name": "w",
            "wheelset": {
                "mass": m,
                "inertia": [Iz, 0.1 * Iz, Iz],
                "rolling_radius": r0,
                "contact_half_spacing": b,
                "conicity": lam,
            },
            "creep": {"f11": f11, "f22": f22, "f23": f23, "f33": f33},
            "primary": {"lateral_stiffness": ky, "yaw_stiffness": kpsi, "lateral_damping": cy, "yaw_damping": cpsi},
            "carbody": {"fixed": True, "wheelset_positions": [0.0]},
        }
    )


def rigid_truck(a, f11, f22, lam, r0, b, m=1813.0, Iz=1120.0, k=1e10):
    """A two-axle bogie frame (semi-wheelbase a), primary stiffness k, under a fixed body
    with zero secondary stiffness."""
    return layout_from_dict(
        {
            "name": "truck",
            "wheelset": {
                "mass": m,
                "inertia": [Iz, 0.1 * Iz, Iz],
                "rolling_radius": r0,
                "contact_half_spacing": b,
                "conicity": lam,
            },
            "creep": {"f11": f11, "f22": f22},
            "primary": {"lateral_stiffness": k, "yaw_stiffness": k},
            "bogie": {"mass": 2615.0, "inertia": [1722.0, 1476.0, 3067.0], "wheelset_positions": [a, -a]},
            "secondary": {"lateral_stiffness": 0.0, "yaw_stiffness": 0.0},
            "carbody": {"fixed": True, "bogie_positions": [0.0]},
        }
    )


def coach(f11=10e6, f22=9e6, lam=0.15):
    """Manchester coach numbers (docs/manchester-coach.md), free car body and two bogies."""
    return layout_from_dict(
        {
            "name": "coach",
            "wheelset": {
                "mass": 1813.0,
                "inertia": [1120.0, 112.0, 1120.0],
                "rolling_radius": 0.46,
                "contact_half_spacing": 0.75,
                "conicity": lam,
            },
            "creep": {"f11": f11, "f22": f22},
            "primary": {
                "lateral_stiffness": 7.768e6,
                "yaw_stiffness": 62.78e6,
                "lateral_damping": 4.0e3,
                "yaw_damping": 1.0e3,
            },
            "bogie": {"mass": 2615.0, "inertia": [1722.0, 1476.0, 3067.0], "wheelset_positions": [1.28, -1.28]},
            "secondary": {
                "lateral_stiffness": 320e3,
                "yaw_stiffness": 320e3,
                "lateral_damping": 64e3,
                "yaw_damping": 2.0e3,
            },
            "carbody": {
                "fixed": False,
                "mass": 32000.0,
                "inertia": [56800.0, 1.97e6, 1.97e6],
                "bogie_positions": [9.5, -9.5],
            },
        }
    )


def wagon(f11=10e6, f22=9e6):
    """Two wheelsets straight under a free car body (no bogies)."""
    return layout_from_dict(
        {
            "name": "wagon",
            "wheelset": {
                "mass": 1250.0,
                "inertia": [700.0, 80.0, 700.0],
                "rolling_radius": 0.45,
                "contact_half_spacing": 0.75,
                "conicity": 0.2,
            },
            "creep": {"f11": f11, "f22": f22},
            "primary": {"lateral_stiffness": 2e6, "yaw_stiffness": 7e6, "lateral_damping": 3e3, "yaw_damping": 5e2},
            "carbody": {
                "fixed": False,
                "mass": 20000.0,
                "inertia": [6e4, 2e5, 2.5e5],
                "wheelset_positions": [4.5, -4.5],
            },
        }
    )


# --- helpers -----------------------------------------------------------------


def max_real(layout, V):
    return planar_eigenvalues(layout, V).real.max()


def linear_critical_speed(layout, v_low=1.0, v_high=400.0, n=400):
    """First speed where the largest real part crosses zero: a scan, then brentq."""
    speeds = np.geomspace(v_low, v_high, n)
    values = [max_real(layout, v) for v in speeds]
    for (v0, s0), (v1, s1) in zip(zip(speeds, values), zip(speeds[1:], values[1:])):
        if s0 < 0.0 <= s1:
            return brentq(lambda v: max_real(layout, v), v0, v1, xtol=1e-12, rtol=1e-13)
    raise AssertionError(f"no crossing of zero between {v_low} and {v_high} m/s")


def slowest_oscillation(layout, V):
    """The eigenvalue with the smallest nonzero |imag| (upper half plane)."""
    eig = planar_eigenvalues(layout, V)
    osc = eig[eig.imag > 1e-9]
    return osc[np.argmin(osc.imag)]


# --- section 2: the matrices are the classical equations ---------------------


def test_single_wheelset_matrices_are_section_2_equations():
    m, Iz, ky, kpsi, f11, f22, lam, r0, b, V = 1813.0, 1120.0, 3e5, 2e6, 10e6, 9e6, 0.1, 0.46, 0.75, 30.0
    M, C, K, names = planar_matrices(single_wheelset(m, Iz, ky, kpsi, f11, f22, lam, r0, b), V)
    assert names == ["wheelset1_lateral", "wheelset1_yaw"]
    # m y'' + 2 f22 (y'/V - psi) + ky y = 0 ; Iz psi'' + 2 f11 b (b psi'/V + lam y/r0) + kpsi psi = 0
    np.testing.assert_allclose(M, np.diag([m, Iz]), rtol=1e-15)
    np.testing.assert_allclose(C, [[2 * f22 / V, 0.0], [0.0, 2 * f11 * b * b / V]], rtol=1e-14)
    np.testing.assert_allclose(K, [[ky, -2 * f22], [2 * f11 * b * lam / r0, kpsi]], rtol=1e-14)
    A = planar_state_matrix(single_wheelset(m, Iz, ky, kpsi, f11, f22, lam, r0, b), V)
    np.testing.assert_allclose(A[:2, 2:], np.eye(2))
    np.testing.assert_allclose(A[2:, :2], -np.linalg.solve(M, K), rtol=1e-14)
    np.testing.assert_allclose(A[2:, 2:], -np.linalg.solve(M, C), rtol=1e-14)


def test_spin_creep_terms():
    """Kalker's spin terms (section 2): Fy gains -2 f23 psi'/V; Mz gains 2 f23 (y'/V - psi) - 2 f33 psi'/V."""
    f11, f22, f23, f33, b, V = 10e6, 9e6, 36.5e3, 121.0, 0.75, 25.0
    base = planar_matrices(single_wheelset(1813, 1120, 0, 2e6, f11, f22, 0.1, 0.46, b), V)
    spin = planar_matrices(single_wheelset(1813, 1120, 0, 2e6, f11, f22, 0.1, 0.46, b, f23=f23, f33=f33), V)
    np.testing.assert_allclose(spin[1] - base[1], [[0, 2 * f23 / V], [-2 * f23 / V, 2 * f33 / V]], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(spin[2] - base[2], [[0, 0], [0, 2 * f23]], rtol=1e-9, atol=1e-9)


# --- section 4: critical speed of a restrained wheelset -----------------------

# (m, Iz, ky, kpsi, f11, f22, lam, r0, b, expected Vc or None, expected f or None)
CASES = [
    # the two checked cases of section 4
    (1813.0, 1120.0, 0.0, 2e6, 10e6, 10e6, 0.1, 0.46, 0.75, 57.50, 4.866),
    (1250.0, 700.0, 1e6, 5e6, 8e6, 6e6, 0.2, 0.45, 0.75, 82.75, 9.431),
    # two more, f11 != f22, both springs nonzero
    (1500.0, 900.0, 5e5, 3e6, 7e6, 9e6, 0.15, 0.5, 0.75, None, None),
    (1813.0, 1120.0, 2e6, 8e6, 12e6, 10.5e6, 0.05, 0.46, 0.7175, None, None),
    # f11 == f22 with a light yaw spring and a stiff lateral one
    (2000.0, 1300.0, 4e6, 1e6, 9e6, 9e6, 0.25, 0.43, 0.75, None, None),
]


@pytest.mark.parametrize("m, Iz, ky, kpsi, f11, f22, lam, r0, b, vc_ref, f_ref", CASES)
def test_critical_speed_matches_closed_form(m, Iz, ky, kpsi, f11, f22, lam, r0, b, vc_ref, f_ref):
    vc, f_hz = closed_form_critical_speed(m, Iz, ky, kpsi, f11, f22, lam, r0, b)
    assert math.isfinite(vc)
    if vc_ref is not None:  # the worked numbers of section 4, to 4 significant figures
        assert vc == pytest.approx(vc_ref, abs=0.005)
        assert f_hz == pytest.approx(f_ref, abs=0.0005)

    layout = single_wheelset(m, Iz, ky, kpsi, f11, f22, lam, r0, b)
    v_num = linear_critical_speed(layout, v_low=0.05 * vc, v_high=20.0 * vc)
    # Vc^2 = P Q / (P^2 lam/(b r0) - (m kpsi - Iz ky)^2/4)   (section 4), to 1e-3 relative
    assert v_num == pytest.approx(vc, rel=1e-3)
    # omega_c^2 = Q/P at Vc (section 4), to 1e-3 relative
    eig = planar_eigenvalues(layout, v_num)
    critical = eig[np.argmax(eig.real)]
    assert abs(critical.imag) == pytest.approx(2 * math.pi * f_hz, rel=1e-3)
    # just below Vc stable, just above unstable
    assert max_real(layout, 0.99 * vc) < 0.0 < max_real(layout, 1.01 * vc)


def test_no_critical_speed_when_denominator_not_positive():
    """Section 4: stable at every speed when P^2 lam/(b r0) <= (m kpsi - Iz ky)^2/4."""
    args = (1813.0, 1120.0, 0.0, 2e9, 10e6, 10e6, 0.01, 0.46, 0.75)
    vc, f_hz = closed_form_critical_speed(*args)
    assert vc == math.inf and math.isnan(f_hz)
    layout = single_wheelset(*args)
    for V in np.geomspace(1.0, 1000.0, 60):
        assert max_real(layout, V) < 0.0


# --- section 3: kinematic (Klingel) wavelengths ------------------------------


def test_klingel_worked_numbers():
    """Section 3 worked numbers: L_w = 17.21 m, 9.53 m and L_b = 18.85 m (to 4 s.f.)."""
    assert 2 * math.pi * math.sqrt(0.5 * 0.75 / 0.05) == pytest.approx(17.21, abs=0.005)
    assert 2 * math.pi * math.sqrt(0.46 * 0.75 / 0.15) == pytest.approx(9.53, abs=0.005)
    assert 2 * math.pi * math.sqrt(0.46 * 0.75 / 0.15 * (1 + 1.28**2 / 0.75**2)) == pytest.approx(18.85, abs=0.005)


@pytest.mark.parametrize(
    "r0, b, lam, f11, f22",
    [
        (0.5, 0.75, 0.05, 10e6, 10e6),
        (0.46, 0.75, 0.15, 10e6, 9e6),
        (0.45, 0.75, 0.2, 8e6, 6e6),
    ],
)
def test_free_wheelset_klingel_wavelength(r0, b, lam, f11, f22):
    V = 2.0
    layout = single_wheelset(1813.0, 1120.0, 0.0, 0.0, f11, f22, lam, r0, b)
    s = slowest_oscillation(layout, V)
    wavelength = V / (s.imag / (2 * math.pi))
    # L_w = 2 pi sqrt(r0 b / lam)   (section 3), to 0.1 %
    assert wavelength == pytest.approx(2 * math.pi * math.sqrt(r0 * b / lam), rel=1e-3)
    # "its amplitude growing very slowly": unstable, but by far less than one e-fold per wavelength
    assert 0.0 < s.real < 0.05 * s.imag


@pytest.mark.parametrize(
    "a, r0, b, lam, f11, f22",
    [
        (1.28, 0.46, 0.75, 0.15, 10e6, 10e6),
        (1.28, 0.46, 0.75, 0.15, 10e6, 9e6),
        (1.0, 0.5, 0.75, 0.05, 8e6, 12e6),
    ],
)
def test_rigid_truck_klingel_wavelength(a, r0, b, lam, f11, f22):
    V = 2.0
    s = slowest_oscillation(rigid_truck(a, f11, f22, lam, r0, b), V)
    wavelength = V / (s.imag / (2 * math.pi))
    # L_b = 2 pi sqrt((r0 b/lam)(1 + (f22/f11) a^2/b^2))   (section 3), to 0.5 %
    expected = 2 * math.pi * math.sqrt(r0 * b / lam * (1 + (f22 / f11) * a**2 / b**2))
    assert wavelength == pytest.approx(expected, rel=5e-3)


# --- docs/frames.md: suspension geometry ------------------------------------


def test_coach_size_names_and_symmetry():
    """Free car body, two bogies, four wheelsets: 14 coordinates, A is 28 x 28.

    With the creep made negligible (f11 = f22 = 1e-9 N) only the suspension is left, whose
    K and C come from an energy and a dissipation function (docs/frames.md): both symmetric, and
    both annihilate the two rigid-body motions of the whole vehicle (all y equal; all psi
    equal with y = x*psi), which deflect no spring.
    """
    layout = coach(f11=1e-9, f22=1e-9)
    M, C, K, names = planar_matrices(layout, 30.0)
    expected = ["carbody_lateral", "carbody_yaw", "bogie1_lateral", "bogie1_yaw", "bogie2_lateral", "bogie2_yaw"] + [
        f"wheelset{i}_{c}" for i in range(1, 5) for c in ("lateral", "yaw")
    ]
    assert names == expected
    assert planar_state_matrix(layout, 30.0).shape == (28, 28)
    assert planar_eigenvalues(layout, 30.0).shape == (28,)
    np.testing.assert_allclose(np.diag(M), [32000, 1.97e6] + [2615, 3067] * 2 + [1813, 1120] * 4)
    scale = np.abs(K).max()  # 1e-15 relative to the largest entry
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-15 * scale)
    np.testing.assert_allclose(C, C.T, rtol=0, atol=1e-15 * np.abs(C).max())

    x = {
        "carbody": 0.0,
        "bogie1": 9.5,
        "bogie2": -9.5,
        "wheelset1": 10.78,
        "wheelset2": 8.22,
        "wheelset3": -8.22,
        "wheelset4": -10.78,
    }
    translation = np.array([1.0 if n.endswith("_lateral") else 0.0 for n in names])
    rotation = np.array([x[n.split("_")[0]] if n.endswith("_lateral") else 1.0 for n in names])
    for mode in (translation, rotation):
        assert np.abs(K @ mode).max() < 1e-12 * scale
        assert np.abs(C @ mode).max() < 1e-12 * np.abs(C).max()
    # and nothing else is free: exactly two zero eigenvalues of K
    assert np.sum(np.abs(np.linalg.eigvalsh(K)) < 1e-9 * scale) == 2


@pytest.mark.parametrize("make", [coach, wagon])
def test_suspension_forces_match_the_written_out_forces(make):
    """K q and C q' equal minus the suspension forces of docs/frames.md summed over every suspension.

    Per suspension, d = y_c - (y_p + (x_c - x_p) psi_p), e = psi_c - psi_p:
    child lateral -ky d; parent lateral +ky d; parent yaw (x_c - x_p) ky d + kpsi e;
    child yaw -kpsi e (and the same with c and the rates).
    """
    layout = make(f11=1e-9, f22=1e-9)
    _M, C, K, names = planar_matrices(layout, 30.0)
    idx = {n: i for i, n in enumerate(names)}
    rng = np.random.default_rng(1)
    q, qd = rng.normal(size=len(names)), rng.normal(size=len(names))

    def coord(vec, body, kind):
        return vec[idx[f"{body}_{kind}"]] if f"{body}_{kind}" in idx else 0.0

    links = []  # (child, x_c, parent, x_p, suspension)
    if layout.bogie is not None:
        per = len(layout.bogie.wheelset_positions)
        for i, xb in enumerate(layout.carbody.bogie_positions, start=1):
            links.append((f"bogie{i}", xb, "carbody", 0.0, layout.secondary))
        for k, xw in enumerate(layout.wheelset_x, start=1):
            xb = layout.carbody.bogie_positions[(k - 1) // per]
            links.append((f"wheelset{k}", xw, f"bogie{(k - 1) // per + 1}", xb, layout.primary))
    else:
        for k, xw in enumerate(layout.wheelset_x, start=1):
            links.append((f"wheelset{k}", xw, "carbody", 0.0, layout.primary))

    for vec, matrix, ky_attr, kpsi_attr in (
        (q, K, "lateral_stiffness", "yaw_stiffness"),
        (qd, C, "lateral_damping", "yaw_damping"),
    ):
        force = np.zeros(len(names))
        for child, x_c, parent, x_p, s in links:
            ky, kpsi = getattr(s, ky_attr), getattr(s, kpsi_attr)
            d = coord(vec, child, "lateral") - (coord(vec, parent, "lateral") + (x_c - x_p) * coord(vec, parent, "yaw"))
            e = coord(vec, child, "yaw") - coord(vec, parent, "yaw")
            force[idx[f"{child}_lateral"]] += -ky * d
            force[idx[f"{child}_yaw"]] += -kpsi * e
            if f"{parent}_lateral" in idx:
                force[idx[f"{parent}_lateral"]] += ky * d
                force[idx[f"{parent}_yaw"]] += (x_c - x_p) * ky * d + kpsi * e
        # generalised force = -K q (or -C q'); creep is 1e-9 N here, far below 1e-9 relative
        np.testing.assert_allclose(-(matrix @ vec), force, rtol=0, atol=1e-9 * np.abs(force).max())


def test_stiff_wagon_primary_behaves_as_rigid_truck():
    """A car body on two wheelsets with very stiff primary is a rigid truck of semi-wheelbase
    a = 4.5 m (section 3 formula with f11 != f22), to 0.5 %."""
    layout = layout_from_dict(
        {
            "name": "stiff-wagon",
            "wheelset": {
                "mass": 1250.0,
                "inertia": [700.0, 80.0, 700.0],
                "rolling_radius": 0.45,
                "contact_half_spacing": 0.75,
                "conicity": 0.2,
            },
            "creep": {"f11": 8e6, "f22": 6e6},
            "primary": {"lateral_stiffness": 1e10, "yaw_stiffness": 1e10},
            "carbody": {
                "fixed": False,
                "mass": 20000.0,
                "inertia": [6e4, 2e5, 2.5e5],
                "wheelset_positions": [4.5, -4.5],
            },
        }
    )
    V = 2.0
    s = slowest_oscillation(layout, V)
    wavelength = V / (s.imag / (2 * math.pi))
    expected = 2 * math.pi * math.sqrt(0.45 * 0.75 / 0.2 * (1 + (6e6 / 8e6) * 4.5**2 / 0.75**2))
    assert wavelength == pytest.approx(expected, rel=5e-3)


def test_speed_must_be_positive():
    with pytest.raises(ValueError):
        planar_matrices(single_wheelset(1813, 1120, 0, 2e6, 10e6, 10e6, 0.1, 0.46, 0.75), 0.0)
