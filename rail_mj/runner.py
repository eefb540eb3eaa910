"""The headless runner: vehicles at constant speed along straight, perfect track.

Example:

    >>> from rail_mj import load_layout, simulate
    >>> run = simulate(load_layout("models/bogie/bogie.toml"), speed=30.0, distance=60.0,
    ...                initial_lateral=0.002)
    >>> run.y.shape[1], round(float(run.x[-1]))   # two wheelsets, 60 m
    (2, 60)

`simulate` picks the timestep (`stable_timestep`), steps MuJoCo with the native creep
callback (rail_mj.native) in chunks (`mujoco.rollout`), records every body's pose and
each wheelset's rates with MuJoCo's sensors, and raises `SimulationError` if the run
diverges, numerically or physically, saying why. `simulate_many` steps many runs
together, packed several vehicles to a model, each with exactly `simulate`'s result.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
from typing import Callable

import mujoco
import numpy as np
from mujoco import rollout

from rail_mj.creep import ContactForces, contact_forces
from rail_mj.forces import CreepForces, contact_parameters, installed
from rail_mj.layout import Layout
from rail_mj.practice import DERAILMENT_LATERAL
from rail_mj.linear import modal_roots, state_matrix
from rail_mj.model import NUMERIC_GEOMETRY, YAW, Vehicle
from rail_mj import native
from rail_mj.native import set_speed

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

    def __init__(self, message: str, run: "Run | None" = None):
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

    def contact_forces(self) -> ContactForces:
        """The rails' forces on each wheelset at every sample, by origin: arrays of shape
        (n_samples, n_wheelsets). One call of the creep law over every sample, from the
        states the run recorded (once: the summary, the CSV and the recording share it)."""
        return self._contact_forces

    @functools.cached_property
    def _contact_forces(self) -> ContactForces:
        params = contact_parameters(self.vehicle.model, len(self.vehicle.wheelset_names))
        rates = self.wheelset_rates
        return contact_forces(params, self.y, self.psi, rates[..., 0], rates[..., 1], self.speed)

    def guiding_forces(self) -> np.ndarray:
        """(n_samples, n_wheelsets): the sum of guiding forces (Sigma Y, N) of each
        wheelset, creep and flange."""
        return self.contact_forces().lateral

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
        return _yaw(self.body_quat[:, self._frame_ids])

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
        return names, np.column_stack(cols)


def _yaw(quat: np.ndarray) -> np.ndarray:
    """Yaw of MuJoCo quaternions (w, x, y, z) over the last axis. The bodies turn about z
    alone (lateral and yaw joints): quaternion (cos psi/2, 0, 0, sin psi/2)."""
    return 2.0 * np.arctan2(quat[..., 3], quat[..., 0])


def _table_header(model: mujoco.MjModel) -> tuple[float, float]:
    """(first y, step in y), m, of a profiled model's contact table (rail_mj.tables)."""
    from rail_mj.tables import HEADER_DY, HEADER_Y0, MM

    header = model.numeric(NUMERIC_GEOMETRY).data
    return float(header[HEADER_Y0]) * MM, float(header[HEADER_DY]) * MM


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
        shift = (layout.wheelset.flangeway_clearance + 0.002 if layout.profiles is None
                 else layout.wheelset.flangeway_clearance - 0.5 * _table_header(vehicle.model)[1])
        qpos0 = np.zeros(vehicle.model.nq)
        qpos0[vehicle.root_lateral_dofs] = shift
        engaged = state_matrix(vehicle.model, forces, qpos0=qpos0)
        rate = max(rate, np.max(np.abs(np.linalg.eigvals(engaged))))
    return min(MAX_TIMESTEP, STEP_FRACTION / rate) if rate > 0 else MAX_TIMESTEP


def _linearly_stable(vehicle: Vehicle, forces: CreepForces | None) -> bool:
    """Whether every mode of the vehicle linearised about the centred state decays."""
    return bool(np.max(modal_roots(state_matrix(vehicle.model, forces)).real) < 0)


def _warnings(data) -> str | None:
    for i, w in enumerate(data.warning):
        if w.number:
            return mujoco.mjtWarning(i).name
    return None


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
        cause = (f"the creep damping 2*f22/V = {2 * c.f22 / speed:.3g} N s/m on a {w.mass:g} kg "
                 f"wheelset" if creep_rate * dt > 0.5 * STEP_FRACTION
                 else "the fastest mode of the linearised vehicle")
        raise RunRefused(
            f"{speed:g} m/s for {distance:g} m is too slow to simulate: {cause} needs a timestep "
            f"of {dt:.2g} s, {steps:.3g} steps (limit {MAX_STEPS:.0e}); raise --speed or "
            f"shorten --distance"
        )
    return _Prepared(request, vehicle, dt, math.ceil(steps), forces)


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
    (rail_mj.native); `python_callback` uses the Python one (rail_mj.forces) instead.
    """
    prepared = prepare(Request(layout, speed, distance, initial_lateral, initial_yaw, state), python_callback)
    ((result,),) = _step([_Pack.alone(prepared)], progress, derailment_lateral, prepared.forces)
    if isinstance(result, SimulationError):
        raise result
    return result


# Vehicles a model when runs are stepped together: a step of a model of eight coaches
# costs a little over a third of eight steps of one, and far fewer Python round trips.
PACK = 8


def simulate_many(requests: list[Request], threads: int = 1, derailment_lateral: float = DERAILMENT_LATERAL,
                  ) -> list[Run | Exception]:
    """Many runs stepped together: runs of one timestep are packed, PACK to a MuJoCo model
    (each vehicle attached under its own name prefix, its own speed in the native block),
    in the order of their length so that few steps are wasted on runs that have ended, and
    the models are stepped side by side by `mujoco.rollout` on `threads` threads. Each
    result is exactly the Run that `simulate` gives for its request, bit for bit, or the
    exception it raises (ValueError, SimulationError). A numerical failure while packed
    is put down to its runs one by one, each run again on its own."""
    results: list = [None] * len(requests)
    groups: dict[float, list[tuple[int, _Prepared]]] = {}
    for k, request in enumerate(requests):
        try:
            prepared = prepare(request)
        except (ValueError, SimulationError) as e:
            results[k] = e
            continue
        groups.setdefault(prepared.timestep, []).append((k, prepared))
    for group in groups.values():
        group.sort(key=lambda item: (item[1].n_steps, item[0]))
        packs = [_Pack.of([item for item in group[j:j + PACK]]) for j in range(0, len(group), PACK)]
        # rollout steps models side by side only when their sizes agree: the full packs
        # together, a last, smaller one on its own.
        by_size: dict[tuple, list[_Pack]] = {}
        for pack in packs:
            by_size.setdefault(pack.size, []).append(pack)
        for same in by_size.values():
            stepped = _step(same, None, derailment_lateral, None, threads)
            for pack, outcomes in zip(same, stepped):
                for k, p, result in zip(pack.indices, pack.prepared, outcomes):
                    if isinstance(result, SimulationError) and not isinstance(result, Derailed) \
                            and len(pack.prepared) > 1:
                        ((result,),) = _step([_Pack.alone(p)], None, derailment_lateral, None)
                    results[k] = result
    return results


@dataclasses.dataclass
class _Pack:
    """A model to step and the runs it holds, each at its place in it."""

    model: mujoco.MjModel
    prepared: list[_Prepared]
    places: list["_Place"]
    indices: tuple[int, ...] = ()  # the runs' places in the caller's list

    @classmethod
    def alone(cls, prepared: _Prepared) -> "_Pack":
        return cls(prepared.vehicle.model, [prepared], [_Place.whole(prepared.vehicle)], (0,))

    @classmethod
    def of(cls, items: list[tuple[int, _Prepared]]) -> "_Pack":
        indices, prepared = zip(*items)
        if len(prepared) == 1:
            return dataclasses.replace(cls.alone(prepared[0]), indices=indices)
        model, places = _pack([p.vehicle for p in prepared], [p.request.speed for p in prepared])
        return cls(model, list(prepared), places, indices)

    @property
    def size(self) -> tuple:
        m = self.model
        return (m.nq, m.nv, m.nbody, m.njnt, m.nsensordata, m.nnumericdata, self.prepared[0].timestep)


@dataclasses.dataclass
class _Place:
    """Where one vehicle sits in the model that is stepped: its sensors, and its qpos and
    qvel entries."""

    sensors: object  # rail_mj.model.Sensors
    qpos: np.ndarray
    qvel: np.ndarray
    lateral: np.ndarray  # qpos entries of its root lateral joints
    yaw: np.ndarray  # qpos entries of its wheelsets' yaw joints

    @classmethod
    def whole(cls, vehicle: Vehicle) -> "_Place":
        model = vehicle.model
        return cls(vehicle.sensors, np.arange(model.nq), np.arange(model.nv),
                   vehicle.root_lateral_dofs, vehicle.wheelset_dofs(YAW))


def _pack(vehicles: list[Vehicle], speeds: list[float]):
    """One model holding every vehicle, attached under the prefixes v0/, v1/, ..., the
    native block listing them all with their speeds."""
    from rail_mj.model import NUMERIC_NATIVE, Sensors, compile_spec

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
        entries.append(native.vehicle_block(model, bodies, contact_parameters(vehicle.model, len(bodies)), speed))
    native_numeric.data = native.block(entries).tolist()
    model = compile_spec(parent, layout)
    places = []
    for k, vehicle in enumerate(vehicles):
        own = vehicle.model
        joints = [model.joint(f"v{k}/{own.joint(j).name}").id for j in range(own.njnt)]
        qpos = np.array([model.jnt_qposadr[j] for j in joints], dtype=np.int64)
        qvel = np.array([model.jnt_dofadr[j] for j in joints], dtype=np.int64)
        # Each own joint is one coordinate (slide or hinge): own index -> packed index.
        places.append(_Place(Sensors(model, vehicle.wheelset_names, prefix=f"v{k}/"), qpos, qvel,
                             qpos[vehicle.root_lateral_dofs], qpos[vehicle.wheelset_dofs(YAW)]))
    return model, places


def _step(packs: list[_Pack], progress, derailment_lateral: float, forces, threads: int = 1,
          ) -> list[list[Run | SimulationError]]:
    """Step every pack (models of one size and timestep, side by side on `threads`
    threads) until each run has covered its distance. MuJoCo steps in chunks
    (`mujoco.rollout`) and measures every body with its sensors. A step's sensor values
    are those of the state it started from (sensors are computed in the forward pass,
    before integration), so step j's record is the sample at step j. A run that leaves
    the rails is stopped there (its part of the state re-centred, so that it cannot
    disturb the others); a numerical failure stops every run still going."""
    dt = packs[0].prepared[0].timestep
    every = max(1, round(SAMPLE_INTERVAL / dt))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    current, counts, records, results, finals, derails = [], [], [], [], [], []
    for pack in packs:
        model = pack.model
        model.opt.timestep = dt
        data = mujoco.MjData(model)
        for p, place in zip(pack.prepared, pack.places):
            r = p.request
            if r.state is None:
                data.qpos[place.lateral] = r.initial_lateral
                data.qpos[place.yaw] = r.initial_yaw
            else:
                data.qpos[place.qpos], data.qvel[place.qvel] = r.state
        state = np.empty(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, state, spec)
        current.append(state)
        counts.append([-(-p.n_steps // every) + 1 for p in pack.prepared])  # the last at or past the distance
        records.append([_records(p.vehicle, max(counts[-1])) for p in pack.prepared])
        results.append([None] * len(pack.prepared))
        finals.append([None] * len(pack.prepared))
        derails.append({})  # run -> (sample, wheelset) where it left the rails
    n_samples = max(max(c) for c in counts)
    t = np.arange(n_samples) * (every * dt)  # exact, where data.time accumulates round-off

    def partial(a: int, m: int, k: int) -> Run:
        pos, quat, rates = records[a][m]
        return Run(packs[a].prepared[m].vehicle, packs[a].prepared[m].request.speed, dt, t[:k].copy(),
                   pos[:k].copy(), quat[:k].copy(), rates[:k].copy())

    for pack in packs:
        # A run that blows up must stay blown up (non-finite) in its own pack, not be reset by
        # MuJoCo to its start: that is how it is told from the runs stepped beside it.
        pack.model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)
    datas = [mujoco.MjData(packs[0].model) for _ in range(max(1, min(threads, len(packs))))]
    nq = packs[0].model.nq
    done = 0  # samples recorded and checked
    active = list(range(len(packs)))
    with installed(forces) if forces else native.installed(), _quiet_mujoco():
        while active:
            count = min(CHECK_EVERY, max(max(counts[a]) for a in active) - done)
            starts = [current[a] for a in active]
            states, readings = rollout.rollout([packs[a].model for a in active], datas[:len(active)],
                                               np.array(starts), nstep=count * every)
            # MuJoCo's warnings are counted per thread, not per pack: they name a failure only
            # when one pack is stepped; otherwise the pack's own non-finite values do.
            warning = _warnings(datas[0]) if len(active) == 1 else None
            for b, a in enumerate(active):
                current[a] = states[b, -1].copy()
                mine_all = readings[b, ::every]
                if warning or not (np.all(np.isfinite(mine_all)) and np.all(np.isfinite(current[a]))):
                    at = t[min(done + count, n_samples) - 1]
                    for m, p in enumerate(packs[a].prepared):
                        if results[a][m] is None and done < counts[a][m]:
                            results[a][m] = SimulationError(
                                f"diverged by t = {at:.4g} s (x = {p.request.speed * at:.4g} m): MuJoCo reported "
                                f"{warning or 'non-finite positions'} with timestep {dt:.3g} s at "
                                f"{p.request.speed:g} m/s; the suspension or creep stiffness is too high for "
                                f"this step", partial(a, m, done))
                    continue
                for m, (p, place) in enumerate(zip(packs[a].prepared, packs[a].places)):
                    if results[a][m] is not None or done >= counts[a][m]:
                        continue
                    mine = slice(done, min(done + count, counts[a][m]))
                    pos, quat, rates = records[a][m]
                    place.sensors.poses(mine_all[:mine.stop - done], pos[mine], quat[mine])
                    place.sensors.rates(mine_all[:mine.stop - done], rates[mine])
                    lateral = np.abs(pos[mine][:, p.vehicle.wheelset_ids, 1])
                    off = np.nonzero(np.max(lateral, axis=1) > p.derailment(derailment_lateral))[0]
                    if len(off):
                        derails[a][m] = done + off[0], int(np.argmax(lateral[off[0]]))
                        results[a][m] = partial(a, m, derails[a][m][0] + 1)  # its Derailed is made below
                        current[a][1 + place.qpos] = 0.0  # re-centred: it cannot blow up the others
                        current[a][1 + nq + place.qvel] = 0.0
                    elif mine.stop == counts[a][m]:  # its last sample: the state the run ends in
                        last = mine.stop - 1 - done
                        state = states[b, last * every - 1] if last > 0 else starts[b]
                        finals[a][m] = (state[1 + place.qpos].copy(), state[1 + nq + place.qvel].copy())
            done += count
            active = [a for a in active if done < max(counts[a])
                      and any(r is None for r in results[a])]
            if progress is not None:
                progress(min(done, n_samples - 1) / max(n_samples - 1, 1))
    for a, pack in enumerate(packs):
        for m, (j, worst) in derails[a].items():  # outside the callback's block: the cause linearises
            results[a][m] = _derailed(pack.prepared[m], worst, j, t, derailment_lateral, forces, results[a][m])
        for m, p in enumerate(pack.prepared):
            if results[a][m] is None:
                pos, quat, rates = records[a][m]
                k = counts[a][m]
                results[a][m] = Run(p.vehicle, p.request.speed, dt, t[:k], pos[:k], quat[:k], rates[:k], finals[a][m])
    return results


@contextlib.contextmanager
def _quiet_mujoco():
    """While stepping, MuJoCo's warnings are not printed nor appended to MUJOCO_LOG.TXT in
    the working folder: the runner reports a failure itself, in one line, naming the
    warning (from the data's warning counters)."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def _records(vehicle: Vehicle, n_samples: int):
    """Empty arrays for a run's body positions, quaternions (the world's set) and rates."""
    nbody = vehicle.model.nbody
    pos, quat = np.empty((n_samples, nbody, 3)), np.empty((n_samples, nbody, 4))
    pos[:, 0], quat[:, 0] = 0.0, (1.0, 0.0, 0.0, 0.0)  # the world; the sensors fill the rest
    return pos, quat, np.empty((n_samples, vehicle.n_wheelsets, 2))


def _derailed(p: _Prepared, worst: int, j: int, t, derailment_lateral: float, forces, run) -> "Derailed":
    """Why a wheelset left the rails: the speed (a linear mode grows) or the start."""
    r = p.request
    derailment_lateral = p.derailment(derailment_lateral)
    why = ("its wheel climbed the flange (past the profiles' contact table)" if r.layout.profiles else
           "the flanges did not hold it" if r.layout.flange else
           "without [flange] contact nothing bounds the motion")
    if _linearly_stable(p.vehicle, forces):
        start = (f"the start (shifted {r.initial_lateral:g} m, yawed {r.initial_yaw:g} rad)"
                 if r.state is None else "the state it started from")
        cause = (f"At {r.speed:g} m/s the centred vehicle is stable (every linear mode decays), "
                 f"so {start} was too large a disturbance and {why}; start nearer the centre")
    else:
        cause = (f"{r.speed:g} m/s is above this vehicle's critical speed (a linear mode grows), "
                 f"and {why}; lower --speed or shorten --distance")
    return Derailed(
        f"wheelset {worst + 1} left the rails: |y| passed {derailment_lateral} m at "
        f"x = {r.speed * t[j]:.4g} m (t = {t[j]:.4g} s). {cause}", run)
