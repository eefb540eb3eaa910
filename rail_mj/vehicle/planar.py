"""The planar vehicle: car body, bogie frames and wheelsets, their joints nested as the suspension is.

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

`rail_mj.vehicle.train.add_flat_carbody` builds the same vehicle flat, for stepping (docs/trains.md): every
body a child of the world on absolute joints, each suspension a pair of fixed tendons whose
lengths are those linearised deflections (as a train's, rail_mj.vehicle.train). Its mass
matrix is diagonal where the nested one couples every body to the joints above it; the two
forms differ by the second-order kinematics the flat one leaves out.

Example:

    >>> from rail_mj.layout import load_layout
    >>> from rail_mj.vehicle import Vehicle
    >>> vehicle = Vehicle(load_layout("models/bogie/bogie.toml"))
    >>> vehicle.wheelset_names
    ('wheelset1', 'wheelset2')
    >>> vehicle.model.nv   # bogie frame and two wheelsets, lateral and yaw each
    6
"""

from __future__ import annotations

from rail_mj.layout import Layout
from rail_mj.layout.kinds import Bogies, Planar
from rail_mj.vehicle.joints import _add_planar_joints, _set_inertia
from rail_mj.vehicle.looks import (
    BOGIE_HEIGHT,
    CARBODY_HEIGHT,
    add_bogie_frame,
    add_carbody_shell,
    add_wheelset_geoms,
    side_frame_heights,
    underframe_bottom,
)
from rail_mj.vehicle.rounding import _pos


def add_wheelset(parent, name: str, x: float, z: float, layout: Layout, spring_top: float, nested: bool = True) -> None:
    """A wheelset hanging from `parent` at (x, z) in its frame, on the primary suspension,
    with its axleboxes and the primary springs up to `spring_top` (above the rail).
    `nested=False` (a train): free joints in the world, the suspension a tendon."""
    w = layout.wheelset
    body = parent.add_body(name=name, pos=_pos(x, z))
    _set_inertia(body, w.mass, w.inertia)
    _add_planar_joints(body, layout.primary if nested else None)
    add_wheelset_geoms(body, name, layout, spring_top)


def add_bogie(parent, name: str, x: float, z: float, layout: Layout, bogies: Bogies, first_wheelset: int) -> None:
    """A bogie frame at (x, z) in the car body, on the secondary suspension, with its wheelsets.

    Drawn as an outside-frame bogie: two side frames over the axleboxes, joined by a
    transom between each pair of wheelsets, carrying the secondary springs.
    """
    bogie = bogies.bogie
    body = parent.add_body(name=name, pos=_pos(x, z))
    _set_inertia(body, bogie.mass, bogie.inertia)
    _add_planar_joints(body, bogies.secondary)
    add_bogie_frame(body, name, layout, bogie.wheelset_positions)
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


def add_carbody_body(worldbody, vehicle: Planar):
    """The car body alone, on the world (no joints when fixed: held over the centreline), drawn."""
    c = vehicle.layout.carbody
    body = worldbody.add_body(name="carbody", pos=[0, 0, CARBODY_HEIGHT])
    if not c.fixed:
        assert c.mass is not None and c.inertia is not None  # the reader requires both of a free body
        _set_inertia(body, c.mass, c.inertia)
        _add_planar_joints(body, None)
    add_carbody_shell(body, vehicle)
    return body


def add_carbody(worldbody, vehicle: Planar) -> None:
    """The car body (held over the centreline when fixed) with everything under it."""
    layout = vehicle.layout
    body = add_carbody_body(worldbody, vehicle)
    if vehicle.bogies is not None:
        n = vehicle.bogies.wheelsets_per_bogie
        for k, x in enumerate(vehicle.bogies.positions):
            add_bogie(body, f"bogie{k + 1}", x, BOGIE_HEIGHT - CARBODY_HEIGHT, layout, vehicle.bogies, k * n + 1)
    else:
        for i, x in enumerate(vehicle.hung_wheelsets):
            add_wheelset(
                body,
                f"wheelset{i + 1}",
                x,
                layout.wheelset.rolling_radius - CARBODY_HEIGHT,
                layout,
                spring_top=underframe_bottom(layout),
            )
