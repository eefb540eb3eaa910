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
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from rail_mj.analysis.en14363 import curving_part, hunting, hunting_assessable, wheel_safety

if TYPE_CHECKING:
    from rail_mj.simulation.run import Run

# scipy.signal takes most of a second to import: it is imported where it is used.


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
    from scipy.signal import find_peaks

    up = _crossings(t, s)
    freq = (len(up) - 1) / (up[-1] - up[0]) if len(up) >= 2 else math.nan
    peaks = np.concatenate([find_peaks(s)[0], find_peaks(-s)[0]])
    peaks = peaks[np.abs(s[peaks]) > 0]
    if len(peaks) >= 3 and len(up) >= 2:
        sigma = float(np.polyfit(t[peaks], np.log(np.abs(s[peaks])), 1)[0])
    else:
        sigma = math.nan
    return float(freq), sigma


class Strike(NamedTuple):
    """One flange contact of one wheelset: samples start to end - 1, on the left (+1) or
    right (-1) rail."""

    wheelset: int  # 0 leads
    start: int
    end: int
    side: int


def flange_strikes(run: Run) -> list[Strike]:
    """Every flange contact of every wheelset (|y| past the flangeway clearance), in the
    order of the wheelsets and then of time; a contact still on at the end ends there."""
    side = np.sign(run.y) * (np.abs(run.y) > run.layout.wheelset.flangeway_clearance)
    padded = np.vstack([np.zeros((1, run.n_wheelsets)), side, np.zeros((1, run.n_wheelsets))])
    strikes = []
    for i in range(run.n_wheelsets):
        changes = np.nonzero(np.diff(padded[:, i]))[0]  # index k: sample k is the first that differs
        strikes += [
            Strike(i, int(a), int(b), int(side[a, i])) for a, b in zip(changes[:-1], changes[1:]) if side[a, i] != 0
        ]
    return strikes


def late_motion(run: Run) -> tuple[np.ndarray, np.ndarray]:
    """Times and lateral displacement of the wheelset that moves most over the second half
    of a run, when the least-damped mode (or a limit cycle) has outlived the rest."""
    late = run.t >= run.t[-1] / 2
    i = int(np.argmax(np.max(np.abs(run.y[late]), axis=0)))
    return run.t[late], run.y[late, i]


# A wheelset whose |y| stays below this fraction of its largest value to the end of the
# run has decayed: what is left is the slow drift of the bodies above it, not its motion.
DECAYED_FRACTION = 0.05


def decayed_at(t: np.ndarray, y: np.ndarray) -> float | None:
    """The time from which |y| stays below DECAYED_FRACTION of its largest value to the
    end, if that covers at least the last quarter of the run; None when it has not decayed."""
    magnitude = np.abs(y)
    above = np.nonzero(magnitude > DECAYED_FRACTION * np.max(magnitude))[0]
    if len(above) == 0:
        return float(t[0])
    end = above[-1] + 1
    if end >= len(t) or t[end] > t[0] + 0.75 * (t[-1] - t[0]):
        return None
    return float(t[end])


def summary(run: Run) -> dict:
    """Per wheelset: largest |y| and yaw, whether (and by when) the motion decayed, and
    the growth rate, dominant frequency and wavelength of the motion that matters: of the
    whole run, or, for a motion that decayed, of the motion while it lasted (not of the
    leftover drift of the bodies above, a thousandth of it)."""
    wheelsets = []
    # On a curve the motion that grows, decays and has a frequency is about the curving offsets.
    about = run.y - curving_part(run, run.y)
    for i in range(run.n_wheelsets):
        y = about[:, i]
        decayed = decayed_at(run.t, y)
        window = run.t <= (run.t[-1] if decayed is None else decayed)
        freq, sigma = oscillation(run.t[window], y[window])
        wheelsets.append(
            {
                "wheelset": i + 1,
                "max_abs_lateral_m": float(np.max(np.abs(run.y[:, i]))),
                "max_abs_yaw_rad": float(np.max(np.abs(run.psi[:, i]))),
                "final_abs_lateral_m": float(np.max(np.abs(run.y[run.t >= 0.9 * run.t[-1], i]))),
                "decayed": decayed is not None,
                "decayed_by_s": decayed,
                "decayed_by_m": None if decayed is None else _distance_at(run, decayed),
                "growth_rate_per_s": None if math.isnan(sigma) else sigma,
                "frequency_hz": None if math.isnan(freq) else freq,
                "wavelength_m": None if math.isnan(freq) else _mean_speed(run, window) / freq,
            }
        )
    if run.track is not None:  # how large the motion about the curving offsets is
        for w, column in zip(wheelsets, about.T, strict=True):
            w["max_abs_lateral_about_curving_m"] = float(np.max(np.abs(column)))
    if run.profile is not None:  # on a speed profile, the speed the motion died at: the ramp's reading
        for w in wheelsets:
            at = w["decayed_by_s"]
            w["decayed_at_speed_m_per_s"] = None if at is None else float(np.interp(at, run.t, run.speeds))
    safety = wheel_safety(run)
    for w, per in zip(wheelsets, safety["wheelsets"]):
        w.update(per)
    return {
        "layout": run.layout.name,
        "speed_m_per_s": run.speed,
        "distance_m": float(run.x[-1]),
        "duration_s": float(run.t[-1]),
        "timestep_s": run.timestep,
        "wheelsets": wheelsets,
        "hunting": hunting(run),
        "hunting_note": hunting_assessable(run),
        **safety["run"],
        **_on_track(run),
        **_on_profile(run),
    }


def _distance_at(run: Run, t: float) -> float:
    """The distance travelled by time `t`: V*t at constant speed, else the odometer's."""
    return t * run.speed if run.profile is None else float(np.interp(t, run.t, run.x))


def _mean_speed(run: Run, window: np.ndarray) -> float:
    """The speed, or on a speed profile its mean over the samples `window` (distance over time),
    which with the motion's frequency gives its wavelength."""
    if run.profile is None:
        return run.speed
    t, x = run.t[window], run.x[window]
    return float((x[-1] - x[0]) / (t[-1] - t[0])) if len(t) > 1 else float(run.speeds[window][0])


def _on_profile(run: Run) -> dict:
    """A run on a speed profile's: the profile's points and the speed at its start and end."""
    profile = run.profile
    if profile is None:
        return {}
    return {
        "speed_profile": {
            "stations_m": list(profile.stations),
            "speeds_m_per_s": list(profile.speeds),
            "start_m_per_s": float(run.speeds[0]),
            "end_m_per_s": float(run.speeds[-1]),
        }
    }


def _on_track(run: Run) -> dict:
    """A run on a curved track's: the track file and, per curve, its steady values
    (rail_mj.analysis.curving); nothing on straight track, whose summary stays as it was."""
    if run.track is None:
        return {}
    from rail_mj.analysis.curving import curves

    return {"track": run.track.source, "curves": curves(run)}
