"""A run's samples as a table: the CSV columns of `rail-mj run --out` (their names and order are
a file format: they do not change).

Example:

    >>> from rail_mj import load_layout, simulate
    >>> run = simulate(load_layout("models/wheelset/wheelset.toml"), speed=30.0, distance=10.0)
    >>> table(run)[0]
    ['t', 'x', 'y1', 'psi1', 'sum_y1', 'flange1']
"""

from __future__ import annotations

import io

import numpy as np

from rail_mj.simulation.run import Run


def table(run: Run) -> tuple[list[str], np.ndarray]:
    """Columns and their values, SI units (s, m, rad, N), one row per sample:

    t, x, y1, psi1, y2, psi2, ...   time, distance, each wheelset's lateral displacement and yaw
    sum_y1, flange1, sum_y2, ...    each wheelset's sum of guiding forces Sigma Y and the
                                    flange's part of it (the rail's lateral force on the
                                    wheelset, positive to the left; 0 off the flange; on
                                    profiles the normal forces' lateral part, gravitational
                                    stiffness included)
    y_bogie1, psi_bogie1, ...       each moving frame's lateral displacement and yaw
    (y_carbody, psi_carbody)        (bogies, then the car body unless it is fixed)
    q_left1, q_right1, ...          each wheel's vertical load Q and lateral force Y (the
    ylat_left1, ylat_right1, ...    rail's, + to the left) and its derailment quotient Y/Q
    y_over_q_left1, ...             (rail_mj.analysis.en14363; NaN where the wheel is off its
                                    rail), for a spatial vehicle (the summary has them for all)
    bounce_bogie1, roll_bogie1,     a spatial vehicle's frames' and car bodies' vertical
    pitch_bogie1, ...               displacement from the static equilibrium (m), roll and pitch
    curvature1, ..., cant1, ...     on a curved track (--track): the track's curvature (1/m, +
                                    left) and cant (m, signed as the curvature) under each wheelset
    alignment1, ..., level1, ...,   on an irregular track: the rails under each wheelset (m,
    cross_level1, ..., gauge1, ...  docs/irregularities.md), then the car body's floor
    floor_lateral_bogie1, ...,      accelerations above each bogie and at its centre (m/s^2, in
    floor_vertical_bogie1, ...      its own axes: docs/ride.md; vertical on a spatial vehicle)
    speed                           on a speed profile (--speed-profile): the speed, m/s
    """
    named, cols = run.columns()
    names = [name for name, _unit in named]
    return names, np.column_stack(cols)


def csv_bytes(run: Run) -> bytes:
    """The table as CSV: a header of the column names, then one row a sample (10 digits)."""
    names, values = table(run)
    buf = io.StringIO()
    np.savetxt(buf, values, delimiter=",", header=",".join(names), comments="", fmt="%.10g")
    return buf.getvalue().encode()
