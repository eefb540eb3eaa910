"""A spatial vehicle (docs/spatial.md): the model's stiffness about its static equilibrium, by
finite differences of MuJoCo's own forces, equals the one assembled by hand from the layout's
elements; a car body on its secondary springs has the closed-form bounce, pitch, yaw and the
lateral-roll (lower and upper sway) pair; the centred state is the static equilibrium; and a
planar layout is refused spatial elements (and the reverse) with one line."""

from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import numpy as np
import pytest
import tomllib
from scipy.linalg import eigh

from rail_mj.layout import LayoutError, layout_from_dict
from rail_mj.model import Vehicle

SPATIAL = tomllib.loads((Path(__file__).parent / "data" / "manchester-coach-spatial.toml").read_text())
G = 9.81


def dof(model, joint: str) -> int:
    return int(model.joint(joint).dofadr[0])


def hand_stiffness(layout, model) -> np.ndarray:
    """K = sum over elements, sides and axes of k * a a^T, a the deflection's coefficients: the
    upper body's point motion minus the lower's, each translation + (roll, pitch, yaw) x r, written
    here from docs/spatial.md alone (only the dof numbers are read from the model)."""
    sp, K = layout.spatial, np.zeros((model.nv, model.nv))

    def motion(body, r, has_vertical):
        rx, ry, rz = r
        rows = [{"pitch": rz, "yaw": -ry}, {"lateral": 1.0, "yaw": rx, "roll": -rz},
                {"vertical": 1.0, "roll": ry, "pitch": -rx}]
        out = []
        for row in rows:
            a = np.zeros(model.nv)
            for m, c in row.items():
                if has_vertical or m in ("lateral", "yaw"):
                    a[dof(model, f"{body}_{m}")] += c
            out.append(a)
        return out

    def element(point, lower, upper, e):
        (lo, lo_c, lo_full), (up, up_c, up_full) = lower, upper
        a_up = motion(up, np.subtract(point, up_c), up_full)
        a_lo = motion(lo, np.subtract(point, lo_c), lo_full)
        for a, b, k in zip(a_up, a_lo, (e.kx, e.ky, e.kz)):
            d = a - b
            K[:] += k * np.outer(d, d)

    hc, hb, r0 = sp.carbody_height, sp.bogie_height, layout.wheelset.rolling_radius
    n = len(layout.bogie.wheelset_positions)
    for i, xb in enumerate(layout.carbody.bogie_positions, start=1):
        frame = (f"bogie{i}", (xb, 0, hb), True)
        for j, xw in enumerate(layout.bogie.wheelset_positions):
            w = (f"wheelset{(i - 1) * n + j + 1}", (xb + xw, 0, r0), False)
            for s in (1, -1):
                element((xb + xw, s * sp.primary.spacing, sp.primary.height), w, frame, sp.primary)
        for s in (1, -1):
            element((xb, s * sp.secondary.spacing, sp.secondary.height), frame, ("carbody", (0, 0, hc), True),
                    sp.secondary)
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
    M = [[m, m h], [m h, Ix + m h^2]], K = [[ky, 0], [0, kphi - W h]], W h = m g h the
    gravitational stiffness when the layout has it on (pitch too: all springs at one height)."""
    sp, c = layout.spatial, layout.carbody
    e, m, (Ix, Iy, Iz) = sp.secondary, c.mass, c.inertia
    n = 2 * len(c.bogie_positions)  # springs
    d, h = e.spacing, sp.carbody_height - e.height
    wh = m * G * h if sp.gravity and sp.gravitational_stiffness else 0.0
    l2 = sum(2 * x ** 2 for x in c.bogie_positions)  # sum over springs of x^2
    bounce = np.sqrt(n * e.kz / m)
    pitch = np.sqrt((e.kz * l2 + n * e.kx * h ** 2 - wh) / Iy)
    yaw = np.sqrt((e.ky * l2 + n * e.kx * d ** 2) / Iz)
    sway = eigh(np.diag([n * e.ky, n * e.kz * d ** 2 - wh]), np.array([[m, m * h], [m * h, Ix + m * h * h]]),
                eigvals_only=True)
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
    roll = np.sqrt(4 * e.kz * e.spacing ** 2 / Ix) / (2 * np.pi)
    pitch = np.sqrt(4 * e.kz * 9.5 ** 2 / Iy) / (2 * np.pi)
    bounce = np.sqrt(4 * e.kz / 32000.0) / (2 * np.pi)
    for expected in (roll, pitch, bounce):
        assert np.min(np.abs(f - expected)) <= 1e-7 * expected


def test_gravity_off_leaves_the_stiffness(coach):
    layout, vehicle = coach
    data = copy.deepcopy(SPATIAL)
    data["spatial"]["gravity"] = False
    other = Vehicle(layout_from_dict(data))
    assert np.allclose(fd_stiffness(other.model), fd_stiffness(vehicle.model), rtol=0, atol=1e-8 * 1e8)
    assert not other.model.tendon_lengthspring.any()


def test_all_at_one_height_is_the_planar_model():
    """Centres of mass and springs all at one height: the lateral and yaw motions part from the
    vertical ones, and the eigenvalues of the planar layout made of the elements' planar
    equivalents are all among the spatial model's (the vertical modes besides)."""
    from rail_mj.stability import Stability

    data = copy.deepcopy(SPATIAL)
    data["spatial"].update(carbody_height=1.0, bogie_height=1.0)
    data["primary"]["axlebox"]["height"] = data["secondary"]["spring"]["height"] = 1.0
    layout = layout_from_dict(data)
    planar = {k: copy.deepcopy(v) for k, v in data.items() if k not in ("spatial", "primary", "secondary")}
    for key, s in (("primary", layout.primary), ("secondary", layout.secondary)):
        planar[key] = {"lateral_stiffness": s.lateral_stiffness, "yaw_stiffness": s.yaw_stiffness,
                       "lateral_damping": s.lateral_damping, "yaw_damping": s.yaw_damping}
    spatial = Stability(layout).eigenvalues(30.0)
    for lam in Stability(layout_from_dict(planar)).eigenvalues(30.0):
        assert np.min(np.abs(spatial - lam)) <= 1e-6 * abs(lam)
    assert len(spatial) > len(Stability(layout_from_dict(planar)).eigenvalues(30.0))


def test_mode_names():
    """The car body's bounce, pitch, yaw and its two sways, lower (roll centre below the centre of
    mass) at the lower frequency; the frames' bounce and pitch."""
    from rail_mj.stability import Stability

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


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.pop("spatial"), r"primary\.axlebox: needs \[spatial\]"),
    (lambda d: d["primary"].update(lateral_stiffness=1.0), r"primary\.lateral_stiffness: not used with \[spatial\]"),
    (lambda d: d["primary"]["axlebox"].pop("kz"), r"primary\.axlebox\.kz: missing"),
    (lambda d: d["secondary"]["spring"].update(height=-1.0), r"secondary\.spring\.height: must be > 0"),
    (lambda d: d["secondary"]["spring"].update(spacing=7.0), r"secondary\.spring\.spacing: must be <= 2\.5"),
    (lambda d: d["spatial"].update(carbody_height=0.5), r"spatial\.carbody_height: must not be below bogie_height"),
    (lambda d: d["spatial"].update(heigth=0.5), r"spatial\.heigth: unknown key"),
    (lambda d: d["carbody"].update(fixed=True), r"spatial: needs a free car body"),
])
def test_bad_spatial_layouts_fail_with_one_line(edit, message):
    data = copy.deepcopy(SPATIAL)
    edit(data)
    with pytest.raises(LayoutError, match=message) as e:
        layout_from_dict(data)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("speed", [10.0, 30.0, 60.0])
def test_mode_names_at_one_height_are_the_planar_ones(speed):
    """All at one height, each planar mode is among the spatial ones (above) and carries the
    planar model's name there: the spatial names add the vertical and roll modes, they do not
    rename the hunting ones."""
    from rail_mj.stability import Stability

    data = copy.deepcopy(SPATIAL)
    data["spatial"].update(carbody_height=1.0, bogie_height=1.0)
    data["primary"]["axlebox"]["height"] = data["secondary"]["spring"]["height"] = 1.0
    layout = layout_from_dict(data)
    planar = {k: copy.deepcopy(v) for k, v in data.items() if k not in ("spatial", "primary", "secondary")}
    for key, s in (("primary", layout.primary), ("secondary", layout.secondary)):
        planar[key] = {"lateral_stiffness": s.lateral_stiffness, "yaw_stiffness": s.yaw_stiffness,
                       "lateral_damping": s.lateral_damping, "yaw_damping": s.yaw_damping}
    spatial = Stability(layout).modes(speed)
    for mode in Stability(layout_from_dict(planar)).modes(speed):
        twin = min(spatial, key=lambda m: abs(m.eigenvalue - mode.eigenvalue))
        assert abs(twin.eigenvalue - mode.eigenvalue) <= 1e-6 * abs(mode.eigenvalue)
        # Which of two bogies (or wheelsets) a symmetric pair is named after is a tie broken by
        # round-off; the kind of mode is not.
        kind = lambda name: "".join(c for c in name if not c.isdigit())  # noqa: E731
        assert kind(twin.name) == kind(mode.name), (mode.frequency, mode.name, twin.name)


# Gravitational stiffness (docs/spatial.md): the preloads' second-order potential as roll and pitch
# stiffness of the car body and the bogie frames; `spatial.gravitational_stiffness`, default on.


@pytest.fixture(scope="module")
def coach_gravitational():
    layout = layout_from_dict(copy.deepcopy(SPATIAL))
    assert layout.spatial.gravitational_stiffness  # the default
    return layout, Vehicle(layout)


def hand_gravitational_stiffness(layout, model) -> np.ndarray:
    """The geometric terms from the weights alone, for a layout symmetric left-right and fore-aft (the
    coach): each secondary spring carries P_s = m_c g / n_s, each axlebox P_p = (m_c g / n_b + m_b g) / n_p
    per bogie; an element adds -P (H_upper - z) to its upper body's roll and pitch, -P (z - H_lower)
    to its lower body's; wheelsets have neither."""
    sp, c, b = layout.spatial, layout.carbody, layout.bogie
    n_b = len(c.bogie_positions)
    n_p = 2 * len(b.wheelset_positions)  # axleboxes per bogie
    P_s = c.mass * G / (2 * n_b)
    P_p = (c.mass * G / n_b + b.mass * G) / n_p
    z_s, z_p, hc, hb = sp.secondary.height, sp.primary.height, sp.carbody_height, sp.bogie_height
    terms = {"carbody": -2 * n_b * P_s * (hc - z_s)}
    for i in range(1, n_b + 1):
        terms[f"bogie{i}"] = -2 * P_s * (z_s - hb) - n_p * P_p * (hb - z_p)
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
    """All at one height every h is zero, and so every term: the planar-limit tests above run with
    the switch on (the default) and keep the planar eigenvalues among the spatial ones."""
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


def test_gravitational_stiffness_is_the_drop_of_the_attachment_points(coach_gravitational):
    """The derivation against MuJoCo's exact kinematics: each element's static force P held vertical
    and constant at its attachment point on each body, V = sum of P*(z_lower - z_upper) with the
    points moved by the bodies' true rotations; its Hessian over the car body's and frames' roll,
    pitch and yaw (central differences, 1e-3 rad: truncation ~1e-6) is diagonal, roll and pitch
    only, and equals the joints' stiffness to 1e-5 of the largest (the MJCF's 6 figures: 2e-6)."""
    from rail_mj.model import spatial_elements

    layout, vehicle = coach_gravitational
    model, data = vehicle.model, mujoco.MjData(vehicle.model)
    force = {model.tendon(t).name: model.tendon_stiffness[t] * model.tendon_lengthspring[t, 0]
             for t in range(model.ntendon)}
    elements = [(force[f"{name}_z"], np.array(point), lower[0], upper[0])
                for name, point, lower, upper, _ in spatial_elements(layout)]
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
