"""A spatial vehicle at rest under gravity (docs/spatial.md): the springs' preload that makes the
centred state the static equilibrium, and the gravitational stiffness of their static forces.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rail_mj.layout import Layout
from rail_mj.vehicle.joints import PITCH, ROLL
from rail_mj.vehicle.rounding import _g6
from rail_mj.vehicle.spatial import AXES, spatial_elements


def preload(spec: mujoco.MjSpec, model: mujoco.MjModel) -> np.ndarray:
    """Make the centred state (qpos = 0) the static equilibrium under gravity (docs/spatial.md):
    solve K q_eq = f_gravity with the tendons' stiffness K, and give each tendon the spring length
    -L(q_eq), so that at q = 0 it carries the force it would carry at q_eq. Returns q_eq, the
    static sag the preload takes out. Linear tendons make this exact (up to the 6 figures the
    MJCF keeps of each spring length). A deadband tendon (springlength lo < hi: a bump stop) is
    left out of K and keeps its deadband: within its play it carries no force and has no
    stiffness, and the lateral stops stay within it, gravity having no lateral part."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    J = tendon_jacobian(model)
    deadband = model.tendon_lengthspring[:, 0] < model.tendon_lengthspring[:, 1]
    K = J.T @ (np.where(deadband, 0.0, model.tendon_stiffness)[:, None] * J)
    q_eq = np.linalg.lstsq(K, -data.qfrc_bias, rcond=None)[0]  # gravity: -qfrc_bias at rest
    lengths = J @ q_eq
    for t, length, idle in zip(spec.tendons, lengths, deadband):
        if idle:
            continue
        stiff = model.tendon_stiffness[model.tendon(t.name).id] > 0
        L0 = _g6(-length)[0] if stiff and abs(length) > 1e-12 else 0.0  # round-off of a zero: 0
        t.springlength = [L0, L0]
    return q_eq


def tendon_jacobian(model: mujoco.MjModel) -> np.ndarray:
    """The fixed tendons' coefficients as a dense (ntendon x nv) Jacobian, read from the model."""
    J = np.zeros((model.ntendon, model.nv))
    for t in range(model.ntendon):
        for w in range(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t]):
            J[t, model.jnt_dofadr[model.wrap_objid[w]]] += model.wrap_prm[w]
    return J


def gravitational_stiffness(layout: Layout, forces: dict[str, float]) -> dict[str, float]:
    """The roll and pitch stiffness, per joint, of the springs' static forces (docs/spatial.md,
    "Gravitational stiffness"): an element carrying a compressive force P at height z_s adds
    -P*(H_B - z_s) to the roll and to the pitch of its upper body B and -P*(z_s - H_A) to those of
    its lower body A (H a centre-of-mass height), the second-order drop of its attachment points
    when the body turns about its centre of mass, which the linear tendons leave out. `forces`:
    each tendon's static force by name, > 0 in compression (k*L0)."""
    stiffness: dict[str, float] = {}
    for name, point, lower, upper, _ in spatial_elements(layout):
        force = forces[f"{name}_z"]
        for (body, centre, joints), sign in ((upper, 1.0), (lower, -1.0)):
            for motion in (ROLL, PITCH):
                if motion in joints:  # a wheelset's roll and pitch are the rails' (none here)
                    joint = f"{body}_{motion}"
                    stiffness[joint] = stiffness.get(joint, 0.0) + sign * force * (point[2] - centre[2])
    return stiffness


def add_gravitational_stiffness(spec: mujoco.MjSpec, layout: Layout, model: mujoco.MjModel, q_eq: np.ndarray) -> None:
    """`gravitational_stiffness` of the forces of `preload`'s solve (q_eq: unrounded, so the terms
    sum to -m g h to round-off) as the stiffness of the roll and pitch hinges, springref 0: no
    force at q = 0, which stays the equilibrium. Negative for a body above its springs; MuJoCo
    takes a negative joint stiffness."""
    lengths = tendon_jacobian(model) @ q_eq
    forces = {model.tendon(t).name: -model.tendon_stiffness[t] * L for t, L in enumerate(lengths)}
    known = {f"{e[0]}_{axis}" for e in spatial_elements(layout) for axis in AXES}
    for t in spec.tendons:
        # A static force at a point spatial_elements does not list would be a term silently missing
        # (a deadband tendon, a bump stop, carries none: preload leaves it in its play).
        preloaded = t.springlength[0] != 0.0 and t.springlength[0] == t.springlength[1]
        if preloaded and t.name not in known:
            raise NotImplementedError(
                f"gravitational stiffness: tendon {t.name} is preloaded but is no element of spatial_elements"
            )
    for joint, k in gravitational_stiffness(layout, forces).items():
        spec.joint(joint).stiffness = _g6(k, 0.0, 0.0)
