"""A vehicle on a curved track: its odometer and the track part of the native block.

The model is the track straightened (docs/track.md): every body's coordinates are measured
from the track at its own station, and what the curve adds is computed in the passive
callback (rail_mj.simulation.curve) from what this module writes into the block:

- the odometer, a massless-looking body on a slide along x that nothing pushes, started at the
  run's speed (or, on a speed profile, that the profile's force drives: rail_mj.track.speed):
  its position is the distance along the track of the vehicle's origin (the car body's centre),
  a state like any other, so that a run continues, packs and repacks with it;
- the track's breakpoints (curvature and cant linear between them, with the heading and its
  integral at each), which give every body's station;
- each body's mass, station and height (the uncompensated acceleration);
- the map from the track's geometry at each body (its lateral offset from the reference
  tangent, its heading and its cant roll) to the model's joint coordinates, from the model's
  own body Jacobians: the geometric pre-deflection of every joint spring and, through each
  tendon's joint coefficients, of every tendon; the linear ones' forces summed per dof, and the
  tendons whose real lengths the wheel loads read, or whose forces are not linear, listed.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rail_mj.layout import Layout
from rail_mj.numerics import ODOMETER_MASS, POSES
from rail_mj.track import SpeedProfile, Track
from rail_mj.units import GRAVITY
from rail_mj.vehicle.block import ODOMETER, joint_chain, tendon_coefficients
from rail_mj.vehicle.joints import PITCH, ROLL

# Entries of G, the map from the track's geometry to the joints, below this are round-off of
# the least-squares solve (its entries are lever arms of metres and ones).
ROUND_OFF = 1e-12


def add_odometer(spec: mujoco.MjSpec) -> None:
    """The odometer body (see the module), last in the world."""
    body = spec.worldbody.add_body(name=ODOMETER, pos=[0.0, 0.0, 0.0])
    body.explicitinertial = True
    body.mass = ODOMETER_MASS
    body.inertia = [1e-3, 1e-3, 1e-3]
    body.add_joint(name=ODOMETER, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0])


def breakpoints(track: Track) -> np.ndarray:
    """Rows (x, curvature, cant, heading, heading's integral) at each section's ends, where
    the curvature and cant are linear between rows (a step between sections: two rows at one x)."""
    rows: list[list[float]] = []
    heading = integral = 0.0
    for section in track.sections:
        for x, k, d in (
            (section.start, section.curvature_start, section.cant_start),
            (section.end, section.curvature_end, section.cant_end),
        ):
            if rows:
                x0, k0, _, h0, i0 = rows[-1]
                t = x - x0
                if t > 0.0:  # the closed forms of rail_mj.simulation.curve.track_at on [x0, x]
                    integral = i0 + h0 * t + k0 * t * t / 2 + (k - k0) * t * t / 6
                    heading = h0 + (k0 + k) * t / 2
                if t == 0.0 and k == k0 and d == rows[-1][2]:
                    continue  # the same point twice
            rows.append([x, k, d, heading, integral])
    return np.array(rows, dtype=np.float64)


def track_part(
    model: mujoco.MjModel, layout: Layout, track: Track, prefix: str = "", profile: SpeedProfile | None = None
) -> np.ndarray:
    """The track part of the block (rail_mj.numerics) of `layout`'s vehicle under `prefix` in
    `model`, with the run's speed `profile` (None: a constant speed, the block's). A spatial
    vehicle's bodies have heights and roll, and its gravity switch says whether the model weighs
    them; a planar model has no vertical motion, and its cant still
    turns g into the track plane."""
    spatial = layout.spatial is not None
    gravity = layout.spatial is None or layout.spatial.gravity
    if spatial and not gravity and track.irregularities is not None:
        raise ValueError(
            f"{layout.source}: a spatial vehicle without gravity on an irregular track is not modelled (its "
            f"wheel loads, which the rails' level and cross level change, come from its suspension's weight): "
            f"set [spatial] gravity = true, or run it on {track.source} without [irregularities]"
        )
    if spatial and not gravity and _cant_varies(track):
        # A wheelset's cant roll reaches its axlebox springs through their roll levers, which only a
        # spatial vehicle with gravity carries (its wheel loads' numeric, rail_mj.vehicle.loads).
        raise ValueError(
            f"{layout.source}: a spatial vehicle without gravity on a track whose cant varies is not modelled "
            f"yet (its wheelsets' cant roll would not reach their axlebox springs; docs/track.md): set "
            f"[spatial] gravity = true, or run it on {track.source} with constant cant"
        )
    odometer = model.body(prefix + ODOMETER).id
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    own = [
        b
        for b in range(1, model.nbody)
        if model.body(b).name.startswith(prefix) and b != odometer and joint_chain(model, b)
    ]
    # The wheelsets first, in order: the callback adds their curve loads to their contact forces
    # and pushes both through their joint chains at once (rail_mj.simulation.native).
    wheelsets = [model.body(f"{prefix}wheelset{i + 1}").id for i in range(layout.n_wheelsets)]
    own = wheelsets + [b for b in own if b not in wheelsets]
    dofs = sorted({int(model.jnt_dofadr[j]) for b in own for j in _own_joints(model, b)})
    # J: each body's lateral offset, yaw and roll (rows) from the joint coordinates (columns).
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    rows = []
    for b in own:
        mujoco.mj_jacBody(model, data, jacp, jacr, b)
        rows += [jacp[1, dofs], jacr[2, dofs], jacr[0, dofs]]
    jacobian = np.array(rows)
    # Where a body cannot take a pose (a wheelset's roll, held by the rails; any roll in a
    # planar model) its row is empty and the least squares leave it out.
    g = np.linalg.pinv(jacobian, rcond=1e-10)
    g[np.abs(g) < ROUND_OFF] = 0.0
    column = {dof: i for i, dof in enumerate(dofs)}

    part: list[float] = [float(odometer), GRAVITY if gravity else 0.0]
    table = breakpoints(track)
    bodies: list[list[float]] = []  # entries, each a list
    for b in own:
        chain = joint_chain(model, b)
        height = float(data.xipos[b, 2]) if spatial else 0.0
        # Principal axes along the track's (rail_mj.vehicle.joints): the yaw inertia is the third.
        inertia = float(model.body_inertia[b, 2])
        bodies.append(
            [
                float(b),
                float(data.xipos[b, 0]),
                height,
                float(model.body_mass[b]),
                inertia,
                len(chain) / 3,
                *chain,
            ]
        )
    # The dofs' rows: the pre-deflection forces of the joint springs and of every linear tendon
    # (no deadband) folded into one linear map from the poses and their rates to each dof, on
    # pose p: -(k*G[p]) summed over the elements (k a joint's stiffness, or a tendon's times its
    # coefficient on the dof), on its rate the same with the dampings.
    on_pose: dict[int, np.ndarray] = {}
    on_rate: dict[int, np.ndarray] = {}

    def fold(dof: int, row: np.ndarray, stiffness: float, damping: float) -> None:
        on_pose.setdefault(dof, np.zeros(jacobian.shape[0]))
        on_rate.setdefault(dof, np.zeros(jacobian.shape[0]))
        on_pose[dof] -= stiffness * row
        on_rate[dof] -= damping * row

    for dof in dofs:
        joint = int(model.dof_jntid[dof])
        stiffness, damping = float(model.jnt_stiffness[joint]), float(model.dof_damping[dof])
        if spatial and model.joint(joint).name.removeprefix(prefix).rpartition("_")[2] in (ROLL, PITCH):
            # A spatial body's roll and pitch hinges are stiff only with the gravitational
            # stiffness (rail_mj.vehicle.statics), added after the first compile: the gravity's
            # tilt at each body is its F_y and F_z already, and the hinge takes no pre-deflection
            # (so that the part is the same from the model before it as after).
            stiffness = 0.0
        if (stiffness == 0.0 and damping == 0.0) or not np.any(g[column[dof]]):
            continue  # nothing to deflect, or the track moves it not
        fold(dof, g[column[dof]], stiffness, damping)
    roll = _wheelset_roll(model, layout, prefix, own, data)
    read = _tendons_read(model, layout, prefix)
    # The tendons listed: those whose real lengths the wheel loads and shear couples read (shifted
    # for them), and those whose forces are not linear in the shift, with the dofs they act on: a
    # deadband's, and on irregular rails the axlebox tendons', which the rails deflect as well.
    tendons: list[list[float]] = []
    for t in range(model.ntendon):
        if not model.tendon(t).name.startswith(prefix):
            continue
        if model.tendon_stiffness[t] == 0.0 and model.tendon_damping[t] == 0.0:
            continue
        coefficients = tendon_coefficients(model, t)
        row = sum((c * g[column[dof]] for dof, c in coefficients), np.zeros(jacobian.shape[0]))
        if t in roll:  # an axlebox tendon: its wheelset's cant roll, which no joint takes
            index, on_moment, height = roll[t]
            row[POSES * index + 2] += on_moment + row[POSES * index] * height
            row[np.abs(row) < ROUND_OFF] = 0.0
        low, high = model.tendon_lengthspring[t]
        linear = low == high and not (track.irregularities is not None and t in roll)
        if linear:
            for dof, c in coefficients:
                fold(dof, row, c * float(model.tendon_stiffness[t]), c * float(model.tendon_damping[t]))
            if t in read:
                tendons.append([float(t), *_terms(row), 0.0])
        else:
            dof_terms = [v for dof, c in coefficients for v in (float(dof), c)]
            tendons.append([float(t), *_terms(row), float(len(coefficients)), *dof_terms])
    joints: list[list[float]] = []
    for dof in sorted(on_pose):
        pose, rate = on_pose[dof], on_rate[dof]
        terms = np.nonzero((pose != 0.0) | (rate != 0.0))[0]
        if len(terms):
            joints.append([float(dof), float(len(terms)), *(v for p in terms for v in (float(p), pose[p], rate[p]))])
    if _straight_and_level(track):
        # The track's geometry moves no body and loads none (every pose and load above is zero): the
        # callback skips them. On irregular rails the axlebox tendons stay listed, with no terms, for
        # the forces of the rails' deflections of them (rail_mj.vehicle.rails).
        bodies, joints, tendons = [], [], []
        if track.irregularities is not None:
            for t in sorted(roll):
                coefficients = tendon_coefficients(model, t)
                dof_terms = [v for dof, c in coefficients for v in (float(dof), c)]
                tendons.append([float(t), 0.0, float(len(coefficients)), *dof_terms])
    part += [float(len(table)), float(len(bodies)), float(len(joints)), float(len(tendons))]
    points = [] if profile is None else profile.block()
    part += [float(model.joint(prefix + ODOMETER).dofadr[0]), float(len(points) // 2)]
    # The entries' index (rail_mj.numerics): where each body's, joint's and tendon's entry starts and
    # where the last ends, from the part's first entry, so that the callback reads them independently.
    entries = [*bodies, *joints, *tendons]
    first = len(part) + 1 + len(points) + table.size + len(entries) + 1
    starts = first + np.cumsum([0] + [len(entry) for entry in entries])
    flat = [v for entry in entries for v in entry]
    body = np.concatenate([points, table.reshape(-1), starts.astype(np.float64), flat])
    if track.irregularities is None:
        return np.concatenate([part, [0.0], body])
    from rail_mj.vehicle.rails import irregular_part

    # Where the irregularity part starts, from the track part's first entry (rail_mj.numerics).
    offset = len(part) + 1 + len(body)
    return np.concatenate([part, [float(offset)], body, irregular_part(model, layout, track, prefix)])


def _tendons_read(model: mujoco.MjModel, layout: Layout, prefix: str) -> set[int]:
    """The tendons whose lengths the wheel loads and the frames' shear couples read
    (rail_mj.vehicle.loads): the callback shifts their copies on a curve."""
    from rail_mj.vehicle.loads import AxleLoads, ShearCouples

    read: set[int] = set()
    loads = AxleLoads.of(model, [f"wheelset{i + 1}" for i in range(layout.n_wheelsets)], prefix)
    if loads is not None:
        for i in range(layout.n_wheelsets):
            read.update(int(t) for t in loads.rows(model, i, prefix)[:, 0])
            read.update(int(t) for t in loads.shear_rows(model, i, prefix).reshape(-1))
    couples = ShearCouples.of(model, prefix)
    if couples is not None:
        read.update(int(t) for t in couples.rows(model, prefix)[:, :3].reshape(-1))
    return read


def _straight_and_level(track: Track) -> bool:
    """Whether `track` is straight with no cant all along (what its geometry adds is then nothing)."""
    return all(
        (s.curvature_start, s.curvature_end, s.cant_start, s.cant_end) == (0.0, 0.0, 0.0, 0.0) for s in track.sections
    )


def _cant_varies(track: Track) -> bool:
    """Whether the cant changes anywhere along `track` (a ramp, or a step between sections)."""
    cants = [d for section in track.sections for d in (section.cant_start, section.cant_end)]
    return any(d != cants[0] for d in cants)


def _wheelset_roll(
    model: mujoco.MjModel, layout: Layout, prefix: str, own: list[int], data: mujoco.MjData
) -> dict[int, tuple[int, float, float]]:
    """Per axlebox tendon (rail_mj.vehicle.loads.AxleLoads): its wheelset's index among `own`,
    its coefficient on the roll moment M and the wheelset's centre's height.

    A wheelset has no roll joint (the rails hold it), so the least squares of G leave its cant
    roll out, and every axlebox tendon would take its frame's whole twist along a cant ramp. The
    coefficient on M is the tendon length's rate in the wheelset's roll about the rail level
    (M is the moment of the tendons' forces about it: virtual work), -s*d for a z tendon and h
    for a y tendon; the roll also moves the wheelset's centre, at its height r0, by -r0 per
    radian sideways, which G gives through the wheelset's lateral offset (its pose carries
    twist*height): the roll's own term is what is left, on_M + (term on the lateral offset)*r0
    (h - r0 for a y tendon, -s*d for a z tendon)."""
    from rail_mj.vehicle.loads import AxleLoads

    names = [f"wheelset{i + 1}" for i in range(layout.n_wheelsets)]
    loads = AxleLoads.of(model, names, prefix)
    if loads is None:
        return {}
    out = {}
    for i, name in enumerate(names):
        body = model.body(prefix + name).id
        index = own.index(body)
        for tendon, _, on_moment in loads.rows(model, i, prefix):
            out[int(tendon)] = (index, float(on_moment), float(data.xipos[body, 2]))
    return out


def _own_joints(model: mujoco.MjModel, body: int) -> range:
    return range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body])


def _terms(row: np.ndarray) -> list[float]:
    """A row of G as the block's terms: count, then (pose, coefficient)."""
    nonzero = np.nonzero(row)[0]
    assert POSES == 3  # rows are laid out (lateral, heading, roll) per body
    return [float(len(nonzero))] + [v for p in nonzero for v in (float(p), float(row[p]))]
