"""Linearisation of the MuJoCo vehicle about the centred state.

Central finite differences of MuJoCo's own forward dynamics (`mj_forward`, with
the creep callback installed) give the continuous-time state matrix

    A = [[0, I], [dqacc/dq, dqacc/dv]]      for the state x = [qpos, qvel],

with no integrator in between. The linear creep law and the kinematics near the
centred state make central differences exact but for round-off. The runner
uses A to choose its timestep, `rail_mj.analysis.stability` for eigenvalues and modes.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rail_mj.simulation.callback import CreepForces, installed

# m or rad. Small enough that a saturating law's O(|F|) curvature at zero (the
# Shen-Hedrick-Elkins u^2/3 term, u ~ 1e-6 here) is below 1e-6, large enough that
# round-off in the differences stays near 1e-8 relative.
FD_STEP = 1e-8
# Roots smaller than this fraction of the largest are rigid-body or pure-integrator
# roots (a free coordinate with no stiffness to anything): they are not modes.
RIGID_TOLERANCE = 1e-9


def modal_roots(A: np.ndarray) -> np.ndarray:
    """The eigenvalues of A that are modes: rigid-body and pure-integrator roots removed."""
    lam = np.linalg.eigvals(A)
    return lam[np.abs(lam) > RIGID_TOLERANCE * np.max(np.abs(lam))]


def state_matrix(
    model: mujoco.MjModel,
    forces: CreepForces | None = None,
    data: mujoco.MjData | None = None,
    qpos0: np.ndarray | None = None,
    qvel0: np.ndarray | None = None,
) -> np.ndarray:
    """A (2nv x 2nv) of `model` with the creep forces acting, about qpos = qpos0 (default
    the centred state, 0) and qvel = qvel0 (default 0; a vehicle on a speed profile rolls at
    its odometer's velocity): `forces` (the Python callback), or by default the native one at
    the speed the model carries (`rail_mj.simulation.native.set_speed`)."""
    data = data or mujoco.MjData(model)
    nv = model.nv
    A = np.zeros((2 * nv, 2 * nv))
    A[:nv, nv:] = np.eye(nv)
    if forces is None:
        from rail_mj.simulation import native

        context = native.installed()
    else:
        context = installed(forces)
    with context:
        for j in range(2 * nv):
            acc = []
            for sign in (1.0, -1.0):
                mujoco.mj_resetData(model, data)
                if qpos0 is not None:
                    data.qpos[:] = qpos0
                if qvel0 is not None:
                    data.qvel[:] = qvel0
                (data.qpos if j < nv else data.qvel)[j % nv] += sign * FD_STEP
                mujoco.mj_forward(model, data)
                acc.append(data.qacc.copy())
            A[nv:, j] = (acc[0] - acc[1]) / (2 * FD_STEP)
    return A
