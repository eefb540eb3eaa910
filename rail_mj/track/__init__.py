"""The track, from distance along it to numbers: no MuJoCo, no layout (docs/track.md).

    geometry.py    `Track`: its sections; curvature, cant, heading, plane position, cant deficiency at x
    reader.py      a track file (TOML sections or CSV design geometry) -> checked `Track`, one line per problem
    speed.py       `SpeedProfile`: the speed along the track, linear between points (a run that brakes)
    bodies.py      each body at its own station: the track under it, the suspension's geometric pre-deflections
    irregularities.py  track irregularities: standard spectra (ERRI B176, FRA), band variances, realisations,
                   a track file's [irregularities] (generated or measured) and their CSV
    errors.py      `TrackError`, one line naming the file and the section

Example:

    >>> from rail_mj.track import load_track
    >>> track = load_track("models/tracks/curve-600.toml")
    >>> [(s.kind, s.length) for s in track.sections]
    [('straight', 200.0), ('transition', 100.0), ('curve', 300.0), ('transition', 100.0), ('straight', 200.0)]
"""

from rail_mj.track.bodies import AtBodies, PreDeflection, at_bodies, curve_pre_deflections, pre_deflections
from rail_mj.track.geometry import CANT_BASE, Section, Track, TrackError
from rail_mj.track.reader import load_track, track_from_csv, track_from_dict
from rail_mj.track.speed import SpeedProfile

__all__ = [
    "CANT_BASE",
    "AtBodies",
    "PreDeflection",
    "Section",
    "SpeedProfile",
    "Track",
    "TrackError",
    "at_bodies",
    "curve_pre_deflections",
    "load_track",
    "pre_deflections",
    "track_from_csv",
    "track_from_dict",
]
