"""Layout files: a vehicle described in TOML, read and checked into a `Layout`.

The layout is the users' interface and the one source of truth for every
physical number of a vehicle; the model, the creep forces and the recording all
read it from here. Units are SI throughout (kg, m, N, s, rad).

`layout_from_dict` reads each table with a reader of its own, in a fixed order, and
resolves what a table leaves to others: a wheelset's conicity and flangeway clearance to
[profiles], the wheel load to the vehicle's weight, f11..f33 to [contact] or [profiles]
(rail_mj.contact.derived computes them). The `Layout` holds the numbers the vehicle runs
with; `Layout.given` what the user wrote in [wheelset] and [creep], None where a number was
left out; `Layout.derived` which numbers were derived, and from what.

Example:

    >>> from rail_mj.layout import load_layout
    >>> layout = load_layout("models/manchester-coach/manchester-coach.toml")
    >>> layout.n_wheelsets, layout.wheelset.rolling_radius
    (4, 0.46)
    >>> layout.given.wheelset.wheel_load is None, round(layout.wheelset.wheel_load)
    (True, 54546)
    >>> dict(layout.derived)
    {'wheelset.wheel_load': 'static weight of the vehicle shared equally by its wheels'}

Every problem with a file raises `LayoutError`, whose message is one line naming
the file, the key and what is wrong.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import rail_mj.contact.derived as derive
from rail_mj.contact.laws import FASTSIM, LAWS, LINEAR, POLACH, SHEN_HEDRICK_ELKINS  # noqa: F401  (re-exported)
from rail_mj.contact.pair import STANDARD_PROFILES, Profiles, read_profiles
from rail_mj.files import read_input
from rail_mj.practice import RANGES
from rail_mj.units import GRAVITY

if TYPE_CHECKING:
    from rail_mj.contact.hertz import ContactPatch

NAME_PATTERN = re.compile(r"^[A-Za-z0-9_-]+$")
# Beyond these no vehicle is meant, and arithmetic on them overflows.
MAX_MAGNITUDE = 1e15  # any number in SI units
MAX_POSITION = 1000.0  # m from the body centre


class LayoutError(ValueError):
    """A layout file that cannot describe a vehicle; the message is one line."""


@dataclasses.dataclass(frozen=True)
class Wheelset:
    mass: float
    inertia: tuple[float, float, float]  # about x (roll), y (axle), z (yaw)
    rolling_radius: float  # r0
    contact_half_spacing: float  # b
    conicity: float  # lam, effective
    flangeway_clearance: float = 0.008
    wheel_load: float | None = None  # N per wheel; None: the static weight shared equally


@dataclasses.dataclass(frozen=True)
class Creep:
    f11: float  # N, longitudinal
    f22: float  # N, lateral
    f23: float = 0.0  # N m, lateral/spin
    f33: float = 0.0  # N m^2, spin
    law: str = "linear"  # one of rail_mj.contact.creep.LAWS
    friction: float | None = None  # mu, for the saturating laws
    # Polach's falling friction (2005), mu = mu0*((1 - A)*exp(-B*w) + A) with slip velocity
    # w: A = mu_infinity/mu0 and B. A = 1 keeps mu constant (the 1999 law).
    falling_friction_ratio: float = 1.0  # A
    falling_friction_rate: float = 0.0  # B, s/m


@dataclasses.dataclass(frozen=True)
class GivenWheelset:
    """[wheelset] as written and checked (`Given`): None where the user left a number to other
    tables: `conicity` and `flangeway_clearance` to [profiles], `wheel_load` to the vehicle's
    weight. On cones an omitted flangeway_clearance takes its default, 8 mm, as in `Wheelset`."""

    mass: float
    inertia: tuple[float, float, float]
    rolling_radius: float
    contact_half_spacing: float
    conicity: float | None
    flangeway_clearance: float | None
    wheel_load: float | None

    def resolved(self, conicity: float, flangeway_clearance: float, wheel_load: float | None) -> Wheelset:
        """The `Wheelset` with the numbers left to other tables filled in."""
        return Wheelset(
            self.mass,
            self.inertia,
            self.rolling_radius,
            self.contact_half_spacing,
            conicity,
            flangeway_clearance,
            wheel_load,
        )


@dataclasses.dataclass(frozen=True)
class GivenCreep:
    """[creep] as written and checked (`Given`): f11..f33 None when left to [contact] or to the
    profiles (given f11 and f22, f23 and f33 default to 0); the law and friction as in `Creep`."""

    f11: float | None
    f22: float | None
    f23: float | None
    f33: float | None
    law: str = "linear"
    friction: float | None = None
    falling_friction_ratio: float = 1.0
    falling_friction_rate: float = 0.0

    def coefficients(self) -> dict[str, float] | None:
        """f11..f33 as given (they are given together or not at all), None when left out."""
        if self.f11 is None or self.f22 is None or self.f23 is None or self.f33 is None:
            return None
        return {"f11": self.f11, "f22": self.f22, "f23": self.f23, "f33": self.f33}


@dataclasses.dataclass(frozen=True)
class Given:
    """What the user wrote in the two tables whose numbers a layout may leave to other tables,
    before anything was derived (`Layout.given`). Every other table of a `Layout` is as written."""

    wheelset: GivenWheelset
    creep: GivenCreep


@dataclasses.dataclass(frozen=True)
class Derived(Mapping[str, str]):
    """The numbers of a `Layout` the reader derived rather than read (`Layout.derived`): each
    layout key ("wheelset.conicity", "creep.f11", ...) with where its number came from (the
    descriptions of rail_mj.contact.derived). A read-only mapping, in the order derived; empty
    when the layout gives every number itself.

        >>> d = Derived((("wheelset.wheel_load", "static weight of the vehicle shared equally by its wheels"),))
        >>> "wheelset.wheel_load" in d, "wheelset.conicity" in d, len(d)
        (True, False, 1)
    """

    sources: tuple[tuple[str, str], ...] = ()

    def __getitem__(self, key: str) -> str:
        for k, source in self.sources:
            if k == key:
                return source
        raise KeyError(key)

    def __iter__(self) -> Iterator[str]:
        return (k for k, _ in self.sources)

    def __len__(self) -> int:
        return len(self.sources)


@dataclasses.dataclass(frozen=True)
class Flange:
    """Flange contact past the flangeway clearance (wheelset.flangeway_clearance)."""

    # A round value of the order of a rail's lateral stiffness on its fastenings.
    stiffness: float = 15.0e6  # N/m
    damping: float = 0.0  # N s/m
    angle: float = math.radians(70.0)  # rad; flanges are cut at 65-75 degrees


@dataclasses.dataclass(frozen=True)
class Contact:
    """The bodies in contact, from which Hertz and Kalker give the creep coefficients."""

    young_modulus: float  # Pa, wheel and rail alike
    poisson_ratio: float
    rail_transverse_radius: float | None  # m, the rail head's crown; None with [profiles]
    wheel_transverse_radius: float | None  # m; None: a conical tread, flat across


@dataclasses.dataclass(frozen=True)
class Suspension:
    """A spring-damper acting on a whole body: lateral and yaw."""

    lateral_stiffness: float
    yaw_stiffness: float
    lateral_damping: float = 0.0
    yaw_damping: float = 0.0


@dataclasses.dataclass(frozen=True)
class Spring:
    """A spatial suspension element ([primary.axlebox], [secondary.spring]; docs/spatial.md): one
    spring-damper on each side, at y = +/-spacing and `height` above the rail, acting along x, y, z
    between the attachment points of the two bodies it joins."""

    kx: float  # N/m
    ky: float
    kz: float
    cx: float = 0.0  # N s/m
    cy: float = 0.0
    cz: float = 0.0
    spacing: float = 1.0  # m, lateral half-distance of the two sides
    height: float = 0.0  # m above the rail

    def planar(self) -> Suspension:
        """The pair's planar equivalent (docs/manchester-coach.md): lateral 2*ky, yaw 2*kx*d^2."""
        d2 = self.spacing**2
        return Suspension(2 * self.ky, 2 * self.kx * d2, 2 * self.cy, 2 * self.cx * d2)


@dataclasses.dataclass(frozen=True)
class Damper:
    """A secondary damper of a spatial vehicle, between each bogie frame and the car body
    ([secondary.lateral_damper]: one on the centreline, acting along y; [secondary.yaw_damper]: one
    on each side at y = +/-spacing, acting along x; docs/spatial.md). Damping only."""

    c: float  # N s/m, each damper
    height: float  # m above the rail
    spacing: float = 0.0  # m; 0: on the centreline


@dataclasses.dataclass(frozen=True)
class BumpStop:
    """[secondary.bump_stop] (docs/spatial.md): a lateral stop between each bogie frame and the car
    body, over the bogie centre at `height`. No force within +/-free_play; beyond it the force
    interpolates linearly through (free_play, 0) and (deflection[i], force[i]), the last segment's
    slope continuing past the table; the same either way."""

    free_play: float  # m
    deflection: tuple[float, ...]  # m, increasing, the first beyond free_play
    force: tuple[float, ...]  # N at each deflection, non-decreasing
    height: float  # m above the rail

    def deadbands(self) -> tuple[tuple[float, float], ...]:
        """(half-width d_i, stiffness k_i) of each breakpoint, the free play first: a deadband
        spring per breakpoint, k_i the rise of the table's slope there, sums to the table exactly."""
        ds, fs = (self.free_play, *self.deflection), (0.0, *self.force)
        slopes = [(f1 - f0) / (d1 - d0) for d0, d1, f0, f1 in zip(ds, ds[1:], fs, fs[1:])]
        return tuple((d, s - before) for d, s, before in zip(ds, slopes, [0.0, *slopes]))


@dataclasses.dataclass(frozen=True)
class Spatial:
    """[spatial] (docs/spatial.md): car body and bogie frames move laterally, vertically, in roll,
    pitch and yaw; wheelsets laterally and in yaw. Heights are of the centres of mass above the rail."""

    carbody_height: float
    bogie_height: float
    primary: Spring  # per axlebox
    secondary: Spring  # per side of each bogie
    gravity: bool = True
    # [secondary.*] besides the springs, each per bogie (docs/spatial.md); None: not fitted.
    lateral_damper: Damper | None = None
    yaw_damper: Damper | None = None
    anti_roll_bar: float | None = None  # N m/rad, on the relative roll of car body and frame
    bump_stop: BumpStop | None = None
    # The weight's gravitational stiffness (docs/spatial.md): the preloads' second-order potential
    # as roll and pitch stiffness and, on coned wheels, the normal forces' lateral parts (on
    # profiles [profiles] has its own switch); no effect without gravity.
    gravitational_stiffness: bool = True
    # The spinning wheelsets' gyroscopic yaw-roll coupling (docs/spatial.md); needs gravity (the
    # wheel loads from the suspension).
    gyroscopic: bool = True
    # Each bogie's design, leading first ([bogie] and [primary.axlebox] with the [bogies.N]
    # overrides, docs/spatial.md); `primary` and Layout.bogie stay the defaults.
    bogies: tuple[BogieDesign, ...] = ()
    # m above the rail: where ride comfort reads the car body's floor (rail_mj.analysis.ride,
    # EN 12299); None: at the car body's centre of mass.
    floor_height: float | None = None


@dataclasses.dataclass(frozen=True)
class Bogie:
    mass: float
    inertia: tuple[float, float, float]
    wheelset_positions: tuple[float, ...]  # x from the bogie centre, leading first


@dataclasses.dataclass(frozen=True)
class BogieDesign:
    """One bogie of a spatial vehicle ([bogies.N], docs/spatial.md): [bogie]'s frame and
    [primary.axlebox]'s axleboxes with that bogie's overrides; the defaults where none."""

    mass: float
    inertia: tuple[float, float, float]
    wheelset_positions: tuple[float, ...]  # x from the bogie centre, leading first
    axlebox: Spring  # per axlebox


@dataclasses.dataclass(frozen=True)
class CarBody:
    fixed: bool
    mass: float | None
    inertia: tuple[float, float, float] | None
    bogie_positions: tuple[float, ...] | None
    wheelset_positions: tuple[float, ...] | None
    # The body as drawn (rail_mj.vehicle.looks; no effect on the dynamics), m: over its ends,
    # across, and from its underside to its top. None: a coach's (docs/review.md).
    length: float | None = None
    width: float | None = None
    height: float | None = None


@dataclasses.dataclass(frozen=True)
class Car:
    """One car body of a train ([[car]]): x of its centre and its length along the train."""

    mass: float
    inertia: tuple[float, float, float]
    position: float  # m, x of the centre along the train
    length: float  # m, over the body ends
    bogies: tuple[int, ...]  # the bogies (1-based, train numbering) that carry it, leading first
    # A spatial train's: its centre of mass above the rail ([[car]] height, else [spatial]'s
    # carbody_height; docs/trains.md); None in a planar train.
    height: float | None = None


@dataclasses.dataclass(frozen=True)
class Coupling:
    """An inter-car element ([[coupling]]) between adjacent car bodies `cars` = (k, k + 1), acting
    at the coupling point midway between the two body ends: lateral spring-damper there
    (coupler and gangway) and yaw spring-damper between the bodies (inter-car yaw dampers)."""

    cars: tuple[int, int]  # 1-based
    lateral_stiffness: float = 0.0
    yaw_stiffness: float = 0.0
    lateral_damping: float = 0.0
    yaw_damping: float = 0.0


@dataclasses.dataclass(frozen=True)
class Train:
    """Several car bodies in a row ([train], [[car]], [[coupling]]; docs/trains.md). The bogies are
    `Layout.carbody.bogie_positions` (x along the train); a bogie carried by two cars is a Jacobs
    bogie, and each of the two bodies takes half of [secondary]."""

    cars: tuple[Car, ...]
    couplings: tuple[Coupling, ...] = ()

    def cars_on(self, bogie: int) -> tuple[int, ...]:
        """The cars (1-based) a bogie (1-based) carries."""
        return tuple(k + 1 for k, car in enumerate(self.cars) if bogie in car.bogies)

    def coupling_x(self, coupling: Coupling) -> float:
        """x of the coupling point: midway between the front car's rear end and the rear car's front."""
        front, rear = (self.cars[k - 1] for k in coupling.cars)
        return ((front.position - front.length / 2) + (rear.position + rear.length / 2)) / 2


@dataclasses.dataclass(frozen=True)
class Layout:
    name: str
    wheelset: Wheelset
    creep: Creep
    primary: Suspension
    carbody: CarBody
    bogie: Bogie | None = None
    secondary: Suspension | None = None
    contact: Contact | None = None  # on cones, `creep.f11..f33` are its Hertz ellipse's; on profiles, the steel
    flange: Flange | None = None  # None: no flange contact (the classical linear model)
    # Wheel and rail profiles: with them the dynamics run on their contact tables
    # (rail_mj.contact.tables); wheelset.conicity is their equivalent conicity at 3 mm (unless
    # given), flangeway_clearance their flange's shift, creep.f11..f33 the centred contact's
    # (docs/dynamics-on-profiles.md).
    profiles: Profiles | None = None
    # Several car bodies ([train]): then `carbody` stands for the train (its bogie_positions
    # are the train's, x along the train; mass the cars' total) and the model is built flat,
    # with fixed tendons for the suspension (docs/trains.md).
    train: Train | None = None
    # A spatial vehicle ([spatial], docs/spatial.md): built flat with a fixed tendon per element
    # and direction; `primary` and `secondary` then hold the elements' planar equivalents.
    spatial: Spatial | None = None
    source: str = "<layout>"
    # Legal values far outside railway practice (rail_mj.practice), one line each.
    warnings: tuple[str, ...] = dataclasses.field(default=(), compare=False)
    # What the user wrote in [wheelset] and [creep], before the numbers left to other tables
    # were derived (None: a Layout built by hand, not read), and which numbers of `wheelset` and
    # `creep` were derived, from what. Both describe the layout as read: dataclasses.replace
    # carries them over as they are, and they do not take part in comparisons.
    given: Given | None = dataclasses.field(default=None, compare=False)
    derived: Derived = dataclasses.field(default=Derived(), compare=False)

    @property
    def wheelset_x(self) -> tuple[float, ...]:
        """Each wheelset's x from the car-body centre, wheelset 1 (leading) first."""
        xs = self.carbody.bogie_positions
        if self.bogie is None or xs is None:
            return tuple(self.carbody.wheelset_positions or ())
        return tuple(xb + xw for xb, design in zip(xs, self.bogie_designs) for xw in design.wheelset_positions)

    @property
    def bogie_designs(self) -> tuple[Bogie | BogieDesign, ...]:
        """Each bogie's design, leading first: a spatial vehicle's own ([bogies.N] over [bogie]),
        else `bogie` for every one (its mass, inertia and wheelset_positions)."""
        if self.spatial is not None and self.spatial.bogies:
            return self.spatial.bogies
        if self.bogie is None:
            return ()
        return (self.bogie,) * len(self.carbody.bogie_positions or ())

    @property
    def n_wheelsets(self) -> int:
        return len(self.wheelset_x)


# --- reading -----------------------------------------------------------------


class _Table:
    """One TOML table being read: tracks which keys were used, to reject typos."""

    def __init__(self, source: str, section: str, data: Any):
        self.source, self.section = source, section
        if not isinstance(data, dict):
            self.fail(None, f"must be a table, got {_kind(data)}")
        self.data = data
        self.used: set[str] = set()

    def fail(self, key: str | None, what: str) -> NoReturn:
        where = ".".join(k for k in (self.section, key) if k) or "(top level)"
        raise LayoutError(f"{self.source}: {where}: {what}")

    def get(self, key: str, default: Any = ..., *, required: bool = True) -> Any:
        self.used.add(key)
        if key in self.data:
            return self.data[key]
        if default is ... and required:
            # A misspelt key is both missing and unknown: name the look-alike given in its place
            # (0.8 of difflib's ratio: 'mas' for 'mass', not 'yaw_stiffness' for 'lateral_stiffness').
            unread = [k for k in self.data if k not in self.used and isinstance(k, str)]
            alike = difflib.get_close_matches(key, unread, n=1, cutoff=0.8)
            hint = f"; {alike[0]!r} is given here, which is no key: a misspelling of it?" if alike else ""
            self.fail(key, f"missing (required){hint}")
        return None if default is ... else default

    def number(self, key, default=..., *, low=None, low_open=False, high=None, required=True):
        value = self.get(key, default, required=required)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"must be a number, got {_kind(value)}")
        value = _float(value)
        if not math.isfinite(value) or abs(value) > MAX_MAGNITUDE:
            self.fail(key, f"must be finite and at most {MAX_MAGNITUDE:g} in size, got {value:g}")
        if low is not None and (value <= low if low_open else value < low):
            self.fail(key, f"must be {'>' if low_open else '>='} {low:g}, got {value:g}")
        if high is not None and value > high:
            self.fail(key, f"must be <= {high:g}, got {value:g}")
        return value

    def positive(self, key, default=..., required=True):
        return self.number(key, default, low=0.0, low_open=True, required=required)

    def non_negative(self, key, default=...):
        return self.number(key, default, low=0.0)

    def flag(self, key, default: bool) -> bool:
        value = self.get(key, default)
        if not isinstance(value, bool):
            self.fail(key, f"must be true or false, got {_kind(value)}")
        return value

    def vector3(self, key, *, required=True):
        value = self.get(key, required=required)
        if value is None:
            return None
        if not isinstance(value, list) or len(value) != 3:
            self.fail(key, f"must be a list of 3 numbers [x, y, z], got {_kind(value)}")
        out = []
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0 < _float(v) <= MAX_MAGNITUDE):
                self.fail(key, f"entry {i + 1} must be a positive number up to {MAX_MAGNITUDE:g}, got {v!r}")
            out.append(_float(v))
        a, b, c = sorted(out)
        if a + b < c * (1 - 1e-9):  # a rigid body's principal moments: each <= the sum of the others
            self.fail(
                key, f"is not a rigid body's inertia: the largest, {c:g}, exceeds the sum of the other two, {a + b:g}"
            )
        return tuple(out)

    def positions(self, key, min_spacing: float, what: str, *, required=True):
        """Positions along x, leading first, at least `min_spacing` apart."""
        value = self.get(key, required=required)
        if value is None:
            return None
        if not isinstance(value, list) or not value:
            self.fail(key, f"must be a non-empty list of x positions in m, got {_kind(value)}")
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not abs(_float(v)) <= MAX_POSITION:
                self.fail(key, f"must hold numbers only, within +/-{MAX_POSITION:g} m, got {v!r}")
        xs = [_float(v) for v in value]
        for front, back in zip(xs, xs[1:]):
            if back >= front:
                self.fail(key, f"must list the leading {what} first (x decreasing), got {xs}")
            if front - back < min_spacing:
                self.fail(
                    key,
                    f"{what}s at x = {front:g} and {back:g} m overlap: they must be at least {min_spacing:g} m apart",
                )
        return tuple(xs)

    def done(self):
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            self.fail(unknown[0], "unknown key")


def _float(value: int | float) -> float:
    """float(), with TOML's unbounded integers beyond float range as +/-inf."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


def _kind(value: Any) -> str:
    return {dict: "a table", list: "a list", str: "a string", bool: "a boolean"}.get(type(value), repr(value))


def _suspension(table: _Table) -> Suspension:
    s = Suspension(
        lateral_stiffness=table.non_negative("lateral_stiffness"),
        yaw_stiffness=table.non_negative("yaw_stiffness"),
        lateral_damping=table.non_negative("lateral_damping", 0.0),
        yaw_damping=table.non_negative("yaw_damping", 0.0),
    )
    table.done()
    return s


def _practice(table: _Table, warnings: list[str], ranges: str | None = None, **values) -> None:
    """Refuse values that cannot describe a rail vehicle, and note those outside railway
    practice (rail_mj.practice.RANGES, keyed by section.key; `ranges`: the section whose ranges
    hold, if not the table's own)."""
    for key, value in values.items():
        if value is None:
            continue
        limits = RANGES[f"{ranges or table.section}.{key}"]
        error = limits.check(value)
        if error:
            table.fail(key, error)
        note = limits.warning(value)
        if note:
            warnings.append(f"{table.source}: {table.section}.{key}: {note}")


# Inertias a body's own size cannot hold are refused: a body lying within a radius R of
# its centre of mass has radii of gyration sqrt(I/m) below R. R is taken generously
# (this factor over the rough envelopes below), so only a wrong mass or unit trips it.
ENVELOPE_MARGIN = 1.5


def _inertia_fits(table: _Table, mass: float | None, inertia, radius: float, what: str) -> None:
    """Refuse an inertia that needs more room than the body has (radius: its envelope, m);
    nothing to check on a body without mass (a fixed car body)."""
    if mass is None or inertia is None:
        return
    radius *= ENVELOPE_MARGIN
    for axis, moment in zip("xyz", inertia):
        gyration = math.sqrt(moment / mass)
        if gyration > radius:
            table.fail(
                "inertia",
                f"{moment:g} kg m^2 about {axis} needs a radius of gyration of "
                f"{gyration:.3g} m in a {mass:g} kg {what}, which fits within about "
                f"{radius:.3g} m: check the mass and the units (kg, kg m^2)",
            )


def layout_from_dict(data: dict, source: str = "<layout>") -> Layout:
    """Check a parsed layout (as from TOML) and build the `Layout`.

    One reader a table, called in this order: an input with several problems is refused for
    the first one met, and that order is part of the interface (the tests hold every line).
    The `_resolve_*` steps fill in what a table leaves to others (a wheelset's conicity and
    flangeway clearance to [profiles], the wheel load to the vehicle's weight, f11..f33 to
    [contact] or [profiles]) as soon as what they need is read, with the functions of
    rail_mj.contact.derived: the Layout holds the resolved numbers, `given` what was written
    and `derived` where each derived number came from."""
    top = _Table(source, "", data)
    warnings: list[str] = []
    derived: dict[str, str] = {}
    name = _name(top)
    given_wheelset = _wheelset(top, warnings)
    profiles = _profiles(top)
    conicity, clearance = _resolve_on_profiles(top, profiles, given_wheelset, warnings, derived)
    given_creep, creep_table = _creep(top, warnings)
    is_spatial = _present(top, "spatial")
    primary, primary_spring = _suspension_or_elements(
        _Table(source, "primary", top.get("primary")), "axlebox", is_spatial
    )
    bogie = _bogie(top, warnings, given_wheelset)
    secondary, secondary_spring, secondary_elements = _secondary(top, bogie, is_spatial)
    carbody, train = _carbody_or_train(top, warnings, bogie, given_wheelset, is_spatial)
    designs = _bogie_designs(top, warnings, bogie, primary_spring, carbody, is_spatial, given_wheelset)
    wheel_load = _resolve_wheel_load(top, given_wheelset, given_creep, carbody, bogie, designs, derived)
    wheelset = given_wheelset.resolved(conicity, clearance, wheel_load)
    contact = _contact(top, warnings, profiled=profiles is not None)
    creep = _resolve_creep(top, given_creep, wheelset, contact, profiles, warnings, derived)
    creep_table.done()  # [creep]'s stray keys are reported after [contact]'s problems, as ever
    flange = _flange(top, creep.law, profiles is not None, wheelset.conicity)
    spatial, train = _spatial_vehicle(
        top, warnings, carbody, bogie, train, primary_spring, secondary_spring, secondary_elements, designs
    )
    top.done()
    return Layout(
        name=name,
        wheelset=wheelset,
        creep=creep,
        primary=primary,
        carbody=carbody,
        bogie=bogie,
        secondary=secondary,
        contact=contact,
        flange=flange,
        profiles=profiles,
        train=train,
        spatial=spatial,
        source=source,
        warnings=tuple(warnings),
        given=Given(given_wheelset, given_creep),
        derived=Derived(tuple(derived.items())),
    )


def _present(top: _Table, key: str) -> bool:
    """Whether the layout has the table `key` (an empty one counts)."""
    return top.get(key, None, required=False) is not None


# --- the tables, one reader each, in reading order -----------------------------------------


def _name(top: _Table) -> str:
    name = top.get("name")
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        top.fail("name", f"must be letters, digits, '-' or '_', got {name!r}")
    return name


def _wheelset(top: _Table, warnings: list[str]) -> GivenWheelset:
    """[wheelset] as written: with [profiles], conicity and flangeway_clearance may be left out."""
    profiled = _present(top, "profiles")
    t = _Table(top.source, "wheelset", top.get("wheelset"))
    wheelset = GivenWheelset(
        mass=t.positive("mass"),
        inertia=t.vector3("inertia"),
        rolling_radius=t.positive("rolling_radius"),
        contact_half_spacing=t.positive("contact_half_spacing"),
        # Treads steeper than 1:2 are not wheels; the linear contact model assumes small angles.
        conicity=t.number("conicity", low=0.0, low_open=True, high=0.5, required=not profiled),
        flangeway_clearance=(
            t.positive("flangeway_clearance", required=False) if profiled else t.positive("flangeway_clearance", 0.008)
        ),
        wheel_load=t.positive("wheel_load", required=False),
    )
    t.done()
    r0, b = wheelset.rolling_radius, wheelset.contact_half_spacing
    _practice(
        t,
        warnings,
        rolling_radius=r0,
        contact_half_spacing=b,
        flangeway_clearance=wheelset.flangeway_clearance,
        mass=wheelset.mass,
        conicity=wheelset.conicity,
        wheel_load=wheelset.wheel_load,
    )
    if r0 >= b * 2:
        t.fail("rolling_radius", "is not smaller than the track gauge: check the units (m)")
    # Wheels at +/-b, axle journals and brake discs about a wheel radius further out.
    _inertia_fits(t, wheelset.mass, wheelset.inertia, math.hypot(b + r0, r0), "wheelset")
    return wheelset


def _creep(top: _Table, warnings: list[str]) -> tuple[GivenCreep, _Table]:
    """[creep] as written, and the table itself: its stray keys are reported after [contact]'s
    problems (layout_from_dict). f11..f33 are left out with [contact], and may be with [profiles]."""
    has_contact, profiled = _present(top, "contact"), _present(top, "profiles")
    t = _Table(top.source, "creep", top.get("creep", {} if has_contact else ...))
    keys = {"f11", "f22", "f23", "f33"}
    if has_contact and keys & set(t.data):
        t.fail(
            min(keys & set(t.data)),
            "given with [contact]: the creep coefficients come from the contact; give one of them",
        )
    written = not has_contact and not (profiled and not keys & set(t.data))  # else left to the contact
    f11, f22 = (t.positive("f11"), t.positive("f22")) if written else (None, None)
    f23, f33 = (t.non_negative("f23", 0.0), t.non_negative("f33", 0.0)) if written else (None, None)
    law = t.get("law", "linear")
    if not isinstance(law, str) or law not in LAWS:
        t.fail("law", f"must be one of {', '.join(LAWS)}, got {law!r}")
    if law == "fastsim" and not (has_contact or profiled):
        # FASTSIM works on the contact ellipse itself, which f11..f33 do not give (docs/creep.md).
        t.fail(
            "law",
            '"fastsim" needs a [contact] table: FASTSIM works on the Hertz contact ellipse, '
            "which f11..f33 alone do not give (docs/creep.md)",
        )
    friction = t.number("friction", low=0.0, low_open=True, high=2.0, required=law != "linear")
    _practice(t, warnings, friction=friction)
    return GivenCreep(f11, f22, f23, f33, law, friction, *_falling_friction(t, law)), t


def _falling_friction(t: _Table, law: str) -> tuple[float, float]:
    """[creep]'s falling_friction_ratio and _rate: Polach's law only; (1, 0) when left out."""
    falling = {k: t.get(k, None, required=False) for k in ("falling_friction_ratio", "falling_friction_rate")}
    if all(v is None for v in falling.values()):
        return 1.0, 0.0
    if law != "polach":
        t.fail(
            next(k for k, v in falling.items() if v is not None),
            f"falling friction belongs to the polach law, not {law!r}",
        )
    return (
        t.number("falling_friction_ratio", low=0.0, low_open=True, high=1.0),
        t.positive("falling_friction_rate"),
    )


def _bogie(top: _Table, warnings: list[str], wheelset: GivenWheelset) -> Bogie | None:
    """[bogie]: the frame and its wheelsets, which cannot be closer than a wheel's diameter."""
    if not _present(top, "bogie"):
        return None
    t = _Table(top.source, "bogie", top.get("bogie"))
    bogie = Bogie(
        mass=t.positive("mass"),
        inertia=t.vector3("inertia"),
        wheelset_positions=t.positions("wheelset_positions", 2.0 * wheelset.rolling_radius, "wheelset"),
    )
    t.done()
    _practice(t, warnings, mass=bogie.mass)
    # Side frames about 0.5 m outside the wheels, ends a wheel radius past the axles.
    reach = max(abs(x) for x in bogie.wheelset_positions) + wheelset.rolling_radius
    _inertia_fits(t, bogie.mass, bogie.inertia, math.hypot(reach, wheelset.contact_half_spacing + 0.5), "bogie frame")
    return bogie


def _secondary(top: _Table, bogie: Bogie | None, is_spatial: bool) -> tuple[Suspension | None, Spring | None, dict]:
    """[secondary], which comes with [bogie]: its planar equivalent with the dampers added, its
    spring element ([spatial]) and the Spatial fields of its other elements."""
    if bogie is None:
        if _present(top, "secondary"):
            top.fail("secondary", "given without [bogie]: secondary suspension joins bogies to the body")
        return None, None, {}
    if not _present(top, "secondary"):
        top.fail("secondary", "missing: a layout with [bogie] needs [secondary]")
    data, elements = _secondary_elements(top.source, top.get("secondary"), is_spatial)
    secondary, spring = _suspension_or_elements(_Table(top.source, "secondary", data), "spring", is_spatial)
    return _planar_dampers(secondary, elements), spring, elements


def _carbody_or_train(
    top: _Table, warnings: list[str], bogie: Bogie | None, wheelset: GivenWheelset, is_spatial: bool
) -> tuple[CarBody, Train | None]:
    """[carbody], or a train's [train], [[car]] and [[coupling]] (its CarBody standing for the train)."""
    if _present(top, "train"):
        return _train(top, warnings, bogie, 2.0 * wheelset.rolling_radius, is_spatial)
    if _present(top, "car") or _present(top, "coupling"):
        top.fail(
            "car" if "car" in top.data else "coupling",
            "given without [train]: [[car]] and [[coupling]] describe the car bodies of a train",
        )
    return _carbody(top, warnings, bogie, wheelset), None


def _carbody(top: _Table, warnings: list[str], bogie: Bogie | None, wheelset: GivenWheelset) -> CarBody:
    """[carbody]: fixed (no mass needed) or free, on bogies or with wheelsets hung from it."""
    t = _Table(top.source, "carbody", top.get("carbody"))
    fixed = t.get("fixed", False)
    if not isinstance(fixed, bool):
        t.fail("fixed", f"must be true or false, got {_kind(fixed)}")
    mass, inertia = t.positive("mass", required=not fixed), t.vector3("inertia", required=not fixed)
    wheel_diameter = 2.0 * wheelset.rolling_radius
    if bogie is not None:
        if "wheelset_positions" in t.data:
            t.fail("wheelset_positions", "not allowed with [bogie]: wheelsets hang from the bogies")
        extent = max(bogie.wheelset_positions) - min(bogie.wheelset_positions) + wheel_diameter
        carbody = CarBody(fixed, mass, inertia, t.positions("bogie_positions", extent, "bogie"), None)
    else:
        if "bogie_positions" in t.data:
            t.fail("bogie_positions", "given without a [bogie] table")
        carbody = CarBody(fixed, mass, inertia, None, t.positions("wheelset_positions", wheel_diameter, "wheelset"))
    xs = carbody.bogie_positions or carbody.wheelset_positions or ()
    length, width, height = _drawn_size(t, xs)
    carbody = dataclasses.replace(carbody, length=length, width=width, height=height)
    t.done()
    _practice(t, warnings, mass=carbody.mass)
    # Ends overhang the outermost wheels by a few metres; about 2 m to the side and roof.
    reach = max(abs(x) for x in xs) + (max(abs(x) for x in bogie.wheelset_positions) if bogie else 0.0)
    _inertia_fits(t, mass, inertia, math.hypot(reach + wheelset.rolling_radius + 3.0, 2.0), "car body")
    return carbody


# The drawn car body's size ([carbody] length, width, height): no railway vehicle is wider than
# 6 m (loading gauges are at most about 3.6 m wide) or taller than MAX_HEIGHT; a body is no
# longer than the 2 * MAX_POSITION its supports may span.
MAX_BODY_WIDTH = 6.0


def _drawn_size(t: _Table, supports: tuple[float, ...]) -> tuple[float | None, float | None, float | None]:
    """[carbody] length, width and height (optional, m): the body as drawn, over the bogie
    centres or wheelsets it rests on (`supports`, x)."""
    length = t.number("length", low=0.0, low_open=True, high=2 * MAX_POSITION, required=False)
    span = max(supports) - min(supports) if supports else 0.0
    if length is not None and length < span:
        what = "bogie centres" if "bogie_positions" in t.data else "wheelsets"
        t.fail("length", f"must reach over the {what} it rests on, {span:g} m apart, got {length:g} m")
    width = t.number("width", low=0.0, low_open=True, high=MAX_BODY_WIDTH, required=False)
    height = t.number("height", low=0.0, low_open=True, high=MAX_HEIGHT, required=False)
    return length, width, height


def _contact(top: _Table, warnings: list[str], profiled: bool) -> Contact | None:
    """[contact]: the bodies in contact (docs/contact.md). With [profiles] only the steel: the
    profiles give every point's curvatures."""
    if not _present(top, "contact"):
        return None
    t = _Table(top.source, "contact", top.get("contact"))
    if profiled:
        for key in ("rail_transverse_radius", "wheel_transverse_radius"):
            if key in t.data:
                t.fail(key, "not used with [profiles]: the profiles give each contact point's curvatures")
    poisson = RANGES["contact.poisson_ratio"].refuse  # Kalker's table
    contact = Contact(
        young_modulus=t.positive("young_modulus"),
        poisson_ratio=t.number("poisson_ratio", low=poisson[0], high=poisson[1]),
        rail_transverse_radius=None if profiled else t.positive("rail_transverse_radius"),
        wheel_transverse_radius=None if profiled else t.positive("wheel_transverse_radius", required=False),
    )
    _practice(
        t,
        warnings,
        young_modulus=contact.young_modulus,
        rail_transverse_radius=contact.rail_transverse_radius,
        wheel_transverse_radius=contact.wheel_transverse_radius,
    )
    t.done()
    return contact


def _flange(top: _Table, law: str, profiled: bool, conicity: float) -> Flange | None:
    """[flange]: flange contact on cones past the flangeway clearance, with a saturating law."""
    if not _present(top, "flange"):
        return None
    t = _Table(top.source, "flange", top.get("flange"))
    if profiled:
        t.fail(None, "not used with [profiles]: the profiles give the flange contact; remove [flange]")
    if law == "linear":
        # On the flange the rolling radius rises by tan(70 deg) per metre: unbounded
        # linear creep turns a millimetre of flange contact into hundreds of kN.
        t.fail(
            None,
            "flange contact needs a saturating creep law: set creep.law to "
            '"shen-hedrick-elkins", "polach" or "fastsim" and creep.friction',
        )
    default = Flange()
    flange = Flange(
        stiffness=t.positive("stiffness", default.stiffness),
        damping=t.non_negative("damping", default.damping),
        angle=t.number("angle", default.angle, low=conicity, low_open=True, high=math.radians(89.0)),
    )
    t.done()
    return flange


def _spatial_vehicle(
    top: _Table,
    warnings: list[str],
    carbody: CarBody,
    bogie: Bogie | None,
    train: Train | None,
    primary: Spring | None,
    secondary: Spring | None,
    elements: dict,
    designs: tuple[BogieDesign, ...],
) -> tuple[Spatial | None, Train | None]:
    """[spatial] with the element tables read before ([primary.axlebox], [secondary.*],
    [bogies.N]); a spatial train's cars with their heights. (None, train) without [spatial]."""
    if not _present(top, "spatial"):
        return None, train
    # With [spatial] the element tables are read, [primary.axlebox] always and
    # [secondary.spring] with [bogie] (_spatial refuses a spatial vehicle without it).
    assert primary is not None
    spatial = _spatial(
        _Table(top.source, "spatial", top.get("spatial")),
        top,
        carbody,
        bogie,
        primary,
        secondary if bogie else None,
    )
    spatial = dataclasses.replace(spatial, **elements, bogies=designs)
    if train is not None:
        train = _spatial_train(top, train, spatial)
    _static_sags(top.source, warnings, spatial, carbody, train)
    _stands_in_roll(top.source, spatial, carbody, train)
    return spatial, train


# --- resolving: the numbers a table leaves to others (rail_mj.contact.derived) -------------


def _resolve_on_profiles(
    top: _Table, profiles: Profiles | None, given: GivenWheelset, warnings: list[str], derived: dict[str, str]
) -> tuple[float, float]:
    """The wheelset's conicity and flangeway clearance: as given on cones; on profiles the
    clearance is where their flange touches, and the conicity, if left out, their equivalent
    conicity at 3 mm (a given one is kept, and noted as unused by the dynamics)."""
    if profiles is None:  # on cones both are given (the conicity is required, the clearance defaults)
        assert given.conicity is not None and given.flangeway_clearance is not None
        return given.conicity, given.flangeway_clearance
    t, r0 = _Table(top.source, "profiles", {}), given.rolling_radius
    from rail_mj.contact.geometry import GeometryError

    try:
        derive.check_centred(profiles, r0)
        conicity = derive.profiles_conicity(profiles, r0)
        shift = derive.flange_shift(profiles, r0)
    except GeometryError as e:
        t.fail(None, str(e))
    if given.conicity is None and not 0.0 < conicity <= 0.5:
        t.fail(
            None,
            f"the profiles' equivalent conicity at 3 mm is {conicity:.4g}, outside (0, 0.5]: give "
            f"wheelset.conicity for the dynamics",
        )
    if given.flangeway_clearance is not None:
        warnings.append(
            f"{top.source}: wheelset.flangeway_clearance is not used with [profiles]: their "
            f"flanges touch at {shift * 1e3:.2f} mm"
        )
    if given.conicity is None:
        derived["wheelset.conicity"] = derive.PROFILES_CONICITY
        _practice(_Table(top.source, "wheelset", {}), warnings, conicity=conicity)
    else:
        warnings.append(
            f"{top.source}: wheelset.conicity is not used by the dynamics: a layout with [profiles] "
            f"runs on their contact tables (equivalent conicity at 3 mm: {conicity:.4g})"
        )
    flanged = derive.has_flange(profiles, r0)
    derived["wheelset.flangeway_clearance"] = derive.PROFILES_FLANGE_SHIFT if flanged else derive.PROFILES_NO_FLANGE
    return (conicity if given.conicity is None else given.conicity), shift


def _resolve_wheel_load(
    top: _Table,
    given: GivenWheelset,
    creep: GivenCreep,
    carbody: CarBody,
    bogie: Bogie | None,
    designs: tuple[BogieDesign, ...],
    derived: dict[str, str],
) -> float | None:
    """The wheel load: as given, or the static weight shared equally by the wheels; refused
    where [contact] or a saturating law needs it and a fixed car body without mass gives none."""
    load = given.wheel_load
    if load is None and carbody.mass is not None:
        n_bogies = len(carbody.bogie_positions or ())
        n_wheelsets = len(carbody.wheelset_positions or ()) or (
            n_bogies * len(bogie.wheelset_positions) if bogie else 0
        )
        # fsum of equal masses is n times one, exactly.
        masses = [d.mass for d in designs] or ([bogie.mass] * n_bogies if bogie else [])
        carried = carbody.mass + (math.fsum(masses) if bogie else 0.0)
        load = derive.static_wheel_load(carried, n_wheelsets, given.mass)
        derived["wheelset.wheel_load"] = derive.STATIC_WHEEL_LOAD
    needs = "[contact]" if _present(top, "contact") else f"creep law {creep.law!r}" if creep.law != "linear" else None
    if needs and load is None:
        top.fail(
            "wheelset.wheel_load",
            f"missing: {needs} needs the wheel load, and a fixed car "
            f"body without mass gives no weight to share; give it in N",
        )
    return load


def _resolve_creep(
    top: _Table,
    given: GivenCreep,
    wheelset: Wheelset,
    contact: Contact | None,
    profiles: Profiles | None,
    warnings: list[str],
    derived: dict[str, str],
) -> Creep:
    """The creep coefficients: as given, or Kalker's from [contact]'s Hertz ellipse on cones, or
    from the centred contact of the profiles (which replace given ones, noted as unused)."""
    coefficients, source = given.coefficients(), None
    if contact is not None and profiles is None:
        coefficients, source = _kalker_of_contact(top, contact, wheelset), derive.CONTACT_KALKER
    if profiles is not None and wheelset.wheel_load is not None:
        _note_on_profiles(top.source, given, warnings)
        coefficients, source = _kalker_of_profiles(top, profiles, wheelset, contact, given), derive.PROFILES_KALKER
    elif profiles is not None and coefficients is None:
        top.fail(
            "wheelset.wheel_load",
            "missing: the contact on profiles needs the wheel load, and a fixed car "
            "body without mass gives no weight to share; give it in N",
        )
    # Given, or from [contact] or the profiles; each way without them has failed above.
    assert coefficients is not None
    if source is not None:
        derived.update((f"creep.{k}", source) for k in coefficients)
    return Creep(
        **coefficients,
        law=given.law,
        friction=given.friction,
        falling_friction_ratio=given.falling_friction_ratio,
        falling_friction_rate=given.falling_friction_rate,
    )


def _kalker_of_contact(top: _Table, contact: Contact, wheelset: Wheelset) -> dict[str, float]:
    """f11..f33 of [contact]'s Hertz ellipse under the wheel load; a contact Hertz cannot
    solve is refused as [contact]'s."""
    from rail_mj.contact.hertz import ContactError  # scipy: only for layouts that need it

    assert wheelset.wheel_load is not None  # _resolve_wheel_load refuses [contact] without it
    try:
        return derive.contact_kalker(contact, wheelset.wheel_load, wheelset.rolling_radius)
    except ContactError as e:
        _Table(top.source, "contact", {}).fail(None, str(e))


def _note_on_profiles(source: str, given: GivenCreep, warnings: list[str]) -> None:
    """What [creep] gives that the dynamics on profiles do not use, or should not."""
    if given.coefficients() is not None:  # given with [profiles]; with [contact] they are refused
        warnings.append(
            f"{source}: creep.f11..f33 are not used by the dynamics: with [profiles] each "
            f"contact point has its own, from Hertz and Kalker"
        )
    if given.law == "linear":
        warnings.append(
            f'{source}: creep.law "linear" on profiles: on the flanges the creep forces '
            f"grow without bound; choose a saturating law for runs"
        )


def _kalker_of_profiles(
    top: _Table, profiles: Profiles, wheelset: Wheelset, contact: Contact | None, given: GivenCreep
) -> dict[str, float]:
    """f11..f33 of the profiles' centred contact under the wheel load; a table that cannot be
    made is refused as [profiles]'."""
    from rail_mj.contact.tables import TableError

    try:
        return derive.profiles_kalker(profiles, wheelset, contact, given.law, given.friction)
    except TableError as e:
        top.fail("profiles", str(e))


# Heights above the rail (m) and a spring's half-spacing: beyond these no rail vehicle is meant.
MAX_HEIGHT = 6.0
MAX_SPACING = 2.5
SPRING_KEYS = ("kx", "ky", "kz", "cx", "cy", "cz", "spacing", "height")


def _suspension_or_elements(t: _Table, element: str, is_spatial: bool) -> tuple[Suspension, Spring | None]:
    """[primary] or [secondary]: the planar whole-body keys, or with [spatial] the element table
    [<section>.<element>] (its planar equivalent as the Suspension)."""
    if not is_spatial:
        if element in t.data:
            t.fail(element, "needs [spatial]: per-element springs belong to a spatial vehicle (docs/spatial.md)")
        return _suspension(t), None
    planar = sorted(set(t.data) - {element})
    if planar:
        t.fail(
            planar[0],
            f"not used with [spatial]: give the elements as [{t.section}.{element}] ({', '.join(SPRING_KEYS)})",
        )
    spring = _spring(_Table(t.source, f"{t.section}.{element}", t.get(element)))
    t.done()
    return spring.planar(), spring


def _spring(e: _Table, default: Spring | None = None) -> Spring:
    """An element table (SPRING_KEYS), checked. Each key it leaves out is `default`'s; with no
    default kx, ky, kz, spacing and height are required and the dampings 0."""

    def inherited(key: str, fallback: Any = ...) -> Any:
        return fallback if default is None else getattr(default, key)

    spring = Spring(
        kx=e.non_negative("kx", inherited("kx")),
        ky=e.non_negative("ky", inherited("ky")),
        kz=e.positive("kz", inherited("kz")),
        cx=e.non_negative("cx", inherited("cx", 0.0)),
        cy=e.non_negative("cy", inherited("cy", 0.0)),
        cz=e.non_negative("cz", inherited("cz", 0.0)),
        spacing=e.number("spacing", inherited("spacing"), low=0.0, low_open=True, high=MAX_SPACING),
        height=e.number("height", inherited("height"), low=0.0, low_open=True, high=MAX_HEIGHT),
    )
    e.done()
    return spring


BOGIE_NUMBER = re.compile(r"^[1-9][0-9]*$")


def _bogie_designs(
    top: _Table,
    warnings: list[str],
    bogie: Bogie | None,
    primary: Spring | None,
    carbody: CarBody,
    is_spatial: bool,
    wheelset: GivenWheelset,
) -> tuple[BogieDesign, ...]:
    """[bogies.N] (docs/spatial.md), checked: each bogie's design, leading first, [bogie] and
    [primary.axlebox] with bogie N's overrides of mass, inertia, wheelset_positions and
    [bogies.N.axlebox]. () for a planar layout, which refuses the table."""
    data = top.get("bogies", None, required=False)
    if data is not None and not is_spatial:
        top.fail(
            "bogies",
            "needs [spatial]: different bogies under one car body belong to a spatial vehicle (docs/spatial.md)",
        )
    xs = carbody.bogie_positions
    if not is_spatial or bogie is None or xs is None:
        if data is not None:
            top.fail("bogies", "given without [bogie]: [bogies.N] changes [bogie]'s design for bogie N")
        return ()
    assert primary is not None  # [primary.axlebox], read with [spatial]
    own = _bogie_overrides(top, data, len(xs))
    designs = tuple(
        _bogie_design(top, warnings, i, own[i], bogie, primary, wheelset)
        if i in own
        else BogieDesign(bogie.mass, bogie.inertia, bogie.wheelset_positions, primary)
        for i in range(1, len(xs) + 1)
    )
    wheel_diameter = 2.0 * wheelset.rolling_radius
    for k in range(1, len(xs)):  # [bogie]'s spacing check holds for its own wheelbase only
        front = xs[k - 1] + min(designs[k - 1].wheelset_positions)
        back = xs[k] + max(designs[k].wheelset_positions)
        if front - back < wheel_diameter:
            top.fail(
                "bogies",
                f"the wheelsets of bogies {k} and {k + 1} at x = {front:g} and {back:g} m overlap: "
                f"they must be at least {wheel_diameter:g} m apart",
            )
    return designs


def _bogie_overrides(top: _Table, data: Any, n: int) -> dict[int, Any]:
    """[bogies]: each bogie number N (1 to n) with its [bogies.N] table, unread."""
    if data is None:
        return {}
    t = _Table(top.source, "bogies", data)
    own = {}
    for key, value in data.items():
        if not BOGIE_NUMBER.fullmatch(key) or int(key) > n:
            t.fail(
                key,
                f"no such bogie: N in [bogies.N] is a bogie's number in carbody.bogie_positions, 1 (leading) to {n}",
            )
        own[int(key)] = value
        t.used.add(key)
    t.done()
    return own


def _bogie_design(
    top: _Table,
    warnings: list[str],
    i: int,
    data: Any,
    bogie: Bogie,
    primary: Spring,
    wheelset: GivenWheelset,
) -> BogieDesign:
    """[bogies.N] for bogie i: [bogie] and [primary.axlebox] with what it overrides."""
    e = _Table(top.source, f"bogies.{i}", data)
    mass = e.positive("mass", bogie.mass)
    inertia = e.vector3("inertia", required=False) or bogie.inertia
    positions = e.positions("wheelset_positions", 2.0 * wheelset.rolling_radius, "wheelset", required=False)
    if positions is not None and len(positions) != len(bogie.wheelset_positions):
        e.fail(
            "wheelset_positions",
            f"gives {len(positions)} wheelsets, [bogie] {len(bogie.wheelset_positions)}: "
            f"every bogie must have [bogie]'s number of wheelsets (a limitation: "
            f"wheelsets are numbered per bogie)",
        )
    positions = positions or bogie.wheelset_positions
    own = e.get("axlebox", None, required=False)
    axlebox = primary if own is None else _spring(_Table(top.source, f"bogies.{i}.axlebox", own), primary)
    e.done()
    if "mass" in e.data:
        _practice(e, warnings, ranges="bogie", mass=mass)
    reach = max(abs(x) for x in positions) + wheelset.rolling_radius  # as [bogie]'s
    _inertia_fits(e, mass, inertia, math.hypot(reach, wheelset.contact_half_spacing + 0.5), "bogie frame")
    return BogieDesign(mass, inertia, positions, axlebox)


SECONDARY_ELEMENTS = ("lateral_damper", "yaw_damper", "anti_roll_bar", "bump_stop")
# A lateral stop's deflections beyond this (m) are no vehicle's: most likely millimetres.
MAX_STOP = 0.5


def _secondary_elements(source: str, data: Any, is_spatial: bool) -> tuple[Any, dict]:
    """[secondary]'s element tables besides [secondary.spring] (SECONDARY_ELEMENTS), read and
    checked: `data` without them (for _suspension_or_elements) and the Spatial fields they give."""
    if not isinstance(data, dict):
        return data, {}
    t = _Table(source, "secondary", data)
    given = [k for k in SECONDARY_ELEMENTS if k in data]
    if given and not is_spatial:
        t.fail(
            given[0],
            "needs [spatial]: per-element dampers, anti-roll bars and bump stops belong to a "
            "spatial vehicle (docs/spatial.md)",
        )
    if is_spatial:  # a misspelt element table would otherwise read as a stray planar key
        for key, value in data.items():
            if isinstance(value, dict) and key not in ("spring", *SECONDARY_ELEMENTS):
                known = ", ".join(("spring", *SECONDARY_ELEMENTS))
                t.fail(key, f"unknown element table: [secondary] holds {known}")
    elements: dict = {}
    for key in given:
        e = _Table(source, f"secondary.{key}", data[key])
        if key == "anti_roll_bar":
            elements[key] = e.positive("stiffness")
        elif key == "bump_stop":
            elements[key] = _bump_stop(e)
        else:
            yaw = key == "yaw_damper"
            elements[key] = Damper(
                c=e.positive("c"),
                height=e.number("height", low=0.0, low_open=True, high=MAX_HEIGHT),
                spacing=e.number("spacing", low=0.0, low_open=True, high=MAX_SPACING) if yaw else 0.0,
            )
        e.done()
    return {k: v for k, v in data.items() if k not in SECONDARY_ELEMENTS}, elements


def _bump_stop(t: _Table) -> BumpStop:
    """[secondary.bump_stop]: its force-deflection table, checked (the BumpStop docstring)."""
    free_play = t.number("free_play", low=0.0, high=MAX_STOP)
    tables = {}
    for key, unit in (("deflection", "m"), ("force", "N")):
        value = t.get(key)
        if not isinstance(value, list) or not value:
            t.fail(key, f"must be a non-empty list of numbers ({unit}), got {_kind(value)}")
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not abs(_float(v)) <= MAX_MAGNITUDE:
                t.fail(key, f"must hold numbers ({unit}) only, up to {MAX_MAGNITUDE:g} in size, got {v!r}")
        tables[key] = tuple(_float(v) for v in value)
    deflection, force = tables["deflection"], tables["force"]
    if deflection[0] <= free_play:
        t.fail("deflection", f"must start beyond free_play ({free_play:g} m), got {deflection[0]:g} m")
    if any(b <= a for a, b in zip(deflection, deflection[1:])):
        t.fail("deflection", f"must increase strictly, got {list(deflection)}")
    if deflection[-1] > MAX_STOP:
        t.fail("deflection", f"must be <= {MAX_STOP:g} m, got {deflection[-1]:g}: check the units (m)")
    if len(force) != len(deflection):
        t.fail("force", f"must give one force per deflection: {len(deflection)} deflections, {len(force)} forces")
    if min(force) < 0.0:
        t.fail("force", f"must be >= 0 (N), got {min(force):g}")
    if any(b < a for a, b in zip(force, force[1:])):
        t.fail("force", f"must not decrease, got {list(force)}")
    return BumpStop(free_play, deflection, force, t.number("height", low=0.0, low_open=True, high=MAX_HEIGHT))


def _planar_dampers(s: Suspension, elements: dict) -> Suspension:
    """The planar equivalent with the secondary dampers added: the lateral damper's c, and the yaw
    dampers' 2 c d^2 (as Spring.planar's), so that what reads Layout.secondary sees them."""
    lateral, yaw = elements.get("lateral_damper"), elements.get("yaw_damper")
    return dataclasses.replace(
        s,
        lateral_damping=s.lateral_damping + (lateral.c if lateral else 0.0),
        yaw_damping=s.yaw_damping + (2 * yaw.c * yaw.spacing**2 if yaw else 0.0),
    )


def _spatial(
    t: _Table, top: _Table, carbody: CarBody, bogie: Bogie | None, primary: Spring, secondary: Spring | None
) -> Spatial:
    """[spatial], checked: a free car body on bogies, the heights of the centres of mass."""
    if bogie is None or secondary is None:  # [secondary.spring] comes with [bogie]
        top.fail("spatial", "needs [bogie]: a spatial vehicle is a car body on bogies")
    if carbody.fixed:
        top.fail("spatial", "needs a free car body (carbody.fixed = false)")
    spatial = Spatial(
        carbody_height=t.number("carbody_height", low=0.0, low_open=True, high=MAX_HEIGHT),
        bogie_height=t.number("bogie_height", low=0.0, low_open=True, high=MAX_HEIGHT),
        primary=primary,
        secondary=secondary,
        gravity=t.flag("gravity", True),
        gravitational_stiffness=t.flag("gravitational_stiffness", True),
        gyroscopic=t.flag("gyroscopic", True),
        floor_height=t.number("floor_height", None, low=0.0, low_open=True, high=MAX_HEIGHT, required=False),
    )
    t.done()
    if spatial.carbody_height < spatial.bogie_height:  # equal: the planar limit (docs/spatial.md)
        t.fail(
            "carbody_height",
            f"must not be below bogie_height ({spatial.bogie_height:g} m), got {spatial.carbody_height:g} m",
        )
    return spatial


def _static_sags(source: str, warnings: list[str], spatial: Spatial, carbody: CarBody, train: Train | None) -> None:
    """The springs' static deflections under the weight (docs/spatial.md), each bogie's with its
    equal share of the car bodies' weight: one that sinks a spring's upper seat below the rail is
    refused (no suspension stands like that: most often N/m taken for kN/m, or a mass in grams),
    one outside practice noted (rail_mj.practice)."""
    bodies = sum(car.mass for car in train.cars) if train is not None else carbody.mass
    if not spatial.gravity or bodies is None:
        return
    n_bogies = len(spatial.bogies)
    e = spatial.secondary
    checks = [("secondary.spring", e.height, GRAVITY * bodies / (2 * n_bogies * e.kz))]
    for i, d in enumerate(spatial.bogies, start=1):
        a = d.axlebox
        section = "primary.axlebox" if a == spatial.primary else f"bogies.{i}.axlebox"
        weight = GRAVITY * (bodies / n_bogies + d.mass)
        checks.append((section, a.height, weight / (2 * len(d.wheelset_positions) * a.kz)))
    for section, height, sag in checks:
        t = _Table(source, section, {})
        if sag >= height:
            t.fail(
                "kz",
                f"the static deflection under the weight, {sag:.3g} m, is more than the spring's "
                f"height above the rail ({height:g} m); check kz's units (N/m) and the masses (kg)",
            )
        if not any(w.startswith(f"{source}: {section}.static_deflection") for w in warnings):
            _practice(t, warnings, ranges="spatial", static_deflection=sag)
    for i, d in enumerate(spatial.bogies, start=1):  # a legal but odd stack: noted
        if d.axlebox.height > e.height:
            section = "primary.axlebox" if d.axlebox == spatial.primary else f"bogies.{i}.axlebox"
            note = (
                f"{source}: {section}.height: {d.axlebox.height:g} m is above the secondary springs "
                f"({e.height:g} m); bogie frames carry their primary springs below their secondary ones"
            )
            if note not in warnings:
                warnings.append(note)


def _stands_in_roll(source: str, spatial: Spatial, carbody: CarBody, train: Train | None) -> None:
    """Each car body must stand on its springs in roll: their roll stiffness about the springs'
    level (each anti-roll bar's besides) must exceed the weight's overturning m*g*h there, or
    the body tips over (a one-line error). Only with gravity and its stiffness (docs/spatial.md)."""
    if not (spatial.gravity and spatial.gravitational_stiffness) or carbody.mass is None:
        return
    e = spatial.secondary
    cars: list[Car | CarBody] = list(train.cars) if train is not None else [carbody]
    for k, car in enumerate(cars, start=1):
        height = getattr(car, "height", None) or spatial.carbody_height
        n = len(car.bogies) if isinstance(car, Car) else len(spatial.bogies)
        mass = car.mass
        assert mass is not None  # a spatial vehicle's car bodies are free, with their mass
        overturning = mass * GRAVITY * (height - e.height)
        roll = n * (2 * e.kz * e.spacing**2 + (spatial.anti_roll_bar or 0.0))
        if train is not None and isinstance(car, Car):  # a Jacobs bogie's springs are shared by its two bodies
            roll = sum(
                (2 * e.kz * e.spacing**2 + (spatial.anti_roll_bar or 0.0)) / len(train.cars_on(b)) for b in car.bogies
            )
        if overturning >= roll:
            name = "carbody" if train is None else f"car[{k}]"
            _Table(source, "spatial", {}).fail(
                "carbody_height",
                f"{name} tips over on its springs: its weight's overturning moment "
                f"m*g*h = {overturning:.3g} N m/rad (h = {height - e.height:.3g} m above the secondary "
                f"springs) exceeds their roll stiffness {roll:.3g} N m/rad; lower the centre of mass, "
                f"stiffen or spread the springs, or fit an anti-roll bar",
            )


def _spatial_train(t: _Table, train: Train, spatial: Spatial) -> Train:
    """A spatial train's cars with their heights: [[car]] height, else [spatial] carbody_height,
    none below bogie_height (docs/trains.md)."""
    cars = []
    for k, car in enumerate(train.cars, start=1):
        height = spatial.carbody_height if car.height is None else car.height
        if height < spatial.bogie_height:
            t.fail(
                f"car[{k}].height" if car.height is not None else "spatial.carbody_height",
                f"must not be below spatial.bogie_height ({spatial.bogie_height:g} m), got {height:g} m",
            )
        cars.append(dataclasses.replace(car, height=height))
    return dataclasses.replace(train, cars=tuple(cars))


# Two body ends nearer than this overlap (m): an articulated set's ends meet over the Jacobs bogie.
END_TOLERANCE = 1e-6


def _train(
    top: _Table, warnings: list[str], bogie: Bogie | None, wheel_diameter: float, is_spatial: bool = False
) -> tuple[CarBody, Train]:
    """[train], [[car]] and [[coupling]], checked (docs/trains.md): the train's bogies and the cars
    they carry, one clear line for each bad topology."""
    if bogie is None:
        top.fail("train", "needs [bogie]: a train's car bodies rest on bogies (train.bogie_positions)")
    if "carbody" in top.data:
        top.fail("carbody", "not used with [train]: give each car body as a [[car]]")
    t = _Table(top.source, "train", top.get("train"))
    extent = max(bogie.wheelset_positions) - min(bogie.wheelset_positions) + wheel_diameter
    bogie_x = t.positions("bogie_positions", extent, "bogie")
    t.done()
    cars_data = top.get("car", None, required=False)
    if isinstance(cars_data, dict):
        top.fail("car", "is one [car] table: give each car body as an array entry, [[car]], leading first")
    if not isinstance(cars_data, list) or not cars_data:
        top.fail("car", "missing: a [train] needs its car bodies, one [[car]] each, leading first")
    cars = [
        _car(_Table(top.source, f"car[{k}]", data), warnings, bogie_x, is_spatial)
        for k, data in enumerate(cars_data, start=1)
    ]
    _check_train(top, cars, bogie_x)
    couplings = _couplings(top, len(cars))
    total = sum(car.mass for car in cars)
    carbody = CarBody(False, total, cars[0].inertia, bogie_positions=bogie_x, wheelset_positions=None)
    return carbody, Train(tuple(cars), couplings)


def _car(t: _Table, warnings: list[str], bogie_x: tuple[float, ...], is_spatial: bool) -> Car:
    """One [[car]]: its body, where it is, and the one or two bogies (of `bogie_x`) under it."""
    mass, inertia = t.positive("mass"), t.vector3("inertia")
    position = t.number("position", low=-MAX_POSITION, high=MAX_POSITION)
    length = t.positive("length")
    if "height" in t.data and not is_spatial:
        t.fail("height", "needs [spatial]: a planar train's car bodies have no height (docs/trains.md)")
    height = t.number("height", low=0.0, low_open=True, high=MAX_HEIGHT, required=False) if is_spatial else None
    carried = t.get("bogies")
    if not isinstance(carried, list) or not all(isinstance(i, int) and not isinstance(i, bool) for i in carried):
        t.fail("bogies", f"must be a list of bogie numbers (1 to {len(bogie_x)}), got {_kind(carried)}")
    if not carried:
        t.fail("bogies", "empty: a car body with no bogie under it has no support")
    if len(carried) > 2 or len(set(carried)) != len(carried):
        t.fail("bogies", f"must name one or two different bogies, got {carried}")
    for i in carried:
        if not 1 <= i <= len(bogie_x):
            t.fail("bogies", f"bogie {i} does not exist: train.bogie_positions lists {len(bogie_x)}")
    if sorted(carried) != carried:
        t.fail("bogies", f"must list the leading bogie first, got {carried}")
    for i in carried:
        if abs(bogie_x[i - 1] - position) > length / 2 + END_TOLERANCE:
            t.fail(
                "bogies",
                f"bogie {i} at x = {bogie_x[i - 1]:g} m is not under this {length:g} m body "
                f"centred at x = {position:g} m",
            )
    t.done()
    _practice(_Table(t.source, "carbody", {}), warnings, mass=mass)
    _inertia_fits(t, mass, inertia, math.hypot(length / 2, 2.0), "car body")
    return Car(mass, inertia, position, length, tuple(carried), height)


def _check_train(top: _Table, cars: list[Car], bogie_x: tuple[float, ...]) -> None:
    """The cars in a row, leading first, ends not overlapping; each bogie under one car or
    under the ends of two adjacent ones (a Jacobs bogie)."""
    for k, (front, rear) in enumerate(zip(cars, cars[1:]), start=1):
        if rear.position >= front.position:
            top.fail(
                f"car[{k + 1}].position",
                f"cars must be listed leading first (x decreasing): "
                f"{rear.position:g} m is not behind car {k} at {front.position:g} m",
            )
        gap = (front.position - front.length / 2) - (rear.position + rear.length / 2)
        if gap < -END_TOLERANCE:
            top.fail(
                f"car[{k + 1}]",
                f"car bodies {k} and {k + 1} overlap by {-gap:g} m: the rear end of one "
                f"must not pass the front end of the next",
            )
    for i in range(1, len(bogie_x) + 1):
        on = [k for k, car in enumerate(cars, start=1) if i in car.bogies]
        if not on:
            top.fail(
                "train.bogie_positions",
                f"bogie {i} at x = {bogie_x[i - 1]:g} m carries no car body: no [[car]] lists it in bogies",
            )
        if len(on) > 2 or (len(on) == 2 and on[1] != on[0] + 1):
            top.fail(
                "train.bogie_positions",
                f"bogie {i} is listed by cars {on}: a (Jacobs) bogie carries the ends of at most two adjacent cars",
            )


def _couplings(top: _Table, n_cars: int) -> tuple[Coupling, ...]:
    """[[coupling]]: at most one between each pair of adjacent cars."""
    couplings: list[Coupling] = []
    coupling_data = top.get("coupling", [], required=False) or []
    if not isinstance(coupling_data, list):
        top.fail("coupling", "must be an array of tables, one [[coupling]] per pair of adjacent cars")
    for k, data in enumerate(coupling_data, start=1):
        t = _Table(top.source, f"coupling[{k}]", data)
        pair = t.get("cars")
        if not (
            isinstance(pair, list)
            and len(pair) == 2
            and all(isinstance(i, int) and not isinstance(i, bool) for i in pair)
        ):
            t.fail("cars", f"must be two car numbers [k, k + 1], got {_kind(pair)}")
        if pair[1] != pair[0] + 1 or not 1 <= pair[0] < n_cars:
            t.fail("cars", f"must be two adjacent cars [k, k + 1] of the {n_cars}, got {pair}")
        if any(c.cars == tuple(pair) for c in couplings):
            t.fail("cars", f"cars {pair} are coupled twice: give one [[coupling]] per pair")
        couplings.append(
            Coupling(
                (pair[0], pair[1]),
                t.non_negative("lateral_stiffness", 0.0),
                t.non_negative("yaw_stiffness", 0.0),
                t.non_negative("lateral_damping", 0.0),
                t.non_negative("yaw_damping", 0.0),
            )
        )
        t.done()
    return tuple(couplings)


def _profiles(top: _Table) -> Profiles | None:
    """[profiles], checked: each profile a standard one or a file that reads, the wheelset's
    placement on the track within reason. Where the wheels then touch: _resolve_on_profiles."""
    if not _present(top, "profiles"):
        return None
    from rail_mj.contact import profiles as p  # numpy: only for layouts that need it

    t = _Table(top.source, "profiles", top.get("profiles"))
    names = {kind: _profile_name(t, kind) for kind in ("wheel", "rail")}
    profiles = Profiles(
        wheel=names["wheel"],
        rail=names["rail"],
        rail_inclination=t.number("rail_inclination", p.RAIL_INCLINATION, low=0.0, high=0.1),
        track_gauge=t.number("track_gauge", p.GAUGE, low=0.5, high=2.0),
        flange_back_spacing=t.positive("flange_back_spacing", p.BACK_TO_BACK),
        gravitational_stiffness=t.flag("gravitational_stiffness", True),
        spin_creep=t.flag("spin_creep", True),
    )
    t.done()
    gauge, back = profiles.track_gauge, profiles.flange_back_spacing
    if not gauge - 0.2 < back < gauge:
        t.fail(
            "flange_back_spacing",
            f"must be below track_gauge ({gauge:g} m) by less than 0.2 m (the flanges and their play), got {back:g} m",
        )
    for key, other in (("wheel", "rail"), ("rail", "wheel")):  # one at a time: an error names its key
        try:
            standard = STANDARD_PROFILES[other][0]
            alone = (
                dataclasses.replace(profiles, rail=standard)
                if other == "rail"
                else dataclasses.replace(profiles, wheel=standard)
            )
            read_profiles(alone)
        except p.ProfileError as e:
            t.fail(key, str(e))
        except ValueError as e:
            t.fail(key, str(e))
    return profiles


def _profile_name(t: _Table, kind: str) -> str:
    """[profiles] `kind` ("wheel" or "rail"): a standard profile's name, or a file's path
    (relative to the layout file) that exists and is a profile file."""
    value = t.get(kind)
    if not isinstance(value, str) or not value.strip():
        t.fail(
            kind,
            f"must be a standard {kind} ({', '.join(STANDARD_PROFILES[kind])}) or a profile "
            f"file's path, got {_kind(value)}",
        )
    if value.lower() in STANDARD_PROFILES[kind]:
        return value.lower()
    other = "rail" if kind == "wheel" else "wheel"
    if value.lower() in STANDARD_PROFILES[other]:
        t.fail(kind, f"{value!r} is a standard {other} profile, not a {kind}")
    base = Path(t.source).parent if t.source != "<layout>" else Path(".")
    path = (base / value) if not Path(value).is_absolute() else Path(value)
    if path.suffix.lower() not in (".csv", ".prw", ".prr"):
        t.fail(
            kind,
            f"must be {', '.join(STANDARD_PROFILES[kind])} or a profile file (.csv, SIMPACK .prw "
            f"or .prr), got {value!r}",
        )
    if not path.is_file():
        t.fail(kind, f"{path}: no such file (paths are relative to the layout file)")
    return str(path)


def contact_patch_of(layout: Layout) -> ContactPatch:
    """The Hertz ellipse and Kalker coefficients of a layout with [contact] on coned wheels."""
    if layout.contact is None:
        raise ValueError(f"{layout.source}: no [contact] table: no Hertz ellipse")
    if layout.wheelset.wheel_load is None:  # the reader refuses [contact] without one
        raise ValueError(f"{layout.source}: no wheel load: no Hertz ellipse")
    return derive.contact_ellipse(layout.contact, layout.wheelset.wheel_load, layout.wheelset.rolling_radius)


def load_layout(path: str | Path) -> Layout:
    """Read and check a layout file."""
    path = Path(path)
    try:
        text = read_input(path).decode("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise LayoutError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    try:
        data = tomllib.loads(text)
    except ValueError as e:  # TOMLDecodeError, and integers too long to convert
        raise LayoutError(f"{path}: not valid TOML: {e}") from None
    except RecursionError:  # arrays or tables nested hundreds deep: no layout is
        raise LayoutError(f"{path}: not a layout: its arrays or tables are nested too deeply to read") from None
    return layout_from_dict(data, source=str(path))
