"""Vehicles on irregular track (rail_mj.vehicle.rails, docs/irregularities.md): each wheelset on the
rails at its own station, against oracles computed here."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import DATA, MODELS, harmonic, measured_track_file

from rail_mj import load_layout, simulate
from rail_mj.contact.creep import ContactParameters, wheelset_forces
from rail_mj.track import load_track
from rail_mj.track.irregularities import CHANNELS

WHEELSET = MODELS / "wheelset" / "wheelset.toml"
SPATIAL = DATA / "manchester-coach-spatial.toml"


def measured_track(tmp_path, length: float, step: float = 0.25, **channels) -> str:
    """A straight track of `length` m with a measured file of the given channels (functions of x, m)."""
    x = np.arange(0.0, length + step / 2, step)
    values = {c: np.asarray(channels[c](x), float) if c in channels else np.zeros_like(x) for c in CHANNELS}
    return measured_track_file(tmp_path, x, values)


@pytest.mark.parametrize("wavelength", [15.0, 40.0])
def test_a_sinusoidal_alignment_gives_the_wheelsets_steady_response(tmp_path, wavelength):
    """The restrained wheelset of docs/creep.md (yaw spring k_psi to a fixed frame, linear creep, no
    flange) on an alignment a = A*sin(2*pi*x/L) at V: its equations of motion relative to the rails
    are, with the rails' a entering only through the rolling-radius difference,

        m*y'' + (2*f22/V)*y' - 2*f22*psi = 0
        I*psi'' + (2*f11*b^2/V)*psi' + k_psi*psi + (2*f11*b*lam/r0)*y = (2*f11*b*lam/r0)*a

    (the lateral creepage y'/V - psi is the same relative to the rails as absolute), so its steady
    amplitude is the solve of that 2x2 system at omega = 2*pi*V/L. RK4 at the run's timestep and the
    spline of a 0.25 m sampled sine are both far inside 1e-4 of it."""
    layout = load_layout(WHEELSET)
    w, c = layout.wheelset, layout.creep
    speed, amplitude = 30.0, 0.002
    ramp = 60.0  # m: the sine grows over this, smoothly, from nothing
    track = measured_track(
        tmp_path,
        800.0,
        alignment=lambda x: (
            amplitude
            * np.sin(2 * np.pi * x / wavelength)
            * np.where(x < ramp, 0.5 - 0.5 * np.cos(np.pi * np.minimum(x, ramp) / ramp), 1.0)
        ),
    )
    run = simulate(layout, speed, 700.0, initial_lateral=0.0, track=load_track(track))
    omega = 2 * np.pi * speed / wavelength
    m, inertia, r0, b, lam = w.mass, w.inertia[2], w.rolling_radius, w.contact_half_spacing, w.conicity
    k_psi = layout.primary.yaw_stiffness
    coupling = 2 * c.f11 * b * lam / r0
    system = np.array(
        [
            [-m * omega**2 + 1j * omega * 2 * c.f22 / speed, -2 * c.f22],
            [coupling, -inertia * omega**2 + 1j * omega * 2 * c.f11 * b**2 / speed + k_psi],
        ]
    )
    expected = np.linalg.solve(system, np.array([0.0, coupling * amplitude]))
    late = run.x > 300.0  # ten seconds: every transient has decayed by e^-20 or more
    # The wheelset at x passes the rails' phase 2*pi*x/L: a = A*sin(omega*t) = Im(A*e^(i*omega*t)),
    # so its response is Im(H*A*e^(i*omega*t)); as a cosine/sine fit, Re(-i*H*A*e^(i*omega*t)).
    for k, column in enumerate((run.y[late, 0], run.psi[late, 0])):
        got = harmonic(column, run.t[late], omega)
        assert abs(got - (-1j) * expected[k]) <= 2e-4 * abs(expected[k]), (k, got, -1j * expected[k])


def test_gauge_moves_each_flange_half_its_widening_out():
    """On cones the flanges meet rails that stand g/2 further out each: the rail's force starts at
    |y| = clearance + g/2 and grows as k*(|y| - clearance - g/2), either side."""
    p = ContactParameters.broadcast(
        1, r0=0.46, b=0.75, conicity=0.05, f11=0.0, f22=0.0, clearance=0.006, flange_stiffness=2e7, flange_slope=0.05
    )
    gauge = 0.003
    for side in (1.0, -1.0):
        y = side * np.array([0.0070, 0.0074, 0.0080, 0.0090])
        fy, _ = wheelset_forces(p, y, np.zeros(4), np.zeros(4), np.zeros(4), 30.0, gauge=np.full(4, gauge))
        over = np.maximum(np.abs(y) - 0.006 - gauge / 2, 0.0)
        np.testing.assert_allclose(fy, -side * 2e7 * over, rtol=0, atol=1e-9)


def test_long_level_waves_carry_the_car_body_with_the_mean_of_its_wheelsets(tmp_path):
    """A level wave 400 m long at 20 m/s (0.05 Hz, a twentieth of the car body's bounce frequency):
    quasi-statically every spring deflects as the rails under its wheelsets rise, so the car body's
    centre rises by the mean of the levels under its four wheelsets. The wave is A*sin^3 (smooth where
    it starts), (3*sin - sin(3*.))/4: its third harmonic, a quarter of A at 0.15 Hz, is amplified by
    1/(1 - 0.15^2) - 1 = 2.3 %, 0.6 % of A (measured 0.62 %); the wheel loads stay at their static
    share to within the wheelsets' inertia m*V^2*z'' and that amplification (measured 0.14 %)."""
    layout = load_layout(SPATIAL)
    amplitude, wavelength = 0.01, 400.0
    track = measured_track(
        tmp_path,
        1500.0,
        step=1.0,
        level=lambda x: amplitude * np.sin(2 * np.pi * np.maximum(x - 100.0, 0) / wavelength) ** 3,
    )
    run = simulate(layout, 20.0, 1200.0, initial_lateral=0.0, track=load_track(track))
    from rail_mj.vehicle.rails import LEVEL, Rails

    rails = Rails.of(run.vehicle.model)
    assert rails is not None and rails.vertical
    mean_level = rails.at(run.wheelset_station)[..., LEVEL].mean(axis=1)
    carbody = run.frame_names.index("carbody")
    bounce = run.frame_bounce[:, carbody]
    assert np.abs(mean_level).max() > 0.9 * amplitude  # the wave has passed under it
    assert np.abs(bounce - mean_level).max() <= 0.01 * amplitude
    q = run.wheel_loads()
    assert np.abs(q / layout.wheelset.wheel_load - 1.0).max() < 0.003


def test_the_rails_roll_the_wheelsets_and_push_them_downhill(tmp_path):
    """A cross level held at 6 mm (a 4 mrad roll of the rails) over a long stretch, at 10 m/s: the
    rails' normal forces tilt with them and push each wheelset downhill (to the right, the left rail
    being higher) by P*phi (P its axle load), which its springs and creep take; the bodies above
    feel no lateral force, gravity being vertical."""
    layout = load_layout(SPATIAL)
    cross = 0.006
    track = measured_track(
        tmp_path,
        800.0,
        step=1.0,
        cross_level=lambda x: cross * (0.5 - 0.5 * np.cos(np.pi * np.clip((x - 50.0) / 150.0, 0.0, 1.0))),
    )
    run = simulate(layout, 10.0, 600.0, initial_lateral=0.0, track=load_track(track))
    held = run.wheelset_station[:, 0] > 450.0
    phi = cross / 1.5
    load = run.wheel_loads().sum(axis=2)[held]
    sum_y = run.guiding_forces()[held]
    # No other lateral force acts on the vehicle from outside: once it runs steadily, the rails' lateral
    # forces on all its wheelsets balance their pushes, sum of sum Y = sum of P*sin(phi).
    np.testing.assert_allclose(sum_y.sum(axis=1), load.sum(axis=1) * math.sin(phi), rtol=0.01)


def test_runs_packed_together_on_irregular_track_are_the_runs_alone(tmp_path):
    """Several vehicles stepped in one model (a sweep's pack) each read their own rails: every run
    bit for bit as alone."""
    from rail_mj.simulation.batch import simulate_many
    from rail_mj.simulation.run import Request

    path = tmp_path / "t.toml"
    path.write_text('[[section]]\nkind = "straight"\nlength = 400.0\n\n[irregularities]\nspectrum = "erri-high"\n')
    track = load_track(path)
    layout = load_layout(SPATIAL)
    packed = simulate_many([Request(layout, v, 200.0, track=track) for v in (30.0, 45.0)])
    for run, speed in zip(packed, (30.0, 45.0)):
        alone = simulate(layout, speed, 200.0, track=track)
        assert np.array_equal(run.body_pos, alone.body_pos) and np.array_equal(run.axle_loads, alone.axle_loads)
        assert np.abs(alone.y).max() > 0.004  # the rails moved it


def test_the_rails_are_the_track_files_channels_splined(tmp_path):
    """At the realisation's samples the block's splines give its channels to rounding (1e-14 m: where a sample
    falls on the end of one interval or the start of the next); between them
    their slopes and curvatures are the derivatives of their values (central differences of a cubic
    at 1 mm: exact to 1e-6 of the slope's scale); before the track's start the rails are level."""
    from rail_mj.vehicle.rails import (
        ALIGNMENT,
        ALIGNMENT_SLOPE,
        GAUGE,
        LEVEL,
        LEVEL_CURVATURE,
        LEVEL_SLOPE,
        ROLL,
        Rails,
    )
    from rail_mj.vehicle.spec import Vehicle

    path = tmp_path / "t.toml"
    path.write_text('[[section]]\nkind = "straight"\nlength = 300.0\n\n[irregularities]\nspectrum = "erri-high"\n')
    track = load_track(path)
    rails = Rails.of(Vehicle(load_layout(SPATIAL), track).model)
    x, channels = track.irregularities.channels(track.length)
    at = rails.at(x[:-1])
    for entry, channel, factor in (
        (ALIGNMENT, "alignment", 1),
        (LEVEL, "level", 1),
        (GAUGE, "gauge", 1),
        (ROLL, "cross_level", 1.5),
    ):
        np.testing.assert_allclose(at[:, entry] * factor, channels[channel][:-1], rtol=0, atol=1e-14)
    s = np.linspace(60.0, 250.0, 777)
    h = 1e-3
    r, ahead, behind = rails.at(s), rails.at(s + h), rails.at(s - h)
    # The curvature's own rate jumps at each knot (a cubic spline is C2, not C3), so a central difference
    # of the slope straddling a knot is off by about h/4 times that jump: 5e-5 of the scale measured.
    pairs = ((ALIGNMENT, ALIGNMENT_SLOPE, 1e-6), (LEVEL, LEVEL_SLOPE, 1e-6), (LEVEL_SLOPE, LEVEL_CURVATURE, 1e-4))
    for value, slope, tolerance in pairs:
        scale = np.abs(r[:, slope]).max()
        difference = (ahead[:, value] - behind[:, value]) / (2 * h)
        np.testing.assert_allclose(difference, r[:, slope], rtol=0, atol=tolerance * scale)
    before = rails.at(np.array([-30.0, -1.0]))
    assert np.all(before == 0.0)


def test_a_run_on_irregular_track_reports_ride_comfort_and_the_sections_statistics(tmp_path, capsys):
    """The summary, JSON and text, of the spatial coach on 400 m of ERRI-high track: N_MV, Wz and the
    floor accelerations at the three floor points; per section Sigma Y, Q, dQ/Q0, Y/Q and the frames'
    accelerations, each extreme within its plain extremes."""
    import json

    from rail_mj.cli import main

    path = tmp_path / "t.toml"
    path.write_text('[[section]]\nkind = "straight"\nlength = 450.0\n\n[irregularities]\nspectrum = "erri-high"\n')
    argv = ["run", str(SPATIAL), "--speed", "40", "--distance", "400", "--track", str(path)]
    assert main([*argv, "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    points = result["ride"]["points"]
    assert [p["point"] for p in points] == ["bogie1", "bogie2", "centre"]
    for p in points:
        assert 0.0 < p["n_mv"] < 6.0 and 1.0 < p["wz_lateral"] < 5.0 and 0.5 < p["wz_vertical"] < 5.0
        assert p["max_continuous_comfort_lateral"] > 0.0
    (section,) = result["sections"]
    assert section["sum_y_limit_n"] == pytest.approx(10e3 + 2 * load_layout(SPATIAL).wheelset.wheel_load / 3)
    for w in section["wheelsets"]:
        for stats in (w["sum_y_n"], w["left"]["q_n"], w["right"]["y_over_q"], w["left"]["unloading"]):
            assert stats["min"] <= stats["p0_15"] <= stats["p99_85"] <= stats["max"]
    assert [f["body"] for f in section["frames"]] == ["bogie1", "bogie2"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "ride comfort (EN 12299, Sperling" in out and "N_MV" in out and "section 1 (straight" in out


def test_a_wheelset_the_rails_throw_off_says_the_track_did_it(tmp_path):
    """Ten times ERRI-high under the S1002 coach at 40 m/s: a wheelset leaves its rails, and the one-line
    message names the track's irregularities as the cause and says what to change, not the start."""
    from rail_mj.simulation.run import Derailed

    path = tmp_path / "rough.toml"
    path.write_text(
        '[[section]]\nkind = "straight"\nlength = 600.0\n\n[irregularities]\nspectrum = "erri-high"\nscale = 10.0\n'
    )
    with pytest.raises(Derailed) as e:
        simulate(
            load_layout(MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml"),
            40.0,
            500.0,
            track=load_track(path),
        )
    message = str(e.value)
    assert "|y| from its rails passed" in message and f"The irregularities of {path}" in message
    assert "irregularities.scale" in message and "\n" not in message and "start nearer" not in message
