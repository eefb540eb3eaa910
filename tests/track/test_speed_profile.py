"""Speed profiles (rail_mj/track/speed.py, docs/track.md): the speed linear in distance between
points, and a run whose odometer is driven along it.

With V = V0 + g*(s - s0) (g = dV/ds), ds/dt = V gives the closed forms the tests use:
  t(s) = ln(V(s)/V0)/g,   s(t) = s0 + (V0/g)*(exp(g*t) - 1),   V(t) = V0*exp(g*t).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import MODELS
from scipy.integrate import quad

from rail_mj.layout import load_layout
from rail_mj.simulation.runner import simulate
from rail_mj.track import SpeedProfile, TrackError

COACH = MODELS / "manchester-coach" / "manchester-coach.toml"


def test_speed_is_linear_in_distance_and_held_beyond_the_ends():
    profile = SpeedProfile.parse("100:90,3100:60,4000:60")
    assert float(profile.at(0.0)) == 90.0  # held before the first point
    assert float(profile.at(1600.0)) == pytest.approx(75.0, rel=1e-15)
    assert float(profile.at(5000.0)) == 60.0
    assert profile.lowest(0.0, 1600.0) == pytest.approx(75.0, rel=1e-15)
    assert profile.highest(1600.0, 5000.0) == pytest.approx(75.0, rel=1e-15)


@pytest.mark.parametrize("text", ["0:90,3000:60", "0:40,500:40,1500:70,2500:30"])
def test_duration_is_the_integral_of_ds_over_v(text):
    """The closed form per piece against numerical quadrature of 1/V(s) (quad's own error
    ~1e-13 on these smooth pieces, hence 1e-11)."""
    profile = SpeedProfile.parse(text)
    cuts = [-200.0, *profile.stations, profile.stations[-1] + 300.0]
    numeric = sum(
        quad(lambda s: 1.0 / float(profile.at(s)), a, b, epsabs=0, epsrel=1e-13)[0]
        for a, b in zip(cuts, cuts[1:], strict=False)
    )
    assert profile.duration(cuts[0], cuts[-1]) == pytest.approx(numeric, rel=1e-11)


@pytest.mark.parametrize(
    "text, says",
    [
        ("0:90,0:60", "must increase"),
        ("0:90,3000", "station:speed pairs"),
        ("fast", "station:speed pairs"),
        ("0:-5", "between 0 and"),
        ("0:0", "must be positive"),
        ("0:nan", "must be finite"),
        ("0:1e9", "speed"),
        ("inf:50", "finite distance"),
        ("", "station:speed pairs"),
    ],
)
def test_bad_profiles_are_refused_in_one_line(text, says):
    with pytest.raises(TrackError, match=says) as caught:
        SpeedProfile.parse(text)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "name, speed",
    [("manchester-coach", 60.0), ("manchester-coach-s1002", 60.0), ("wheelset", 5.0)],
)
def test_a_profile_of_one_speed_is_the_constant_speed_run(name, speed):
    """One point: dV/ds = 0 everywhere, the odometer's force is zero and its velocity the run's
    speed, so every operation is the constant run's: the timestep equal to the last bit
    (linearised with the odometer rolling at the speed: on profiles and at 5 m/s the contact,
    not the 1 ms cap, sets it), and the motion too where the same model steps. A coach steps
    on its profile's straight track in its nested form, and without a track in its flat twin
    (Vehicle.stepped): there the motion agrees to the forms' difference, second order in the
    yaw angles: 5.5e-10 m on the coned coach, 1.6e-8 m on S1002/60E1, where RK4's own change
    from dt to dt/2 is 2.0e-6 m (tests/validation/test_peers.py bounds it on the coach too)."""
    layout = load_layout(MODELS / name / f"{name}.toml")
    constant = simulate(layout, speed, 150.0, initial_lateral=0.002)
    profiled = simulate(layout, SpeedProfile((0.0,), (speed,)), 150.0, initial_lateral=0.002)
    if name != "manchester-coach":
        assert constant.timestep < 1e-3
    assert profiled.timestep == constant.timestep
    if constant.vehicle.stepped is constant.vehicle:
        np.testing.assert_array_equal(profiled.y, constant.y)
        np.testing.assert_array_equal(profiled.psi, constant.psi)
    else:
        np.testing.assert_allclose(profiled.y, constant.y, rtol=0, atol=5e-8)
        np.testing.assert_allclose(profiled.psi, constant.psi, rtol=0, atol=5e-8)
    np.testing.assert_array_equal(profiled.x, profiled.station - profiled.station[0])
    np.testing.assert_allclose(profiled.x, constant.x, rtol=0, atol=1e-9)


def test_the_odometer_follows_a_deceleration():
    """A coach braking 70 -> 50 m/s over 1000 m (dV/dt = V*dV/ds = 1.0-1.4 m/s^2): the odometer's
    station against s(t) = (V0/g)(exp(g t) - 1). Its force is exact, so what is left is RK4's
    error in the exponential at the run's timestep, (g*V*dt)^4-small: 1e-6 m over 1 km."""
    layout = load_layout(COACH)
    profile = SpeedProfile.ramp(70.0, 50.0, 1000.0)
    run = simulate(layout, profile, 1000.0, initial_lateral=0.001)
    g = -20.0 / 1000.0
    expected = (70.0 / g) * np.expm1(g * 70.0 / 70.0 * run.t)  # V0 = 70 m/s at s = 0
    np.testing.assert_allclose(run.station, expected, rtol=0, atol=1e-6)
    assert run.t[-1] == pytest.approx(math.log(50.0 / 70.0) / g, abs=run.timestep)
    on = run.station <= 1000.0  # beyond its last point the profile holds 50 m/s
    np.testing.assert_allclose(run.speeds[on], 70.0 * np.exp(g * run.t[on]), rtol=1e-8)
    assert run.x[-1] == pytest.approx(1000.0, abs=0.1)  # the last step lands within a step's travel


def test_the_odometer_keeps_to_a_profile_of_several_pieces():
    """Braking, accelerating and braking again: the time at every station is the profile's
    closed-form duration to it. Where dV/ds jumps, an RK4 step across the point misses the
    speed by about dt*V*jump/2 (1.6e-3 m/s here), which the pull back onto the profile
    (PROFILE_RELAXATION, 0.05 s) turns into a lasting time error of about
    (1.6e-3/65)*0.05 = 1.2e-6 s a point: 5e-6 s for the three."""
    layout = load_layout(COACH)
    profile = SpeedProfile.parse("0:70,300:60,600:65,1000:50")
    run = simulate(layout, profile, 1000.0, initial_lateral=0.001)
    on = (run.station > 0.0) & (run.station <= 1000.0)
    expected = np.array([profile.duration(0.0, s) for s in run.station[on]])
    np.testing.assert_allclose(run.t[on], expected, rtol=0, atol=5e-6)


def test_a_profile_runs_on_a_curved_track_as_on_a_straight_one():
    """A profile needs no track (it runs on a straight one of its length), and with one the
    odometer is the same: the station depends on the profile, not on the curve."""
    from rail_mj.track import track_from_dict

    layout = load_layout(COACH)
    profile = SpeedProfile.ramp(50.0, 45.0, 400.0)
    track = track_from_dict(
        {
            "section": [
                {"kind": "straight", "length": 100.0},
                {"kind": "transition", "length": 100.0},
                {"kind": "curve", "length": 300.0, "radius": 1500.0, "cant": 0.1},
            ]
        }
    )
    straight = simulate(layout, profile, 300.0, initial_lateral=0.0)
    curved = simulate(layout, profile, 300.0, track=track, initial_lateral=0.0)
    np.testing.assert_allclose(curved.station, straight.station, rtol=0, atol=1e-9)
    assert np.abs(curved.y).max() > 1e-3  # the curve moved the wheelsets: it was run


def test_a_profiled_run_shows_its_speed_in_the_csv_the_recording_and_the_summary(tmp_path, capsys):
    """The speed of every sample, as the odometer had it: the CSV's last column, the recording's
    /vehicle/speed at the recorded samples, and in the JSON the profile and its speeds at the ends."""
    import json

    from rerun.chunk import RrdReader

    from rail_mj.cli import main
    from rail_mj.output.recording import SPEED_PATH

    csv, rrd = tmp_path / "run.csv", tmp_path / "run.rrd"
    argv = ["run", str(COACH), "--speed-profile", "0:50,200:40", "--distance", "300"]
    assert main([*argv, "--out", str(csv), "--rrd", str(rrd), "--rrd-rate", "full", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["speed_profile"]["stations_m"] == [0.0, 200.0]
    assert result["speed_profile"]["start_m_per_s"] == 50.0
    assert result["speed_profile"]["end_m_per_s"] == pytest.approx(40.0, rel=1e-9)
    assert "track" not in result and "curves" not in result  # straight track: no curve to report
    header = csv.read_text().splitlines()[0].split(",")
    values = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert header[-1] == "speed" and "curvature1" not in header
    np.testing.assert_allclose(values[:, -1], SpeedProfile.parse("0:50,200:40").at(values[:, 1]), rtol=1e-8)
    recorded = []
    for chunk in RrdReader(str(rrd)).stream():
        batch = chunk.to_record_batch()
        if chunk.entity_path == SPEED_PATH and "Scalars:scalars" in batch.schema.names:
            recorded += [v[0] for v in batch.column("Scalars:scalars").to_pylist()]
    np.testing.assert_allclose(recorded, values[:, -1], rtol=1e-9)


def test_profiled_runs_packed_together_are_each_the_run_alone():
    """Runs on one speed profile share a model eight at a time; those that end early give their
    places up and the rest are packed again, continuing with their odometers' own velocities
    (not reset to the profile's start): each is the run alone, bit for bit."""
    from rail_mj.simulation.batch import simulate_many
    from rail_mj.simulation.run import Request

    layout = load_layout(COACH)
    profile = SpeedProfile.ramp(60.0, 45.0, 300.0)
    requests = [Request(layout, 60.0, 40.0 + 25.0 * k, 0.0005 * (k % 4), profile=profile) for k in range(11)]
    many = simulate_many(requests, threads=2)
    for request, result in zip(requests, many):
        alone = simulate(layout, profile, request.distance, request.initial_lateral)
        np.testing.assert_array_equal(result.y, alone.y)
        np.testing.assert_array_equal(result.station, alone.station)
