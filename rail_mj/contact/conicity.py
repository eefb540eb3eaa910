"""Equivalent conicity (EN 15302) from a rolling-radius-difference function Δr(y).

Δr(y) = r_left − r_right of the rigid wheelset shifted y to the left, in mm (docs/conicity.md).
The kinematic (Klingel) motion it gives is y'' + Δr(y)/(e·r0) = 0 in distance; its wavelength L
depends on the amplitude ŷ (half the peak-to-peak), and the equivalent conicity is the cone's
with the same wavelength, λe(ŷ) = (2π/L)²·e·r0/2. Three ways to it:

- `equivalent_conicity(..., method="integration")` (what `rail-mj conicity` reports): the
  standard's reference method, integration of the nonlinear equation, done here by the exact
  period of the conservative oscillator (quadrature of T = ∮ dy / sqrt(2(Φ − G(y))), G' = Δr/(e r0)).
- `klingel_ode`: the same equation stepped in distance with solve_ivp, a check of the quadrature.
- `equivalent_conicity(..., method="harmonic")`: harmonic linearisation (the describing
  function), a cross-check, exact for a cone and a few per cent off where Δr bends.

Example, a 1:20 cone and the same cone shifted 1 mm (wheels of unequal diameters):

    >>> cone = DeltaR.cone(0.05, half_range=10.0)
    >>> [round(float(v), 9) for v in equivalent_conicity(cone, [1.0, 3.0, 9.0])]
    [0.05, 0.05, 0.05]
    >>> shifted = DeltaR.cone(0.05, half_range=10.0, centre=1.0)
    >>> shifted.centre, round(float(equivalent_conicity(shifted, [3.0])[0]), 9)
    ((1.0, 1.0), 0.05)

Every problem with the input raises `ConicityError`, whose message is one line.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rail_mj.files import read_input

E = 1500.0  # mm, distance between the contact points (standard gauge)
R0 = 460.0  # mm, nominal rolling radius; neither changes λe (docs/conicity.md)
DEFAULT_AMPLITUDES = tuple(0.5 * k for k in range(1, 21))  # mm: 0.5 to 10 in steps of 0.5
QUOTED_AMPLITUDE = 3.0  # mm: the amplitude at which λe is quoted in acceptance work
HEADER = ("y_mm", "delta_r_mm")
METHODS = ("integration", "harmonic")

_SAMPLES = 4001  # where a Δr given as a function is checked for its sign pattern
_NEAR_TURN = 1e-4  # fraction of the half-swing within which Φ − G is taken from Δr itself


class ConicityError(ValueError):
    """A Δr function or an amplitude that cannot give an equivalent conicity; one line."""


class DeltaR:
    """A rolling-radius-difference function on [y_min, y_max] (mm), with its integral.

    `value(y)` is Δr in mm; `integral(y)` any antiderivative of it (mm²). The function must
    go from negative to positive once as y grows (a stable centre); it may vanish on a band
    (a dead band), whose edges are `centre`. Build it with `from_points`, `read_csv`, `cone`
    or `from_function`.
    """

    def __init__(
        self,
        value: Callable,
        integral: Callable,
        y_min: float,
        y_max: float,
        grid=None,
        source: str = "Δr",
        lines=None,
        knots=(),
    ):
        if not (math.isfinite(y_min) and math.isfinite(y_max) and y_min < y_max):
            raise ConicityError(f"{source}: needs y_min < y_max, got {y_min} and {y_max}")
        self.value = value
        self.integral = integral
        self.y_min = float(y_min)
        self.y_max = float(y_max)
        self.source = source
        self.knots = np.asarray(knots, dtype=float)  # where Δr may bend sharply: pieces are smooth
        grid = np.linspace(y_min, y_max, _SAMPLES) if grid is None else np.asarray(grid, float)
        self.centre = self._find_centre(grid, lines)
        self._base = float(integral(self.centre[0]))

    # --- construction -------------------------------------------------------------------

    @classmethod
    def from_points(cls, y, dr, source: str = "Δr", lines=None) -> DeltaR:
        """Δr through the points (y, Δr), mm, interpolated by a monotone cubic (PCHIP).
        `lines`: each point's line in `source`, for the messages."""
        from scipy.interpolate import PchipInterpolator

        y = np.asarray(y, dtype=float)
        dr = np.asarray(dr, dtype=float)
        where = (lambda k: f"{source}:{lines[k]}") if lines is not None else (lambda k: f"{source}: point {k + 1}")
        if y.ndim != 1 or y.shape != dr.shape:
            raise ConicityError(f"{source}: y and Δr must be two lists of the same length")
        if len(y) < 3:
            raise ConicityError(f"{source}: needs at least 3 points, got {len(y)}")
        for k in range(len(y)):
            if not (math.isfinite(y[k]) and math.isfinite(dr[k])):
                raise ConicityError(f"{where(k)}: not a finite number")
            if k and not y[k] > y[k - 1]:
                raise ConicityError(
                    f"{where(k)}: y = {y[k]:g} mm does not increase (the line before has {y[k - 1]:g} mm)"
                )
        shape = PchipInterpolator(y, dr, extrapolate=False)
        area = shape.antiderivative()
        return cls(shape, area, y[0], y[-1], grid=y, source=source, lines=lines, knots=y)

    @classmethod
    def read_csv(cls, path) -> DeltaR:
        """Δr from a CSV file with the header `y_mm,delta_r_mm`, one point a line, y increasing.
        Blank lines and lines starting with # are skipped."""
        y, dr, lines = read_delta_r_csv(path)
        return cls.from_points(y, dr, source=str(path), lines=lines)

    @classmethod
    def cone(cls, conicity: float, half_range: float = 20.0, centre: float = 0.0) -> DeltaR:
        """A cone: Δr = 2λ(y − centre) on centre ± half_range (a centre off 0: wheels of
        unequal diameters)."""
        lam, c = float(conicity), float(centre)
        return cls(
            lambda y: 2.0 * lam * (np.asarray(y, float) - c),
            lambda y: lam * (np.asarray(y, float) - c) ** 2,
            c - half_range,
            c + half_range,
            source=f"cone {lam:g}",
        )

    @classmethod
    def from_function(
        cls, value: Callable, y_min: float, y_max: float, integral: Callable | None = None, source: str = "Δr", knots=()
    ) -> DeltaR:
        """Δr from a function of y (mm); `integral`, an antiderivative, or None to integrate
        `value` numerically; `knots`, where it has kinks (for the harmonic linearisation)."""
        if integral is None:
            from scipy.integrate import quad

            def integral(y):
                return quad(value, 0.0, float(y), epsabs=0.0, epsrel=1e-13, limit=400)[0]

        return cls(value, integral, y_min, y_max, source=source, knots=knots)

    # --- the centre -----------------------------------------------------------------------

    def _at(self, y: float) -> float:
        return float(self.value(y))

    def many(self, ys: np.ndarray) -> np.ndarray:
        """Δr at each of `ys`, with `value` called on the array when it takes one."""
        try:
            out = np.asarray(self.value(ys), dtype=float)
        except (TypeError, ValueError):
            out = None
        if out is None or out.shape != ys.shape:
            out = np.array([self._at(y) for y in ys])
        return out

    def _find_centre(self, grid, lines) -> tuple[float, float]:
        """(a, b): Δr < 0 below a, = 0 on [a, b], > 0 above b. Refuses any other sign pattern."""
        values = np.array([self._at(y) for y in grid])
        at = (lambda k: f"line {lines[k]}") if lines is not None else (lambda k: f"y = {grid[k]:g} mm")
        if not np.all(np.isfinite(values)):
            raise ConicityError(f"{self.source}: Δr is not finite at {at(int(np.argmin(np.isfinite(values))))}")
        negative = np.flatnonzero(values < 0)
        positive = np.flatnonzero(values > 0)
        if len(negative) == 0 or len(positive) == 0:
            sign = "negative" if len(negative) == 0 else "positive"
            raise ConicityError(
                f"{self.source}: Δr is never {sign} for y from {grid[0]:g} to {grid[-1]:g} mm: "
                f"the centre of the motion, where Δr vanishes, is not within the data"
            )
        if positive[0] < negative[-1]:
            raise ConicityError(
                f"{self.source}: Δr must go from negative to positive once as y grows (a stable centre), "
                f"but it is positive at {at(int(positive[0]))} and negative at {at(int(negative[-1]))} "
                f"(Δr = r_left - r_right, y to the left)"
            )
        i, j = int(negative[-1]), int(positive[0])
        a = self._edge(grid[i], grid[i + 1], lambda y: self._at(y) < 0)
        b = self._edge(grid[j - 1], grid[j], lambda y: not self._at(y) > 0)
        if b - a <= 1e-12 * (grid[-1] - grid[0]):  # one zero, found from both sides
            a = b = 0.5 * (a + b)
        return a, max(a, b)

    @staticmethod
    def _edge(lo: float, hi: float, below: Callable[[float], bool]) -> float:
        """The point in [lo, hi] where `below` stops holding (true at lo, false at hi)."""
        lo, hi = float(lo), float(hi)
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mid <= lo or mid >= hi:
                break
            if below(mid):
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi) if lo != hi else lo

    # --- the motion ---------------------------------------------------------------------------

    def potential(self, y: float) -> float:
        """G(y) = ∫ Δr from the centre to y (mm²): never negative."""
        return float(self.integral(y)) - self._base

    def largest_amplitude(self) -> float:
        """The largest amplitude (mm) whose motion stays within the data."""
        return self._swing(self._top())[2]

    def _top(self) -> float:
        return min(self.potential(self.y_min), self.potential(self.y_max))

    def _swing(self, level: float) -> tuple[float, float, float]:
        """The turning points (y-, y+) of the motion at energy `level` (mm², as G) and its
        amplitude, half of y+ − y-."""
        from scipy.optimize import brentq

        a, b = self.centre
        tol = 1e-15 * (self.y_max - self.y_min)
        if level <= 0.0:
            return a, b, 0.5 * (b - a)
        hi = brentq(lambda y: self.potential(y) - level, b, self.y_max, xtol=tol, rtol=1e-15)
        lo = brentq(lambda y: self.potential(y) - level, self.y_min, a, xtol=tol, rtol=1e-15)
        return lo, hi, 0.5 * (hi - lo)

    def turning_points(self, amplitude: float) -> tuple[float, float, float]:
        """(y-, y+, level): the turning points of the motion of `amplitude` (mm; half the
        peak-to-peak about the centre) and its energy level in mm² (0: inside a dead band)."""
        from scipy.optimize import brentq

        amplitude = _amplitude(amplitude)
        a, b = self.centre
        if amplitude <= 0.5 * (b - a):
            return a, b, 0.0
        top = self._top()
        largest = self._swing(top)[2]
        if amplitude > largest * (1 + 1e-12):
            raise ConicityError(
                f"{self.source}: amplitude {amplitude:g} mm is beyond the data: the motion about the centre "
                f"(y = {0.5 * (a + b):g} mm) stays within y from {self.y_min:g} to {self.y_max:g} mm only up "
                f"to {largest:.4g} mm"
            )
        if amplitude >= largest:
            level = top
        else:
            level = brentq(lambda p: self._swing(p)[2] - amplitude, 0.0, top, xtol=1e-15 * top, rtol=1e-15)
        lo, hi, found = self._swing(level)
        if abs(found - amplitude) > 1e-9 * max(amplitude, 1.0):
            # No motion has this amplitude: Δr vanishes again beyond the centre and the
            # amplitude jumps over a plateau of G, where the period grows without bound.
            return lo, hi, math.nan
        return lo, hi, level

    def half_period(self, amplitude: float) -> float:
        """∫ dy / sqrt(2(Φ − G(y))) from y- to y+ (mm per sqrt(mm) units with e·r0 = 1):
        the half wavelength divided by sqrt(e·r0). math.inf inside a dead band, NaN where no
        periodic motion has this amplitude."""
        lo, hi, level = self.turning_points(amplitude)
        if not level > 0.0:
            return level if math.isnan(level) else math.inf
        a, b = self.centre
        flat = (b - a) / math.sqrt(2.0 * level)  # the dead band, crossed at constant speed
        return flat + self._quarter(b, hi, level) + self._quarter(a, lo, level)

    def _quarter(self, start: float, turn: float, level: float) -> float:
        """∫ dy / sqrt(2(Φ − G)) from the centre's edge `start` to the turning point `turn`,
        with y = start + (turn − start)·sin θ, which removes the singularity at the turn."""
        from scipy.integrate import quad

        span = turn - start

        def integrand(theta: float) -> float:
            gap = abs(span) * 2.0 * math.sin(math.pi / 4 - theta / 2) ** 2  # |turn − y|, exactly
            y = turn - math.copysign(gap, span)
            if gap < _NEAR_TURN * abs(span):  # Φ − G(y) is ∫ Δr from y to the turn
                drop = abs(self._at(turn - math.copysign(0.5 * gap, span))) * gap
            else:
                drop = level - self.potential(y)
            if drop <= 0.0:
                return 0.0 if gap == 0.0 else math.inf
            return abs(span) * math.cos(theta) / math.sqrt(2.0 * drop)

        value, error, _info = quad(integrand, 0.0, math.pi / 2, epsabs=0.0, epsrel=1e-12, limit=500, full_output=1)[:3]
        if not (math.isfinite(value) and error <= 1e-8 * value):
            raise ConicityError(
                f"{self.source}: the period did not converge near y = {turn:g} mm (Δr vanishes at the turning point)"
            )
        return value


# Amplitudes below this are refused: the level of the motion's energy, about lam*y^2, would
# be lost in the round-off of the potential's values (mm^2 near the data's ends), and no
# measured profile resolves a hundredth of a millimetre anyway.
MIN_AMPLITUDE = 0.05  # mm


def _amplitude(value) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ConicityError(f"an amplitude must be a positive number of mm, got {value:g}")
    if value < MIN_AMPLITUDE:
        raise ConicityError(
            f"an amplitude must be at least {MIN_AMPLITUDE:g} mm (below it the energy level "
            f"is lost in round-off), got {value:g}"
        )
    return value


def wavelength(delta_r: DeltaR, amplitude: float, e: float = E, r0: float = R0) -> float:
    """The wavelength (mm) of the kinematic motion of `amplitude` (mm), from the exact period
    of y'' + Δr(y)/(e·r0) = 0; math.inf inside a dead band."""
    _check_geometry(e, r0)
    return 2.0 * math.sqrt(e * r0) * delta_r.half_period(amplitude)


def equivalent_conicity(
    delta_r: DeltaR, amplitudes, method: str = "integration", e: float = E, r0: float = R0
) -> np.ndarray:
    """λe at each amplitude (mm): `integration` (EN 15302's reference method; λe = (2π/L)²·e·r0/2
    from the wavelength L of the nonlinear Klingel motion) or `harmonic` (harmonic
    linearisation, a cross-check). NaN where no periodic motion has the amplitude (a Δr that
    vanishes again away from the centre); 0 within a dead band."""
    if method not in METHODS:
        raise ConicityError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    _check_geometry(e, r0)
    out = []
    for amplitude in np.atleast_1d(np.asarray(amplitudes, dtype=float)):
        if method == "harmonic":
            out.append(harmonic_conicity(delta_r, amplitude))
            continue
        length = wavelength(delta_r, amplitude, e, r0)
        out.append(
            (2.0 * math.pi / length) ** 2 * e * r0 / 2.0
            if math.isfinite(length)
            else (math.nan if math.isnan(length) else 0.0)
        )
    return np.array(out)


def harmonic_conicity(delta_r: DeltaR, amplitude: float) -> float:
    """Harmonic linearisation: for y = c + ŷ·sin φ, the centre c where Δr's mean over a cycle
    vanishes, and λe = (1/(2πŷ))·∮ Δr(c + ŷ sin φ)·sin φ dφ (the first harmonic of Δr over 2ŷ)."""
    from scipy.optimize import brentq

    amp = _amplitude(amplitude)
    lo, hi = delta_r.y_min + amp, delta_r.y_max - amp
    if lo > hi:
        raise ConicityError(
            f"{delta_r.source}: amplitude {amp:g} mm is beyond the data "
            f"(y from {delta_r.y_min:g} to {delta_r.y_max:g} mm)"
        )

    def bias(c: float) -> float:
        phi, weight = _cycle(delta_r.knots, c, amp)
        return float(weight @ delta_r.many(c + amp * np.sin(phi))) / math.pi

    b_lo, b_hi = bias(lo), bias(hi)
    if b_lo > 0 or b_hi < 0:
        raise ConicityError(
            f"{delta_r.source}: amplitude {amp:g} mm is beyond the data: no centre within "
            f"y from {delta_r.y_min:g} to {delta_r.y_max:g} mm balances Δr over a cycle"
        )
    c = lo if b_lo == 0 else hi if b_hi == 0 else brentq(bias, lo, hi, xtol=1e-14 * amp, rtol=1e-15)
    phi, weight = _cycle(delta_r.knots, c, amp)
    return float(weight @ (delta_r.many(c + amp * np.sin(phi)) * np.sin(phi))) / (math.pi * amp)


_GAUSS = np.polynomial.legendre.leggauss(16)


def _cycle(knots, c: float, amp: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights over φ in [−π/2, π/2] (half a cycle; the other half repeats it):
    16-point Gauss-Legendre on pieces no longer than π/64, broken where y = c + ŷ sin φ
    crosses a knot of Δr, so that each piece is smooth."""
    inside = knots[(knots > c - amp) & (knots < c + amp)]
    cuts = np.unique(np.concatenate([[-math.pi / 2, math.pi / 2], np.arcsin((inside - c) / amp)]))
    pieces: list[tuple[float, float]] = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        edges = np.linspace(a, b, max(1, math.ceil((b - a) / (math.pi / 64))) + 1)
        pieces.extend(zip(edges[:-1], edges[1:]))
    ends = np.array(pieces)
    half = 0.5 * (ends[:, 1] - ends[:, 0])
    mid = 0.5 * (ends[:, 1] + ends[:, 0])
    phi = (mid[:, None] + half[:, None] * _GAUSS[0][None, :]).ravel()
    weight = (half[:, None] * _GAUSS[1][None, :]).ravel()
    return phi, weight


def klingel_ode(
    delta_r: DeltaR, release: float, e: float = E, r0: float = R0, rtol: float = 1e-12
) -> tuple[float, float]:
    """(amplitude, wavelength), mm: the wheelset let go at rest at y = `release` (mm, beyond
    the centre on either side) and y'' = −Δr(y)/(e·r0) stepped in distance (DOP853) through
    one period, from turning point to turning point and back. A check of `wavelength`."""
    from scipy.integrate import solve_ivp

    _check_geometry(e, r0)
    scale = delta_r.y_max - delta_r.y_min

    def rhs(_x, s):
        return [s[1], -delta_r._at(s[0]) / (e * r0)]

    first = 1.0 if release > delta_r.centre[1] else -1.0  # at the far side the slope changes sign
    state, points, length = [float(release), 0.0], [float(release)], 0.0
    span = 100.0 * math.pi * math.sqrt(e * r0)  # far beyond any period of interest
    for direction in (first, -first):
        run = solve_ivp(
            rhs, (0.0, span), state, method="DOP853", rtol=rtol, atol=rtol * scale * 1e-3, events=_Turned(direction)
        )
        if not run.t_events[0].size:
            raise ConicityError(f"{delta_r.source}: no turning point within {span:g} mm of running")
        length += float(run.t_events[0][0])
        state = [float(run.y_events[0][0][0]), 0.0]
        points.append(state[0])
    return 0.5 * (max(points) - min(points)), length


class _Turned:
    """solve_ivp's event: the wheelset's lateral velocity dy/dx (s[1]) passes zero in one
    direction, a turning point of the kinematic oscillation; the run stops there."""

    terminal = True

    def __init__(self, direction: float) -> None:
        self.direction = direction

    def __call__(self, _x: float, s: np.ndarray) -> float:
        return s[1]


def _check_geometry(e: float, r0: float) -> None:
    if not (math.isfinite(e) and math.isfinite(r0) and e > 0 and r0 > 0):
        raise ConicityError(f"e and r0 must be positive lengths in mm, got {e:g} and {r0:g}")


def read_delta_r_csv(path) -> tuple[list[float], list[float], list[int]]:
    """(y, Δr, line numbers) from a CSV with the header `y_mm,delta_r_mm`."""
    path = Path(path)
    try:
        text = read_input(path).decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as e:
        raise ConicityError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    ys, drs, lines = [], [], []
    header = False
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(",")]
        if not header:
            if tuple(f.strip('"').lower() for f in fields) != HEADER:
                raise ConicityError(
                    f"{path}:{number}: expected the header {','.join(HEADER)} "
                    f"(y and Δr = r_left - r_right, in mm), got {line[:60]!r}"
                )
            header = True
            continue
        if len(fields) != 2:
            raise ConicityError(f"{path}:{number}: expected 2 fields (y_mm, delta_r_mm), got {len(fields)}")
        try:
            y, dr = float(fields[0]), float(fields[1])
        except ValueError:
            raise ConicityError(f"{path}:{number}: not a number: {line[:60]!r}") from None
        if not (math.isfinite(y) and math.isfinite(dr)):
            raise ConicityError(f"{path}:{number}: not a finite number: {line[:60]!r}")
        ys.append(y)
        drs.append(dr)
        lines.append(number)
    if not header:
        raise ConicityError(f"{path}: empty: expected the header {','.join(HEADER)} and at least 3 points")
    return ys, drs, lines
