"""Layout files: a vehicle described in TOML, read and checked into a `Layout`.

The layout is the users' interface and the one source of truth for every
physical number of a vehicle; the model, the creep forces and the recording all
read it from here. Units are SI throughout (kg, m, N, s, rad).

Example:

    >>> from rail_mj.layout import load_layout
    >>> layout = load_layout("models/manchester-coach/manchester-coach.toml")
    >>> layout.n_wheelsets, layout.wheelset.rolling_radius
    (4, 0.46)

Every problem with a file raises `LayoutError`, whose message is one line naming
the file, the key and what is wrong.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import tomllib
from pathlib import Path
from typing import Any, NoReturn

from rail_mj.contact.laws import FASTSIM, LAWS, LINEAR, POLACH, SHEN_HEDRICK_ELKINS  # noqa: F401  (re-exported)
from rail_mj.contact.pair import STANDARD_PROFILES, Profiles, read_profiles, stamp
from rail_mj.practice import RANGES

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
    contact: Contact | None = None  # when given, `creep` was computed from it
    flange: Flange | None = None  # None: no flange contact (the classical linear model)
    # Wheel and rail profiles: with them the dynamics run on their contact tables
    # (rail_mj.contact.tables); wheelset.conicity is their equivalent conicity at 3 mm, creep.f11..f33
    # the centred contact's (docs/dynamics-on-profiles.md).
    profiles: Profiles | None = None
    # Several car bodies ([train]): then `carbody` stands for the train (its bogie_positions
    # are the train's, x along the train; mass the cars' total) and the model is built flat,
    # with fixed tendons for the suspension (docs/trains.md).
    train: Train | None = None
    # A spatial vehicle ([spatial], docs/spatial.md): built flat with a fixed tendon per element
    # and direction; `primary` and `secondary` then hold the elements' planar equivalents.
    spatial: Spatial | None = None
    source: str = "<layout>"
    # Legal values far outside railway practice (rail_mj.layout.practice), one line each.
    warnings: tuple[str, ...] = dataclasses.field(default=(), compare=False)

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
            self.fail(key, "missing (required)")
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
    practice (rail_mj.layout.practice.RANGES, keyed by section.key; `ranges`: the section whose ranges
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
    """Check a parsed layout (as from TOML) and build the `Layout`."""
    top = _Table(source, "", data)
    warnings: list[str] = []

    name = top.get("name")
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        top.fail("name", f"must be letters, digits, '-' or '_', got {name!r}")

    has_profiles = top.get("profiles", None, required=False) is not None
    t = _Table(source, "wheelset", top.get("wheelset"))
    wheelset = Wheelset(
        mass=t.positive("mass"),
        inertia=t.vector3("inertia"),
        rolling_radius=t.positive("rolling_radius"),
        contact_half_spacing=t.positive("contact_half_spacing"),
        # Treads steeper than 1:2 are not wheels; the linear contact model assumes small angles.
        # With [profiles], omitted: the profiles' equivalent conicity (below).
        conicity=t.number("conicity", low=0.0, low_open=True, high=0.5, required=not has_profiles),
        flangeway_clearance=t.positive("flangeway_clearance", 0.008),
        wheel_load=t.positive("wheel_load", required=False),
    )
    t.done()
    _practice(
        t,
        warnings,
        rolling_radius=wheelset.rolling_radius,
        contact_half_spacing=wheelset.contact_half_spacing,
        flangeway_clearance=wheelset.flangeway_clearance,
        mass=wheelset.mass,
        conicity=wheelset.conicity,
        wheel_load=wheelset.wheel_load,
    )
    if wheelset.rolling_radius >= wheelset.contact_half_spacing * 2:
        t.fail("rolling_radius", "is not smaller than the track gauge: check the units (m)")
    r0, b = wheelset.rolling_radius, wheelset.contact_half_spacing
    # Wheels at +/-b, axle journals and brake discs about a wheel radius further out.
    _inertia_fits(t, wheelset.mass, wheelset.inertia, math.hypot(b + r0, r0), "wheelset")
    profiles = None
    if has_profiles:
        profiles, conicity, shift = _profiles(_Table(source, "profiles", top.get("profiles")), wheelset)
        if "flangeway_clearance" in (top.get("wheelset") or {}):
            warnings.append(
                f"{source}: wheelset.flangeway_clearance is not used with [profiles]: their "
                f"flanges touch at {shift * 1e3:.2f} mm"
            )
        wheelset = dataclasses.replace(wheelset, flangeway_clearance=shift)
        if wheelset.conicity is None:
            wheelset = dataclasses.replace(wheelset, conicity=conicity)
            _practice(_Table(source, "wheelset", {}), warnings, conicity=conicity)
        else:
            warnings.append(
                f"{source}: wheelset.conicity is not used by the dynamics: a layout with [profiles] "
                f"runs on their contact tables (equivalent conicity at 3 mm: {conicity:.4g})"
            )

    has_contact = top.get("contact", None, required=False) is not None
    t = _Table(source, "creep", top.get("creep", {} if has_contact else ...))
    if has_contact:
        given = sorted({"f11", "f22", "f23", "f33"} & set(t.data))
        if given:
            t.fail(given[0], "given with [contact]: the creep coefficients come from the contact; give one of them")
        coefficients = None
    elif has_profiles and not {"f11", "f22", "f23", "f33"} & set(t.data):
        coefficients = None  # each contact point's own, from Hertz and Kalker (below)
    else:
        coefficients = dict(
            f11=t.positive("f11"), f22=t.positive("f22"), f23=t.non_negative("f23", 0.0), f33=t.non_negative("f33", 0.0)
        )
    law = t.get("law", "linear")
    if law not in LAWS:
        t.fail("law", f"must be one of {', '.join(LAWS)}, got {law!r}")
    if law == "fastsim" and not (has_contact or has_profiles):
        # FASTSIM works on the contact ellipse itself, which f11..f33 do not give (docs/creep.md).
        t.fail(
            "law",
            '"fastsim" needs a [contact] table: FASTSIM works on the Hertz contact ellipse, '
            "which f11..f33 alone do not give (docs/creep.md)",
        )
    friction = t.number("friction", low=0.0, low_open=True, high=2.0, required=law != "linear")
    _practice(t, warnings, friction=friction)
    falling = {k: t.get(k, None, required=False) for k in ("falling_friction_ratio", "falling_friction_rate")}
    if any(v is not None for v in falling.values()):
        if law != "polach":
            t.fail(
                next(k for k, v in falling.items() if v is not None),
                f"falling friction belongs to the polach law, not {law!r}",
            )
        falling = dict(
            falling_friction_ratio=t.number("falling_friction_ratio", low=0.0, low_open=True, high=1.0),
            falling_friction_rate=t.positive("falling_friction_rate"),
        )
    else:
        falling = {}
    creep_table = t

    is_spatial = top.get("spatial", None, required=False) is not None
    primary, primary_spring = _suspension_or_elements(
        _Table(source, "primary", top.get("primary")), "axlebox", is_spatial
    )

    # Two wheels cannot be closer than their diameter: that is the overlap check.
    wheel_diameter = 2.0 * wheelset.rolling_radius
    bogie = secondary = None
    secondary_elements: dict = {}
    has_bogie = top.get("bogie", None, required=False) is not None
    if has_bogie:
        t = _Table(source, "bogie", top.get("bogie"))
        bogie = Bogie(
            mass=t.positive("mass"),
            inertia=t.vector3("inertia"),
            wheelset_positions=t.positions("wheelset_positions", wheel_diameter, "wheelset"),
        )
        t.done()
        _practice(t, warnings, mass=bogie.mass)
        # Side frames about 0.5 m outside the wheels, ends a wheel radius past the axles.
        reach = max(abs(x) for x in bogie.wheelset_positions) + r0
        _inertia_fits(t, bogie.mass, bogie.inertia, math.hypot(reach, b + 0.5), "bogie frame")
        if top.get("secondary", None, required=False) is None:
            top.fail("secondary", "missing: a layout with [bogie] needs [secondary]")
        secondary_data, secondary_elements = _secondary_elements(source, top.get("secondary"), is_spatial)
        secondary, secondary_spring = _suspension_or_elements(
            _Table(source, "secondary", secondary_data), "spring", is_spatial
        )
        secondary = _planar_dampers(secondary, secondary_elements)
    elif top.get("secondary", None, required=False) is not None:
        top.fail("secondary", "given without [bogie]: secondary suspension joins bogies to the body")

    train = None
    if top.get("train", None, required=False) is not None:
        carbody, train = _train(top, source, warnings, bogie, wheel_diameter, r0, b, is_spatial)
    elif top.get("car", None, required=False) is not None or top.get("coupling", None, required=False) is not None:
        top.fail(
            "car" if "car" in top.data else "coupling",
            "given without [train]: [[car]] and [[coupling]] describe the car bodies of a train",
        )
    else:
        t = _Table(source, "carbody", top.get("carbody"))
        fixed = t.get("fixed", False)
        if not isinstance(fixed, bool):
            t.fail("fixed", f"must be true or false, got {_kind(fixed)}")
        carbody_mass = t.positive("mass", required=not fixed)
        carbody_inertia = t.vector3("inertia", required=not fixed)
        if bogie is not None:
            if "wheelset_positions" in t.data:
                t.fail("wheelset_positions", "not allowed with [bogie]: wheelsets hang from the bogies")
            extent = max(bogie.wheelset_positions) - min(bogie.wheelset_positions) + wheel_diameter
            carbody = CarBody(
                fixed,
                carbody_mass,
                carbody_inertia,
                bogie_positions=t.positions("bogie_positions", extent, "bogie"),
                wheelset_positions=None,
            )
        else:
            if "bogie_positions" in t.data:
                t.fail("bogie_positions", "given without a [bogie] table")
            carbody = CarBody(
                fixed,
                carbody_mass,
                carbody_inertia,
                bogie_positions=None,
                wheelset_positions=t.positions("wheelset_positions", wheel_diameter, "wheelset"),
            )
        t.done()
        _practice(t, warnings, mass=carbody.mass)
        # Ends overhang the outermost wheels by a few metres; about 2 m to the side and roof.
        xs = carbody.bogie_positions or carbody.wheelset_positions or ()
        reach = max(abs(x) for x in xs) + (max(abs(x) for x in bogie.wheelset_positions) if bogie else 0.0)
        _inertia_fits(t, carbody.mass, carbody.inertia, math.hypot(reach + r0 + 3.0, 2.0), "car body")
    designs = _bogie_designs(top, warnings, bogie, primary_spring, carbody, is_spatial, wheel_diameter, r0, b)
    if wheelset.wheel_load is None and carbody.mass is not None:
        # The mean static wheel load, the nominal load the creep coefficients are given at: each
        # wheel's own for a symmetric vehicle. (A spatial vehicle's wheels carry their own static
        # loads, from its suspension: rail_mj.vehicle.loads.) fsum of equal masses is n times one, exactly.
        n_bogies = len(carbody.bogie_positions or ())
        n_wheelsets = len(carbody.wheelset_positions or ()) or (
            n_bogies * len(bogie.wheelset_positions) if bogie else 0
        )
        masses = [d.mass for d in designs] or ([bogie.mass] * n_bogies if bogie else [])
        mass = carbody.mass + (math.fsum(masses) if bogie else 0.0)
        wheelset = dataclasses.replace(wheelset, wheel_load=GRAVITY * (mass / n_wheelsets + wheelset.mass) / 2)
    needs_load = "[contact]" if has_contact else f"creep law {law!r}" if law != "linear" else None
    if needs_load and wheelset.wheel_load is None:
        top.fail(
            "wheelset.wheel_load",
            f"missing: {needs_load} needs the wheel load, and a fixed car "
            f"body without mass gives no weight to share; give it in N",
        )
    contact = None
    if has_contact:
        contact, coefficients = _contact(_Table(source, "contact", top.get("contact")), wheelset, profiled=has_profiles)
    if has_profiles and wheelset.wheel_load is not None:
        if coefficients is not None and not has_contact:
            warnings.append(
                f"{source}: creep.f11..f33 are not used by the dynamics: with [profiles] each "
                f"contact point has its own, from Hertz and Kalker"
            )
        if law == "linear":
            warnings.append(
                f'{source}: creep.law "linear" on profiles: on the flanges the creep forces '
                f"grow without bound; choose a saturating law for runs"
            )
        from rail_mj.contact.tables import TableError, centred_coefficients

        try:
            coefficients = centred_coefficients(profiles, wheelset, contact, law, friction)
        except TableError as e:
            top.fail("profiles", str(e))
    elif has_profiles and coefficients is None:
        top.fail(
            "wheelset.wheel_load",
            "missing: the contact on profiles needs the wheel load, and a fixed car "
            "body without mass gives no weight to share; give it in N",
        )
    creep_table.done()
    # Given, or from [contact] or the profiles; each way without them has failed above.
    assert coefficients is not None
    creep = Creep(**coefficients, law=law, friction=friction, **falling)
    flange = None
    if top.get("flange", None, required=False) is not None:
        t = _Table(source, "flange", top.get("flange"))
        if has_profiles:
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
            angle=t.number("angle", default.angle, low=wheelset.conicity, low_open=True, high=math.radians(89.0)),
        )
        t.done()
    spatial = None
    if is_spatial:
        # With [spatial] the element tables are read, [primary.axlebox] always and
        # [secondary.spring] with [bogie] (_spatial refuses a spatial vehicle without it).
        assert primary_spring is not None
        spatial = _spatial(
            _Table(source, "spatial", top.get("spatial")),
            top,
            carbody,
            bogie,
            train,
            primary_spring,
            secondary_spring if bogie else None,
            r0,
        )
        spatial = dataclasses.replace(spatial, **secondary_elements, bogies=designs)
        if train is not None:
            train = _spatial_train(top, train, spatial)
        _static_sags(source, warnings, spatial, carbody, train)
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
    )


GRAVITY = 9.81  # m/s^2
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
    wheel_diameter: float,
    r0: float,
    b: float,
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
    n = len(xs)
    given = {}
    if data is not None:
        t = _Table(top.source, "bogies", data)
        for key, value in data.items():
            if not BOGIE_NUMBER.fullmatch(key) or int(key) > n:
                t.fail(
                    key,
                    f"no such bogie: N in [bogies.N] is a bogie's number in carbody.bogie_positions, "
                    f"1 (leading) to {n}",
                )
            given[int(key)] = value
            t.used.add(key)
        t.done()
    designs = []
    for i in range(1, n + 1):
        if i not in given:
            designs.append(BogieDesign(bogie.mass, bogie.inertia, bogie.wheelset_positions, primary))
            continue
        e = _Table(top.source, f"bogies.{i}", given[i])
        mass = e.positive("mass", bogie.mass)
        inertia = e.vector3("inertia", required=False) or bogie.inertia
        positions = e.positions("wheelset_positions", wheel_diameter, "wheelset", required=False)
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
        reach = max(abs(x) for x in positions) + r0  # as [bogie]'s
        _inertia_fits(e, mass, inertia, math.hypot(reach, b + 0.5), "bogie frame")
        designs.append(BogieDesign(mass, inertia, positions, axlebox))
    for k in range(1, n):  # [bogie]'s spacing check holds for its own wheelbase only
        front = xs[k - 1] + min(designs[k - 1].wheelset_positions)
        back = xs[k] + max(designs[k].wheelset_positions)
        if front - back < wheel_diameter:
            top.fail(
                "bogies",
                f"the wheelsets of bogies {k} and {k + 1} at x = {front:g} and {back:g} m overlap: "
                f"they must be at least {wheel_diameter:g} m apart",
            )
    return tuple(designs)


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
    t: _Table,
    top: _Table,
    carbody: CarBody,
    bogie: Bogie | None,
    train,
    primary: Spring,
    secondary: Spring | None,
    r0: float,
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
    )
    t.done()
    if spatial.carbody_height < spatial.bogie_height:  # equal: the planar limit (docs/spatial.md)
        t.fail(
            "carbody_height",
            f"must not be below bogie_height ({spatial.bogie_height:g} m), got {spatial.carbody_height:g} m",
        )
    return spatial


def _static_sags(source: str, warnings: list[str], spatial: Spatial, carbody: CarBody, train) -> None:
    """The springs' static deflections under the weight (docs/spatial.md), each bogie's with its
    equal share of the car bodies' weight: one that sinks a spring's upper seat below the rail is
    refused (no suspension stands like that: most often N/m taken for kN/m, or a mass in grams),
    one outside practice noted (rail_mj.layout.practice). And the car body must stand on its springs in
    roll: their roll stiffness about the springs' level (each anti-roll bar's besides) must
    exceed the weight's overturning m*g*h there, or the body tips over (a one-line error)."""
    if not spatial.gravity:
        return
    bodies = sum(car.mass for car in train.cars) if train is not None else carbody.mass
    if bodies is None:
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
    if spatial.gravitational_stiffness:
        cars = train.cars if train is not None else [carbody]
        for k, car in enumerate(cars, start=1):
            height = getattr(car, "height", None) or spatial.carbody_height
            n = len(car.bogies) if train is not None else n_bogies
            overturning = car.mass * GRAVITY * (height - e.height)
            roll = n * (2 * e.kz * e.spacing**2 + (spatial.anti_roll_bar or 0.0))
            if train is not None:  # a Jacobs bogie's springs are shared by its two bodies
                roll = sum(
                    (2 * e.kz * e.spacing**2 + (spatial.anti_roll_bar or 0.0)) / len(train.cars_on(b))
                    for b in car.bogies
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
    top: _Table,
    source: str,
    warnings: list[str],
    bogie: Bogie | None,
    wheel_diameter: float,
    r0: float,
    b: float,
    is_spatial: bool = False,
) -> tuple[CarBody, Train]:
    """[train], [[car]] and [[coupling]], checked (docs/trains.md): the train's bogies and the cars
    they carry, one clear line for each bad topology."""
    if bogie is None:
        top.fail("train", "needs [bogie]: a train's car bodies rest on bogies (train.bogie_positions)")
    if "carbody" in top.data:
        top.fail("carbody", "not used with [train]: give each car body as a [[car]]")
    t = _Table(source, "train", top.get("train"))
    extent = max(bogie.wheelset_positions) - min(bogie.wheelset_positions) + wheel_diameter
    bogie_x = t.positions("bogie_positions", extent, "bogie")
    t.done()
    cars_data = top.get("car", None, required=False)
    if isinstance(cars_data, dict):
        top.fail("car", "is one [car] table: give each car body as an array entry, [[car]], leading first")
    if not isinstance(cars_data, list) or not cars_data:
        top.fail("car", "missing: a [train] needs its car bodies, one [[car]] each, leading first")
    cars = []
    for k, data in enumerate(cars_data, start=1):
        t = _Table(source, f"car[{k}]", data)
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
        _practice(_Table(source, "carbody", {}), warnings, mass=mass)
        _inertia_fits(t, mass, inertia, math.hypot(length / 2, 2.0), "car body")
        cars.append(Car(mass, inertia, position, length, tuple(carried), height))
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
    couplings: list[Coupling] = []
    coupling_data = top.get("coupling", [], required=False) or []
    if not isinstance(coupling_data, list):
        top.fail("coupling", "must be an array of tables, one [[coupling]] per pair of adjacent cars")
    for k, data in enumerate(coupling_data, start=1):
        t = _Table(source, f"coupling[{k}]", data)
        pair = t.get("cars")
        if not (
            isinstance(pair, list)
            and len(pair) == 2
            and all(isinstance(i, int) and not isinstance(i, bool) for i in pair)
        ):
            t.fail("cars", f"must be two car numbers [k, k + 1], got {_kind(pair)}")
        if pair[1] != pair[0] + 1 or not 1 <= pair[0] < len(cars):
            t.fail("cars", f"must be two adjacent cars [k, k + 1] of the {len(cars)}, got {pair}")
        if any(c.cars == tuple(pair) for c in couplings):
            t.fail("cars", f"cars {pair} are coupled twice: give one [[coupling]] per pair")
        couplings.append(
            Coupling(
                tuple(pair),
                t.non_negative("lateral_stiffness", 0.0),
                t.non_negative("yaw_stiffness", 0.0),
                t.non_negative("lateral_damping", 0.0),
                t.non_negative("yaw_damping", 0.0),
            )
        )
        t.done()
    total = sum(car.mass for car in cars)
    carbody = CarBody(False, total, cars[0].inertia, bogie_positions=bogie_x, wheelset_positions=None)
    return carbody, Train(tuple(cars), tuple(couplings))


def _profiles(t: _Table, wheelset: Wheelset) -> tuple[Profiles, float | None, float]:
    """[profiles], checked: the files read, the wheelset stood on its rails; the shift at
    which a flange touches (the profiles' flangeway clearance, m) and with wheelset.conicity
    omitted, the profiles' equivalent conicity at 3 mm."""
    from rail_mj.contact import profiles as p  # numpy: only for layouts that need it

    base = Path(t.source).parent if t.source != "<layout>" else Path(".")
    names = {}
    for kind in ("wheel", "rail"):
        value = t.get(kind)
        if not isinstance(value, str) or not value.strip():
            t.fail(
                kind,
                f"must be a standard {kind} ({', '.join(STANDARD_PROFILES[kind])}) or a profile "
                f"file's path, got {_kind(value)}",
            )
        if value.lower() in STANDARD_PROFILES[kind]:
            names[kind] = value.lower()
            continue
        other = "rail" if kind == "wheel" else "wheel"
        if value.lower() in STANDARD_PROFILES[other]:
            t.fail(kind, f"{value!r} is a standard {other} profile, not a {kind}")
        path = (base / value) if not Path(value).is_absolute() else Path(value)
        if path.suffix.lower() not in (".csv", ".prw", ".prr"):
            t.fail(
                kind,
                f"must be {', '.join(STANDARD_PROFILES[kind])} or a profile file (.csv, SIMPACK .prw "
                f"or .prr), got {value!r}",
            )
        if not path.is_file():
            t.fail(kind, f"{path}: no such file (paths are relative to the layout file)")
        names[kind] = str(path)
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
    from rail_mj.contact.geometry import GeometryError

    try:
        conicity, shift = _profiles_conicity(profiles, wheelset.rolling_radius, stamp(profiles))
    except GeometryError as e:
        t.fail(None, str(e))
    if wheelset.conicity is None and not (conicity is not None and 0.0 < conicity <= 0.5):
        t.fail(
            None,
            f"the profiles' equivalent conicity at 3 mm is {conicity:.4g}, outside (0, 0.5]: give "
            f"wheelset.conicity for the dynamics",
        )
    if shift is None:  # flangeless wheels (a test cone): held only where the table ends
        from rail_mj.contact.geometry import DEFAULT_YS

        shift = float(-DEFAULT_YS[0])
    return profiles, conicity, shift


TREAD_ANGLE = 0.2  # rad
TREAD_HALF_WIDTH = 0.025  # m either side of the taping line


@functools.lru_cache(maxsize=32)
def _profiles_conicity(profiles: Profiles, r0: float, _stamp) -> tuple[float, float | None]:
    """The profiles' equivalent conicity at 3 mm (EN 15302) from their contact geometry,
    and where a flange first touches. Once per profiles."""
    from rail_mj.contact import geometry
    from rail_mj.contact.conicity import QUOTED_AMPLITUDE, ConicityError

    track = geometry.track_of_profiles(profiles, r0)
    centred = geometry.contact_table(track, ys=[0.0])
    # Centred, each wheel must stand on its tread, near its taping line: tread cones are 1:40
    # to 1:10 (0.025-0.1 rad) and run about 25 mm either side of the taping line (S1002: the
    # flange root begins 26 mm inside it); a flange is at 65-75 degrees. A wheel touching
    # farther out, steeper, or at the end of its profile is placed wrongly (flange back
    # spacing, gauge or cant), not a wheel standing on a rail.
    lo, hi = float(track.wheel.y[0]), float(track.wheel.y[-1])
    for side in ("left", "right"):
        angle = float(getattr(centred, f"contact_angle_{side}")[0])
        s = float(getattr(centred, f"wheel_s_{side}")[0])
        if abs(s) > TREAD_HALF_WIDTH:
            raise geometry.GeometryError(
                f"centred, the {side} wheel touches its rail {s * 1e3:.1f} mm from its taping line, off its "
                f"tread: check flange_back_spacing, track_gauge and rail_inclination"
            )
        if abs(angle) > TREAD_ANGLE:
            raise geometry.GeometryError(
                f"centred, the {side} wheel touches its rail at {angle:.3g} rad (s = {s * 1e3:.1f} mm), not on "
                f"its tread: check flange_back_spacing, track_gauge and rail_inclination"
            )
        if not lo + 0.001 < s < hi - 0.001:
            raise geometry.GeometryError(
                f"centred, the {side} wheel touches its rail at the edge of its profile (s = {s * 1e3:.1f} mm): "
                f"check flange_back_spacing, track_gauge and rail_inclination"
            )
    table = geometry.default_table(profiles, r0)
    shift = geometry.flange_contact_shift(table)
    try:
        return geometry.equivalent_conicity(table, QUOTED_AMPLITUDE), shift
    except ConicityError as e:
        raise geometry.GeometryError(f"no equivalent conicity: {e}") from None


def _contact(t: _Table, wheelset: Wheelset, profiled: bool = False):
    """[contact]: Hertz's ellipse and Kalker's coefficients (docs/contact.md). With
    [profiles] only the steel: the profiles give every point's curvatures."""
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
    t.done()
    if profiled:
        return contact, None
    from rail_mj.contact.hertz import ContactError  # scipy: only for layouts that need it

    try:
        patch = _patch(contact, wheelset)
    except ContactError as e:
        t.fail(None, str(e))
    return contact, patch.creep_coefficients


def _patch(contact: Contact, wheelset: Wheelset):
    """The Hertz ellipse and Kalker coefficients of [contact] under `wheelset`'s wheels."""
    from rail_mj.contact.hertz import contact_patch

    # A [contact] on cones has its rail's crown and its wheel load (the reader requires both).
    assert contact.rail_transverse_radius is not None and wheelset.wheel_load is not None
    return contact_patch(
        wheelset.wheel_load,
        wheelset.rolling_radius,
        contact.rail_transverse_radius,
        young_modulus=contact.young_modulus,
        poisson_ratio=contact.poisson_ratio,
        wheel_transverse_radius=contact.wheel_transverse_radius,
    )


def contact_patch_of(layout: Layout):
    """The Hertz ellipse and Kalker coefficients of a layout with [contact]."""
    if layout.contact is None:
        raise ValueError(f"{layout.source}: no [contact] table: no Hertz ellipse")
    return _patch(layout.contact, layout.wheelset)


def load_layout(path: str | Path) -> Layout:
    """Read and check a layout file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise LayoutError(f"{path}: cannot read: {getattr(e, 'strerror', None) or e}") from None
    try:
        data = tomllib.loads(text)
    except ValueError as e:  # TOMLDecodeError, and integers too long to convert
        raise LayoutError(f"{path}: not valid TOML: {e}") from None
    return layout_from_dict(data, source=str(path))
