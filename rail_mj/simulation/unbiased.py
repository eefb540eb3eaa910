"""MuJoCo's RK4 step without its bias-force pass, for models that have no bias forces.

Each stage of MuJoCo's RK4 step runs the whole forward pipeline, and its velocity stage computes
the com-based velocities (`mj_comVel`) and the Coriolis, centrifugal and gravity forces
(`mj_rne`, into `qfrc_bias`) of every body. In a model where every body hangs on the world by
slides perpendicular to gravity followed by at most one hinge, through its centre of mass and
along a principal axis of its inertia (a planar vehicle's flat twin, rail_mj.vehicle.planar),
those forces are zero: a slide's motion is a translation of a fixed axis, and a body turning
about a principal axis through its centre of mass has no centripetal acceleration of that centre
and no gyroscopic moment (omega x I omega = 0). MuJoCo still spends on them a third of the flat
coach's bare step (2.0 us of a model of eight coaches' 7.5 us forward pass, measured).

`rail_mj_rollout` (C, built once per installation beside MuJoCo's headers, rail_mj.compiled) is
`mujoco.rollout` of `mj_step` with MuJoCo's RK4 as its engine_forward.c writes it, each stage
calling MuJoCo's own position stage, passive forces (and so the native creep callback),
actuation, acceleration and constraint stages, and its sensors at the first stage, exactly as
`mj_forwardSkip` orders them; only `mj_comVel` and `mj_rne` are left out, and `qfrc_bias` is the
zero that `mj_rne` writes for such a model. The states are MuJoCo's to the bit
(tests/simulation/test_unbiased.py compares every step of packed coaches with `mujoco.rollout`), and where
the model does not qualify (`applies`), or no library can be built here, MuJoCo's own rollout
steps it.

Example:

    >>> import mujoco, numpy as np
    >>> model = mujoco.MjModel.from_xml_string(
    ...     '<mujoco><option integrator="RK4"><flag constraint="disable"/></option><worldbody>'
    ...     '<body><joint type="slide" axis="0 1 0" stiffness="100"/><joint type="hinge" axis="0 0 1"/>'
    ...     '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body></worldbody></mujoco>')
    >>> applies(model)
    True
    >>> data = mujoco.MjData(model)
    >>> start = np.zeros(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    >>> start[1] = 0.01  # the slide 10 mm out
    >>> states, readings = np.empty((10, start.size)), np.empty((10, 0))
    >>> roll(model, data, start, 10, states, readings)
    True
    >>> from mujoco import rollout
    >>> reference = np.empty((1, 10, start.size))
    >>> _ = rollout.rollout(model, mujoco.MjData(model), start[None], nstep=10, state=reference)
    >>> bool(np.array_equal(states, reference[0]))
    True
"""

from __future__ import annotations

import ctypes
import threading
from pathlib import Path

import mujoco
import numpy as np

from rail_mj import compiled

# MuJoCo's RK4 (mj_RungeKutta in engine_forward.c) and mj_step around it, each stage
# mj_forwardSkip(m, d, mjSTAGE_NONE, skipsensor) less mj_fwdVelocity's com velocities and RNE;
# the loop is mujoco.rollout's (rollout.cc) for one model and no controls.
_C_SOURCE = r"""/* Written by rail_mj.simulation.unbiased for MuJoCo {version}. */
#include <mujoco/mujoco.h>

static const mjtNum RK4_A[9] = {{0.5, 0, 0, 0, 0.5, 0, 0, 0, 1}};
static const mjtNum RK4_B[4] = {{1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0}};

/* mj_forwardSkip's stages; of mj_fwdVelocity only mj_passive: no tendons, flexes or actuators
   to take velocities of, no constraints to reference, and qfrc_bias zero (`applies`). */
static void forward(const mjModel *m, mjData *d, int sensors) {{
    mj_fwdPosition(m, d);
    if (sensors) mj_sensorPos(m, d);
    if (!d->flg_energypos) d->energy[0] = d->energy[1] = 0;
    d->flg_subtreevel = 0;
    d->flg_energyvel = 0;
    mj_passive(m, d);
    if (sensors) mj_sensorVel(m, d);
    mj_fwdActuation(m, d);
    mj_fwdAcceleration(m, d);
    mj_fwdConstraint(m, d);
    if (sensors) {{
        d->flg_rnepost = 0;
        mj_sensorAcc(m, d);
    }}
}}

/* mj_step with mjINT_RK4: X, F, dX room for 4 (qpos, qvel), 4 qacc and 2 nv. */
static void step(const mjModel *m, mjData *d, mjtNum **X, mjtNum **F, mjtNum *dX) {{
    int nq = m->nq, nv = m->nv;
    mjtNum h = m->opt.timestep, time = d->time, C[3], T[3];
    mj_checkPos(m, d);
    mj_checkVel(m, d);
    forward(m, d, 1);
    mj_checkAcc(m, d);
    for (int i = 1; i < 4; i++) {{
        C[i - 1] = 0;
        for (int j = 0; j < i; j++) C[i - 1] += RK4_A[(i - 1) * 3 + j];
        T[i - 1] = d->time + C[i - 1] * h;
    }}
    mju_copy(X[0], d->qpos, nq);
    mju_copy(X[0] + nq, d->qvel, nv);
    mju_copy(F[0], d->qacc, nv);
    for (int i = 1; i < 4; i++) {{
        mju_zero(dX, 2 * nv);
        for (int j = 0; j < i; j++) {{
            mju_addToScl(dX, X[j] + nq, RK4_A[(i - 1) * 3 + j], nv);
            mju_addToScl(dX + nv, F[j], RK4_A[(i - 1) * 3 + j], nv);
        }}
        mju_copy(X[i], X[0], nq + nv);
        mj_integratePos(m, X[i], dX, h);
        mju_addToScl(X[i] + nq, dX + nv, h, nv);
        mju_copy(d->qpos, X[i], nq);
        mju_copy(d->qvel, X[i] + nq, nv);
        d->time = T[i - 1];
        forward(m, d, 0);
        mju_copy(F[i], d->qacc, nv);
    }}
    mju_zero(dX, 2 * nv);
    for (int j = 0; j < 4; j++) {{
        mju_addToScl(dX, X[j] + nq, RK4_B[j], nv);
        mju_addToScl(dX + nv, F[j], RK4_B[j], nv);
    }}
    d->time = time;
    mju_copy(d->qpos, X[0], nq);
    mju_copy(d->qvel, X[0] + nq, nv);
    /* mj_advance, with no activations, history, sleep or plugins */
    mju_addToScl(d->qvel, dX + nv, h, nv);
    mj_integratePos(m, d->qpos, dX, h);
    d->time += h;
}}

/* mujoco.rollout of one model from state0 (mjSTATE_FULLPHYSICS) for nstep steps: each step's
   end state and sensor values; after a warning, the state it stopped in. */
void rail_mj_rollout(const mjModel *m, mjData *d, const mjtNum *state0, int nstep, mjtNum *state,
                     mjtNum *sensordata) {{
    int nstate = mj_stateSize(m, mjSTATE_FULLPHYSICS), nq = m->nq, nv = m->nv, ns = m->nsensordata;
    int warned = 0;
    mju_zero(d->ctrl, m->nu);
    mju_zero(d->qfrc_applied, nv);
    mju_zero(d->xfrc_applied, 6 * m->nbody);
    mj_setState(m, d, state0, mjSTATE_FULLPHYSICS);
    mju_zero(d->qacc_warmstart, nv);
    mju_zero(d->qfrc_bias, nv);
    for (int i = 0; i < mjNWARNING; i++) d->warning[i].number = 0;
    mj_markStack(d);
    mjtNum *X[4], *F[4], *dX = mj_stackAllocNum(d, 2 * nv);
    for (int i = 0; i < 4; i++) {{
        X[i] = mj_stackAllocNum(d, nq + nv);
        F[i] = mj_stackAllocNum(d, nv);
    }}
    for (int t = 0; t < nstep; t++) {{
        for (int i = 0; i < mjNWARNING && !warned; i++) warned = d->warning[i].number != 0;
        if (!warned) step(m, d, X, F, dX);
        mj_getState(m, d, state + (size_t)t * nstate, mjSTATE_FULLPHYSICS);
        mju_copy(sensordata + (size_t)t * ns, d->sensordata, ns);
    }}
    mj_freeStack(d);
}}
"""


def _mujoco_folder() -> Path:
    return Path(mujoco.__file__).parent


def _library_file() -> Path | None:
    """The MuJoCo library the bindings load (its headers sit beside it, in include/)."""
    found = sorted(_mujoco_folder().glob("libmujoco.so*")) + sorted(_mujoco_folder().glob("libmujoco*.dylib"))
    return found[0] if found else None


_LIBRARY: ctypes.CDLL | None = None
_TRIED = False
_LOCK = threading.Lock()


def library() -> ctypes.CDLL | None:
    """The stepper's library, built the first time (a C compiler and MuJoCo's headers, which its
    wheel carries); None where it cannot be built: MuJoCo's rollout steps every model then."""
    global _LIBRARY, _TRIED
    with _LOCK:
        if not _TRIED:
            _TRIED = True
            shared = _library_file()
            headers = _mujoco_folder() / "include"
            if shared is not None and (headers / "mujoco" / "mujoco.h").is_file():
                source = _C_SOURCE.format(version=mujoco.__version__)
                flags = (f"-I{headers}", str(shared), f"-Wl,-rpath,{shared.parent}")
                found = compiled.load("unbiased", f"MuJoCo {mujoco.__version__}, {shared}", source, flags=flags)
                if found is not None:
                    found.rail_mj_rollout.restype = None
                    found.rail_mj_rollout.argtypes = (
                        ctypes.c_void_p,
                        ctypes.c_void_p,
                        ctypes.c_void_p,
                        ctypes.c_int,
                        ctypes.c_void_p,
                        ctypes.c_void_p,
                    )
                _LIBRARY = found
    return _LIBRARY


_SLIDE, _HINGE = int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE)
_SENSORS = {int(mujoco.mjtSensor.mjSENS_CLOCK), int(mujoco.mjtSensor.mjSENS_USER)}


def _rotate(quat: np.ndarray, vector: np.ndarray) -> np.ndarray:
    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, vector, quat)
    return out


def applies(model: mujoco.MjModel) -> bool:
    """Whether `model` has no bias forces and nothing the left-out stages feed: MuJoCo's RK4;
    every body a child of the world, on slides whose axes are perpendicular to gravity and
    then at most one hinge, its anchor at the body's centre of mass and its axis a principal axis
    of the body's inertia; no tendons, flexes, actuators, mocap bodies, equalities, plugins,
    history, fluid or gravity compensation; constraints off, no optional stages enabled, and only
    clock and user sensors (which read no velocities)."""
    options = model.opt
    if options.integrator != mujoco.mjtIntegrator.mjINT_RK4 or options.enableflags != 0:
        return False
    if not options.disableflags & mujoco.mjtDisableBit.mjDSBL_CONSTRAINT:
        return False
    counts = ("nu", "na", "ntendon", "nflex", "nmocap", "neq", "nplugin", "nhistory")
    if any(getattr(model, name, 0) for name in counts):
        return False
    if options.density != 0 or options.viscosity != 0 or np.any(model.body_gravcomp):
        return False
    if not set(model.sensor_type.tolist()) <= _SENSORS:
        return False
    if model.nbody > 1 and np.any(model.body_parentid[1:] != 0):
        return False
    gravity = np.zeros(3) if options.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY else options.gravity
    for body in range(1, model.nbody):
        start, count = int(model.body_jntadr[body]), int(model.body_jntnum[body])
        kinds = model.jnt_type[start : start + count].tolist()
        if any(k not in (_SLIDE, _HINGE) for k in kinds) or kinds.count(_HINGE) > 1:
            return False
        if _HINGE in kinds[:-1]:  # a slide after a hinge turns with it: Coriolis forces
            return False
        for j in range(start, start + count):
            axis = model.jnt_axis[j]
            if kinds[j - start] == _SLIDE:
                if float(np.dot(_rotate(model.body_quat[body], axis), gravity)) != 0.0:
                    return False
                continue
            if not np.array_equal(model.jnt_pos[j], model.body_ipos[body]):
                return False
            conjugate = model.body_iquat[body] * np.array([1.0, -1.0, -1.0, -1.0])
            principal = _rotate(conjugate, axis)  # the axis in the body's inertial frame
            if np.count_nonzero(principal) != 1:
                return False
    return True


def roll(model: mujoco.MjModel, data: mujoco.MjData, start: np.ndarray, nstep: int, states, sensordata) -> bool:
    """Step a model that `applies` `nstep` times from `start` (mjSTATE_FULLPHYSICS), as
    `mujoco.rollout` would: each step's end state into the rows of `states` and its sensor values
    into those of `sensordata` (C-contiguous float64 arrays of nstep rows). False, and nothing
    stepped, where the library cannot be built here."""
    stepper = library()
    if stepper is None:
        return False
    start = np.ascontiguousarray(start, dtype=float)
    for array in (states, sensordata):
        if not (array.flags.c_contiguous and array.dtype == np.float64):
            raise ValueError("states and sensordata must be C-contiguous float64 arrays")
    if states.size < nstep * start.size or sensordata.size < nstep * model.nsensordata:
        raise ValueError(f"room for {nstep} steps' states and sensor values needed")
    stepper.rail_mj_rollout(model._address, data._address, start.ctypes.data, nstep, states.ctypes.data,
                            sensordata.ctypes.data)  # fmt: skip
    return True
