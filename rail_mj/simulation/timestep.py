"""The timestep of a run: RK4's stability limit for the vehicle's fastest linear mode.

The creep forces are explicit (computed once per RK4 stage from the state), so the step is
set by the fastest mode of the vehicle linearised with them (rail_mj.simulation.linear),
centred and, with flanges or profiles, pressed into its stiffest contact.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rail_mj.layout.kinds import Coned, Profiled, contact_model
from rail_mj.layout.reader import Flange
from rail_mj.numerics import HEADER_DY, HEADER_Y0, NUMERIC_GEOMETRY
from rail_mj.simulation.callback import CreepForces
from rail_mj.simulation.linear import modal_roots, state_matrix
from rail_mj.units import M_PER_MM
from rail_mj.vehicle.spec import Vehicle

# RK4 is stable for |lambda|*dt up to 2.78 on the real axis and 2.83 on the imaginary
# axis; 1.0 for the fastest mode lambda of the linearised vehicle leaves margin, and the
# slow (hunting, kinematic) modes, 10-1000x slower, come out with negligible error.
STEP_FRACTION = 1.0
MAX_TIMESTEP = 1e-3  # s; the modes of interest are below 20 Hz


def table_header(model: mujoco.MjModel) -> tuple[float, float]:
    """(first y, step in y), m, of a profiled model's contact table (rail_mj.contact.tables)."""
    header = model.numeric(NUMERIC_GEOMETRY).data
    return float(header[HEADER_Y0]) * M_PER_MM, float(header[HEADER_DY]) * M_PER_MM


def stable_timestep(vehicle: Vehicle, forces: CreepForces | None = None) -> float:
    """Timestep for RK4 with explicit creep forces: STEP_FRACTION / (fastest linear rate).

    The creep damping 2*f22/V grows without bound as V falls, so the slowest runs
    need the smallest steps. `forces`: the Python callback, or None for the native one at
    the model's speed.
    """
    rate = np.max(np.abs(np.linalg.eigvals(state_matrix(vehicle.model, forces))))
    clearance = vehicle.layout.wheelset.flangeway_clearance
    # In flange contact the rail's stiffness and the steep radius rise add faster rates:
    # linearise there too, the whole vehicle pressed 2 mm into the flange springs; on
    # profiles, in the table's step where the contact jumps onto the flange (the normal
    # force's lateral part rises by ~2 W over 0.05 mm: the stiffest place).
    match contact_model(vehicle.layout):
        case Profiled():
            shift: float | None = clearance - 0.5 * table_header(vehicle.model)[1]
        case Coned(flange=Flange()):
            shift = clearance + 0.002
        case _:
            shift = None
    if shift is not None:
        qpos0 = np.zeros(vehicle.model.nq)
        qpos0[vehicle.root_lateral_dofs] = shift
        engaged = state_matrix(vehicle.model, forces, qpos0=qpos0)
        rate = max(rate, np.max(np.abs(np.linalg.eigvals(engaged))))
    return min(MAX_TIMESTEP, STEP_FRACTION / rate) if rate > 0 else MAX_TIMESTEP


def linearly_stable(vehicle: Vehicle, forces: CreepForces | None) -> bool:
    """Whether every mode of the vehicle linearised about the centred state decays."""
    return bool(np.max(modal_roots(state_matrix(vehicle.model, forces, qvel0=rolling(vehicle))).real) < 0)


def rolling(vehicle: Vehicle) -> np.ndarray | None:
    """The velocities to linearise about: None (all zero) at a constant speed, which the
    callback reads from the block; on a speed profile, whose speed is the odometer's velocity
    (rail_mj.simulation.curve.profiled_speed), the odometer at the block's speed (set_speed)."""
    if vehicle.profile is None:
        return None
    from rail_mj.numerics import SPEED
    from rail_mj.vehicle.block import vehicle_starts
    from rail_mj.vehicle.curve import ODOMETER

    model = vehicle.model
    qvel0 = np.zeros(model.nv)
    qvel0[model.joint(ODOMETER).dofadr[0]] = model.numeric_data[vehicle_starts(model)[0] + SPEED]
    return qvel0
