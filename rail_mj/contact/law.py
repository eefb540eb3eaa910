"""The contact law, compiled: Kalker's law on coned wheels, saturation, FASTSIM, flanges.

rail_mj.contact.creep is its public face (every name here is one of creep's too): this module is
what numba compiles, the native callback's law (rail_mj.simulation.kernel) and the contact
library's (rail_mj.contact.creep, built once per installation by rail_mj.compiled).

One wheelset at a time, written as plain scalar arithmetic and compiled with numba
(the per-step force callback calls it four times a step: numpy's per-operation cost
on arrays of a few wheelsets was most of a step). Independent of MuJoCo (the binding
is `rail_mj.simulation.callback`), it takes arrays of any shape whose last axis is the wheelsets:
one call serves every wheelset of a model at one instant, or a whole run's samples.

Frames, signs and an example: rail_mj.contact.creep.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

from rail_mj import numerics as _t
from rail_mj.contact.laws import FASTSIM, LAWS, LINEAR, SHEN_HEDRICK_ELKINS
from rail_mj.contact.parameters import FORCE_ROWS, NO_GEOMETRY, ContactParameters  # noqa: F401  (re-exported)
from rail_mj.numerics import (  # noqa: F401  (re-exported)  # noqa: E402
    _B,
    _C11,
    _C22,
    _C23,
    _C_FLANGE,
    _CLEARANCE,
    _F11,
    _F22,
    _F23,
    _F33,
    _FALL_RATE,
    _FALL_RATIO,
    _FASTSIM_ROWS,
    _K_FLANGE,
    _LAM,
    _LIMIT,
    _NORMAL,
    _R0,
    _ROWS,
    _SEMI_A,
    _SEMI_B,
    _SHEAR,
    _SLOPE,
    ROWS,
)
from rail_mj.units import M_PER_MM, N_PER_KN, PA_PER_GPA, RAD_PER_MRAD

# The scalar laws are compiled functions for the kernel (`_saturation`, ...), each with an
# element-wise numpy version under the public name. numba.njit caches on disk; numba's
# vectorize ufuncs were rebuilt at every import, most of a command's start-up.
_compiled = numba.njit(cache=True)


def _elementwise(compiled):
    """The element-wise numpy version of a compiled scalar function."""
    vectorized = np.vectorize(compiled, otypes=[np.float64])

    @functools.wraps(compiled.py_func)
    def public(*args):
        return vectorized(*args)

    return public


@_compiled
def _saturation(law, resultant, limit):
    """The saturated tangential force for a linear (Kalker) resultant, per wheel.

    Shen-Hedrick-Elkins: u = F/(mu*N), mu*N*(u - u^2/3 + u^3/27) for u < 3, mu*N beyond.
    Polach: eps = pi*F/(4*mu*N), which is his pi*G*a*b*c*s/(4*N*mu) with G*a*b*c*s the
    Kalker resultant; (2*mu*N/pi)*(eps/(1 + eps^2) + atan(eps)). With falling friction
    `limit` is mu(w)*N at the wheel's slip velocity (`falling_friction`).
    Both have Kalker's slope at zero, never exceed mu*N, and are continuous.
    """
    if law == LINEAR:
        return resultant
    u = min(resultant / limit, 1e100)  # far past saturation either way; no overflow
    if law == SHEN_HEDRICK_ELKINS:
        c = min(u, 3.0)
        return limit * (c - c * c / 3.0 + c * c * c / 27.0)  # = limit from u = 3 on
    eps = math.pi * u / 4.0  # Polach
    return (2.0 * limit / math.pi) * (eps / (1.0 + eps * eps) + math.atan(eps))


saturation = _elementwise(_saturation)


# FASTSIM's default grid: strips across the ellipse, elements along each strip. The
# small-creepage slopes are Kalker's C11, C22 to 0.125 % and C23 to 0.15 % (docs/creep.md, FASTSIM).
FASTSIM_STRIPS = 20
FASTSIM_ELEMENTS = 20


@_compiled
def _fastsim(a, b, normal_force, friction, shear_modulus, c11, c22, c23, xi, eta, phi, n_strips, n_elements):
    """Kalker's FASTSIM (1982): the rail's force Fx, Fy (N) and spin moment Mz (N m) on the
    wheel through one contact ellipse (semi-axes a along the rolling direction, b across, m),
    for creepages xi, eta and spin phi (rad/m). Signs as the linear law: small creepages give
    Fx = -f11*xi, Fy = -f22*eta - f23*phi (docs/creep.md, FASTSIM).

    The surface is a bed of springs of flexibility L1 = 8a/(3*C11*G) for xi, L2 = 8a/(3*C22*G)
    for eta and L3 = pi*a*sqrt(a/b)/(4*C23*G) for spin. The ellipse is cut into n_strips
    strips of equal width along the rolling direction, each into n_elements elements of
    equal length; the traction is sampled at their centres. Marching from a strip's
    leading edge x = +a*sqrt(1 - y^2/b^2), the traction changes over a step dx by
    -(xi/L1 - phi*y/L3)*dx along x and -(eta/L2 + phi*x/L3)*dx across (x at the step's
    middle), and is scaled back onto mu*p(x, y) where it exceeds it, with Kalker's
    parabolic pressure p ~ 1 - x^2/a^2 - y^2/b^2 scaled so that its sum over the grid is N.
    Allocation-free: the native callback calls it inside MuJoCo's step.
    """
    if xi == 0.0 and eta == 0.0 and phi == 0.0:
        return 0.0, 0.0, 0.0
    k1 = 3.0 * c11 * shear_modulus / (8.0 * a)  # 1/L1, Pa/m
    k2 = 3.0 * c22 * shear_modulus / (8.0 * a)  # 1/L2
    k3 = 4.0 * c23 * shear_modulus / (math.pi * a * math.sqrt(a / b))  # 1/L3, Pa/m^2
    dy = 2.0 * b / n_strips
    # The grid's sum of (1 - x^2/a^2 - y^2/b^2)*dx*dy: per strip exactly
    # a*s^3*(4/3)*(1 + 1/(2*n_elements^2)) at the element centres, s = sqrt(1 - y^2/b^2).
    cubes = 0.0
    for j in range(n_strips):
        y = -b + (j + 0.5) * dy
        s2 = 1.0 - (y / b) * (y / b)
        cubes += s2 * math.sqrt(s2)
    shape_sum = a * dy * cubes * (4.0 / 3.0) * (1.0 + 0.5 / (n_elements * n_elements))
    bound_scale = friction * normal_force / shape_sum  # mu*p = bound_scale*(1 - x^2/a^2 - y^2/b^2)
    inverse_a2 = 1.0 / (a * a)
    fx = 0.0
    fy = 0.0
    mz = 0.0
    # Strips in mirrored pairs, at y and -y: the same length, elements and bound, so one loop
    # marches both (two independent chains of arithmetic: twice as fast when they slip).
    for j in range((n_strips + 1) // 2):
        y = b - (j + 0.5) * dy  # > 0; 0 for the middle strip of an odd count
        weight = 1.0 if 2 * j + 1 < n_strips else 0.5  # the middle strip is its own mirror
        s2 = 1.0 - (y / b) * (y / b)
        half = a * math.sqrt(s2)  # the strip's half-length
        dx = 2.0 * half / n_elements
        slope_up = xi * k1 - phi * y * k3  # along x the rigid slip is constant in a strip
        slope_down = xi * k1 + phi * y * k3  # the mirror strip's, at -y
        slope_y = eta * k2
        px_up = py_up = px_down = py_down = 0.0
        sum_px_up = sum_py_up = sum_xpy_up = sum_px_down = sum_py_down = sum_xpy_down = 0.0
        x = half
        step = 0.5 * dx  # the leading edge to the first centre
        for _ in range(n_elements):
            lateral = (slope_y + phi * (x - 0.5 * step) * k3) * step  # slip at the step's middle
            px_up -= slope_up * step
            py_up -= lateral
            px_down -= slope_down * step
            py_down -= lateral
            x -= step
            bound = bound_scale * (s2 - x * x * inverse_a2)
            bound2 = bound * bound
            # Slip: onto the traction bound, in the direction the traction points.
            t2 = px_up * px_up + py_up * py_up
            if t2 > bound2:
                scale = bound / math.sqrt(t2)
                px_up *= scale
                py_up *= scale
            t2 = px_down * px_down + py_down * py_down
            if t2 > bound2:
                scale = bound / math.sqrt(t2)
                px_down *= scale
                py_down *= scale
            sum_px_up += px_up
            sum_py_up += py_up
            sum_xpy_up += x * py_up
            sum_px_down += px_down
            sum_py_down += py_down
            sum_xpy_down += x * py_down
            step = dx
        area = weight * dx * dy
        fx += (sum_px_up + sum_px_down) * area
        fy += (sum_py_up + sum_py_down) * area
        mz += (sum_xpy_up + sum_xpy_down - y * (sum_px_up - sum_px_down)) * area
    return fx, fy, mz


def fastsim(
    a,
    b,
    normal_force,
    friction,
    shear_modulus,
    c11,
    c22,
    c23,
    xi,
    eta,
    phi,
    n_strips: int = FASTSIM_STRIPS,
    n_elements: int = FASTSIM_ELEMENTS,
):
    """Kalker's FASTSIM (see `_fastsim`) element-wise over numpy arrays (broadcast):
    (Fx, Fy, Mz) in N and N m, the rail's force and spin moment on the wheel."""
    for name, value in (
        ("a", a),
        ("b", b),
        ("normal_force", normal_force),
        ("friction", friction),
        ("shear_modulus", shear_modulus),
        ("c11", c11),
        ("c22", c22),
        ("c23", c23),
    ):
        value = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(value) & (value > 0.0)):
            raise ValueError(f"fastsim: {name} must be a positive number, got {value}")
    if not (int(n_strips) == n_strips >= 1 and int(n_elements) == n_elements >= 1):
        raise ValueError(f"fastsim: n_strips and n_elements must be positive integers, got {n_strips}, {n_elements}")
    return _FASTSIM_ELEMENTWISE(
        a, b, normal_force, friction, shear_modulus, c11, c22, c23, xi, eta, phi, int(n_strips), int(n_elements)
    )


_FASTSIM_ELEMENTWISE = np.vectorize(_fastsim, otypes=[np.float64] * 3)


def patch_forces(patch, law, xi: float, eta: float, phi: float, friction: float | None = None):
    """One wheel's (Fx, Fy, Mz), N and N m, on one contact patch by `law` (a name of LAWS
    or its number), for creepages xi, eta and spin phi (rad/m); what `rail-mj creep` prints.

    `patch` is a `rail_mj.contact.hertz.ContactPatch` (ellipse, load, shear modulus, Kalker's
    coefficients); `friction` is mu, needed by every law but the linear one. The linear and
    saturating laws are Kalker's Fx = -f11*xi, Fy = -f22*eta - f23*phi, Mz = f23*eta - f33*phi,
    scaled together onto the law as in a run (`contact_forces`; Polach with constant mu);
    fastsim is `fastsim` on the default grid.
    """
    law = LAWS[law] if isinstance(law, str) else int(law)
    if law != LINEAR and not (friction is not None and friction > 0.0):
        raise ValueError(f"the {_LAW_NAMES[law]} law needs a friction coefficient > 0, got {friction}")
    if law == FASTSIM:
        forces = fastsim(
            patch.a,
            patch.b,
            patch.normal_load,
            friction,
            patch.shear_modulus,
            patch.C["C11"],
            patch.C["C22"],
            patch.C["C23"],
            xi,
            eta,
            phi,
        )
    else:
        f = patch.creep_coefficients
        fx, fy, mz = -f["f11"] * xi, -f["f22"] * eta - f["f23"] * phi, f["f23"] * eta - f["f33"] * phi
        scale = 1.0 if law == LINEAR else _saturation_factor(law, fx, fy, friction * patch.normal_load)
        forces = scale * fx, scale * fy, scale * mz
    return tuple(float(v) + 0.0 for v in forces)  # + 0.0: no -0.0


_LAW_NAMES = {number: name for name, number in LAWS.items()}


@_compiled
def _falling_friction(limit, ratio, rate, slip_velocity):
    """mu*N at a wheel: Polach's (2005) falling friction mu0*((1 - A)*exp(-B*w) + A) at slip
    velocity w (m/s), with limit = mu0*N, ratio A = mu_infinity/mu0 and rate B (s/m)."""
    return limit * ((1.0 - ratio) * math.exp(-rate * slip_velocity) + ratio)


falling_friction = _elementwise(_falling_friction)


@_compiled
def _radius_rise(y, conicity, flange_slope, clearance):
    """How much a wheel's rolling radius grows when the wheelset moves y towards its side
    (r_left - r0 = radius_rise(y), r_right - r0 = radius_rise(-y)).

    On the tread each wheel is a cone: lam*y. Past the flangeway clearance the contact
    runs up the flange, whose radius rises as tan(flange angle) per metre: the steep rise
    of the rolling-radius difference at flange contact (flange_slope = lam: no flange).
    """
    return conicity * y + (flange_slope - conicity) * max(y - clearance, 0.0)


radius_rise = _elementwise(_radius_rise)


@_compiled
def _flange_force(y, y_dot, clearance, stiffness, damping):
    """Lateral force (N) of the rails on a wheelset's flanges: zero within the flangeway
    clearance, beyond it an elastic rail (stiffness k, damping c) that only pushes:
    -sign(y) * max(0, k*(|y| - clearance) + c*|y|')."""
    over = abs(y) - clearance
    if over <= 0.0:
        return 0.0
    side = 1.0 if y > 0.0 else -1.0
    return -side * max(stiffness * over + damping * side * y_dot, 0.0)


flange_force = _elementwise(_flange_force)


@_compiled
def _flange_lead(y, psi, radius, flange_slope, b):
    """Where the flange contact lies along the track ahead of the wheelset centre, m, for
    the flanging wheel's contact radius `radius`.

    A straight rail's surface normals have no longitudinal part, so the flange touches
    it where the yawed flange cone's normal has none either: at sin(theta) =
    tan(gamma)*tan(psi) ahead of the axle in the wheel's own plane (gamma: the flange
    angle). The wheel's centre itself sits b*psi behind the wheelset's, so in the track
    frame the left flange touches at psi*(r*tan(gamma) - b), r the contact radius (small
    angles), and the right one, by mirror symmetry, at -psi*(r*tan(gamma) - b). A wheelset
    yawed into the rail it strikes has its contact ahead, for a 70 degree flange
    (r*tan(gamma) = 1.26 m against b = 0.75 m): there the flange force turns it away.
    """
    side = 1.0 if y > 0.0 else -1.0 if y < 0.0 else 0.0
    return side * psi * (radius * flange_slope - b)


flange_lead = _elementwise(_flange_lead)


@numba.njit(cache=True)
def wear_number(fx, fy, mz, xi_x, xi_y, xi_sp):
    """The wear number T-gamma of one contact (N, J/m): the energy the creep forces dissipate in it
    per metre rolled, -(Fx*xi_x + Fy*xi_y + Mz*xi_sp), with (Fx, Fy, Mz) the rail's forces and spin
    moment on the wheel and xi_x, xi_y, xi_sp (rad/m) the creepages they are computed from. The
    forces oppose the creepages, so it is >= 0: Kalker's linear law gives f11*xi_x^2 + f22*xi_y^2 +
    f33*xi_sp^2 (the f23 terms cancel), a saturating law that times its factor (docs/track.md, section 9)."""
    return -(fx * xi_x + fy * xi_y + mz * xi_sp)


@numba.njit(cache=True, inline="always")
def _norm(a, b):
    """|(a, b)|. libm's hypot guards against overflow past 1e154, which no creepage or force comes
    near, at several times the cost of a square root: most of the law's time in a coach-step."""
    return math.sqrt(a * a + b * b)


@numba.njit(cache=True)
def _saturation_factor(law, fx, fy, limit):
    """The factor that scales a wheel's linear (Fx, Fy) onto the creep law's resultant:
    1 at zero, where every law has Kalker's slope."""
    linear = _norm(fx, fy)
    return 1.0 if linear == 0.0 else _saturation(law, linear, limit) / linear


@numba.njit(cache=True)
def _kalker_wheelset(p, law, falling, xi_left, xi_right, xi_y, xi_sp, speed, q_left, q_right, wear=False):
    """Both wheels' creep forces by Kalker's linear law, saturated by `law` (not FASTSIM):
    (creep lateral, creep couple, spin moment, left wheel's lateral, right wheel's lateral, left
    wheel's wear number, right wheel's: `wear_number`, here scale*(f11*xi_x^2 + f22*xi_y^2 +
    f33*xi_sp^2) with the wheel's coefficients, as f23's two terms cancel; 0 unless `wear`).

    q_left, q_right: each wheel's load over the load the coefficients are given at (1, 1 on a
    planar vehicle). Kalker's coefficients are G*(a*b)*C11, G*(a*b)*C22, G*(a*b)^(3/2)*C23 and
    G*(a*b)^2*C33, and Hertz's semi-axes grow as N^(1/3) (docs/creep.md), so f11 and f22 scale
    as q^(2/3), f23 as q and f33 as q^(4/3); the friction limit mu*N as q."""
    # Kalker per wheel: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp.
    if q_left == 1.0 and q_right == 1.0:  # equal nominal loads: the classical arithmetic, bit for bit
        fx_left, fx_right = -p[_F11] * xi_left, -p[_F11] * xi_right
        fy_left = fy_right = -p[_F22] * xi_y - p[_F23] * xi_sp
        mz_left = mz_right = p[_F23] * xi_y - p[_F33] * xi_sp
    else:
        area_left, area_right = q_left ** (2.0 / 3.0), q_right ** (2.0 / 3.0)
        fx_left, fx_right = -p[_F11] * area_left * xi_left, -p[_F11] * area_right * xi_right
        fy_left = -p[_F22] * area_left * xi_y - p[_F23] * q_left * xi_sp
        fy_right = -p[_F22] * area_right * xi_y - p[_F23] * q_right * xi_sp
        mz_left = p[_F23] * q_left * xi_y - p[_F33] * area_left * area_left * xi_sp
        mz_right = p[_F23] * q_right * xi_y - p[_F33] * area_right * area_right * xi_sp
    scale_left = scale_right = 1.0
    if law != LINEAR:
        limit_left, limit_right = p[_LIMIT] * q_left, p[_LIMIT] * q_right
        if falling:  # each wheel's slip velocity V*|(xi_x, xi_y)|, spin aside, as Polach
            limit_left = _falling_friction(limit_left, p[_FALL_RATIO], p[_FALL_RATE], speed * _norm(xi_left, xi_y))
            limit_right = _falling_friction(limit_right, p[_FALL_RATIO], p[_FALL_RATE], speed * _norm(xi_right, xi_y))
        # Fx, Fy and the spin moment of a wheel all saturate by one factor (a common
        # simplification: Kalker's full theory saturates the moment its own way). An unloaded
        # wheel (limit 0) carries nothing.
        scale_left = _saturation_factor(law, fx_left, fy_left, limit_left) if limit_left > 0.0 else 0.0
        scale_right = _saturation_factor(law, fx_right, fy_right, limit_right) if limit_right > 0.0 else 0.0
    if q_left == 1.0 and q_right == 1.0:
        creep_lateral = (scale_left + scale_right) * fy_left
        spin = (scale_left + scale_right) * mz_left
    else:
        creep_lateral = scale_left * fy_left + scale_right * fy_right
        spin = scale_left * mz_left + scale_right * mz_right
    couple = p[_B] * (scale_right * fx_right - scale_left * fx_left)  # Fx_left at y = +b
    wear_left = wear_right = 0.0
    if wear:
        wear_left = scale_left * wear_number(fx_left, fy_left, mz_left, xi_left, xi_y, xi_sp)
        wear_right = scale_right * wear_number(fx_right, fy_right, mz_right, xi_right, xi_y, xi_sp)
    return creep_lateral, couple, spin, scale_left * fy_left, scale_right * fy_right, wear_left, wear_right


@numba.njit(cache=True)
def _fastsim_wheel(p, xi_x, xi_y, xi_sp, q):
    """One wheel's (Fx, Fy, Mz) by FASTSIM on the default grid, from its column `p` of
    `ContactParameters.table`; mu*N is the table's friction limit. `q`: the wheel's load over
    the table's (Hertz: the semi-axes grow as q^(1/3)); an unloaded wheel carries nothing."""
    if q <= 0.0:
        return 0.0, 0.0, 0.0
    grow = 1.0 if q == 1.0 else q ** (1.0 / 3.0)
    return _fastsim(
        p[_SEMI_A] * grow,
        p[_SEMI_B] * grow,
        p[_NORMAL] * q,
        p[_LIMIT] / p[_NORMAL],
        p[_SHEAR] * PA_PER_GPA,
        p[_C11],
        p[_C22],
        p[_C23],
        xi_x,
        xi_y,
        xi_sp,
        FASTSIM_STRIPS,
        FASTSIM_ELEMENTS,
    )


def compile_apart() -> None:
    """Compile FASTSIM's wheel kernel on its own, before a caller that inlines the law (the
    native callback, the contact library) is compiled. Measured (numba 0.68, 1 km of the coach at
    60 m/s): compiled first on its own, the callback's FASTSIM runs take 0.59-0.64 s; compiled
    only inside the callback's one compilation, 1.78-1.85 s, the same forces to the bit. Which
    of the two a build got depended on what the process had compiled before it (the peer's batch
    happened to compile it first): now every build gets the faster."""
    column = numba.types.Array(numba.types.float64, 1, "A")  # a column of the parameter table
    _fastsim_wheel.compile((column, *[numba.types.float64] * 4))


@numba.njit(cache=True)
def cone_wheel_loads(load, moment, b, y):
    """Each wheel's vertical load (N) on coned wheels from the wheelset's axle load `load` (N)
    and the roll moment `moment` (N m, positive rolling it to the left, i.e. about +x) of every
    other force on it about the rail level under its centre (docs/spatial.md, wheel loads).
    The knife-edge rails stay at +/-b from the track's centre, so with the wheelset shifted by
    y their levers are b - y and b + y: Q_left + Q_right = load,
    b*(Q_left - Q_right) - y*load + moment = 0. A wheel that would pull on its rail lifts: the
    other carries the axle."""
    q_left = 0.5 * load + 0.5 * (y * load - moment) / b
    q_right = load - q_left
    if not load > 0.0:
        return 0.0, 0.0
    if q_left < 0.0:
        return 0.0, load
    if q_right < 0.0:
        return load, 0.0
    return q_left, q_right


@numba.njit(cache=True)
def gyroscopic(spin_inertia, spin, roll_rate, yaw_rate):
    """The spinning wheelset's gyroscopic terms (docs/spatial.md): its angular momentum I_y*Omega
    along the axle (Omega = V/r0), turned by its roll rate phi' (about x, left side up) and yaw
    rate psi', changes at (Omega x H) = I_y*Omega*(psi'*(-x) + phi'*z). Returns the yaw moment it
    feels, -I_y*Omega*phi', and the roll moment the rails must supply, -I_y*Omega*psi'."""
    h = spin_inertia * spin
    return -h * roll_rate, -h * yaw_rate


@numba.njit(cache=True)
def cone_gravity_forces(lam, b, y, wheel_left, wheel_right):
    """The lateral parts of the normal forces on coned wheels over knife-edge rails: the contact
    angle is the cone's, atan(lam), plus or minus the wheelset's roll lam*y/b; each wheel's
    normal force, carrying its vertical load Q, leans towards the track centre:
    Y_left = -Q_left*tan(d0 + phi), Y_right = Q_right*tan(d0 - phi). With equal loads their sum
    is -2*Q*phi*sec^2(d0) to first order: the gravitational stiffness W*lam/b of the classical
    literature (Wickens, 2003), restoring on cones."""
    d0, phi = math.atan(lam), lam * y / b
    return -wheel_left * math.tan(d0 + phi), wheel_right * math.tan(d0 - phi)


@numba.njit(cache=True)
def wheelset_contact(
    p,
    law,
    flange,
    falling,
    y,
    psi,
    y_dot,
    psi_dot,
    speed,
    load=math.nan,
    moment=0.0,
    nominal=math.nan,
    spin_inertia=0.0,
    cone_gravity=False,
    wear=False,
    gauge=0.0,
):
    """The rails' forces on one wheelset, by origin: (creep lateral, flange lateral, creep
    couple, spin moment, flange moment), N and N m (see `ContactForces`), then each wheel's
    vertical load Q and lateral force Y (Q_left, Q_right, Y_left, Y_right). `p`: its column
    of `ContactParameters.table`. The one implementation of the contact law: the array
    kernel below and the native passive-force callback (rail_mj.simulation.native) both call it.

    `load` and `moment`: the wheelset's axle load and the roll moment on it about the rail
    level from the model's suspension (`cone_wheel_loads`; a spatial vehicle's, docs/spatial.md),
    `nominal` the wheel load the coefficients are given at; a NaN `load` (a planar vehicle):
    both wheels carry `nominal` and the coefficients are used as given. With a `load`:
    `spin_inertia` (I_y, 0: off) adds the spinning wheelset's gyroscopic terms (`gyroscopic`),
    `cone_gravity` the normal forces' lateral parts on knife-edge rails (`cone_gravity_forces`),
    counted with the flange's. Returns the gyroscopic yaw moment, then each wheel's wear number
    (`wear_number`: left, right) if `wear`, else zeros: the native callback, which reads the first
    ten entries only, leaves `wear` out, and its compiled law has no trace of it.

    `gauge`: the gauge's departure from nominal (m, wider positive; a track irregularity,
    rail_mj.track.irregularities): each rail stands gauge/2 further out, so each flange meets its
    rail gauge/2 later; the cones' tread and the knife-edge rails' spacing are left as they are
    (a gauge of a few mm changes b by a few parts in 10^3). On irregular track `y`, `psi`,
    `y_dot` are the wheelset's relative to the rails' centreline (rail_mj.simulation.irregular)."""
    # Creepages (docs/creep.md): on the tread xi_x_left = -(b*psi'/V) - lam*y/r0 and
    # xi_x_right is its negative; the lateral creepage is the same on both wheels, and the
    # spin differs between them only by the constant contact-angle term, which cancels
    # between the two wheels' linear forces and is left out (with a saturating law or FASTSIM
    # it would not cancel exactly: docs/creep.md, section 6). Without flange contact
    # flange_slope is the conicity: no rise.
    clearance = p[_CLEARANCE] + 0.5 * gauge
    rise_left = _radius_rise(y, p[_LAM], p[_SLOPE], clearance)
    rise_right = _radius_rise(-y, p[_LAM], p[_SLOPE], clearance)
    turning = p[_B] * psi_dot / speed
    xi_left = -turning - rise_left / p[_R0]
    xi_right = turning - rise_right / p[_R0]
    xi_y = y_dot / speed - psi
    xi_sp = psi_dot / speed
    gyro_yaw = 0.0
    if math.isnan(load):
        wheel_left = wheel_right = nominal
        q_left = q_right = 1.0
    else:
        if spin_inertia > 0.0:  # the kinematic roll of a coned wheelset: lam*y/b
            gyro_yaw, gyro_roll = gyroscopic(spin_inertia, speed / p[_R0], p[_LAM] / p[_B] * y_dot, psi_dot)
            moment -= gyro_roll
        wheel_left, wheel_right = cone_wheel_loads(load, moment, p[_B], y)
        q_left, q_right = wheel_left / nominal, wheel_right / nominal
    if law == FASTSIM:  # each wheel's contact ellipse through Kalker's FASTSIM
        fx_left, y_left, mz_left = _fastsim_wheel(p, xi_left, xi_y, xi_sp, q_left)
        fx_right, y_right, mz_right = _fastsim_wheel(p, xi_right, xi_y, xi_sp, q_right)
        creep_lateral = y_left + y_right
        couple = p[_B] * (fx_right - fx_left)  # Fx_left at y = +b
        spin = mz_left + mz_right
        wear_left = wear_right = 0.0
        if wear:
            wear_left = wear_number(fx_left, y_left, mz_left, xi_left, xi_y, xi_sp)
            wear_right = wear_number(fx_right, y_right, mz_right, xi_right, xi_y, xi_sp)
    else:
        creep_lateral, couple, spin, y_left, y_right, wear_left, wear_right = _kalker_wheelset(
            p, law, falling, xi_left, xi_right, xi_y, xi_sp, speed, q_left, q_right, wear
        )
    flange_lateral = flange_moment = 0.0
    if flange:
        flange_lateral = _flange_force(y, y_dot, clearance, p[_K_FLANGE], p[_C_FLANGE])
        if flange_lateral != 0.0:
            radius = p[_R0] + max(rise_left, rise_right)  # the flanging wheel's
            flange_moment = flange_lateral * _flange_lead(y, psi, radius, p[_SLOPE], p[_B])
            if y > 0.0:  # the left flange against the left rail
                y_left += flange_lateral
            else:
                y_right += flange_lateral
    if cone_gravity and not math.isnan(load):
        pushed_left, pushed_right = cone_gravity_forces(p[_LAM], p[_B], y, wheel_left, wheel_right)
        y_left += pushed_left
        y_right += pushed_right
        flange_lateral += pushed_left + pushed_right
    return (
        creep_lateral,
        flange_lateral,
        couple,
        spin,
        flange_moment,
        wheel_left,
        wheel_right,
        y_left,
        y_right,
        gyro_yaw,
        wear_left,
        wear_right,
    )


@numba.njit(cache=True, error_model="numpy", inline="always")
def _between(lo, hi, t, column):
    """A table entry interpolated between two rows."""
    return lo[column] + t * (hi[column] - lo[column])


@numba.njit(cache=True, error_model="numpy")
def _normal_loads(
    lo, hi, t, lo2, hi2, t2, axle_load, r0, moment, about_rail, creep_left=(0.0, 0.0), creep_right=(0.0, 0.0)
):
    """Each wheel's normal load (N) from the wheelset's vertical and roll equilibrium under
    its axle load: N_L*V_L + N_R*V_R = W, N_L*M_L + N_R*M_R + moment = 0 with V = sum w*cos(g)
    and M = sum w*(l*cos(g) - s*h*sin(g)) over the wheel's points (the roll moment of its
    normal forces per unit load). A planar vehicle (`about_rail` false, `moment` 0) takes
    moments about the wheelset's centre (h = r, the creep forces left out); a spatial one
    about the rail level under it (h = r - r0), `moment` being the suspension's there, whose
    lateral force the rails' lateral forces balance (docs/spatial.md, wheel loads). Where
    that would have a wheel pull on its rail, one wheel carries the axle alone: the one
    whose own normal force rolls the wheelset onto it (M_L <= 0: the left; M_R >= 0: the
    right). `creep_left`, `creep_right`: each wheel's creep forces' vertical force and roll
    moment per unit normal load, added to its V and M (a spatial vehicle's: Nadal's balance).
    The left wheel's entries are interpolated between rows `lo`, `hi` at `t`, the right's between
    `lo2`, `hi2` at `t2` (the same rows but on a track whose gauge departs from nominal).
    Returns (N_left, N_right, V_left, V_right), V without the creep."""
    v_left = v_right = m_left = m_right = 0.0
    for side in range(2):
        s = 1.0 - 2.0 * side
        if side == 1:
            lo, hi, t = lo2, hi2, t2
        for slot in range(_t.SLOTS):
            c = _t.FIRST_POINT + (side * _t.SLOTS + slot) * _t.POINT
            w = _between(lo, hi, t, c + _t.WEIGHT)
            rise = _between(lo, hi, t, c + _t.RADIUS) * M_PER_MM
            h = rise if about_rail else r0 + rise
            g = _between(lo, hi, t, c + _t.ANGLE)
            lever = _between(lo, hi, t, c + _t.LEVER) * M_PER_MM
            v, m = w * math.cos(g), w * (lever * math.cos(g) - s * h * math.sin(g))
            if side == 0:
                v_left, m_left = v_left + v, m_left + m
            else:
                v_right, m_right = v_right + v, m_right + m
    normal_left, normal_right = v_left, v_right
    v_left, m_left = v_left + creep_left[0], m_left + creep_left[1]
    v_right, m_right = v_right + creep_right[0], m_right + creep_right[1]
    det = v_left * m_right - v_right * m_left
    n_left = (axle_load * m_right + moment * v_right) / det
    n_right = (-axle_load * m_left - moment * v_left) / det
    if not axle_load > 0.0:
        return 0.0, 0.0, normal_left, normal_right
    if not (n_left >= 0.0 and n_right >= 0.0):
        left_carries = n_right < 0.0 if about_rail else m_left <= 0.0
        if left_carries:
            n_left, n_right = axle_load / v_left, 0.0
        else:
            n_left, n_right = 0.0, axle_load / v_right
    return n_left, n_right, normal_left, normal_right


# In Nadal's balance (`profiled_contact`), a wheel whose creep would take away more than this share
# of its normal forces' vertical part (friction holding it down on a steep flange) is balanced
# without its creep.
NADAL_FLOOR = 0.5
# Nadal's balance is solved again, the creep per unit load updated, until the wheels' vertical
# forces meet the axle load to this (relative), in at most NADAL_PASSES passes (one where the
# creep saturates; at the flange's onset, its load moving fast, a few).
NADAL_TOLERANCE = 1e-6
NADAL_PASSES = 5


@numba.njit(cache=True, error_model="numpy")
def profiled_contact(
    geo,
    p,
    law,
    falling,
    y,
    psi,
    y_dot,
    psi_dot,
    speed,
    load=math.nan,
    moment=0.0,
    spin_inertia=0.0,
    wear=False,
    gauge=0.0,
):
    """The rails' forces on one wheelset on profiles, by origin as `wheelset_contact` gives
    them: (creep lateral, normal lateral, creep couple, spin moment, lead moment). `geo`:
    its contact table (rail_mj.contact.tables), interpolated linearly in y and held at its end rows
    beyond (the runner stops a wheelset that leaves it); `p`: its column of
    ContactParameters.table, for the falling-friction constants. docs/dynamics-on-profiles.md.

    Per contact point k of side s (+1 left, -1 right), load share w, radius r, contact
    angle g (leaning towards the track centre), lateral lever l:
      normal loads from the wheelset's vertical and roll equilibrium (`_normal_loads`);
      creepages xi_x = (r0 - r)/r0 - l*psi'/V, xi_y = y'/(V*cos(g)) - psi*cos(phi)/cos(g - s*phi)
        (the slip the rigid contact allows lies in the contact plane, its contact point led by the
        yaw; phi the wheelset's roll from the table, g - s*phi the contact angle on the wheel),
        spin = psi'*cos(g)/V - s*sin(g - s*phi)/r0 (the wheel turns at V/r0 about its rolled axle);
      Kalker's law with this point's ellipse at its load (a, b grow as N^(1/3)), saturated,
        or FASTSIM on that ellipse;
      the normal force's lateral part -s*N*sin(g): gravitational stiffness and the flange.
    The table's header switches gravitational stiffness and spin creep (f23 = f33 = 0) off.
    `load`, `moment`: a spatial vehicle's axle load and suspension roll moment about the rail
    level (`_normal_loads`); NaN: the table's axle load, moments about the centre. Returns
    the five forces, then each wheel's vertical load and lateral force (Q_left, Q_right,
    Y_left, Y_right) as `wheelset_contact` does, the gyroscopic yaw moment (`spin_inertia`,
    a spatial vehicle's: the wheelset's roll rate from the table's roll against y), and each
    wheel's wear number, summed over its contact points, each with its own creepages, if `wear`
    (else zeros, as `wheelset_contact`).

    `gauge`: the gauge's departure from nominal (m, wider positive; a track irregularity): each rail
    stands gauge/2 further out, and each wheel's entries are read at its own shift from its rail,
    the left's at y - gauge/2, the right's at y + gauge/2. That leaves out how the gauge changes
    the wheelset's roll, which moves each contact a little (docs/irregularities.md: against tables
    made at the wider gauge, delta r within 0.4 % rms at 2 mm, 5 % at 5 mm on S1002/60E1).
    """
    # The table is stored in mm, kN and GPa (rail_mj.contact.tables): SI from here on.
    y0, dy, rows = geo[0, _t.HEADER_Y0] * M_PER_MM, geo[0, _t.HEADER_DY] * M_PER_MM, int(geo[0, _t.HEADER_ROWS])
    axle_load, shear = geo[0, _t.HEADER_AXLE_LOAD] * N_PER_KN, geo[0, _t.HEADER_SHEAR_MODULUS] * PA_PER_GPA
    mu, r0 = geo[0, _t.HEADER_FRICTION], geo[0, _t.HEADER_R0] * M_PER_MM
    gravity, spinning = geo[0, _t.HEADER_GRAVITY] != 0.0, geo[0, _t.HEADER_SPIN] != 0.0
    if math.isnan(y):  # a diverged state: no table row, and the runner reports it
        nan = math.nan
        return nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan
    u = min(max((y - 0.5 * gauge - y0) / dy, 0.0), rows - 1.0)
    i = min(int(u), rows - 2)
    t = u - i
    lo, hi = geo[1 + i], geo[2 + i]
    u2 = min(max((y + 0.5 * gauge - y0) / dy, 0.0), rows - 1.0)
    i2 = min(int(u2), rows - 2)
    t2 = u2 - i2
    lo2, hi2 = geo[1 + i2], geo[2 + i2]
    spatial = not math.isnan(load)
    gyro_yaw = 0.0
    if spatial and spin_inertia > 0.0:  # roll in mrad per mm of y: rad/m
        slope = (hi[_t.ROLL] - lo[_t.ROLL]) / (hi[_t.Y] - lo[_t.Y])
        slope2 = (hi2[_t.ROLL] - lo2[_t.ROLL]) / (hi2[_t.Y] - lo2[_t.Y])
        roll_rate = 0.5 * (slope + slope2) * y_dot
        gyro_yaw, gyro_roll = gyroscopic(spin_inertia, speed / r0, roll_rate, psi_dot)
        moment -= gyro_roll
    n_left, n_right, v_left, v_right = _normal_loads(
        lo, hi, t, lo2, hi2, t2, load if spatial else axle_load, r0, moment if spatial else 0.0, spatial
    )
    f = _points(
        lo,
        hi,
        t,
        lo2,
        hi2,
        t2,
        p,
        law,
        falling,
        psi,
        y_dot,
        psi_dot,
        speed,
        shear,
        mu,
        r0,
        gravity,
        spinning,
        n_left,
        n_right,
        wear,
    )
    # Nadal's balance (a spatial vehicle): the creep forces' vertical parts (large on a steep
    # flange) belong in the wheelset's equilibrium, and they grow with the loads they act under.
    # Taken per unit normal load from a first evaluation, they enter the balance once more: exact
    # where the creep saturates (mu*N), to the creep's N^(2/3) growth where it does not. Where
    # friction holds a wheel down on a steep flange harder than NADAL_FLOOR of its normal forces'
    # vertical part (mu*tan(g) past it: the flange's wedge, which a rigid rail and a held
    # wheelset cannot resolve), that wheel's balance leaves its creep out, as a planar one does.
    creep_left = creep_right = (0.0, 0.0)
    for _ in range(NADAL_PASSES if spatial else 0):
        creep_left = creep_right = (0.0, 0.0)
        if n_left > 0.0 and f[7] / n_left >= -NADAL_FLOOR * v_left:
            creep_left = (f[7] / n_left, f[9] / n_left)
        if n_right > 0.0 and f[8] / n_right >= -NADAL_FLOOR * v_right:
            creep_right = (f[8] / n_right, f[10] / n_right)
        if creep_left == (0.0, 0.0) and creep_right == (0.0, 0.0):
            break
        n_left, n_right, v_left, v_right = _normal_loads(
            lo, hi, t, lo2, hi2, t2, load, r0, moment, True, creep_left, creep_right
        )
        f = _points(
            lo,
            hi,
            t,
            lo2,
            hi2,
            t2,
            p,
            law,
            falling,
            psi,
            y_dot,
            psi_dot,
            speed,
            shear,
            mu,
            r0,
            gravity,
            spinning,
            n_left,
            n_right,
            wear,
        )
        vertical = n_left * v_left + n_right * v_right
        if creep_left != (0.0, 0.0):
            vertical += f[7]
        if creep_right != (0.0, 0.0):
            vertical += f[8]
        if abs(vertical - load) <= NADAL_TOLERANCE * load:  # the balance met: sum Q = the axle load
            break
    # Q: the vertical part of the rails' whole force on each wheel, creep included where the balance
    # has it; otherwise the normal forces' alone, as the balance.
    q_left, q_right = n_left * v_left, n_right * v_right
    if creep_left != (0.0, 0.0):
        q_left += f[7]
    if creep_right != (0.0, 0.0):
        q_right += f[8]
    return f[0], f[1], f[2], f[3], f[4], q_left, q_right, f[5], f[6], gyro_yaw, f[11], f[12]


@numba.njit(cache=True, error_model="numpy")
def _creepages(cos_g, sin_g, s, cos_roll, sin_roll, rise, lever, r0, y_dot, psi, psi_dot, speed):
    """One contact point's creepages (xi_x, xi_y, spin in rad/m) on profiles: side s (+1 left,
    -1 right), contact angle g in the track frame (leaning towards the track centre; its cos and
    sin), the wheelset's roll phi (left side up; its cos and sin), radius rise r - r0 and lateral
    lever l (m), the wheelset's y', psi, psi' and speed V (docs/dynamics-on-profiles.md):

        xi_x = (r0 - r)/r0 - l*psi'/V
        xi_y = y'/(V*cos(g)) - psi*cos(phi)/cos(g - s*phi)
        spin = psi'*cos(g)/V - s*sin(g - s*phi)/r0

    g - s*phi is the contact angle on the wheel, from its rolled axle: the wheel turns at V/r0
    about that axle (its spin along the normal), and the yaw's slip -V*psi lies along the wheel's
    meridian through the contact, led ahead of the axle. At phi = 0 they are the unrolled
    expressions to the last bit: xi_y = (y'/V - psi)/cos(g), spin = psi'*cos(g)/V - s*sin(g)/r0."""
    # sin and cos of g - s*phi by the angle sum (exact at phi = 0: no trigonometry per point).
    sin_wheel = sin_g * cos_roll - s * cos_g * sin_roll
    cos_wheel = cos_g * cos_roll + s * sin_g * sin_roll
    xi_x = -rise / r0 - lever * psi_dot / speed
    tilt = cos_roll * cos_g / cos_wheel  # cos(phi)/cos(g - s*phi) as a factor on sec(g): 1 at phi = 0
    xi_y = (y_dot / speed - psi * tilt) / cos_g
    xi_sp = psi_dot * cos_g / speed - s * sin_wheel / r0
    return xi_x, xi_y, xi_sp


@numba.njit(cache=True, error_model="numpy")
def _points(
    lo,
    hi,
    t,
    lo2,
    hi2,
    t2,
    p,
    law,
    falling,
    psi,
    y_dot,
    psi_dot,
    speed,
    shear,
    mu,
    r0,
    gravity,
    spinning,
    n_left,
    n_right,
    wear=False,
):
    """Every contact point's forces under the wheels' normal loads (`profiled_contact`): (creep
    lateral, normal lateral, couple, spin, lead moment, Y_left, Y_right, and per wheel the creep
    forces' vertical force and roll moment about the rail level under the wheelset's centre:
    Fz_left, Fz_right, Mx_left, Mx_right; and each wheel's wear number, `wear_number` summed over
    its points: wear_left, wear_right, if `wear`, else zeros). A point's creep force in its contact plane, across the
    rolling direction, has the track components (cos(g), s*sin(g)) (the plane's tangent).

    The wheelset's roll phi (the table's, left side up) tilts its axle: a point at the track-frame
    contact angle g lies at g - s*phi on the wheel, which sets the spin of the wheel's rotation
    and the yaw's lateral slip (docs/dynamics-on-profiles.md, creepages); with phi = 0 both are
    the unrolled expressions to the last bit. The left wheel's entries are interpolated between
    `lo`, `hi` at `t`, the right's between `lo2`, `hi2` at `t2` (`profiled_contact`, gauge); the
    wheelset's roll is the mean of the two rows' (exactly either where they are one)."""
    creep_lateral = normal_lateral = couple = spin = lead_moment = 0.0
    y_left = y_right = 0.0
    fz_left = fz_right = mx_left = mx_right = 0.0
    wear_left = wear_right = 0.0
    wheelset_roll = 0.5 * (_between(lo, hi, t, _t.ROLL) + _between(lo2, hi2, t2, _t.ROLL)) * RAD_PER_MRAD  # rad
    cos_roll, sin_roll = math.cos(wheelset_roll), math.sin(wheelset_roll)
    for side in range(2):
        s = 1.0 - 2.0 * side
        wheel = n_left if side == 0 else n_right
        if side == 1:
            lo, hi, t = lo2, hi2, t2
        for slot in range(_t.SLOTS):
            c = _t.FIRST_POINT + (side * _t.SLOTS + slot) * _t.POINT
            normal = wheel * _between(lo, hi, t, c + _t.WEIGHT)
            if not normal > 0.0:
                continue
            rise = _between(lo, hi, t, c + _t.RADIUS) * M_PER_MM
            r = r0 + rise
            g = _between(lo, hi, t, c + _t.ANGLE)
            lever = _between(lo, hi, t, c + _t.LEVER) * M_PER_MM
            cube = (normal / N_PER_KN) ** (1.0 / 3.0) * M_PER_MM  # semi-axes per unit load: mm/kN^(1/3)
            a = cube * _between(lo, hi, t, c + _t.SEMI_A)
            b = cube * _between(lo, hi, t, c + _t.SEMI_B)
            ab = a * b
            c11, c22 = _between(lo, hi, t, c + _t.C11), _between(lo, hi, t, c + _t.C22)
            c23 = _between(lo, hi, t, c + _t.C23)
            cos_g, sin_g = math.cos(g), math.sin(g)
            xi_x, xi_y, xi_sp = _creepages(
                cos_g, sin_g, s, cos_roll, sin_roll, rise, lever, r0, y_dot, psi, psi_dot, speed
            )
            if not spinning:
                xi_sp = 0.0
            scale = 1.0
            if law == FASTSIM:  # this point's ellipse through Kalker's FASTSIM
                fx, fy, mz = _fastsim(
                    a, b, normal, mu, shear, c11, c22, c23, xi_x, xi_y, xi_sp, FASTSIM_STRIPS, FASTSIM_ELEMENTS
                )
            else:
                f23 = f33 = 0.0
                if spinning:
                    f23 = shear * ab * math.sqrt(ab) * c23
                    f33 = shear * ab * ab * _between(lo, hi, t, c + _t.C33)
                fx = -shear * ab * c11 * xi_x
                fy = -shear * ab * c22 * xi_y - f23 * xi_sp
                mz = f23 * xi_y - f33 * xi_sp
                if law != LINEAR:
                    limit = mu * normal
                    if falling:
                        limit = _falling_friction(limit, p[_FALL_RATIO], p[_FALL_RATE], speed * _norm(xi_x, xi_y))
                    scale = _saturation_factor(law, fx, fy, limit)
            lateral = scale * fy * cos_g
            pushed = -s * normal * sin_g if gravity else 0.0
            creep_lateral += lateral
            normal_lateral += pushed
            vertical = s * scale * fy * sin_g
            roll = lever * vertical + rise * lateral  # y*Fz - z*Fy, the point at z = -rise
            if side == 0:
                y_left += lateral + pushed
                fz_left += vertical
                mx_left += roll
            else:
                y_right += lateral + pushed
                fz_right += vertical
                mx_right += roll
            if wear:
                dissipated = scale * wear_number(fx, fy, mz, xi_x, xi_y, xi_sp)
                if side == 0:
                    wear_left += dissipated
                else:
                    wear_right += dissipated
            couple -= lever * scale * fx
            spin += scale * mz * cos_g
            # Where the point lies along the track: a yawed wheel touches a straight rail
            # ahead of its axle by r*tan(g) (see _flange_lead), its centre sits l*psi behind.
            lead_moment += psi * (s * r * math.tan(g) - lever) * (lateral + pushed)
    return (
        creep_lateral,
        normal_lateral,
        couple,
        spin,
        lead_moment,
        y_left,
        y_right,
        fz_left,
        fz_right,
        mx_left,
        mx_right,
        wear_left,
        wear_right,
    )


@numba.njit(cache=True, nogil=True)  # summaries on one thread while another steps
def _forces_into(
    out,
    table,
    geometry,
    law,
    flange,
    falling,
    y,
    psi,
    y_dot,
    psi_dot,
    speed,
    load,
    moment,
    nominal,
    spin_inertia,
    cone_gravity,
    gauge,
):
    """`contact_forces` over flat, contiguous state arrays (the speed and the gauge's departure
    among them) into `out` (FORCE_ROWS x samples, every entry written): the last axis of the
    original shape is the wheelsets, sample k belongs to wheelset k % n. Rows: the fields of
    ContactForces, in order. A non-empty `geometry` is the wheelsets' contact table."""
    n = table.shape[1]
    profiled = geometry.shape[0] > 0
    for k in range(y.size):
        if profiled:
            forces = profiled_contact(
                geometry,
                table[:, k % n],
                law,
                falling,
                y[k],
                psi[k],
                y_dot[k],
                psi_dot[k],
                speed[k],
                load[k],
                moment[k],
                spin_inertia,
                True,
                gauge[k],
            )
        else:
            forces = wheelset_contact(
                table[:, k % n],
                law,
                flange,
                falling,
                y[k],
                psi[k],
                y_dot[k],
                psi_dot[k],
                speed[k],
                load[k],
                moment[k],
                nominal,
                spin_inertia,
                cone_gravity,
                True,
                gauge[k],
            )
        for row in range(5):
            out[row, k] = forces[row]
        out[5, k] = out[0, k] + out[1, k]
        out[6, k] = out[2, k] + out[3, k] + out[4, k]
        if forces[9] != 0.0:
            out[6, k] += forces[9]
        for row in range(5):
            out[7 + row, k] = forces[5 + row]
        out[12, k] = forces[10]
        out[13, k] = forces[11]


@numba.njit(cache=True, nogil=True)
def _kernel(
    table,
    geometry,
    law,
    flange,
    falling,
    y,
    psi,
    y_dot,
    psi_dot,
    speed,
    load,
    moment,
    nominal,
    spin_inertia,
    cone_gravity,
    gauge,
):
    """`_forces_into` a new array: where the contact library cannot be built (rail_mj.contact.creep)."""
    out = np.zeros((FORCE_ROWS, y.size))
    _forces_into(
        out,
        table,
        geometry,
        law,
        flange,
        falling,
        y,
        psi,
        y_dot,
        psi_dot,
        speed,
        load,
        moment,
        nominal,
        spin_inertia,
        cone_gravity,
        gauge,
    )
    return out


_VECTOR = numba.types.CPointer(numba.types.float64)
_INT = numba.types.int64
# The contact library's kernel (rail_mj.contact.creep, _C_SOURCE): `_forces_into` on the memory
# of numpy arrays, its flags as integers.
FORCES_SIGNATURE = numba.types.void(
    _VECTOR,  # out: FORCE_ROWS x size
    _VECTOR,  # table: ROWS x n
    _INT,  # n
    _VECTOR,  # geometry: rows x COLUMNS
    _INT,  # rows
    _INT,  # law
    _INT,  # flange
    _INT,  # falling
    _VECTOR,  # y, psi, y_dot, psi_dot, speed, load, moment: size each
    _VECTOR,
    _VECTOR,
    _VECTOR,
    _VECTOR,
    _VECTOR,
    _VECTOR,
    numba.types.float64,  # nominal
    numba.types.float64,  # spin_inertia
    _INT,  # cone_gravity
    _VECTOR,  # gauge: size
    _INT,  # size
)


def forces_cfunc():
    """numba's cfunc of `_forces_into` with FORCES_SIGNATURE, compiled when called."""

    @numba.cfunc(FORCES_SIGNATURE, nopython=True)
    def forces(
        out,
        table,
        n,
        geometry,
        rows,
        law,
        flange,
        falling,
        y,
        psi,
        y_dot,
        psi_dot,
        speed,
        load,
        moment,
        nominal,
        spin_inertia,
        cone_gravity,
        gauge,
        size,
    ):
        _forces_into(
            numba.carray(out, (FORCE_ROWS, size)),
            numba.carray(table, (ROWS, n)),
            numba.carray(geometry, (rows, _t.COLUMNS)),
            law,
            flange != 0,
            falling != 0,
            numba.carray(y, (size,)),
            numba.carray(psi, (size,)),
            numba.carray(y_dot, (size,)),
            numba.carray(psi_dot, (size,)),
            numba.carray(speed, (size,)),
            numba.carray(load, (size,)),
            numba.carray(moment, (size,)),
            nominal,
            spin_inertia,
            cone_gravity != 0,
            numba.carray(gauge, (size,)),
        )

    return forces
