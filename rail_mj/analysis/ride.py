"""Ride comfort of a run: the car body's floor accelerations, EN 12299's frequency weightings, the
standard mean comfort N_MV and the continuous comfort, and Sperling's ride index Wz (docs/ride.md).

The floor accelerations are the run's (`Run.floor_accelerations`): above each bogie's centre and at
the car body's centre, at the layout's [spatial] floor_height (else at the car body's centre of
mass), as an accelerometer fixed to the floor reads them, laterally with the part of gravity the
body's roll tilts into its floor.

Each weighting is EN 12299's H = H_h*H_l*H_t*H_s (high pass, low pass, acceleration-velocity
transition, upward step) with Q1 = 1/sqrt(2):

    H_h = s^2/(s^2 + w1*s/Q1 + w1^2)        H_l = w2^2/(s^2 + w2*s/Q1 + w2^2)
    H_t = (1 + s/w3)/(1 + s/(Q4*w4) + s^2/w4^2)
    H_s = K*(1 + s/(Q5*w5) + s^2/w5^2)/(1 + s/(Q6*w6) + s^2/w6^2)

applied once, causally: the analog filter is taken to discrete time by the bilinear transform and
run forwards only (filtering forwards and backwards would apply |H|^2, not H). N_MV =
6*sqrt(a_XP95^2 + a_YP95^2 + a_ZP95^2), each a_P95 the 95th percentile of the 5 s rms values of the
weighted accelerations (lateral and longitudinal Wd, vertical Wb); the runs have no longitudinal
motion, so a_X = 0. The continuous comfort is the 5 s rms itself, N_CY = 6*a_Y and N_CZ = 6*a_Z.
Sperling's Wz = 4.42*a_w^0.3, a_w the rms (m/s^2) of the acceleration weighted in the frequency domain
by B_z(f) vertically and B_y = 1.25*B_z laterally.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rail_mj.simulation.run import Run

COMFORT_WINDOW = 5.0  # s: EN 12299's rms interval
PERCENTILE = 95.0  # EN 12299's N_MV takes the 95th percentile of the 5 s rms values
MEAN_COMFORT_SCALE = 6.0  # N_MV = 6*sqrt(...), N_C = 6*a
Q1 = 1.0 / math.sqrt(2.0)


@dataclasses.dataclass(frozen=True)
class Weighting:
    """An EN 12299 frequency weighting: corner frequencies (Hz) and quality factors; f5 = 0: no
    upward step H_s."""

    name: str
    f1: float
    f2: float
    f3: float
    f4: float
    q4: float
    f5: float = 0.0
    q5: float = 0.0
    f6: float = 0.0
    q6: float = 0.0
    k: float = 1.0

    def analog(self) -> tuple[np.ndarray, np.ndarray]:
        """(numerator, denominator) of H(s), highest power first."""
        w1, w2, w3, w4 = (2 * math.pi * f for f in (self.f1, self.f2, self.f3, self.f4))
        num = np.polymul([1.0, 0.0, 0.0], [w2**2])
        den = np.polymul([1.0, w1 / Q1, w1**2], [1.0, w2 / Q1, w2**2])
        num = np.polymul(num, [1.0 / w3, 1.0])
        den = np.polymul(den, [1.0 / w4**2, 1.0 / (self.q4 * w4), 1.0])
        if self.f5:
            w5, w6 = 2 * math.pi * self.f5, 2 * math.pi * self.f6
            num = np.polymul(num, np.multiply(self.k, [1.0 / w5**2, 1.0 / (self.q5 * w5), 1.0]))
            den = np.polymul(den, [1.0 / w6**2, 1.0 / (self.q6 * w6), 1.0])
        return num, den

    def gain(self, f) -> np.ndarray:
        """|H(i*2*pi*f)| of the analog weighting at frequencies f (Hz)."""
        num, den = self.analog()
        s = 2j * math.pi * np.asarray(f, dtype=float)
        return np.abs(np.polyval(num, s) / np.polyval(den, s))

    def apply(self, signal: np.ndarray, fs: float) -> np.ndarray:
        """The weighted signal (samples along axis 0, sampled at fs Hz): the bilinear transform of
        H run forwards once."""
        from scipy.signal import bilinear_zpk, sosfilt, tf2zpk, zpk2sos

        z, p, k = tf2zpk(*self.analog())
        sos = zpk2sos(*bilinear_zpk(z, p, k, fs))
        return sosfilt(sos, signal, axis=0)


# EN 12299 (2009), Table A.1: Wb vertical, Wd horizontal, Wc seat back (longitudinal).
WB = Weighting("Wb", 0.4, 100.0, 16.0, 16.0, 0.63, 2.5, 0.8, 4.0, 0.8, 0.4)
WD = Weighting("Wd", 0.4, 100.0, 2.0, 2.0, 0.63)
WC = Weighting("Wc", 0.4, 100.0, 8.0, 8.0, 0.63)


def sperling_gain(f, lateral: bool) -> np.ndarray:
    """Sperling's weighting B(f) (f in Hz): B_z vertically, B_y = 1.25*B_z laterally."""
    f = np.asarray(f, dtype=float)
    b = 0.588 * np.sqrt(
        (1.911 * f**2 + (0.25 * f**2) ** 2) / ((1 - 0.2777 * f**2) ** 2 + (1.563 * f - 0.0368 * f**3) ** 2)
    )
    return 1.25 * b if lateral else b


def sperling(signal: np.ndarray, fs: float, lateral: bool) -> float:
    """Sperling's Wz of an acceleration (m/s^2, sampled at fs Hz): 4.42*a_w^0.3, a_w its rms weighted by
    B(f) through its spectrum (Parseval: the mean of the weighted signal's square), its mean left out."""
    x = np.asarray(signal, dtype=float) - np.mean(signal)
    spectrum = np.fft.rfft(x)
    f = np.fft.rfftfreq(len(x), 1.0 / fs)
    weighted = np.fft.irfft(spectrum * sperling_gain(f, lateral), n=len(x))
    return float(4.42 * np.sqrt(np.mean(weighted**2)) ** 0.3)


def windowed_rms(signal: np.ndarray, fs: float, window: float = COMFORT_WINDOW) -> np.ndarray:
    """The rms of each whole `window` (s) of the signal, consecutive: EN 12299's 5 s values."""
    n = round(window * fs)
    blocks = len(signal) // n
    if blocks == 0:
        return np.zeros(0)
    return np.sqrt(np.mean(np.asarray(signal[: blocks * n], float).reshape(blocks, n) ** 2, axis=1))


def mean_comfort(lateral: np.ndarray, vertical: np.ndarray | None, fs: float) -> float | None:
    """EN 12299's N_MV of floor accelerations (m/s^2), lateral weighted Wd and vertical Wb (None:
    none), from the 95th percentiles of their 5 s rms values; None if shorter than one window."""
    y = windowed_rms(WD.apply(lateral, fs), fs)
    if not len(y):
        return None
    total = np.percentile(y, PERCENTILE) ** 2
    if vertical is not None:
        total += np.percentile(windowed_rms(WB.apply(vertical, fs), fs), PERCENTILE) ** 2
    return float(MEAN_COMFORT_SCALE * math.sqrt(total))


def continuous_comfort(signal: np.ndarray, fs: float, weighting: Weighting) -> np.ndarray:
    """EN 12299's continuous comfort N_C = 6*a, a the rms of the weighted signal over the 5 s up to each
    sample; NaN until 5 s have passed."""
    from rail_mj.analysis.en14363 import sliding_rms

    t = np.arange(len(signal)) / fs
    return MEAN_COMFORT_SCALE * sliding_rms(t, weighting.apply(signal, fs), COMFORT_WINDOW - 0.5 / fs)


def ride(run: Run) -> dict | None:
    """N_MV, Sperling's Wz lateral and vertical and the largest continuous comfort at each floor
    point, with the rms of the floor accelerations (0.4-10 Hz is EN 14363's band: here unfiltered, the
    runs having nothing above the vehicle's own modes); None where the car body does not move."""
    floor = run.floor_accelerations()
    if floor is None:
        return None
    points = []
    for i, name in enumerate(floor.names):
        lateral = floor.lateral[:, i]
        vertical = None if floor.vertical is None else floor.vertical[:, i]
        entry = {
            "point": name,
            "n_mv": mean_comfort(lateral, vertical, floor.fs),
            "wz_lateral": sperling(lateral, floor.fs, True),
            "wz_vertical": None if vertical is None else sperling(vertical, floor.fs, False),
            "rms_lateral_m_per_s2": float(np.sqrt(np.mean(lateral**2))),
            "rms_vertical_m_per_s2": None if vertical is None else float(np.sqrt(np.mean(vertical**2))),
            "max_continuous_comfort_lateral": _finite_max(continuous_comfort(lateral, floor.fs, WD)),
            "max_continuous_comfort_vertical": None
            if vertical is None
            else _finite_max(continuous_comfort(vertical, floor.fs, WB)),
        }
        points.append(entry)
    return {"floor_height_m": _floor_height(run), "points": points}


def _finite_max(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(finite.max()) if finite.size else None


def _floor_height(run: Run) -> float | None:
    spatial = run.layout.spatial
    if spatial is None:
        return None
    return spatial.carbody_height if spatial.floor_height is None else spatial.floor_height
