"""Each body's pose that a curved, canted track gives it, and the tendons' shifts: what the
native callback (rail_mj.simulation.curve) and a run's recorded wheel loads
(rail_mj.vehicle.sensors) both read off the track part of the block (docs/track.md).

Every body's coordinates are measured from the track at its own station, and the model's world
is the track plane at the vehicle's origin: besides the model's own coordinates, each body is
displaced by the track's geometry between its station and the origin's, its pose (lateral offset
from the reference tangent, heading, cant roll). A tendon's real deflection is its model length
plus its terms in those poses (its shift), and its rate likewise.

Compiled with numba; `block` is a pointer to the block's doubles (as the callback has it), or,
from Python, `tendon_shifts` takes the model's numeric data as an array.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types
from numba.extending import intrinsic

from rail_mj.numerics import BREAKPOINT, POSES, SPEED_POINT, TRACK_HEADER
from rail_mj.track.geometry import CANT_BASE

LOADS = 3  # per body, after the poses and rates in the scratch: fy, fz, mz


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


@numba.njit(cache=True, inline="always")
def breakpoints_at(block, k):
    """Where the breakpoints of the track part at `k` start: after its header and speed points."""
    return k + TRACK_HEADER + SPEED_POINT * int(block[k + 7])


@numba.njit(cache=True, inline="always")
def table_of(block, k):
    """The breakpoints of the track part at `k` (`block` a pointer, as the callback has it)."""
    m = int(block[k + 2])
    start = breakpoints_at(block, k)
    return numba.carray(block, (start + BREAKPOINT * m,))[start:].reshape((m, BREAKPOINT))


@numba.njit(cache=True, inline="always")
def scratch_size(block, k):
    """The size of `curve_state`'s scratch for the track part at `k`."""
    return (2 * POSES + LOADS) * int(block[k + 3])


@numba.njit(cache=True)
def curve_state(block, k, speed, s_ref, scratch):
    """The track part at `k` with the vehicle's origin at station `s_ref`: fill `scratch`
    (`scratch_size`, the caller's: nothing is shared between threads) with each body's pose
    (POSES per body: lateral offset, heading, cant roll), their rates, then its curve loads (fy,
    fz, mz: rail_mj.simulation.curve); where the bodies' entries end."""
    gravity = block[k + 1]
    m, nb = int(block[k + 2]), int(block[k + 3])
    table = table_of(block, k)
    e = breakpoints_at(block, k) + BREAKPOINT * m
    k_ref, cant_ref, h_ref, i_ref, slope_ref, _ = track_at(table, s_ref)
    # The reference: the track plane at the vehicle's origin, which the model's world is.
    theta_ref = math.asin(cant_ref / CANT_BASE)
    theta_rate_ref = speed * slope_ref / (CANT_BASE * math.cos(theta_ref))
    rates, loads = POSES * nb, 2 * POSES * nb
    for b in range(nb):
        x, height, mass, yaw_inertia = block[e + 1], block[e + 2], block[e + 3], block[e + 4]
        e += 6 + 3 * int(block[e + 5])
        curvature, cant, heading, integral, slope, curvature_slope = track_at(table, s_ref + x)
        # sin and cos of the cant angle from the cant itself: one transcendental a body, not four.
        sine = cant / CANT_BASE
        cosine = math.sqrt(1.0 - sine * sine)
        theta = math.asin(sine)
        theta_rate = speed * slope / (CANT_BASE * cosine)
        # Off the reference tangent: the integral of the heading's change from the reference;
        # the track plane here rolled from the reference's (the right rail up: about +x,
        # -theta) about the rail-level centreline, which moves a centre of mass at `height`.
        twist, twist_rate = theta - theta_ref, theta_rate - theta_rate_ref
        scratch[POSES * b] = integral - i_ref - x * h_ref + twist * height
        scratch[POSES * b + 1] = heading - h_ref
        scratch[POSES * b + 2] = -twist
        scratch[rates + POSES * b] = speed * (heading - h_ref - x * k_ref) + twist_rate * height
        scratch[rates + POSES * b + 1] = speed * (curvature - k_ref)
        scratch[rates + POSES * b + 2] = -twist_rate
        centripetal = speed * speed * curvature
        scratch[loads + LOADS * b] = -mass * (centripetal * cosine - gravity * sine)
        scratch[loads + LOADS * b + 1] = -mass * (gravity * cosine + centripetal * sine - gravity)
        # Along a transition the track's heading turns faster and faster under the body: in the
        # track-following frame, the frame's angular acceleration V^2*k' as a yaw moment.
        scratch[loads + LOADS * b + 2] = -yaw_inertia * speed * speed * curvature_slope
    return e


@numba.njit(cache=True)
def add_tendon_shifts(block, k, e, scratch, length, velocity):
    """Add to each tendon of the track part at `k` its shift and its rate (`e`: where the
    bodies' entries end, `scratch`: curve_state's) in `length` and `velocity` (arrays by
    tendon id, the model's lengths and rates copied)."""
    nb, nr, nt = int(block[k + 3]), int(block[k + 4]), int(block[k + 5])
    rates = POSES * nb
    for _ in range(nr):
        e += 4 + 2 * int(block[e + 3])
    for _ in range(nt):
        t, terms = int(block[e]), int(block[e + 1])
        e += 2
        shift, shift_rate = 0.0, 0.0
        for c in range(terms):
            p, coefficient = int(block[e + 2 * c]), block[e + 1 + 2 * c]
            shift += coefficient * scratch[p]
            shift_rate += coefficient * scratch[rates + p]
        e += 2 * terms
        length[t] += shift
        velocity[t] += shift_rate
        e += 1 + 2 * int(block[e])


@intrinsic
def _pointer(typingctx, array):
    """An array's data as a pointer to doubles (the callback's `block`)."""
    signature = types.CPointer(types.float64)(array)

    def codegen(context, builder, sig, args):
        return context.make_array(sig.args[0])(context, builder, args[0]).data

    return signature, codegen


@numba.njit(cache=True)
def tendon_shifts(data, k, speeds, stations, lengths, rates):
    """Add to recorded tendon `lengths` and `rates` (samples, ntendon) each sample's shifts
    (`add_tendon_shifts`), the vehicle's origin at `stations` and its speed `speeds` (samples,):
    the track part at `k` of the native block `data` (the model's first numeric, as an array)."""
    block = _pointer(data)
    scratch = np.empty(scratch_size(block, k))
    for i in range(stations.shape[0]):
        e = curve_state(block, k, speeds[i], stations[i], scratch)
        add_tendon_shifts(block, k, e, scratch, lengths[i], rates[i])
