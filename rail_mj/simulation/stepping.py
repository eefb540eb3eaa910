"""MuJoCo stepped in chunks: a model holding one run or several (a pack), the checks between
chunks, and the runs' records.

A run is stepped on its own (`step_alone`: what `simulate` does; in a pack of one, or with the
Python callback in its vehicle's own model) or in a pack of up to PACK vehicles, each attached
under its own name prefix with its own speed in the native block (rail_mj.simulation.batch fills
and refills the packs from its queue). Either way `drive` steps it in chunks of CHECK_EVERY
samples' steps at SAMPLE_INTERVAL (`mujoco.rollout`), reads every body's pose from MuJoCo's
sensors (a flat twin's from its states) and each wheelset's Sigma Y from the callback at the
samples it keeps, and stops it where it diverges or leaves the rails, saying why.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import mujoco
import numpy as np
from mujoco import rollout

from rail_mj.layout.kinds import Profiled, contact_model
from rail_mj.numerics import CLOCK_SENSOR, GUIDING_SENSOR, userdata_size
from rail_mj.simulation import native
from rail_mj.simulation.callback import CreepForces, installed
from rail_mj.simulation.run import Derailed, Request, Run, SimulationError
from rail_mj.simulation.timestep import linearly_stable, table_header
from rail_mj.simulation.unbiased import applies, roll
from rail_mj.vehicle import block
from rail_mj.vehicle.block import contact_parameters, set_speed
from rail_mj.vehicle.curve import ODOMETER, track_part
from rail_mj.vehicle.joints import YAW
from rail_mj.vehicle.loads import AxleLoads, ShearCouples
from rail_mj.vehicle.spec import Vehicle

if TYPE_CHECKING:
    from rail_mj.vehicle.rails import Rails
    from rail_mj.vehicle.sensors import JointSensors, Sensors

SAMPLE_INTERVAL = 1e-3  # s between recorded samples (or every step, if longer)
# Samples at SAMPLE_INTERVAL between divergence checks (and progress reports): a chunk is this
# many samples' steps whatever the run keeps, so that a thinned run is checked as often and its
# chunk's buffers (every step's state and sensors) stay as small. A second of a run: a pack of
# eight coaches holds 2.3 MB of states at their 1 ms step, and a sweep's Python work a chunk
# (each run's record, its checks) costs half what it did at half a second.
CHECK_EVERY = 1000
# Chunks' samples a streamed run holds before its sink reads them (Running.stream).
STREAM_CHUNKS = 4

# Vehicles a model when runs are stepped together: a coach's step in a model of eight
# costs two thirds of its step alone (no drawn shapes, MuJoCo's overheads shared) and far
# fewer Python round trips; models of 16 or 32 save 1-2 % more, and balance worse.
PACK = 8


class Waiting(Protocol):
    """The runs waiting to take an empty place in a pack (rail_mj.simulation.batch's queue)."""

    @property
    def cancelled(self) -> bool: ...

    def take(self, n: int, cadence: tuple | None = None) -> list[tuple[int, Prepared]]: ...

    def take_like(self, prepared: Prepared) -> tuple[int, Prepared] | None: ...


@dataclasses.dataclass
class Prepared:
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

    @property
    def stepped(self) -> Vehicle:
        """The vehicle MuJoCo steps, `Vehicle.stepped` (a planar vehicle on straight track: its
        flat twin), with either callback."""
        return self.vehicle.stepped

    @functools.cached_property
    def every(self) -> int:
        """Steps between the samples the run keeps: its request's sample interval (or
        SAMPLE_INTERVAL) in whole steps, at least one."""
        interval = self.request.sample_interval
        return max(1, round((SAMPLE_INTERVAL if interval is None else interval) / self.timestep))

    @property
    def chunk(self) -> int:
        """Steps in a chunk: CHECK_EVERY samples at SAMPLE_INTERVAL."""
        return CHECK_EVERY * max(1, round(SAMPLE_INTERVAL / self.timestep))

    @property
    def cadence(self) -> tuple:
        """What the runs of one pack share: the timestep, the steps between kept samples, and the
        gravity (a packed model has one: a spatial vehicle's may be off)."""
        return self.timestep, self.every, tuple(float(g) for g in self.vehicle.model.opt.gravity)

    @functools.cached_property
    def rails(self) -> Rails | None:
        """The rails under the wheelsets of an irregular track (rail_mj.vehicle.rails); None: perfect."""
        from rail_mj.vehicle.block import track_part_at

        if track_part_at(self.vehicle.model, "") is None:  # straight track (rails, compiled, not imported)
            return None
        from rail_mj.vehicle.rails import Rails

        return Rails.of(self.vehicle.model)

    @functools.cached_property
    def table_end(self) -> float:
        """|y| where a profiled vehicle's contact table ends; inf on coned wheels."""
        profiled = isinstance(contact_model(self.request.layout), Profiled)
        return -table_header(self.vehicle.model)[0] if profiled else math.inf


class Running:
    """A run being stepped: what it has recorded, how far it has come, and the state (qpos,
    qvel) it starts or continues from (None: its request's disturbance)."""

    def __init__(self, index: int, prepared: Prepared):
        self.index, self.prepared = index, prepared
        self.every = prepared.every
        self.count = -(-prepared.n_steps // self.every) + 1  # samples: the last at or past the distance
        self.last = (self.count - 1) * self.every  # the step of the last sample
        stream = prepared.request.stream
        self.sink = None if stream is None else stream(self.count, self.every * prepared.timestep)
        # Streamed, STREAM_CHUNKS chunks' samples at a time (a chunk's steps over `every`, rounded
        # up, each): the sink's fixed cost a call (a piece Run, the contact law, numpy's per-call
        # overhead) amortised over more samples, for a coach 4.6 MB a run in flight.
        size = self.count
        if self.sink is not None:
            size = min(self.count, STREAM_CHUNKS * -(-prepared.chunk // self.every))
        # A flat twin's record is read from its states (JointSensors): each body's yaw angle, as
        # the Run of its samples carries it (Run.body_yaw, which its quaternions are made from when
        # read); else each body's quaternion, from sensors.
        self.pos, self.quat, self.yaw, self.rates, self.loads = _records(prepared.vehicle, size, prepared.stepped.flat)
        # Each wheelset's Sigma Y as the callback recorded it (`record`); None: re-evaluated from
        # the record (not recorded, or not at every sample).
        self.guiding: np.ndarray | None = None
        self.guided = True
        self.held = 0  # streamed: samples in the buffers not yet given to the sink
        self.done = 0  # samples recorded
        self.stepped = 0  # steps taken
        # In the stepped vehicle's coordinates (a flat twin's: Prepared.stepped), as the packs keep it.
        state = prepared.request.state
        self.state = None if state is None else prepared.vehicle.to_stepped(state)
        self.seconds = prepared.seconds  # and its share of the time of the models it was stepped in

    def t(self) -> np.ndarray:
        return np.arange(self.count) * (self.every * self.prepared.timestep)  # exact, unlike data.time

    def record(self, sensors, readings: np.ndarray, guiding: np.ndarray | None = None) -> slice:
        """Put a chunk's sensor readings (a row a sample; a flat twin's, its states) after the
        samples recorded (streamed: at the start of the chunk's buffers), and `guiding`, each
        wheelset's Sigma Y at those samples as the callback recorded it (None: not recorded);
        their slice."""
        start = self.done if self.sink is None else self.held
        mine = slice(start, start + len(readings))
        self.pos[mine, 0] = 0.0  # the world; the sensors the rest
        if self.yaw is not None:
            sensors.poses(readings, self.pos[mine], self.yaw[mine])
        else:
            self.quat[mine, 0] = (1.0, 0.0, 0.0, 0.0)
            sensors.poses(readings, self.pos[mine], self.quat[mine])
        sensors.rates(readings, self.rates[mine])
        sensors.loads(readings, self.loads[mine])
        if guiding is None:
            self.guided = False
        elif self.guided:
            if self.guiding is None:
                self.guiding = np.empty((len(self.pos), guiding.shape[1]))
            self.guiding[mine] = guiding
        return mine

    def _guiding(self, part: slice | None = None) -> np.ndarray | None:
        """The recorded Sigma Y of the samples `part` (all: None), if every sample has one."""
        if not self.guided or self.guiding is None:
            return None
        return self.guiding if part is None else self.guiding[part]

    def left_rails(self, mine: slice, derailment_lateral: float) -> tuple[int, int] | None:
        """(sample, wheelset) where a wheelset first left the rails among the samples `mine`
        (|y| past `derailment_lateral`, or the end of the profiles' table), or None; the sample
        counted from the first of `mine`."""
        vehicle = self.prepared.vehicle
        lateral = np.abs(self.pos[mine][:, vehicle.wheelset_ids, 1])
        rails = self.prepared.rails
        if rails is not None:  # on an irregular track, relative to its rails (each a gauge/2 further out)
            stations = self.pos[mine][:, vehicle.model.body(ODOMETER).id, 0][:, None] + vehicle.sensors.wheelset_x
            y, _, _, gauge = rails.relative(stations, self.pos[mine][:, vehicle.wheelset_ids, 1], 0.0, 0.0, 0.0)
            lateral = np.abs(y) - 0.5 * gauge
        off = np.nonzero(np.max(lateral, axis=1) > self.prepared.derailment(derailment_lateral))[0]
        if not len(off):
            return None
        return int(off[0]), int(np.argmax(lateral[off[0]]))

    def run(self, final):
        """Its result: the Run of every sample, or what its sink makes of them; `final` the
        stepped vehicle's last state (the Run's final_state is its own vehicle's)."""
        p = self.prepared
        final = p.vehicle.from_stepped(final)
        if self.sink is not None:
            return self.sink.finish(final)
        return Run(
            p.vehicle, p.request.speed, p.timestep, self.t(), self.pos, self.quat, self.rates, final, self.loads,
            self._guiding(), self.yaw,
        )  # fmt: skip

    def stream(self, mine: slice) -> None:
        """Keep the samples `mine` of the chunk's buffers for its sink (nothing if it has none),
        and give it the samples held once the buffers could not hold another chunk's, or the
        run's last sample is among them."""
        if self.sink is None:
            return
        self.held = mine.stop
        n = mine.stop - mine.start
        if self.done + n < self.count and self.held + -(-self.prepared.chunk // self.every) <= len(self.pos):
            return
        p, held, first = self.prepared, slice(0, self.held), self.done + n - self.held
        t = np.arange(first, first + self.held) * (self.every * p.timestep)  # as `t`, bit for bit
        piece = Run(
            p.vehicle,
            p.request.speed,
            p.timestep,
            t,
            self.pos[held],
            None if self.quat is None else self.quat[held],
            self.rates[held],
            None,
            self.loads[held],
            self._guiding(held),
            None if self.yaw is None else self.yaw[held],
        )
        self.held = 0
        self.sink.add(piece, first)

    def partial(self, k: int) -> Run | None:
        """The Run of its first k samples (what was simulated before a failure); None streamed."""
        p = self.prepared
        if self.sink is not None:
            return None
        return Run(
            p.vehicle,
            p.request.speed,
            p.timestep,
            self.t()[:k],
            self.pos[:k].copy(),
            None if self.quat is None else self.quat[:k].copy(),
            self.rates[:k].copy(),
            axle_loads=self.loads[:k].copy(),
            guiding=None if (g := self._guiding(slice(0, k))) is None else g.copy(),
            body_yaw=None if self.yaw is None else self.yaw[:k].copy(),
        )


@dataclasses.dataclass
class _Place:
    """Where one vehicle sits in the model that is stepped: its sensors, and its qpos and
    qvel entries."""

    sensors: Sensors | JointSensors
    qpos: np.ndarray
    qvel: np.ndarray
    lateral: np.ndarray  # qpos entries of its root lateral joints
    yaw: np.ndarray  # qpos entries of its wheelsets' yaw joints
    odometer: tuple[int, int] | None = None  # on a curved track: its odometer's qpos and qvel entries
    # Where its wheelsets' Sigma Y sit in sensordata (rail_mj.numerics.GUIDING_SENSOR); None: not recorded.
    guiding: np.ndarray | None = None

    @classmethod
    def whole(cls, vehicle: Vehicle) -> _Place:
        model = vehicle.model
        return cls(
            vehicle.sensors,
            np.arange(model.nq),
            np.arange(model.nv),
            vehicle.root_lateral_dofs,
            vehicle.wheelset_dofs(YAW),
            _odometer(model),
        )


class Pack:
    """A model that one thread steps and the runs in it, each at its place; a place whose
    run has ended is empty (None), its vehicle at rest in the centre."""

    STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS

    def __init__(self, runs: list[Running], alone: bool = False):
        started = time.perf_counter()
        self.runs: list[Running | None] = list(runs)
        # As `simulate` steps it: in a pack of one (no drawn shapes; a train's or a flat twin's
        # springs in the callback; each wheelset's Sigma Y recorded), or with the Python callback in
        # its vehicle's own model.
        self.alone = alone
        vehicle = runs[0].prepared.stepped
        if alone and runs[0].prepared.forces is not None:
            self.model, self.places = vehicle.model, [_Place.whole(vehicle)]
        else:
            # The native callback records each wheelset's Sigma Y as it steps (the Python one does not).
            self.model, self.places = _pack(
                [r.prepared.stepped for r in runs],
                [r.prepared.request.speed for r in runs],
                guiding=runs[0].prepared.forces is None,
            )
        model = self.model
        model.opt.timestep = runs[0].prepared.timestep
        # A run that blows up must stay blown up (non-finite), not be reset by MuJoCo to its
        # start: that is how it is told from the runs stepped beside it.
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
        if _unconstrained(model):  # nothing to constrain: the constraint stages are skipped, same result
            model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
        if _undamped(model):  # no damper of MuJoCo's own (a flat twin's are the callback's): same result
            model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_DAMPER)
        # No bias forces (a flat twin's bodies, each on its slides and one hinge through its centre
        # of mass): stepped without MuJoCo's pass that computes them, to the same bits.
        self.unbiased = applies(model)
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
            if place.odometer is not None:  # from the track's start, at the run's speed
                self.state[1 + place.odometer[0]] = 0.0
                self.state[1 + nq + place.odometer[1]] = run.prepared.request.speed
        else:
            self.state[1 + place.qpos], self.state[1 + nq + place.qvel] = run.state
            # Continued at the request's speed, where it had come to; on a speed profile the state's
            # own (the profile's speed there, to its error), also when a run is repacked mid-way.
            if place.odometer is not None and run.prepared.request.profile is None:
                self.state[1 + nq + place.odometer[1]] = run.prepared.request.speed

    def state_of(self, m: int, vector: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(qpos, qvel) of run m in a state vector of this model."""
        place = self.places[m]
        return vector[1 + place.qpos].copy(), vector[1 + self.model.nq + place.qvel].copy()

    def going(self) -> list[tuple[int, Running]]:
        """The runs still going, each with its place."""
        return [(m, run) for m, run in enumerate(self.runs) if run is not None]

    def share(self, seconds: float) -> None:
        going = self.going()
        for _, run in going:
            run.seconds += seconds / len(going)


def _odometer(model: mujoco.MjModel, prefix: str = "") -> tuple[int, int] | None:
    """The qpos and qvel entries of a vehicle's odometer (rail_mj.vehicle.curve), if it has one."""
    try:
        joint = model.joint(prefix + ODOMETER)
    except KeyError:
        return None
    return int(joint.qposadr[0]), int(joint.dofadr[0])


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


def _undamped(model: mujoco.MjModel) -> bool:
    """Whether MuJoCo has no damper to add (no joint, tendon or flex damping): mjDSBL_DAMPER then
    skips its loop over every dof at every stage, and leaves the passive-force callback, which
    mjDSBL_SPRING would also take with it, running (MuJoCo skips both only when both are off)."""
    poly = getattr(model, "dof_dampingpoly", np.zeros(0))
    return model.ntendon == 0 and model.nflex == 0 and not np.any(model.dof_damping) and not np.any(poly)


def _pack(vehicles: list[Vehicle], speeds: list[float], guiding: bool = False):
    """One model holding every vehicle, attached under the prefixes v0/, v1/, ..., the
    native block listing them all with their speeds; `guiding`: ending with the clock and
    guiding sensors, in which the native callback records each wheelset's Sigma Y
    (rail_mj.numerics.GUIDING_SENSOR)."""
    from rail_mj.numerics import NUMERIC_NATIVE
    from rail_mj.vehicle.spec import compile_spec

    parent = mujoco.MjSpec()
    first = vehicles[0].spec
    parent.option.timestep = first.option.timestep
    parent.option.integrator = first.option.integrator
    parent.option.disableflags = first.option.disableflags
    parent.option.gravity = first.option.gravity  # a spatial vehicle without gravity has none
    native_numeric = parent.add_numeric(name=NUMERIC_NATIVE, data=[0.0])  # first: the block
    for k, vehicle in enumerate(vehicles):
        # The drawn shapes touch nothing and weigh nothing, yet MuJoCo places each one at
        # every stage of every step (a fifth of a coach's step): a packed model goes without
        # them, and each Run keeps its own vehicle's, for its recording. A train's tendons go
        # too: its suspension is summed in the callback (block.spring_rows).
        if vehicle.springs_in_callback:
            child = vehicle.stepping_spec.copy()
        else:
            child = vehicle.spec.copy()
            for geom in list(child.geoms):
                child.delete(geom)
            for mesh in list(child.meshes):
                child.delete(mesh)
        child.nuserdata = 0  # the pack's own, for all of them: set below
        parent.attach(child, prefix=f"v{k}/", frame=parent.worldbody.add_frame())
    layout = vehicles[0].layout
    model = compile_spec(parent, layout)
    entries = []
    for k, (vehicle, speed) in enumerate(zip(vehicles, speeds)):
        bodies = [model.body(f"v{k}/{w}").id for w in vehicle.wheelset_names]
        loads = AxleLoads.of(vehicle.model, vehicle.wheelset_names)
        part = (
            None
            if vehicle.track is None
            else track_part(model, vehicle.layout, vehicle.track, f"v{k}/", profile=vehicle.profile)
        )
        entries.append(
            block.vehicle_block(
                model,
                bodies,
                contact_parameters(vehicle.model, len(bodies)),
                speed,
                loads,
                prefix=f"v{k}/",
                couples=ShearCouples.of(vehicle.model),
                track_part=part,
                springs=block.spring_rows(vehicle.model, model, f"v{k}/") if vehicle.springs_in_callback else (),
            )
        )
    native = block.block(entries)
    native_numeric.data = native.tolist()
    parent.nuserdata = userdata_size(native, model.ntendon)  # the callback's scratch on a curve
    if guiding:  # last, as the callback looks for them: a clock, then an entry per body
        parent.add_sensor(name=CLOCK_SENSOR, type=mujoco.mjtSensor.mjSENS_CLOCK)
        parent.add_sensor(
            name=GUIDING_SENSOR,
            type=mujoco.mjtSensor.mjSENS_USER,
            dim=model.nbody,
            needstage=mujoco.mjtStage.mjSTAGE_POS,
            datatype=mujoco.mjtDataType.mjDATATYPE_REAL,
        )
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
                vehicle.sensors_in(model, prefix=f"v{k}/"),
                qpos,
                qvel,
                qpos[vehicle.root_lateral_dofs],
                qpos[vehicle.wheelset_dofs(YAW)],
                _odometer(model, prefix=f"v{k}/"),
                _guiding(model, vehicle, f"v{k}/") if guiding else None,
            )
        )
    return model, places


def _guiding(model: mujoco.MjModel, vehicle: Vehicle, prefix: str) -> np.ndarray:
    """The sensordata entries of the vehicle's wheelsets' Sigma Y (rail_mj.numerics.GUIDING_SENSOR)."""
    start = int(model.sensor(GUIDING_SENSOR).adr[0])
    return np.array([start + model.body(prefix + w).id for w in vehicle.wheelset_names], dtype=np.int64)


class Roller:
    """One thread's `mujoco.rollout` on the calling thread, into buffers it keeps: the states
    each step starts from (the first `start`, then every step's end but the last), each step's
    end and its sensor readings, views valid until the next call."""

    def __init__(self):
        self._rollout = rollout.Rollout(nthread=0)
        self._states, self._readings = np.empty(0), np.empty(0)

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData, start: np.ndarray, nstep: int, unbiased=False):
        """`unbiased`: the model has no bias forces (rail_mj.simulation.unbiased.applies), and is
        stepped without MuJoCo's pass that computes them, to the same bits, where it can be."""
        nstate, nsensor = start.size, model.nsensordata
        if self._states.size < (nstep + 1) * nstate:
            self._states = np.empty((nstep + 1) * nstate)
        if self._readings.size < nstep * nsensor:
            self._readings = np.empty(nstep * nsensor)
        # Row 0 the start, MuJoCo's states after it: step j starts from row j and ends at row j + 1,
        # so that a record read from states (JointSensors) takes rows 0..nstep-1 without a copy.
        rows = self._states[: (nstep + 1) * nstate].reshape(nstep + 1, nstate)
        rows[0] = start
        readings = self._readings[: nstep * nsensor].reshape(1, nstep, nsensor)
        if not (unbiased and roll(model, data, rows[0], nstep, rows[1:], readings[0])):
            self._rollout.rollout(
                [model], [data], start[None], skip_checks=True, nstep=nstep, state=rows[1:][None], sensordata=readings
            )
        return rows[:-1], rows[1:], readings[0]


def step_alone(prepared: Prepared, derailment_lateral: float, progress=None) -> Run | SimulationError:
    """One run on its own (in a pack of one; with the Python callback, in its vehicle's own
    model): what `simulate` steps."""
    outcome = []
    forces = prepared.forces
    with installed(forces) if forces else native.installed(), stepping():
        later = drive(
            Pack([Running(0, prepared)], alone=True),
            Roller(),
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


def drive(
    pack: Pack, roller: Roller, done, derailment_lateral: float, forces, queue: Waiting | None, progress=None
) -> list[Callable[[], Derailed]]:
    """Step `pack` until its runs have covered their distances (and those that take their
    places from `queue`), telling `done(k, result, seconds)` each result. MuJoCo steps in
    chunks of `Prepared.chunk` steps (`mujoco.rollout`) and measures every body with its
    sensors. A step's sensor values are those of the state it started from (sensors are
    computed in the forward pass, before integration), so step j's record is the sample
    at step j, and a run is stepped one step past its last sample. Every run starts at the
    start of a chunk, so each meets the same chunks and checks as on its own. A run that
    leaves the rails is stopped there (its place emptied, so that it cannot disturb the
    others); a numerical failure stops every run still going, and in a pack of several, each
    is run again on its own. Returns the Derailed results
    still to make when `forces` (the Python callback) is installed: thunks for the caller."""
    later: list[Callable[[], Derailed]] = []
    while True:
        going = pack.going()
        if not going or (queue is not None and queue.cancelled):
            return later
        runs = [r for _, r in going]
        # The steps to the last sample of the run that goes furthest, and one more: a step's
        # sensors are read before it integrates.
        steps = min(runs[0].prepared.chunk, max(r.last + 1 - r.stepped for r in runs))
        started = time.perf_counter()
        start = pack.state
        began, states, readings = roller(pack.model, pack.data, start, steps, pack.unbiased)
        pack.state = states[-1].copy()
        pack.share(time.perf_counter() - started)
        warning = _warnings(pack.data)
        if warning or not (np.all(np.isfinite(readings)) and np.all(np.isfinite(pack.state))):
            _diverged(pack, runs, steps, warning, done, derailment_lateral)
            return later
        first, ended = runs[0].stepped, []
        # A flat twin's samples are states (JointSensors): step j's is the state it started from, `began[j]`.
        for m, r in going:
            # Its samples among this chunk's steps: sample j is at the run's step j*every.
            # A slice (every `every`-th row from the first kept): a view of the pack's readings, not
            # a copy of every vehicle's sensors for each run.
            first_kept = r.done * r.every - r.stepped
            n = max(0, min(r.count, -(-(r.stepped + steps) // r.every)) - r.done)
            kept = slice(first_kept, first_kept + (n - 1) * r.every + 1, r.every) if n else slice(0, 0)
            place = pack.places[m]
            source = began if place.sensors.from_state else readings
            guided = None if place.guiding is None else readings[kept][:, place.guiding]
            mine = r.record(place.sensors, source[kept], guided)
            off = r.left_rails(mine, derailment_lateral)
            if off is not None:
                j, worst = r.done + off[0], off[1]

                def make(r=r, j=j, worst=worst):
                    return _derailed(r.prepared, worst, j, r.t(), derailment_lateral, forces, r.partial(j + 1))

                if forces is None:
                    done(r.index, make(), r.seconds)
                else:
                    later.append(make)
                ended.append((m, r))
                continue
            r.stream(mine)
            if r.done + n == r.count:  # its last sample: the state the run ends in
                last = r.last - r.stepped
                done(r.index, r.run(pack.state_of(m, states[last - 1] if last > 0 else start)), r.seconds)
                ended.append((m, r))
            else:
                r.done += n
                r.stepped += steps
        _refill(pack, ended, queue)
        if progress is not None:
            progress(min(first + steps, runs[0].last) / max(runs[0].last, 1))
        empty = len(pack.runs) - len(pack.going())
        if queue is not None and empty and 2 * empty >= len(pack.runs):
            repacked = _repacked(pack, queue, runs[0].prepared.cadence)
            if repacked is None:
                return later
            pack = repacked


def _diverged(pack: Pack, runs: list[Running], steps: int, warning: str | None, done, derailment_lateral: float):
    """Tell each run of a chunk of `steps` that failed numerically its result: alone, the
    failure; in a pack of several, the run again on its own (the failure may be another run's)."""
    for r in runs:
        if pack.alone:
            dt = r.prepared.timestep
            at = min(r.stepped + steps, r.last) * dt
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
            done(r.index, step_alone(r.prepared, derailment_lateral), r.seconds)


def _refill(pack: Pack, ended: list[tuple[int, Running]], queue: Waiting | None) -> None:
    """Give the places of the runs that ended (place, run) to runs waiting, or leave them empty."""
    for m, run in ended:
        # The longest run waiting of the same vehicle takes the place: only the speed changes.
        item = queue.take_like(run.prepared) if queue is not None else None
        pack.runs[m] = None if item is None else Running(*item)
        if item is not None:
            set_speed(pack.model, item[1].request.speed, vehicle=m)
        pack.start(m)


def _repacked(pack: Pack, queue: Waiting, cadence: tuple) -> Pack | None:
    """Half the places empty: the runs going continue in a new model, with runs waiting
    (None when there are none of either)."""
    keep = pack.going()
    for m, run in keep:
        run.state = pack.state_of(m, pack.state)
    items = queue.take(PACK - len(keep), cadence)
    runs = [run for _, run in keep] + [Running(k, p) for k, p in items]
    return Pack(runs) if runs else None


_STEPPING = threading.Lock()
_stepping_users = 0
_stepping_previous: tuple = ()


@contextlib.contextmanager
def stepping():
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


def _untimed():
    """A native clock that always reads 0 (MuJoCo's default reads the system clock): the native
    callback's library holds it (rail_mj.simulation.native)."""
    from rail_mj.simulation import native

    return native.native().clock


def _records(vehicle: Vehicle, n_samples: int, yawed: bool):
    """Empty arrays for a run's body positions, then its bodies' quaternions, or where `yawed` (a
    flat twin's) their yaw angles (None the other), then each wheelset's rates and axle loads,
    filled as it goes (the memory is touched then, a chunk at a time, not all before the first
    step; the yaw angles' zeros stay for the world and the bodies without a yaw joint)."""
    nbody, n = vehicle.model.nbody, vehicle.n_wheelsets
    return (
        np.empty((n_samples, nbody, 3)),
        None if yawed else np.empty((n_samples, nbody, 4)),
        np.zeros((n_samples, nbody)) if yawed else None,
        np.empty((n_samples, n, 2)),
        np.empty((n_samples, n, 2)),
    )


def _derailed(p: Prepared, worst: int, j: int, t, derailment_lateral: float, forces, run) -> Derailed:
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
    speed, x = r.speed, r.speed * t[j]
    if r.profile is not None and run is not None:  # where it left, at the speed it had there
        x, speed = float(run.x[-1]), float(run.speeds[-1])
        set_speed(p.vehicle.model, speed)  # the run is over: its model is linearised at that speed
    if p.rails is not None and r.track is not None:  # the rails drove it there, whatever the start
        cause = (
            f"The irregularities of {r.track.source} moved it further than its wheels can follow at "
            f"{speed:.4g} m/s, and {why}; lower --speed, or run a smoother track (a smaller irregularities.scale)"
        )
    elif linearly_stable(p.vehicle, forces):
        start = (
            f"the start (shifted {r.initial_lateral:g} m, yawed {r.initial_yaw:g} rad)"
            if r.state is None
            else "the state it started from"
        )
        cause = (
            f"At {speed:.4g} m/s the centred vehicle is stable (every linear mode decays), "
            f"so {start} was too large a disturbance and {why}; start nearer the centre"
        )
    else:
        cause = (
            f"{speed:.4g} m/s is above this vehicle's critical speed (a linear mode grows), "
            f"and {why}; lower --speed or shorten --distance"
        )
    return Derailed(
        f"wheelset {worst + 1} left the rails: |y|{' from its rails' if p.rails is not None else ''} passed "
        f"{derailment_lateral} m at "
        f"x = {x:.4g} m (t = {t[j]:.4g} s). {cause}",
        run,
    )


def _warnings(data) -> str | None:
    raised = np.flatnonzero(data.warning.number)
    return mujoco.mjtWarning(int(raised[0])).name if raised.size else None
