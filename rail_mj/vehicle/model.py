"""Model generation: a `Layout` built into MuJoCo MJCF with the MjSpec API.

The model lives in a frame that travels along the track with the vehicle at the
run's speed: x is along the track, y to the left, z up (docs/frames.md).
Forward motion is not a degree of freedom; the runner adds x = V*t. Each
body has a lateral slide joint and a yaw hinge, nested as the suspension is:

    world -> carbody -> bogieK -> wheelsetN        (with [bogie])
    world -> carbody -> wheelsetN                  (without)

so each suspension is the stiffness and damping of the joints of the body it
carries. A wheelset joint measures y_w - (y_f + (x_w - x_f)*psi_f) and
psi_w - psi_f relative to its frame, exactly the suspension deflections of
docs/frames.md once linearised. A fixed car body has no joints.

Example:

    >>> from rail_mj.layout import load_layout
    >>> from rail_mj.vehicle.model import Vehicle
    >>> vehicle = Vehicle(load_layout("models/bogie/bogie.toml"))
    >>> vehicle.wheelset_names
    ('wheelset1', 'wheelset2')
    >>> vehicle.model.nv   # bogie frame and two wheelsets, lateral and yaw each
    6
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import mujoco
import numpy as np

from rail_mj.files import staged
from rail_mj.layout import GRAVITY, LAWS, Layout, Suspension
from rail_mj.units import PA_PER_GPA
from rail_mj.vehicle.wheel import wheel_profile, wheel_stl

# Heights of the bodies above the rail, m. The model is planar (lateral and yaw), so
# these place the bodies for viewing and have no effect on the dynamics. Bogie frame
# and car body are the Manchester benchmark's centres of mass (docs/manchester-coach.md).
BOGIE_HEIGHT = 0.6
CARBODY_HEIGHT = 1.8
AXLE_RADIUS = 0.08
RAIL_HEAD_WIDTH = 0.072  # UIC60, m

# The drawn parts, m: a handful of boxes and cylinders per body besides the wheel meshes
# (shapes that rail_mj.output.recording draws in Rerun too). No geom collides or weighs anything
# (inertias come from the layout), so none of this touches the dynamics. Lengths follow
# the layout (wheelbase, b, r0, body positions); heights above the rail stack up from r0:
# axlebox, primary spring, bogie side frame, secondary spring, car body.
# Axleboxes, bogie side frames and the springs on them stand this far outside the
# contact points: b = 0.75 puts them at +/-1.0 m, the Manchester benchmark's primary and
# secondary spring spacing (the frame of an outside-frame bogie clears the wheels).
SPRING_OUTSET = 0.25
AXLEBOX_HALF = (0.15, 0.09, 0.12)  # half length (x), width (y), height (z)
PRIMARY_SPRING_RADIUS = 0.08
PRIMARY_SPRING_LENGTH = 0.10  # axlebox top to the side frame's underside
SIDE_FRAME_HALF = (0.1, 0.1)  # half width (y) and depth (z)
TRANSOM_HALF_LENGTH = 0.2  # along x; at most a tenth of the gap between two wheelsets
SECONDARY_SPRING_RADIUS = 0.12
# A Mark-type coach (the Manchester benchmark's): 2.8 m wide, floor about 1.25 m and roof
# 3.9 m above the rail, ends 2.75 m beyond the bogie centres (19 m apart: 24.5 m long).
CARBODY_HALF_WIDTH = 1.4
UNDERFRAME_BOTTOM = 1.05  # raised if the wheels or bogie frames would reach it
UNDERFRAME_DEPTH = 0.2
UNDERFRAME_CLEARANCE = 0.08  # at least this above the wheels' or bogie frames' tops
ROOF_HEIGHT = 3.9
ROOF_DEPTH = 0.15
OVERHANG = 2.75
WALL = 0.05  # side walls and ends
WINDOW_BAND = (0.75, 1.55)  # window strip, above the floor
VESTIBULE = 1.2  # no windows this far from each end (doors)
SIDES = (("left", 1.0), ("right", -1.0))  # name and sign of y
AXLEBOX_RGBA = [0.25, 0.25, 0.28, 1]
SPRING_RGBA = [0.85, 0.65, 0.15, 1]
FRAME_RGBA = [0.2, 0.3, 0.6, 1]

# The run's speed replaces nothing here: the timestep is chosen by the runner.
DEFAULT_TIMESTEP = 1e-3

from rail_mj.numerics import (  # noqa: E402  (re-exported)
    NUMERIC_CREEP,
    NUMERIC_ELLIPSE,
    NUMERIC_FLANGE,
    NUMERIC_GEOMETRY,
    NUMERIC_NATIVE,
    NUMERIC_SATURATION,
    NUMERIC_WHEEL,
)

# A wheelset's lateral/yaw joints are named <body>_lateral and <body>_yaw.
LATERAL, YAW = "lateral", "yaw"
# A spatial vehicle's car body and bogie frames also move vertically, roll and pitch
# (docs/spatial.md): joints <body>_vertical, <body>_roll, <body>_pitch.
VERTICAL, ROLL, PITCH = "vertical", "roll", "pitch"


def _g6(*values: float) -> list[float]:
    """Numbers as MuJoCo's MJCF writer prints them, to 6 significant figures: every
    physical number goes into the model through this, so that the written MJCF compiles
    to exactly the model the runner simulates."""
    return [float(f"{v:.6g}") for v in values]


def _pos(x: float, z: float) -> list[float]:
    return _g6(x, 0.0, z)


def _quat_about_x(angle: float) -> list[float]:
    return [float(np.cos(angle / 2)), float(np.sin(angle / 2)), 0.0, 0.0]


def _add_planar_joints(body, suspension: Suspension | None) -> None:
    """Lateral slide and yaw hinge; `suspension` (None: free) is their stiffness and damping."""
    s = suspension or Suspension(0.0, 0.0)
    body.add_joint(
        name=f"{body.name}_{LATERAL}",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0, 1, 0],
        stiffness=_g6(s.lateral_stiffness, 0.0, 0.0),
        damping=_g6(s.lateral_damping, 0.0, 0.0),
    )
    body.add_joint(
        name=f"{body.name}_{YAW}",
        type=mujoco.mjtJoint.mjJNT_HINGE,
        axis=[0, 0, 1],
        stiffness=_g6(s.yaw_stiffness, 0.0, 0.0),
        damping=_g6(s.yaw_damping, 0.0, 0.0),
    )


def _set_inertia(body, mass: float, inertia) -> None:
    body.explicitinertial = True
    # Centre of mass at the body origin, principal axes along the track axes; set
    # explicitly because an unset ipos is not the origin.
    body.ipos = [0.0, 0.0, 0.0]
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.mass = _g6(mass)[0]
    body.inertia = _g6(*inertia)


def _box(body, name: str, half, pos, rgba) -> None:
    body.add_geom(
        name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=_g6(*half), pos=_g6(*pos), contype=0, conaffinity=0, rgba=rgba
    )


def _upright_cylinder(body, name: str, radius: float, x: float, y: float, bottom: float, top: float, rgba) -> None:
    """A cylinder standing from `bottom` to `top` (heights in `body`'s frame): a coil spring."""
    body.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=_g6(radius, (top - bottom) / 2, 0.0),
        pos=_g6(x, y, (top + bottom) / 2),
        contype=0,
        conaffinity=0,
        rgba=rgba,
    )


def spring_spacing(layout: Layout) -> float:
    """Lateral distance of the axleboxes, bogie side frames and springs from the centreline."""
    return layout.wheelset.contact_half_spacing + SPRING_OUTSET


def side_frame_heights(layout: Layout) -> tuple[float, float]:
    """Underside and top of a bogie side frame above the rail: on the primary springs."""
    bottom = layout.wheelset.rolling_radius + AXLEBOX_HALF[2] + PRIMARY_SPRING_LENGTH
    return bottom, bottom + 2 * SIDE_FRAME_HALF[1]


def wheel_radius(layout: Layout) -> float:
    """The wheel's outline, flange included (the mesh's largest radius)."""
    w = layout.wheelset
    return float(wheel_profile(w.rolling_radius, w.conicity)[:, 0].max())


def underframe_bottom(layout: Layout) -> float:
    """Height of the car body's underside above the rail: clear of what is under it."""
    wheel_top = layout.wheelset.rolling_radius + wheel_radius(layout)
    below = side_frame_heights(layout)[1] if layout.bogie else wheel_top
    return max(UNDERFRAME_BOTTOM, below + UNDERFRAME_CLEARANCE)


def add_wheelset(parent, name: str, x: float, z: float, layout: Layout, spring_top: float, nested: bool = True) -> None:
    """A wheelset hanging from `parent` at (x, z) in its frame, on the primary suspension,
    with its axleboxes and the primary springs up to `spring_top` (above the rail).
    `nested=False` (a train): free joints in the world, the suspension a tendon."""
    w = layout.wheelset
    body = parent.add_body(name=name, pos=_pos(x, z))
    _set_inertia(body, w.mass, w.inertia)
    _add_planar_joints(body, layout.primary if nested else None)
    b, ys = w.contact_half_spacing, spring_spacing(layout)
    body.add_geom(  # through the wheels into the axleboxes
        name=f"{name}_axle",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=_g6(AXLE_RADIUS, ys, 0),
        quat=_quat_about_x(np.pi / 2),
        contype=0,
        conaffinity=0,
        rgba=[0.4, 0.4, 0.45, 1],
    )
    # The mesh's axis (its +z) points outward: +y for the left wheel, -y for the right.
    for side, y, angle in (("left", b, -np.pi / 2), ("right", -b, np.pi / 2)):
        body.add_geom(
            name=f"{name}_{side}_wheel",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname="wheel",
            pos=[0, y, 0],
            quat=_quat_about_x(angle),
            contype=0,
            conaffinity=0,
            rgba=[0.55, 0.55, 0.6, 1],
        )
    # The body's origin is the axle centre, r0 above the rail.
    for side, sign in SIDES:
        _box(body, f"{name}_axlebox_{side}", AXLEBOX_HALF, (0, sign * ys, 0), AXLEBOX_RGBA)
        _upright_cylinder(
            body,
            f"{name}_spring_{side}",
            PRIMARY_SPRING_RADIUS,
            0,
            sign * ys,
            AXLEBOX_HALF[2],
            spring_top - w.rolling_radius,
            SPRING_RGBA,
        )


def add_bogie(parent, name: str, x: float, z: float, layout: Layout, first_wheelset: int) -> None:
    """A bogie frame at (x, z) in the car body, on the secondary suspension, with its wheelsets.

    Drawn as an outside-frame bogie: two side frames over the axleboxes, joined by a
    transom between each pair of wheelsets, carrying the secondary springs.
    """
    bogie = layout.bogie
    body = parent.add_body(name=name, pos=_pos(x, z))
    _set_inertia(body, bogie.mass, bogie.inertia)
    _add_planar_joints(body, layout.secondary)
    add_bogie_frame(body, name, layout)
    bottom = side_frame_heights(layout)[0] - BOGIE_HEIGHT  # in this body's frame
    for i, x in enumerate(bogie.wheelset_positions):
        add_wheelset(
            body,
            f"wheelset{first_wheelset + i}",
            x,
            layout.wheelset.rolling_radius - BOGIE_HEIGHT,
            layout,
            spring_top=bottom + BOGIE_HEIGHT,
        )


def add_bogie_frame(body, name: str, layout: Layout, wheelset_positions=None) -> None:
    """A bogie frame's geoms in its body (origin BOGIE_HEIGHT above the rail), over its wheelsets
    (`wheelset_positions`, x from its centre; None: [bogie]'s)."""
    xs = sorted(wheelset_positions or layout.bogie.wheelset_positions)
    ys = spring_spacing(layout)
    middle = (xs[0] + xs[-1]) / 2
    # Heights in this body's frame; its origin is BOGIE_HEIGHT above the rail.
    bottom, top = (h - BOGIE_HEIGHT for h in side_frame_heights(layout))
    half_depth = SIDE_FRAME_HALF[1]
    # Side frames reach the outline of the end wheels.
    half_length = (xs[-1] - xs[0]) / 2 + wheel_radius(layout)
    for side, sign in SIDES:
        _box(
            body,
            f"{name}_side_{side}",
            (half_length, SIDE_FRAME_HALF[0], half_depth),
            (middle, sign * ys, bottom + half_depth),
            FRAME_RGBA,
        )
    # A transom midway between each two wheelsets; a little shallower than the side
    # frames and ending inside them, so that no two faces coincide.
    gaps = list(zip(xs, xs[1:]))
    for k, (a, c) in enumerate(gaps):
        _box(
            body,
            f"{name}_transom" + (f"{k + 1}" if len(gaps) > 1 else ""),
            (min(TRANSOM_HALF_LENGTH, (c - a) / 10), ys, 0.8 * half_depth),
            ((a + c) / 2, 0, bottom + half_depth),
            FRAME_RGBA,
        )
    # Secondary springs on the side frames at the bogie centre, up to the car body.
    for side, sign in SIDES:
        _upright_cylinder(
            body,
            f"{name}_spring_{side}",
            SECONDARY_SPRING_RADIUS,
            middle,
            sign * ys,
            top,
            underframe_bottom(layout) - BOGIE_HEIGHT,
            SPRING_RGBA,
        )


def add_carbody_shell(body, layout: Layout) -> None:
    """The car body's geoms: a coach (underframe, side walls with a window strip, ends,
    roof) over the bogies or wheelsets; a fixed body is only a translucent underframe,
    the frame the suspension is held by."""
    c = layout.carbody
    xs = c.bogie_positions if layout.bogie else c.wheelset_positions
    middle = (max(xs) + min(xs)) / 2
    if c.fixed:  # a plate over the running gear, reaching 0.5 m past the wheels
        half_width = CARBODY_HALF_WIDTH
        bottom = underframe_bottom(layout) - CARBODY_HEIGHT
        reach = (
            (max(layout.bogie.wheelset_positions) - min(layout.bogie.wheelset_positions)) / 2 if layout.bogie else 0.0
        )
        half_length = (max(xs) - min(xs)) / 2 + reach + wheel_radius(layout) + 0.5
        _box(
            body,
            "carbody_underframe",
            (half_length, half_width, UNDERFRAME_DEPTH / 2),
            (middle, 0, bottom + UNDERFRAME_DEPTH / 2),
            [0.7, 0.2, 0.2, 0.35],
        )
        return
    add_coach_shell(body, "carbody", layout, middle, (max(xs) - min(xs)) / 2 + OVERHANG)


def add_coach_shell(body, name: str, layout: Layout, middle: float, half_length: float) -> None:
    """A coach's geoms, named <name>_*: centred at x = `middle` in `body`, `half_length` long."""
    half_width = CARBODY_HALF_WIDTH
    # Heights in this body's frame; its origin is CARBODY_HEIGHT above the rail.
    bottom = underframe_bottom(layout) - CARBODY_HEIGHT
    floor = bottom + UNDERFRAME_DEPTH
    body_rgba, dark = [0.7, 0.2, 0.2, 1], [0.15, 0.15, 0.17, 1]
    # The underframe a little narrower than the body, so that it reads as a separate band.
    _box(
        body,
        f"{name}_underframe",
        (half_length, half_width - 0.1, UNDERFRAME_DEPTH / 2),
        (middle, 0, bottom + UNDERFRAME_DEPTH / 2),
        dark,
    )
    eaves = ROOF_HEIGHT - ROOF_DEPTH - CARBODY_HEIGHT
    wall_half_height = (eaves - floor) / 2
    for side, sign in SIDES:
        _box(
            body,
            f"{name}_side_{side}",
            (half_length, WALL / 2, wall_half_height),
            (middle, sign * (half_width - WALL / 2), floor + wall_half_height),
            body_rgba,
        )
        # Windows: a dark strip just proud of the wall, short of the vestibules at the ends.
        low, high = WINDOW_BAND
        _box(
            body,
            f"{name}_windows_{side}",
            (half_length - VESTIBULE, 0.005, (high - low) / 2),
            (middle, sign * (half_width + 0.005), floor + (low + high) / 2),
            [0.1, 0.12, 0.18, 1],
        )
    for end, sign in (("front", 1.0), ("rear", -1.0)):
        _box(
            body,
            f"{name}_end_{end}",
            (WALL / 2, half_width - WALL, wall_half_height),
            (middle + sign * (half_length - WALL / 2), 0, floor + wall_half_height),
            body_rgba,
        )
    # The roof overhangs the walls by 2 cm.
    _box(
        body,
        f"{name}_roof",
        (half_length + 0.02, half_width + 0.02, ROOF_DEPTH / 2),
        (middle, 0, eaves + ROOF_DEPTH / 2),
        [0.45, 0.45, 0.48, 1],
    )


def add_carbody(worldbody, layout: Layout) -> None:
    """The car body (held over the centreline when fixed) with everything under it."""
    c = layout.carbody
    body = worldbody.add_body(name="carbody", pos=[0, 0, CARBODY_HEIGHT])
    if not c.fixed:
        _set_inertia(body, c.mass, c.inertia)
        _add_planar_joints(body, None)
    add_carbody_shell(body, layout)
    if layout.bogie:
        n = len(layout.bogie.wheelset_positions)
        for k, x in enumerate(c.bogie_positions):
            add_bogie(body, f"bogie{k + 1}", x, BOGIE_HEIGHT - CARBODY_HEIGHT, layout, k * n + 1)
    else:
        for i, x in enumerate(c.wheelset_positions):
            add_wheelset(
                body,
                f"wheelset{i + 1}",
                x,
                layout.wheelset.rolling_radius - CARBODY_HEIGHT,
                layout,
                spring_top=underframe_bottom(layout),
            )


# Half the gap left between two car bodies' drawn ends (gangway, coupler), m; drawing only.
END_GAP = 0.15


def add_train(spec: mujoco.MjSpec, layout: Layout) -> None:
    """A train (layout.train; docs/trains.md): every car body, bogie frame and wheelset a child of
    the world with its own lateral slide and yaw hinge (absolute coordinates, no spring), and each
    suspension or inter-car element a pair of fixed tendons whose lengths are its lateral and yaw
    deflections, their stiffness and damping the element's. Bodies: carbodyK, bogieK, wheelsetN
    (numbered from the front)."""
    train, bogie, world = layout.train, layout.bogie, spec.worldbody
    x_of: dict[str, float] = {}
    for k, car in enumerate(train.cars, start=1):
        name = f"carbody{k}"
        body = world.add_body(name=name, pos=_pos(car.position, CARBODY_HEIGHT))
        _set_inertia(body, car.mass, car.inertia)
        _add_planar_joints(body, None)
        add_coach_shell(body, name, layout, 0.0, car.length / 2 - END_GAP)
        x_of[name] = car.position
    spring_top = side_frame_heights(layout)[0]
    n = len(bogie.wheelset_positions)
    for i, xb in enumerate(layout.carbody.bogie_positions, start=1):
        name = f"bogie{i}"
        add_flat_bogie(world, name, xb, BOGIE_HEIGHT, layout, spatial=False)
        x_of[name] = xb
        for j, xw in enumerate(bogie.wheelset_positions):
            wheelset = f"wheelset{(i - 1) * n + j + 1}"
            add_wheelset(world, wheelset, xb + xw, layout.wheelset.rolling_radius, layout, spring_top, nested=False)
            x_of[wheelset] = xb + xw
            _suspension_tendons(spec, wheelset, f"{name}", x_of, layout.primary)
        carried_by = train.cars_on(i)
        for k in carried_by:  # a Jacobs bogie shares [secondary] between its two bodies
            _suspension_tendons(spec, name, f"carbody{k}", x_of, layout.secondary, 1.0 / len(carried_by))
    _coupling_tendons(spec, train, x_of)


def _coupling_tendons(spec, train, x_of: dict[str, float], heights: dict[str, float] | None = None) -> None:
    """Each [[coupling]]'s lateral and yaw tendons (docs/trains.md) on the car bodies' lateral and
    yaw coordinates, which are absolute in a planar and in a spatial train alike. A spatial
    train's (`heights`: each body's centre of mass above the rail) acts at one point, midway
    between the two bodies' heights, where each body's lateral motion has its roll's part too:
    the coupling's two forces then lie on one line (no couple of their own)."""
    for c in train.couplings:
        front, rear = (f"carbody{k}" for k in c.cars)
        x = train.coupling_x(c)
        # The rear body's point at x against the front body's: y + (x - x_body)*psi of each.
        lateral = {
            f"{rear}_{LATERAL}": 1.0,
            f"{rear}_{YAW}": x - x_of[rear],
            f"{front}_{LATERAL}": -1.0,
            f"{front}_{YAW}": -(x - x_of[front]),
        }
        if heights is not None and heights[front] != heights[rear]:  # and - (z - H_body)*phi
            z = 0.5 * (heights[front] + heights[rear])
            lateral[f"{rear}_{ROLL}"] = -(z - heights[rear])
            lateral[f"{front}_{ROLL}"] = z - heights[front]
        _tendon(spec, f"coupling{c.cars[0]}_{LATERAL}", lateral, c.lateral_stiffness, c.lateral_damping)
        _tendon(
            spec,
            f"coupling{c.cars[0]}_{YAW}",
            {f"{rear}_{YAW}": 1.0, f"{front}_{YAW}": -1.0},
            c.yaw_stiffness,
            c.yaw_damping,
        )


def _add_spatial_joints(body) -> None:
    """Lateral slide and yaw hinge (as a planar body's), then vertical slide, roll and pitch
    hinges, all at the centre of mass and with no spring: absolute coordinates."""
    _add_planar_joints(body, None)
    body.add_joint(name=f"{body.name}_{VERTICAL}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
    body.add_joint(name=f"{body.name}_{ROLL}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[1, 0, 0])
    body.add_joint(name=f"{body.name}_{PITCH}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0])


def point_motion(body: str, r, joints) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """The displacement (x, y, z) of the point at `r` = (rx, ry, rz) from `body`'s centre of mass,
    linear in the body's joint coordinates (docs/spatial.md): the translation plus w x r for the
    small rotation w = (roll, pitch, yaw). `joints`: the motions the body has; each component a
    {joint name: coefficient}."""
    rx, ry, rz = r
    ux = {PITCH: rz, YAW: -ry}
    uy = {LATERAL: 1.0, YAW: rx, ROLL: -rz}
    uz = {VERTICAL: 1.0, ROLL: ry, PITCH: -rx}
    return tuple({f"{body}_{m}": c for m, c in u.items() if m in joints and c != 0.0} for u in (ux, uy, uz))


SPATIAL_BODY = (LATERAL, YAW, VERTICAL, ROLL, PITCH)
SPATIAL_WHEELSET = (LATERAL, YAW)  # vertical and roll held by the (rigid) track
AXES = "xyz"


def spring_tendons(
    spec,
    name: str,
    point,
    lower: tuple[str, tuple, tuple],
    upper: tuple[str, tuple, tuple],
    spring,
    measured: bool = False,
) -> None:
    """A spatial spring-damper (`spring`: kx..cz) at `point` (x, y, z in the vehicle's frame, z above
    the rail) between `lower` and `upper`, each (body, centre (x, y, z), joints): three fixed tendons
    <name>_x|y|z, their lengths the deflections u_upper - u_lower of the point along x, y, z.
    `measured`: every axis a tendon, a spring-less one too (its length is what the preload's
    shear couples act on, rail_mj.vehicle.loads.ShearCouples)."""
    for axis, coefficients in zip(AXES, deflections(point, lower, upper)):
        k, c = getattr(spring, f"k{axis}"), getattr(spring, f"c{axis}")
        _tendon(spec, f"{name}_{axis}", coefficients, k, c, keep=measured)


def deflections(point, lower: tuple[str, tuple, tuple], upper: tuple[str, tuple, tuple]) -> tuple[dict, dict, dict]:
    """The deflections (x, y, z) u_upper - u_lower at `point` of two bodies, each (body, centre, joints)
    as in `spring_tendons`: each a {joint name: coefficient}."""
    motions = []
    for body, centre, joints in (upper, lower):
        r = tuple(p - c for p, c in zip(point, centre))
        motions.append(point_motion(body, r, joints))
    out = []
    for up, low in zip(*motions):
        coefficients = dict(up)
        for joint, c in low.items():
            coefficients[joint] = coefficients.get(joint, 0.0) - c
        out.append(coefficients)
    return tuple(out)


def secondary_elements(
    spec,
    bogie: str,
    x: float,
    frame: tuple[str, tuple, tuple],
    carbody: tuple[str, tuple, tuple],
    sp,
    share: float = 1.0,
) -> None:
    """The secondary elements of a spatial vehicle besides its springs (`sp`: layout.spatial;
    docs/spatial.md) between a bogie frame at x and the car body, each at its place: tendons
    <bogie>_<carbody>_lateral_damper, _left|right_yaw_damper, _anti_roll_bar, _bump_stop_<i>;
    `share` of each (a Jacobs bogie's half under each of its two bodies, docs/trains.md)."""
    name = f"{bogie}_{carbody[0]}"
    if sp.lateral_damper:
        e = sp.lateral_damper
        _tendon(spec, f"{name}_lateral_damper", deflections((x, 0.0, e.height), frame, carbody)[1], 0.0, share * e.c)
    if sp.yaw_damper:
        e = sp.yaw_damper
        for side, sign in SIDES:
            longitudinal = deflections((x, sign * e.spacing, e.height), frame, carbody)[0]
            _tendon(spec, f"{name}_{side}_yaw_damper", longitudinal, 0.0, share * e.c)
    if sp.anti_roll_bar:
        # A torsion bar's moment is k times the relative roll of the two bodies, wherever its
        # arms and links sit: exactly a tendon on the two roll hinges.
        _tendon(
            spec,
            f"{name}_anti_roll_bar",
            {f"{carbody[0]}_{ROLL}": 1.0, f"{bogie}_{ROLL}": -1.0},
            share * sp.anti_roll_bar,
            0.0,
        )
    if sp.bump_stop:
        e = sp.bump_stop
        lateral = deflections((x, 0.0, e.height), frame, carbody)[1]
        # The piecewise-linear table as a sum of deadband springs: MuJoCo's tendon spring is idle
        # within springlength [lo, hi] and linear outside, so each breakpoint's spring adds its
        # rise of slope from there on (BumpStop.deadbands).
        for i, (play, k) in enumerate(e.deadbands(), start=1):
            tendon = _tendon(spec, f"{name}_bump_stop_{i}", lateral, share * k, 0.0)
            if tendon is not None:
                tendon.springlength = _g6(-play, play)


def spatial_carbodies(layout: Layout) -> list[tuple[str, tuple, tuple]]:
    """A spatial vehicle's car bodies as (name, centre (x, 0, height), joints): its one `carbody`, or
    a spatial train's carbody1, carbody2, ... each at its own x and height (docs/trains.md)."""
    if layout.train is None:
        return [("carbody", (0.0, 0.0, layout.spatial.carbody_height), SPATIAL_BODY)]
    return [
        (f"carbody{k}", (car.position, 0.0, car.height), SPATIAL_BODY)
        for k, car in enumerate(layout.train.cars, start=1)
    ]


def carried(layout: Layout, bogie: int) -> list[tuple[tuple[str, tuple, tuple], float]]:
    """The car bodies bogie `bogie` (1-based) carries, each with its share of the secondary
    elements: the one car body's whole, or on a Jacobs bogie half to each of the two (as add_train)."""
    bodies = spatial_carbodies(layout)
    if layout.train is None:
        return [(bodies[0], 1.0)]
    on = layout.train.cars_on(bogie)
    return [(bodies[k - 1], 1.0 / len(on)) for k in on]


def _shared(spring, share: float):
    """`spring` (a Spring) with its stiffness and damping times `share` (itself when 1)."""
    if share == 1.0:
        return spring
    return dataclasses.replace(spring, **{f"{k}{a}": share * getattr(spring, f"{k}{a}") for k in "kc" for a in AXES})


def add_spatial(spec: mujoco.MjSpec, layout: Layout) -> None:
    """A spatial vehicle (layout.spatial; docs/spatial.md), built flat: the car body and bogie
    frames children of the world with lateral, yaw, vertical, roll and pitch joints at their centres
    of mass, the wheelsets with lateral and yaw; each spring-damper element one fixed tendon per
    direction (x, y, z), its length the element's linearised deflection. Tendons are named
    <lower>_<upper>_<side>_<axis>, e.g. wheelset1_bogie1_left_z. A spatial train (docs/trains.md):
    car bodies carbody1, ... each at its place and height, a Jacobs bogie carrying half of each
    secondary element under each of its two bodies, the couplings as add_train's."""
    sp, world = layout.spatial, spec.worldbody
    hb, r0 = sp.bogie_height, layout.wheelset.rolling_radius
    train = layout.train
    couples = sp.gravity and sp.gravitational_stiffness  # rail_mj.vehicle.loads.ShearCouples
    for k, (name, (x, _, h), _) in enumerate(spatial_carbodies(layout)):
        body = world.add_body(name=name, pos=[0, 0, _g6(h)[0]] if train is None else _pos(x, h))
        if train is None:
            _set_inertia(body, layout.carbody.mass, layout.carbody.inertia)
            _add_spatial_joints(body)
            add_carbody_shell(body, layout)
        else:
            car = train.cars[k]
            _set_inertia(body, car.mass, car.inertia)
            _add_spatial_joints(body)
            add_coach_shell(body, name, layout, 0.0, car.length / 2 - END_GAP)
    spring_top = side_frame_heights(layout)[0]
    n = len(layout.bogie.wheelset_positions)  # every bogie's ([bogies.N] keeps it)
    for i, (xb, design) in enumerate(zip(layout.carbody.bogie_positions, sp.bogies), start=1):
        name = f"bogie{i}"
        add_flat_bogie(world, name, xb, hb, layout, spatial=True, design=design)
        frame = (name, (xb, 0.0, hb), SPATIAL_BODY)
        for j, xw in enumerate(design.wheelset_positions):
            wheelset = f"wheelset{(i - 1) * n + j + 1}"
            add_wheelset(world, wheelset, xb + xw, r0, layout, spring_top, nested=False)
            for side, sign in SIDES:
                e = design.axlebox
                spring_tendons(
                    spec,
                    f"{wheelset}_{name}_{side}",
                    (xb + xw, sign * e.spacing, e.height),
                    (wheelset, (xb + xw, 0.0, r0), SPATIAL_WHEELSET),
                    frame,
                    e,
                    couples,
                )
        for carbody, share in carried(layout, i):
            for side, sign in SIDES:
                e = sp.secondary
                spring_tendons(
                    spec,
                    f"{name}_{carbody[0]}_{side}",
                    (xb, sign * e.spacing, e.height),
                    frame,
                    carbody,
                    _shared(e, share),
                    couples,
                )
            secondary_elements(spec, name, xb, frame, carbody, sp, share)
    if train is not None:
        x_of = {f"carbody{k}": car.position for k, car in enumerate(train.cars, start=1)}
        heights = {name: h for name, (_, _, h), _ in spatial_carbodies(layout)}
        _coupling_tendons(spec, train, x_of, heights)


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


def spatial_elements(layout: Layout):
    """The spring-damper elements of a spatial vehicle, as `add_spatial` joins them and in its
    order: (name, point, lower, upper, spring), the arguments `spring_tendons` takes (a Jacobs
    bogie's secondary springs once under each of its two bodies, each with half the spring)."""
    sp, r0 = layout.spatial, layout.wheelset.rolling_radius
    n = len(layout.bogie.wheelset_positions)
    for i, (xb, design) in enumerate(zip(layout.carbody.bogie_positions, sp.bogies), start=1):
        frame = (f"bogie{i}", (xb, 0.0, sp.bogie_height), SPATIAL_BODY)
        e = design.axlebox
        for j, xw in enumerate(design.wheelset_positions):
            wheelset = (f"wheelset{(i - 1) * n + j + 1}", (xb + xw, 0.0, r0), SPATIAL_WHEELSET)
            for side, sign in SIDES:
                point = (xb + xw, sign * e.spacing, e.height)
                yield f"{wheelset[0]}_{frame[0]}_{side}", point, wheelset, frame, e
        for carbody, share in carried(layout, i):
            for side, sign in SIDES:
                point = (xb, sign * sp.secondary.spacing, sp.secondary.height)
                yield f"{frame[0]}_{carbody[0]}_{side}", point, frame, carbody, _shared(sp.secondary, share)


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
        # A static force at a point this module does not know would be a term silently missing
        # (a deadband tendon, a bump stop, carries none: preload leaves it in its play).
        preloaded = t.springlength[0] != 0.0 and t.springlength[0] == t.springlength[1]
        if preloaded and t.name not in known:
            raise NotImplementedError(
                f"gravitational stiffness: tendon {t.name} is preloaded but is no element of spatial_elements"
            )
    for joint, k in gravitational_stiffness(layout, forces).items():
        spec.joint(joint).stiffness = _g6(k, 0.0, 0.0)


def add_flat_bogie(world, name: str, x: float, height: float, layout: Layout, spatial: bool, design=None) -> None:
    """A bogie frame as a child of the world at (x, height): planar (lateral, yaw) or spatial
    joints, with no spring (a train's or a spatial vehicle's; its wheelsets are added apart).
    `design`: its mass, inertia and wheelset_positions (a spatial vehicle's BogieDesign); None:
    [bogie]'s."""
    design = design or layout.bogie
    body = world.add_body(name=name, pos=_pos(x, height))
    _set_inertia(body, design.mass, design.inertia)
    if spatial:
        _add_spatial_joints(body)
    else:
        _add_planar_joints(body, None)
    add_bogie_frame(body, name, layout, design.wheelset_positions)


def _suspension_tendons(
    spec, child: str, parent: str, x_of: dict[str, float], s: Suspension, share: float = 1.0
) -> None:
    """The lateral and yaw deflections of `child` hung from `parent` (docs/frames.md),
    d = y_c - y_p - (x_c - x_p)*psi_p and e = psi_c - psi_p, as tendons with `share` of `s`."""
    arm = x_of[child] - x_of[parent]
    lateral = {f"{child}_{LATERAL}": 1.0, f"{parent}_{LATERAL}": -1.0, f"{parent}_{YAW}": -arm}
    _tendon(spec, f"{child}_{parent}_{LATERAL}", lateral, share * s.lateral_stiffness, share * s.lateral_damping)
    _tendon(
        spec,
        f"{child}_{parent}_{YAW}",
        {f"{child}_{YAW}": 1.0, f"{parent}_{YAW}": -1.0},
        share * s.yaw_stiffness,
        share * s.yaw_damping,
    )


def _tendon(spec, name: str, coefficients: dict[str, float], stiffness: float, damping: float, keep: bool = False):
    """A fixed tendon, length sum(coef*q) (zero when centred), with a linear spring and damper;
    none (None) when both are zero, unless `keep` (its length is needed)."""
    if stiffness == 0.0 and damping == 0.0 and not keep:
        return None
    tendon = spec.add_tendon(
        name=name, stiffness=_g6(stiffness, 0.0, 0.0), damping=_g6(damping, 0.0, 0.0), springlength=[0.0, 0.0]
    )
    for joint, coef in coefficients.items():
        if coef != 0.0:
            tendon.wrap_joint(joint, _g6(coef)[0])
    return tendon


def mesh_file(layout: Layout) -> str:
    w = layout.wheelset
    return f"wheel_r{w.rolling_radius:g}_c{w.conicity:g}.stl"


def build_spec(layout: Layout) -> mujoco.MjSpec:
    """The vehicle alone as an MjSpec, its wheel mesh in `spec.assets`."""
    spec = mujoco.MjSpec()
    spec.modelname = layout.name
    spec.compiler.degree = False
    spec.meshdir = "assets"
    # Masses and inertias come from the layout, never from the (visual) geoms; to_xml
    # writes the <inertial> elements only when asked to.
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.saveinertial = True
    # Only the car-body/bogie/wheelset lateral-yaw dynamics are modelled; nothing collides.
    # RK4: MuJoCo integrates callback (creep) forces explicitly, and the semi-implicit
    # Euler integrators then misjudge the creep damping by O(dt*2*f22/(m*V)), which moved
    # the time-domain critical speed of the restrained wheelset by 5 % at dt = 1 ms;
    # RK4 reproduces the eigenvalues' growth rates to 4 digits at the same step.
    spec.option.timestep = DEFAULT_TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.disableflags = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)

    spec.add_numeric(name=NUMERIC_NATIVE, data=[0.0])  # first; filled in by `compiled`
    w = layout.wheelset
    stl = wheel_stl(w.rolling_radius, w.conicity)
    spec.add_mesh(name="wheel", file=mesh_file(layout))
    spec.assets = {mesh_file(layout): stl}
    if layout.spatial is not None:
        add_spatial(spec, layout)
        if layout.spatial.gravity:  # the wheel loads come from the suspension (rail_mj.vehicle.loads)
            from rail_mj.vehicle.loads import NUMERIC_LOADS

            e = layout.spatial.primary
            spin = w.inertia[1] if layout.spatial.gyroscopic else 0.0
            cone_gravity = layout.spatial.gravitational_stiffness and layout.profiles is None
            # Each wheelset's axlebox spacing and height after the defaults, when a bogie has its
            # own ([bogies.N.axlebox]; rail_mj.vehicle.loads reads either form).
            own = [(d.axlebox.spacing, d.axlebox.height) for d in layout.spatial.bogies for _ in d.wheelset_positions]
            own = [] if all(a == (e.spacing, e.height) for a in own) else [v for a in own for v in a]
            spec.add_numeric(
                name=NUMERIC_LOADS,
                data=_g6(GRAVITY * w.mass, w.wheel_load, e.spacing, e.height, spin, float(cone_gravity), *own),
            )
            if layout.spatial.gravitational_stiffness:  # the preloads' shear couples (rail_mj.vehicle.loads)
                from rail_mj.vehicle.loads import NUMERIC_COUPLES

                spec.add_numeric(name=NUMERIC_COUPLES, data=[1.0])
    elif layout.train is not None:
        add_train(spec, layout)
    else:
        add_carbody(spec.worldbody, layout)

    c = layout.creep
    spec.add_numeric(
        name=NUMERIC_WHEEL,
        data=_g6(
            w.rolling_radius,
            w.contact_half_spacing,
            w.conicity,
            w.flangeway_clearance,
        ),
    )
    spec.add_numeric(name=NUMERIC_CREEP, data=_g6(c.f11, c.f22, c.f23, c.f33))
    limit = c.friction * w.wheel_load if c.law != "linear" else 0.0  # unused by the linear law
    spec.add_numeric(
        name=NUMERIC_SATURATION, data=_g6(LAWS[c.law], limit, c.falling_friction_ratio, c.falling_friction_rate)
    )
    f = layout.flange
    spec.add_numeric(
        name=NUMERIC_FLANGE, data=_g6(1.0, f.stiffness, f.damping, np.tan(f.angle)) if f else _g6(0.0, 0.0, 0.0, 0.0)
    )
    spec.add_numeric(name=NUMERIC_ELLIPSE, data=_g6(*_ellipse(layout)))
    if layout.profiles is not None:
        from rail_mj.contact.tables import TableError, dynamics_table

        try:
            table = dynamics_table(layout)
        except TableError as e:
            raise ValueError(f"{layout.source}: {e}") from None
        spec.add_numeric(name=NUMERIC_GEOMETRY, data=_g6(*table.reshape(-1)))
    return spec


def _ellipse(layout: Layout) -> tuple[float, ...]:
    """NUMERIC_ELLIPSE's numbers: the Hertz ellipse of [contact], or zeros (also on
    profiles, whose contact table carries each point's ellipse)."""
    if layout.contact is None or layout.profiles is not None:
        return (0.0,) * 7
    from rail_mj.layout import contact_patch_of  # scipy: only for layouts with [contact]

    patch = contact_patch_of(layout)
    return (
        patch.a,
        patch.b,
        patch.normal_load,
        patch.shear_modulus / PA_PER_GPA,
        patch.C["C11"],
        patch.C["C22"],
        patch.C["C23"],
    )


def compile_spec(spec: mujoco.MjSpec, layout: Layout) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as e:
        why = "; ".join(line.strip() for line in str(e).splitlines() if line.strip())
        raise ValueError(f"{layout.source}: MuJoCo could not compile the model: {why}") from None


def compiled(layout: Layout) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    """The vehicle's spec and compiled model, its native block filled in: the block lists
    bodies, joints and dofs by the ids the compiler gave them, so it is written after a
    first compile (a millisecond or two) and the model compiled again."""
    from rail_mj.vehicle import block  # numba (the contact law's module): only once a model is built

    spec = build_spec(layout)
    model = compile_spec(spec, layout)
    if layout.spatial is not None:
        if layout.spatial.gravity:
            q_eq = preload(spec, model)
            # After the preload, and so outside the K it solves with: these terms are made of its
            # forces, and act about q = 0, which they must leave the equilibrium (docs/spatial.md).
            if layout.spatial.gravitational_stiffness:
                add_gravitational_stiffness(spec, layout, model, q_eq)
        else:
            spec.option.gravity = [0.0, 0.0, 0.0]
    spec.numerics[0].data = block.block_for(model, layout.n_wheelsets).tolist()
    add_sensors(spec, [model.body(b).name for b in range(1, model.nbody)])
    add_load_sensors(spec, model, [f"wheelset{i + 1}" for i in range(layout.n_wheelsets)])
    return spec, compile_spec(spec, layout)


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

    def poses(self, readings: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
        """Fill every moving body's position and quaternion (w, x, y, z) from sensor readings
        (samples along axis 0); the world's stay as they are."""
        pos[:, self.bodies] = readings[:, self.pos]
        quat[:, self.bodies] = readings[:, self.quat]

    def rates(self, readings: np.ndarray, rates: np.ndarray) -> None:
        """Fill each wheelset's (y_dot, psi_dot) from sensor readings."""
        rates[..., 0] = readings[:, self.lateral_rate]
        rates[..., 1] = readings[:, self.yaw_rate]

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
        loads[..., 0], loads[..., 1] = self.axle_loads.evaluate(self.model, lengths, rates, self.prefix)


class Vehicle:
    """A compiled vehicle: the MuJoCo model of a layout, its parts read by name.

    Example:

        >>> from rail_mj.layout import load_layout
        >>> vehicle = Vehicle(load_layout("models/manchester-coach/manchester-coach.toml"))
        >>> vehicle.wheelset_names[0], vehicle.model.nv
        ('wheelset1', 14)
    """

    def __init__(self, layout: Layout):
        self.layout = layout
        self.spec, self.model = compiled(layout)
        self.wheelset_names = tuple(f"wheelset{i + 1}" for i in range(layout.n_wheelsets))
        self.wheelset_ids = np.array([self.model.body(n).id for n in self.wheelset_names], dtype=np.int64)

    @property
    def n_wheelsets(self) -> int:
        return len(self.wheelset_names)

    @functools.cached_property
    def sensors(self) -> Sensors:
        return Sensors(self.model, self.wheelset_names)

    @functools.cached_property
    def root_lateral_dofs(self) -> np.ndarray:
        """The lateral joints that move the whole vehicle: those whose parent cannot move."""
        dofs = []
        for j in range(self.model.njnt):
            name = self.model.joint(j).name
            parent = self.model.body_parentid[self.model.jnt_bodyid[j]]
            if name.endswith(f"_{LATERAL}") and self.model.body_dofnum[parent] == 0:
                dofs.append(self.model.jnt_dofadr[j])
        return np.array(dofs, dtype=np.int64)

    def wheelset_dofs(self, motion: str) -> np.ndarray:
        return np.array(
            [self.model.joint(f"{n}_{motion}").dofadr[0] for n in self.wheelset_names],
            dtype=np.int64,
        )


SCENE_TEMPLATE = """\
<mujoco model="{name} scene">
  <include file="{name}.xml"/>

  <statistic center="0 0 1" extent="{extent:g}"/>

  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="120" elevation="-20"/>
  </visual>

  <asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="512" height="3072"/>
    <texture type="2d" name="ballast" builtin="checker" mark="edge" rgb1="0.35 0.33 0.3" rgb2="0.3 0.28 0.25"
      markrgb="0.5 0.5 0.5" width="300" height="300"/>
    <material name="ballast" texture="ballast" texuniform="true" texrepeat="5 5" reflectance="0"/>
    <material name="steel" rgba="0.75 0.75 0.78 1" specular="0.8"/>
  </asset>

  <worldbody>
    <light name="sun" pos="0 0 20" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="0 0 0.05" pos="0 0 {floor_z:g}" material="ballast"/>
    <!-- Rail heads centred on the contact points (y = +/- b), top at z = 0. -->
    <geom name="left_rail" type="box" size="{rail_half_length:g} {rail_half_width:g} 0.08"
      pos="0 {b:g} -0.08" material="steel"/>
    <geom name="right_rail" type="box" size="{rail_half_length:g} {rail_half_width:g} 0.08"
      pos="0 {neg_b:g} -0.08" material="steel"/>
  </worldbody>
</mujoco>
"""


def scene_xml(layout: Layout) -> str:
    xs = layout.wheelset_x
    length = max(xs) - min(xs) + 10.0
    b = layout.wheelset.contact_half_spacing
    return SCENE_TEMPLATE.format(
        name=layout.name,
        extent=length,
        floor_z=-0.16,
        rail_half_length=length,
        rail_half_width=RAIL_HEAD_WIDTH / 2,
        b=b,
        neg_b=-b,
    )


def generated_files(layout: Layout) -> dict[str, bytes]:
    """Every file `generate` writes, relative to the output folder."""
    spec, model = compiled(layout)  # to_xml needs a compiled spec; also proves the model is valid
    xml = spec.to_xml()
    # MuJoCo's writer keeps 6 significant figures (every number went in through _g6) and
    # writes as 0 any entry of a numeric below 1e-12 of its largest: check that the MJCF
    # reads back to the very model the runner steps, numbers and all.
    written = mujoco.MjModel.from_xml_string(xml, spec.assets)
    if not np.array_equal(written.numeric_data, model.numeric_data):
        k = int(np.flatnonzero(written.numeric_data != model.numeric_data)[0])
        raise ValueError(
            f"{layout.source}: the written MJCF would not read back to the model (numeric entry {k}: "
            f"{model.numeric_data[k]!r} written as {written.numeric_data[k]!r}); a bug in rail-mj"
        )
    files = {f"{layout.name}.xml": xml.encode(), "scene.xml": scene_xml(layout).encode()}
    for name, data in spec.assets.items():
        files[f"assets/{name}"] = bytes(data)
    return files


def generate(layout: Layout, out_dir: str | Path) -> list[Path]:
    """Write `<name>.xml`, `scene.xml` and `assets/` into `out_dir`.

    The files are written to temporary names and renamed into place together, so a
    failure never leaves a half-written file or half a model.
    """
    files = generated_files(layout)
    written = [Path(out_dir) / rel for rel in files]
    with staged(written) as temps:
        for tmp, data in zip(temps, files.values()):
            tmp.write_bytes(data)
    return written
