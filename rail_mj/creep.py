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
    law: int = LINEAR

    @classmethod
    def broadcast(cls, n: int, *, r0, b, conicity, f11, f22, f23=0.0, f33=0.0,
                  friction_limit=np.inf, law=LINEAR):
        full = lambda v: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy()  # noqa: E731
        return cls(full(r0), full(b), full(conicity), full(f11), full(f22), full(f23), full(f33),
                   full(friction_limit), int(law))


def saturation(law: int, resultant, limit):
    """The saturated tangential force for a linear (Kalker) resultant, per wheel.

    Shen-Hedrick-Elkins: u = F/(mu*N), mu*N*(u - u^2/3 + u^3/27) for u < 3, mu*N beyond.
    Polach (no falling friction): eps = pi*F/(4*mu*N), which is his pi*G*a*b*c*s/(4*N*mu)
    with G*a*b*c*s the Kalker resultant; (2*mu*N/pi)*(eps/(1 + eps^2) + atan(eps)).
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


def creepages(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float):
    """Creepages of the left wheel (reference sheet, section 2).

    Returns (xi_x_left, xi_y, xi_sp_left). The right wheel has -xi_x_left, the same
    xi_y, and a spin that differs only by the constant contact-angle term, which
    cancels between the two wheels.
    """
    xi_x = -(p.b * psi_dot / speed) - p.conicity * y / p.r0
    xi_y = y_dot / speed - psi
    xi_sp = psi_dot / speed
    return xi_x, xi_y, xi_sp


def wheelset_forces(p: ContactParameters, y, psi, y_dot, psi_dot, speed: float):
    """Lateral force Fy (N) and yaw moment Mz (N m) of the rails on each wheelset.

    Kalker per wheel: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp.
    A saturating law scales each wheel's (Fx, Fy) by one factor (the spin moment stays
    linear). The longitudinal forces of the two wheels, +/-Fx at y = +/-b, make the yaw
    moment -2*b*Fx_left. With the linear law and f23 = f33 = 0 this is exactly

        Fy = -2*f22*(y_dot/V - psi),   Mz = -2*f11*b*(b*psi_dot/V + lam*y/r0).
    """
    xi_x, xi_y, xi_sp = creepages(p, y, psi, y_dot, psi_dot, speed)
    fx_left = -p.f11 * xi_x
    fy_wheel = -p.f22 * xi_y - p.f23 * xi_sp  # the same on both wheels
    if p.law != LINEAR:
        # Both wheels carry the same resultant here (+/-Fx, equal Fy): one factor serves.
        linear = np.hypot(fx_left, fy_wheel)
        scale = np.divide(saturation(p.law, linear, p.friction_limit), linear,
                          out=np.ones_like(linear), where=linear > 0)
        fx_left, fy_wheel = scale * fx_left, scale * fy_wheel
    fy = 2.0 * fy_wheel
    mz = -2.0 * p.b * fx_left + 2.0 * (p.f23 * xi_y - p.f33 * xi_sp)
    return fy, mz
