"""Nonlinear stability: limit cycles, the nonlinear critical speed and the bifurcation diagram.

With flange contact and saturating creep, hunting above the linear critical speed
grows into a limit cycle. Lowering the speed step by step, each step continuing from
the last one's state and long enough to settle, follows that limit cycle down until
it dies: the nonlinear critical speed, below the linear one (docs/flange.md).
Raising the speed from a small disturbance follows the centred branch
up to the linear critical speed, where the motion jumps onto the limit cycle.

Example (about a minute; the layout needs [flange] and a saturating creep law):

    from rail_mj import load_layout
    from rail_mj.analysis.bifurcation import nonlinear_critical_speed
    critical, branch = nonlinear_critical_speed(load_layout("models/bogie/bogie.toml"))
    critical.critical_speed, critical.linear_critical_speed   # about 63 and 80.8 m/s

tests/analysis/test_nonlinear.py runs it on a restrained wheelset.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from rail_mj.analysis import late_motion, oscillation
from rail_mj.analysis.stability import CriticalSpeed, Stability
from rail_mj.layout import Layout
from rail_mj.layout.kinds import Profiled, contact_model
from rail_mj.practice import RANGES
from rail_mj.simulation.runner import simulate
from rail_mj.track import SpeedProfile, Track
from rail_mj.track.speed import PROFILE_TRACK

# One procedure and one step for every nonlinear critical speed rail-mj reports (the
# critical-speed command, the bifurcation diagram, the README's tables): 2 % a step, so
# the answer is known to within 2 % from above.
STEP = 0.02
DWELL = 6.0  # s at each speed: tens of hunting cycles, enough for the limit cycle to settle
# A motion smaller than this fraction of the flangeway clearance has died away; one
# whose peaks shrink by more than SHRINKING over a quarter of a step is dying.
DEAD_FRACTION = 0.05
SHRINKING = 0.1


@dataclasses.dataclass
class Branch:
    """Amplitude (largest wheelset |y| over the last half of each step) against speed."""

    direction: str  # "down" (from the limit cycle) or "up" (from a small disturbance)
    speeds: list[float]
    amplitudes: list[float]  # m
    frequencies: list[float]  # Hz, of the largest wheelset motion; nan when it has died
    alive: list[bool]  # whether a settled oscillation (not a dying one) was there


def _amplitude(run, late: bool = True) -> tuple[float, float, float]:
    """(amplitude, its change from the first to the second quarter of the late half, frequency);
    not `late`: over the whole run, halves."""
    t, y = late_motion(run) if late else _largest(run)
    half = len(y) // 2
    first, second = np.max(np.abs(y[:half])), np.max(np.abs(y[half:]))
    freq, _ = oscillation(t, y)
    return float(second), float(second - first), freq


def _largest(run) -> tuple[np.ndarray, np.ndarray]:
    """(t, y) of the wheelset that moves most in `run`."""
    lead = int(np.argmax(np.max(np.abs(run.y), axis=0)))
    return run.t, run.y[:, lead]


def follow(
    layout: Layout,
    speeds,
    state=None,
    initial_lateral: float = 0.0,
    dwell: float = DWELL,
    stop_when_dead: bool = False,
    restart: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Branch:
    """Step through `speeds`, each run continuing from the previous one's final state
    (or, with `restart`, each from the initial disturbance afresh). `progress` is told
    each step's result, one short line."""
    direction = "down" if speeds[-1] < speeds[0] else "small disturbance" if restart else "up"
    branch = Branch(direction, [], [], [], [])
    dead = DEAD_FRACTION * layout.wheelset.flangeway_clearance
    for v in speeds:
        run = simulate(layout, float(v), float(v) * dwell, initial_lateral, 1e-4 if state is None else 0.0, state=state)
        state = None if restart else run.final_state
        amplitude, change, freq = _amplitude(run)
        branch.speeds.append(float(v))
        branch.amplitudes.append(amplitude)
        branch.frequencies.append(freq)
        branch.alive.append(bool(amplitude >= dead and change >= -SHRINKING * amplitude))
        if progress is not None:
            progress(
                f"{branch.direction}: {v:.2f} m/s, amplitude {amplitude * 1e3:.2f} mm"
                f"{'' if branch.alive[-1] else ', dying'}"
            )
        if stop_when_dead and amplitude < dead and change <= 0:
            break
    return branch


def _bounded(layout: Layout):
    """The layout's contact model, if it bounds hunting in a limit cycle (flange contact and a
    saturating law); ValueError otherwise."""
    contact = contact_model(layout)
    if not contact.flanged or layout.creep.law == "linear":
        raise ValueError(
            f"{layout.source}: the nonlinear critical speed needs flange contact ([flange] or "
            f"[profiles]) and a saturating creep law: without them hunting grows without bound"
        )
    return contact


# m/s: the top of the linear critical speed's search when no vmax is given: the table of practice's
# limit on speeds (twice the wheel-on-rail record). A vehicle whose nonlinear critical speed lies
# far below its linear one (an EMU's 94 m/s under 154) starts from its linear one wherever it is.
SEARCH_LIMIT = RANGES["speed"].refuse[1]


def _linear_start(
    layout: Layout, amplitude: float | None, vmin: float, vmax: float | None
) -> tuple[CriticalSpeed, float]:
    """The linear critical speed a limit cycle is started above, searched from `vmin` to `vmax`
    (None: to SEARCH_LIMIT), and the top speed the start is held to. Where a given `vmax` is
    too low for it, the note says which vmax is needed."""
    top = SEARCH_LIMIT if vmax is None else vmax
    stability = Stability(layout, amplitude)
    linear = stability.critical_speed(vmin, top)
    if linear.critical_speed is None and linear.outcome == "stable" and top < SEARCH_LIMIT:
        beyond = stability.critical_speed(top, SEARCH_LIMIT)
        if beyond.critical_speed is not None:
            needed = 1.1 * beyond.critical_speed
            note = (
                f"{linear.note}; the linear critical speed is {beyond.critical_speed:.1f} m/s: a vmax "
                f"of {math.ceil(needed):g} m/s (1.1 times it, where the limit cycle starts) or none finds it"
            )
            linear = dataclasses.replace(linear, note=note)
    return linear, top


def _no_start(method: str, linear: CriticalSpeed, vmin: float, vmax: float, **more) -> CriticalSpeed:
    """No nonlinear critical speed: no linear one to start from, and why."""
    return CriticalSpeed(
        method,
        None,
        None,
        None,
        vmin,
        vmax,
        f"no linear critical speed to start from: {linear.note}",
        outcome=linear.outcome,
        amplitude_mm=linear.amplitude_mm,
        **more,
    )


def nonlinear_critical_speed(
    layout: Layout,
    vmin: float = 5.0,
    vmax: float | None = None,
    step: float = STEP,
    dwell: float = DWELL,
    progress: Callable[[str], None] | None = None,
    amplitude: float | None = None,
) -> tuple[CriticalSpeed, Branch | None]:
    """Lowest speed at which the hunting limit cycle survives, with the branch it followed
    (None: no linear critical speed to start from, the note says why).

    Starts at 1.1 x the linear (eigen) critical speed on the limit cycle, reached from a
    disturbance of twice the flangeway clearance, and lowers the speed by `step` (a
    fraction) per `dwell` seconds until the motion dies away. A limit cycle that dies
    before the speed falls below the linear critical speed gives no nonlinear critical
    speed (the note says so): it is never reported above the linear one.
    """
    contact = _bounded(layout)
    linear, vmax = _linear_start(layout, amplitude, vmin, vmax)
    if linear.critical_speed is None:
        return _no_start("nonlinear", linear, vmin, vmax), None
    vc = linear.critical_speed
    start = min(1.1 * linear.critical_speed, vmax)
    speeds = start * (1.0 - step) ** np.arange(int(math.log(vmin / start) / math.log(1.0 - step)) + 1)
    # Onto the flanges: twice the clearance into the flange spring, or on profiles, whose
    # flanges are rigid walls, to where they touch.
    reach = 1.0 if isinstance(contact, Profiled) else 2.0
    branch = follow(
        layout,
        speeds,
        initial_lateral=reach * layout.wheelset.flangeway_clearance,
        dwell=dwell,
        stop_when_dead=True,
        progress=progress,
    )
    alive = [k for k, ok in enumerate(branch.alive) if ok]
    if alive and alive[-1] == len(branch.alive) - 1:
        return CriticalSpeed(
            "nonlinear",
            None,
            None,
            None,
            vmin,
            vmax,
            f"the limit cycle survives down to {branch.speeds[-1]:.2f} m/s",
            linear_critical_speed=vc,
            step=step,
            outcome="unstable",
            amplitude_mm=linear.amplitude_mm,
        ), branch
    if not alive:
        return CriticalSpeed(
            "nonlinear",
            None,
            None,
            None,
            vmin,
            vmax,
            f"no limit cycle at {start:.2f} m/s",
            linear_critical_speed=vc,
            step=step,
            outcome="none",
            amplitude_mm=linear.amplitude_mm,
        ), branch
    last = alive[-1]  # the lowest speed that still carried the limit cycle
    if branch.speeds[last] > vc:
        return CriticalSpeed(
            "nonlinear",
            None,
            None,
            None,
            vmin,
            vmax,
            f"no limit cycle below the linear critical speed: it dies below "
            f"{branch.speeds[last]:.2f} m/s (steps of {step:.0%}), above "
            f"{vc:.2f} m/s, so hunting starts at the linear critical speed",
            linear_critical_speed=vc,
            step=step,
            outcome="linear",
            amplitude_mm=linear.amplitude_mm,
        ), branch
    return CriticalSpeed(
        "nonlinear",
        branch.speeds[last],
        branch.frequencies[last],
        linear.mode,
        vmin,
        vmax,
        f"the limit cycle dies below this speed (steps of {step:.0%}); the mode is the linear one at {vc:.2f} m/s",
        linear_critical_speed=vc,
        step=step,
        amplitude_mm=linear.amplitude_mm,
    ), branch


def bifurcation(
    layout: Layout,
    vmin: float = 5.0,
    vmax: float | None = None,
    step: float = STEP,
    dwell: float = DWELL,
    progress: Callable[[str], None] | None = None,
    amplitude: float | None = None,
) -> tuple[CriticalSpeed, Branch | None, Branch | None]:
    """Both branches of the bifurcation diagram around the linear critical speed Vc:
    down from the limit cycle at 1.1*Vc until it dies, and, at the same speeds, runs from
    a small disturbance (5 % of the clearance) for twice as long, which decay below Vc
    and grow onto the limit cycle above it. Between the two critical speeds both the
    centred state and the limit cycle are stable: the hysteresis of hunting. Without a
    linear critical speed to start from, both branches are None (the note says why)."""
    critical, down = nonlinear_critical_speed(layout, vmin, vmax, step, dwell, progress, amplitude)
    if down is None:
        return critical, None, None
    low = down.speeds[-1] * (1.0 - step) ** np.arange(3, 0, -1)  # a little below where it died
    speeds = [float(v) for v in low if v >= vmin] + down.speeds[::-1]
    up = follow(
        layout,
        speeds,
        initial_lateral=DEAD_FRACTION * layout.wheelset.flangeway_clearance,
        dwell=2 * dwell,
        restart=True,
        progress=progress,
    )
    return critical, down, up


# The ramp: a practitioner's other nonlinear critical speed (a vehicle braked slowly through
# it on a long straight, as a line test or a simulation in SIMPACK or GENSYS is run), one
# speed profile instead of the staircase. A slow deceleration keeps the limit cycle settled:
# its collapse lags the fold by the time it takes (a few seconds) times the deceleration,
# so the ramp's answer lies below the staircase's by about that (docs/track.md measures it).
RAMP_DECELERATION = 0.1  # m/s^2: 0.5 % of the speed per second at 70 m/s
RAMP_SETTLE = 3.0  # s at the starting speed, for the limit cycle to form from the disturbance
RAMP_CHUNK = 1.0  # s a piece of the ramp, continued from the last: the amplitude's window
RAMP_STEADY = 0.02  # a piece's amplitude within 2 % of the last one's: the cycle has not begun to collapse
RAMP_POINT = 0.005  # relative: the profile's points, V^2 = V0^2 - 2*a*s, every 0.5 % in speed


def deceleration_profile(start: float, end: float, deceleration: float, settle: float = RAMP_SETTLE) -> SpeedProfile:
    """A speed profile (rail_mj.track.SpeedProfile) held at `start` m/s for `settle` s, then
    falling at `deceleration` m/s^2 to `end`: V^2 = V0^2 - 2*a*(s - s0), linear between points
    RAMP_POINT apart in speed, so dV/dt = V*dV/ds stays within RAMP_POINT of `deceleration`."""
    s0 = start * settle
    count = max(1, math.ceil(math.log(end / start) / math.log(1.0 - RAMP_POINT)))
    speeds = start * (1.0 - RAMP_POINT) ** np.arange(count + 1)
    speeds[-1] = end
    stations = s0 + (start**2 - speeds**2) / (2.0 * deceleration)
    return SpeedProfile(
        (0.0, *map(float, stations)),
        (float(start), *map(float, speeds)),
        f"<deceleration {deceleration:g} m/s^2 from {start:g} to {end:g} m/s>",
    )


def ramp_critical_speed(
    layout: Layout,
    vmin: float = 5.0,
    vmax: float | None = None,
    deceleration: float = RAMP_DECELERATION,
    progress: Callable[[str], None] | None = None,
    amplitude: float | None = None,
) -> tuple[CriticalSpeed, Branch | None]:
    """The speed at which the hunting limit cycle dies as the vehicle is braked through it at
    `deceleration` m/s^2, with the amplitude and frequency each RAMP_CHUNK s against speed
    (None: no linear critical speed to start from, the note says why).

    Starts as `nonlinear_critical_speed` does, on the limit cycle at 1.1 x the linear critical
    speed, holds that speed RAMP_SETTLE s and then brakes down to `vmin`, one run continued
    piece by piece along one speed profile, until the motion has died (below DEAD_FRACTION of
    the flangeway clearance). The critical speed is the speed at the end of the last piece that
    still carried a settled limit cycle, as the staircase's steps are judged (its peaks not
    shrinking by more than SHRINKING from the first half of the piece to the second), and the
    frequency is the cycle's before its collapse began (RAMP_STEADY).
    """
    contact = _bounded(layout)
    if not (math.isfinite(deceleration) and deceleration > 0):
        raise ValueError(f"the deceleration must be a positive number (m/s^2), got {deceleration}")
    linear, vmax = _linear_start(layout, amplitude, vmin, vmax)
    if linear.critical_speed is None:
        return _no_start("ramp", linear, vmin, vmax, deceleration=deceleration), None
    vc = linear.critical_speed
    start = min(1.1 * vc, vmax)
    profile = deceleration_profile(start, vmin, deceleration)
    # One straight track for every piece (the odometer's), past the profile's end by far more
    # than the pieces that reach vmin; no curvature: the model is the one of straight track.
    track = Track.straight(profile.stations[-1] + 100.0 * start * RAMP_CHUNK + max(layout.wheelset_x), PROFILE_TRACK)
    reach = 1.0 if isinstance(contact, Profiled) else 2.0
    dead = DEAD_FRACTION * layout.wheelset.flangeway_clearance
    branch = Branch("ramp", [], [], [], [])
    state = None
    while True:
        if state is None:  # onto the flanges, as the staircase starts
            lateral = reach * layout.wheelset.flangeway_clearance
            run = simulate(layout, profile, start * RAMP_CHUNK, lateral, 1e-4, track=track)
        else:
            run = simulate(layout, profile, float(run.speeds[-1]) * RAMP_CHUNK, state=state, track=track)
        state = run.final_state
        size, change, frequency = _amplitude(run, late=False)
        speed = float(run.speeds[-1])
        branch.speeds.append(speed)
        branch.amplitudes.append(size)
        branch.frequencies.append(frequency)
        branch.alive.append(bool(size >= dead and change >= -SHRINKING * size))
        if progress is not None:
            progress(f"ramp: {speed:.2f} m/s, amplitude {size * 1e3:.2f} mm")
        settled = run.station[-1] >= profile.stations[1]
        if (settled and size < dead) or speed <= vmin * (1.0 + 1e-9):
            break

    def result(note: str, outcome: str, critical=None, frequency=None, mode=None) -> CriticalSpeed:
        return CriticalSpeed(
            "ramp",
            critical,
            frequency,
            mode,
            vmin,
            vmax,
            note,
            linear_critical_speed=vc,
            amplitude_mm=linear.amplitude_mm,
            deceleration=deceleration,
            outcome=outcome,
        )

    alive = [k for k, ok in enumerate(branch.alive) if ok]
    if not alive:
        return result(f"no limit cycle at {start:.2f} m/s", "none"), branch
    last = alive[-1]  # the last piece that still carried a settled limit cycle
    if last == len(branch.alive) - 1:
        return result(f"the limit cycle survives down to {branch.speeds[-1]:.2f} m/s", "unstable"), branch
    critical = branch.speeds[last]
    # The frequency of the cycle before it collapses: the last piece whose amplitude is within
    # RAMP_STEADY of the one before (in the last alive pieces the cycle already shrinks and slows).
    steady = [k for k in alive if k > 0 and branch.amplitudes[k] >= (1 - RAMP_STEADY) * branch.amplitudes[k - 1]]
    frequency = branch.frequencies[steady[-1] if steady else last]
    how = f"braked at {deceleration:g} m/s^2 from {start:.2f} m/s"
    if critical > vc:
        note = (
            f"no limit cycle below the linear critical speed: {how}, it dies at {critical:.2f} m/s, "
            f"above {vc:.2f} m/s, so hunting starts at the linear critical speed"
        )
        return result(note, "linear"), branch
    note = f"the limit cycle dies at this speed, {how}; the mode is the linear one at {vc:.2f} m/s"
    return result(note, "crossing", critical, frequency, linear.mode), branch
