"""Wheel-rail contact from the bodies in contact: Hertz's ellipse and Kalker's coefficients.

See docs/contact.md. Pure functions of numbers, no MuJoCo: the layout uses
them to turn Young's modulus, Poisson's ratio, the radii and the wheel load into
the creep coefficients f11, f22, f23, f33.

Example (the reference case: a 10 t wheel, r 0.46 m, conical tread, rail head 0.30 m):

    >>> c = contact_patch(98.1e3, 0.46, 0.30, young_modulus=210e9, poisson_ratio=0.28)
    >>> round(float(c.a) * 1e3, 2), round(float(c.b) * 1e3, 2), round(float(c.p0) / 1e6)
    (7.15, 5.38, 1219)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

# Kalker's creep coefficients (J. J. Kalker, 1967; docs/contact.md): rows by
# semi-axis ratio, columns Poisson's ratio 0, 0.25, 0.5. `a` is the semi-axis along
# the rolling direction. The rows run a/b = 0.1 ... 1.0, then b/a = 0.9 ... 0.1; they
# are indexed here by s = a/b for a <= b and s = 2 - b/a for a > b, one axis 0.1-1.9.
# Longer ellipses than a/b = 10 (a flange's) take Kalker's asymptotes: `slender_coefficients`.
KALKER_S = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9])
KALKER_NU = (0.0, 0.25, 0.5)
KALKER = {  # name -> (19 rows, 3 columns)
    "C11": np.array(
        [
            [2.51, 3.31, 4.85],
            [2.59, 3.37, 4.81],
            [2.68, 3.44, 4.80],
            [2.78, 3.53, 4.82],
            [2.88, 3.62, 4.83],
            [2.98, 3.72, 4.91],
            [3.09, 3.81, 4.97],
            [3.19, 3.91, 5.05],
            [3.29, 4.01, 5.12],
            [3.40, 4.12, 5.20],
            [3.51, 4.22, 5.30],
            [3.65, 4.36, 5.42],
            [3.82, 4.54, 5.58],
            [4.06, 4.78, 5.80],
            [4.37, 5.10, 6.11],
            [4.84, 5.57, 6.57],
            [5.57, 6.34, 7.34],
            [6.96, 7.78, 8.82],
            [10.7, 11.7, 12.9],
        ]
    ),
    "C22": np.array(
        [
            [2.51, 2.52, 2.53],
            [2.59, 2.63, 2.66],
            [2.68, 2.75, 2.81],
            [2.78, 2.88, 2.98],
            [2.88, 3.01, 3.14],
            [2.98, 3.14, 3.31],
            [3.09, 3.28, 3.48],
            [3.19, 3.41, 3.65],
            [3.29, 3.54, 3.82],
            [3.40, 3.67, 3.98],
            [3.51, 3.81, 4.16],
            [3.65, 3.99, 4.39],
            [3.82, 4.21, 4.67],
            [4.06, 4.50, 5.04],
            [4.37, 4.90, 5.56],
            [4.84, 5.48, 6.31],
            [5.57, 6.40, 7.51],
            [6.96, 8.14, 9.79],
            [10.7, 12.8, 16.0],
        ]
    ),
    "C23": np.array(
        [
            [0.334, 0.473, 0.731],
            [0.483, 0.603, 0.809],
            [0.607, 0.715, 0.889],
            [0.720, 0.823, 0.977],
            [0.827, 0.929, 1.07],
            [0.930, 1.03, 1.18],
            [1.03, 1.14, 1.29],
            [1.13, 1.25, 1.40],
            [1.23, 1.36, 1.51],
            [1.33, 1.47, 1.63],
            [1.44, 1.59, 1.77],
            [1.58, 1.75, 1.94],
            [1.76, 1.95, 2.18],
            [2.01, 2.23, 2.50],
            [2.35, 2.62, 2.96],
            [2.88, 3.24, 3.70],
            [3.79, 4.32, 5.01],
            [5.72, 6.63, 7.89],
            [12.2, 14.6, 18.0],
        ]
    ),
    "C33": np.array(
        [
            [6.42, 8.28, 11.7],
            [3.46, 4.27, 5.66],
            [2.49, 2.96, 3.72],
            [2.02, 2.32, 2.77],
            [1.74, 1.93, 2.22],
            [1.56, 1.68, 1.86],
            [1.43, 1.50, 1.60],
            [1.34, 1.37, 1.42],
            [1.27, 1.27, 1.27],
            [1.21, 1.19, 1.16],
            [1.16, 1.11, 1.06],
            [1.10, 1.04, 0.95],
            [1.05, 0.97, 0.85],
            [1.01, 0.89, 0.75],
            [0.96, 0.82, 0.65],
            [0.91, 0.75, 0.55],
            [0.87, 0.67, 0.45],
            [0.83, 0.60, 0.34],
            [0.80, 0.53, 0.23],
        ]
    ),
}


class ContactError(ValueError):
    """Contact data that gives no ellipse Kalker's table covers."""


@dataclasses.dataclass(frozen=True)
class ContactPatch:
    """A Hertz contact ellipse and the Kalker creep coefficients that go with it."""

    normal_load: float  # N
    a: float  # m, semi-axis along the rolling direction
    b: float  # m, semi-axis across it
    p0: float  # Pa, peak pressure
    C: dict  # C11, C22, C23, C33 (dimensionless)
    shear_modulus: float  # Pa

    @property
    def creep_coefficients(self) -> dict:
        """f11, f22 (N), f23 (N m), f33 (N m^2): G*ab*C11, G*ab*C22, G*(ab)^1.5*C23, G*(ab)^2*C33."""
        ab, G = self.a * self.b, self.shear_modulus
        return {
            "f11": float(G * ab * self.C["C11"]),
            "f22": float(G * ab * self.C["C22"]),
            "f23": float(G * ab**1.5 * self.C["C23"]),
            "f33": float(G * ab**2 * self.C["C33"]),
        }

    def as_dict(self) -> dict:
        return {
            "normal_load_n": self.normal_load,
            "a_m": self.a,
            "b_m": self.b,
            "a_over_b": self.a / self.b,
            "peak_pressure_pa": self.p0,
            **self.C,
            **self.creep_coefficients,
        }


def _curvature(radius: float | None) -> float:
    return 0.0 if radius is None or math.isinf(radius) else 1.0 / radius


def hertz_ellipse(
    normal_load: float,
    curvature_sum_rolling: float,
    curvature_sum_lateral: float,
    young_modulus: float,
    poisson_ratio: float,
) -> tuple[float, float]:
    """Semi-axes (a along the rolling direction, b across), m, of the Hertz ellipse.

    With A the curvature sum along the rolling direction and B across, the longer
    semi-axis lies along the flatter direction. Its eccentricity e solves
    B/A = ((a/b)^2*E(e) - K(e)) / (K(e) - E(e)) (A < B), and
    a^3 = 3*N*(K - E) / (2*pi*E* * A * e^2), E* = E / (2*(1 - nu^2)).
    """
    A, B = curvature_sum_rolling, curvature_sum_lateral
    if not (A > 0 and B > 0):
        raise ContactError("both curvature sums must be positive: some radius must be finite")
    swap = A > B
    small, large = (B, A) if swap else (A, B)
    estar = young_modulus / (2.0 * (1.0 - poisson_ratio**2))

    def ratio(m: float) -> float:  # m = e^2, scipy's parameter
        K, E = ellipk(m), ellipe(m)
        return (E / (1.0 - m) - K) / (K - E) - large / small

    if large / small < 1.0 + 1e-9:  # a circle: (K - E)/e^2 -> pi/4
        m, k_minus_e_over_m = 0.0, math.pi / 4
    else:
        m = brentq(ratio, 1e-12, 1.0 - 1e-15, xtol=1e-15, rtol=1e-14)
        k_minus_e_over_m = (ellipk(m) - ellipe(m)) / m
    longer = (3.0 * normal_load * k_minus_e_over_m / (2.0 * math.pi * estar * small)) ** (1 / 3)
    shorter = longer * math.sqrt(1.0 - m)
    return (float(shorter), float(longer)) if swap else (float(longer), float(shorter))


def kalker_coefficients(a_over_b: float, poisson_ratio: float) -> dict:
    """C11, C22, C23, C33 from Kalker's table: linear in the semi-axis ratio between rows,
    and 1/C quadratic in nu through the three columns (docs/contact.md). Beyond the table's
    slender end, a/b > 10 (a flange's patch), C11, C22 and C23 follow Kalker's asymptotic
    expressions for b/a -> 0, joined continuously to the table (`slender_coefficients`)."""
    if a_over_b > SLENDER:
        return slender_coefficients(a_over_b, poisson_ratio)
    s = a_over_b if a_over_b <= 1.0 else 2.0 - 1.0 / a_over_b
    if not KALKER_S[0] <= s <= KALKER_S[-1]:
        raise ContactError(
            f"contact ellipse a/b = {a_over_b:.3g} is outside Kalker's table, which starts at a/b = 0.1 "
            f"(ten times wider across the rolling direction than along it)"
        )
    nu = poisson_ratio
    # Lagrange weights on 1/C at nu = 0, 0.25, 0.5.
    weights = np.array([8 * (nu - 0.25) * (nu - 0.5), -16 * nu * (nu - 0.5), 8 * nu * (nu - 0.25)])
    out = {}
    for name, table in KALKER.items():
        inverse = [np.interp(s, KALKER_S, 1.0 / table[:, k]) for k in range(3)]
        out[name] = float(1.0 / (weights @ np.array(inverse)))
    return out


# The table's slender end: a/b = 10 (its last row, b/a = 0.1).
SLENDER = 10.0


def kalker_asymptotes(b_over_a: float, poisson_ratio: float) -> dict:
    """Kalker's asymptotic C11, C22, C23 of a slender ellipse, long along the rolling
    direction, as g = b/a -> 0 (with his table of the coefficients, Kalker 1990; CONTACT's
    `linrol` evaluates the same beyond the table), with Lambda = ln(16/g^2):

        C11 = 2*pi/((Lambda - 2*nu)*g) * (1 + (3 - ln 4)/(Lambda - 2*nu))
        C22 = 2*pi/(((1 - nu)*Lambda + 2*nu)*g) * (1 + (1 - nu)*(3 - ln 4)/((1 - nu)*Lambda + 2*nu))
        C23 = 2*pi/(3*g^(3/2)*((1 - nu)*Lambda - 2 + 4*nu))
    """
    g, nu = b_over_a, poisson_ratio
    big = math.log(16.0 / (g * g))
    s, w = big - 2.0 * nu, (1.0 - nu) * big + 2.0 * nu
    c = 3.0 - math.log(4.0)
    return {
        "C11": 2.0 * math.pi / (s * g) * (1.0 + c / s),
        "C22": 2.0 * math.pi / (w * g) * (1.0 + (1.0 - nu) * c / w),
        "C23": 2.0 * math.pi / (3.0 * g**1.5 * ((1.0 - nu) * big - 2.0 + 4.0 * nu)),
    }


def slender_coefficients(a_over_b: float, poisson_ratio: float) -> dict:
    """C11..C33 of an ellipse longer than the table's a/b = 10 (docs/contact.md, "Slender
    ellipses"). C11, C22, C23: Kalker's asymptotes (`kalker_asymptotes`) times a factor that
    joins them to the table at a/b = 10 and fades to 1 as b/a -> 0,

        C = C_asymptote(g) * (1 + e*(Lambda(0.1)/Lambda(g))^2),   e = C_table(10)/C_asymptote(0.1) - 1

    (e: +3.8 %, +2.3 %, +0.01 % for C11, C22, C23 at nu = 0.28; the expansions leave out terms of
    relative order 1/Lambda^2). C33 keeps the table's a/b = 10 value: no asymptote for it is used
    here (CONTACT's `linrol` carries none), and a flange patch's spin moment f33*phi, its (a*b)^2
    small, is a negligible part of the wheelset's yaw moment."""
    edge = kalker_coefficients(SLENDER, poisson_ratio)
    at_edge = kalker_asymptotes(1.0 / SLENDER, poisson_ratio)
    g = 1.0 / a_over_b
    here = kalker_asymptotes(g, poisson_ratio)
    fade = (math.log(16.0 * SLENDER**2) / math.log(16.0 / (g * g))) ** 2
    out = {name: here[name] * (1.0 + (edge[name] / at_edge[name] - 1.0) * fade) for name in here}
    out["C33"] = edge["C33"]
    return out


def contact_patch(
    normal_load: float,
    wheel_rolling_radius: float,
    rail_transverse_radius: float,
    *,
    young_modulus: float,
    poisson_ratio: float,
    wheel_transverse_radius: float | None = None,
    rail_longitudinal_radius: float | None = None,
) -> ContactPatch:
    """Hertz ellipse and Kalker coefficients of a wheel on a rail (same material).

    Curvature sums: A = (1/R_wheel_rolling + 1/R_rail_longitudinal)/2,
    B = (1/R_wheel_transverse + 1/R_rail_transverse)/2; None or inf is a flat direction
    (a conical tread across, a straight rail along).
    """
    A = (_curvature(wheel_rolling_radius) + _curvature(rail_longitudinal_radius)) / 2
    B = (_curvature(wheel_transverse_radius) + _curvature(rail_transverse_radius)) / 2
    a, b = hertz_ellipse(normal_load, A, B, young_modulus, poisson_ratio)
    return ellipse_patch(
        normal_load, a, b, shear_modulus=young_modulus / (2.0 * (1.0 + poisson_ratio)), poisson_ratio=poisson_ratio
    )


def ellipse_patch(
    normal_load: float, a: float, b: float, *, shear_modulus: float, poisson_ratio: float
) -> ContactPatch:
    """The contact patch of a given ellipse (a along the rolling direction, b across, m):
    Kalker's coefficients at a/b and nu, Hertz's peak pressure 3*N/(2*pi*a*b)."""
    C = kalker_coefficients(a / b, poisson_ratio)
    return ContactPatch(normal_load, a, b, 3.0 * normal_load / (2.0 * math.pi * a * b), C, shear_modulus)
