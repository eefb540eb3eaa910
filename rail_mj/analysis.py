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


# EN 14363's running-instability criterion (after Prud'homme): the rms of each wheelset's
# sum of guiding forces over a sliding 100 m of track, against (10 + 2*P0/3)/2 kN with
# P0 the static axle load in kN. EN 14363 band-pass filters Sigma Y around the hunting
# frequency first; on perfect straight track the model has no other content, so it is
# taken unfiltered here.
HUNTING_WINDOW = 100.0  # m


def hunting_limit(axle_load: float) -> float:
    """The rms limit of Sigma Y, N, for a static axle load in N."""
    return (10e3 + 2.0 * axle_load / 3.0) / 2.0


def sliding_rms(x: np.ndarray, signal: np.ndarray, window: float) -> np.ndarray:
    """rms of `signal` (samples along axis 0) over the `window` (m) of x ending at each
    sample; nan until one full window has passed."""
    signal = np.asarray(signal, dtype=float)
    cumulative = np.concatenate([np.zeros((1,) + signal.shape[1:]), np.cumsum(signal**2, axis=0)])
    start = np.searchsorted(x, x - window, side="left")
    count = (np.arange(1, len(x) + 1) - start).reshape((-1,) + (1,) * (signal.ndim - 1))
    rms = np.sqrt(np.maximum(cumulative[1:] - cumulative[start], 0.0) / count)
    full = (x - x[0] >= window).reshape(count.shape)
    return np.where(full, rms, np.nan)


def hunting(run: Run) -> dict | None:
    """The instability criterion per wheelset; None without a wheel load or a full window."""
    load = run.layout.wheelset.wheel_load
    if load is None or run.x[-1] < HUNTING_WINDOW:
        return None
    rms = sliding_rms(run.x, run.guiding_forces(), HUNTING_WINDOW)
    worst = np.nanmax(rms, axis=0)
    limit = hunting_limit(2.0 * load)
    return {
        "criterion": "EN 14363 rms of the sum of guiding forces over 100 m, unfiltered",
        "limit_n": limit,
        "max_rms_n": [float(v) for v in worst],
        "hunting": bool(np.any(worst > limit)),
    }


def late_motion(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """Times and lateral displacement of the wheelset that moves most over the second half
    of a run, when the least-damped mode (or a limit cycle) has outlived the rest."""
    late = run.t >= run.t[-1] / 2
    i = int(np.argmax(np.max(np.abs(run.y[late]), axis=0)))
    return run.t[late], run.y[late, i]


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
        "hunting": hunting(run),
    }
