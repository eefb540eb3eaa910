"""Mode names that are true: round-off is not instability, an aperiodic root is not hunting, a
roll is a roll, and the time-domain critical speed names the motion it saw."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from conftest import DATA, MODELS

from rail_mj.analysis.stability import APERIODIC_DAMPING, NEUTRAL, Stability, late_growth
from rail_mj.cli import main
from rail_mj.layout import layout_from_dict, load_layout
from rail_mj.simulation.runner import simulate

SPATIAL = DATA / "manchester-coach-spatial.toml"


def _undamped_vertically():
    """The coned spatial coach with no vertical dampers (legal: 0 is the default): its bounce
    and pitch modes are undamped, their real parts round-off."""
    data = tomllib.loads(SPATIAL.read_text())
    data["primary"]["axlebox"]["cz"] = 0.0
    data["secondary"]["spring"]["cz"] = 0.0
    return layout_from_dict(data, "undamped")


def test_round_off_is_neither_growth_nor_oscillation():
    stability = Stability(_undamped_vertically())
    modes = stability.modes(30.0)
    neutral = [m for m in modes if m.neutral]
    assert {"car body bounce", "bogie 1 frame bounce", "bogie 2 frame bounce"} <= {m.name for m in neutral}
    # What grows of them is round-off, as measured (1e-15 of |lambda|): far inside the tolerance.
    assert all(m.eigenvalue.real < 1e-3 * NEUTRAL * abs(m.eigenvalue) for m in neutral)
    assert not any(m.growing for m in modes)
    result = stability.critical_speed(5.0, 150.0)
    assert result.outcome == "crossing" and "hunting" in result.mode
    # The hunting root's own crossing: where the damped coach (the same lateral suspension)
    # crosses, to the few per cent its vertical dampers' coupling moves it.
    damped = Stability(load_layout(SPATIAL)).critical_speed(5.0, 150.0)
    assert result.critical_speed == pytest.approx(damped.critical_speed, rel=0.05)


def test_the_eigen_command_says_stable_and_names_the_neutral_modes(capsys, tmp_path):
    path = tmp_path / "undamped.toml"
    path.write_text(SPATIAL.read_text().replace("cz = 4e3", "cz = 0.0").replace("cz = 20e3", "cz = 0.0"))
    assert main(["eigen", str(path), "--speed", "30"]) == 0
    out = capsys.readouterr().out
    assert "stable at 30 m/s" in out and "unstable" not in out
    assert "neutral (undamped, to round-off): " in out and "bounce" in out


def test_a_double_real_root_stays_two_real_roots():
    """Two identical coaches: their wheelsets' real roots come in equal pairs, which the
    solver splits by round-off into 'complex' pairs 1e-14 off the axis. Every root is counted
    once: real roots as themselves, complex ones by their upper member."""
    stability = Stability(load_layout(MODELS / "two-coaches" / "two-coaches.toml"))
    for speed in (5.0, 20.0, 60.0):
        modes = stability.modes(speed)
        roots = stability.eigenvalues(speed)
        assert sum(1 if not m.oscillatory else 2 for m in modes) == len(roots)
        for m in modes:
            assert m.eigenvalue.imag == 0.0 or m.eigenvalue.imag > NEUTRAL * abs(m.eigenvalue)


@pytest.mark.parametrize("model", ["wheelset", "bogie", "manchester-coach", "two-coaches", "wagon"])
def test_an_aperiodic_root_is_not_hunting(model):
    stability = Stability(load_layout(MODELS / model / f"{model}.toml"))
    seen = 0
    for speed in (5.0, 20.0, 60.0):
        for m in stability.modes(speed):
            if "hunting" in m.name:
                assert m.oscillatory and m.damping_ratio < APERIODIC_DAMPING, m
            seen += m.name.endswith("(aperiodic)")
    assert seen  # each of these has creep-damped roots that were once called hunting


def test_the_aperiodic_threshold_is_a_one_percent_overshoot():
    zeta = APERIODIC_DAMPING
    assert np.exp(-np.pi * zeta / np.sqrt(1.0 - zeta * zeta)) == pytest.approx(0.01, rel=1e-12)


def test_a_car_body_rolling_alone_is_named_roll():
    """Springs at the centre of mass's height: the car body rolls with round-off lateral and yaw,
    whose comparison once named it 'yaw'."""
    stability = Stability(load_layout(SPATIAL))
    modes = stability._spatial_modes
    q = np.zeros(stability.model.nv, dtype=complex)
    lateral, yaw, _, roll, _ = modes.dofs["carbody"]
    q[roll], q[lateral], q[yaw] = 1.0, 1e-17, 1e-15
    energy = modes.energies(q)
    total = sum(e.sum() for e in energy.values())
    share = {n: float(e.sum() / total) for n, e in energy.items()}
    assert modes.name(q, share, energy) == "car body roll"
    q[lateral] = 0.3  # with a real lateral part it is a sway, named by its roll centre
    energy = modes.energies(q)
    assert modes.name(q, share, energy).endswith("sway")


def test_the_time_domain_mode_is_the_motion_s_shape_not_the_nearest_frequency():
    """The spatial coach just above its critical speed: the run's late motion is the hunting
    mode's shape. Asked at a frequency 30 % off (no lateral mode near it), the match is still
    that mode, where the mode nearest that frequency is another."""
    layout = load_layout(SPATIAL)
    stability = Stability(layout)
    vc = stability.critical_speed(5.0, 150.0).critical_speed
    speed = 1.03 * vc
    run = simulate(layout, speed, 10.0 * speed, 1e-4, 1e-5)
    freq = late_growth(run)[1]
    hunting = stability.crossing_mode(vc).name
    mode, mac = stability.matching_mode(run, freq, speed)
    assert mode.name == hunting and mac > 0.9
    off = 1.3 * freq
    nearest = min((m for m in stability.modes(speed) if m.oscillatory), key=lambda m: abs(m.frequency - off))
    assert nearest.name != hunting
    assert stability.matching_mode(run, off, speed)[0].name == hunting
