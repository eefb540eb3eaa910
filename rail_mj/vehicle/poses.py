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

from rail_mj.numerics import BREAKPOINT, CACHE_KEY, LOADS, POSES, SPEED_POINT, TRACK_HEADER
from rail_mj.track.geometry import CANT_BASE


@numba.njit(cache=True)
def last_at_or_before(block, start, stride, n, s):
    """The last of `n` rows of `stride` entries at `start` whose first entry (ascending) is at
    or before `s`, the first row's at or before it and the last's after it: a bisection."""
    lo, hi = 0, n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if block[start + stride * mid] <= s:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True)
def track_at(block, start, m, s, hint):
    """(curvature, cant, heading, heading's integral, cant's slope, curvature's slope, interval)
    at distance `s` from the `m` breakpoints at `start` in `block` (rows of BREAKPOINT: x,
    curvature, cant, heading, heading's integral), curvature and cant linear between breakpoints
    and held beyond the ends; `hint`, an interval to try before searching (the reference's: a
    vehicle's bodies are metres apart, breakpoints mostly hundreds), -1 beyond the ends.

    Read through the pointer, not as a (m, BREAKPOINT) view: a view costs more than the lookup.
    Where curvature or cant is constant between two breakpoints (a curve's constant part, a
    straight) their ramps' divisions are left out: they would add exact zeros."""
    if s <= block[start]:
        t = s - block[start]
        k = block[start + 1]
        heading, integral = block[start + 3], block[start + 4]
        return k, block[start + 2], heading + k * t, integral + heading * t + 0.5 * k * t * t, 0.0, 0.0, -1
    last = start + BREAKPOINT * (m - 1)
    if s >= block[last]:
        t = s - block[last]
        k = block[last + 1]
        heading, integral = block[last + 3], block[last + 4]
        return k, block[last + 2], heading + k * t, integral + heading * t + 0.5 * k * t * t, 0.0, 0.0, -1
    if 0 <= hint < m - 1 and block[start + BREAKPOINT * hint] <= s < block[start + BREAKPOINT * (hint + 1)]:
        i = hint
    else:
        i = last_at_or_before(block, start, BREAKPOINT, m, s)
    p = start + BREAKPOINT * i
    q = p + BREAKPOINT
    length = block[q] - block[p]
    t = s - block[p]
    k0, dk = block[p + 1], block[q + 1] - block[p + 1]
    heading0, integral0 = block[p + 3], block[p + 4]
    # The ramps' terms are exact zeros where dk (or the cant's step) is 0: + 0.0 keeps their sum's bits.
    if dk == 0.0:
        curvature, curvature_slope = k0 + 0.0, 0.0
        heading = heading0 + k0 * t + 0.0
        integral = integral0 + heading0 * t + 0.5 * k0 * t * t + 0.0
    else:
        curvature, curvature_slope = k0 + dk * t / length, dk / length
        heading = heading0 + k0 * t + dk * t * t / (2.0 * length)
        integral = integral0 + heading0 * t + 0.5 * k0 * t * t + dk * t * t * t / (6.0 * length)
    rise = block[q + 2] - block[p + 2]
    slope = rise / length if rise != 0.0 else 0.0
    return curvature, block[p + 2] + slope * t, heading, integral, slope, curvature_slope, i


@numba.njit(cache=True, inline="always")
def breakpoints_at(block, k):
    """Where the breakpoints of the track part at `k` start: after its header and speed points."""
    return k + TRACK_HEADER + SPEED_POINT * int(block[k + 7])


@numba.njit(cache=True, inline="always")
def entries_at(block, k):
    """Where the entries' index of the track part at `k` starts, after its breakpoints: where
    each body's, joint's and tendon's entry starts, then one past the last (rail_mj.numerics)."""
    return breakpoints_at(block, k) + BREAKPOINT * int(block[k + 2])


@numba.njit(cache=True, inline="always")
def entry_at(block, k, i):
    """Where entry `i` of the track part at `k` starts (bodies, then joints, then tendons, then
    one past the last)."""
    return k + int(block[entries_at(block, k) + i])


@numba.njit(cache=True, inline="always")
def cache_size(block, k):
    """The size of the callback's cache for the track part at `k` (rail_mj.numerics.cache_size)."""
    nb, nr, nt = int(block[k + 3]), int(block[k + 4]), int(block[k + 5])
    return CACHE_KEY + (2 * POSES + LOADS) * nb + 2 * nt + nr


@numba.njit(cache=True, inline="always")
def scratch_size(block, k):
    """The size of `curve_state`'s scratch for the track part at `k`."""
    return (2 * POSES + LOADS) * int(block[k + 3])


@numba.njit(cache=True)
def curve_state(block, k, speed, s_ref, scratch):
    """The track part at `k` with the vehicle's origin at station `s_ref`: fill `scratch`
    (`scratch_size`, the caller's: nothing is shared between threads) with each body's pose
    (POSES per body: lateral offset, heading, cant roll), their rates, then its curve loads (fy,
    fz, mz: rail_mj.simulation.curve)."""
    gravity = block[k + 1]
    m, nb = int(block[k + 2]), int(block[k + 3])
    start = breakpoints_at(block, k)
    k_ref, cant_ref, h_ref, i_ref, slope_ref, _, interval = track_at(block, start, m, s_ref, -1)
    # The reference: the track plane at the vehicle's origin, which the model's world is.
    theta_ref = math.asin(cant_ref / CANT_BASE)
    theta_rate_ref = speed * slope_ref
    if slope_ref != 0.0:
        theta_rate_ref /= CANT_BASE * math.cos(theta_ref)
    # The cant's angle, sine and cosine at the last cant met: on a constant cant (a curve's body,
    # a straight) every body has the reference's, and the transcendentals are taken once a call.
    sine_ref = cant_ref / CANT_BASE
    cosine_ref = math.sqrt(1.0 - sine_ref * sine_ref)
    last_cant, sine, cosine, theta = cant_ref, sine_ref, cosine_ref, theta_ref
    rates, loads = POSES * nb, 2 * POSES * nb
    # Steady: the reference between two breakpoints of equal curvature and cant (a curve's constant
    # part, a straight), where every body between the same two has its pose in closed form.
    steady, low, high = False, 0.0, 0.0
    if interval >= 0:
        p = start + BREAKPOINT * interval
        q = p + BREAKPOINT
        steady = block[q + 1] == block[p + 1] and block[q + 2] == block[p + 2]
        low, high = block[p], block[q]
    for b in range(nb):
        e = entry_at(block, k, b)
        x, height, mass, yaw_inertia = block[e + 1], block[e + 2], block[e + 3], block[e + 4]
        if steady and low <= s_ref + x < high:
            # On a constant curvature k the body at x off the reference lies k*x^2/2 off its tangent,
            # turned by k*x, in the same plane, and none of them changes as the vehicle runs: the
            # general form's difference of the heading's integrals, to its round-off.
            scratch[POSES * b] = 0.5 * k_ref * x * x
            scratch[POSES * b + 1] = k_ref * x
            scratch[POSES * b + 2] = 0.0
            scratch[rates + POSES * b] = 0.0
            scratch[rates + POSES * b + 1] = 0.0
            scratch[rates + POSES * b + 2] = 0.0
            centripetal = speed * speed * k_ref
            scratch[loads + LOADS * b] = -mass * (centripetal * cosine_ref - gravity * sine_ref)
            scratch[loads + LOADS * b + 1] = -mass * (gravity * cosine_ref + centripetal * sine_ref - gravity)
            scratch[loads + LOADS * b + 2] = 0.0
            continue
        curvature, cant, heading, integral, slope, curvature_slope, _ = track_at(block, start, m, s_ref + x, interval)
        if cant != last_cant:
            # sin and cos of the cant angle from the cant itself: one transcendental a body, not four.
            last_cant, sine = cant, cant / CANT_BASE
            cosine = math.sqrt(1.0 - sine * sine)
            theta = math.asin(sine)
        theta_rate = speed * slope
        if slope != 0.0:
            theta_rate /= CANT_BASE * cosine
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


@numba.njit(cache=True)
def tendon_shifts_into(block, k, scratch, shifts):
    """Each listed tendon's shift and its rate (`shifts`, 2 per tendon in the order listed) of the
    track part at `k`, from curve_state's `scratch`."""
    nb, nr, nt = int(block[k + 3]), int(block[k + 4]), int(block[k + 5])
    rates = POSES * nb
    index = entries_at(block, k) + nb + nr
    for i in range(nt):
        e = k + int(block[index + i])
        terms = int(block[e + 1])
        shift, shift_rate = 0.0, 0.0
        for c in range(terms):
            p, coefficient = int(block[e + 2 + 2 * c]), block[e + 3 + 2 * c]
            shift += coefficient * scratch[p]
            shift_rate += coefficient * scratch[rates + p]
        shifts[2 * i], shifts[2 * i + 1] = shift, shift_rate


@numba.njit(cache=True)
def apply_shifts(block, k, shifts, length, velocity):
    """Add the listed tendons' `shifts` (tendon_shifts_into's) to `length` and `velocity`
    (arrays by tendon id, the model's lengths and rates copied)."""
    nb, nr, nt = int(block[k + 3]), int(block[k + 4]), int(block[k + 5])
    index = entries_at(block, k) + nb + nr
    for i in range(nt):
        t = int(block[k + int(block[index + i])])
        length[t] += shifts[2 * i]
        velocity[t] += shifts[2 * i + 1]


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
    shifts = np.empty(2 * int(block[k + 5]))
    for i in range(stations.shape[0]):
        curve_state(block, k, speeds[i], stations[i], scratch)
        tendon_shifts_into(block, k, scratch, shifts)
        apply_shifts(block, k, shifts, lengths[i], rates[i])
