"""Trains (docs/trains.md): uncoupled vehicles keep their own eigenvalues, an articulated pair
agrees with the independent planar model (tests/validation/planar.py), its snaking mode is named, and bad
topologies fail with one line."""

from __future__ import annotations

import copy
import tomllib

import numpy as np
import pytest
from conftest import MODELS
from planar import planar_train_eigenvalues
from scipy.optimize import linear_sum_assignment

from rail_mj.analysis.stability import Stability
from rail_mj.analysis.train_modes import SNAKING
from rail_mj.layout import LayoutError, layout_from_dict, load_layout

COACH = tomllib.loads((MODELS / "manchester-coach" / "manchester-coach.toml").read_text())


def running_gear() -> dict:
    """The Manchester coach's wheelset, creep (linear), suspension and bogie: a train's parts."""
    data = {k: copy.deepcopy(COACH[k]) for k in ("wheelset", "creep", "primary", "bogie", "secondary")}
    data["creep"] = {"f11": COACH["creep"]["f11"], "f22": COACH["creep"]["f22"]}
    return data


def coach(position: float, bogies: list[int]) -> dict:
    c = COACH["carbody"]
    return {"mass": c["mass"], "inertia": c["inertia"], "position": position, "length": 24.5, "bogies": bogies}


def two_coaches(**coupling) -> dict:
    """Two Manchester coaches, bogies 19 m apart on each, ends 0.5 m apart."""
    return {
        "name": "two",
        **running_gear(),
        "train": {"bogie_positions": [22.0, 3.0, -3.0, -22.0]},
        "car": [coach(12.5, [1, 2]), coach(-12.5, [3, 4])],
        **({"coupling": [{"cars": [1, 2], **coupling}]} if coupling else {}),
    }


def articulated_pair(**coupling) -> dict:
    """Two 18 m bodies on three bogies, the middle one a Jacobs bogie."""
    car = {"mass": 30000.0, "inertia": [50000.0, 1.5e6, 1.5e6], "length": 18.0}
    return {
        "name": "pair",
        **running_gear(),
        "train": {"bogie_positions": [18.0, 0.0, -18.0]},
        "car": [{**car, "position": 9.0, "bogies": [1, 2]}, {**car, "position": -9.0, "bogies": [2, 3]}],
        **({"coupling": [{"cars": [1, 2], **coupling}]} if coupling else {}),
    }


def matched_error(a: np.ndarray, b: np.ndarray) -> float:
    """Largest relative difference of two sets of eigenvalues, paired one to one."""
    assert len(a) == len(b)
    cost = np.abs(a[:, None] - b[None, :]) / np.abs(b[None, :])
    rows, cols = linear_sum_assignment(cost)
    return float(cost[rows, cols].max())


def single_coach() -> dict:
    return {"name": "coach", **running_gear(), "carbody": copy.deepcopy(COACH["carbody"])}


@pytest.mark.parametrize("speed", [20.0, 90.0])
def test_uncoupled_vehicles_keep_each_vehicles_eigenvalues(speed):
    one = Stability(layout_from_dict(single_coach())).eigenvalues(speed)
    two = Stability(layout_from_dict(two_coaches())).eigenvalues(speed)
    assert matched_error(two, np.concatenate([one, one])) < 1e-6


def test_zero_coupling_is_no_coupling():
    free = Stability(layout_from_dict(two_coaches())).eigenvalues(40.0)
    zero = Stability(layout_from_dict(two_coaches(lateral_stiffness=0.0, yaw_damping=0.0))).eigenvalues(40.0)
    assert matched_error(zero, free) < 1e-9


@pytest.mark.parametrize(
    "coupling", [{}, {"lateral_stiffness": 2e5, "yaw_stiffness": 3e6, "lateral_damping": 1e4, "yaw_damping": 4e5}]
)
@pytest.mark.parametrize("speed", [15.0, 60.0])
def test_articulated_pair_agrees_with_the_planar_model(coupling, speed):
    layout = layout_from_dict(articulated_pair(**coupling))
    mujoco_roots = Stability(layout).eigenvalues(speed)
    assert matched_error(mujoco_roots, planar_train_eigenvalues(layout, speed)) < 1e-6


def test_coupled_coaches_agree_with_the_planar_model():
    layout = layout_from_dict(two_coaches(lateral_stiffness=1e6, yaw_damping=2e5))
    assert matched_error(Stability(layout).eigenvalues(50.0), planar_train_eigenvalues(layout, 50.0)) < 1e-6


@pytest.mark.parametrize("speed", [20.0, 70.0])
def test_the_shipped_articulated_set_agrees_with_the_planar_model(speed):
    """Three cars, the end ones longer than the middle one's half-pitch: the couplings act
    between the body ends, not between the centres (a test trains symmetric about x = 0
    cannot tell), with all four coupling terms at work; linear creep, no flange. 1e-9: both
    are exact linear models (measured 3e-14)."""
    data = tomllib.loads((MODELS / "articulated-set" / "articulated-set.toml").read_text())
    data["creep"] = {"f11": data["creep"]["f11"], "f22": data["creep"]["f22"]}
    data.pop("flange", None)
    data["wheelset"].pop("flangeway_clearance", None)
    for c in data["coupling"]:
        c.update(lateral_stiffness=5e6, yaw_stiffness=2e6, lateral_damping=3e4, yaw_damping=2e5)
    layout = layout_from_dict(data)
    assert matched_error(Stability(layout).eigenvalues(speed), planar_train_eigenvalues(layout, speed)) < 1e-9


ARTICULATION = 5e6  # N/m: the lateral stiffness of the articulation between the two body ends


def test_the_snaking_mode_is_named():
    analysis = Stability(layout_from_dict(articulated_pair(lateral_stiffness=ARTICULATION)))
    modes = analysis.modes(30.0)
    snaking = [m for m in modes if m.name == SNAKING]
    assert len(snaking) == 1
    mode = snaking[0]
    assert 0.3 < mode.frequency < 1.5  # a car-body mode
    assert mode.participation["carbody1"] + mode.participation["carbody2"] > 0.5
    names = {m.name for m in modes}
    assert "bogie 2 (Jacobs) frame lateral/yaw (primary hunting)" in names
    assert "bogie 1 frame lateral/yaw (primary hunting)" in names


def test_inter_car_yaw_damping_damps_the_snaking():
    def snaking_damping(c):
        pair = articulated_pair(lateral_stiffness=ARTICULATION, yaw_damping=c)
        modes = Stability(layout_from_dict(pair)).modes(30.0)
        return next(m for m in modes if m.name == SNAKING).damping_ratio

    assert snaking_damping(2e5) > snaking_damping(0.0)


def test_single_vehicle_layouts_are_not_trains():
    assert load_layout(MODELS / "manchester-coach" / "manchester-coach.toml").train is None


def edit(data: dict, change) -> dict:
    data = copy.deepcopy(data)
    change(data)
    return data


BAD = {
    "body without support": (lambda d: d["car"][1].update(bogies=[]), "car[2].bogies: empty: a car body with no bogie"),
    "bogie under no body": (
        lambda d: (d["car"][0].update(bogies=[1]), d["car"][1].update(bogies=[3])),
        "train.bogie_positions: bogie 2 at x = 0 m carries no car body",
    ),
    "bodies overlap": (lambda d: d["car"][1].update(length=20.0), "car[2]: car bodies 1 and 2 overlap by 1 m"),
    "bogies overlap": (
        lambda d: d["train"].update(bogie_positions=[18.0, 16.0, -18.0]),
        "train.bogie_positions: bogies at x = 18 and 16 m overlap",
    ),
    "no such bogie": (lambda d: d["car"][1].update(bogies=[2, 5]), "car[2].bogies: bogie 5 does not exist"),
    "bogie not under its body": (
        lambda d: d["car"][0].update(bogies=[1, 3]),
        "car[1].bogies: bogie 3 at x = -18 m is not under this 18 m body",
    ),
    "cars out of order": (lambda d: d.update(car=d["car"][::-1]), "car[2].position: cars must be listed leading first"),
    "no cars": (lambda d: d.pop("car"), "car: missing: a [train] needs its car bodies"),
    "carbody with train": (lambda d: d.update(carbody={"mass": 1.0}), "carbody: not used with [train]"),
    "cars without train": (lambda d: d.pop("train"), "car: given without [train]"),
    "train without bogie": (lambda d: (d.pop("bogie"), d.pop("secondary")), "train: needs [bogie]"),
    "coupling not adjacent": (
        lambda d: d.update(coupling=[{"cars": [1, 3]}]),
        "coupling[1].cars: must be two adjacent cars",
    ),
    "coupling typo": (
        lambda d: d.update(coupling=[{"cars": [1, 2], "yaw_dampin": 1.0}]),
        "coupling[1].yaw_dampin: unknown key",
    ),
    "one [coupling] table": (lambda d: d.update(coupling={"cars": [1, 2]}), "coupling: must be an array of tables"),
    "one [car] table": (lambda d: d.update(car=d["car"][0]), "car: is one [car] table"),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_topologies_fail_with_one_line(case):
    change, message = BAD[case]
    with pytest.raises(LayoutError) as e:
        layout_from_dict(edit(articulated_pair(), change), source="t.toml")
    text = str(e.value)
    assert "\n" not in text and text.startswith("t.toml: ")
    assert message in text, text


def test_sweep_keys_reach_into_a_trains_couplings():
    from rail_mj.studies.sweep import SweepError, with_value

    data = tomllib.loads((MODELS / "articulated-set" / "articulated-set.toml").read_text())
    every = with_value(data, "coupling.*.yaw_damping", 1.0)
    assert [c["yaw_damping"] for c in every["coupling"]] == [1.0, 1.0]
    second = with_value(data, "coupling.2.lateral_damping", 3.0)
    assert "lateral_damping" not in second["coupling"][0] and second["coupling"][1]["lateral_damping"] == 3.0
    assert "lateral_damping" not in data["coupling"][1]  # a copy
    for key, message in (
        ("coupling.3.yaw_damping", "must number one of the 2"),
        ("coupling.yaw_damping", "holds several tables"),
    ):
        with pytest.raises(SweepError, match=message):
            with_value(data, key, 1.0)


def test_a_trains_recording_groups_its_plots_per_car(tmp_path):
    """Each car's body, bogies and wheelsets plotted together (lateral and yaw); a Jacobs
    bogie in both its cars' plots, and its series sent once."""
    from rail_mj.output.recording import plots, write_recording
    from rail_mj.simulation.runner import simulate

    layout = load_layout(MODELS / "articulated-set" / "articulated-set.toml")
    run = simulate(layout, 60.0, 60.0, 0.002)
    shown = {p.title: [s.path for s in p.series] for p in plots(run)}
    for k in (1, 2, 3):
        assert f"Car {k}: lateral y (mm)" in shown and f"Car {k}: yaw ψ (mrad)" in shown
    shared = {path for path in shown["Car 1: lateral y (mm)"] if path in shown["Car 2: lateral y (mm)"]}
    assert shared == {"/lateral/bogie2", "/lateral/wheelset3", "/lateral/wheelset4"}  # the Jacobs bogie
    assert len(shown["Car 1: lateral y (mm)"]) == 1 + 2 + 4  # its body, two bogies, four wheelsets
    out = tmp_path / "set.rrd"
    write_recording(run, out)
    assert out.stat().st_size > 0
