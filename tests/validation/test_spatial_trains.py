"""Spatial trains (docs/trains.md, "Spatial trains"): two uncoupled spatial coaches keep one coach's
eigenvalues; a spatial articulated pair's stiffness is the hand-assembled one, its preload an exact
equilibrium, its static wheel loads the lever rule's (the Jacobs bogie carrying half of each body);
both callbacks agree; `run` reports Y/Q and Q; mode names per car; bad inputs fail in one line."""

from __future__ import annotations

import copy
import json
import tomllib

import mujoco
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import DATA, assert_callbacks_agree
from test_loads import ROUNDING, static_wheel_loads
from test_spatial import SPATIAL, G, dof, fd_stiffness, point_motion_rows
from test_trains import matched_error

from rail_mj.analysis.stability import Stability
from rail_mj.analysis.train_modes import SNAKING
from rail_mj.cli import cli
from rail_mj.layout import LayoutError, layout_from_dict
from rail_mj.vehicle.spec import Vehicle, build_spec, compile_spec
from rail_mj.vehicle.statics import preload, tendon_jacobian

PAIR_FILE = DATA / "spatial-articulated-pair.toml"
PAIR = tomllib.loads(PAIR_FILE.read_text())


def two_coaches(**coupling) -> dict:
    """Two spatial Manchester coaches (tests/data/manchester-coach-spatial.toml), bogies 19 m apart
    on each, ends 0.5 m apart, with one [[coupling]] of `coupling`'s keys."""
    data = {k: copy.deepcopy(v) for k, v in SPATIAL.items() if k != "carbody"}
    c = SPATIAL["carbody"]
    car = {"mass": c["mass"], "inertia": c["inertia"], "length": 24.5}
    data.update(
        name="two",
        train={"bogie_positions": [22.0, 3.0, -3.0, -22.0]},
        car=[{**car, "position": 12.5, "bogies": [1, 2]}, {**car, "position": -12.5, "bogies": [3, 4]}],
        coupling=[{"cars": [1, 2], **coupling}],
    )
    return data


def pair(gravitational_stiffness: bool = True, longitudinal: bool = True) -> dict:
    """The shipped test pair (car 2 at its own height 1.9 m); `longitudinal` False: no longitudinal
    springs, which the bodies' static pitch (the Jacobs bogie sagging more) would load."""
    data = copy.deepcopy(PAIR)
    data["spatial"]["gravitational_stiffness"] = gravitational_stiffness
    if not longitudinal:
        data["primary"]["axlebox"]["kx"] = data["secondary"]["spring"]["kx"] = 0.0
    return data


@pytest.mark.parametrize("speed", [20.0, 60.0])
def test_uncoupled_spatial_coaches_keep_one_coachs_eigenvalues(speed):
    """A [[coupling]] of zero stiffness and damping: the train's roots are the single spatial coach's,
    each twice (1e-6 relative, paired one to one)."""
    one = Stability(layout_from_dict(copy.deepcopy(SPATIAL))).eigenvalues(speed)
    data = two_coaches(lateral_stiffness=0.0, yaw_stiffness=0.0, lateral_damping=0.0, yaw_damping=0.0)
    two = Stability(layout_from_dict(data)).eigenvalues(speed)
    assert matched_error(two, np.concatenate([one, one])) < 1e-6


def hand_train_stiffness(layout, model, kind: str = "k") -> np.ndarray:
    """K = sum k a a^T from the layout alone (docs/spatial.md's point motion, docs/trains.md's
    couplings): each axlebox between its wheelset (lateral, yaw) and frame; each secondary spring
    (and anti-roll bar) between its frame and every body the bogie carries, with 1/(number of
    bodies) of its k; each coupling's lateral tendon (the rear body's point at the coupling against
    the front's) and yaw tendon. kind = "c": the damping matrix, the secondary lateral and yaw
    dampers shared alike."""
    sp, train, r0 = layout.spatial, layout.train, layout.wheelset.rolling_radius
    K = np.zeros((model.nv, model.nv))

    def motion(body, r, full):
        return point_motion_rows(model, body, r, full)

    def element(point, lower, upper, gains):
        for a, b, k in zip(
            motion(upper[0], np.subtract(point, upper[1]), upper[2]),
            motion(lower[0], np.subtract(point, lower[1]), lower[2]),
            gains,
        ):
            K[:] += k * np.outer(a - b, a - b)

    n = len(layout.bogie.wheelset_positions)
    for i, xb in enumerate(layout.carbody.bogie_positions, start=1):
        frame = (f"bogie{i}", (xb, 0, sp.bogie_height), True)
        e = sp.primary
        for j, xw in enumerate(layout.bogie.wheelset_positions):
            w = (f"wheelset{(i - 1) * n + j + 1}", (xb + xw, 0, r0), False)
            for s in (1, -1):
                element((xb + xw, s * e.spacing, e.height), w, frame, [getattr(e, kind + a) for a in "xyz"])
        on = [k for k, car in enumerate(train.cars, start=1) if i in car.bogies]
        e = sp.secondary
        for k in on:
            car = train.cars[k - 1]
            body = (f"carbody{k}", (car.position, 0, car.height), True)
            share = 1.0 / len(on)
            for s in (1, -1):
                element((xb, s * e.spacing, e.height), frame, body, [share * getattr(e, kind + a) for a in "xyz"])
            if kind == "c" and sp.lateral_damper:
                element((xb, 0, sp.lateral_damper.height), frame, body, (0.0, share * sp.lateral_damper.c, 0.0))
            if kind == "c" and sp.yaw_damper:
                for s in (1, -1):
                    element(
                        (xb, s * sp.yaw_damper.spacing, sp.yaw_damper.height),
                        frame,
                        body,
                        (share * sp.yaw_damper.c, 0.0, 0.0),
                    )
            if kind == "k" and sp.anti_roll_bar:
                a = np.zeros(model.nv)
                a[dof(model, f"carbody{k}_roll")], a[dof(model, f"bogie{i}_roll")] = 1.0, -1.0
                K[:] += share * sp.anti_roll_bar * np.outer(a, a)
    for c in train.couplings:
        (f, front), (r, rear) = ((k, train.cars[k - 1]) for k in c.cars)
        x = ((front.position - front.length / 2) + (rear.position + rear.length / 2)) / 2
        a = np.zeros(model.nv)
        a[dof(model, f"carbody{r}_lateral")] += 1.0
        a[dof(model, f"carbody{r}_yaw")] += x - rear.position
        a[dof(model, f"carbody{f}_lateral")] -= 1.0
        a[dof(model, f"carbody{f}_yaw")] -= x - front.position
        # At the point midway between the bodies' heights, where each body's roll moves it too.
        h_front, h_rear = (car.height if car.height is not None else sp.carbody_height for car in (front, rear))
        z = (h_front + h_rear) / 2
        a[dof(model, f"carbody{r}_roll")] -= z - h_rear
        a[dof(model, f"carbody{f}_roll")] += z - h_front
        K[:] += (c.lateral_stiffness if kind == "k" else c.lateral_damping) * np.outer(a, a)
        a = np.zeros(model.nv)
        a[dof(model, f"carbody{r}_yaw")], a[dof(model, f"carbody{f}_yaw")] = 1.0, -1.0
        K[:] += (c.yaw_stiffness if kind == "k" else c.yaw_damping) * np.outer(a, a)
    return K


def hand_gravitational_terms(layout, model) -> np.ndarray:
    """The preloads' roll and pitch terms (docs/spatial.md) from the weights by the lever rule:
    each body, symmetric over its two bogies, puts W_k/2 on each, W_k/4 on each side's spring; a
    spring carrying P at z_s adds -P (H_body - z_s) to its body and -P (z_s - H_b) to its frame;
    each frame's axleboxes carry all its springs' load and its own weight, -P (H_b - h_axlebox)."""
    sp, train = layout.spatial, layout.train
    z_s, hb = sp.secondary.height, sp.bogie_height
    terms = {f"bogie{i}": 0.0 for i in range(1, len(layout.carbody.bogie_positions) + 1)}
    on_frame = dict.fromkeys(terms, 0.0)
    for k, car in enumerate(train.cars, start=1):
        W = car.mass * G
        terms[f"carbody{k}"] = -W * (car.height - z_s)
        for i in car.bogies:
            terms[f"bogie{i}"] += -W / 2 * (z_s - hb)
            on_frame[f"bogie{i}"] += W / 2
    for b in on_frame:
        terms[b] += -(on_frame[b] + layout.bogie.mass * G) * (hb - sp.primary.height)
    K = np.zeros((model.nv, model.nv))
    for body, k in terms.items():
        for m in ("roll", "pitch"):
            K[dof(model, f"{body}_{m}"), dof(model, f"{body}_{m}")] = k
    return K


@pytest.mark.parametrize("gravitational", [False, True], ids=["tendons", "gravitational"])
def test_articulated_pair_stiffness_is_the_hand_assembled_one(gravitational):
    """Finite differences of MuJoCo's forces about q = 0 against the hand assembly, to 1e-8 of the
    largest entry (the MJCF's 6 figures); with the gravitational stiffness (no longitudinal springs,
    see `pair`) plus the lever rule's terms. The Jacobs bogie's halves matter: bogie 2's bounce
    stiffness is its four axleboxes' and the two bodies' halves, i.e. one frame's."""
    layout = layout_from_dict(pair(gravitational, longitudinal=not gravitational))
    model = Vehicle(layout).model
    K_fd, K_hand = fd_stiffness(model), hand_train_stiffness(layout, model)
    if gravitational:
        K_hand = K_hand + hand_gravitational_terms(layout, model)
    assert np.abs(K_fd - K_fd.T).max() <= 1e-7 * np.abs(K_hand).max()
    assert np.abs(K_fd - K_hand).max() <= 1e-8 * np.abs(K_hand).max()
    z1, z2 = dof(model, "bogie1_vertical"), dof(model, "bogie2_vertical")
    assert K_fd[z2, z2] == pytest.approx(K_fd[z1, z1], rel=1e-9)


def test_articulated_pair_secondary_elements_are_shared():
    """With the secondary dampers, the anti-roll bar and a bump stop, each shared by the Jacobs bogie's
    two bodies: the damping matrix (MuJoCo's per unit velocity) and the stiffness are the hand
    assembly's, 1e-8 of the largest entry, the coupling's damping in; the stop (within its play at
    q = 0) adds nothing there, and its tendons under the Jacobs bogie have half the end bogies' k."""
    from test_spatial import ELEMENTS, MANCHESTER_STOP, fd_damping

    data = pair(gravitational_stiffness=False)
    data["secondary"].update(copy.deepcopy(ELEMENTS), bump_stop=copy.deepcopy(MANCHESTER_STOP))
    layout = layout_from_dict(data)
    model = Vehicle(layout).model
    for measured, kind in ((fd_damping(model), "c"), (fd_stiffness(model), "k")):
        hand = hand_train_stiffness(layout, model, kind)
        assert np.abs(measured - hand).max() <= 1e-8 * np.abs(hand).max(), kind
    k = lambda name: model.tendon_stiffness[model.tendon(name).id]  # noqa: E731
    assert k("bogie2_carbody1_bump_stop_2") == pytest.approx(k("bogie1_carbody1_bump_stop_2") / 2, rel=1e-6)
    assert k("bogie2_carbody2_anti_roll_bar") == pytest.approx(k("bogie3_carbody2_anti_roll_bar") / 2, rel=1e-6)


def test_preload_is_an_exact_equilibrium_of_the_jacobs_arrangement():
    """preload's least-squares solve of K q = f_gravity: the residual is round-off (the gravity
    force is in K's range: the null space, the train's free lateral and yaw, takes none), and at
    q = 0 the compiled pair is at rest to the MJCF's 6 figures (as the single coach: 1e-3 m/s^2)."""
    layout = layout_from_dict(pair())
    spec = build_spec(layout)
    model = compile_spec(spec, layout)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    J = tendon_jacobian(model)
    K = J.T @ (model.tendon_stiffness[:, None] * J)
    f = -data.qfrc_bias.copy()
    q_eq = preload(spec, model)
    assert np.linalg.norm(K @ q_eq - f) <= 1e-10 * np.linalg.norm(f)
    assert q_eq[dof(model, "carbody1_vertical")] < -0.1  # a real sag was taken out
    model = Vehicle(layout).model
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert np.abs(data.qacc).max() < 1e-3


def test_articulated_pair_static_wheel_loads():
    """The loads sum to the train's weight; each end bogie's wheelsets carry half of its body's
    weight (lever rule, the body symmetric over its bogies) and the frame's, the Jacobs bogie's
    half of each body's and its own, each wheel half its wheelset's (ROUNDING: the spring lengths'
    6 figures). No longitudinal springs (`pair`)."""
    layout = layout_from_dict(pair(longitudinal=False))
    q, load, moment = static_wheel_loads(Vehicle(layout))
    W1, W2 = (car.mass * G for car in layout.train.cars)
    b, w = layout.bogie.mass * G, layout.wheelset.mass * G
    expected = [w + (b + W1 / 2) / 2] * 2 + [w + (b + W1 / 2 + W2 / 2) / 2] * 2 + [w + (b + W2 / 2) / 2] * 2
    np.testing.assert_allclose(load, expected, rtol=ROUNDING)
    np.testing.assert_allclose(q, np.array(expected)[:, None] / 2 * [1, 1], rtol=ROUNDING)
    total = G * (sum(c.mass for c in layout.train.cars) + 3 * layout.bogie.mass + 6 * layout.wheelset.mass)
    assert q.sum() == pytest.approx(total, rel=ROUNDING)
    assert np.all(np.abs(moment) <= ROUNDING * total)


@pytest.mark.parametrize("law", ["linear", "polach"])
def test_callbacks_agree_on_a_spatial_train(law):
    data = pair()
    data["creep"].update(law=law, friction=0.35)
    assert_callbacks_agree(Vehicle(layout_from_dict(data)), 40.0, seed=7, samples=8, position=0.003, rate=0.05)


def test_run_on_a_spatial_train(tmp_path):
    """`run` from the CLI on the pair: the summary has every wheelset's Y/Q and Q, the CSV the
    frames' and wheels' columns."""
    out = tmp_path / "pair.csv"
    result = CliRunner().invoke(
        cli, ["run", str(PAIR_FILE), "--speed", "40", "--distance", "100", "--json", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert 0.0 < summary["largest_y_over_q"] < summary["y_over_q_limit"]
    assert 40e3 < summary["smallest_wheel_load_n"] < 70e3
    assert len(summary["wheelsets"]) == 6
    names = out.read_text().splitlines()[0].split(",")
    assert {"y_carbody1", "psi_carbody2", "y_bogie2", "q_left6", "y_over_q_right3"} <= set(names)


def test_mode_names_per_car():
    """The pair at 30 m/s: the train's snaking, the car bodies' bounce, pitch and lower sway
    (numbered as the planar trains number them), the Jacobs frame's bounce."""
    names = {m.name for m in Stability(layout_from_dict(pair())).modes(30.0)}
    assert SNAKING in names
    for motion in ("bounce", "pitch", "lower sway"):
        assert any(n.startswith("car bod") and n.endswith(motion) for n in names), (motion, names)
    assert "bogie 2 (Jacobs) frame bounce" in names
    assert "bogie 1 frame lateral/yaw (primary hunting)" in names


def test_unlike_cars_bounce_apart():
    """Two coupled coaches, car 2 twice as heavy: each body's bounce is its own mode, named
    `car body 1 bounce` and `car body 2 bounce`, the heavier one lower."""
    data = two_coaches(lateral_stiffness=1e6)
    data["car"][1]["mass"] = 64000.0
    modes = Stability(layout_from_dict(data)).modes(30.0)
    bounce = {m.name: m.frequency for m in modes if m.name in ("car body 1 bounce", "car body 2 bounce")}
    assert set(bounce) == {"car body 1 bounce", "car body 2 bounce"}
    assert bounce["car body 2 bounce"] < bounce["car body 1 bounce"]


def test_car_heights():
    layout = layout_from_dict(pair())
    assert [c.height for c in layout.train.cars] == [1.8, 1.9]
    model = Vehicle(layout).model
    assert model.body("carbody2").pos[2] == pytest.approx(1.9) and model.body("carbody1").pos[2] == pytest.approx(1.8)


def edit(change) -> dict:
    data = pair()
    change(data)
    return data


def planar_with_height() -> dict:
    from test_trains import articulated_pair

    data = articulated_pair()
    data["car"][0]["height"] = 1.8
    return data


BAD = {
    "car below its bogies": (
        edit(lambda d: d["car"][1].update(height=0.5)),
        "car[2].height: must not be below spatial.bogie_height (0.6 m), got 0.5 m",
    ),
    "negative height": (edit(lambda d: d["car"][0].update(height=-1.0)), "car[1].height: must be"),
    "height not a number": (edit(lambda d: d["car"][0].update(height="high")), "car[1].height:"),
    "default below the bogies": (
        edit(lambda d: d["spatial"].update(carbody_height=0.4)),
        "spatial.carbody_height: must not be below bogie_height",
    ),
    "height in a planar train": (planar_with_height(), "car[1].height: needs [spatial]"),
}


@pytest.mark.parametrize("case", BAD, ids=list(BAD))
def test_bad_spatial_trains_fail_with_one_line(case):
    data, message = BAD[case]
    with pytest.raises(LayoutError) as e:
        layout_from_dict(data, source="t.toml")
    text = str(e.value)
    assert "\n" not in text and text.startswith("t.toml: ")
    assert message in text, text


def test_a_spatial_trains_recording(tmp_path):
    """Per car its lateral and yaw plots (as a planar train's), and the spatial roll, bounce, Q and Y/Q."""
    from rail_mj.layout import load_layout
    from rail_mj.output.recording import plots, write_recording
    from rail_mj.simulation.runner import simulate

    run = simulate(load_layout(PAIR_FILE), 40.0, 20.0, 0.002)
    titles = [p.title for p in plots(run)]
    for title in (
        "Car 1: lateral y (mm)",
        "Car 2: yaw ψ (mrad)",
        "Bogies, car body: roll φ (mrad)",
        "Bogies, car body: bounce z (mm)",
        "Wheels: vertical load Q (kN)",
    ):
        assert title in titles
    out = tmp_path / "pair.rrd"
    write_recording(run, out)
    assert out.stat().st_size > 0
