"""The creep law as MuJoCo's passive-force callback in native code: no Python in a step.

`rail_mj.simulation.callback.CreepForces` is the same physics in Python: readable, and what the tests
compare this with. The callback's code is `rail_mj.simulation.kernel._apply` (numba): it reads each
wheelset's state from mjData, calls the one contact law (`rail_mj.contact.law.wheelset_contact`)
and adds the forces to `qfrc_passive`. This module builds it, with this MuJoCo's struct offsets,
into the installation's library (rail_mj.compiled) and hands MuJoCo its pointer; where no library
can be built, numba compiles it here. It holds the GIL never and shares no buffer, so
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
    >>> from rail_mj.vehicle.spec import Vehicle
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
import threading
from typing import cast

import mujoco
import numpy as np

from rail_mj import compiled
from rail_mj.vehicle.block import NativeError, set_speed  # noqa: F401  (re-exported: a native model's speed)

# --- the layout of MuJoCo's structs, from the installed version's declarations ----------

_VALUE_TYPES = {
    "mjtNum": ctypes.c_double,
    "double": ctypes.c_double,
    "float": ctypes.c_float,
    "mjtSize": ctypes.c_int64,
    "int": ctypes.c_int,
    "unsigned int": ctypes.c_uint,
    "size_t": ctypes.c_size_t,
    "uintptr_t": ctypes.c_size_t,
    "uint64_t": ctypes.c_uint64,
    "mjtBool": ctypes.c_ubyte,
    "mjtByte": ctypes.c_ubyte,
    "char": ctypes.c_char,
}


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
        return type(
            "anonymous", (ctypes.Structure,), {"_fields_": [(f.name, _ctype(f.type, structs)) for f in declared.fields]}
        )
    raise NativeError(f"MuJoCo {mujoco.__version__}: cannot lay out a field of type {declared}")


_LAYOUTS: dict[str, type[ctypes.Structure]] = {}


def _struct(name: str, structs) -> type[ctypes.Structure]:
    if name not in _LAYOUTS:
        fields = [(f.name, _ctype(f.type, structs)) for f in structs[name].fields]
        # type() with three arguments is typed as returning a plain `type`: this one is a Structure.
        _LAYOUTS[name] = cast(type[ctypes.Structure], type(name, (ctypes.Structure,), {"_fields_": fields}))
    return _LAYOUTS[name]


# What the callback reads: model sizes and the numeric data; data arrays it reads and writes.
MODEL_FIELDS = (
    "nnumeric",
    "ntendon",
    "nuserdata",
    "numeric_data",
    "tendon_stiffness",
    "tendon_damping",
    "tendon_lengthspring",
    "nsensor",
    "nsensordata",
    "nbody",
    "sensor_type",
    "sensor_dim",
)
DATA_FIELDS = (
    "qvel",
    "qpos",
    "xpos",
    "xmat",
    "xanchor",
    "xaxis",
    "userdata",
    "ten_length",
    "ten_velocity",
    "qfrc_passive",
    "sensordata",
    "time",
)


def _offsets() -> tuple[int, ...]:
    """Byte offsets of MODEL_FIELDS in mjModel and DATA_FIELDS in mjData, checked on a live
    model against the arrays the bindings expose."""
    from mujoco.introspect import structs

    try:
        model_layout = _struct("mjModel", structs.STRUCTS)
        data_layout = _struct("mjData", structs.STRUCTS)
    except (KeyError, AttributeError) as e:
        raise NativeError(
            f"MuJoCo {mujoco.__version__}: its struct declarations are not as expected "
            f"({e}); use the Python callback (rail_mj.simulation.callback)"
        ) from None
    model = mujoco.MjModel.from_xml_string(
        '<mujoco><size nuserdata="2"/><custom><numeric name="probe" data="1 2 3"/></custom><worldbody><body>'
        '<joint name="j" type="hinge"/><geom size="0.1"/></body></worldbody>'
        '<tendon><fixed stiffness="1"><joint joint="j" coef="1"/></fixed></tendon><sensor><clock/></sensor></mujoco>'
    )
    data = mujoco.MjData(model)
    offsets = []
    for layout, obj, names in ((model_layout, model, MODEL_FIELDS), (data_layout, data, DATA_FIELDS)):
        live = layout.from_address(obj._address)
        for name in names:
            value = getattr(obj, name)
            expected = value.ctypes.data if isinstance(value, np.ndarray) else value
            if getattr(live, name) != expected:
                raise NativeError(
                    f"MuJoCo {mujoco.__version__}: {layout.__name__}.{name} is not where its "
                    f"declaration puts it; use the Python callback (rail_mj.simulation.callback)"
                )
            offsets.append(getattr(layout, name).offset)
    return tuple(offsets)


# --- the library: the kernel's machine code beside a few lines of C (rail_mj.compiled) -------

# MuJoCo's callback around the kernel, and the clock stepping threads give MuJoCo, so that a
# process that steps never imports numba.
_C_SOURCE = r"""/* Written by rail_mj.simulation.native for MuJoCo {version}. */
#include <math.h>
#include <stdint.h>

/* rail_mj.simulation.kernel._apply with this MuJoCo's struct offsets, as numba compiled it. */
int rail_mj_apply(void **result, void **exception, void *model, void *data);

static int64_t failures;

void rail_mj_passive(void *model, void *data) {{
    void *result = 0, *exception = 0;
    int status = rail_mj_apply(&result, &exception, model, data);
    if (status != 0 && status != -2) {{
        /* The law raised (a division by zero): none of its forces can be trusted. A NaN makes
           the step's accelerations NaN, which every run reads as divergence. */
        __atomic_add_fetch(&failures, 1, __ATOMIC_RELAXED);
        (*(double **)((char *)data + {force_offset}))[0] = NAN;
    }}
}}

int64_t rail_mj_failures(void) {{ return __atomic_load_n(&failures, __ATOMIC_RELAXED); }}

/* MuJoCo's clock for stepping threads (rail_mj.simulation.stepping): always 0, no system call. */
double rail_mj_zero_clock(void) {{ return 0.0; }}
"""

_PASSIVE = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
_CLOCK = ctypes.CFUNCTYPE(ctypes.c_double)


class Native:
    """This process's native callback (`passive`, the pointer MuJoCo's passive callback takes)
    and the clock beside it (`clock`, reading 0). From the installation's library (`kind` is
    "library", rail_mj.compiled) or, where none can be built, from numba in this process
    ("numba")."""

    def __init__(self, kind: str, passive, clock, library: ctypes.CDLL | None = None, keep=()):
        self.kind, self.passive, self.clock = kind, passive, clock
        self._library = library
        self._keep = keep  # the numba cfuncs the pointers point into, alive while this is
        if library is not None:
            library.rail_mj_failures.restype = ctypes.c_int64

    def failures(self) -> int:
        """How many calls of the library's callback found the law raising (each made its step NaN;
        numba's cfunc reports its own)."""
        return int(self._library.rail_mj_failures()) if self._library is not None else 0


_NATIVE: Native | None = None
_NATIVE_LOCK = threading.Lock()


def native() -> Native:
    """This process's native callback: the installation's library, built by the first process
    that needs it (numba compiles the kernel, 10 to 20 s; the C compiler links it), else numba's
    cfunc compiled here."""
    global _NATIVE
    with _NATIVE_LOCK:
        if _NATIVE is None:
            offsets = _offsets()
            source = _source(offsets)
            library = compiled.load("passive", _key(offsets), source, lambda: {"rail_mj_apply": _cfuncs(offsets)[0]})
            if library is None:
                passive, clock = _cfuncs(offsets)
                _NATIVE = Native("numba", _PASSIVE(passive.address), _CLOCK(clock.address), keep=(passive, clock))
            else:
                passive_at = _PASSIVE(int(ctypes.cast(library.rail_mj_passive, ctypes.c_void_p).value or 0))
                clock_at = _CLOCK(int(ctypes.cast(library.rail_mj_zero_clock, ctypes.c_void_p).value or 0))
                _NATIVE = Native("library", passive_at, clock_at, library)
    return _NATIVE


def callback():
    """The C function pointer MuJoCo's passive callback takes."""
    return native().passive


def library_path():
    """Where this installation keeps the callback's library (it may not be built yet)."""
    offsets = _offsets()
    return compiled.library_path("passive", _key(offsets), _source(offsets))


def _key(offsets: tuple[int, ...]) -> str:
    return f"MuJoCo {mujoco.__version__}, offsets {offsets}"


def _source(offsets: tuple[int, ...]) -> str:
    force_offset = offsets[len(MODEL_FIELDS) + DATA_FIELDS.index("qfrc_passive")]
    return _C_SOURCE.format(version=mujoco.__version__, force_offset=force_offset)


def _cfuncs(offsets: tuple[int, ...]):
    """numba's cfuncs of the kernel with these offsets (constants in its code) and of the clock,
    compiled in this process."""
    import numba
    from numba import types

    from rail_mj.contact.law import compile_apart
    from rail_mj.simulation.kernel import _apply

    compile_apart()

    @numba.cfunc(types.void(types.voidptr, types.voidptr), nopython=True)
    def passive(model, data):
        _apply(model, data, *offsets)

    @numba.cfunc(types.float64(), nopython=True)
    def clock():
        return 0.0

    return passive, clock


_users = 0  # blocks inside `installed`, in every thread
_users_lock = threading.Lock()


@contextlib.contextmanager
def installed():
    """Install the native callback while any thread needs it, and remove it after the last.

    One callback serves every model (each carries its own block; a model without one is
    left alone), so threads that step different vehicles at different speeds share it.
    The Python callback (rail_mj.simulation.callback) cannot be installed meanwhile.
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
