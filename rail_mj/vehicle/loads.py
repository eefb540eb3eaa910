"""Axle loads and roll moments from a spatial vehicle's suspension: what the wheel loads Q
come from (docs/spatial.md, "Wheel loads").

A wheelset's vertical motion and roll are held by the rails, so the rails carry whatever the
primary suspension and the wheelset's weight put on it. Per wheelset, from the forces `f` of
its axlebox tendons (f = -k*(L - L0) - c*L', positive pushing the frame up or to +y and the
wheelset the other way):

    axle load         P = W_wheelset + sum over the z tendons of f
    roll moment       M = sum over z tendons of -s*d*f  +  sum over y tendons of h*f

M is about the rail level under the wheelset's centre (x axis, positive rolling it to the
left); s = +1 left, -1 right, d the axleboxes' half spacing, h their height above the rail.
Taking moments about the rail level leaves out the rails' lateral forces, which act there;
the wheelset's own lateral inertia (m*y''*r0) is left out, as the wheels' loads are read
quasi-statically from the suspension. `rail_mj.contact.creep` turns (P, M) into Q_left and Q_right
(`cone_wheel_loads` on cones, the contact table's equilibrium on profiles).

The same numbers serve the native callback (its block carries each wheelset's tendons with
their coefficients), the Python callback and the runs' outputs (tendon sensors).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from rail_mj.numerics import NUMERIC_COUPLES, NUMERIC_LOADS

SIDES = {"left": 1.0, "right": -1.0}


def tendon_forces(model: mujoco.MjModel, ids, lengths: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """Spring and damper forces of fixed tendons (no deadband) from their lengths and rates:
    f = -k*(L - L0) - c*L', positive pushing the upper body up (or along +x, +y)."""
    return (
        -model.tendon_stiffness[ids] * (lengths[..., ids] - model.tendon_lengthspring[ids, 0])
        - model.tendon_damping[ids] * rates[..., ids]
    )


def _couples_on(model: mujoco.MjModel, prefix: str) -> bool:
    try:
        model.numeric(prefix + NUMERIC_COUPLES)
    except KeyError:
        return False
    return True


def _elements(names) -> dict[str, tuple[str, str]]:
    """Tendon triples <lower>_<upper>_<side>_x|y|z by their z tendon: {z name: (lower, stem)}."""
    out = {}
    for name in names:
        stem, _, axis = name.rpartition("_")
        side = stem.rpartition("_")[2]
        if axis == "z" and side in SIDES and f"{stem}_y" in names and f"{stem}_x" in names:
            out[name] = (stem.partition("_")[0], stem)
    return out


@dataclasses.dataclass(frozen=True)
class ShearCouples:
    """The couples of the springs' preloads when the springs shear (docs/spatial.md, "Shear
    couples"): a spring carrying P between a lower body A and an upper body B, its upper seat
    moved by (dx, dy) from its lower one (the element's x and y tendon lengths), passes its load
    to A at the upper seat, not at A's own: the couple -P*dy about x and P*dx about y on A, which
    the linear tendons (their forces at each body's own point) leave out. For a bogie frame under
    the car body that is a roll and pitch moment on the frame (here); for a wheelset under its
    frame, a roll moment the rails take (`AxleLoads.shear`).

    Example:

        >>> from rail_mj.layout import load_layout
        >>> from rail_mj.vehicle.spec import Vehicle
        >>> model = Vehicle(load_layout("tests/data/manchester-coach-spatial.toml")).model
        >>> ShearCouples.of(model).elements[0]
        ('bogie1_carbody_left_z', 'bogie1_carbody_left_y', 'bogie1_carbody_left_x', 'bogie1_roll', 'bogie1_pitch')
    """

    elements: tuple[tuple[str, str, str, str, str], ...]  # (z, y, x tendon, lower roll joint, lower pitch joint)

    @classmethod
    def of(cls, model: mujoco.MjModel, prefix: str = "") -> ShearCouples | None:
        if not _couples_on(model, prefix):
            return None
        names = {n.removeprefix(prefix) for t in range(model.ntendon) if (n := model.tendon(t).name).startswith(prefix)}
        joints = {n.removeprefix(prefix) for j in range(model.njnt) if (n := model.joint(j).name).startswith(prefix)}
        elements = []
        for z, (lower, stem) in sorted(_elements(names).items()):
            if f"{lower}_roll" in joints and f"{lower}_pitch" in joints:
                elements.append((z, f"{stem}_y", f"{stem}_x", f"{lower}_roll", f"{lower}_pitch"))
        return cls(tuple(elements))

    def rows(self, model: mujoco.MjModel, prefix: str = "") -> np.ndarray:
        """(n, 5): z, y, x tendon ids and the lower body's roll and pitch dofs in `model`."""
        return np.array(
            [
                (
                    model.tendon(prefix + z).id,
                    model.tendon(prefix + y).id,
                    model.tendon(prefix + x).id,
                    model.joint(prefix + roll).dofadr[0],
                    model.joint(prefix + pitch).dofadr[0],
                )
                for z, y, x, roll, pitch in self.elements
            ],
            dtype=np.float64,
        ).reshape(-1, 5)

    def forces(self, model: mujoco.MjModel, lengths: np.ndarray, rates: np.ndarray, rows=None) -> np.ndarray:
        """The generalized forces (nv,) of the couples at tendon lengths and rates (ntendon,);
        `rows`: `self.rows(model)`, if the caller keeps them."""
        out = np.zeros(model.nv)
        rows = (self.rows(model) if rows is None else rows).astype(int)
        if len(rows):
            load = tendon_forces(model, rows[:, 0], lengths, rates)
            np.add.at(out, rows[:, 3], -load * lengths[rows[:, 1]])
            np.add.at(out, rows[:, 4], load * lengths[rows[:, 2]])
        return out


@dataclasses.dataclass(frozen=True)
class AxleLoads:
    """Each wheelset's axlebox tendons and what their forces put on the rails.

    Example:

        >>> from rail_mj.layout import load_layout
        >>> from rail_mj.vehicle.spec import Vehicle
        >>> vehicle = Vehicle(load_layout("tests/data/manchester-coach-spatial.toml"))
        >>> loads = AxleLoads.of(vehicle.model, vehicle.wheelset_names)
        >>> [name for name, _, _ in loads.tendons[0]][:2]
        ['wheelset1_bogie1_left_y', 'wheelset1_bogie1_left_z']
    """

    weight: float  # N, one wheelset
    nominal: float  # N, the wheel load the contact's coefficients are given at
    tendons: tuple[tuple[tuple[str, float, float], ...], ...]  # per wheelset: (tendon, on P, on M)
    spin_inertia: float = 0.0  # kg m^2, I_y for the gyroscopic terms; 0: off
    cone_gravity: bool = False  # the normal forces' lateral parts on coned wheels (rail_mj.contact.creep)
    # Per wheelset: its axleboxes' (z, y) tendons whose shear couples -P*dy it carries (M); empty: off.
    shear: tuple[tuple[tuple[str, str], ...], ...] = ()

    @classmethod
    def of(cls, model: mujoco.MjModel, wheelset_names, prefix: str = "") -> AxleLoads | None:
        """Read from a model built by rail_mj.vehicle.spec (None: not a spatial vehicle with gravity,
        whose wheels carry the layout's static load)."""
        try:
            data = model.numeric(prefix + NUMERIC_LOADS).data
        except KeyError:
            return None
        weight, nominal, spacing, height, spin, gravity = data[:6]
        axleboxes = [(spacing, height)] * len(wheelset_names)
        if len(data) > 6:  # each wheelset's own
            if len(data) != 6 + 2 * len(wheelset_names):
                raise ValueError(
                    f"numeric {prefix + NUMERIC_LOADS}: {len(data)} entries for {len(wheelset_names)} "
                    f"wheelsets: 6, or 6 and 2 per wheelset"
                )
            axleboxes = data[6:].reshape(-1, 2).tolist()
        names = [n.removeprefix(prefix) for t in range(model.ntendon) if (n := model.tendon(t).name).startswith(prefix)]
        tendons = []
        for w, (spacing, height) in zip(wheelset_names, axleboxes):
            mine = []
            for name in sorted(n for n in names if n.startswith(f"{w}_bogie")):
                side, axis = name.split("_")[-2:]
                if side in SIDES and axis == "z":
                    mine.append((name, 1.0, -SIDES[side] * spacing))
                elif side in SIDES and axis == "y":
                    mine.append((name, 0.0, height))
            tendons.append(tuple(mine))
        shear: tuple[tuple[tuple[str, str], ...], ...] = ()
        if _couples_on(model, prefix):
            elements = _elements(set(names))
            shear = tuple(
                tuple((z, f"{stem}_y") for z, (lower, stem) in sorted(elements.items()) if lower == w)
                for w in wheelset_names
            )
        return cls(float(weight), float(nominal), tuple(tendons), float(spin), bool(gravity), shear)

    def contact(self) -> dict:
        """The keywords `rail_mj.contact.creep.contact_forces` takes besides the loads."""
        return {"nominal": self.nominal, "spin_inertia": self.spin_inertia, "cone_gravity": self.cone_gravity}

    def rows(self, model: mujoco.MjModel, wheelset: int, prefix: str = "") -> np.ndarray:
        """(n, 3): tendon id in `model`, coefficient on P, coefficient on M."""
        return np.array(
            [(model.tendon(prefix + name).id, a, b) for name, a, b in self.tendons[wheelset]], dtype=np.float64
        ).reshape(-1, 3)

    def shear_rows(self, model: mujoco.MjModel, wheelset: int, prefix: str = "") -> np.ndarray:
        """(n, 2): the z and y tendon ids in `model` of the wheelset's shear couples."""
        pairs = self.shear[wheelset] if self.shear else ()
        return np.array(
            [(model.tendon(prefix + z).id, model.tendon(prefix + y).id) for z, y in pairs], dtype=np.float64
        ).reshape(-1, 2)

    def evaluate(self, model: mujoco.MjModel, lengths: np.ndarray, rates: np.ndarray, prefix: str = ""):
        """(P, M), each (..., n_wheelsets), from tendon lengths and rates (..., ntendon) of
        `model` (MuJoCo's data.ten_length and ten_velocity, or recorded)."""
        shape = lengths.shape[:-1] + (len(self.tendons),)
        load, moment = np.full(shape, self.weight), np.zeros(shape)
        for i in range(len(self.tendons)):
            rows = self.rows(model, i, prefix)
            ids = rows[:, 0].astype(int)
            force = tendon_forces(model, ids, lengths, rates)
            load[..., i] += force @ rows[:, 1]
            moment[..., i] += force @ rows[:, 2]
            pairs = self.shear_rows(model, i, prefix).astype(int)
            if len(pairs):  # the axlebox loads passed on at the frame's seats
                moment[..., i] -= np.sum(
                    tendon_forces(model, pairs[:, 0], lengths, rates) * lengths[..., pairs[:, 1]], axis=-1
                )
        return load, moment
