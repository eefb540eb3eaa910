"""A `Layout` as one MjSpec (options, the bodies, the numerics the creep callback reads) and
compiled, its native block filled in: `Vehicle`.
"""

from __future__ import annotations

import copy
import functools

import mujoco
import numpy as np

from rail_mj.contact.parameters import ContactParameters
from rail_mj.layout import GRAVITY, LAWS, Layout
from rail_mj.layout.kinds import Hertzian, Planar, SpatialVehicle, TrainOfCars, contact_model, vehicle_kind
from rail_mj.numerics import (
    NUMERIC_CREEP,
    NUMERIC_ELLIPSE,
    NUMERIC_FLANGE,
    NUMERIC_GEOMETRY,
    NUMERIC_NATIVE,
    NUMERIC_SATURATION,
    NUMERIC_WHEEL,
)
from rail_mj.track import SpeedProfile, Track
from rail_mj.units import PA_PER_GPA
from rail_mj.vehicle.curve import ODOMETER, add_odometer
from rail_mj.vehicle.joints import LATERAL, YAW
from rail_mj.vehicle.looks import add_wheel_mesh
from rail_mj.vehicle.planar import add_carbody
from rail_mj.vehicle.rounding import _g6
from rail_mj.vehicle.sensors import JointSensors, Sensors, add_load_sensors, add_sensors
from rail_mj.vehicle.spatial import add_spatial
from rail_mj.vehicle.statics import add_gravitational_stiffness, preload
from rail_mj.vehicle.train import add_flat_carbody, add_train

# The run's speed replaces nothing here: the timestep is chosen by the runner.
DEFAULT_TIMESTEP = 1e-3


def build_spec(layout: Layout, track: Track | None = None, flat: bool = False) -> mujoco.MjSpec:
    """The vehicle alone as an MjSpec, its wheel mesh in `spec.assets`; on `track` (curved or
    canted: rail_mj.vehicle.curve) with its odometer. `flat`: a planar vehicle built flat
    (rail_mj.vehicle.train.add_flat_carbody), the form it is stepped in on straight track."""
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

    spec.add_numeric(name=NUMERIC_NATIVE, data=[0.0])  # first; filled in by `compiled`
    add_wheel_mesh(spec, layout)
    w = layout.wheelset
    vehicle = vehicle_kind(layout)
    match vehicle:
        case SpatialVehicle():
            add_spatial(spec, vehicle)
            if vehicle.spatial.gravity:  # the wheel loads come from the suspension (rail_mj.vehicle.loads)
                _add_loads(spec, vehicle)
        case TrainOfCars():
            add_train(spec, vehicle)
        case Planar() if flat:
            add_flat_carbody(spec, vehicle)
        case Planar():
            add_carbody(spec.worldbody, vehicle)
    if track is not None:
        add_odometer(spec)

    c = layout.creep
    spec.add_numeric(
        name=NUMERIC_WHEEL,
        data=_g6(
            w.rolling_radius,
            w.contact_half_spacing,
            w.conicity,
            w.flangeway_clearance,
        ),
    )
    spec.add_numeric(name=NUMERIC_CREEP, data=_g6(c.f11, c.f22, c.f23, c.f33))
    limit = 0.0  # unused by the linear law
    if c.law != "linear":
        assert c.friction is not None and w.wheel_load is not None  # the reader requires both of a saturating law
        limit = c.friction * w.wheel_load
    spec.add_numeric(
        name=NUMERIC_SATURATION, data=_g6(LAWS[c.law], limit, c.falling_friction_ratio, c.falling_friction_rate)
    )
    f = layout.flange
    spec.add_numeric(
        name=NUMERIC_FLANGE, data=_g6(1.0, f.stiffness, f.damping, np.tan(f.angle)) if f else _g6(0.0, 0.0, 0.0, 0.0)
    )
    spec.add_numeric(name=NUMERIC_ELLIPSE, data=_g6(*_ellipse(layout)))
    if layout.profiles is not None:
        from rail_mj.contact.tables import TableError, dynamics_table

        try:
            table = dynamics_table(layout)
        except TableError as e:
            raise ValueError(f"{layout.source}: {e}") from None
        spec.add_numeric(name=NUMERIC_GEOMETRY, data=_g6(*table.reshape(-1)))
    return spec


def _add_loads(spec: mujoco.MjSpec, vehicle: SpatialVehicle) -> None:
    """The numerics rail_mj.vehicle.loads reads a spatial vehicle's wheel loads by: the axle's
    weight, the nominal wheel load, the axleboxes' spacing and height, the wheelsets' spin
    inertia and the switch of the cones' gravitational stiffness; the shear couples' switch."""
    from rail_mj.vehicle.loads import NUMERIC_COUPLES, NUMERIC_LOADS

    layout, sp = vehicle.layout, vehicle.spatial
    w, e = layout.wheelset, sp.primary
    spin = w.inertia[1] if sp.gyroscopic else 0.0
    cone_gravity = sp.gravitational_stiffness and layout.profiles is None
    # Each wheelset's axlebox spacing and height after the defaults, when a bogie has its
    # own ([bogies.N.axlebox]; rail_mj.vehicle.loads reads either form).
    own = [(d.axlebox.spacing, d.axlebox.height) for d in sp.bogies for _ in d.wheelset_positions]
    flat = [] if all(a == (e.spacing, e.height) for a in own) else [v for a in own for v in a]
    assert w.wheel_load is not None  # the reader's default: the static weight shared equally
    spec.add_numeric(
        name=NUMERIC_LOADS,
        data=_g6(GRAVITY * w.mass, w.wheel_load, e.spacing, e.height, spin, float(cone_gravity), *flat),
    )
    if sp.gravitational_stiffness:  # the preloads' shear couples (rail_mj.vehicle.loads)
        spec.add_numeric(name=NUMERIC_COUPLES, data=[1.0])


def _ellipse(layout: Layout) -> tuple[float, ...]:
    """NUMERIC_ELLIPSE's numbers: the Hertz ellipse of [contact], or zeros (also on
    profiles, whose contact table carries each point's ellipse)."""
    if not isinstance(contact_model(layout), Hertzian):
        return (0.0,) * 7
    from rail_mj.layout import contact_patch_of  # scipy: only for layouts with [contact]

    patch = contact_patch_of(layout)
    return (
        patch.a,
        patch.b,
        patch.normal_load,
        patch.shear_modulus / PA_PER_GPA,
        patch.C["C11"],
        patch.C["C22"],
        patch.C["C23"],
    )


def compile_spec(spec: mujoco.MjSpec, layout: Layout) -> mujoco.MjModel:
    try:
        return spec.compile()
    except ValueError as e:
        why = "; ".join(line.strip() for line in str(e).splitlines() if line.strip())
        raise ValueError(f"{layout.source}: MuJoCo could not compile the model: {why}") from None


def compiled(
    layout: Layout, track: Track | None = None, profile: SpeedProfile | None = None, flat: bool = False
) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    """The vehicle's spec and compiled model, its native block filled in: the block lists
    bodies, joints and dofs by the ids the compiler gave them, so it is written after a
    first compile (a millisecond or two) and the model compiled again."""
    from rail_mj.numerics import userdata_size
    from rail_mj.vehicle import block  # numba (the contact law's module): only once a model is built

    spec = build_spec(layout, track, flat)
    model = compile_spec(spec, layout)
    if layout.spatial is not None:  # a spatial vehicle's gravity: the only one with vertical motion
        if layout.spatial.gravity:
            q_eq = preload(spec, model)
            # After the preload, and so outside the K it solves with: these terms are made of its
            # forces, and act about q = 0, which they must leave the equilibrium (docs/spatial.md).
            if layout.spatial.gravitational_stiffness:
                add_gravitational_stiffness(spec, layout, model, q_eq)
        else:
            spec.option.gravity = [0.0, 0.0, 0.0]
    part = None
    if track is not None:
        from rail_mj.vehicle.curve import track_part

        part = track_part(model, layout, track, profile=profile)
    native = block.block_for(model, layout.n_wheelsets, part)
    spec.numerics[0].data = native.tolist()
    spec.nuserdata = userdata_size(native, model.ntendon)  # the callback's scratch on a curve
    if not flat:  # a flat twin's record is read from its state (JointSensors)
        add_sensors(spec, [model.body(b).name for b in range(1, model.nbody)])
        add_load_sensors(spec, model, [f"wheelset{i + 1}" for i in range(layout.n_wheelsets)])
    return spec, compile_spec(spec, layout)


class Vehicle:
    """A compiled vehicle: the MuJoCo model of a layout, its parts read by name.

    Example:

        >>> from rail_mj.layout import load_layout
        >>> vehicle = Vehicle(load_layout("models/manchester-coach/manchester-coach.toml"))
        >>> vehicle.wheelset_names[0], vehicle.model.nv
        ('wheelset1', 14)
    """

    def __init__(
        self, layout: Layout, track: Track | None = None, profile: SpeedProfile | None = None, flat: bool = False
    ):
        """`track`: a curved or canted track to run on (None: straight, the shipped MJCF);
        `profile`: the speed along it (rail_mj.track.speed; None: the run's constant speed). A
        profile needs a track (the odometer it drives): `Track.straight` where there is no curve.
        `flat`: a planar vehicle's flat twin on straight track (`stepped`), not its MJCF."""
        if profile is not None and track is None:
            raise ValueError("a speed profile needs a track to run along (rail_mj.track.Track.straight)")
        if flat and (track is not None or not isinstance(vehicle_kind(layout), Planar)):
            raise ValueError("only a planar vehicle on straight track has a flat twin")
        self.layout, self.track, self.profile, self.flat = layout, track, profile, flat
        if track is None and profile is None and not flat:
            spec, model = _compiled_once(layout)
            self.spec, self.model = spec.copy(), copy.copy(model)
        else:
            self.spec, self.model = compiled(layout, track, profile, flat)
        self.wheelset_names = tuple(f"wheelset{i + 1}" for i in range(layout.n_wheelsets))
        self.wheelset_ids = np.array([self.model.body(n).id for n in self.wheelset_names], dtype=np.int64)

    @property
    def springs_in_callback(self) -> bool:
        """Whether the model that steps this vehicle (rail_mj.simulation.stepping) leaves its
        suspension to the native callback: a flat train, or a planar vehicle's flat twin, on
        straight track, whose every tendon is a linear spring and damper on its joints.
        MuJoCo's tendon stages cost a train's step more than the same forces summed in the
        callback (docs/trains.md); its own model, and its MJCF, keep the tendons."""
        return self.track is None and (self.flat or isinstance(vehicle_kind(self.layout), TrainOfCars))

    @functools.cached_property
    def stepped(self) -> Vehicle:
        """The vehicle that steps for this one (rail_mj.simulation.stepping): a planar vehicle
        on straight track whose joints are nested (a body on a moving body) steps as its flat
        twin (`Vehicle(layout, flat=True)`: the same bodies, names and joints, each body on its
        own absolute joints, its suspension summed in the callback: docs/trains.md); any
        other, itself. On a track file the nested model steps (its curve loads and tendon shifts
        are the nested chain's). States pass between the two by `from_stepped` and `to_stepped`."""
        nested = np.any(self.model.body_dofnum[self.model.body_parentid[self.model.jnt_bodyid]] > 0)
        if self.flat or self.track is not None or not isinstance(vehicle_kind(self.layout), Planar) or not nested:
            return self
        return _flat_twin(self.layout)

    @functools.cached_property
    def _from_stepped(self) -> np.ndarray:
        """The matrix that takes the stepped twin's coordinates (absolute lateral and yaw of each
        body) to this vehicle's (each joint relative to the body it hangs from): a child c's
        lateral joint reads y_c - y_p - a*psi_p (a: its x in its parent's frame), its yaw
        psi_c - psi_p, the suspension deflections the twin's tendons measure (docs/frames.md)."""
        own, twin = self.model, self.stepped.model
        names = [own.joint(j).name for j in range(own.njnt)]
        if [twin.joint(j).name for j in range(twin.njnt)] != names:
            raise ValueError("the flat twin's joints are not the vehicle's")
        T = np.eye(own.nv)
        for j, name in enumerate(names):
            body = int(own.jnt_bodyid[j])
            parent = int(own.body_parentid[body])
            if own.body_dofnum[parent] == 0:  # on the world or a fixed car body: absolute already
                continue
            p = own.body(parent).name
            T[j, names.index(f"{p}_{YAW}")] = -1.0 if name.endswith(f"_{YAW}") else -float(own.body_pos[body, 0])
            if name.endswith(f"_{LATERAL}"):
                T[j, names.index(f"{p}_{LATERAL}")] = -1.0
        return T

    def from_stepped(self, state: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """(qpos, qvel) of the stepped vehicle (`stepped`) as this vehicle's own."""
        if self.stepped is self:
            return state
        return self._from_stepped @ state[0], self._from_stepped @ state[1]

    def to_stepped(self, state: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """(qpos, qvel) of this vehicle as its stepped twin's (`stepped`)."""
        if self.stepped is self:
            return state
        return np.linalg.solve(self._from_stepped, state[0]), np.linalg.solve(self._from_stepped, state[1])

    @functools.cached_property
    def stepping_spec(self) -> mujoco.MjSpec:
        """The spec a model that steps this vehicle attaches when `springs_in_callback`: its own
        without the drawn shapes and the tendons. Written out and read back without them: MjSpec
        deletes one element at a time in time growing with the spec (half a second for a ten-car
        train's 460 shapes, against 25 ms for this); every number in the spec is already in the
        MJCF's six figures (rail_mj.vehicle.rounding) and the block is rebuilt by the pack."""
        import xml.etree.ElementTree as ElementTree

        root = ElementTree.fromstring(self.spec.to_xml())
        for parent in root.iter():
            for child in list(parent):
                if child.tag in ("geom", "mesh") or parent.tag == "tendon":
                    parent.remove(child)
        return mujoco.MjSpec.from_string(ElementTree.tostring(root, encoding="unicode"))

    @functools.cached_property
    def contact_parameters(self) -> ContactParameters:
        """The contact data its model carries (rail_mj.vehicle.block.contact_parameters), read once:
        a run's summary evaluates the law over every piece of a streamed run with them."""
        from rail_mj.vehicle.block import contact_parameters

        return contact_parameters(self.model, self.n_wheelsets)

    @property
    def n_wheelsets(self) -> int:
        return len(self.wheelset_names)

    @functools.cached_property
    def frame_ids(self) -> np.ndarray:
        """The moving bodies other than the wheelsets: the bogie frames (bogie1, ...), then the
        car body unless it is fixed (a fixed car body, no joints, has no motion to show); read
        once, a streamed run's every piece reads them."""
        model, wheelsets = self.model, set(self.wheelset_ids.tolist())
        moving = [
            b
            for b in range(1, model.nbody)
            if b not in wheelsets and model.body_dofnum[b] > 0 and model.body(b).name != ODOMETER
        ]
        return np.array(sorted(moving, key=lambda b: (model.body(b).name == "carbody", b)), dtype=np.int64)

    @functools.cached_property
    def frame_names(self) -> tuple[str, ...]:
        return tuple(self.model.body(int(b)).name for b in self.frame_ids)

    @functools.cached_property
    def sensors(self) -> Sensors | JointSensors:
        return self.sensors_in(self.model)

    def sensors_in(self, model: mujoco.MjModel, prefix: str = "") -> Sensors | JointSensors:
        """Where this vehicle's readings sit in `model` (its own, or a pack's under `prefix`): a
        flat twin's are its joints' (`JointSensors`)."""
        kind = JointSensors if self.flat else Sensors
        return kind(model, self.wheelset_names, prefix)

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


# A sweep builds a vehicle of one layout for each of its speeds: compiled once (5 ms), copied for
# each (a quarter of a millisecond), so that each vehicle's model is its own (set_speed writes it).
# Not a flat twin: the runs of a layout share one already (`_flat_twin`).
@functools.lru_cache(maxsize=16)
def _compiled_once(layout: Layout) -> tuple[mujoco.MjSpec, mujoco.MjModel]:
    return compiled(layout, None, None, False)


# A sweep's runs of one layout share its twin (6 ms to build with its stepping spec, a run of 1 km
# about 150 ms): it does not depend on the speed, which each pack's block carries, and the packs
# only read it (a Python-callback run steps its model, one at a time: that callback is global).
@functools.lru_cache(maxsize=16)
def _flat_twin(layout: Layout) -> Vehicle:
    return Vehicle(layout, flat=True)
