"""A peer of rail-mj: the coach on a fixed-step RK4 compiled with numba.

What a user would write instead of rail-mj to run the Manchester coach fast: the
14 planar equations of its 7 bodies with exact nested kinematics (see benchmarks/peers.py
for the derivation), rail-mj's own creep law called from inside the compiled code
(`rail_mj.contact.creep.wheelset_contact`: Polach saturation and flange contact, the same
function rail-mj's MuJoCo callback calls), and the classical RK4 at rail-mj's timestep.
It follows rail-mj's nested model (what rail-mj steps on a track file) to round-off: 1e-18 m
over 1 km at 60 m/s, 4e-16 m hunting on the flanges at 100 m/s, where |y| reaches 15 mm; on
straight track rail-mj steps the coach's flat twin, 5.5e-10 m from it at 60 m/s (docs/trains.md).

    PYTHONPATH=. python benchmarks/peer_numba.py

prints the agreement with `rail_mj.simulate` over 1 km at 60 m/s and a timing table:
one run, and a batch of 64 speeds run at once on every core (`batch`, numba prange).
`time_single` and `time_batch` return (seconds, vehicle-km) for benchmarks/benchmark.py,
`step_time` the CPU time of one step.
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np
from peers import (
    DISTANCE,
    INITIAL_LATERAL,
    SPEED,
    TIMESTEP,
    Coach,
    best,
    coach,
    initial_state,
    max_difference,
    reference,
    table,
    time_rail_mj,
)

from rail_mj.contact.creep import wheelset_contact

BATCH_SPEEDS = (20.0, 100.0)  # m/s: the batch's speeds, evenly spaced
BATCH_RUNS = 64
TAIL = 100.0  # m: a batch run reports its largest wheelset |y| over its last TAIL metres


@numba.njit(cache=True)
def _workspace(parent):
    """The arrays one run's right-hand side works in, allocated once a run (allocating
    in every call would cost more than its algebra), and the tree's bookkeeping:

    chain[i, :slots[i]]  the joints that move body i: its ancestors' (lateral, yaw) from
                         the car body down, then its own; a body's Jacobians are kept
                         over these slots only (the other joints do not move it)
    dof_parent[k]        the joint next above joint k in the tree (-1: none), which
                         shapes the sparse factorisation of M
    theta, p, J, a       each body's absolute yaw, position, dp/dq over its chain's
                         slots, and its acceleration at q'' = 0
    M, Q                 mass matrix (lower triangle) and generalised forces
    """
    bodies = parent.size
    dofs = 2 * bodies
    chain = np.zeros((bodies, 2 * bodies), dtype=np.int64)
    slots = np.zeros(bodies, dtype=np.int64)
    dof_parent = np.full(dofs, -1, dtype=np.int64)
    for i in range(bodies):
        P = parent[i]
        above = 0 if P < 0 else slots[P]
        chain[i, :above] = chain[P, :above]
        chain[i, above], chain[i, above + 1] = 2 * i, 2 * i + 1
        slots[i] = above + 2
        dof_parent[2 * i] = -1 if P < 0 else 2 * P + 1  # a body's slide hangs from its parent's hinge
        dof_parent[2 * i + 1] = 2 * i  # its hinge from its own slide
    return (
        chain,
        slots,
        dof_parent,
        np.zeros(bodies),
        np.zeros((bodies, 2)),
        np.zeros((bodies, 2, 2 * bodies)),
        np.zeros((bodies, 2)),
        np.zeros((dofs, dofs)),
        np.zeros(dofs),
    )


@numba.njit(cache=True)
def _kinematics(parent, offset, chain, slots, q, v, theta, p, J, a):
    """Each body's absolute yaw theta, position p, Jacobian J = dp/dq over its chain and
    a = J' q', its acceleration when q'' = 0; parents come before their children.
    dtheta/dq is 1 on the chain's yaw slots (odd), 0 on its slides (even)."""
    for i in range(parent.size):
        lat, yaw = 2 * i, 2 * i + 1
        P = parent[i]
        above = slots[i] - 2
        theta_p = px = py = ax = ay = w = 0.0  # a child of the world: the world's frame
        if P >= 0:
            theta_p, px, py, ax, ay = theta[P], p[P, 0], p[P, 1], a[P, 0], a[P, 1]
            for c in range(1, above, 2):  # the parent's yaw rate: its chain's hinges
                w += v[chain[i, c]]
        s, co = math.sin(theta_p), math.cos(theta_p)
        ux = offset[i] * co - q[lat] * s  # (offset, q_y) turned into the track frame
        uy = offset[i] * s + q[lat] * co
        theta[i] = theta_p + q[yaw]
        p[i, 0], p[i, 1] = px + ux, py + uy
        for c in range(above):  # the parent's, and every hinge above swings u too
            J[i, 0, c] = J[P, 0, c] - (uy if c % 2 else 0.0)
            J[i, 1, c] = J[P, 1, c] + (ux if c % 2 else 0.0)
        J[i, 0, above], J[i, 1, above] = -s, co  # the slide runs along the parent's y axis
        J[i, 0, above + 1] = J[i, 1, above + 1] = 0.0  # the own hinge turns it about its centre
        # Centripetal -w^2 u and Coriolis 2 w q_y' (the parent's y axis turned a quarter more).
        a[i, 0] = ax - w * w * ux - 2.0 * w * v[lat] * co
        a[i, 1] = ay - w * w * uy - 2.0 * w * v[lat] * s


@numba.njit(cache=True)
def _solve_tree(M, dof_parent, x):
    """Solve M x = b in place (b given in x) for the mass matrix of a tree of joints: the
    L^T D L factorisation in reverse order has no fill-in, so each row only meets the
    joints above it (Featherstone, Rigid Body Dynamics Algorithms, 2008, sec. 6.5: what
    MuJoCo does too). M's lower triangle is overwritten with L and D."""
    n = x.size
    for k in range(n - 1, -1, -1):
        i = dof_parent[k]
        while i >= 0:
            factor = M[k, i] / M[k, k]
            j = i
            while j >= 0:
                M[i, j] -= M[k, j] * factor
                j = dof_parent[j]
            M[k, i] = factor
            i = dof_parent[i]
    for k in range(n - 1, -1, -1):  # L^T z = b
        i = dof_parent[k]
        while i >= 0:
            x[i] -= M[k, i] * x[k]
            i = dof_parent[i]
    for k in range(n):  # D
        x[k] /= M[k, k]
    for k in range(n):  # L x = z, parents first
        i = dof_parent[k]
        while i >= 0:
            x[k] -= M[k, i] * x[i]
            i = dof_parent[i]


@numba.njit(cache=True)
def _accelerations(vehicle, speed, q, v, work, qacc):
    """q'' of the coach at (q, q') into qacc: M(q) q'' = Q - sum m J^T a."""
    parent, offset, mass, izz, stiffness, damping, wheelsets, contact, law, flange, falling = vehicle
    chain, slots, dof_parent, theta, p, J, a, M, Q = work
    _kinematics(parent, offset, chain, slots, q, v, theta, p, J, a)
    for k in range(q.size):  # the suspension: springs and dampers on the joints themselves
        Q[k] = -stiffness[k] * q[k] - damping[k] * v[k]
    for w in range(wheelsets.size):  # the rails on each wheelset, from rail-mj's law
        i = wheelsets[w]
        y_dot = psi_dot = 0.0
        for c in range(slots[i]):
            y_dot += J[i, 1, c] * v[chain[i, c]]
            if c % 2:
                psi_dot += v[chain[i, c]]
        f = wheelset_contact(contact[:, w], law, flange, falling, p[i, 1], theta[i], y_dot, psi_dot, speed)
        fy, mz = f[0] + f[1], f[2] + f[3] + f[4]
        for c in range(slots[i]):
            Q[chain[i, c]] += J[i, 1, c] * fy + (mz if c % 2 else 0.0)
    # M = sum m J^T J + I G^T G and the velocity-product forces -m J^T a, body by body over
    # its chain; ancestors' joints come first, so M[chain[c], chain[b <= c]] is the lower triangle.
    M[:, :] = 0.0
    for i in range(parent.size):
        for c in range(slots[i]):
            k = chain[i, c]
            Q[k] -= mass[i] * (J[i, 0, c] * a[i, 0] + J[i, 1, c] * a[i, 1])
            for b in range(c + 1):
                M[k, chain[i, b]] += mass[i] * (J[i, 0, c] * J[i, 0, b] + J[i, 1, c] * J[i, 1, b]) + (
                    izz[i] if c % 2 and b % 2 else 0.0
                )
    qacc[:] = Q
    _solve_tree(M, dof_parent, qacc)


@numba.njit(cache=True)
def _run(vehicle, speed, state, dt, steps, every, ys, psis):
    """RK4 (the classical one, as MuJoCo's) from `state` (q, q', changed in place) for
    `steps` steps of dt, a multiple of `every`; every `every` steps, from step 0 to the
    last, the wheelsets' y and psi into the next row of ys, psis."""
    n = state.size // 2
    work = _workspace(vehicle[0])
    q, v = state[:n], state[n:]
    k1, k2, k3, k4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    q2, q3, q4, v2, v3, v4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    wheelsets = vehicle[6]
    chain, slots, theta, p, J, a = work[0], work[1], work[3], work[4], work[5], work[6]
    h = dt
    for step in range(steps):
        _accelerations(vehicle, speed, q, v, work, k1)
        if step % every == 0:  # the first stage's kinematics are the step's start
            row = step // every
            for w in range(wheelsets.size):
                ys[row, w] = p[wheelsets[w], 1]
                psis[row, w] = theta[wheelsets[w]]
        for k in range(n):
            q2[k] = q[k] + 0.5 * h * v[k]
            v2[k] = v[k] + 0.5 * h * k1[k]
        _accelerations(vehicle, speed, q2, v2, work, k2)
        for k in range(n):
            q3[k] = q[k] + 0.5 * h * v2[k]
            v3[k] = v[k] + 0.5 * h * k2[k]
        _accelerations(vehicle, speed, q3, v3, work, k3)
        for k in range(n):
            q4[k] = q[k] + h * v3[k]
            v4[k] = v[k] + h * k3[k]
        _accelerations(vehicle, speed, q4, v4, work, k4)
        for k in range(n):
            q[k] += h / 6.0 * (v[k] + 2.0 * v2[k] + 2.0 * v3[k] + v4[k])
            v[k] += h / 6.0 * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k])
    _kinematics(vehicle[0], vehicle[1], chain, slots, q, v, theta, p, J, a)  # the last sample
    for w in range(wheelsets.size):
        ys[steps // every, w] = p[wheelsets[w], 1]
        psis[steps // every, w] = theta[wheelsets[w]]


def _arrays(vehicle: Coach) -> tuple:
    """The vehicle as the tuple the compiled functions take."""
    return (
        vehicle.parent,
        vehicle.offset,
        vehicle.mass,
        vehicle.yaw_inertia,
        vehicle.stiffness,
        vehicle.damping,
        vehicle.wheelsets,
        np.ascontiguousarray(vehicle.contact),
        vehicle.law,
        vehicle.flange,
        vehicle.falling,
    )


def simulate(
    vehicle: Coach, speed: float, distance: float, initial_lateral: float, dt: float = TIMESTEP, every: int = 1
):
    """One run: (t, y, psi), the wheelsets' absolute lateral displacement (m) and yaw
    (rad), sampled every `every` steps as rail-mj samples (its last sample at or past
    `distance`)."""
    steps = math.ceil(distance / speed / dt)
    samples = -(-steps // every) + 1
    steps = (samples - 1) * every
    ys, psis = np.zeros((samples, vehicle.wheelsets.size)), np.zeros((samples, vehicle.wheelsets.size))
    state = initial_state(vehicle, initial_lateral)
    _run(_arrays(vehicle), float(speed), state, dt, steps, every, ys, psis)
    return np.arange(samples) * (every * dt), ys, psis


@numba.njit(cache=True, parallel=True)
def _batch(vehicle, speeds, distance, initial_lateral, dt, tail, amplitude, final):
    for r in numba.prange(speeds.size):
        speed = speeds[r]
        steps = math.ceil(distance / speed / dt)
        wheelsets = vehicle[6].size
        ys = np.zeros((steps + 1, wheelsets))  # every step: 1 km at 20 m/s is 1.6 MB
        psis = np.zeros((steps + 1, wheelsets))
        state = final[r]
        state[:] = 0.0
        state[0] = initial_lateral
        _run(vehicle, speed, state, dt, steps, 1, ys, psis)
        last = max(0, steps + 1 - int(tail / speed / dt))
        amplitude[r] = np.max(np.abs(ys[last:]))


def batch(
    vehicle: Coach,
    speeds: np.ndarray,
    distance: float = DISTANCE,
    initial_lateral: float = INITIAL_LATERAL,
    dt: float = TIMESTEP,
    tail: float = TAIL,
):
    """Many runs at once, one speed each, spread over every core (numba prange):
    (amplitude, final), each run's largest wheelset |y| over its last `tail` metres (m)
    and its final state (q, q'). What a speed sweep keeps (a bifurcation diagram plots
    the amplitude); `simulate` gives whole trajectories."""
    speeds = np.ascontiguousarray(speeds, dtype=np.float64)
    amplitude = np.zeros(speeds.size)
    final = np.zeros((speeds.size, 2 * vehicle.dofs))
    _batch(_arrays(vehicle), speeds, float(distance), float(initial_lateral), float(dt), float(tail), amplitude, final)
    return amplitude, final


def threads() -> int:
    return numba.get_num_threads()


def agreement(
    run=None, speed: float = SPEED, distance: float = DISTANCE, initial_lateral: float = INITIAL_LATERAL
) -> float:
    """max |y_peer - y_rail_mj| (m) over the samples of rail-mj's run of the coach in its
    nested model, the peer's equations (made here unless given: `run` must be
    `peers.reference(speed, distance, initial_lateral, nested=True)`, or without `nested` to
    measure the flat twin rail-mj steps on straight track), at its timestep."""
    run = run or reference(speed, distance, initial_lateral, nested=True)
    every = max(1, round((run.t[1] - run.t[0]) / run.timestep))
    t, y, _ = simulate(coach(), speed, distance, initial_lateral, run.timestep, every)
    return max_difference(run, t, y)


def time_single(speed: float = SPEED, distance: float = DISTANCE, repeats: int = 3) -> tuple[float, float]:
    """(seconds, vehicle-km) of one run, compilation excluded (a short run first)."""
    vehicle = coach()
    simulate(vehicle, speed, 1.0, INITIAL_LATERAL)
    return best(lambda: simulate(vehicle, speed, distance, INITIAL_LATERAL), repeats), distance / 1000.0


def time_batch(
    runs: int = BATCH_RUNS,
    speeds: tuple[float, float] = BATCH_SPEEDS,
    distance: float = DISTANCE,
    repeats: int = 2,
    balanced: bool = False,
) -> tuple[float, float]:
    """(seconds, vehicle-km) of `runs` runs at speeds evenly from speeds[0] to speeds[1],
    each `distance` long, on every core; compilation excluded.

    As a user writes it the speeds go in in order, and numba's prange gives each thread an
    equal block of them: on two threads, one gets the 32 slowest runs, 2.2 times the other's
    work. `balanced` deals the speeds out in turn instead (thread i gets speeds i, i + T,
    ...), so that each thread's share of the work is nearly equal."""
    vehicle = coach()
    grid = np.linspace(*speeds, runs)
    if balanced:
        grid = np.concatenate([grid[i :: threads()] for i in range(threads())])
    batch(vehicle, grid[: threads()], 1.0)
    return best(lambda: batch(vehicle, grid, distance), repeats), runs * distance / 1000.0


def step_time(speed: float = SPEED, steps: int = 5000, repeats: int = 5) -> float:
    """CPU seconds of one RK4 step of the coach (the calling thread's time, best of
    `repeats` runs of `steps` steps from the 2 mm start)."""
    vehicle = coach()
    arrays = _arrays(vehicle)
    ys, psis = np.zeros((steps + 1, vehicle.wheelsets.size)), np.zeros((steps + 1, vehicle.wheelsets.size))
    _run(arrays, speed, initial_state(vehicle, INITIAL_LATERAL), TIMESTEP, 1, 1, ys[:2], psis[:2])
    times = []
    for _ in range(repeats):
        state = initial_state(vehicle, INITIAL_LATERAL)
        started = time.thread_time()
        _run(arrays, speed, state, TIMESTEP, steps, 1, ys, psis)
        times.append((time.thread_time() - started) / steps)
    return min(times)


def main() -> None:
    run = reference()
    print(
        f"max |y - y_rail_mj| over {DISTANCE:g} m at {SPEED:g} m/s: {agreement(run):.3g} m "
        f"(timestep {run.timestep:g} s)"
    )
    print()
    print(
        table(
            [
                (f"rail_mj.simulate, {DISTANCE / 1000:g} km at {SPEED:g} m/s", *time_rail_mj()),
                (f"numba RK4, {DISTANCE / 1000:g} km at {SPEED:g} m/s", *time_single()),
                (
                    f"numba RK4 batch: {BATCH_RUNS} speeds {BATCH_SPEEDS[0]:g}-{BATCH_SPEEDS[1]:g} m/s, "
                    f"{DISTANCE / 1000:g} km each, {threads()} threads",
                    *time_batch(),
                ),
            ]
        )
    )


if __name__ == "__main__":
    main()
