"""[profiles]: the wheel and rail profiles a layout names, and how the track places them.

A record of names and numbers, no numpy: a layout keeps it as the user wrote it
(rail_mj.layout) and the contact geometry reads the profiles it names (rail_mj.contact.geometry).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

STANDARD_PROFILES = {"wheel": ("s1002",), "rail": ("60e1", "uic60")}


@dataclasses.dataclass(frozen=True)
class Profiles:
    """[profiles]: wheel and rail profiles and how the track places them (docs/geometry.md).
    `wheel` and `rail` are a standard name ("s1002", "60e1") or a file's resolved path."""

    wheel: str
    rail: str
    rail_inclination: float  # tan of each rail's cant towards the track centre
    track_gauge: float  # m, 14 mm below the rail top
    flange_back_spacing: float  # m, between the wheels' inner faces
    # Switches that keep the classical planar law reachable: the normal forces' lateral
    # parts, and spin creep (off: f23 = f33 = 0).
    gravitational_stiffness: bool = True
    spin_creep: bool = True
    # Not a layout key: linear analysis sets it to linearise the contact at this lateral
    # amplitude, mm (rail_mj.contact.tables.linearised); None: the full tables.
    linearised_at: float | None = None


def read_profiles(profiles: Profiles):
    """(wheel, rail): the Profile objects [profiles] names. Raises ProfileError."""
    from rail_mj.contact.profiles import ProfileError, read_profile, standard  # numpy: only when read

    out = []
    for kind, name in (("wheel", profiles.wheel), ("rail", profiles.rail)):
        if name in STANDARD_PROFILES[kind]:
            out.append(standard(name))
            continue
        shape = read_profile(name, kind if Path(name).suffix.lower() == ".csv" else None)
        if shape.kind != kind:
            raise ProfileError(f"{name}: a {shape.kind} profile given as the {kind}")
        out.append(shape)
    return tuple(out)


def stamp(profiles: Profiles):
    """The profile files' modification times: a changed file is read again."""
    return tuple(Path(n).stat().st_mtime_ns if Path(n).is_file() else 0 for n in (profiles.wheel, profiles.rail))
