"""Which vehicle a layout describes, as a type: `Planar`, `TrainOfCars` or `SpatialVehicle`.

A `Layout` keeps the tables the user wrote, and most are optional: `[bogie]`, `[train]`,
`[spatial]`. Which of them are there decides the vehicle, and the reader has already refused
the combinations that describe none (a `[train]` or `[spatial]` without `[bogie]`, a spatial
vehicle on a fixed car body). `vehicle_kind(layout)` reads the decision once, and each stage
(the model builder, the mode names, the run's columns) takes the kind it needs, whose fields
are then never None: the variants are types, not `is None` tests in every stage.

    Planar          a car body (fixed or free) on bogies or on wheelsets hung from it; lateral and yaw
    TrainOfCars     car bodies in a row on bogies, Jacobs bogies and couplings (docs/trains.md)
    SpatialVehicle  a car body, or a train of them, on bogies in five motions (docs/spatial.md)

Example:

    >>> from rail_mj.layout import load_layout
    >>> kind = vehicle_kind(load_layout("models/manchester-coach/manchester-coach.toml"))
    >>> type(kind).__name__, kind.bogies.positions, kind.bogies.wheelsets_per_bogie
    ('Planar', (9.5, -9.5), 2)
"""

from __future__ import annotations

import dataclasses

from rail_mj.layout.reader import Bogie, BogieDesign, Layout, Spatial, Suspension, Train


@dataclasses.dataclass(frozen=True)
class Bogies:
    """A vehicle's bogies: [bogie]'s frame, the secondary suspension that carries the car body
    on them, each bogie's centre along the vehicle (leading first) and each bogie's design (a
    spatial vehicle's [bogies.N] over [bogie]; [bogie] itself otherwise)."""

    bogie: Bogie
    secondary: Suspension
    positions: tuple[float, ...]
    designs: tuple[Bogie | BogieDesign, ...]

    @property
    def wheelsets_per_bogie(self) -> int:
        # [bogies.N] may move a bogie's wheelsets but not change their number (the reader refuses it).
        return len(self.bogie.wheelset_positions)

    def wheelsets_of(self, index: int) -> list[str]:
        """The wheelsets of bogie `index` (0-based, leading first), by name."""
        n = self.wheelsets_per_bogie
        return [f"wheelset{index * n + j + 1}" for j in range(n)]


@dataclasses.dataclass(frozen=True)
class Planar:
    """One car body, lateral and yaw: on `bogies`, or with `hung_wheelsets` (x from the body's
    centre) hanging from it on the primary suspension; exactly one of the two is given."""

    layout: Layout
    bogies: Bogies | None
    hung_wheelsets: tuple[float, ...] = ()

    @property
    def supports(self) -> tuple[float, ...]:
        """x of what the car body rests on: its bogies' centres, or its wheelsets."""
        return self.bogies.positions if self.bogies is not None else self.hung_wheelsets


@dataclasses.dataclass(frozen=True)
class TrainOfCars:
    """Several car bodies in a row on bogies, lateral and yaw (docs/trains.md)."""

    layout: Layout
    train: Train
    bogies: Bogies


@dataclasses.dataclass(frozen=True)
class SpatialVehicle:
    """A car body on bogies in lateral, vertical, roll, pitch and yaw (docs/spatial.md); with
    `train`, a spatial train of car bodies (docs/trains.md)."""

    layout: Layout
    spatial: Spatial
    bogies: Bogies
    train: Train | None = None

    @property
    def supports(self) -> tuple[float, ...]:
        """x of what the car bodies rest on: the bogies' centres."""
        return self.bogies.positions


VehicleKind = Planar | TrainOfCars | SpatialVehicle


def _bogies(layout: Layout) -> Bogies | None:
    if layout.bogie is None:
        return None
    # The reader requires [secondary] and bogie positions with [bogie]; a Layout built by hand
    # without them describes no vehicle.
    if layout.secondary is None or layout.carbody.bogie_positions is None:
        raise ValueError(f"{layout.source}: [bogie] without [secondary] or bogie positions")
    positions = layout.carbody.bogie_positions
    designs: tuple[Bogie | BogieDesign, ...] = (
        layout.spatial.bogies
        if layout.spatial is not None and layout.spatial.bogies
        else (layout.bogie,) * len(positions)
    )
    return Bogies(layout.bogie, layout.secondary, positions, designs)


def vehicle_kind(layout: Layout) -> VehicleKind:
    """The vehicle `layout` describes (see the module's docstring)."""
    bogies = _bogies(layout)
    if layout.spatial is not None or layout.train is not None:
        if bogies is None:  # refused by the reader: a train's and a spatial vehicle's bodies rest on bogies
            raise ValueError(f"{layout.source}: [train] and [spatial] need [bogie]")
        if layout.spatial is not None:
            return SpatialVehicle(layout, layout.spatial, bogies, layout.train)
        assert layout.train is not None
        return TrainOfCars(layout, layout.train, bogies)
    if bogies is None:
        if layout.carbody.wheelset_positions is None:
            raise ValueError(f"{layout.source}: neither [bogie] nor carbody.wheelset_positions")
        return Planar(layout, None, layout.carbody.wheelset_positions)
    return Planar(layout, bogies)
