"""What a run through curves shows: per curve, the quasi-static values practitioners read.

For each curve's constant part (rail_mj.track.Track.curves) the samples with the whole
vehicle inside it (every wheelset between its start and end) are the curve's steady running;
over them, per wheelset: the lateral displacement and yaw from the track (the track-following
frame, docs/track.md), the angle of attack (the yaw towards the outer rail, positive when
the wheelset points at it, flange-leading), the guiding force Sigma Y, each wheel's Y/Q
(EN 14363, rail_mj.analysis.en14363) and each wheel's wear number T-gamma (the energy its creep
dissipates per metre rolled, N: rail_mj.contact.creep.wear_number), as means and extremes; and
the curve's radius, cant, cant deficiency and uncompensated acceleration at the run's speed.

Example:

    >>> from rail_mj import load_layout, load_track, simulate
    >>> track = load_track("models/tracks/curve-600.toml")
    >>> run = simulate(load_layout("models/bogie/bogie.toml"), 25.0, 580.0, track=track)
    >>> curve = curves(run)[0]
    >>> curve["radius_m"], round(curve["cant_deficiency_mm"])
    (600.0, 9)
    >>> round(curve["wheelsets"][0]["mean_angle_of_attack_rad"] * 1e3, 2)   # the leading wheelset, mrad
    3.69
"""

from __future__ import annotations

import numpy as np

from rail_mj.analysis.en14363 import derailment_quotients
from rail_mj.layout import Layout
from rail_mj.simulation.run import Run
from rail_mj.units import MM_PER_M


def curves(run: Run) -> list[dict]:
    """Per curve the run went wholly through (see the module); [] on straight track."""
    track = run.track
    if track is None:
        return []
    xs = np.asarray(run.layout.wheelset_x)
    out = []
    for section in track.curves:
        inside = (run.station + xs.min() >= section.start) & (run.station + xs.max() <= section.end)
        if not np.any(inside):
            continue
        middle = 0.5 * (section.start + section.end)
        # The outer rail is the right one on a left curve (positive curvature), the left on a right.
        outward = -1.0 if section.curvature_start > 0 else 1.0
        y, psi = run.y[inside], run.psi[inside]
        contact = run.contact_forces()
        forces = contact.lateral[inside]
        wear = np.stack([contact.wear_left[inside], contact.wear_right[inside]], axis=-1)
        quotients = derailment_quotients(run)[inside]
        wheelsets = []
        for i in range(run.n_wheelsets):
            attack = outward * psi[:, i]
            wheelsets.append(
                {
                    "wheelset": i + 1,
                    "mean_lateral_m": float(np.mean(y[:, i])),
                    "mean_yaw_rad": float(np.mean(psi[:, i])),
                    "mean_angle_of_attack_rad": float(np.mean(attack)),
                    "max_angle_of_attack_rad": float(np.max(attack)),
                    "mean_guiding_force_n": float(np.mean(forces[:, i])),
                    "max_abs_guiding_force_n": float(np.max(np.abs(forces[:, i]))),
                    "max_y_over_q": _finite_max(quotients[:, i]),
                    "mean_wear_number_n": [float(v) for v in np.mean(wear[:, i], axis=0)],
                    "max_wear_number_n": [float(v) for v in np.max(wear[:, i], axis=0)],
                }
            )
        speed = float(np.interp(middle, run.station, run.speeds))  # on a speed profile, the curve's own
        out.append(
            {
                "section": section.number,
                "radius_m": section.radius,
                "cant_m": section.cant,
                "from_m": float(run.station[inside][0]),
                "to_m": float(run.station[inside][-1]),
                # Both positive outward (a deficiency), negative inward (an excess), on either hand.
                "cant_deficiency_mm": -outward * float(track.cant_deficiency(middle, speed)) * MM_PER_M,
                "uncompensated_acceleration_m_per_s2": -outward
                * float(track.uncompensated_acceleration(middle, speed)),
                "wheelsets": wheelsets,
            }
        )
    return out


def _finite_max(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(np.max(finite)) if finite.size else None


# --- steady curving: the quasi-static state on a constant curve, solved directly --------------

# The curve the steady state is solved on: long, so that every body is on its constant part,
# the vehicle's origin in its middle.
STEADY_LENGTH = 10_000.0  # m
# The continuation from straight track (steady_state), in shares of the curve:
CONTINUATION_STEP = 0.25  # of the curve's curvature and cant, a continuation step at most
CONTINUATION_FINEST = 1.0 / 64.0  # and at least
# The state is steady when no joint accelerates more than this (m/s^2 or rad/s^2): round-off
# of the forces (N on tonnes) is a thousand times below it.
STEADY_TOLERANCE = 1e-7


class CurvingError(ValueError):
    """No steady state found: the message, one line, says why."""


def steady_state(layout: Layout, radius: float, speed: float, cant: float = 0.0) -> Run:
    """The vehicle's quasi-static state on a constant curve of `radius` (m, + left) and `cant`
    (m) at `speed` (m/s), as a Run of one sample: the joint coordinates at which every body's
    acceleration vanishes with the bodies at rest relative to the track, found by Powell's
    hybrid method (scipy.optimize.root) on MuJoCo's accelerations with the native callback,
    as the commercial codes' quasi-static solvers do. Raises CurvingError when it finds none
    (a vehicle pushed off its rails, or a curve it cannot take)."""
    guess: np.ndarray | None = None
    # Continuation in the curve (curvature and cant together, from straight track): on profiles
    # the contact steps onto the flange, and Newton's method takes the step from nearby only. A
    # step that fails is halved (where the flange takes over, the path bends sharply), down to
    # CONTINUATION_FINEST of the curve.
    reached, step = 0.0, CONTINUATION_STEP
    while reached < 1.0:
        share = min(1.0, reached + step)
        vehicle, data, solution, residual = _solve(layout, radius / share, cant * share, speed, guess)
        if residual < STEADY_TOLERANCE:
            guess, reached = solution.x, share
            step = min(CONTINUATION_STEP, 2.0 * step)
            continue
        if step / 2.0 < CONTINUATION_FINEST:
            raise CurvingError(
                f"{layout.source}: no steady state on a {radius:g} m curve with {cant * MM_PER_M:g} mm cant at "
                f"{speed:g} m/s: the solver stopped {residual:.2g} m/s^2 from it on the way, at a "
                f"{radius / share:.4g} m curve ({' '.join(solution.message.split())})"
            )
        step /= 2.0
    model = vehicle.model
    readings = data.sensordata[None, :]
    pos, quat = np.zeros((1, model.nbody, 3)), np.zeros((1, model.nbody, 4))
    pos[:, 0], quat[:, 0] = 0.0, (1.0, 0.0, 0.0, 0.0)
    rates, loads = np.zeros((1, vehicle.n_wheelsets, 2)), np.full((1, vehicle.n_wheelsets, 2), np.nan)
    sensors = vehicle.sensors
    sensors.poses(readings, pos, quat)
    sensors.rates(readings, rates)
    sensors.loads(readings, loads)
    axle_loads = None if np.isnan(loads).all() else loads
    return Run(vehicle, speed, model.opt.timestep, np.zeros(1), pos, quat, rates, axle_loads=axle_loads)


def _solve(layout: Layout, radius: float, cant: float, speed: float, guess: np.ndarray | None):
    """The root of the joints' accelerations on one constant curve, from `guess` (None: centred)."""
    import mujoco
    from scipy.optimize import root

    from rail_mj.simulation import native
    from rail_mj.track import track_from_dict
    from rail_mj.vehicle.block import set_speed
    from rail_mj.vehicle.curve import ODOMETER
    from rail_mj.vehicle.spec import Vehicle

    track = track_from_dict(
        {"section": [{"kind": "curve", "length": STEADY_LENGTH, "radius": radius, "cant": cant}]},
        source=f"<curve R {radius:g} m, cant {cant:g} m>",
    )
    vehicle = Vehicle(layout, track)
    model = vehicle.model
    set_speed(model, speed)
    data = mujoco.MjData(model)
    odometer = model.joint(ODOMETER)
    free = np.array([d for d in range(model.nv) if d != odometer.dofadr[0]], dtype=np.int64)
    # Slides and hinges only: a joint's qpos entry is its dof's.
    start = model.qpos0.copy()
    start[odometer.qposadr[0]] = STEADY_LENGTH / 2

    def accelerations(q: np.ndarray) -> np.ndarray:
        data.qpos[:] = start
        data.qpos[free] += q
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        return data.qacc[free].copy()

    with native.installed():
        x0 = np.zeros(len(free)) if guess is None else guess
        solution = root(accelerations, x0, method="hybr", options={"xtol": 1e-13})
        residual = float(np.max(np.abs(accelerations(solution.x))))
    return vehicle, data, solution, residual


def steady_curving(layout: Layout, radius: float, speed: float, cant: float = 0.0) -> dict:
    """The steady state on a constant curve (`steady_state`) as practitioners read it: the
    curve's cant deficiency and uncompensated acceleration; per wheelset its lateral
    displacement, yaw and angle of attack, the guiding force Sigma Y and each wheel's Q, Y, Y/Q and
    wear number T-gamma (N, left then right: rail_mj.contact.creep.wear_number); each frame's and
    car body's lateral displacement and yaw (and a spatial vehicle's roll)."""
    run = steady_state(layout, radius, speed, cant)
    assert run.track is not None
    outward = -1.0 if radius > 0 else 1.0
    s = STEADY_LENGTH / 2
    forces = run.contact_forces()
    q, y, quotients = run.wheel_loads()[0], run.wheel_lateral_forces()[0], derailment_quotients(run)[0]
    wheelsets = []
    for i in range(run.n_wheelsets):
        wheelsets.append(
            {
                "wheelset": i + 1,
                "lateral_m": float(run.y[0, i]),
                "yaw_rad": float(run.psi[0, i]),
                "angle_of_attack_rad": float(outward * run.psi[0, i]),
                "guiding_force_n": float(forces.lateral[0, i]),
                "wheel_loads_n": [float(v) for v in q[i]],
                "wheel_lateral_forces_n": [float(v) for v in y[i]],
                "y_over_q": [None if not np.isfinite(v) else float(v) for v in quotients[i]],
                "wear_number_n": [float(forces.wear_left[0, i]), float(forces.wear_right[0, i])],
            }
        )
    frames = []
    for k, name in enumerate(run.frame_names):
        frame = {"body": name, "lateral_m": float(run.frame_y[0, k]), "yaw_rad": float(run.frame_psi[0, k])}
        if layout.spatial is not None:
            frame["roll_rad"] = float(run.frame_roll[0, k])
        frames.append(frame)
    return {
        "layout": layout.name,
        "radius_m": radius,
        "cant_m": cant,
        "speed_m_per_s": speed,
        "cant_deficiency_mm": -outward * float(run.track.cant_deficiency(s, speed)) * MM_PER_M,
        "uncompensated_acceleration_m_per_s2": -outward * float(run.track.uncompensated_acceleration(s, speed)),
        "wheelsets": wheelsets,
        "bodies": frames,
    }
