"""Rerun recordings of runs, for review in the Rerun viewer (`rerun FILE.rrd`).

Entity paths (stable; later tools read them back):

    /lateral/wheelset<i>   lateral displacement y of wheelset i, m (Scalars)
    /yaw/wheelset<i>       yaw psi of wheelset i, rad (Scalars)
    /layout                the layout file and the run's settings, logged once

each on two timelines, TIME (seconds) and DISTANCE (millimetres travelled: Rerun
timelines are integer sequences or times, so distance is a sequence in mm). The
blueprint opens on the two plots.

Example:

    >>> from rail_mj import load_layout, simulate
    >>> import tempfile, os
    >>> run = simulate(load_layout("models/wheelset/wheelset.toml"), speed=20.0, distance=10.0,
    ...                initial_lateral=0.002)
    >>> path = os.path.join(tempfile.mkdtemp(), "run.rrd")
    >>> write_recording(run, path).stat().st_size > 0
    True
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from rail_mj.runner import Run

APP_ID = "rail-mj"
TIME = "time"
DISTANCE = "distance_mm"


def lateral_path(i: int) -> str:
    return f"/lateral/wheelset{i + 1}"


def yaw_path(i: int) -> str:
    return f"/yaw/wheelset{i + 1}"


def blueprint() -> rrb.Blueprint:
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.TimeSeriesView(origin="/lateral", name="Lateral displacement y (m)"),
                rrb.TimeSeriesView(origin="/yaw", name="Yaw psi (rad)"),
            ),
            rrb.TextDocumentView(origin="/layout", name="Layout and run"),
            column_shares=[3, 1],
        ),
        collapse_panels=True,
    )


def _layout_text(run: Run) -> str:
    try:
        source = Path(run.layout.source).read_text(encoding="utf-8")
    except OSError:
        source = repr(run.layout)
    return (
        f"# {run.layout.name}\n\n"
        f"speed {run.speed:g} m/s, distance {run.x[-1]:g} m, timestep {run.timestep:.4g} s\n\n"
        f"```toml\n{source}\n```\n"
    )


def log_run(rec: rr.RecordingStream, run: Run) -> None:
    """Log a run into an open recording: static data once, series in column batches."""
    rec.log("/layout", rr.TextDocument(_layout_text(run), media_type=rr.MediaType.MARKDOWN), static=True)
    indexes = [
        rr.TimeColumn(TIME, duration=run.t),
        rr.TimeColumn(DISTANCE, sequence=np.round(run.x * 1000.0).astype(np.int64)),
    ]
    for i in range(run.n_wheelsets):
        for path, values, unit in (
            (lateral_path(i), run.y[:, i], "m"),
            (yaw_path(i), run.psi[:, i], "rad"),
        ):
            rec.log(path, rr.SeriesLines(names=f"wheelset {i + 1} ({unit})"), static=True)
            rec.send_columns(path, indexes=indexes, columns=rr.Scalars.columns(scalars=values))


def write_recording(run: Run, path: str | Path) -> Path:
    """Write `run` to an .rrd file; the file appears only once it is complete."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    Path(tmp).unlink()  # Rerun creates the file itself, with the usual permissions
    try:
        rec = rr.RecordingStream(APP_ID, recording_id=f"{run.layout.name}-{run.speed:g}")
        rec.save(tmp, default_blueprint=blueprint())
        log_run(rec, run)
        rec.flush()
        rec.disconnect()
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
