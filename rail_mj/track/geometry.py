"""The track's design geometry along its length: curvature, cant, heading and plane position.

A `Track` is a row of sections, each with curvature and cant linear in the distance along it:
constant on a straight or a curve, a ramp on a transition (a clothoid). Curvature, cant and
heading are therefore closed forms; the plane position is the chord of a circle on straights
and curves, and on transitions a Gauss-Legendre quadrature accurate to rounding. Every function
of the distance x takes and gives numpy arrays (a number gives a 0-d array).

The signs, defined here once (docs/track.md explains them; docs/frames.md has the rest):

- x, m: distance along the track centreline from its start, in the direction of travel.
- curvature, 1/m: positive where the track turns left (towards +y); a curve of radius R has 1/R.
- cant, m: the height of the right rail over the left, over `CANT_BASE` = 1.5 m between the rail
  centres. It is signed as the curvature: a left curve raises its outer rail, the right one, and
  has positive cant; a right curve raises the left rail and has negative cant. The track plane
  rolls about the centreline at rail level (the right rail up by cant/2, the left down by as
  much), so its roll about +x is minus the cant angle.
- cant angle, rad: asin(cant / 1.5), signed as the cant.
- heading, rad: the direction of the tangent from that at the start, positive to the left: the
  integral of the curvature.
- plane position, m: (X, Y) of the centreline in a level frame with the track's start at the
  origin heading along +X and Y to the left.

Beyond its ends a track goes on as it starts and ends: curvature and cant hold their values at
x = 0 and x = length, heading and position follow that circle or straight. A vehicle standing
at the start or the end of a track thus has every body on track.

Example:

    >>> track = Track.straight(100.0)
    >>> track.length, float(track.curvature(40.0)), track.xy([0.0, 40.0]).tolist()
    (100.0, 0.0, [[0.0, 0.0], [40.0, 0.0]])
    >>> from rail_mj.track import track_from_dict
    >>> curve = track_from_dict({"section": [{"kind": "curve", "length": 300.0, "radius": 600.0, "cant": 0.15}]})
    >>> round(float(curve.heading(300.0)), 12)  # 300 m of a 600 m radius: half a radian, to the left
    0.5
    >>> round(float(curve.cant_deficiency(150.0, speed=120 / 3.6)) * 1e3)  # mm, at 120 km/h
    133
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rail_mj.track.errors import TrackError
from rail_mj.units import GRAVITY

if TYPE_CHECKING:
    from rail_mj.track.irregularities import Irregularities

Array = NDArray[np.float64]

# The distance between the rail centres on standard gauge, over which cant is given (EN 13803
# quotes every cant over 1500 mm for the 1435 mm gauge).
CANT_BASE = 1.5  # m
KINDS = ("straight", "transition", "curve")

# A transition's plane position: Gauss-Legendre quadrature of exp(i*heading) over pieces short
# enough that the tangent turns by at most PIECE_TURN along one. NODES nodes integrate it exactly
# up to a term of order PIECE_TURN**(2*NODES)/(2*NODES)! of the piece's length, 1e-23 here:
# rounding is all that is left. (Fresnel integrals would do one piece but lose digits when the
# curvature at both ends is nearly the same, a compound curve's transition.)
PIECE_TURN = 0.25  # rad
NODES = 8
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(NODES)


@dataclasses.dataclass(frozen=True)
class Section:
    """One stretch of the track, its curvature and cant linear from its start to its end (both
    signed as `Track.curvature` and `Track.cant`)."""

    number: int  # 1-based, in the order of the track
    kind: str  # one of KINDS
    start: float  # m along the track
    length: float  # m
    curvature_start: float  # 1/m
    curvature_end: float
    cant_start: float  # m
    cant_end: float
    radius: float | None = None  # a curve's, m, signed as its curvature; None for the others

    @property
    def end(self) -> float:
        return self.start + self.length

    @property
    def cant(self) -> float | None:
        """A straight's or a curve's cant (m, signed); None on a transition, where it varies."""
        return self.cant_start if self.cant_start == self.cant_end else None

    @property
    def label(self) -> str:
        """How messages name it: 'section 3 (curve)'."""
        return f"section {self.number} ({self.kind})"


@dataclasses.dataclass(frozen=True)
class Track:
    """A checked track: its sections in order, from x = 0 to `length`, each starting where the
    one before ends. Read one with `rail_mj.track.load_track`; `Track.straight` is the default."""

    sections: tuple[Section, ...]
    source: str = dataclasses.field(default="<track>", compare=False)
    # Legal values far outside railway practice and steps between sections with no transition
    # (rail_mj.practice), one line each.
    warnings: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    # [irregularities] (rail_mj.track.irregularities), or None: perfect track.
    irregularities: Irregularities | None = None
    # The sections as arrays, for vectorised look-ups (set once, by __post_init__).
    _starts: Array = dataclasses.field(init=False, repr=False, compare=False)
    _lengths: Array = dataclasses.field(init=False, repr=False, compare=False)
    _k0: Array = dataclasses.field(init=False, repr=False, compare=False)
    _k1: Array = dataclasses.field(init=False, repr=False, compare=False)
    _d0: Array = dataclasses.field(init=False, repr=False, compare=False)
    _d1: Array = dataclasses.field(init=False, repr=False, compare=False)
    _heading0: Array = dataclasses.field(init=False, repr=False, compare=False)
    # The pieces the plane position is integrated over (Track._pieces).
    _piece_start: Array = dataclasses.field(init=False, repr=False, compare=False)
    _piece_heading: Array = dataclasses.field(init=False, repr=False, compare=False)
    _piece_k: Array = dataclasses.field(init=False, repr=False, compare=False)
    _piece_rate: Array = dataclasses.field(init=False, repr=False, compare=False)
    _piece_z: NDArray[np.complex128] = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.sections:
            raise TrackError(f"{self.source}: no sections: a track needs at least one")
        end = 0.0
        for section in self.sections:
            numbers = [section.start, section.length, section.curvature_start, section.curvature_end]
            numbers += [section.cant_start, section.cant_end]
            if not all(math.isfinite(v) for v in numbers):
                raise TrackError(f"{self.source}: {section.label}: its numbers must be finite, got {numbers}")
            if section.kind not in KINDS:
                raise TrackError(f"{self.source}: {section.label}: the kind must be one of {', '.join(KINDS)}")
            if section.length <= 0.0:
                raise TrackError(f"{self.source}: {section.label}: length must be > 0 m, got {section.length:g}")
            if section.start != end:
                raise TrackError(
                    f"{self.source}: {section.label}: starts at {section.start:g} m, not where the track "
                    f"before it ends ({end:g} m)"
                )
            end = section.end
        starts = np.array([s.start for s in self.sections])
        heading0 = [0.0]  # the heading at each section's start
        for s in self.sections[:-1]:
            heading0.append(heading0[-1] + (s.curvature_start + s.curvature_end) / 2 * s.length)
        fields = {
            "_starts": starts,
            "_lengths": np.array([s.length for s in self.sections]),
            "_k0": np.array([s.curvature_start for s in self.sections]),
            "_k1": np.array([s.curvature_end for s in self.sections]),
            "_d0": np.array([s.cant_start for s in self.sections]),
            "_d1": np.array([s.cant_end for s in self.sections]),
            "_heading0": np.array(heading0),
        }
        pieces = self._pieces(heading0)
        fields.update(zip(("_piece_start", "_piece_heading", "_piece_k", "_piece_rate", "_piece_z"), pieces))
        for name, value in fields.items():
            object.__setattr__(self, name, value)

    def _pieces(self, heading0: list[float]) -> tuple[Array, Array, Array, Array, NDArray[np.complex128]]:
        """The pieces the plane position is integrated over: each straight and curve whole, each
        transition in pieces along which the tangent turns by at most PIECE_TURN. For each piece
        its start (m), heading and curvature there, the rate of change of curvature (1/m^2) and
        the position of its start (X + iY)."""
        start, heading, k, rate = [], [], [], []
        for s, psi in zip(self.sections, heading0):
            slope = (s.curvature_end - s.curvature_start) / s.length
            turn = max(abs(s.curvature_start), abs(s.curvature_end)) * s.length
            n = 1 if slope == 0.0 else max(1, math.ceil(turn / PIECE_TURN))
            for j in range(n):
                u = s.length * j / n
                start.append(s.start + u)
                heading.append(psi + s.curvature_start * u + slope * u * u / 2)
                k.append(s.curvature_start + slope * u)
                rate.append(slope)
        starts = np.array(start)
        lengths = np.diff(np.append(starts, self.sections[-1].end))
        steps = _advance(np.array(heading), np.array(k), np.array(rate), lengths)
        z = np.concatenate([[0j], np.cumsum(steps)[:-1]])
        return starts, np.array(heading), np.array(k), np.array(rate), z

    @classmethod
    def straight(cls, length: float, source: str = "<straight track>") -> Track:
        """A straight, level track `length` m long: what a run has when it is given no track."""
        return cls((Section(1, "straight", 0.0, float(length), 0.0, 0.0, 0.0, 0.0),), source)

    @property
    def length(self) -> float:
        """m, from the start to the end of the last section."""
        return self.sections[-1].end

    @property
    def curves(self) -> tuple[Section, ...]:
        """The curves' constant parts, in order: each has start, end, radius and cant."""
        return tuple(s for s in self.sections if s.kind == "curve")

    # --- where x is ------------------------------------------------------------------------------

    def _locate(self, x: ArrayLike) -> tuple[Array, NDArray[np.intp], Array]:
        """x as an array, the index of the section holding it (at a boundary, the section that
        starts there) and the distance into that section, with x held to [0, length]."""
        x = np.asarray(x, dtype=float)
        held = np.clip(x, 0.0, self.length)
        i = np.clip(np.searchsorted(self._starts, held, side="right") - 1, 0, len(self.sections) - 1)
        return x, i, held - self._starts[i]

    def section_index(self, x: ArrayLike) -> NDArray[np.intp]:
        """The index in `sections` of the section at each x (at a boundary, the one that starts
        there; before the start the first, beyond the end the last)."""
        return self._locate(x)[1]

    def section_at(self, x: float) -> Section:
        """The section at x (at a boundary, the one that starts there)."""
        return self.sections[int(self.section_index(float(x)))]

    # --- design geometry -------------------------------------------------------------------------

    def _ramp(self, x: ArrayLike, start: Array, end: Array) -> Array:
        _, i, u = self._locate(x)
        return start[i] + (end[i] - start[i]) * (u / self._lengths[i])

    def curvature(self, x: ArrayLike) -> Array:
        """1/m, positive turning left."""
        return self._ramp(x, self._k0, self._k1)

    def cant(self, x: ArrayLike) -> Array:
        """m, the right rail over the left over 1.5 m: positive in a left curve's cant."""
        return self._ramp(x, self._d0, self._d1)

    def cant_angle(self, x: ArrayLike) -> Array:
        """rad, asin(cant / 1.5): the track plane's roll about +x is minus this."""
        return np.arcsin(self.cant(x) / CANT_BASE)

    def heading(self, x: ArrayLike) -> Array:
        """rad, the tangent's direction from the start's, positive to the left: the integral of
        the curvature (quadratic in x along a transition)."""
        x, i, u = self._locate(x)
        slope = (self._k1[i] - self._k0[i]) / self._lengths[i]
        inside = self._heading0[i] + self._k0[i] * u + slope * u * u / 2
        held = self._starts[i] + u
        return inside + self.curvature(held) * (x - held)  # beyond an end, on that end's circle

    def xy(self, x: ArrayLike) -> Array:
        """m, the centreline's plane position (X, Y), shape x.shape + (2,): the start at the
        origin heading along +X, Y to the left."""
        x = np.asarray(x, dtype=float)
        held = np.clip(x, 0.0, self.length)
        j = np.clip(np.searchsorted(self._piece_start, held, side="right") - 1, 0, len(self._piece_start) - 1)
        u = held - self._piece_start[j]
        z = self._piece_z[j] + _advance(self._piece_heading[j], self._piece_k[j], self._piece_rate[j], u)
        beyond = x - held
        z = z + _advance(self.heading(held), self.curvature(held), np.zeros_like(held), beyond)
        return np.stack([z.real, z.imag], axis=-1)

    # --- speed on the curve ------------------------------------------------------------------------

    def uncompensated_acceleration(self, x: ArrayLike, speed: ArrayLike) -> Array:
        """m/s^2, in the track plane along its y axis: V^2*curvature*cos(phi) - g*sin(phi), phi
        the cant angle. What the rails must still supply beyond what the tilted weight does, to
        hold a vehicle at `speed` (m/s) on the curve: signed as the curvature under cant
        deficiency (a left curve taken too fast pushes the vehicle out, to the right, and the
        rails push back to the left), opposite under cant excess. Zero at the balance speed
        sqrt(g*R*tan(phi)), close to the sqrt(g*R*cant/1.5) of the small angles."""
        v = np.asarray(speed, dtype=float)
        phi = self.cant_angle(x)
        return v * v * self.curvature(x) * np.cos(phi) - GRAVITY * np.sin(phi)

    def cant_deficiency(self, x: ArrayLike, speed: ArrayLike) -> Array:
        """m, 1.5*V^2*curvature/g - cant: the cant the curve lacks for `speed` (m/s), signed as
        the curvature (negative: cant excess). In mm with V in km/h and R in m, practice writes
        it 11.8*V^2/R - cant; g * this / 1.5 is the uncompensated acceleration to within
        V^2*curvature*(1 - cos(phi))."""
        v = np.asarray(speed, dtype=float)
        return CANT_BASE * v * v * self.curvature(x) / GRAVITY - self.cant(x)


def _advance(heading: ArrayLike, k: ArrayLike, rate: ArrayLike, u: ArrayLike) -> NDArray[np.complex128]:
    """X + iY travelled over a distance u (may be negative) from a point with that heading and
    curvature k, the curvature changing at `rate` per metre: the integral of exp(i*psi(t)),
    psi(t) = heading + k*t + rate*t^2/2, from 0 to u. Constant curvature: the chord of the
    circle, 2*sin(k*u/2)/k along heading + k*u/2 (exact, and the straight's u at k = 0).
    Otherwise Gauss-Legendre over [0, u] (u within a piece, where it is exact to rounding)."""
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (heading, k, rate, u)))
    shape = arrays[0].shape
    heading, k, rate, u = (a.ravel() for a in arrays)
    z = u * np.sinc(k * u / (2 * np.pi)) * np.exp(1j * (heading + k * u / 2))
    ramp = rate != 0.0
    if np.any(ramp):
        h, kk, r, uu = heading[ramp], k[ramp], rate[ramp], u[ramp]
        t = uu[:, None] * (1.0 + _NODES) / 2  # the nodes on [0, u]
        psi = h[:, None] + kk[:, None] * t + r[:, None] * t * t / 2
        z[ramp] = uu / 2 * (np.exp(1j * psi) @ _WEIGHTS)
    return z.reshape(shape)
