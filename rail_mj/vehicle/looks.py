"""What a vehicle looks like: its geoms (wheelsets, bogie frames, car bodies), their sizes and
colours, and the wheel's mesh asset. Nothing here touches the dynamics.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rail_mj.layout import Layout
from rail_mj.layout.kinds import Planar, SpatialVehicle
from rail_mj.units import SIDES
from rail_mj.vehicle.rounding import _g6
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
AXLEBOX_RGBA = [0.25, 0.25, 0.28, 1]
SPRING_RGBA = [0.85, 0.65, 0.15, 1]
FRAME_RGBA = [0.2, 0.3, 0.6, 1]

# Half the gap left between two car bodies' drawn ends (gangway, coupler), m; drawing only.
END_GAP = 0.15


def _quat_about_x(angle: float) -> list[float]:
    return [float(np.cos(angle / 2)), float(np.sin(angle / 2)), 0.0, 0.0]


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


def add_wheelset_geoms(body, name: str, layout: Layout, spring_top: float) -> None:
    """A wheelset's geoms in its body (origin the axle centre): axle, wheels, axleboxes and the
    primary springs up to `spring_top` (above the rail)."""
    w = layout.wheelset
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


def add_bogie_frame(body, name: str, layout: Layout, wheelset_positions: tuple[float, ...]) -> None:
    """A bogie frame's geoms in its body (origin BOGIE_HEIGHT above the rail), over its wheelsets
    (`wheelset_positions`, x from its centre)."""
    xs = sorted(wheelset_positions)
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


def add_carbody_shell(body, vehicle: Planar | SpatialVehicle) -> None:
    """The car body's geoms: a coach (underframe, side walls with a window strip, ends,
    roof) over the bogies or wheelsets; a fixed body is only a translucent underframe,
    the frame the suspension is held by."""
    layout, bogies = vehicle.layout, vehicle.bogies
    xs = vehicle.supports
    middle = (max(xs) + min(xs)) / 2
    if layout.carbody.fixed:  # a plate over the running gear, reaching 0.5 m past the wheels
        half_width = CARBODY_HALF_WIDTH
        bottom = underframe_bottom(layout) - CARBODY_HEIGHT
        wheelbase = bogies.bogie.wheelset_positions if bogies is not None else (0.0,)
        reach = (max(wheelbase) - min(wheelbase)) / 2
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


def mesh_file(layout: Layout) -> str:
    w = layout.wheelset
    return f"wheel_r{w.rolling_radius:g}_c{w.conicity:g}.stl"


def add_wheel_mesh(spec: mujoco.MjSpec, layout: Layout) -> None:
    """The wheel's mesh (rail_mj.vehicle.wheel), which every wheel geom draws, in `spec.assets`."""
    w = layout.wheelset
    stl = wheel_stl(w.rolling_radius, w.conicity)
    spec.add_mesh(name="wheel", file=mesh_file(layout))
    spec.assets = {mesh_file(layout): stl}
