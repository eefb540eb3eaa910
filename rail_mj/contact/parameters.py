"""What the contact law takes of each wheelset (`ContactParameters`) and what it gives
(`ContactForces`): plain data, without the compiled law (rail_mj.contact.law), so that building
a model or reading its forces needs no compiler.

Example:

    >>> p = ContactParameters.broadcast(2, r0=0.46, b=0.75, conicity=0.15, f11=10e6, f22=9e6)
    >>> p.table.shape   # one row per number the compiled law reads, one column per wheelset
    (21, 2)
"""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

import numpy as np

from rail_mj import numerics as _t
from rail_mj.contact.laws import FASTSIM, LINEAR, POLACH
from rail_mj.numerics import _FASTSIM_ROWS, _ROWS
from rail_mj.units import PA_PER_GPA

_FASTSIM_NEEDS = ("friction_limit", *_FASTSIM_ROWS)


@dataclasses.dataclass(frozen=True)
class ContactParameters:
    """Contact geometry and Kalker coefficients, one entry per wheelset (arrays of shape (n,)),
    the creep law with its friction limit mu*N per wheel and Polach's falling friction,
    the flange contact, and the contact ellipse FASTSIM works on."""

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
    # The contact ellipse, for FASTSIM (unused by the other laws; zero where there is none):
    semi_axis_a: np.ndarray  # m, along the rolling direction
    semi_axis_b: np.ndarray  # m, across it
    normal_force: np.ndarray  # N per wheel (FASTSIM's pressure; mu*N is friction_limit)
    shear_modulus: np.ndarray  # Pa
    c11: np.ndarray  # Kalker's coefficients at a/b and nu, dimensionless
    c22: np.ndarray
    c23: np.ndarray
    law: int = LINEAR
    flange: bool = False  # flange contact on
    # A profiled wheelset's contact table (rail_mj.contact.tables); empty: coned wheels.
    geometry: np.ndarray = dataclasses.field(default_factory=lambda: NO_GEOMETRY)

    def __post_init__(self):
        if self.law == FASTSIM and len(self.geometry) == 0:  # on profiles: each point's own ellipse
            for name in _FASTSIM_NEEDS:
                value = np.asarray(getattr(self, name))
                if not np.all(np.isfinite(value) & (value > 0.0)):
                    raise ValueError(f"the fastsim law needs {name} finite and > 0 for every wheelset, got {value}")

    @functools.cached_property
    def falling(self) -> bool:
        """Whether the law is Polach's with falling friction (only a shortcut: with A = 1
        `falling_friction` returns mu0*N anyway)."""
        return self.law == POLACH and bool(np.any(self.falling_friction_ratio < 1.0))

    @functools.cached_property
    def table(self) -> np.ndarray:
        """The per-wheelset numbers as rows of one array, for the compiled kernel; the
        shear modulus in GPa (GPA), as the model's numerics carry it."""
        rows = [getattr(self, name) / (PA_PER_GPA if name == "shear_modulus" else 1.0) for name in _ROWS]
        return np.ascontiguousarray(np.stack(rows))

    @classmethod
    def broadcast(
        cls,
        n: int,
        *,
        r0,
        b,
        conicity,
        f11,
        f22,
        f23=0.0,
        f33=0.0,
        friction_limit=np.inf,
        falling_friction_ratio=1.0,
        falling_friction_rate=0.0,
        law=LINEAR,
        clearance=0.008,
        flange_stiffness=0.0,
        flange_damping=0.0,
        flange_slope=None,
        semi_axis_a=0.0,
        semi_axis_b=0.0,
        normal_force=0.0,
        shear_modulus=0.0,
        c11=0.0,
        c22=0.0,
        c23=0.0,
        geometry=None,
    ):
        full = lambda v: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy()  # noqa: E731
        flange = flange_slope is not None
        return cls(
            full(r0),
            full(b),
            full(conicity),
            full(f11),
            full(f22),
            full(f23),
            full(f33),
            full(friction_limit),
            full(falling_friction_ratio),
            full(falling_friction_rate),
            full(clearance),
            full(flange_stiffness),
            full(flange_damping),
            full(flange_slope if flange else conicity),
            full(semi_axis_a),
            full(semi_axis_b),
            full(normal_force),
            full(shear_modulus),
            full(c11),
            full(c22),
            full(c23),
            int(law),
            flange,
            NO_GEOMETRY if geometry is None else np.ascontiguousarray(geometry, dtype=np.float64),
        )


NO_GEOMETRY: np.ndarray = np.zeros((0, _t.COLUMNS))
# The shear modulus travels in GPa (ContactParameters.table, the rail_mj/ellipse numeric):
# MuJoCo's MJCF writer writes as 0 every entry of a numeric below 1e-12 of its largest,
# and 8e10 Pa would take a flangeway clearance of 0.008 m with it.


class ContactForces(NamedTuple):
    """The rails' forces on each wheelset, by origin: arrays shaped like the states, the
    last axis the wheelsets; N and N m. On profiles (`profiled_contact`) the flange entries
    are the normal forces' lateral part (gravitational stiffness on the tread, the flange
    force on the flange) and the moment of every lateral force at its contact's lead."""

    creep_lateral: np.ndarray  # Fy of both wheels' creep forces
    flange_lateral: np.ndarray  # the flange's lateral force, zero off the flange; with the
    # normal forces' lateral part (gravitational stiffness) on profiles and on a spatial vehicle's cones
    creep_couple: np.ndarray  # b*(Fx_right - Fx_left): the longitudinal creep forces' yaw moment
    spin_moment: np.ndarray  # Kalker's f23*xi_y - f33*xi_sp of both wheels, saturated as their forces;
    # with the fastsim law FASTSIM's own Mz
    flange_moment: np.ndarray  # the flange force acting at the flange contact's lead
    lateral: np.ndarray  # Sigma Y: everything lateral, creep and flange
    yaw: np.ndarray  # every yaw moment
    # Per wheel (docs/spatial.md, wheel loads): the vertical load Q and the lateral force Y of
    # the rail on the wheel (track frame, + to the left). Q on cones is the nominal wheel load
    # unless the model's suspension gives the axle loads (NaN if the layout has none).
    load_left: np.ndarray
    load_right: np.ndarray
    lateral_left: np.ndarray
    lateral_right: np.ndarray
    # A spatial vehicle's spinning wheelset: the gyroscopic yaw moment (in `yaw`; not a contact force).
    gyroscopic: np.ndarray
    # Per wheel: the wear number T-gamma (N, i.e. J/m), the energy the creep dissipates in the
    # contact per metre rolled, -(Fx*xi_x + Fy*xi_y + Mz*xi_sp) over the wheel's contact points with
    # the rail's forces on the wheel and the creepages the law is given (`wear_number`); >= 0.
    wear_left: np.ndarray
    wear_right: np.ndarray


FORCE_ROWS = len(ContactForces._fields)
