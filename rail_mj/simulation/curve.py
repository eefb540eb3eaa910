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
- each tendon's real deflection, its model length plus its shift (the same terms), which a
  spatial vehicle's wheel loads and shear couples read (native.py, from a copy of the lengths and
  rates it makes once a call on a curve: rail_mj.vehicle.poses, whose kernel gives the bodies'
  poses and loads here too);
- the wheelsets' yaw rate in the creepages: the track turns under a wheelset at V*k, so its
  absolute yaw rate is psi_dot + V*k (native.py adds it before calling the contact law):
  the longitudinal creepage -/+ b*k of the inner and outer wheels and the curve's spin.
"""

from __future__ import annotations

import math

import numba

from rail_mj.numerics import LOADS, ODOMETER_MASS, POSES, SPEED_POINT, TRACK_HEADER
from rail_mj.vehicle.poses import breakpoints_at, entries_at, entry_at, last_at_or_before, track_at


@numba.njit(cache=True)
def odometer(block, k, xpos):
    """The distance along the track of the vehicle's origin, from its odometer body (the track
    part at `k`); NaN on straight track."""
    body = int(block[k])
    if body < 0:
        return math.nan
    return xpos[3 * body]


# s: how fast the odometer is pulled back onto its profile. The profile's own acceleration
# V*dVp/ds keeps a speed that is on the profile on it exactly; what RK4 loses where dV/ds jumps
# (a step across a point of the profile, ~dt*V*jump) would otherwise stay as an offset and
# drift the timing (1.8e-4 s over 1 km measured without it); 0.05 s >> the timestep (1e-3 s at
# most), so the pull is not stiff, and << the seconds a speed changes over.
PROFILE_RELAXATION = 0.05


@numba.njit(cache=True)
def profiled_speed(block, k, s, qvel, force):
    """A vehicle on a speed profile (the track part at `k` has its points), its odometer at
    station `s`: its speed, the odometer's velocity V, after adding to the odometer the force
    ODOMETER_MASS * (V*dVp/ds + (Vp - V)/PROFILE_RELAXATION), Vp the profile's speed at `s`,
    that keeps it on the profile (dV/dt = V*dV/ds along it; held beyond its ends; V, not Vp,
    in the first term, so that the force is continuous in s where the linearisation holds the
    odometer still); NaN without a profile. The bodies' own longitudinal inertia under the deceleration is left out: the
    model has no longitudinal freedom (docs/track.md, speed profiles)."""
    n = int(block[k + 7])
    if n == 0:
        return math.nan
    dof = int(block[k + 6])
    speed = qvel[dof]
    p = k + TRACK_HEADER
    if s < block[p]:
        target, gradient = block[p + 1], 0.0
    elif s >= block[p + SPEED_POINT * (n - 1)]:
        target, gradient = block[p + SPEED_POINT * (n - 1) + 1], 0.0
    else:
        lo = last_at_or_before(block, p, SPEED_POINT, n, s)  # a slow ramp has hundreds of points
        a, b = p + SPEED_POINT * lo, p + SPEED_POINT * (lo + 1)
        gradient = (block[b + 1] - block[a + 1]) / (block[b] - block[a])
        target = block[a + 1] + gradient * (s - block[a])
    force[dof] += ODOMETER_MASS * (speed * gradient + (target - speed) / PROFILE_RELAXATION)
    return speed


@numba.njit(cache=True)
def curvature_at(block, k, s):
    """The curvature at `s` of the track part at `k`."""
    return track_at(block, breakpoints_at(block, k), int(block[k + 2]), s, -1)[0]


@numba.njit(cache=True, inline="always")
def body_loads(scratch, nb, i):
    """Body `i`'s curve loads (fy, fz, mz) in curve_state's `scratch` of `nb` bodies."""
    loads = 2 * POSES * nb + LOADS * i
    return scratch[loads], scratch[loads + 1], scratch[loads + 2]


@numba.njit(cache=True)
def push_load(force, chain, count, xpos, xanchor, xaxis, body, fy, fz, mz):
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
def folded_forces(block, k, scratch, out):
    """Each dof row's force (`out`, in the rows' order) of the track part at `k`: the joints' and
    linear tendons' geometric pre-deflections, folded per dof (rail_mj.vehicle.curve), from
    curve_state's `scratch`. A function of the station and speed alone, as the scratch is."""
    nb, nr = int(block[k + 3]), int(block[k + 4])
    rates = POSES * nb
    index = entries_at(block, k) + nb
    for i in range(nr):
        e = k + int(block[index + i])
        terms = int(block[e + 1])
        f = 0.0
        for c in range(terms):
            p = int(block[e + 2 + 3 * c])
            f += block[e + 3 + 3 * c] * scratch[p] + block[e + 4 + 3 * c] * scratch[rates + p]
        out[i] = f


@numba.njit(cache=True)
def add_curve_forces(
    block,
    k,
    pushed,
    scratch,
    folded,
    xpos,
    xanchor,
    xaxis,
    stiffness,
    damping,
    springlength,
    length,
    velocity,
    shifted,
    shifted_rate,
    force,
):
    """Add the curve's forces (see the module) of the vehicle whose track part starts at `k`,
    its bodies' poses, rates and loads in `scratch` (rail_mj.vehicle.poses.curve_state), its dof
    rows' forces `folded` (`folded_forces`), its tendons' model lengths and rates `length`,
    `velocity` and their real ones, shifted (rail_mj.vehicle.poses.apply_shifts); the loads of
    its first `pushed` bodies (its wheelsets) the caller has pushed with their contact forces.
    Where the part's entries end."""
    nb, nr, nt = int(block[k + 3]), int(block[k + 4]), int(block[k + 5])
    for i in range(pushed, nb):
        b = entry_at(block, k, i)
        body, count = int(block[b]), int(block[b + 5])
        chain = numba.carray(block, (b + 6 + 3 * count,))[b + 6 :]
        fy, fz, mz = body_loads(scratch, nb, i)
        push_load(force, chain, count, xpos, xanchor, xaxis, body, fy, fz, mz)
    index = entries_at(block, k) + nb
    for i in range(nr):  # the joints' and linear tendons' pre-deflections, folded per dof
        force[int(block[k + int(block[index + i])])] += folded[i]
    for i in range(nt):  # the rest: each from its real length and its model length
        e = entry_at(block, k, nb + nr + i)
        e += 2 + 2 * int(block[e + 1])
        dofs = int(block[e])
        if dofs == 0:
            continue  # folded above: listed for its shift alone
        t = int(block[entry_at(block, k, nb + nr + i)])
        low, high = springlength[2 * t], springlength[2 * t + 1]
        extra = _spring(stiffness[t], low, high, shifted[t]) - _spring(stiffness[t], low, high, length[t])
        extra -= damping[t] * (shifted_rate[t] - velocity[t])
        for c in range(dofs):
            force[int(block[e + 1 + 2 * c])] += block[e + 2 + 2 * c] * extra
    return entry_at(block, k, nb + nr + nt)
