"""Creep saturation laws (docs/creep.md, section 5): Kalker's slope at zero, never
above mu*N, continuous; and a saturating vehicle keeps every linear result."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from conftest import linear_text

from rail_mj.analysis.stability import Stability
from rail_mj.contact.creep import (
    LINEAR,
    POLACH,
    SHEN_HEDRICK_ELKINS,
    ContactParameters,
    contact_forces,
    falling_friction,
    saturation,
    wheelset_forces,
)
from rail_mj.layout import GRAVITY, LayoutError, layout_from_dict, load_layout

LIMIT = 0.3 * 50e3  # mu*N, N


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH])
def test_slope_at_zero_is_kalkers(law):
    # F(h)/h for h = 1e-6 of the limit: the curvature term makes the error O(h), 1e-6 here.
    h = 1e-6 * LIMIT
    assert saturation(law, np.array([h]), LIMIT)[0] / h == pytest.approx(1.0, rel=2e-6)


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH])
def test_never_above_the_friction_limit_and_monotone(law):
    linear = np.concatenate([np.linspace(0.0, 20 * LIMIT, 200_001), [1e12, 1e300]])
    force = saturation(law, linear, LIMIT)
    assert np.all(force <= LIMIT * (1 + 1e-15)) and np.all(force >= 0.0)
    assert np.all(np.diff(force) >= -1e-9 * LIMIT)  # non-decreasing, to round-off
    assert force[-1] == pytest.approx(LIMIT, rel=1e-9)  # and it reaches the limit


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH])
def test_continuous(law):
    # No jumps: neighbouring samples 1e-6*limit apart differ by at most their spacing
    # (the slope never exceeds Kalker's 1), including SHE's switch at u = 3.
    linear = np.linspace(2.5 * LIMIT, 3.5 * LIMIT, 1_000_001)
    steps = np.diff(saturation(law, linear, LIMIT))
    assert np.max(np.abs(steps)) <= (linear[1] - linear[0]) * (1 + 1e-9)


def test_the_linear_law_is_unchanged():
    linear = np.linspace(0.0, 10 * LIMIT, 11)
    assert np.array_equal(saturation(LINEAR, linear, LIMIT), linear)


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH])
def test_wheelset_forces_are_bounded_by_two_wheels_of_friction(law):
    p = ContactParameters.broadcast(1, r0=0.46, b=0.75, conicity=0.15, f11=10e6, f22=9e6, friction_limit=LIMIT, law=law)
    for y_dot in (0.1, 1.0, 10.0):  # lateral slip of 0.3 % to 30 % at 30 m/s
        fy, _mz = wheelset_forces(p, np.zeros(1), np.zeros(1), np.array([y_dot]), np.zeros(1), 30.0)
        assert abs(fy[0]) <= 2 * LIMIT * (1 + 1e-12)
    # Creepage far past saturation: the lateral force has reached 2*mu*N, pointing against the slip.
    assert fy[0] == pytest.approx(-2 * LIMIT, rel=0.05 if law == SHEN_HEDRICK_ELKINS else 0.1)


def saturating(tmp_path, law: str):
    text = linear_text("manchester-coach").replace("f33 = 0.0\n", f'f33 = 0.0\nlaw = "{law}"\nfriction = 0.3\n')
    path = tmp_path / f"{law}.toml"
    path.write_text(text)
    return load_layout(path)


@pytest.mark.parametrize("law", ["shen-hedrick-elkins", "polach"])
def test_saturation_keeps_the_linear_critical_speed(law, tmp_path):
    """Every law has Kalker's slope at zero, so the linearised vehicle is the same."""
    layout = saturating(tmp_path, law)
    assert layout.wheelset.wheel_load == pytest.approx(GRAVITY * (32000 + 2 * 2615 + 4 * 1813) / 8)
    linear = Stability(layout_from_dict(tomllib.loads(linear_text("manchester-coach")))).critical_speed()
    saturated = Stability(layout).critical_speed()
    # The finite differences (rail_mj.simulation.linear, 1e-8 m) see SHE's O(u) curvature at
    # u ~ 1e-6, and Brent stops within 1e-4 of the crossing: agreement to 1e-4.
    assert saturated.critical_speed == pytest.approx(linear.critical_speed, rel=1e-4)
    assert saturated.mode == linear.mode


@pytest.mark.parametrize(
    "change, fragment",
    [
        ('law = "coulomb"', "creep.law: must be one of linear, shen-hedrick-elkins, polach"),
        ('law = "polach"', "creep.friction: missing"),
        ('law = "polach"\nfriction = 0.0', "creep.friction: must be > 0"),
        (
            'law = "shen-hedrick-elkins"\nfriction = 0.3\nfalling_friction_ratio = 0.4',
            "creep.falling_friction_ratio: falling friction belongs to the polach law",
        ),
        ('law = "polach"\nfriction = 0.3\nfalling_friction_ratio = 0.4', "creep.falling_friction_rate: missing"),
        ('law = "polach"\nfriction = 0.3\nfalling_friction_rate = 0.6', "creep.falling_friction_ratio: missing"),
        (
            'law = "polach"\nfriction = 0.3\nfalling_friction_ratio = 1.5\nfalling_friction_rate = 0.6',
            "creep.falling_friction_ratio: must be <= 1",
        ),
        (
            'law = "polach"\nfriction = 0.3\nfalling_friction_ratio = 0.4\nfalling_friction_rate = -1',
            "creep.falling_friction_rate: must be > 0",
        ),
    ],
)
def test_bad_creep_laws(change, fragment, tmp_path):
    text = linear_text("bogie").replace("f22 = 9.0e6\n", f"f22 = 9.0e6\n{change}\n")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(LayoutError, match=fragment.replace(".", r"\.")):
        load_layout(path)


def test_a_fixed_body_needs_a_wheel_load_for_saturation(tmp_path):
    text = linear_text("bogie").replace("f22 = 9.0e6\n", 'f22 = 9.0e6\nlaw = "polach"\nfriction = 0.3\n')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(LayoutError, match=r"wheelset\.wheel_load: missing"):
        load_layout(path)
    path.write_text(text.replace("conicity = 0.15\n", "conicity = 0.15\nwheel_load = 55e3\n"))
    assert load_layout(path).wheelset.wheel_load == 55e3


# Polach's (2005) falling friction, with illustrative values: mu falls from mu0 (0.3, as in
# the shipped models) towards A*mu0, A = mu_infinity/mu0 = 0.4, at the rate B = 0.6 s/m.
FALLING = dict(friction_limit=LIMIT, falling_friction_ratio=0.4, falling_friction_rate=0.6, law=POLACH)


def lateral_force_against_slip(speed: float, slips: np.ndarray, **law) -> np.ndarray:
    """A centred, unyawed wheelset sliding sideways at y_dot = slip*V: Fy of both wheels."""
    p = ContactParameters.broadcast(len(slips), r0=0.46, b=0.75, conicity=0.15, f11=10e6, f22=9e6, **law)
    zero = np.zeros(len(slips))
    return contact_forces(p, zero, zero, slips * speed, zero, speed).creep_lateral


def test_falling_friction_keeps_kalkers_slope_and_falls_to_its_floor():
    assert falling_friction(LIMIT, 0.4, 0.6, 0.0) == LIMIT  # at pure rolling mu is mu0
    # Kalker's slope at zero: F/slip for slip 1e-9 is 2*f22 to the law's O(u) curvature.
    assert lateral_force_against_slip(30.0, np.array([1e-9]), **FALLING)[0] / 1e-9 == pytest.approx(-2 * 9e6, rel=1e-6)
    slips = np.linspace(0.0, 2.0, 200_001)  # up to 60 m/s of slip at 30 m/s: exp(-0.6*60) ~ 2e-16
    force = -lateral_force_against_slip(30.0, slips, **FALLING)
    assert np.all(force <= 2 * LIMIT) and np.all(force >= 0.0)
    peak = int(np.argmax(force))
    assert 0 < peak < len(slips) - 1  # it rises, then falls: falling friction
    rounding = 1e-12 * LIMIT
    assert np.all(np.diff(force[: peak + 1]) >= -rounding) and np.all(np.diff(force[peak:]) <= rounding)
    # Far past saturation the force is the floor's friction, 2 * A * mu0 * N: Polach's
    # law is then 1 - O(1/eps^3) of its limit, eps ~ 3e3 here, and exp(-B*w) ~ 2e-16.
    assert force[-1] == pytest.approx(2 * 0.4 * LIMIT, rel=1e-9)
    # Continuous: no step larger than Kalker's slope allows between neighbouring samples.
    assert np.max(np.abs(np.diff(force))) <= 2 * 9e6 * (slips[1] - slips[0])


def test_without_falling_friction_polach_is_unchanged():
    slips = np.linspace(0.0, 0.05, 101)
    constant = lateral_force_against_slip(30.0, slips, friction_limit=LIMIT, law=POLACH)
    flat = lateral_force_against_slip(
        30.0, slips, friction_limit=LIMIT, law=POLACH, falling_friction_ratio=1.0, falling_friction_rate=0.6
    )
    assert np.array_equal(constant, flat)


def test_falling_friction_keeps_the_linear_critical_speed(tmp_path):
    """The friction only falls with slip, away from the centred state: the linearised
    vehicle, and so the eigen critical speed, are those of the linear law."""
    text = linear_text("manchester-coach").replace(
        "f33 = 0.0\n",
        'f33 = 0.0\nlaw = "polach"\nfriction = 0.3\nfalling_friction_ratio = 0.4\nfalling_friction_rate = 0.6\n',
    )
    path = tmp_path / "falling.toml"
    path.write_text(text)
    linear = Stability(layout_from_dict(tomllib.loads(linear_text("manchester-coach")))).critical_speed()
    falling = Stability(load_layout(path)).critical_speed()
    assert falling.critical_speed == pytest.approx(linear.critical_speed, rel=1e-4)  # as the other laws


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH])
def test_spin_moment_saturates_with_the_forces(law):
    """Reference case coefficients (docs/contact.md, section 3): f22 13.1 MN, f23 36.5 kN m, f33 121 N m^2.
    Near zero creepage the moment is Kalker's; sliding sideways (xi_y alone) the moment
    f23*xi_y and the force -f22*xi_y saturate together, so the moment stays f23/f22 times
    the lateral force at every slip, and under 2*mu*N*f23/f22."""
    coefficients = dict(
        r0=0.46, b=0.75, conicity=0.15, f11=14.3e6, f22=13.1e6, f23=36.5e3, f33=121.0, friction_limit=LIMIT, law=law
    )
    zero = np.zeros(1)
    small = contact_forces(
        ContactParameters.broadcast(1, **coefficients),
        zero,
        zero,
        np.array([1e-9 * 30.0]),
        np.array([1e-9 * 30.0 / 0.75]),
        30.0,
    )
    linear = 2 * (36.5e3 * 1e-9 - 121.0 * 1e-9 / 0.75)  # xi_y = 1e-9, xi_sp = psi_dot/V
    assert small.spin_moment[0] == pytest.approx(linear, rel=1e-6)  # SHE's 1 - u/3, u ~ 1e-6
    slips = np.geomspace(1e-6, 1.0, 61)
    zero = np.zeros(61)
    sideways = contact_forces(ContactParameters.broadcast(61, **coefficients), zero, zero, slips * 30.0, zero, 30.0)
    np.testing.assert_allclose(sideways.spin_moment, -(36.5e3 / 13.1e6) * sideways.creep_lateral, rtol=1e-12)
    assert np.all(np.abs(sideways.spin_moment) <= 2 * LIMIT * 36.5e3 / 13.1e6 * (1 + 1e-12))


@pytest.mark.parametrize("law", [SHEN_HEDRICK_ELKINS, POLACH])
def test_pure_spin_is_kalkers(law):
    """A yawing wheelset displaced so that its rolling-radius difference exactly feeds its
    yaw rate (xi_x = 0 on both wheels, lam*y/r0 = -b*psi'/V) has no tangential force, so
    nothing saturates: the spin moment is Kalker's -2*f33*xi_sp, with no jump at zero force."""
    p = ContactParameters.broadcast(
        1, r0=0.5, b=0.75, conicity=0.125, f11=14.3e6, f22=13.1e6, f33=121.0, friction_limit=LIMIT, law=law
    )
    psi_dot, speed = 0.1, 30.0
    y = -0.75 * psi_dot * 0.5 / (speed * 0.125)  # exact in binary: the creepages cancel to 0
    zero = np.zeros(1)
    forces = contact_forces(p, np.array([y]), zero, zero, np.array([psi_dot]), speed)
    assert forces.creep_couple[0] == 0.0 and forces.creep_lateral[0] == 0.0
    assert forces.spin_moment[0] == pytest.approx(-2 * 121.0 * psi_dot / speed, rel=1e-12)
