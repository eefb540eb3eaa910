"""The headless runner: a vehicle at constant speed along straight, perfect track.

Example:

    >>> from rail_mj import load_layout, simulate
    >>> run = simulate(load_layout("models/bogie/bogie.toml"), speed=30.0, distance=60.0,
    ...                initial_lateral=0.002)
    >>> run.y.shape[1], round(float(run.x[-1]))   # two wheelsets, 60 m
    (2, 60)

`simulate` picks the timestep (`stable_timestep`), steps MuJoCo with the creep
forces installed, samples each wheelset's absolute lateral displacement and yaw in
the track frame, and raises `SimulationError` if the run diverges, numerically or
physically, saying why.
"""

from __future__ import annotations

import dataclasses
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
from rail_mj.model import YAW, Vehicle
from rail_mj import native
from rail_mj.native import set_speed

# RK4 is stable for |lambda|*dt up to 2.78 on the real axis and 2.83 on the imaginary
# axis; 1.0 for the fastest mode lambda of the linearised vehicle leaves margin, and the
# slow (hunting, kinematic) modes, 10-1000x slower, come out with negligible error.
STEP_FRACTION = 1.0
MAX_TIMESTEP = 1e-3  # s; the modes of interest are below 20 Hz
MAX_STEPS = 50_000_000  # about half an hour of stepping: beyond this, refuse
SAMPLE_INTERVAL = 1e-3  # s between recorded samples (or every step, if longer)
CHECK_EVERY = 200  # samples between divergence checks


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
        states the run recorded."""
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

    @property
    def y(self) -> np.ndarray:
        return self.body_pos[:, self.vehicle.wheelset_ids, 1]

    @property
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
                                        wheelset, positive to the left; 0 off the flange)
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


def stable_timestep(vehicle: Vehicle, forces: CreepForces | None = None) -> float:
    """Timestep for RK4 with explicit creep forces: STEP_FRACTION / (fastest linear rate).

    The creep damping 2*f22/V grows without bound as V falls, so the slowest runs
    need the smallest steps. `forces`: the Python callback, or None for the native one at
    the model's speed.
    """
    rate = np.max(np.abs(np.linalg.eigvals(state_matrix(vehicle.model, forces))))
    if vehicle.layout.flange is not None:
        # In flange contact the rail's stiffness and the steep radius rise add faster
        # rates: linearise there too, the whole vehicle pressed 2 mm into the flanges.
        qpos0 = np.zeros(vehicle.model.nq)
        qpos0[vehicle.root_lateral_dofs] = vehicle.layout.wheelset.flangeway_clearance + 0.002
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
    for name, value in (("speed", speed), ("distance", distance)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a positive number, got {value}")
    for name, value in (("initial lateral", initial_lateral), ("initial yaw", initial_yaw)):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
    if abs(initial_lateral) >= derailment_lateral:
        raise ValueError(
            f"initial lateral {initial_lateral} m puts the wheels off the rails "
            f"(|y| must be below {derailment_lateral} m)"
        )

    vehicle = Vehicle(layout)
    model = vehicle.model
    set_speed(model, speed)
    # The native callback unless the Python one is asked for (the tests compare them).
    forces = CreepForces(model, vehicle.wheelset_names, speed) if python_callback else None
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
    n_steps = math.ceil(steps)
    model.opt.timestep = dt
    data = mujoco.MjData(model)
    if state is None:
        data.qpos[vehicle.root_lateral_dofs] = initial_lateral
        data.qpos[vehicle.wheelset_dofs(YAW)] = initial_yaw
    else:
        data.qpos[:], data.qvel[:] = state

    every = max(1, round(SAMPLE_INTERVAL / dt))
    n_samples = -(-n_steps // every) + 1  # the last sample at or past `distance`
    t = np.arange(n_samples) * (every * dt)  # exact, where data.time accumulates round-off
    pos = np.zeros((n_samples, model.nbody, 3))
    quat = np.zeros((n_samples, model.nbody, 4))
    quat[:, 0, 0] = 1.0  # the world
    rates = np.empty((n_samples, vehicle.n_wheelsets, 2))
    sensors = vehicle.sensors

    def partial(k: int) -> Run:
        return Run(vehicle, speed, dt, t[:k].copy(), pos[:k].copy(), quat[:k].copy(), rates[:k].copy())

    # MuJoCo steps in chunks (`mujoco.rollout`) and measures every body with its sensors;
    # a step's sensor values are those of the state it started from (sensors are computed
    # in the forward pass before integration), so step j's record is sample j/every's.
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    current = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, current, spec)
    chunk = CHECK_EVERY * every
    done = 0  # samples recorded and checked
    derailed = None  # (sample, wheelset) where a wheelset left the rails
    with installed(forces) if forces else native.installed():
        while done < n_samples:
            count = min(CHECK_EVERY, n_samples - done)
            start = current
            states, readings = rollout.rollout(model, data, current, nstep=count * every)
            readings = readings[0, ::every]
            batch = slice(done, done + count)
            sensors.poses(readings, pos[batch], quat[batch])
            sensors.rates(readings, rates[batch])
            current = states[0, -1]
            warning = _warnings(data)
            if warning or not np.all(np.isfinite(readings)):
                raise SimulationError(
                    f"diverged by t = {t[done + count - 1]:.4g} s (x = {speed * t[done + count - 1]:.4g} m): "
                    f"MuJoCo reported {warning or 'non-finite positions'} with timestep {dt:.3g} s at "
                    f"{speed:g} m/s; the suspension or creep stiffness is too high for this step",
                    partial(done),
                )
            lateral = np.abs(pos[batch][:, vehicle.wheelset_ids, 1])
            off = np.nonzero(np.max(lateral, axis=1) > derailment_lateral)[0]
            if len(off):
                derailed = done + off[0], int(np.argmax(lateral[off[0]]))
                break
            done += count
            if progress is not None:
                progress(min(done, n_samples - 1) / (n_samples - 1))
    # The last sample's state: the run ends there (the chunk ran `every` steps past it).
    final = states[0, (count - 1) * every - 1] if count > 1 else start
    if derailed is not None:
        j, worst = derailed
        why = ("the flanges did not hold it" if layout.flange else
               "without [flange] contact nothing bounds the motion")
        if _linearly_stable(vehicle, forces):
            start = (f"the start (shifted {initial_lateral:g} m, yawed {initial_yaw:g} rad)"
                     if state is None else "the state it started from")
            cause = (f"At {speed:g} m/s the centred vehicle is stable (every linear mode decays), "
                     f"so {start} was too large a disturbance and {why}; start nearer the centre")
        else:
            cause = (f"{speed:g} m/s is above this vehicle's critical speed (a linear mode grows), "
                     f"and {why}; lower --speed or shorten --distance")
        raise Derailed(
            f"wheelset {worst + 1} left the rails: |y| passed {derailment_lateral} m at "
            f"x = {speed * t[j]:.4g} m (t = {t[j]:.4g} s). {cause}",
            partial(j + 1),
        )
    return Run(vehicle, speed, dt, t, pos, quat, rates, _qpos_qvel(model, final))


def _qpos_qvel(model: mujoco.MjModel, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(qpos, qvel) of a full-physics state vector: time, then qpos, then qvel."""
    return state[1:1 + model.nq].copy(), state[1 + model.nq:1 + model.nq + model.nv].copy()


