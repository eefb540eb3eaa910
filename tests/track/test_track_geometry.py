"""The track's design geometry (rail_mj/track/geometry.py, docs/track.md) against closed forms:
the circle, the clothoid's Fresnel integrals, the balance speed and practice's cant deficiency.

Tolerances are set by what the formulas leave: where rail-mj computes the closed form itself
(curvature, heading, the circle's chord), rounding, a few units in the last place of the
largest number involved; where it integrates (a transition's position), rounding too, since the
quadrature is exact to 1e-23 of a piece (PIECE_TURN, NODES); where practice rounds a constant
or drops a small angle, exactly that difference.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import fresnel

from rail_mj.track import CANT_BASE, Section, Track, TrackError, track_from_dict
from rail_mj.units import GRAVITY

EPS = np.finfo(float).eps


def curve(radius: float, length: float, cant: float = 0.0) -> Track:
    return track_from_dict({"section": [{"kind": "curve", "length": length, "radius": radius, "cant": cant}]})


def entry(radius: float, transition: float, cant: float = 0.0, curve_length: float = 100.0) -> Track:
    """Straight, transition, curve, transition, straight: the design track."""
    sections = [
        {"kind": "straight", "length": 50.0},
        {"kind": "transition", "length": transition},
        {"kind": "curve", "length": curve_length, "radius": radius, "cant": cant},
        {"kind": "transition", "length": transition},
        {"kind": "straight", "length": 50.0},
    ]
    return track_from_dict({"section": sections})


@pytest.mark.parametrize("radius", [150.0, 600.0, -600.0, 5000.0])
def test_a_curve_is_a_circle(radius):
    """A curve from the start is the circle X = R sin(x/R), Y = ±R(1 - cos(x/R)) (to the left
    for R > 0), over the whole turn and beyond both ends (the track goes on as it starts and
    ends); heading x/R. The chord formula is exact: the error is rounding, a few ulps of R."""
    r, side = abs(radius), math.copysign(1.0, radius)
    track = curve(radius, 2 * math.pi * r)
    x = np.linspace(-50.0, track.length + 50.0, 4001)
    expected = np.stack([r * np.sin(x / r), side * r * (1 - np.cos(x / r))], axis=-1)
    assert np.abs(track.xy(x) - expected).max() < 10 * EPS * r
    assert np.abs(track.heading(x) - x / radius).max() < 10 * EPS * (track.length / r)
    assert np.abs(track.xy(track.length)).max() < 10 * EPS * r  # once round, back at the start
    assert np.all(track.curvature(x) == 1 / radius)


@pytest.mark.parametrize(("radius", "length"), [(600.0, 100.0), (150.0, 300.0), (-1200.0, 150.0), (10.0, 500.0)])
def test_a_transition_from_straight_is_a_clothoid(radius, length):
    """From a straight into a curve of radius R over L: curvature x/(R L), linear; heading
    x^2/(2 R L), quadratic; position the clothoid's Fresnel integrals with A^2 = |R| L:
    X = A sqrt(pi) C(x/(A sqrt(pi))), Y = ±A sqrt(pi) S(...). The last case turns the tangent
    through 25 rad, a hundred quadrature pieces. To rounding: 1e-12 m over hundreds of metres."""
    track = track_from_dict(
        {"section": [{"kind": "transition", "length": length}, {"kind": "curve", "length": 10.0, "radius": radius}]}
    )
    x = np.linspace(0.0, length, 2001)
    assert np.abs(track.curvature(x) - x / (radius * length)).max() < 4 * EPS / abs(radius)
    assert np.abs(track.heading(x) - x**2 / (2 * radius * length)).max() < 4 * EPS * length / abs(radius)
    a = math.sqrt(abs(radius) * length)
    s, c = fresnel(x / (a * math.sqrt(math.pi)))
    expected = np.stack([a * math.sqrt(math.pi) * c, math.copysign(1.0, radius) * a * math.sqrt(math.pi) * s], axis=-1)
    assert np.abs(track.xy(x) - expected).max() < 1e-12


def test_a_transition_between_two_curves():
    """A compound curve, 1000 m then 400 m radius with a transition between (the case where
    one Fresnel integral loses digits): the position against an adaptive quadrature of
    cos and sin of the closed-form heading, to its tolerance."""
    track = track_from_dict(
        {
            "section": [
                {"kind": "curve", "length": 80.0, "radius": 1000.0, "cant": 0.05},
                {"kind": "transition", "length": 120.0},
                {"kind": "curve", "length": 80.0, "radius": 400.0, "cant": 0.12},
            ]
        }
    )
    k0, k1 = 1 / 1000, 1 / 400

    def heading(x):
        if x <= 80.0:
            return k0 * x
        if x <= 200.0:
            u = x - 80.0
            return k0 * 80.0 + k0 * u + (k1 - k0) * u * u / 240.0
        return k0 * 80.0 + (k0 + k1) * 60.0 + k1 * (x - 200.0)

    for x in (40.0, 80.0, 130.0, 200.0, 280.0):
        expected = [
            quad(lambda t: math.cos(heading(t)), 0, x, points=[80.0, 200.0], epsabs=1e-13, epsrel=1e-13)[0],
            quad(lambda t: math.sin(heading(t)), 0, x, points=[80.0, 200.0], epsabs=1e-13, epsrel=1e-13)[0],
        ]
        assert np.abs(track.xy(x) - expected).max() < 1e-10
        assert float(track.heading(x)) == pytest.approx(heading(x), abs=1e-15)
    assert float(track.cant(140.0)) == pytest.approx(0.05 + 0.07 * 60.0 / 120.0, abs=1e-16)


def test_the_design_track_ends_where_the_closed_forms_put_it():
    """Straight, clothoid, circle, clothoid, straight, composed from their closed forms: the
    clothoid of A^2 = R L ends at (A sqrt(pi) C(t), A sqrt(pi) S(t)), t = L/(A sqrt(pi)), turned
    by L/(2R); the circle's chord is 2R sin(Lc/(2R)) at half its turn; the way out is the way in
    mirrored, (X, -Y) in the frame of its end. The example track (models/tracks) ends at
    (817.902, 283.202) m, heading (300 + 100)/600 rad."""
    r, lt, lc, ls = 600.0, 100.0, 300.0, 200.0
    track = track_from_dict(
        {
            "section": [
                {"kind": "straight", "length": ls},
                {"kind": "transition", "length": lt},
                {"kind": "curve", "length": lc, "radius": r, "cant": 0.15},
                {"kind": "transition", "length": lt},
                {"kind": "straight", "length": ls},
            ]
        }
    )
    a = math.sqrt(r * lt) * math.sqrt(math.pi)
    s, c = fresnel(lt / a)
    clothoid = complex(a * c, a * s)
    turn_in, turn_curve = lt / (2 * r), lc / r
    z = ls + clothoid
    z += 2 * r * math.sin(turn_curve / 2) * np.exp(1j * (turn_in + turn_curve / 2))
    heading = 2 * turn_in + turn_curve
    z += clothoid.conjugate() * np.exp(1j * heading)
    z += ls * np.exp(1j * heading)
    assert np.abs(track.xy(track.length) - [z.real, z.imag]).max() < 1e-10
    assert float(track.heading(track.length)) == pytest.approx(heading, abs=4 * EPS)
    assert track.xy(track.length).round(3).tolist() == [817.902, 283.202]


def test_everything_is_continuous_through_transitions():
    """Straight, transition, curve, transition, straight: curvature, cant, heading and position
    have no step at any boundary: 2 nm apart, either side of it, they differ by at most their
    slope (on the ramps 1/600 per 100 m of curvature, 150 mm per 100 m of cant; the heading's, the
    curvature; the position's, 1) times 2 nm, and rounding. At a boundary the section that starts
    there holds x. The heading after it all is the curvature times the curve's length plus half of
    each transition's."""
    track = entry(600.0, 100.0, cant=0.15)
    gap, k = 2e-9, 1 / 600
    for section in track.sections[1:]:
        b = section.start
        before, after = b - gap / 2, b + gap / 2
        assert abs(float(track.curvature(after) - track.curvature(before))) <= gap * k / 100.0 + 4 * EPS * k
        assert abs(float(track.cant(after) - track.cant(before))) <= gap * 0.15 / 100.0 + 4 * EPS * 0.15
        assert abs(float(track.heading(after) - track.heading(before))) <= gap * k + 4 * EPS
        assert np.abs(track.xy(after) - track.xy(before)).max() <= gap + 4 * EPS * track.length
        assert track.section_at(b) is section
    assert float(track.heading(track.length)) == pytest.approx((100.0 + 100.0) / 600.0, abs=1e-15)
    assert float(track.curvature(100.0)) == pytest.approx(0.5 / 600.0, abs=1e-18)  # halfway up the ramp
    assert float(track.cant(100.0)) == pytest.approx(0.075, abs=1e-16)


def test_cant_is_signed_with_the_curve():
    """The convention, once (docs/track.md): positive cant raises the right rail, the outer rail
    of a left curve. A left curve given 150 mm of cant has cant +0.15 and cant angle
    asin(0.15/1.5); a right curve -0.15. Standing still, the weight's part in the tilted track plane
    pulls the vehicle towards the low rail, the left one in a left curve: the rails must push it
    to the right, an uncompensated acceleration of -g sin(phi) = -0.1 g."""
    left, right = curve(600.0, 100.0, cant=0.15), curve(-600.0, 100.0, cant=0.15)
    assert float(left.cant(50.0)) == 0.15 and float(right.cant(50.0)) == -0.15
    assert float(left.cant_angle(50.0)) == math.asin(0.15 / 1.5) == -float(right.cant_angle(50.0))
    assert float(left.curvature(50.0)) > 0 > float(right.curvature(50.0))
    at_rest = float(left.uncompensated_acceleration(50.0, 0.0))
    assert at_rest == pytest.approx(-GRAVITY * 0.1, rel=4 * EPS)
    assert float(right.uncompensated_acceleration(50.0, 0.0)) == -at_rest
    assert left.curves[0].cant == 0.15 and right.curves[0].cant == -0.15
    # Negative cant raises the inner rail: the left one of a left curve, the right one of a right curve.
    assert float(curve(600.0, 10.0, cant=-0.05).cant(5.0)) == -0.05
    assert float(curve(-600.0, 10.0, cant=-0.05).cant(5.0)) == 0.05
    assert math.copysign(1.0, float(curve(-600.0, 10.0).cant(5.0))) == 1.0  # a level curve: +0, not -0


@pytest.mark.parametrize(("radius", "cant"), [(600.0, 0.15), (-600.0, 0.15), (250.0, 0.18), (3000.0, 0.05)])
def test_the_balance_speed(radius, cant):
    """At V = sqrt(g R d/1.5) the cant deficiency is zero (to rounding) and the track-plane
    uncompensated acceleration V^2 cos(phi)/R - g sin(phi) = g sin(phi)(cos(phi) - 1), of order
    g phi^3/2: 5 mm/s^2 at 150 mm of cant. At sqrt(g R tan(phi)) it is zero to rounding."""
    track = curve(radius, 100.0, cant)
    phi = math.asin(cant / CANT_BASE)
    v = math.sqrt(GRAVITY * abs(radius) * cant / CANT_BASE)
    assert abs(float(track.cant_deficiency(50.0, v))) < 4 * EPS * cant
    a = float(track.uncompensated_acceleration(50.0, v))
    assert a == pytest.approx(math.copysign(1.0, radius) * GRAVITY * math.sin(phi) * (math.cos(phi) - 1), rel=1e-9)
    assert abs(a) <= GRAVITY * phi**3 / 2
    exact = math.sqrt(GRAVITY * abs(radius) * math.tan(phi))
    assert abs(float(track.uncompensated_acceleration(50.0, exact))) < 8 * EPS * GRAVITY


@pytest.mark.parametrize(("radius", "cant", "kmh"), [(600.0, 0.15, 120.0), (-600.0, 0.15, 120.0), (1200.0, 0.1, 200.0)])
def test_cant_deficiency_is_practices_formula(radius, cant, kmh):
    """Practice writes the cant deficiency in mm as I = 11.8 V^2/R - d (V in km/h): its 11.8 is
    1500/(3.6^2 g) = 11.7984 rounded, so the two differ by exactly (1500/(3.6^2 g) - 11.8) V^2/R,
    1.4e-4 of the first term. g I/1.5 is the uncompensated acceleration to within exactly
    V^2 kappa (1 - cos(phi)) <= V^2 kappa phi^2/2, the small-angle error."""
    track = curve(radius, 100.0, cant)
    v, side = kmh / 3.6, math.copysign(1.0, radius)
    deficiency = float(track.cant_deficiency(50.0, v))
    practice = side * (11.8 * kmh**2 / abs(radius) - cant * 1e3)  # mm
    rounding = side * (1500 / (3.6**2 * GRAVITY) - 11.8) * kmh**2 / abs(radius)
    assert deficiency * 1e3 - practice == pytest.approx(rounding, abs=1e-10)
    assert abs(deficiency * 1e3 - practice) < 2e-4 * 11.8 * kmh**2 / abs(radius)
    phi = math.asin(cant / CANT_BASE)
    a = float(track.uncompensated_acceleration(50.0, v))
    small_angle = GRAVITY * deficiency / CANT_BASE
    assert a - small_angle == pytest.approx(-(v**2) / radius * (1 - math.cos(phi)), abs=1e-13)
    assert abs(a - small_angle) <= v**2 / abs(radius) * phi**2 / 2


def test_straight_track():
    """The default track: level and straight, X = x; a length that is not positive is refused."""
    track = Track.straight(250.0)
    x = np.array([[0.0, 10.0], [100.0, 250.0]])
    assert track.length == 250.0
    assert np.all(track.curvature(x) == 0) and np.all(track.cant(x) == 0) and np.all(track.heading(x) == 0)
    assert track.xy(x).shape == (2, 2, 2)
    assert np.array_equal(track.xy(x)[..., 0], x) and np.all(track.xy(x)[..., 1] == 0)
    assert np.all(track.uncompensated_acceleration(x, 50.0) == 0) and track.curves == ()
    for bad in (0.0, -5.0, math.nan):
        with pytest.raises(TrackError, match="<straight track>: section 1 \\(straight\\)"):
            Track.straight(bad)


def test_beyond_the_ends_the_track_goes_on_as_it_starts_and_ends():
    """Curvature and cant hold their end values; heading and position follow the end's
    circle or straight (a vehicle at the start or the end has all its bodies on track)."""
    track = entry(600.0, 100.0, cant=0.15)
    assert float(track.curvature(-30.0)) == 0.0 and float(track.cant(track.length + 30.0)) == 0.0
    end = track.xy(track.length)
    psi = float(track.heading(track.length))
    assert np.allclose(track.xy(track.length + 30.0), end + 30.0 * np.array([math.cos(psi), math.sin(psi)]), atol=1e-12)
    assert np.allclose(track.xy(-30.0), [-30.0, 0.0], atol=1e-15)
    inside = curve(300.0, 100.0, cant=0.1)
    assert float(inside.cant(-5.0)) == 0.1 and float(inside.heading(-5.0)) == pytest.approx(-5.0 / 300.0, abs=1e-17)


def test_sections_and_curves_by_distance():
    """section_at and section_index: the section that starts at a boundary holds it; before
    the start the first, beyond the end the last. `curves` are the curves' constant parts."""
    track = entry(-800.0, 60.0, cant=0.1)
    assert [s.kind for s in track.sections] == ["straight", "transition", "curve", "transition", "straight"]
    assert track.section_index([-1.0, 0.0, 49.9, 50.0, 110.0, 1e6]).tolist() == [0, 0, 0, 1, 2, 4]
    (c,) = track.curves
    assert (c.start, c.end, c.radius, c.cant, c.number, c.label) == (110.0, 210.0, -800.0, -0.1, 3, "section 3 (curve)")
    assert track.sections[1].cant is None  # a transition's varies


def test_vectorised_in_any_shape():
    """Arrays in, arrays out, of the same shape (xy adds a last axis of 2); NaN stays NaN."""
    track = entry(600.0, 100.0, cant=0.15)
    x = np.linspace(-10.0, track.length + 10.0, 24).reshape(2, 3, 4)
    for f in (track.curvature, track.cant, track.cant_angle, track.heading):
        values = f(x)
        assert values.shape == x.shape
        assert np.array_equal(values.ravel(), [float(f(v)) for v in x.ravel()])
    assert track.xy(x).shape == (2, 3, 4, 2)
    speeds = np.array([[[10.0]], [[40.0]]])
    assert track.uncompensated_acceleration(x, speeds).shape == x.shape
    assert np.isnan(track.curvature(math.nan)) and np.isnan(track.xy(math.nan)).all()


def test_a_track_is_checked_when_built():
    """Sections must follow each other without gaps, with finite numbers and a known kind."""
    first = Section(1, "straight", 0.0, 10.0, 0.0, 0.0, 0.0, 0.0)
    with pytest.raises(
        TrackError, match=r"^t: section 2 \(curve\): starts at 11 m, not where the track before it ends \(10 m\)$"
    ):
        Track((first, Section(2, "curve", 11.0, 10.0, 0.01, 0.01, 0.0, 0.0, 100.0)), "t")
    with pytest.raises(TrackError, match="must be finite"):
        Track((Section(1, "curve", 0.0, 10.0, math.inf, math.inf, 0.0, 0.0),), "t")
    with pytest.raises(TrackError, match="kind must be one of"):
        Track((Section(1, "spiral", 0.0, 10.0, 0.0, 0.0, 0.0, 0.0),), "t")
    with pytest.raises(TrackError, match=r"^t: no sections"):
        Track((), "t")
