"""Wheel and rail profiles: the standard S1002 wheel and 60E1 rail, and measured ones.

One convention for every profile, wheel or rail (docs/profiles.md):

- **y** runs across the profile, in metres, **positive towards the field side** (away from
  the track centre). Its origin is the taping line for a wheel and the head's centreline
  for a rail. A profile is the same for a left and a right wheel (or rail): the track frame
  (y to the left) has the left one at `y_track = y_c + y` and the right one mirrored,
  `y_track = -(y_c + y)`.
- **z** is up, in metres. A rail's z is the height of its head's surface, 0 at the top.
  A wheel's z is the height of its surface at its lowest point (under the axle) above the
  lowest point of the taping-line circle: `z = -(r - r0)`, so the flange, a larger radius,
  hangs down to z = -28 mm. Wheel and rail surfaces face each other in the same frame:
  where a wheel stands on a rail, the gap is `z_wheel(y) - z_rail(y)` plus the offset
  between their origins.
- Points run along y, strictly increasing; the surface between them is their straight
  interpolation (`Profile.height`), or the published definition itself for s1002() and
  rail_60e1().

Files: CSV (`y_mm,z_mm`, the convention above in millimetres) and SIMPACK's .prw (wheel)
and .prr (rail). `read_profile` refuses a bad file with a `ProfileError`: one line naming
the file and the line.

Example:

    >>> wheel = s1002()
    >>> [round(float(wheel.height(y)) * 1e3, 3) for y in (-0.055, 0.0, 0.06)]   # z, mm
    [-28.0, 0.0, 2.636]
    >>> rail = rail_60e1()
    >>> round(float(rail.height(0.0)), 9), round(2 * rail_60e1_head().y3, 3)   # head width, mm
    (0.0, 72.0)
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "s1002.csv"
    >>> _ = path.write_bytes(write_csv(wheel))
    >>> again = read_profile(path, kind="wheel")
    >>> bool(np.allclose(again.z, wheel.z, atol=1e-12))
    True
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rail_mj.files import read_input

WHEEL = "wheel"
RAIL = "rail"
KINDS = (WHEEL, RAIL)
CSV_HEADER = "y_mm,z_mm"

# Standard track (EN 13715 and EN 13674-1 profiles on standard gauge): for the docs and
# for placing profiles on a track.
GAUGE = 1.435  # m, between the heads' inner faces ...
GAUGE_DEPTH = 0.014  # m ... measured this far below the top of the rails
RAIL_INCLINATION = 1 / 40  # rails lean towards the track centre
BACK_TO_BACK = 1.360  # m, between the flange backs
TAPING_LINE_FROM_BACK = 0.070  # m, from a flange back to its taping line (1.5 m apart)
NOMINAL_RADIUS = 0.46  # m, at the taping line

# A profile spans a few centimetres: far outside this, the units are wrong.
_SPAN_MIN, _SPAN_MAX = 0.005, 0.4  # m


class ProfileError(ValueError):
    """A profile file that cannot be read; the message is one line naming file and line."""


@dataclasses.dataclass(frozen=True, eq=False)
class Profile:
    """A wheel or rail profile: points (y, z) in metres, in the module's convention."""

    name: str
    kind: str  # "wheel" or "rail"
    y: np.ndarray  # m, strictly increasing, positive towards the field side
    z: np.ndarray  # m, up (a wheel: -(r - r0))
    source: str = ""  # the standard or the file it comes from
    # The exact surface and its slope, for the standard profiles (y in m -> z in m).
    exact: Callable[[np.ndarray], np.ndarray] | None = dataclasses.field(default=None, repr=False)
    exact_slope: Callable[[np.ndarray], np.ndarray] | None = dataclasses.field(default=None, repr=False)

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"profile kind must be 'wheel' or 'rail', got {self.kind!r}")
        y = np.array(self.y, dtype=float)
        z = np.array(self.z, dtype=float)
        if y.ndim != 1 or y.shape != z.shape or len(y) < 2:
            raise ValueError("a profile needs y and z of the same length, at least 2 points")
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(z))):
            raise ValueError("profile points must be finite numbers")
        if np.any(np.diff(y) <= 0):
            raise ValueError("profile points must run along y, strictly increasing")
        y.flags.writeable = False
        z.flags.writeable = False
        object.__setattr__(self, "y", y)
        object.__setattr__(self, "z", z)

    def height(self, y):
        """The surface's z (m) at lateral position(s) y (m); NaN outside the profile."""
        y = np.asarray(y, dtype=float)
        if self.exact is not None:
            return self.exact(y)
        return np.interp(y, self.y, self.z, left=np.nan, right=np.nan)

    def slope(self, y):
        """dz/dy at y (m): exact for the standard profiles, else the slope of the straight
        piece between the points around y (the right-hand one at a point); NaN outside."""
        y = np.asarray(y, dtype=float)
        if self.exact_slope is not None:
            return self.exact_slope(y)
        k = np.clip(np.searchsorted(self.y, y, side="right") - 1, 0, len(self.y) - 2)
        s = (self.z[k + 1] - self.z[k]) / (self.y[k + 1] - self.y[k])
        return np.where((y >= self.y[0]) & (y <= self.y[-1]), s, np.nan)


# --- S1002 (EN 13715) -----------------------------------------------------------------

# The published coefficients (mm): F(S) is the radius above the nominal one, S the lateral
# position from the taping line, positive towards the outer face.
_AA, _BA = 1.364323640, 0.066666667
_B = (
    0.0,
    3.358537058e-2,
    1.565681624e-3,
    2.810427944e-5,
    5.844240864e-8,
    1.562379023e-8,
    5.309217349e-15,
    5.957839843e-12,
    2.646656573e-13,
)  # AB..IB, signs alternate
_C = (
    4.320221063e3,
    1.038384026e3,
    1.065501873e2,
    6.051367875,
    2.054332446e-1,
    4.169739389e-3,
    4.687195829e-5,
    2.252755540e-7,
)  # AC..HC, all subtracted
_AD, _BD, _CD = 16.446, 13.0, 26.210665
_AE, _BE = 93.576667419, 2.747477419
_AF, _BF, _CF = 8.834924130, 20.0, 58.558326413
_AG, _BG, _CG = 16.0, 12.0, 55.0
_AH, _BH, _CH = 9.519259302, 20.5, 49.5


def _root(r, u):
    return np.sqrt(np.maximum(r * r - u * u, 0.0))  # 0, not NaN, at an arc's end


def _poly(coefficients, s, signs):
    return sum(sign * c * s**k for k, (c, sign) in enumerate(zip(coefficients, signs)))


def _dpoly(coefficients, s, signs):
    return sum(k * sign * c * s ** (k - 1) for k, (c, sign) in enumerate(zip(coefficients, signs)) if k)


_ALTERNATE = [(-1) ** k for k in range(9)]
_MINUS = [-1] * 8


def _circle_up(a, r, c):  # a + sqrt(r^2 - (S + c)^2): the top of a circle
    return (lambda s: a + _root(r, s + c), lambda s: -(s + c) / _root(r, s + c))


# (name, S from, S to, F(S), dF/dS), from the outer face inwards. Adjacent sections meet
# tangentially; those of C meet B and D within 0.12 µm, the precision of C's published
# ten-digit coefficients.
S1002_SECTIONS = (
    ("A", 60.0, 32.15796, lambda s: _AA - _BA * s, lambda s: np.full_like(s, -_BA)),
    ("B", 32.15796, -26.0, lambda s: _poly(_B, s, _ALTERNATE), lambda s: _dpoly(_B, s, _ALTERNATE)),
    ("C", -26.0, -35.0, lambda s: _poly(_C, s, _MINUS), lambda s: _dpoly(_C, s, _MINUS)),
    ("D", -35.0, -38.426669071, lambda s: _AD - _root(_BD, s + _CD), lambda s: (s + _CD) / _root(_BD, s + _CD)),
    ("E", -38.426669071, -39.764473993, lambda s: -_AE - _BE * s, lambda s: np.full_like(s, -_BE)),
    ("F", -39.764473993, -49.662510381, *_circle_up(_AF, _BF, _CF)),
    ("G", -49.662510381, -62.764705882, *_circle_up(_AG, _BG, _CG)),
    ("H", -62.764705882, -70.0, *_circle_up(_AH, _BH, _CH)),
)
S1002_RANGE_MM = (-70.0, 60.0)


def _by_section(s_mm, which: int):
    s = np.asarray(s_mm, dtype=float)
    flat = np.atleast_1d(s).ravel()
    out = np.full(flat.shape, np.nan)
    for _, hi, lo, *functions in S1002_SECTIONS:
        mask = (flat <= hi) & (flat >= lo) & np.isnan(out)  # a boundary goes to the outer section
        if np.any(mask):
            with np.errstate(divide="ignore"):  # an arc's vertical end: an infinite slope
                out[mask] = functions[which](flat[mask])
    return out.reshape(s.shape) if s.ndim else float(out[0])


def s1002_radius(s_mm):
    """F(S): the S1002 wheel's radius above the nominal radius, mm, at S mm from the taping
    line (positive towards the outer face); NaN outside -70 <= S <= 60."""
    return _by_section(s_mm, 0)


def s1002_radius_slope(s_mm):
    """dF/dS of `s1002_radius` (infinite at S = -70, where the flange back is vertical)."""
    return _by_section(s_mm, 1)


def _resample(y_of_t, z_of_t, t, points: int):
    """`points` points spread evenly along the curve (y(t), z(t)) sampled densely at t: even
    in arc length, not in y, so the flange and the rail's flank get their share."""
    y, z = y_of_t(t), z_of_t(t)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(y), np.diff(z)))])
    return np.interp(np.linspace(0.0, arc[-1], points), arc, t)


def _check_points(points: int) -> None:
    if not (isinstance(points, (int, np.integer)) and 2 <= points <= 1_000_000):
        raise ValueError(f"points must be a whole number from 2 to 1000000, got {points!r}")


def s1002(points: int = 1001) -> Profile:
    """The S1002 wheel (EN 13715), from the flange back (y = -70 mm) to the outer face
    (y = +60 mm), as `points` points evenly spread along the profile; `height` and `slope`
    evaluate the published definition itself."""
    _check_points(points)
    # Dense in S where the flange back turns vertical (S = -70), sparse on the flat tread.
    dense = -70.0 + 130.0 * np.linspace(0.0, 1.0, 200_001) ** 2
    s = _resample(lambda t: t, s1002_radius, dense, points)
    s[0], s[-1] = -70.0, 60.0

    def exact(y):
        return 0.0 - np.asarray(s1002_radius(np.asarray(y) * 1e3)) * 1e-3  # 0.0 - : no -0.0

    def exact_slope(y):
        return -np.asarray(s1002_radius_slope(np.asarray(y) * 1e3))

    return Profile("S1002", WHEEL, s * 1e-3, 0.0 - s1002_radius(s) * 1e-3, "EN 13715 S1002", exact, exact_slope)


# --- 60E1 (EN 13674-1) ----------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class _RailHead:
    """The 60E1 head's half (y >= 0), mm: three tangent arcs, then the 1:20 flank. Arc k
    has centre (ck_y, ck_z) and radius rk, and runs over angles (from the upward vertical,
    towards +y) phi_{k-1}..phi_k; point k is where arc k ends."""

    r1: float = 300.0
    r2: float = 80.0
    r3: float = 13.0
    y1: float = 10.228  # where the 300 mm arc gives way to the 80 mm one
    y2: float = 26.0265  # where the 80 mm arc gives way to the 13 mm one
    flank: float = 1 / 20  # the side, from the vertical
    # Derived from the above in __post_init__: the arcs' centres, end angles and point 3.
    c1: tuple[float, float] = dataclasses.field(init=False)
    c2: tuple[float, float] = dataclasses.field(init=False)
    c3: tuple[float, float] = dataclasses.field(init=False)
    phi1: float = dataclasses.field(init=False)
    phi2: float = dataclasses.field(init=False)
    phi3: float = dataclasses.field(init=False)
    y3: float = dataclasses.field(init=False)
    z3: float = dataclasses.field(init=False)

    def __post_init__(self):
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen
        set_("c1", (0.0, -self.r1))
        set_("phi1", math.asin(self.y1 / self.r1))
        # A tangent arc's centre lies on the line through the last centre and the junction.
        p1 = self.point(self.c1, self.r1, self.phi1)
        set_("c2", (p1[0] - self.r2 * math.sin(self.phi1), p1[1] - self.r2 * math.cos(self.phi1)))
        set_("phi2", math.asin((self.y2 - self.c2[0]) / self.r2))
        p2 = self.point(self.c2, self.r2, self.phi2)
        set_("c3", (p2[0] - self.r3 * math.sin(self.phi2), p2[1] - self.r3 * math.cos(self.phi2)))
        # The 13 mm arc ends where its tangent leans 1:20 from the vertical: dz/dy = -20.
        set_("phi3", math.atan(1 / self.flank))
        p3 = self.point(self.c3, self.r3, self.phi3)
        set_("y3", p3[0])
        set_("z3", p3[1])

    @staticmethod
    def point(c, r, phi):
        return c[0] + r * math.sin(phi), c[1] + r * math.cos(phi)

    def arcs(self):
        return (
            (self.c1, self.r1, 0.0, self.phi1),
            (self.c2, self.r2, self.phi1, self.phi2),
            (self.c3, self.r3, self.phi2, self.phi3),
        )

    def height(self, y):
        """z (mm) at |y| (mm), NaN beyond the flank's end at `depth` below the top."""
        a = np.abs(np.asarray(y, dtype=float))
        z = np.full(a.shape, np.nan)
        edges = (0.0, self.y1, self.y2, self.y3)
        for k, (c, r, _, _) in enumerate(self.arcs()):
            m = (a >= edges[k]) & (a <= edges[k + 1]) & np.isnan(z)
            z[m] = c[1] + _root(r, a[m] - c[0])
        m = (a > self.y3) & np.isnan(z)
        z[m] = self.z3 - (a[m] - self.y3) / self.flank
        return z

    def slope(self, y):
        """dz/dy (-) at y (mm): odd in y."""
        y = np.asarray(y, dtype=float)
        a = np.abs(y)
        d = np.full(a.shape, np.nan)
        edges = (0.0, self.y1, self.y2, self.y3)
        for k, (c, r, _, _) in enumerate(self.arcs()):
            m = (a >= edges[k]) & (a <= edges[k + 1]) & np.isnan(d)
            d[m] = -(a[m] - c[0]) / _root(r, a[m] - c[0])
        d[(a > self.y3) & np.isnan(d)] = -1 / self.flank
        return np.sign(y) * d

    def half(self, depth: float, n: int):
        """The half head from the top (y = 0) to `depth` mm below it, densely: (y, z) mm."""
        ys, zs = [], []
        for c, r, lo, hi in self.arcs():
            phi = np.linspace(lo, hi, n)
            ys.append(c[0] + r * np.sin(phi))
            zs.append(c[1] + r * np.cos(phi))
        z_end = -depth
        ys.append(np.linspace(self.y3, self.y3 + (self.z3 - z_end) * self.flank, n))
        zs.append(np.linspace(self.z3, z_end, n))
        return np.concatenate(ys), np.concatenate(zs)


_RAIL = _RailHead()


def rail_60e1(points: int = 801, depth_mm: float = 40.0) -> Profile:
    """The 60E1 (UIC60) rail head (EN 13674-1), symmetric, from one side to the other,
    down to `depth_mm` below the top (enough for any contact) on each side, as `points`
    points evenly spread along the profile; `height` and `slope` evaluate the definition."""
    _check_points(points)
    if not (-_RAIL.z3 < depth_mm <= 60.0):
        raise ValueError(f"depth_mm must be above {-_RAIL.z3:.2f} (the flank's top) and at most 60, got {depth_mm}")
    hy, hz = _RAIL.half(depth_mm, 4001)
    keep = np.concatenate([[True], np.diff(hy) > 0])  # arcs share their end points
    hy, hz = hy[keep], hz[keep]
    y = np.concatenate([-hy[:0:-1], hy])
    z = np.concatenate([hz[:0:-1], hz])
    # Even in arc length along the dense polyline (exact on the straight flank), then the
    # points on the arcs put on the exact surface.
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(y), np.diff(z)))])
    at = np.linspace(0.0, arc[-1], points)
    ys, zs = np.interp(at, arc, y), np.interp(at, arc, z)
    on_arcs = np.abs(ys) <= _RAIL.y3
    zs[on_arcs] = _RAIL.height(ys[on_arcs])
    y_end = _RAIL.y3 + (_RAIL.z3 + depth_mm) * _RAIL.flank
    limit = y_end * 1e-3

    def exact(yq):
        yq = np.asarray(yq, dtype=float)
        z_mm = _RAIL.height(yq * 1e3)
        return np.where(np.abs(yq) <= limit * (1 + 1e-12), z_mm * 1e-3, np.nan)

    def exact_slope(yq):
        yq = np.asarray(yq, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(np.abs(yq) <= limit * (1 + 1e-12), _RAIL.slope(yq * 1e3), np.nan)

    return Profile("60E1", RAIL, ys * 1e-3, zs * 1e-3, "EN 13674-1 60E1", exact, exact_slope)


def rail_60e1_head():
    """The 60E1 head's construction (mm): centres, radii, angles and end points of its arcs
    (`c1`, `r1`, `phi1`, ..., `y3`, `z3`, where the 1:20 flank begins)."""
    return _RAIL


# --- Files ----------------------------------------------------------------------------


def write_csv(profile: Profile) -> bytes:
    """The profile as CSV: `y_mm,z_mm`, then one point per line, increasing y."""
    lines = [CSV_HEADER] + [f"{y * 1e3:.10g},{z * 1e3:.10g}" for y, z in zip(profile.y, profile.z)]
    return ("\n".join(lines) + "\n").encode()


def read_profile(path, kind: str | None = None) -> Profile:
    """A profile from a file: `.csv` (y_mm,z_mm in this module's convention), `.prw` (a
    SIMPACK wheel) or `.prr` (a SIMPACK rail). `kind` ("wheel" or "rail") must agree with a
    SIMPACK file; for a CSV without it, a profile whose highest point lies inside its span
    is a rail, else a wheel. A bad file raises ProfileError, one line naming file and line."""
    path = Path(path)
    if kind is not None and kind not in KINDS:
        raise ValueError(f"kind must be 'wheel' or 'rail', got {kind!r}")
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".prw", ".prr"):
        raise ProfileError(
            f"{path}: unknown profile format {path.suffix or '(no suffix)'!r}: "
            f"expected .csv, .prw (SIMPACK wheel) or .prr (SIMPACK rail)"
        )
    try:
        text = read_input(path).decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise ProfileError(f"{path}: not a text file (byte {e.start} is not UTF-8)") from None
    except OSError as e:
        raise ProfileError(f"{path}: cannot read it: {e.strerror or e}") from None
    if suffix == ".csv":
        y, z, lines = _parse_csv(path, text)
    else:
        file_kind = WHEEL if suffix == ".prw" else RAIL
        if kind is not None and kind != file_kind:
            raise ProfileError(f"{path}: a {suffix} file is a {file_kind} profile, not a {kind}")
        kind = file_kind
        y, z, lines = _parse_simpack(path, text, kind)
    return _finish(path, y, z, lines, kind, ordered=suffix == ".csv")


_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _number(text: str) -> float | None:
    text = text.strip()
    if not re.fullmatch(_NUMBER, text):
        return None
    return float(text)


def _parse_csv(path: Path, text: str):
    ys: list[float] = []
    zs: list[float] = []
    lines: list[int] = []
    header_seen = False
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if not header_seen:
            if line.replace(" ", "") != CSV_HEADER:
                raise ProfileError(f"{path}, line {n}: expected the header {CSV_HEADER!r}, got {_show(line)}")
            header_seen = True
            continue
        fields = line.split(",")
        values = [v for v in map(_number, fields) if v is not None]
        if len(fields) != 2 or len(values) != 2:
            raise ProfileError(f"{path}, line {n}: expected two numbers y_mm,z_mm, got {_show(line)}")
        ys.append(values[0] * 1e-3)
        zs.append(values[1] * 1e-3)
        lines.append(n)
    if not header_seen:
        raise ProfileError(f"{path}: empty: expected the header {CSV_HEADER!r} and points")
    return np.array(ys), np.array(zs), lines


# SIMPACK's header flags rail-mj honours, and their values when absent (identity).
_FLAGS = {
    "mirror.y": 0.0,
    "mirror.z": 0.0,
    "inversion": 0.0,
    "shift.y": 0.0,
    "shift.z": 0.0,
    "rotate": 0.0,
    "units.len.f": 1.0,
    "units.ang.f": 1.0,
    "bound.y.min": 1.0,
    "bound.y.max": 0.0,
    "bound.z.min": 1.0,
    "bound.z.max": 0.0,
}


def _parse_simpack(path: Path, text: str, kind: str):
    """Points and flags of a SIMPACK profile, then SIMPACK's own preprocessing, in its
    order: shift, rotate, bounds, mirror, inversion, units; then its z (down) to ours (up)."""
    flags = dict(_FLAGS)
    ys: list[float] = []
    zs: list[float] = []
    lines: list[int] = []
    begin = end = None
    in_header = False
    for n, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("!", 1)[0].strip()  # '!' starts a comment
        if not line:
            continue
        word = line.split()[0].lower()
        in_points = begin is not None and end is None
        if word == "point.begin":
            if begin is not None:
                raise ProfileError(f"{path}, line {n}: a second point.begin (the first on line {begin})")
            begin = n
        elif word == "point.end":
            if not in_points:
                raise ProfileError(f"{path}, line {n}: point.end without point.begin")
            end = n
        elif in_points:
            if word.endswith((".begin", ".end")):  # another section: the points never ended
                raise ProfileError(f"{path}, line {begin}: point.begin without point.end (line {n} is {word})")
            parts = line.split()
            values = [v for v in map(_number, parts) if v is not None]
            if len(parts) not in (2, 3) or len(values) != len(parts):
                raise ProfileError(
                    f"{path}, line {n}: expected two numbers y z (and an optional weight) "
                    f"between point.begin and point.end, got {_show(line)}"
                )
            ys.append(values[0])
            zs.append(values[1])
            lines.append(n)
        elif word in ("header.begin", "header.end"):
            in_header = word == "header.begin"
        elif "=" in line:
            key, value = (part.strip().strip("'\"") for part in line.split("=", 1))
            key = key.lower()
            if in_header and key == "type" and value in ("0", "1") and (value == "1") != (kind == WHEEL):
                raise ProfileError(
                    f"{path}, line {n}: type = {value} declares a "
                    f"{'wheel' if value == '1' else 'rail'} profile in a {path.suffix} "
                    f"({kind}) file"
                )
            if key in _FLAGS:
                flags[key] = _flag(path, n, key, value)
    if begin is None:
        raise ProfileError(
            f"{path}: no point.begin line: a SIMPACK profile lists its points between point.begin and point.end"
        )
    if end is None:
        raise ProfileError(f"{path}, line {begin}: point.begin without point.end")
    if len(ys) < 2:
        raise ProfileError(
            f"{path}, line {begin}: {len(ys)} point(s) between point.begin (line {begin}) "
            f"and point.end (line {end}): a profile needs at least 2"
        )
    y, z, at = np.array(ys), np.array(zs), np.array(lines)
    # 1. shift, in the file's length unit
    y, z = y + flags["shift.y"], z + flags["shift.z"]
    # 2. rotate about x (right-handed in SIMPACK's frame), in the file's angle unit
    angle = flags["rotate"] / flags["units.ang.f"]
    if not math.isfinite(angle):
        raise ProfileError(
            f"{path}: rotate / units.ang.f is not a finite angle ({flags['rotate']:g} / {flags['units.ang.f']:g})"
        )
    if angle:
        c, s = math.cos(angle), math.sin(angle)
        y, z = c * y - s * z, s * y + c * z
    # 3. bounds (active when min < max): points outside bound.y dropped, z clipped to bound.z
    if flags["bound.y.min"] < flags["bound.y.max"]:
        keep = (y >= flags["bound.y.min"]) & (y <= flags["bound.y.max"])
        y, z, at = y[keep], z[keep], at[keep]
        if len(y) < 2:
            raise ProfileError(
                f"{path}: {len(y)} point(s) left within bound.y.min..bound.y.max: a profile needs at least 2"
            )
    if flags["bound.z.min"] < flags["bound.z.max"]:
        z = np.clip(z, flags["bound.z.min"], flags["bound.z.max"])
    # 4. mirror
    if flags["mirror.y"]:
        y = -y
    if flags["mirror.z"]:
        z = -z
    # 5. inversion: the order of the points reversed
    if flags["inversion"]:
        y, z, at = y[::-1], z[::-1], at[::-1]
    # 6. units: units.len.f is the file's length unit per metre (1000 for millimetres)
    y, z = y / flags["units.len.f"], z / flags["units.len.f"]
    # SIMPACK's profile z points down (a wheel's z is its radius above r0, a rail's the depth
    # below the top); rail-mj's points up.
    return y, -z, list(at)


def _flag(path: Path, n: int, key: str, value: str) -> float:
    number = _number(value)
    if number is None or not math.isfinite(number):
        raise ProfileError(f"{path}, line {n}: {key} must be a number, got {_show(value)}")
    if key in ("mirror.y", "mirror.z", "inversion") and number not in (0.0, 1.0):
        raise ProfileError(f"{path}, line {n}: {key} must be 0 or 1, got {_show(value)}")
    if key in ("units.len.f", "units.ang.f") and number <= 0:
        raise ProfileError(f"{path}, line {n}: {key} must be positive, got {_show(value)}")
    return number


def _finish(path: Path, y, z, lines, kind: str | None, ordered: bool) -> Profile:
    if len(y) < 2:
        raise ProfileError(f"{path}: {len(y)} point(s): a profile needs at least 2")
    bad = ~(np.isfinite(y) & np.isfinite(z))
    if np.any(bad):
        raise ProfileError(f"{path}, line {lines[int(np.argmax(bad))]}: not a finite number")
    if not ordered and y[-1] < y[0]:
        # A SIMPACK file may list its points either way along y; rail-mj keeps them increasing.
        y, z, lines = y[::-1], z[::-1], lines[::-1]
    step = np.diff(y)
    if np.any(step <= 0):
        k = int(np.argmax(step <= 0)) + 1
        what = "the same y as" if step[k - 1] == 0 else "a y before that of"
        direction = "increasing" if ordered else "in one direction along"
        raise ProfileError(
            f"{path}, line {lines[k]}: y = {y[k] * 1e3:.6g} mm is {what} the point on line "
            f"{lines[k - 1]} ({y[k - 1] * 1e3:.6g} mm): points must run {direction} y, "
            f"each y once"
        )
    span = y[-1] - y[0]
    if not (_SPAN_MIN <= span <= _SPAN_MAX):
        hint = (
            "the CSV is in millimetres"
            if ordered
            else "units.len.f is the number of the file's length units in a metre: 1000 for mm"
        )
        raise ProfileError(
            f"{path}: the points span {span * 1e3:.6g} mm across, not a wheel or rail "
            f"profile (a few centimetres): {hint}"
        )
    if not (np.all(np.isfinite(z)) and np.ptp(z) <= _SPAN_MAX):
        raise ProfileError(
            f"{path}: the heights span {np.ptp(z) * 1e3:.6g} mm, not a wheel or rail profile "
            f"(a few centimetres): check the units and the points"
        )
    if kind is None:
        top = int(np.argmax(z))
        kind = RAIL if 0 < top < len(z) - 1 else WHEEL
    return Profile(path.stem, kind, y, z, str(path))


def _show(text: str, limit: int = 60) -> str:
    text = " ".join(text.split())
    return repr(text if len(text) <= limit else text[:limit] + "...")


def standard(name: str) -> Profile:
    """A standard profile by its name: 's1002' or '60e1' (any case)."""
    key = name.lower()
    if key == "s1002":
        return s1002()
    if key in ("60e1", "uic60"):
        return rail_60e1()
    raise ValueError(f"unknown standard profile {name!r}: s1002 or 60e1")
