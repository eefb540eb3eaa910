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
from rail_mj.layout.kinds import contact_model

if TYPE_CHECKING:
    from rail_mj.simulation.run import Run


def local_maxima(s: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of s, as scipy.signal.find_peaks(s) without conditions
    gives them: a sample higher than its left neighbour and not lower than the right, a flat
    top counted once at its middle (the left one of two), none at either end.

    Written here because it is all a run's summary needs of scipy.signal, whose import costs
    half a second of every `rail-mj run` (issue 19: a warm 100 m run under 1 s).
    """
    d = np.diff(s)
    moves = np.flatnonzero(d != 0)  # moves[k]: s rises or falls from sample moves[k] to the next
    rises = d[moves] > 0
    top = np.flatnonzero(rises[:-1] & ~rises[1:])  # a rise, a flat top (or none), then a fall
    return (moves[top] + 1 + moves[top + 1]) // 2


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
    peaks = np.concatenate([local_maxima(s), local_maxima(-s)])
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


# A motion whose peaks over the second half of the run change by less than this fraction
# neither grows nor decays to the eye: a limit cycle's.
SUSTAINED_FRACTION = 0.05
# A body coordinate that never moves more than this (m, or rad) is at rest: what it shows is
# round-off (a symmetric start leaves a coach's car body unyawed to 1e-18 rad), not a motion.
AT_REST = 1e-9
# Of a body's lateral and yaw motion, one smaller than this fraction of the other (lateral metres
# both) leaves the body's verdict to the other: a coach's car body, driven by its hunting bogies,
# yaws by microradians, whose beating is no motion of its own.
SIGNIFICANT = 0.1
# What a body's motion is doing, from best to worst; a body's verdict is its worst coordinate's.
MOTIONS = ("at rest", "decayed", "decaying", "not oscillating", "sustained", "growing")


def late_verdict(late_sigma: float, duration: float) -> str:
    """A motion that has not decayed, from its growth rate over the late `duration` (s): how
    much its peaks change over it."""
    change = math.exp(late_sigma * duration) if not math.isnan(late_sigma) else math.nan
    if math.isnan(change):
        return "not oscillating"
    if abs(change - 1.0) < SUSTAINED_FRACTION:
        return "sustained"
    return "growing" if change > 1.0 else "decaying"


def _motion(run: Run, about: np.ndarray, late: np.ndarray) -> dict:
    """One coordinate's motion about its curving offsets: whether (and by when, and where) it
    decayed; the growth rate, frequency and wavelength of the whole run or, for a motion that
    decayed, of the motion while it lasted; and its verdict (`MOTIONS`), whose growing,
    sustained or decaying is read from the peaks of the second half of the run, where a motion
    that has reached its limit cycle has stopped growing (`late`: those samples, `_late`)."""
    at_rest = np.max(np.abs(about)) <= AT_REST
    decayed = float(run.t[0]) if at_rest else decayed_at(run.t, about)
    window = run.t <= (run.t[-1] if decayed is None else decayed)
    freq, sigma = oscillation(run.t[window], about[window])
    if at_rest:
        verdict = "at rest"
    elif decayed is not None:
        verdict = "decayed"
    else:
        late_sigma = oscillation(run.t[late], about[late])[1] if np.count_nonzero(late) > 2 else math.nan
        verdict = late_verdict(late_sigma, float(run.t[-1] - run.t[late][0]))
    return {
        "decayed": decayed is not None,
        "decayed_by_s": decayed,
        "decayed_by_m": None if decayed is None else _distance_at(run, decayed),
        "growth_rate_per_s": None if math.isnan(sigma) else sigma,
        "frequency_hz": None if math.isnan(freq) else freq,
        "wavelength_m": None if math.isnan(freq) else _mean_speed(run, window) / freq,
        "motion": verdict,
    }


def _late(run: Run) -> np.ndarray:
    """The samples a motion's verdict is read from: the second half of the run, or on a track
    the second half of the stretch over which the whole vehicle is on the section it ends on:
    where the geometry under it still changes, the motion about the curving offsets holds the
    transients of entering and leaving curves, which are no growth."""
    start = 0.0
    if run.track is not None:
        last = run.track.section_at(float(run.wheelset_station[-1].max()))
        on = np.all(run.wheelset_station >= last.start, axis=1)
        start = float(run.t[np.argmax(on)]) if on.any() else float(run.t[-1])
    return run.t >= (start + run.t[-1]) / 2


def _frames(run: Run, late: np.ndarray) -> list[dict]:
    """Each bogie frame's and car body's largest lateral displacement and yaw and its motion: of
    the worse of its lateral and yaw motions (lateral on a tie) among those that matter, so that a
    car body yawing on its own reads as moving; a spatial body's largest roll too. A coordinate
    matters when, over the second half of the run, it moves at least SIGNIFICANT of the other:
    the yaw as the lateral motion it gives at the nearest wheelset (its lever, m)."""
    names = run.frame_names
    if not names:
        return []
    stations = run.frame_station
    coordinates = {"lateral": run.frame_y, "yaw": run.frame_psi}
    about = {c: v - curving_part(run, v, stations) for c, v in coordinates.items()}
    offsets = stations[0] - run.station[0]
    lever = np.min(np.abs(offsets[:, None] - np.asarray(run.layout.wheelset_x)[None, :]), axis=1)
    reach = {
        "lateral": np.max(np.abs(about["lateral"][late]), axis=0),
        "yaw": lever * np.max(np.abs(about["yaw"][late]), axis=0),
    }
    roll = run.frame_roll if run.layout.spatial is not None else None
    frames = []
    for k, name in enumerate(names):
        largest = max(r[k] for r in reach.values())
        motions = {c: _motion(run, about[c][:, k], late) for c in coordinates if reach[c][k] >= SIGNIFICANT * largest}
        worst = max(motions, key=lambda c: MOTIONS.index(motions[c]["motion"]))
        lateral, yaw = coordinates["lateral"][:, k], coordinates["yaw"][:, k]
        frame = {
            "body": name,
            "max_abs_lateral_m": float(np.max(np.abs(lateral))),
            "max_abs_yaw_rad": float(np.max(np.abs(yaw))),
            "final_abs_lateral_m": float(np.max(np.abs(lateral[run.t >= 0.9 * run.t[-1]]))),
        }
        if roll is not None:
            frame["max_abs_roll_rad"] = float(np.max(np.abs(roll[:, k])))
        frame.update(motions[worst])
        frame["coordinate"] = worst
        if run.track is not None:
            frame["max_abs_lateral_about_curving_m"] = float(np.max(np.abs(about["lateral"][:, k])))
        frames.append(frame)
    return frames


def flange_contact(run: Run) -> dict | None:
    """The run's flange contact: how many strikes (`flange_strikes`), per wheelset too; the
    first (wheelset, rail, time and distance); and the largest lateral force of a flange on its
    rail while in contact, where. None where the layout models no flange (cones without [flange])."""
    if not contact_model(run.layout).flanged:
        return None
    strikes = flange_strikes(run)
    per = [sum(s.wheelset == i for s in strikes) for i in range(run.n_wheelsets)]
    result: dict = {"strikes": len(strikes), "strikes_per_wheelset": per, "first_strike": None}
    result.update(largest_flange_force_n=None, largest_flange_force_at=None)
    if not strikes:
        return result

    def where(wheelset: int, side: int, k: int) -> dict:
        rail = "left" if side > 0 else "right"
        return {"wheelset": wheelset + 1, "rail": rail, "t_s": float(run.t[k]), "x_m": float(run.x[k])}

    first = min(strikes, key=lambda s: (s.start, s.wheelset))
    result["first_strike"] = where(first.wheelset, first.side, first.start)
    force = np.abs(run.contact_forces().flange_lateral)
    # On profiles the flange entry also carries the tread's gravitational stiffness: only the
    # samples in contact count.
    best = max(strikes, key=lambda s: float(np.max(force[s.start : s.end, s.wheelset])))
    k = best.start + int(np.argmax(force[best.start : best.end, best.wheelset]))
    result["largest_flange_force_n"] = float(force[k, best.wheelset])
    result["largest_flange_force_at"] = where(best.wheelset, best.side, k)
    return result


def summary(run: Run) -> dict:
    """Per wheelset: largest |y| and yaw, whether (and by when) the motion decayed, and
    the growth rate, dominant frequency and wavelength of the motion that matters: of the
    whole run, or, for a motion that decayed, of the motion while it lasted (not of the
    leftover drift of the bodies above, a thousandth of it). The same of each bogie frame and
    car body (`frames`), the bodies whose motion grows or is sustained, and the flange contact."""
    wheelsets = []
    # On a curve the motion that grows, decays and has a frequency is about the curving offsets.
    about = run.y - curving_part(run, run.y)
    late = _late(run)
    for i in range(run.n_wheelsets):
        wheelsets.append(
            {
                "wheelset": i + 1,
                "max_abs_lateral_m": float(np.max(np.abs(run.y[:, i]))),
                "max_abs_yaw_rad": float(np.max(np.abs(run.psi[:, i]))),
                "final_abs_lateral_m": float(np.max(np.abs(run.y[run.t >= 0.9 * run.t[-1], i]))),
                **_motion(run, about[:, i], late),
            }
        )
    if run.track is not None:  # how large the motion about the curving offsets is
        for w, column in zip(wheelsets, about.T, strict=True):
            w["max_abs_lateral_about_curving_m"] = float(np.max(np.abs(column)))
    frames = _frames(run, late)
    if run.profile is not None:  # on a speed profile, the speed the motion died at: the ramp's reading
        for w in wheelsets + frames:
            at = w["decayed_by_s"]
            w["decayed_at_speed_m_per_s"] = None if at is None else float(np.interp(at, run.t, run.speeds))
    safety = wheel_safety(run)
    for w, per in zip(wheelsets, safety["wheelsets"]):
        w.update(per)
    bodies = [(f"wheelset{w['wheelset']}", w) for w in wheelsets] + [(f["body"], f) for f in frames]
    return {
        "layout": run.layout.name,
        "speed_m_per_s": run.speed,
        "distance_m": float(run.x[-1]),
        "duration_s": float(run.t[-1]),
        "timestep_s": run.timestep,
        # Seconds between the samples the run kept (and the summary read): every step or
        # millisecond, unless the run was asked to keep fewer (Request.sample_interval, --sample-rate).
        "sample_interval_s": float(run.t[1] - run.t[0]) if len(run.t) > 1 else None,
        "wheelsets": wheelsets,
        "frames": frames,
        "decayed": all(b["decayed"] for _, b in bodies),
        "growing": [name for name, b in bodies if b["motion"] == "growing"],
        "sustained": [name for name, b in bodies if b["motion"] == "sustained"],
        "flange_contact": flange_contact(run),
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

    out: dict[str, object] = {"track": run.track.source, "curves": curves(run)}
    if run.track.irregularities is not None:  # ride comfort and the on-track statistics (docs/ride.md)
        from rail_mj.analysis.en14363 import on_track
        from rail_mj.analysis.ride import ride

        out["ride"] = ride(run)
        out["sections"] = on_track(run)
    return out
