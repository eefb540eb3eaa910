"""EN 14363's quantities of a run: the running-instability criterion on the sum of guiding
forces Sigma Y, the derailment quotient Y/Q of each wheel, and the wheels' safety (the largest
Y/Q, the smallest wheel load Q). The forces are the run's, per sample (`Run.contact_forces`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING

import numpy as np

from rail_mj.analysis.filters import butterworth_sos, periodogram, sosfiltfilt

if TYPE_CHECKING:
    from rail_mj.simulation.run import Run

# EN 14363's limit on the derailment quotient Y/Q of a wheel, for curve radii of 250 m and more
# (tangent track included); the quotient itself is the one Nadal's formula bounds.
Y_OVER_Q_LIMIT = 0.8
Y_OVER_Q_WINDOW = 2.0  # m: EN 14363 assesses Y/Q as its sliding mean over 2 m of track

# EN 14363's running-instability criterion (after Prud'homme): the rms of each wheelset's
# sum of guiding forces, band-pass filtered around the instability frequency f0 (f0 +/- 2 Hz),
# over a sliding 100 m of track, against half Prud'homme's track-shift limit,
# (10 + 2*Q0/3)/2 kN = (10 + P0/3)/2 kN with Q0 the static wheel load and P0 = 2*Q0 the
# static axle load, in kN (alpha = 1: passenger vehicles and locomotives). The filter keeps
# the hunting and drops its flange-contact harmonics (and, on real track, the
# irregularities' broad band).
HUNTING_WINDOW = 100.0  # m
HUNTING_BAND = 2.0  # Hz either side of f0
FILTER_ORDER = 4  # Butterworth, run forwards and backwards (no phase shift)


def window_starts(x: np.ndarray, window: float) -> np.ndarray:
    """For each sample, the first sample within `window` (m) of x behind it (x increasing)."""
    return np.searchsorted(x, x - window, side="left")


def hunting_limit(axle_load: float) -> float:
    """The rms limit of Sigma Y, N, for a static axle load in N: (10 kN + P0/3)/2."""
    return (10e3 + axle_load / 3.0) / 2.0


def sliding_rms(x: np.ndarray, signal: np.ndarray, window: float, start: np.ndarray | None = None) -> np.ndarray:
    """rms of `signal` (samples along axis 0) over the `window` (m) of x ending at each
    sample; nan until one full window has passed. `start`: `window_starts(x, window)`, if
    already found (a run's wheelsets share it)."""
    signal = np.asarray(signal, dtype=float)
    # In place where it can be: a long run's column is millions of samples, and a sweep's runs
    # finish while others step on.
    cumulative = np.empty((len(signal) + 1,) + signal.shape[1:])
    cumulative[0] = 0.0
    np.cumsum(np.square(signal), axis=0, out=cumulative[1:])
    if start is None:
        start = window_starts(x, window)
    rms = cumulative[1:] - cumulative[start]
    del cumulative
    count = np.arange(1, len(x) + 1)
    count -= start
    np.maximum(rms, 0.0, out=rms)
    np.divide(rms, count.reshape((-1,) + (1,) * (signal.ndim - 1)), out=rms)
    np.sqrt(rms, out=rms)
    rms[x - x[0] < window] = np.nan
    return rms


def dominant_frequency(t: np.ndarray, signal: np.ndarray) -> float:
    """The frequency (Hz) of the highest peak of the signals' summed periodogram (samples
    along axis 0, evenly spaced), leaving out the mean: the instability frequency f0."""
    columns = np.asarray(signal, dtype=float).reshape(len(signal), -1)
    if columns.shape[1] == 0:
        raise ValueError("no signal to take the periodogram of")
    return _dominant(t, (columns[:, c] for c in range(columns.shape[1])))


# Up to this many samples of all columns together, their spectra are taken in one FFT call: the
# same numbers (pocketfft transforms each column alike), a plan made once instead of a column's
# each (a third of the time for a run's four wheelsets). Past it, one column at a time: for a
# length with a large prime factor (Bluestein's algorithm) the FFT needs about 16 times its
# input, and of several columns at once that many times more.
_TOGETHER = 1 << 18


def _dominant(t: np.ndarray, columns: Iterator[np.ndarray]) -> float:
    """`dominant_frequency` of the columns, given one at a time (their spectra summed in column
    order)."""
    fs = 1.0 / (t[1] - t[0])
    first = np.asarray(next(columns), dtype=float)
    if len(first) * 4 > _TOGETHER:  # a long run: a column's spectrum at a time
        freq, total = periodogram(first, fs=fs)
        for column in columns:
            total = total + periodogram(column, fs=fs)[1]
        return float(freq[1:][np.argmax(total[1:])])
    # Each column less its own mean (a contiguous column's, as periodogram takes it), then one FFT.
    rows = np.stack([c - c.mean() for c in (first, *(np.asarray(c, dtype=float) for c in columns))])
    freq, power = periodogram(rows.T, fs=fs, centred=True)
    total = power[:, 0]
    for c in range(1, power.shape[1]):
        total = total + power[:, c]
    return float(freq[1:][np.argmax(total[1:])])


def band_pass(t: np.ndarray, signal: np.ndarray, f0: float) -> np.ndarray:
    """EN 14363's filter: f0 +/- 2 Hz (a low-pass at f0 + 2 Hz where f0 <= 2 Hz, for slow
    car-body instabilities), Butterworth, without phase shift. Samples along axis 0."""
    fs = 1.0 / (t[1] - t[0])
    high = min(f0 + HUNTING_BAND, 0.45 * fs)
    # An f0 past the filter's top (only for samples far sparser than a run's) keeps the
    # low-pass: the band cannot be resolved there.
    if f0 > HUNTING_BAND and f0 - HUNTING_BAND < high:
        sos = butterworth_sos(FILTER_ORDER, (f0 - HUNTING_BAND, high), fs)
    else:
        sos = butterworth_sos(FILTER_ORDER, high, fs)
    return sosfiltfilt(sos, signal)


def curving_part(run: Run, signal: np.ndarray, stations: np.ndarray | None = None) -> np.ndarray:
    """The part of `signal` (samples along axis 0, one column a wheelset) that follows the curve:
    its least-squares fit, column by column, to the track's curvature and uncompensated
    acceleration under that wheelset, which is what a linear vehicle's quasi-static response to
    a slowly varying curve is made of (the steady state scales with both). No constant: where the
    track is straight there is nothing quasi-static. Zero on straight track. `stations`: the
    distance along the track of each column's body, shaped like `signal` (None: the wheelsets')."""
    if run.track is None or not np.any(run.wheelset_curvature):
        return np.zeros_like(signal)
    if stations is None:
        stations = run.wheelset_station
    curvature = run.track.curvature(stations)
    acceleration = run.track.uncompensated_acceleration(stations, run.speeds[:, None])
    flat = signal.reshape(len(signal), -1)
    fitted = np.empty_like(flat)
    for i in range(flat.shape[1]):
        basis = np.column_stack([curvature[:, i], acceleration[:, i]])
        coefficients = np.linalg.lstsq(basis, flat[:, i], rcond=None)[0]
        fitted[:, i] = basis @ coefficients
    return fitted.reshape(signal.shape)


def hunting_rms(run: Run, guiding: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """EN 14363's f0 (Hz) and the band-passed sliding rms of each wheelset's Sigma Y (N,
    shape (n_samples, n_wheelsets), nan before the first full window). `guiding`: the
    run's guiding forces, if already computed."""
    guiding = run.guiding_forces() if guiding is None else guiding
    # On a curve, of the forces about their quasi-static part: EN 14363's instability is the
    # oscillation, and a low-pass (f0 <= 2 Hz) would keep the steady guiding force.
    return _hunting_rms(run.t, run.x, guiding - curving_part(run, guiding))


def _hunting_rms(t: np.ndarray, x: np.ndarray, guiding: np.ndarray) -> tuple[float, np.ndarray]:
    """`hunting_rms` of the guiding forces at times t and distances x (m)."""
    f0 = dominant_frequency(t, guiding)
    columns = guiding.reshape(len(guiding), -1)
    rms = np.empty(columns.shape)
    for c, column in enumerate(_band_rms(t, x, f0, (columns[:, c] for c in range(columns.shape[1])))):
        rms[:, c] = column
    return f0, rms.reshape(guiding.shape)


def _band_rms(t: np.ndarray, x: np.ndarray, f0: float, columns: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    """Each column's band-passed sliding rms over EN 14363's window, a column at a time: the
    filter's and the window's buffers (about six times the signal) are a column's, not the
    run's (a sweep's long runs finish while others step on)."""
    start = window_starts(x, HUNTING_WINDOW)
    for column in columns:
        yield sliding_rms(x, band_pass(t, column, f0), HUNTING_WINDOW, start)


def _largest(rms: np.ndarray) -> float:
    """The largest rms of a wheelset's column leaving out nan (no whole window yet); nan if
    every sample is."""
    kept = rms[~np.isnan(rms)]
    return float(np.max(kept)) if kept.size else math.nan


def hunting_assessable(run: Run) -> str | None:
    """Why EN 14363's criterion cannot be applied to `run` (None when it can): no wheel
    load, less than one 100 m window, or samples too sparse or too few for the filter."""
    return _assessable(run.layout, float(run.x[-1]), len(run.t))


def _assessable(layout, distance: float, n_samples: int) -> str | None:
    if layout.wheelset.wheel_load is None:
        return "no wheel load: give wheelset.wheel_load or a car body with mass"
    if distance < HUNTING_WINDOW:
        return f"the run is shorter than EN 14363's {HUNTING_WINDOW:g} m window"
    # The zero-phase filter pads each end by 3 x (2 x sections + 1) samples; a run needs
    # a few filter lengths beyond that before its rms means anything.
    if n_samples < 10 * 3 * (2 * FILTER_ORDER + 1):
        return f"the run has only {n_samples} samples, too few for the band-pass filter"
    return None


def hunting(run: Run) -> dict | None:
    """The instability criterion per wheelset; None when it cannot be applied
    (`hunting_assessable` says why)."""
    if hunting_assessable(run) is not None:
        return None
    f0, rms = hunting_rms(run)
    columns = rms.reshape(len(rms), -1)
    return _criterion(run.layout, f0, [_largest(columns[:, c]) for c in range(columns.shape[1])])


def hunting_of(
    layout, t: np.ndarray, x: np.ndarray, column: Callable[[int], np.ndarray], n_columns: int
) -> dict | None:
    """`hunting` of a run on straight track given as its times, distances and each wheelset's
    guiding forces, `column(c)` for c < n_columns (rail_mj.analysis.streaming: a run summarised as
    it is stepped, its Sigma Y read back a wheelset at a time)."""
    if _assessable(layout, float(x[-1]), len(t)) is not None:
        return None
    f0 = _dominant(t, (column(c) for c in range(n_columns)))
    worst = [_largest(rms) for rms in _band_rms(t, x, f0, (column(c) for c in range(n_columns)))]
    return _criterion(layout, f0, worst)


def _criterion(layout, f0: float, worst: list[float]) -> dict | None:
    """The criterion from each wheelset's largest rms (nan: none)."""
    wheel_load = layout.wheelset.wheel_load
    if not np.any(np.isfinite(worst)):
        return None
    limit = hunting_limit(2.0 * wheel_load)
    return {
        "criterion": "EN 14363: rms over 100 m of the sum of guiding forces, band-passed f0 +/- 2 Hz",
        "frequency_hz": f0,
        "limit_n": limit,
        "max_rms_n": [float(v) for v in worst],
        "hunting": bool(np.any(np.asarray(worst) > limit)),
    }


WHEELS = ("left", "right")


def derailment_quotients(run: Run) -> np.ndarray:
    """(n_samples, n_wheelsets, 2): Y/Q of each wheel, `Run.derailment_quotients`."""
    return run.derailment_quotients()


def sliding_mean(values: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    """The mean of `values` (samples along axis 0, at distances `x`, m) over `window` metres of
    track centred on each sample, as EN 14363 processes Y/Q; NaN where the window holds a NaN (a
    wheel off its rail), and only there. At the run's ends the end values stand for the track
    beyond (the whole run if it is shorter than the window)."""
    step = float(x[1] - x[0]) if len(x) > 1 else 0.0
    n = max(1, round(window / step)) if step > 0 else 1
    n = min(n, len(values))
    half = n // 2
    padded = np.concatenate([np.repeat(values[:1], half, axis=0), values, np.repeat(values[-1:], n - 1 - half, axis=0)])
    missing = np.isnan(padded)
    zero = np.zeros((1,) + values.shape[1:])
    total = np.concatenate([zero, np.cumsum(np.where(missing, 0.0, padded), axis=0)])
    holes = np.concatenate([zero, np.cumsum(missing, axis=0)])
    mean = (total[n:] - total[:-n]) / n
    return np.where(holes[n:] - holes[:-n] > 0, np.nan, mean)


def wheel_safety(run: Run) -> dict:
    """The largest derailment quotient Y/Q and the smallest wheel load Q, per wheelset and over
    the run, with where they happened (None when the layout gives no wheel loads). Y/Q as
    EN 14363 assesses it, its mean over Y_OVER_Q_WINDOW of track; its largest sample beside it
    (a flange impact's peak: on a rigid flange, and with the creep forces left out of the
    wheelset's vertical balance, an upper bound; docs/spatial.md)."""
    q, peaks = run.wheel_loads(), derailment_quotients(run)
    if np.isnan(q).all():
        none = {"largest_y_over_q": None, "largest_y_over_q_peak": None, "smallest_wheel_load_n": None}
        return {"wheelsets": [dict(none) for _ in range(run.n_wheelsets)], "run": dict(none)}
    quotient = sliding_mean(peaks, run.x, Y_OVER_Q_WINDOW)

    def at(values, pick) -> tuple[float | None, dict | None]:
        finite = np.where(np.isnan(values), -np.inf if pick is np.nanargmax else np.inf, values)
        if not np.isfinite(finite).any():
            return None, None
        j, i, side = np.unravel_index(pick(finite), values.shape)
        return float(values[j, i, side]), {
            "wheelset": int(i) + 1,
            "wheel": WHEELS[side],
            "x_m": float(run.x[j]),
            "t_s": float(run.t[j]),
        }

    per = []
    for i in range(run.n_wheelsets):
        per.append(
            {
                "largest_y_over_q": at(quotient[:, i : i + 1], np.nanargmax)[0],
                "largest_y_over_q_peak": at(peaks[:, i : i + 1], np.nanargmax)[0],
                "smallest_wheel_load_n": at(q[:, i : i + 1], np.nanargmin)[0],
            }
        )
    largest, where_largest = at(quotient, np.nanargmax)
    smallest, where_smallest = at(q, np.nanargmin)
    # Where Q comes from: a spatial vehicle's suspension (rail_mj.vehicle.loads); on profiles the contact's
    # equilibrium under the static axle load; on a planar vehicle's cones the static share.
    spatial = run.layout.spatial
    source = (
        "suspension"
        if spatial is not None and spatial.gravity
        else "profile contact, static axle load"
        if run.layout.profiles is not None
        else "static share"
    )
    return {
        "wheelsets": per,
        "run": {
            "largest_y_over_q": largest,
            "largest_y_over_q_at": where_largest,
            "wheel_loads_from": source,
            "largest_y_over_q_peak": at(peaks, np.nanargmax)[0],
            "y_over_q_window_m": Y_OVER_Q_WINDOW,
            "smallest_wheel_load_n": smallest,
            "smallest_wheel_load_at": where_smallest,
            "y_over_q_limit": Y_OVER_Q_LIMIT,
            "y_over_q_exceeded": largest is not None and largest > Y_OVER_Q_LIMIT,
        },
    }


# EN 14363's statistics of a section's on-track quantities: the extremes read as the 0.15 % and
# 99.85 % percentiles of the processed signal, beside its plain extremes.
PERCENTILES = (0.15, 99.85)
GUIDING_WINDOW = 2.0  # m: Sigma Y as its sliding mean over 2 m of track


def guiding_limit(wheel_load: float) -> float:
    """Prud'homme's limit on Sigma Y (2 m), N, for a static wheel load Q0 in N: 10 kN + 2*Q0/3."""
    return 10e3 + 2.0 * wheel_load / 3.0


def _statistics(values: np.ndarray) -> dict:
    """min, max and the 0.15/99.85 % percentiles of the finite values; None where there are none."""
    finite = values[np.isfinite(values)]
    if not finite.size:
        return {"min": None, "max": None, "p0_15": None, "p99_85": None}
    low, high = np.percentile(finite, PERCENTILES)
    return {"min": float(finite.min()), "max": float(finite.max()), "p0_15": float(low), "p99_85": float(high)}


def on_track(run: Run) -> list[dict]:
    """Per section of the run's track (rail_mj.track, in order) its samples' statistics (min, max,
    0.15 and 99.85 % percentiles): per wheelset Sigma Y (2 m mean, N) against Prud'homme's limit; per
    wheel Q (N), the unloading dQ/Q0 = (Q - Q0)/Q0, Y (N) and Y/Q (2 m means); per bogie frame its
    lateral acceleration (m/s^2, in its own axes as a frame-mounted accelerometer reads it: on a
    spatial vehicle with g*roll). A sample belongs to the section its wheelset (or frame) is in."""
    if run.track is None:
        return []
    x, stations = run.x, run.wheelset_station
    guiding = sliding_mean(run.guiding_forces(), x, GUIDING_WINDOW)
    q, lateral = run.wheel_loads(), run.wheel_lateral_forces()
    lateral_2m = sliding_mean(lateral, x, Y_OVER_Q_WINDOW)
    quotient = sliding_mean(run.derailment_quotients(), x, Y_OVER_Q_WINDOW)
    q0 = run.layout.wheelset.wheel_load
    frames = _frame_accelerations(run)
    out = []
    for section in run.track.sections:
        inside = (stations >= section.start) & (stations < section.end)
        if not inside.any():
            continue
        wheelsets = []
        for i in range(run.n_wheelsets):
            mine = inside[:, i]
            if not mine.any():
                continue
            wheels = {}
            for side, wheel in enumerate(WHEELS):
                load = q[mine, i, side]
                wheels[wheel] = {
                    "q_n": _statistics(load),
                    "unloading": None if q0 is None else _statistics((load - q0) / q0),
                    "y_n": _statistics(lateral_2m[mine, i, side]),
                    "y_over_q": _statistics(quotient[mine, i, side]),
                }
            wheelsets.append({"wheelset": i + 1, "sum_y_n": _statistics(guiding[mine, i]), **wheels})
        entry = {
            "section": section.number,
            "kind": section.kind,
            "from_m": section.start,
            "to_m": section.end,
            "sum_y_limit_n": None if q0 is None else guiding_limit(q0),
            "wheelsets": wheelsets,
        }
        if frames:
            centre = run.station[:, None]
            here = (centre >= section.start) & (centre < section.end)
            entry["frames"] = [
                {"body": name, "lateral_acceleration_m_per_s2": _statistics(a[here[:, 0]])} for name, a in frames
            ]
        out.append(entry)
    return out


def _frame_accelerations(run: Run) -> list[tuple[str, np.ndarray]]:
    """Each bogie frame's lateral acceleration at its centre, in its own axes (see `on_track`)."""
    from rail_mj.simulation.run import second_derivative
    from rail_mj.units import GRAVITY

    if len(run.t) < 3:
        return []
    dt = float(run.t[1] - run.t[0])
    out = []
    for k, name in enumerate(run.frame_names):
        if not name.startswith("bogie"):
            continue
        a = second_derivative(run.frame_y[:, k], dt)
        if run.layout.spatial is not None:
            a = a + GRAVITY * run.frame_roll[:, k]
        out.append((name, a))
    return out
