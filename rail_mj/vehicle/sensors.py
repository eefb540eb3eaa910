"""What a run records, measured by MuJoCo at every step: the sensors added to a vehicle, and
where their readings sit in sensordata.
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np

from rail_mj.vehicle.block import native_block, track_part_at


def add_sensors(spec: mujoco.MjSpec, bodies: list[str]) -> None:
    """What a run records, measured by MuJoCo at every step: each body's pose (frame
    position and orientation) and each wheelset's velocity, in the track frame."""
    frame = mujoco.mjtObj.mjOBJ_XBODY
    for body in bodies:
        spec.add_sensor(name=f"{body}_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=frame, objname=body)
        spec.add_sensor(name=f"{body}_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT, objtype=frame, objname=body)
    for body in bodies:
        if body.startswith("wheelset"):
            spec.add_sensor(
                name=f"{body}_linvel", type=mujoco.mjtSensor.mjSENS_FRAMELINVEL, objtype=frame, objname=body
            )
            spec.add_sensor(
                name=f"{body}_angvel", type=mujoco.mjtSensor.mjSENS_FRAMEANGVEL, objtype=frame, objname=body
            )


def add_load_sensors(spec: mujoco.MjSpec, model: mujoco.MjModel, wheelsets: list[str]) -> None:
    """A spatial vehicle's axlebox tendons' lengths and rates, what its wheel loads come from
    (rail_mj.vehicle.loads): <tendon>_length and <tendon>_rate."""
    from rail_mj.vehicle.loads import AxleLoads

    loads = AxleLoads.of(model, wheelsets)
    if loads is None:
        return
    for name in sorted({name for tendons in loads.tendons for name, _, _ in tendons}):
        spec.add_sensor(
            name=f"{name}_length",
            type=mujoco.mjtSensor.mjSENS_TENDONPOS,
            objtype=mujoco.mjtObj.mjOBJ_TENDON,
            objname=name,
        )
        spec.add_sensor(
            name=f"{name}_rate",
            type=mujoco.mjtSensor.mjSENS_TENDONVEL,
            objtype=mujoco.mjtObj.mjOBJ_TENDON,
            objname=name,
        )


class Sensors:
    """Where `add_sensors`' readings sit in MuJoCo's sensordata, and what they mean."""

    from_state = False  # read from sensordata (JointSensors: from the state)

    def __init__(self, model: mujoco.MjModel, wheelset_names, prefix: str = ""):
        """`model` holds the vehicle under `prefix` (several vehicles stepped together);
        the readings are for the vehicle's own bodies 1, 2, ... in its own order."""
        address = lambda name: model.sensor(prefix + name).adr[0]  # noqa: E731
        own = [
            name.removeprefix(prefix) for b in range(1, model.nbody) if (name := model.body(b).name).startswith(prefix)
        ]
        self.bodies = np.arange(1, len(own) + 1, dtype=np.int64)
        self.pos = np.array([np.arange(3) + address(f"{name}_pos") for name in own])
        self.quat = np.array([np.arange(4) + address(f"{name}_quat") for name in own])
        # The lateral velocity and yaw rate of each wheelset, in the world (track) frame.
        self.lateral_rate = np.array([address(f"{w}_linvel") + 1 for w in wheelset_names])
        self.yaw_rate = np.array([address(f"{w}_angvel") + 2 for w in wheelset_names])
        # A spatial vehicle's axlebox tendons (rail_mj.vehicle.loads), read as the model's ten_length/velocity.
        from rail_mj.vehicle.loads import AxleLoads

        self.model, self.prefix = model, prefix
        self.axle_loads = AxleLoads.of(model, wheelset_names, prefix)
        self.tendons = np.zeros(0, dtype=np.int64)
        if self.axle_loads is not None:
            names = sorted({n for tendons in self.axle_loads.tendons for n, _, _ in tendons})
            self.tendons = np.array([model.tendon(prefix + n).id for n in names], dtype=np.int64)
            self.tendon_length = np.array([address(f"{n}_length") for n in names])
            self.tendon_rate = np.array([address(f"{n}_rate") for n in names])
        # On a curved or canted track, where the vehicle's track part sits in the native block and
        # where its odometer's reading is: the tendons' lengths are shifted by the track's geometry.
        self.track_part, self.station = track_part_at(model, prefix), -1
        # Each wheelset's distance ahead of the vehicle's origin, m (its station less the origin's).
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        self.wheelset_x = np.array([data.xpos[model.body(prefix + w).id, 0] for w in wheelset_names])
        if self.track_part is not None:
            from rail_mj.vehicle.curve import ODOMETER

            self.station = address(f"{ODOMETER}_pos")

    def poses(self, readings: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Fill every moving body's position and quaternion (w, x, y, z) from sensor readings
        (samples along axis 0); the world's stay as they are."""
        pos[:, self.bodies] = readings[:, self.pos]
        quat[:, self.bodies] = readings[:, self.quat]

    def rates(self, readings: np.ndarray, rates: np.ndarray) -> None:
        """Fill each wheelset's (y_dot, psi_dot) from sensor readings."""
        rates[..., 0] = readings[:, self.lateral_rate]
        rates[..., 1] = readings[:, self.yaw_rate]

    @functools.cached_property
    def _block(self) -> np.ndarray:
        """The native block, copied once: its track and irregularity parts do not change in a run
        (its speeds do, with set_speed: `loads` reads those from the model)."""
        return native_block(self.model)

    @functools.cached_property
    def _rails(self):
        from rail_mj.vehicle.rails import Rails

        return Rails.of(self.model, self.prefix)

    def loads(self, readings: np.ndarray, loads: np.ndarray) -> None:
        """Fill each wheelset's (axle load P, roll moment M) from sensor readings (rail_mj.vehicle.loads);
        NaN for a vehicle whose wheels carry the layout's static load."""
        if self.axle_loads is None:
            loads[...] = np.nan
            return
        lengths = np.zeros((len(readings), self.model.ntendon))
        rates = np.zeros_like(lengths)
        lengths[:, self.tendons] = readings[:, self.tendon_length]
        rates[:, self.tendons] = readings[:, self.tendon_rate]
        if self.track_part is not None:  # the real deflections: plus each tendon's shift, per sample
            from rail_mj.numerics import SPEED, SPEED_POINT, TRACK_HEADER
            from rail_mj.vehicle.poses import tendon_shifts

            start, k = self.track_part
            block = self._block
            stations = np.ascontiguousarray(readings[:, self.station], dtype=np.float64)
            # The speed at each sample: the block's, or on a speed profile the profile's at the
            # station, which the odometer follows (rail_mj.simulation.curve.profiled_speed).
            points = int(block[k + 7])
            if points:
                profile = block[k + TRACK_HEADER : k + TRACK_HEADER + SPEED_POINT * points].reshape(points, 2)
                speeds = np.interp(stations, profile[:, 0], profile[:, 1])
            else:
                # Read live: set_speed changes a compiled model's speed (the copy keeps the rest).
                speeds = np.full(
                    len(stations), float(self.model.numeric_data[self.model.numeric_adr[0] + start + SPEED])
                )
            tendon_shifts(block, k, speeds, stations, lengths, rates)
            from rail_mj.vehicle.rails import axlebox_shifts

            rails = self._rails
            if rails is not None and rails.vertical:  # the rails' level and cross level under each wheelset
                at = np.ascontiguousarray(stations[:, None] + self.wheelset_x[None, :])
                axlebox_shifts(block, rails.part, speeds, at, lengths, rates)
                rise, roll = rails.inertia(at, speeds[:, None])
                loads[..., 0], loads[..., 1] = self.axle_loads.evaluate(self.model, lengths, rates, self.prefix)
                loads[..., 0] += rise
                loads[..., 1] -= roll
                return
        loads[..., 0], loads[..., 1] = self.axle_loads.evaluate(self.model, lengths, rates, self.prefix)


class JointSensors:
    """What a flat twin's run records, read from MuJoCo's state instead of sensors (it has none:
    frame sensors cost a twentieth of its step to turn each body's pose and velocity out of the
    kinematics, and every body is on the world, rail_mj.vehicle.train.add_flat_carbody): each
    body's position its place at rest moved along y by its lateral joint, its orientation a turn
    about z by its yaw joint's angle (Run.body_yaw; Run.body_quat is made of it when read); each
    wheelset's rates its joints'.
    `readings` are states (mjSTATE_FULLPHYSICS: the time, then qpos, then qvel), a sample's the
    state its step starts from. A planar vehicle's wheels carry the static load."""

    from_state = True

    def __init__(self, model: mujoco.MjModel, wheelset_names, prefix: str = ""):
        from rail_mj.vehicle.joints import LATERAL, YAW

        own = [
            name.removeprefix(prefix) for b in range(1, model.nbody) if (name := model.body(b).name).startswith(prefix)
        ]
        self.bodies = np.arange(1, len(own) + 1, dtype=np.int64)
        data = mujoco.MjData(model)
        mujoco.mj_kinematics(model, data)
        ids = [model.body(prefix + name).id for name in own]
        self.rest = data.xpos[ids].copy()
        # Square to the track at rest: a body's orientation is its yaw joint's turn alone.
        if not np.array_equal(data.xquat[ids], np.tile((1.0, 0.0, 0.0, 0.0), (len(ids), 1))):
            raise ValueError("a flat twin's bodies are not square to the track at rest")
        names = {model.joint(j).name.removeprefix(prefix): j for j in range(model.njnt)}
        qpos = lambda joint: 1 + model.jnt_qposadr[names[joint]]  # noqa: E731
        qvel = lambda joint: 1 + model.nq + model.jnt_dofadr[names[joint]]  # noqa: E731
        self.sliding = np.array([k for k, b in enumerate(own) if f"{b}_{LATERAL}" in names], dtype=np.int64)
        self.turning = np.array([k for k, b in enumerate(own) if f"{b}_{YAW}" in names], dtype=np.int64)
        self._turning = 1 + self.turning  # their columns of a record's bodies (the world's first)
        self.lateral = np.array([qpos(f"{own[k]}_{LATERAL}") for k in self.sliding], dtype=np.int64)
        self.yaw = np.array([qpos(f"{own[k]}_{YAW}") for k in self.turning], dtype=np.int64)
        if np.any(model.qpos0[self.yaw - 1] != 0.0):  # MuJoCo turns a hinge by qpos - qpos0
            raise ValueError("a flat twin's yaw joints do not start at 0")
        self.lateral_rate = np.array([qvel(f"{w}_{LATERAL}") for w in wheelset_names], dtype=np.int64)
        self.yaw_rate = np.array([qvel(f"{w}_{YAW}") for w in wheelset_names], dtype=np.int64)
        self._rates = np.stack([self.lateral_rate, self.yaw_rate], axis=1)  # one gather for both
        self.axle_loads, self.track_part, self.station = None, None, -1
        self.wheelset_x = np.array([data.xpos[model.body(prefix + w).id, 0] for w in wheelset_names])

    def poses(self, readings: np.ndarray, pos: np.ndarray, yaw: np.ndarray) -> None:
        """Fill every moving body's position and yaw angle (its yaw joint's: the record's
        orientation, Run.body_yaw, which Run turns into quaternions if asked) from states
        (samples along axis 0); the world's, and the yaw of a body without a yaw joint, stay as
        they are (zeros, where the record starts)."""
        moved = pos[:, 1 : 1 + len(self.bodies)]  # bodies 1, 2, ...: a view, not a gather
        moved[...] = self.rest
        moved[:, self.sliding, 1] += readings[:, self.lateral]
        yaw[:, self._turning] = readings[:, self.yaw]

    def rates(self, readings: np.ndarray, rates: np.ndarray) -> None:
        """Fill each wheelset's (y_dot, psi_dot) from states."""
        rates[...] = readings[:, self._rates]

    def loads(self, readings: np.ndarray, loads: np.ndarray) -> None:
        """NaN: the wheels carry the layout's static load."""
        loads[...] = np.nan
