"""The creep law as MuJoCo's passive-force callback, written for numba: the source of the native
callback (`rail_mj.simulation.native`), which compiles it once per installation into a shared
library of its own and loads that library without numba.

`_apply` reads each wheelset's state from mjData, calls the one contact law
(`rail_mj.contact.law.wheelset_contact`) and adds the forces to `qfrc_passive`. It allocates
nothing and needs nothing of numba's runtime (arrays are views of MuJoCo's memory, a scratch
buffer is on the stack), so that its machine code stands alone: libm is all it calls.
"""

from __future__ import annotations

import math

import numba
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from rail_mj.contact.law import profiled_contact, wheelset_contact
from rail_mj.numerics import (
    CACHE_KEY,
    COLUMNS,
    COUPLE,
    LOADS_HEADER,
    MAGIC,
    ROWS,
    SENSOR_CLOCK,
    SENSOR_USER,
    TRACK_AT,
    TRACK_HEADER,
    VEHICLE_HEADER,
    YAW_HINGE,
)
from rail_mj.simulation.curve import (
    add_curve_forces,
    body_loads,
    curvature_at,
    folded_forces,
    odometer,
    profiled_speed,
    push_load,
)
from rail_mj.vehicle.poses import apply_shifts, cache_size, curve_state, scratch_size, tendon_shifts_into
from rail_mj.vehicle.rails import (
    ALIGNMENT,
    ALIGNMENT_SLOPE,
    GAUGE,
    LEVEL,
    LEVEL_CURVATURE,
    LEVEL_SLOPE,
    ROLL,
    ROLL_CURVATURE,
    ROLL_SLOPE,
    irregular_at,
    next_wheelset,
    part_end,
    rails_at,
    shift_axleboxes,
    wheelsets_at,
)


@intrinsic
def _size_at(typingctx, base, offset):
    """The mjtSize (int64) stored `offset` bytes into the struct at `base`."""
    signature = types.int64(types.voidptr, types.intp)

    def codegen(context, builder, sig, args):
        field = builder.gep(builder.bitcast(args[0], ir.IntType(8).as_pointer()), [args[1]])
        return builder.load(builder.bitcast(field, ir.IntType(64).as_pointer()))

    return signature, codegen


@intrinsic
def _double_at(typingctx, base, offset):
    """The double stored `offset` bytes into the struct at `base` (mjData.time)."""
    signature = types.float64(types.voidptr, types.intp)

    def codegen(context, builder, sig, args):
        field = builder.gep(builder.bitcast(args[0], ir.IntType(8).as_pointer()), [args[1]])
        return builder.load(builder.bitcast(field, ir.DoubleType().as_pointer()))

    return signature, codegen


@intrinsic
def _int_at(typingctx, base, offset, index):
    """Entry `index` of the int array whose pointer is stored `offset` bytes into the struct at
    `base` (mjModel.sensor_type, sensor_dim)."""
    signature = types.int64(types.voidptr, types.intp, types.intp)

    def codegen(context, builder, sig, args):
        field = builder.gep(builder.bitcast(args[0], ir.IntType(8).as_pointer()), [args[1]])
        array = builder.load(builder.bitcast(field, ir.IntType(32).as_pointer().as_pointer()))
        value = builder.load(builder.gep(array, [args[2]]))
        return builder.sext(value, ir.IntType(64))

    return signature, codegen


@intrinsic
def _address(typingctx, base):
    """A struct's address as an integer (the key of a vehicle's cache: the model it was filled for)."""
    signature = types.int64(types.voidptr)

    def codegen(context, builder, sig, args):
        return builder.ptrtoint(args[0], ir.IntType(64))

    return signature, codegen


@intrinsic
def _pointer_at(typingctx, base, offset):
    """The pointer stored `offset` bytes into the struct at `base`, as doubles."""
    signature = types.CPointer(types.float64)(types.voidptr, types.intp)

    def codegen(context, builder, sig, args):
        field = builder.gep(builder.bitcast(args[0], ir.IntType(8).as_pointer()), [args[1]])
        return builder.load(builder.bitcast(field, ir.DoubleType().as_pointer().as_pointer()))

    return signature, codegen


@intrinsic
def _shifted(typingctx, base, offset):
    """`offset` doubles on from `base` (a carray of a block's part, without reshaping a slice:
    numba's reshape calls its runtime)."""
    signature = types.CPointer(types.float64)(types.CPointer(types.float64), types.intp)

    def codegen(context, builder, sig, args):
        return builder.gep(args[0], [args[1]])

    return signature, codegen


@intrinsic
def _on_stack(typingctx, count):
    """Room for `count` doubles in the calling function's frame (np.empty would need numba's
    runtime): a call's scratch buffer, gone when it returns."""
    signature = types.CPointer(types.float64)(types.intp)

    def codegen(context, builder, sig, args):
        return builder.alloca(ir.DoubleType(), size=args[0])

    return signature, codegen


@numba.njit(cache=True, inline="always")
def _wheelset_motion(chain, n, qpos, qvel, xpos, xmat, xanchor, xaxis, body):
    """A body's yaw, lateral velocity and yaw rate, in one pass over the joints between it and the
    world. The rates: v = sum of slide axes and of hinge axes x (point - anchor), times the joint
    rate. The yaw: the sum of the hinge angles where every hinge of the chain turns it about z
    (rail_mj.numerics.YAW_HINGE: their dof is their qpos) and there is one; else atan2 of its
    rotation (a chain of slides alone may carry a body built turned)."""
    vy = 0.0
    wz = 0.0
    psi = 0.0
    summed = False  # a YAW_HINGE met, and no other hinge
    other = False
    px = xpos[3 * body]
    for c in range(n):
        j, dof, flag = int(chain[3 * c]), int(chain[3 * c + 1]), chain[3 * c + 2]
        ax, ay, az = xaxis[3 * j], xaxis[3 * j + 1], xaxis[3 * j + 2]
        rate = qvel[dof]
        if flag != 0.0:
            rx, rz = px - xanchor[3 * j], xpos[3 * body + 2] - xanchor[3 * j + 2]
            vy += (az * rx - ax * rz) * rate
            wz += az * rate
            if flag == YAW_HINGE:
                psi += qpos[dof]
                summed = True
            else:
                other = True
        else:
            vy += ay * rate
    if other or not summed:
        return math.atan2(xmat[9 * body + 3], xmat[9 * body]), vy, wz
    if psi > math.pi or psi < -math.pi:  # atan2's range, which a wheelset spun round (off its rails) reaches
        psi = math.atan2(math.sin(psi), math.cos(psi))
    return psi, vy, wz


@numba.njit(cache=True, inline="always")
def _tendon_force(stiffness, damping, springlength, length, velocity, t):
    """A fixed tendon's spring and damper force (no deadband), as rail_mj.vehicle.loads.tendon_forces."""
    return -stiffness[t] * (length[t] - springlength[2 * t]) - damping[t] * velocity[t]


@numba.njit(cache=True, inline="always")
def _guiding_at(model, data, off_nsensor, off_nsensordata, off_nbody, off_sensor_type, off_sensor_dim,
                off_sensordata, off_time):  # fmt: skip
    """Where in sensordata this call writes each wheelset's Sigma Y (at the address plus the
    wheelset's body id), or -1: not a model ending with the clock and guiding sensors, or not the
    first stage of a step."""
    nsensor, nbody = _size_at(model, off_nsensor), _size_at(model, off_nbody)
    if nsensor < 2 or _int_at(model, off_sensor_type, nsensor - 1) != SENSOR_USER:
        return -1
    if _int_at(model, off_sensor_dim, nsensor - 1) != nbody:
        return -1
    if _int_at(model, off_sensor_type, nsensor - 2) != SENSOR_CLOCK:
        return -1
    start = _size_at(model, off_nsensordata) - nbody
    if _pointer_at(data, off_sensordata)[start - 1] != _double_at(data, off_time):
        return -1
    return start


@numba.njit(cache=True)
def _apply(
    model,
    data,
    off_nnumeric,
    off_ntendon,
    off_nuserdata,
    off_numeric,
    off_stiffness,
    off_damping,
    off_springlength,
    off_nsensor,
    off_nsensordata,
    off_nbody,
    off_sensor_type,
    off_sensor_dim,
    off_qvel,
    off_qpos,
    off_xpos,
    off_xmat,
    off_xanchor,
    off_xaxis,
    off_userdata,
    off_length,
    off_velocity,
    off_force,
    off_sensordata,
    off_time,
):
    """Add every vehicle's contact forces to qfrc_passive: J^T [Fy, Mz] at each wheelset's
    origin, over the slide and hinge joints between it and the world. A model without the
    block (not rail-mj's) is left alone."""
    if _size_at(model, off_nnumeric) == 0:
        return
    block = _pointer_at(model, off_numeric)
    if block[0] != MAGIC:
        return
    qpos, qvel = _pointer_at(data, off_qpos), _pointer_at(data, off_qvel)
    xpos = _pointer_at(data, off_xpos)
    xmat = _pointer_at(data, off_xmat)
    xanchor = _pointer_at(data, off_xanchor)
    xaxis = _pointer_at(data, off_xaxis)
    force = _pointer_at(data, off_force)
    stiffness, damping = _pointer_at(model, off_stiffness), _pointer_at(model, off_damping)
    springlength = _pointer_at(model, off_springlength)
    length, velocity = _pointer_at(data, off_length), _pointer_at(data, off_velocity)
    ntendon = _size_at(model, off_ntendon)
    nuserdata, userdata = _size_at(model, off_nuserdata), _pointer_at(data, off_userdata)
    cached = 2 * ntendon  # where the next vehicle's cache starts in userdata, after the copies
    # Each wheelset's Sigma Y at the state a step starts from, for the run's record, where the model
    # ends with rail-mj's clock and guiding sensors (rail_mj.numerics.GUIDING_SENSOR): the clock
    # reads the step's start (MuJoCo computes sensors in the step's first stage only), so the call
    # whose time is the clock's is that stage's, and its forces go into the guiding sensor, which
    # MuJoCo has just cleared and leaves alone until the next step's first stage.
    guiding = _guiding_at(model, data, off_nsensor, off_nsensordata, off_nbody, off_sensor_type, off_sensor_dim,
                          off_sensordata, off_time)  # fmt: skip
    sensordata = _pointer_at(data, off_sensordata)
    address = float(_address(model))
    k = 2
    for _ in range(int(block[1])):
        speed, n = block[k], int(block[k + 1])
        law, flange, falling = int(block[k + 2]), block[k + 3] != 0.0, block[k + 4] != 0.0
        rows = int(block[k + 5])
        track = k + int(block[k + TRACK_AT])
        s_ref = odometer(block, track, xpos)  # NaN on straight track
        curved = s_ref == s_ref
        if curved:  # on a speed profile the speed is the odometer's, which the profile drives
            profiled = profiled_speed(block, track, s_ref, qvel, force)
            if profiled == profiled:
                speed = profiled
        # The tendons' real deflections and rates: on a curve their model lengths plus their shifts
        # (rail_mj.vehicle.poses), copies for this call; on straight track the model's own.
        lengths, velocities = numba.carray(length, ntendon), numba.carray(velocity, ntendon)
        scratch, folded, bodies = lengths[:0], lengths[:0], 0
        if curved:
            # What the track's geometry gives the vehicle at this station and speed, in its cache in
            # mjData.userdata (rail_mj.numerics), filled where the key differs: a pure function of
            # the two, so that a hit changes no bit. A model not sized for it (built elsewhere): a
            # buffer for this call.
            size, nt = scratch_size(block, track), int(block[track + 5])
            extent = cache_size(block, track)
            if cached + extent <= nuserdata:
                cache = numba.carray(userdata, (cached + extent,))[cached:]
                copies = numba.carray(userdata, (2 * ntendon,))
                cached += extent
            else:
                buffer = numba.carray(_on_stack(extent + 2 * ntendon), (extent + 2 * ntendon,))
                cache, copies = buffer[:extent], buffer[extent:]
                cache[0] = 0.0
            scratch = cache[CACHE_KEY : CACHE_KEY + size]
            shifts = cache[CACHE_KEY + size : CACHE_KEY + size + 2 * nt]
            folded = cache[CACHE_KEY + size + 2 * nt :]
            if not (cache[0] == 1.0 and cache[1] == address and cache[2] == s_ref and cache[3] == speed):
                curve_state(block, track, speed, s_ref, scratch)
                tendon_shifts_into(block, track, scratch, shifts)
                folded_forces(block, track, scratch, folded)
                cache[0], cache[1], cache[2], cache[3] = 1.0, address, s_ref, speed
            bodies = int(block[track + 3])
            lengths, velocities = copies[:ntendon], copies[ntendon:]
            for t in range(ntendon):
                lengths[t], velocities[t] = length[t], velocity[t]
            apply_shifts(block, track, shifts, lengths, velocities)
        # An irregular track (rail_mj.vehicle.rails): each wheelset on the rails at its own station.
        rails = irregular_at(block, track) if curved else 0
        vertical = rails != 0 and block[rails + 3] != 0.0
        w = wheelsets_at(block, rails) if rails else 0
        r = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        height = 0.0
        k += VEHICLE_HEADER
        table = numba.carray(_shifted(block, k), (ROWS, n))
        k += ROWS * n
        geometry = numba.carray(_shifted(block, k), (rows, COLUMNS))
        k += rows * COLUMNS
        for i in range(n):
            body, count = int(block[k]), int(block[k + 1])
            chain = numba.carray(block, (k + 2 + 3 * count,))[k + 2 :]
            k += 2 + 3 * count
            weight, nominal, spin_inertia = block[k], block[k + 1], block[k + 2]
            cone_gravity, tendons = block[k + 3] != 0.0, int(block[k + 4])
            k += LOADS_HEADER
            if rails:
                r = rails_at(block, rails, s_ref + xpos[3 * body])
                if vertical:  # before the loads: the axlebox tendons' real deflections
                    shift_axleboxes(
                        block, w, speed, r[LEVEL], r[LEVEL_SLOPE], r[ROLL], r[ROLL_SLOPE], lengths, velocities
                    )
            load, moment = math.nan, 0.0
            if tendons:  # a spatial vehicle: its axle load and roll moment (rail_mj.vehicle.loads)
                load = weight
                for c in range(tendons):
                    f = _tendon_force(stiffness, damping, springlength, lengths, velocities, int(block[k + 3 * c]))
                    load += block[k + 3 * c + 1] * f
                    moment += block[k + 3 * c + 2] * f
                k += 3 * tendons
            pairs = int(block[k])
            for c in range(pairs):  # the axlebox loads passed on at the frame's seats (rail_mj.vehicle.loads)
                z, lateral = int(block[k + 1 + 2 * c]), int(block[k + 2 + 2 * c])
                moment -= _tendon_force(stiffness, damping, springlength, lengths, velocities, z) * lengths[lateral]
            k += 1 + 2 * pairs
            gauge = push = 0.0
            if rails:
                gauge = r[GAUGE]
                if vertical:  # the wheelset's inertia rising and rolling with the rails
                    mass, roll_inertia, height = block[w], block[w + 1], block[w + 2]
                    load += mass * speed * speed * r[LEVEL_CURVATURE]
                    moment -= roll_inertia * speed * speed * r[ROLL_CURVATURE]
                w = next_wheelset(block, w)
            if curved and bodies:  # its curve loads, which add_curve_forces leaves to this loop
                cfy, cfz, cmz = body_loads(scratch, bodies, i)
            else:
                cfy = cfz = cmz = 0.0
            if speed <= 0.0:  # no speed set: no rolling, no creep; the curve's loads alone
                if cfy != 0.0 or cfz != 0.0 or cmz != 0.0:
                    push_load(force, chain, count, xpos, xanchor, xaxis, body, cfy, cfz, cmz)
                continue
            y = xpos[3 * body + 1]
            psi, y_dot, psi_dot = _wheelset_motion(chain, count, qpos, qvel, xpos, xmat, xanchor, xaxis, body)
            if curved:  # on a curve the track turns under the wheelset: its absolute yaw rate
                psi_dot += speed * curvature_at(block, track, s_ref + xpos[3 * body])
            if rails:  # the wheelset relative to its rails (rail_mj.vehicle.rails)
                y -= r[ALIGNMENT]
                psi -= r[ALIGNMENT_SLOPE]
                y_dot -= speed * r[ALIGNMENT_SLOPE]
                if vertical:
                    y += height * r[ROLL]
                    y_dot += height * speed * r[ROLL_SLOPE]
                    push = -load * r[ROLL]  # the rails' tilted normal forces, downhill
            if rows > 0:
                f = profiled_contact(
                    geometry,
                    table[:, i],
                    law,
                    falling,
                    y,
                    psi,
                    y_dot,
                    psi_dot,
                    speed,
                    load,
                    moment,
                    spin_inertia,
                    False,
                    gauge,
                )
            else:
                f = wheelset_contact(
                    table[:, i],
                    law,
                    flange,
                    falling,
                    y,
                    psi,
                    y_dot,
                    psi_dot,
                    speed,
                    load,
                    moment,
                    nominal,
                    spin_inertia,
                    cone_gravity,
                    False,
                    gauge,
                )
            fy, mz = f[0] + f[1], f[2] + f[3] + f[4]
            if guiding >= 0:
                sensordata[guiding + body] = fy
            if push != 0.0:
                fy += push
            if f[9] != 0.0:  # the gyroscopic yaw moment (as the kernel adds it)
                mz += f[9]
            if curved and bodies:  # with the body's curve loads, in one pass over its joints
                push_load(force, chain, count, xpos, xanchor, xaxis, body, fy + cfy, cfz, mz + cmz)
                continue
            px, pz = xpos[3 * body], xpos[3 * body + 2]
            for c in range(count):
                j, dof, hinge = int(chain[3 * c]), int(chain[3 * c + 1]), chain[3 * c + 2]
                ax, ay, az = xaxis[3 * j], xaxis[3 * j + 1], xaxis[3 * j + 2]
                if hinge:  # axis . (M + r x F), F = (0, fy, 0), M = (0, 0, mz)
                    rx, rz = px - xanchor[3 * j], pz - xanchor[3 * j + 2]
                    force[dof] += ax * (-rz * fy) + az * (mz + rx * fy)
                else:
                    force[dof] += ay * fy
        couples = int(block[k])
        for c in range(couples):  # the frames' shear couples (rail_mj.vehicle.loads.ShearCouples)
            e = k + 1 + COUPLE * c
            load = _tendon_force(stiffness, damping, springlength, lengths, velocities, int(block[e]))
            force[int(block[e + 3])] -= load * lengths[int(block[e + 1])]
            force[int(block[e + 4])] += load * lengths[int(block[e + 2])]
        k += 1 + COUPLE * couples
        springs = int(block[k])
        k += 1
        for _ in range(springs):  # linear springs and dampers on the coordinates (a stepped flat model's)
            ks, cs, terms = block[k], block[k + 1], int(block[k + 2])
            k += 3
            deflection = rate = 0.0
            for c in range(terms):
                dof, coef = int(block[k + 2 * c]), block[k + 2 * c + 1]
                deflection += coef * qpos[dof]
                rate += coef * qvel[dof]
            f = -ks * deflection - cs * rate
            for c in range(terms):
                force[int(block[k + 2 * c])] += block[k + 2 * c + 1] * f
            k += 2 * terms
        if curved:
            k = add_curve_forces(
                block,
                track,
                n,
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
                lengths,
                velocities,
                force,
            )
            if rails:
                k = part_end(block, rails)
        else:
            k = track + TRACK_HEADER
