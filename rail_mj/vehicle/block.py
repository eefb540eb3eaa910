"""The native block: the one writer of what the compiled callback reads from a model.

`Vehicle` fills the model's first numeric ("rail_mj/native", layout in rail_mj.numerics)
with each vehicle's speed, contact parameters, contact table and the joint chains of its
wheelsets; `set_speed` changes a compiled model's speed. `contact_parameters` reads a
model's named numerics back into the ContactParameters the contact law takes, for the
Python callback and the block alike.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from rail_mj import numerics
from rail_mj.contact.parameters import ContactParameters
from rail_mj.numerics import (
    COLUMNS,
    COUPLE,
    LOADS_HEADER,
    MAGIC,
    NUMERIC_CREEP,
    NUMERIC_ELLIPSE,
    NUMERIC_FLANGE,
    NUMERIC_GEOMETRY,
    NUMERIC_NATIVE,
    NUMERIC_SATURATION,
    NUMERIC_WHEEL,
    SPEED,
    TRACK_AT,
    TRACK_HEADER,
    YAW_HINGE,
)
from rail_mj.units import PA_PER_GPA
from rail_mj.vehicle.loads import AxleLoads, ShearCouples

# The odometer body of a vehicle on a track (rail_mj.vehicle.curve): its slide is the distance along it.
ODOMETER = "odometer"

# A straight track's part: no odometer, nothing to read.
STRAIGHT = np.array([-1.0] + [0.0] * (TRACK_HEADER - 1))


class NativeError(ValueError):
    """The native callback cannot run on this MuJoCo, or on this model."""


def contact_parameters(model: mujoco.MjModel, n_wheelsets: int) -> ContactParameters:
    r0, b, conicity, clearance = model.numeric(NUMERIC_WHEEL).data
    f11, f22, f23, f33 = model.numeric(NUMERIC_CREEP).data
    law, limit, falling_ratio, falling_rate = model.numeric(NUMERIC_SATURATION).data
    flange, stiffness, damping, slope = model.numeric(NUMERIC_FLANGE).data
    try:
        a, semi_b, normal, shear, c11, c22, c23 = model.numeric(NUMERIC_ELLIPSE).data
    except KeyError:  # an MJCF written before the ellipse was carried: no fastsim law
        a = semi_b = normal = shear = c11 = c22 = c23 = 0.0
    try:
        geometry = model.numeric(NUMERIC_GEOMETRY).data.reshape(-1, COLUMNS).copy()
    except KeyError:  # coned wheels
        geometry = None
    return ContactParameters.broadcast(
        n_wheelsets,
        r0=r0,
        b=b,
        conicity=conicity,
        f11=f11,
        f22=f22,
        f23=f23,
        f33=f33,
        friction_limit=limit,
        falling_friction_ratio=falling_ratio,
        falling_friction_rate=falling_rate,
        law=int(law),
        clearance=clearance,
        flange_stiffness=stiffness,
        flange_damping=damping,
        flange_slope=slope if flange else None,
        geometry=geometry,
        semi_axis_a=a,
        semi_axis_b=semi_b,
        normal_force=normal,
        shear_modulus=shear * PA_PER_GPA,
        c11=c11,
        c22=c22,
        c23=c23,
    )


_SLIDE, _HINGE = int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE)


def vehicle_block(
    model: mujoco.MjModel,
    wheelset_bodies,
    params,
    speed: float = 0.0,
    loads=None,
    prefix: str = "",
    couples=None,
    track_part: np.ndarray | None = None,
    springs=(),
) -> np.ndarray:
    """One vehicle's entries of the block: see VEHICLE_HEADER. `loads`: its AxleLoads
    (rail_mj.vehicle.loads), its tendons named in `model` under `prefix`; None: static loads.
    `couples`: its frames' ShearCouples, or None. `track_part`: its curved track's
    (rail_mj.vehicle.curve.track_part); None: straight track."""
    table, geometry = params.table, params.geometry
    entries = [
        speed,
        len(wheelset_bodies),
        params.law,
        float(params.flange),
        float(params.falling),
        float(geometry.shape[0]),
        0.0,  # where the track part starts: set below
    ]
    entries += list(table.reshape(-1)) + list(geometry.reshape(-1))
    for i, body in enumerate(wheelset_bodies):
        chain = joint_chain(model, int(body))
        entries += [body, len(chain) // 3] + chain
        if loads is None:
            entries += [0.0] * LOADS_HEADER
        else:
            rows = loads.rows(model, i, prefix)
            entries += [
                loads.weight,
                loads.nominal,
                loads.spin_inertia,
                float(loads.cone_gravity),
                float(len(rows)),
            ] + list(rows.reshape(-1))
        pairs = loads.shear_rows(model, i, prefix) if loads is not None else np.zeros((0, 2))
        entries += [float(len(pairs))] + list(pairs.reshape(-1))
    rows = couples.rows(model, prefix) if couples is not None else np.zeros((0, COUPLE))
    entries += [float(len(rows))] + list(rows.reshape(-1))
    entries += [float(len(springs))]
    for stiffness, damping, terms in springs:
        entries += [stiffness, damping, float(len(terms))] + [v for dof, coef in terms for v in (float(dof), coef)]
    entries[TRACK_AT] = float(len(entries))
    entries += list(STRAIGHT if track_part is None else track_part)
    return np.asarray(entries, dtype=np.float64)


HINGE = 1.0  # a chain's hinge flag; YAW_HINGE (rail_mj.numerics): one of a chain turning its body about z


def joint_chain(model: mujoco.MjModel, body: int) -> list[float]:
    """The joints from `body` to the world, as the block lists them: (joint, dof, flag) each,
    the body's own first; flag 0 for a slide, 1 for a hinge, YAW_HINGE for every hinge of a chain
    whose hinges all turn about z from the world down (every body on the way square to its parent,
    each hinge's axis z and its reference angle 0): there the body's orientation is a turn about z
    by the sum of their angles, which the callback reads as its yaw (the same as atan2 of its
    rotation to an ulp, without the atan2)."""
    chain: list[float] = []
    b, about_z = body, True
    while b:
        about_z &= bool(np.array_equal(model.body_quat[b], (1.0, 0.0, 0.0, 0.0)))
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            kind = int(model.jnt_type[j])
            if kind not in (_SLIDE, _HINGE):
                raise NativeError(
                    f"joint {model.joint(j).name}: the native callback handles slide and hinge joints only"
                )
            if kind == _HINGE:
                about_z &= bool(np.array_equal(model.jnt_axis[j], (0.0, 0.0, 1.0)))
                about_z &= model.qpos0[model.jnt_qposadr[j]] == 0.0 and model.jnt_qposadr[j] == model.jnt_dofadr[j]
            chain += [j, model.jnt_dofadr[j], float(kind == _HINGE)]
        b = model.body_parentid[b]
    if about_z:
        for c in range(2, len(chain), 3):
            if chain[c] == HINGE:
                chain[c] = YAW_HINGE
    return chain


def block(vehicles: list[np.ndarray]) -> np.ndarray:
    """The whole numeric: MAGIC, the number of vehicles, then each vehicle's entries."""
    return np.concatenate([[MAGIC, float(len(vehicles))], *vehicles])


def block_for(model: mujoco.MjModel, n_wheelsets: int, track_part: np.ndarray | None = None) -> np.ndarray:
    """The block of a model built by rail_mj.vehicle.spec: one vehicle, wheelset1..N, its contact
    parameters read from the model's named numerics, no speed yet; `track_part` its curved
    track's (rail_mj.vehicle.curve), None on straight track."""
    names = [f"wheelset{i + 1}" for i in range(n_wheelsets)]
    bodies = [model.body(name).id for name in names]
    return block(
        [
            vehicle_block(
                model,
                bodies,
                contact_parameters(model, n_wheelsets),
                loads=AxleLoads.of(model, names),
                couples=ShearCouples.of(model),
                track_part=track_part,
            )
        ]
    )


def _block_of(model: mujoco.MjModel) -> np.ndarray:
    if model.nnumeric == 0 or model.numeric(0).name != NUMERIC_NATIVE or model.numeric_data[0] != MAGIC:
        raise NativeError(
            f"model {model.names[:40]!r}...: its first numeric is not {NUMERIC_NATIVE}; "
            f"build it with rail_mj.vehicle.spec.Vehicle"
        )
    return model.numeric_data


def vehicle_starts(model: mujoco.MjModel) -> list[int]:
    """Where each vehicle's entries start in the block."""
    return numerics.vehicle_starts(_block_of(model))


def set_speed(model: mujoco.MjModel, speed: float, vehicle: int | None = None) -> None:
    """Set the forward speed (m/s) of one vehicle of `model` (all of them by default)."""
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be a positive number, got {speed}")
    starts = vehicle_starts(model)
    for k in starts if vehicle is None else [starts[vehicle]]:
        model.numeric_data[k + SPEED] = speed


def native_block(model: mujoco.MjModel) -> np.ndarray:
    """The native block: the model's first numeric's data (rail_mj.numerics), a copy."""
    adr, size = int(model.numeric_adr[0]), int(model.numeric_size[0])
    return np.array(model.numeric_data[adr : adr + size], dtype=np.float64)


def track_part_at(model: mujoco.MjModel, prefix: str) -> tuple[int, int] | None:
    """(where the vehicle's entries start, where its track part starts) in the native block,
    for the vehicle under `prefix` on a track; None on straight track (no track part)."""
    from rail_mj.numerics import MAGIC, TRACK_AT, vehicle_starts

    try:
        odometer = model.body(prefix + ODOMETER).id
    except KeyError:
        return None
    if model.nnumeric == 0:
        return None
    block = native_block(model)
    if block[0] != MAGIC:
        return None
    for start in vehicle_starts(block):
        k = start + int(block[start + TRACK_AT])
        if int(block[k]) == odometer:
            return start, k
    return None


def spring_rows(own: mujoco.MjModel, model: mujoco.MjModel, prefix: str = "") -> list[tuple[float, float, list]]:
    """The tendons of `own` (a vehicle's model, each a linear spring and damper on its joints,
    centred at zero length) as the block's springs on the coordinates of `model`, where the
    vehicle is attached under `prefix`: (stiffness, damping, [(dof, coefficient), ...]) each.
    The callback reads a spring's deflection from qpos at its dof: slide and hinge joints only,
    whose qpos and qvel entries coincide."""
    rows = []
    for t in range(own.ntendon):
        if np.any(own.tendon_lengthspring[t] != 0.0):
            raise NativeError(f"tendon {own.tendon(t).name}: not centred at zero length, not a block spring")
        # A limit, friction loss or armature makes MuJoCo's constraint or inertia stages act on the
        # tendon, which the stepped model (without tendons, constraint stages off) would drop.
        for what, value in (
            ("limited", own.tendon_limited[t]),
            ("friction loss", own.tendon_frictionloss[t]),
            ("armature", own.tendon_armature[t]),
        ):
            if value:
                raise NativeError(f"tendon {own.tendon(t).name}: {what}, not a block spring")
        terms = []
        for dof, coef in tendon_coefficients(own, t):
            joint = model.joint(prefix + own.joint(int(own.dof_jntid[dof])).name)
            if int(joint.qposadr[0]) != int(joint.dofadr[0]) or int(model.jnt_type[joint.id]) not in (_SLIDE, _HINGE):
                raise NativeError(f"joint {joint.name}: a block spring's joints are slides and hinges, qpos at qvel")
            terms.append((int(joint.dofadr[0]), coef))
        rows.append((float(own.tendon_stiffness[t]), float(own.tendon_damping[t]), terms))
    return rows


def tendon_coefficients(model: mujoco.MjModel, t: int) -> list[tuple[int, float]]:
    """A fixed tendon's (dof, coefficient) per joint: its length is their sum times the coordinates."""
    out = []
    for w in range(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t]):
        if model.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT:
            raise ValueError(f"tendon {model.tendon(t).name}: only fixed tendons (on joints) are rail-mj's")
        out.append((int(model.jnt_dofadr[model.wrap_objid[w]]), float(model.wrap_prm[w])))
    return out
