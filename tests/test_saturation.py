"""Creep saturation laws (reference sheet, section 6): Kalker's slope at zero, never
above mu*N, continuous; and a saturating vehicle keeps every linear result."""

from __future__ import annotations

import numpy as np
import pytest

import tomllib

from conftest import linear_text
from rail_mj.creep import LINEAR, POLACH, SHEN_HEDRICK_ELKINS, ContactParameters, saturation, wheelset_forces
from rail_mj.layout import GRAVITY, LayoutError, layout_from_dict, load_layout
from rail_mj.stability import Stability

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
    p = ContactParameters.broadcast(1, r0=0.46, b=0.75, conicity=0.15, f11=10e6, f22=9e6,
                                    friction_limit=LIMIT, law=law)
    for y_dot in (0.1, 1.0, 10.0):  # lateral slip of 0.3 % to 30 % at 30 m/s
        fy, mz = wheelset_forces(p, np.zeros(1), np.zeros(1), np.array([y_dot]), np.zeros(1), 30.0)
        assert abs(fy[0]) <= 2 * LIMIT * (1 + 1e-12)
    # Creepage far past saturation: the lateral force has reached 2*mu*N, pointing against the slip.
    assert fy[0] == pytest.approx(-2 * LIMIT, rel=0.05 if law == SHEN_HEDRICK_ELKINS else 0.1)


def saturating(tmp_path, law: str):
    text = linear_text("manchester-coach").replace(
        "f33 = 0.0\n", f'f33 = 0.0\nlaw = "{law}"\nfriction = 0.3\n')
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
    # The finite differences (rail_mj.linear, 1e-8 m) see SHE's O(u) curvature at
    # u ~ 1e-6, and Brent stops within 1e-4 of the crossing: agreement to 1e-4.
    assert saturated.critical_speed == pytest.approx(linear.critical_speed, rel=1e-4)
    assert saturated.mode == linear.mode


@pytest.mark.parametrize("change, fragment", [
    ('law = "coulomb"', "creep.law: must be one of linear, shen-hedrick-elkins, polach"),
    ('law = "polach"', "creep.friction: missing"),
    ('law = "polach"\nfriction = 0.0', "creep.friction: must be > 0"),
])
def test_bad_creep_laws(change, fragment, tmp_path):
    text = linear_text("bogie").replace("f22 = 9.0e6\n", f"f22 = 9.0e6\n{change}\n")
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(LayoutError, match=fragment.replace(".", r"\.")):
        load_layout(path)


def test_a_fixed_body_needs_a_wheel_load_for_saturation(tmp_path):
    text = linear_text("bogie").replace(
        "f22 = 9.0e6\n", 'f22 = 9.0e6\nlaw = "polach"\nfriction = 0.3\n')
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(LayoutError, match="wheelset.wheel_load: missing"):
        load_layout(path)
    path.write_text(text.replace("conicity = 0.15\n", "conicity = 0.15\nwheel_load = 55e3\n"))
    assert load_layout(path).wheelset.wheel_load == 55e3
