"""Rerun recordings of runs, for review in the Rerun viewer (`rerun FILE.rrd`).

Entity paths (stable; later tools read them back):

    /lateral/wheelset<i>   lateral displacement y of wheelset i, m (Scalars)
    /yaw/wheelset<i>       yaw psi of wheelset i, rad (Scalars)
    /guiding/wheelset<i>   the sum of guiding forces Sigma Y on wheelset i, N (Scalars):
                           the lateral force of the rails, creep and flange
    /layout                the layout file and the run's settings, logged once
    /world/rails           the track, logged once
    /world/vehicle/<body>  each body's pose (car body, bogieK, wheelsetN) moving along
                           the track, its MJCF geoms (boxes, axle, wheel meshes) under it

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

from pathlib import Path

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from rail_mj.analysis import flange_strikes
from rail_mj.files import staged
from rail_mj.model import RAIL_HEAD_WIDTH
from rail_mj.runner import Run

APP_ID = "rail-mj"
TIME = "time"
DISTANCE = "distance_mm"


FLANGE_EVENTS = "/events/flange"


def flange_path(i: int) -> str:
    return f"/flange/wheelset{i + 1}"


def lateral_path(i: int) -> str:
    return f"/lateral/wheelset{i + 1}"


def yaw_path(i: int) -> str:
    return f"/yaw/wheelset{i + 1}"


def guiding_path(i: int) -> str:
    return f"/guiding/wheelset{i + 1}"


def blueprint(flange: bool = False) -> rrb.Blueprint:
    plots = [rrb.TimeSeriesView(origin="/lateral", name="Lateral displacement y (m)"),
             rrb.TimeSeriesView(origin="/yaw", name="Yaw psi (rad)"),
             rrb.TimeSeriesView(origin="/guiding", name="Sum of guiding forces ΣY (N)")]
    if flange:
        plots += [rrb.TimeSeriesView(origin="/flange", name="Flange contact: rail deflection (m)"),
                  rrb.TextLogView(origin=FLANGE_EVENTS, name="Flange contacts")]
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(*plots),
            rrb.Vertical(
                rrb.Spatial3DView(origin="/world", name="Vehicle on the track"),
                rrb.TextDocumentView(origin="/layout", name="Layout and run"),
            ),
            column_shares=[3, 2],
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
    log_vehicle(rec, run, indexes)
    if run.layout.flange is not None:
        log_flange_contacts(rec, run, indexes)
    guiding = run.guiding_forces()
    for i in range(run.n_wheelsets):
        for path, values, unit in (
            (lateral_path(i), run.y[:, i], "m"),
            (yaw_path(i), run.psi[:, i], "rad"),
            (guiding_path(i), guiding[:, i], "N"),
        ):
            rec.log(path, rr.SeriesLines(names=f"wheelset {i + 1} ({unit})"), static=True)
            rec.send_columns(path, indexes=indexes, columns=rr.Scalars.columns(scalars=values))


def log_flange_contacts(rec: rr.RecordingStream, run: Run, indexes) -> None:
    """Per wheelset, how far past the flangeway clearance it presses into the rail (signed:
    positive into the left rail), and a log line each time a flange strikes a rail."""
    clearance = run.layout.wheelset.flangeway_clearance
    into = np.sign(run.y) * np.maximum(np.abs(run.y) - clearance, 0.0)
    for i in range(run.n_wheelsets):
        rec.log(flange_path(i), rr.SeriesLines(names=f"wheelset {i + 1} (m)"), static=True)
        rec.send_columns(flange_path(i), indexes=indexes, columns=rr.Scalars.columns(scalars=into[:, i]))
    strikes = flange_strikes(run)
    times = [run.t[s.start] for s in strikes]
    distances = [int(round(run.x[s.start] * 1000.0)) for s in strikes]
    lines = [f"wheelset {s.wheelset + 1} flange strikes the {'left' if s.side > 0 else 'right'} rail "
             f"at x = {run.x[s.start]:.2f} m" for s in strikes]
    if lines:
        order = np.argsort(times, kind="stable")
        rec.send_columns(FLANGE_EVENTS, indexes=[
            rr.TimeColumn(TIME, duration=np.asarray(times)[order]),
            rr.TimeColumn(DISTANCE, sequence=np.asarray(distances, dtype=np.int64)[order]),
        ], columns=rr.TextLog.columns(text=[lines[k] for k in order], level=["WARN"] * len(lines)))


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    """MuJoCo quaternions are w, x, y, z; Rerun's are x, y, z, w."""
    return np.roll(np.asarray(wxyz, dtype=float), -1, axis=-1)


def _geom_archetype(model: mujoco.MjModel, g: int):
    """The Rerun shape of one MJCF geom, in the geom's own frame; None for other types."""
    colour = (np.asarray(model.geom_rgba[g]) * 255).astype(np.uint8)
    size = model.geom_size[g]
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size], colors=[colour], fill_mode="solid")
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_CYLINDER:  # axis along the geom's z
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], colors=[colour])
    if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
        f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
        return rr.Mesh3D(vertex_positions=model.mesh_vert[v0:v0 + nv],
                         triangle_indices=model.mesh_face[f0:f0 + nf], albedo_factor=colour)
    return None


def log_vehicle(rec: rr.RecordingStream, run: Run, indexes) -> None:
    """The vehicle's bodies moving along the track in 3D: geometry once, poses in columns.

    The model travels with the vehicle, so each pose gets the distance x = V*t added.
    """
    model = run.vehicle.model
    for g in range(model.ngeom):
        shape = _geom_archetype(model, g)
        body = model.body(model.geom_bodyid[g]).name
        if shape is not None:
            path = f"/world/vehicle/{body}/{model.geom(g).name}"
            rec.log(path, rr.Transform3D(translation=model.geom_pos[g],
                                         quaternion=_xyzw(model.geom_quat[g])), static=True)
            rec.log(path, shape, static=True)
    pos = run.body_pos.copy()
    pos[:, :, 0] += run.x[:, None]
    for b in range(1, model.nbody):
        rec.send_columns(f"/world/vehicle/{model.body(b).name}", indexes=indexes,
                         columns=rr.Transform3D.columns(translation=pos[:, b],
                                                        quaternion=_xyzw(run.body_quat[:, b])))
    b = run.layout.wheelset.contact_half_spacing
    length = float(run.x[-1]) + 40.0
    rec.log("/world/rails", rr.Boxes3D(
        centers=[[length / 2 - 20.0, side * b, -0.08] for side in (1, -1)],
        half_sizes=[[length / 2, RAIL_HEAD_WIDTH / 2, 0.08]] * 2,
        colors=[[190, 190, 200]] * 2, fill_mode="solid"), static=True)


def save_recording(run: Run, path: str | Path) -> None:
    """Write `run` to an .rrd file at `path` (use `write_recording` for a safe write)."""
    rec = rr.RecordingStream(APP_ID, recording_id=f"{run.layout.name}-{run.speed:g}")
    rec.save(str(path), default_blueprint=blueprint(run.layout.flange is not None))
    log_run(rec, run)
    rec.flush()
    rec.disconnect()


def write_recording(run: Run, path: str | Path) -> Path:
    """Write `run` to an .rrd file; the file appears only once it is complete."""
    with staged([path]) as (tmp,):
        save_recording(run, tmp)
    return Path(path)
