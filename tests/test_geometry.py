"""Contact geometry of a rigid wheelset (rail_mj/geometry.py, docs/geometry.md), the
[profiles] layout table and `rail-mj contact-geometry`."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from rail_mj import geometry
from rail_mj.geometry import Track, contact_table, gaps
from rail_mj.profiles import Profile, rail_60e1, s1002

MODELS = Path(__file__).resolve().parent.parent / "models"
LAMBDA, R0 = 0.05, 0.46


def cone_wheel(lam=LAMBDA):
    """A straight tread of conicity lam across 120 mm: z = -(r - r0) = lam * s."""
    s = np.array([-0.06, 0.06])
    return Profile("cone", "wheel", s, lam * s)


def knife_rail():
    """A knife edge: the apex at (0, 0), 45-degree sides down to 20 mm below it."""
    return Profile("knife", "rail", np.array([-0.02, 0.0, 0.02]), np.array([-0.02, 0.0, -0.02]))


@pytest.fixture(scope="module")
def standard():
    return contact_table(Track(s1002(), rail_60e1()))


def exact_cone_on_knives(y, track, apex):
    """Roll and both rolling radii of the cone wheelset on knife edges at +/-apex, from the
    straight lines themselves: an independent closed form (brentq on the roll)."""
    d, r0, lam = track.taping_half_spacing, track.r0, LAMBDA

    def wheel_on(k, phi):
        """(Y, r): where side k's section passes over its knife. In the axle frame a point
        (Y, -r) with r = r0 + lam d - lam k Y lands at y + Y cos(phi) + r sin(phi): linear in Y."""
        big_y = (k * apex - y - (r0 + lam * d) * math.sin(phi)) / (math.cos(phi) - lam * k * math.sin(phi))
        return big_y, r0 + lam * d - lam * k * big_y

    def height(k, phi):  # the wheel's z over the knife, axle centre at 0
        big_y, r = wheel_on(k, phi)
        return big_y * math.sin(phi) - r * math.cos(phi)

    phi = brentq(lambda p: height(1, p) - height(-1, p), -0.1, 0.1, xtol=1e-16)
    return phi, wheel_on(1, phi)[1], wheel_on(-1, phi)[1]


def test_cone_on_knife_edges_gives_the_closed_form():
    track = Track(cone_wheel(), knife_rail(), rail_inclination=0.0, r0=R0)
    ys = np.linspace(-0.008, 0.008, 17)
    t = contact_table(track, ys=ys)
    for i, y in enumerate(ys):
        # the apex 14 mm outside the gauge point: the side is at 45 degrees
        phi, r_left, r_right = exact_cone_on_knives(y, track, track.track_gauge / 2 + 0.014)
        # The apex is sharp and exact (a polyline), so only rounding separates them: 1e-10.
        assert t.roll[i] == pytest.approx(phi, abs=1e-10)
        assert t.r_left[i] == pytest.approx(r_left, abs=1e-10)
        assert t.r_right[i] == pytest.approx(r_right, abs=1e-10)
        # The contact angle is atan(lam) on the wheelset, +/- its roll in the track frame: 1e-12.
        assert t.contact_angle_left[i] - t.roll[i] == pytest.approx(math.atan(LAMBDA), abs=1e-12)
        assert t.contact_angle_right[i] + t.roll[i] == pytest.approx(math.atan(LAMBDA), abs=1e-12)
    # Delta r = 2 lam y, the textbook cone, up to the roll: rolling about the axle moves both
    # wheels' lowest points r0*phi sideways, so Delta r = 2 lam (y + r0 phi) to first order in
    # the roll (1e-4 relative: the exact lines add lam*d*phi and cosines), which is
    # 2 lam y * b / (b - lam r0), 3.2 % more here (lam r0 / b = 0.031): within 3.5 %.
    np.testing.assert_allclose(t.delta_r, 2 * LAMBDA * (ys + R0 * t.roll), rtol=1e-4, atol=1e-12)
    nonzero = ys != 0
    ratio = t.delta_r[nonzero] / (2 * LAMBDA * ys[nonzero])
    assert np.all((ratio > 1.0) & (ratio < 1.035))


def test_cone_on_canted_knife_edges():
    """Canted 1:40, the knife's inner side leans 45 + 1.4 degrees: the gauge point 14 mm
    below the apex moves, and with it the apex; the closed form at the apex's new place."""
    track = Track(cone_wheel(), knife_rail(), rail_inclination=1 / 40, r0=R0)
    t = contact_table(track, ys=[-0.004, 0.003])
    delta = math.atan(1 / 40)
    # The inner side, u = -w .. 0 at z = u, canted: the point 14 mm below the (unmoved) apex.
    # q(u) = cos(delta) u - sin(delta) u, z(u) = sin(delta) u + cos(delta) u = -0.014
    u = -0.014 / (math.sin(delta) + math.cos(delta))
    apex = track.track_gauge / 2 - (math.cos(delta) - math.sin(delta)) * u
    for i, y in enumerate([-0.004, 0.003]):
        phi, r_left, r_right = exact_cone_on_knives(y, track, apex)
        assert t.roll[i] == pytest.approx(phi, abs=1e-10)
        assert t.r_left[i] == pytest.approx(r_left, abs=1e-10)
        assert t.r_right[i] == pytest.approx(r_right, abs=1e-10)
    np.testing.assert_allclose(t.contact_angle_left - t.roll, math.atan(LAMBDA), atol=1e-12)


def test_symmetric_pair_is_odd(standard):
    t = standard
    assert t.y[200] == 0.0
    np.testing.assert_allclose(t.delta_r, -t.delta_r[::-1], atol=1e-9)
    np.testing.assert_allclose(t.contact_angle_left, t.contact_angle_right[::-1], atol=1e-9)
    np.testing.assert_allclose(t.roll, -t.roll[::-1], atol=1e-9)
    np.testing.assert_allclose(t.contact_y_left, -t.contact_y_right[::-1], atol=1e-9)


def test_centred_wheelset(standard):
    t, i = standard, 200
    wheel = s1002()
    assert t.roll[i] == pytest.approx(0.0, abs=1e-12)
    for side in ("left", "right"):
        s = getattr(t, f"wheel_s_{side}")[i]
        # r = r0 + F at the contact, F = -z of the wheel profile: 1e-12 m
        assert getattr(t, f"r_{side}")[i] == pytest.approx(R0 - float(wheel.height(s)), abs=1e-12)
    assert t.r_left[i] == pytest.approx(t.r_right[i], abs=1e-12)


def test_no_penetration_anywhere(standard):
    t = standard
    s = np.linspace(-0.055, 0.06, 100_001)  # 1.15 um apart, 90 times the solver's coarse search
    for i in range(0, len(t.y), 8):
        for side in ("left", "right"):
            g = gaps(t, i, side, s)
            assert np.nanmin(g) > -1e-9, (t.y[i], side)      # nowhere into the rail
            assert np.nanmin(g) < 1e-9, (t.y[i], side)       # and touching it


def test_flange_contact_and_the_jump(standard):
    t = standard
    flange = np.flatnonzero(t.contact_angle_left > 1.0)
    assert len(flange) and t.y[flange[0]] < 0.010
    k = flange[0]
    # on the flange: about 70 degrees (S1002's flank is 70.0 degrees)
    assert 1.1 < t.contact_angle_left[k] < 1.3
    # Delta r jumps there: more than 5 mm of rolling radius within one 0.05 mm step
    assert t.delta_r[k] - t.delta_r[k - 1] > 0.005
    # At the step itself tread and flange touch together: bisect y to 1 nm between the
    # rows and the last tread row there shows a second contact (gap2 within 1e-5 m).
    track = t.track
    lo, hi = t.y[k - 1], t.y[k]
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        on_flange = contact_table(track, ys=[mid]).contact_angle_left[0] > 1.0
        lo, hi = (lo, mid) if on_flange else (mid, hi)
    row = contact_table(track, ys=[lo])
    assert row.two_point_left[0] == 1.0
    # S1002's 13 mm throat arc meets 60E1's 13 mm gauge corner: the points are a few mm
    # apart across the wheel, their contact angles more than 0.1 rad apart.
    assert abs(row.contact_angle2_left[0] - row.contact_angle_left[0]) > 0.1
    assert abs(row.contact_y2_left[0] - row.contact_y_left[0]) > 1e-3
    assert 0 <= row.gap2_left[0] <= geometry.TWO_POINT_GAP
    assert row.two_point_right[0] == 0.0


def test_csv_has_the_contract_columns_first(standard):
    text = standard.to_csv().decode()
    header = text.splitlines()[0].split(",")
    assert header[:7] == ["y_m", "r_left_m", "r_right_m", "delta_r_m", "contact_angle_left_rad",
                          "contact_angle_right_rad", "roll_rad"]
    assert "z_m" in header and "two_point_left" in header
    rows = np.loadtxt(text.splitlines()[1:], delimiter=",")
    assert rows.shape == (401, len(header))
    np.testing.assert_allclose(rows[:, 3], rows[:, 1] - rows[:, 2], atol=1e-11)


def test_delta_r_feeds_the_conicity(standard):
    d = geometry.delta_r(standard)
    assert d.centre[0] == pytest.approx(0.0, abs=1e-12) and d.centre[0] == d.centre[1]
    value = geometry.equivalent_conicity(standard, 3.0)
    assert 0.05 < value < 0.5  # a plausible new-profile value; the number is printed in the docs
