"""The wear number T-gamma per wheel (docs/track.md, section 9): the energy the creep forces
dissipate in the contact per metre rolled, -(Fx*xi_x + Fy*xi_y + Mz*xi_sp) with the rail's forces on
the wheel and the creepages the law is given, >= 0 because the forces oppose the creepages."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import MODELS

from rail_mj.contact.creep import (
    FASTSIM,
    LINEAR,
    POLACH,
    SHEN_HEDRICK_ELKINS,
    ContactParameters,
    _fastsim,
    contact_forces,
    fastsim,
    wear_number,
)
from rail_mj.contact.hertz import contact_patch
from rail_mj.layout import load_layout
from rail_mj.vehicle.block import contact_parameters
from rail_mj.vehicle.spec import Vehicle

R0, B, LAM, V = 0.46, 0.75, 0.15, 30.0
# The reference case of docs/contact.md: f11 14.3 MN, f22 13.1 MN, f23 36.5 kN m, f33 121 N m^2.
PATCH = contact_patch(98.1e3, 0.46, 0.30, young_modulus=210e9, poisson_ratio=0.28)
F = PATCH.creep_coefficients
MU = 0.3
LIMIT = MU * PATCH.normal_load  # mu*Q per wheel
ELLIPSE = dict(
    semi_axis_a=PATCH.a,
    semi_axis_b=PATCH.b,
    normal_force=PATCH.normal_load,
    shear_modulus=PATCH.shear_modulus,
    c11=PATCH.C["C11"],
    c22=PATCH.C["C22"],
    c23=PATCH.C["C23"],
)


def _cones(law: int = LINEAR, n: int = 1, **more) -> ContactParameters:
    return ContactParameters.broadcast(n, r0=R0, b=B, conicity=LAM, law=law, friction_limit=LIMIT, **F, **more)


def _states(rng, n: int, scale: float = 1.0):
    """Wheelset states from the tread's creep to gross sliding: y, psi, y', psi'."""
    return (
        rng.uniform(-0.008, 0.008, n),
        scale * rng.normal(0.0, 3e-3, n),
        scale * rng.normal(0.0, 0.1, n),
        scale * rng.normal(0.0, 0.3, n),
    )


def _tread_creepages(y, psi, y_dot, psi_dot):
    """The creepages of docs/creep.md on the tread: xi_x = -/+ (b*psi'/V + lam*y/r0) on the
    left/right wheel, xi_y = y'/V - psi, the spin psi'/V."""
    xi = B * psi_dot / V + LAM * y / R0
    return -xi, xi, y_dot / V - psi, psi_dot / V


def test_the_linear_law_on_cones_is_kalker_s_quadratic_form():
    """Kalker's linear law: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp, so
    T-gamma = f11*xi_x^2 + f22*xi_y^2 + f33*xi_sp^2 per wheel (f23's two terms cancel: spin couples
    force and moment without dissipating), with each wheel's creepages."""
    rng = np.random.default_rng(1)
    y, psi, y_dot, psi_dot = _states(rng, 200)
    forces = contact_forces(_cones(n=200), y, psi, y_dot, psi_dot, V)
    left, right, xi_y, xi_sp = _tread_creepages(y, psi, y_dot, psi_dot)
    spin_and_lateral = F["f22"] * xi_y**2 + F["f33"] * xi_sp**2
    np.testing.assert_allclose(forces.wear_left, F["f11"] * left**2 + spin_and_lateral, rtol=1e-12)
    np.testing.assert_allclose(forces.wear_right, F["f11"] * right**2 + spin_and_lateral, rtol=1e-12)
    # A centred, unyawed wheelset rolling straight dissipates nothing.
    zero = np.zeros(1)
    still = contact_forces(_cones(), zero, zero, zero, zero, V)
    assert still.wear_left[0] == 0.0 and still.wear_right[0] == 0.0


def test_each_wheel_s_coefficients_follow_its_load():
    """A spatial vehicle's wheels under unequal loads Q = q*N0: f11 and f22 grow as q^(2/3), f33 as
    q^(4/3) (Hertz: docs/creep.md), and so does each wheel's T-gamma, term by term."""
    rng = np.random.default_rng(2)
    y, psi, y_dot, psi_dot = _states(rng, 50)
    nominal = PATCH.normal_load
    load = np.full(50, 2 * nominal)
    moment = rng.uniform(-20e3, 20e3, 50)
    forces = contact_forces(_cones(n=50), y, psi, y_dot, psi_dot, V, load, moment, nominal=nominal)
    left, right, xi_y, xi_sp = _tread_creepages(y, psi, y_dot, psi_dot)
    for q, xi_x, wear in ((forces.load_left, left, forces.wear_left), (forces.load_right, right, forces.wear_right)):
        area = (q / nominal) ** (2 / 3)
        expected = area * (F["f11"] * xi_x**2 + F["f22"] * xi_y**2) + area**2 * F["f33"] * xi_sp**2
        np.testing.assert_allclose(wear, expected, rtol=1e-12)


def test_on_the_flange_the_radius_rise_enters_the_longitudinal_creepage():
    """Past the flangeway clearance a coned wheel's radius rises by the flange's slope: its
    longitudinal creepage, and so its T-gamma, grows with it (the flange force itself, normal to
    the flange, dissipates nothing in this model)."""
    slope, clearance = 1.5, 0.008
    p = _cones(flange_slope=slope, clearance=clearance, flange_stiffness=50e6)
    y = 0.010  # the left flange, 2 mm up it
    zero = np.zeros(1)
    forces = contact_forces(p, np.array([y]), zero, zero, zero, V)
    rise_left = LAM * y + (slope - LAM) * (y - clearance)
    assert forces.wear_left[0] == pytest.approx(F["f11"] * (rise_left / R0) ** 2, rel=1e-12)
    assert forces.wear_right[0] == pytest.approx(F["f11"] * (LAM * y / R0) ** 2, rel=1e-12)
    assert forces.wear_left[0] > 5 * forces.wear_right[0]


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH, "falling"])
def test_a_saturated_wheel_dissipates_at_most_mu_q_times_its_slip(law):
    """A saturating law scales a wheel's Kalker forces by one factor in (0, 1], so T-gamma is that
    factor times the linear one, >= 0; and |F| <= mu*Q bounds it: without spin,
    T-gamma = -F.xi <= mu*Q*|xi| per wheel, reached as the wheel slides."""
    falling = law == "falling"
    number = POLACH if falling else law
    more = dict(falling_friction_ratio=0.4, falling_friction_rate=0.6) if falling else {}
    coefficients = {**F, "f23": 0.0, "f33": 0.0}
    n = 400
    p = ContactParameters.broadcast(
        n, r0=R0, b=B, conicity=LAM, law=number, friction_limit=LIMIT, **coefficients, **more
    )
    rng = np.random.default_rng(3)
    y, psi, y_dot, psi_dot = _states(rng, n, scale=10.0)
    forces = contact_forces(p, y, psi, y_dot, psi_dot, V)
    left, right, xi_y, _ = _tread_creepages(y, psi, y_dot, psi_dot)
    for xi_x, wear in ((left, forces.wear_left), (right, forces.wear_right)):
        slip = np.hypot(xi_x, xi_y)
        assert np.all(wear >= 0.0)
        assert np.all(wear <= LIMIT * slip * (1 + 1e-12))
        linear = F["f11"] * xi_x**2 + F["f22"] * xi_y**2
        assert np.all(wear <= linear * (1 + 1e-12))
    # Sliding sideways (y' = 3 m/s: 10 % lateral creepage), each wheel dissipates mu*Q*|xi_y|, with
    # falling friction at its slip velocity's mu, to Polach's approach to its limit (0.1 % here).
    zero = np.zeros(1)
    sliding = contact_forces(_cones(number, **more), zero, zero, np.array([3.0]), zero, V)
    mu_ratio = (1 - 0.4) * math.exp(-0.6 * 3.0) + 0.4 if falling else 1.0
    tolerance = 2e-3 if number == POLACH else 1e-12
    assert sliding.wear_left[0] == pytest.approx(LIMIT * mu_ratio * 0.1, rel=tolerance)


def test_wear_is_never_negative_on_any_law_with_spin():
    """The forces oppose the creepages: T-gamma >= 0 on every law and wheel, with spin, from the
    stick range to full sliding, on cones."""
    rng = np.random.default_rng(4)
    n = 300
    y, psi, y_dot, psi_dot = _states(rng, n, scale=10.0)
    for law in (LINEAR, SHEN_HEDRICK_ELKINS, POLACH, FASTSIM):
        forces = contact_forces(_cones(law, n, **ELLIPSE), y, psi, y_dot, psi_dot, V)
        assert np.all(forces.wear_left >= 0.0) and np.all(forces.wear_right >= 0.0), law


def test_fastsim_s_dissipation_is_the_work_of_its_forces_and_never_negative():
    """FASTSIM gives Fx, Fy and Mz for the creepages; its T-gamma is -(Fx*xi + Fy*eta + Mz*phi), the
    work of its traction against the rigid slip, which is >= 0 over creepages from the stick range to
    full sliding, with spin; at small creepage it is the linear law's f11*xi^2 + f22*eta^2 (the
    grid's slopes within 0.15 %); sliding longitudinally, it is mu*N*|xi|."""
    rng = np.random.default_rng(5)
    size = np.exp(rng.uniform(np.log(1e-6), np.log(0.3), 500))
    angle = rng.uniform(0, 2 * np.pi, 500)
    xi, eta = size * np.cos(angle), size * np.sin(angle)
    phi = rng.choice([0.0, 1.0], 500) * rng.normal(0.0, 3.0, 500)
    a, b, n, g, c11, c22, c23 = (
        ELLIPSE[k] for k in ("semi_axis_a", "semi_axis_b", "normal_force", "shear_modulus", "c11", "c22", "c23")
    )
    fx, fy, moment = fastsim(a, b, n, MU, g, c11, c22, c23, xi, eta, phi)
    wear = -(fx * xi + fy * eta + moment * phi)
    assert np.all(wear >= 0.0)
    # |F| <= mu*N bounds the forces' part, the spin its own.
    assert np.all(wear <= (LIMIT * np.hypot(xi, eta) + np.abs(moment * phi)) * (1 + 1e-12))
    small = 1e-7
    fx, fy, mz = _fastsim(a, b, n, MU, g, c11, c22, c23, small, -small, 0.0, 20, 20)
    assert wear_number(fx, fy, mz, small, -small, 0.0) == pytest.approx((F["f11"] + F["f22"]) * small**2, rel=2e-3)
    # Sliding, the traction is mu*p everywhere: along the slip when it is longitudinal (T-gamma =
    # mu*N*|xi|); at other directions along (xi*C11, eta*C22), FASTSIM's flexibilities', a little
    # off the slip, so T-gamma is at most mu*N*|xi|.
    fx, fy, mz = _fastsim(a, b, n, MU, g, c11, c22, c23, 1e3, 0.0, 0.0, 20, 20)
    assert wear_number(fx, fy, mz, 1e3, 0.0, 0.0) == pytest.approx(LIMIT * 1e3, rel=1e-12)
    fx, fy, mz = _fastsim(a, b, n, MU, g, c11, c22, c23, 0.6, 0.8, 0.0, 20, 20)
    assert 0.99 * LIMIT < wear_number(fx, fy, mz, 0.6, 0.8, 0.0) <= LIMIT * (1 + 1e-12)
    # Through the wheelset law: each wheel's FASTSIM forces at its own creepages.
    y, psi, y_dot, psi_dot = (np.array([v]) for v in (0.004, -0.002, 0.05, 0.2))
    forces = contact_forces(_cones(FASTSIM, **ELLIPSE), y, psi, y_dot, psi_dot, V)
    left, right, xi_y, xi_sp = (float(v[0]) for v in _tread_creepages(y, psi, y_dot, psi_dot))
    for xi_x, got in ((left, forces.wear_left[0]), (right, forces.wear_right[0])):
        fx, fy, mz = _fastsim(a, b, n, MU, g, c11, c22, c23, xi_x, xi_y, xi_sp, 20, 20)
        assert got == pytest.approx(-(fx * xi_x + fy * xi_y + mz * xi_sp), rel=1e-12)


@pytest.fixture(scope="module")
def s1002():
    layout = load_layout(MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml")
    return contact_parameters(Vehicle(layout).model, 1)


@pytest.mark.parametrize("law", [LINEAR, POLACH, FASTSIM])
def test_on_profiles_every_wheel_dissipates_and_the_flange_most(s1002, law):
    """On S1002/60E1, each contact point with its own creepages: T-gamma >= 0 over states across
    the table, flange contact included, on the linear law, Polach's and FASTSIM. A wheelset yawed
    into the rail it flanges on (as it runs in a curve) dissipates far more on the flanging wheel,
    whose contact angle gives it a large spin and rolling-radius difference, than on the other."""
    import dataclasses

    p = dataclasses.replace(s1002, law=law)
    rng = np.random.default_rng(6)
    n = 200
    y = rng.uniform(-0.0085, 0.0085, n)
    psi, y_dot, psi_dot = rng.normal(0.0, 3e-3, n), rng.normal(0.0, 0.05, n), rng.normal(0.0, 0.1, n)
    forces = contact_forces(p, y, psi, y_dot, psi_dot, V)
    assert np.all(np.isfinite(forces.wear_left)) and np.all(np.isfinite(forces.wear_right))
    assert np.all(forces.wear_left >= 0.0) and np.all(forces.wear_right >= 0.0)
    # Run 6.2 mm to the right, onto the right flange (the leading wheelset's place in the steady
    # 300 m curve, docs/track.md), yawed 5 mrad towards the right rail (nose right, psi < 0): the
    # outer wheel of a left curve's leading wheelset. (Past 6.5 mm the planar wheelset's left wheel
    # lifts: the right rail carries it all, and the left wheel dissipates nothing.)
    flanging = contact_forces(p, np.array([-0.0062]), np.array([-0.005]), np.zeros(1), np.zeros(1), V)
    assert flanging.wear_right[0] > 4 * flanging.wear_left[0] > 0.0
    assert math.isfinite(flanging.wear_right[0])
