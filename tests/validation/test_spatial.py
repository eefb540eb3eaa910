"""A spatial vehicle (docs/spatial.md): the model's stiffness about its static equilibrium, by
finite differences of MuJoCo's own forces, equals the one assembled by hand from the layout's
elements; a car body on its secondary springs has the closed-form bounce, pitch, yaw and the
lateral-roll (lower and upper sway) pair; the centred state is the static equilibrium; and a
planar layout is refused spatial elements (and the reverse) with one line."""

from __future__ import annotations

import copy
import tomllib

import mujoco
import numpy as np
import pytest
from conftest import DATA, MODELS
from scipy.linalg import eigh

from rail_mj.layout import LayoutError, layout_from_dict
from rail_mj.vehicle.spec import Vehicle

SPATIAL = tomllib.loads((DATA / "manchester-coach-spatial.toml").read_text())
G = 9.81


def dof(model, joint: str) -> int:
    return int(model.joint(joint).dofadr[0])


def point_motion_rows(model, body: str, r, has_vertical: bool) -> list[np.ndarray]:
    """The displacement (x, y, z) of the point at r from `body`'s centre of mass as rows over the
    model's dofs: translation + (roll, pitch, yaw) x r (docs/spatial.md); a wheelset (not
    `has_vertical`) only its lateral and yaw."""
    rx, ry, rz = r
    rows = [
        {"pitch": rz, "yaw": -ry},
        {"lateral": 1.0, "yaw": rx, "roll": -rz},
        {"vertical": 1.0, "roll": ry, "pitch": -rx},
    ]
    out = []
    for row in rows:
        a = np.zeros(model.nv)
        for m, c in row.items():
            if has_vertical or m in ("lateral", "yaw"):
                a[dof(model, f"{body}_{m}")] += c
        out.append(a)
    return out


def hand_stiffness(layout, model, kind="k") -> np.ndarray:
    """K = sum over elements, sides and axes of k * a a^T, a the deflection's coefficients: the
    upper body's point motion minus the lower's, each translation + (roll, pitch, yaw) x r, written
    here from docs/spatial.md alone (only the dof numbers are read from the model); each anti-roll
    bar k (e_body - e_frame)(...)^T on the roll coordinates; each bogie's axleboxes and wheelsets its
    own (`Spatial.bogies`, [bogies.N]). The bump stops, within their play about q = 0, add nothing.
    kind = "c": the damping matrix, sum c a a^T, the lateral and yaw dampers too."""
    sp, K = layout.spatial, np.zeros((model.nv, model.nv))

    def motion(body, r, has_vertical):
        return point_motion_rows(model, body, r, has_vertical)

    def element(point, lower, upper, e):
        (lo, lo_c, lo_full), (up, up_c, up_full) = lower, upper
        a_up = motion(up, np.subtract(point, up_c), up_full)
        a_lo = motion(lo, np.subtract(point, lo_c), lo_full)
        gains = e if isinstance(e, tuple) else (getattr(e, f"{kind}{axis}") for axis in "xyz")
        for a, b, k in zip(a_up, a_lo, gains):
            d = a - b
            K[:] += k * np.outer(d, d)

    hc, hb, r0 = sp.carbody_height, sp.bogie_height, layout.wheelset.rolling_radius
    n = len(layout.bogie.wheelset_positions)
    for i, (xb, bogie) in enumerate(zip(layout.carbody.bogie_positions, sp.bogies), start=1):
        frame = (f"bogie{i}", (xb, 0, hb), True)
        e = bogie.axlebox  # each bogie's own ([bogies.N])
        for j, xw in enumerate(bogie.wheelset_positions):
            w = (f"wheelset{(i - 1) * n + j + 1}", (xb + xw, 0, r0), False)
            for s in (1, -1):
                element((xb + xw, s * e.spacing, e.height), w, frame, e)
        for s in (1, -1):
            element(
                (xb, s * sp.secondary.spacing, sp.secondary.height), frame, ("carbody", (0, 0, hc), True), sp.secondary
            )
        body = ("carbody", (0, 0, hc), True)
        if kind == "c" and sp.lateral_damper:
            element((xb, 0, sp.lateral_damper.height), frame, body, (0.0, sp.lateral_damper.c, 0.0))
        if kind == "c" and sp.yaw_damper:
            e = sp.yaw_damper
            for s in (1, -1):
                element((xb, s * e.spacing, e.height), frame, body, (e.c, 0.0, 0.0))
        if kind == "k" and sp.anti_roll_bar:
            a = np.zeros(model.nv)
            a[dof(model, "carbody_roll")], a[dof(model, f"bogie{i}_roll")] = 1.0, -1.0
            K[:] += sp.anti_roll_bar * np.outer(a, a)
    return K


def fd_stiffness(model, step=1e-6) -> np.ndarray:
    """-d(generalised spring and gravity forces)/dq about q = 0, central differences."""
    data = mujoco.MjData(model)
    K = np.zeros((model.nv, model.nv))
    for j in range(model.nv):
        f = []
        for sign in (1.0, -1.0):
            mujoco.mj_resetData(model, data)
            data.qpos[j] = sign * step
            mujoco.mj_forward(model, data)
            f.append(data.qfrc_spring - data.qfrc_bias)
        K[:, j] = -(f[0] - f[1]) / (2 * step)
    return K


def mass_matrix(model) -> np.ndarray:
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return M


def assert_refused(data: dict, message: str) -> None:
    """`data` fails to load with a LayoutError matching `message`, in one line."""
    with pytest.raises(LayoutError, match=message) as e:
        layout_from_dict(data)
    assert "\n" not in str(e.value)


def planar_coach() -> dict:
    """The coach as a planar layout: its elements' planar equivalents as [primary] and [secondary]."""
    layout = layout_from_dict(copy.deepcopy(SPATIAL))
    data = {k: copy.deepcopy(v) for k, v in SPATIAL.items() if k not in ("spatial", "primary", "secondary")}
    for key, s in (("primary", layout.primary), ("secondary", layout.secondary)):
        data[key] = {"lateral_stiffness": s.lateral_stiffness, "yaw_stiffness": s.yaw_stiffness}
    layout_from_dict(copy.deepcopy(data))  # valid as it is
    return data


@pytest.fixture(scope="module")
def coach():
    """The coach with the tendons' stiffness alone; its gravitational stiffness is tested at the end."""
    data = copy.deepcopy(SPATIAL)
    data["spatial"]["gravitational_stiffness"] = False
    layout = layout_from_dict(data)
    return layout, Vehicle(layout)


def test_stiffness_matrix_is_the_hand_assembled_one(coach):
    layout, vehicle = coach
    model = vehicle.model
    assert model.nv == 2 * 5 + 5 + 4 * 2  # bogies and car body 5 each, wheelsets 2
    K_fd, K_hand = fd_stiffness(model), hand_stiffness(layout, model)
    assert np.abs(K_fd - K_fd.T).max() <= 1e-7 * np.abs(K_hand).max()
    assert np.abs(K_fd - K_hand).max() <= 1e-8 * np.abs(K_hand).max()


def test_centred_state_is_the_static_equilibrium(coach):
    _, vehicle = coach
    data = mujoco.MjData(vehicle.model)
    mujoco.mj_forward(vehicle.model, data)
    # The springs carry the weights: only the 6 figures the MJCF keeps of each spring length are left.
    assert np.abs(data.qacc).max() < 1e-3
    z = dof(vehicle.model, "carbody_vertical")
    force = data.qfrc_spring[z]
    assert force == pytest.approx(32000.0 * G, rel=1e-5)


def carbody_frequencies(vehicle) -> np.ndarray:
    """The car body's natural frequencies on its secondary springs, the bogie frames held still
    (the car-body block of K and M), Hz, ascending."""
    model = vehicle.model
    idx = [dof(model, f"carbody_{m}") for m in ("lateral", "yaw", "vertical", "roll", "pitch")]
    K, M = fd_stiffness(model), mass_matrix(model)
    w2 = eigh(K[np.ix_(idx, idx)], M[np.ix_(idx, idx)], eigvals_only=True)
    return np.sort(np.sqrt(w2) / (2 * np.pi))


def closed_forms(layout) -> np.ndarray:
    """Bounce, pitch, yaw, and the lateral-roll pair about the spring level (lower and upper sway):
    M = [[m, m h], [m h, Ix + m h^2]], K = [[ky, 0], [0, kphi - W h]], kphi = sum kz d^2 plus each
    bogie's anti-roll bar, W h = m g h the gravitational stiffness when the layout has it on (pitch
    too: all springs at one height)."""
    sp, c = layout.spatial, layout.carbody
    e, m, (Ix, Iy, Iz) = sp.secondary, c.mass, c.inertia
    n = 2 * len(c.bogie_positions)  # springs
    d, h = e.spacing, sp.carbody_height - e.height
    wh = m * G * h if sp.gravity and sp.gravitational_stiffness else 0.0
    l2 = sum(2 * x**2 for x in c.bogie_positions)  # sum over springs of x^2
    bounce = np.sqrt(n * e.kz / m)
    pitch = np.sqrt((e.kz * l2 + n * e.kx * h**2 - wh) / Iy)
    yaw = np.sqrt((e.ky * l2 + n * e.kx * d**2) / Iz)
    k_phi = n * e.kz * d**2 + len(c.bogie_positions) * (sp.anti_roll_bar or 0.0) - wh
    sway = eigh(np.diag([n * e.ky, k_phi]), np.array([[m, m * h], [m * h, Ix + m * h * h]]), eigvals_only=True)
    return np.sort(np.array([bounce, pitch, yaw, *np.sqrt(sway)]) / (2 * np.pi))


def test_carbody_modes_match_closed_forms(coach):
    layout, vehicle = coach
    expected = closed_forms(layout)
    assert carbody_frequencies(vehicle) == pytest.approx(expected, rel=1e-7)


def test_springs_at_the_centre_of_mass_uncouple_roll():
    """With the secondary springs at the car body's centre of mass: the issue's closed forms exactly,
    roll sqrt(sum kz d^2/Ix) and pitch sqrt(sum kz l^2/Iy)."""
    data = copy.deepcopy(SPATIAL)
    data["secondary"]["spring"]["height"] = data["spatial"]["carbody_height"]
    layout = layout_from_dict(data)
    f = carbody_frequencies(Vehicle(layout))
    e, (Ix, Iy, _) = layout.spatial.secondary, layout.carbody.inertia
    roll = np.sqrt(4 * e.kz * e.spacing**2 / Ix) / (2 * np.pi)
    pitch = np.sqrt(4 * e.kz * 9.5**2 / Iy) / (2 * np.pi)
    bounce = np.sqrt(4 * e.kz / 32000.0) / (2 * np.pi)
    for expected in (roll, pitch, bounce):
        assert np.min(np.abs(f - expected)) <= 1e-7 * expected


def test_gravity_off_leaves_the_stiffness(coach):
    _layout, vehicle = coach
    data = copy.deepcopy(SPATIAL)
    data["spatial"]["gravity"] = False
    other = Vehicle(layout_from_dict(data))
    assert np.allclose(fd_stiffness(other.model), fd_stiffness(vehicle.model), rtol=0, atol=1e-8 * 1e8)
    assert not other.model.tendon_lengthspring.any()


LOAD_ROUNDING = 5e-6  # relative: the static wheel loads from spring lengths kept to 6 figures


def one_height():
    """The spatial coach with every centre of mass and spring at one height, gravitational
    stiffness and gyroscopic terms off (the issue's "both off": the classical planar equations;
    the suspension's gravitational terms vanish at one height anyway), and the planar layout
    (as a dict) made of its elements' planar equivalents."""
    data = copy.deepcopy(SPATIAL)
    data["spatial"].update(carbody_height=1.0, bogie_height=1.0, gravitational_stiffness=False, gyroscopic=False)
    data["primary"]["axlebox"]["height"] = data["secondary"]["spring"]["height"] = 1.0
    layout = layout_from_dict(data)
    planar = {k: copy.deepcopy(v) for k, v in data.items() if k not in ("spatial", "primary", "secondary")}
    for key, s in (("primary", layout.primary), ("secondary", layout.secondary)):
        planar[key] = {
            "lateral_stiffness": s.lateral_stiffness,
            "yaw_stiffness": s.yaw_stiffness,
            "lateral_damping": s.lateral_damping,
            "yaw_damping": s.yaw_damping,
        }
    return layout, planar


def test_all_at_one_height_is_the_planar_model():
    """Centres of mass and springs all at one height: the lateral and yaw motions part from the
    vertical ones, and the eigenvalues of the planar layout made of the elements' planar
    equivalents are all among the spatial model's (the vertical modes besides)."""
    from rail_mj.analysis.stability import Stability

    layout, planar = one_height()
    spatial = Stability(layout).eigenvalues(30.0)
    for lam in Stability(layout_from_dict(planar)).eigenvalues(30.0):
        # The spatial wheels carry the loads their preloaded springs give, the spring lengths
        # kept to the MJCF's 6 significant figures (docs/spatial.md): loads within 5e-6 of the
        # planar static share, Kalker's coefficients (as load^(2/3)) within 3.4e-6.
        assert np.min(np.abs(spatial - lam)) <= LOAD_ROUNDING * abs(lam)
    assert len(spatial) > len(Stability(layout_from_dict(planar)).eigenvalues(30.0))


def test_mode_names():
    """The car body's bounce, pitch, yaw and its two sways, lower (roll centre below the centre of
    mass) at the lower frequency; the frames' bounce and pitch."""
    from rail_mj.analysis.stability import Stability

    modes = Stability(layout_from_dict(copy.deepcopy(SPATIAL))).modes(30.0)
    names = {m.name for m in modes}
    for name in ("car body bounce", "car body pitch", "car body yaw", "car body lower sway", "car body upper sway"):
        assert name in names
    assert any(n.endswith("frame bounce") for n in names) and any(n.endswith("frame pitch") for n in names)
    frequency = {m.name: m.frequency for m in sorted(modes, key=lambda m: -m.frequency)}  # lowest of each name
    assert frequency["car body lower sway"] < frequency["car body upper sway"]
    for speed in (30.0, 60.0):  # a hunting bogie dragging the body is not a car-body mode
        for m in Stability(layout_from_dict(copy.deepcopy(SPATIAL))).modes(speed):
            assert m.name.startswith("car body") == (m.participation["carbody"] >= 0.5), (m.name, m.participation)


def test_planar_equivalent(coach):
    layout, _ = coach
    assert layout.primary.lateral_stiffness == 2 * 3884e3
    assert layout.primary.yaw_stiffness == 2 * 31391e3
    assert layout.secondary.lateral_damping == 2 * 32e3


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d.pop("spatial"), r"primary\.axlebox: needs \[spatial\]"),
        (
            lambda d: d["primary"].update(lateral_stiffness=1.0),
            r"primary\.lateral_stiffness: not used with \[spatial\]",
        ),
        (lambda d: d["primary"]["axlebox"].pop("kz"), r"primary\.axlebox\.kz: missing"),
        (lambda d: d["secondary"]["spring"].update(height=-1.0), r"secondary\.spring\.height: must be > 0"),
        (lambda d: d["secondary"]["spring"].update(spacing=7.0), r"secondary\.spring\.spacing: must be <= 2\.5"),
        (lambda d: d["spatial"].update(carbody_height=0.5), r"spatial\.carbody_height: must not be below bogie_height"),
        (lambda d: d["spatial"].update(heigth=0.5), r"spatial\.heigth: unknown key"),
        (lambda d: d["carbody"].update(fixed=True), r"spatial: needs a free car body"),
        # kN/m for N/m: a 78 km sag, the car body far below the rail.
        (lambda d: d["secondary"]["spring"].update(kz=430.0), r"secondary\.spring\.kz: the static deflection"),
        (lambda d: d["primary"]["axlebox"].update(kz=1220.0), r"primary\.axlebox\.kz: the static deflection"),
        (lambda d: d.update(bogies={"2": {"axlebox": {"kz": 1.0}}}), r"bogies\.2\.axlebox\.kz: the static deflection"),
        # m*g*h 1.16 MN m/rad over springs giving 0.155: the body tips over.
        (
            lambda d: (d["spatial"].update(carbody_height=4.5), d["secondary"]["spring"].update(spacing=0.3)),
            r"spatial\.carbody_height: carbody tips over on its springs",
        ),
    ],
)
def test_bad_spatial_layouts_fail_with_one_line(edit, message):
    data = copy.deepcopy(SPATIAL)
    edit(data)
    assert_refused(data, message)


@pytest.mark.parametrize("speed", [10.0, 30.0, 60.0])
def test_mode_names_at_one_height_are_the_planar_ones(speed):
    """All at one height, each planar mode is among the spatial ones (above) and carries the
    planar model's name there: the spatial names add the vertical and roll modes, they do not
    rename the hunting ones."""
    from rail_mj.analysis.stability import Stability

    layout, planar = one_height()
    spatial = Stability(layout).modes(speed)
    for mode in Stability(layout_from_dict(planar)).modes(speed):
        twin = min(spatial, key=lambda m: abs(m.eigenvalue - mode.eigenvalue))
        assert abs(twin.eigenvalue - mode.eigenvalue) <= LOAD_ROUNDING * abs(mode.eigenvalue)
        # Which of two bogies (or wheelsets) a symmetric pair is named after is a tie broken by
        # round-off; the kind of mode is not.
        kind = lambda name: "".join(c for c in name if not c.isdigit())  # noqa: E731
        assert kind(twin.name) == kind(mode.name), (mode.frequency, mode.name, twin.name)


# --- the secondary elements besides the springs: dampers, anti-roll bar, bump stop ------------------

# The Manchester benchmark coach's lateral stop: 25 mm free play, then its force table.
MANCHESTER_STOP = {
    "free_play": 0.025,
    "deflection": [0.030, 0.035, 0.040, 0.045, 0.050, 0.055, 0.060, 0.065],
    "force": [0.6e3, 1.76e3, 3.73e3, 6.87e3, 11.58e3, 17.17e3, 29.2e3, 230e3],
    "height": 1.0,
}
ELEMENTS = {
    "lateral_damper": {"c": 30e3, "height": 1.1},
    "yaw_damper": {"c": 250e3, "spacing": 1.3, "height": 0.9},
    "anti_roll_bar": {"stiffness": 2.0e6},
    "bump_stop": MANCHESTER_STOP,
}


def with_elements(**tables) -> dict:
    data = copy.deepcopy(SPATIAL)
    data["secondary"].update(copy.deepcopy(tables))
    return data


@pytest.fixture(scope="module")
def fitted():
    layout = layout_from_dict(with_elements(**ELEMENTS))
    return layout, Vehicle(layout)


def fd_damping(model) -> np.ndarray:
    """-d(qfrc_damper)/dqvel at q = 0, each column the difference from rest (zero damper force) to a
    unit velocity along one coordinate: exact, MuJoCo's damper forces being linear in qvel."""
    data = mujoco.MjData(model)
    D = np.zeros((model.nv, model.nv))
    for j in range(model.nv):
        mujoco.mj_resetData(model, data)
        data.qvel[j] = 1.0
        mujoco.mj_forward(model, data)
        D[:, j] = -data.qfrc_damper
    return D


def test_damping_matrix_is_the_hand_assembled_one(fitted):
    """MuJoCo's damping matrix, every damper a tendon at its place, equals sum c a a^T from the
    layout, the lateral and yaw dampers included (1e-8 of the largest entry); without them the hand
    assembly is a different matrix, so the comparison sees them."""
    layout, vehicle = fitted
    model = vehicle.model
    D_fd, D_hand = fd_damping(model), hand_stiffness(layout, model, kind="c")
    assert np.abs(D_fd - D_hand).max() <= 1e-8 * np.abs(D_hand).max()
    springs_only = hand_stiffness(layout_from_dict(copy.deepcopy(SPATIAL)), model, kind="c")
    assert np.abs(D_hand - springs_only).max() > 0.1 * np.abs(D_hand).max()
    # The planar equivalents carry them: lateral c, yaw 2 c d^2, besides the springs' dampers.
    e, yaw = layout.spatial.secondary, layout.spatial.yaw_damper
    assert layout.secondary.lateral_damping == pytest.approx(2 * e.cy + 30e3, rel=1e-15)
    assert layout.secondary.yaw_damping == pytest.approx(
        2 * e.cx * e.spacing**2 + 2 * yaw.c * yaw.spacing**2, rel=1e-15
    )


def test_anti_roll_bar_stiffness_and_sway(fitted):
    """With an anti-roll bar (and the stops, idle about q = 0): the finite-difference stiffness is
    the hand-assembled one, bars included (1e-8); q = 0 stays the static equilibrium; and the car
    body's lateral-roll pair, frames held, has kphi = sum kz d^2 + n_bogies k_bar (1e-7), which moves
    the upper sway by more than 1 % from the bar-less coach's."""
    layout, vehicle = fitted
    model = vehicle.model
    # The preloads' gravitational stiffness (on by default) besides the tendons (the coach is
    # symmetric, as hand_gravitational_stiffness needs).
    K_fd, K_hand = fd_stiffness(model), hand_stiffness(layout, model) + hand_gravitational_stiffness(layout, model)
    assert np.abs(K_fd - K_hand).max() <= 1e-8 * np.abs(K_hand).max()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert np.abs(data.qacc).max() < 1e-3  # as the bare coach: the 6 figures of the spring lengths
    expected = closed_forms(layout)
    assert carbody_frequencies(vehicle) == pytest.approx(expected, rel=1e-7)
    bare = closed_forms(layout_from_dict(copy.deepcopy(SPATIAL)))
    assert np.abs(expected - bare).max() > 0.01 * expected.max()


def stop_force(stop, d: np.ndarray) -> np.ndarray:
    """The stop's force at deflection d (either sign) from its layout table: zero within the play,
    numpy.interp through (free_play, 0) and the table, the last slope beyond it."""
    xp, fp = np.array([stop.free_play, *stop.deflection]), np.array([0.0, *stop.force])
    a = np.abs(d)
    beyond = np.maximum(a - xp[-1], 0.0) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
    return np.sign(d) * (np.interp(a, xp, fp) + beyond)


@pytest.mark.parametrize(
    "stop",
    [
        MANCHESTER_STOP,
        # a falling slope (a negative deadband stiffness) and no free play (the first spring linear)
        {"free_play": 0.01, "deflection": [0.02, 0.04, 0.05], "force": [1.0e3, 1.5e3, 9.0e3], "height": 0.7},
        {"free_play": 0.0, "deflection": [0.01, 0.03], "force": [500.0, 4.0e3], "height": 1.2},
    ],
    ids=["manchester", "falling-slope", "no-play"],
)
def test_bump_stop_force_is_the_table(stop):
    """The car body moved laterally against the held frames: each frame's lateral passive force is
    its two springs' 2 ky d plus the stop's table force (1e-9 relative, 1e-9 N at zero), within the
    play, at every breakpoint and midway, and 5 mm beyond the table, both ways; at q = 0 the stops
    carry nothing (the forces are the stopless coach's, 1e-12) and keep their deadbands."""
    data = with_elements(bump_stop=stop)
    layout, bare = layout_from_dict(data), Vehicle(layout_from_dict(copy.deepcopy(SPATIAL)))
    vehicle = Vehicle(layout)
    model, e = vehicle.model, layout.spatial.bump_stop
    run = mujoco.MjData(model)
    mujoco.mj_forward(model, run)
    rest = mujoco.MjData(bare.model)
    mujoco.mj_forward(bare.model, rest)
    assert np.abs(run.qfrc_spring - rest.qfrc_spring).max() <= 1e-12 * np.abs(rest.qfrc_spring).max()
    for i, (play, _) in enumerate(e.deadbands(), start=1):
        for bogie in ("bogie1", "bogie2"):
            t = model.tendon(f"{bogie}_carbody_bump_stop_{i}")
            assert run.ten_length[t.id] == 0.0
            if play > 0:
                assert list(model.tendon_lengthspring[t.id]) == [-play, play]
    xp = [e.free_play, *e.deflection]
    points = [0.0, 0.8 * e.free_play, *xp, *((a + b) / 2 for a, b in zip(xp, xp[1:])), xp[-1] + 0.005]
    ky = layout.spatial.secondary.ky
    for d in sorted({s * p for p in points for s in (1.0, -1.0)}):
        mujoco.mj_resetData(model, run)
        run.qpos[dof(model, "carbody_lateral")] = d
        mujoco.mj_forward(model, run)
        expected = 2 * ky * d + stop_force(e, np.array(d))
        for bogie in ("bogie1", "bogie2"):
            got = run.qfrc_spring[dof(model, f"{bogie}_lateral")]
            assert abs(got - expected) <= 1e-9 * abs(expected) + 1e-9, (d, bogie, got, expected)


def test_manchester_stop_breakpoints():
    """The deadband springs of the benchmark's stop: one per breakpoint from the free play on, each
    the rise of slope there (the table's slopes 120, 232, 394, ... kN/m, exact to 1e-9)."""
    layout = layout_from_dict(with_elements(bump_stop=MANCHESTER_STOP))
    bands = layout.spatial.bump_stop.deadbands()
    d = [0.025, *MANCHESTER_STOP["deflection"]]
    f = [0.0, *MANCHESTER_STOP["force"]]
    slopes = np.diff(f) / np.diff(d)
    assert [b[0] for b in bands] == d[:-1]
    assert np.allclose(np.cumsum([b[1] for b in bands]), slopes, rtol=1e-9, atol=0)
    assert slopes[0] == pytest.approx(120e3, rel=1e-9)


def test_coach_without_the_elements_is_unchanged(coach):
    layout, vehicle = coach
    assert vehicle.model.ntendon == 36
    assert layout.secondary == layout.spatial.secondary.planar()
    assert (
        layout.spatial.lateral_damper,
        layout.spatial.yaw_damper,
        layout.spatial.anti_roll_bar,
        layout.spatial.bump_stop,
    ) == (None, None, None, None)


def _stop(**changes):
    return lambda d: d["secondary"]["bump_stop"].update(changes)


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            _stop(deflection=[0.03, 0.04, 0.035, 0.045, 0.05, 0.055, 0.06, 0.065]),
            r"secondary\.bump_stop\.deflection: must increase strictly",
        ),
        (
            _stop(deflection=[0.025, 0.035, 0.04, 0.045, 0.05, 0.055, 0.06, 0.065]),
            r"secondary\.bump_stop\.deflection: must start beyond free_play \(0\.025 m\)",
        ),
        (_stop(deflection=[30, 35, 40, 45, 50, 55, 60, 65]), r"secondary\.bump_stop\.deflection: must be <= 0\.5 m"),
        (_stop(force=[0.6e3, 1.76e3]), r"secondary\.bump_stop\.force: must give one force per deflection"),
        (
            _stop(force=[-0.6e3, 1.76e3, 3.73e3, 6.87e3, 11.58e3, 17.17e3, 29.2e3, 230e3]),
            r"secondary\.bump_stop\.force: must be >= 0",
        ),
        (
            _stop(force=[0.6e3, 1.76e3, 3.73e3, 6.87e3, 11.58e3, 17.17e3, 29.2e3, 20e3]),
            r"secondary\.bump_stop\.force: must not decrease",
        ),
        (_stop(free_play=-0.001), r"secondary\.bump_stop\.free_play: must be >= 0"),
        (_stop(force="230 kN"), r"secondary\.bump_stop\.force: must be a non-empty list"),
        (_stop(deflection=[0.03, "0.035"]), r"secondary\.bump_stop\.deflection: must hold numbers"),
        (lambda d: d["secondary"]["bump_stop"].pop("height"), r"secondary\.bump_stop\.height: missing"),
        (lambda d: d["secondary"]["lateral_damper"].update(c=0.0), r"secondary\.lateral_damper\.c: must be > 0"),
        (
            lambda d: d["secondary"]["lateral_damper"].update(spacing=1.0),
            r"secondary\.lateral_damper\.spacing: unknown key",
        ),
        (
            lambda d: d["secondary"]["yaw_damper"].update(spacing=3.0),
            r"secondary\.yaw_damper\.spacing: must be <= 2\.5",
        ),
        (lambda d: d["secondary"]["yaw_damper"].update(cc=1.0), r"secondary\.yaw_damper\.cc: unknown key"),
        (
            lambda d: d["secondary"]["anti_roll_bar"].update(stiffness=-1.0),
            r"secondary\.anti_roll_bar\.stiffness: must be > 0",
        ),
        (lambda d: d["secondary"].update(lateral_dampr={"c": 1.0}), r"secondary\.lateral_dampr: unknown element table"),
    ],
)
def test_bad_secondary_elements_fail_with_one_line(edit, message):
    data = with_elements(**ELEMENTS)
    edit(data)
    with pytest.raises(LayoutError, match=message) as e:
        layout_from_dict(data)
    assert "\n" not in str(e.value)


# Gravitational stiffness (docs/spatial.md): the preloads' second-order potential as roll and pitch
# stiffness of the car body and the bogie frames; `spatial.gravitational_stiffness`, default on.


@pytest.fixture(scope="module")
def coach_gravitational():
    layout = layout_from_dict(copy.deepcopy(SPATIAL))
    assert layout.spatial.gravitational_stiffness  # the default
    return layout, Vehicle(layout)


def hand_gravitational_stiffness(layout, model) -> np.ndarray:
    """The geometric terms from the weights alone, for a layout symmetric left-right with two bogies,
    each symmetric fore-aft, and either the whole vehicle symmetric fore-aft (the coach) or no
    longitudinal springs (else a static pitch loads them): bogie i takes W_i of the car body's
    weight by the lever rule, each of its secondary springs P_s = W_i / 2, each of its axleboxes
    P_p = (W_i + m_b,i g) / n_p; an element adds -P (H_upper - z) to its upper body's roll and pitch,
    -P (z - H_lower) to its lower body's; wheelsets have neither."""
    sp, c = layout.spatial, layout.carbody
    (x1, x2), W = c.bogie_positions, c.mass * G
    z_s, hc, hb = sp.secondary.height, sp.carbody_height, sp.bogie_height
    terms = {"carbody": -W * (hc - z_s)}
    for i, (share, bogie) in enumerate(zip((-x2 / (x1 - x2), x1 / (x1 - x2)), sp.bogies), start=1):
        n_p = 2 * len(bogie.wheelset_positions)  # axleboxes
        P_s, P_p = share * W / 2, (share * W + bogie.mass * G) / n_p
        terms[f"bogie{i}"] = -2 * P_s * (z_s - hb) - n_p * P_p * (hb - bogie.axlebox.height)
    K = np.zeros((model.nv, model.nv))
    for body, k in terms.items():
        for motion in ("roll", "pitch"):
            K[dof(model, f"{body}_{motion}"), dof(model, f"{body}_{motion}")] = k
    return K


def test_gravitational_stiffness_is_the_hand_one(coach_gravitational):
    """FD stiffness = the tendons' sum k a a^T + the hand terms, to 1e-8 of the largest entry (the
    MJCF's 6 figures of each spring length leave ~1e-6 of a term, ~3e-9 of the largest); the car
    body's roll term is -m g h to 1e-5."""
    layout, vehicle = coach_gravitational
    model = vehicle.model
    K_fd, K_hand = fd_stiffness(model), hand_stiffness(layout, model)
    K_g = hand_gravitational_stiffness(layout, model)
    assert np.abs(K_fd - K_fd.T).max() <= 1e-7 * np.abs(K_hand).max()
    assert np.abs(K_fd - K_hand - K_g).max() <= 1e-8 * np.abs(K_hand).max()
    roll = dof(model, "carbody_roll")
    h = layout.spatial.carbody_height - layout.spatial.secondary.height
    assert K_fd[roll, roll] - K_hand[roll, roll] == pytest.approx(-32000.0 * G * h, rel=1e-5)


def test_gravitational_stiffness_keeps_the_equilibrium(coach_gravitational):
    """The terms act about q = 0 and so give no force there: the centred state stays the static
    equilibrium, as without them (1e-3, the 6 figures of the spring lengths)."""
    _, vehicle = coach_gravitational
    data = mujoco.MjData(vehicle.model)
    mujoco.mj_forward(vehicle.model, data)
    assert np.abs(data.qacc).max() < 1e-3


def test_carbody_modes_with_gravitational_stiffness(coach, coach_gravitational):
    """Frames held, the closed forms with k_phi - m g h in the lateral-roll pair and - m g h in pitch
    to 1e-7, as without (measured 4e-8: the MJCF's 6 figures of the joint stiffness; 4e-12 without);
    bounce and yaw are those without (1e-7); both sways and pitch lower."""
    layout, vehicle = coach_gravitational
    f_on, f_off = carbody_frequencies(vehicle), carbody_frequencies(coach[1])
    assert f_on == pytest.approx(closed_forms(layout), rel=1e-7)
    assert f_off == pytest.approx(closed_forms(coach[0]), rel=1e-7)
    bounce = np.sqrt(4 * layout.spatial.secondary.kz / 32000.0) / (2 * np.pi)
    for f in (f_on, f_off):
        assert np.min(np.abs(f - bounce)) <= 1e-7 * bounce
    unchanged = [f for f in f_on if np.min(np.abs(f_off - f)) <= 1e-7 * f]
    assert len(unchanged) == 2  # bounce and yaw
    assert np.all(f_on <= f_off * (1 + 1e-7))  # both ascending: sways, pitch lower, the rest kept


def test_gravitational_stiffness_is_zero_at_one_height():
    """All at one height every h is zero, and so every suspension term (the switch also brings in
    the cones' normal forces, which the planar-limit tests above switch off)."""
    data = copy.deepcopy(SPATIAL)
    data["spatial"].update(carbody_height=1.0, bogie_height=1.0)
    data["primary"]["axlebox"]["height"] = data["secondary"]["spring"]["height"] = 1.0
    layout = layout_from_dict(data)
    assert layout.spatial.gravitational_stiffness
    model = Vehicle(layout).model
    assert model.tendon_lengthspring.any() and not model.jnt_stiffness.any()


def test_gravitational_stiffness_must_be_a_boolean():
    data = copy.deepcopy(SPATIAL)
    data["spatial"]["gravitational_stiffness"] = "yes"
    with pytest.raises(LayoutError, match=r"spatial\.gravitational_stiffness: must be true or false") as e:
        layout_from_dict(data)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("table", sorted(ELEMENTS))
def test_secondary_elements_need_spatial(table):
    """A planar layout (the coach's planar equivalents) refuses each element table in one line."""
    data = planar_coach()
    data["secondary"][table] = copy.deepcopy(ELEMENTS[table])
    assert_refused(data, rf"secondary\.{table}: needs \[spatial\]")


def test_preload_leaves_out_the_deadband_tendons():
    """preload on a body hanging on a spring (k) beside a stiffer deadband spring whose play it does
    not reach: the sag is m g / k alone (1e-6, the 6 figures of a spring length), so q = 0 is the
    equilibrium, and the deadband is kept. (A lateral stop on the coach cannot show this: gravity
    has no lateral part.)"""
    from rail_mj.vehicle.statics import preload

    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="b", mass=2.0, inertia=[1.0, 1.0, 1.0])
    body.add_joint(name="z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
    for name, k, play in (("spring", 1.0e3, 0.0), ("stop", 1.0e5, 0.5)):
        tendon = spec.add_tendon(name=name, stiffness=[k, 0, 0], springlength=[-play, play])
        tendon.wrap_joint("z", 1.0)
    q_eq = preload(spec, spec.compile())
    assert q_eq[0] == pytest.approx(-2.0 * G / 1.0e3, rel=1e-12)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert abs(data.qacc[0]) <= 1e-6 * G
    assert list(model.tendon_lengthspring[model.tendon("stop").id]) == [-0.5, 0.5]


def test_gravitational_stiffness_is_the_drop_of_the_attachment_points(coach_gravitational):
    """The derivation against MuJoCo's exact kinematics: each element's static force P held vertical
    and constant at its attachment point on each body, V = sum of P*(z_lower - z_upper) with the
    points moved by the bodies' true rotations; its Hessian over the car body's and frames' roll,
    pitch and yaw (central differences, 1e-3 rad: truncation ~1e-6) is diagonal, roll and pitch
    only, and equals the joints' stiffness to 1e-5 of the largest (the MJCF's 6 figures: 2e-6)."""
    from rail_mj.vehicle.spatial import spatial_elements

    layout, vehicle = coach_gravitational
    model, data = vehicle.model, mujoco.MjData(vehicle.model)
    force = {
        model.tendon(t).name: model.tendon_stiffness[t] * model.tendon_lengthspring[t, 0] for t in range(model.ntendon)
    }
    elements = [
        (force[f"{name}_z"], np.array(point), lower[0], upper[0])
        for name, point, lower, upper, _ in spatial_elements(layout)
    ]
    mujoco.mj_kinematics(model, data)
    arm = {b: {} for b in ("carbody", "bogie1", "bogie2")}  # point's offset from the centre of mass at q = 0
    for k, (_, point, lower, upper) in enumerate(elements):
        for body in (lower, upper):
            if body in arm:
                arm[body][k] = point - data.body(body).xipos

    def potential(qpos):
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        V = 0.0
        for k, (P, _, lower, upper) in enumerate(elements):
            for body, sign in ((lower, 1.0), (upper, -1.0)):
                if body in arm:
                    b = data.body(body)
                    V += sign * P * (b.xipos + b.ximat.reshape(3, 3) @ arm[body][k])[2]
        return V

    dofs = [dof(model, f"{b}_{m}") for b in arm for m in ("roll", "pitch", "yaw")]
    step, H = 1e-3, np.zeros((len(dofs), len(dofs)))
    for i, a in enumerate(dofs):
        for j, b in enumerate(dofs):
            V = []
            for sa, sb in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                q = np.zeros(model.nq)
                q[model.jnt_qposadr[model.dof_jntid[a]]] += sa * step
                q[model.jnt_qposadr[model.dof_jntid[b]]] += sb * step
                V.append(potential(q))
            H[i, j] = (V[0] - V[1] - V[2] + V[3]) / (4 * step * step)
    expected = np.diag([model.jnt_stiffness[model.dof_jntid[d]] for d in dofs])
    assert np.abs(expected).max() > 3e5 and not expected[2::3, 2::3].any()  # yaw takes nothing
    assert np.abs(H - expected).max() <= 1e-5 * np.abs(expected).max()


# --- the shipped spatial coach (models/manchester-coach-spatial) ---------------------------------

SHIPPED_SPATIAL = MODELS / "manchester-coach-spatial" / "manchester-coach-spatial.toml"


def test_shipped_coach_carbody_modes_match_closed_forms():
    """The shipped coach (gravitational stiffness on, bump stops idle at the centre): the car body
    on its secondary springs, frames held, has the closed-form bounce, pitch, yaw and sways with
    -m g h (1e-7, the MJCF's 6 figures: 4e-8)."""
    from rail_mj.layout import load_layout

    layout = load_layout(SHIPPED_SPATIAL)
    assert layout.spatial.gravitational_stiffness and layout.spatial.bump_stop is not None
    assert carbody_frequencies(Vehicle(layout)) == pytest.approx(closed_forms(layout), rel=1e-7)


def test_shipped_coach_bounce_is_the_two_mass_chain():
    """The whole coach's car body bounce, as `eigen` names it: bounce couples with nothing lateral
    (the wheelsets' vertical motion is the rails'), and by symmetry the frames bounce in phase under
    it, so it is a root of the two-mass chain, car body m_c on the secondary (4 kz, 4 cz) over the
    frames 2 m_b on the primary (8 kz, 8 cz): (M s^2 + C s + K) v = 0, damping included (1e-7: the
    finite-difference linearisation, rail_mj.simulation.linear, gives 6e-9)."""
    from rail_mj.analysis.stability import Stability
    from rail_mj.layout import load_layout

    layout = load_layout(SHIPPED_SPATIAL)
    sp, c, b = layout.spatial, layout.carbody, layout.bogie
    n_s = 2 * len(c.bogie_positions)
    n_p = 2 * layout.n_wheelsets
    M = np.diag([c.mass, len(c.bogie_positions) * b.mass])
    chain = lambda k_s, k_p: np.array([[k_s, -k_s], [-k_s, k_s + k_p]])  # noqa: E731
    K = chain(n_s * sp.secondary.kz, n_p * sp.primary.kz)
    C = chain(n_s * sp.secondary.cz, n_p * sp.primary.cz)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    roots = np.linalg.eigvals(A)
    modes = Stability(layout).modes(30.0)
    bounce = [m for m in modes if m.name == "car body bounce"]
    assert len(bounce) == 1
    closest = roots[np.argmin(np.abs(roots - bounce[0].eigenvalue))]
    assert abs(bounce[0].eigenvalue - closest) <= 1e-7 * abs(closest)
    # ... the lower root of the chain (the frames' own bounce is the upper one, 7.2 Hz)
    assert abs(closest.imag) == pytest.approx(np.min(np.abs(roots.imag)), rel=1e-12)


# --- different bogies under one car body ([bogies.N], docs/spatial.md) ---------------------------

# The trailing bogie a motor bogie: a heavier frame and stiffer axleboxes, placed wider and higher
# (made-up numbers, each unlike [bogie]'s and [primary.axlebox]'s).
MOTOR_BOGIE = {
    "mass": 3400.0,
    "inertia": [2200.0, 1900.0, 3900.0],
    "axlebox": {"kz": 1500e3, "ky": 5.0e6, "cz": 6e3, "spacing": 1.05, "height": 0.5},
}


def different_bogies(gravitational_stiffness: bool = True, longitudinal: bool = True, **bogie2) -> dict:
    """The coach with bogie 2 the motor bogie (and `bogie2`'s keys besides); `longitudinal` False:
    no longitudinal springs (kx = 0), which a static pitch would load."""
    data = copy.deepcopy(SPATIAL)
    data["bogies"] = {"2": copy.deepcopy(MOTOR_BOGIE) | bogie2}
    data["spatial"]["gravitational_stiffness"] = gravitational_stiffness
    if not longitudinal:
        data["primary"]["axlebox"]["kx"] = data["secondary"]["spring"]["kx"] = 0.0
    return data


def test_different_bogies_layout():
    """bogie 2 has its overrides and inherits the rest ([bogie], [primary.axlebox]); bogie 1 and
    Layout.bogie keep the defaults; the wheelsets sit where each bogie puts them."""
    layout = layout_from_dict(different_bogies(wheelset_positions=[1.4, -1.4]))
    first, second = layout.spatial.bogies
    default = layout.spatial.primary
    assert (first.mass, first.inertia, first.wheelset_positions, first.axlebox) == (
        2615.0,
        (1722.0, 1476.0, 3067.0),
        (1.28, -1.28),
        default,
    )
    assert (second.mass, second.inertia, second.wheelset_positions) == (3400.0, (2200.0, 1900.0, 3900.0), (1.4, -1.4))
    assert (second.axlebox.kz, second.axlebox.ky, second.axlebox.cz, second.axlebox.spacing, second.axlebox.height) == (
        1500e3,
        5.0e6,
        6e3,
        1.05,
        0.5,
    )
    assert (second.axlebox.kx, second.axlebox.cx, second.axlebox.cy) == (default.kx, default.cx, default.cy)
    assert layout.bogie.mass == 2615.0 and layout.bogie.wheelset_positions == (1.28, -1.28)
    assert layout.wheelset_x == (9.5 + 1.28, 9.5 - 1.28, -9.5 + 1.4, -9.5 - 1.4)
    model = Vehicle(layout).model
    for i, x in enumerate(layout.wheelset_x, start=1):
        assert model.body(f"wheelset{i}").pos[0] == pytest.approx(x, abs=1e-12)
    assert model.body("bogie2").mass[0] == 3400.0 and list(model.body("bogie2").inertia) == [2200.0, 1900.0, 3900.0]
    assert model.body("bogie1").mass[0] == 2615.0


def test_bogies_repeating_the_defaults_give_the_same_model():
    """A [bogies.2] that only repeats [bogie] and [primary.axlebox] gives the very MJCF of the
    layout without it."""
    data = copy.deepcopy(SPATIAL)
    data["bogies"] = {"2": {"mass": 2615.0, "axlebox": {"kz": 1220e3, "height": 0.46}}}
    plain, same = (Vehicle(layout_from_dict(d)) for d in (copy.deepcopy(SPATIAL), data))
    assert same.spec.to_xml() == plain.spec.to_xml()


@pytest.mark.parametrize("gravitational", [False, True], ids=["tendons", "gravitational"])
def test_different_bogies_stiffness_is_the_hand_assembled_one(gravitational):
    """Bogie 2 heavier, stiffer, its axleboxes wider and higher: the finite-difference stiffness is the
    hand-assembled sum k a a^T with each bogie's own elements (1e-8 of the largest entry, as the
    coach's), and with the gravitational stiffness on (no longitudinal springs, which the car body's
    static pitch over unequal frames' sag would load) the hand terms with each bogie's share of the
    car body by the lever rule, its own weight and axlebox height (1e-8). The per-bogie elements
    matter: the coach's own hand assembly misses bogie 2's bounce stiffness by more than 10 %."""
    layout = layout_from_dict(different_bogies(gravitational, longitudinal=not gravitational))
    model = Vehicle(layout).model
    K_fd, K_hand = fd_stiffness(model), hand_stiffness(layout, model)
    if gravitational:
        K_hand = K_hand + hand_gravitational_stiffness(layout, model)
    assert np.abs(K_fd - K_hand).max() <= 1e-8 * np.abs(K_hand).max()
    data = copy.deepcopy(SPATIAL)
    if gravitational:
        data["primary"]["axlebox"]["kx"] = data["secondary"]["spring"]["kx"] = 0.0
    coach_hand = hand_stiffness(layout_from_dict(data), model)
    z = dof(model, "bogie2_vertical")
    assert abs(K_fd[z, z] - coach_hand[z, z]) > 0.1 * K_fd[z, z]


def frame_frequencies(vehicle, bogie: str) -> np.ndarray:
    """A bogie frame's natural frequencies with the car body and the wheelsets held (its block of K
    and M), Hz, ascending."""
    model = vehicle.model
    idx = [dof(model, f"{bogie}_{m}") for m in ("lateral", "yaw", "vertical", "roll", "pitch")]
    K, M = fd_stiffness(model), mass_matrix(model)
    w2 = eigh(K[np.ix_(idx, idx)], M[np.ix_(idx, idx)], eigvals_only=True)
    return np.sort(np.sqrt(w2) / (2 * np.pi))


def test_different_bogies_frame_bounce():
    """Each frame alone, car body and wheelsets held: its bounce is sqrt(sum kz / m_b) over the
    vertical springs on it, its own four axleboxes and its two secondary springs (a frame symmetric
    fore-aft and left-right: bounce couples with nothing), to 1e-7: 7.4566 Hz for bogie 1 and
    7.1490 Hz for the motor bogie. In the whole vehicle each is named a frame bounce, the motor
    bogie's lower."""
    from rail_mj.analysis.stability import Stability

    layout = layout_from_dict(different_bogies())
    vehicle = Vehicle(layout)
    ks = layout.spatial.secondary.kz
    expected = {}
    for i, bogie in enumerate(layout.spatial.bogies, start=1):
        kz = 2 * len(bogie.wheelset_positions) * bogie.axlebox.kz + 2 * ks
        expected[i] = np.sqrt(kz / bogie.mass) / (2 * np.pi)
        f = frame_frequencies(vehicle, f"bogie{i}")
        assert np.min(np.abs(f - expected[i])) <= 1e-7 * expected[i], (i, f, expected[i])
    assert expected[1] == pytest.approx(7.4566, abs=1e-4) and expected[2] == pytest.approx(7.1490, abs=1e-4)
    modes = Stability(layout).modes(30.0)
    bounce = {m.name: m.frequency for m in modes if m.name.endswith("frame bounce")}
    assert set(bounce) == {"bogie 1 frame bounce", "bogie 2 frame bounce"}
    assert bounce["bogie 2 frame bounce"] < bounce["bogie 1 frame bounce"]


def _bogies(edit):
    def change(d):
        d["bogies"] = {"2": copy.deepcopy(MOTOR_BOGIE)}
        edit(d)

    return change


@pytest.mark.parametrize(
    "edit, message",
    [
        (
            _bogies(lambda d: d["bogies"].update({"3": {"mass": 3000.0}})),
            r"bogies\.3: no such bogie: N in \[bogies\.N\] is a bogie's number in carbody\.bogie_positions, "
            r"1 \(leading\) to 2",
        ),
        (_bogies(lambda d: d["bogies"].update({"0": {}})), r"bogies\.0: no such bogie"),
        (_bogies(lambda d: d["bogies"].update({"motor": {}})), r"bogies\.motor: no such bogie"),
        (lambda d: d.update(bogies=[{"mass": 3400.0}]), r"bogies: must be a table, got a list"),
        (_bogies(lambda d: d["bogies"].update({"2": 3400.0})), r"bogies\.2: must be a table"),
        (
            _bogies(lambda d: d["bogies"]["2"].update(wheelset_positions=[2.0, 0.0, -2.0])),
            r"bogies\.2\.wheelset_positions: gives 3 wheelsets, \[bogie\] 2: every bogie must have \[bogie\]'s number "
            r"of wheelsets \(a limitation",
        ),
        (
            _bogies(lambda d: d["bogies"]["2"].update(wheelset_positions=[-1.28, 1.28])),
            r"bogies\.2\.wheelset_positions: must list the leading wheelset first",
        ),
        (_bogies(lambda d: d["bogies"]["2"].update(masss=1.0)), r"bogies\.2\.masss: unknown key"),
        (_bogies(lambda d: d["bogies"]["2"].update(mass=-1.0)), r"bogies\.2\.mass: must be > 0"),
        (
            _bogies(lambda d: d["bogies"]["2"].update(inertia=[1000.0, 1000.0, 3000.0])),
            r"bogies\.2\.inertia: is not a rigid body's inertia",
        ),
        (_bogies(lambda d: d["bogies"]["2"].update(mass=34.0)), r"bogies\.2\.inertia: .* check the mass and the units"),
        (_bogies(lambda d: d["bogies"]["2"]["axlebox"].update(kz=0.0)), r"bogies\.2\.axlebox\.kz: must be > 0"),
        (
            _bogies(lambda d: d["bogies"]["2"]["axlebox"].update(spacing=7.0)),
            r"bogies\.2\.axlebox\.spacing: must be <= 2\.5",
        ),
        (_bogies(lambda d: d["bogies"]["2"]["axlebox"].update(kzz=1.0)), r"bogies\.2\.axlebox\.kzz: unknown key"),
        (_bogies(lambda d: d["bogies"]["2"].update(axlebox=1.0)), r"bogies\.2\.axlebox: must be a table"),
        (
            _bogies(
                lambda d: (
                    d["bogies"].update({"1": {"wheelset_positions": [1.28, -9.6]}}),
                    d["bogies"]["2"].update(wheelset_positions=[9.6, -1.28]),
                )
            ),
            r"bogies: the wheelsets of bogies 1 and 2 at x = -0\.1 and 0\.1 m overlap",
        ),
    ],
)
def test_bad_bogies_fail_with_one_line(edit, message):
    data = copy.deepcopy(SPATIAL)
    edit(data)
    assert_refused(data, message)


def test_bogies_need_spatial_on_a_planar_layout():
    """A planar layout (the coach's planar equivalents) refuses [bogies.N] in one line."""
    data = planar_coach()
    data["bogies"] = {"2": {"mass": 3400.0}}
    assert_refused(data, r"bogies: needs \[spatial\]: different bogies under one car body")


def test_bogie_mass_outside_practice_warns_under_its_own_name():
    layout = layout_from_dict(different_bogies(mass=40000.0, inertia=[20000.0, 20000.0, 30000.0]))
    assert any("bogies.2.mass" in w for w in layout.warnings), layout.warnings


def test_soft_springs_are_noted():
    """A secondary spring sagging 0.45 m under the car body is legal but outside practice (up to
    about 0.3 m): the layout loads with a warning naming it; the coach's own (0.18 m) none."""
    data = copy.deepcopy(SPATIAL)
    assert not [w for w in layout_from_dict(copy.deepcopy(SPATIAL)).warnings if "static_deflection" in w]
    data["secondary"]["spring"]["kz"] = 0.4 * data["secondary"]["spring"]["kz"]
    warnings = [w for w in layout_from_dict(data).warnings if "static_deflection" in w]
    assert len(warnings) == 1 and "secondary.spring" in warnings[0] and "outside railway practice" in warnings[0]


def test_a_primary_above_the_secondary_is_noted():
    data = copy.deepcopy(SPATIAL)
    data["primary"]["axlebox"]["height"] = 0.9  # above the 0.8275 m secondary
    warnings = layout_from_dict(data).warnings
    assert any("primary.axlebox.height: 0.9 m is above the secondary springs" in w for w in warnings)
