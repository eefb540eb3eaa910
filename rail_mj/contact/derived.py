"""What a layout's contact implies: the numbers a layout file may leave out, one function each.

A layout may leave a wheelset's conicity and flangeway clearance to its wheel and rail
profiles, the creep coefficients f11..f33 to [contact] or to the profiles, and the wheel load
to the vehicle's weight. The layout reader (rail_mj.layout.reader) keeps what the user wrote
(`Layout.given`), puts the numbers these functions derive in the layout, and names where each
came from (`Layout.derived`, with the descriptions below). No layout and no MuJoCo here:
profiles (rail_mj.contact.pair.Profiles), radii, loads and moduli in, numbers out. numpy and
scipy are imported by the functions that need them, so that a layout on cones reads fast.

Example (new S1002 on 60E1 at 1:40, the nominal radius 0.46 m):

    >>> from rail_mj.contact.pair import Profiles
    >>> pair = Profiles("s1002", "60e1", rail_inclination=0.025, track_gauge=1.435, flange_back_spacing=1.36)
    >>> check_centred(pair, 0.46)
    >>> round(profiles_conicity(pair, 0.46), 4), round(flange_shift(pair, 0.46) * 1e3, 2)
    (0.1771, 6.3)
    >>> round(static_wheel_load(32000.0 + 2 * 2615.0, 4, 1813.0))
    54546
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Protocol

from rail_mj.contact.pair import Profiles, stamp
from rail_mj.units import GRAVITY

if TYPE_CHECKING:
    from rail_mj.contact.hertz import ContactPatch

# Where each derived number comes from, as `Layout.derived` names it.
PROFILES_CONICITY = "equivalent conicity of the profiles at 3 mm (EN 15302)"  # conicity.QUOTED_AMPLITUDE
PROFILES_FLANGE_SHIFT = "lateral shift at which a flange of the profiles first touches its rail"
PROFILES_NO_FLANGE = "end of the profiles' contact table: no flange touches within it"
CONTACT_KALKER = "Kalker's coefficients of the Hertz ellipse of [contact] under the wheel load"
PROFILES_KALKER = "Kalker's coefficients at the centred contact of the profiles under the wheel load"
STATIC_WHEEL_LOAD = "static weight of the vehicle shared equally by its wheels"

# Centred, each wheel must stand on its tread, near its taping line: tread cones are 1:40 to
# 1:10 (0.025-0.1 rad) and run about 25 mm either side of the taping line (S1002: the flange
# root begins 26 mm inside it); a flange is at 65-75 degrees.
TREAD_ANGLE = 0.2  # rad
TREAD_HALF_WIDTH = 0.025  # m either side of the taping line


class _Contact(Protocol):
    """[contact]'s steel and radii (rail_mj.layout.reader.Contact)."""

    @property
    def young_modulus(self) -> float: ...
    @property
    def poisson_ratio(self) -> float: ...
    @property
    def rail_transverse_radius(self) -> float | None: ...
    @property
    def wheel_transverse_radius(self) -> float | None: ...


def check_centred(profiles: Profiles, r0: float) -> None:
    """Raise GeometryError unless the centred wheelset stands on its treads: a wheel touching
    farther out than TREAD_HALF_WIDTH, steeper than TREAD_ANGLE or at the end of its profile is
    placed wrongly (flange back spacing, gauge or cant), not a wheel standing on a rail."""
    _check_centred(profiles, r0, stamp(profiles))


@functools.lru_cache(maxsize=32)
def _check_centred(profiles: Profiles, r0: float, _stamp: tuple[int, ...]) -> None:
    from rail_mj.contact import geometry

    track = geometry.track_of_profiles(profiles, r0)
    centred = geometry.contact_table(track, ys=[0.0])
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


def profiles_conicity(profiles: Profiles, r0: float) -> float:
    """The profiles' equivalent conicity at 3 mm (EN 15302) from their contact geometry (the
    default table, rail_mj.contact.geometry.default_table); once a process for each profiles
    and r0. Raises GeometryError, also where EN 15302 gives none."""
    return _profiles_conicity(profiles, r0, stamp(profiles))


@functools.lru_cache(maxsize=32)
def _profiles_conicity(profiles: Profiles, r0: float, _stamp: tuple[int, ...]) -> float:
    from rail_mj.contact import geometry
    from rail_mj.contact.conicity import QUOTED_AMPLITUDE, ConicityError

    table = geometry.default_table(profiles, r0)
    try:
        return geometry.equivalent_conicity(table, QUOTED_AMPLITUDE)
    except ConicityError as e:
        raise geometry.GeometryError(f"no equivalent conicity: {e}") from None


def flange_shift(profiles: Profiles, r0: float) -> float:
    """The lateral shift (m) at which a flange first touches its rail: the profiles' flangeway
    clearance; for flangeless wheels (a test cone) the end of the table, where the wheelset is
    held (`has_flange` tells which). Raises GeometryError."""
    from rail_mj.contact import geometry

    shift = geometry.flange_contact_shift(geometry.default_table(profiles, r0))
    return float(-geometry.DEFAULT_YS[0]) if shift is None else shift


def has_flange(profiles: Profiles, r0: float) -> bool:
    """Whether a flange of the profiles touches its rail within the contact table."""
    from rail_mj.contact import geometry

    return geometry.flange_contact_shift(geometry.default_table(profiles, r0)) is not None


def contact_ellipse(contact: _Contact, wheel_load: float, r0: float) -> ContactPatch:
    """The Hertz ellipse of [contact] on coned wheels of rolling radius r0 under `wheel_load`
    (N), with its Kalker coefficients (rail_mj.contact.hertz). Raises ContactError."""
    from rail_mj.contact.hertz import contact_patch

    if contact.rail_transverse_radius is None:  # only [contact] on profiles leaves it out
        raise ValueError("[contact] without rail_transverse_radius: on profiles each point has its own ellipse")
    return contact_patch(
        wheel_load,
        r0,
        contact.rail_transverse_radius,
        young_modulus=contact.young_modulus,
        poisson_ratio=contact.poisson_ratio,
        wheel_transverse_radius=contact.wheel_transverse_radius,
    )


def contact_kalker(contact: _Contact, wheel_load: float, r0: float) -> dict[str, float]:
    """f11, f22 (N), f23 (N m), f33 (N m^2) of [contact]'s Hertz ellipse (`contact_ellipse`)."""
    return contact_ellipse(contact, wheel_load, r0).creep_coefficients


def profiles_kalker(profiles: Profiles, wheelset, contact: _Contact | None, law: str, friction) -> dict[str, float]:
    """f11..f33 of one wheel of the centred wheelset on its profiles under its static load,
    summed over its contact points: what a coned model of the same wheelset would take
    (rail_mj.contact.tables.centred_coefficients; `wheelset` gives rolling_radius and
    wheel_load, `contact` the steel, None: 210 GPa and 0.28). Raises TableError."""
    from rail_mj.contact.tables import centred_coefficients

    return centred_coefficients(profiles, wheelset, contact, law, friction)


def static_wheel_load(carried_mass: float, n_wheelsets: int, wheelset_mass: float) -> float:
    """The mean static wheel load (N): the weight of what the wheelsets carry (kg; car body and
    bogie frames) shared equally by the n wheelsets, each with its own, over its two wheels.
    The nominal load the creep coefficients are given at; each wheel's own on a symmetric
    vehicle (a spatial vehicle's wheels carry their own static loads from its suspension,
    rail_mj.vehicle.loads)."""
    return GRAVITY * (carried_mass / n_wheelsets + wheelset_mass) / 2
