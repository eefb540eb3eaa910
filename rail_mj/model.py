"""Model generation: a `Layout` built into MuJoCo MJCF with the MjSpec API.

The model lives in a frame that travels along the track with the vehicle at the
run's speed: x is along the track, y to the left, z up (docs/frames.md).
Forward motion is not a degree of freedom; the runner adds x = V*t. Each
body has a lateral slide joint and a yaw hinge, nested as the suspension is:

    world -> carbody -> bogieK -> wheelsetN        (with [bogie])
    world -> carbody -> wheelsetN                  (without)

so each suspension is the stiffness and damping of the joints of the body it
carries. A wheelset joint measures y_w - (y_f + (x_w - x_f)*psi_f) and
psi_w - psi_f relative to its frame, exactly the suspension deflections of
docs/frames.md once linearised. A fixed car body has no joints.

Example:

    >>> from rail_mj.layout import load_layout
    >>> from rail_mj.model import Vehicle
    >>> vehicle = Vehicle(load_layout("models/bogie/bogie.toml"))
    >>> vehicle.wheelset_names
    ('wheelset1', 'wheelset2')
    >>> vehicle.model.nv   # bogie frame and two wheelsets, lateral and yaw each
    6
"""

from __future__ import annotations

import functools
from pathlib import Path

import mujoco
import numpy as np

from rail_mj.files import staged
from rail_mj.layout import LAWS, Layout, Suspension
from rail_mj.wheel import wheel_stl

# Heights of the bodies above the rail, m. The model is planar (lateral and yaw), so
# these place the bodies for viewing and have no effect on the dynamics. Bogie frame
# and car body are the Manchester benchmark's centres of mass (docs/manchester-coach.md).
BOGIE_HEIGHT = 0.6
CARBODY_HEIGHT = 1.8
AXLE_RADIUS = 0.08
RAIL_HEAD_WIDTH = 0.072  # UIC60, m

# The run's speed replaces nothing here: the timestep is chosen by the runner.
DEFAULT_TIMESTEP = 1e-3

# Names of the custom numerics that carry the contact data for the creep forces,
# so that a generated MJCF alone is enough to simulate the vehicle.
NUMERIC_WHEEL = "rail_mj/wheel"  # r0, b, conicity, flangeway clearance
NUMERIC_CREEP = "rail_mj/creep"  # f11, f22, f23, f33
NUMERIC_SATURATION = "rail_mj/saturation"  # creep law number (rail_mj.creep.LAWS), mu*N per wheel,
# and Polach's falling friction: mu_infinity/mu0 and its rate, s/m
NUMERIC_FLANGE = "rail_mj/flange"  # on (1) or off (0), stiffness, damping, tan(flange angle)

# A wheelset's lateral/yaw joints are named <body>_lateral and <body>_yaw.
LATERAL, YAW = "lateral", "yaw"


def _g6(*values: float) -> list[float]:
    """Numbers as MuJoCo's MJCF writer prints them, to 6 significant figures: every
    physical number goes into the model through this, so that the written MJCF compiles
    to exactly the model the runner simulates."""
    return [float(f"{v:.6g}") for v in values]


def _pos(x: float, z: float) -> list[float]:
    return _g6(x, 0.0, z)


def _quat_about_x(angle: float) -> list[float]:
    return [float(np.cos(angle / 2)), float(np.sin(angle / 2)), 0.0, 0.0]


def _add_planar_joints(body, suspension: Suspension | None) -> None:
    """Lateral slide and yaw hinge; `suspension` (None: free) is their stiffness and damping."""
    s = suspension or Suspension(0.0, 0.0)
    body.add_joint(
        name=f"{body.name}_{LATERAL}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 1, 0],
        stiffness=_g6(s.lateral_stiffness, 0.0, 0.0), damping=_g6(s.lateral_damping, 0.0, 0.0),
    )
    body.add_joint(
        name=f"{body.name}_{YAW}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1],
        stiffness=_g6(s.yaw_stiffness, 0.0, 0.0), damping=_g6(s.yaw_damping, 0.0, 0.0),
    )


def _set_inertia(body, mass: float, inertia) -> None:
    body.explicitinertial = True
    # Centre of mass at the body origin, principal axes along the track axes; set
    # explicitly because an unset ipos is not the origin.
    body.ipos = [0.0, 0.0, 0.0]
    body.iquat = [1.0, 0.0, 0.0, 0.0]
    body.mass = _g6(mass)[0]
    body.inertia = _g6(*inertia)


def add_wheelset(parent, name: str, x: float, z: float, layout: Layout) -> None:
    """A wheelset hanging from `parent` at (x, z) in its frame, on the primary suspension."""
    w = layout.wheelset
    body = parent.add_body(name=name, pos=_pos(x, z))
    _set_inertia(body, w.mass, w.inertia)
    _add_planar_joints(body, layout.primary)
    b = w.contact_half_spacing
    body.add_geom(
        name=f"{name}_axle", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[AXLE_RADIUS, b, 0],
        quat=_quat_about_x(np.pi / 2), contype=0, conaffinity=0, rgba=[0.4, 0.4, 0.45, 1],
    )
    # The mesh's axis (its +z) points outward: +y for the left wheel, -y for the right.
    for side, y, angle in (("left", b, -np.pi / 2), ("right", -b, np.pi / 2)):
        body.add_geom(
            name=f"{name}_{side}_wheel", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="wheel",
            pos=[0, y, 0], quat=_quat_about_x(angle), contype=0, conaffinity=0,
            rgba=[0.55, 0.55, 0.6, 1],
        )


def add_bogie(parent, name: str, x: float, z: float, layout: Layout, first_wheelset: int) -> None:
    """A bogie frame at (x, z) in the car body, on the secondary suspension, with its wheelsets."""
    bogie = layout.bogie
    body = parent.add_body(name=name, pos=_pos(x, z))
    _set_inertia(body, bogie.mass, bogie.inertia)
    _add_planar_joints(body, layout.secondary)
    xs = bogie.wheelset_positions
    half_length = (max(xs) - min(xs)) / 2 + layout.wheelset.rolling_radius
    body.add_geom(
        name=f"{name}_frame", type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[half_length, layout.wheelset.contact_half_spacing + 0.1, 0.1],
        pos=[(max(xs) + min(xs)) / 2, 0, 0], contype=0, conaffinity=0, rgba=[0.2, 0.3, 0.6, 1],
    )
    for i, x in enumerate(xs):
        add_wheelset(
            body, f"wheelset{first_wheelset + i}", x,
            layout.wheelset.rolling_radius - BOGIE_HEIGHT, layout,
        )


def add_carbody(worldbody, layout: Layout) -> None:
    """The car body (held over the centreline when fixed) with everything under it."""
    c = layout.carbody
    body = worldbody.add_body(name="carbody", pos=[0, 0, CARBODY_HEIGHT])
    if not c.fixed:
        _set_inertia(body, c.mass, c.inertia)
        _add_planar_joints(body, None)
    xs = c.bogie_positions if layout.bogie else c.wheelset_positions
    half_length = (max(xs) - min(xs)) / 2 + 2.0
    body.add_geom(
        name="carbody_shell", type=mujoco.mjtGeom.mjGEOM_BOX, size=[half_length, 1.4, 0.05],
        pos=[(max(xs) + min(xs)) / 2, 0, -0.5], contype=0, conaffinity=0,
        rgba=[0.7, 0.2, 0.2, 0.5 if c.fixed else 1.0],
    )
    if layout.bogie:
        n = len(layout.bogie.wheelset_positions)
        for k, x in enumerate(c.bogie_positions):
            add_bogie(body, f"bogie{k + 1}", x, BOGIE_HEIGHT - CARBODY_HEIGHT, layout, k * n + 1)
    else:
        for i, x in enumerate(xs):
            add_wheelset(
                body, f"wheelset{i + 1}", x,
                layout.wheelset.rolling_radius - CARBODY_HEIGHT, layout,
            )


def mesh_file(layout: Layout) -> str:
    w = layout.wheelset
    return f"wheel_r{w.rolling_radius:g}_c{w.conicity:g}.stl"


def build_spec(layout: Layout) -> mujoco.MjSpec:
    """The vehicle alone as an MjSpec, its wheel mesh in `spec.assets`."""
    spec = mujoco.MjSpec()
    spec.modelname = layout.name
    spec.compiler.degree = False
    spec.meshdir = "assets"
    # Masses and inertias come from the layout, never from the (visual) geoms; to_xml
    # writes the <inertial> elements only when asked to.
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.saveinertial = True
    # Only the car-body/bogie/wheelset lateral-yaw dynamics are modelled; nothing collides.
    # RK4: MuJoCo integrates callback (creep) forces explicitly, and the semi-implicit
    # Euler integrators then misjudge the creep damping by O(dt*2*f22/(m*V)), which moved
    # the time-domain critical speed of the restrained wheelset by 5 % at dt = 1 ms;
    # RK4 reproduces the eigenvalues' growth rates to 4 digits at the same step.
    spec.option.timestep = DEFAULT_TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.disableflags = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)

    w = layout.wheelset
    stl = wheel_stl(w.rolling_radius, w.conicity)
    spec.add_mesh(name="wheel", file=mesh_file(layout))
    spec.assets = {mesh_file(layout): stl}
    add_carbody(spec.worldbody, layout)

    c = layout.creep
    spec.add_numeric(name=NUMERIC_WHEEL, data=_g6(
        w.rolling_radius, w.contact_half_spacing, w.conicity, w.flangeway_clearance,
    ))
    spec.add_numeric(name=NUMERIC_CREEP, data=_g6(c.f11, c.f22, c.f23, c.f33))
    limit = c.friction * w.wheel_load if c.law != "linear" else 0.0  # unused by the linear law
    spec.add_numeric(name=NUMERIC_SATURATION, data=_g6(LAWS[c.law], limit, c.falling_friction_ratio,
                                                       c.falling_friction_rate))
    f = layout.flange
    spec.add_numeric(name=NUMERIC_FLANGE, data=_g6(1.0, f.stiffness, f.damping, np.tan(f.angle))
                     if f else _g6(0.0, 0.0, 0.0, 0.0))
    return spec


def compile_spec(spec: mujoco.MjSpec, layout: Layout) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as e:
        why = "; ".join(line.strip() for line in str(e).splitlines() if line.strip())
        raise ValueError(f"{layout.source}: MuJoCo could not compile the model: {why}") from None


class Vehicle:
    """A compiled vehicle: the MuJoCo model of a layout, its parts read by name.

    Example:

        >>> from rail_mj.layout import load_layout
        >>> vehicle = Vehicle(load_layout("models/manchester-coach/manchester-coach.toml"))
        >>> vehicle.wheelset_names[0], vehicle.model.nv
        ('wheelset1', 14)
    """

    def __init__(self, layout: Layout):
        self.layout = layout
        self.spec = build_spec(layout)
        self.model = compile_spec(self.spec, layout)
        self.wheelset_names = tuple(f"wheelset{i + 1}" for i in range(layout.n_wheelsets))
        self.wheelset_ids = np.array(
            [self.model.body(n).id for n in self.wheelset_names], dtype=np.int64
        )

    @functools.cached_property
    def root_lateral_dofs(self) -> np.ndarray:
        """The lateral joints that move the whole vehicle: those whose parent cannot move."""
        dofs = []
        for j in range(self.model.njnt):
            name = self.model.joint(j).name
            parent = self.model.body_parentid[self.model.jnt_bodyid[j]]
            if name.endswith(f"_{LATERAL}") and self.model.body_dofnum[parent] == 0:
                dofs.append(self.model.jnt_dofadr[j])
        return np.array(dofs, dtype=np.int64)

    def wheelset_dofs(self, motion: str) -> np.ndarray:
        return np.array(
            [self.model.joint(f"{n}_{motion}").dofadr[0] for n in self.wheelset_names],
            dtype=np.int64,
        )


SCENE_TEMPLATE = """\
<mujoco model="{name} scene">
  <include file="{name}.xml"/>

  <statistic center="0 0 1" extent="{extent:g}"/>

  <visual>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <global azimuth="120" elevation="-20"/>
  </visual>

  <asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="512" height="3072"/>
    <texture type="2d" name="ballast" builtin="checker" mark="edge" rgb1="0.35 0.33 0.3" rgb2="0.3 0.28 0.25"
      markrgb="0.5 0.5 0.5" width="300" height="300"/>
    <material name="ballast" texture="ballast" texuniform="true" texrepeat="5 5" reflectance="0"/>
    <material name="steel" rgba="0.75 0.75 0.78 1" specular="0.8"/>
  </asset>

  <worldbody>
    <light name="sun" pos="0 0 20" dir="0 0 -1" directional="true"/>
    <geom name="floor" type="plane" size="0 0 0.05" pos="0 0 {floor_z:g}" material="ballast"/>
    <!-- Rail heads centred on the contact points (y = +/- b), top at z = 0. -->
    <geom name="left_rail" type="box" size="{rail_half_length:g} {rail_half_width:g} 0.08"
      pos="0 {b:g} -0.08" material="steel"/>
    <geom name="right_rail" type="box" size="{rail_half_length:g} {rail_half_width:g} 0.08"
      pos="0 {neg_b:g} -0.08" material="steel"/>
  </worldbody>
</mujoco>
"""


def scene_xml(layout: Layout) -> str:
    xs = layout.wheelset_x
    length = max(xs) - min(xs) + 10.0
    b = layout.wheelset.contact_half_spacing
    return SCENE_TEMPLATE.format(
        name=layout.name, extent=length, floor_z=-0.16, rail_half_length=length,
        rail_half_width=RAIL_HEAD_WIDTH / 2, b=b, neg_b=-b,
    )


def generated_files(layout: Layout) -> dict[str, bytes]:
    """Every file `generate` writes, relative to the output folder."""
    spec = build_spec(layout)
    compile_spec(spec, layout)  # to_xml needs a compiled spec; also proves the model is valid
    files = {f"{layout.name}.xml": spec.to_xml().encode(), "scene.xml": scene_xml(layout).encode()}
    for name, data in spec.assets.items():
        files[f"assets/{name}"] = bytes(data)
    return files


def generate(layout: Layout, out_dir: str | Path) -> list[Path]:
    """Write `<name>.xml`, `scene.xml` and `assets/` into `out_dir`.

    The files are written to temporary names and renamed into place together, so a
    failure never leaves a half-written file or half a model.
    """
    files = generated_files(layout)
    written = [Path(out_dir) / rel for rel in files]
    with staged(written) as temps:
        for tmp, data in zip(temps, files.values()):
            tmp.write_bytes(data)
    return written
