"""Wheel-rail contact and creep: Kalker's law on coned wheels, saturation, flanges.

One wheelset at a time, written as plain scalar arithmetic and compiled with numba
(the per-step force callback calls it four times a step: numpy's per-operation cost
on arrays of a few wheelsets was most of a step). Independent of MuJoCo (the binding
is `rail_mj.forces`), it takes arrays of any shape whose last axis is the wheelsets:
one call serves every wheelset of a model at one instant, or a whole run's samples.

Frames and signs are those of docs/frames.md: y to the left, psi positive
nose-left, forces in the track frame. The physics is in docs/creep.md and docs/flange.md.

Example:

    >>> import numpy as np
    >>> from rail_mj.creep import ContactParameters, wheelset_forces
    >>> p = ContactParameters.broadcast(1, r0=0.46, b=0.75, conicity=0.15, f11=10e6, f22=9e6)
    >>> Fy, Mz = wheelset_forces(p, np.array([0.003]), np.zeros(1), np.zeros(1), np.zeros(1), 30.0)
    >>> round(float(Mz[0]), 6)   # -2*f11*b*lam*y/r0: yaws the displaced wheelset back (nose-right)
    -14673.913043
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import NamedTuple

import numba
import numpy as np

from rail_mj import tables as _t
from rail_mj.layout import LAWS, LINEAR, POLACH, SHEN_HEDRICK_ELKINS  # noqa: F401  (re-exported)


@dataclasses.dataclass(frozen=True)
class ContactParameters:
    """Contact geometry and Kalker coefficients, one entry per wheelset (arrays of shape (n,)),
    the creep law with its friction limit mu*N per wheel and Polach's falling friction,
    and the flange contact."""

    r0: np.ndarray  # rolling radius, m
    b: np.ndarray  # half the distance between the contact points, m
    conicity: np.ndarray  # effective conicity lam
    f11: np.ndarray  # N
    f22: np.ndarray  # N
    f23: np.ndarray  # N m
    f33: np.ndarray  # N m^2
    friction_limit: np.ndarray  # mu*N per wheel, N (unused by the linear law)
    falling_friction_ratio: np.ndarray  # Polach's A = mu_infinity/mu0; 1: no falling friction
    falling_friction_rate: np.ndarray  # Polach's B, s/m
    clearance: np.ndarray  # flangeway clearance, m
    flange_stiffness: np.ndarray  # N/m, the rail's lateral stiffness under the flange
    flange_damping: np.ndarray  # N s/m
    flange_slope: np.ndarray  # tan(flange angle), the radius rise per metre on the flange; lam if no flange
    law: int = LINEAR
    flange: bool = False  # flange contact on
    # A profiled wheelset's contact table (rail_mj.tables); empty: coned wheels.
    geometry: np.ndarray = dataclasses.field(default_factory=lambda: NO_GEOMETRY)

    @functools.cached_property
    def falling(self) -> bool:
        """Whether the law is Polach's with falling friction (only a shortcut: with A = 1
        `falling_friction` returns mu0*N anyway)."""
        return self.law == POLACH and bool(np.any(self.falling_friction_ratio < 1.0))

    @functools.cached_property
    def table(self) -> np.ndarray:
        """The per-wheelset numbers as rows of one array, for the compiled kernel."""
        return np.ascontiguousarray(np.stack([getattr(self, name) for name in _ROWS]))

    @classmethod
    def broadcast(cls, n: int, *, r0, b, conicity, f11, f22, f23=0.0, f33=0.0,
                  friction_limit=np.inf, falling_friction_ratio=1.0, falling_friction_rate=0.0,
                  law=LINEAR, clearance=0.008, flange_stiffness=0.0, flange_damping=0.0,
                  flange_slope=None, geometry=None):
        full = lambda v: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy()  # noqa: E731
        flange = flange_slope is not None
        return cls(full(r0), full(b), full(conicity), full(f11), full(f22), full(f23), full(f33),
                   full(friction_limit), full(falling_friction_ratio), full(falling_friction_rate),
                   full(clearance), full(flange_stiffness),
                   full(flange_damping), full(flange_slope if flange else conicity), int(law), flange,
                   NO_GEOMETRY if geometry is None else np.ascontiguousarray(geometry, dtype=np.float64))


NO_GEOMETRY = np.zeros((0, _t.COLUMNS))

# The rows of ContactParameters.table, in order.
_ROWS = ("r0", "b", "conicity", "f11", "f22", "f23", "f33", "friction_limit", "falling_friction_ratio",
         "falling_friction_rate", "clearance", "flange_stiffness", "flange_damping", "flange_slope")
(_R0, _B, _LAM, _F11, _F22, _F23, _F33, _LIMIT, _FALL_RATIO, _FALL_RATE, _CLEARANCE, _K_FLANGE,
 _C_FLANGE, _SLOPE) = range(len(_ROWS))
ROWS = len(_ROWS)


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


class ContactForces(NamedTuple):
    """The rails' forces on each wheelset, by origin: arrays shaped like the states, the
    last axis the wheelsets; N and N m."""

    creep_lateral: np.ndarray  # Fy of both wheels' creep forces
    flange_lateral: np.ndarray  # the flange's lateral force, zero off the flange
    creep_couple: np.ndarray  # b*(Fx_right - Fx_left): the longitudinal creep forces' yaw moment
    spin_moment: np.ndarray  # Kalker's f23*xi_y - f33*xi_sp of both wheels, saturated as their forces
    flange_moment: np.ndarray  # the flange force acting at the flange contact's lead
    lateral: np.ndarray  # Sigma Y: everything lateral, creep and flange
    yaw: np.ndarray  # every yaw moment


@numba.njit(cache=True)
def _saturation_factor(law, fx, fy, limit):
    """The factor that scales a wheel's linear (Fx, Fy) onto the creep law's resultant:
    1 at zero, where every law has Kalker's slope."""
    linear = math.hypot(fx, fy)
    return 1.0 if linear == 0.0 else _saturation(law, linear, limit) / linear


@numba.njit(cache=True)
def wheelset_contact(p, law, flange, falling, y, psi, y_dot, psi_dot, speed):
    """The rails' forces on one wheelset, by origin: (creep lateral, flange lateral, creep
    couple, spin moment, flange moment), N and N m (see `ContactForces`). `p`: its column
    of `ContactParameters.table`. The one implementation of the contact law: the array
    kernel below and the native passive-force callback (rail_mj.native) both call it."""
    # Creepages (docs/creep.md): on the tread xi_x_left = -(b*psi'/V) - lam*y/r0 and
    # xi_x_right is its negative; the lateral creepage is the same on both wheels, and the
    # spin differs between them only by the constant contact-angle term, which cancels
    # between the two wheels' linear forces and is left out. Without flange contact
    # flange_slope is the conicity: no rise.
    rise_left = _radius_rise(y, p[_LAM], p[_SLOPE], p[_CLEARANCE])
    rise_right = _radius_rise(-y, p[_LAM], p[_SLOPE], p[_CLEARANCE])
    turning = p[_B] * psi_dot / speed
    xi_left = -turning - rise_left / p[_R0]
    xi_right = turning - rise_right / p[_R0]
    xi_y = y_dot / speed - psi
    xi_sp = psi_dot / speed
    # Kalker per wheel: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp.
    fx_left, fx_right = -p[_F11] * xi_left, -p[_F11] * xi_right
    fy, mz = -p[_F22] * xi_y - p[_F23] * xi_sp, p[_F23] * xi_y - p[_F33] * xi_sp
    scale_left = scale_right = 1.0
    if law != LINEAR:
        limit_left = limit_right = p[_LIMIT]
        if falling:  # each wheel's slip velocity V*|(xi_x, xi_y)|, spin aside, as Polach
            limit_left = _falling_friction(p[_LIMIT], p[_FALL_RATIO], p[_FALL_RATE],
                                           speed * math.hypot(xi_left, xi_y))
            limit_right = _falling_friction(p[_LIMIT], p[_FALL_RATIO], p[_FALL_RATE],
                                            speed * math.hypot(xi_right, xi_y))
        # Fx, Fy and the spin moment of a wheel all saturate by one factor (a common
        # simplification: Kalker's full theory saturates the moment its own way).
        scale_left = _saturation_factor(law, fx_left, fy, limit_left)
        scale_right = _saturation_factor(law, fx_right, fy, limit_right)
    creep_lateral = (scale_left + scale_right) * fy
    couple = p[_B] * (scale_right * fx_right - scale_left * fx_left)  # Fx_left at y = +b
    spin = (scale_left + scale_right) * mz
    flange_lateral = flange_moment = 0.0
    if flange:
        flange_lateral = _flange_force(y, y_dot, p[_CLEARANCE], p[_K_FLANGE], p[_C_FLANGE])
        if flange_lateral != 0.0:
            radius = p[_R0] + max(rise_left, rise_right)  # the flanging wheel's
            flange_moment = flange_lateral * _flange_lead(y, psi, radius, p[_SLOPE], p[_B])
    return creep_lateral, flange_lateral, couple, spin, flange_moment


@numba.njit(cache=True)
def profiled_contact(geo, p, law, falling, y, psi, y_dot, psi_dot, speed):
    """The rails' forces on one wheelset on profiles, by origin as `wheelset_contact` gives
    them: (creep lateral, normal lateral, creep couple, spin moment, lead moment). `geo`:
    its contact table (rail_mj.tables), interpolated linearly in y and held at its last row
    beyond (the runner stops a wheelset that leaves it); `p`: its column of
    ContactParameters.table, for the falling-friction constants. docs/dynamics-on-profiles.md.

    Per contact point k of side s (+1 left, -1 right), load share w, radius r, contact
    angle g (leaning towards the track centre), lateral lever l:
      normal loads from the wheelset's vertical and roll equilibrium under the axle load W:
        N_L*V_L + N_R*V_R = W,  N_L*M_L + N_R*M_R = 0,
        V = sum w*cos(g),  M = sum w*(l*cos(g) - s*r*sin(g)),
      a wheel that would need to pull on its rail carries nothing (it lifts);
      creepages xi_x = (r0 - r)/r0 - l*psi'/V, xi_y = y'/(V*cos g) - psi*cos g (the slip
        the rigid contact allows lies in the contact plane), spin = psi'*cos(g)/V - s*sin(g)/r;
      Kalker's law with this point's ellipse at its load (a, b grow as N^(1/3)), saturated;
      the normal force's lateral part -s*N*sin(g): gravitational stiffness and the flange.
    The table's header switches gravitational stiffness and spin creep (f23 = f33 = 0) off.
    """
    y0, dy, rows = geo[0, _t.HEADER_Y0], geo[0, _t.HEADER_DY], int(geo[0, _t.HEADER_ROWS])
    axle_load, shear = geo[0, _t.HEADER_AXLE_LOAD], geo[0, _t.HEADER_SHEAR_MODULUS]
    mu, r0 = geo[0, _t.HEADER_FRICTION], geo[0, _t.HEADER_R0]
    gravity, spinning = geo[0, _t.HEADER_GRAVITY] != 0.0, geo[0, _t.HEADER_SPIN] != 0.0
    u = min(max((y - y0) / dy, 0.0), rows - 1.0)
    i = min(int(u), rows - 2)
    t = u - i
    lo, hi = geo[1 + i], geo[2 + i]
    # Vertical and roll equilibrium.
    v_left = v_right = m_left = m_right = 0.0
    for side in range(2):
        s = 1.0 - 2.0 * side
        for slot in range(_t.SLOTS):
            c = _t.FIRST_POINT + (side * _t.SLOTS + slot) * _t.POINT
            w = lo[c + _t.WEIGHT] + t * (hi[c + _t.WEIGHT] - lo[c + _t.WEIGHT])
            r = r0 + lo[c + _t.RADIUS] + t * (hi[c + _t.RADIUS] - lo[c + _t.RADIUS])
            g = lo[c + _t.ANGLE] + t * (hi[c + _t.ANGLE] - lo[c + _t.ANGLE])
            lever = lo[c + _t.LEVER] + t * (hi[c + _t.LEVER] - lo[c + _t.LEVER])
            v = w * math.cos(g)
            m = w * (lever * math.cos(g) - s * r * math.sin(g))
            if side == 0:
                v_left += v
                m_left += m
            else:
                v_right += v
                m_right += m
    det = v_left * m_right - v_right * m_left
    n_left, n_right = axle_load * m_right / det, -axle_load * m_left / det
    if n_right < 0.0:
        n_left, n_right = axle_load / v_left, 0.0
    elif n_left < 0.0:
        n_left, n_right = 0.0, axle_load / v_right
    creep_lateral = normal_lateral = couple = spin = lead_moment = 0.0
    for side in range(2):
        s = 1.0 - 2.0 * side
        wheel = n_left if side == 0 else n_right
        for slot in range(_t.SLOTS):
            c = _t.FIRST_POINT + (side * _t.SLOTS + slot) * _t.POINT
            normal = wheel * (lo[c + _t.WEIGHT] + t * (hi[c + _t.WEIGHT] - lo[c + _t.WEIGHT]))
            if normal <= 0.0:
                continue
            rise = lo[c + _t.RADIUS] + t * (hi[c + _t.RADIUS] - lo[c + _t.RADIUS])
            r = r0 + rise
            g = lo[c + _t.ANGLE] + t * (hi[c + _t.ANGLE] - lo[c + _t.ANGLE])
            lever = lo[c + _t.LEVER] + t * (hi[c + _t.LEVER] - lo[c + _t.LEVER])
            cube = normal ** (1.0 / 3.0)
            a = cube * (lo[c + _t.SEMI_A] + t * (hi[c + _t.SEMI_A] - lo[c + _t.SEMI_A]))
            b = cube * (lo[c + _t.SEMI_B] + t * (hi[c + _t.SEMI_B] - lo[c + _t.SEMI_B]))
            ab = a * b
            f11 = shear * ab * (lo[c + _t.C11] + t * (hi[c + _t.C11] - lo[c + _t.C11]))
            f22 = shear * ab * (lo[c + _t.C22] + t * (hi[c + _t.C22] - lo[c + _t.C22]))
            f23 = f33 = 0.0
            if spinning:
                f23 = shear * ab * math.sqrt(ab) * (lo[c + _t.C23] + t * (hi[c + _t.C23] - lo[c + _t.C23]))
                f33 = shear * ab * ab * (lo[c + _t.C33] + t * (hi[c + _t.C33] - lo[c + _t.C33]))
            cos_g, sin_g = math.cos(g), math.sin(g)
            xi_x = -rise / r0 - lever * psi_dot / speed
            xi_y = y_dot / (speed * cos_g) - psi * cos_g
            xi_sp = psi_dot * cos_g / speed - s * sin_g / r
            fx = -f11 * xi_x
            fy = -f22 * xi_y - f23 * xi_sp
            mz = f23 * xi_y - f33 * xi_sp
            scale = 1.0
            if law != LINEAR:
                limit = mu * normal
                if falling:
                    limit = _falling_friction(limit, p[_FALL_RATIO], p[_FALL_RATE], speed * math.hypot(xi_x, xi_y))
                scale = _saturation_factor(law, fx, fy, limit)
            lateral = scale * fy * cos_g
            pushed = -s * normal * sin_g if gravity else 0.0
            creep_lateral += lateral
            normal_lateral += pushed
            couple -= lever * scale * fx
            spin += scale * mz * cos_g
            # Where the point lies along the track: a yawed wheel touches a straight rail
            # ahead of its axle by r*tan(g) (see _flange_lead), its centre sits l*psi behind.
            lead_moment += psi * (s * r * math.tan(g) - lever) * (lateral + pushed)
    return creep_lateral, normal_lateral, couple, spin, lead_moment


@numba.njit(cache=True)
def _kernel(table, geometry, law, flange, falling, y, psi, y_dot, psi_dot, speed):
    """`contact_forces` over flat, contiguous state arrays: the last axis of the original
    shape is the wheelsets, sample k belongs to wheelset k % n. Rows: the fields of
    ContactForces, in order. A non-empty `geometry` is the wheelsets' contact table."""
    n = table.shape[1]
    out = np.zeros((7, y.size))
    profiled = geometry.shape[0] > 0
    for k in range(y.size):
        if profiled:
            forces = profiled_contact(geometry, table[:, k % n], law, falling, y[k], psi[k], y_dot[k],
                                      psi_dot[k], speed)
        else:
            forces = wheelset_contact(table[:, k % n], law, flange, falling, y[k], psi[k], y_dot[k],
                                      psi_dot[k], speed)
        for row in range(5):
            out[row, k] = forces[row]
        out[5, k] = out[0, k] + out[1, k]
        out[6, k] = out[2, k] + out[3, k] + out[4, k]
    return out


def _evaluate(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float):
    """The kernel's rows, each shaped like the states."""
    shape = np.shape(y)
    flat = [np.ascontiguousarray(v, dtype=np.float64).reshape(-1) for v in (y, psi, y_dot, psi_dot)]
    return _kernel(p.table, p.geometry, p.law, p.flange, p.falling, *flat, float(speed)).reshape((7,) + shape)


def contact_forces(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float) -> ContactForces:
    """The rails' forces on each wheelset, by origin: see `ContactForces`. States are
    arrays of one shape whose last axis is the wheelsets.

    Kalker per wheel: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp.
    A saturating law scales each wheel's Fx, Fy and Mz by one factor, which brings the
    resultant of (Fx, Fy) onto the law. The longitudinal forces, Fx_left at y = +b and Fx_right at y = -b, make the
    yaw moment b*(Fx_right - Fx_left). On the flange the rail adds its lateral force,
    applied at the contact's lead (`flange_lead`).
    """
    return ContactForces(*_evaluate(p, y, psi, y_dot, psi_dot, speed))


def wheelset_forces(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float):
    """Lateral force Fy (N) and yaw moment Mz (N m) of the rails on each wheelset: the
    sums of `contact_forces`. On the tread, with the linear law and f23 = f33 = 0, this is
    exactly

        Fy = -2*f22*(y_dot/V - psi),   Mz = -2*f11*b*(b*psi_dot/V + lam*y/r0).
    """
    rows = _evaluate(p, y, psi, y_dot, psi_dot, speed)
    return rows[5], rows[6]
