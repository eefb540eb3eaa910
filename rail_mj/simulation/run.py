"""A run: what is asked of it (`Request`) and what it gives (`Run`), or why it failed.

A `Run` holds the samples MuJoCo's sensors recorded (every body's pose, each wheelset's
rates and a spatial vehicle's axle loads) and the kinematics read from them; the contact
forces are the creep law's, recomputed from those samples. What the samples show (EN
14363's quantities, the summary) is rail_mj.analysis's; the CSV columns, rail_mj.output.samples's.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np

from rail_mj.contact.creep import ContactForces, contact_forces
from rail_mj.layout import Layout
from rail_mj.practice import INITIAL_LATERAL
from rail_mj.track import SpeedProfile, Track
from rail_mj.track.irregularities import RAIL_BASE
from rail_mj.track.speed import PROFILE_TRACK
from rail_mj.units import GRAVITY
from rail_mj.vehicle.curve import ODOMETER
from rail_mj.vehicle.loads import AxleLoads
from rail_mj.vehicle.spec import Vehicle

if TYPE_CHECKING:
    from rail_mj.vehicle.rails import Rails


@dataclasses.dataclass
class Request:
    """One run to make: a layout at a speed for a distance, from a disturbed start (or from
    `state` = (qpos, qvel), to continue a run)."""

    layout: Layout
    speed: float
    distance: float
    initial_lateral: float = INITIAL_LATERAL  # m, as `simulate`
    initial_yaw: float = 0.0
    state: tuple[np.ndarray, np.ndarray] | None = None
    track: Track | None = None  # None: straight track
    # The speed along the track (rail_mj.track.speed), `speed` its value at the start; None: constant.
    profile: SpeedProfile | None = None
    # Seconds between the samples the run keeps (rounded to whole steps); None: every millisecond
    # (rail_mj.simulation.stepping.SAMPLE_INTERVAL). The steps are the same either way: a sample
    # kept is the one a full record has at that time, bit for bit. Fewer samples are a long run's
    # way to fit in memory; what is read from them is not low-passed first (README, Speed: memory).
    sample_interval: float | None = None
    # Where the run's samples go instead of a record: `stream(n_samples, interval)` makes a Sink,
    # given the samples a chunk at a time, whose `finish` is the run's result (a sweep's row
    # needs a few numbers, not every body's pose at every sample). None: a Run of every sample.
    stream: Callable[[int, float], Sink] | None = dataclasses.field(default=None, compare=False)


class Sink(Protocol):
    """What takes a run's samples as they are stepped (`Request.stream`): `add` is told each
    chunk's, as a Run of those samples (sample `start` its first; its arrays are reused after the
    call: keep copies), `finish` the state the run ends in, and returns the run's result."""

    def add(self, piece: Run, start: int) -> None: ...

    def finish(self, final_state: tuple[np.ndarray, np.ndarray]) -> object: ...


class _FromYaw:
    """`Run.body_quat`: the quaternions given, or where None is given, the turns about z of the
    bodies' yaw angles (`Run.body_yaw`, a flat twin's record: every body square to the track but
    for its yaw), (cos psi/2, 0, 0, sin psi/2), made when first read. A sweep's summary reads
    yaw only, and turning every sample's angles into quaternions was a tenth of its work beside
    the stepping; a run's record no longer holds them until asked."""

    def __get__(self, run, owner=None) -> np.ndarray:
        if run is None:  # a dataclass field without a default
            raise AttributeError("body_quat")
        quat = run.__dict__["_body_quat"]
        if quat is None:
            if run.body_yaw is None:
                raise ValueError("a Run needs body_quat or body_yaw")
            half = 0.5 * run.body_yaw
            quat = np.zeros((*half.shape, 4))
            quat[..., 0] = np.cos(half)
            quat[..., 3] = np.sin(half)
            run.__dict__["_body_quat"] = quat
        return quat

    def __set__(self, run, value: np.ndarray | None) -> None:
        run.__dict__["_body_quat"] = value


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
    speed: float  # m/s; on a speed profile its speed at the start (`speeds`: at every sample)
    timestep: float
    t: np.ndarray
    body_pos: np.ndarray  # (n_samples, nbody, 3): every body's position in the moving frame
    # (n_samples, nbody, 4): and orientation, MuJoCo's w, x, y, z; given as None where `body_yaw`
    # is given, made from it when first read. A descriptor without a default (its class access
    # raises AttributeError, which dataclasses read so): mypy takes it for one, hence the ignore.
    body_quat: _FromYaw = _FromYaw()
    wheelset_rates: np.ndarray  # type: ignore[misc]  # (n_samples, n_wheelsets, 2): y_dot (m/s), psi_dot (rad/s)
    final_state: tuple[np.ndarray, np.ndarray] | None = None  # (qpos, qvel) at the end
    # (n_samples, n_wheelsets, 2): a spatial vehicle's axle load P (N) and roll moment M (N m)
    # from its suspension (rail_mj.vehicle.loads); None or NaN: the wheels carry the layout's static load.
    axle_loads: np.ndarray | None = None
    # (n_samples, n_wheelsets): each wheelset's Sigma Y (N) as the native callback applied it at each
    # sample (a run stepped in a pack, rail_mj.numerics.GUIDING_SENSOR); None: `guiding_forces`
    # evaluates the law again from the record, which gives the same to round-off.
    guiding: np.ndarray | None = None
    # (n_samples, nbody): each body's yaw about z (rad), where the record holds it as an angle (a
    # flat twin's yaw joints: rail_mj.vehicle.sensors.JointSensors); `psi` and a planar run's
    # `frame_psi` read it instead of turning body_quat back into angles (the same to an ulp).
    # None: they read body_quat.
    body_yaw: np.ndarray | None = None

    def contact_forces(self) -> ContactForces:
        """The rails' forces on each wheelset at every sample, by origin: arrays of shape
        (n_samples, n_wheelsets). One call of the creep law over every sample, from the
        states the run recorded (once: the summary, the CSV and the recording share it)."""
        return self._contact_forces

    @functools.cached_property
    def _contact_forces(self) -> ContactForces:
        params = self.vehicle.contact_parameters
        rates = self.wheelset_rates.copy()
        # On a curve the track turns under each wheelset at V*k: its absolute yaw rate, as the
        # callback gives the contact law (rail_mj.simulation.curve).
        speed = self.speeds[:, None]
        rates[..., 1] += speed * self.wheelset_curvature
        y, psi, gauge = self.y, self.psi, None
        rails = self.rails
        if rails is not None:  # on an irregular track each wheelset relative to its rails, as the callback has it
            y, psi, rates[..., 0], gauge = rails.relative(self.wheelset_station, y, psi, rates[..., 0], speed)
        loads = self.axle_loads
        if loads is None or np.isnan(loads).all():
            return contact_forces(
                params,
                y,
                psi,
                rates[..., 0],
                rates[..., 1],
                speed,
                nominal=self.layout.wheelset.wheel_load,
                gauge=gauge,
            )
        axle = AxleLoads.of(self.vehicle.model, self.vehicle.wheelset_names)
        # Axle loads are recorded only from a spatial vehicle's suspension (rail_mj.vehicle.sensors).
        assert axle is not None, "axle loads recorded from a vehicle without a suspension's loads"
        return contact_forces(
            params,
            y,
            psi,
            rates[..., 0],
            rates[..., 1],
            speed,
            loads[..., 0],
            loads[..., 1],
            **axle.contact(),
            gauge=gauge,
        )

    def guiding_forces(self) -> np.ndarray:
        """(n_samples, n_wheelsets): the sum of guiding forces (Sigma Y, N) of each
        wheelset, creep and flange: as the callback applied them, where it recorded them
        (`guiding`), else `contact_forces().lateral` (the law again from the record: the same
        to round-off)."""
        if self.guiding is not None:
            return self.guiding
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

    def columns(self) -> tuple[list[tuple[str, str]], list[np.ndarray]]:
        """Every sampled quantity as (name, unit) and its values, one per sample, SI units: the
        columns of `rail-mj run --out` (rail_mj.output.samples, where each is described) and of
        `to_dataframe`. Units are written as in names: s, m, rad, n (newtons), 1_per_m, m_per_s,
        and "" for a ratio."""
        names: list[tuple[str, str]] = [("t", "s"), ("x", "m")]
        cols = [self.t, self.x]
        y, psi = self.y, self.psi
        for i in range(self.n_wheelsets):
            names += [(f"y{i + 1}", "m"), (f"psi{i + 1}", "rad")]
            cols += [y[:, i], psi[:, i]]
        forces = self.contact_forces()
        for i in range(self.n_wheelsets):
            names += [(f"sum_y{i + 1}", "n"), (f"flange{i + 1}", "n")]
            cols += [forces.lateral[:, i], forces.flange_lateral[:, i]]
        frame_y, frame_psi = self.frame_y, self.frame_psi
        for k, name in enumerate(self.frame_names):
            names += [(f"y_{name}", "m"), (f"psi_{name}", "rad")]
            cols += [frame_y[:, k], frame_psi[:, k]]
        if self.layout.spatial is not None:  # a planar run's columns stay as they were
            q, lateral, quotient = self.wheel_loads(), self.wheel_lateral_forces(), self.derailment_quotients()
            for i in range(self.n_wheelsets):
                for what, unit, values in (("q", "n", q), ("ylat", "n", lateral), ("y_over_q", "", quotient)):
                    names += [(f"{what}_left{i + 1}", unit), (f"{what}_right{i + 1}", unit)]
                    cols += [values[:, i, 0], values[:, i, 1]]
            roll, pitch, bounce = self.frame_roll, self.frame_pitch, self.frame_bounce
            for k, name in enumerate(self.frame_names):
                names += [(f"bounce_{name}", "m"), (f"roll_{name}", "rad"), (f"pitch_{name}", "rad")]
                cols += [bounce[:, k], roll[:, k], pitch[:, k]]
        if self.track is not None:  # a run on straight track keeps its columns
            cant = self.track.cant(self.wheelset_station)
            names += [(f"curvature{i + 1}", "1_per_m") for i in range(self.n_wheelsets)]
            cols += [self.wheelset_curvature[:, i] for i in range(self.n_wheelsets)]
            names += [(f"cant{i + 1}", "m") for i in range(self.n_wheelsets)]
            cols += [cant[:, i] for i in range(self.n_wheelsets)]
        rails = self.rails
        if rails is not None:  # on irregular track: the rails under each wheelset, the floor's accelerations
            from rail_mj.vehicle.rails import ALIGNMENT, GAUGE, LEVEL, ROLL

            at = rails.at(self.wheelset_station)
            for name, entry, factor in (
                ("alignment", ALIGNMENT, 1.0),
                ("level", LEVEL, 1.0),
                ("cross_level", ROLL, RAIL_BASE),
                ("gauge", GAUGE, 1.0),
            ):
                names += [(f"{name}{i + 1}", "m") for i in range(self.n_wheelsets)]
                cols += [factor * at[:, i, entry] for i in range(self.n_wheelsets)]
            floor = self.floor_accelerations()
            if floor is not None:
                names += [(f"floor_lateral_{p}", "m_per_s2") for p in floor.names]
                cols += list(floor.lateral.T)
                if floor.vertical is not None:
                    names += [(f"floor_vertical_{p}", "m_per_s2") for p in floor.names]
                    cols += list(floor.vertical.T)
        if self.profile is not None:  # a run at constant speed keeps its columns
            names.append(("speed", "m_per_s"))
            cols.append(self.speeds)
        return names, cols

    def to_dataframe(self):
        """The run's samples as a pandas DataFrame, a row a sample: the columns of `columns`,
        each named with its unit (`t_s`, `x_m`, `y1_m`, `psi1_rad`, `sum_y1_n`, `y_over_q_left1`).

        Example:

            >>> from rail_mj import load_layout, simulate
            >>> run = simulate(load_layout("models/wheelset/wheelset.toml"), 30.0, 10.0)
            >>> list(run.to_dataframe().columns)
            ['t_s', 'x_m', 'y1_m', 'psi1_rad', 'sum_y1_n', 'flange1_n']
        """
        import pandas as pd

        names, cols = self.columns()
        return pd.DataFrame({f"{name}_{unit}" if unit else name: col for (name, unit), col in zip(names, cols)})

    @functools.cached_property
    def rails(self) -> Rails | None:
        """The rails under the wheelsets of an irregular track (rail_mj.vehicle.rails); None: perfect."""
        from rail_mj.vehicle.block import track_part_at

        if track_part_at(self.vehicle.model, "") is None:  # straight track (rails, compiled, not imported)
            return None
        from rail_mj.vehicle.rails import Rails

        return Rails.of(self.vehicle.model)

    @property
    def layout(self) -> Layout:
        return self.vehicle.layout

    @functools.cached_property
    def y(self) -> np.ndarray:
        return self.body_pos[:, self.vehicle.wheelset_ids, 1]

    @functools.cached_property
    def psi(self) -> np.ndarray:
        if self.body_yaw is not None:
            return self.body_yaw[:, self.vehicle.wheelset_ids]
        return _yaw(self.body_quat[:, self.vehicle.wheelset_ids])

    @functools.cached_property
    def x(self) -> np.ndarray:
        """Distance travelled, m."""
        if self.profile is None:
            return self.speed * self.t
        return self.station - self.station[0]

    @property
    def profile(self) -> SpeedProfile | None:
        """The speed along the track (rail_mj.track.speed); None: the constant `speed`."""
        return self.vehicle.profile

    @functools.cached_property
    def speeds(self) -> np.ndarray:
        """(n_samples,): the speed at each sample, m/s: `speed`, or on a speed profile the
        profile's at the odometer's station (which the odometer follows to the integrator's
        error: rail_mj.simulation.curve.profiled_speed)."""
        if self.profile is None:
            return np.full(self.t.shape, float(self.speed))
        return self.profile.at(self.station)

    @property
    def n_wheelsets(self) -> int:
        return self.y.shape[1]

    @property
    def track(self) -> Track | None:
        """The curved or canted track of the run (rail_mj.track); None: straight (also the
        straight track a speed profile runs along when none was given)."""
        track = self.vehicle.track
        return None if track is None or track.source == PROFILE_TRACK else track

    @functools.cached_property
    def station(self) -> np.ndarray:
        """(n_samples,): the distance along the track of the vehicle's origin (its car body's
        centre), m: the odometer's (rail_mj.vehicle.curve); on straight track, `x`."""
        if self.vehicle.track is None:
            return self.x
        return self.body_pos[:, self.vehicle.model.body(ODOMETER).id, 0]

    @functools.cached_property
    def wheelset_station(self) -> np.ndarray:
        """(n_samples, n_wheelsets): each wheelset's distance along the track, m."""
        return self.station[:, None] + np.asarray(self.layout.wheelset_x)[None, :]

    @functools.cached_property
    def wheelset_curvature(self) -> np.ndarray:
        """(n_samples, n_wheelsets): the track's curvature under each wheelset, 1/m (+ left)."""
        if self.track is None:
            return np.zeros_like(self.y)
        return self.track.curvature(self.wheelset_station)

    @property
    def frame_names(self) -> tuple[str, ...]:
        """The moving bodies other than the wheelsets: the bogie frames (bogie1, ...), then the
        car body unless it is fixed. A fixed car body (no joints) has no motion to show."""
        return self.vehicle.frame_names

    @property
    def _frame_ids(self) -> np.ndarray:
        return self.vehicle.frame_ids

    @property
    def frame_y(self) -> np.ndarray:
        """(n_samples, n_frames): lateral displacement of each of `frame_names`, m (absolute,
        track frame, like `y`)."""
        return self.body_pos[:, self._frame_ids, 1]

    @property
    def frame_station(self) -> np.ndarray:
        """(n_samples, n_frames): each of `frame_names`' distance along the track, m: the
        vehicle's station and the body's own place along it, as `wheelset_station`."""
        return self.station[:, None] + self.body_pos[0, self._frame_ids, 0][None, :]

    @property
    def frame_psi(self) -> np.ndarray:
        """(n_samples, n_frames): yaw of each of `frame_names`, rad (absolute, like `psi`)."""
        if self.body_yaw is not None:
            return self.body_yaw[:, self._frame_ids]
        quat = self.body_quat[:, self._frame_ids]
        return _yaw(quat) if self.layout.spatial is None else _spatial_angles(quat)[2]

    @property
    def frame_roll(self) -> np.ndarray:
        """(n_samples, n_frames): a spatial vehicle's frames' roll, rad (about x, left side up)."""
        return _spatial_angles(self.body_quat[:, self._frame_ids])[0]

    @property
    def frame_pitch(self) -> np.ndarray:
        """(n_samples, n_frames): a spatial vehicle's frames' pitch, rad (about y)."""
        return _spatial_angles(self.body_quat[:, self._frame_ids])[1]

    @property
    def frame_bounce(self) -> np.ndarray:
        """(n_samples, n_frames): a spatial vehicle's frames' vertical displacement from the
        static equilibrium (the centred state), m."""
        rest = self.vehicle.model.body_pos[self._frame_ids, 2]
        return self.body_pos[:, self._frame_ids, 2] - rest

    def floor_accelerations(self) -> Floor | None:
        """The car body's floor accelerations (`Floor`) as an accelerometer fixed to the floor reads
        them, in the car body's own axes: the second derivative of each floor point's motion
        (`floor_motion`) and, laterally, the part of gravity the body's roll tilts into its floor,
        g*phi. A planar car body has no roll or vertical motion: lateral only. None if the car body
        does not move."""
        motion = self.floor_motion()
        if motion is None or len(self.t) < 3:
            return None
        dt = float(self.t[1] - self.t[0])
        lateral = np.column_stack([second_derivative(u, dt) for u in motion.lateral.T]) + GRAVITY * motion.roll[:, None]
        vertical = None
        if motion.vertical is not None:
            vertical = np.column_stack([second_derivative(u, dt) for u in motion.vertical.T])
        return Floor(motion.names, 1.0 / dt, lateral, vertical)

    def floor_motion(self) -> FloorMotion | None:
        """The car body's floor points (above each bogie, then the centre, at the spatial layout's
        floor height) displaced by its lateral, vertical, roll, pitch and yaw motion, linear in them as
        the model's tendons are (rail_mj.vehicle.spatial.point_motion): what `floor_accelerations`
        differentiates. None if the car body does not move."""
        if "carbody" not in self.frame_names:
            return None
        k = self.frame_names.index("carbody")
        layout = self.layout
        bogies = layout.carbody.bogie_positions if layout.bogie is not None else None
        positions = [*(bogies or ()), 0.0]
        names = tuple([f"bogie{i + 1}" for i in range(len(positions) - 1)] + ["centre"])
        y, yaw = self.frame_y[:, k], self.frame_psi[:, k]
        spatial = layout.spatial
        if spatial is None:
            return FloorMotion(names, np.column_stack([y + x * yaw for x in positions]), None, np.zeros_like(y))
        roll, pitch, bounce = self.frame_roll[:, k], self.frame_pitch[:, k], self.frame_bounce[:, k]
        floor = spatial.carbody_height if spatial.floor_height is None else spatial.floor_height
        rz = floor - spatial.carbody_height
        # A floor point at (x, 0, rz) from the centre of mass: u_y = y + x*yaw - rz*roll, u_z = z - x*pitch.
        lateral = np.column_stack([y + x * yaw - rz * roll for x in positions])
        vertical = np.column_stack([bounce - x * pitch for x in positions])
        return FloorMotion(names, lateral, vertical, roll)


@dataclasses.dataclass(frozen=True)
class FloorMotion:
    """A car body's floor points displaced (samples, points), m, in its own axes: `lateral`, `vertical`
    (None on a planar vehicle), and the body's `roll` (samples,), rad, which tilts gravity into the floor."""

    names: tuple[str, ...]
    lateral: np.ndarray
    vertical: np.ndarray | None
    roll: np.ndarray


@dataclasses.dataclass(frozen=True)
class Floor:
    """A car body's floor accelerations at its points (above each bogie, then the centre), in its own
    axes: `lateral` and `vertical` (samples, points), m/s^2; `vertical` None on a planar vehicle."""

    names: tuple[str, ...]
    fs: float
    lateral: np.ndarray
    vertical: np.ndarray | None


def second_derivative(x: np.ndarray, dt: float) -> np.ndarray:
    """Central second differences of samples at dt, the ends one-sided (second order)."""
    return np.gradient(np.gradient(x, dt, edge_order=2), dt, edge_order=2)


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
