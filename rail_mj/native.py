"""The creep law as MuJoCo's passive-force callback in native code: no Python in a step.

`rail_mj.forces.CreepForces` is the same physics in Python: readable, and what the tests
compare this with. This module compiles a C callback with numba that reads each
wheelset's state from mjData, calls the one contact law (`rail_mj.creep.wheelset_contact`)
and adds the forces to `qfrc_passive`. It holds the GIL never and shares no buffer, so
MuJoCo may call it from many threads at once (`mujoco.rollout`, `mujoco.batch`).

Everything it needs comes from the model, so a batch may mix vehicles and speeds:
the custom numeric `rail_mj/native` (the model's first numeric) lists, per vehicle, its
speed, its creep law and contact parameters, and per wheelset its body and the joints
between it and the world (for the Jacobian). `Vehicle` writes it; `set_speed` changes
the speed of a compiled model.

The callback reads mjModel and mjData through byte offsets taken from MuJoCo's own struct
declarations (`mujoco.introspect`, generated from the installed version's headers) and
checked, before the callback is first compiled, against the arrays the Python bindings
expose: on a MuJoCo whose structs differ, `callback()` raises NativeError with a message,
never a wrong force.

Example:

    >>> import mujoco
    >>> from rail_mj.layout import load_layout
    >>> from rail_mj.model import Vehicle
    >>> vehicle = Vehicle(load_layout("models/wheelset/wheelset.toml"))
    >>> set_speed(vehicle.model, 20.0)
    >>> data = mujoco.MjData(vehicle.model)
    >>> data.qpos[0] = 0.003
    >>> with installed():
    ...     mujoco.mj_forward(vehicle.model, data)
    >>> round(float(data.qfrc_passive[1]))   # -2*f11*b*lam*y/r0, yawing it back
    -9783
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import threading

import mujoco
import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from rail_mj.creep import ROWS, profiled_contact, wheelset_contact
from rail_mj.tables import COLUMNS
from rail_mj.forces import contact_parameters
from rail_mj.loads import AxleLoads, ShearCouples
from rail_mj.model import NUMERIC_NATIVE

# --- the layout of MuJoCo's structs, from the installed version's declarations ----------

_VALUE_TYPES = {
    "mjtNum": ctypes.c_double, "double": ctypes.c_double, "float": ctypes.c_float,
    "mjtSize": ctypes.c_int64, "int": ctypes.c_int, "unsigned int": ctypes.c_uint,
    "size_t": ctypes.c_size_t, "uintptr_t": ctypes.c_size_t, "uint64_t": ctypes.c_uint64,
    "mjtBool": ctypes.c_ubyte, "mjtByte": ctypes.c_ubyte, "char": ctypes.c_char,
}


class NativeError(ValueError):
    """The native callback cannot run on this MuJoCo, or on this model."""


def _ctype(declared, structs):
    kind = type(declared).__name__
    if kind == "PointerType":
        return ctypes.c_void_p
    if kind == "ArrayType":
        inner = _ctype(declared.inner_type, structs)
        for extent in reversed(declared.extents):
            inner = inner * extent
        return inner
    if kind == "ValueType":
        if declared.name in _VALUE_TYPES:
            return _VALUE_TYPES[declared.name]
        if declared.name in structs:
            return _struct(declared.name, structs)
        if declared.name.startswith("mjt"):  # an enum
            return ctypes.c_int
    if kind == "AnonymousStructDecl":
        return type("anonymous", (ctypes.Structure,),
                    {"_fields_": [(f.name, _ctype(f.type, structs)) for f in declared.fields]})
    raise NativeError(f"MuJoCo {mujoco.__version__}: cannot lay out a field of type {declared}")


_LAYOUTS: dict[str, type] = {}


def _struct(name: str, structs) -> type:
    if name not in _LAYOUTS:
        fields = [(f.name, _ctype(f.type, structs)) for f in structs[name].fields]
        _LAYOUTS[name] = type(name, (ctypes.Structure,), {"_fields_": fields})
    return _LAYOUTS[name]


# What the callback reads: model sizes and the numeric data; data arrays it reads and writes.
MODEL_FIELDS = ("nnumeric", "numeric_data", "tendon_stiffness", "tendon_damping", "tendon_lengthspring")
DATA_FIELDS = ("qvel", "xpos", "xmat", "xanchor", "xaxis", "ten_length", "ten_velocity", "qfrc_passive")


def _offsets() -> tuple[int, ...]:
    """Byte offsets of MODEL_FIELDS in mjModel and DATA_FIELDS in mjData, checked on a live
    model against the arrays the bindings expose."""
    from mujoco.introspect import structs

    try:
        model_layout = _struct("mjModel", structs.STRUCTS)
        data_layout = _struct("mjData", structs.STRUCTS)
    except (KeyError, AttributeError) as e:
        raise NativeError(f"MuJoCo {mujoco.__version__}: its struct declarations are not as expected "
                          f"({e}); use the Python callback (rail_mj.forces)") from None
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><custom><numeric name="probe" data="1 2 3"/></custom><worldbody><body>'
        '<joint name="j" type="hinge"/><geom size="0.1"/></body></worldbody>'
        '<tendon><fixed stiffness="1"><joint joint="j" coef="1"/></fixed></tendon></mujoco>')
    data = mujoco.MjData(model)
    offsets = []
    for layout, obj, names in ((model_layout, model, MODEL_FIELDS), (data_layout, data, DATA_FIELDS)):
        live = layout.from_address(obj._address)
        for name in names:
            value = getattr(obj, name)
            expected = value.ctypes.data if isinstance(value, np.ndarray) else value
            if getattr(live, name) != expected:
                raise NativeError(f"MuJoCo {mujoco.__version__}: {layout.__name__}.{name} is not where its "
                                  f"declaration puts it; use the Python callback (rail_mj.forces)")
            offsets.append(getattr(layout, name).offset)
    return tuple(offsets)


# --- the numeric block that carries a model's vehicles -----------------------------------

# The block's first number, "this is rail-mj's native block, version 4": six significant
# figures, as MuJoCo's MJCF writer keeps them.
MAGIC = 7043.04
# Per vehicle: speed, wheelset count, law, flange (0/1), falling friction (0/1), the number
# of rows of its profile contact table (0: coned wheels), then the contact parameters
# (ContactParameters.table, row-major), the profile contact table (rail_mj.tables,
# row-major), then per wheelset its body and the joints from it to the world: count, then
# (joint, dof, 1 for a hinge / 0 for a slide); then its weight (N), the nominal wheel load
# (N), its spin inertia (gyroscopic terms; 0: off), the cones' gravitational stiffness (0/1)
# and its axlebox tendons (rail_mj.loads): count, then (tendon, on P, on M); count 0: the
# wheels carry the static load; then its shear couples: count, then (z tendon, y tendon).
# After the wheelsets, the frames' shear couples (rail_mj.loads.ShearCouples): count, then
# (z, y, x tendon, roll dof, pitch dof).
LOADS_HEADER = 5
COUPLE = 5
VEHICLE_HEADER = 6
_SLIDE, _HINGE = int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE)
SPEED = 0  # offset of the speed within a vehicle's entries


def vehicle_block(model: mujoco.MjModel, wheelset_bodies, params, speed: float = 0.0, loads=None,
                  prefix: str = "", couples=None) -> np.ndarray:
    """One vehicle's entries of the block: see VEHICLE_HEADER. `loads`: its AxleLoads
    (rail_mj.loads), its tendons named in `model` under `prefix`; None: static loads.
    `couples`: its frames' ShearCouples, or None."""
    table, geometry = params.table, params.geometry
    entries = [speed, len(wheelset_bodies), params.law, float(params.flange), float(params.falling),
               float(geometry.shape[0])]
    entries += list(table.reshape(-1)) + list(geometry.reshape(-1))
    for i, body in enumerate(wheelset_bodies):
        chain = []
        b = int(body)
        while b:
            for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
                kind = int(model.jnt_type[j])
                if kind not in (_SLIDE, _HINGE):
                    raise NativeError(f"joint {model.joint(j).name}: the native callback handles slide "
                                      f"and hinge joints only")
                chain += [j, model.jnt_dofadr[j], float(kind == _HINGE)]
            b = model.body_parentid[b]
        entries += [body, len(chain) // 3] + chain
        if loads is None:
            entries += [0.0] * LOADS_HEADER
        else:
            rows = loads.rows(model, i, prefix)
            entries += [loads.weight, loads.nominal, loads.spin_inertia, float(loads.cone_gravity),
                        float(len(rows))] + list(rows.reshape(-1))
        pairs = loads.shear_rows(model, i, prefix) if loads is not None else np.zeros((0, 2))
        entries += [float(len(pairs))] + list(pairs.reshape(-1))
    rows = couples.rows(model, prefix) if couples is not None else np.zeros((0, COUPLE))
    entries += [float(len(rows))] + list(rows.reshape(-1))
    return np.asarray(entries, dtype=np.float64)


def block(vehicles: list[np.ndarray]) -> np.ndarray:
    """The whole numeric: MAGIC, the number of vehicles, then each vehicle's entries."""
    return np.concatenate([[MAGIC, float(len(vehicles))], *vehicles])


def block_for(model: mujoco.MjModel, n_wheelsets: int) -> np.ndarray:
    """The block of a model built by rail_mj.model: one vehicle, wheelset1..N, its contact
    parameters read from the model's named numerics, no speed yet."""
    names = [f"wheelset{i + 1}" for i in range(n_wheelsets)]
    bodies = [model.body(name).id for name in names]
    return block([vehicle_block(model, bodies, contact_parameters(model, n_wheelsets), loads=AxleLoads.of(model, names),
                                couples=ShearCouples.of(model))])


def _block_of(model: mujoco.MjModel) -> np.ndarray:
    if model.nnumeric == 0 or model.numeric(0).name != NUMERIC_NATIVE or model.numeric_data[0] != MAGIC:
        raise NativeError(f"model {model.names[:40]!r}...: its first numeric is not {NUMERIC_NATIVE}; "
                          f"build it with rail_mj.model.Vehicle")
    return model.numeric_data


def vehicle_starts(model: mujoco.MjModel) -> list[int]:
    """Where each vehicle's entries start in the block."""
    data = _block_of(model)
    starts, k = [], 2
    for _ in range(int(data[1])):
        starts.append(k)
        n, rows = int(data[k + 1]), int(data[k + 5])
        k += VEHICLE_HEADER + ROWS * n + rows * COLUMNS
        for _ in range(n):
            k += 2 + 3 * int(data[k + 1])
            k += LOADS_HEADER + 3 * int(data[k + LOADS_HEADER - 1])
            k += 1 + 2 * int(data[k])
        k += 1 + COUPLE * int(data[k])
    return starts


def set_speed(model: mujoco.MjModel, speed: float, vehicle: int | None = None) -> None:
    """Set the forward speed (m/s) of one vehicle of `model` (all of them by default)."""
    if not (math.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be a positive number, got {speed}")
    starts = vehicle_starts(model)
    for k in starts if vehicle is None else [starts[vehicle]]:
        model.numeric_data[k + SPEED] = speed


# --- the callback -------------------------------------------------------------------------

@intrinsic
def _size_at(typingctx, base, offset):
    """The mjtSize (int64) stored `offset` bytes into the struct at `base`."""
    signature = types.int64(types.voidptr, types.intp)

    def codegen(context, builder, sig, args):
        field = builder.gep(builder.bitcast(args[0], ir.IntType(8).as_pointer()), [args[1]])
        return builder.load(builder.bitcast(field, ir.IntType(64).as_pointer()))

    return signature, codegen


@intrinsic
def _pointer_at(typingctx, base, offset):
    """The pointer stored `offset` bytes into the struct at `base`, as doubles."""
    signature = types.CPointer(types.float64)(types.voidptr, types.intp)

    def codegen(context, builder, sig, args):
        field = builder.gep(builder.bitcast(args[0], ir.IntType(8).as_pointer()), [args[1]])
        return builder.load(builder.bitcast(field, ir.DoubleType().as_pointer().as_pointer()))

    return signature, codegen


@numba.njit(cache=True)
def _wheelset_rates(chain, n, qvel, xpos, xanchor, xaxis, body):
    """Lateral velocity and yaw rate of a body's origin from the joints between it and the
    world: v = sum of slide axes and of hinge axes x (point - anchor), times the joint rate."""
    vy = 0.0
    wz = 0.0
    px, py = xpos[3 * body], xpos[3 * body + 1]
    for c in range(n):
        j, dof, hinge = int(chain[3 * c]), int(chain[3 * c + 1]), chain[3 * c + 2]
        ax, ay, az = xaxis[3 * j], xaxis[3 * j + 1], xaxis[3 * j + 2]
        rate = qvel[dof]
        if hinge:
            rx, rz = px - xanchor[3 * j], xpos[3 * body + 2] - xanchor[3 * j + 2]
            vy += (az * rx - ax * rz) * rate
            wz += az * rate
        else:
            vy += ay * rate
    return vy, wz


@numba.njit(cache=True, inline="always")
def _tendon_force(stiffness, damping, springlength, length, velocity, t):
    """A fixed tendon's spring and damper force (no deadband), as rail_mj.loads.tendon_forces."""
    return -stiffness[t] * (length[t] - springlength[2 * t]) - damping[t] * velocity[t]


@numba.njit(cache=True)
def _apply(model, data, off_nnumeric, off_numeric, off_stiffness, off_damping, off_springlength, off_qvel, off_xpos,
           off_xmat, off_xanchor, off_xaxis, off_length, off_velocity, off_force):
    """Add every vehicle's contact forces to qfrc_passive: J^T [Fy, Mz] at each wheelset's
    origin, over the slide and hinge joints between it and the world. A model without the
    block (not rail-mj's) is left alone."""
    if _size_at(model, off_nnumeric) == 0:
        return
    block = _pointer_at(model, off_numeric)
    if block[0] != MAGIC:
        return
    qvel = _pointer_at(data, off_qvel)
    xpos = _pointer_at(data, off_xpos)
    xmat = _pointer_at(data, off_xmat)
    xanchor = _pointer_at(data, off_xanchor)
    xaxis = _pointer_at(data, off_xaxis)
    force = _pointer_at(data, off_force)
    stiffness, damping = _pointer_at(model, off_stiffness), _pointer_at(model, off_damping)
    springlength = _pointer_at(model, off_springlength)
    length, velocity = _pointer_at(data, off_length), _pointer_at(data, off_velocity)
    k = 2
    for _ in range(int(block[1])):
        speed, n = block[k], int(block[k + 1])
        law, flange, falling = int(block[k + 2]), block[k + 3] != 0.0, block[k + 4] != 0.0
        rows = int(block[k + 5])
        k += VEHICLE_HEADER
        table = numba.carray(block, (k + ROWS * n,))[k:].reshape((ROWS, n))
        k += ROWS * n
        geometry = numba.carray(block, (k + rows * COLUMNS,))[k:].reshape((rows, COLUMNS))
        k += rows * COLUMNS
        for i in range(n):
            body, count = int(block[k]), int(block[k + 1])
            chain = numba.carray(block, (k + 2 + 3 * count,))[k + 2:]
            k += 2 + 3 * count
            weight, nominal, spin_inertia = block[k], block[k + 1], block[k + 2]
            cone_gravity, tendons = block[k + 3] != 0.0, int(block[k + 4])
            k += LOADS_HEADER
            load, moment = math.nan, 0.0
            if tendons:  # a spatial vehicle: its axle load and roll moment (rail_mj.loads)
                load = weight
                for c in range(tendons):
                    f = _tendon_force(stiffness, damping, springlength, length, velocity, int(block[k + 3 * c]))
                    load += block[k + 3 * c + 1] * f
                    moment += block[k + 3 * c + 2] * f
                k += 3 * tendons
            pairs = int(block[k])
            for c in range(pairs):  # the axlebox loads passed on at the frame's seats (rail_mj.loads)
                z, lateral = int(block[k + 1 + 2 * c]), int(block[k + 2 + 2 * c])
                moment -= _tendon_force(stiffness, damping, springlength, length, velocity, z) * length[lateral]
            k += 1 + 2 * pairs
            if speed <= 0.0:
                continue  # no speed set: no rolling, no creep
            y = xpos[3 * body + 1]
            psi = math.atan2(xmat[9 * body + 3], xmat[9 * body])
            y_dot, psi_dot = _wheelset_rates(chain, count, qvel, xpos, xanchor, xaxis, body)
            if rows > 0:
                f = profiled_contact(geometry, table[:, i], law, falling, y, psi, y_dot, psi_dot, speed, load, moment,
                                     spin_inertia)
            else:
                f = wheelset_contact(table[:, i], law, flange, falling, y, psi, y_dot, psi_dot, speed, load, moment,
                                     nominal, spin_inertia, cone_gravity)
            fy, mz = f[0] + f[1], f[2] + f[3] + f[4]
            if f[9] != 0.0:  # the gyroscopic yaw moment (as the kernel adds it)
                mz += f[9]
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
        for c in range(couples):  # the frames' shear couples (rail_mj.loads.ShearCouples)
            e = k + 1 + COUPLE * c
            load = _tendon_force(stiffness, damping, springlength, length, velocity, int(block[e]))
            force[int(block[e + 3])] -= load * length[int(block[e + 1])]
            force[int(block[e + 4])] += load * length[int(block[e + 2])]
        k += 1 + COUPLE * couples


_CALLBACK = None
_CALLBACK_LOCK = threading.Lock()


def callback():
    """The C function pointer MuJoCo's passive callback takes (compiled once a process)."""
    global _CALLBACK
    with _CALLBACK_LOCK:
        if _CALLBACK is None:
            _CALLBACK = _compile()
    return _CALLBACK[1]


def _compile():
    """The cfunc and its ctypes pointer. The offsets are constants of this process's
    MuJoCo, so the cfunc itself is not cached on disk (the law it calls is)."""
    offsets = _offsets()

    @numba.cfunc(types.void(types.voidptr, types.voidptr), nopython=True)
    def passive(model, data):
        _apply(model, data, *offsets)

    return passive, ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)(passive.address)


_users = 0  # blocks inside `installed`, in every thread
_users_lock = threading.Lock()


@contextlib.contextmanager
def installed():
    """Install the native callback while any thread needs it, and remove it after the last.

    One callback serves every model (each carries its own block; a model without one is
    left alone), so threads that step different vehicles at different speeds share it.
    The Python callback (rail_mj.forces) cannot be installed meanwhile.
    """
    global _users
    pointer = callback()
    with _users_lock:
        if _users == 0:
            if mujoco.get_mjcb_passive() is not None:
                raise RuntimeError("another MuJoCo passive callback is already installed")
            mujoco.set_mjcb_passive(pointer)
        _users += 1
    try:
        yield
    finally:
        with _users_lock:
            _users -= 1
            if _users == 0:
                mujoco.set_mjcb_passive(None)
