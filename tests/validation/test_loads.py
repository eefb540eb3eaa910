"""Wheel loads Q of a spatial vehicle from its suspension (rail_mj.vehicle.loads, docs/spatial.md):
static loads sum to the weight and follow the layout, a frame's roll moves load between the
wheels as the springs' moments say, both callbacks agree with the loads in, and runs report
each wheel's Q, Y and Y/Q."""

from __future__ import annotations

import copy
import json
import tomllib

import mujoco
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import DATA, MODELS, assert_callbacks_agree
from test_spatial import SPATIAL, G

from rail_mj.cli import cli
from rail_mj.contact.creep import contact_forces
from rail_mj.layout import layout_from_dict
from rail_mj.simulation.callback import contact_parameters
from rail_mj.vehicle.loads import AxleLoads
from rail_mj.vehicle.spec import Vehicle

# The static loads come from spring lengths kept to 6 significant figures (docs/spatial.md).
ROUNDING = 5e-6


def static_wheel_loads(vehicle: Vehicle, qpos=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(Q (n_wheelsets, 2), P, M) at rest in `qpos` (default: the centred state)."""
    model = vehicle.model
    data = mujoco.MjData(model)
    if qpos is not None:
        data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    loads = AxleLoads.of(model, vehicle.wheelset_names)
    load, moment = loads.evaluate(model, data.ten_length, data.ten_velocity)
    n = len(vehicle.wheelset_names)
    zero = np.zeros(n)
    f = contact_forces(contact_parameters(model, n), zero, zero, zero, zero, 30.0, load, moment, loads.nominal)
    return np.stack([f.load_left, f.load_right], axis=-1), load, moment


def spatial_on_profiles() -> dict:
    data = copy.deepcopy(SPATIAL)
    s1002 = tomllib.loads((MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml").read_text())
    data["profiles"], data["creep"], data["wheelset"] = s1002["profiles"], s1002["creep"], s1002["wheelset"]
    return data


def weight(layout) -> float:
    bogies = sum(b.mass for b in layout.spatial.bogies)  # each its own ([bogies.N])
    return G * (layout.carbody.mass + bogies + layout.n_wheelsets * layout.wheelset.mass)


@pytest.mark.parametrize("data", [SPATIAL, spatial_on_profiles()], ids=["cones", "profiles"])
def test_static_wheel_loads_sum_to_the_weight_in_equal_shares(data):
    layout = layout_from_dict(copy.deepcopy(data))
    q, _, moment = static_wheel_loads(Vehicle(layout))
    total = weight(layout)
    assert q.sum() == pytest.approx(total, rel=ROUNDING)
    np.testing.assert_allclose(q, total / q.size, rtol=ROUNDING)  # a symmetric layout: equal shares
    assert np.all(np.abs(moment) <= ROUNDING * total)


def test_unequal_bogie_positions_give_unequal_axle_loads():
    """Bogies at +9.5 m and -7.5 m: the car body's weight parts as the lever rule says
    (7.5/17 and 9.5/17), each bogie's load on its two wheelsets equally. Without longitudinal
    springs: the car body is held along x at its centre of mass, so the pitched body's
    longitudinal springs (below that centre) would carry a part of its moment (0.05 % of the
    loads on the spatial coach, docs/spatial.md)."""
    data = copy.deepcopy(SPATIAL)
    data["carbody"]["bogie_positions"] = [9.5, -7.5]
    data["primary"]["axlebox"]["kx"] = data["secondary"]["spring"]["kx"] = 0.0
    layout = layout_from_dict(data)
    q, load, _ = static_wheel_loads(Vehicle(layout))
    c, b, w = layout.carbody.mass * G, layout.bogie.mass * G, layout.wheelset.mass * G
    expected = [w + (b + c * 7.5 / 17.0) / 2] * 2 + [w + (b + c * 9.5 / 17.0) / 2] * 2
    np.testing.assert_allclose(load, expected, rtol=ROUNDING)
    np.testing.assert_allclose(q.sum(axis=1), expected, rtol=ROUNDING)
    assert q.sum() == pytest.approx(weight(layout), rel=ROUNDING)


def test_frame_roll_moves_load_between_the_wheels():
    """A bogie frame rolled by phi (left side up): each of its axleboxes' vertical springs
    changes by -s*d*phi*kz, its lateral springs by ky*phi*(h - H_b), and each axlebox's load P0
    comes down at the frame's seat, sheared by -phi*(h - H_b) from the wheelset's (the shear
    couple, docs/spatial.md), so about the rail level M = 2*kz*d^2*phi + 2*(h*ky + P0)*phi*(h - H_b),
    and on cones Q_left - Q_right = -M/b with the axle load unchanged."""
    layout, vehicle = layout_from_dict(copy.deepcopy(SPATIAL)), None
    vehicle = Vehicle(layout)
    model, phi = vehicle.model, 1e-3
    qpos = np.zeros(model.nq)
    qpos[model.joint("bogie1_roll").qposadr[0]] = phi
    q0, load0, _ = static_wheel_loads(vehicle)
    q, load, moment = static_wheel_loads(vehicle, qpos)
    e, hb, b = layout.spatial.primary, layout.spatial.bogie_height, layout.wheelset.contact_half_spacing
    p0 = (load0[:2] - layout.wheelset.mass * G) / 2  # each axlebox's static load
    m = 2 * e.kz * e.spacing**2 * phi + 2 * (e.height * e.ky + p0) * phi * (e.height - hb)
    # Linear tendons: exact to round-off, and to the 6 figures of the wheelset weight in p0 (2e-9).
    np.testing.assert_allclose(moment[:2], m, rtol=1e-8)
    np.testing.assert_allclose(load, load0, rtol=1e-12)
    np.testing.assert_allclose(q[:2, 0] - q[:2, 1], -m / b, rtol=1e-8)
    np.testing.assert_allclose(q[2:], q0[2:], rtol=1e-12)  # the other bogie's wheels keep theirs
    assert q[0, 0] < q[0, 1]  # left side up: the left wheel unloaded


@pytest.mark.parametrize(
    "data, law",
    [(SPATIAL, "linear"), (SPATIAL, "polach"), (spatial_on_profiles(), "polach"), (spatial_on_profiles(), "fastsim")],
    ids=["cones-linear", "cones-polach", "profiles-polach", "profiles-fastsim"],
)
def test_native_and_python_callbacks_agree_with_the_loads_in(data, law):
    """The native callback sums the axlebox tendons' forces in its block; the Python one reads
    them through rail_mj.vehicle.loads: at random states (the frames rolled, pitched and bouncing) both
    give one qfrc_passive."""
    data = copy.deepcopy(data)
    data.setdefault("creep", {})["law"] = law
    data["creep"].setdefault("friction", 0.35)
    assert_callbacks_agree(Vehicle(layout_from_dict(data)), 40.0, seed=3, samples=10, position=0.003, rate=0.05)


def test_loads_change_the_creep_forces():
    """A loaded wheel's creep coefficients grow as Q^(2/3) (Hertz, Kalker): with the left
    wheels of bogie 1 unloaded by a frame roll, its wheelsets' lateral creep force under one
    lateral creepage follows, wheel by wheel, (Q/Q0)^(2/3)."""
    layout = layout_from_dict(copy.deepcopy(SPATIAL))
    vehicle = Vehicle(layout)
    model = vehicle.model
    qpos = np.zeros(model.nq)
    qpos[model.joint("bogie1_roll").qposadr[0]] = 2e-3
    q, load, moment = static_wheel_loads(vehicle, qpos)
    n, slip = layout.n_wheelsets, np.full(layout.n_wheelsets, 0.3)  # y_dot: xi_y = 0.01 at 30 m/s
    zero = np.zeros(n)
    p, nominal = contact_parameters(model, n), AxleLoads.of(model, vehicle.wheelset_names).nominal
    loaded = contact_forces(p, zero, zero, slip, zero, 30.0, load, moment, nominal)
    planar = contact_forces(p, zero, zero, slip, zero, 30.0)
    factor = (q / nominal) ** (2 / 3)
    np.testing.assert_allclose(loaded.lateral_left, planar.lateral_left * factor[:, 0], rtol=1e-12)
    np.testing.assert_allclose(loaded.lateral_right, planar.lateral_right * factor[:, 1], rtol=1e-12)
    assert factor[0, 0] < 0.99 < 1.01 < factor[0, 1]  # the roll's load transfer matters at this size


def test_run_reports_wheel_loads_and_derailment_quotients(tmp_path):
    """run --json carries the largest Y/Q and the smallest Q, the CSV each wheel's Q, Y and
    Y/Q; per wheelset the wheels' Y add up to its Sigma Y and the quotient is Y/Q, outward."""
    layout = DATA / "manchester-coach-spatial.toml"
    out = tmp_path / "coach.csv"
    result = CliRunner().invoke(
        cli, ["run", str(layout), "--speed", "40", "--distance", "200", "--json", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    names = out.read_text().splitlines()[0].split(",")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    column = lambda name: table[:, names.index(name)]  # noqa: E731
    quotients, loads = [], []
    for i in range(1, 5):
        np.testing.assert_allclose(
            column(f"ylat_left{i}") + column(f"ylat_right{i}"),
            column(f"sum_y{i}"),
            rtol=0,
            atol=1e-6 * np.max(np.abs(column(f"sum_y{i}"))),
        )
        for side, outward in (("left", -1.0), ("right", 1.0)):
            q, y = column(f"q_{side}{i}"), column(f"ylat_{side}{i}")
            np.testing.assert_allclose(column(f"y_over_q_{side}{i}"), outward * y / q, rtol=1e-8)
            quotients.append(outward * y / q)
            loads.append(q)
        assert summary["wheelsets"][i - 1]["largest_y_over_q_peak"] == pytest.approx(
            max(np.max(v) for v in quotients[-2:]), rel=1e-8
        )
    assert summary["largest_y_over_q_peak"] == pytest.approx(max(np.max(v) for v in quotients), rel=1e-8)
    # EN 14363's quantity, the 2 m sliding mean: never above the peak.
    assert summary["y_over_q_window_m"] == 2.0
    assert 0.0 < summary["largest_y_over_q"] <= summary["largest_y_over_q_peak"]
    assert summary["smallest_wheel_load_n"] == pytest.approx(min(np.min(v) for v in loads), rel=1e-8)
    assert 0.0 < summary["largest_y_over_q"] < summary["y_over_q_limit"]  # a stable coach at 40 m/s
    # The loads move: the suspension's dynamic forces are in them (not a static share).
    assert np.ptp(column("q_left1")) > 1e-3 * np.mean(column("q_left1"))
    # The frames' and car body's bounce, roll and pitch (the car body sways from the 2 mm start).
    assert {"bounce_carbody", "roll_carbody", "pitch_carbody", "roll_bogie2"} <= set(names)
    assert np.max(np.abs(column("roll_carbody"))) > 1e-5


def switched(gravitational: bool, gyroscopic: bool) -> dict:
    data = copy.deepcopy(SPATIAL)
    data["spatial"].update(gravitational_stiffness=gravitational, gyroscopic=gyroscopic)
    return data


def wheelset_entries(stability, speed: float):
    """A at `speed`, and each wheelset's (lateral, yaw) dofs."""
    from rail_mj.vehicle.joints import LATERAL, YAW

    model = stability.model
    dofs = [
        (int(model.joint(f"{w}_{LATERAL}").dofadr[0]), int(model.joint(f"{w}_{YAW}").dofadr[0]))
        for w in (f"wheelset{i + 1}" for i in range(4))
    ]
    return stability.state_matrix_at(speed), dofs, model.nv


def test_gyroscopic_yaw_moment_in_the_linearisation():
    """The spinning wheelset rolled by its cones at lam*y'/b feels the yaw moment
    -I_y*(V/r0)*(lam/b)*y' (Wickens, 2003): switching the gyroscopic terms on changes A only in
    each wheelset's yaw acceleration against its own lateral velocity, by that over I_z, a term
    growing with V. (The rails' share of the roll moment, -I_y*(V/r0)*psi', moves load between
    the wheels, which at the centred state changes no creep force.)"""
    from rail_mj.analysis.stability import Stability

    on, off = Stability(layout_from_dict(switched(False, True))), Stability(layout_from_dict(switched(False, False)))
    w = on.layout.wheelset
    for speed in (20.0, 60.0):
        (a_on, dofs, nv), (a_off, _, _) = wheelset_entries(on, speed), wheelset_entries(off, speed)
        expected = np.zeros_like(a_on)
        for lateral, yaw in dofs:
            expected[nv + yaw, nv + lateral] = (
                -w.inertia[1] * speed / w.rolling_radius * w.conicity / w.contact_half_spacing / w.inertia[2]
            )
        # Finite differences of MuJoCo's step (rail_mj.simulation.linear): 1e-6 of the term.
        scale = np.abs(expected).max()
        assert np.abs((a_on - a_off) - expected).max() <= 1e-6 * scale


def test_cone_gravitational_stiffness_in_the_linearisation():
    """On coned wheels over knife-edge rails each wheel's normal force leans at the cone angle
    d0 = atan(lam) plus or minus the wheelset's roll phi = lam*y/b: the lateral force
    -Q_left*tan(d0 + phi) + Q_right*tan(d0 - phi). With equal loads that is the classical
    gravitational stiffness 2*Q*(lam/b)*sec^2(d0), restoring; and the loads themselves move: the
    axleboxes' lateral springs (ky each, at height h) pull a displaced wheelset back at h, their
    moment about the rail level, with the axlebox loads P0 coming down at the frame's seats
    (sheared by -y: the shear couple) and the rails' levers b -/+ y, shifts
    (2*Q - 2*h*ky - 2*P0)*y/b between the wheels, and the loaded wheel's normal force leans the
    other way: d(Sigma Y)/dy = (2*lam/b)*(h*ky + P0 - Q*(2 + lam^2)), P0 = Q - m_w*g/2."""
    from rail_mj.analysis.stability import Stability

    on, off = Stability(layout_from_dict(switched(True, False))), Stability(layout_from_dict(switched(False, False)))
    w, e = on.layout.wheelset, on.layout.spatial.primary
    (a_on, dofs, nv), (a_off, _, _) = wheelset_entries(on, 30.0), wheelset_entries(off, 30.0)
    lam, b = w.conicity, w.contact_half_spacing
    p0 = w.wheel_load - w.mass * G / 2
    expected = 2 * lam / b * (e.height * e.ky + p0 - w.wheel_load * (2 + lam**2))
    for lateral, _ in dofs:
        # The static loads to the spring lengths' 6 figures (5e-6), the finite differences 1e-6.
        assert (a_on - a_off)[nv + lateral, lateral] * w.mass == pytest.approx(expected, rel=1e-5)
    # With no suspension moment, the rails' levers alone move load: -2*Q*(lam/b)*(2 + lam^2).
    q = np.full(1, w.wheel_load)
    f = contact_forces(
        contact_parameters(on.model, 1),
        np.array([1e-6]),
        np.zeros(1),
        np.zeros(1),
        np.zeros(1),
        30.0,
        2 * q,
        np.zeros(1),
        w.wheel_load,
        cone_gravity=True,
    )
    assert f.flange_lateral[0] / 1e-6 == pytest.approx(-2 * w.wheel_load * lam / b * (2 + lam**2), rel=1e-5)


# --- different bogies under one car body ([bogies.N], docs/spatial.md) ---------------------------


@pytest.mark.parametrize("positions", [[9.5, -9.5], [9.5, -7.5]], ids=["symmetric", "unequal"])
def test_different_bogies_static_wheel_loads(positions):
    """Bogie 2 the heavier motor bogie on stiffer, wider and higher axleboxes: each bogie carries its
    lever-rule share of the car body's weight plus its own, in equal parts on its wheelsets, and each
    wheel half of its wheelset's (left-right symmetric: no roll moment), to the spring lengths' 6
    figures (ROUNDING); all sum to the weight. No longitudinal springs, as in
    test_unequal_bogie_positions_give_unequal_axle_loads. The layout's wheel_load, the nominal load of
    the creep coefficients, is the mean: the wheels' own differ from it (+/-1.7 % on symmetric positions)."""
    from test_spatial import different_bogies

    data = different_bogies(longitudinal=False)
    data["carbody"]["bogie_positions"] = positions
    layout = layout_from_dict(data)
    q, load, moment = static_wheel_loads(Vehicle(layout))
    (x1, x2), c, w = positions, layout.carbody.mass * G, layout.wheelset.mass * G
    b1, b2 = (bogie.mass * G for bogie in layout.spatial.bogies)
    expected = [w + (b1 + c * -x2 / (x1 - x2)) / 2] * 2 + [w + (b2 + c * x1 / (x1 - x2)) / 2] * 2
    np.testing.assert_allclose(load, expected, rtol=ROUNDING)
    np.testing.assert_allclose(q, np.array(expected)[:, None] / 2 * [1, 1], rtol=ROUNDING)
    assert np.all(np.abs(moment) <= ROUNDING * weight(layout))
    assert q.sum() == pytest.approx(weight(layout), rel=ROUNDING)
    assert layout.wheelset.wheel_load == pytest.approx(weight(layout) / q.size, rel=1e-15)
    assert np.ptp(q) > 0.03 * layout.wheelset.wheel_load  # the bogies' loads do differ (3.5 %, symmetric)


def test_motor_bogie_roll_moves_load_by_its_own_axleboxes():
    """The motor bogie (2) rolled by phi: its wheelsets' roll moment is its own axleboxes', M =
    2*kz*d^2*phi + 2*h*ky*phi*(h - H_b) with its kz, ky, spacing d and height h (rail_mj.vehicle.loads reads
    each wheelset's spacing and height from the model), to round-off (1e-9); with bogie 1's
    axleboxes it would be 31 % less."""
    from test_spatial import different_bogies

    layout = layout_from_dict(different_bogies())
    vehicle = Vehicle(layout)
    model, phi = vehicle.model, 1e-3
    assert len(model.numeric("rail_mj/loads").data) == 6 + 2 * layout.n_wheelsets
    qpos = np.zeros(model.nq)
    qpos[model.joint("bogie2_roll").qposadr[0]] = phi
    _q0, load0, _ = static_wheel_loads(vehicle)
    q, load, moment = static_wheel_loads(vehicle, qpos)
    hb = layout.spatial.bogie_height

    p0 = (load0[2:] - layout.wheelset.mass * G) / 2  # each of its axleboxes' static load, per wheelset

    def roll_moment(e):  # with the shear couple of the axlebox loads (test_frame_roll_moves_...)
        return 2 * e.kz * e.spacing**2 * phi + 2 * (e.height * e.ky + p0) * phi * (e.height - hb)

    m = roll_moment(layout.spatial.bogies[1].axlebox)
    np.testing.assert_allclose(moment[2:], m, rtol=1e-8)  # p0 to the wheelset weight's 6 figures
    np.testing.assert_allclose(moment[:2], 0.0, atol=ROUNDING * load0[0])
    np.testing.assert_allclose(load, load0, rtol=1e-12)
    b = layout.wheelset.contact_half_spacing
    np.testing.assert_allclose(q[2:, 0] - q[2:, 1], -m / b, rtol=1e-8)
    assert np.all(roll_moment(layout.spatial.primary) < 0.75 * m)


@pytest.mark.parametrize("data, law", [("cones", "linear"), ("cones", "polach"), ("profiles", "polach")])
def test_different_bogies_callbacks_agree(data, law):
    """With different bogies (each wheelset's axlebox coefficients its own) the native and the Python
    callbacks give one qfrc_passive at random states (1e-9, assert_callbacks_agree)."""
    from test_spatial import MOTOR_BOGIE

    data = copy.deepcopy(SPATIAL) if data == "cones" else spatial_on_profiles()
    data["bogies"] = {"2": copy.deepcopy(MOTOR_BOGIE)}
    data.setdefault("creep", {})["law"] = law
    data["creep"].setdefault("friction", 0.35)
    assert_callbacks_agree(Vehicle(layout_from_dict(data)), 40.0, seed=5, samples=10, position=0.003, rate=0.05)


def test_sliding_mean_of_a_sinusoid():
    """A sinusoid of wavelength L averaged over w metres keeps sin(pi w/L)/(pi w/L) of its
    amplitude (the window's transfer function), and a constant stays itself; sampled at 1 mm the
    window's discreteness costs 1e-3 of w, so 2e-3."""
    from rail_mj.analysis import sliding_mean

    x = np.arange(0.0, 40.0, 0.001)
    for wavelength in (5.0, 8.0, 17.0):
        values = np.sin(2 * np.pi * x / wavelength)[:, None]
        mean = sliding_mean(values, x, 2.0)[5000:-5000]  # away from the ends
        a = np.pi * 2.0 / wavelength
        assert np.max(np.abs(mean)) == pytest.approx(np.sin(a) / a, rel=2e-3)
    np.testing.assert_allclose(sliding_mean(np.full((100, 2), 3.0), x[:100], 2.0), 3.0, rtol=1e-12)


def test_a_climbing_flange_meets_nadal():
    """A spatial wheelset's balance has the creep forces' vertical parts (Nadal's): its left wheel
    alone on its flange at angle g, yawed into the rail so that the friction, saturated at mu*N
    and wholly across the rolling direction (no longitudinal creepage there, no spin), pushes the
    wheel up the flange, carries Y/Q = (tan g - mu)/(1 + mu*tan g) (Nadal, 1908) and the two
    wheels' Q still sum to the axle load (both to round-off: the friction is saturated, where the
    two-pass balance is exact)."""
    from rail_mj.contact import tables as T
    from rail_mj.units import M_PER_MM

    data = tomllib.loads((MODELS / "manchester-coach-spatial" / "manchester-coach-spatial.toml").read_text())
    data["profiles"]["spin_creep"] = False
    data["creep"]["law"] = "shen-hedrick-elkins"  # exactly mu*N past three times the limit
    layout = layout_from_dict(data)
    model = Vehicle(layout).model
    p = contact_parameters(model, 1)
    geo, mu = p.geometry, layout.creep.friction
    y = 0.0063  # the left wheel on its flange alone (slot 1, weight 1), the right on its tread
    rows = geo[1 : int(geo[0, T.HEADER_ROWS]) + 1]
    column = lambda k: np.interp(y / M_PER_MM, rows[:, T.Y], rows[:, k])  # noqa: E731
    flange = T.FIRST_POINT + 1 * T.POINT
    assert column(flange + T.WEIGHT) == pytest.approx(1.0)
    g = column(flange + T.ANGLE)
    rise, lever = column(flange + T.RADIUS) * M_PER_MM, column(flange + T.LEVER) * M_PER_MM
    speed, psi = 30.0, 0.05  # nose-left: the left wheel's front into the left rail
    psi_dot = -rise * speed / (layout.wheelset.rolling_radius * lever)  # xi_x = -rise/r0 - l*psi'/V = 0
    axle = 2 * layout.wheelset.wheel_load
    f = contact_forces(
        p,
        np.array([y]),
        np.array([psi]),
        np.zeros(1),
        np.array([psi_dot]),
        speed,
        np.array([axle]),
        np.zeros(1),
        layout.wheelset.wheel_load,
    )
    outward = -f.lateral_left[0] / f.load_left[0]
    nadal = (np.tan(g) - mu) / (1 + mu * np.tan(g))
    assert outward == pytest.approx(nadal, rel=1e-9)
    assert f.load_left[0] + f.load_right[0] == pytest.approx(axle, rel=1e-12)
    assert np.degrees(g) > 65.0 and nadal < 0.5 * np.tan(g)  # a steep flange, and friction matters


def test_sliding_mean_forgets_a_lifted_wheel():
    """A wheel off its rail for one sample (Y/Q NaN) leaves NaN in the windows that hold it and
    nowhere else: the assessment goes on after it."""
    from rail_mj.analysis import sliding_mean

    x = np.arange(0.0, 10.0, 0.1)
    values = np.ones((100, 1))
    values[20] = np.nan
    mean = sliding_mean(values, x, 2.0)
    hit = np.isnan(mean[:, 0])
    assert hit[20] and not hit[60:].any() and hit.sum() == 20  # the 20 windows of 2 m that hold sample 20
    np.testing.assert_allclose(mean[~hit], 1.0, rtol=1e-12)


def roll_balance(layout, pushed: str, F: float = 10e3) -> tuple[float, float, float]:
    """(the rails' roll moment, F*h + sum W_i*y_i, sum W_i*y_i) under a steady lateral force F on the
    body `pushed`, the wheelsets held by the rails: linear statics from central differences of
    MuJoCo's forces with the native callback at speed 0 (no creep; the shear couples)."""
    from rail_mj.simulation import native
    from rail_mj.vehicle.joints import LATERAL, ROLL, YAW

    vehicle = Vehicle(layout)
    model = vehicle.model
    data = mujoco.MjData(model)
    held = {int(model.joint(f"{w}_{m}").dofadr[0]) for w in vehicle.wheelset_names for m in (LATERAL, YAW)}
    free = np.array([d for d in range(model.nv) if d not in held])

    def force(q):
        data.qpos[:], data.qvel[:] = q, 0.0
        mujoco.mj_forward(model, data)
        return data.qfrc_passive - data.qfrc_bias

    step = 1e-6
    with native.installed():
        K = np.zeros((model.nv, model.nv))
        for j in free:
            e = np.zeros(model.nq)
            e[j] = step
            K[:, j] = -(force(e) - force(-e)) / (2 * step)
        push = np.zeros(model.nv)
        push[model.joint(f"{pushed}_{LATERAL}").dofadr[0]] = F
        q = np.zeros(model.nq)
        q[free] = np.linalg.solve(K[np.ix_(free, free)], push[free])
        force(q)
    loads = AxleLoads.of(model, vehicle.wheelset_names)
    _, moment = loads.evaluate(model, data.ten_length, data.ten_velocity)
    bodies = [model.body(b).name for b in range(1, model.nbody) if model.body(b).name.startswith(("carbody", "bogie"))]
    assert all(model.joint(f"{b}_{ROLL}") for b in bodies)
    weights = sum(G * model.body(b).mass[0] * q[model.joint(f"{b}_{LATERAL}").qposadr[0]] for b in bodies)
    height = model.body(pushed).pos[2]
    return -moment.sum(), F * height + weights, weights


@pytest.mark.parametrize("longitudinal", [True, False], ids=["springs", "no-kx"])
def test_whole_vehicle_roll_balance_under_a_lateral_force(longitudinal):
    """The rails' roll moment on the whole vehicle equals that of every other force on it. A
    steady lateral force F on the car body (wind, or the unbalanced part of curving), the
    wheelsets held by the rails: sum over wheelsets of b*(Q_left - Q_right) = F*h_c + sum W_i*y_i
    over the car body and frames, their weights having moved with them. This holds only with the
    preloads' shear couples (each spring's load passed on at its upper seat): without them the
    model gives 0.81 of it on this coach; also with no longitudinal springs, where the elements'
    x tendons are kept for the couples (no spring on them). Linear statics: 1e-6."""
    data = copy.deepcopy(SPATIAL)
    if not longitudinal:
        data["primary"]["axlebox"]["kx"] = data["secondary"]["spring"]["kx"] = 0.0
        data["primary"]["axlebox"].pop("cx", None)
    rails, expected, weights = roll_balance(layout_from_dict(data), "carbody")
    assert rails == pytest.approx(expected, rel=1e-6)
    assert weights > 0.1 * expected  # the weights' share matters here


def test_spatial_train_roll_balance_with_unequal_heights():
    """The spatial articulated pair, its bodies' centres of mass at 1.8 and 1.9 m: pushed on either
    body, the rails' roll moment is the force's and the weights' (1e-6 with no longitudinal
    springs, whose static forces the bodies' pitch on the Jacobs bogie's sag would load, 1.5e-4).
    The coupling acts midway between the bodies' heights, its two forces on one line; at each
    body's own height they would add a couple of 1 % here."""
    data = tomllib.loads((DATA / "spatial-articulated-pair.toml").read_text())
    data["primary"]["axlebox"]["kx"] = data["secondary"]["spring"]["kx"] = 0.0
    data["primary"]["axlebox"].pop("cx", None)
    data["secondary"]["spring"].pop("cx", None)
    layout = layout_from_dict(data)
    heights = {car.height for car in layout.train.cars}
    assert len(heights) == 2 and layout.train.couplings
    for body in ("carbody1", "carbody2"):
        rails, expected, _ = roll_balance(layout, body)
        assert rails == pytest.approx(expected, rel=1e-6)


def test_a_wedged_flange_keeps_its_balance():
    """Friction holding a wheel down on a steep flange (mu = 0.6, mu*tan(g) past 1: the flange's
    wedge) would leave it no vertical capacity: that wheel is balanced without its creep, so the
    loads stay finite, non-negative and sum to the axle load."""
    from rail_mj.contact.creep import profiled_contact

    data = tomllib.loads((MODELS / "manchester-coach-spatial" / "manchester-coach-spatial.toml").read_text())
    data["creep"]["friction"] = 0.6
    layout = layout_from_dict(data)
    p = contact_parameters(Vehicle(layout).model, 1)
    axle = 2 * layout.wheelset.wheel_load
    for y, psi, y_dot, psi_dot, moment in ((0.0065, -0.02, -0.3, -1.0, -65455.0), (0.0064, -0.005, 0.6, 0.0, 0.0)):
        f = profiled_contact(p.geometry, p.table[:, 0], p.law, False, y, psi, y_dot, psi_dot, 30.0, axle, moment, 0.0)
        assert np.all(np.isfinite(f)) and f[5] >= 0.0 and f[6] >= 0.0
        # The axle load to the creep's N^(2/3) growth between the balance's two passes (2e-8 here).
        assert f[5] + f[6] == pytest.approx(axle, rel=1e-6)


def test_nadal_balance_meets_the_axle_load():
    """Nadal's balance is solved until the wheels' vertical forces meet the axle load: over random
    states across the whole contact table (flange onsets included), axle loads of 0.7 to 1.5 times
    the static one and suspension moments of some 10 kN m, sum Q = P within 1e-3 everywhere (the
    passes' limit at the flange's onset) and within 1e-6 in 95 % of the states; no Q negative."""
    data = tomllib.loads((MODELS / "manchester-coach-spatial" / "manchester-coach-spatial.toml").read_text())
    layout = layout_from_dict(data)
    p = contact_parameters(Vehicle(layout).model, 1)
    rng = np.random.default_rng(1)
    n = 4000
    axle = 2 * layout.wheelset.wheel_load * rng.uniform(0.7, 1.5, n)
    states = [rng.uniform(-0.01, 0.01, n), rng.normal(0, 0.005, n), rng.normal(0, 0.3, n), rng.normal(0, 0.3, n)]
    f = contact_forces(
        p,
        *(v[:, None] for v in states),
        40.0,
        axle[:, None],
        rng.normal(0, 1e4, n)[:, None],
        layout.wheelset.wheel_load,
    )
    error = np.abs(f.load_left[:, 0] + f.load_right[:, 0] - axle) / axle
    assert np.max(error) < 1e-3 and np.mean(error < 1e-6) > 0.95
    assert np.all(f.load_left >= 0.0) and np.all(f.load_right >= 0.0)


def test_summary_flags_y_over_q_and_says_where_q_comes_from(tmp_path):
    """Above EN 14363's limit the summary says so; a spatial vehicle without gravity (no preload,
    no loads from its suspension) has the static share, and says it."""
    data = copy.deepcopy(SPATIAL)
    data["spatial"]["gravity"] = False
    from rail_mj.analysis import summary
    from rail_mj.simulation.runner import simulate

    result = summary(simulate(layout_from_dict(data), 40.0, 50.0, 0.002))
    assert result["wheel_loads_from"] == "static share" and result["y_over_q_exceeded"] is False
    coach = MODELS / "manchester-coach" / "manchester-coach.toml"
    out = CliRunner().invoke(cli, ["run", str(coach), "--speed", "85", "--distance", "600", "--json"])
    assert out.exit_code == 0, out.output
    hunting = json.loads(out.output)
    assert hunting["largest_y_over_q"] > hunting["y_over_q_limit"] and hunting["y_over_q_exceeded"] is True
