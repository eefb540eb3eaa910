"""Which vehicle a layout describes, and on which contact, as types: `Planar`, `TrainOfCars` or
`SpatialVehicle`; `Coned`, `Hertzian` or `Profiled`.

A `Layout` keeps the tables the user wrote, and most are optional: `[bogie]`, `[train]`,
`[spatial]`. Which of them are there decides the vehicle, and the reader has already refused
the combinations that describe none (a `[train]` or `[spatial]` without `[bogie]`, a spatial
vehicle on a fixed car body). `vehicle_kind(layout)` reads the decision once, and each stage
(the model builder, the mode names, the run's columns) takes the kind it needs, whose fields
are then never None: the variants are types, not `is None` tests in every stage.

    Planar          a car body (fixed or free) on bogies or on wheelsets hung from it; lateral and yaw
    TrainOfCars     car bodies in a row on bogies, Jacobs bogies and couplings (docs/trains.md)
    SpatialVehicle  a car body, or a train of them, on bogies in five motions (docs/spatial.md)

and `contact_model(layout)` the contact under it, from [contact], [flange] and [profiles]:

    Coned           coned wheels, creep coefficients as given; a flange spring or none
    Hertzian        coned wheels with Hertz's ellipse and Kalker's coefficients from [contact]
    Profiled        wheel and rail profiles, every contact point from their contact table

Example:

    >>> from rail_mj.layout import load_layout
    >>> kind = vehicle_kind(load_layout("models/manchester-coach/manchester-coach.toml"))
    >>> type(kind).__name__, kind.bogies.positions, kind.bogies.wheelsets_per_bogie
    ('Planar', (9.5, -9.5), 2)
    >>> contact = contact_model(load_layout("models/manchester-coach/manchester-coach.toml"))
    >>> type(contact).__name__, contact.flanged
    ('Coned', True)
"""

from __future__ import annotations

import dataclasses

from rail_mj.layout.reader import Bogie, BogieDesign, Contact, Flange, Layout, Profiles, Spatial, Suspension, Train


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


# --- the contact model ---------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Coned:
    """Coned wheels (docs/dynamics.md): the linear contact geometry of `wheelset` (conicity,
    contact spacing, flangeway clearance) with the creep coefficients of [creep]; `flange` the
    flange spring beyond the clearance, None without (the classical linear model)."""

    layout: Layout
    flange: Flange | None

    @property
    def flanged(self) -> bool:
        return self.flange is not None


@dataclasses.dataclass(frozen=True)
class Hertzian(Coned):
    """Coned wheels whose creep coefficients come from Hertz's ellipse of [contact] and Kalker's
    table (docs/contact.md); FASTSIM works on that ellipse."""

    contact: Contact = dataclasses.field(kw_only=True)


@dataclasses.dataclass(frozen=True)
class Profiled:
    """Wheel and rail profiles (docs/dynamics-on-profiles.md): every contact point from their
    contact table, the flanges rigid walls of the profiles."""

    layout: Layout
    profiles: Profiles

    @property
    def flanged(self) -> bool:
        return True


ContactModel = Coned | Hertzian | Profiled


def contact_model(layout: Layout) -> ContactModel:
    """The contact `layout` describes (see Coned, Hertzian, Profiled)."""
    if layout.profiles is not None:
        return Profiled(layout, layout.profiles)
    if layout.contact is not None:
        return Hertzian(layout, layout.flange, contact=layout.contact)
    return Coned(layout, layout.flange)
