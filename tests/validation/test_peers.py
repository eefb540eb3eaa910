"""The peers of benchmarks/ (what a user would write instead of rail-mj) model the same coach:
the numba peer follows rail-mj's trajectory to round-off, and the solve_ivp peer's numpy
creep law and equations of motion are rail-mj's law and the numba peer's equations."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))

import peer_numba
import peer_solve_ivp
import peers

from rail_mj.contact.creep import ContactParameters, wheelset_forces


@pytest.fixture(scope="module")
def coach():
    return peers.coach()


@pytest.mark.parametrize("speed", [60.0, 120.0])  # decaying; hunting on the flanges
def test_numba_peer_follows_rail_mj(speed):
    """Same equations (the coach's nested model, which rail-mj steps on a track file), same
    law, same RK4 and step: the trajectories agree to round-off (over 100 m: |y| up to 2 mm at
    60 m/s; at 120 m/s the wheelsets are on the flanges, past the 8 mm clearance, from 27 m on)."""
    run = peers.reference(speed, 100.0, 0.002, nested=True)
    assert np.abs(run.y).max() > (0.008 if speed > 100 else 0.001)
    assert peer_numba.agreement(run, speed, 100.0, 0.002) < 1e-12


def test_the_flat_twin_is_within_rk4_s_own_error_of_the_nested_equations():
    """On straight track rail-mj steps the coach flat (Vehicle.stepped): its suspension
    deflections linearised, y_c - y_p - a*psi_p, where the nested joints are exact. What that
    leaves out is second order in the yaw angles; over 1 km at 60 m/s (|y| up to 2.1 mm) it
    moves the wheelsets less than RK4 itself does at the run's step, measured as the exact
    nested equations' (the numba peer's) change from dt to dt/2 (5.5e-10 m against 1.4e-9 m)."""
    run = peers.reference(60.0, 1000.0, 0.002)
    dt = run.timestep
    t, y, _ = peer_numba.simulate(peers.coach(), 60.0, 1000.0, 0.002, dt, 1)
    _, half, _ = peer_numba.simulate(peers.coach(), 60.0, 1000.0, 0.002, dt / 2, 2)
    assert half.shape == y.shape
    rk4 = np.max(np.abs(y - half))
    # Above round-off (1e-13 if the nested model were stepped): the twin is what steps.
    assert 1e-11 < peers.max_difference(run, t, y) < rk4


def test_on_the_flanges_the_flat_twin_keeps_the_nested_limit_cycle():
    """Hunting on the flanges at 100 m/s (|y| 14.8 mm) the two forms drift in phase (the
    second-order terms change the cycle's period slightly: 1.4e-4 m apart after 1 km, RK4's own
    change from dt to dt/2 there 2e-5 m), and the limit cycle is the same: its amplitude over
    the last 200 m agrees to 2e-5 of itself (8e-6 measured; the phase drift makes the last bits
    depend on the machine's rounding)."""
    flat = peers.reference(100.0, 1000.0, 0.002)
    nested = peers.reference(100.0, 1000.0, 0.002, nested=True)
    late = slice(int(0.8 * len(flat.y)), None)
    amplitude = np.abs(flat.y[late]).max()
    assert amplitude > 0.008  # on the flanges
    assert abs(amplitude - np.abs(nested.y[late]).max()) < 2e-5 * amplitude


def test_numpy_law_is_rail_mj_law(coach):
    """The solve_ivp peer's creep law, written out in numpy, gives rail-mj's forces, on the
    tread and on the flanges."""
    params = ContactParameters(*(row for row in coach.contact), law=coach.law, flange=coach.flange)
    rng = np.random.default_rng(5)
    for speed in (20.0, 60.0, 140.0):
        y, psi = rng.normal(0.0, 0.01, 4), rng.normal(0.0, 0.005, 4)
        y_dot, psi_dot = rng.normal(0.0, 0.2, 4), rng.normal(0.0, 0.2, 4)
        ours = peer_solve_ivp.creep_forces(
            coach.contact, coach.law, coach.flange, coach.falling, y, psi, y_dot, psi_dot, speed
        )
        np.testing.assert_allclose(ours, wheelset_forces(params, y, psi, y_dot, psi_dot, speed), rtol=1e-13)


def test_peers_share_equations(coach):
    """The two peers write the exact nested kinematics two ways (body by body; all bodies
    through the ancestor matrix): the same accelerations at a disturbed state."""
    rng = np.random.default_rng(3)
    q, v = rng.normal(0.0, 0.01, coach.dofs), rng.normal(0.0, 0.1, coach.dofs)
    numba_qacc = np.zeros(coach.dofs)
    peer_numba._accelerations(peer_numba._arrays(coach), 60.0, q, v, peer_numba._workspace(coach.parent), numba_qacc)
    numpy_qacc = peer_solve_ivp.Equations(coach, 60.0)(0.0, np.concatenate([q, v]))[coach.dofs :]
    np.testing.assert_allclose(numpy_qacc, numba_qacc, rtol=0, atol=1e-12 * np.abs(numba_qacc).max())
