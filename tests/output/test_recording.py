"""Rerun recordings, read back with Rerun's own reader."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pytest
from conftest import BOGIE_FRAME, MODELS, WHEELSET
from rerun.chunk import RrdReader

from rail_mj.analysis import flange_strikes, late_motion, oscillation
from rail_mj.analysis.en14363 import derailment_quotients
from rail_mj.cli import main
from rail_mj.layout import layout_from_dict, load_layout
from rail_mj.output.recording import (
    DISTANCE,
    FLANGE_EVENTS,
    FLOOR_RATE,
    SAMPLES_PER_CYCLE,
    TIME,
    axis_range,
    flange_path,
    frame_lateral_path,
    frame_yaw_path,
    guiding_path,
    lateral_path,
    plots,
    recorded_samples,
    recording_rate,
    write_recording,
    yaw_path,
)
from rail_mj.output.samples import table
from rail_mj.simulation.run import Run
from rail_mj.simulation.runner import simulate
from rail_mj.vehicle.spec import Vehicle

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"


def read_series(path) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """entity path -> (time s, distance mm, value) for every Scalars column, in time order."""
    out: dict[str, list] = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if "Scalars:scalars" not in batch.schema.names:
            continue
        times = batch.column(TIME).cast(pa.int64()).to_numpy() / 1e9  # duration in ns
        dist = batch.column(DISTANCE).to_numpy()
        values = np.array([v[0] for v in batch.column("Scalars:scalars").to_pylist()])
        out.setdefault(chunk.entity_path, []).append((times, dist, values))
    series = {}
    for entity, parts in out.items():
        t, dist, values = (np.concatenate(p) for p in zip(*parts))
        order = np.argsort(t, kind="stable")
        series[entity] = (t[order], dist[order], values[order])
    return series


def static_entities(path) -> set[str]:
    return {c.entity_path for c in RrdReader(str(path)).stream() if c.is_static}


def blueprint_components(path) -> dict[str, list]:
    """Blueprint component (e.g. "EyeControls3D:tracking_entity") -> its values, all views."""
    reader = RrdReader(str(path))
    out: dict[str, list] = {}
    for chunk in reader.stream(store=reader.blueprints()[0]):
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if ":" in name:
                out.setdefault(name, []).extend(batch.column(name).to_pylist())
    return out


def co_co() -> dict:
    """A Co-Co locomotive: the Manchester coach's parts, two three-axle bogies."""
    return {
        "name": "co-co",
        "wheelset": {**WHEELSET, "flangeway_clearance": 0.008},
        "creep": {"f11": 10e6, "f22": 9e6, "law": "polach", "friction": 0.3},
        "flange": {},
        "primary": {"lateral_stiffness": 7.768e6, "yaw_stiffness": 62.78e6, "lateral_damping": 4e3},
        "bogie": {**BOGIE_FRAME, "wheelset_positions": [2.0, 0.0, -2.0]},
        "secondary": {"lateral_stiffness": 320e3, "yaw_stiffness": 320e3, "lateral_damping": 64e3},
        "carbody": {
            "fixed": False,
            "mass": 32000.0,
            "inertia": [56800.0, 1.97e6, 1.97e6],
            "bogie_positions": [5.0, -5.0],
        },
    }


def test_recording_holds_the_run_in_mm_mrad_and_kn(tmp_path):
    run = simulate(
        load_layout(MODELS / "bogie" / "bogie.toml"),
        speed=25.0,
        distance=30.0,
        initial_lateral=0.002,
        initial_yaw=0.0005,
    )
    path = write_recording(run, tmp_path / "bogie.rrd", rate=math.inf)  # every sample
    series = read_series(path)
    # The shipped bogie has flange contact; its car body is fixed: only the bogie frame moves.
    assert run.frame_names == ("bogie1",)
    assert set(series) == (
        {lateral_path(i) for i in range(2)}
        | {yaw_path(i) for i in range(2)}
        | {guiding_path(i) for i in range(2)}
        | {flange_path(i) for i in range(2)}
        | {"/lateral/bogie1", "/yaw/bogie1"}
    )
    forces = run.contact_forces()
    assert np.max(np.abs(forces.lateral)) > 0
    expected = {
        frame_lateral_path("bogie1"): run.frame_y[:, 0] * 1000,
        frame_yaw_path("bogie1"): run.frame_psi[:, 0] * 1000,
    }
    for i in range(run.n_wheelsets):
        expected[lateral_path(i)] = run.y[:, i] * 1000  # mm
        expected[yaw_path(i)] = run.psi[:, i] * 1000  # mrad
        expected[guiding_path(i)] = forces.lateral[:, i] / 1000  # kN
        expected[flange_path(i)] = forces.flange_lateral[:, i] / 1000
    for entity, values in expected.items():
        t, dist, logged = series[entity]
        np.testing.assert_array_equal(logged, values)  # float64 both ways: exact
        np.testing.assert_allclose(t, run.t, atol=1e-9)  # ns resolution
        np.testing.assert_array_equal(dist, np.round(run.x * 1000).astype(np.int64))
    # The bogie frame moves: its series are not a copy of zeros.
    assert np.max(np.abs(run.frame_y)) > 1e-4 and np.max(np.abs(run.frame_psi)) > 1e-5
    assert "/layout" in static_entities(path)


def test_recording_has_a_blueprint(tmp_path):
    run = simulate(load_layout(MODELS / "wheelset" / "wheelset.toml"), speed=20.0, distance=5.0, initial_lateral=0.0)
    path = write_recording(run, tmp_path / "w.rrd")
    assert len(RrdReader(str(path)).blueprints()) == 1


def test_the_camera_follows_the_vehicle(tmp_path):
    run = simulate(load_layout(MODELS / "bogie" / "bogie.toml"), speed=25.0, distance=5.0, initial_lateral=0.0)
    path = write_recording(run, tmp_path / "bogie.rrd")
    bp = blueprint_components(path)
    # The 3D view tracks an entity fixed to the car body that spans the whole vehicle.
    assert bp["EyeControls3D:tracking_entity"] == [["/world/vehicle/carbody/extent"]]
    extent = next(c for c in RrdReader(str(path)).stream() if c.entity_path == "/world/vehicle/carbody/extent")
    corners = np.array(extent.to_record_batch().column("Points3D:positions").to_pylist()[0])
    wheelset_x = np.array(load_layout(MODELS / "bogie" / "bogie.toml").wheelset_x)
    assert corners[0, 0] < wheelset_x.min() - 0.4 and corners[1, 0] > wheelset_x.max() + 0.4
    # It starts looking at the vehicle, from a distance that takes it in.
    target = np.array(bp["EyeControls3D:look_target"][0][0])
    eye = np.array(bp["EyeControls3D:position"][0][0])
    assert abs(target[0]) < 1.0 and 4.0 < np.linalg.norm(eye - target) < 30.0
    assert {"/world/rails", "/world/sleepers"} <= static_entities(path)


def test_plot_axes_get_labelled_ticks():
    assert axis_range([np.array([0.0, 8.0, -3.0])]) == [-10.0, 10.0]
    assert axis_range([np.array([13.0]), np.array([-2.0])]) == [-15.0, 15.0]
    assert axis_range([np.array([0.0021])]) == [-0.003, 0.003]
    assert axis_range([np.zeros(3)]) == [-1.0, 1.0]


def test_rate_follows_the_motion():
    """SAMPLES_PER_CYCLE samples a cycle of the frequency below which 99 % of the lateral
    velocity's power lies; at least FLOOR_RATE; at most every sample."""
    vehicle = Vehicle(load_layout(MODELS / "bogie" / "bogie.toml"))
    n, nbody = 4001, vehicle.model.nbody
    t = np.arange(n) * 1e-3

    def run_with(velocity) -> Run:
        rates = np.zeros((n, 2, 2))
        rates[:, :, 0] = velocity[:, None]
        return Run(vehicle, 30.0, 1e-3, t, np.zeros((n, nbody, 3)), np.tile([1.0, 0, 0, 0], (n, nbody, 1)), rates)

    assert recording_rate(run_with(np.zeros(n))) == pytest.approx(FLOOR_RATE)
    assert recording_rate(run_with(np.sin(2 * np.pi * 2.0 * t))) == pytest.approx(FLOOR_RATE)
    # 12 Hz: at least 120 samples/s, one sample in 8 of 1000/s.
    assert recording_rate(run_with(np.sin(2 * np.pi * 12.0 * t))) == pytest.approx(125.0)
    fast = run_with(np.sin(2 * np.pi * 12.0 * t) + 0.3 * np.sin(2 * np.pi * 40.0 * t))
    assert recording_rate(fast) >= SAMPLES_PER_CYCLE * 40.0
    assert recording_rate(run_with(np.sin(2 * np.pi * 150.0 * t))) == pytest.approx(1000.0)
    slow = run_with(np.zeros(n))
    keep = recorded_samples(slow)
    assert keep[0] == 0 and keep[-1] == n - 1 and np.all(np.diff(keep[:-1]) == 20)
    assert len(recorded_samples(slow, math.inf)) == n
    assert len(recorded_samples(slow, 100.0)) == 401  # one in 10, and the last is the 400th
    assert len(recorded_samples(slow, 1e6)) == n  # no more than every sample
    for bad in (0.0, -5.0, math.nan):
        with pytest.raises(ValueError, match="positive"):
            recorded_samples(slow, bad)


def test_decimated_recording_keeps_the_flange_strikes(tmp_path):
    """Hunting onto the flanges: the default rate is high, but below the run's, the
    samples logged are the run's own, and the strikes are found in the full run."""
    run = simulate(load_layout(COACH), speed=85.0, distance=250.0, initial_lateral=0.002)
    rate = recording_rate(run)
    hunting = oscillation(*late_motion(run))[0]  # about 5 Hz
    assert 20 * hunting < rate < 1000.0  # many samples a cycle, fewer than the run's
    path = write_recording(run, tmp_path / "coach.rrd")
    keep = recorded_samples(run)
    assert len(keep) < len(run.t) / 2
    t, _dist, values = read_series(path)[lateral_path(0)]
    np.testing.assert_array_equal(values, run.y[keep, 0] * 1000)
    np.testing.assert_allclose(t, run.t[keep], atol=1e-9)
    np.testing.assert_allclose(np.diff(t[:-1]), 1.0 / rate, rtol=1e-6)
    strikes = flange_strikes(run)
    assert len(strikes) > 4
    events = [c for c in RrdReader(str(path)).stream() if c.entity_path == FLANGE_EVENTS]
    times = np.concatenate([c.to_record_batch().column(TIME).cast(pa.int64()).to_numpy() for c in events]) / 1e9
    np.testing.assert_allclose(np.sort(times), np.sort([run.t[s.start] for s in strikes]), atol=1e-9)
    assert not set(np.round(np.sort(times) * 1000).astype(int)) <= set(np.round(run.t[keep] * 1000).astype(int))


def test_stable_run_recording_is_small(tmp_path):
    """A stable 1 km of the coach at 40 m/s: recorded at a rate far below 1000/s, so that
    10 km (250 s) stays under 25 MB; every sample on request, several times the size."""
    run = simulate(load_layout(COACH), speed=40.0, distance=1000.0, initial_lateral=0.002)
    rate = recording_rate(run)
    assert rate <= 100.0
    small = write_recording(run, tmp_path / "auto.rrd").stat().st_size
    full = write_recording(run, tmp_path / "full.rrd", rate=math.inf).stat().st_size
    assert small < 25e6 / 10  # 1 km of 10
    assert full > 5 * small
    assert len(read_series(tmp_path / "full.rrd")[yaw_path(3)][0]) == len(run.t)


def test_six_wheelsets_each_series_readable(tmp_path):
    """A Co-Co: six wheelsets, two bogies and the car body; each wheelset keeps its colour
    in every plot, and the legend names are short."""
    run = simulate(layout_from_dict(co_co()), speed=40.0, distance=20.0, initial_lateral=0.002)
    assert run.n_wheelsets == 6 and run.frame_names == ("bogie1", "bogie2", "carbody")
    path = write_recording(run, tmp_path / "coco.rrd")
    series = read_series(path)
    for name in run.frame_names:
        assert frame_lateral_path(name) in series and frame_yaw_path(name) in series
    assert {lateral_path(i) for i in range(6)} <= set(series)
    shown = plots(run)
    assert [len(p.series) for p in shown] == [6, 6, 6, 3, 3, 6]
    for p in shown:
        assert len({s.colour for s in p.series}) == len(p.series)  # distinct within a plot
        assert all(len(s.label) <= 20 for s in p.series)
        assert p.title.endswith(("(mm)", "(mrad)", "(kN)"))
    wheelset_plots = [p for p in shown if p.series[0].path.endswith("wheelset1")]
    for i in range(6):
        assert len({p.series[i].colour for p in wheelset_plots}) == 1  # the same in every plot
    legends = blueprint_components(path)["PlotLegend:corner"]
    assert len(legends) == len(shown)


def test_table_columns(tmp_path):
    run = simulate(load_layout(COACH), speed=40.0, distance=10.0, initial_lateral=0.002)
    names, values = table(run)
    n = run.n_wheelsets
    assert names[: 2 + 2 * n] == ["t", "x"] + [f"{q}{i + 1}" for i in range(n) for q in ("y", "psi")]
    assert names[2 + 2 * n :] == (
        [f"{q}{i + 1}" for i in range(n) for q in ("sum_y", "flange")]
        + ["y_bogie1", "psi_bogie1", "y_bogie2", "psi_bogie2", "y_carbody", "psi_carbody"]
    )
    column = dict(zip(names, values.T))
    forces = run.contact_forces()
    np.testing.assert_array_equal(column["y3"], run.y[:, 2])
    np.testing.assert_array_equal(column["sum_y2"], forces.lateral[:, 1])
    np.testing.assert_array_equal(column["flange4"], forces.flange_lateral[:, 3])
    carbody = run.vehicle.model.body("carbody").id
    np.testing.assert_array_equal(column["y_carbody"], run.body_pos[:, carbody, 1])
    np.testing.assert_allclose(column["psi_bogie2"], run.frame_psi[:, 1])
    assert np.max(np.abs(column["y_carbody"])) > 1e-3  # the car body moves with the 2 mm start
    # The fixed car body of the shipped bogie has no columns.
    bogie = simulate(load_layout(MODELS / "bogie" / "bogie.toml"), speed=25.0, distance=2.0, initial_lateral=0.0)
    assert table(bogie)[0][-2:] == ["y_bogie1", "psi_bogie1"]


def test_cli_writes_recording_and_csv(tmp_path, capsys):
    rrd, csv = tmp_path / "coach.rrd", tmp_path / "coach.csv"
    status = main(["run", str(COACH), "--speed", "40", "--distance", "20", "--rrd", str(rrd), "--out", str(csv)])
    assert status == 0 and rrd.is_file()
    assert f"rerun {rrd}" in capsys.readouterr().out
    # lateral, yaw, guiding and flange forces of four wheelsets; lateral and yaw of three frames
    assert len(read_series(rrd)) == 4 * 4 + 3 * 2
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:4] == ["t", "x", "y1", "psi1"] and header[-2:] == ["y_carbody", "psi_carbody"]
    assert len(header) == 2 + 4 * 4 + 3 * 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["coach.csv", "coach.rrd"]  # no temporary left


def test_recording_moves_the_vehicle_along_the_track(tmp_path):
    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    run = simulate(layout, speed=25.0, distance=10.0, initial_lateral=0.002)
    path = write_recording(run, tmp_path / "bogie.rrd", exaggeration=1.0)  # true size (tests/output/test_review.py)
    keep = recorded_samples(run)
    poses = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if not chunk.is_static and "Transform3D:translation" in batch.schema.names:
            t = batch.column(TIME).cast(pa.int64()).to_numpy() / 1e9
            xyz = np.array([v[0] for v in batch.column("Transform3D:translation").to_pylist()])
            poses[chunk.entity_path] = xyz[np.argsort(t, kind="stable")]
    assert set(poses) == {
        "/world/vehicle/carbody",
        "/world/vehicle/bogie1",
        "/world/vehicle/wheelset1",
        "/world/vehicle/wheelset2",
    }
    # Rerun stores translations as float32: relative resolution 2^-24 = 6e-8.
    f32 = 2.0**-23
    for i, x_w in enumerate(layout.wheelset_x):
        xyz = poses[f"/world/vehicle/wheelset{i + 1}"]
        # x = V*t + position, but for the frame's yaw (1e-3 rad) times lateral offsets (1e-3 m).
        np.testing.assert_allclose(xyz[:, 0], run.x[keep] + x_w, rtol=f32, atol=1e-6)
        np.testing.assert_allclose(xyz[:, 1], run.y[keep, i], rtol=f32, atol=1e-30)  # the same lateral motion
        np.testing.assert_allclose(xyz[:, 2], layout.wheelset.rolling_radius, rtol=f32)
    static = static_entities(path)
    assert "/world/rails" in static and "/world/vehicle/wheelset1/wheelset1_left_wheel" in static


def test_spatial_recording_plots_roll_bounce_and_wheel_loads(tmp_path):
    """A spatial run's recording has the frames' and car body's roll and bounce, and each wheel's
    Q and Y/Q, the values the Run gives (Q in kN); the wheel loads' axis from 0, bounce's no
    narrower than 0.1 mm (its round-off, 6e-4 mm, would fill a tighter one)."""
    from rail_mj.output.recording import frame_bounce_path, frame_roll_path, quotient_path, wheel_load_path

    run = simulate(
        load_layout(MODELS.parent / "tests" / "data" / "manchester-coach-spatial.toml"),
        speed=40.0,
        distance=30.0,
        initial_lateral=0.002,
    )
    shown = {p.title: p for p in plots(run)}
    assert {
        "Bogies, car body: roll φ (mrad)",
        "Bogies, car body: bounce z (mm)",
        "Wheels: vertical load Q (kN)",
        "Wheels: derailment quotient Y/Q (limit 0.8)",
    } <= set(shown)
    q_plot = shown["Wheels: vertical load Q (kN)"]
    assert axis_range([s.values for s in q_plot.series], q_plot.floor, q_plot.positive)[0] == 0.0
    bounce = shown["Bogies, car body: bounce z (mm)"]
    assert np.max(np.abs(run.frame_bounce)) * 1e3 < 0.01  # smooth track: round-off only
    assert axis_range([s.values for s in bounce.series], bounce.floor)[1] >= 0.1
    rrd = write_recording(run, tmp_path / "spatial.rrd", rate=math.inf)
    series = read_series(rrd)
    np.testing.assert_allclose(series[wheel_load_path(1, "right")][2], run.wheel_loads()[:, 1, 1] / 1e3, rtol=1e-12)
    np.testing.assert_allclose(series[quotient_path(0, "left")][2], derailment_quotients(run)[:, 0, 0], rtol=1e-12)
    carbody = run.frame_names.index("carbody")
    np.testing.assert_allclose(series[frame_roll_path("carbody")][2], run.frame_roll[:, carbody] * 1e3, rtol=1e-12)
    np.testing.assert_allclose(series[frame_bounce_path("bogie2")][2], run.frame_bounce[:, 1] * 1e3, rtol=1e-12)
    assert np.max(np.abs(run.frame_roll[:, carbody])) > 1e-5  # the 2 mm start sways the body


def test_a_run_on_a_curved_track_is_drawn_along_it(tmp_path):
    """On a curved, canted track the recording carries every body by the track's frame at its
    own station: the car body's translation stays within its lateral displacement (and the
    cant's lean of its height) of the centreline, which turns through the curve; the rails
    follow the track, a wheel base b either side of it in the canted plane."""
    from rail_mj.track import load_track

    track = load_track(MODELS / "tracks" / "curve-600.toml")
    run = simulate(load_layout(COACH), 30.0, 700.0, track=track, initial_lateral=0.0)
    path = tmp_path / "curve.rrd"
    write_recording(run, path, exaggeration=1.0)  # true size: the lateral bound below is the body's own
    chunks = [c for c in RrdReader(str(path)).stream() if c.entity_path == "/world/vehicle/carbody"]
    rows = [c.to_record_batch() for c in chunks]
    translation = np.concatenate(
        [
            np.array(b.column("Transform3D:translation").to_pylist()).reshape(-1, 3)
            for b in rows
            if "Transform3D:translation" in b.schema.names
        ]
    )
    centre = track.xy(np.linspace(0.0, run.station[-1], 20000))
    gaps = np.min(np.linalg.norm(translation[:, None, :2] - centre[None, :, :], axis=-1), axis=1)
    # |y| of the body plus its height times the cant angle, and the 0.07 m between centreline samples.
    body = run.frame_names.index("carbody")
    bound = np.max(np.abs(run.frame_y[:, body])) + 3.0 * 0.1 + 0.05
    assert np.max(gaps) < bound
    # The body has turned with the curve: its track heading at the end, 0.5 rad after 300 m of 600 m.
    assert translation[-1, 1] > 100.0
    rails = next(c for c in RrdReader(str(path)).stream() if c.entity_path == "/world/rails").to_record_batch()
    strips = rails.column("LineStrips3D:strips").to_pylist()[0]
    left, right = (np.array(s) for s in strips)
    half = np.linalg.norm(left - right, axis=1) / 2
    # Rerun keeps positions in float32: 6e-8 of up to 800 m.
    np.testing.assert_allclose(half, run.layout.wheelset.contact_half_spacing, rtol=0, atol=1e-4)


def test_a_run_on_a_curved_track_plots_each_wheel_s_wear_number(tmp_path):
    """On curved track the recording plots each wheel's T-gamma (N, from 0) beside the curvature and
    cant, the values of Run.contact_forces(); a run on straight track has no such plot."""
    from rail_mj.output.recording import wear_path
    from rail_mj.track import load_track

    track = load_track(MODELS / "tracks" / "curve-600.toml")
    run = simulate(load_layout(COACH), 30.0, 420.0, track=track, initial_lateral=0.0)
    titles = [p.title for p in plots(run)]
    assert titles.index("Wheels: wear number Tγ (N)") == titles.index("Track under the wheelsets: cant (mm)") + 1
    rrd = write_recording(run, tmp_path / "curve.rrd", rate=math.inf)
    series = read_series(rrd)
    forces = run.contact_forces()
    np.testing.assert_allclose(series[wear_path(0, "right")][2], forces.wear_right[:, 0], rtol=1e-12)
    np.testing.assert_allclose(series[wear_path(3, "left")][2], forces.wear_left[:, 3], rtol=1e-12)
    assert np.max(forces.wear_right[:, 0]) > 0.0
    straight = simulate(load_layout(COACH), 30.0, 10.0, initial_lateral=0.002)
    assert not any("Tγ" in p.title for p in plots(straight))


def test_a_run_on_irregular_track_plots_its_rails_floor_accelerations_and_comfort(tmp_path):
    """On irregular track the recording adds the rails under each wheelset (alignment, level), the
    car body's floor accelerations above each bogie and at the centre and the continuous comfort: the
    values the Run and rail_mj.analysis.ride give (mm, m/s^2)."""
    from rail_mj.analysis.ride import WD, continuous_comfort
    from rail_mj.output.recording import floor_path, rails_path
    from rail_mj.track import track_from_dict
    from rail_mj.vehicle.rails import ALIGNMENT, LEVEL, Rails

    track = track_from_dict(
        {"section": [{"kind": "straight", "length": 400.0}], "irregularities": {"spectrum": "erri-high"}}
    )
    layout = load_layout(MODELS.parent / "tests" / "data" / "manchester-coach-spatial.toml")
    run = simulate(layout, speed=40.0, distance=300.0, track=track)
    titles = {p.title for p in plots(run)}
    assert {
        "Rails under the wheelsets: alignment (mm)",
        "Rails under the wheelsets: level (mm)",
        "Car body floor: lateral acceleration (m/s²)",
        "Car body floor: vertical acceleration (m/s²)",
        "Ride comfort: continuous N_CY (EN 12299, 5 s)",
        "Ride comfort: continuous N_CZ (EN 12299, 5 s)",
    } <= titles
    series = read_series(write_recording(run, tmp_path / "rails.rrd", rate=math.inf))
    at = Rails.of(run.vehicle.model).at(run.wheelset_station)
    np.testing.assert_allclose(series[rails_path("alignment", 0)][2], at[:, 0, ALIGNMENT] * 1e3, rtol=1e-12)
    np.testing.assert_allclose(series[rails_path("level", 3)][2], at[:, 3, LEVEL] * 1e3, rtol=1e-12)
    floor = run.floor_accelerations()
    np.testing.assert_allclose(series[floor_path("vertical", "centre")][2], floor.vertical[:, 2], rtol=1e-12)
    comfort = continuous_comfort(floor.lateral[:, 0], floor.fs, WD)
    logged = series[floor_path("comfort_lateral", "bogie1")][2]
    late = np.isfinite(comfort)
    np.testing.assert_allclose(logged[-late.sum() :], comfort[late], rtol=1e-12)
