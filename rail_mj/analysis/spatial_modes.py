"""Mode names of a spatial vehicle (docs/spatial.md): the car body's and bogie frames' bounce,
pitch, roll and lower/upper sway besides the planar names. A spatial train's (docs/trains.md) with
the train's numbering of rail_mj.analysis.train_modes: `car body K bounce`, `car bodies (all) pitch`,
`bogie K (Jacobs) frame bounce`, and the train's snaking.

The model is flat: every coordinate is absolute, so a body's modal motion is read straight off
its joints: lateral y, yaw psi, vertical z, roll phi, pitch theta (docs/spatial.md). Each motion's
kinetic-energy measure (m|y|^2, Iz|psi|^2, m|z|^2, Ix|phi|^2, Iy|theta|^2) decides the name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rail_mj.layout.kinds import SpatialVehicle
from rail_mj.vehicle.joints import LATERAL, PITCH, ROLL, VERTICAL, YAW

if TYPE_CHECKING:
    from rail_mj.analysis.train_modes import TrainModes

MOTIONS = (LATERAL, YAW, VERTICAL, ROLL, PITCH)
# A sway's roll centre nearer the centre of mass than this (m): the body rolls about itself.
ROLL_ABOUT_ITSELF = 0.05


class SpatialModes:
    """Names and energy shares of a spatial vehicle's modes from their eigenvectors."""

    def __init__(self, vehicle: SpatialVehicle, model, train_modes: TrainModes | None = None):
        """`train_modes`: a spatial train's rail_mj.analysis.train_modes.TrainModes (its snaking test)."""
        self.layout, self.train_modes = vehicle.layout, train_modes
        dof = lambda body, m: int(model.joint(f"{body}_{m}").dofadr[0])  # noqa: E731
        bogies = [f"bogie{i + 1}" for i in range(len(vehicle.bogies.positions))]
        train = vehicle.train
        self.cars = ["carbody"] if train is None else [f"carbody{k + 1}" for k in range(len(train.cars))]
        self.groups: dict[str, list[str]] = {c: [] for c in self.cars} | {
            b: vehicle.bogies.wheelsets_of(i) for i, b in enumerate(bogies)
        }
        self.dofs: dict[str, list[int]] = {}
        self.inertia: dict[str, np.ndarray] = {}
        self.x: dict[str, float] = {}
        self.half: dict[str, float] = {}
        for body in [*self.cars, *bogies]:
            self.dofs[body] = [dof(body, m) for m in MOTIONS]
        for _group, wheelsets in self.groups.items():
            for w in wheelsets:
                self.dofs[w] = [dof(w, LATERAL), dof(w, YAW)]
        for b in range(1, model.nbody):
            name = model.body(b).name
            m, (ix, iy, iz) = model.body_mass[b], model.body_inertia[b]
            self.inertia[name] = np.array([m, iz, m, ix, iy])
            self.x[name] = model.body_pos[b][0]
        # Half the length over which a frame's pitch and yaw move its ends (bogie or wheelset spacing).
        xs = vehicle.bogies.positions
        if train is None:
            self.half["carbody"] = max(abs(x) for x in xs)
        else:  # each car body over its own bogies
            for c, car in zip(self.cars, train.cars):
                self.half[c] = max(abs(xs[i - 1] - car.position) for i in car.bogies)
        for frame, design in zip(bogies, vehicle.bogies.designs):  # each bogie's own wheelbase ([bogies.N])
            self.half[frame] = max(abs(x) for x in design.wheelset_positions)

    def energies(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Each body's kinetic-energy measures per motion (its own coordinates only)."""
        return {body: self.inertia[body][: len(d)] * np.abs(q[d]) ** 2 for body, d in self.dofs.items()}

    def _label(self, body: str) -> str:
        """`car body`, `bogie K frame`; in a train `car body K` and `bogie K (Jacobs) frame`."""
        if self.train_modes is not None:
            return self.train_modes.label(body)
        return "car body" if body == "carbody" else f"{body.replace('bogie', 'bogie ')} frame"

    def name(self, q: np.ndarray, share: dict[str, float], energy: dict[str, np.ndarray]) -> str:
        group_energy = {g: share[g] + sum(share[w] for w in ws) for g, ws in self.groups.items()}
        # The car bodies against the whole running gear first (as the planar names do in effect: a
        # bogie hunting drags the body, which may then carry more than either bogie alone), then
        # the bogie with most energy.
        cars = sum(group_energy[c] for c in self.cars)
        if cars >= 1.0 - cars:
            return self._car_name(q, share, energy)
        top = max((g for g in group_energy if g not in self.cars), key=group_energy.__getitem__)
        wheelsets = self.groups[top]
        label = self._label(top)
        if wheelsets and sum(share[w] for w in wheelsets) > share[top]:
            relative = sum(self._relative(q, top, w) for w in wheelsets)
            absolute = sum(energy[w].sum() for w in wheelsets)
            ws = max(wheelsets, key=share.__getitem__).removeprefix("wheelset")
            if relative >= 0.5 * absolute:
                return f"wheelset {ws} (secondary hunting)"
            return f"{label} {'/'.join(self._planar(top, energy))} (primary hunting)"
        return f"{label} {self._motion(q, top, energy)}"

    def _car_name(self, q, share, energy) -> str:
        """A car-body mode: one body's motion (`car body bounce`; in a train `car body K bounce`),
        several bodies moving together (`car bodies (all) bounce`, as rail_mj.analysis.train_modes names them:
        those with at least SUBSTANTIAL of the top one's energy, the top one's motion), or the
        train's snaking, when the bodies move in the lateral plane (lateral, yaw, roll above
        bounce and pitch) and TrainModes calls it snaking."""
        top = max(self.cars, key=share.__getitem__)
        if self.train_modes is None:
            return f"{self._label(top)} {self._motion(q, top, energy)}"
        from rail_mj.analysis.train_modes import SNAKING, SUBSTANTIAL

        planar = {c: (energy[c][0], energy[c][1]) for c in self.cars}
        lateral_plane = sum(energy[c][0] + energy[c][1] + energy[c][3] for c in self.cars)
        vertical_plane = sum(energy[c][2] + energy[c][4] for c in self.cars)
        if lateral_plane > vertical_plane and self.train_modes.snaking(q, share, planar):
            return SNAKING
        moving = [k + 1 for k, c in enumerate(self.cars) if share[c] >= SUBSTANTIAL * share[top]]
        motion = self._motion(q, top, energy)
        if len(moving) > 1:
            numbers = ", ".join(map(str, moving)) if len(moving) < len(self.cars) else "all"
            return f"car bodies ({numbers}) {motion}"
        return f"{self._label(top)} {motion}"

    def _planar(self, body: str, energy) -> tuple[str, str]:
        """('lateral', 'yaw') or ('yaw', 'lateral'): the lateral motion at the centre against that
        which yaw makes at the ends."""
        e, m = energy[body], self.inertia[body]
        at_ends = e[1] * self.half[body] ** 2 * m[0] / m[1]
        return (LATERAL, YAW) if e[0] >= at_ends else (YAW, LATERAL)

    def _motion(self, q, body: str, energy) -> str:
        """bounce, pitch, lateral, yaw, roll, lower sway or upper sway: the plane (vertical: bounce and
        pitch; lateral: lateral, yaw and roll) with most energy, then its largest motion, ends'
        motion for pitch and yaw. Lateral with roll is a sway, named by where its roll centre is:
        lower sway about a centre below the centre of mass (the lower-frequency pair member, the
        roof swinging most), upper sway about one above it (the floor swinging most)."""
        e, m = energy[body], self.inertia[body]
        ends = self.half[body] ** 2 * m[0]
        if e[2] + e[4] > e[0] + e[1] + e[3]:
            return "bounce" if e[2] >= e[4] * ends / m[4] else "pitch"
        # Roll carrying most of the lateral plane's energy is roll or a sway, whatever the round-off
        # of the other two says (springs all at the centre of mass's height: roll alone, lateral and
        # yaw at 1e-30, whose comparison would name it).
        rolls = e[3] > e[0] + e[1]
        first = self._planar(body, energy)[0]
        if rolls and e[0] < 0.05 * e[3]:
            return ROLL
        if not rolls and (first == YAW or e[3] < 0.05 * e[0]):
            return first
        if body not in self.cars:  # a frame's lateral and roll: no sway names (they are the body's)
            return "lateral/roll"
        y, phi = q[self.dofs[body][0]], q[self.dofs[body][3]]
        centre = (y / phi).real  # u_y = y - phi*r_z vanishes at r_z = y/phi above the centre of mass
        if abs(centre) < ROLL_ABOUT_ITSELF:
            return ROLL
        return "upper sway" if centre > 0 else "lower sway"

    def _relative(self, q, frame: str, wheelset: str) -> float:
        """Energy measure of a wheelset's motion relative to its frame (the primary's deflection)."""
        f, w = self.dofs[frame], self.dofs[wheelset]
        arm = self.x[wheelset] - self.x[frame]
        y = q[w[0]] - q[f[0]] - arm * q[f[1]]
        psi = q[w[1]] - q[f[1]]
        return float(self.inertia[wheelset][0] * abs(y) ** 2 + self.inertia[wheelset][1] * abs(psi) ** 2)
