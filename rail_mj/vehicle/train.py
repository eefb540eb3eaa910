"""A train built flat (docs/trains.md): every body a child of the world with absolute lateral
and yaw joints, each suspension and coupling a pair of fixed tendons on them; its bogie frames,
tendons and couplings serve the spatial vehicle, also built flat, as well, and the planar
vehicle's flat twin (`add_flat_carbody`), which steps it on straight track.
"""

from __future__ import annotations

import mujoco

from rail_mj.layout import Layout, Suspension
from rail_mj.layout.kinds import Planar, TrainOfCars
from rail_mj.layout.reader import Bogie, BogieDesign
from rail_mj.vehicle.joints import LATERAL, ROLL, YAW, _add_planar_joints, _add_spatial_joints, _set_inertia
from rail_mj.vehicle.looks import (
    BOGIE_HEIGHT,
    CARBODY_HEIGHT,
    END_GAP,
    add_bogie_frame,
    add_coach_shell,
    side_frame_heights,
    underframe_bottom,
)
from rail_mj.vehicle.planar import add_carbody_body, add_wheelset
from rail_mj.vehicle.rounding import _g6, _pos


def add_train(spec: mujoco.MjSpec, vehicle: TrainOfCars) -> None:
    """A train (layout.train; docs/trains.md): every car body, bogie frame and wheelset a child of
    the world with its own lateral slide and yaw hinge (absolute coordinates, no spring), and each
    suspension or inter-car element a pair of fixed tendons whose lengths are its lateral and yaw
    deflections, their stiffness and damping the element's. Bodies: carbodyK, bogieK, wheelsetN
    (numbered from the front)."""
    layout, train, bogies, world = vehicle.layout, vehicle.train, vehicle.bogies, spec.worldbody
    x_of: dict[str, float] = {}
    for k, car in enumerate(train.cars, start=1):
        name = f"carbody{k}"
        body = world.add_body(name=name, pos=_pos(car.position, CARBODY_HEIGHT))
        _set_inertia(body, car.mass, car.inertia)
        _add_planar_joints(body, None)
        add_coach_shell(body, name, layout, 0.0, car.length / 2 - END_GAP)
        x_of[name] = car.position
    spring_top = side_frame_heights(layout)[0]
    n = bogies.wheelsets_per_bogie
    for i, xb in enumerate(bogies.positions, start=1):
        name = f"bogie{i}"
        add_flat_bogie(world, name, xb, BOGIE_HEIGHT, layout, bogies.bogie, spatial=False)
        x_of[name] = xb
        for j, xw in enumerate(bogies.bogie.wheelset_positions):
            wheelset = f"wheelset{(i - 1) * n + j + 1}"
            add_wheelset(world, wheelset, xb + xw, layout.wheelset.rolling_radius, layout, spring_top, nested=False)
            x_of[wheelset] = xb + xw
            add_suspension_tendons(spec, wheelset, f"{name}", x_of, layout.primary)
        carried_by = train.cars_on(i)
        for k in carried_by:  # a Jacobs bogie shares [secondary] between its two bodies
            add_suspension_tendons(spec, name, f"carbody{k}", x_of, bogies.secondary, 1.0 / len(carried_by))
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


def add_flat_bogie(
    world, name: str, x: float, height: float, layout: Layout, design: Bogie | BogieDesign, spatial: bool
) -> None:
    """A bogie frame as a child of the world at (x, height): planar (lateral, yaw) or spatial
    joints, with no spring (a train's or a spatial vehicle's; its wheelsets are added apart).
    `design`: its mass, inertia and wheelset_positions ([bogie], or a spatial vehicle's BogieDesign)."""
    body = world.add_body(name=name, pos=_pos(x, height))
    _set_inertia(body, design.mass, design.inertia)
    if spatial:
        _add_spatial_joints(body)
    else:
        _add_planar_joints(body, None)
    add_bogie_frame(body, name, layout, design.wheelset_positions)


def add_suspension_tendons(
    spec,
    child: str,
    parent: str,
    x_of: dict[str, float],
    s: Suspension,
    share: float = 1.0,
    fixed: set[str] | frozenset[str] = frozenset(),
) -> None:
    """The lateral and yaw deflections of `child` hung from `parent` (docs/frames.md),
    d = y_c - y_p - (x_c - x_p)*psi_p and e = psi_c - psi_p, as tendons with `share` of `s`;
    a parent in `fixed` (a fixed car body: no joints) adds no terms."""
    arm = x_of[child] - x_of[parent]
    lateral = {f"{child}_{LATERAL}": 1.0}
    yaw = {f"{child}_{YAW}": 1.0}
    if parent not in fixed:
        lateral |= {f"{parent}_{LATERAL}": -1.0, f"{parent}_{YAW}": -arm}
        yaw[f"{parent}_{YAW}"] = -1.0
    _tendon(spec, f"{child}_{parent}_{LATERAL}", lateral, share * s.lateral_stiffness, share * s.lateral_damping)
    _tendon(spec, f"{child}_{parent}_{YAW}", yaw, share * s.yaw_stiffness, share * s.yaw_damping)


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


def add_flat_carbody(spec, vehicle: Planar) -> None:
    """`add_carbody` built flat: the same bodies, in the same order and at the same places, each
    a child of the world with its own lateral slide and yaw hinge (a fixed car body none), and
    each suspension a pair of fixed tendons on them (rail_mj.vehicle.train)."""
    layout, world = vehicle.layout, spec.worldbody
    add_carbody_body(world, vehicle)
    x_of = {"carbody": 0.0}
    fixed = {"carbody"} if layout.carbody.fixed else set()
    if vehicle.bogies is not None:
        n = vehicle.bogies.wheelsets_per_bogie
        spring_top = side_frame_heights(layout)[0]
        for k, xb in enumerate(vehicle.bogies.positions):
            name = f"bogie{k + 1}"
            add_flat_bogie(world, name, xb, BOGIE_HEIGHT, layout, vehicle.bogies.bogie, spatial=False)
            x_of[name] = xb
            add_suspension_tendons(spec, name, "carbody", x_of, vehicle.bogies.secondary, fixed=fixed)
            for j, xw in enumerate(vehicle.bogies.bogie.wheelset_positions):
                wheelset = f"wheelset{k * n + j + 1}"
                add_wheelset(world, wheelset, xb + xw, layout.wheelset.rolling_radius, layout, spring_top, nested=False)
                x_of[wheelset] = xb + xw
                add_suspension_tendons(spec, wheelset, name, x_of, layout.primary)
    else:
        for i, x in enumerate(vehicle.hung_wheelsets):
            wheelset = f"wheelset{i + 1}"
            add_wheelset(
                world, wheelset, x, layout.wheelset.rolling_radius, layout, underframe_bottom(layout), nested=False
            )
            x_of[wheelset] = x
            add_suspension_tendons(spec, wheelset, "carbody", x_of, layout.primary, fixed=fixed)
