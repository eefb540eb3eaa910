"""Each body at its own station (rail_mj/track/bodies.py, docs/track.md): the track under every
body, and the suspension's geometric pre-deflections against the chord geometry of the circle.

A point dx ahead on a circle of radius R stands R(1 - cos(dx/R)) = dx^2/(2R) - dx^4/(24R^3) + ...
off the tangent, turned by dx/R: the exact pre-deflections on a curve, which the small-angle
forms dx^2/(2R) and dx/R match to the next term of that series.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rail_mj.track import Track, at_bodies, curve_pre_deflections, pre_deflections, track_from_dict

EPS = np.finfo(float).eps
# The Manchester coach (docs/manchester-coach.md): bogie centres at +/-9.5 m, wheelsets +/-1.28 m in them.
COACH = np.array([9.5 + 1.28, 9.5 - 1.28, -9.5 + 1.28, -9.5 - 1.28])


def design(radius=600.0, cant=0.15) -> Track:
    return track_from_dict(
        {
            "section": [
                {"kind": "straight", "length": 200.0},
                {"kind": "transition", "length": 100.0},
                {"kind": "curve", "length": 300.0, "radius": radius, "cant": cant},
                {"kind": "transition", "length": 100.0},
                {"kind": "straight", "length": 200.0},
            ]
        }
    )


def test_each_body_sees_the_track_at_its_own_station():
    """The coach's wheelsets, its centre at s: each at s + its offset. Entering the transition
    (curvature x'/(R L) at x' into it), the leading wheelset is 10.78 m into it when the
    centre is at its start and the trailing ones are still on the straight. Arrays of reference
    points give one row each."""
    track = design()
    at = at_bodies(track, 200.0, COACH)
    assert np.array_equal(at.x, 200.0 + COACH)
    assert at.curvature.tolist() == pytest.approx([10.78 / 60000, 8.22 / 60000, 0.0, 0.0], abs=1e-18)
    assert at.cant.tolist() == pytest.approx([0.15 * 10.78 / 100, 0.15 * 8.22 / 100, 0.0, 0.0], abs=1e-16)
    s = np.array([0.0, 250.0, 450.0, 880.0])
    many = at_bodies(track, s, COACH)
    assert many.curvature.shape == (4, 4)
    assert np.array_equal(many.curvature, track.curvature(s[:, None] + COACH))
    assert np.all(many.curvature[2] == 1 / 600) and np.all(many.cant[2] == 0.15)


@pytest.mark.parametrize("radius", [600.0, -600.0, 150.0, 3000.0])
@pytest.mark.parametrize("dx", [1.28, -1.28, 9.5, -9.5, 10.78, 30.0])
def test_pre_deflections_on_a_curve_are_the_chord_geometry(radius, dx):
    """On a curve, a child dx ahead of its parent (behind: dx < 0) is turned by dx/R and stands
    R(1 - cos(dx/R)) to the inside of the parent's tangent (to the left in a left curve): to
    rounding, a few ulps of the positions (hundreds of metres). The small-angle forms dx/R
    (exact) and dx^2/(2R) match, the latter to within dx^4/(24|R|^3) (plus rounding)."""
    track = design(radius, 0.1)
    s = 450.0  # mid-curve: both bodies on it
    exact = pre_deflections(track, s, parent=0.0, child=dx)
    k, r = 1 / radius, abs(radius)
    assert float(exact.yaw) == pytest.approx(dx * k, abs=8 * EPS)
    offset = math.copysign(r * (1 - math.cos(dx / r)), radius)
    assert float(exact.lateral) == pytest.approx(offset, abs=100 * EPS * s)
    small = curve_pre_deflections(dx, k)
    assert float(small.yaw) == dx * k
    assert float(small.lateral) == dx**2 * k / 2
    assert abs(float(exact.lateral) - float(small.lateral)) <= dx**4 / (24 * r**3) + 100 * EPS * s
    # The same pair with both offsets moved along the vehicle: only their difference counts.
    moved = pre_deflections(track, s - 3.0, parent=3.0, child=3.0 + dx)
    assert float(moved.lateral) == pytest.approx(float(exact.lateral), abs=100 * EPS * s)


def test_pre_deflections_on_a_straight_are_zero_and_arrays_broadcast():
    """Nothing on a straight; a parent and several children over several reference points."""
    straight = Track.straight(500.0)
    bent = pre_deflections(straight, np.array([[100.0], [300.0]]), parent=0.0, child=COACH)
    assert bent.yaw.shape == bent.lateral.shape == (2, 4)
    assert np.all(bent.yaw == 0.0) and np.abs(bent.lateral).max() < 1e-12


def test_pre_deflections_along_a_transition():
    """Both bodies in the first transition (curvature k0 at the parent, rising at k' = 1/(R L)):
    the yaw is the curvature's integral dx k0 + k' dx^2/2, exact to rounding; the small-angle
    lateral dx^2 k0/2 + k' dx^3/6 is within |dx| psi^3/6 of the exact offset (psi the largest
    turn over dx), as sin(psi) is within psi^3/6 of psi."""
    track = design(150.0, 0.15)
    rate = 1 / (150.0 * 100.0)
    for s, dx in [(230.0, 9.5), (270.0, -9.5), (220.0, 19.0), (285.0, -30.0)]:
        exact = pre_deflections(track, s, parent=0.0, child=dx)
        k0 = (s - 200.0) * rate
        small = curve_pre_deflections(dx, k0, rate)
        assert float(exact.yaw) == pytest.approx(float(small.yaw), abs=8 * EPS)
        psi = max(abs(dx * k0), abs(float(small.yaw)))
        assert abs(float(exact.lateral) - float(small.lateral)) <= abs(dx) * psi**3 / 6 + 100 * EPS * s


def test_pre_deflections_across_a_boundary():
    """A car body on the straight, its leading bogie 9.5 m ahead and 4 m into the transition
    (curvature rising at k' = 1/(600 * 100) 1/m^2): yaw the curvature's integral over those 4 m,
    k' 4^2/2; lateral the integral of sin(k' u^2/2) over them, k' 4^3/6 (the sine's cubic term
    is of order 1e-25 m), while the 5.5 m on the straight add nothing."""
    track = design()
    rate = 1 / 60000
    bent = pre_deflections(track, 194.5, parent=0.0, child=9.5)
    assert float(bent.yaw) == pytest.approx(rate * 4.0**2 / 2, abs=8 * EPS)
    assert float(bent.lateral) == pytest.approx(rate * 4.0**3 / 6, abs=1e-12)
