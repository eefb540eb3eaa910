"""Wheel-rail contact and creep: Kalker's law on coned wheels, saturation, FASTSIM, flanges.

One wheelset at a time, written as plain scalar arithmetic and compiled with numba
(the per-step force callback calls it four times a step: numpy's per-operation cost
on arrays of a few wheelsets was most of a step). Independent of MuJoCo (the binding
is `rail_mj.simulation.callback`), it takes arrays of any shape whose last axis is the wheelsets:
one call serves every wheelset of a model at one instant, or a whole run's samples.

Frames and signs are those of docs/frames.md: y to the left, psi positive
nose-left, forces in the track frame. The physics is in docs/creep.md and docs/flange.md.

The compiled law is rail_mj.contact.law, whose every name this module gives too (imported when
first asked for: numba's import is most of a short command's time). `contact_forces` and
`wheelset_forces` call the law built into the installation's contact library
(rail_mj.compiled) and need no numba, except where that library cannot be built.

Example:

    >>> import numpy as np
    >>> from rail_mj.contact.creep import ContactParameters, wheelset_forces
    >>> p = ContactParameters.broadcast(1, r0=0.46, b=0.75, conicity=0.15, f11=10e6, f22=9e6)
    >>> Fy, Mz = wheelset_forces(p, np.array([0.003]), np.zeros(1), np.zeros(1), np.zeros(1), 30.0)
    >>> round(float(Mz[0]), 6)   # -2*f11*b*lam*y/r0: yaws the displaced wheelset back (nose-right)
    -14673.913043
"""

from __future__ import annotations

import ctypes
import functools

import numpy as np

from rail_mj.contact.laws import FASTSIM, LAWS, LINEAR, POLACH, SHEN_HEDRICK_ELKINS  # noqa: F401  (re-exported)
from rail_mj.contact.parameters import (  # noqa: F401  (re-exported)
    FORCE_ROWS,
    NO_GEOMETRY,
    ContactForces,
    ContactParameters,
)
from rail_mj.numerics import ROWS  # noqa: F401  (re-exported)


def __getattr__(name: str):
    """The compiled law's names (rail_mj.contact.law), imported with numba when first asked for."""
    if name.startswith("__"):  # the import system's questions (__path__, ...): not the law's
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from rail_mj.contact import law

    try:
        return getattr(law, name)
    except AttributeError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None


# The contact library's entry point: `rail_mj.contact.law._forces_into` as numba compiled it
# (its FORCES_SIGNATURE), returning 0, or 1 where the law raised.
_C_SOURCE = """/* Written by rail_mj.contact.creep. */
#include <stdint.h>

typedef double *V;
int rail_mj_forces_into(void **result, void **exception, V out, V table, int64_t n, V geometry,
                        int64_t rows, int64_t law, int64_t flange, int64_t falling, V y, V psi, V y_dot,
                        V psi_dot, V speed, V load, V moment, double nominal, double spin_inertia,
                        int64_t cone_gravity, V gauge, int64_t size);

int rail_mj_contact_forces(V out, V table, int64_t n, V geometry, int64_t rows, int64_t law,
                           int64_t flange, int64_t falling, V y, V psi, V y_dot, V psi_dot, V speed,
                           V load, V moment, double nominal, double spin_inertia,
                           int64_t cone_gravity, V gauge, int64_t size) {
    void *result = 0, *exception = 0;
    int status = rail_mj_forces_into(&result, &exception, out, table, n, geometry, rows, law, flange,
                                     falling, y, psi, y_dot, psi_dot, speed, load, moment, nominal,
                                     spin_inertia, cone_gravity, gauge, size);
    return status == 0 || status == -2 ? 0 : 1;
}
"""


def _address(array: np.ndarray) -> int:
    return array.ctypes.data


@functools.cache
def _library() -> ctypes.CDLL | None:
    """The installation's contact library (built the first time: rail_mj.compiled), or None."""
    from rail_mj import compiled

    def kernels():
        from rail_mj.contact import law

        law.compile_apart()
        return {"rail_mj_forces_into": law.forces_cfunc()}

    library = compiled.load("contact", "rail_mj.contact.law._forces_into", _C_SOURCE, kernels)
    if library is not None:
        i64, f64, v = ctypes.c_int64, ctypes.c_double, ctypes.c_void_p
        library.rail_mj_contact_forces.argtypes = (v, v, i64, v, i64, i64, i64, i64, *[v] * 7, f64, f64, i64, v, i64)
        library.rail_mj_contact_forces.restype = ctypes.c_int
    return library


def _evaluate(
    p: ContactParameters,
    y,
    psi,
    y_dot,
    psi_dot,
    speed,
    load=None,
    moment=None,
    nominal: float | None = None,
    spin_inertia: float = 0.0,
    cone_gravity: bool = False,
    gauge=None,
):
    """The kernel's rows, each shaped like the states."""
    shape = np.shape(y)
    flat = [np.ascontiguousarray(v, dtype=np.float64).reshape(-1) for v in (y, psi, y_dot, psi_dot)]
    if load is None:
        loads = [np.full(flat[0].size, np.nan), np.zeros(flat[0].size)]
    else:
        loads = [np.ascontiguousarray(np.broadcast_to(v, shape), dtype=np.float64).reshape(-1) for v in (load, moment)]
    # A speed a sample (a run on a speed profile) or one for all: broadcast like the states.
    speeds = np.ascontiguousarray(np.broadcast_to(np.asarray(speed, dtype=np.float64), shape)).reshape(-1)
    gauges = np.ascontiguousarray(np.broadcast_to(np.asarray(0.0 if gauge is None else gauge, float), shape)).reshape(
        -1
    )
    nominal_load = np.nan if nominal is None else float(nominal)
    library = _library()
    if library is None:
        from rail_mj.contact import law as compiled_law

        rows = compiled_law._kernel(
            p.table,
            p.geometry,
            p.law,
            p.flange,
            p.falling,
            *flat,
            speeds,
            *loads,
            nominal_load,
            float(spin_inertia),
            bool(cone_gravity),
            gauges,
        )
        return rows.reshape((FORCE_ROWS,) + shape)
    rows = np.zeros((FORCE_ROWS, flat[0].size))
    table, geometry = np.ascontiguousarray(p.table), np.ascontiguousarray(p.geometry)
    status = library.rail_mj_contact_forces(
        _address(rows),
        _address(table),
        table.shape[1],
        _address(geometry),
        len(geometry),
        int(p.law),
        int(p.flange),
        int(p.falling),
        *(_address(v) for v in (*flat, speeds, *loads)),
        nominal_load,
        float(spin_inertia),
        int(bool(cone_gravity)),
        _address(gauges),
        flat[0].size,
    )
    if status != 0:  # numba's code raises ZeroDivisionError, the library returns its status
        raise ZeroDivisionError("the contact law divided by zero")
    return rows.reshape((FORCE_ROWS,) + shape)


def contact_forces(
    p: ContactParameters,
    y,
    psi,
    y_dot,
    psi_dot,
    speed: float | np.ndarray,
    load=None,
    moment=None,
    nominal: float | None = None,
    spin_inertia: float = 0.0,
    cone_gravity: bool = False,
    gauge=None,
) -> ContactForces:
    """The rails' forces on each wheelset, by origin: see `ContactForces`. States are
    arrays of one shape whose last axis is the wheelsets.

    Kalker per wheel: Fx = -f11*xi_x, Fy = -f22*xi_y - f23*xi_sp, Mz = f23*xi_y - f33*xi_sp.
    A saturating law scales each wheel's Fx, Fy and Mz by one factor, which brings the
    resultant of (Fx, Fy) onto the law; the fastsim law computes each wheel's Fx, Fy, Mz by
    FASTSIM on its contact ellipse instead (`fastsim`). The longitudinal forces, Fx_left at
    y = +b and Fx_right at y = -b, make the yaw moment b*(Fx_right - Fx_left). On the flange
    the rail adds its lateral force, applied at the contact's lead (`flange_lead`).

    `speed`: one for all, or shaped like the states (a run on a speed profile).
    `load`, `moment` (shaped like the states, or None: a planar vehicle): a spatial vehicle's
    axle loads and suspension roll moments about the rail level (docs/spatial.md, wheel
    loads); `nominal`: the wheel load the coefficients hold at (on cones each wheel's are
    scaled to its load; without `load` both wheels carry it); `spin_inertia` and `cone_gravity`:
    the gyroscopic terms and the gravitational stiffness on cones (`wheelset_contact`);
    `gauge` (None: nominal, or shaped like the states): the gauge's departure from nominal, m,
    with the states relative to the rails' centreline (an irregular track's).
    """
    return ContactForces(
        *_evaluate(p, y, psi, y_dot, psi_dot, speed, load, moment, nominal, spin_inertia, cone_gravity, gauge)
    )


def wheelset_forces(
    p: ContactParameters,
    y,
    psi,
    y_dot,
    psi_dot,
    speed: float | np.ndarray,
    load=None,
    moment=None,
    nominal: float | None = None,
    spin_inertia: float = 0.0,
    cone_gravity: bool = False,
    gauge=None,
):
    """Lateral force Fy (N) and yaw moment Mz (N m) of the rails on each wheelset: the
    sums of `contact_forces`. On the tread, with the linear law and f23 = f33 = 0, this is
    exactly

        Fy = -2*f22*(y_dot/V - psi),   Mz = -2*f11*b*(b*psi_dot/V + lam*y/r0).
    """
    rows = _evaluate(p, y, psi, y_dot, psi_dot, speed, load, moment, nominal, spin_inertia, cone_gravity, gauge)
    return rows[5], rows[6]
