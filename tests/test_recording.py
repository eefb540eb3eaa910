"""Rerun recordings, read back with Rerun's own reader."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader

from conftest import MODELS
from rail_mj.cli import main
from rail_mj.layout import load_layout
from rail_mj.recording import (DISTANCE, TIME, flange_path, guiding_path, lateral_path, write_recording,
                               yaw_path)
from rail_mj.runner import simulate


def read_series(path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """entity path -> (time s, distance mm, value) for every Scalars column."""
    out: dict[str, list] = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if "Scalars:scalars" not in batch.schema.names:
            continue
        times = batch.column(TIME).cast(pa.int64()).to_numpy() / 1e9  # duration in ns
        dist = batch.column(DISTANCE).to_numpy()
        values = np.array([v[0] for v in batch.column("Scalars:scalars").to_pylist()])
        out.setdefault(chunk.entity_path, []).append((times, dist, values))
    return {k: tuple(np.concatenate(parts) for parts in zip(*v)) for k, v in out.items()}


def static_entities(path) -> set[str]:
    return {c.entity_path for c in RrdReader(str(path)).stream() if c.is_static}


def test_recording_holds_the_run(tmp_path):
    run = simulate(load_layout(MODELS / "bogie" / "bogie.toml"), speed=25.0, distance=30.0,
                   initial_lateral=0.002, initial_yaw=0.0005)
    path = write_recording(run, tmp_path / "bogie.rrd")
    series = read_series(path)
    # The shipped bogie has flange contact: its rail-deflection series come along.
    assert set(series) == ({lateral_path(i) for i in range(2)} | {yaw_path(i) for i in range(2)}
                           | {guiding_path(i) for i in range(2)} | {flange_path(i) for i in range(2)})
    guiding = run.guiding_forces()
    assert np.max(np.abs(guiding)) > 0
    for i in range(run.n_wheelsets):
        for entity, expected in ((lateral_path(i), run.y[:, i]), (yaw_path(i), run.psi[:, i]),
                                 (guiding_path(i), guiding[:, i])):
            t, dist, values = series[entity]
            order = np.argsort(t, kind="stable")
            np.testing.assert_array_equal(values[order], expected)  # float64 both ways: exact
            np.testing.assert_allclose(t[order], run.t, atol=1e-9)  # ns resolution
            np.testing.assert_array_equal(dist[order], np.round(run.x * 1000).astype(np.int64))
    assert "/layout" in static_entities(path)


def test_recording_has_a_blueprint(tmp_path):
    run = simulate(load_layout(MODELS / "wheelset" / "wheelset.toml"), speed=20.0, distance=5.0)
    path = write_recording(run, tmp_path / "w.rrd")
    assert len(RrdReader(str(path)).blueprints()) == 1


def test_cli_writes_recording(tmp_path, capsys):
    rrd = tmp_path / "coach.rrd"
    status = main(["run", str(MODELS / "manchester-coach" / "manchester-coach.toml"),
                   "--speed", "40", "--distance", "20", "--rrd", str(rrd)])
    assert status == 0 and rrd.is_file()
    assert f"rerun {rrd}" in capsys.readouterr().out
    assert len(read_series(rrd)) == 4 * 4  # lateral, yaw, guiding forces and flange of four wheelsets
    assert [p.name for p in tmp_path.iterdir()] == ["coach.rrd"]  # no temporary left behind


def test_recording_moves_the_vehicle_along_the_track(tmp_path):
    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    run = simulate(layout, speed=25.0, distance=10.0, initial_lateral=0.002)
    path = write_recording(run, tmp_path / "bogie.rrd")
    poses = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if not chunk.is_static and "Transform3D:translation" in batch.schema.names:
            t = batch.column(TIME).cast(pa.int64()).to_numpy() / 1e9
            xyz = np.array([v[0] for v in batch.column("Transform3D:translation").to_pylist()])
            poses[chunk.entity_path] = xyz[np.argsort(t, kind="stable")]
    assert set(poses) == {"/world/vehicle/carbody", "/world/vehicle/bogie1",
                          "/world/vehicle/wheelset1", "/world/vehicle/wheelset2"}
    # Rerun stores translations as float32: relative resolution 2^-24 = 6e-8.
    f32 = 2.0**-23
    for i, x_w in enumerate(layout.wheelset_x):
        xyz = poses[f"/world/vehicle/wheelset{i + 1}"]
        # x = V*t + position, but for the frame's yaw (1e-3 rad) times lateral offsets (1e-3 m).
        np.testing.assert_allclose(xyz[:, 0], run.x + x_w, rtol=f32, atol=1e-6)
        np.testing.assert_allclose(xyz[:, 1], run.y[:, i], rtol=f32, atol=1e-30)  # the same lateral motion
        np.testing.assert_allclose(xyz[:, 2], layout.wheelset.rolling_radius, rtol=f32)
    static = static_entities(path)
    assert "/world/rails" in static and "/world/vehicle/wheelset1/wheelset1_left_wheel" in static
