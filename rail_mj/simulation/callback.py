"""The MuJoCo binding of the creep law: wheel-rail forces through `mjcb_passive`.

`CreepForces` reads each wheelset's lateral position, yaw and their rates from
MuJoCo, asks `rail_mj.contact.creep` for the forces of all wheelsets in one call, and adds
them to `qfrc_passive` through the wheelset Jacobians. It reads the contact data
from the compiled model by name (the `rail_mj/*` numerics written by
`rail_mj.vehicle.spec`), so a generated MJCF alone is enough.

MuJoCo's passive callback is process-global, cannot be installed while a model
compiles, and its forces are integrated explicitly: see `installed` and the
runner's timestep choice.

Example:

    >>> import mujoco
    >>> from rail_mj.layout import load_layout
    >>> from rail_mj.vehicle.spec import Vehicle
    >>> vehicle = Vehicle(load_layout("models/wheelset/wheelset.toml"))
    >>> data = mujoco.MjData(vehicle.model)
    >>> data.qpos[0] = 0.003
    >>> forces = CreepForces(vehicle.model, vehicle.wheelset_names, speed=20.0)
    >>> with installed(forces):
    ...     mujoco.mj_step(vehicle.model, data)
"""

from __future__ import annotations

import contextlib

import mujoco
import numpy as np

from rail_mj.contact.creep import wheelset_forces
from rail_mj.vehicle.block import contact_parameters
from rail_mj.vehicle.loads import AxleLoads, ShearCouples


class CreepForces:
    """Creep forces on every wheelset of `model` at forward speed `speed` (m/s).

    Call it as MuJoCo's passive callback (`installed(forces)`). The yaw angle is taken from
    the body rotation (atan2), the rates from the body Jacobians at the wheelset
    centre.
    """

    def __init__(self, model: mujoco.MjModel, wheelset_names, speed: float):
        if not speed > 0:
            raise ValueError(f"speed must be > 0 m/s, got {speed}")
        self.speed = float(speed)
        self.body_ids = np.array([model.body(n).id for n in wheelset_names], dtype=np.int64)
        self.params = contact_parameters(model, len(self.body_ids))
        n, nv = len(self.body_ids), model.nv
        self.loads = AxleLoads.of(model, wheelset_names)  # a spatial vehicle's: Q from its suspension
        self.couples = ShearCouples.of(model)  # and its frames' shear couples
        self._couple_rows = None if self.couples is None else self.couples.rows(model)  # looked up once
        self._jacp = np.zeros((n, 3, nv))
        self._jacr = np.zeros((n, 3, nv))

    def _kinematics(
        self, model: mujoco.MjModel, data: mujoco.MjData
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray, np.ndarray]:
        """(y, psi, y_dot, psi_dot) over wheelsets, and the lateral and yaw Jacobian rows."""
        for i, body in enumerate(self.body_ids):
            mujoco.mj_jacBody(model, data, self._jacp[i], self._jacr[i], body)
        jy, jpsi = self._jacp[:, 1, :], self._jacr[:, 2, :]
        xmat = data.xmat[self.body_ids]
        # Yaw from the body rotation: atan2(R10, R00) of the row-major 3x3 xmat.
        states = (data.xpos[self.body_ids, 1], np.arctan2(xmat[:, 3], xmat[:, 0]), jy @ data.qvel, jpsi @ data.qvel)
        return states, jy, jpsi

    def __call__(self, model, data):
        states, jy, jpsi = self._kinematics(model, data)
        if self.loads is None:
            fy, mz = wheelset_forces(self.params, *states, self.speed)
        else:
            load, moment = self.loads.evaluate(model, data.ten_length, data.ten_velocity)
            fy, mz = wheelset_forces(self.params, *states, self.speed, load, moment, **self.loads.contact())
        if self.couples is not None:
            data.qfrc_passive += self.couples.forces(model, data.ten_length, data.ten_velocity, self._couple_rows)
        data.qfrc_passive += fy @ jy + mz @ jpsi  # J^T [Fy, Mz] over every wheelset


@contextlib.contextmanager
def installed(callback):
    """Install `callback` (a Python callable, or a C function: `rail_mj.simulation.native.callback()`)
    as MuJoCo's passive-force callback, and always remove it.

    MuJoCo refuses to compile any model while a Python callback is installed, and
    the callback is global to the process: compile first, step inside this block.
    """
    if mujoco.get_mjcb_passive() is not None:
        raise RuntimeError("another MuJoCo passive callback is already installed")
    mujoco.set_mjcb_passive(callback)
    try:
        yield callback
    finally:
        mujoco.set_mjcb_passive(None)
