"""Rerun recordings of runs, for review in the Rerun viewer (`rerun FILE.rrd`).

Entity paths (stable; later tools read them back), in review units: mm, mrad, kN:

    /lateral/wheelset<i>   lateral displacement y of wheelset i, mm (Scalars)
    /yaw/wheelset<i>       yaw psi of wheelset i, mrad (Scalars)
    /guiding/wheelset<i>   the sum of guiding forces Sigma Y on wheelset i, kN (Scalars):
                           the lateral force of the rails, creep and flange
    /wear/wheelset<i>/<side>  (on a curved track) each wheel's wear number T-gamma, N: the
                           energy its creep dissipates per metre rolled (left, right)
    /flange/wheelset<i>    (with [flange] contact) the flange's part of it, kN: the rail's
                           lateral force on the flange, positive to the left, 0 off the flange;
                           on profiles the normal forces' lateral part (gravitational
                           stiffness on the tread, the flange force on the flange)
    /lateral/<frame>       lateral displacement of each moving frame, mm: bogie1, bogie2, ...
    /yaw/<frame>           and its yaw, mrad; then carbody, unless it is fixed
    /events/flange         (with [flange] or profiles) a log line for each flange strike
    /layout                the layout file and the run's settings, logged once
    /exaggeration          what the 3D view exaggerates, and by how much (a text, logged once)
    /world/rails           the track, logged once, and /world/sleepers, one every 0.6 m
    /world/vehicle/<body>  each body's pose (carbody, bogieK, wheelsetN) moving along the
                           track (x = V*t + the body's place, m), its MJCF geoms (boxes, axle,
                           wheel meshes) under it; /world/vehicle/<root>/extent marks the
                           vehicle's extent (invisible) for the 3D view's camera to follow.
                           Its lateral displacement and yaw relative to the track are drawn
                           `exaggeration` times their size (`exaggeration(run)`); the plots
                           show true values

each on two timelines, TIME (seconds) and DISTANCE (millimetres travelled: Rerun
timelines are integer sequences or times, so distance is a sequence in mm).

The run samples every millisecond; the recording keeps one sample in every n, at a
rate chosen from the run's motion (`recording_rate`), or as asked: `rate` in samples
per second, `math.inf` for every sample. Flange strikes are found in the full run.

The blueprint opens on a grid of plots (wheelsets above, the bogies and car body below;
lateral, yaw, forces), each showing a window of a few seconds around the run's first flange
strike or its largest motion (`review_window`), on either timeline, each legend in a corner
the data leave free or hidden; and a 3D view whose camera follows the vehicle.

Example:

    >>> from rail_mj import load_layout, simulate
    >>> import tempfile, os
    >>> run = simulate(load_layout("models/wheelset/wheelset.toml"), speed=20.0, distance=10.0,
    ...                initial_lateral=0.002)
    >>> path = os.path.join(tempfile.mkdtemp(), "run.rrd")
    >>> write_recording(run, path).stat().st_size > 0
    True
"""

from __future__ import annotations

import errno
import math
import uuid
from pathlib import Path
from typing import NamedTuple

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from rerun.blueprint.components import AbsoluteTimeRange
from rerun.encodings import TimeInt

from rail_mj.analysis import flange_strikes
from rail_mj.analysis.en14363 import dominant_frequency
from rail_mj.files import staged
from rail_mj.layout.kinds import Coned, Profiled, contact_model
from rail_mj.layout.reader import Flange
from rail_mj.practice import EXAGGERATION_LIMITS
from rail_mj.simulation.run import Run
from rail_mj.track import Track
from rail_mj.units import MM_PER_M, MRAD_PER_RAD, N_PER_KN
from rail_mj.vehicle.curve import ODOMETER
from rail_mj.vehicle.looks import RAIL_HEAD_WIDTH

APP_ID = "rail-mj"
TIME = "time"
DISTANCE = "distance_mm"
FLANGE_EVENTS = "/events/flange"


# The recording rate. The plots and the 3D view need each motion drawn smoothly, not
# every millisecond: every sample costs about 0.75 MB per simulated second. The motion's
# highest frequency of interest, f_motion, is the frequency below which MOTION_POWER
# of the power of the wheelsets' lateral velocity lies. The velocity, not the
# displacement: the displacement's spectrum is swamped by its slow drift and by the
# jump from its start to its end (the initial offset), while the velocity starts at
# rest and weights the faster motion (flange strikes, the harmonics of hunting) up.
# SAMPLES_PER_CYCLE samples per cycle of f_motion draw a sinusoid at f_motion within
# 1 - cos(pi/10) = 5 % of its peaks, and the bulk of the motion, well below f_motion,
# closer still. 98 % of the power: the last 2 % are the sharp corners of flange strikes,
# which the full-rate flange events (/events/flange) mark anyway. The Manchester coach
# hunting on its flanges at 85 m/s (5.1 Hz) is recorded at 167 samples/s, 33 a cycle
# (its EN 14363 band, f0 +/- 2 Hz, at 24 or more); at 40 m/s, stable, at 50 samples/s.
# A 10 km run then stays under 25 MB either way (17 MB hunting). FLOOR_RATE keeps slow
# runs smooth on screen. Never above the run's own sampling rate; `rate=math.inf` (or
# `--rrd-rate full`) records every sample.
MOTION_POWER = 0.98
SAMPLES_PER_CYCLE = 10
FLOOR_RATE = 50.0  # samples/s

SLEEPER_SPACING = 0.6  # m
TRACK_MARGIN = 30.0  # m of track drawn before the start and past the end

# The 3D view's camera: direction from the vehicle's centre (x ahead, y left, z up) and
# distance, per metre of vehicle length.
CAMERA_DIRECTION = (0.3, -1.0, 0.4)
CAMERA_DISTANCE = 1.25
CAMERA_MIN_DISTANCE = 6.0  # m

AXIS_EDGES = (1, 1.5, 2, 3, 4, 5, 6, 10)  # times a power of ten: see axis_range

# Series colours by wheelset (and by bogie), the same in every plot; the car body white.
PALETTE = [
    (86, 156, 255),
    (255, 110, 90),
    (90, 210, 110),
    (255, 200, 60),
    (200, 130, 255),
    (60, 220, 210),
    (255, 140, 200),
    (180, 230, 80),
    (255, 160, 60),
    (140, 150, 255),
    (200, 200, 200),
    (190, 140, 100),
]
CARBODY_COLOUR = (235, 235, 235)
# The palette's colours by name, for the key the recording's notes give (a hidden legend's).
COLOUR_NAMES = (
    "blue",
    "red",
    "green",
    "yellow",
    "violet",
    "cyan",
    "pink",
    "lime",
    "orange",
    "indigo",
    "grey",
    "brown",
)

# The 3D view's exaggeration of lateral motion and yaw. Hunting of 13 mm under a 25 m coach,
# seen from the camera's 30 m in a view some 600 pixels across, moves the wheels by a quarter
# of a pixel: invisible. Each body's lateral displacement y and yaw psi relative to the track are drawn
# times a factor, the same for both (a body's lateral motion and the yaw that steers it keep
# their proportion) and for every body (the suspension's deflections scale with them). The
# factor shows the run's largest |y| as up to EXAGGERATED_REACH of b (half of b: a quarter of
# the gauge, 0.375 m on standard gauge), rounded down to 1, 2 or 5 times a power of ten so that
# it reads as a plain number; at least 1 (a run already as large draws true), at most
# MAX_EXAGGERATION (a run at rest, or round-off, is not blown up to fill the view).
EXAGGERATED_REACH = 0.5  # of wheelset.contact_half_spacing
MAX_EXAGGERATION = 100.0

# The window the plots open on: WINDOW_CYCLES cycles of the motion's frequency (the highest
# peak of the wheelsets' lateral velocity's spectrum), kept within WINDOW_SPAN (s), its moment
# (the first flange strike, or the largest lateral motion) WINDOW_LEAD of the way in, so that
# the growth before it shows and more of the motion after it. 4 s hold 20 cycles of hunting at
# 5 Hz, each some 20 pixels wide in a plot of the grid: the shape of each cycle shows, where the
# whole of a 23 s run draws a solid band. Slower motions get longer windows, up to 10 s.
WINDOW_CYCLES = 10
WINDOW_SPAN = (4.0, 10.0)  # s
WINDOW_LEAD = 0.25

# A legend's box, as fractions of its plot (a grid plot of about 450 x 250 pixels; egui draws a
# legend row about 20 pixels high, a label of 20 characters about 130 pixels wide). A legend goes
# in the first corner (right top, left top, right bottom, left bottom) in which no sample of the
# window the plot opens on falls; in none, it is hidden (the series are named on hover, and the
# notes give the colours' key).
LEGEND_WIDTH = 0.35
LEGEND_ROW = 0.08
LEGEND_MARGIN = 0.06
LEGEND_CORNERS = (
    (rrb.Corner2D.RightTop, "right", "top"),
    (rrb.Corner2D.LeftTop, "left", "top"),
    (rrb.Corner2D.RightBottom, "right", "bottom"),
    (rrb.Corner2D.LeftBottom, "left", "bottom"),
)
EXAGGERATION_PATH = "/exaggeration"


def flange_path(i: int) -> str:
    return f"/flange/wheelset{i + 1}"


def lateral_path(i: int) -> str:
    return f"/lateral/wheelset{i + 1}"


def yaw_path(i: int) -> str:
    return f"/yaw/wheelset{i + 1}"


def guiding_path(i: int) -> str:
    return f"/guiding/wheelset{i + 1}"


def curvature_path(i: int) -> str:
    return f"/track/curvature/wheelset{i + 1}"


def cant_path(i: int) -> str:
    return f"/track/cant/wheelset{i + 1}"


SPEED_PATH = "/vehicle/speed"


def wear_path(i: int, side: str) -> str:
    """Each wheel's wear number T-gamma on a curved track; `side`: left or right."""
    return f"/wear/wheelset{i + 1}/{side}"


def frame_lateral_path(name: str) -> str:
    """`name` one of `Run.frame_names`: bogie1, ..., carbody."""
    return f"/lateral/{name}"


def frame_yaw_path(name: str) -> str:
    return f"/yaw/{name}"


def frame_roll_path(name: str) -> str:
    return f"/roll/{name}"


def frame_bounce_path(name: str) -> str:
    return f"/bounce/{name}"


def wheel_load_path(i: int, side: str) -> str:
    """`side`: left or right."""
    return f"/wheel_load/wheelset{i + 1}/{side}"


def quotient_path(i: int, side: str) -> str:
    return f"/y_over_q/wheelset{i + 1}/{side}"


def sample_rate(run: Run) -> float:
    """The run's own sampling rate, samples/s."""
    return 1.0 / (run.t[1] - run.t[0]) if len(run.t) > 1 else math.inf


def recording_rate(run: Run) -> float:
    """The automatic recording rate of `run`, samples/s: SAMPLES_PER_CYCLE times the
    frequency below which MOTION_POWER of the power of the wheelsets' lateral velocity
    lies, at least FLOOR_RATE (see the comment above MOTION_POWER); raised to the run's
    own rate divided by a whole number, at most the run's own rate."""
    fs = sample_rate(run)
    if not math.isfinite(fs):
        return fs
    velocity = run.wheelset_rates[..., 0]
    power = np.sum(np.abs(np.fft.rfft(velocity, axis=0)) ** 2, axis=1)
    cumulative = np.cumsum(power)
    f_motion = 0.0  # no motion at all
    if cumulative[-1] > 0:
        frequencies = np.fft.rfftfreq(len(velocity), 1.0 / fs)
        f_motion = float(frequencies[np.searchsorted(cumulative, MOTION_POWER * cumulative[-1])])
    return fs / _stride(fs, max(FLOOR_RATE, SAMPLES_PER_CYCLE * f_motion))


def _stride(fs: float, rate: float) -> int:
    """Keep one sample in this many for at least `rate` samples/s out of `fs`."""
    # Capped at a billion samples: a rate so low (1e-308 /s) that one sample spans the run.
    if rate <= fs * 1e-9:
        return 10**9
    return max(1, math.floor(fs / rate * (1 + 1e-9)))  # 1e-9: 1000/(1000/3) is 3, not 2.99..


def recorded_samples(run: Run, rate: float | None = None) -> np.ndarray:
    """Indices of the samples of `run` a recording at `rate` keeps: one in every
    `stride`, the most that gives at least `rate` samples/s, and the last sample.
    `rate`: samples/s, None for `recording_rate(run)`, math.inf for every sample."""
    if rate is not None and not rate > 0:  # also NaN
        raise ValueError(f"recording rate must be a positive number of samples per second, got {rate}")
    fs = sample_rate(run)
    if rate is None:
        rate = recording_rate(run)
    stride = min(_stride(fs, rate), max(1, len(run.t) - 1)) if math.isfinite(fs) else 1  # at least both ends
    keep = np.arange(0, len(run.t), stride)
    if keep[-1] != len(run.t) - 1:
        keep = np.append(keep, len(run.t) - 1)
    return keep


def exaggeration(run: Run) -> float:
    """The 3D view's automatic exaggeration of lateral motion and yaw: the run's largest |y| (of
    any wheelset, bogie frame or car body, relative to the track) drawn as up to
    EXAGGERATED_REACH of b, the factor 1, 2 or 5 times a power of ten, from 1 to
    MAX_EXAGGERATION (see the comment above EXAGGERATED_REACH)."""
    largest = float(np.max(np.abs(run.y), initial=0.0))
    if run.frame_names:
        largest = max(largest, float(np.max(np.abs(run.frame_y), initial=0.0)))
    if not largest > 0.0:  # at rest (or not a number): nothing to enlarge
        return 1.0
    wanted = min(EXAGGERATED_REACH * run.layout.wheelset.contact_half_spacing / largest, MAX_EXAGGERATION)
    if wanted <= 1.0:
        return 1.0
    decade = 10.0 ** math.floor(math.log10(wanted))
    return max(m * decade for m in (1.0, 2.0, 5.0) if m * decade <= wanted * (1 + 1e-9))


def _factor(run: Run, factor: float | None) -> float:
    """`factor` checked (EXAGGERATION_LIMITS), or the automatic one for None."""
    if factor is None:
        return exaggeration(run)
    lo, hi = EXAGGERATION_LIMITS
    if not lo <= factor <= hi:  # also NaN
        raise ValueError(f"the exaggeration must be a number from {lo:g} (true size) to {hi:g}, got {factor}")
    return float(factor)


def exaggerated_poses(run: Run, keep: np.ndarray, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Every body's pose at the samples `keep` in the moving (track-following) frame, positions
    (m) and MuJoCo (w, x, y, z) quaternions, its lateral displacement y and yaw psi `factor` times
    their size. The yaw: a turn by (factor - 1) psi about z before the body's own rotation
    R = Rz(psi) Rx(phi) Ry(theta) (rail_mj.vehicle.joints) makes it Rz(factor psi) Rx(phi) Ry(theta):
    a spatial body's roll and pitch stay true. The odometer (a curved track's) is no body drawn."""
    pos, quat = run.body_pos[keep].copy(), run.body_quat[keep].copy()
    if factor == 1.0:
        return pos, quat
    model = run.vehicle.model
    bodies = [b for b in range(1, model.nbody) if model.body(b).name != ODOMETER]
    pos[:, bodies, 1] *= factor
    w, x, y, z = (quat[:, bodies, k] for k in range(4))
    psi = np.arctan2(-2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z))  # as Run.frame_psi reads it
    c, s = np.cos(0.5 * (factor - 1.0) * psi), np.sin(0.5 * (factor - 1.0) * psi)
    # (c, 0, 0, s) * (w, x, y, z), the turn about z first in the product: applied after R.
    quat[:, bodies] = np.stack([c * w - s * z, c * x - s * y, c * y + s * x, c * z + s * w], axis=-1)
    return pos, quat


class Window(NamedTuple):
    """The samples the plots open on, `start` to `end` (inclusive), around the sample `moment`."""

    start: int
    end: int
    moment: int
    reason: str  # what happens at `moment`, for the notes


def review_window(run: Run) -> Window | None:
    """The few seconds the plots open on (see WINDOW_CYCLES): around the first flange strike
    when the run has flange contact and strikes, else around the largest lateral motion of a
    wheelset (the start, for a disturbance that dies away; the end, for one that grows); None
    when the run is no longer than the window (the plots then show the whole of it)."""
    t = run.t
    if len(t) < 2:
        return None
    strikes = flange_strikes(run) if _flanges(run) else []
    if strikes:
        first = min(strikes, key=lambda s: s.start)
        moment, reason = first.start, f"the first flange strike (wheelset {first.wheelset + 1})"
    else:
        moment, reason = int(np.argmax(np.max(np.abs(run.y), axis=1))), "the largest lateral motion of a wheelset"
    frequency = dominant_frequency(t, run.wheelset_rates[..., 0])
    low, high = WINDOW_SPAN
    span = min(max(WINDOW_CYCLES / frequency, low), high) if frequency > 0 else low
    if t[-1] - t[0] <= span:
        return None
    begin = min(max(t[moment] - WINDOW_LEAD * span, t[0]), t[-1] - span)
    start = int(np.searchsorted(t, begin - 1e-9))
    end = int(np.searchsorted(t, t[start] + span + 1e-9)) - 1
    return Window(start, end, moment, reason)


def _visible_ranges(run: Run, window: Window | None) -> list[rrb.VisibleTimeRange] | None:
    """The window on both timelines, time (s) and distance (mm); None: the whole run."""
    if window is None:
        return None
    start, end = window.start, window.end
    millimetres = np.round(run.x[[start, end]] * MM_PER_M).astype(np.int64)
    return [
        rrb.VisibleTimeRange(
            TIME,
            start=rr.TimeRangeBoundary.absolute(seconds=float(run.t[start])),
            end=rr.TimeRangeBoundary.absolute(seconds=float(run.t[end])),
        ),
        rrb.VisibleTimeRange(
            DISTANCE,
            start=rr.TimeRangeBoundary.absolute(seq=int(millimetres[0])),
            end=rr.TimeRangeBoundary.absolute(seq=int(millimetres[1])),
        ),
    ]


def legend_corner(plot: Plot, run: Run, window: Window | None) -> rrb.Corner2D | None:
    """Where `plot`'s legend covers no data: the first of LEGEND_CORNERS whose box (LEGEND_WIDTH
    wide, LEGEND_MARGIN plus LEGEND_ROW a series high) no sample of `window` (the whole run for
    None) falls in, on the plot's y range (`axis_range`); None: every corner holds data."""
    height = LEGEND_MARGIN + LEGEND_ROW * len(plot.series)
    if height >= 1.0 or not plot.series:
        return None
    samples = slice(window.start, window.end + 1) if window is not None else slice(None)
    t = run.t[samples]
    across = (t - t[0]) / (t[-1] - t[0]) if len(t) > 1 else np.zeros(len(t))
    low, high = axis_range([s.values for s in plot.series], plot.floor, plot.positive)
    level = (np.stack([s.values[samples] for s in plot.series]) - low) / (high - low)  # NaN: no sample
    for corner, side, end in LEGEND_CORNERS:
        columns = across >= 1.0 - LEGEND_WIDTH if side == "right" else across <= LEGEND_WIDTH
        rows = level >= 1.0 - height if end == "top" else level <= height
        if not np.any(rows[:, columns]):
            return corner
    return None


class Series(NamedTuple):
    """One plotted series: entity path, legend label, colour and its values at every
    sample of the run, in review units."""

    path: str
    label: str
    colour: tuple[int, int, int]
    values: np.ndarray


class Plot(NamedTuple):
    title: str
    series: list[Series]
    # The y range's least half-height (review units): motions far below it are round-off (a spatial
    # vehicle's bounce on smooth track: 6e-4 mm, the spring lengths' 6 figures), not worth a full plot.
    floor: float = 0.0
    positive: bool = False  # a quantity that is never negative (a wheel load): the range from 0


def plots(run: Run) -> list[Plot]:
    """What the plots show, in the order of the blueprint's grid (row by row, three
    columns: lateral, yaw, forces; wheelsets above, bogies and car body below; for a train,
    each car's body, bogies and wheelsets, lateral and yaw, a pair of plots per car)."""
    forces = run.contact_forces()
    y, psi = run.y, run.psi
    wheelsets = [(f"wheelset {i + 1}", PALETTE[i % len(PALETTE)]) for i in range(run.n_wheelsets)]
    frames = [
        ("car body", CARBODY_COLOUR)
        if name == "carbody"
        else (name.replace("carbody", "car body "), CARBODY_COLOUR)
        if name.startswith("carbody")
        else (name.replace("bogie", "bogie "), PALETTE[k % len(PALETTE)])
        for k, name in enumerate(run.frame_names)
    ]

    def wheelset_series(path, unit, values):
        return [
            Series(path(i), f"{label} ({unit})", colour, values[:, i]) for i, (label, colour) in enumerate(wheelsets)
        ]

    def frame_series(path, unit, values):
        return [
            Series(path(name), f"{label} ({unit})", colour, values[:, k])
            for k, (name, (label, colour)) in enumerate(zip(run.frame_names, frames))
        ]

    out = [
        Plot("Wheelsets: lateral y (mm)", wheelset_series(lateral_path, "mm", y * MM_PER_M)),
        Plot("Wheelsets: yaw ψ (mrad)", wheelset_series(yaw_path, "mrad", psi * MRAD_PER_RAD)),
        Plot("Wheelsets: ΣY guiding force (kN)", wheelset_series(guiding_path, "kN", forces.lateral / N_PER_KN)),
    ]
    train = run.layout.train
    if train is not None:  # a train: each car's body, bogies and wheelsets together
        bogie = run.layout.bogie
        assert bogie is not None, "a train's cars rest on bogies (the layout reader refuses one without)"
        per_bogie = len(bogie.wheelset_positions)
        lateral = frame_series(frame_lateral_path, "mm", run.frame_y * MM_PER_M)
        yaw = frame_series(frame_yaw_path, "mrad", run.frame_psi * MRAD_PER_RAD)
        wheel_lateral, wheel_yaw = out[0].series, out[1].series
        index = {name: k for k, name in enumerate(run.frame_names)}
        for k, car in enumerate(train.cars, start=1):
            mine = [index[f"carbody{k}"]] + [index[f"bogie{b}"] for b in car.bogies]
            axles = [(b - 1) * per_bogie + j for b in car.bogies for j in range(per_bogie)]
            out += [
                Plot(f"Car {k}: lateral y (mm)", [lateral[m] for m in mine] + [wheel_lateral[i] for i in axles]),
                Plot(f"Car {k}: yaw ψ (mrad)", [yaw[m] for m in mine] + [wheel_yaw[i] for i in axles]),
            ]
    elif run.frame_names:
        out += [
            Plot("Bogies, car body: lateral y (mm)", frame_series(frame_lateral_path, "mm", run.frame_y * MM_PER_M)),
            Plot("Bogies, car body: yaw ψ (mrad)", frame_series(frame_yaw_path, "mrad", run.frame_psi * MRAD_PER_RAD)),
        ]
    if run.layout.spatial is not None:  # what the spatial vehicle adds: roll, bounce, wheel loads
        out += [
            Plot(
                "Bogies, car body: roll φ (mrad)",
                frame_series(frame_roll_path, "mrad", run.frame_roll * MRAD_PER_RAD),
                floor=0.1,
            ),
            Plot(
                "Bogies, car body: bounce z (mm)",
                frame_series(frame_bounce_path, "mm", run.frame_bounce * MM_PER_M),
                floor=0.1,
            ),
        ]
        out += _wheel_plots(run, wheelsets)
    if run.track is not None:  # the curve under each wheelset, which its lateral and yaw follow
        out += [
            Plot(
                "Track under the wheelsets: curvature (1/km)",
                wheelset_series(curvature_path, "1/km", run.wheelset_curvature * 1e3),
            ),
            Plot(
                "Track under the wheelsets: cant (mm)",
                wheelset_series(cant_path, "mm", run.track.cant(run.wheelset_station) * MM_PER_M),
            ),
            Plot(
                "Wheels: wear number Tγ (N)",
                _wheel_series(wheelsets, wear_path, "N", np.stack([forces.wear_left, forces.wear_right], axis=-1)),
                positive=True,
            ),
        ]
    out += _irregular_plots(run, wheelset_series)
    if run.profile is not None:  # a speed that changes: what the motion's growth and decay follow
        out.append(Plot("Vehicle: speed (m/s)", [Series(SPEED_PATH, "speed (m/s)", CARBODY_COLOUR, run.speeds)]))
    match contact_model(run.layout):
        case Profiled():  # the normal forces: gravitational stiffness and the flange
            out.append(
                Plot(
                    "Wheelsets: normal forces, lateral part (kN)",
                    wheelset_series(flange_path, "kN", forces.flange_lateral / N_PER_KN),
                )
            )
        case Coned(flange=Flange()):
            out.append(
                Plot(
                    "Wheelsets: flange force (kN)", wheelset_series(flange_path, "kN", forces.flange_lateral / N_PER_KN)
                )
            )
    return out


def rails_path(channel: str, i: int) -> str:
    return f"/track/{channel}/wheelset{i + 1}"


def floor_path(what: str, point: str) -> str:
    return f"/ride/{what}/{point}"


def _irregular_plots(run: Run, wheelset_series) -> list[Plot]:
    """On irregular track: the rails under each wheelset (alignment; level too on a spatial vehicle),
    the car body's floor accelerations above each bogie and at its centre, and the continuous comfort
    N_C laterally (rail_mj.analysis.ride)."""
    from rail_mj.analysis.ride import WB, WD, continuous_comfort
    from rail_mj.vehicle.rails import ALIGNMENT, LEVEL

    rails = run.rails
    if rails is None:
        return []
    at = rails.at(run.wheelset_station)
    out = [
        Plot(
            "Rails under the wheelsets: alignment (mm)",
            wheelset_series(lambda i: rails_path("alignment", i), "mm", at[..., ALIGNMENT] * MM_PER_M),
        )
    ]
    if rails.vertical:
        out.append(
            Plot(
                "Rails under the wheelsets: level (mm)",
                wheelset_series(lambda i: rails_path("level", i), "mm", at[..., LEVEL] * MM_PER_M),
            )
        )
    floor = run.floor_accelerations()
    if floor is None:
        return out
    colours = [PALETTE[k % len(PALETTE)] for k in range(len(floor.names) - 1)] + [CARBODY_COLOUR]

    def points(what: str, label: str, values) -> list[Series]:
        return [
            Series(floor_path(what, name), f"{name} ({label})", colour, values[:, k])
            for k, (name, colour) in enumerate(zip(floor.names, colours))
        ]

    out.append(Plot("Car body floor: lateral acceleration (m/s²)", points("lateral", "m/s²", floor.lateral)))
    comfort = np.column_stack([continuous_comfort(floor.lateral[:, k], floor.fs, WD) for k in range(len(floor.names))])
    if floor.vertical is not None:
        out.append(Plot("Car body floor: vertical acceleration (m/s²)", points("vertical", "m/s²", floor.vertical)))
        vertical = [continuous_comfort(floor.vertical[:, k], floor.fs, WB) for k in range(len(floor.names))]
        out.append(
            Plot(
                "Ride comfort: continuous N_CZ (EN 12299, 5 s)",
                points("comfort_vertical", "N_CZ", np.column_stack(vertical)),
                positive=True,
            )
        )
    out.append(
        Plot("Ride comfort: continuous N_CY (EN 12299, 5 s)", points("comfort_lateral", "N_CY", comfort), positive=True)
    )
    return out


def _wheel_plots(run: Run, wheelsets: list[tuple[str, tuple[int, int, int]]]) -> list[Plot]:
    """Each wheel's vertical load Q and derailment quotient Y/Q (EN 14363's limit in the title),
    the right wheel a darker shade of its wheelset's colour."""
    from rail_mj.analysis.en14363 import Y_OVER_Q_LIMIT, derailment_quotients

    loads, quotients = run.wheel_loads(), derailment_quotients(run)
    return [
        Plot(
            "Wheels: vertical load Q (kN)",
            _wheel_series(wheelsets, wheel_load_path, "kN", loads / N_PER_KN),
            positive=True,
        ),
        Plot(
            f"Wheels: derailment quotient Y/Q (limit {Y_OVER_Q_LIMIT:g})",
            _wheel_series(wheelsets, quotient_path, "", quotients),
        ),
    ]


def _wheel_series(wheelsets: list[tuple[str, tuple[int, int, int]]], path, unit: str, values) -> list[Series]:
    """A series per wheel, `values` (n_samples, n_wheelsets, 2) left then right, the right wheel
    a darker shade of its wheelset's colour."""
    out = []
    for i, (label, colour) in enumerate(wheelsets):
        for k, side in enumerate(("left", "right")):
            shade = colour if k == 0 else _darker(colour)
            out.append(
                Series(path(i, side), f"{label} {side} ({unit})" if unit else f"{label} {side}", shade, values[:, i, k])
            )
    return out


def _darker(colour: tuple[int, int, int]) -> tuple[int, int, int]:
    """A darker shade of `colour` (a wheelset's right wheel)."""
    r, g, b = colour
    return int(0.55 * r), int(0.55 * g), int(0.55 * b)


def axis_range(values, floor: float = 0.0, positive: bool = False) -> list[float]:
    """A y range symmetric about 0 (the track's centre line, no force), its edge a round
    number just past the largest |value|. egui's plots label only multiples of powers of
    ten, at least 20 points apart: a range like +-8 in a short plot gets a lone "0" label,
    and +-10 gets three. Edges of 1, 1.5, 2, 3, 4, 5 or 6 times a power of ten give 3 to
    13 labels."""
    finite = [np.abs(v[np.isfinite(v)]) for v in values]
    peak = max(1.05 * max((float(np.max(v)) for v in finite if len(v)), default=0.0), floor)
    if not (peak > 0 and math.isfinite(peak)):
        return [0.0, 1.0] if positive else [-1.0, 1.0]
    decade = 10.0 ** math.floor(math.log10(peak))
    edge = next(m * decade for m in AXIS_EDGES if m * decade >= peak)
    return [0.0, edge] if positive else [-edge, edge]


def blueprint(run: Run, shown: list[Plot], factor: float | None, window: Window | None) -> rrb.Blueprint:
    """The default layout: the plots `shown` (`plots(run)`) in a grid on the left, each
    opening on `review_window(run)` on both timelines, its legend where it covers no data
    (`legend_corner`); on the right the 3D view, its camera following the vehicle, lateral
    motion and yaw exaggerated `factor` times (None: `exaggeration(run)`) as its name says,
    above the layout and the flange strikes. The time panel marks the window (`window`,
    `review_window(run)`, found once by the caller)."""
    factor = _factor(run, factor)
    ranges = _visible_ranges(run, window)
    views = []
    for p in shown:
        corner = legend_corner(p, run, window)
        views.append(
            rrb.TimeSeriesView(
                origin="/",
                contents=[s.path for s in p.series],
                name=p.title,
                plot_legend=rrb.PlotLegend(corner=corner or rrb.Corner2D.RightTop, visible=corner is not None),
                axis_y=rrb.ScalarAxis(range=axis_range([s.values for s in p.series], p.floor, p.positive)),
                # The x axis is left to Rerun, which fits it to the data the visible range holds.
                time_ranges=ranges,
            )
        )
    notes: list[rrb.View] = [rrb.TextDocumentView(origin="/layout", name="Layout and run")]
    if _flanges(run):
        notes.append(rrb.TextLogView(origin=FLANGE_EVENTS, name="Flange strikes"))
    extent = _extent(run)
    centre = extent.mean(axis=0) + [float(run.x[0]), 0.0, 0.0]
    # The camera follows the vehicle (tracking its extent, see log_vehicle), from its right,
    # ahead of it and a little above, far enough to take in its length.
    distance = max(CAMERA_DISTANCE * float(np.ptp(extent[:, 0])), CAMERA_MIN_DISTANCE)
    direction = np.array(CAMERA_DIRECTION) / np.linalg.norm(CAMERA_DIRECTION)
    eye = rrb.EyeControls3D(
        kind=rrb.Eye3DKind.Orbital,
        position=centre + distance * direction,
        look_target=centre,
        eye_up=[0.0, 0.0, 1.0],
        tracking_entity=_extent_path(run),
    )
    time_panel = rrb.TimePanel(
        state="collapsed",
        timeline=TIME,
        time_selection=None
        if window is None
        else AbsoluteTimeRange(TimeInt(seconds=float(run.t[window.start])), TimeInt(seconds=float(run.t[window.end]))),
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Grid(*views, grid_columns=3 if len(views) > 4 else 2),
            rrb.Vertical(
                rrb.Spatial3DView(origin="/world", name=view_name(factor), eye_controls=eye),
                rrb.Tabs(*notes),
                row_shares=[3, 2],
            ),
            column_shares=[2, 1],
        ),
        time_panel,
        collapse_panels=True,
    )


def view_name(factor: float) -> str:
    """The 3D view's name, which states its exaggeration."""
    if factor == 1.0:
        return "Vehicle on the track, true size (the camera follows it)"
    return f"Vehicle on the track, lateral motion and yaw ×{factor:g} (the camera follows it)"


def exaggeration_text(factor: float) -> str:
    """What the 3D view exaggerates (logged at EXAGGERATION_PATH and in the notes)."""
    if factor == 1.0:
        return "The 3D view draws every body's motion at its true size."
    return (
        f"The 3D view draws every body's lateral displacement and yaw relative to the track "
        f"{factor:g} times their size (`--exaggerate`), and on irregular track the rails' alignment and "
        f"gauge too (their level and cross level, as the vertical motion, at true size); the plots show "
        f"true values."
    )


def _layout_text(run: Run, keep: np.ndarray, factor: float, shown: list[Plot], window: Window | None) -> str:
    try:
        source = Path(run.layout.source).read_text(encoding="utf-8")
    except OSError:
        source = repr(run.layout)
    every = int(keep[1] - keep[0]) if len(keep) > 1 else 1
    rate = sample_rate(run) / every
    return (
        f"# {run.layout.name}\n\n"
        f"speed {_speed_text(run)}, distance {run.x[-1]:g} m, timestep {run.timestep:.4g} s\n\n"
        f"recorded at {rate:.4g} samples/s, one in {every} of the run's samples (the CSV of "
        f"`rail-mj run --out` has them all)\n\n"
        f"{exaggeration_text(factor)}\n\n"
        f"{_window_text(run, window)}\n\n"
        f"{_key_text(shown)}\n\n"
        f"```toml\n{source}\n```\n"
    )


def _window_text(run: Run, window: Window | None) -> str:
    if window is None:
        return "The plots show the whole run."
    start, end, moment = window.start, window.end, window.moment
    return (
        f"The plots open on t = {run.t[start]:.2f} to {run.t[end]:.2f} s (x = {run.x[start]:.0f} to "
        f"{run.x[end]:.0f} m), around {window.reason} at t = {run.t[moment]:.2f} s, x = {run.x[moment]:.1f} m; "
        f"the time panel marks the window. For the whole run, set a plot's visible time range to its "
        f"default (selection panel)."
    )


def _key_text(shown: list[Plot]) -> str:
    """The colours' key: the wheelsets' (and bogies'), which a plot whose legend is hidden keeps."""
    names = {**dict(zip(PALETTE, COLOUR_NAMES)), CARBODY_COLOUR: "white"}
    seen: dict[str, str] = {}
    for s in (s for p in shown for s in p.series):
        label = s.label.split(" (")[0]  # "wheelset 1 (mm)": "wheelset 1"; a wheel's ends "left" or "right"
        if label.startswith(("wheelset", "bogie", "car body")) and not label.endswith(("left", "right")):
            seen.setdefault(label, names[s.colour])
    parts = [f"{label} {colour}" for label, colour in seen.items()]
    return (
        f"Colours, the same in every plot: {', '.join(parts)}; a right wheel a darker shade of its "
        f"wheelset's. Plots without a legend (none of their corners free of data) name each line on hover."
    )


def _speed_text(run: Run) -> str:
    if run.profile is None:
        return f"{run.speed:g} m/s"
    points = ", ".join(f"{v:g} m/s at {s:g} m" for s, v in zip(run.profile.stations, run.profile.speeds, strict=True))
    return f"{run.speeds[0]:.4g} to {run.speeds[-1]:.4g} m/s along the profile {points}"


def log_run(rec: rr.RecordingStream, run: Run, rate: float | None = None, exaggeration: float | None = None) -> None:
    """Log a run into an open recording, at `rate` (see `recorded_samples`), the 3D view's
    lateral motion and yaw `exaggeration` times their size (None: `exaggeration(run)`): static
    data once, the series in column batches."""
    _log_samples(rec, run, recorded_samples(run, rate), plots(run), _factor(run, exaggeration), review_window(run))


def _log_samples(
    rec: rr.RecordingStream, run: Run, keep: np.ndarray, shown: list[Plot], factor: float, window: Window | None
) -> None:
    text = _layout_text(run, keep, factor, shown, window)
    rec.log("/layout", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN), static=True)
    rec.log(EXAGGERATION_PATH, rr.TextDocument(exaggeration_text(factor)), static=True)
    indexes = [
        rr.TimeColumn(TIME, duration=run.t[keep]),
        rr.TimeColumn(DISTANCE, sequence=np.round(run.x[keep] * 1000.0).astype(np.int64)),
    ]
    logged: set[str] = set()  # a series shown twice (a Jacobs bogie under two cars) is sent once
    for series in (s for p in shown for s in p.series):
        if series.path in logged:
            continue
        logged.add(series.path)
        # MinMax: zoomed out, a pixel spans cycles of hunting; the default average flattens them.
        rec.log(
            series.path,
            rr.SeriesLines(names=series.label, colors=[series.colour], aggregation_policy="MinMax"),
            static=True,
        )
        rec.send_columns(series.path, indexes=indexes, columns=rr.Scalars.columns(scalars=series.values[keep]))
    if _flanges(run):
        log_flange_strikes(rec, run)
    log_vehicle(rec, run, keep, indexes, factor)


def _flanges(run: Run) -> bool:
    """Whether the run has flange contact: [flange], or profiles (their own flanges)."""
    return contact_model(run.layout).flanged


def log_flange_strikes(rec: rr.RecordingStream, run: Run) -> None:
    """A log line each time a flange strikes a rail, found in the full run."""
    strikes = flange_strikes(run)
    if not strikes:
        return
    order = np.argsort([s.start for s in strikes], kind="stable")
    strikes = [strikes[k] for k in order]
    starts = np.array([s.start for s in strikes])
    lines = [
        f"wheelset {s.wheelset + 1} flange strikes the {'left' if s.side > 0 else 'right'} rail "
        f"at x = {run.x[s.start]:.2f} m"
        for s in strikes
    ]
    rec.send_columns(
        FLANGE_EVENTS,
        indexes=[
            rr.TimeColumn(TIME, duration=run.t[starts]),
            rr.TimeColumn(DISTANCE, sequence=np.round(run.x[starts] * 1000.0).astype(np.int64)),
        ],
        columns=rr.TextLog.columns(text=lines, level=["WARN"] * len(lines)),
    )


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions are w, x, y, z; Rerun's are x, y, z, w."""
    return np.roll(np.asarray(wxyz, dtype=float), -1, axis=-1)


def _geom_archetype(model: mujoco.MjModel, g: int):
    """The Rerun shape of one MJCF geom, in the geom's own frame; None for other types."""
    colour = (np.asarray(model.geom_rgba[g]) * 255).astype(np.uint8)
    size = model.geom_size[g]
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size], colors=[colour], fill_mode="solid")
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER:  # axis along the geom's z
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], colors=[colour])
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
        f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
        return rr.Mesh3D(
            vertex_positions=model.mesh_vert[v0 : v0 + nv],
            triangle_indices=model.mesh_face[f0 : f0 + nf],
            albedo_factor=colour,
        )
    return None


def _root(run: Run) -> str:
    """The body the others hang from (the car body), which the camera follows."""
    return run.vehicle.model.body(1).name


def _extent_path(run: Run) -> str:
    return f"/world/vehicle/{_root(run)}/extent"


def _extent(run: Run) -> np.ndarray:
    """(2, 3): the corners of the box around all the vehicle's geoms, in the moving frame,
    in the model's reference pose."""
    model = run.vehicle.model
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    corners: list[np.ndarray] = []
    for g in range(model.ngeom):
        centre, half = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        local = centre + half * np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        corners.append(data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T)
    every = np.vstack(corners)
    return np.array([every.min(axis=0), every.max(axis=0)])


def log_vehicle(rec: rr.RecordingStream, run: Run, keep: np.ndarray, indexes, factor: float = 1.0) -> None:
    """The vehicle's bodies moving along the track in 3D: geometry once, poses in columns, each
    body's lateral displacement and yaw `factor` times their size (`exaggerated_poses`).

    The model travels with the vehicle, so each pose gets the distance x = V*t added.
    The 3D view's camera tracks the vehicle's extent, two invisible points fixed to the
    root body (`_extent_path`): Rerun's camera follows an entity's own bounding box.
    """
    model = run.vehicle.model
    rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for g in range(model.ngeom):
        shape = _geom_archetype(model, g)
        body = model.body(model.geom_bodyid[g]).name
        if shape is not None:
            path = f"/world/vehicle/{body}/{model.geom(g).name}"
            rec.log(
                path,
                rr.Transform3D(translation=model.geom_pos[g], quaternion=rr.Quaternion(xyzw=_xyzw(model.geom_quat[g]))),
                static=True,
            )
            rec.log(path, shape, static=True)
    root = model.body(_root(run)).id
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rec.log(
        _extent_path(run), rr.Points3D(_extent(run) - data.xpos[root], radii=0.0, colors=[(0, 0, 0, 0)]), static=True
    )
    pos, wxyz = exaggerated_poses(run, keep, factor)
    if run.track is None:
        pos[:, :, 0] += run.x[keep, None]
        quat = _xyzw(wxyz)
    else:
        pos, quat = _on_track(run, keep, pos, wxyz)
    for b in range(1, model.nbody):
        rec.send_columns(
            f"/world/vehicle/{model.body(b).name}",
            indexes=indexes,
            columns=rr.Transform3D.columns(translation=pos[:, b], quaternion=quat[:, b]),
        )
    log_track(rec, run, factor)


def _track_frames(track: Track, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The track-following frame at distances `s` (any shape): its origin on the centreline at
    rail level in the level plane (..., 3) and its rotation (..., 3, 3), the heading about z
    and then the cant's roll of the track plane (the right rail up: -theta about x)."""
    xy = track.xy(s.reshape(-1)).reshape(*s.shape, 2)
    heading, theta = track.heading(s), -track.cant_angle(s)
    ch, sh, cr, sr = np.cos(heading), np.sin(heading), np.cos(theta), np.sin(theta)
    zero, one = np.zeros_like(ch), np.ones_like(ch)
    rz = np.stack([np.stack([ch, -sh, zero], -1), np.stack([sh, ch, zero], -1), np.stack([zero, zero, one], -1)], -2)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cr, -sr], -1), np.stack([zero, sr, cr], -1)], -2)
    return np.concatenate([xy, np.zeros((*s.shape, 1))], axis=-1), rz @ rx


def _on_track(run: Run, keep: np.ndarray, local: np.ndarray, wxyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every body's pose on the curved track (positions and xyzw quaternions, samples `keep`):
    its pose in the track-following frame (docs/track.md; `local` and `wxyz`, as
    `exaggerated_poses` gives them) carried by the track's frame at its own station."""
    assert run.track is not None
    model = run.vehicle.model
    x0 = mujoco.MjData(model)
    mujoco.mj_kinematics(model, x0)
    # Each body's station: the vehicle's, plus its own x along the vehicle (the odometer's own
    # x is the station itself).
    along = np.where(np.arange(model.nbody) == model.body(ODOMETER).id, 0.0, x0.xpos[:, 0])
    stations = run.station[keep, None] + along[None, :]
    origin, rotation = _track_frames(run.track, stations)
    local = local.copy()
    local[:, :, 0] -= along[None, :]
    local[:, model.body(ODOMETER).id] = 0.0  # drawn nowhere: it has no shape
    pos = origin + np.einsum("...ij,...j->...i", rotation, local)
    body = np.array([_matrix(q) for q in wxyz.reshape(-1, 4)]).reshape(*rotation.shape)
    quat = np.empty((*stations.shape, 4))
    mujoco_quat = np.empty(4)
    for index in np.ndindex(stations.shape):
        mujoco.mju_mat2Quat(mujoco_quat, (rotation[index] @ body[index]).reshape(-1))
        quat[index] = mujoco_quat
    return pos, _xyzw(quat)


def _matrix(wxyz: np.ndarray) -> np.ndarray:
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, wxyz)
    return out.reshape(3, 3)


def log_track(rec: rr.RecordingStream, run: Run, factor: float = 1.0) -> None:
    """The rails and the sleepers under them, along the whole run, logged once; on a curved
    track (run.track) drawn along it, turned and canted; on an irregular one each rail where its
    irregularities put it (`_irregular_rails`), laterally `factor` times, as the vehicle's lateral
    motion is drawn."""
    if run.track is not None:
        _log_curved_track(rec, run, run.track, factor)
        return
    b = run.layout.wheelset.contact_half_spacing
    start, end = float(run.x[0]) - TRACK_MARGIN, float(run.x[-1]) + TRACK_MARGIN
    length = end - start
    rec.log(
        "/world/rails",
        rr.Boxes3D(
            centers=[[start + length / 2, side * b, -0.08] for side in (1, -1)],
            half_sizes=[[length / 2, RAIL_HEAD_WIDTH / 2, 0.08]] * 2,
            colors=[[190, 190, 200]] * 2,
            fill_mode="solid",
        ),
        static=True,
    )
    x = np.arange(math.ceil(start / SLEEPER_SPACING), math.floor(end / SLEEPER_SPACING) + 1) * SLEEPER_SPACING
    rec.log(
        "/world/sleepers",
        rr.Boxes3D(
            centers=np.column_stack([x, np.zeros_like(x), np.full_like(x, -0.16 - 0.11)]),
            half_sizes=np.tile([0.13, b + 0.5, 0.11], (len(x), 1)),
            colors=[[110, 100, 90]],
            fill_mode="solid",
        ),
        static=True,
    )


def _irregular_rails(run: Run, s: np.ndarray, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Each rail's (left, right) shift from its place on perfect track at stations `s`, in the track
    frame, (2, len(s), 3), and the centreline's, (len(s), 3), as the run's irregularities put them
    (rail_mj.vehicle.rails): laterally the alignment and half the gauge's widening outwards, `factor`
    times (the wheelsets' lateral motion is drawn so, and they stay on their rails); vertically the
    level and half the cross level up on the left, at true size, as the vertical motion is drawn.
    Zero on perfect track."""
    from rail_mj.track.irregularities import RAIL_BASE
    from rail_mj.vehicle.rails import ALIGNMENT, GAUGE, LEVEL, ROLL

    shift = np.zeros((2, len(s), 3))
    rails = run.rails
    if rails is None:
        return shift, np.zeros((len(s), 3))
    at = rails.at(s)
    for k, side in enumerate((1.0, -1.0)):
        shift[k, :, 1] = factor * (at[:, ALIGNMENT] + side * at[:, GAUGE] / 2)
        shift[k, :, 2] = at[:, LEVEL] + side * at[:, ROLL] * RAIL_BASE / 2
    return shift, shift.mean(axis=0)


def _log_curved_track(rec: rr.RecordingStream, run: Run, track: Track, factor: float = 1.0) -> None:
    b = run.layout.wheelset.contact_half_spacing
    reach = np.abs(np.asarray(run.layout.wheelset_x)).max() + TRACK_MARGIN
    start, end = float(run.station[0]) - reach, float(run.station[-1]) + reach
    s = np.arange(math.ceil(start / SLEEPER_SPACING), math.floor(end / SLEEPER_SPACING) + 1) * SLEEPER_SPACING
    origin, rotation = _track_frames(track, s)
    shift, centre = _irregular_rails(run, s, factor)
    rails = [
        origin + np.einsum("nij,nj->ni", rotation, np.array([0.0, side * b, -0.08]) + shift[k])
        for k, side in enumerate((1, -1))
    ]
    rec.log(
        "/world/rails",
        rr.LineStrips3D(rails, radii=RAIL_HEAD_WIDTH / 2, colors=[[190, 190, 200]]),
        static=True,
    )
    quat = np.empty((len(s), 4))
    one = np.empty(4)
    for k in range(len(s)):
        mujoco.mju_mat2Quat(one, rotation[k].reshape(-1))
        quat[k] = one
    rec.log(
        "/world/sleepers",
        rr.Boxes3D(
            centers=origin + np.einsum("nij,nj->ni", rotation, np.array([0.0, 0.0, -0.16 - 0.11]) + centre),
            half_sizes=np.tile([0.13, b + 0.5, 0.11], (len(s), 1)),
            quaternions=_xyzw(quat),
            colors=[[110, 100, 90]],
            fill_mode="solid",
        ),
        static=True,
    )


def save_recording(run: Run, path: str | Path, rate: float | None = None, exaggeration: float | None = None) -> None:
    """Write `run` to an .rrd file at `path` (use `write_recording` for a safe write), at
    `rate` samples/s: None for `recording_rate(run)`, math.inf for every sample; the 3D view's
    lateral motion and yaw `exaggeration` times their size: None for `exaggeration(run)`, 1 for
    true size (at most 1000)."""
    keep = recorded_samples(run, rate)  # refuse a bad rate or factor before the file is opened
    factor = _factor(run, exaggeration)
    shown = plots(run)
    # One id per recording: Rerun merges recordings that share one when opened together
    # (the runs of a sweep share a layout name and perhaps a speed).
    rec = rr.RecordingStream(APP_ID, recording_id=str(uuid.uuid4()))
    # Encoded in memory and written here, not by Rerun's file sink: a sink that cannot write
    # (a full disk) logs ERROR lines and its flush never returns, where this write raises
    # one OSError. One read at the end: the reader of 0.41 takes one stream per file.
    stream = rr.binary_stream(rec)
    window = review_window(run)  # a flange-strike search and a periodogram: once, for both
    rec.send_blueprint(blueprint(run, shown, factor, window), make_active=False, make_default=True)
    _log_samples(rec, run, keep, shown, factor, window)
    data = stream.read()
    rec.disconnect()
    if not data:  # Rerun always writes a header: nothing at all is its failure, not a recording
        raise OSError(errno.EIO, "the recording came out empty")
    Path(path).write_bytes(data)


def write_recording(run: Run, path: str | Path, rate: float | None = None, exaggeration: float | None = None) -> Path:
    """Write `run` to an .rrd file; the file appears only once it is complete. `rate` and
    `exaggeration` as for `save_recording`."""
    with staged([path]) as (tmp,):
        save_recording(run, tmp, rate, exaggeration)
    return Path(path)
