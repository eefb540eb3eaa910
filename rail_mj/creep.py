"""Wheel-rail contact and creep: Kalker's linear law on coned wheels.

Pure numpy over arrays of wheelsets, apart from MuJoCo (the binding is
`rail_mj.forces`): one call serves every wheelset of every vehicle in a model,
it can be tested on its own, and it can later be compiled to native code.

Frames and signs are those of the reference sheet, section 1: y to the left,
psi positive nose-left, forces in the track frame.

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
from typing import NamedTuple

import numpy as np


# Creep laws, by the number the model stores (reference sheet, section 6).
LINEAR, SHEN_HEDRICK_ELKINS, POLACH = 0, 1, 2
LAWS = {"linear": LINEAR, "shen-hedrick-elkins": SHEN_HEDRICK_ELKINS, "polach": POLACH}


@dataclasses.dataclass(frozen=True)
class ContactParameters:
    """Contact geometry and Kalker coefficients, one entry per wheelset (arrays of shape (n,)),
    and the creep law with its friction limit mu*N per wheel."""

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
    flange_slope: np.ndarray  # tan of the flange angle: the radius rise per metre on the flange
    law: int = LINEAR
    flange: bool = False  # flange contact on

    @functools.cached_property
    def falling(self) -> bool:
        """Whether the law is Polach's with falling friction."""
        return self.law == POLACH and bool(np.any(self.falling_friction_ratio < 1.0))

    @classmethod
    def broadcast(cls, n: int, *, r0, b, conicity, f11, f22, f23=0.0, f33=0.0,
                  friction_limit=np.inf, falling_friction_ratio=1.0, falling_friction_rate=0.0,
                  law=LINEAR, clearance=0.008, flange_stiffness=0.0, flange_damping=0.0,
                  flange_slope=None):
        full = lambda v: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy()  # noqa: E731
        flange = flange_slope is not None
        return cls(full(r0), full(b), full(conicity), full(f11), full(f22), full(f23), full(f33),
                   full(friction_limit), full(falling_friction_ratio), full(falling_friction_rate),
                   full(clearance), full(flange_stiffness),
                   full(flange_damping), full(flange_slope if flange else conicity), int(law), flange)


def saturation(law: int, resultant, limit):
    """The saturated tangential force for a linear (Kalker) resultant, per wheel.

    Shen-Hedrick-Elkins: u = F/(mu*N), mu*N*(u - u^2/3 + u^3/27) for u < 3, mu*N beyond.
    Polach: eps = pi*F/(4*mu*N), which is his pi*G*a*b*c*s/(4*N*mu) with G*a*b*c*s the
    Kalker resultant; (2*mu*N/pi)*(eps/(1 + eps^2) + atan(eps)). With falling friction
    `limit` is mu(w)*N at each wheel's slip velocity (`friction_limits`).
    Both have Kalker's slope at zero, never exceed mu*N, and are continuous.
    """
    if law == LINEAR:
        return resultant
    u = np.minimum(resultant / limit, 1e100)  # far past saturation either way; no overflow
    if law == SHEN_HEDRICK_ELKINS:
        c = np.minimum(u, 3.0)
        return limit * (c - c**2 / 3.0 + c**3 / 27.0)  # = limit from u = 3 on
    if law == POLACH:
        eps = np.pi * u / 4.0
        return (2.0 * limit / np.pi) * (eps / (1.0 + eps**2) + np.arctan(eps))
    raise ValueError(f"unknown creep law {law}")


def on_flange(p: ContactParameters, y) -> bool:
    """Whether any wheelset is past its flangeway clearance (and flange contact is on)."""
    return p.flange and bool(np.any(np.abs(y) > p.clearance))


def rolling_radius_changes(p: ContactParameters, y, engaged: bool | None = None):
    """(r_left - r0, r_right - r0) for a wheelset displaced y to the left of the track.

    On the tread each wheel is a cone: +/-lam*y. Past the flangeway clearance the contact
    runs up the flanging wheel's flange, whose radius rises as tan(flange angle) per
    metre: the steep rise of the rolling-radius difference at flange contact.
    """
    tread = p.conicity * y
    if not (on_flange(p, y) if engaged is None else engaged):
        return tread, -tread
    rise = p.flange_slope - p.conicity
    return (tread + rise * np.maximum(y - p.clearance, 0.0),
            -tread + rise * np.maximum(-y - p.clearance, 0.0))


def flange_force(p: ContactParameters, y, y_dot, engaged: bool | None = None):
    """Lateral force (N) of the rails on each wheelset's flanges: zero within the
    flangeway clearance, beyond it an elastic rail (stiffness k, damping c) that
    only pushes: -sign(y) * max(0, k*(|y| - clearance) + c*|y|')."""
    if not (on_flange(p, y) if engaged is None else engaged):
        return np.zeros_like(y)
    over = np.abs(y) - p.clearance
    side = np.sign(y)
    push = np.maximum(p.flange_stiffness * over + p.flange_damping * side * y_dot, 0.0)
    return np.where(over > 0, -side * push, 0.0)


def creepages(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float,
              engaged: bool | None = None):
    """Creepages (reference sheet, section 2): (xi_x_left, xi_x_right, xi_y, xi_sp).

    On the tread xi_x_left = -(b*psi'/V) - lam*y/r0 and xi_x_right is its negative; the
    lateral creepage is the same on both wheels, and the spin differs between them only
    by the constant contact-angle term, which cancels between the two wheels.
    """
    dr_left, dr_right = rolling_radius_changes(p, y, engaged)
    turning = p.b * psi_dot / speed
    xi_y = y_dot / speed - psi
    return -turning - dr_left / p.r0, turning - dr_right / p.r0, xi_y, psi_dot / speed


def friction_limits(p: ContactParameters, slip_velocity):
    """mu*N at each wheel: Polach's (2005) falling friction mu0*((1 - A)*exp(-B*w) + A)
    at slip velocity w (m/s), which falls from mu0 at pure rolling towards A*mu0."""
    a = p.falling_friction_ratio
    return p.friction_limit * ((1.0 - a) * np.exp(-p.falling_friction_rate * slip_velocity) + a)


def _saturated(p: ContactParameters, fx, fy, limit):
    """Each wheel's (Fx, Fy) scaled together so that the resultant follows the creep law."""
    linear = np.hypot(fx, fy)
    scale = saturation(p.law, linear, limit) / np.maximum(linear, 1e-300)
    return scale * fx, scale * fy


class ContactForces(NamedTuple):
    """The rails' forces on each wheelset, by origin (arrays over wheelsets; N and N m)."""

    creep_lateral: np.ndarray  # Fy of both wheels' creep forces
    flange_lateral: np.ndarray  # the flange's lateral force, zero off the flange
    creep_couple: np.ndarray  # b*(Fx_right - Fx_left): the longitudinal creep forces' yaw moment
    spin_moment: np.ndarray  # 2*(f23*xi_y - f33*xi_sp): Kalker's spin moment, both wheels
    flange_moment: np.ndarray  # the flange force acting at the flange contact's lead

    @property
    def lateral(self):
        """Sigma Y: everything lateral, creep and flange."""
        return self.creep_lateral + self.flange_lateral

    @property
    def yaw(self):
        return self.creep_couple + self.spin_moment + self.flange_moment


def flange_lead(p: ContactParameters, y, psi):
    """Where the flange contact lies along the track ahead of the wheelset centre, m.

    A straight rail's surface normals have no longitudinal part, so the flange touches
    it where the yawed flange cone's normal has none either: at sin(theta) =
    tan(gamma)*tan(psi) ahead of the axle in the wheel's own plane (gamma: the flange
    angle). The wheel's centre itself sits b*psi behind the wheelset's, so in the track
    frame the left flange touches at psi*(r*tan(gamma) - b), r the contact radius (small
    angles), and the right one, by mirror symmetry, at -psi*(r*tan(gamma) - b). A wheelset
    yawed into the rail it strikes has its contact ahead, for a 70 degree flange
    (r*tan(gamma) = 1.26 m against b = 0.75 m): there the flange force turns it away.
    """
    radius = p.r0 + np.maximum(*rolling_radius_changes(p, y, True))  # the flanging wheel's
    return np.sign(y) * psi * (radius * p.flange_slope - p.b)


def contact_forces(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float) -> ContactForces:
    """The rails' forces on each wheelset, by origin: see `ContactForces`.

    Kalker per wheel: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp.
    A saturating law scales each wheel's (Fx, Fy) by one factor (the spin moment stays
    linear). The longitudinal forces, Fx_left at y = +b and Fx_right at y = -b, make the
    yaw moment b*(Fx_right - Fx_left). On the flange the rail adds its lateral force,
    applied at the contact's lead (`flange_lead`).
    """
    engaged = on_flange(p, y)  # decided once for the radii and the flange force
    xi_left, xi_right, xi_y, xi_sp = creepages(p, y, psi, y_dot, psi_dot, speed, engaged)
    fx = -p.f11 * np.stack([xi_left, xi_right])  # (2, n): left wheels, right wheels
    fy = -p.f22 * xi_y - p.f23 * xi_sp  # the same on both wheels
    if p.law == LINEAR:
        fy_sum = 2.0 * fy
    else:
        limit = p.friction_limit
        if p.falling:  # each wheel's slip velocity V*|(xi_x, xi_y)|, spin aside, as Polach
            limit = friction_limits(p, speed * np.hypot(np.stack([xi_left, xi_right]), xi_y))
        fx, fy = _saturated(p, fx, np.broadcast_to(fy, fx.shape), limit)
        fy_sum = fy[0] + fy[1]
    spin = 2.0 * (p.f23 * xi_y - p.f33 * xi_sp)
    if engaged:
        flange = flange_force(p, y, y_dot, engaged)
        flange_moment = flange * flange_lead(p, y, psi)
    else:
        flange = flange_moment = np.zeros_like(fy_sum)
    return ContactForces(fy_sum, flange, p.b * (fx[1] - fx[0]), spin, flange_moment)


def wheelset_forces(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float):
    """Lateral force Fy (N) and yaw moment Mz (N m) of the rails on each wheelset: the
    sums of `contact_forces`. On the tread, with the linear law and f23 = f33 = 0, this is
    exactly

        Fy = -2*f22*(y_dot/V - psi),   Mz = -2*f11*b*(b*psi_dot/V + lam*y/r0).
    """
    f = contact_forces(p, y, psi, y_dot, psi_dot, speed)
    return f.lateral, f.yaw
