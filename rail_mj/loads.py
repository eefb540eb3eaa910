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
quasi-statically from the suspension. `rail_mj.creep` turns (P, M) into Q_left and Q_right
(`cone_wheel_loads` on cones, the contact table's equilibrium on profiles).

The same numbers serve the native callback (its block carries each wheelset's tendons with
their coefficients), the Python callback and the runs' outputs (tendon sensors).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

# Wheelset weight (N), nominal wheel load (N), axlebox half spacing and height (m), the wheelset's
# spin inertia I_y (kg m^2; 0: no gyroscopic terms), the cones' gravitational stiffness on (1) or off (0);
# then, when the bogies' axleboxes differ ([bogies.N.axlebox]), each wheelset's axlebox half spacing and
# height (2 per wheelset, wheelset 1 first), which take the place of the two above.
NUMERIC_LOADS = "rail_mj/loads"
SIDES = {"left": 1.0, "right": -1.0}


@dataclasses.dataclass(frozen=True)
class AxleLoads:
    """Each wheelset's axlebox tendons and what their forces put on the rails.

    Example:

        >>> from rail_mj.layout import load_layout
        >>> from rail_mj.model import Vehicle
        >>> vehicle = Vehicle(load_layout("tests/data/manchester-coach-spatial.toml"))
        >>> loads = AxleLoads.of(vehicle.model, vehicle.wheelset_names)
        >>> [name for name, _, _ in loads.tendons[0]][:2]
        ['wheelset1_bogie1_left_y', 'wheelset1_bogie1_left_z']
    """

    weight: float  # N, one wheelset
    nominal: float  # N, the wheel load the contact's coefficients are given at
    tendons: tuple[tuple[tuple[str, float, float], ...], ...]  # per wheelset: (tendon, on P, on M)
    spin_inertia: float = 0.0  # kg m^2, I_y for the gyroscopic terms; 0: off
    cone_gravity: bool = False  # the normal forces' lateral parts on coned wheels (rail_mj.creep)

    @classmethod
    def of(cls, model: mujoco.MjModel, wheelset_names, prefix: str = "") -> "AxleLoads | None":
        """Read from a model built by rail_mj.model (None: not a spatial vehicle with gravity,
        whose wheels carry the layout's static load)."""
        try:
            data = model.numeric(prefix + NUMERIC_LOADS).data
        except KeyError:
            return None
        weight, nominal, spacing, height, spin, gravity = data[:6]
        axleboxes = [(spacing, height)] * len(wheelset_names)
        if len(data) > 6:  # each wheelset's own
            if len(data) != 6 + 2 * len(wheelset_names):
                raise ValueError(f"numeric {prefix + NUMERIC_LOADS}: {len(data)} entries for {len(wheelset_names)} "
                                 f"wheelsets: 6, or 6 and 2 per wheelset")
            axleboxes = data[6:].reshape(-1, 2).tolist()
        names = [model.tendon(t).name.removeprefix(prefix) for t in range(model.ntendon)]
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
        return cls(float(weight), float(nominal), tuple(tendons), float(spin), bool(gravity))

    def contact(self) -> dict:
        """The keywords `rail_mj.creep.contact_forces` takes besides the loads."""
        return {"nominal": self.nominal, "spin_inertia": self.spin_inertia, "cone_gravity": self.cone_gravity}

    def rows(self, model: mujoco.MjModel, wheelset: int, prefix: str = "") -> np.ndarray:
        """(n, 3): tendon id in `model`, coefficient on P, coefficient on M."""
        return np.array([(model.tendon(prefix + name).id, a, b) for name, a, b in self.tendons[wheelset]],
                        dtype=np.float64).reshape(-1, 3)

    def evaluate(self, model: mujoco.MjModel, lengths: np.ndarray, rates: np.ndarray, prefix: str = ""):
        """(P, M), each (..., n_wheelsets), from tendon lengths and rates (..., ntendon) of
        `model` (MuJoCo's data.ten_length and ten_velocity, or recorded)."""
        shape = lengths.shape[:-1] + (len(self.tendons),)
        load, moment = np.full(shape, self.weight), np.zeros(shape)
        for i in range(len(self.tendons)):
            rows = self.rows(model, i, prefix)
            ids = rows[:, 0].astype(int)
            force = (-model.tendon_stiffness[ids] * (lengths[..., ids] - model.tendon_lengthspring[ids, 0])
                     - model.tendon_damping[ids] * rates[..., ids])
            load[..., i] += force @ rows[:, 1]
            moment[..., i] += force @ rows[:, 2]
        return load, moment
