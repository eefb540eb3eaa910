"""A spatial vehicle built flat (docs/spatial.md): car bodies and bogie frames with lateral, yaw,
vertical, roll and pitch joints, wheelsets with lateral and yaw, each spring-damper element
fixed tendons at its place (its linearised deflections along x, y, z), the secondary dampers,
anti-roll bars and bump stops; a spatial train's car bodies and couplings too (docs/trains.md).
"""

from __future__ import annotations

import dataclasses

import mujoco

from rail_mj.layout import Layout
from rail_mj.layout.kinds import SpatialVehicle, vehicle_kind
from rail_mj.layout.reader import Spatial
from rail_mj.units import SIDES
from rail_mj.vehicle.joints import (
    LATERAL,
    PITCH,
    ROLL,
    SPATIAL_BODY,
    SPATIAL_WHEELSET,
    VERTICAL,
    YAW,
    _add_spatial_joints,
    _set_inertia,
)
from rail_mj.vehicle.looks import END_GAP, add_carbody_shell, add_coach_shell, side_frame_heights
from rail_mj.vehicle.planar import add_wheelset
from rail_mj.vehicle.rounding import _g6, _pos
from rail_mj.vehicle.train import _coupling_tendons, _tendon, add_flat_bogie

AXES = "xyz"  # a spring's tendons <name>_x, <name>_y, <name>_z


def point_motion(body: str, r, joints) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """The displacement (x, y, z) of the point at `r` = (rx, ry, rz) from `body`'s centre of mass,
    linear in the body's joint coordinates (docs/spatial.md): the translation plus w x r for the
    small rotation w = (roll, pitch, yaw). `joints`: the motions the body has; each component a
    {joint name: coefficient}."""
    rx, ry, rz = r
    ux = {PITCH: rz, YAW: -ry}
    uy = {LATERAL: 1.0, YAW: rx, ROLL: -rz}
    uz = {VERTICAL: 1.0, ROLL: ry, PITCH: -rx}
    x, y, z = ({f"{body}_{m}": c for m, c in u.items() if m in joints and c != 0.0} for u in (ux, uy, uz))
    return x, y, z


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


def deflections(
    point, lower: tuple[str, tuple, tuple], upper: tuple[str, tuple, tuple]
) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
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
    x, y, z = out
    return x, y, z


def secondary_elements(
    spec,
    bogie: str,
    x: float,
    frame: tuple[str, tuple, tuple],
    carbody: tuple[str, tuple, tuple],
    sp: Spatial,
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
        stop = sp.bump_stop
        lateral = deflections((x, 0.0, stop.height), frame, carbody)[1]
        # The piecewise-linear table as a sum of deadband springs: MuJoCo's tendon spring is idle
        # within springlength [lo, hi] and linear outside, so each breakpoint's spring adds its
        # rise of slope from there on (BumpStop.deadbands).
        for i, (play, k) in enumerate(stop.deadbands(), start=1):
            tendon = _tendon(spec, f"{name}_bump_stop_{i}", lateral, share * k, 0.0)
            if tendon is not None:
                tendon.springlength = _g6(-play, play)


def spatial_carbodies(vehicle: SpatialVehicle) -> list[tuple[str, tuple, tuple]]:
    """A spatial vehicle's car bodies as (name, centre (x, 0, height), joints): its one `carbody`, or
    a spatial train's carbody1, carbody2, ... each at its own x and height (docs/trains.md)."""
    if vehicle.train is None:
        return [("carbody", (0.0, 0.0, vehicle.spatial.carbody_height), SPATIAL_BODY)]
    return [
        (f"carbody{k}", (car.position, 0.0, car.height), SPATIAL_BODY)
        for k, car in enumerate(vehicle.train.cars, start=1)
    ]


def carried(vehicle: SpatialVehicle, bogie: int) -> list[tuple[tuple[str, tuple, tuple], float]]:
    """The car bodies bogie `bogie` (1-based) carries, each with its share of the secondary
    elements: the one car body's whole, or on a Jacobs bogie half to each of the two (as add_train)."""
    bodies = spatial_carbodies(vehicle)
    if vehicle.train is None:
        return [(bodies[0], 1.0)]
    on = vehicle.train.cars_on(bogie)
    return [(bodies[k - 1], 1.0 / len(on)) for k in on]


def spatial_vehicle(layout: Layout) -> SpatialVehicle:
    """`layout`'s spatial vehicle; a ValueError for any other kind."""
    vehicle = vehicle_kind(layout)
    if not isinstance(vehicle, SpatialVehicle):
        raise ValueError(f"{layout.source}: not a spatial vehicle (no [spatial])")
    return vehicle


def _shared(spring, share: float):
    """`spring` (a Spring) with its stiffness and damping times `share` (itself when 1)."""
    if share == 1.0:
        return spring
    return dataclasses.replace(spring, **{f"{k}{a}": share * getattr(spring, f"{k}{a}") for k in "kc" for a in AXES})


def add_spatial(spec: mujoco.MjSpec, vehicle: SpatialVehicle) -> None:
    """A spatial vehicle (layout.spatial; docs/spatial.md), built flat: the car body and bogie
    frames children of the world with lateral, yaw, vertical, roll and pitch joints at their centres
    of mass, the wheelsets with lateral and yaw; each spring-damper element one fixed tendon per
    direction (x, y, z), its length the element's linearised deflection. Tendons are named
    <lower>_<upper>_<side>_<axis>, e.g. wheelset1_bogie1_left_z. A spatial train (docs/trains.md):
    car bodies carbody1, ... each at its place and height, a Jacobs bogie carrying half of each
    secondary element under each of its two bodies, the couplings as add_train's."""
    layout, sp, world = vehicle.layout, vehicle.spatial, spec.worldbody
    hb, r0 = sp.bogie_height, layout.wheelset.rolling_radius
    train = vehicle.train
    couples = sp.gravity and sp.gravitational_stiffness  # rail_mj.vehicle.loads.ShearCouples
    for k, (name, (x, _, h), _) in enumerate(spatial_carbodies(vehicle)):
        body = world.add_body(name=name, pos=[0, 0, _g6(h)[0]] if train is None else _pos(x, h))
        if train is None:
            assert layout.carbody.mass is not None and layout.carbody.inertia is not None  # free: the reader's rule
            _set_inertia(body, layout.carbody.mass, layout.carbody.inertia)
            _add_spatial_joints(body)
            add_carbody_shell(body, vehicle)
        else:
            car = train.cars[k]
            _set_inertia(body, car.mass, car.inertia)
            _add_spatial_joints(body)
            add_coach_shell(body, name, layout, 0.0, car.length / 2 - END_GAP)
    spring_top = side_frame_heights(layout)[0]
    n = vehicle.bogies.wheelsets_per_bogie
    for i, (xb, design) in enumerate(zip(vehicle.bogies.positions, sp.bogies), start=1):
        name = f"bogie{i}"
        add_flat_bogie(world, name, xb, hb, layout, design, spatial=True)
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
        for carbody, share in carried(vehicle, i):
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
        heights = {name: h for name, (_, _, h), _ in spatial_carbodies(vehicle)}
        _coupling_tendons(spec, train, x_of, heights)


def spatial_elements(layout: Layout):
    """The spring-damper elements of a spatial vehicle, as `add_spatial` joins them and in its
    order: (name, point, lower, upper, spring), the arguments `spring_tendons` takes (a Jacobs
    bogie's secondary springs once under each of its two bodies, each with half the spring)."""
    vehicle = spatial_vehicle(layout)
    sp, r0 = vehicle.spatial, layout.wheelset.rolling_radius
    n = vehicle.bogies.wheelsets_per_bogie
    for i, (xb, design) in enumerate(zip(vehicle.bogies.positions, sp.bogies), start=1):
        frame = (f"bogie{i}", (xb, 0.0, sp.bogie_height), SPATIAL_BODY)
        e = design.axlebox
        for j, xw in enumerate(design.wheelset_positions):
            wheelset = (f"wheelset{(i - 1) * n + j + 1}", (xb + xw, 0.0, r0), SPATIAL_WHEELSET)
            for side, sign in SIDES:
                point = (xb + xw, sign * e.spacing, e.height)
                yield f"{wheelset[0]}_{frame[0]}_{side}", point, wheelset, frame, e
        for carbody, share in carried(vehicle, i):
            for side, sign in SIDES:
                point = (xb, sign * sp.secondary.spacing, sp.secondary.height)
                yield f"{frame[0]}_{carbody[0]}_{side}", point, frame, carbody, _shared(sp.secondary, share)
