"""An independent planar (lateral + yaw) state-space model of a railway vehicle.

Written from the physics notes `docs/creep.md` and `docs/frames.md` only (section
numbers below are those of docs/creep.md),
so that it can check the eigenvalues of the MuJoCo-based model in `rail_mj`. It
imports nothing from `rail_mj` except `rail_mj.layout` (the `Layout` it reads
the numbers from); no MuJoCo, no creep code and no model code is shared.

Coordinates (docs/frames.md)
----------------------------
Every movable body has two coordinates, both absolute in the track frame:
the lateral displacement `y` (positive to the left) and the yaw `psi` (about z,
positive nose-left). The movable bodies are, in this order:

* the car body, unless `layout.carbody.fixed` (then it is the ground: its `y`
  and `psi` are zero and are not states);
* each bogie frame, numbered from the front (bogie 1 leads), if `layout.bogie`;
* each wheelset, numbered globally from the front (wheelset 1 leads, the order
  of `layout.wheelset_x`).

Yaw inertia is `inertia[2]` (Izz) of the body. Names are `"<body>_lateral"` and
`"<body>_yaw"`, e.g. `"carbody_lateral"`, `"bogie1_yaw"`, `"wheelset3_lateral"`.

Equations
---------
The linear equations are `M q'' + C q' + K q = 0`, with `M` diagonal. The
generalised force on the coordinates is `-C q' - K q`, so each force term
`F = -c*q_j' - k*q_j` on coordinate `i` adds `c` to `C[i, j]` and `k` to `K[i, j]`.

*Creep* (section 2, Kalker's linear law summed over the two wheels). With
`xi_y = y'/V - psi` and the spin creepage `psi'/V` (its constant contact-angle
part cancels between the wheels), the rails put on each wheelset

    Fy = -2*f22*(y'/V - psi) - 2*f23*psi'/V
    Mz = -2*f11*b*(b*psi'/V + lam*y/r0) + 2*f23*(y'/V - psi) - 2*f33*psi'/V

With `f23 = f33 = 0` these are exactly the section-2 forces. No gravitational
stiffness, gyroscopic coupling or flange contact: this is the classical case.

*Suspension* (docs/frames.md). A spring-damper set (ky, kpsi, cy, cpsi) between a
child body centred at `x_c` and its parent centred at `x_p` (x measured from
the car-body centre) acts on the lateral deflection and the yaw deflection

    d = y_c - (y_p + (x_c - x_p)*psi_p)        e = psi_c - psi_p

Its potential energy is `ky*d**2/2 + kpsi*e**2/2` and its dissipation function
`cy*d'**2/2 + cpsi*e'**2/2`. Since `d` and `e` are linear in the coordinates,
`d = g_d . q` and `e = g_e . q`, the stiffness matrix gets `ky * g_d g_d^T +
kpsi * g_e g_e^T` and the damping matrix `cy * g_d g_d^T + cpsi * g_e g_e^T`
(both symmetric). Written out, the forces are: child lateral `-ky*d - cy*d'`;
parent lateral `+ky*d + cy*d'`; parent yaw `(x_c - x_p)*(ky*d + cy*d') +
(kpsi*e + cpsi*e')`; child yaw `-(kpsi*e + cpsi*e')`.

Which suspension: a wheelset hangs from its bogie frame through `layout.primary`
if `layout.bogie` is set, otherwise from the car body through `layout.primary`;
each bogie frame hangs from the car body through `layout.secondary`. A free car
body has no spring to the ground.

State space: `x = [q, q']`, `A = [[0, I], [-M^-1 K, -M^-1 C]]`.
"""

from __future__ import annotations

import math

import numpy as np

from rail_mj.layout import Layout


def _bodies(layout: Layout):
    """The bodies as (name, x_centre, mass, Izz, parent_name or None, suspension or None).

    The car body is listed even when fixed (it can be a parent); its entry has
    mass None when it does not move. x is measured from the car-body centre.
    """
    cb = layout.carbody
    bodies = [("carbody", 0.0, None if cb.fixed else cb.mass, None if cb.fixed else cb.inertia[2], None, None)]
    if layout.bogie is not None:
        for i, xb in enumerate(cb.bogie_positions, start=1):
            bodies.append((f"bogie{i}", xb, layout.bogie.mass, layout.bogie.inertia[2], "carbody", layout.secondary))
        n_per_bogie = len(layout.bogie.wheelset_positions)
        parents = [f"bogie{k // n_per_bogie + 1}" for k in range(layout.n_wheelsets)]
    else:
        parents = ["carbody"] * layout.n_wheelsets
    ws = layout.wheelset
    for k, (xw, parent) in enumerate(zip(layout.wheelset_x, parents), start=1):
        bodies.append((f"wheelset{k}", xw, ws.mass, ws.inertia[2], parent, layout.primary))
    return bodies


def planar_matrices(layout: Layout, speed: float):
    """Mass, damping and stiffness matrices of the planar model at forward speed `speed`.

    Returns `(M, C, K, names)`: `M` diagonal (n x n), `C` and `K` (n x n), and
    `names[i]` the label of coordinate `i` ("carbody_lateral", "bogie1_yaw",
    "wheelset3_lateral", ...). Order: car body (if free), bogies from the
    front, wheelsets from the front; lateral then yaw for each body. The
    equations are `M q'' + C q' + K q = 0`; see the module docstring for the
    derivation (creep: docs/creep.md, section 2; suspension: docs/frames.md).
    """
    V = float(speed)
    if not V > 0.0:
        raise ValueError(f"speed must be positive (creepages divide by V), got {speed!r}")

    bodies = _bodies(layout)
    index = {}  # body name -> (lateral index, yaw index), movable bodies only
    names, masses = [], []
    for name, _x, mass, izz, _parent, _susp in bodies:
        if mass is None:
            continue
        index[name] = (len(names), len(names) + 1)
        names += [f"{name}_lateral", f"{name}_yaw"]
        masses += [mass, izz]
    n = len(names)
    M = np.diag(np.asarray(masses, dtype=float))
    C = np.zeros((n, n))
    K = np.zeros((n, n))

    # Suspension (docs/frames.md): energy ky*d^2/2 + kpsi*e^2/2 -> K += k g g^T; same for C.
    x_of = {name: x for name, x, *_ in bodies}
    for name, x_c, _m, _i, parent, susp in bodies:
        if parent is None:
            continue
        g_d = np.zeros(n)  # gradient of d = y_c - (y_p + (x_c - x_p)*psi_p)
        g_e = np.zeros(n)  # gradient of e = psi_c - psi_p
        ic_y, ic_psi = index[name]
        g_d[ic_y] += 1.0
        g_e[ic_psi] += 1.0
        if parent in index:  # a fixed parent contributes nothing (y_p = psi_p = 0)
            ip_y, ip_psi = index[parent]
            g_d[ip_y] -= 1.0
            g_d[ip_psi] -= x_c - x_of[parent]
            g_e[ip_psi] -= 1.0
        K += susp.lateral_stiffness * np.outer(g_d, g_d) + susp.yaw_stiffness * np.outer(g_e, g_e)
        C += susp.lateral_damping * np.outer(g_d, g_d) + susp.yaw_damping * np.outer(g_e, g_e)

    # Creep on each wheelset (section 2, with Kalker's spin terms f23, f33).
    ws, cr = layout.wheelset, layout.creep
    r0, b, lam = ws.rolling_radius, ws.contact_half_spacing, ws.conicity
    f11, f22, f23, f33 = cr.f11, cr.f22, cr.f23, cr.f33
    for name, *_ in bodies:
        if not name.startswith("wheelset"):
            continue
        iy, ip = index[name]
        # Fy = -2 f22 (y'/V - psi) - 2 f23 psi'/V
        C[iy, iy] += 2.0 * f22 / V
        K[iy, ip] += -2.0 * f22
        C[iy, ip] += 2.0 * f23 / V
        # Mz = -2 f11 b (b psi'/V + lam y/r0) + 2 f23 (y'/V - psi) - 2 f33 psi'/V
        C[ip, ip] += 2.0 * f11 * b * b / V + 2.0 * f33 / V
        K[ip, iy] += 2.0 * f11 * b * lam / r0
        C[ip, iy] += -2.0 * f23 / V
        K[ip, ip] += 2.0 * f23
    return M, C, K, names


def planar_state_matrix(layout: Layout, speed: float) -> np.ndarray:
    """State matrix `A` (2n x 2n) of `x = [q, q']`: `A = [[0, I], [-M^-1 K, -M^-1 C]]`.

    Built from `planar_matrices` (docs/creep.md, section 2; docs/frames.md).
    """
    M, C, K, _names = planar_matrices(layout, speed)
    n = M.shape[0]
    m_inv = 1.0 / np.diag(M)  # M is diagonal
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -m_inv[:, None] * K
    A[n:, n:] = -m_inv[:, None] * C
    return A


def planar_eigenvalues(layout: Layout, speed: float) -> np.ndarray:
    """Eigenvalues (1/s) of `planar_state_matrix`, sorted by real part, then imaginary part."""
    return np.sort_complex(np.linalg.eigvals(planar_state_matrix(layout, speed)))


def closed_form_critical_speed(m, Iz, ky, kpsi, f11, f22, lam, r0, b):
    """Linear critical speed of one wheelset sprung to a fixed body (docs/creep.md, section 4).

    For the section-2 equations (no spin creep, no suspension damping), with
    `P = m*f11*b^2 + Iz*f22` and `Q = f22*kpsi + f11*b^2*ky`:

        Vc^2 = P*Q / (P^2*lam/(b*r0) - (m*kpsi - Iz*ky)^2/4)
        omega_c^2 = Q/P          (hunting angular frequency at Vc)

    Returns `(Vc in m/s, omega_c/(2*pi) in Hz)`; `(inf, nan)` when the
    denominator is <= 0 (the wheelset is then stable at every speed).
    """
    P = m * f11 * b**2 + Iz * f22
    Q = f22 * kpsi + f11 * b**2 * ky
    denominator = P**2 * lam / (b * r0) - (m * kpsi - Iz * ky) ** 2 / 4.0
    if denominator <= 0.0:
        return math.inf, math.nan
    Vc = math.sqrt(P * Q / denominator)
    return Vc, math.sqrt(Q / P) / (2.0 * math.pi)


# --- trains (docs/trains.md) ---------------------------------------------------------------
#
# A train's bodies: car bodies carbody1..N at their positions, bogies bogie1..M at
# train.bogie_positions, wheelsets numbered over the train. Every element is a spring-damper
# set acting on a lateral deflection d (at the point x where it acts) and the relative yaw e:
#
#   suspension, child c under parent p:  d = y_c - (y_p + (x_c - x_p)*psi_p)   e = psi_c - psi_p
#   coupling of car A (front) and B:      d = (y_B + (x - x_B)*psi_B) - (y_A + (x - x_A)*psi_A)
#                                         e = psi_B - psi_A,   x midway between the body ends
#
# A bogie carried by two car bodies (a Jacobs bogie) hangs from each with half of the
# secondary suspension. The creep forces are those of planar_matrices.


def planar_train_matrices(layout: Layout, speed: float):
    """(M, C, K, names) of a train layout, in the order car bodies, bogies, wheelsets."""
    V = float(speed)
    train, bogie, ws = layout.train, layout.bogie, layout.wheelset
    bodies = []  # (name, x, mass, Izz)
    for k, car in enumerate(train.cars, start=1):
        bodies.append((f"carbody{k}", car.position, car.mass, car.inertia[2]))
    for i, xb in enumerate(layout.carbody.bogie_positions, start=1):
        bodies.append((f"bogie{i}", xb, bogie.mass, bogie.inertia[2]))
    for k, xw in enumerate(layout.wheelset_x, start=1):
        bodies.append((f"wheelset{k}", xw, ws.mass, ws.inertia[2]))
    index = {name: (2 * k, 2 * k + 1) for k, (name, *_rest) in enumerate(bodies)}
    x_of = {name: x for name, x, *_rest in bodies}
    n = 2 * len(bodies)
    M = np.diag([v for _n, _x, m, iz in bodies for v in (m, iz)])
    C, K = np.zeros((n, n)), np.zeros((n, n))

    def element(lateral: dict, yaw: dict, ky, kpsi, cy, cpsi):
        g_d, g_e = np.zeros(n), np.zeros(n)
        for (body, which), coef in lateral.items():
            g_d[index[body][which]] += coef
        for (body, which), coef in yaw.items():
            g_e[index[body][which]] += coef
        K[:] += ky * np.outer(g_d, g_d) + kpsi * np.outer(g_e, g_e)
        C[:] += cy * np.outer(g_d, g_d) + cpsi * np.outer(g_e, g_e)

    def hang(child, parent, s, share=1.0):
        element(
            {(child, 0): 1.0, (parent, 0): -1.0, (parent, 1): -(x_of[child] - x_of[parent])},
            {(child, 1): 1.0, (parent, 1): -1.0},
            share * s.lateral_stiffness,
            share * s.yaw_stiffness,
            share * s.lateral_damping,
            share * s.yaw_damping,
        )

    per_bogie = len(bogie.wheelset_positions)
    for k in range(layout.n_wheelsets):
        hang(f"wheelset{k + 1}", f"bogie{k // per_bogie + 1}", layout.primary)
    for i in range(1, len(layout.carbody.bogie_positions) + 1):
        on = [k for k, car in enumerate(train.cars, start=1) if i in car.bogies]
        for k in on:
            hang(f"bogie{i}", f"carbody{k}", layout.secondary, 1.0 / len(on))
    for c in train.couplings:
        a, b = (train.cars[k - 1] for k in c.cars)
        x = ((a.position - a.length / 2) + (b.position + b.length / 2)) / 2
        A, B = (f"carbody{k}" for k in c.cars)
        element(
            {(B, 0): 1.0, (B, 1): x - b.position, (A, 0): -1.0, (A, 1): -(x - a.position)},
            {(B, 1): 1.0, (A, 1): -1.0},
            c.lateral_stiffness,
            c.yaw_stiffness,
            c.lateral_damping,
            c.yaw_damping,
        )

    cr = layout.creep
    r0, b, lam = ws.rolling_radius, ws.contact_half_spacing, ws.conicity
    for k in range(layout.n_wheelsets):
        iy, ip = index[f"wheelset{k + 1}"]
        C[iy, iy] += 2.0 * cr.f22 / V
        K[iy, ip] += -2.0 * cr.f22
        C[iy, ip] += 2.0 * cr.f23 / V
        C[ip, ip] += 2.0 * cr.f11 * b * b / V + 2.0 * cr.f33 / V
        K[ip, iy] += 2.0 * cr.f11 * b * lam / r0
        C[ip, iy] += -2.0 * cr.f23 / V
        K[ip, ip] += 2.0 * cr.f23
    names = [f"{name}_{w}" for name, *_rest in bodies for w in ("lateral", "yaw")]
    return M, C, K, names


def planar_train_eigenvalues(layout: Layout, speed: float) -> np.ndarray:
    """Eigenvalues of the planar train model, rigid-body roots (none with creep) included."""
    M, C, K, _names = planar_train_matrices(layout, speed)
    n = M.shape[0]
    m_inv = 1.0 / np.diag(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -m_inv[:, None] * K
    A[n:, n:] = -m_inv[:, None] * C
    return np.linalg.eigvals(A)
