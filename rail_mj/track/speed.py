"""A speed profile: the speed along the track, linear between given points (docs/track.md).

A run at constant speed has a number; a run that accelerates or brakes along the track, as
a practitioner's slow deceleration through the critical speed does, has a `SpeedProfile`:
(station, speed) points, the speed linear in distance between them and held beyond the
ends. Stations are the distance along the track of the vehicle's origin (its car body's
centre), as the odometer measures it (rail_mj.vehicle.curve).

Speed linear in distance, not in time, because that is how a line's speeds are written; the
time it takes is then a closed form, ln(V1/V0)/(dV/ds) a piece. Along it dV/dt = V*dV/ds.

Example:

    >>> profile = SpeedProfile.parse("0:90,3000:60")
    >>> float(profile.at(1500.0)), round(float(profile.duration(0.0, 3000.0)), 2)
    (75.0, 40.55)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rail_mj.practice import RANGES
from rail_mj.track.geometry import TrackError

Array = NDArray[np.float64]

# The source of the straight track a speed profile runs along when no track is given (the
# odometer it drives needs one): a run on it is a run on straight track (rail_mj.simulation.run).
PROFILE_TRACK = "<straight track of a speed profile>"


@dataclasses.dataclass(frozen=True)
class SpeedProfile:
    """Speed (m/s) against the odometer's station (m), linear between the points."""

    stations: tuple[float, ...]
    speeds: tuple[float, ...]
    source: str = "<speed profile>"

    def __post_init__(self) -> None:
        where = f"{self.source}: speed profile"
        if len(self.stations) != len(self.speeds) or len(self.stations) < 1:
            raise TrackError(f"{where} needs at least one point, a station and a speed each")
        for s in self.stations:
            if not math.isfinite(s):
                raise TrackError(f"{where}: station {s} is not a finite distance (m)")
        if any(b <= a for a, b in zip(self.stations, self.stations[1:], strict=False)):
            raise TrackError(f"{where}: its stations must increase, got {', '.join(f'{s:g}' for s in self.stations)}")
        speed = RANGES["speed"]
        for v in self.speeds:
            problem = speed.check(v) if math.isfinite(v) else f"must be finite, got {v}"
            if problem is None and v <= 0.0:
                problem = f"must be positive (a run rolls), got {v:g}"
            if problem is not None:
                raise TrackError(f"{where}: speed {problem}")

    @classmethod
    def parse(cls, text: str, source: str = "--speed-profile") -> SpeedProfile:
        """From 'S:V,S:V,...' (stations in m, speeds in m/s), as the command line takes it."""
        stations, speeds = [], []
        for item in text.split(","):
            parts = item.strip().split(":")
            try:
                if len(parts) != 2:
                    raise ValueError
                stations.append(float(parts[0]))
                speeds.append(float(parts[1]))
            except ValueError:
                raise TrackError(
                    f"{source}: expected station:speed pairs such as 0:90,3000:60 (m, m/s), got {item.strip()!r}"
                ) from None
        return cls(tuple(stations), tuple(speeds), source)

    @classmethod
    def ramp(cls, start: float, end: float, length: float, station: float = 0.0) -> SpeedProfile:
        """From `start` to `end` m/s over `length` m from `station`."""
        return cls((station, station + length), (start, end), f"<ramp {start:g} -> {end:g} m/s over {length:g} m>")

    def at(self, s: ArrayLike) -> Array:
        """The speed at station(s) `s`, m/s."""
        return np.interp(np.asarray(s, dtype=float), self.stations, self.speeds)

    def duration(self, start: float, end: float) -> float:
        """The time from station `start` to `end` (> start) along the profile, s: per piece
        ds/V with V linear in s, ln(V1/V0)/(dV/ds), and (s1 - s0)/V where V is constant."""
        cuts = [start] + [s for s in self.stations if start < s < end] + [end]
        total = 0.0
        for a, b in zip(cuts, cuts[1:], strict=False):
            va, vb = float(self.at(a)), float(self.at(b))
            gradient = (vb - va) / (b - a)
            total += (b - a) / va if abs(vb - va) <= 1e-12 * va else math.log(vb / va) / gradient
        return total

    def lowest(self, start: float, end: float) -> float:
        """The lowest speed between stations `start` and `end`, m/s (it sets the timestep)."""
        return min(self._inside(start, end))

    def highest(self, start: float, end: float) -> float:
        """The highest speed between stations `start` and `end`, m/s."""
        return max(self._inside(start, end))

    def _inside(self, start: float, end: float) -> list[float]:
        ends = [float(self.at(s)) for s in (start, end)]
        return ends + [v for s, v in zip(self.stations, self.speeds, strict=True) if start < s < end]

    def block(self) -> list[float]:
        """The points as the native block carries them (rail_mj.numerics, the track part)."""
        return [float(v) for pair in zip(self.stations, self.speeds, strict=True) for v in pair]
