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
from rail_mj.simulation.runner import simulate

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


def _amplitude(run) -> tuple[float, float, float]:
    """(amplitude, its change from the first to the second quarter of the late half, frequency)."""
    t, y = late_motion(run)
    half = len(y) // 2
    first, second = np.max(np.abs(y[:half])), np.max(np.abs(y[half:]))
    freq, _ = oscillation(t, y)
    return float(second), float(second - first), freq


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


def nonlinear_critical_speed(
    layout: Layout,
    vmin: float = 5.0,
    vmax: float = 150.0,
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
    contact = contact_model(layout)
    if not contact.flanged or layout.creep.law == "linear":
        raise ValueError(
            f"{layout.source}: the nonlinear critical speed needs flange contact ([flange] or "
            f"[profiles]) and a saturating creep law: without them hunting grows without bound"
        )
    linear = Stability(layout, amplitude).critical_speed(vmin, vmax)
    if linear.critical_speed is None:
        return CriticalSpeed(
            "nonlinear",
            None,
            None,
            None,
            vmin,
            vmax,
            f"no linear critical speed to start from: {linear.note}",
            outcome=linear.outcome,
            amplitude_mm=linear.amplitude_mm,
        ), None
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
    vmax: float = 150.0,
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
