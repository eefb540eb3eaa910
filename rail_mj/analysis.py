"""What a run shows: per wheelset, amplitude, growth rate, frequency and wavelength.

Example:

    >>> import numpy as np
    >>> t = np.linspace(0.0, 10.0, 10001)
    >>> f, sigma = oscillation(t, 0.003 * np.exp(0.1 * t) * np.cos(2 * np.pi * 1.5 * t))
    >>> round(f, 4), round(sigma, 3)
    (1.5, 0.1)
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import find_peaks

from rail_mj.runner import Run


def _crossings(t: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Times of upward zero crossings, linearly interpolated between samples."""
    i = np.nonzero((s[:-1] < 0) & (s[1:] >= 0))[0]
    return t[i] - s[i] * (t[i + 1] - t[i]) / (s[i + 1] - s[i])


def oscillation(t: np.ndarray, s: np.ndarray) -> tuple[float, float]:
    """Dominant frequency (Hz) and growth rate (1/s) of a signal oscillating about zero.

    Frequency: whole periods between the first and last upward zero crossings, which
    is exact for a damped or growing sinusoid (its zeros are evenly spaced). Growth
    rate: slope of log|peak| against time over every positive and negative peak.
    NaN where the signal completes less than one cycle.
    """
    up = _crossings(t, s)
    freq = (len(up) - 1) / (up[-1] - up[0]) if len(up) >= 2 else math.nan
    peaks = np.concatenate([find_peaks(s)[0], find_peaks(-s)[0]])
    peaks = peaks[np.abs(s[peaks]) > 0]
    if len(peaks) >= 3 and len(up) >= 2:
        sigma = float(np.polyfit(t[peaks], np.log(np.abs(s[peaks])), 1)[0])
    else:
        sigma = math.nan
    return float(freq), sigma


def summary(run: Run) -> dict:
    """Per wheelset: largest |y|, growth rate, dominant frequency and wavelength."""
    wheelsets = []
    for i in range(run.n_wheelsets):
        freq, sigma = oscillation(run.t, run.y[:, i])
        wheelsets.append({
            "wheelset": i + 1,
            "max_abs_lateral_m": float(np.max(np.abs(run.y[:, i]))),
            "max_abs_yaw_rad": float(np.max(np.abs(run.psi[:, i]))),
            "growth_rate_per_s": None if math.isnan(sigma) else sigma,
            "frequency_hz": None if math.isnan(freq) else freq,
            "wavelength_m": None if math.isnan(freq) else run.speed / freq,
        })
    return {
        "layout": run.layout.name,
        "speed_m_per_s": run.speed,
        "distance_m": float(run.x[-1]),
        "duration_s": float(run.t[-1]),
        "timestep_s": run.timestep,
        "wheelsets": wheelsets,
    }
