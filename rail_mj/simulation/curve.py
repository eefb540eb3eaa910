"""The curve's forces in the passive callback (docs/track.md): what a curved and canted track
adds to a vehicle whose bodies move relative to the track at their own stations.

Compiled with numba and called by the native callback (rail_mj.simulation.native) with the
vehicle's track part of the block (layout in rail_mj.numerics, written by
rail_mj.vehicle.curve). The model is the track straightened: every body's coordinates are
measured from the track at its own distance along it, the track-following frame of the
commercial codes. What the curve adds, each evaluated at each body's own station:

- the uncompensated lateral acceleration: F_y = -m*(V^2*k*cos(theta) - g*sin(theta)) at each
  body's centre of mass in the track plane, and its normal part -m*(g*cos(theta) +
  V^2*k*sin(theta) - g) (the model's own gravity gives -m*g); along a transition the yaw
  moment -I_z*V^2*k' of the frame's angular acceleration (the roll acceleration at the ends of a
  cant ramp, an impulse, is left out);
- the suspension's geometric pre-deflections: every spring and damper deflected, besides the
  bodies' motion, by the track's geometry between the stations of the bodies it joins (each
  body's lateral offset from the reference tangent, heading and cant roll, through the
  model's own joint and tendon kinematics), with their rates at the speed V;
- the wheelsets' yaw rate in the creepages: the track turns under a wheelset at V*k, so its
  absolute yaw rate is psi_dot + V*k (native.py adds it before calling the contact law):
  the longitudinal creepage -/+ b*k of the inner and outer wheels and the curve's spin.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from rail_mj.numerics import BREAKPOINT, POSES, TRACK_HEADER
from rail_mj.track.geometry import CANT_BASE


@numba.njit(cache=True)
def track_at(table, s):
    """(curvature, cant, heading, heading's integral, cant's slope, curvature's slope) at
    distance `s` from the breakpoints `table` (rows: x, curvature, cant, heading, heading's
    integral), curvature and cant linear between breakpoints and held beyond the ends."""
    m = table.shape[0]
    if s <= table[0, 0]:
        t = s - table[0, 0]
        k = table[0, 1]
        return k, table[0, 2], table[0, 3] + k * t, table[0, 4] + table[0, 3] * t + 0.5 * k * t * t, 0.0, 0.0
    if s >= table[m - 1, 0]:
        t = s - table[m - 1, 0]
        k = table[m - 1, 1]
        heading, integral = table[m - 1, 3], table[m - 1, 4]
        return k, table[m - 1, 2], heading + k * t, integral + heading * t + 0.5 * k * t * t, 0.0, 0.0
    lo, hi = 0, m - 1  # the last breakpoint at or before s: table[lo, 0] <= s < table[hi, 0]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if table[mid, 0] <= s:
            lo = mid
        else:
            hi = mid
    i = lo
    length = table[i + 1, 0] - table[i, 0]
    t = s - table[i, 0]
    k0, dk = table[i, 1], table[i + 1, 1] - table[i, 1]
    slope = (table[i + 1, 2] - table[i, 2]) / length
    heading0 = table[i, 3]
    curvature = k0 + dk * t / length
    heading = heading0 + k0 * t + dk * t * t / (2.0 * length)
    integral = table[i, 4] + heading0 * t + 0.5 * k0 * t * t + dk * t * t * t / (6.0 * length)
    return curvature, table[i, 2] + slope * t, heading, integral, slope, dk / length


@numba.njit(cache=True)
def odometer(block, k, xpos):
    """The distance along the track of the vehicle's origin, from its odometer body (the track
    part at `k`); NaN on straight track."""
    body = int(block[k])
    if body < 0:
        return math.nan
    return xpos[3 * body]


@numba.njit(cache=True)
def curvature_at(block, k, s):
    """The curvature at `s` of the track part at `k`."""
    return track_at(_table(block, k), s)[0]


@numba.njit(cache=True, inline="always")
def _table(block, k):
    """The breakpoints of the track part at `k` (`block` a pointer, as the callback has it)."""
    m = int(block[k + 2])
    start = k + TRACK_HEADER
    return numba.carray(block, (start + BREAKPOINT * m,))[start:].reshape((m, BREAKPOINT))


@numba.njit(cache=True)
def _push(force, chain, count, xpos, xanchor, xaxis, body, fy, fz, mz):
    """Add J^T (F, M) for a force F = (0, fy, fz) at `body`'s origin (its centre of mass: rail-mj
    puts every body's there) and a moment M = (0, 0, mz), over the joints `chain`."""
    px, py, pz = xpos[3 * body], xpos[3 * body + 1], xpos[3 * body + 2]
    for c in range(count):
        j, dof, hinge = int(chain[3 * c]), int(chain[3 * c + 1]), chain[3 * c + 2]
        ax, ay, az = xaxis[3 * j], xaxis[3 * j + 1], xaxis[3 * j + 2]
        if hinge:  # axis . (r x F)
            rx, ry, rz = px - xanchor[3 * j], py - xanchor[3 * j + 1], pz - xanchor[3 * j + 2]
            force[dof] += ax * (ry * fz - rz * fy) + ay * (-rx * fz) + az * (rx * fy + mz)
        else:
            force[dof] += ay * fy + az * fz


@numba.njit(cache=True)
def _spring(stiffness, low, high, length):
    """A tendon spring's force at `length`, idle within [low, high] (MuJoCo's deadband)."""
    if length > high:
        return -stiffness * (length - high)
    if length < low:
        return -stiffness * (length - low)
    return 0.0


@numba.njit(cache=True)
def add_curve_forces(block, k, speed, xpos, xanchor, xaxis, stiffness, damping, springlength, length, force):
    """Add the curve's forces (see the module) of the vehicle whose track part starts at `k`;
    where the part ends."""
    body = int(block[k])
    if body < 0:
        return k + TRACK_HEADER
    s_ref = xpos[3 * body]
    gravity = block[k + 1]
    m, nb, nr, nt = int(block[k + 2]), int(block[k + 3]), int(block[k + 4]), int(block[k + 5])
    table = _table(block, k)
    e = k + TRACK_HEADER + BREAKPOINT * m
    k_ref, cant_ref, h_ref, i_ref, slope_ref, _ = track_at(table, s_ref)
    # The reference: the track plane at the vehicle's origin, which the model's world is.
    theta_ref = math.asin(cant_ref / CANT_BASE)
    theta_rate_ref = speed * slope_ref / (CANT_BASE * math.cos(theta_ref))
    # One allocation a call (every entry is set below): each body's pose, then their rates.
    scratch = np.empty(2 * POSES * nb)
    pose, rate = scratch[: POSES * nb], scratch[POSES * nb :]
    for b in range(nb):
        body, x, height, mass, yaw_inertia = int(block[e]), block[e + 1], block[e + 2], block[e + 3], block[e + 4]
        count = int(block[e + 5])
        chain = numba.carray(block, (e + 6 + 3 * count,))[e + 6 :]
        e += 6 + 3 * count
        curvature, cant, heading, integral, slope, curvature_slope = track_at(table, s_ref + x)
        theta = math.asin(cant / CANT_BASE)
        theta_rate = speed * slope / (CANT_BASE * math.cos(theta))
        # Off the reference tangent: the integral of the heading's change from the reference;
        # the track plane here rolled from the reference's (the right rail up: about +x,
        # -theta) about the rail-level centreline, which moves a centre of mass at `height`.
        twist, twist_rate = theta - theta_ref, theta_rate - theta_rate_ref
        pose[POSES * b] = integral - i_ref - x * h_ref + twist * height
        pose[POSES * b + 1] = heading - h_ref
        pose[POSES * b + 2] = -twist
        rate[POSES * b] = speed * (heading - h_ref - x * k_ref) + twist_rate * height
        rate[POSES * b + 1] = speed * (curvature - k_ref)
        rate[POSES * b + 2] = -twist_rate
        centripetal = speed * speed * curvature
        fy = -mass * (centripetal * math.cos(theta) - gravity * math.sin(theta))
        fz = -mass * (gravity * math.cos(theta) + centripetal * math.sin(theta) - gravity)
        # Along a transition the track's heading turns faster and faster under the body: in the
        # track-following frame, the frame's angular acceleration V^2*k' as a yaw moment.
        mz = -yaw_inertia * speed * speed * curvature_slope
        _push(force, chain, count, xpos, xanchor, xaxis, body, fy, fz, mz)
    for _ in range(nr):
        dof, k_joint, c_joint, terms = int(block[e]), block[e + 1], block[e + 2], int(block[e + 3])
        q, q_rate = 0.0, 0.0
        for c in range(terms):
            p, coefficient = int(block[e + 4 + 2 * c]), block[e + 5 + 2 * c]
            q += coefficient * pose[p]
            q_rate += coefficient * rate[p]
        force[dof] -= k_joint * q + c_joint * q_rate
        e += 4 + 2 * terms
    for _ in range(nt):
        t, terms = int(block[e]), int(block[e + 1])
        e += 2
        shift, shift_rate = 0.0, 0.0
        for c in range(terms):
            p, coefficient = int(block[e + 2 * c]), block[e + 1 + 2 * c]
            shift += coefficient * pose[p]
            shift_rate += coefficient * rate[p]
        e += 2 * terms
        low, high = springlength[2 * t], springlength[2 * t + 1]
        extra = _spring(stiffness[t], low, high, length[t] + shift) - _spring(stiffness[t], low, high, length[t])
        extra -= damping[t] * shift_rate
        dofs = int(block[e])
        for c in range(dofs):
            force[int(block[e + 1 + 2 * c])] += block[e + 2 + 2 * c] * extra
        e += 1 + 2 * dofs
    return e
