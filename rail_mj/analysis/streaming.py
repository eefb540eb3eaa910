"""A run summarised as it is stepped: what a sweep's row reads of a run on straight track, kept
from its samples a chunk at a time instead of a record of every body's pose at every sample.

A sweep of long runs holds the runs in flight (sixteen on two threads), and a coach's full
record is 584 bytes a sample: 64 runs of 10 km peaked at 3.2 GB. What the row needs of the
motion is kept exactly, in a few numbers and events a coordinate (`Coordinate`): the largest
|value| (over the run, its second half and its last tenth), the samples that can end a decay
(`decayed_at`), the upward zero crossings and the peaks. EN 14363's instability criterion needs
the whole run's Sigma Y (its f0 is the peak of the whole run's periodogram, and the band-pass
runs forwards and backwards), which is kept a sample a wheelset in a temporary file until the run
ends, and then read back and filtered a wheelset at a time, one run at a time. Everything is the
full summary's, bit for bit (tests/analysis/test_streaming.py): only the memory changes.

Example:

    >>> from rail_mj import load_layout
    >>> from rail_mj.simulation.batch import simulate_many
    >>> from rail_mj.simulation.run import Request
    >>> layout = load_layout("models/bogie/bogie.toml")
    >>> (streamed,) = simulate_many([Request(layout, 30.0, 150.0, 0.002, stream=Summarised.stream(layout, 30.0))])
    >>> streamed["decayed"], len(streamed["wheelsets"])
    (True, 2)
"""

from __future__ import annotations

import ctypes
import functools
import math
import tempfile
import threading
import weakref
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from rail_mj.analysis.en14363 import hunting_of
from rail_mj.analysis.motion import AT_REST, DECAYED_FRACTION, MOTIONS, SIGNIFICANT, late_verdict

if TYPE_CHECKING:
    from rail_mj.layout import Layout
    from rail_mj.simulation.run import Run


# `Coordinate._add_numpy` in one pass in C (built once per installation, rail_mj.compiled): the
# same comparisons and the same arithmetic in the same order, so the same bits. The samples are
# the previous chunk's last (if `has_last`) and then the chunk's, numbered from start - has_last.
_C_SOURCE = """/* Written by rail_mj.analysis.streaming. */
#include <math.h>
#include <stdint.h>

void rail_mj_events(int64_t start, const double *t, const double *s, int64_t n, double t_end,
                    int64_t has_last, double last_t, double last_s, int64_t *move, double *reach,
                    int64_t *counts, int64_t *ints, double *reals, int64_t width) {
    int64_t mine = 0, crossings = 0, peaks = 0, troughs = 0;
    double top = 0.0, late = -1.0, final = -1.0, after = -INFINITY;
    for (int64_t i = 0; i < n; i++) {
        double m = fabs(s[i]);
        if (i == 0 || m > top) top = m;
        if (t[i] >= t_end / 2 && m > late) late = m;
        if (t[i] >= 0.9 * t_end && m > final) final = m;
    }
    for (int64_t i = n - 1; i >= 0; i--) { /* each sample above every later one, last first */
        double m = fabs(s[i]);
        if (m > after) {
            ints[mine] = i;
            reals[mine++] = m;
            after = m;
        }
    }
    for (int64_t a = 0, b = mine - 1; a < b; a++, b--) {
        int64_t i = ints[a]; ints[a] = ints[b]; ints[b] = i;
        double m = reals[a]; reals[a] = reals[b]; reals[b] = m;
    }
    int64_t base = start - has_last, total = n + has_last;
    for (int64_t k = 0; k + 1 < total; k++) {
        double t0 = (has_last && k == 0) ? last_t : t[k - has_last], t1 = t[k + 1 - has_last];
        double s0 = (has_last && k == 0) ? last_s : s[k - has_last], s1 = s[k + 1 - has_last];
        if (s0 < 0 && s1 >= 0) {
            ints[width + crossings] = base + k;
            reals[width + crossings++] = t0 - s0 * (t1 - t0) / (s1 - s0);
        }
        double d = s1 - s0;
        if (d != 0) {
            int64_t rising = d > 0;
            if (move[0] && move[2] && !rising) { /* a rise then a fall: a peak at s0 */
                ints[2 * width + peaks] = move[1];
                ints[3 * width + peaks] = base + k;
                reals[2 * width + peaks++] = s0;
            } else if (move[0] && !move[2] && rising) { /* a fall then a rise: a trough */
                ints[4 * width + troughs] = move[1];
                ints[5 * width + troughs] = base + k;
                reals[3 * width + troughs++] = s0;
            }
            move[0] = 1, move[1] = base + k, move[2] = rising;
        }
    }
    reach[0] = top, reach[1] = late, reach[2] = final;
    counts[0] = mine, counts[1] = crossings, counts[2] = peaks, counts[3] = troughs;
}
"""


class _Workspace(threading.local):
    """A thread's buffers for the kernel's results (6 + 4 rows of up to n + 1 entries, reach,
    counts, the move's state), kept from chunk to chunk, and their addresses."""

    def __init__(self):
        self.size = -1

    def fit(self, n: int) -> _Workspace:
        if n > self.size:
            self.size = max(n, 2 * self.size)
            self.arrays = (
                np.empty((6, self.size + 1), np.int64),
                np.empty((4, self.size + 1)),
                np.empty(3),
                np.empty(4, np.int64),
                np.empty(3, np.int64),
            )
            state, reach, counts, ints, reals = (self.arrays[k] for k in (4, 2, 3, 0, 1))
            self.pointers = (state.ctypes.data, reach.ctypes.data, counts.ctypes.data, ints.ctypes.data,
                             reals.ctypes.data, self.size + 1)  # fmt: skip
        return self


_WORK = _Workspace()


@functools.cache
def _library() -> ctypes.CDLL | None:
    from rail_mj import compiled

    library = compiled.load("events", "", _C_SOURCE)
    if library is not None:
        i64, f64, v = ctypes.c_int64, ctypes.c_double, ctypes.c_void_p
        library.rail_mj_events.argtypes = (i64, v, v, i64, f64, i64, f64, f64, v, v, v, v, v, i64)
        library.rail_mj_events.restype = None
    return library


class Coordinate:
    """One coordinate's samples (evenly spaced, sample k at t = k*interval) as they come, reduced
    to what `rail_mj.analysis.motion` reads of them, exactly:

    - the largest |s| over the run, over its second half (t >= t_end/2) and its last tenth
      (t >= 0.9*t_end);
    - the strict suffix maxima of |s| (each sample larger than every later one) above
      DECAYED_FRACTION of the largest so far: the last sample above any fraction of the final
      largest is the last of these above it (`decayed_at`);
    - the upward zero crossings, interpolated as `motion._crossings` does;
    - every peak and trough as `motion.local_maxima` finds them, with the two moves around it
      (the sample before its rise, the sample its fall starts from), which say whether it is a
      peak of a window of the run too.
    """

    def __init__(self, n_samples: int, interval: float, events: bool = True):
        self.n, self.interval, self.events = n_samples, interval, events  # events False: the largest only
        self.t_end = float(np.arange(n_samples)[-1] * interval)  # as Run.t[-1]
        self.largest = self.late = self.final = 0.0
        self.stairs = (np.empty(0, np.int64), np.empty(0))
        self.crossings: list[tuple[np.ndarray, np.ndarray]] = []
        self.tops: dict[bool, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {True: [], False: []}
        self._last: tuple[float, float] | None = None  # the previous sample's (t, s)
        self._move: tuple[int, bool] | None = None  # the last move: (from sample, rising)

    def add(self, start: int, t: np.ndarray, s: np.ndarray, native: bool = True) -> None:
        """The samples start, start + 1, ... at times t. `native`: by the C library's kernel (else
        numpy's, as where it cannot be built; the two agree bit for bit)."""
        library = _library() if native and self.events else None
        if library is None:
            self._add_numpy(start, t, s)
            return
        t, s = np.ascontiguousarray(t, dtype=np.float64), np.ascontiguousarray(s, dtype=np.float64)
        n = len(s)
        work = _WORK.fit(n)
        ints, reals, reach, counts, state = work.arrays
        state[:] = (0, 0, 0) if self._move is None else (1, *self._move)
        last = (0, 0.0, 0.0) if self._last is None else (1, *self._last)
        library.rail_mj_events(start, t.ctypes.data, s.ctypes.data, n, self.t_end, *last, *work.pointers)
        top = float(reach[0])
        self.largest = max(self.largest, top)
        if reach[1] >= 0.0:
            self.late = max(self.late, float(reach[1]))
        if reach[2] >= 0.0:
            self.final = max(self.final, float(reach[2]))
        mine, crossings, peaks, troughs = (int(c) for c in counts)
        index, value = self.stairs
        keep = value > top
        index = np.concatenate([index[keep], start + ints[0, :mine]])
        value = np.concatenate([value[keep], reals[0, :mine]])
        keep = value > DECAYED_FRACTION * self.largest  # never the last above the final fraction
        self.stairs = (index[keep], value[keep])
        if crossings:
            self.crossings.append((ints[1, :crossings].copy(), reals[1, :crossings].copy()))
        for peak, count in ((True, peaks), (False, troughs)):
            if count:
                row = 2 if peak else 4
                self.tops[peak].append(
                    (ints[row, :count].copy(), ints[row + 1, :count].copy(), reals[row // 2 + 1, :count].copy())
                )
        if state[0]:
            self._move = (int(state[1]), bool(state[2]))
        self._last = (float(t[-1]), float(s[-1]))

    def _add_numpy(self, start: int, t: np.ndarray, s: np.ndarray) -> None:
        magnitude = np.abs(s)
        top = float(np.max(magnitude))
        self.largest = max(self.largest, top)
        if not self.events:
            return
        late, final = magnitude[t >= self.t_end / 2], magnitude[t >= 0.9 * self.t_end]  # as motion's masks
        if late.size:
            self.late = max(self.late, float(np.max(late)))
        if final.size:
            self.final = max(self.final, float(np.max(final)))
        # Strict suffix maxima: of the kept ones those above everything since, and the chunk's own.
        after = np.append(np.maximum.accumulate(magnitude[::-1])[::-1][1:], -np.inf)
        own = np.flatnonzero(magnitude > after)
        index, value = self.stairs
        keep = value > top
        index, value = np.concatenate([index[keep], start + own]), np.concatenate([value[keep], magnitude[own]])
        keep = value > DECAYED_FRACTION * self.largest  # never the last above the final fraction
        self.stairs = (index[keep], value[keep])
        if self._last is not None:
            t = np.concatenate([[self._last[0]], t])
            s = np.concatenate([[self._last[1]], s])
            start -= 1
        i = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
        if i.size:
            self.crossings.append((start + i, t[i] - s[i] * (t[i + 1] - t[i]) / (s[i + 1] - s[i])))
        d = np.diff(s)
        moves = np.flatnonzero(d != 0)
        rises = d[moves] > 0
        moves = start + moves
        if self._move is not None:
            moves = np.concatenate([[self._move[0]], moves])
            rises = np.concatenate([[self._move[1]], rises])
        if moves.size:
            self._move = (int(moves[-1]), bool(rises[-1]))
        for peak in (True, False):  # a rise then a fall; a fall then a rise
            j = np.flatnonzero((rises[:-1] & ~rises[1:]) if peak else (~rises[:-1] & rises[1:]))
            if j.size:
                before, fall = moves[j], moves[j + 1]
                self.tops[peak].append((before, fall, s[fall - start]))
        self._last = (float(t[-1]), float(s[-1]))

    def _events(self, first: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """The upward crossing times and the peaks (peaks, then troughs: times and |s| > 0) of
        the samples first..stop-1, as `motion.oscillation` finds them in that slice."""
        up = [c[1][(c[0] >= first) & (c[0] <= stop - 2)] for c in self.crossings]
        times, values = [], []
        for peak in (True, False):
            for before, fall, value in self.tops[peak]:
                inside = (before >= first) & (fall <= stop - 2)
                times.append(((before[inside] + 1 + fall[inside]) // 2) * self.interval)
                values.append(value[inside])
        t, v = np.concatenate(times or [np.empty(0)]), np.concatenate(values or [np.empty(0)])
        nonzero = np.abs(v) > 0
        return np.concatenate(up or [np.empty(0)]), np.stack([t[nonzero], np.abs(v[nonzero])])

    def oscillation(self, first: int, stop: int) -> tuple[float, float]:
        """`motion.oscillation` of the samples first..stop-1."""
        up, (t, v) = self._events(first, stop)
        freq = (len(up) - 1) / (up[-1] - up[0]) if len(up) >= 2 else math.nan
        sigma = float(np.polyfit(t, np.log(v), 1)[0]) if len(t) >= 3 and len(up) >= 2 else math.nan
        return float(freq), sigma

    def decayed_at(self) -> tuple[float, int] | None:
        """`motion.decayed_at` of the whole run, and the sample it is at."""
        index, value = self.stairs
        above = index[value > DECAYED_FRACTION * self.largest]
        if not above.size:
            return 0.0, 0
        end = int(above[-1]) + 1
        at = end * self.interval
        if end >= self.n or at > 0.0 + 0.75 * (self.t_end - 0.0):
            return None
        return float(at), end

    def motion(self, speed: float) -> dict:
        """`motion._motion` of this coordinate at constant `speed` on straight track."""
        at_rest = self.largest <= AT_REST
        ended = (0.0, 0) if at_rest else self.decayed_at()
        decayed = None if ended is None else ended[0]
        freq, sigma = self.oscillation(0, self.n if ended is None else ended[1] + 1)
        if at_rest:
            verdict = "at rest"
        elif decayed is not None:
            verdict = "decayed"
        else:
            late = int(np.argmax(np.arange(self.n) * self.interval >= self.t_end / 2))
            late_sigma = self.oscillation(late, self.n)[1] if self.n - late > 2 else math.nan
            t_late = float(np.arange(self.n)[late] * self.interval)
            verdict = late_verdict(late_sigma, float(self.t_end - t_late))
        return {
            "decayed": decayed is not None,
            "decayed_by_s": decayed,
            "decayed_by_m": None if decayed is None else decayed * speed,
            "growth_rate_per_s": None if math.isnan(sigma) else sigma,
            "frequency_hz": None if math.isnan(freq) else freq,
            "wavelength_m": None if math.isnan(freq) else speed / freq,
            "motion": verdict,
        }


# The runs of a sweep end on several threads at once; each one's EN 14363 filters hold a few
# times a wheelset's Sigma Y (4 MB for 500 s at 1 kHz), and numpy's FFT of its periodogram, for a
# length with a large prime factor (Bluestein's algorithm), about 16 times it: one at a time.
_FINISHING = threading.Lock()
_BLOCK = 1 << 20  # bytes of Sigma Y read back at a time
# Samples from which a finished run's heap is given back (release_memory): its filters' buffers,
# about eight columns of samples, are then 8 MB or more; a shorter run's are reused by the next
# run's as they are (the trim, a millisecond, is a tenth of a short run's summary).
_TRIM_FROM = 1 << 17


def release_memory() -> None:
    """Give the heap's free pages back to the system. glibc keeps what a thread's arena has freed
    for that thread's next allocations: a finished run's filter buffers (tens of MB) would stay in
    the process's resident memory, arena by arena, till the end of the sweep. Elsewhere (another
    C library): nothing."""
    if _TRIM is not None:
        _TRIM(0)


def _malloc_trim():
    import ctypes
    import ctypes.util
    import sys

    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
    except (OSError, AttributeError):  # musl and others: no malloc_trim
        return None


_TRIM = _malloc_trim()


class Summarised:
    """A Sink (rail_mj.simulation.run.Sink) for a run at constant speed on straight track:
    `finish` gives what `rail_mj.analysis.motion.summary` says of the run's motion and EN 14363
    instability, its `wheelsets` (largest |y| and yaw, last tenth's |y|, motion), `frames`
    (the same of the bogie frames and car body), `decayed`, `hunting` and `max_abs_lateral_m`,
    equal to the full summary's bit for bit."""

    def __init__(self, layout: Layout, speed: float, n_samples: int, interval: float):
        self.layout, self.speed, self.interval = layout, speed, interval
        self.n = n_samples
        self.wheelsets: list[dict[str, Coordinate]] = []
        self.frames: list[dict[str, Coordinate]] = []
        self.names: tuple[str, ...] = ()
        self.lever = np.empty(0)
        self.spatial = layout.spatial is not None
        # Sigma Y, a chunk at a time: on disk, not in memory; closed by `finish` (or when dropped).
        self.guiding = tempfile.TemporaryFile()  # noqa: SIM115
        # A run that derails or is cancelled is dropped without `finish`: its file closes then.
        weakref.finalize(self, self.guiding.close)
        self.n_wheelsets = 0

    @classmethod
    def stream(cls, layout: Layout, speed: float) -> Callable[[int, float], Summarised]:
        """The `Request.stream` of a run of `layout` at `speed`."""
        return lambda n_samples, interval: cls(layout, speed, n_samples, interval)

    def add(self, piece: Run, start: int) -> None:
        n, interval = self.n, self.interval
        if start == 0:
            self.names = piece.frame_names
            self.wheelsets = [
                # Of a wheelset's yaw the summary reads only its largest.
                {"lateral": Coordinate(n, interval), "yaw": Coordinate(n, interval, events=False)}
                for _ in range(piece.n_wheelsets)
            ]
            coordinates = ("lateral", "yaw", "roll") if self.spatial else ("lateral", "yaw")
            self.frames = [{c: Coordinate(n, interval, events=c != "roll") for c in coordinates} for _ in self.names]
            offsets = piece.frame_station[0] - piece.station[0]
            self.lever = np.min(np.abs(offsets[:, None] - np.asarray(self.layout.wheelset_x)[None, :]), axis=1)
            self.n_wheelsets = piece.n_wheelsets
        t = piece.t
        y, psi = piece.y, piece.psi
        for i, w in enumerate(self.wheelsets):
            w["lateral"].add(start, t, y[:, i])
            w["yaw"].add(start, t, psi[:, i])
        if self.frames:
            values = {"lateral": piece.frame_y, "yaw": piece.frame_psi}
            if self.spatial:
                values["roll"] = piece.frame_roll
            for k, frame in enumerate(self.frames):
                for c, coordinate in frame.items():
                    coordinate.add(start, t, values[c][:, k])
        self.guiding.write(np.ascontiguousarray(piece.guiding_forces(), dtype=np.float64).tobytes())

    def _guiding(self, c: int) -> np.ndarray:
        """Wheelset c's Sigma Y over the run, read back from the file (a sample's wheelsets
        side by side) a block of samples at a time."""
        column = np.empty(self.n)
        block = max(1, _BLOCK // (8 * self.n_wheelsets))
        self.guiding.seek(0)
        for start in range(0, self.n, block):
            rows = np.fromfile(self.guiding, dtype=np.float64, count=min(block, self.n - start) * self.n_wheelsets)
            column[start : start + block] = rows.reshape(-1, self.n_wheelsets)[:, c]
        return column

    def finish(self, final_state) -> dict:
        wheelsets = []
        for i, w in enumerate(self.wheelsets):
            wheelsets.append(
                {
                    "wheelset": i + 1,
                    "max_abs_lateral_m": w["lateral"].largest,
                    "max_abs_yaw_rad": w["yaw"].largest,
                    "final_abs_lateral_m": w["lateral"].final,
                    **w["lateral"].motion(self.speed),
                }
            )
        frames = []
        for k, (name, frame) in enumerate(zip(self.names, self.frames, strict=True)):
            reach = {"lateral": frame["lateral"].late, "yaw": self.lever[k] * frame["yaw"].late}
            largest = max(reach.values())
            motions = {c: frame[c].motion(self.speed) for c in reach if reach[c] >= SIGNIFICANT * largest}
            worst = max(motions, key=lambda c: MOTIONS.index(motions[c]["motion"]))
            entry = {
                "body": name,
                "max_abs_lateral_m": frame["lateral"].largest,
                "max_abs_yaw_rad": frame["yaw"].largest,
                "final_abs_lateral_m": frame["lateral"].final,
            }
            if self.spatial:
                entry["max_abs_roll_rad"] = frame["roll"].largest
            entry.update(motions[worst])
            entry["coordinate"] = worst
            frames.append(entry)
        with _FINISHING:  # one run's filters in memory at a time
            t = np.arange(self.n) * self.interval
            hunting = hunting_of(self.layout, t, self.speed * t, self._guiding, self.n_wheelsets)
            self.guiding.close()
            del t
            if self.n >= _TRIM_FROM:
                release_memory()
        return {
            "wheelsets": wheelsets,
            "frames": frames,
            "decayed": all(b["decayed"] for b in wheelsets + frames),
            "hunting": hunting,
            "max_abs_lateral_m": max(w["max_abs_lateral_m"] for w in wheelsets),
            "final_state": final_state,
        }
