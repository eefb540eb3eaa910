"""Trains: the names of a train's modes (docs/trains.md).

A train's model is flat (rail_mj.vehicle.train.add_train): every body's joints are absolute, so
the grouping of rail_mj.analysis.stability (a frame and the wheelsets nested under it) is read here
from the layout instead: each bogie frame with its wheelsets, and each car body.

A mode is named after the group with most of its kinetic energy, as for one vehicle
(`Stability._name`), with the car or bogie number on the train; a bogie carried by two
car bodies is called a Jacobs bogie. When the car bodies carry most of the energy and
adjacent bodies yaw in antiphase (each pair where both yaw substantially, at least one
such pair), the mode is the train's snaking: 'train snaking (car bodies yawing in
alternation)'.
"""

from __future__ import annotations

import numpy as np

from rail_mj.layout import Layout
from rail_mj.layout.kinds import Bogies
from rail_mj.layout.reader import Train

# Car bodies must carry at least this share of a mode's kinetic energy for it to be
# named after them, and a body's yaw counts in the alternation when it is at least
# SUBSTANTIAL of the largest car-body yaw in the mode.
CAR_SHARE = 0.5
SUBSTANTIAL = 0.3
SNAKING = "train snaking (car bodies yawing in alternation)"


class TrainModes:
    """Mode names for a train layout, from the eigenvector's absolute body motions."""

    def __init__(self, layout: Layout, train: Train, bogies: Bogies, model, absolute: dict, mass: dict):
        self.layout, self.model, self.absolute, self.mass = layout, model, absolute, mass
        self.train, self.bogies = train, bogies
        self.cars = [f"carbody{k + 1}" for k in range(len(train.cars))]
        self.bogie_x = bogies.positions
        self.groups = {f"bogie{i + 1}": bogies.wheelsets_of(i) for i in range(len(self.bogie_x))}
        self.wheelset_x = dict(zip((f"wheelset{i + 1}" for i in range(layout.n_wheelsets)), layout.wheelset_x))

    def arms(self) -> dict[str, float]:
        """(Half a body's length)^2 * m / Iz: yaw energy as end-lateral energy (see
        Stability._arm): a car body's half length over its bogies, a bogie's wheelbase."""
        out = {}
        for name, car in zip(self.cars, self.train.cars):
            half = max(abs(self.bogie_x[i - 1] - car.position) for i in car.bogies)
            out[name] = half**2 * car.mass / car.inertia[2]
        b = self.bogies.bogie
        half = max(abs(x) for x in b.wheelset_positions)
        for name in self.groups:
            out[name] = half**2 * b.mass / b.inertia[2]
        return out

    def _energy(self, body: str, y: complex, psi: complex) -> float:
        m, iz = self.mass[body]
        return m * abs(y) ** 2 + iz * abs(psi) ** 2

    def yaw(self, q: np.ndarray) -> list[complex]:
        """Each car body's modal yaw (complex amplitude), front first."""
        return [complex(self.absolute[c][1] @ q) for c in self.cars]

    def snaking(self, q: np.ndarray, share: dict[str, float], motion: dict) -> bool:
        """Whether the car bodies carry the mode, mostly in yaw (their yaw's energy as end-lateral
        motion above their lateral motion's), and adjacent ones yaw in antiphase."""
        if len(self.cars) < 2 or sum(share[c] for c in self.cars) < CAR_SHARE:
            return False
        arms = self.arms()
        if sum(motion[c][1] * arms[c] for c in self.cars) < sum(motion[c][0] for c in self.cars):
            return False
        psi = self.yaw(q)
        big = max(abs(p) for p in psi)
        pairs = [(a, b) for a, b in zip(psi, psi[1:]) if min(abs(a), abs(b)) >= SUBSTANTIAL * big]
        return bool(pairs) and all((a * b.conjugate()).real < 0 for a, b in pairs)

    def label(self, body: str) -> str:
        if body.startswith("carbody"):
            return f"car body {body.removeprefix('carbody')}"
        i = int(body.removeprefix("bogie"))
        jacobs = " (Jacobs)" if len(self.train.cars_on(i)) == 2 else ""
        return f"bogie {i}{jacobs} frame"

    def name(self, q: np.ndarray, share: dict[str, float], motion: dict, direction) -> str:
        """The mode's name; `direction(body, motion)` orders 'lateral' and 'yaw' as
        Stability._direction does."""
        if self.snaking(q, share, motion):
            return SNAKING
        energy = {c: share[c] for c in self.cars}
        energy.update({g: share[g] + sum(share[w] for w in ws) for g, ws in self.groups.items()})
        top = max(energy, key=energy.__getitem__)
        first, second = direction(top, motion)
        if top in self.cars:
            # Car bodies that move with it, each with at least SUBSTANTIAL of its energy.
            moving = [k + 1 for k, c in enumerate(self.cars) if share[c] >= SUBSTANTIAL * share[top]]
            if len(moving) > 1:
                arms = self.arms()
                lateral = sum(motion[f"carbody{k}"][0] for k in moving)
                yaw = sum(motion[f"carbody{k}"][1] * arms[f"carbody{k}"] for k in moving)
                numbers = ", ".join(map(str, moving)) if len(moving) < len(self.cars) else "all"
                return f"car bodies ({numbers}) {'lateral' if lateral >= yaw else 'yaw'}"
            return f"{self.label(top)} {first}"
        wheelsets = self.groups[top]
        ws = max(wheelsets, key=share.__getitem__)
        # The wheelsets' motion relative to their frame: the primary suspension's deflection.
        jy, jpsi = self.absolute[top]
        y_f, psi_f = jy @ q, jpsi @ q
        x_f = self.bogie_x[int(top.removeprefix("bogie")) - 1]
        relative = absolute = 0.0
        for w in wheelsets:
            wy, wpsi = self.absolute[w]
            y, psi = wy @ q, wpsi @ q
            relative += self._energy(w, y - y_f - (self.wheelset_x[w] - x_f) * psi_f, psi - psi_f)
            absolute += self._energy(w, y, psi)
        if relative < 0.5 * absolute:
            return f"{self.label(top)} {first}/{second} (primary hunting)"
        if share[top] > sum(share[w] for w in wheelsets):
            return f"{self.label(top)} {first}"
        return f"wheelset {ws.removeprefix('wheelset')} (secondary hunting)"
