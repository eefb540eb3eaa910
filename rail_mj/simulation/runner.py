"""The headless runner: vehicles at constant speed along straight, perfect track.

Example:

    >>> from rail_mj import load_layout, simulate
    >>> run = simulate(load_layout("models/bogie/bogie.toml"), speed=30.0, distance=60.0,
    ...                initial_lateral=0.002)
    >>> run.y.shape[1], round(float(run.x[-1]))   # two wheelsets, 60 m
    (2, 60)

`simulate` picks the timestep (`stable_timestep`), steps MuJoCo with the native creep
callback (rail_mj.simulation.native) in chunks (`mujoco.rollout`), records every body's pose and
each wheelset's rates with MuJoCo's sensors, and raises `SimulationError` if the run
diverges, numerically or physically, saying why. `simulate_many` steps many runs
together, packed several vehicles to a model, each with exactly `simulate`'s result.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
import threading
import time
from collections.abc import Callable

import mujoco
import numpy as np
from mujoco import rollout

from rail_mj.contact.creep import ContactForces, contact_forces
from rail_mj.layout import Layout
from rail_mj.layout.practice import DERAILMENT_LATERAL
from rail_mj.numerics import NUMERIC_GEOMETRY
from rail_mj.simulation import native
from rail_mj.simulation.callback import CreepForces, installed
from rail_mj.simulation.linear import modal_roots, state_matrix
from rail_mj.vehicle import block
from rail_mj.vehicle.block import contact_parameters, set_speed
from rail_mj.vehicle.joints import YAW
from rail_mj.vehicle.loads import AxleLoads, ShearCouples
from rail_mj.vehicle.spec import Vehicle

# RK4 is stable for |lambda|*dt up to 2.78 on the real axis and 2.83 on the imaginary
# axis; 1.0 for the fastest mode lambda of the linearised vehicle leaves margin, and the
# slow (hunting, kinematic) modes, 10-1000x slower, come out with negligible error.
STEP_FRACTION = 1.0
MAX_TIMESTEP = 1e-3  # s; the modes of interest are below 20 Hz
MAX_STEPS = 50_000_000  # about half an hour of stepping: beyond this, refuse
SAMPLE_INTERVAL = 1e-3  # s between recorded samples (or every step, if longer)
CHECK_EVERY = 500  # samples between divergence checks (and progress reports)


class SimulationError(RuntimeError):
    """A run that cannot be done or that diverged; the message says why, in one line."""

    def __init__(self, message: str, run: Run | None = None):
        super().__init__(message)
        self.run = run  # what was simulated before the failure, if anything


class RunRefused(SimulationError):
    """A run refused before it started: it would take too many steps."""


class Derailed(SimulationError):
    """A wheelset left the rails: hunting that linear creep cannot bound."""


@dataclasses.dataclass
class Run:
    """A simulated run: samples in time, each wheelset's y and psi (wheelset 1 leads).

    y and psi are absolute, in the track frame: metres and radians, arrays of shape
    (n_samples, n_wheelsets).
    """

    vehicle: Vehicle
    speed: float
    timestep: float
    t: np.ndarray
    body_pos: np.ndarray  # (n_samples, nbody, 3): every body's position in the moving frame
    body_quat: np.ndarray  # (n_samples, nbody, 4): and orientation, MuJoCo's w, x, y, z
    wheelset_rates: np.ndarray  # (n_samples, n_wheelsets, 2): y_dot (m/s) and psi_dot (rad/s)
    final_state: tuple[np.ndarray, np.ndarray] | None = None  # (qpos, qvel) at the end
    # (n_samples, n_wheelsets, 2): a spatial vehicle's axle load P (N) and roll moment M (N m)
    # from its suspension (rail_mj.vehicle.loads); None or NaN: the wheels carry the layout's static load.
    axle_loads: np.ndarray | None = None

    def contact_forces(self) -> ContactForces:
        """The rails' forces on each wheelset at every sample, by origin: arrays of shape
        (n_samples, n_wheelsets). One call of the creep law over every sample, from the
        states the run recorded (once: the summary, the CSV and the recording share it)."""
        return self._contact_forces

    @functools.cached_property
    def _contact_forces(self) -> ContactForces:
        params = contact_parameters(self.vehicle.model, len(self.vehicle.wheelset_names))
        rates = self.wheelset_rates
        loads = self.axle_loads
        if loads is None or np.isnan(loads).all():
            return contact_forces(
                params,
                self.y,
                self.psi,
                rates[..., 0],
                rates[..., 1],
                self.speed,
                nominal=self.layout.wheelset.wheel_load,
            )
        axle = AxleLoads.of(self.vehicle.model, self.vehicle.wheelset_names)
        return contact_forces(
            params,
            self.y,
            self.psi,
            rates[..., 0],
            rates[..., 1],
            self.speed,
            loads[..., 0],
            loads[..., 1],
            **axle.contact(),
        )

    def guiding_forces(self) -> np.ndarray:
        """(n_samples, n_wheelsets): the sum of guiding forces (Sigma Y, N) of each
        wheelset, creep and flange."""
        return self.contact_forces().lateral

    def wheel_loads(self) -> np.ndarray:
        """(n_samples, n_wheelsets, 2): each wheel's vertical load Q (N), left then right. A
        spatial vehicle's come from its suspension (rail_mj.vehicle.loads) and the contact; a planar
        one's are the static share, or on profiles the contact's equilibrium under it (NaN
        when the layout gives no wheel load)."""
        f = self.contact_forces()
        return np.stack([f.load_left, f.load_right], axis=-1)

    def wheel_lateral_forces(self) -> np.ndarray:
        """(n_samples, n_wheelsets, 2): the rail's lateral force Y on each wheel (N, track
        frame, + to the left), creep, flange and the normal force's lateral part."""
        f = self.contact_forces()
        return np.stack([f.lateral_left, f.lateral_right], axis=-1)

    def derailment_quotients(self) -> np.ndarray:
        """(n_samples, n_wheelsets, 2): Y/Q of each wheel (EN 14363), Y the force the wheel puts
        on its rail towards the outside of the track (positive: the flange-climbing direction:
        the left wheel pushing its rail to the left). NaN where a wheel is off its rail (Q = 0)."""
        outward = self.wheel_lateral_forces() * np.array([-1.0, 1.0])
        q = self.wheel_loads()
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(q > 0.0, outward / np.where(q > 0.0, q, 1.0), np.nan)

    @property
    def layout(self) -> Layout:
        return self.vehicle.layout

    @functools.cached_property
    def y(self) -> np.ndarray:
        return self.body_pos[:, self.vehicle.wheelset_ids, 1]

    @functools.cached_property
    def psi(self) -> np.ndarray:
        return _yaw(self.body_quat[:, self.vehicle.wheelset_ids])

    @property
    def x(self) -> np.ndarray:
        """Distance travelled, m."""
        return self.speed * self.t

    @property
    def n_wheelsets(self) -> int:
        return self.y.shape[1]

    @property
    def frame_names(self) -> tuple[str, ...]:
        """The moving bodies other than the wheelsets: the bogie frames (bogie1, ...), then the
        car body unless it is fixed. A fixed car body (no joints) has no motion to show."""
        return tuple(self.vehicle.model.body(b).name for b in self._frame_ids)

    @property
    def _frame_ids(self) -> list[int]:
        model = self.vehicle.model
        wheelsets = set(self.vehicle.wheelset_ids.tolist())
        moving = [b for b in range(1, model.nbody) if b not in wheelsets and model.body_dofnum[b] > 0]
        return sorted(moving, key=lambda b: (model.body(b).name == "carbody", b))

    @property
    def frame_y(self) -> np.ndarray:
        """(n_samples, n_frames): lateral displacement of each of `frame_names`, m (absolute,
        track frame, like `y`)."""
        return self.body_pos[:, self._frame_ids, 1]

    @property
    def frame_psi(self) -> np.ndarray:
        """(n_samples, n_frames): yaw of each of `frame_names`, rad (absolute, like `psi`)."""
        quat = self.body_quat[:, self._frame_ids]
        return _yaw(quat) if self.layout.spatial is None else _spatial_angles(quat)[2]

    @property
    def frame_roll(self) -> np.ndarray:
        """(n_samples, n_frames): a spatial vehicle's frames' roll, rad (about x, left side up)."""
        return _spatial_angles(self.body_quat[:, self._frame_ids])[0]

    @property
    def frame_bounce(self) -> np.ndarray:
        """(n_samples, n_frames): a spatial vehicle's frames' vertical displacement from the
        static equilibrium (the centred state), m."""
        rest = self.vehicle.model.body_pos[self._frame_ids, 2]
        return self.body_pos[:, self._frame_ids, 2] - rest

    def table(self) -> tuple[list[str], np.ndarray]:
        """Columns and their values, SI units (s, m, rad, N), one row per sample:

        t, x, y1, psi1, y2, psi2, ...   time, distance, each wheelset's lateral displacement and yaw
        sum_y1, flange1, sum_y2, ...    each wheelset's sum of guiding forces Sigma Y and the
                                        flange's part of it (the rail's lateral force on the
                                        wheelset, positive to the left; 0 off the flange; on
                                        profiles the normal forces' lateral part, gravitational
                                        stiffness included)
        y_bogie1, psi_bogie1, ...       each moving frame's lateral displacement and yaw
        (y_carbody, psi_carbody)        (bogies, then the car body unless it is fixed)
        q_left1, q_right1, ...          each wheel's vertical load Q and lateral force Y (the
        ylat_left1, ylat_right1, ...    rail's, + to the left) and its derailment quotient Y/Q
        y_over_q_left1, ...             (`derailment_quotients`; NaN where the wheel is off its
                                        rail), for a spatial vehicle (the summary has them for all)
        bounce_bogie1, roll_bogie1,     a spatial vehicle's frames' and car bodies' vertical
        pitch_bogie1, ...               displacement from the static equilibrium (m), roll and pitch
        """
        names = ["t", "x"]
        cols = [self.t, self.x]
        y, psi = self.y, self.psi
        for i in range(self.n_wheelsets):
            names += [f"y{i + 1}", f"psi{i + 1}"]
            cols += [y[:, i], psi[:, i]]
        forces = self.contact_forces()
        for i in range(self.n_wheelsets):
            names += [f"sum_y{i + 1}", f"flange{i + 1}"]
            cols += [forces.lateral[:, i], forces.flange_lateral[:, i]]
        frame_y, frame_psi = self.frame_y, self.frame_psi
        for k, name in enumerate(self.frame_names):
            names += [f"y_{name}", f"psi_{name}"]
            cols += [frame_y[:, k], frame_psi[:, k]]
        if self.layout.spatial is not None:  # a planar run's columns stay as they were
            q = self.wheel_loads()
            lateral, quotient = self.wheel_lateral_forces(), self.derailment_quotients()
            for i in range(self.n_wheelsets):
                for what, values in (("q", q), ("ylat", lateral), ("y_over_q", quotient)):
                    names += [f"{what}_left{i + 1}", f"{what}_right{i + 1}"]
                    cols += [values[:, i, 0], values[:, i, 1]]
            roll, pitch, _ = _spatial_angles(self.body_quat[:, self._frame_ids])
            bounce = self.frame_bounce
            for k, name in enumerate(self.frame_names):
                names += [f"bounce_{name}", f"roll_{name}", f"pitch_{name}"]
                cols += [bounce[:, k], roll[:, k], pitch[:, k]]
        return names, np.column_stack(cols)


def _yaw(quat: np.ndarray) -> np.ndarray:
    """Yaw of MuJoCo quaternions (w, x, y, z) over the last axis. The bodies turn about z
    alone (lateral and yaw joints): quaternion (cos psi/2, 0, 0, sin psi/2)."""
    return 2.0 * np.arctan2(quat[..., 3], quat[..., 0])


def _spatial_angles(quat: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(roll, pitch, yaw) of a spatial body's quaternions (w, x, y, z), its joints turning it
    by yaw, then roll, then pitch (rail_mj.vehicle.joints: R = Rz(psi) Rx(phi) Ry(theta)): from R's
    entries R21 = sin(phi), R20 = -cos(phi) sin(theta), R01 = -sin(psi) cos(phi)."""
    w, x, y, z = (quat[..., k] for k in range(4))
    roll = np.arcsin(np.clip(2.0 * (y * z + w * x), -1.0, 1.0))
    pitch = np.arctan2(-2.0 * (x * z - w * y), 1.0 - 2.0 * (x * x + y * y))
    yaw = np.arctan2(-2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z))
    return roll, pitch, yaw


def _table_header(model: mujoco.MjModel) -> tuple[float, float]:
    """(first y, step in y), m, of a profiled model's contact table (rail_mj.contact.tables)."""
    from rail_mj.numerics import HEADER_DY, HEADER_Y0
    from rail_mj.units import M_PER_MM

    header = model.numeric(NUMERIC_GEOMETRY).data
    return float(header[HEADER_Y0]) * M_PER_MM, float(header[HEADER_DY]) * M_PER_MM


def stable_timestep(vehicle: Vehicle, forces: CreepForces | None = None) -> float:
    """Timestep for RK4 with explicit creep forces: STEP_FRACTION / (fastest linear rate).

    The creep damping 2*f22/V grows without bound as V falls, so the slowest runs
    need the smallest steps. `forces`: the Python callback, or None for the native one at
    the model's speed.
    """
    rate = np.max(np.abs(np.linalg.eigvals(state_matrix(vehicle.model, forces))))
    layout = vehicle.layout
    if layout.flange is not None or layout.profiles is not None:
        # In flange contact the rail's stiffness and the steep radius rise add faster
        # rates: linearise there too, the whole vehicle pressed 2 mm into the flanges; on
        # profiles, in the table's step where the contact jumps onto the flange (the
        # normal force's lateral part rises by ~2 W over 0.05 mm: the stiffest place).
        shift = (
            layout.wheelset.flangeway_clearance + 0.002
            if layout.profiles is None
            else layout.wheelset.flangeway_clearance - 0.5 * _table_header(vehicle.model)[1]
        )
        qpos0 = np.zeros(vehicle.model.nq)
        qpos0[vehicle.root_lateral_dofs] = shift
        engaged = state_matrix(vehicle.model, forces, qpos0=qpos0)
        rate = max(rate, np.max(np.abs(np.linalg.eigvals(engaged))))
    return min(MAX_TIMESTEP, STEP_FRACTION / rate) if rate > 0 else MAX_TIMESTEP


def _linearly_stable(vehicle: Vehicle, forces: CreepForces | None) -> bool:
    """Whether every mode of the vehicle linearised about the centred state decays."""
    return bool(np.max(modal_roots(state_matrix(vehicle.model, forces)).real) < 0)


def _warnings(data) -> str | None:
    raised = np.flatnonzero(data.warning.number)
    return mujoco.mjtWarning(int(raised[0])).name if raised.size else None


@dataclasses.dataclass
class Request:
    """One run to make: a layout at a speed for a distance, from a disturbed start (or from
    `state` = (qpos, qvel), to continue a run)."""

    layout: Layout
    speed: float
    distance: float
    initial_lateral: float = 0.0
    initial_yaw: float = 0.0
    state: tuple[np.ndarray, np.ndarray] | None = None


@dataclasses.dataclass
class _Prepared:
    """A request checked, its vehicle built and its timestep chosen."""

    request: Request
    vehicle: Vehicle
    timestep: float
    n_steps: int
    forces: CreepForces | None = None  # the Python callback, when asked for; None: the native one
    seconds: float = 0.0  # the time it took

    def derailment(self, lateral: float) -> float:
        """|y| past which a wheelset has left the rails: `lateral`, or on profiles the end of
        their contact table (10 mm: far up the flange, where a rigid wheel climbs it)."""
        return min(lateral, self.table_end)

    @functools.cached_property
    def table_end(self) -> float:
        """|y| where a profiled vehicle's contact table ends; inf on coned wheels."""
        return -_table_header(self.vehicle.model)[0] if self.request.layout.profiles is not None else math.inf


def prepare(request: Request, python_callback: bool = False) -> _Prepared:
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
    vehicle = Vehicle(layout)
    set_speed(vehicle.model, speed)
    forces = CreepForces(vehicle.model, vehicle.wheelset_names, speed) if python_callback else None
    dt = stable_timestep(vehicle, forces)
    steps = distance / speed / float(dt)
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
    return _Prepared(request, vehicle, dt, math.ceil(steps), forces, time.perf_counter() - started)


def simulate(
    layout: Layout,
    speed: float,
    distance: float,
    initial_lateral: float = 0.0,
    initial_yaw: float = 0.0,
    progress: Callable[[float], None] | None = None,
    derailment_lateral: float = DERAILMENT_LATERAL,
    state: tuple[np.ndarray, np.ndarray] | None = None,
    python_callback: bool = False,
) -> Run:
    """Run `layout` at `speed` (m/s) for `distance` (m) from a disturbed start.

    The disturbance: the whole vehicle shifted left by `initial_lateral` (m), and every
    wheelset yawed by `initial_yaw` (rad) about its centre; or, to continue a run at a
    new speed, `state` = (qpos, qvel), for example a previous run's `final_state`.
    Raises ValueError for an impossible request and `SimulationError` for a run that
    cannot be done or diverges. The creep forces come from the native callback
    (rail_mj.simulation.native); `python_callback` uses the Python one (rail_mj.simulation.callback) instead.
    """
    prepared = prepare(Request(layout, speed, distance, initial_lateral, initial_yaw, state), python_callback)
    result = _alone(prepared, derailment_lateral, progress)
    if isinstance(result, SimulationError):
        raise result
    return result


# Vehicles a model when runs are stepped together: a coach's step in a model of eight
# costs two thirds of its step alone (no drawn shapes, MuJoCo's overheads shared) and far
# fewer Python round trips; models of 16 or 32 save 1-2 % more, and balance worse.
PACK = 8


def simulate_many(
    requests: list[Request],
    threads: int = 1,
    derailment_lateral: float = DERAILMENT_LATERAL,
    finished: Callable[[int, Run | Exception, float], None] | None = None,
    stop: threading.Event | None = None,
) -> list[Run | Exception]:
    """Many runs stepped together, each result exactly the Run that `simulate` gives for its
    request, bit for bit, or the exception it raises (ValueError, SimulationError).

    `threads` threads step a MuJoCo model each, holding up to PACK runs of one timestep
    (each vehicle attached under its own name prefix, its own speed in the native block).
    A thread takes the longest runs waiting, so that the threads finish together. When one
    of its runs ends, the longest run waiting of the same layout and timestep takes its
    place (the model's speed for that vehicle changes, nothing else); when half of its
    places are empty, the runs still going continue where they are in a new model, with
    runs waiting of any layout. A numerical failure while packed is put down to its runs
    one by one, each run again on its own. `finished(k, result, seconds)`, if given, is
    told each result as soon as it is known, from the thread that stepped it: k its
    place in `requests`, seconds its share of the threads' time. Once `stop` is set, the
    threads stop after their chunk (the runs not finished have no result: None)."""
    results: list = [None] * len(requests)

    def done(k: int, result, seconds: float) -> None:
        results[k] = result
        if finished is not None:
            finished(k, result, seconds)

    def put_all() -> None:
        """Prepare the requests, the longest first, for the threads to take as they come."""
        for k in sorted(range(len(requests)), key=lambda k: (-_duration(requests[k]), k)):
            started = time.perf_counter()
            try:
                queue.put(k, prepare(requests[k]))
            except (ValueError, SimulationError) as e:
                done(k, e, time.perf_counter() - started)
        queue.close()

    queue = _Queue(stop)
    workers = max(1, min(threads, len(requests)))
    size = min(PACK, -(-len(requests) // workers))  # the first packs: every thread busy
    with native.installed(), _stepping():
        if workers == 1:
            put_all()
            _work(queue, size, done, derailment_lateral)
        else:
            errors: list[BaseException] = []

            def work() -> None:
                try:
                    _work(queue, size, done, derailment_lateral)
                except BaseException as e:
                    errors.append(e)
                    queue.cancel()

            pool = [threading.Thread(target=work, name=f"rail-mj-{i}", daemon=True) for i in range(workers)]
            for thread in pool:
                thread.start()
            try:
                put_all()  # while the threads step the first runs prepared
                for thread in pool:
                    while thread.is_alive():  # a timeout, so that Ctrl-C is heard
                        thread.join(0.2)
            except BaseException:
                queue.cancel()  # each thread stops after its chunk; the callback stays till then
                for thread in pool:
                    thread.join()
                raise
            if errors:
                raise errors[0]
    return results


def _duration(request: Request) -> float:
    """Seconds of simulated time, for the order of the runs (0 for a request to be refused)."""
    try:
        duration = request.distance / request.speed
    except (TypeError, ZeroDivisionError):
        return 0.0
    return duration if math.isfinite(duration) and duration > 0 else 0.0


class _Queue:
    """The runs waiting to be stepped, the longest first, shared by the threads; put in as
    they are prepared, until `close`."""

    def __init__(self, stop: threading.Event | None = None):
        self._items: list[tuple[int, _Prepared]] = []
        self._ready = threading.Condition()
        self._closed = False
        self._stop = stop or threading.Event()

    def put(self, k: int, prepared: _Prepared) -> None:
        with self._ready:
            self._items.append((k, prepared))
            self._ready.notify_all()

    def close(self) -> None:
        with self._ready:
            self._closed = True
            self._ready.notify_all()

    def cancel(self) -> None:
        self._stop.set()
        self.close()

    @property
    def cancelled(self) -> bool:
        return self._stop.is_set()

    def take(self, n: int, timestep: float | None = None) -> list[tuple[int, _Prepared]]:
        """Up to n runs of `timestep`, the longest first. Without a timestep: the first run
        waiting's, and n of them if n will come (it waits for them)."""
        with self._ready:
            while True:
                if self.cancelled or n <= 0:
                    return []
                dt = timestep if timestep is not None or not self._items else self._items[0][1].timestep
                chosen = [item for item in self._items if item[1].timestep == dt][:n]
                if timestep is not None or self._closed or len(chosen) == n:
                    break
                self._ready.wait(0.1)
            for item in chosen:
                self._items.remove(item)
            return chosen

    def take_like(self, prepared: _Prepared) -> tuple[int, _Prepared] | None:
        """The longest run that can take the place of `prepared` in its model: its timestep
        and an equal layout (so an equal vehicle), the speed alone differing."""
        with self._ready:
            for item in self._items:
                if item[1].timestep == prepared.timestep and _same(item[1].request.layout, prepared.request.layout):
                    self._items.remove(item)
                    return item
            return None


def _same(a: Layout, b: Layout) -> bool:
    try:
        return a is b or bool(a == b)
    except (TypeError, ValueError):  # fields that do not compare (arrays): not known to be equal
        return False


class _Running:
    """A run being stepped: what it has recorded, how far it has come, and the state (qpos,
    qvel) it starts or continues from (None: its request's disturbance)."""

    def __init__(self, index: int, prepared: _Prepared):
        self.index, self.prepared = index, prepared
        self.every = max(1, round(SAMPLE_INTERVAL / prepared.timestep))
        self.count = -(-prepared.n_steps // self.every) + 1  # samples: the last at or past the distance
        self.pos, self.quat, self.rates, self.loads = _records(prepared.vehicle, self.count)
        self.done = 0  # samples recorded
        self.state = prepared.request.state
        self.seconds = prepared.seconds  # and its share of the time of the models it was stepped in

    def t(self) -> np.ndarray:
        return np.arange(self.count) * (self.every * self.prepared.timestep)  # exact, unlike data.time

    def run(self, final) -> Run:
        p = self.prepared
        return Run(p.vehicle, p.request.speed, p.timestep, self.t(), self.pos, self.quat, self.rates, final, self.loads)

    def partial(self, k: int) -> Run:
        """The Run of its first k samples (what was simulated before a failure)."""
        p = self.prepared
        return Run(
            p.vehicle,
            p.request.speed,
            p.timestep,
            self.t()[:k],
            self.pos[:k].copy(),
            self.quat[:k].copy(),
            self.rates[:k].copy(),
            axle_loads=self.loads[:k].copy(),
        )


@dataclasses.dataclass
class _Place:
    """Where one vehicle sits in the model that is stepped: its sensors, and its qpos and
    qvel entries."""

    sensors: object  # rail_mj.vehicle.sensors.Sensors
    qpos: np.ndarray
    qvel: np.ndarray
    lateral: np.ndarray  # qpos entries of its root lateral joints
    yaw: np.ndarray  # qpos entries of its wheelsets' yaw joints

    @classmethod
    def whole(cls, vehicle: Vehicle) -> _Place:
        model = vehicle.model
        return cls(
            vehicle.sensors,
            np.arange(model.nq),
            np.arange(model.nv),
            vehicle.root_lateral_dofs,
            vehicle.wheelset_dofs(YAW),
        )


class _Pack:
    """A model that one thread steps and the runs in it, each at its place; a place whose
    run has ended is empty (None), its vehicle at rest in the centre."""

    STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS

    def __init__(self, runs: list[_Running], alone: bool = False):
        started = time.perf_counter()
        self.runs: list[_Running | None] = list(runs)
        self.alone = alone  # the run's own vehicle model (drawn shapes and all), as `simulate` steps it
        if alone:
            vehicle = runs[0].prepared.vehicle
            self.model, self.places = vehicle.model, [_Place.whole(vehicle)]
        else:
            self.model, self.places = _pack(
                [r.prepared.vehicle for r in runs], [r.prepared.request.speed for r in runs]
            )
        model = self.model
        model.opt.timestep = runs[0].prepared.timestep
        # A run that blows up must stay blown up (non-finite), not be reset by MuJoCo to its
        # start: that is how it is told from the runs stepped beside it.
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        if _unconstrained(model):  # nothing to constrain: the constraint stages are skipped, same result
            model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
        self.data = mujoco.MjData(model)
        self.state = np.empty(mujoco.mj_stateSize(model, self.STATE))
        mujoco.mj_getState(model, self.data, self.state, self.STATE)
        for m in range(len(runs)):
            self.start(m)
        self.share(time.perf_counter() - started)

    def start(self, m: int) -> None:
        """Put run m's starting state at its place (or its vehicle at rest, if empty)."""
        place, run, nq = self.places[m], self.runs[m], self.model.nq
        self.state[1 + place.qpos] = self.model.qpos0[place.qpos]
        self.state[1 + nq + place.qvel] = 0.0
        if run is None:
            return
        if run.state is None:
            self.state[1 + place.lateral] = run.prepared.request.initial_lateral
            self.state[1 + place.yaw] = run.prepared.request.initial_yaw
        else:
            self.state[1 + place.qpos], self.state[1 + nq + place.qvel] = run.state

    def state_of(self, m: int, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(qpos, qvel) of run m in a state vector of this model."""
        place = self.places[m]
        return vector[1 + place.qpos].copy(), vector[1 + self.model.nq + place.qvel].copy()

    def going(self) -> list[int]:
        return [m for m, run in enumerate(self.runs) if run is not None]

    def share(self, seconds: float) -> None:
        going = self.going()
        for m in going:
            self.runs[m].seconds += seconds / len(going)


def _unconstrained(model: mujoco.MjModel) -> bool:
    """Whether nothing in the model makes a constraint: no contacts, equalities, limits,
    friction loss or tendons (so mjDSBL_CONSTRAINT changes nothing but the time)."""
    return (
        bool(model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
        and model.neq == 0
        and model.ntendon == 0
        and model.nflex == 0
        and not np.any(model.jnt_limited)
        and not np.any(model.dof_frictionloss)
    )


def _pack(vehicles: list[Vehicle], speeds: list[float]):
    """One model holding every vehicle, attached under the prefixes v0/, v1/, ..., the
    native block listing them all with their speeds."""
    from rail_mj.numerics import NUMERIC_NATIVE
    from rail_mj.vehicle.sensors import Sensors
    from rail_mj.vehicle.spec import compile_spec

    parent = mujoco.MjSpec()
    first = vehicles[0].spec
    parent.option.timestep = first.option.timestep
    parent.option.integrator = first.option.integrator
    parent.option.disableflags = first.option.disableflags
    native_numeric = parent.add_numeric(name=NUMERIC_NATIVE, data=[0.0])  # first: the block
    for k, vehicle in enumerate(vehicles):
        child = vehicle.spec.copy()
        # The drawn shapes touch nothing and weigh nothing, yet MuJoCo places each one at
        # every stage of every step (a fifth of a coach's step): a packed model goes without
        # them, and each Run keeps its own vehicle's, for its recording.
        for geom in list(child.geoms):
            child.delete(geom)
        for mesh in list(child.meshes):
            child.delete(mesh)
        parent.attach(child, prefix=f"v{k}/", frame=parent.worldbody.add_frame())
    layout = vehicles[0].layout
    model = compile_spec(parent, layout)
    entries = []
    for k, (vehicle, speed) in enumerate(zip(vehicles, speeds)):
        bodies = [model.body(f"v{k}/{w}").id for w in vehicle.wheelset_names]
        loads = AxleLoads.of(vehicle.model, vehicle.wheelset_names)
        entries.append(
            block.vehicle_block(
                model,
                bodies,
                contact_parameters(vehicle.model, len(bodies)),
                speed,
                loads,
                prefix=f"v{k}/",
                couples=ShearCouples.of(vehicle.model),
            )
        )
    native_numeric.data = block.block(entries).tolist()
    model = compile_spec(parent, layout)
    places = []
    for k, vehicle in enumerate(vehicles):
        own = vehicle.model
        joints = [model.joint(f"v{k}/{own.joint(j).name}").id for j in range(own.njnt)]
        qpos = np.array([model.jnt_qposadr[j] for j in joints], dtype=np.int64)
        qvel = np.array([model.jnt_dofadr[j] for j in joints], dtype=np.int64)
        # Each own joint is one coordinate (slide or hinge): own index -> packed index.
        places.append(
            _Place(
                Sensors(model, vehicle.wheelset_names, prefix=f"v{k}/"),
                qpos,
                qvel,
                qpos[vehicle.root_lateral_dofs],
                qpos[vehicle.wheelset_dofs(YAW)],
            )
        )
    return model, places


class _Roller:
    """One thread's `mujoco.rollout` on the calling thread, into buffers it keeps: states
    and sensor readings, views valid until the next call."""

    def __init__(self):
        self._rollout = rollout.Rollout(nthread=0)
        self._states, self._readings = np.empty(0), np.empty(0)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, start: np.ndarray, nstep: int):
        nstate, nsensor = start.size, model.nsensordata
        if self._states.size < nstep * nstate:
            self._states = np.empty(nstep * nstate)
        if self._readings.size < nstep * nsensor:
            self._readings = np.empty(nstep * nsensor)
        states = self._states[: nstep * nstate].reshape(1, nstep, nstate)
        readings = self._readings[: nstep * nsensor].reshape(1, nstep, nsensor)
        self._rollout.rollout(
            [model], [data], start[None], skip_checks=True, nstep=nstep, state=states, sensordata=readings
        )
        return states[0], readings[0]


def _work(queue: _Queue, size: int, done, derailment_lateral: float) -> None:
    """One thread's share of `simulate_many`: packs of the longest runs waiting, until none wait."""
    roller = _Roller()
    while not queue.cancelled:
        items = queue.take(size)
        if not items:
            return
        _drive(_Pack([_Running(k, p) for k, p in items]), roller, done, derailment_lateral, None, queue)


def _alone(prepared: _Prepared, derailment_lateral: float, progress=None) -> Run | SimulationError:
    """One run on its own, in its vehicle's own model: what `simulate` steps."""
    outcome = []
    forces = prepared.forces
    with installed(forces) if forces else native.installed(), _stepping():
        later = _drive(
            _Pack([_Running(0, prepared)], alone=True),
            _Roller(),
            lambda k, result, seconds: outcome.append(result),
            derailment_lateral,
            forces,
            None,
            progress,
        )
    for make in later:  # outside the callback's block: the cause linearises
        outcome.append(make())
    (result,) = outcome
    return result


def _drive(
    pack: _Pack, roller: _Roller, done, derailment_lateral: float, forces, queue: _Queue | None, progress=None
) -> list:
    """Step `pack` until its runs have covered their distances (and those that take their
    places from `queue`), telling `done(k, result, seconds)` each result. MuJoCo steps in
    chunks of CHECK_EVERY samples (`mujoco.rollout`) and measures every body with its
    sensors. A step's sensor values are those of the state it started from (sensors are
    computed in the forward pass, before integration), so step j's record is the sample
    at step j. Every run starts at the start of a chunk, so each meets the same chunks and
    checks as on its own. A run that leaves the rails is stopped there (its place emptied,
    so that it cannot disturb the others); a numerical failure stops every run still going,
    and in a pack of several, each is run again on its own. Returns the Derailed results
    still to make when `forces` (the Python callback) is installed: thunks for the caller."""
    later = []
    while True:
        going = pack.going()
        if not going or (queue is not None and queue.cancelled):
            return later
        runs = [pack.runs[m] for m in going]
        every, dt = runs[0].every, runs[0].prepared.timestep
        count = min(CHECK_EVERY, max(r.count - r.done for r in runs))
        started = time.perf_counter()
        start = pack.state
        states, readings = roller(pack.model, pack.data, start, count * every)
        readings = readings[::every]
        pack.state = states[-1].copy()
        pack.share(time.perf_counter() - started)
        warning = _warnings(pack.data)
        if warning or not (np.all(np.isfinite(readings)) and np.all(np.isfinite(pack.state))):
            for r in runs:
                if pack.alone:
                    at = (min(r.done + count, r.count) - 1) * (every * dt)
                    speed = r.prepared.request.speed
                    done(
                        r.index,
                        SimulationError(
                            f"diverged by t = {at:.4g} s (x = {speed * at:.4g} m): MuJoCo reported "
                            f"{warning or 'non-finite positions'} with timestep {dt:.3g} s at "
                            f"{speed:g} m/s; the suspension or creep stiffness is too high for "
                            f"this step",
                            r.partial(r.done),
                        ),
                        r.seconds,
                    )
                else:
                    done(r.index, _alone(r.prepared, derailment_lateral), r.seconds)
            return later
        first, ended = runs[0].done, []
        for m, r in zip(going, runs):
            place = pack.places[m]
            n = min(count, r.count - r.done)
            mine = slice(r.done, r.done + n)
            r.pos[mine, 0], r.quat[mine, 0] = 0.0, (1.0, 0.0, 0.0, 0.0)  # the world; the sensors the rest
            place.sensors.poses(readings[:n], r.pos[mine], r.quat[mine])
            place.sensors.rates(readings[:n], r.rates[mine])
            place.sensors.loads(readings[:n], r.loads[mine])
            lateral = np.abs(r.pos[mine][:, r.prepared.vehicle.wheelset_ids, 1])
            off = np.nonzero(np.max(lateral, axis=1) > r.prepared.derailment(derailment_lateral))[0]
            if len(off):
                j, worst = r.done + off[0], int(np.argmax(lateral[off[0]]))

                def make(r=r, j=j, worst=worst):
                    return _derailed(r.prepared, worst, j, r.t(), derailment_lateral, forces, r.partial(j + 1))

                if forces is None:
                    done(r.index, make(), r.seconds)
                else:
                    later.append(make)
                ended.append(m)
            elif r.done + n == r.count:  # its last sample: the state the run ends in
                last = n - 1
                done(r.index, r.run(pack.state_of(m, states[last * every - 1] if last > 0 else start)), r.seconds)
                ended.append(m)
            else:
                r.done += n
        for m in ended:
            # The longest run waiting of the same vehicle takes the place: only the speed changes.
            item = queue.take_like(pack.runs[m].prepared) if queue is not None else None
            pack.runs[m] = None if item is None else _Running(*item)
            if item is not None:
                set_speed(pack.model, item[1].request.speed, vehicle=m)
            pack.start(m)
        if progress is not None:
            progress(min(first + count, runs[0].count - 1) / max(runs[0].count - 1, 1))
        empty = len(pack.runs) - len(pack.going())
        if queue is not None and empty and 2 * empty >= len(pack.runs):
            # Half the places empty: the runs going continue in a new model, with runs waiting.
            keep = pack.going()
            for m in keep:
                pack.runs[m].state = pack.state_of(m, pack.state)
            items = queue.take(PACK - len(keep), dt)
            runs = [pack.runs[m] for m in keep] + [_Running(k, p) for k, p in items]
            if not runs:
                return later
            pack = _Pack(runs)


_STEPPING = threading.Lock()
_stepping_users = 0
_stepping_previous: tuple = ()


@contextlib.contextmanager
def _stepping():
    """While any thread steps: MuJoCo's warnings are not printed nor appended to
    MUJOCO_LOG.TXT in the working folder (the runner reports a failure itself, in one
    line, naming the warning from the data's warning counters), and MuJoCo's pipeline
    timers (data.timer, a clock read at every stage, 2 % of a step) are off."""
    global _stepping_users, _stepping_previous
    with _STEPPING:
        if _stepping_users == 0:
            _stepping_previous = (mujoco.get_mju_user_warning(), mujoco.get_mjcb_time())
            mujoco.set_mju_user_warning(lambda message: None)
            mujoco.set_mjcb_time(_untimed())
        _stepping_users += 1
    try:
        yield
    finally:
        with _STEPPING:
            _stepping_users -= 1
            if _stepping_users == 0:
                mujoco.set_mju_user_warning(_stepping_previous[0])
                mujoco.set_mjcb_time(_stepping_previous[1])


@functools.cache
def _untimed():
    """A native clock that always reads 0 (MuJoCo's default reads the system clock)."""
    import ctypes

    import numba

    @numba.cfunc(numba.types.float64(), cache=True)
    def zero():
        return 0.0

    return ctypes.CFUNCTYPE(ctypes.c_double)(zero.address)


def _records(vehicle: Vehicle, n_samples: int):
    """Empty arrays for a run's body positions, quaternions and rates, filled as it goes
    (the memory is touched then, a chunk at a time, not all before the first step)."""
    nbody, n = vehicle.model.nbody, vehicle.n_wheelsets
    return (
        np.empty((n_samples, nbody, 3)),
        np.empty((n_samples, nbody, 4)),
        np.empty((n_samples, n, 2)),
        np.empty((n_samples, n, 2)),
    )


def _derailed(p: _Prepared, worst: int, j: int, t, derailment_lateral: float, forces, run) -> Derailed:
    """Why a wheelset left the rails: the speed (a linear mode grows) or the start."""
    r = p.request
    derailment_lateral = p.derailment(derailment_lateral)
    why = (
        "its wheel climbed the flange (past the profiles' contact table)"
        if r.layout.profiles
        else "the flanges did not hold it"
        if r.layout.flange
        else "without [flange] contact nothing bounds the motion"
    )
    if _linearly_stable(p.vehicle, forces):
        start = (
            f"the start (shifted {r.initial_lateral:g} m, yawed {r.initial_yaw:g} rad)"
            if r.state is None
            else "the state it started from"
        )
        cause = (
            f"At {r.speed:g} m/s the centred vehicle is stable (every linear mode decays), "
            f"so {start} was too large a disturbance and {why}; start nearer the centre"
        )
    else:
        cause = (
            f"{r.speed:g} m/s is above this vehicle's critical speed (a linear mode grows), "
            f"and {why}; lower --speed or shorten --distance"
        )
    return Derailed(
        f"wheelset {worst + 1} left the rails: |y| passed {derailment_lateral} m at "
        f"x = {r.speed * t[j]:.4g} m (t = {t[j]:.4g} s). {cause}",
        run,
    )
