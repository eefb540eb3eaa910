"""What a run through curves shows: per curve, the quasi-static values practitioners read.

For each curve's constant part (rail_mj.track.Track.curves) the samples with the whole
vehicle inside it (every wheelset between its start and end) are the curve's steady running;
over them, per wheelset: the lateral displacement and yaw from the track (the track-following
frame, docs/track.md), the angle of attack (the yaw towards the outer rail, positive when
the wheelset points at it, flange-leading), the guiding force Sigma Y and each wheel's Y/Q
(EN 14363, rail_mj.analysis.en14363), as means and extremes; and the curve's radius, cant,
cant deficiency and uncompensated acceleration at the run's speed.

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
        forces = run.contact_forces().lateral[inside]
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
                }
            )
        out.append(
            {
                "section": section.number,
                "radius_m": section.radius,
                "cant_m": section.cant,
                "from_m": float(run.station[inside][0]),
                "to_m": float(run.station[inside][-1]),
                # Both positive outward (a deficiency), negative inward (an excess), on either hand.
                "cant_deficiency_mm": -outward * float(track.cant_deficiency(middle, run.speed)) * MM_PER_M,
                "uncompensated_acceleration_m_per_s2": -outward
                * float(track.uncompensated_acceleration(middle, run.speed)),
                "wheelsets": wheelsets,
            }
        )
    return out


def _finite_max(values: np.ndarray) -> float | None:
    finite = values[np.isfinite(values)]
    return float(np.max(finite)) if finite.size else None
