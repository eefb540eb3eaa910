"""What a recording shows a reviewer: the 3D view's exaggeration, the window the plots open on,
legends that leave the data free, the car body's drawn size and the profiled wheel's mesh; and
the map's cells and axis labels. Recordings are read back with Rerun's own reader."""

from __future__ import annotations

import math

import numpy as np
import pyarrow as pa
import pytest
from conftest import MODELS
from rerun.chunk import RrdReader

from rail_mj.analysis import flange_strikes
from rail_mj.layout import LayoutError, layout_from_dict, load_layout
from rail_mj.output.recording import (
    DISTANCE,
    EXAGGERATED_REACH,
    EXAGGERATION_PATH,
    LEGEND_CORNERS,
    LEGEND_MARGIN,
    LEGEND_ROW,
    LEGEND_WIDTH,
    MAX_EXAGGERATION,
    TIME,
    WINDOW_LEAD,
    WINDOW_SPAN,
    axis_range,
    exaggerated_poses,
    exaggeration,
    lateral_path,
    legend_corner,
    plots,
    recorded_samples,
    review_window,
    write_recording,
)
from rail_mj.simulation.run import Run, _spatial_angles
from rail_mj.simulation.runner import simulate
from rail_mj.vehicle.spec import Vehicle

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"
SPATIAL = MODELS.parent / "tests" / "data" / "manchester-coach-spatial.toml"


@pytest.fixture(scope="module")
def hunting():
    """The README's main job, shortened: the coach at 85 m/s strikes its flanges within 55 m and
    hunts in a limit cycle of about 13 mm at 5 Hz; 500 m are 5.9 s, longer than the window."""
    return simulate(load_layout(COACH), speed=85.0, distance=500.0, initial_lateral=0.002)


def views(path) -> dict[str, dict[str, list]]:
    """Each blueprint view by its name: its components and those of its properties (PlotLegend,
    VisibleTimeRanges, ...), "Archetype:field" -> the logged value."""
    reader = RrdReader(str(path))
    by_id: dict[str, dict[str, list]] = {}
    for chunk in reader.stream(store=reader.blueprints()[0]):
        parts = chunk.entity_path.strip("/").split("/")
        if parts[0] != "view":
            continue
        batch = chunk.to_record_batch()
        fields = by_id.setdefault(parts[1], {})
        for name in batch.schema.names:
            if ":" in name:
                fields[name] = batch.column(name).to_pylist()[0]
    return {fields["ViewBlueprint:display_name"][0]: fields for fields in by_id.values()}


def blueprint_entity(path, entity: str) -> dict[str, list]:
    reader = RrdReader(str(path))
    out: dict[str, list] = {}
    for chunk in reader.stream(store=reader.blueprints()[0]):
        if chunk.entity_path == entity:
            batch = chunk.to_record_batch()
            out.update({n: batch.column(n).to_pylist()[0] for n in batch.schema.names if ":" in n})
    return out


def poses(path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each moving body's logged (translations, xyzw quaternions), in time order."""
    out = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if chunk.is_static or "Transform3D:translation" not in batch.schema.names:
            continue
        order = np.argsort(batch.column(TIME).cast(pa.int64()).to_numpy(), kind="stable")
        xyz = np.array([v[0] for v in batch.column("Transform3D:translation").to_pylist()])[order]
        xyzw = np.array([v[0] for v in batch.column("Transform3D:quaternion").to_pylist()])[order]
        out[chunk.entity_path] = (xyz, xyzw)
    return out


def static_text(path, entity: str) -> str:
    chunk = next(c for c in RrdReader(str(path)).stream() if c.entity_path == entity)
    return chunk.to_record_batch().column("TextDocument:text").to_pylist()[0][0]


def series_values(path, entity: str) -> np.ndarray:
    """A Scalars series' values, in time order."""
    parts = []
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if chunk.entity_path == entity and "Scalars:scalars" in batch.schema.names:
            t = batch.column(TIME).cast(pa.int64()).to_numpy()
            parts.append((t, np.array([v[0] for v in batch.column("Scalars:scalars").to_pylist()])))
    t, values = (np.concatenate(p) for p in zip(*parts))
    return values[np.argsort(t, kind="stable")]


def yaw_of_xyzw(xyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = (xyzw[..., k] for k in range(4))
    return np.arctan2(-2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z))


def synthetic_run(layout_path, t: np.ndarray, y: np.ndarray, v: np.ndarray) -> Run:
    """A Run of the layout's vehicle whose every wheelset moves laterally by y(t) at velocity v(t)."""
    vehicle = Vehicle(load_layout(layout_path))
    n, nbody = len(t), vehicle.model.nbody
    pos = np.zeros((n, nbody, 3))
    pos[:, vehicle.wheelset_ids, 1] = y[:, None]
    rates = np.zeros((n, len(vehicle.wheelset_ids), 2))
    rates[:, :, 0] = v[:, None]
    return Run(vehicle, 30.0, t[1] - t[0], t, pos, np.tile([1.0, 0, 0, 0], (n, nbody, 1)), rates)


# --- the 3D view's exaggeration ------------------------------------------------------------


def test_exaggeration_enlarges_the_largest_motion_to_a_round_factor():
    """The largest |y| drawn as up to half of b (0.375 m), the factor 1, 2 or 5 times a power of
    ten, between 1 and MAX_EXAGGERATION."""
    t = np.arange(2001) * 1e-3
    wave = np.sin(2 * np.pi * 5.0 * t)
    b = load_layout(MODELS / "wheelset" / "wheelset.toml").wheelset.contact_half_spacing
    cases = {0.013: 20.0, 0.004: 50.0, 0.03: 10.0, 0.2: 1.0, 1e-6: MAX_EXAGGERATION, 0.0: 1.0}
    for amplitude, factor in cases.items():
        run = synthetic_run(MODELS / "wheelset" / "wheelset.toml", t, amplitude * wave, wave)
        assert exaggeration(run) == factor, amplitude
        if 1.0 < factor < MAX_EXAGGERATION:  # the largest motion shown as a sizeable part of b/2
            assert 0.4 * EXAGGERATED_REACH * b < factor * amplitude <= EXAGGERATED_REACH * b


def test_the_3d_view_exaggerates_lateral_motion_and_yaw_and_says_so(tmp_path, hunting):
    """Every body's y and psi drawn 20 times (13 mm of hunting: 0.26 m), stated in the 3D view's
    name, in a text of its own and in the notes; the plots keep the true values."""
    factor = exaggeration(hunting)
    assert factor == 20.0
    path = write_recording(hunting, tmp_path / "coach.rrd")
    keep = recorded_samples(hunting)
    drawn = poses(path)
    model = hunting.vehicle.model
    for name in ("wheelset1", "wheelset4", "bogie1", "carbody"):
        body = model.body(name).id
        xyz, xyzw = drawn[f"/world/vehicle/{name}"]
        np.testing.assert_allclose(xyz[:, 1], factor * hunting.body_pos[keep, body, 1], rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(xyz[:, 0], hunting.x[keep] + hunting.body_pos[keep, body, 0], rtol=1e-6)
        true_yaw = 2.0 * np.arctan2(hunting.body_quat[keep, body, 3], hunting.body_quat[keep, body, 0])
        np.testing.assert_allclose(yaw_of_xyzw(xyzw), factor * true_yaw, rtol=1e-5, atol=1e-6)
    assert np.max(np.abs(drawn["/world/vehicle/wheelset1"][0][:, 1])) > 0.2  # visible: a fifth of a metre
    assert "Vehicle on the track, lateral motion and yaw ×20 (the camera follows it)" in views(path)
    assert "20 times their size" in static_text(path, EXAGGERATION_PATH)
    assert "20 times their size" in static_text(path, "/layout")
    np.testing.assert_array_equal(series_values(path, lateral_path(0)), hunting.y[keep, 0] * 1000)  # true mm


def test_an_exaggeration_asked_for_and_true_size(tmp_path):
    run = simulate(load_layout(MODELS / "bogie" / "bogie.toml"), speed=25.0, distance=5.0, initial_lateral=0.002)
    keep = recorded_samples(run)
    path = write_recording(run, tmp_path / "five.rrd", exaggeration=5.0)
    y = run.body_pos[keep, run.vehicle.model.body("wheelset2").id, 1]
    np.testing.assert_allclose(poses(path)["/world/vehicle/wheelset2"][0][:, 1], 5.0 * y, rtol=1e-6, atol=1e-9)
    assert "Vehicle on the track, lateral motion and yaw ×5 (the camera follows it)" in views(path)
    true = write_recording(run, tmp_path / "true.rrd", exaggeration=1.0)
    np.testing.assert_allclose(poses(true)["/world/vehicle/wheelset2"][0][:, 1], y, rtol=1e-6, atol=1e-9)
    assert "Vehicle on the track, true size (the camera follows it)" in views(true)
    assert "true size" in static_text(true, EXAGGERATION_PATH)
    for bad in (0.5, 0.0, -2.0, 2000.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="exaggeration must be a number from 1"):
            write_recording(run, tmp_path / "bad.rrd", exaggeration=bad)
    assert not (tmp_path / "bad.rrd").exists()


def test_a_spatial_body_keeps_its_roll_and_pitch_when_its_yaw_is_exaggerated():
    run = simulate(load_layout(SPATIAL), speed=40.0, distance=20.0, initial_lateral=0.002, initial_yaw=0.001)
    keep = np.arange(0, len(run.t), 50)
    body = run.vehicle.model.body("carbody").id
    _, quat = exaggerated_poses(run, keep, 30.0)
    roll, pitch, yaw = _spatial_angles(run.body_quat[keep, body])
    roll30, pitch30, yaw30 = _spatial_angles(quat[:, body])
    assert np.max(np.abs(roll)) > 1e-5 and np.max(np.abs(yaw)) > 1e-6  # it rolls and yaws
    np.testing.assert_allclose(yaw30, 30.0 * yaw, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(roll30, roll, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(pitch30, pitch, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(quat, axis=-1), 1.0, rtol=1e-12)


# --- timelines and the window the plots open on ---------------------------------------------


def test_every_sample_logged_is_on_both_timelines(tmp_path, hunting):
    """Series, flange strikes and the bodies' poses: each row on the time and the distance
    timeline, the distance the run's (mm)."""
    run = hunting
    assert flange_strikes(run)  # the flange events are among them
    path = write_recording(run, tmp_path / "bogie.rrd")
    temporal = [c for c in RrdReader(str(path)).stream() if not c.is_static]
    kinds = set()
    for chunk in temporal:
        batch = chunk.to_record_batch()
        assert {TIME, DISTANCE} <= set(batch.schema.names), chunk.entity_path
        t = batch.column(TIME).cast(pa.int64()).to_numpy() / 1e9
        at = np.searchsorted(run.t, t - 1e-7)
        np.testing.assert_array_equal(batch.column(DISTANCE).to_numpy(), np.round(run.x[at] * 1000).astype(np.int64))
        kinds |= {n.split(":")[0] for n in batch.schema.names if ":" in n}
    assert {"Scalars", "TextLog", "Transform3D"} <= kinds


def test_the_plots_open_on_seconds_around_the_first_flange_strike(tmp_path, hunting):
    """4 s (20 cycles at 5 Hz) from the start, the first strike at 0.64 s in it, on both timelines
    in every plot, and marked in the time panel; the notes say so."""
    window = review_window(hunting)
    first = min(s.start for s in flange_strikes(hunting))
    assert window is not None and window.moment == first and hunting.t[first] == pytest.approx(0.637, abs=0.01)
    assert window.start == 0 and hunting.t[window.end] == pytest.approx(WINDOW_SPAN[0])
    path = write_recording(hunting, tmp_path / "coach.rrd")
    seconds = (0, round(hunting.t[window.end] * 1e9))
    millimetres = (0, round(hunting.x[window.end] * 1000))
    time_series = {name: v for name, v in views(path).items() if v["ViewBlueprint:class_identifier"] == ["TimeSeries"]}
    assert len(time_series) == len(plots(hunting))
    for name, fields in time_series.items():
        ranges = {r["timeline"]: (r["range"]["start"], r["range"]["end"]) for r in fields["VisibleTimeRanges:ranges"]}
        assert ranges == {TIME: seconds, DISTANCE: millimetres}, name
        assert "TimeAxis:view_range" not in fields  # Rerun fits the x axis to the window's data
    panel = blueprint_entity(path, "/time_panel")
    assert panel["TimePanelBlueprint:timeline"] == [TIME]
    assert panel["TimePanelBlueprint:time_selection"] == [{"min": seconds[0], "max": seconds[1]}]
    assert "around the first flange strike (wheelset 1) at t = 0.64 s" in static_text(path, "/layout")


def test_the_window_follows_the_largest_motion_where_no_flange_strikes():
    """A motion that peaks mid-run at 2 Hz: 10 cycles, 5 s, a quarter of it before the peak; one
    that grows to the end: the last 5 s; a run shorter than the window: the whole of it."""
    t = np.arange(20001) * 1e-3
    envelope = np.exp(-(((t - 12.0) / 2.0) ** 2))
    wave, speed = np.sin(2 * np.pi * 2.0 * t), np.cos(2 * np.pi * 2.0 * t)
    layout = MODELS / "wheelset" / "wheelset.toml"  # no [flange]
    run = synthetic_run(layout, t, 0.003 * envelope * wave, speed)
    window = review_window(run)
    assert window is not None and window.reason == "the largest lateral motion of a wheelset"
    assert t[window.moment] == pytest.approx(12.0, abs=0.25)
    assert t[window.start] == pytest.approx(t[window.moment] - WINDOW_LEAD * 5.0)
    assert t[window.end] - t[window.start] == pytest.approx(5.0)
    growing = synthetic_run(layout, t, 0.003 * np.exp(0.2 * t) * wave, speed)
    late = review_window(growing)
    assert late is not None and late.end == len(t) - 1 and t[late.start] == pytest.approx(15.0)
    short = synthetic_run(layout, t[:3001], 0.003 * wave[:3001], speed[:3001])
    assert review_window(short) is None


def test_a_run_shorter_than_the_window_opens_whole(tmp_path):
    run = simulate(load_layout(MODELS / "bogie" / "bogie.toml"), speed=25.0, distance=20.0, initial_lateral=0.002)
    path = write_recording(run, tmp_path / "short.rrd")
    assert all("VisibleTimeRanges:ranges" not in v for v in views(path).values())
    assert "time_selection" not in str(blueprint_entity(path, "/time_panel"))
    assert "The plots show the whole run." in static_text(path, "/layout")


# --- legends ---------------------------------------------------------------------------------


def corner_samples(plot, run, window, corner) -> int:
    """How many of the window's samples fall in the legend's box in `corner` (LEGEND_CORNERS)."""
    _, side, end = next(c for c in LEGEND_CORNERS if c[0] == corner)
    span = slice(window.start, window.end + 1) if window else slice(None)
    t = run.t[span]
    u = (t - t[0]) / (t[-1] - t[0])
    low, high = axis_range([s.values for s in plot.series], plot.floor, plot.positive)
    height = LEGEND_MARGIN + LEGEND_ROW * len(plot.series)
    count = 0
    for s in plot.series:
        v = (s.values[span] - low) / (high - low)
        across = u >= 1 - LEGEND_WIDTH if side == "right" else u <= LEGEND_WIDTH
        up = v >= 1 - height if end == "top" else v <= height
        count += int(np.sum(across & up))
    return count


def test_the_wheel_loads_legend_sits_where_no_load_is(tmp_path):
    """The eight wheel loads run near the top of their axis (55 kN of 60): the legend, which hid
    one of them top right, goes to a bottom corner, where no sample is; every legend shown covers
    no sample."""
    run = simulate(load_layout(SPATIAL), speed=40.0, distance=30.0, initial_lateral=0.002)
    window = review_window(run)
    shown = {p.title: p for p in plots(run)}
    loads = shown["Wheels: vertical load Q (kN)"]
    assert len(loads.series) == 8
    assert corner_samples(loads, run, window, LEGEND_CORNERS[0][0]) > 0  # top right: the old place, on the data
    corner = legend_corner(loads, run, window)
    assert corner in {LEGEND_CORNERS[2][0], LEGEND_CORNERS[3][0]}
    path = write_recording(run, tmp_path / "spatial.rrd")
    blueprint = views(path)
    for title, plot in shown.items():
        corner = legend_corner(plot, run, window)
        fields = blueprint[title]
        assert fields["PlotLegend:visible"] == [corner is not None], title
        if corner is not None:
            assert fields["PlotLegend:corner"] == [corner.value]
            assert corner_samples(plot, run, window, corner) == 0, title
    assert blueprint["Wheels: vertical load Q (kN)"]["PlotLegend:visible"] == [True]


def test_hunting_plots_hide_the_legends_their_data_fill_and_the_notes_give_the_colours(tmp_path, hunting):
    window = review_window(hunting)
    lateral = plots(hunting)[0]
    assert lateral.title == "Wheelsets: lateral y (mm)"
    assert all(corner_samples(lateral, hunting, window, c[0]) > 0 for c in LEGEND_CORNERS)
    assert legend_corner(lateral, hunting, window) is None
    path = write_recording(hunting, tmp_path / "coach.rrd")
    assert views(path)["Wheelsets: lateral y (mm)"]["PlotLegend:visible"] == [False]
    notes = static_text(path, "/layout")
    assert "wheelset 1 blue, wheelset 2 red, wheelset 3 green, wheelset 4 yellow" in notes
    assert "car body white" in notes and "darker shade" in notes


# --- the car body's size and the wheels' profile -------------------------------------------


def flat_wagon(**carbody) -> dict:
    import tomllib

    data = tomllib.loads((MODELS / "wagon" / "wagon.toml").read_text())
    data["carbody"].update(carbody)
    return data


def test_a_flat_wagon_is_drawn_as_a_deck_of_its_size(tmp_path):
    """[carbody] length, width and height: a deck 0.3 m high, 13 m by 2.9 m, over the wheelsets,
    not a coach; the recording draws the same box."""
    layout = layout_from_dict(flat_wagon(length=13.0, width=2.9, height=0.3))
    assert (layout.carbody.length, layout.carbody.width, layout.carbody.height) == (13.0, 2.9, 0.3)
    model = Vehicle(layout).model
    names = {model.geom(g).name for g in range(model.ngeom)}
    assert "carbody_deck" in names and not {"carbody_roof", "carbody_windows_left"} & names
    deck = model.geom("carbody_deck")
    np.testing.assert_allclose(deck.size, [6.5, 1.45, 0.15])
    run = simulate(layout, speed=20.0, distance=5.0, initial_lateral=0.002)
    path = write_recording(run, tmp_path / "flat.rrd")
    deck = [
        c.to_record_batch()
        for c in RrdReader(str(path)).stream()
        if c.entity_path == "/world/vehicle/carbody/carbody_deck"
    ]
    boxes = next(b for b in deck if "Boxes3D:half_sizes" in b.schema.names)
    half = boxes.column("Boxes3D:half_sizes").to_pylist()[0][0]
    np.testing.assert_allclose(half, [6.5, 1.45, 0.15], rtol=1e-6)


def test_a_car_body_without_its_size_is_the_coach_and_a_given_size_sizes_it():
    coach = Vehicle(load_layout(MODELS / "wagon" / "wagon.toml")).model
    data = Vehicle(load_layout(MODELS / "wagon" / "wagon.toml")).layout.carbody
    assert (data.length, data.width, data.height) == (None, None, None)
    roof = coach.geom("carbody_roof")
    assert roof.size[1] == pytest.approx(1.4 + 0.02)  # 2.8 m wide, the coach's
    top = coach.body("carbody").pos[2] + roof.pos[2] + roof.size[2]
    assert top == pytest.approx(3.9)  # the roof 3.9 m above the rail
    van = Vehicle(layout_from_dict(flat_wagon(length=10.0, width=2.6, height=2.0))).model
    roof = van.geom("carbody_roof")
    assert roof.size[:2] == pytest.approx([5.02, 1.32])
    side = van.geom("carbody_side_left")
    bottom = van.geom("carbody_underframe")
    body_bottom = bottom.pos[2] - bottom.size[2]
    assert roof.pos[2] + roof.size[2] - body_bottom == pytest.approx(2.0)
    assert side.rgba.tolist() != coach.geom("carbody_side_left").rgba.tolist()  # not the red coach
    assert "carbody_windows_left" not in {van.geom(g).name for g in range(van.ngeom)}  # too low for windows


@pytest.mark.parametrize(
    ("carbody", "message"),
    [
        ({"length": -3.0}, "carbody.length: must be > 0, got -3"),
        ({"length": 5.0}, "carbody.length: must reach over the wheelsets it rests on, 6 m apart, got 5 m"),
        ({"width": 0.0}, "carbody.width: must be > 0, got 0"),
        ({"width": 8.0}, "carbody.width: must be <= 6, got 8"),
        ({"height": -0.3}, "carbody.height: must be > 0, got -0.3"),
        ({"height": "tall"}, "carbody.height: must be a number, got a string"),
        ({"lenght": 12.0}, "carbody.lenght: unknown key"),
    ],
)
def test_a_bad_car_body_size_is_one_line_naming_the_key(carbody, message):
    with pytest.raises(LayoutError) as error:
        layout_from_dict(flat_wagon(**carbody), source="wagon.toml")
    assert str(error.value) == f"wagon.toml: {message}"


def test_profiled_wheels_are_their_profile_revolved():
    """The mesh of a layout with [profiles] is its wheel profile turned about the axle: every
    vertex on the tread and flange at r = r0 - z(y) of the profile (to the outline's 0.1 mm), the
    flange tip at r0 + 28 mm; on cones the mesh is the cone's, as before."""
    import trimesh

    from rail_mj.contact.profiles import read_profile
    from rail_mj.vehicle.looks import mesh_file, wheel_outline
    from rail_mj.vehicle.wheel import HUB_FRACTION, outline_stl

    layout = load_layout(MODELS / "manchester-coach-worn" / "manchester-coach-worn.toml")
    profile = read_profile(layout.profiles.wheel, "wheel")
    mesh = trimesh.load(trimesh.util.wrap_as_stream(outline_stl(wheel_outline(layout))), file_type="stl")
    r = np.hypot(mesh.vertices[:, 0], mesh.vertices[:, 1])
    axial = mesh.vertices[:, 2]
    r0 = layout.wheelset.rolling_radius
    surface = r > 1.01 * HUB_FRACTION * r0
    # The taping line sits at b (0.75 m) on the standard track, where the geoms stand: no offset.
    expected = r0 - np.interp(axial[surface], profile.y, profile.z)
    assert np.max(np.abs(r[surface] - expected)) < 0.5e-3  # the flange's steep faces: 0.1 mm across them
    assert r.max() == pytest.approx(r0 - profile.z.min(), abs=0.1e-3)  # the flange tip, to the outline's 0.1 mm
    assert axial.min() == pytest.approx(profile.y[0]) and axial.max() == pytest.approx(profile.y[-1])
    assert mesh.is_watertight and len(mesh.faces) < 5000  # thinned from the profile's 785 points
    assert mesh_file(layout) == "wheel_s1002_worn_r0.46.stl"
    coned = load_layout(COACH)
    assert mesh_file(coned) == "wheel_r0.46_c0.15.stl"
    assert (MODELS / "manchester-coach" / "assets" / mesh_file(coned)).read_bytes() == outline_stl(wheel_outline(coned))


# --- the stability map ------------------------------------------------------------------------


def test_map_cells_meet_at_geometric_midpoints_on_a_log_axis_and_axes_name_their_units(monkeypatch):
    """A log axis from 2e6: cell edges at the geometric means of neighbours, the outer ones half
    a cell (in log space) beyond, never below 1e6 where matplotlib's arithmetic edges reached
    down past 3e5; a linear axis keeps arithmetic midpoints. Labels: the key and its unit."""
    import matplotlib.axes
    import pyarrow as pa

    from rail_mj.output.plots import cell_edges, key_label, stability_map_png

    xs = [2e6, 8e6, 3.2e7]
    np.testing.assert_allclose(cell_edges(xs, True), [1e6, 4e6, 1.6e7, 6.4e7])
    np.testing.assert_allclose(cell_edges([0.1, 0.2, 0.4], False), [0.05, 0.15, 0.3, 0.5])
    np.testing.assert_allclose(cell_edges([5.0], True), [5.0 / 10**0.25, 5.0 * 10**0.25])
    assert key_label("primary.yaw_stiffness") == "primary.yaw_stiffness (N·m/rad)"
    assert key_label("wheelset.conicity") == "wheelset.conicity (-)"
    assert key_label("bogies.2.mass") == "bogies.2.mass (kg)"
    assert key_label("secondary.lateral_damping") == "secondary.lateral_damping (N·s/m)"
    assert key_label("mystery") == "mystery"
    rows = [
        {"primary.yaw_stiffness": x, "wheelset.conicity": c, "status": "ok", "outcome": "critical"}
        | {"critical_speed_m_per_s": 50.0 + x / 1e6 + c, "mode": "bogie hunting"}
        for x in xs
        for c in (0.1, 0.2, 0.4)
    ]
    seen = {}
    original = matplotlib.axes.Axes.pcolormesh

    def spy(self, *args, **kwargs):
        if "axes" not in seen:  # the map's own; the colour bar draws itself with another
            seen.update(x=np.asarray(args[0]), y=np.asarray(args[1]), axes=self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "pcolormesh", spy)
    png = stability_map_png(
        pa.Table.from_pylist(rows), "primary.yaw_stiffness", "wheelset.conicity", True, False, "eigen", "coach"
    )
    assert png.startswith(b"\x89PNG")
    np.testing.assert_allclose(seen["x"], [1e6, 4e6, 1.6e7, 6.4e7])
    np.testing.assert_allclose(seen["y"], [0.05, 0.15, 0.3, 0.5])
    axes = seen["axes"]
    assert axes.get_xlim()[0] >= 1e6 * (1 - 1e-9)  # the bottom cell ends half a cell below 2e6, at 1e6
    assert axes.get_xlabel() == "primary.yaw_stiffness (N·m/rad)" and axes.get_ylabel() == "wheelset.conicity (-)"


def test_the_command_line_sets_the_exaggeration_and_refuses_one_below_true_size(tmp_path, capsys):
    from rail_mj.cli import main

    rrd, bogie = tmp_path / "b.rrd", str(MODELS / "bogie" / "bogie.toml")
    assert main(["run", bogie, "--speed", "25", "--distance", "5", "--rrd", str(rrd), "--exaggerate", "5"]) == 0
    assert "Vehicle on the track, lateral motion and yaw ×5 (the camera follows it)" in views(rrd)
    assert "3D view lateral motion and yaw x5" in capsys.readouterr().out
    assert main(["run", bogie, "--speed", "25", "--distance", "5", "--rrd", str(rrd), "--exaggerate", "0.5"]) == 2
    assert "--exaggerate must be auto or a factor from 1" in capsys.readouterr().err


def test_the_3d_view_draws_the_irregular_rails_as_it_draws_the_wheelsets_on_them(tmp_path):
    """On irregular track each rail is drawn where the run's irregularities put it: laterally the
    alignment plus half the gauge's widening outwards, exaggerated as the vehicle's lateral motion
    is (so a wheelset drawn at factor*y sits on rails drawn at factor*a), vertically the level and
    half the cross level (left up) at true size; the exaggeration's text says so."""
    from rail_mj.output.recording import EXAGGERATION_PATH
    from rail_mj.track import track_from_dict
    from rail_mj.track.irregularities import RAIL_BASE
    from rail_mj.vehicle.rails import ALIGNMENT, GAUGE, LEVEL, ROLL

    track = track_from_dict(
        {"section": [{"kind": "straight", "length": 300.0}], "irregularities": {"spectrum": "erri-high", "seed": 4}}
    )
    layout = load_layout(MODELS.parent / "tests" / "data" / "manchester-coach-spatial.toml")
    run = simulate(layout, speed=40.0, distance=100.0, track=track)
    path = write_recording(run, tmp_path / "irregular.rrd", exaggeration=10.0)
    rails = next(c for c in RrdReader(str(path)).stream() if c.entity_path == "/world/rails").to_record_batch()
    left, right = (np.array(p) for p in rails.column("LineStrips3D:strips").to_pylist()[0])
    at = run.rails.at(left[:, 0].astype(float))
    b = layout.wheelset.contact_half_spacing
    assert np.abs(at[:, ALIGNMENT]).max() > 1e-3  # the rails do wander
    # Rerun keeps positions in float32: 6e-8 m at 1 m from the centreline.
    np.testing.assert_allclose(left[:, 1] - b, 10.0 * (at[:, ALIGNMENT] + at[:, GAUGE] / 2), rtol=0, atol=1e-6)
    np.testing.assert_allclose(right[:, 1] + b, 10.0 * (at[:, ALIGNMENT] - at[:, GAUGE] / 2), rtol=0, atol=1e-6)
    np.testing.assert_allclose(left[:, 2] + 0.08, at[:, LEVEL] + at[:, ROLL] * RAIL_BASE / 2, rtol=0, atol=1e-6)
    np.testing.assert_allclose(right[:, 2] + 0.08, at[:, LEVEL] - at[:, ROLL] * RAIL_BASE / 2, rtol=0, atol=1e-6)
    assert "rails' alignment and gauge too" in static_text(path, EXAGGERATION_PATH)
