"""Rigid contact geometry of a wheelset on two rails, at zero yaw (docs/geometry.md).

A rigid wheelset with two identical wheel profiles (the right one mirrored) stands on two
identical rails (mirrored), each canted by atan(rail_inclination) towards the track centre
and placed so that the gauge, 14 mm below the rail top, is `track_gauge`. For each lateral
shift y of the wheelset (its axle centre, to the left), `contact_table` finds the roll and
the height at which both wheels touch their rails without penetrating them, and at each
wheel the contact point, rolling radius, contact angle and the two profiles' transverse
curvatures, with a second point where tread and flange touch together.

Frames: the track frame has y to the left and z up, z = 0 at the top of the canted rails'
crowns. Each side is worked in its own mirror image of the left side (q = lateral distance
outwards from the track centre), so the left and right wheels go through the same
arithmetic. The gap is measured vertically in the track frame.

Example, S1002 on 60E1 at 1:40, standard gauge:

    >>> from rail_mj.contact.profiles import rail_60e1, s1002
    >>> t = contact_table(Track(s1002(), rail_60e1()), ys=[-0.003, 0.0, 0.003])
    >>> [round(float(v) * 1e3, 4) for v in t.delta_r]          # mm
    [-0.9585, 0.0, 0.9585]
    >>> round(float(t.roll[1]), 12), bool(t.r_left[1] == t.r_right[1])
    (0.0, True)
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import io
import math
from pathlib import Path

import numpy as np

from rail_mj.contact import profiles as _p
from rail_mj.files import cached_arrays, keep_arrays

# Columns of `ContactTable.to_csv`: the contract first, then the rest.
LEADING_COLUMNS = (
    "y_m",
    "r_left_m",
    "r_right_m",
    "delta_r_m",
    "contact_angle_left_rad",
    "contact_angle_right_rad",
    "roll_rad",
)
DEFAULT_YS = np.round(np.arange(-200, 201) * 0.05e-3, 12)  # m: -10 to +10 mm in 0.05 mm steps
TWO_POINT_GAP = 1e-5  # m: a second local minimum of the gap this close to 0 is a second contact
# m: a second local minimum this close is recorded (r2_*, ... gap2_*): under load the elastic
# approach of wheel and rail, ~0.05-0.1 mm for a 50-100 kN wheel, closes such a gap, and the
# dynamics share the wheel's load between the two points (rail_mj.contact.tables).
NEAR_GAP = 1e-4
_SECOND_APART = 1e-3  # m: ... and at least this far across the wheel from the first
_COARSE = 0.1e-3  # m between wheel points in the first search of the gap
_FINE = 201  # points across two steps of the last grid, at each refinement
_HERMITE = 2e-6  # m between the tabulated points of an exact wheel
_RAIL_POINTS = 40_001  # along an exact (standard) rail, evenly in arc length
_CURVATURE_STEP = (1e-5, 5e-4)  # m: three-point curvature on exact / sampled profiles
_ROLL_BRACKET = 0.02  # rad: the roll is searched within +/- this first


class GeometryError(ValueError):
    """Profiles that cannot stand on each other as placed; the message is one line."""


@dataclasses.dataclass(frozen=True, eq=False)
class Track:
    """A wheel profile on a rail profile, as placed by a layout's [profiles] table."""

    wheel: _p.Profile
    rail: _p.Profile
    rail_inclination: float = _p.RAIL_INCLINATION
    track_gauge: float = _p.GAUGE
    flange_back_spacing: float = _p.BACK_TO_BACK
    r0: float = _p.NOMINAL_RADIUS  # m, at the taping line

    @property
    def taping_half_spacing(self) -> float:
        """d: the taping lines' distance from the wheelset centre."""
        return self.flange_back_spacing / 2 + _p.TAPING_LINE_FROM_BACK


def track_of(layout) -> Track:
    """The Track of a Layout with [profiles] (or of a layout.Profiles, r0 = 0.46 m)."""
    p = getattr(layout, "profiles", layout)
    if p is None:
        raise GeometryError(f"{getattr(layout, 'source', 'layout')}: no [profiles] table")
    r0 = layout.wheelset.rolling_radius if hasattr(layout, "wheelset") else _p.NOMINAL_RADIUS
    return track_of_profiles(p, r0)


def track_of_profiles(p, r0: float) -> Track:
    """The Track of a layout.Profiles with wheels of nominal radius r0."""
    from rail_mj.contact.pair import read_profiles

    wheel, rail = read_profiles(p)
    return Track(wheel, rail, p.rail_inclination, p.track_gauge, p.flange_back_spacing, r0)


class _Placed:
    """The profiles placed: the rail as a dense polyline in side coordinates (q outwards,
    z up), the wheel's contact side as the points searched."""

    def __init__(self, track: Track):
        self.track = track
        w, r = track.wheel, track.rail
        if w.kind != _p.WHEEL or r.kind != _p.RAIL:
            raise GeometryError(f"need a wheel and a rail profile, got a {w.kind} and a {r.kind}")
        self.r0, self.d = float(track.r0), track.taping_half_spacing
        # The rail's own points (exact ones densely), canted: rotated by delta about its origin,
        # the field side (u > 0) up.
        if r.exact is not None:
            u = _even_in_arc(r, _RAIL_POINTS)
        else:
            u = np.array(r.y)
        zr = np.asarray(r.height(u), float)
        delta = math.atan(track.rail_inclination)
        c, s = math.cos(delta), math.sin(delta)
        q, z = c * u - s * zr, s * u + c * zr
        # The surface seen from above: from the field end inwards, only points further in.
        keep = np.zeros(len(q), bool)
        lowest = math.inf
        for k in range(len(q) - 1, -1, -1):
            if q[k] < lowest:
                keep[k], lowest = True, q[k]
        u, q, z = u[keep], q[keep], z[keep]
        top = float(np.max(z))
        level = top - _p.GAUGE_DEPTH
        above = np.flatnonzero(z >= level)
        if len(above) == 0 or above[0] == 0:
            raise GeometryError(
                f"{r.name}: the rail profile does not reach {_p.GAUGE_DEPTH * 1e3:g} mm below "
                f"its top on the gauge side, where the gauge is measured"
            )
        k = int(above[0])
        q_gauge = q[k - 1] + (level - z[k - 1]) * (q[k] - q[k - 1]) / (z[k] - z[k - 1])
        self.rail_centre = track.track_gauge / 2 - q_gauge  # the head centreline's q
        self.rail_u, self.rail_q, self.rail_z = u, q + self.rail_centre, z - top
        self.rail_top = top
        self.delta = delta
        # The wheel from its lowest point (the flange tip) out to its outer face.
        lo = float(w.y[int(np.argmin(w.z))])
        n = max(3, math.ceil((w.y[-1] - lo) / _COARSE) + 1)
        if w.exact is not None:  # the published curve, tabulated finely for cubic Hermite
            grid = np.linspace(lo, float(w.y[-1]), math.ceil((w.y[-1] - lo) / _HERMITE) + 1)
            self._table: tuple[np.ndarray, np.ndarray, np.ndarray] | None = (
                grid,
                np.asarray(w.height(grid), float),
                np.asarray(w.slope(grid), float),
            )
        else:
            self._table = None
        self.s = np.linspace(lo, float(w.y[-1]), n)
        self.zw = self.wheel_height(self.s)
        self.s_range = (lo, float(w.y[-1]))

    # --- the gap -------------------------------------------------------------------------

    def wheel_height(self, s):
        """The wheel's z at s: its points' polyline, or for an exact profile a cubic Hermite
        through the published curve every _HERMITE: within 1e-11 m of it for S1002, except in
        the 2 um cells at S = -26 and -35 mm, where the published section C misses its
        neighbours by 0.12 um (profiles.md) and the Hermite piece bridges the step."""
        s = np.asarray(s, float)
        if self._table is None:
            return np.asarray(self.track.wheel.height(s), float)
        grid, z, dz = self._table
        h = grid[1] - grid[0]
        k = np.clip(((s - grid[0]) / h).astype(int), 0, len(grid) - 2)
        t = (s - grid[k]) / h
        t2, t3 = t * t, t * t * t
        out = (
            (2 * t3 - 3 * t2 + 1) * z[k]
            + (t3 - 2 * t2 + t) * h * dz[k]
            + (-2 * t3 + 3 * t2) * z[k + 1]
            + (t3 - t2) * h * dz[k + 1]
        )
        return np.where((s >= grid[0]) & (s <= grid[-1]), out, np.nan)

    def points(self, eta, psi, s, zw=None):
        """Side coordinates (q, z) of wheel points s at shift eta (outwards) and roll psi
        (this side up), for the wheelset centre at height 0."""
        zw = self.wheel_height(s) if zw is None else zw
        big_z = -self.r0 + zw
        c, sn = math.cos(psi), math.sin(psi)
        return eta + c * (self.d + s) - sn * big_z, sn * (self.d + s) + c * big_z

    def rail_height(self, q):
        """The canted rail's top surface at q; -inf beside it (nothing to touch)."""
        return np.interp(q, self.rail_q, self.rail_z, left=-np.inf, right=-np.inf)

    def gap(self, eta, psi, s, zw=None):
        """The vertical gap under wheel points s (centre at height 0)."""
        q, z = self.points(eta, psi, s, zw)
        return z - self.rail_height(q)

    def minima(self, eta, psi, margin=1e-4):
        """The local minima of the gap within `margin` of the lowest, refined, lowest first:
        [(gap, s), ...], at least _SECOND_APART apart."""
        g = self.gap(eta, psi, self.s, self.zw)
        if not np.any(np.isfinite(g)):
            raise GeometryError(
                "the wheel is beside its rail: no contact (check track_gauge and "
                "flange_back_spacing, and the profiles' units)"
            )
        lowest = float(np.min(g))
        inner = (g[1:-1] <= g[:-2]) & (g[1:-1] <= g[2:])
        k = np.flatnonzero(np.concatenate([[g[0] <= g[1]], inner, [g[-1] <= g[-2]]]))
        k = k[g[k] <= lowest + margin]
        found = sorted((self._refine(eta, psi, int(i)) for i in k), key=lambda t: t[0])
        out: list[tuple[float, float]] = []
        for value, s in found:
            if all(abs(s - other) >= _SECOND_APART for _, other in out):
                out.append((value, s))
        return out

    def _refine(self, eta, psi, i):
        """The minimum near coarse point i: grids 100 times finer each time, down to 1e-12 m
        (the gap may have a kink, over a polyline rail's corner), then a parabola."""
        lo = self.s[max(i - 1, 0)]
        hi = self.s[min(i + 1, len(self.s) - 1)]
        while True:
            s = np.linspace(lo, hi, _FINE)
            g = self.gap(eta, psi, s)
            j = int(np.argmin(g))
            step = s[1] - s[0]
            if step < 1e-12:
                break
            lo, hi = s[max(j - 1, 0)], s[min(j + 1, len(s) - 1)]
        best = (float(g[j]), float(s[j]))
        if 0 < j < len(s) - 1:  # the parabola through the lowest three
            a, b, c = g[j - 1], g[j], g[j + 1]
            den = a - 2 * b + c
            if den > 0:
                s_min = s[j] + 0.5 * (a - c) / den * step
                g_min = float(self.gap(eta, psi, np.array([s_min]))[0])
                if g_min <= b:
                    best = (g_min, float(s_min))
        return best

    def lowest(self, eta, psi):
        return self.minima(eta, psi, margin=0.0)[0][0]


@functools.lru_cache(maxsize=8)
def _placed(track: Track) -> _Placed:
    return _Placed(track)


def _even_in_arc(profile: _p.Profile, n: int) -> np.ndarray:
    """n values of y spread evenly along an exact profile's length."""
    t = np.linspace(profile.y[0], profile.y[-1], 200_001)
    z = np.asarray(profile.height(t), float)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(t), np.diff(z)))])
    u = np.interp(np.linspace(0.0, arc[-1], n), arc, t)
    u[0], u[-1] = profile.y[0], profile.y[-1]
    return u


def _curvature(profile: _p.Profile, y: float) -> float:
    """The profile's curvature at y (1/m, d2z/dy2 over (1 + z'^2)^1.5): positive where the
    surface is convex from below (its z curves up), from the circle through three points
    a small step apart (10 um on an exact profile, 0.5 mm on a sampled one)."""
    h = _CURVATURE_STEP[0] if profile.exact is not None else _CURVATURE_STEP[1]
    lo, hi = max(y - h, profile.y[0]), min(y + h, profile.y[-1])
    if hi - lo < h:
        return math.nan
    ys = np.array([lo, 0.5 * (lo + hi), hi])
    (y1, y2, y3), (z1, z2, z3) = ys, np.asarray(profile.height(ys), float)
    cross = (y2 - y1) * (z3 - z1) - (z2 - z1) * (y3 - y1)
    a, b, c = math.hypot(y2 - y1, z2 - z1), math.hypot(y3 - y2, z3 - z2), math.hypot(y3 - y1, z3 - z1)
    return 2.0 * cross / (a * b * c)


@dataclasses.dataclass(frozen=True, eq=False)
class ContactTable:
    """The contact geometry against the lateral shift y (m, the axle centre, to the left),
    at zero yaw; every column a numpy array over y. Per side (left, right):

    r (rolling radius r0 + F), contact_angle (rad, the wheel surface's slope at the contact
    in the track frame, roll included: positive leaning towards the track centre, about
    70 degrees on the flange), contact_y (m, track frame), wheel_s (m, across the wheel from
    its taping line, + outwards), rail_u (m, across the rail from its head centreline,
    + outwards), wheel_curvature and rail_curvature (1/m, transverse, positive where convex
    towards the other body), two_point (a second contact within TWO_POINT_GAP), and a
    second point within NEAR_GAP: its r2, contact_angle2, contact_y2, gap2, wheel_s2 and
    curvatures (NaN without one). roll (rad, the
    left side up) and z (m, the axle centre's height above the rails' top)."""

    columns: dict
    track: Track

    def __getattr__(self, name):
        try:
            return self.__dict__["columns"][name]
        except KeyError:
            raise AttributeError(name) from None

    def to_csv(self) -> bytes:
        """The table as CSV: the contract's columns first (LEADING_COLUMNS), then the rest."""
        keys = [k for k, _ in _CSV_ORDER if k in self.columns]
        header = ",".join(name for k, name in _CSV_ORDER if k in self.columns)
        data = np.column_stack([np.asarray(self.columns[k], float) for k in keys])
        buf = io.StringIO()
        np.savetxt(buf, data, delimiter=",", header=header, comments="", fmt="%.12g")
        return buf.getvalue().encode()


# Column key -> CSV name, in CSV order.
_CSV_ORDER = (
    ("y", "y_m"),
    ("r_left", "r_left_m"),
    ("r_right", "r_right_m"),
    ("delta_r", "delta_r_m"),
    ("contact_angle_left", "contact_angle_left_rad"),
    ("contact_angle_right", "contact_angle_right_rad"),
    ("roll", "roll_rad"),
    ("z", "z_m"),
    ("contact_y_left", "contact_y_left_m"),
    ("contact_y_right", "contact_y_right_m"),
    ("wheel_s_left", "wheel_s_left_m"),
    ("wheel_s_right", "wheel_s_right_m"),
    ("rail_u_left", "rail_u_left_m"),
    ("rail_u_right", "rail_u_right_m"),
    ("wheel_curvature_left", "wheel_curvature_left_per_m"),
    ("wheel_curvature_right", "wheel_curvature_right_per_m"),
    ("rail_curvature_left", "rail_curvature_left_per_m"),
    ("rail_curvature_right", "rail_curvature_right_per_m"),
    ("two_point_left", "two_point_left"),
    ("two_point_right", "two_point_right"),
    ("r2_left", "r2_left_m"),
    ("r2_right", "r2_right_m"),
    ("contact_angle2_left", "contact_angle2_left_rad"),
    ("contact_angle2_right", "contact_angle2_right_rad"),
    ("contact_y2_left", "contact_y2_left_m"),
    ("contact_y2_right", "contact_y2_right_m"),
    ("gap2_left", "gap2_left_m"),
    ("gap2_right", "gap2_right_m"),
    ("wheel_s2_left", "wheel_s2_left_m"),
    ("wheel_s2_right", "wheel_s2_right_m"),
    ("wheel_curvature2_left", "wheel_curvature2_left_per_m"),
    ("wheel_curvature2_right", "wheel_curvature2_right_per_m"),
    ("rail_curvature2_left", "rail_curvature2_left_per_m"),
    ("rail_curvature2_right", "rail_curvature2_right_per_m"),
)
CSV_COLUMNS = tuple(name for _, name in _CSV_ORDER)
assert CSV_COLUMNS[: len(LEADING_COLUMNS)] == LEADING_COLUMNS


def solve_roll(placed: _Placed, y: float) -> tuple[float, float]:
    """(roll, z) of the wheelset shifted y: both lowest gaps zero."""
    from scipy.optimize import brentq

    def unbalance(phi):
        return placed.lowest(y, phi) - placed.lowest(-y, -phi)

    if y == 0.0:
        phi = 0.0
    else:
        a = _ROLL_BRACKET
        fa, fb = unbalance(-a), unbalance(a)
        while fa > 0 or fb < 0:
            a *= 2
            if a > 0.5:
                raise GeometryError(f"no roll stands the wheelset on both rails at y = {y * 1e3:g} mm")
            fa, fb = unbalance(-a), unbalance(a)
        phi = brentq(unbalance, -a, a, xtol=1e-15, rtol=1e-15, maxiter=200)
    return phi, -placed.lowest(y, phi)


def _side(placed: _Placed, eta: float, psi: float, h: float) -> dict:
    """One side's contact (side coordinates; h the centre's height)."""
    track = placed.track
    found = placed.minima(eta, psi, margin=NEAR_GAP + 1e-5)
    out = {}
    for tag, (g, s) in zip(("", "2"), found[:2]):
        q, _ = placed.points(eta, psi, np.array([s]))
        slope = float(track.wheel.slope(np.array([s]))[0])
        u = float(np.interp(q[0], placed.rail_q, placed.rail_u))
        out[tag] = {
            "r": placed.r0 - float(track.wheel.height(np.array([s]))[0]),
            "contact_angle": psi + math.atan(slope),
            "q": float(q[0]),
            "gap": g + h,
            "s": s,
            "u": u,
            "wheel_curvature": _curvature(track.wheel, s),
            "rail_curvature": -_curvature(track.rail, u),
        }
    return out


def default_table(profiles, r0: float) -> ContactTable:
    """The contact table of a layout.Profiles at the default shifts (DEFAULT_YS), made once a
    process for each profiles and r0 (a profile file that changes is read again): a layout's
    equivalent conicity and `rail-mj contact-geometry` share it."""
    from rail_mj.contact.pair import stamp

    return _default_table(profiles, r0, stamp(profiles))


@functools.lru_cache(maxsize=8)
def _default_table(profiles, r0: float, _stamp) -> ContactTable:
    """Made once a process, and kept on disk between commands (seconds to build: S1002 on 60E1
    takes 2.6 s) under a key of everything the table depends on: the profiles' contents (a
    file's bytes, a standard profile's name), how the track places them, r0 and the shifts; the
    code that computes it names the cache's folder (rail_mj.files.cache_folder)."""
    key = _table_key(profiles, r0)
    track = track_of_profiles(profiles, r0)
    kept = cached_arrays(CACHE_KIND, key)
    if kept is not None and _table_key(profiles, r0) == key:  # the same code (the folder) and inputs
        return ContactTable(kept, track)
    table = contact_table(track)
    if _table_key(profiles, r0) == key:  # a file saved while it was read is not kept under either
        keep_arrays(CACHE_KIND, key, table.columns)
    return table


CACHE_KIND = "contact"


def _table_key(profiles, r0: float) -> str:
    from importlib.metadata import version

    from rail_mj.contact.pair import STANDARD_PROFILES

    # numpy's and scipy's versions too: their interpolation and root finding make the numbers.
    what: list[object] = [version("numpy"), version("scipy")]
    for kind, name in (("wheel", profiles.wheel), ("rail", profiles.rail)):
        if name in STANDARD_PROFILES[kind]:
            what.append(name)
        else:  # its contents and its suffix (.csv and .prw read differently); unreadable: no key
            try:
                with open(name, "rb") as f:
                    what += [Path(name).suffix.lower(), hashlib.sha256(f.read()).hexdigest()]
            except OSError:
                what.append(None)
    what += [profiles.rail_inclination, profiles.track_gauge, profiles.flange_back_spacing, r0]
    what.append(hashlib.sha256(DEFAULT_YS.tobytes()).hexdigest())
    return hashlib.sha256(repr(what).encode()).hexdigest()[:32]


def contact_table(source, ys=None) -> ContactTable:
    """The contact geometry of a Track (or a Layout with [profiles]) at the lateral shifts
    ys (m; default -10 to +10 mm in 0.05 mm steps). Raises GeometryError."""
    if ys is None and not isinstance(source, Track) and getattr(source, "profiles", None) is not None:
        return default_table(source.profiles, source.wheelset.rolling_radius)
    track = source if isinstance(source, Track) else track_of(source)
    ys = DEFAULT_YS if ys is None else np.asarray(ys, dtype=float)
    if ys.ndim != 1 or len(ys) == 0 or not np.all(np.isfinite(ys)) or np.any(np.diff(ys) <= 0):
        raise GeometryError("ys must be finite lateral shifts in m, increasing")
    placed = _placed(track)
    keys = [k for k, _ in _CSV_ORDER]
    cols = {k: np.full(len(ys), np.nan) for k in keys}
    for i, y in enumerate(ys):
        phi, h = solve_roll(placed, float(y))
        cols["y"][i], cols["roll"][i], cols["z"][i] = y, phi, h
        for side, sign in (("left", 1.0), ("right", -1.0)):
            found = _side(placed, sign * y, sign * phi, h)
            first = found[""]
            cols[f"r_{side}"][i] = first["r"]
            cols[f"contact_angle_{side}"][i] = first["contact_angle"]
            cols[f"contact_y_{side}"][i] = sign * first["q"]
            cols[f"wheel_s_{side}"][i] = first["s"]
            cols[f"rail_u_{side}"][i] = first["u"]
            cols[f"wheel_curvature_{side}"][i] = first["wheel_curvature"]
            cols[f"rail_curvature_{side}"][i] = first["rail_curvature"]
            second = found.get("2")
            near = second is not None and second["gap"] <= NEAR_GAP
            cols[f"two_point_{side}"][i] = float(near and second is not None and second["gap"] <= TWO_POINT_GAP)
            if near and second is not None:
                cols[f"r2_{side}"][i] = second["r"]
                cols[f"contact_angle2_{side}"][i] = second["contact_angle"]
                cols[f"contact_y2_{side}"][i] = sign * second["q"]
                cols[f"gap2_{side}"][i] = second["gap"]
                cols[f"wheel_s2_{side}"][i] = second["s"]
                cols[f"wheel_curvature2_{side}"][i] = second["wheel_curvature"]
                cols[f"rail_curvature2_{side}"][i] = second["rail_curvature"]
    cols["delta_r"] = cols["r_left"] - cols["r_right"]
    return ContactTable(cols, track)


FLANGE_ANGLE = 1.0  # rad: a contact steeper than this (57 degrees) is on the flange


def flange_contact_shift(table: ContactTable) -> float | None:
    """The smallest |y| (m) of the table at which a wheel touches its rail on the flange:
    the profiles' flangeway clearance; None if none does within the table."""
    on = np.flatnonzero(np.maximum(table.contact_angle_left, table.contact_angle_right) > FLANGE_ANGLE)
    return float(np.min(np.abs(table.y[on]))) if len(on) else None


def wheel_points(table: ContactTable, i: int, side: str, s=None) -> tuple[np.ndarray, np.ndarray]:
    """The wheel's profile in the track frame (y, z) at row i of the table, on `side`."""
    placed = _placed(table.track)
    sign = 1.0 if side == "left" else -1.0
    s = placed.s if s is None else np.asarray(s, float)
    q, z = placed.points(sign * table.y[i], sign * table.roll[i], s)
    return sign * q, z + table.z[i]


def rail_points(track: Track, side: str) -> tuple[np.ndarray, np.ndarray]:
    """The canted rail's top surface in the track frame (y, z)."""
    placed = _placed(track)
    sign = 1.0 if side == "left" else -1.0
    return sign * placed.rail_q, placed.rail_z


def gaps(table: ContactTable, i: int, side: str, s) -> np.ndarray:
    """The vertical gap (m) under the wheel points s (m across the wheel from its taping
    line) at row i: what the table's roll and height leave between wheel and rail."""
    placed = _placed(table.track)
    sign = 1.0 if side == "left" else -1.0
    return placed.gap(sign * table.y[i], sign * table.roll[i], np.asarray(s, float)) + table.z[i]


def delta_r(table: ContactTable):
    """Δr(y) of the table as a conicity.DeltaR (mm)."""
    from rail_mj.contact.conicity import DeltaR

    return DeltaR.from_points(
        table.y * 1e3,
        table.delta_r * 1e3,
        source=f"contact geometry ({table.track.wheel.name} on {table.track.rail.name})",
    )


def equivalent_conicity(table: ContactTable, amplitude: float = 3.0) -> float:
    """EN 15302's equivalent conicity of the table's Δr at `amplitude` mm (the integration
    method), with e the contact points' spacing at y = 0 and r0 the nominal radius."""
    from rail_mj.contact.conicity import equivalent_conicity as lam

    return float(lam(delta_r(table), [amplitude])[0])
