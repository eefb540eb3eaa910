"""The physics against closed forms of docs/creep.md (the section numbers below are its own)."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from conftest import WHEELSET, free_truck, free_wheelset

from rail_mj.analysis import summary
from rail_mj.contact.creep import LINEAR, POLACH, SHEN_HEDRICK_ELKINS, ContactParameters, wheelset_forces
from rail_mj.layout import layout_from_dict
from rail_mj.simulation.callback import CreepForces, installed
from rail_mj.simulation.runner import simulate
from rail_mj.vehicle.spec import Vehicle

# Low enough that creep is effectively rigid (no slip): the inertia correction to the
# kinematic wavelength is of order (V^2 * m / f22 / L)^2, below 1e-4 at 5 m/s.
LOW_SPEED = 5.0


@pytest.mark.parametrize(
    "r0, b, lam",
    [
        (0.46, 0.75, 0.15),  # Manchester wheelset, L_w = 9.53 m (section 3)
        (0.50, 0.75, 0.05),  # the seed's example: "nearly 17 metres", L_w = 17.21 m
        (0.45, 0.70, 0.30),
        (0.60, 0.80, 0.025),  # 1:40 high-speed tread
    ],
)
def test_free_wheelset_follows_klingel_wavelength(r0, b, lam):
    klingel = 2 * math.pi * math.sqrt(r0 * b / lam)  # section 3, seed equation 6 with w = 2b
    run = simulate(free_wheelset(r0, b, lam), speed=LOW_SPEED, distance=3 * klingel, initial_lateral=0.003)
    w = summary(run)["wheelsets"][0]
    # Section 3: the dynamic model matches the kinematic wavelength to better than 0.1 %.
    assert w["wavelength_m"] == pytest.approx(klingel, rel=1e-3)
    # Kinematic motion neither grows nor decays much: |sigma| * (time of one wavelength) << 1.
    assert abs(w["growth_rate_per_s"]) * klingel / LOW_SPEED < 0.05


@pytest.mark.parametrize(
    "a, lam, f11, f22",
    [
        (1.28, 0.15, 10e6, 10e6),  # Manchester bogie, L_b = 18.85 m (section 3)
        (1.00, 0.05, 10e6, 9e6),  # f11 != f22
    ],
)
def test_stiff_two_axle_bogie_follows_rigid_truck_wavelength(a, lam, f11, f22):
    r0, b = WHEELSET["rolling_radius"], WHEELSET["contact_half_spacing"]
    # Section 3: L_b = 2*pi*sqrt((r0*b/lam)*(1 + (f22/f11)*a^2/b^2)).
    rigid = 2 * math.pi * math.sqrt(r0 * b / lam * (1 + f22 / f11 * a**2 / b**2))
    run = simulate(
        free_truck([a, -a], lam, f11, f22, primary=1e9), speed=LOW_SPEED, distance=2.5 * rigid, initial_lateral=0.003
    )
    for w in summary(run)["wheelsets"]:
        # 1e9 N/m and N m/rad are 50-100x the creep stiffnesses: rigid to about 0.1 %.
        assert w["wavelength_m"] == pytest.approx(rigid, rel=2e-3)


def restrained_wheelset(ky, kpsi, cy=0.0, cpsi=0.0, f23=0.0, f33=0.0):
    return layout_from_dict(
        {
            "name": "restrained",
            "wheelset": WHEELSET,
            "creep": {"f11": 10e6, "f22": 9e6, "f23": f23, "f33": f33},
            "primary": {"lateral_stiffness": ky, "yaw_stiffness": kpsi, "lateral_damping": cy, "yaw_damping": cpsi},
            "carbody": {"fixed": True, "wheelset_positions": [0.0]},
        }
    )


@pytest.mark.parametrize(
    "state",
    [
        (0.004, 0.0, 0.0, 0.0),
        (0.0, 0.002, 0.0, 0.0),
        (0.0, 0.0, 0.05, 0.0),
        (0.0, 0.0, 0.0, 0.03),
        (-0.003, 0.001, 0.02, -0.01),
    ],
)
def test_mujoco_wheelset_obeys_the_classical_equations(state):
    """Section 2, with the suspension as MuJoCo joint springs and dampers:
    m*y'' + 2*f22*(y'/V - psi) + ky*y + cy*y' = 0
    Iz*psi'' + 2*f11*b*(b*psi'/V + lam*y/r0) + kpsi*psi + cpsi*psi' = 0"""
    ky, kpsi, cy, cpsi, V = 7.768e6, 62.78e6, 4e3, 1e3, 37.0
    vehicle = Vehicle(restrained_wheelset(ky, kpsi, cy, cpsi))
    model, data = vehicle.model, mujoco.MjData(vehicle.model)
    y, psi, yd, psid = state
    data.qpos[:] = [y, psi]
    data.qvel[:] = [yd, psid]
    with installed(CreepForces(model, vehicle.wheelset_names, V)):
        mujoco.mj_forward(model, data)
    m, Iz = WHEELSET["mass"], WHEELSET["inertia"][2]
    r0, b, lam, f11, f22 = 0.46, 0.75, 0.15, 10e6, 9e6
    y_dd = -(2 * f22 * (yd / V - psi) + ky * y + cy * yd) / m
    psi_dd = -(2 * f11 * b * (b * psid / V + lam * y / r0) + kpsi * psi + cpsi * psid) / Iz
    # The single wheelset's joints are its absolute y and psi, so this holds to round-off.
    np.testing.assert_allclose(data.qacc, [y_dd, psi_dd], rtol=1e-9, atol=1e-9)


def test_spin_terms_sum_kalkers_law_over_both_wheels():
    """Section 2 per wheel, summed by hand: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp,
    Mz = f23*xi_y - f33*xi_sp, with xi_sp = psi'/V -/+ gamma/r0 (left/right) for any
    contact angle gamma, which must cancel."""
    r0, b, lam, f11, f22, f23, f33, V = 0.46, 0.75, 0.15, 10e6, 9e6, 3.6e4, 1.2e2, 42.0
    y, psi, yd, psid, gamma = 0.002, -0.001, 0.03, 0.02, 0.2
    xi_x_left = -(b * psid / V) - lam * y / r0
    xi_y = yd / V - psi
    fy = mz = 0.0
    for side, xi_x, xi_sp in ((+1, xi_x_left, psid / V - gamma / r0), (-1, -xi_x_left, psid / V + gamma / r0)):
        fx = -f11 * xi_x
        fy += -f22 * xi_y - f23 * xi_sp
        mz += -side * b * fx + f23 * xi_y - f33 * xi_sp  # Fx at y = side*b yaws by -y*Fx
    p = ContactParameters.broadcast(1, r0=r0, b=b, conicity=lam, f11=f11, f22=f22, f23=f23, f33=f33)
    got_fy, got_mz = wheelset_forces(p, np.array([y]), np.array([psi]), np.array([yd]), np.array([psid]), V)
    assert got_fy[0] == pytest.approx(fy, rel=1e-12)
    assert got_mz[0] == pytest.approx(mz, rel=1e-12)


@pytest.mark.parametrize("law", [LINEAR, SHEN_HEDRICK_ELKINS, POLACH])
def test_creep_law_is_vectorised_over_wheelsets(law):
    rng = np.random.default_rng(7)
    n = 6
    p = ContactParameters.broadcast(
        n,
        r0=rng.uniform(0.4, 0.5, n),
        b=0.75,
        conicity=rng.uniform(0.05, 0.3, n),
        f11=10e6,
        f22=rng.uniform(5e6, 1e7, n),
        f23=1e4,
        f33=50.0,
        friction_limit=rng.uniform(1e4, 3e4, n),
        law=law,
    )
    states = rng.normal(scale=1e-3, size=(4, n))
    fy, mz = wheelset_forces(p, *states, 33.0)
    for i in range(n):
        one = dataclasses.replace(
            p,
            **{f.name: getattr(p, f.name)[i : i + 1] for f in dataclasses.fields(p) if f.name not in ("law", "flange")},
        )
        single = wheelset_forces(one, *states[:, i : i + 1], 33.0)
        assert (fy[i], mz[i]) == (single[0][0], single[1][0])


def test_centred_vehicle_stays_centred():
    """No disturbance, no motion: the creep law has no offset and the model no preload."""
    layout = free_truck([1.28, -1.28], primary=5e6)
    run = simulate(layout, speed=50.0, distance=50.0, initial_lateral=0.0)
    assert np.max(np.abs(run.y)) == 0.0 and np.max(np.abs(run.psi)) == 0.0
