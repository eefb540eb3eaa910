"""Track irregularities from standard spectra: their densities, band variances and realisations
(docs/irregularities.md).

Four channels, as EN 13848 measures them: lateral alignment and vertical level (each the mean of
the two rails), cross level (the height of the left rail over the right, over the 1.5 m between
rail centres) and gauge (its departure from nominal). Each spectrum is a one-sided power spectral
density S(Ω) in m² per rad/m of the spatial angular frequency Ω = 2π/λ; per cycle per metre,
S_f(f) = 2π·S(2π·f). A realisation is a sum of cosines at evenly spaced spatial frequencies over
the band kept, each of amplitude sqrt(2·S_f·Δf) and a random phase (Shinozuka's harmonic
synthesis), so that its variance is Σ S_f·Δf, the band integral of the density by the midpoint
rule; `band_variance` gives the integral itself (in closed form for ERRI B176's alignment and
level).

The spectra:

- ERRI B176 (ERRI 1993; as SIMPACK and GENSYS implement it), "erri-low" and "erri-high" (high is
  the worse track): S(Ω) = A·Ωc²/((Ω² + Ωr²)(Ω² + Ωc²)), Ωc = 0.8246, Ωr = 0.0206 rad/m, with A
  (m·rad) for alignment and level; cross level and gauge the same family times
  Ω²/(Ω² + Ωs²), Ωs = 0.438 rad/m, cross level as a rail-height difference over the 1.5 m base
  (the angle's density A_v/b²·..., b = 0.75 m, times (2b)²).
- FRA track classes 1 to 6 (Hamid & Yang 1981; class 6 the best): S(Ω) = k·A·Ωc²/(Ω²(Ω² + Ωc²)),
  k = 0.25, Ωc = 0.8245 rad/m, A in cm²·rad/m, for level and alignment. The classes give no
  cross level or gauge in this family: those channels are zero (`Spectrum.channels` says which
  are given). The Ω⁻² tail makes the variance depend on the longest wavelength kept: always
  state the band.

Example:

    >>> s = SPECTRA["erri-low"]
    >>> round(band_variance(s, "level", (3.0, 150.0)) ** 0.5 * 1e3, 3)  # rms level, mm, EN 13848 D1-D3
    2.863
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from rail_mj.track.errors import TrackError

Array = NDArray[np.float64]

CHANNELS = ("alignment", "level", "cross_level", "gauge")
# EN 13848-1's wavelength bands, m: D1 3-25, D2 25-70, D3 70-150. The default band is all three.
BANDS = {"D1": (3.0, 25.0), "D2": (25.0, 70.0), "D3": (70.0, 150.0)}
DEFAULT_BAND = (3.0, 150.0)  # m
# A realisation's spacing, m: a tenth of the shortest wavelength in EN 13848's bands, far finer
# than the half a wavelength sampling needs, so that linear interpolation between samples loses
# under 2 % of the amplitude of the shortest waves (1 - cos(π/10)).
SPACING = 0.3  # m
FADE_IN = 50.0  # m: the irregularities grow from nothing over this, so the vehicle is not kicked
RAIL_BASE = 1.5  # m, between rail centres: cross level is a height difference over it
MAX_SAMPLES = 20_000_000  # a measured file resampled evenly: 320 bytes a sample in a run's model

_ERRI_C, _ERRI_R, _ERRI_S = 0.8246, 0.0206, 0.438  # rad/m
_FRA_C, _FRA_K = 0.8245, 0.25  # rad/m, -
CM2 = 1e-4  # m² per cm²


@dataclasses.dataclass(frozen=True)
class Spectrum:
    """A named track spectrum: `density(channel, Ω)`, one-sided, m² per rad/m, for each channel
    it gives (`channels`; the others are zero)."""

    name: str
    channels: tuple[str, ...]
    _densities: dict[str, Callable[[Array], Array]] = dataclasses.field(repr=False, compare=False)

    def density(self, channel: str, omega) -> Array:
        """S(Ω), m²/(rad/m), at spatial angular frequencies Ω (rad/m); zero for a channel the
        spectrum does not give."""
        if channel not in CHANNELS:
            raise TrackError(f"irregularities: channel must be one of {', '.join(CHANNELS)}, got {channel!r}")
        omega = np.asarray(omega, dtype=float)
        if channel not in self.channels:
            return np.zeros_like(omega)
        return self._densities[channel](omega)


def _erri(a_lateral: float, a_vertical: float, a_gauge: float) -> dict[str, Callable[[Array], Array]]:
    c2, r2, s2 = _ERRI_C**2, _ERRI_R**2, _ERRI_S**2

    def base(a: float) -> Callable[[Array], Array]:
        return lambda w: a * c2 / ((w**2 + r2) * (w**2 + c2))

    def shaped(a: float) -> Callable[[Array], Array]:
        return lambda w: a * c2 * w**2 / ((w**2 + r2) * (w**2 + c2) * (w**2 + s2))

    b = RAIL_BASE / 2.0
    # The cross level's angle has density (A_v/b²)·...; its height over the base 2b, (2b)² that.
    cross = a_vertical / b**2 * (2.0 * b) ** 2
    return {
        "alignment": base(a_lateral),
        "level": base(a_vertical),
        "cross_level": shaped(cross),
        "gauge": shaped(a_gauge),
    }


def _fra(a_vertical_cm2: float, a_lateral_cm2: float) -> dict[str, Callable[[Array], Array]]:
    c2 = _FRA_C**2

    def one(a: float) -> Callable[[Array], Array]:
        return lambda w: _FRA_K * a * CM2 * c2 / (w**2 * (w**2 + c2))

    return {"level": one(a_vertical_cm2), "alignment": one(a_lateral_cm2)}


# A (m·rad) of ERRI B176: lateral, vertical, gauge; low level is the better track.
_ERRI_A = {"erri-low": (2.119e-7, 4.032e-7, 5.32e-8), "erri-high": (6.125e-7, 1.080e-6, 1.032e-7)}
# A (cm²·rad/m) of the FRA classes, vertical and alignment (Hamid & Yang 1981).
_FRA_A = {
    1: (1.2107, 3.3634),
    2: (1.0181, 1.2107),
    3: (0.6816, 0.4128),
    4: (0.5376, 0.3027),
    5: (0.2095, 0.0762),
    6: (0.0339, 0.0339),
}

SPECTRA: dict[str, Spectrum] = {
    **{name: Spectrum(name, CHANNELS, _erri(*a)) for name, a in _ERRI_A.items()},
    **{f"fra-{k}": Spectrum(f"fra-{k}", ("alignment", "level"), _fra(*a)) for k, a in _FRA_A.items()},
}


def spectrum(name: str) -> Spectrum:
    try:
        return SPECTRA[name]
    except KeyError:
        raise TrackError(
            f"irregularities.spectrum: must be one of {', '.join(map(repr, SPECTRA))}, got {name!r}"
        ) from None


def check_band(band) -> tuple[float, float]:
    """The band of wavelengths kept, m, as (shortest, longest), checked."""
    try:
        short, long = (float(v) for v in band)
    except (TypeError, ValueError):
        raise TrackError(f"irregularities.wavelengths: give [shortest, longest] in m, got {band!r}") from None
    if not (math.isfinite(short) and math.isfinite(long) and 2.0 * SPACING < short < long <= 1000.0):
        raise TrackError(
            f"irregularities.wavelengths: need {2 * SPACING:g} m < shortest < longest <= 1000 m, got {band!r}"
        )
    return short, long


def band_variance(spec: Spectrum, channel: str, band=DEFAULT_BAND) -> float:
    """The variance, m², of `channel` between the band's wavelengths (m): the integral of S(Ω)
    over Ω from 2π/longest to 2π/shortest. In closed form for ERRI's alignment and level,
    σ² = A·Ωc²/(Ωc² − Ωr²)·[atan(Ω/Ωr)/Ωr − atan(Ω/Ωc)/Ωc] between the ends; otherwise by
    Gauss-Legendre quadrature on a log scale (200 points: the densities are smooth rational
    functions, exact there to 1e-12)."""
    short, long = check_band(band)
    lo, hi = 2.0 * math.pi / long, 2.0 * math.pi / short
    if spec.name in _ERRI_A and channel in ("alignment", "level"):
        a = _ERRI_A[spec.name][0 if channel == "alignment" else 1]
        c, r = _ERRI_C, _ERRI_R

        def primitive(w: float) -> float:
            return a * c**2 / (c**2 - r**2) * (math.atan(w / r) / r - math.atan(w / c) / c)

        return primitive(hi) - primitive(lo)
    nodes, weights = np.polynomial.legendre.leggauss(200)
    u = 0.5 * (math.log(hi) - math.log(lo)) * nodes + 0.5 * (math.log(hi) + math.log(lo))
    w = np.exp(u)
    return float(0.5 * (math.log(hi) - math.log(lo)) * np.sum(weights * spec.density(channel, w) * w))


def line_grid(length: float, band) -> tuple[float, Array, Array]:
    """(L, f, w): the period L (a whole multiple of the longest wavelength, at least `length`),
    the spatial frequencies j/L inside the band (cycles/m) and their trapezoid
    weights (a half at each end of the band), so that Σ w·S_f·Δf is the band integral to second
    order in Δf = 1/L."""
    short, long = check_band(band)
    period = long * math.ceil(length / long - 1e-9)
    j = np.arange(math.ceil(period / long - 1e-9), math.floor(period / short + 1e-9) + 1)
    f = j / period
    w = np.ones_like(f)
    if len(w) > 1:
        w[0] = w[-1] = 0.5
    return period, f, w


def realise(
    spec: Spectrum, length: float, band=DEFAULT_BAND, seed: int = 1, scale: float = 1.0, fade_in: float = FADE_IN
) -> tuple[Array, dict[str, Array]]:
    """A realisation over `length` m: (x, {channel: values, m}) at SPACING (or the little less
        that divides the grid's period evenly), every channel from
        its own stream of the one `seed` (the same seed, the same track), faded in over `fade_in` m
    (a raised cosine).

        The spatial frequencies are j/L on a grid of period L (`line_grid`), every one inside the band,
        so that over L the cosines are orthogonal and the variance over L is Σ w·S_f·Δf
        (`realised_variance`). On that grid the sum of cosines is an inverse FFT of L/SPACING points."""
    if not (math.isfinite(length) and length > 0.0):
        raise TrackError(f"irregularities: the track's length must be positive, got {length!r}")
    if not (math.isfinite(scale) and scale >= 0.0):
        raise TrackError(f"irregularities.scale: must be a number >= 0, got {scale!r}")
    period, f, w = line_grid(length, band)
    n = math.ceil(period / SPACING - 1e-9)  # samples a period, at SPACING or a little closer
    step = period / n
    j = np.rint(f * period).astype(int)
    x = np.arange(0, math.ceil(length / step - 1e-9) + 1, dtype=float) * step  # to the end, or a little past
    if not (math.isfinite(fade_in) and fade_in >= 0.0):
        raise TrackError(f"irregularities: the fade-in must be a length >= 0, got {fade_in!r}")
    fade = np.ones_like(x) if fade_in == 0.0 else 0.5 - 0.5 * np.cos(np.pi * np.clip(x / fade_in, 0.0, 1.0))
    streams = np.random.default_rng(seed).spawn(len(CHANNELS))
    out: dict[str, Array] = {}
    for channel, rng in zip(CHANNELS, streams):
        phases = rng.uniform(0.0, 2.0 * np.pi, len(f))
        amplitude = np.sqrt(2.0 * w * 2.0 * np.pi * spec.density(channel, 2.0 * np.pi * f) / period)
        coefficients = np.zeros(n, dtype=complex)
        coefficients[j % n] = amplitude * np.exp(1j * phases)
        # Σ a·cos(2π·j·k/n + θ) at sample k: the real part of n·ifft of the coefficients.
        values = (n * np.fft.ifft(coefficients)).real
        out[channel] = scale * fade * values[np.arange(len(x)) % n]
    return x, out


def realised_variance(spec: Spectrum, channel: str, length: float, band=DEFAULT_BAND, scale: float = 1.0) -> float:
    """The variance a realisation of `length` m has over its grid's period, m²: Σ w·S_f·Δf
    (see `realise`), the trapezoid rule of `band_variance`'s integral."""
    period, f, w = line_grid(length, band)
    return float(scale**2 * np.sum(w * 2.0 * np.pi * spec.density(channel, 2.0 * np.pi * f)) / period)


# --- in a track file ---------------------------------------------------------------------------

CSV_COLUMNS = ("x_m", "alignment_mm", "level_mm", "cross_level_mm", "gauge_mm")
KEYS = ("spectrum", "wavelengths", "seed", "scale", "file")
MM = 1e-3  # m per mm


@dataclasses.dataclass(frozen=True)
class Irregularities:
    """A track file's [irregularities]: generated from `spectrum` over the band `wavelengths` (m)
    with `seed` and `scale`, or measured, `measured` = (x, the four channels, m) from a CSV."""

    spectrum: str | None = None
    wavelengths: tuple[float, float] = DEFAULT_BAND
    seed: int = 1
    scale: float = 1.0
    file: str | None = None  # the measured CSV's path, for messages
    measured: tuple[tuple[float, ...], ...] | None = dataclasses.field(default=None, repr=False)

    def channels(self, length: float) -> tuple[Array, dict[str, Array]]:
        """(x, {channel: values, m}) over a track of `length` m: realised, or as measured."""
        if self.measured is not None:
            x, *columns = (np.asarray(c, dtype=float) for c in self.measured)
            return x, dict(zip(CHANNELS, columns))
        assert self.spectrum is not None
        return realise(spectrum(self.spectrum), length, self.wavelengths, self.seed, self.scale)

    def spline(self, length: float) -> tuple[float, float, Array]:
        """The channels as cubic splines on an even grid, as a run reads them
        (rail_mj.vehicle.rails): (x0, the interval, m, and per interval, per channel in CHANNELS
        order, the coefficients c0..c3 of c0 + c1*t + c2*t^2 + c3*t^3, t the distance from the
        interval's start), (intervals, 16). A realisation is on an even grid already; a measured
        file is first splined at its own points and sampled at its median spacing."""
        from scipy.interpolate import CubicSpline

        x, channels = self.channels(length)
        values = np.column_stack([channels[c] for c in CHANNELS])
        steps = np.diff(x)
        step = float(np.median(steps))
        if not np.allclose(steps, step, rtol=1e-9, atol=0.0):
            count = math.floor((x[-1] - x[0]) / step + 1e-9)
            if count > MAX_SAMPLES:
                raise TrackError(f"irregularities: {count} samples at {step:g} m: more than {MAX_SAMPLES:g}")
            even = x[0] + step * np.arange(count + 1)
            values = CubicSpline(x, values, axis=0)(even)
            x = even
        # Coefficients highest power first, (4, intervals, channels): ours lowest first, by channel.
        c = CubicSpline(x, values, axis=0).c[::-1]
        return float(x[0]), step, np.ascontiguousarray(c.transpose(1, 2, 0)).reshape(len(x) - 1, 4 * len(CHANNELS))


def irregularities_from_dict(data, source: str, read: Callable[[str], str]) -> Irregularities:
    """[irregularities] checked: a spectrum (with optional wavelengths, seed, scale) or a measured
    file (`file`, read by `read` from a path relative to the track file)."""
    where = f"{source}: irregularities"
    if not isinstance(data, dict):
        raise TrackError(f"{where}: must be a table")
    for key in data:
        if key not in KEYS:
            raise TrackError(f"{where}.{key}: unknown key (one of {', '.join(KEYS)})")
    if ("spectrum" in data) == ("file" in data):
        raise TrackError(f"{where}: give a spectrum (generated) or a file (measured), one of them")
    if "file" in data:
        if set(data) - {"file"}:
            raise TrackError(f"{where}: a measured file takes no {', '.join(sorted(set(data) - {'file'}))}")
        name = data["file"]
        if not isinstance(name, str):
            raise TrackError(f"{where}.file: must be a path, got {name!r}")
        return Irregularities(file=name, measured=_measured(read(name), f"{source}: {name}"))
    name = data["spectrum"]
    if not isinstance(name, str):
        raise TrackError(f"{where}.spectrum: must be a name, one of {', '.join(map(repr, SPECTRA))}")
    spectrum(name)  # refused here if unknown
    try:
        band = check_band(data.get("wavelengths", DEFAULT_BAND))
    except TrackError as e:
        raise TrackError(f"{source}: {e}") from None
    seed = data.get("seed", 1)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise TrackError(f"{where}.seed: must be a whole number >= 0, got {seed!r}")
    scale = data.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not (math.isfinite(scale) and scale >= 0):
        raise TrackError(f"{where}.scale: must be a number >= 0, got {scale!r}")
    return Irregularities(name, band, seed, float(scale))


def _measured(text: str, where: str) -> tuple[tuple[float, ...], ...]:
    """A measured CSV's columns, m: the header exactly CSV_COLUMNS, x increasing, all finite."""
    lines = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    header = tuple(c.strip() for c in lines[0].split(",")) if lines else ()
    if header != CSV_COLUMNS:
        raise TrackError(f"{where}: the header must be {','.join(CSV_COLUMNS)}, got {','.join(header) or 'nothing'}")
    rows = []
    for k, line in enumerate(lines[1:], start=2):
        try:
            row = [float(v) for v in line.split(",")]
        except ValueError:
            raise TrackError(f"{where}: line {k}: not {len(CSV_COLUMNS)} numbers: {line.strip()[:60]!r}") from None
        if len(row) != len(CSV_COLUMNS) or not all(math.isfinite(v) for v in row):
            raise TrackError(f"{where}: line {k}: need {len(CSV_COLUMNS)} finite numbers, got {line.strip()[:60]!r}")
        rows.append(row)
    if len(rows) < 2:
        raise TrackError(f"{where}: need at least two rows of measurements")
    table = np.array(rows)
    if np.any(np.diff(table[:, 0]) <= 0):
        raise TrackError(f"{where}: x_m must increase from row to row")
    x = table[:, 0]
    return (tuple(x), *(tuple(table[:, i] * MM) for i in range(1, len(CSV_COLUMNS))))


def channels_csv(x: Array, channels: dict[str, Array]) -> bytes:
    """The channels as the measured CSV reads them (mm), a row a sample."""
    rows = [",".join(CSV_COLUMNS)]
    for k in range(len(x)):
        # + 0.0: a faded-in start is 0, not -0
        rows.append(",".join([f"{x[k] + 0.0:.10g}", *(f"{channels[c][k] / MM + 0.0:.10g}" for c in CHANNELS)]))
    return ("\n".join(rows) + "\n").encode()
