"""The Manchester coach as the two "peers" see it, and the side-by-side benchmark.

The peers are what a user would write instead of rail-mj, for the same vehicle and
the same creep law:

    benchmarks/peer_solve_ivp.py   scipy's solve_ivp (RK45, DOP853) on a numpy right-hand side
    benchmarks/peer_numba.py       a fixed-step RK4 compiled with numba, one run and a batch

This module holds what both share: the coach's numbers (`coach`), rail-mj's own run to
compare with (`reference`), the timing of rail-mj (`time_rail_mj`) and the small helpers
that print the tables. Run it to measure everything side by side in one process:

    PYTHONPATH=. python benchmarks/peers.py

The equations (peer_numba writes them body by body, peer_solve_ivp all bodies at once)
-------------------------------------------------------------------------------------
The bodies are nested as in rail-mj's MuJoCo model: world -> car body -> bogie frame ->
wheelset, each with a lateral slide and a yaw hinge relative to its parent. The
generalised coordinates q are those joints: 14 of them, (lateral, yaw) per body in
MuJoCo's order (car body, bogie 1, wheelsets 1 and 2, bogie 2, wheelsets 3 and 4).
The kinematics are exact, as MuJoCo's: a body whose parent sits at p_P with absolute
yaw theta_P hangs at the offset (x, q_y) in the parent's yawed frame,

    p = p_P + R(theta_P) (x, q_y),      theta = theta_P + q_psi,

so its Jacobians (dp/dq, dtheta/dq) are its parent's plus the parent's yaw swinging
u = R(theta_P) (x, q_y) about the parent, plus its own slide along the parent's y axis.
Lagrange's equations with T = sum(m |p'|^2 + I theta'^2)/2 give

    M(q) q'' = Q - sum_i m_i J_i^T a_i,     M(q) = sum_i m_i J_i^T J_i + I_i G_i^T G_i,

J_i = dp_i/dq, G_i = dtheta_i/dq, and a_i = J_i' q' the acceleration body i has at q'' = 0
(centripetal and Coriolis: a_i = a_P - w_P^2 u + 2 w_P q_y' R(theta_P)(-1, 0), w_P the
parent's yaw rate). The joint springs and dampers act on the joint coordinates
themselves (Q = -k q - c q'), and the rails' force Fy and moment Mz on a wheelset enter as
J_y^T Fy + G^T Mz, J_y the row of its lateral position: all exactly as MuJoCo does it.
"""

from __future__ import annotations

import dataclasses
import timeit
from pathlib import Path

import numpy as np

from rail_mj.layout import load_layout
from rail_mj.simulation.callback import contact_parameters
from rail_mj.simulation.run import Run
from rail_mj.simulation.runner import simulate
from rail_mj.track import Track
from rail_mj.vehicle.spec import Vehicle

COACH = Path(__file__).resolve().parent.parent / "models" / "manchester-coach" / "manchester-coach.toml"

# The comparison run: 1 km at 60 m/s from the whole vehicle shifted 2 mm.
SPEED = 60.0  # m/s
DISTANCE = 1000.0  # m
INITIAL_LATERAL = 0.002  # m
TIMESTEP = 1e-3  # s: rail-mj's for the coach from 20 to 140 m/s (its MAX_TIMESTEP), and its sampling


@dataclasses.dataclass(frozen=True)
class Coach:
    """The vehicle as arrays: bodies in MuJoCo's order (parents before children), their
    joints two a body (lateral, then yaw), and the contact data of the wheelsets."""

    names: tuple[str, ...]
    parent: np.ndarray  # (bodies,) index of the parent body, -1 for the car body (the world's child)
    offset: np.ndarray  # (bodies,) x of the body's centre in its parent's frame, m
    mass: np.ndarray  # (bodies,) kg
    yaw_inertia: np.ndarray  # (bodies,) Izz, kg m^2
    stiffness: np.ndarray  # (2*bodies,) of each joint: N/m (lateral), N m/rad (yaw)
    damping: np.ndarray  # (2*bodies,) N s/m, N m s/rad
    wheelsets: np.ndarray  # (4,) the wheelsets' body indices, wheelset 1 first
    contact: np.ndarray  # (ROWS, 4) rail_mj.contact.creep.ContactParameters.table: one column a wheelset
    law: int  # rail_mj.contact.creep's law number (POLACH for the coach)
    flange: bool  # flange contact on
    falling: bool  # Polach's falling friction on

    @property
    def dofs(self) -> int:
        return 2 * len(self.names)


def coach(path: Path = COACH) -> Coach:
    """The coach's numbers: the mechanics from its layout file, the contact data from
    rail-mj's compiled model (`contact_parameters`): the friction limit and flange slope
    are rounded to 6 significant figures there, so both sides use the same numbers."""
    layout = load_layout(path)
    car, bogie, wheelset = layout.carbody, layout.bogie, layout.wheelset
    if car.fixed or bogie is None:
        raise ValueError("the peers model a free car body on bogies, as the coach")
    names, rows = ["carbody"], [(-1, 0.0, car.mass, car.inertia[2], (0.0, 0.0, 0.0, 0.0))]

    def joints(s):  # (k_lateral, k_yaw, c_lateral, c_yaw) of a suspension
        return s.lateral_stiffness, s.yaw_stiffness, s.lateral_damping, s.yaw_damping

    wheelsets = []
    for k, xb in enumerate(car.bogie_positions):
        names.append(f"bogie{k + 1}")
        index = len(rows)
        rows.append((0, xb, bogie.mass, bogie.inertia[2], joints(layout.secondary)))
        for xw in bogie.wheelset_positions:
            names.append(f"wheelset{len(wheelsets) + 1}")
            wheelsets.append(len(rows))
            rows.append((index, xw, wheelset.mass, wheelset.inertia[2], joints(layout.primary)))
    parent, offset, mass, izz, springs = zip(*rows)
    springs = np.array(springs)
    params = contact_parameters(Vehicle(layout).model, len(wheelsets))
    return Coach(
        names=tuple(names),
        parent=np.array(parent, dtype=np.int64),
        offset=np.array(offset),
        mass=np.array(mass),
        yaw_inertia=np.array(izz),
        stiffness=springs[:, :2].reshape(-1),
        damping=springs[:, 2:].reshape(-1),
        wheelsets=np.array(wheelsets, dtype=np.int64),
        contact=params.table.copy(),
        law=params.law,
        flange=params.flange,
        falling=params.falling,
    )


def initial_state(vehicle: Coach, initial_lateral: float) -> np.ndarray:
    """(q, q'): rail-mj's start, the car body's slide (so the whole vehicle) shifted."""
    state = np.zeros(2 * vehicle.dofs)
    state[0] = initial_lateral
    return state


def reference(
    speed: float = SPEED,
    distance: float = DISTANCE,
    initial_lateral: float = INITIAL_LATERAL,
    path: Path = COACH,
    nested: bool = False,
) -> Run:
    """rail-mj's run of the coach: what the peers are compared with. On straight track rail-mj
    steps the coach's flat twin (rail_mj.vehicle.spec.Vehicle.stepped); `nested`: its own
    nested model, the peers' equations, which it steps on a track file (a straight one here)."""
    track = Track.straight(distance + 100.0) if nested else None
    return simulate(load_layout(path), speed, distance, initial_lateral, track=track)


def best(fn, repeats: int) -> float:
    """The shortest wall time of `repeats` calls of fn(), s: on a shared machine the
    least disturbed one."""
    return min(timeit.repeat(fn, number=1, repeat=repeats))


def time_rail_mj(
    speed: float = SPEED, distance: float = DISTANCE, repeats: int = 3, path: Path = COACH
) -> tuple[float, float]:
    """(seconds, vehicle-km) of `rail_mj.simulate` on the coach: the whole call, as a user
    makes it (building the model and choosing the timestep included)."""
    coach_layout = load_layout(path)
    simulate(coach_layout, speed, 10.0, INITIAL_LATERAL)  # compiles and loads what a first run needs
    return best(lambda: simulate(coach_layout, speed, distance, INITIAL_LATERAL), repeats), distance / 1000.0


def table(rows: list[tuple[str, float, float]]) -> str:
    """A Markdown table of (what, seconds, vehicle-km) rows, with seconds per vehicle-km
    and the ratio to the first row."""
    lines = ["| run (coach, 14 dof) | wall time | s per vehicle-km | vs first row |", "|---|---|---|---|"]
    base = rows[0][1] / rows[0][2]
    for what, seconds, km in rows:
        per_km = seconds / km
        lines.append(f"| {what} | {seconds:.3g} s for {km:g} km | {per_km:.3g} | {per_km / base:.3g}x |")
    return "\n".join(lines)


def max_difference(run: Run, t: np.ndarray, y: np.ndarray) -> float:
    """Largest |y_peer - y_rail_mj| over the run's samples and wheelsets, m. `t` must be
    the run's sample times (checked) and `y` of shape (samples, wheelsets)."""
    if len(t) != len(run.t) or not np.allclose(t, run.t, rtol=0, atol=1e-9):
        raise ValueError("the peer's samples are not at rail-mj's times")
    return float(np.max(np.abs(y - run.y)))


def main() -> None:
    """Every run of the brief side by side: rail-mj, solve_ivp (RK45, DOP853), the numba
    peer alone and a batch of 64 speeds on all cores; then each peer's agreement."""
    import peer_numba
    import peer_solve_ivp

    rows = [("rail_mj.simulate, 1 km at 60 m/s", *time_rail_mj())]
    for method in peer_solve_ivp.METHODS:
        rows.append((f"solve_ivp {method} (numpy), 1 km at 60 m/s", *peer_solve_ivp.time_run(method)))
    rows.append(("numba RK4, 1 km at 60 m/s", *peer_numba.time_single()))
    rows.append(
        (f"numba RK4 batch: 64 speeds 20-100 m/s, 1 km each, {peer_numba.threads()} threads", *peer_numba.time_batch())
    )
    print(table(rows))
    print()
    run = reference()
    print(f"max |y - y_rail_mj| over 1 km at 60 m/s (rail-mj timestep {run.timestep:g} s):")
    for method in peer_solve_ivp.METHODS:
        print(f"- solve_ivp {method}: {peer_solve_ivp.agreement(run, method):.3g} m")
    print(f"- numba RK4: {peer_numba.agreement(run):.3g} m")


if __name__ == "__main__":
    main()
