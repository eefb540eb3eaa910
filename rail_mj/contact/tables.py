"""Contact tables: a profiled wheelset's contact, ready for the compiled creep law.

`rail_mj.contact.geometry` finds where a rigid wheelset touches its rails at each lateral shift y.
This module turns that into one array the compiled law (`rail_mj.contact.creep.profiled_contact`)
interpolates at every step: per row y, the roll, and per wheel two contact slots, each
following one contact point across the rows, with its share of the wheel's load, rolling
radius, contact angle, lateral lever, and the Hertz ellipse and Kalker coefficients of that
point per unit load. The physics is in docs/dynamics-on-profiles.md.

Two switches in the header keep the classical planar law reachable: gravitational stiffness
(the normal forces' lateral parts) and spin creep (with it off, f23 = f33 = 0).

Why two slots: a wheel may touch its rail at two points at once, where the elastic approach
of wheel and rail (~0.07 mm at 50 kN) closes a second rigid gap (the centred S1002 on 60E1
stands on two tread points); the load is then shared as Hertz's law shares it, N_k as
(approach_k)^(3/2). And where the contact jumps across the wheel (tread to flange root),
the point left behind and the point reached are in different slots, so interpolating
between rows moves the load from one to the other instead of dragging one point across.

Layout of the array (float64, shape (1 + rows, COLUMNS)): row 0 is a header (HEADER_*),
rows 1.. are the uniform y grid.

Example, S1002 on 60E1 at 1:40 near the centre, a 110 kN axle, the Polach law's mu:

    >>> import numpy as np
    >>> from rail_mj.contact.geometry import Track, contact_table
    >>> from rail_mj.contact.profiles import rail_60e1, s1002
    >>> geo = contact_table(Track(s1002(), rail_60e1()), ys=np.linspace(-1e-3, 1e-3, 41))
    >>> t = build(geo, 110e3, 210e9, 0.28, 0.3)
    >>> t.shape == (42, COLUMNS), round(float(t[21, point_column(0, 0, ANGLE)]), 4)
    (True, 0.0244)
"""

from __future__ import annotations

import functools
import math

import numpy as np

from rail_mj.numerics import (  # noqa: F401  (the table's layout, re-exported)
    ANGLE,
    C11,
    C22,
    C23,
    C33,
    COLUMNS,
    FIRST_POINT,
    HEADER_AXLE_LOAD,
    HEADER_DY,
    HEADER_FRICTION,
    HEADER_GRAVITY,
    HEADER_R0,
    HEADER_ROWS,
    HEADER_SHEAR_MODULUS,
    HEADER_SPIN,
    HEADER_Y0,
    LEVER,
    POINT,
    RADIUS,
    ROLL,
    SEMI_A,
    SEMI_B,
    SLOTS,
    WEIGHT,
    Y,
    point_column,
)
from rail_mj.units import M_PER_MM, N_PER_KN, PA_PER_GPA, RAD_PER_MRAD

_JUMP = 2e-3  # m across the wheel: a contact point moving further between two rows is a new one


class TableError(ValueError):
    """A contact table that cannot be made; the message is one line."""


def _hertz_per_unit_load(A, B, young, poisson):
    """Semi-axes at 1 N, Kalker's coefficients and the approach coefficient c
    (approach = c*N^(2/3)) of a point with curvature sums A, B. Beyond a/b = 10 (a flange's
    slender patch) the coefficients are Kalker's asymptotes joined to his table
    (`hertz.slender_coefficients`); below a/b = 0.1 they are held at the table's a/b = 0.1."""
    from rail_mj.contact.hertz import KALKER_S, hertz_ellipse, kalker_coefficients

    # A conformal point (B near 0 or below: a worn tread on a rail of nearly its shape)
    # has a long, narrow ellipse across; Hertz needs B > 0, so it is held at A/1000.
    B = max(B, 1e-3 * A)
    a, b = hertz_ellipse(1.0, A, B, young, poisson)
    C = kalker_coefficients(max(a / b, KALKER_S[0]), poisson)
    estar = young / (2.0 * (1.0 - poisson**2))
    # Johnson (1985, eq. 4.25): an ellipse's approach as the equivalent sphere's, radius
    # 1/(2*sqrt(A*B)); only used to share a wheel's load between two points.
    approach = (9.0 * 2.0 * math.sqrt(A * B) / (16.0 * estar**2)) ** (1.0 / 3.0)
    return a, b, C, approach


def _share(points, load, young, poisson):
    """Load shares of a wheel's points [(gap, angle, A, B), ...] (vertical gaps, the first
    0) under the vertical wheel load `load`: the common vertical approach zeta solves
    sum N_k*cos(angle_k) = load with N_k = ((zeta - gap_k)*cos(angle_k)/c_k)^(3/2)."""
    from scipy.optimize import brentq

    coeff = [_hertz_per_unit_load(A, B, young, poisson)[3] for _, _, A, B in points]

    def normal(zeta):
        return [max((zeta - g) * math.cos(gamma), 0.0) ** 1.5 / c**1.5 for (g, gamma, _, _), c in zip(points, coeff)]

    def excess(zeta):
        return sum(n * math.cos(p[1]) for n, p in zip(normal(zeta), points)) - load

    hi = 1e-4
    while excess(hi) < 0:
        hi *= 2
    zeta = brentq(excess, 0.0, hi, xtol=1e-15)
    n = normal(zeta)
    return [v / sum(n) for v in n]


def _side_points(cols, side: str, i: int):
    """The contact points of one side at row i: [(gap, s, r, angle, y, kw, kr), ...]."""
    out = [
        (
            0.0,
            cols[f"wheel_s_{side}"][i],
            cols[f"r_{side}"][i],
            cols[f"contact_angle_{side}"][i],
            cols[f"contact_y_{side}"][i],
            cols[f"wheel_curvature_{side}"][i],
            cols[f"rail_curvature_{side}"][i],
        )
    ]
    if np.isfinite(cols[f"r2_{side}"][i]):
        out.append(
            (
                max(cols[f"gap2_{side}"][i], 0.0),
                cols[f"wheel_s2_{side}"][i],
                cols[f"r2_{side}"][i],
                cols[f"contact_angle2_{side}"][i],
                cols[f"contact_y2_{side}"][i],
                cols[f"wheel_curvature2_{side}"][i],
                cols[f"rail_curvature2_{side}"][i],
            )
        )
    return out


def _assign_slots(wheel_s, centre: int) -> list[list[int]]:
    """Which slot each row's points go to, following each point across the rows.

    `wheel_s[i]`: the wheel coordinates s of row i's points. From the centred row (its
    outer point in slot 0) outwards both ways, a point stays in the slot whose point it
    continues: of two points, the pairing that moves them least; a single point stays in
    the slot that was occupied if it lies within _JUMP of that slot's point, and starts in
    the other slot if it jumped (the contact leaving the tread for the flange root): then
    the one slot's load fades out across the table step as the other's fades in."""
    out: list[list[int]] = [[] for _ in wheel_s]
    first = sorted(range(len(wheel_s[centre])), key=lambda k: -wheel_s[centre][k])
    out[centre] = [first.index(k) for k in range(len(wheel_s[centre]))]
    for step in (1, -1):
        last = [math.nan] * SLOTS
        occupied = set(out[centre])
        for k, slot in enumerate(out[centre]):
            last[slot] = wheel_s[centre][k]
        i = centre + step
        while 0 <= i < len(wheel_s):
            points = wheel_s[i]
            if len(points) == 2:
                if len(occupied) == 1:
                    (q,) = occupied
                    near = int(np.argmin([abs(v - last[q]) for v in points]))
                    slots = [q, 1 - q] if near == 0 else [1 - q, q]
                else:
                    keep = abs(points[0] - last[0]) + abs(points[1] - last[1])
                    swap = abs(points[0] - last[1]) + abs(points[1] - last[0])
                    slots = [0, 1] if keep <= swap else [1, 0]
            elif len(occupied) == 1:
                (q,) = occupied
                slots = [q if abs(points[0] - last[q]) <= _JUMP else 1 - q]
            else:
                slots = [int(np.argmin([abs(points[0] - last[0]), abs(points[0] - last[1])]))]
            out[i] = slots
            occupied = set(slots)
            for k, slot in enumerate(slots):
                last[slot] = points[k]
            i += step
    return out


def build(geometry, axle_load: float, young: float, poisson: float, friction: float) -> np.ndarray:
    """The table (in its stored units: mm, kN, GPa) from a rail_mj.contact.geometry.ContactTable
    (uniform y), for an axle load (N, the vertical load the two wheels carry together),
    steel of Young's modulus `young` (Pa) and Poisson's ratio `poisson`, and the friction
    coefficient (0 for the linear law)."""
    cols = geometry.columns
    ys = np.asarray(cols["y"], float)
    steps = np.diff(ys)
    if len(ys) < 3 or not np.allclose(steps, steps[0], rtol=0, atol=1e-12):
        raise TableError("the contact geometry must be tabulated on a uniform grid of at least 3 shifts")
    rows = len(ys)
    table = np.zeros((rows + 1, COLUMNS))
    r0 = 0.5 * float(np.interp(0.0, ys, cols["r_left"]) + np.interp(0.0, ys, cols["r_right"]))
    table[0, :9] = (
        ys[0] / M_PER_MM,
        steps[0] / M_PER_MM,
        rows,
        axle_load / N_PER_KN,
        young / (2.0 * (1.0 + poisson)) / PA_PER_GPA,
        friction,
        r0 / M_PER_MM,
        1.0,
        1.0,
    )
    body = table[1:]
    body[:, Y] = ys / M_PER_MM
    body[:, ROLL] = np.asarray(cols["roll"], float) / RAD_PER_MRAD
    centre = int(np.argmin(np.abs(ys)))
    for k, side in enumerate(("left", "right")):
        points = [_side_points(cols, side, i) for i in range(rows)]
        slots = _assign_slots([[p[1] for p in row] for row in points], centre)
        filled = np.zeros((rows, SLOTS), bool)
        for i in range(rows):
            shapes = []
            for gap, _s, r, gamma, _y_c, kw, kr in points[i]:
                A = math.cos(gamma) / (2.0 * r)  # the wheel's circumferential curvature (Meusnier)
                B = 0.5 * (kw + kr)
                shapes.append((gap, gamma, A, B))
            weights = [1.0] if len(shapes) == 1 else _share(shapes, axle_load / 2.0, young, poisson)
            for (_gap, _s, r, gamma, y_c, _kw, _kr), (_, _, A, B), w, slot in zip(points[i], shapes, weights, slots[i]):
                a, b, C, _ = _hertz_per_unit_load(A, B, young, poisson)
                per_kn = N_PER_KN ** (1.0 / 3.0) / M_PER_MM  # m/N^(1/3) -> mm/kN^(1/3)
                values = (
                    w,
                    (r - r0) / M_PER_MM,
                    gamma,
                    (y_c - ys[i]) / M_PER_MM,
                    a * per_kn,
                    b * per_kn,
                    C["C11"],
                    C["C22"],
                    C["C23"],
                    C["C33"],
                )
                c = point_column(k, slot, 0)
                body[i, c : c + POINT] = values
                filled[i, slot] = True
        # An empty slot keeps its own nearest point at no load, so that between two rows a
        # slot's load fades while its geometry stays its own point's.
        for slot in range(SLOTS):
            have = np.flatnonzero(filled[:, slot])
            c = point_column(k, slot, 0)
            for empty in np.flatnonzero(~filled[:, slot]):
                source = (have[np.argmin(np.abs(have - empty))], slot) if len(have) else (empty, 1 - slot)
                body[empty, c : c + POINT] = body[
                    source[0], point_column(k, source[1], 0) : point_column(k, source[1], 0) + POINT
                ]
                body[empty, c + WEIGHT] = 0.0
    if not np.all(np.isfinite(table)):
        raise TableError("the contact table has undefined entries (a profile's curvature at its end?)")
    return table


def _one_point_per_wheel(table: np.ndarray) -> np.ndarray:
    """The table with each wheel's points merged into one carrying the wheel's load, in
    slot 0: contact angle, radius and lever their load-weighted means, and an ellipse with
    the wheel's Kalker coefficients: at a wheel load N each point k carries w_k*N, its a*b
    grows as (w_k*N)^(2/3), so f11 = G*N^(2/3)*sum(w_k^(2/3)*(ab)_k*C11_k) (per unit load
    (ab)_k) and likewise f22; f23 with (ab)^1.5 and weight w_k, f33 with (ab)^2 and w_k^(4/3).
    The merged point keeps the load-weighted a/b."""
    out = table.copy()
    body = out[1:]
    for side in range(2):
        w = np.stack([body[:, point_column(side, k, WEIGHT)] for k in range(SLOTS)])
        total = np.sum(w, axis=0)
        share = w / np.where(total > 0, total, 1.0)

        def field(f, side=side):
            return np.stack([body[:, point_column(side, k, f)] for k in range(SLOTS)])

        ab = field(SEMI_A) * field(SEMI_B)
        merged_ab = np.sum(share ** (2 / 3) * ab, axis=0)
        ratio = np.sum(share * field(SEMI_A) / field(SEMI_B), axis=0)
        merged = {
            WEIGHT: np.ones(len(body)),
            RADIUS: np.sum(share * field(RADIUS), axis=0),
            ANGLE: np.sum(share * field(ANGLE), axis=0),
            LEVER: np.sum(share * field(LEVER), axis=0),
            SEMI_A: np.sqrt(merged_ab * ratio),
            SEMI_B: np.sqrt(merged_ab / ratio),
            C11: np.sum(share ** (2 / 3) * ab * field(C11), axis=0) / merged_ab,
            C22: np.sum(share ** (2 / 3) * ab * field(C22), axis=0) / merged_ab,
            C23: np.sum(share * ab**1.5 * field(C23), axis=0) / merged_ab**1.5,
            C33: np.sum(share ** (4 / 3) * ab**2 * field(C33), axis=0) / merged_ab**2,
        }
        for f, values in merged.items():
            body[:, point_column(side, 0, f)] = values
        c = point_column(side, 1, 0)
        body[:, c : c + POINT] = body[:, point_column(side, 0, 0) : point_column(side, 0, 0) + POINT]
        body[:, c + WEIGHT] = 0.0
    return out


def linearised(table: np.ndarray, geometry, amplitude: float) -> np.ndarray:
    """The table linearised about the centred state for a harmonic lateral motion of
    amplitude `amplitude` (mm), as practitioners linearise: the rolling radii as the cone
    of the equivalent conicity there (EN 15302, so that Δr = 2*λe*y, about the centred
    radii); every other entry c(y) as c0 + c1*y with the describing function's two
    coefficients over y = amplitude*sin(θ): c1 = (1/π)∫c·sin θ dθ / amplitude, the
    first-harmonic slope, and c0 = (1/π)∫c·sin²θ dθ, the mean weighted as a gain on an
    in-phase motion (what the wheel meets over the cycle, not only at the centre: the
    centred S1002/60E1 contact's two tread points exist for |y| < 0.45 mm only). Each wheel
    is first made one point carrying its whole load (`_one_point_per_wheel`), so that a
    wheel's contact angle, lever and creep coefficients are linearised as the wheel's, not
    slot by slot. Three rows, one grid step apart."""
    from rail_mj.contact import geometry as g

    lam = g.equivalent_conicity(geometry, amplitude)
    body = _one_point_per_wheel(table)[1:]
    ys = body[:, Y]
    theta = np.linspace(0.0, 2.0 * math.pi, 721)[:-1]
    along = np.array([np.interp(amplitude * np.sin(theta), ys, body[:, c]) for c in range(COLUMNS)])
    mean = np.mean(along * 2.0 * np.sin(theta) ** 2, axis=1)
    slope = np.mean(along * np.sin(theta), axis=1) * 2.0 / amplitude
    for side, sign in ((0, 1.0), (1, -1.0)):
        for slot in range(SLOTS):
            c = point_column(side, slot, RADIUS)
            mean[c], slope[c] = np.interp(0.0, ys, body[:, c]), sign * lam
    dy = table[0, HEADER_DY]
    out = np.zeros((4, COLUMNS))
    out[0] = table[0]
    out[0, HEADER_Y0], out[0, HEADER_ROWS] = -dy, 3
    for i, y in enumerate((-dy, 0.0, dy)):
        out[i + 1] = mean + slope * y
    out[1:, Y] = (-dy, 0.0, dy)
    return out


def dynamics_table(layout, amplitude: float | None = None) -> np.ndarray:
    """The table of a Layout with [profiles]: its default contact geometry, the wheel load
    from the layout, steel from [contact] (or 210 GPa and 0.28), the creep law's friction.
    Linearised at `amplitude` (mm; default the profiles' own `linearised_at`), if any."""
    c = layout.creep
    return table_for(layout.profiles, layout.wheelset, layout.contact, c.law, c.friction, amplitude)


def table_for(profiles, wheelset, contact, law: str, friction, amplitude: float | None = None) -> np.ndarray:
    """`dynamics_table` from the layout's parts (the layout checks itself with it)."""
    from rail_mj.contact import geometry as g

    if wheelset.wheel_load is None:
        raise TableError(
            "wheelset.wheel_load: missing: the contact on profiles needs the wheel load, and a "
            "fixed car body without mass gives no weight to share; give it in N"
        )
    amplitude = profiles.linearised_at if amplitude is None else amplitude
    geo = g.default_table(_geometry_key(profiles), wheelset.rolling_radius)
    young, poisson = (
        (contact.young_modulus, contact.poisson_ratio) if contact else (STEEL_YOUNG_MODULUS, STEEL_POISSON_RATIO)
    )
    mu = friction if law != "linear" and friction is not None else 0.0
    table = _build(geo, 2.0 * wheelset.wheel_load, young, poisson, mu)
    table = table if amplitude is None else linearised(table, geo, amplitude)
    if not (profiles.gravitational_stiffness and profiles.spin_creep):
        table = table.copy()
        table[0, HEADER_GRAVITY], table[0, HEADER_SPIN] = profiles.gravitational_stiffness, profiles.spin_creep
    return table


def _geometry_key(profiles):
    """The profiles as far as the rigid geometry goes: the default table is made once for them."""
    import dataclasses

    return dataclasses.replace(profiles, linearised_at=None, gravitational_stiffness=True, spin_creep=True)


def centred_coefficients(profiles, wheelset, contact, law: str, friction) -> dict:
    """Kalker's f11, f22 (N), f23 (N m), f33 (N m^2) of one wheel of the centred wheelset
    under its static load, summed over its contact points: what a coned model of the same
    wheelset would take."""
    table = table_for(profiles, wheelset, contact, law, friction)
    body = table[1:]
    row = np.array([np.interp(0.0, body[:, Y], body[:, c]) for c in range(COLUMNS)])
    shear, out = table[0, HEADER_SHEAR_MODULUS] * PA_PER_GPA, dict(f11=0.0, f22=0.0, f23=0.0, f33=0.0)
    for slot in range(SLOTS):
        w = row[point_column(0, slot, WEIGHT)]
        if w <= 0:
            continue
        cube = (w * wheelset.wheel_load / N_PER_KN) ** (1.0 / 3.0) * M_PER_MM
        ab = cube**2 * row[point_column(0, slot, SEMI_A)] * row[point_column(0, slot, SEMI_B)]
        out["f11"] += shear * ab * row[point_column(0, slot, C11)]
        out["f22"] += shear * ab * row[point_column(0, slot, C22)]
        out["f23"] += shear * ab**1.5 * row[point_column(0, slot, C23)]
        out["f33"] += shear * ab**2 * row[point_column(0, slot, C33)]
    return {k: float(v) for k, v in out.items()}


STEEL_YOUNG_MODULUS = 210e9  # Pa, wheel and rail steel
STEEL_POISSON_RATIO = 0.28


@functools.lru_cache(maxsize=16)
def _build(geo, axle_load, young, poisson, friction):
    """`build` once per geometry (ContactTables hash by identity; the default one is itself
    made once per profiles) and load."""
    table = build(geo, axle_load, young, poisson, friction)
    table.setflags(write=False)
    return table
