"""Runs on curved and canted track against the closed forms of steady curving (docs/track.md).

Conventions of rail-mj (docs/frames.md): y to the left, yaw nose-left, a left curve has
positive curvature k = 1/R and its outer (right) rail raised; the closed forms of the literature
(Wickens 2003; Iwnicki 2006) are usually written with y and the angle of attack positive
outward, so they carry the opposite sign here. Every run is long enough that the transients
have died to round-off of the steady state: each tolerance below is the integrator's and the
samples' resolution, far below the terms the closed forms keep.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest
from conftest import MODELS

from rail_mj.layout import layout_from_dict
from rail_mj.simulation.run import Request
from rail_mj.simulation.runner import simulate
from rail_mj.track import track_from_dict
from rail_mj.units import GRAVITY


def _linear(name: str, **changes) -> dict:
    """A shipped layout on the linear creep law, no spin, no flange: the closed forms' model."""
    data = tomllib.loads((MODELS / name / f"{name}.toml").read_text())
    data["creep"] = {"f11": data["creep"]["f11"], "f22": data["creep"]["f22"]}
    data.pop("flange", None)
    data.update(changes)
    return data


def _curve(radius: float, cant: float = 0.0, length: float = 4000.0):
    return track_from_dict({"section": [{"kind": "curve", "length": length, "radius": radius, "cant": cant}]})


def _balance_cant(radius: float, speed: float) -> float:
    """The cant that leaves no uncompensated acceleration: tan(theta) = V^2/(g R) (rail_mj.track)."""
    return 1.5 * math.sin(math.atan(speed * speed / (GRAVITY * radius)))


ELASTIC_RADIUS, ELASTIC_SPEED = 1000.0, 10.0  # m, m/s: the elastic bogie's curve, at its balance speed


def _elastic_bogie():
    """The shipped bogie on the linear law with its frame free of the car body, and the closed
    form of its steady curving at the balance speed (Wickens 2003, the elastic bogie):
    psi_1 = -psi_2 = (a/R)*k_psi^2*k_y*r0/D and the frame's psi_b = 2*a^2*f22*k_psi*k_y*r0/(R*D),
    D = 4a^2 f11 f22 k_y b lam + 4 f11 f22 k_psi b lam + k_psi^2 k_y r0, the leading wheelset yawed
    outward. Returns (layout, psi_1, psi_b)."""
    data = _linear("bogie", secondary={"lateral_stiffness": 0.0, "yaw_stiffness": 0.0, "lateral_damping": 64e3})
    layout = layout_from_dict(data)
    radius = ELASTIC_RADIUS
    w, c, p = layout.wheelset, layout.creep, layout.primary
    assert layout.bogie is not None
    a, b, lam, r0 = layout.bogie.wheelset_positions[0], w.contact_half_spacing, w.conicity, w.rolling_radius
    ky, kpsi = p.lateral_stiffness, p.yaw_stiffness
    d = 4 * a * a * c.f11 * c.f22 * ky * b * lam + 4 * c.f11 * c.f22 * kpsi * b * lam + kpsi**2 * ky * r0
    return layout, (a / radius) * kpsi**2 * ky * r0 / d, 2 * a * a * c.f22 * kpsi * ky * r0 / (radius * d)


def test_a_restrained_wheelset_settles_where_its_creep_and_spring_balance_the_curve():
    """A wheelset with yaw stiffness k_psi and no lateral spring, on a constant curve without cant:
    its lateral creep force carries the centrifugal force, 2*f22*psi = m*V^2*k, and its creep
    yaw moment the spring's, -2*f11*b*(lam*y/r0 + b*k) = k_psi*psi: so it runs at
    y = -(r0/lam)*(b*k + k_psi*psi/(2*f11*b)), the pure-rolling offset r0*b/(lam*R) outward and
    a little more."""
    layout = layout_from_dict(_linear("wheelset"))
    radius, speed = 1000.0, 20.0
    run = simulate(layout, speed, 1500.0, track=_curve(radius), initial_lateral=0.0)
    w, c, k = layout.wheelset, layout.creep, 1.0 / radius
    psi = w.mass * speed**2 * k / (2 * c.f22)
    y = -(w.rolling_radius / w.conicity) * (
        w.contact_half_spacing * k + layout.primary.yaw_stiffness * psi / (2 * c.f11 * w.contact_half_spacing)
    )
    # The last 100 m: the kinematic oscillation (12 m wavelength) decayed long before.
    late = run.x > run.x[-1] - 100.0
    np.testing.assert_allclose(run.psi[late, 0], psi, rtol=1e-6)
    np.testing.assert_allclose(run.y[late, 0], y, rtol=1e-6)


def _uncompensated(radius: float, speed: float, cant: float) -> float:
    """V^2/R cos(theta) - g sin(theta) in the canted track plane (docs/track.md, section 4)."""
    theta = math.asin(cant / 1.5)
    return speed**2 / radius * math.cos(theta) - GRAVITY * math.sin(theta)


@pytest.mark.parametrize("balanced", [True, False])
def test_a_free_wheelset_takes_the_pure_rolling_offset(balanced):
    """A wheelset with no suspension at all, solved directly (rail_mj.analysis.curving: a free
    wheelset hunts at every speed, so no run settles): its creep yaw moment vanishes only at
    pure rolling, lam*y/r0 = -b/R, the offset y0 = r0*b/(lam*R) outward whatever the speed, and its
    lateral creep force 2*f22*psi alone carries m*a_nc (zero at the balance speed). Both hold to
    the solver's residual (1e-7 m/s^2 on 1813 kg against f22 = 1e7 N: 1e-14 rad)."""
    from rail_mj.analysis.curving import steady_curving

    layout = layout_from_dict(_linear("wheelset", primary={"lateral_stiffness": 0.0, "yaw_stiffness": 0.0}))
    radius, speed = 800.0, 25.0
    cant = _balance_cant(radius, speed) if balanced else 0.0
    (wheelset,) = steady_curving(layout, radius, speed, cant)["wheelsets"]
    w, c = layout.wheelset, layout.creep
    assert wheelset["lateral_m"] == pytest.approx(-w.rolling_radius * w.contact_half_spacing / (w.conicity * radius))
    psi = w.mass * _uncompensated(radius, speed, cant) / (2 * c.f22)
    assert wheelset["yaw_rad"] == pytest.approx(psi, rel=1e-9, abs=1e-14)


def test_a_rigid_bogie_takes_its_closed_form():
    """Two wheelsets held rigidly in a frame free in yaw and sideways (primary springs of 1e11 N/m
    and N m/rad, the secondary removed), Wickens (2003), in rail-mj's signs (the angle of attack
    outward is a negative yaw here): each wheelset yawed -/+a/R from the track by the frame's
    heading at the bogie centre, plus the frame's F/(4*f22) that carries the uncompensated force F
    on the bogie; at the balance speed both at y = -y0*(1 + (f22/f11)*(a/b)^2). The stiff springs
    still give: forces of ~3e4 N and moments of ~4e4 N m over 1e11, 1e-6 allowed either way."""
    from rail_mj.analysis.curving import steady_curving

    data = _linear("bogie", secondary={"lateral_stiffness": 0.0, "yaw_stiffness": 0.0, "lateral_damping": 64e3})
    data["primary"] = dict(data["primary"], lateral_stiffness=1e11, yaw_stiffness=1e11)
    layout = layout_from_dict(data)
    assert layout.bogie is not None
    w, c = layout.wheelset, layout.creep
    a, b, radius, speed = layout.bogie.wheelset_positions[0], w.contact_half_spacing, 800.0, 25.0
    for cant in (_balance_cant(radius, speed), 0.0):
        result = steady_curving(layout, radius, speed, cant)
        force = _uncompensated(radius, speed, cant) * (2 * w.mass + layout.bogie.mass)
        frame = force / (4 * c.f22)
        yaws = [x["yaw_rad"] for x in result["wheelsets"]]
        np.testing.assert_allclose(yaws, [frame - a / radius, frame + a / radius], rtol=0, atol=1e-6)
        assert result["bodies"][0]["yaw_rad"] == pytest.approx(frame, abs=1e-6)
    y0 = w.rolling_radius * b / (w.conicity * radius)
    balanced = steady_curving(layout, radius, speed, _balance_cant(radius, speed))
    lateral = [x["lateral_m"] for x in balanced["wheelsets"]]
    np.testing.assert_allclose(lateral, -y0 * (1 + (c.f22 / c.f11) * (a / b) ** 2), rtol=0, atol=1e-6)


def test_an_elastic_bogie_at_the_balance_speed_takes_the_closed_form_angles_of_attack():
    """Two wheelsets on primary springs k_y, k_psi in a frame free of the car body, at the
    balance speed (no uncompensated force): psi_1 = -psi_2 = (a/R)*k_psi^2*k_y*r0/D and the
    frame's psi_b = 2*a^2*f22*k_psi*k_y*r0/(R*D), D = 4a^2 f11 f22 k_y b lam + 4 f11 f22 k_psi
    b lam + k_psi^2 k_y r0 (Wickens 2003, the elastic bogie), the leading wheelset yawed
    outward, here negative."""
    layout, psi1, psi_b = _elastic_bogie()
    radius, speed = ELASTIC_RADIUS, ELASTIC_SPEED
    run = simulate(layout, speed, 600.0, track=_curve(radius, _balance_cant(radius, speed)), initial_lateral=0.0)
    late = run.x > run.x[-1] - 100.0
    np.testing.assert_allclose(run.psi[late], np.broadcast_to([-psi1, psi1], run.psi[late].shape), rtol=1e-6)
    np.testing.assert_allclose(run.frame_psi[late, 0], -psi_b, rtol=1e-6)


@pytest.mark.parametrize(
    ("name", "distance"), [("manchester-coach", 400.0), ("two-coaches", 400.0), ("manchester-coach-spatial", 1200.0)]
)
def test_the_rails_carry_the_whole_vehicle_uncompensated_force(name, distance):
    """Steady on a constant curve, the lateral forces of the rails on all wheelsets (Sigma Y,
    creep and flange) carry the uncompensated force of every body, m*(V^2*k*cos(theta) -
    g*sin(theta)) summed over the vehicle's mass: Newton, for a planar vehicle, a train and a
    spatial vehicle (whose body roll settles slowest: 1200 m); at the balance speed they carry
    nothing. The suspension's pre-deflections are internal and sum to zero."""
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / name / f"{name}.toml")
    radius, speed, cant = 1200.0, 30.0, 0.08
    track = _curve(radius, cant)
    run = simulate(layout, speed, distance, track=track, initial_lateral=0.0)
    model = run.vehicle.model
    moving = [b for b in range(1, model.nbody) if model.body_dofnum[b] > 0 and model.body(b).name != "odometer"]
    mass = float(np.sum(model.body_mass[moving]))
    force = mass * float(track.uncompensated_acceleration(0.0, speed))
    total = run.contact_forces().lateral[-1].sum()
    # The rails push inward (+y, left) on a left curve: minus the outward uncompensated force.
    assert total == pytest.approx(force, rel=1e-6)
    balanced = simulate(
        layout, speed, distance, track=_curve(radius, _balance_cant(radius, speed)), initial_lateral=0.0
    )
    assert abs(balanced.contact_forces().lateral[-1].sum()) < 1e-6 * force


def test_a_long_car_body_sits_inside_the_curve_by_the_chord_s_offset():
    """A rigid car body on two bogies 2c apart rests on the chord between them: at its centre
    c^2/(2R) inside the track (Esveld 2001) when nothing else pushes it (the balance speed)."""
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / "manchester-coach" / "manchester-coach.toml")
    radius, speed = 600.0, 20.0
    run = simulate(layout, speed, 300.0, track=_curve(radius, _balance_cant(radius, speed)), initial_lateral=0.0)
    c = max(layout.carbody.bogie_positions or ())
    body = run.frame_names.index("carbody")
    bogies = run.frame_y[-1, [run.frame_names.index("bogie1"), run.frame_names.index("bogie2")]]
    # The bogies' own offsets (their wheelsets' curving, a few mm) carried along with their mean.
    assert run.frame_y[-1, body] - bogies.mean() == pytest.approx(c * c / (2 * radius), rel=1e-4)


def test_a_transition_brings_the_wheelset_onto_its_curving_offset_without_a_kick():
    """Through a clothoid the curvature grows linearly, and a stable wheelset follows its
    steady curving offset, which grows with it (to 5 % of the offset: it lags by its creep's
    time constant); entered without a transition the curve's yaw moment 2*f11*b^2*k arrives at
    once and jerks the wheelset sideways. The peak lateral acceleration through the
    transition is a small fraction of the step's (measured: 0.012 against 0.77 m/s^2)."""
    layout = layout_from_dict(_linear("wheelset"))
    radius, speed = 500.0, 20.0
    w = layout.wheelset
    offset = -w.rolling_radius * w.contact_half_spacing / (w.conicity * radius)
    smooth = track_from_dict(
        {
            "section": [
                {"kind": "straight", "length": 100.0},
                {"kind": "transition", "length": 100.0},
                {"kind": "curve", "length": 800.0, "radius": radius},
            ]
        }
    )
    step = track_from_dict(
        {"section": [{"kind": "straight", "length": 100.0}, {"kind": "curve", "length": 900.0, "radius": radius}]}
    )
    peaks = []
    for track in (smooth, step):
        run = simulate(layout, speed, 600.0, track=track, initial_lateral=0.0)
        if track is smooth:
            quasi_static = offset * run.wheelset_curvature[:, 0] * radius
            assert np.max(np.abs(run.y[:, 0] - quasi_static)) < 0.05 * abs(offset)
        acceleration = np.gradient(run.wheelset_rates[:, 0, 0], run.t)
        peaks.append(np.max(np.abs(acceleration)))
    assert peaks[0] < 0.05 * peaks[1]


def test_runs_packed_together_on_a_track_are_each_run_alone():
    """The odometer is a state: runs stepped several to a model, each from the track's start at
    its own speed, give exactly what each gives alone."""
    from rail_mj.layout import load_layout
    from rail_mj.simulation.batch import simulate_many

    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    track = _curve(800.0, 0.05, 1000.0)
    requests = [Request(layout, v, 150.0, 0.001, track=track) for v in (20.0, 25.0, 30.0)]
    together = simulate_many(requests)
    for request, run in zip(requests, together):
        alone = simulate(layout, request.speed, 150.0, 0.001, track=track)
        np.testing.assert_array_equal(run.y, alone.y)
        np.testing.assert_array_equal(run.station, alone.station)


def test_a_run_longer_than_its_track_is_refused_in_one_line():
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    with pytest.raises(ValueError, match=r"longer than the track .*1000 m"):
        simulate(layout, 20.0, 2000.0, track=_curve(800.0, 0.0, 1000.0), initial_lateral=0.0)


def test_straight_track_given_as_a_track_runs_as_without_one():
    """A straight Track adds the odometer, and the vehicle steps in its nested form (without a
    track, its flat twin: Vehicle.stepped): the same motion to the two forms' difference,
    second order in the yaw angles, 1.8e-10 m here over 200 m, where RK4's own change from
    dt to dt/2 is 1.5e-9 m (tests/validation/test_peers.py measures both on the coach)."""
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    straight = track_from_dict({"section": [{"kind": "straight", "length": 500.0}]})
    plain = simulate(layout, 30.0, 200.0, 0.002)
    on_track = simulate(layout, 30.0, 200.0, 0.002, track=straight)
    np.testing.assert_allclose(on_track.y, plain.y, rtol=0, atol=5e-10)
    assert dataclasses.asdict(layout) == dataclasses.asdict(on_track.layout)


def test_the_steady_state_solved_directly_is_the_elastic_bogie_s_closed_form():
    """rail_mj.analysis.curving's quasi-static solve, on the linear elastic bogie at the
    balance speed: the closed form of Wickens (2003) as the time run above gives it."""
    from rail_mj.analysis.curving import steady_curving

    layout, psi1, _ = _elastic_bogie()
    radius, speed = ELASTIC_RADIUS, ELASTIC_SPEED
    result = steady_curving(layout, radius, speed, _balance_cant(radius, speed))
    # The angle of attack is the yaw towards the outer rail: the leading wheelset's positive.
    attack = [w["angle_of_attack_rad"] for w in result["wheelsets"]]
    np.testing.assert_allclose(attack, [psi1, -psi1], rtol=1e-7)
    # Practice's cant deficiency, 1.5*V^2*k/g - cant, is the exact balance's to the small angle:
    # here 1.5*(tan(theta) - sin(theta)), under a micrometre.
    theta = math.atan(speed**2 / (GRAVITY * radius))
    assert result["cant_deficiency_mm"] == pytest.approx(1.5e3 * (math.tan(theta) - math.sin(theta)), rel=1e-9)


def test_the_elastic_bogie_s_wear_numbers_are_its_creepages_squared():
    """T-gamma per wheel on the linear law without spin is f11*xi_x^2 + f22*xi_y^2 (docs/track.md,
    section 9), at the elastic bogie's steady state at the balance speed: xi_y = -psi with psi the
    closed form of Wickens (2003), xi_x = -/+(lam*y/r0 + b/R) on the left/right wheel (the track
    turning under the wheelset at V/R) with y the solved state's. The same on both wheels of a
    wheelset; the leading wheelset's, at its larger rolling-radius deficit, several times the
    trailing one's."""
    from rail_mj.analysis.curving import steady_curving

    layout, psi1, _ = _elastic_bogie()
    radius, speed = ELASTIC_RADIUS, ELASTIC_SPEED
    result = steady_curving(layout, radius, speed, _balance_cant(radius, speed))
    c, w = layout.creep, layout.wheelset
    lam, r0, b = w.conicity, w.rolling_radius, w.contact_half_spacing
    wheelsets = result["wheelsets"]
    for wheelset, psi in zip(wheelsets, (-psi1, psi1)):  # rail-mj's signs: the leading one nose-right
        assert wheelset["yaw_rad"] == pytest.approx(psi, rel=1e-7)
        xi_x = lam * wheelset["lateral_m"] / r0 + b / radius
        expected = c.f11 * xi_x**2 + c.f22 * psi**2
        np.testing.assert_allclose(wheelset["wear_number_n"], [expected, expected], rtol=1e-6)
    assert wheelsets[0]["wear_number_n"][0] > 3 * wheelsets[1]["wear_number_n"][0] > 0.0


def test_the_flanging_wheel_of_the_s1002_coach_dissipates_most():
    """The coach on S1002/60E1 in a 300 m curve: its leading wheelset's outer (right) wheel runs on
    its flange, whose contact angle gives it a large spin and a steep rise of the rolling radius;
    its T-gamma is 2.5 times the inner wheel's (274 N against 109 N), and every wheel's is positive."""
    from rail_mj.analysis.curving import steady_curving
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml")
    result = steady_curving(layout, 300.0, 15.0, 0.1)
    wear = np.array([w["wear_number_n"] for w in result["wheelsets"]])
    assert np.all(wear > 0.0)
    inner, outer = wear[0]
    assert outer > 2 * inner


def test_the_s1002_coach_s_steady_state_is_found_at_every_speed_through_its_flange_contact():
    """In a 300 m curve with 100 mm cant the S1002 coach's leading wheelset is on its flange from
    15 m/s up; at 20 m/s the continuation from straight track used to stop where the flange takes
    over (a fixed step of a quarter of the curve) while 18 and 22 m/s were solved: a failed step
    is now halved. The state is continuous in the speed: every wheelset's offset and guiding force
    at 20 m/s lie between those at 18 and 22 m/s, and the flange holds the leading one at the same
    offset to 0.1 mm (-6.21 and -6.22 mm measured)."""
    from rail_mj.analysis.curving import steady_curving
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / "manchester-coach-s1002" / "manchester-coach-s1002.toml")
    low, middle, high = (steady_curving(layout, 300.0, v, 0.1)["wheelsets"] for v in (18.0, 20.0, 22.0))
    for a, b, c in zip(low, middle, high):
        for key in ("lateral_m", "guiding_force_n"):
            assert min(a[key], c[key]) <= b[key] <= max(a[key], c[key])
    assert abs(middle[0]["lateral_m"] - low[0]["lateral_m"]) < 1e-4


@pytest.mark.parametrize(
    ("name", "radius", "speed", "cant"),
    [("bogie", 600.0, 20.0, 0.0), ("manchester-coach-s1002", 300.0, 15.0, 0.1)],
)
def test_the_steady_state_solved_directly_is_where_a_run_settles(name, radius, speed, cant):
    """The nonlinear steady state (the flange spring and Polach's saturation on cones; on
    S1002/60E1 the leading wheelsets in flange contact in a 300 m curve) solved directly equals
    the state a time run on a long constant curve settles in, to the solver's tolerance."""
    from rail_mj.analysis.curving import steady_state
    from rail_mj.layout import load_layout

    layout = load_layout(MODELS / name / f"{name}.toml")
    steady = steady_state(layout, radius, speed, cant)
    run = simulate(layout, speed, 600.0, track=_curve(radius, cant, 700.0), initial_lateral=0.0)
    np.testing.assert_allclose(steady.y[0], run.y[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(steady.psi[0], run.psi[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(steady.frame_y[0], run.frame_y[-1], rtol=0, atol=1e-8)
    if name.endswith("s1002"):  # the leading wheelset is on its flange: past the profiles' clearance
        assert steady.y[0, 0] < -0.9 * layout.wheelset.flangeway_clearance


SPATIAL_CONED = MODELS.parent / "tests" / "data" / "manchester-coach-spatial.toml"


def test_a_spatial_vehicle_at_the_balance_speed_neither_rolls_nor_unloads_a_wheel():
    """At the balance speed the track plane carries the whole weight and nothing pushes a body
    sideways: every body's roll is nil (to the steady solve's resolution, here 2e-6 rad: the
    frames' roll under the wheelsets' opposite steering forces) and each wheelset's Q_left -
    Q_right is only its steering's share. The lateral creep force Sigma Y at the rail, which
    its primary springs react at the axlebox height h, rolls it by h*Sigma Y; the offset y of the
    wheelset from the rails' centre moves its load P sideways by P*y; divided by the contact
    half spacing b, with 25 % for the terms this leaves out (the gyroscopic moment, the
    primary's shear couples). (Before the wheel loads took the curve's geometry: the car body
    rolled by -3.1 mrad and Q_left - Q_right was 10-15 kN per wheelset of the S1002 coach at
    R 600 m, 150 mm, with Sigma Y of 2 kN.)"""
    from rail_mj.analysis.curving import steady_curving
    from rail_mj.layout import load_layout

    layout = load_layout(SPATIAL_CONED)
    radius, cant = 1200.0, 0.08
    speed = math.sqrt(GRAVITY * radius * math.tan(math.asin(cant / 1.5)))
    result = steady_curving(layout, radius, speed, cant)
    assert result["uncompensated_acceleration_m_per_s2"] == pytest.approx(0.0, abs=1e-12)
    for body in result["bodies"]:
        assert abs(body["roll_rad"]) < 1e-5, body
    from rail_mj.numerics import NUMERIC_LOADS
    from rail_mj.vehicle.spec import Vehicle

    h = float(Vehicle(layout).model.numeric(NUMERIC_LOADS).data[3])  # the axleboxes' height above the rail
    b = layout.wheelset.contact_half_spacing
    for w in result["wheelsets"]:
        left, right = w["wheel_loads_n"]
        share = (h * abs(w["guiding_force_n"]) + (left + right) * abs(w["lateral_m"])) / b
        assert abs(left - right) < 1.25 * share, w


def _static_roll(layout, lateral: float, normal: float) -> float:
    """The car body's roll, rad, of `layout` at rest on straight track under the acceleration
    (0, -lateral, -normal) in place of gravity, its wheelsets held on the rails' centre (at
    rest they have no creep to hold them: the rails do, as in the curve)."""
    import mujoco
    from scipy.optimize import root

    from rail_mj.simulation import native
    from rail_mj.vehicle.spec import Vehicle

    vehicle = Vehicle(layout)
    model = vehicle.model
    assert model.numeric_data[2] == 0.0  # no speed set: no rolling, no creep
    model.opt.gravity[:] = (0.0, -lateral, -normal)
    data = mujoco.MjData(model)
    held = {model.joint(f"{w}_{m}").dofadr[0] for w in vehicle.wheelset_names for m in ("lateral", "yaw")}
    free = np.array([d for d in range(model.nv) if d not in held], dtype=np.int64)

    def accelerations(q):
        data.qpos[:] = model.qpos0
        data.qpos[free] += q
        data.qvel[:] = 0.0
        mujoco.mj_forward(model, data)
        return data.qacc[free].copy()

    with native.installed():
        solution = root(accelerations, np.zeros(len(free)), method="hybr", options={"xtol": 1e-13})
        assert np.max(np.abs(accelerations(solution.x))) < 1e-8
    return float(data.qpos[model.joint("carbody_roll").qposadr[0]])


def test_under_cant_deficiency_the_car_body_rolls_outward_as_on_straight_track_under_the_same_acceleration():
    """Past the balance speed the uncompensated acceleration a_nc = V^2*k*cos(theta) -
    g*sin(theta) pushes every body outward in the track plane, and the car body rolls outward on
    its springs (positive on a left curve) by what the same vehicle gives at rest on straight
    track under the lateral acceleration a_nc and the normal g*cos(theta) + V^2*k*sin(theta): the
    same loads on the same suspension. On the curve the wheelsets run off the rails' centre and
    steer, but their creep forces, opposite on a bogie's leading and trailing wheelsets, are
    internal to the bogie: its primary springs pass on the same sum, at the same height, as the
    rails' hold at rest. So the roll is the same to the steady solves' tolerance (measured
    5e-13 relative; before the wheel loads took the curve's geometry, the balance speed alone
    rolled the S1002 coach's car body by -3.1 mrad)."""
    from rail_mj.analysis.curving import steady_curving
    from rail_mj.layout import load_layout

    layout = load_layout(SPATIAL_CONED)
    radius, cant = 1200.0, 0.08
    theta = math.asin(cant / 1.5)
    speed = 1.3 * math.sqrt(GRAVITY * radius * math.tan(theta))
    result = steady_curving(layout, radius, speed, cant)
    roll = next(b["roll_rad"] for b in result["bodies"] if b["body"] == "carbody")
    centripetal = speed * speed / radius
    lateral = centripetal * math.cos(theta) - GRAVITY * math.sin(theta)
    normal = GRAVITY * math.cos(theta) + centripetal * math.sin(theta)
    static = _static_roll(layout, lateral, normal)
    assert roll > 0.0
    assert roll == pytest.approx(static, rel=1e-9)


def test_a_spatial_run_packed_with_others_on_a_cant_ramp_is_the_run_alone():
    """The track part of a packed spatial vehicle is the one it has alone (its gravitational
    stiffness's hinges take no pre-deflection either way): bit for bit, along a transition whose
    cant ramps up."""
    from rail_mj.layout import load_layout
    from rail_mj.simulation.batch import simulate_many

    layout = load_layout(SPATIAL_CONED)
    track = track_from_dict(
        {
            "section": [
                {"kind": "straight", "length": 30.0},
                {"kind": "transition", "length": 60.0},
                {"kind": "curve", "length": 200.0, "radius": 800.0, "cant": 0.1},
            ]
        }
    )
    requests = [Request(layout, v, 80.0, 0.002, track=track) for v in (20.0, 25.0)]
    together = simulate_many(requests)
    for request, run in zip(requests, together):
        alone = simulate(layout, request.speed, request.distance, 0.002, track=track)
        np.testing.assert_array_equal(run.body_pos, alone.body_pos)
        np.testing.assert_array_equal(run.body_quat, alone.body_quat)
        np.testing.assert_array_equal(run.wheel_loads(), alone.wheel_loads())


def test_a_spatial_vehicle_without_gravity_on_a_cant_ramp_is_refused_in_one_line():
    """Without gravity a spatial vehicle carries no axlebox roll levers (its wheel loads are the
    layout's static ones), so a wheelset's cant roll along a ramp would not reach its axlebox
    springs: refused there; on constant cant, where the wheelsets do not roll from the vehicle's
    origin, it runs."""
    import tomllib

    data = tomllib.loads(SPATIAL_CONED.read_text())
    data["spatial"]["gravity"] = False
    for switch in ("gravitational_stiffness", "gyroscopic"):
        data["spatial"].pop(switch, None)
    layout = layout_from_dict(data)
    ramp = track_from_dict(
        {
            "section": [
                {"kind": "straight", "length": 50.0},
                {"kind": "transition", "length": 50.0},
                {"kind": "curve", "length": 400.0, "radius": 1200.0, "cant": 0.08},
            ]
        }
    )
    with pytest.raises(ValueError, match=r"a spatial vehicle without gravity on a track whose cant varies"):
        simulate(layout, 30.0, 100.0, track=ramp, initial_lateral=0.0)
    assert simulate(layout, 30.0, 20.0, track=_curve(1200.0, 0.08), initial_lateral=0.0).station[-1] == pytest.approx(
        20.0, abs=0.05
    )


def test_straight_and_curved_runs_stepped_together_are_each_run_alone():
    """More runs than a pack holds, on straight track and on two tracks, the same layout: a place
    freed by one run is taken only by a run of the same vehicle on the same track."""
    from rail_mj.layout import load_layout
    from rail_mj.simulation.batch import simulate_many

    layout = load_layout(MODELS / "bogie" / "bogie.toml")
    tracks = [None, _curve(800.0, 0.05, 1000.0), _curve(-500.0, 0.1, 1000.0)]
    requests = [Request(layout, 20.0 + 2.0 * k, 40.0 + 20.0 * (k % 3), 0.001, track=tracks[k % 3]) for k in range(11)]
    together = simulate_many(requests)
    for request, run in zip(requests, together):
        alone = simulate(layout, request.speed, request.distance, 0.001, track=request.track)
        np.testing.assert_array_equal(run.y, alone.y)


def test_a_linear_planar_vehicle_settles_on_one_linear_solve():
    """The general oracle of steady curving for a linear vehicle: K q = f, K its stiffness on
    straight track (the velocity-independent part of its linear equations: suspension and the
    creep terms -2*f22*psi, 2*f11*b*lam*y/r0; here dqacc/dq of MuJoCo's dynamics, central
    differences) and f the curve's loads at q = 0 (the uncompensated force on every body, the
    suspension's pre-deflections, the curvature's yaw moment 2*f11*b^2/R per wheelset). The
    coach on the linear law, run 2 km along a 1200 m curve with 100 mm cant, settles on the
    solve to 1e-7 of its largest coordinate in every coordinate (the differences' relative
    round-off, eps/FD_STEP = 1e-8, times the stiffness's conditioning; 1.7e-9 m of 3.3e-2 m
    measured). Newton on f: the root lateral joint, which moves every body, carries the whole
    uncompensated force, -(sum of masses)*a_nc, to the bodies' headings off the root's,
    cos(9.5/1200) = 1 - 3e-5."""
    import mujoco

    from rail_mj.simulation import native
    from rail_mj.simulation.linear import state_matrix
    from rail_mj.vehicle.curve import ODOMETER
    from rail_mj.vehicle.spec import Vehicle

    layout = layout_from_dict(_linear("manchester-coach"))
    radius, speed, cant = 1200.0, 30.0, 0.1
    track = _curve(radius, cant)
    straight = Vehicle(layout)
    native.set_speed(straight.model, speed)
    nv = straight.model.nv
    stiffness = state_matrix(straight.model)[nv:, :nv]  # M^-1 K, as qacc per q
    curved = Vehicle(layout, track)
    native.set_speed(curved.model, speed)
    model = curved.model
    coordinates = [i for i in range(model.nv) if i != model.joint(ODOMETER).dofadr[0]]
    data = mujoco.MjData(model)
    with native.installed():
        mujoco.mj_forward(model, data)
    loads = data.qacc[coordinates].copy()  # M^-1 f at q = 0 on the curve
    solved = np.linalg.solve(stiffness, -loads)
    run = simulate(layout, speed, 2000.0, track=track, initial_lateral=0.0)
    settled = run.final_state[0][coordinates]
    np.testing.assert_allclose(settled, solved, rtol=0, atol=1e-7 * np.max(np.abs(solved)))
    force = np.zeros(model.nv)
    mujoco.mj_mulM(model, data, force, data.qacc)
    root = model.joint("carbody_lateral").dofadr[0]
    total = sum(float(model.body_mass[b]) for b in range(model.nbody) if model.body(b).name != ODOMETER)
    assert force[root] == pytest.approx(-total * _uncompensated(radius, speed, cant), rel=1e-4)


def test_on_a_curve_the_summary_reads_the_motion_about_the_curving_offset():
    """A linear wheelset on a constant curve oscillates about its steady curving state with the
    modes it has on straight track (the curve's loads are constant: superposition), so the
    summary's frequency and growth rate, taken about the offsets it fits to the curvature and
    uncompensated acceleration, are the straight run's: to 1e-3 and 3e-3 (the same least-damped
    mode, started from another mix of lateral and yaw; 3e-4 and 1.3e-3 measured). Taken from the
    raw motion, 4 mm off centre, there would be no zero crossing and no frequency at all."""
    from rail_mj.analysis import summary

    layout = layout_from_dict(_linear("wheelset"))
    straight = summary(simulate(layout, 40.0, 800.0, 0.002))["wheelsets"][0]
    run = simulate(layout, 40.0, 800.0, 0.002, track=_curve(1000.0, 0.05))
    curved = summary(run)["wheelsets"][0]
    assert curved["final_abs_lateral_m"] > 1e-3  # the offset is there, and reported
    assert curved["frequency_hz"] == pytest.approx(straight["frequency_hz"], rel=1e-3)
    assert curved["growth_rate_per_s"] == pytest.approx(straight["growth_rate_per_s"], rel=3e-3)
    assert curved["decayed"] and curved["max_abs_lateral_about_curving_m"] < curved["max_abs_lateral_m"]
