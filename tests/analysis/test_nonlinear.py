"""Flange contact, limit cycles and the nonlinear critical speed (docs/flange.md)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import MODELS
from rerun.chunk import RrdReader
from scipy.optimize import minimize_scalar

from rail_mj.analysis import (
    band_pass,
    dominant_frequency,
    flange_strikes,
    hunting_limit,
    late_motion,
    oscillation,
    sliding_rms,
)
from rail_mj.analysis.bifurcation import bifurcation
from rail_mj.analysis.stability import Stability
from rail_mj.cli import main
from rail_mj.contact.creep import POLACH, ContactParameters, contact_forces, flange_force, flange_lead, radius_rise
from rail_mj.layout import LayoutError, load_layout
from rail_mj.output.plots import bifurcation_csv, bifurcation_png
from rail_mj.output.recording import FLANGE_EVENTS, flange_path, write_recording
from rail_mj.simulation.runner import simulate

FLANGED = """
wheel_load = 60e3
[flange]
"""
MU, LOAD, K_FLANGE = 0.3, 60e3, 15e6


def flanged_wheelset(tmp_path):
    """The shipped restrained wheelset (linear critical speed 57.50 m/s) with Polach
    saturation and flange contact: no lateral spring, so the rails alone hold it."""
    text = (MODELS / "wheelset" / "wheelset.toml").read_text()
    text = text.replace("conicity = 0.1\n", "conicity = 0.1\nwheel_load = 60e3\n")
    text = text.replace("f22 = 10.0e6\n", f'f22 = 10.0e6\nlaw = "polach"\nfriction = {MU}\n')
    path = tmp_path / "flanged.toml"
    path.write_text(text + "\n[flange]\n")
    return path


P = ContactParameters.broadcast(
    3,
    r0=0.46,
    b=0.75,
    conicity=0.1,
    f11=10e6,
    f22=10e6,
    friction_limit=MU * LOAD,
    law=POLACH,
    clearance=0.008,
    flange_stiffness=K_FLANGE,
    flange_damping=1e4,
    flange_slope=math.tan(math.radians(70)),
)


def test_flange_force_is_a_one_sided_elastic_rail():
    y = np.array([0.005, 0.010, -0.012])
    force = flange_force(y, np.zeros(3), 0.008, K_FLANGE, 1e4)
    assert force[0] == 0.0  # within the clearance
    assert force[1] == pytest.approx(-K_FLANGE * 0.002)  # pushed back to the right
    assert force[2] == pytest.approx(K_FLANGE * 0.004)  # pushed back to the left
    # Leaving the rail fast, the damper may not pull the wheel back onto it.
    assert flange_force(0.009, -10.0, 0.008, K_FLANGE, 1e4) == 0.0
    # The contact forces carry it, on flanged wheelsets only.
    zero = np.zeros(3)
    assert np.array_equal(contact_forces(P, y, zero, zero, zero, 30.0).flange_lateral, force)


def test_rolling_radius_rises_up_the_flange():
    y = np.array([0.004, 0.008, 0.010])
    slope = math.tan(math.radians(70))
    left, right = radius_rise(y, 0.1, slope, 0.008), radius_rise(-y, 0.1, slope, 0.008)
    np.testing.assert_allclose(right, -0.1 * y)  # the other wheel stays on its cone
    np.testing.assert_allclose(left[:2], 0.1 * y[:2])
    assert left[2] == pytest.approx(0.1 * 0.008 + slope * 0.002)
    # With the linear law the creep couple is -f11*b*(r_left - r_right)/r0 (docs/creep.md, section 2).
    linear = ContactParameters.broadcast(
        3, r0=0.46, b=0.75, conicity=0.1, f11=10e6, f22=10e6, clearance=0.008, flange_slope=slope
    )
    zero = np.zeros(3)
    couple = contact_forces(linear, y, zero, zero, zero, 30.0).creep_couple
    np.testing.assert_allclose(couple, -10e6 * 0.75 * (left - right) / 0.46, rtol=1e-12)


def test_flange_contact_needs_a_saturating_law(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text((MODELS / "wheelset" / "wheelset.toml").read_text() + "\n[flange]\n")
    with pytest.raises(LayoutError, match="flange: flange contact needs a saturating creep law"):
        load_layout(path)


def test_flange_and_saturation_leave_the_linear_results_unchanged(tmp_path):
    """Both act only away from the centred state (the flange) or beyond Kalker's slope
    (saturation): the eigen critical speed is the linear one, 57.50 m/s."""
    linear = Stability(load_layout(MODELS / "wheelset" / "wheelset.toml")).critical_speed()
    flanged = Stability(load_layout(flanged_wheelset(tmp_path))).critical_speed()
    assert flanged.critical_speed == pytest.approx(linear.critical_speed, rel=1e-4)  # Brent's xtol
    assert flanged.frequency == pytest.approx(linear.frequency, rel=1e-4)


@pytest.fixture(scope="module")
def hunting_run(tmp_path_factory):
    """The flanged wheelset at 75 m/s (1.3 x its critical speed) for 12 s."""
    layout = load_layout(flanged_wheelset(tmp_path_factory.mktemp("hunting")))
    return simulate(layout, 75.0, 75.0 * 12.0, 0.002)


def test_hunting_is_a_limit_cycle_held_by_the_flanges(hunting_run):
    """At 75 m/s (1.3 x the critical speed) hunting grows onto the flanges and stays there.
    With no lateral spring, Newton across the track is m*y'' = F_creep + F_flange with
    |F_creep| <= 2*mu*N, so the rail deflection past the clearance is at most
    (m*max|y''| + 2*mu*N) / k_flange."""
    run, layout = hunting_run, hunting_run.layout
    y = run.y[:, 0]
    late = run.t > 6.0
    amplitude = np.max(np.abs(y[late]))
    assert amplitude > layout.wheelset.flangeway_clearance  # the flanges strike
    acceleration = np.gradient(np.gradient(y, run.t), run.t)
    deflection = (layout.wheelset.mass * np.max(np.abs(acceleration)) + 2 * MU * LOAD) / K_FLANGE
    # 5 % for the second difference of 1 kHz samples missing the true peak acceleration.
    assert amplitude <= layout.wheelset.flangeway_clearance + 1.05 * deflection
    # A settled cycle: the late peaks are as high as each other to 2 %.
    peaks = [np.max(np.abs(y[(run.t > a) & (run.t <= a + 1.5)])) for a in (6.0, 7.5, 9.0, 10.5)]
    assert max(peaks) <= 1.02 * min(peaks)


@pytest.mark.parametrize("degrees", [50.0, 60.0, 70.0, 75.0])
@pytest.mark.parametrize("psi", [0.005, 0.013, 0.03, -0.013])
@pytest.mark.parametrize("y", [0.010, -0.010])
def test_flange_contact_lead_is_where_the_yawed_flange_meets_the_rail(degrees, psi, y):
    """Search numerically, on the yawed flanging wheel's circle at the contact radius, for
    the point furthest into the rail's flank (a face along the track, inclined at the
    flange angle gamma): its longitudinal position is the contact's lead. The closed form
    psi*(r*tan(gamma) - b) keeps first order in psi*tan(gamma), so it may be off by the
    next order, r*(psi*tan(gamma))^3."""
    gamma = math.radians(degrees)
    side = math.copysign(1.0, y)
    radius = 0.46 + radius_rise(abs(y), 0.1, math.tan(gamma), 0.008)
    forward = np.array([math.cos(psi), math.sin(psi), 0.0])
    axle = np.array([-math.sin(psi), math.cos(psi), 0.0])
    into_rail = np.array([0.0, side * math.sin(gamma), -math.cos(gamma)])

    def point(theta):  # on the wheel's circle of the contact radius, theta ahead of the bottom
        return side * 0.75 * axle + radius * (math.sin(theta) * forward - math.cos(theta) * np.array([0, 0, 1.0]))

    best = minimize_scalar(
        lambda th: -into_rail @ point(th), bounds=(-0.5, 0.5), method="bounded", options={"xatol": 1e-12}
    ).x
    lead = flange_lead(y, psi, radius, math.tan(gamma), 0.75)
    assert abs(lead - point(best)[0]) <= radius * abs(psi * math.tan(gamma)) ** 3


def test_flange_strikes_begin_yawed_into_the_rail_and_turn_away(hunting_run):
    """The seed article (docs/flange.md, section 3): at a flange strike the colliding wheel
    is behind its partner, the wheelset yawed towards the struck rail. Every strike of the
    limit cycle begins so, because the hunting wheelset arrives heading for the rail. On the
    flange, though, contact mechanics turns it away: the rolling radius rising up the flange
    makes the colliding wheel's longitudinal creep force push it forward (the creep couple,
    docs/creep.md, section 2, with the radius difference), and the flange force, acting ahead of
    the axle while the wheelset is yawed into the rail (`flange_lead`, for a 70 degree
    flange), is a yaw stiffness |Q|*(r*tan(gamma) - b) against any yaw."""
    run = hunting_run
    y, psi = run.y[:, 0], run.psi[:, 0]
    forces = run.contact_forces()
    strikes = [strike for strike in flange_strikes(run) if strike.start > 0 and strike.end < len(y)]
    assert len(strikes) >= 20
    for _, s, e, towards in strikes:  # positive yaw moments and angles turn the wheelset into the struck rail
        assert towards == np.sign(y[s]) and np.all(np.abs(y[s:e]) > 0.008) and abs(y[e]) <= 0.008
        assert towards * psi[s] > 0  # arrives yawed into the rail: the colliding wheel behind
        assert towards * psi[e - 1] < towards * psi[s]  # leaves turned away from it
        assert towards * np.mean(forces.creep_couple[s:e, 0]) < 0
        assert np.all(forces.flange_moment[s:e, 0] * psi[s:e] <= 0)


def test_recording_marks_flange_contacts(tmp_path):
    layout = load_layout(flanged_wheelset(tmp_path))
    run = simulate(layout, 75.0, 75.0 * 4.0, 0.002)
    path = write_recording(run, tmp_path / "hunting.rrd", rate=math.inf)
    events, force = [], None
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if chunk.entity_path == FLANGE_EVENTS and "TextLog:text" in batch.schema.names:
            events += [v[0] for v in batch.column("TextLog:text").to_pylist()]
        if chunk.entity_path == flange_path(0) and "Scalars:scalars" in batch.schema.names:
            force = np.array([v[0] for v in batch.column("Scalars:scalars").to_pylist()])
    strikes = np.sum(np.diff((np.abs(run.y[:, 0]) > 0.008).astype(int)) == 1)
    assert strikes >= 4 and len(events) == strikes
    assert any("left rail" in e for e in events) and any("right rail" in e for e in events)
    # The flange force, kN: the rail's lateral force on the flange.
    assert force is not None and np.max(np.abs(force)) > 0
    np.testing.assert_array_equal(force, run.contact_forces().flange_lateral[:, 0] / 1000)


def test_nonlinear_critical_speed_is_below_the_linear_one(tmp_path):
    layout = load_layout(flanged_wheelset(tmp_path))
    critical, down, up = bifurcation(layout, step=0.08, dwell=3.0)
    assert critical.linear_critical_speed == pytest.approx(57.50, abs=0.01)
    assert 0 < critical.critical_speed < critical.linear_critical_speed
    # Hysteresis: just below the linear critical speed the limit cycle lives on, while a
    # small disturbance at the same speed dies away.
    v = max(s for s in down.speeds if s < critical.linear_critical_speed)
    assert down.alive[down.speeds.index(v)] and not up.alive[up.speeds.index(v)]
    assert down.amplitudes[0] > layout.wheelset.flangeway_clearance
    png = bifurcation_png(critical, down, up, 0.008, "flanged")
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert bifurcation_csv([down, up]).decode().startswith("branch,speed_m_per_s,amplitude_m")


def test_cli_nonlinear_needs_flange_contact(capsys):
    assert main(["critical-speed", str(MODELS / "wagon" / "wagon.toml"), "--method", "nonlinear"]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        len(err.splitlines()) == 1 and "needs flange contact ([flange] or [profiles]) and a saturating creep law" in err
    )


def test_sliding_rms_matches_a_direct_sum():
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.uniform(0.5, 1.5, 400))
    signal = rng.normal(size=(400, 2))
    rms = sliding_rms(x, signal, 50.0)
    for k in (100, 250, 399):
        inside = (x >= x[k] - 50.0) & (x <= x[k])
        np.testing.assert_allclose(rms[k], np.sqrt(np.mean(signal[inside] ** 2, axis=0)), rtol=1e-9)
    assert np.all(np.isnan(rms[x - x[0] < 50.0]))


def test_guiding_force_is_newtons_law_for_a_wheelset_without_lateral_spring(tmp_path):
    """With no lateral spring or damper the rails alone push the wheelset across the
    track: Sigma Y = m * y''. Central second differences of 1 kHz samples of a 5 Hz
    oscillation are accurate to (2*pi*f*dt)^2/12 = 8e-5; 1e-3 of the peak force allows it,
    after the first 0.1 s (the creep-damped start, time constant m*V/(2*f22) = 4.5 ms,
    is too fast for second differences)."""
    layout = load_layout(flanged_wheelset(tmp_path))
    run = simulate(layout, 50.0, 50.0 * 3.0, 0.002)  # below the critical speed: on the treads
    force = run.guiding_forces()[:, 0]
    acceleration = np.gradient(np.gradient(run.y[:, 0], run.t), run.t)
    inner = slice(100, -5)
    assert np.max(np.abs(force[inner] - layout.wheelset.mass * acceleration[inner])) < 1e-3 * np.max(np.abs(force))


def test_hunting_detector(tmp_path, capsys):
    """EN 14363: rms of Sigma Y over 100 m against (10 + 2*Q0/3)/2 = (10 + P0/3)/2 kN, with
    wheel load Q0 = 60 kN and axle load P0 = 120 kN here: 25 kN."""
    path = flanged_wheelset(tmp_path)
    assert hunting_limit(120e3) == 25e3
    for speed, expected in ((50.0, False), (75.0, True)):
        assert main(["run", str(path), "--speed", str(speed), "--distance", "300", "--json"]) == 0
        summary = json.loads(capsys.readouterr().out)
        result = summary["hunting"]
        assert result["hunting"] is expected and result["limit_n"] == 25e3
    # The filter's f0 is the limit cycle's frequency, to the periodogram's resolution 1/duration.
    run = simulate(load_layout(path), 75.0, 300.0, 0.002)  # the CLI's run: default disturbance
    assert result["frequency_hz"] == pytest.approx(oscillation(*late_motion(run))[0], abs=1.0 / run.t[-1])


def test_hunting_filter_keeps_the_hunting_and_drops_its_harmonics():
    """EN 14363's band-pass around f0: a square-ish Sigma Y, a 5 Hz fundamental with a third
    harmonic of a third its size, keeps the fundamental's rms. Run forwards and backwards, the
    4th-order Butterworth band-pass passes 1 - 3e-6 of the amplitude at the band centre, half
    at the band edges (3 and 7 Hz: -3 dB twice) and 6e-5 at 15 Hz, so the rms is the
    fundamental's to 1e-5; 1e-4 allows it."""
    t = np.arange(0.0, 20.0, 1e-3)
    fundamental = 20e3 * np.sin(2 * np.pi * 5.0 * t)
    guiding = np.column_stack([fundamental + 20e3 / 3 * np.sin(2 * np.pi * 15.0 * t), 0.5 * fundamental])
    assert dominant_frequency(t, guiding) == pytest.approx(5.0, abs=1 / 20.0)  # the periodogram's resolution
    filtered = band_pass(t, guiding, 5.0)
    inner = slice(2000, -2000)  # away from the ends the filter starts and stops at
    rms = np.sqrt(np.mean(filtered[inner] ** 2, axis=0))
    np.testing.assert_allclose(rms, [20e3 / np.sqrt(2), 10e3 / np.sqrt(2)], rtol=1e-4)
    half = band_pass(t, np.sin(2 * np.pi * 7.0 * t), 5.0)[inner]
    assert np.sqrt(2 * np.mean(half**2)) == pytest.approx(0.5, rel=1e-3)  # the band edge


def test_one_nonlinear_critical_speed_from_both_commands(tmp_path, capsys):
    """critical-speed --method nonlinear and bifurcation follow one procedure with one step:
    the same nonlinear critical speed, below the linear one, each printing the step."""
    path = str(flanged_wheelset(tmp_path))
    assert main(["critical-speed", path, "--method", "nonlinear", "--step", "0.08", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["step"] == 0.08
    assert 0 < result["critical_speed"] < result["linear_critical_speed"]
    assert main(["bifurcation", path, "-o", str(tmp_path / "b.png"), "--step", "0.08"]) == 0
    out = capsys.readouterr().out
    assert f"nonlinear {result['critical_speed']:.2f} m/s (speed lowered in 8% steps)" in out


def test_a_limit_cycle_dying_above_the_linear_critical_speed_gives_no_nonlinear_one(tmp_path, monkeypatch):
    """Where the staircase loses the limit cycle before reaching the linear critical speed
    (a supercritical bifurcation, within the step), nothing above it is reported."""
    import rail_mj.analysis.bifurcation as bifurcation_module

    layout = load_layout(flanged_wheelset(tmp_path))

    def dies_early(layout, speeds, **kwargs):
        alive = [v > 60.0 for v in speeds[:3]]  # the linear critical speed is 57.50 m/s
        return bifurcation_module.Branch(
            "down", list(speeds[:3]), [0.01 if a else 0.0 for a in alive], [5.0] * 3, alive
        )

    monkeypatch.setattr(bifurcation_module, "follow", dies_early)
    critical, branch = bifurcation_module.nonlinear_critical_speed(layout, step=0.04)
    assert branch.alive[0] and branch.speeds[0] > 60.0
    assert critical.critical_speed is None
    assert "no limit cycle below the linear critical speed" in critical.note
    assert critical.linear_critical_speed == pytest.approx(57.50, abs=0.01)


def test_the_ramp_agrees_with_the_staircase_and_converges_as_it_slows(tmp_path):
    """Braked through it, the limit cycle dies at the nonlinear critical speed less the lag of
    its collapse (a few seconds times the deceleration): at 0.4 and 0.1 m/s^2 the ramp's
    speed rises towards the staircase's as the ramp slows, the slower one within the
    staircase's own bracket (its lowest live step less 4 %, the step here) and below that
    step. Both start on the same limit cycle at 1.1 x the linear critical speed."""
    from rail_mj.analysis.bifurcation import nonlinear_critical_speed, ramp_critical_speed

    layout = load_layout(flanged_wheelset(tmp_path))
    stairs, _ = nonlinear_critical_speed(layout, step=0.04, dwell=3.0)
    fast, _ = ramp_critical_speed(layout, deceleration=0.4)
    slow, branch = ramp_critical_speed(layout, deceleration=0.1)
    assert slow.method == "ramp" and slow.deceleration == 0.1 and slow.outcome == "crossing"
    assert slow.linear_critical_speed == pytest.approx(57.50, abs=0.01)
    assert fast.critical_speed < slow.critical_speed < slow.linear_critical_speed
    assert stairs.critical_speed * (1 - 0.04) <= slow.critical_speed <= stairs.critical_speed
    # Along the ramp the cycle is the staircase's: at the staircase's lowest live step its
    # frequency is that step's (zero crossings over 1 s against 1.5 s; 5.527 against 5.521 Hz measured, 1 % allowed).
    at = int(np.argmin(np.abs(np.array(branch.speeds) - stairs.critical_speed)))
    assert branch.frequencies[at] == pytest.approx(stairs.frequency, rel=0.01)
    # It started on the flanges' limit cycle (past the clearance) and ended with the motion dead.
    assert branch.amplitudes[0] > layout.wheelset.flangeway_clearance
    assert branch.amplitudes[-1] < 0.05 * layout.wheelset.flangeway_clearance


def test_cli_ramp_critical_speed(tmp_path, capsys):
    path = str(flanged_wheelset(tmp_path))
    assert main(["critical-speed", path, "--method", "ramp", "--deceleration", "0.4", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["method"] == "ramp" and result["deceleration"] == 0.4
    assert 0 < result["critical_speed"] < result["linear_critical_speed"]
    assert main(["critical-speed", path, "--method", "ramp", "--deceleration", "0.8"]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("critical speed (ramp): ") and "braked at 0.8 m/s^2" in out
    assert "warning: --deceleration 0.8 m/s^2 is outside railway practice" in err


def test_the_nonlinear_search_is_not_bounded_by_a_default_vmax(capsys):
    """Without a vmax the linear critical speed it starts above is searched up to the table of
    practice's limit; a vmax too low for it is named with the vmax that would do."""
    from rail_mj.analysis.bifurcation import nonlinear_critical_speed
    from rail_mj.cli import main

    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    free, _ = nonlinear_critical_speed(layout, 40.0)
    bounded, _ = nonlinear_critical_speed(layout, 40.0, 150.0)
    assert free.critical_speed == pytest.approx(bounded.critical_speed, rel=1e-3)
    low, branch = nonlinear_critical_speed(layout, 40.0, 70.0)
    assert branch is None and low.critical_speed is None
    needed = math.ceil(1.1 * bounded.linear_critical_speed)
    assert f"a vmax of {needed:g} m/s" in low.note
    assert main(["critical-speed", str(MODELS / "bogie" / "bogie.toml"), "--method", "nonlinear", "--vmax", "70"]) == 0
    assert f"a vmax of {needed:g} m/s" in capsys.readouterr().out


def test_a_limit_cycle_started_past_the_speed_record_is_warned_about(capsys):
    from rail_mj.analysis.stability import CriticalSpeed
    from rail_mj.cli.stability import _warn_record

    _warn_record(CriticalSpeed("nonlinear", 140.0, 3.0, "m", 5.0, 320.0, "", linear_critical_speed=154.0))
    assert "169.4 m/s" in capsys.readouterr().err
    _warn_record(CriticalSpeed("nonlinear", 80.0, 3.0, "m", 5.0, 320.0, "", linear_critical_speed=140.0))
    assert capsys.readouterr().err == ""
