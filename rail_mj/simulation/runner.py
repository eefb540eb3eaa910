"""The headless runner: vehicles along a perfect track, straight or curved, at constant speed or
on a speed profile.

Example:

    >>> from rail_mj import load_layout, simulate
    >>> run = simulate(load_layout("models/bogie/bogie.toml"), speed=30.0, distance=60.0,
    ...                initial_lateral=0.002)
    >>> run.y.shape[1], round(float(run.x[-1]))   # two wheelsets, 60 m
    (2, 60)

`simulate` picks the timestep (rail_mj.simulation.timestep), steps MuJoCo with the native
creep callback (rail_mj.simulation.native) in chunks (rail_mj.simulation.stepping), records
every body's pose and each wheelset's rates with MuJoCo's sensors, and raises
`SimulationError` if the run diverges, numerically or physically, saying why.
`simulate_many` (rail_mj.simulation.batch) steps many runs together, packed several
vehicles to a model, each with exactly `simulate`'s result.
"""

from __future__ import annotations

import importlib
import math
import time
from collections.abc import Callable

import numpy as np

from rail_mj.layout import Layout
from rail_mj.practice import DERAILMENT_LATERAL, INITIAL_LATERAL
from rail_mj.simulation.callback import CreepForces
from rail_mj.simulation.run import Request, Run, RunRefused, SimulationError
from rail_mj.simulation.stepping import Prepared, step_alone
from rail_mj.simulation.timestep import STEP_FRACTION, stable_timestep
from rail_mj.track import SpeedProfile, Track
from rail_mj.track.speed import PROFILE_TRACK
from rail_mj.vehicle.block import set_speed
from rail_mj.vehicle.curve import ODOMETER
from rail_mj.vehicle.spec import Vehicle

MAX_STEPS = 50_000_000  # about half an hour of stepping: beyond this, refuse
# Sample intervals a thinned run keeps at least: it ends at the first kept sample at or past its
# distance, so at most a tenth further.
MIN_INTERVALS = 10


def prepare(request: Request, python_callback: bool = False) -> Prepared:
    """Check a request, build its vehicle (speed set) and choose its timestep. Raises
    ValueError for an impossible request and RunRefused for one too slow to simulate."""
    started = time.perf_counter()
    layout, speed, distance = request.layout, request.speed, request.distance
    for name, value in (("speed", speed), ("distance", distance)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value}")
    for name, value in (("initial lateral", request.initial_lateral), ("initial yaw", request.initial_yaw)):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
    if abs(request.initial_lateral) >= DERAILMENT_LATERAL:
        raise ValueError(
            f"initial lateral {request.initial_lateral} m puts the wheels off the rails "
            f"(|y| must be below {DERAILMENT_LATERAL} m)"
        )
    interval = request.sample_interval
    if interval is not None and not (math.isfinite(interval) and interval > 0):
        raise ValueError(f"sample interval must be a positive number of seconds, got {interval}")
    if request.state is not None and not (len(request.state) == 2 and all(np.ndim(v) == 1 for v in request.state)):
        raise ValueError("state must be (qpos, qvel), a run's final_state")
    track, profile = request.track, request.profile
    if (track is not None or profile is not None) and python_callback:
        raise ValueError(
            "curved track and speed profiles run with the native callback only; leave out the Python callback"
        )
    if profile is not None and track is None:  # the odometer the profile drives runs along a straight track
        start = _start_station(request, None)
        track = Track.straight(start + distance + max(layout.wheelset_x) + 1.0, PROFILE_TRACK)
    vehicle = Vehicle(layout, track, profile)
    if request.state is not None and (
        len(request.state[0]) != vehicle.model.nq or len(request.state[1]) != vehicle.model.nv
    ):
        raise ValueError(
            f"state has {len(request.state[0])} positions and {len(request.state[1])} velocities; this run's model "
            f"has {vehicle.model.nq} and {vehicle.model.nv} (a state continues a run of the same layout, "
            "track and speed profile, or lack of them)"
        )
    duration = distance / speed
    if track is not None:
        start = _check_on_track(request, vehicle, track)
        if profile is not None:
            # The speed at the start is the profile's there; the timestep is the stablest for the
            # speeds along the run (the creep damping 2*f22/V at the lowest, the kinematic modes
            # at the highest), and the run lasts the profile's time over its distance.
            speed = float(profile.at(start))
            request.speed = speed
            duration = profile.duration(start, start + distance)
    dt = _timestep(vehicle, python_callback, speed, request)
    if profile is None:
        set_speed(vehicle.model, speed)
    # On the model that steps (Vehicle.stepped: a planar vehicle's flat twin on straight track).
    forces = CreepForces(vehicle.stepped.model, vehicle.wheelset_names, speed) if python_callback else None
    steps = duration / float(dt)
    if not steps <= MAX_STEPS:  # also catches inf from an absurdly slow run
        w, c = layout.wheelset, layout.creep
        creep_rate = 2 * c.f22 / (speed * w.mass)  # lateral creep damping / wheelset mass
        cause = (
            f"the creep damping 2*f22/V = {2 * c.f22 / speed:.3g} N s/m on a {w.mass:g} kg wheelset"
            if creep_rate * dt > 0.5 * STEP_FRACTION
            else "the fastest mode of the linearised vehicle"
        )
        raise RunRefused(
            f"{speed:g} m/s for {distance:g} m is too slow to simulate: {cause} needs a timestep "
            f"of {dt:.2g} s, {steps:.3g} steps (limit {MAX_STEPS:.0e}); raise --speed or "
            f"shorten --distance"
        )
    prepared = Prepared(request, vehicle, dt, math.ceil(steps), forces)
    interval = request.sample_interval
    if interval is not None and (interval > duration / MIN_INTERVALS or prepared.every * dt > duration / MIN_INTERVALS):
        # The samples are evenly spaced (the filters and spectra of the analysis need it) and the
        # run ends at the first at or past the distance: a long interval would carry it far beyond.
        raise ValueError(
            f"sample interval {request.sample_interval:.3g} s is longer than a tenth of the run "
            f"({duration:.3g} s): keep at least {MIN_INTERVALS} intervals (a higher --sample-rate)"
        )
    prepared.seconds = time.perf_counter() - started
    return prepared


def _timestep(vehicle: Vehicle, python_callback: bool, speed: float, request: Request) -> float:
    """The run's timestep (rail_mj.simulation.timestep) at its speed, or on a speed profile the
    smallest of those at its lowest and highest speeds, each the timestep of the same vehicle at
    that constant speed (on the same track, or none); the vehicle's speed is left at `speed`."""
    profile = request.profile
    if profile is None:
        set_speed(vehicle.model, speed)
        forces = CreepForces(vehicle.model, vehicle.wheelset_names, speed) if python_callback else None
        return stable_timestep(vehicle, forces)
    start = speed_start = _start_station(request, vehicle)
    end = start + request.distance
    constant = Vehicle(request.layout, request.track)  # the request's own track: None if it gave none
    steps = []
    for v in {profile.lowest(start, end), profile.highest(start, end)}:
        set_speed(constant.model, v)
        steps.append(stable_timestep(constant))
    set_speed(vehicle.model, float(profile.at(speed_start)))
    return min(steps)


def _start_station(request: Request, vehicle: Vehicle | None) -> float:
    """Where the vehicle's origin starts along the track: 0, or where a continued run's odometer
    had come to (its state's odometer entry; `vehicle` None: the request's own layout's model,
    whose odometer, last in the world, is its state's last qpos entry)."""
    if request.state is None:
        return 0.0
    if vehicle is not None:
        return float(request.state[0][vehicle.model.joint(ODOMETER).qposadr[0]])
    return float(request.state[0][-1])


def _check_on_track(request: Request, vehicle: Vehicle, track: Track) -> float:
    """Refuse a run that would leave its track: the vehicle's origin (the car body's centre)
    starts at the track's start, or where a continued run's odometer had come to, and its
    leading wheelset must still be on the track at the end (beyond its ends a track goes on as
    it begins and ends, rail_mj.track: the bodies behind are on track all the way); where it starts."""
    start = _start_station(request, vehicle)
    reach = track.length - max(request.layout.wheelset_x) - start
    if request.distance > reach:
        raise ValueError(
            f"distance {request.distance:g} m is longer than the track ({track.source}: {track.length:g} m, "
            f"{reach:g} m for the vehicle's centre from {start:g} m with its leading wheelset on it)"
        )
    return start


def simulate(
    layout: Layout,
    speed: float | SpeedProfile,
    distance: float,
    initial_lateral: float = INITIAL_LATERAL,
    initial_yaw: float = 0.0,
    progress: Callable[[float], None] | None = None,
    derailment_lateral: float = DERAILMENT_LATERAL,
    state: tuple[np.ndarray, np.ndarray] | None = None,
    python_callback: bool = False,
    track: Track | None = None,
    sample_interval: float | None = None,
) -> Run:
    """Run `layout` at `speed` (m/s, or a `SpeedProfile` of the speed along the track) for
    `distance` (m) from a disturbed start.

    The disturbance: the whole vehicle shifted left by `initial_lateral` (m: 2 mm unless told, as
    `rail-mj run`; 0 starts centred, and on straight perfect track nothing then moves), and every
    wheelset yawed by `initial_yaw` (rad) about its centre; or, to continue a run at a
    new speed, `state` = (qpos, qvel), for example a previous run's `final_state`.
    Raises ValueError for an impossible request and `SimulationError` for a run that
    cannot be done or diverges. The creep forces come from the native callback
    (rail_mj.simulation.native); `python_callback` uses the Python one (rail_mj.simulation.callback) instead.
    `track`: a curved or canted track (rail_mj.track) the vehicle's centre runs along from its
    start; None: straight track. `sample_interval`: seconds between the samples kept (whole
    steps; None: every millisecond), for a long run whose every sample would not fit in memory;
    the steps are the same, and a sample kept is the full record's at its time, bit for bit;
    evenly spaced, at least MIN_INTERVALS of them, the last at or past `distance`.
    """
    if isinstance(speed, SpeedProfile):
        request = Request(
            layout, float(speed.at(0.0)), distance, initial_lateral, initial_yaw, state, track, speed, sample_interval
        )
    else:
        request = Request(
            layout, speed, distance, initial_lateral, initial_yaw, state, track, sample_interval=sample_interval
        )
    prepared = prepare(request, python_callback)
    result = step_alone(prepared, derailment_lateral, progress)
    if isinstance(result, SimulationError):
        raise result
    return result


# What rail_mj 0.2's runner.py held besides: the timestep, a run's samples, the stepping
# and the batches each have a module of their own now; their names are still found here
# (old name -> module, name there).
_MOVED = {
    "MAX_TIMESTEP": ("timestep", "MAX_TIMESTEP"),
    "_table_header": ("timestep", "table_header"),
    "Derailed": ("run", "Derailed"),
    "SAMPLE_INTERVAL": ("stepping", "SAMPLE_INTERVAL"),
    "CHECK_EVERY": ("stepping", "CHECK_EVERY"),
    "PACK": ("stepping", "PACK"),
    "_Prepared": ("stepping", "Prepared"),
    "_Pack": ("stepping", "Pack"),
    "_Running": ("stepping", "Running"),
    "_stepping": ("stepping", "stepping"),
    "simulate_many": ("batch", "simulate_many"),
}


def __getattr__(name: str):
    # By name, not an import statement: the batches use this module, not it them.
    if name in _MOVED:
        module, new = _MOVED[name]
        return getattr(importlib.import_module(f"rail_mj.simulation.{module}"), new)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
