"""The dynamics on wheel and rail profiles: the contact tables (rail_mj/contact/tables.py) and the
compiled law that interpolates them (rail_mj.contact.creep.profiled_contact), docs/dynamics-on-profiles.md."""

from __future__ import annotations

import dataclasses
import json
import math

import numba
import numpy as np
import pytest
from conftest import MODELS, PROFILES_TOML, assert_callbacks_agree

from rail_mj.analysis.stability import Stability
from rail_mj.cli import main
from rail_mj.contact import geometry, tables
from rail_mj.contact.creep import ContactParameters, _creepages, contact_forces
from rail_mj.layout import LayoutError, load_layout
from rail_mj.simulation.runner import simulate
from rail_mj.units import M_PER_MM, N_PER_KN
from rail_mj.vehicle.spec import Vehicle

PROFILES = PROFILES_TOML
COACH = (MODELS / "manchester-coach" / "manchester-coach.toml").read_text().replace("conicity = 0.15", "").replace(
    "flangeway_clearance = 0.008", ""
).replace("[flange]", "") + PROFILES
for key in ("f11", "f22", "f23", "f33"):
    COACH = "\n".join(line for line in COACH.splitlines() if not line.startswith(key))


@pytest.fixture(scope="module")
def coach(tmp_path_factory):
    path = tmp_path_factory.mktemp("profiled") / "coach.toml"
    path.write_text(COACH)
    return load_layout(path)


def forces_at(table, y, psi=0.0, y_dot=0.0, psi_dot=0.0, speed=30.0, law=0):
    p = ContactParameters.broadcast(
        1, r0=0.46, b=0.75, conicity=0.1, f11=1.0, f22=1.0, law=law, friction_limit=1.0, geometry=table
    )
    return contact_forces(p, np.array([y]), np.array([psi]), np.array([y_dot]), np.array([psi_dot]), speed)


def test_the_coach_on_profiles_takes_everything_from_them(coach):
    assert coach.flange is None and coach.profiles is not None
    # The flangeway clearance is where a flange is met: the contact steeper than 1 rad
    # there, on the tread one table step (0.05 mm) nearer the centre.
    geo = geometry.contact_table(coach)
    i = int(np.argmin(np.abs(geo.y - coach.wheelset.flangeway_clearance)))
    assert geo.contact_angle_left[i] > 1.0 > geo.contact_angle_left[i - 1]
    # Kalker's coefficients of the centred contact, from Hertz at each point: of the order of
    # 10 MN for a 5.5 t wheel (docs/contact.md's 10 t reference case gives 14.3 and 13.1 MN).
    assert 5e6 < coach.creep.f22 < coach.creep.f11 < 20e6


@pytest.mark.parametrize("y_mm", [0.5, 1.0, 2.0, 3.0, 4.5, 5.5, 5.8, -3.0])
def test_normal_forces_do_the_virtual_work_of_the_axle_load(coach, y_mm):
    """Gravitational stiffness from equilibrium: the lateral resultant of the normal forces
    that balance the axle load W in vertical and roll equilibrium equals -W*dz/dy, z(y) the
    rigid wheelset's height from the geometry (virtual work: the contact forces of a rigid
    constraint do none). Independent: z is never used by the law. 1e-3 relative: the
    central difference of z over +/- 0.05 mm and the interpolation between rows."""
    table = tables.dynamics_table(coach)
    geo = geometry.contact_table(coach)
    y = y_mm * 1e-3
    i = round((y - geo.y[0]) / (geo.y[1] - geo.y[0]))
    dz_dy = (geo.z[i + 1] - geo.z[i - 1]) / (geo.y[i + 1] - geo.y[i - 1])
    w = table[0, tables.HEADER_AXLE_LOAD] * N_PER_KN
    got = float(forces_at(table, geo.y[i]).flange_lateral[0])
    assert got == pytest.approx(-w * dz_dy, rel=1e-3)
    assert got * y < 0  # it pushes the wheelset back to the centre


def test_forces_are_odd_on_a_symmetric_track(coach):
    """Mirror the state, mirror the forces: the two sides are worked alike (1e-7 of the
    largest force, the geometry's rows at -y and +y are found independently)."""
    table = tables.dynamics_table(coach)
    rng = np.random.default_rng(3)
    for _ in range(20):
        state = rng.normal(scale=[0.003, 0.003, 0.05, 0.05])
        a = forces_at(table, *state, law=2)
        b = forces_at(table, *(-state), law=2)
        scale = max(abs(float(a.lateral[0])), abs(float(a.yaw[0])), 1.0)
        assert float(b.lateral[0]) == pytest.approx(-float(a.lateral[0]), abs=1e-7 * scale)
        assert float(b.yaw[0]) == pytest.approx(-float(a.yaw[0]), abs=1e-7 * scale)
    centred = forces_at(table, 0.0)
    assert abs(float(centred.lateral[0])) < 1e-9 * table[0, tables.HEADER_AXLE_LOAD] * N_PER_KN


def cone_on_knives(tmp_path, lam):
    """A restrained wheelset (models/wheelset, a 50 kN wheel load, its yaw spring softened
    to 0.2 MN m/rad: on knife edges the ellipse is small and f11, f22 are ~1.4 MN) on a
    straight-tread cone of conicity lam and knife-edge rails, gravitational stiffness and
    spin creep off."""
    (tmp_path / "cone.csv").write_text(f"y_mm,z_mm\n-60,{-60 * lam!r}\n60,{60 * lam!r}\n")
    (tmp_path / "knife.csv").write_text("y_mm,z_mm\n-20,-20\n0,0\n20,-20\n")
    text = (
        (MODELS / "wheelset" / "wheelset.toml")
        .read_text()
        .replace("conicity = 0.1", "wheel_load = 50.0e3")
        .replace("yaw_stiffness = 2.0e6", "yaw_stiffness = 2.0e5")
    )
    text = "\n".join(line for line in text.splitlines() if not line.startswith(("f11", "f22")))
    text += (
        '\n[profiles]\nwheel = "cone.csv"\nrail = "knife.csv"\nrail_inclination = 0.0\n'
        "gravitational_stiffness = false\nspin_creep = false\n"
    )
    path = tmp_path / "cone.toml"
    path.write_text(text)
    return load_layout(path)


def test_a_cone_on_knife_edges_is_the_classical_restrained_wheelset(tmp_path):
    """With gravitational stiffness and spin creep off, a coned wheelset on knife-edge
    rails linearised at any amplitude is the classical wheelset of docs/creep.md: its
    critical speed is the closed form Vc^2 = P*Q/(P^2*lam/(b*r0) - (m*kpsi - Iz*ky)^2/4)
    with lam the table's conicity (Δr = 2*lam*y exactly on knives), b the contacts' lever
    and f11, f22 Hertz's and Kalker's at the centred contact. 5e-4 relative: the contact
    plane's tilt atan(lam) enters the lateral creepage as cos(gamma) = 1 - 3.1e-4 at 1:40,
    which moves Vc by as much (measured 3.15e-4)."""
    layout = cone_on_knives(tmp_path, 0.025)
    stability = Stability(layout, amplitude=2.0)
    table = tables.dynamics_table(layout)
    centre = table[1:][np.argmin(np.abs(table[1:, tables.Y]))]
    b = centre[tables.point_column(0, 0, tables.LEVER)] * M_PER_MM
    lam = stability.equivalent_conicity
    w, c = layout.wheelset, layout.creep
    # r0: the centred contact's rolling radius (the knives touch 18.5 mm inside the taping line)
    m, iz, r0, kpsi = w.mass, w.inertia[2], table[0, tables.HEADER_R0] * M_PER_MM, layout.primary.yaw_stiffness
    p = m * c.f11 * b**2 + iz * c.f22
    q = c.f22 * kpsi
    closed = math.sqrt(p * q / (p**2 * lam / (b * r0) - (m * kpsi) ** 2 / 4))
    got = stability.critical_speed(5.0, 150.0).critical_speed
    assert got == pytest.approx(closed, rel=5e-4)


@pytest.mark.parametrize("law", ["polach", "fastsim"])
def test_native_and_python_callbacks_agree_on_profiles(coach, law):
    """On the tread, across the jump to the flange and up it, with Polach's law and with
    FASTSIM at each contact point: qfrc_passive agrees to 1e-9."""
    vehicle = Vehicle(dataclasses.replace(coach, creep=dataclasses.replace(coach.creep, law=law)))
    assert_callbacks_agree(vehicle, 61.0, seed=11, samples=15, position=0.005, rate=0.2)


def test_equivalent_conicity_sets_the_linear_critical_speed(coach):
    """Linearised at 1 mm the S1002/60E1 pair is far steeper than at 3 mm (λe 0.36 against
    0.18): the coach hunts from a lower speed, as the seed's kinematic argument says."""
    small, quoted = Stability(coach, amplitude=1.0), Stability(coach)
    assert quoted.amplitude == 3.0
    assert small.equivalent_conicity > 1.5 * quoted.equivalent_conicity
    v_small = small.critical_speed(20.0, 150.0).critical_speed
    v_quoted = quoted.critical_speed(20.0, 150.0).critical_speed
    assert v_small < 0.85 * v_quoted


def test_the_profiled_coach_decays_below_and_hunts_on_its_flanges_above(coach):
    """Below the linear critical speed a 2 mm start dies away; well above it the motion
    grows onto a limit cycle that the flanges bound: no further than a little past where
    they touch (rigid profiles: the contact climbs the flange root, a wall of ~2W)."""
    vc = Stability(coach).critical_speed(20.0, 150.0).critical_speed
    slow = simulate(coach, 0.6 * vc, 400.0, 0.002)
    assert np.max(np.abs(slow.y[-100:])) < 1e-4
    fast = simulate(coach, 1.15 * vc, 1200.0, 0.002)
    late = np.max(np.abs(fast.y[len(fast.y) // 2 :]))
    clearance = coach.wheelset.flangeway_clearance
    assert 0.8 * clearance < late < clearance + 0.5e-3


def test_profiles_take_the_place_of_flange_and_cone(tmp_path):
    path = tmp_path / "both.toml"
    path.write_text((MODELS / "manchester-coach" / "manchester-coach.toml").read_text() + PROFILES)
    with pytest.raises(LayoutError, match=r"flange: not used with \[profiles\]"):
        load_layout(path)
    path.write_text(COACH.replace("flange_back_spacing = 1.360", "flange_back_spacing = 1.360\nspin_creep = 1"))
    with pytest.raises(LayoutError, match="spin_creep: must be true or false"):
        load_layout(path)
    path.write_text(COACH.replace('law = "polach"', 'law = "polach"\nf11 = 1.0e7\nf22 = 1.0e7'))
    assert any("f11..f33 are not used" in w for w in load_layout(path).warnings)


def test_cli_states_the_linearisation_amplitude(coach, capsys):
    assert main(["eigen", coach.source, "--speed", "40", "--json", "--amplitude", "2"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["amplitude_mm"] == 2.0
    assert out["equivalent_conicity"] == pytest.approx(
        geometry.equivalent_conicity(geometry.contact_table(coach), 2.0), rel=1e-12
    )
    status = main(["critical-speed", str(MODELS / "wheelset" / "wheelset.toml"), "--amplitude", "2"])
    err = capsys.readouterr().err
    assert status == 2 and len(err.strip().splitlines()) == 1 and "cones" in err
    status = main(["eigen", coach.source, "--speed", "40", "--amplitude", "20"])
    err = capsys.readouterr().err
    assert status == 2 and "--amplitude" in err.strip().splitlines()[-1]


def test_a_steep_flange_holds_the_wheelset_on_the_flanging_wheel(coach):
    """On a flange steeper than the S1002's 70 degrees the other wheel lifts: the flanging
    wheel carries the axle load alone and pushes back with W*tan(gamma) (75 degrees here,
    3.73 W), never lets the wheelset through."""
    table = tables.dynamics_table(coach).copy()
    row = 1 + int(np.argmin(np.abs(table[1:, tables.Y] - 6.4)))
    for slot in range(tables.SLOTS):
        table[row, tables.point_column(0, slot, tables.ANGLE)] = math.radians(75.0)
    w = table[0, tables.HEADER_AXLE_LOAD] * N_PER_KN
    got = float(forces_at(table, table[row, tables.Y] * M_PER_MM).flange_lateral[0])
    assert got == pytest.approx(-w * math.tan(math.radians(75.0)), rel=1e-9)


def test_a_flange_yawed_into_its_rail_is_turned_away(coach):
    """Against the left rail's flange, nose-left (into the rail): the normal force acts
    ahead of the axle (r*tan(gamma) > l) and yaws the wheelset nose-right (docs/flange.md).
    Under the coach's own law, Polach's, whose mu*N bounds the creep: the linear law's creep on
    a yawed flange is unbounded (with the flange patch's own Kalker coefficients, a/b = 24, 1.6
    times the normal force here) and would outweigh it."""
    table = tables.dynamics_table(coach)
    f = forces_at(table, 6.4e-3, psi=0.004, law=2)
    assert float(f.flange_lateral[0]) < 0 and float(f.flange_moment[0]) < 0


def test_spin_creep_opposes_gravitational_stiffness(coach):
    """At rest 3 mm off centre the contact angles differ, and so do the wheels' spin
    creepages: their lateral force pushes outwards, against the normal forces' restoring
    part, but does not cancel it (Wickens 2003)."""
    f = forces_at(tables.dynamics_table(coach), 3e-3, law=2)
    assert float(f.flange_lateral[0]) < 0 < float(f.creep_lateral[0]) < -float(f.flange_lateral[0])


def test_a_nan_state_gives_nan_not_a_wild_read(coach):
    f = forces_at(tables.dynamics_table(coach), math.nan)
    assert np.all(np.isnan(np.array(f)))


def test_hertz_shares_two_points_load_by_their_approach():
    """Two like points: equal gaps share equally; a gap g moves load to the closer point as
    Hertz's law says, N2/N1 = ((zeta - g)/zeta)^(3/2) for the common approach zeta."""
    A, B = 1.0, 5.0
    assert tables._share([(0.0, 0.0, A, B), (0.0, 0.0, A, B)], 50e3, 210e9, 0.28) == pytest.approx([0.5, 0.5])
    w1, w2 = tables._share([(0.0, 0.0, A, B), (2e-5, 0.0, A, B)], 50e3, 210e9, 0.28)
    c = tables._hertz_per_unit_load(A, B, 210e9, 0.28)[3]
    zeta = c * (w1 * 50e3) ** (2 / 3)  # the first point's approach at its load
    assert w2 / w1 == pytest.approx(((zeta - 2e-5) / zeta) ** 1.5, rel=1e-9)
    assert w2 < w1


def test_slots_follow_their_points_across_the_rows():
    """Two tread points from the centre; the outer one leaves, the inner one carries on,
    then the contact jumps to the flange root: a new point in the freed slot."""
    s = [[-8.0e-3, 3.2e-3], [-8.1e-3, 3.1e-3], [-8.2e-3], [-8.3e-3], [-30e-3], [-30.1e-3]]
    assert tables._assign_slots(s, 0) == [[1, 0], [1, 0], [1], [1], [0], [0]]
    # and outwards the other way from a centre inside the list
    assert tables._assign_slots([[-30e-3], [-8.3e-3], [3.2e-3, -8.0e-3]], 2) == [[0], [1], [0, 1]]


def test_linearisation_is_the_describing_function(tmp_path):
    """An entry c(y) = c0 + c1*y + c2*y^2 + c3*y^3 linearised at amplitude A: slope
    c1 + (3/4)*c3*A^2 (first harmonic) and mean c0 + (3/4)*c2*A^2 (weighted by sin^2);
    the radii become the cone of the equivalent conicity (1e-9). 1e-4 for the polynomial:
    the law interpolates linearly between rows 0.05 mm apart, off by c''*dy^2/8."""
    layout = cone_on_knives(tmp_path, 0.025)
    table = tables.dynamics_table(layout).copy()
    y = table[1:, tables.Y]
    c0, c1, c2, c3 = 0.05, 0.01, 0.002, 0.0003  # per mm
    column = tables.point_column(0, 0, tables.ANGLE)
    table[1:, column] = c0 + c1 * y + c2 * y**2 + c3 * y**3
    amplitude = 3.0
    lin = tables.linearised(table, geometry.contact_table(layout), amplitude)
    dy = lin[0, tables.HEADER_DY]
    assert (lin[3, column] - lin[1, column]) / (2 * dy) == pytest.approx(c1 + 0.75 * c3 * amplitude**2, rel=1e-4)
    assert lin[2, column] == pytest.approx(c0 + 0.75 * c2 * amplitude**2, rel=1e-4)
    lam = geometry.equivalent_conicity(geometry.contact_table(layout), amplitude)
    radius = tables.point_column(0, 0, tables.RADIUS)
    assert (lin[3, radius] - lin[1, radius]) / (2 * dy) == pytest.approx(lam, rel=1e-9)


def test_a_wheelset_past_the_table_has_climbed_its_flange(coach):
    from rail_mj.simulation.run import Derailed

    with pytest.raises(Derailed, match="climbed the flange"):
        simulate(coach, 30.0, 50.0, 0.0105)


# --- the wheelset's roll in the creepages (docs/dynamics-on-profiles.md, creepages) ---------


@numba.njit
def _unrolled(g, s, rise, lever, r0, y_dot, psi, psi_dot, speed):
    """The creepages as they were before the roll entered them (track-frame angle only)."""
    return (
        -rise / r0 - lever * psi_dot / speed,
        (y_dot / speed - psi) / math.cos(g),
        psi_dot * math.cos(g) / speed - s * math.sin(g) / r0,
    )


def _rotation(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    m = np.eye(3)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def rolled_axle_creepages(g, s, roll, psi, psi_dot, y_dot, speed, r0):
    """The lateral and spin creepages from the kinematics in three dimensions: a wheelset
    rolled by `roll` (about x, left side up) and yawed by `psi` (about z) spins at V/r0 about its
    axle; the contact normal n = (0, -s*sin(g), cos(g)) (a straight rail's: no x part). Spin:
    the angular velocity along n, over V (CONTACT: omega*sin(g - roll)/V at zero yaw). Lateral:
    the slip along the wheel's meridian through the contact, n x c (c the circumferential
    direction, along axle x n, where the rotation's own slip lies); the lateral velocity y' slips
    in the contact plane (its vertical part from the rigid contact), the forward speed V as x."""
    axle = _rotation(2, psi) @ _rotation(0, roll) @ np.array([0.0, 1.0, 0.0])
    n = np.array([0.0, -s * math.sin(g), math.cos(g)])
    omega = speed / r0 * axle + np.array([0.0, 0.0, psi_dot])
    c = np.cross(axle, n)
    meridian = np.cross(n, c / np.linalg.norm(c))
    slip = np.array([speed, y_dot, s * y_dot * math.tan(g)])
    return float(slip @ meridian) / speed, float(omega @ n) / speed


def test_unrolled_creepages_are_unchanged_to_the_last_bit():
    """At zero roll the creepages are the previous expressions exactly, on both sides, whatever
    the angle (tread to flange), state and speed."""
    rng = np.random.default_rng(20)
    for _ in range(3000):
        g, s = rng.uniform(-0.2, 1.3), float(rng.choice([1.0, -1.0]))
        rise, lever, r0 = rng.uniform(-5e-3, 30e-3), rng.uniform(-0.8, 0.8), rng.uniform(0.3, 0.6)
        state = rng.normal(0, 0.1), rng.normal(0, 3e-3), rng.normal(0, 0.05), rng.uniform(1, 150)  # y', psi, psi', V
        for roll in (0.0, -0.0):
            got = _creepages(math.cos(g), math.sin(g), s, math.cos(roll), math.sin(roll), rise, lever, r0, *state)
            assert got == _unrolled(g, s, rise, lever, r0, *state)


@pytest.mark.parametrize("s", [1.0, -1.0])
def test_creepages_of_a_rolled_wheelset_are_its_rotating_axles(s):
    """Against the three-dimensional kinematics of the rolled, yawed, spinning wheelset: the spin
    is (V/r0)*sin(g - s*roll)/V plus the yaw rate's part to round-off at zero yaw, and to second
    order in the yaw otherwise; the lateral creepage to round-off at zero yaw, and otherwise to
    second order in the yaw (twice the leading neglected terms, the yaw tilting the meridian:
    psi^2*tan(d)*tan(g)/2 of the yaw's part and psi^2/(2*cos(d)^2) of the lateral velocity's,
    d = g - s*roll)."""
    rng = np.random.default_rng(11 if s > 0 else 12)
    for _ in range(500):
        g, roll = rng.uniform(-0.05, 1.25), rng.uniform(-0.015, 0.015)
        psi_dot, y_dot, speed, r0 = rng.normal(0, 0.05), rng.normal(0, 0.1), rng.uniform(5, 100), 0.46
        trig = math.cos(g), math.sin(g), s, math.cos(roll), math.sin(roll)
        _, xi_y, spin = _creepages(*trig, 0.0, 0.0, r0, y_dot, 0.0, psi_dot, speed)
        lateral, oracle = rolled_axle_creepages(g, s, roll, 0.0, psi_dot, y_dot, speed, r0)
        assert spin == pytest.approx(oracle, rel=1e-12, abs=1e-15)
        assert spin == pytest.approx(psi_dot * math.cos(g) / speed - s * math.sin(g - s * roll) / r0, abs=1e-15)
        assert xi_y == pytest.approx(lateral, rel=1e-12, abs=1e-15)
        psi = rng.uniform(-5e-3, 5e-3)
        _, xi_y, spin = _creepages(*trig, 0.0, 0.0, r0, y_dot, psi, psi_dot, speed)
        lateral, oracle = rolled_axle_creepages(g, s, roll, psi, psi_dot, y_dot, speed, r0)
        assert spin == pytest.approx(oracle, abs=psi**2 / r0)
        d = g - s * roll  # the neglected terms: the meridian's tilt by the yaw, both parts
        bound = abs(psi) * (1 + abs(math.tan(d) * math.tan(g))) / math.cos(d) + abs(y_dot / speed) / (
            math.cos(d) ** 2 * math.cos(g)
        )
        assert xi_y == pytest.approx(lateral, abs=psi**2 * bound)


def test_the_wheel_opposite_a_flange_spins_with_the_wheelsets_roll(coach):
    """On the flange (y = 8 mm: the wheelset rolled 8.6 mrad, left side up) at rest, linear law:
    every point's lateral creep force and spin moment are Kalker's -f23*spin and -f33*spin with
    spin = -s*sin(g - s*roll)/r0 from the table's own angles and roll. The wheel opposite the
    flange spins twice as fast as its track-frame angle alone would say (the finding against
    CONTACT)."""
    from rail_mj.contact.creep import _normal_loads

    table = tables.dynamics_table(coach)
    body = table[1:]
    i = int(np.argmin(np.abs(body[:, tables.Y] - 8.0)))
    row, r0 = body[i], table[0, tables.HEADER_R0] * M_PER_MM
    shear = table[0, tables.HEADER_SHEAR_MODULUS] * 1e9
    roll = row[tables.ROLL] * 1e-3
    axle = table[0, tables.HEADER_AXLE_LOAD] * N_PER_KN
    n_left, n_right, _, _ = _normal_loads(row, row, 0.0, row, row, 0.0, axle, r0, 0.0, False)
    lateral = moment = 0.0
    for side, (s, wheel) in enumerate(((1.0, n_left), (-1.0, n_right))):
        for slot in range(tables.SLOTS):
            at = lambda field, side=side, slot=slot: row[tables.point_column(side, slot, field)]  # noqa: E731
            normal = wheel * at(tables.WEIGHT)
            if normal <= 0:
                continue
            g = at(tables.ANGLE)
            ab = (normal / N_PER_KN) ** (2 / 3) * M_PER_MM**2 * at(tables.SEMI_A) * at(tables.SEMI_B)
            spin = -s * math.sin(g - s * roll) / r0
            lateral += -shear * ab**1.5 * at(tables.C23) * spin * math.cos(g)
            moment += -shear * ab**2 * at(tables.C33) * spin * math.cos(g)
            if s < 0:
                assert math.sin(g + roll) > 1.8 * math.sin(g) > 0  # 8.6 mrad on a 7 mrad tread
    f = forces_at(table, row[tables.Y] * M_PER_MM)
    assert roll == pytest.approx(8.6e-3, abs=0.1e-3)
    assert float(f.creep_lateral[0]) == pytest.approx(lateral, rel=1e-9)
    assert float(f.spin_moment[0]) == pytest.approx(moment, rel=1e-9)


def test_flange_points_carry_the_slender_coefficients(coach):
    """Every loaded point's Kalker coefficients are those of its own ellipse's a/b, beyond
    Kalker's table on the flange (a/b up to 24.5) as well: the slender extension, not the
    table's a/b = 10 row."""
    from rail_mj.contact.hertz import kalker_coefficients

    body = tables.dynamics_table(coach)[1:]
    slender = 0
    for side in range(2):
        for slot in range(tables.SLOTS):
            at = lambda field, side=side, slot=slot: body[:, tables.point_column(side, slot, field)]  # noqa: E731
            for k in np.flatnonzero(at(tables.WEIGHT) > 0):
                ratio = at(tables.SEMI_A)[k] / at(tables.SEMI_B)[k]
                expected = kalker_coefficients(max(ratio, 0.1), 0.28)
                got = {name: at(getattr(tables, name))[k] for name in expected}
                assert got == pytest.approx(expected, rel=1e-12)
                slender += ratio > 10
    assert slender >= 100  # both flanges, from 6.3 mm out
