"""What a vehicle looks like: its geoms (wheelsets, bogie frames, car bodies), their sizes and
colours, and the wheel's mesh asset. Nothing here touches the dynamics.
"""

from __future__ import annotations

import functools
from pathlib import Path

import mujoco
import numpy as np

from rail_mj.layout import Layout
from rail_mj.layout.kinds import Planar, SpatialVehicle
from rail_mj.units import SIDES
from rail_mj.vehicle.rounding import _g6
from rail_mj.vehicle.wheel import outline_stl, profile_outline, wheel_profile

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

# [carbody] length, width and height (rail_mj.layout: optional) size the drawn body in place of the
# coach's. A body no taller than FLAT_HEIGHT is a flat wagon's deck, one box; a taller one has
# walls and a roof, and windows where its walls are tall enough for WINDOW_BAND with
# WINDOW_HEADROOM above (a coach; a lower, windowless body is drawn in FREIGHT_RGBA).
FLAT_HEIGHT = 0.6
WINDOW_HEADROOM = 0.2
DECK_RGBA = [0.42, 0.3, 0.2, 1]
COACH_RGBA = [0.7, 0.2, 0.2, 1]
FREIGHT_RGBA = [0.45, 0.32, 0.22, 1]


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
    return float(wheel_outline(layout)[:, 0].max())


def wheel_outline(layout: Layout) -> np.ndarray:
    """The (radius, axial) outline the wheel mesh revolves (rail_mj.vehicle.wheel): the layout's
    own wheel profile with [profiles], else the coned tread and flange of r0 and the conicity."""
    w = layout.wheelset
    if layout.profiles is None:
        return wheel_profile(w.rolling_radius, w.conicity)
    from rail_mj.contact.pair import stamp

    return _profile_outline(layout.profiles, w.rolling_radius, w.contact_half_spacing, stamp(layout.profiles))


@functools.lru_cache(maxsize=32)
def _profile_outline(profiles, rolling_radius: float, half_spacing: float, stamp) -> np.ndarray:
    """The wheel profile's outline, read once per profile file version (`stamp`: a changed file
    is read again) and radius; the wheel geoms stand at b, the taping line at the track's d."""
    from rail_mj.contact.pair import read_profiles
    from rail_mj.contact.profiles import TAPING_LINE_FROM_BACK

    wheel = read_profiles(profiles)[0]
    taping = profiles.flange_back_spacing / 2 + TAPING_LINE_FROM_BACK  # rail_mj.contact.geometry's d
    outline = profile_outline(wheel.y, wheel.z, rolling_radius, taping - half_spacing)
    outline.flags.writeable = False  # shared by every caller
    return outline


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
    roof) over the bogies or wheelsets, or the body [carbody] length, width and height
    describe (`add_coach_shell`); a fixed body is only a translucent underframe, the frame the
    suspension is held by (length, width and height its size when given)."""
    layout, bogies = vehicle.layout, vehicle.bogies
    c = layout.carbody
    xs = vehicle.supports
    middle = (max(xs) + min(xs)) / 2
    if c.fixed:  # a plate over the running gear, reaching 0.5 m past the wheels
        half_width = CARBODY_HALF_WIDTH if c.width is None else c.width / 2
        depth = UNDERFRAME_DEPTH if c.height is None else c.height
        bottom = underframe_bottom(layout) - CARBODY_HEIGHT
        wheelbase = bogies.bogie.wheelset_positions if bogies is not None else (0.0,)
        reach = (max(wheelbase) - min(wheelbase)) / 2
        half_length = (max(xs) - min(xs)) / 2 + reach + wheel_radius(layout) + 0.5 if c.length is None else c.length / 2
        _box(
            body,
            "carbody_underframe",
            (half_length, half_width, depth / 2),
            (middle, 0, bottom + depth / 2),
            [0.7, 0.2, 0.2, 0.35],
        )
        return
    half_length = (max(xs) - min(xs)) / 2 + OVERHANG if c.length is None else c.length / 2
    add_coach_shell(body, "carbody", layout, middle, half_length)


def add_coach_shell(body, name: str, layout: Layout, middle: float, half_length: float) -> None:
    """A car body's geoms, named <name>_*: centred at x = `middle` in `body`, `half_length` long;
    a coach, [carbody]'s width and height when given (a flat wagon's deck when low: FLAT_HEIGHT)."""
    c = layout.carbody
    half_width = CARBODY_HALF_WIDTH if c.width is None else c.width / 2
    # Heights in this body's frame; its origin is CARBODY_HEIGHT above the rail.
    bottom = underframe_bottom(layout) - CARBODY_HEIGHT
    top = ROOF_HEIGHT - CARBODY_HEIGHT if c.height is None else bottom + c.height
    if top - bottom <= FLAT_HEIGHT:
        _box(
            body,
            f"{name}_deck",
            (half_length, half_width, (top - bottom) / 2),
            (middle, 0, (top + bottom) / 2),
            DECK_RGBA,
        )
        return
    floor = bottom + UNDERFRAME_DEPTH
    low, high = WINDOW_BAND
    eaves = top - ROOF_DEPTH
    windows = eaves - floor >= high + WINDOW_HEADROOM and half_length > VESTIBULE + 0.5
    body_rgba, dark = (COACH_RGBA if windows else FREIGHT_RGBA), [0.15, 0.15, 0.17, 1]
    # The underframe a little narrower than the body, so that it reads as a separate band.
    _box(
        body,
        f"{name}_underframe",
        (half_length, max(half_width - 0.1, 0.5 * half_width), UNDERFRAME_DEPTH / 2),
        (middle, 0, bottom + UNDERFRAME_DEPTH / 2),
        dark,
    )
    wall_half_height = (eaves - floor) / 2
    for side, sign in SIDES:
        _box(
            body,
            f"{name}_side_{side}",
            (half_length, WALL / 2, wall_half_height),
            (middle, sign * (half_width - WALL / 2), floor + wall_half_height),
            body_rgba,
        )
        if windows:  # a dark strip just proud of the wall, short of the vestibules at the ends
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
            (WALL / 2, max(half_width - WALL, 0.5 * half_width), wall_half_height),
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
    if layout.profiles is None:
        return f"wheel_r{w.rolling_radius:g}_c{w.conicity:g}.stl"
    from rail_mj.contact.pair import STANDARD_PROFILES

    wheel = layout.profiles.wheel
    name = wheel if wheel in STANDARD_PROFILES["wheel"] else Path(wheel).stem
    return f"wheel_{name}_r{w.rolling_radius:g}.stl"


def add_wheel_mesh(spec: mujoco.MjSpec, layout: Layout) -> None:
    """The wheel's mesh (rail_mj.vehicle.wheel: `wheel_outline` revolved), which every wheel geom
    draws, in `spec.assets`."""
    stl = outline_stl(wheel_outline(layout))
    spec.add_mesh(name="wheel", file=mesh_file(layout))
    spec.assets = {mesh_file(layout): stl}
