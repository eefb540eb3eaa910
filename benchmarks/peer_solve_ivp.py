"""A peer of rail-mj: the coach integrated by scipy's solve_ivp on a numpy right-hand side.

What a user would write instead of rail-mj with the scientific Python stack alone:
the 14 planar equations of the Manchester coach's 7 bodies with exact nested
kinematics (derived in benchmarks/peers.py), the creep law written out in numpy over the
4 wheelsets (rail-mj's law, transcribed from rail_mj/contact/creep.py: Kalker's linear
forces per wheel, Polach's saturation, flange contact), and an adaptive Runge-Kutta
method (RK45 or DOP853) at tight tolerances.

Over 1 km at 60 m/s it is 1.5e-9 m from rail-mj: that is rail-mj's own error, its RK4
at a 1 ms step (the numba peer, the same RK4, shows the same 1.5e-9 m at 1 ms and is
within 1e-13 m of this peer at 0.05 ms); the equations are the same to round-off
(tests/validation/test_peers.py).

    PYTHONPATH=. python benchmarks/peer_solve_ivp.py

prints the agreement with `rail_mj.simulate` over 1 km at 60 m/s and a timing table.
`time_run(method)` returns (seconds, vehicle-km) for benchmarks/benchmark.py.
"""

from __future__ import annotations

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
from scipy.integrate import solve_ivp

from rail_mj.contact.creep import POLACH

METHODS = ("RK45", "DOP853")
# Tight: 1e-13 m from the converged trajectory at 60 m/s, where rail-mj's RK4 at 1 ms is
# 1.5e-9 m off it. (The stiff creep modes, not the tolerance, set most of the steps.)
RTOL = 1e-10
ATOL = 1e-13  # m, rad and their rates: y is a few mm, the rates a few cm/s


def creep_forces(contact: np.ndarray, law: int, flange: bool, falling: bool, y, psi, y_dot, psi_dot, speed: float):
    """The rails' lateral force Fy (N) and yaw moment Mz (N m) on each wheelset: rail-mj's
    law (docs/creep.md, docs/flange.md) in numpy, arrays over the wheelsets. `contact` is
    rail_mj.contact.creep.ContactParameters.table (one column a wheelset); `falling`: Polach's
    falling friction on."""
    if law != POLACH:
        raise ValueError("this peer writes Polach's law only, the coach's")
    (r0, b, lam, f11, f22, f23, f33, limit, fall_ratio, fall_rate, clearance, k_flange, c_flange, slope, *_ellipse) = (
        contact  # the contact ellipse's rows serve the fastsim law only
    )

    def rise(y):  # a wheel's rolling radius over r0 when the wheelset moves y towards it
        return lam * y + (slope - lam) * np.maximum(y - clearance, 0.0)

    rise_left, rise_right = rise(y), rise(-y)
    # Creepages: longitudinal per wheel, lateral and spin common to both.
    turning = b * psi_dot / speed
    xi_left, xi_right = -turning - rise_left / r0, turning - rise_right / r0
    xi_y, xi_spin = y_dot / speed - psi, psi_dot / speed
    # Kalker, per wheel.
    fx_left, fx_right = -f11 * xi_left, -f11 * xi_right
    fy, mz = -f22 * xi_y - f23 * xi_spin, f23 * xi_y - f33 * xi_spin

    def polach(fx, xi_x):  # the factor bringing a wheel's (Fx, Fy) onto Polach's curve
        mu_n = limit  # mu*N, or with falling friction mu(w)*N at the wheel's slip velocity w
        if falling:
            mu_n = limit * ((1.0 - fall_ratio) * np.exp(-fall_rate * speed * np.hypot(xi_x, xi_y)) + fall_ratio)
        linear = np.hypot(fx, fy)
        eps = np.pi / 4.0 * np.minimum(linear / mu_n, 1e100)
        saturated = 2.0 * mu_n / np.pi * (eps / (1.0 + eps * eps) + np.arctan(eps))
        return np.divide(saturated, linear, out=np.ones_like(linear), where=linear > 0.0)

    scale_left, scale_right = polach(fx_left, xi_left), polach(fx_right, xi_right)
    lateral = (scale_left + scale_right) * fy
    yaw = b * (scale_right * fx_right - scale_left * fx_left) + (scale_left + scale_right) * mz
    if flange:  # the rail under the flange: elastic, pushing only, at the contact's lead
        side = np.sign(y)
        over = np.abs(y) - clearance
        push = -side * np.maximum(k_flange * over + c_flange * side * y_dot, 0.0)
        push = np.where(over > 0.0, push, 0.0)
        lead = side * psi * ((r0 + np.maximum(rise_left, rise_right)) * slope - b)
        lateral = lateral + push
        yaw = yaw + push * lead
    return lateral, yaw


def ancestors(parent: np.ndarray) -> np.ndarray:
    """A[i, j] = 1 when body j is body i or above it in the tree (parent[i]: -1 the world)."""
    A = np.zeros((len(parent), len(parent)))
    for i in range(len(parent)):
        j = i
        while j >= 0:
            A[i, j] = 1.0
            j = parent[j]
    return A


class Equations:
    """The coach's equations of motion, x' = f(t, x) with x = (q, q'), for solve_ivp.

    Written for numpy: every body at once, through the tree's ancestor matrix A
    (A[i, j] = 1 when body j is body i or above it). With u_j = R(theta_P(j)) (x_j, q_y,j)
    the offset of body j from its parent P(j) in the track frame (benchmarks/peers.py), the
    chain of offsets adds up to every position and its derivatives:

        theta_i = sum_j A[i, j] q_psi,j           p_i = sum_j A[i, j] u_j
        dp_i/dq_y,j   = A[i, j] R(theta_P(j)) (0, 1)     (a slide: along its parent's y axis)
        dp_i/dq_psi,j = A[i, j] (p_i - p_j) turned a quarter   (a hinge: about body j's centre)
        a_i = sum_j A[i, j] (-w_P(j)^2 u_j + 2 w_P(j) q_y,j' R(theta_P(j)) (-1, 0))

    w_P the parent's yaw rate: the recursion peer_numba.py writes body by body, unrolled.
    """

    def __init__(self, vehicle: Coach, speed: float):
        self.vehicle, self.speed = vehicle, float(speed)
        self.A = ancestors(vehicle.parent)
        self.G = np.zeros((len(vehicle.parent), vehicle.dofs))  # dtheta/dq: constant, 1 on the hinges of a chain
        self.G[:, 1::2] = self.A
        self.rotary_mass = (self.G.T * vehicle.yaw_inertia) @ self.G  # sum I G^T G: constant too
        self.Gw = self.G[vehicle.wheelsets]

    def kinematics(self, q, v):
        """(theta, omega, p, J, a): every body's absolute yaw and yaw rate, position (2,
        bodies), Jacobian dp/dq (2, bodies, joints) and acceleration at q'' = 0 (2, bodies)."""
        A, offset = self.A, self.vehicle.offset
        q_y, q_psi, v_y, v_psi = q[0::2], q[1::2], v[0::2], v[1::2]
        theta, omega = A @ q_psi, A @ v_psi
        theta_p, omega_p = theta - q_psi, omega - v_psi  # the parents'
        s, c = np.sin(theta_p), np.cos(theta_p)
        u = np.array([offset * c - q_y * s, offset * s + q_y * c])
        p = u @ A.T
        J = np.empty((2, len(offset), self.vehicle.dofs))
        J[0, :, 0::2], J[1, :, 0::2] = -A * s, A * c
        J[0, :, 1::2] = -A * (p[1][:, None] - p[1][None, :])
        J[1, :, 1::2] = A * (p[0][:, None] - p[0][None, :])
        a = (-(omega_p**2) * u - 2.0 * omega_p * v_y * np.array([c, s])) @ A.T
        return theta, omega, p, J, a

    def __call__(self, t, x):
        veh, n = self.vehicle, self.vehicle.dofs
        q, v = x[:n], x[n:]
        theta, omega, p, J, a = self.kinematics(q, v)
        mJ = J * veh.mass[:, None]
        M = J[0].T @ mJ[0] + J[1].T @ mJ[1] + self.rotary_mass
        Q = -veh.stiffness * q - veh.damping * v - (a[0] @ mJ[0] + a[1] @ mJ[1])
        ws = veh.wheelsets
        Jy = J[1, ws]
        fy, mz = creep_forces(
            veh.contact, veh.law, veh.flange, veh.falling, p[1, ws], theta[ws], Jy @ v, omega[ws], self.speed
        )
        Q += fy @ Jy + mz @ self.Gw
        return np.concatenate([v, np.linalg.solve(M, Q)])


def wheelset_y(vehicle: Coach, q: np.ndarray) -> np.ndarray:
    """The wheelsets' absolute lateral displacement (m) for joint positions q (samples, 14)."""
    A = ancestors(vehicle.parent)
    theta_p = q[:, 1::2] @ A.T - q[:, 1::2]  # each body's parent's yaw
    return ((vehicle.offset * np.sin(theta_p) + q[:, 0::2] * np.cos(theta_p)) @ A.T)[:, vehicle.wheelsets]


def simulate(
    vehicle: Coach,
    speed: float,
    t_eval: np.ndarray,
    initial_lateral: float,
    method: str = "RK45",
    rtol: float = RTOL,
    atol: float = ATOL,
):
    """One run sampled at t_eval (s): (y, solution), the wheelsets' absolute lateral
    displacement (samples, 4) and solve_ivp's result."""
    f = Equations(vehicle, speed)
    solution = solve_ivp(
        f,
        (0.0, t_eval[-1]),
        initial_state(vehicle, initial_lateral),
        method=method,
        t_eval=t_eval,
        rtol=rtol,
        atol=atol,
    )
    if not solution.success:
        raise RuntimeError(f"solve_ivp {method} failed: {solution.message}")
    return wheelset_y(vehicle, solution.y[: vehicle.dofs].T), solution


def sample_times(speed: float, distance: float, dt: float = TIMESTEP) -> np.ndarray:
    """rail-mj's sample times for a run: every step of its 1 ms, the last at or past `distance`."""
    return np.arange(int(np.ceil(distance / speed / dt)) + 1) * dt


def agreement(
    run=None,
    method: str = "RK45",
    speed: float = SPEED,
    distance: float = DISTANCE,
    initial_lateral: float = INITIAL_LATERAL,
) -> float:
    """max |y_peer - y_rail_mj| (m) over the samples of rail-mj's run of the coach (made
    here unless given: `run` must be `peers.reference(speed, distance, initial_lateral)`)."""
    run = run or reference(speed, distance, initial_lateral)
    y, _ = simulate(coach(), speed, run.t, initial_lateral, method)
    return max_difference(run, run.t, y)


def time_run(
    method: str = "RK45", speed: float = SPEED, distance: float = DISTANCE, repeats: int = 2
) -> tuple[float, float]:
    """(seconds, vehicle-km) of one run of `distance` m with `method`, sampled as rail-mj samples."""
    vehicle, t = coach(), sample_times(speed, distance)
    return best(lambda: simulate(vehicle, speed, t, INITIAL_LATERAL, method), repeats), distance / 1000.0


def main() -> None:
    run = reference()
    rows = [(f"rail_mj.simulate, {DISTANCE / 1000:g} km at {SPEED:g} m/s", *time_rail_mj())]
    for method in METHODS:
        y, solution = simulate(coach(), SPEED, run.t, INITIAL_LATERAL, method)
        print(
            f"{method} (rtol {RTOL:g}, atol {ATOL:g}): max |y - y_rail_mj| = {max_difference(run, run.t, y):.3g} m "
            f"over {DISTANCE:g} m at {SPEED:g} m/s; {solution.nfev} evaluations"
        )
        rows.append((f"solve_ivp {method}, {DISTANCE / 1000:g} km at {SPEED:g} m/s", *time_run(method)))
    print()
    print(table(rows))


if __name__ == "__main__":
    main()
