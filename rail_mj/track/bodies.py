"""Each body at its own station: the track under every body of a vehicle, and the geometric
pre-deflections of the suspension between bodies at different stations (docs/track.md).

A vehicle's reference point is at distance s along the track; a body whose centre sits dx ahead
of it along the vehicle (leading positive, as layouts give positions: docs/frames.md) is at
s + dx and sees the curvature and cant there. A leading wheelset enters a transition before its
bogie frame, the frame before the car body.

In the track-following frame a body's lateral displacement y and yaw psi are measured from the
track at its own station. A suspension element between a parent and a child dx ahead of it is
then deflected by the difference of their coordinates plus a part that is the track's geometry
alone: with both bodies centred on the track and yawed with it, the child is turned from its
parent by the change of heading between their stations, and stands off the parent's axis by the
track's offset from the parent's tangent there. Those are the pre-deflections (`pre_deflections`,
exact; `curve_pre_deflections`, their small-angle forms):

    yaw        heading(s + dx) - heading(s)        = dx*k on a curve of curvature k
    lateral    the track at s + dx, off the tangent at s, to the left
                                                   = dx^2*k/2 - dx^4*k^3/24 + ... on a curve

and the element's deflections are psi_c - psi_p + yaw (rad) and y_c - y_p - dx*psi_p + lateral
(m, along the parent's y axis). Said the other way round: coordinates taken from the parent's
tangent (not from the track at each station) are deflected from where the curve puts them by
psi_c - psi_p - yaw and y_c - y_p - dx*psi_p - lateral.

Example:

    >>> from rail_mj.track import load_track
    >>> track = load_track("models/tracks/curve-600.toml")   # the curve starts at 300 m
    >>> at = at_bodies(track, 300.0, [1.28, -1.28])           # a bogie's wheelsets, its centre at 300 m
    >>> (at.curvature * 600.0).round(4).tolist()             # the trailing one is still in the transition
    [1.0, 0.9872]
    >>> bent = pre_deflections(track, 450.0, parent=0.0, child=9.5)  # a bogie 9.5 m ahead of the body
    >>> round(float(bent.yaw), 7), round(float(bent.lateral), 7)   # 9.5/600; 600*(1 - cos(9.5/600))
    (0.0158333, 0.0752068)
    >>> round(float(curve_pre_deflections(9.5, 1 / 600).lateral), 7)  # 9.5^2/1200, 1.6 um more
    0.0752083
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike

from rail_mj.track.geometry import Array, Track


@dataclasses.dataclass(frozen=True)
class AtBodies:
    """The track under each body: arrays of shape s.shape + offsets.shape."""

    x: Array  # m, each body's distance along the track
    curvature: Array  # 1/m, positive turning left
    cant: Array  # m, signed as Track.cant


@dataclasses.dataclass(frozen=True)
class PreDeflection:
    """The deflection of a suspension element from the track's geometry alone (see the module)."""

    yaw: Array  # rad, the child turned from its parent, positive nose-left
    lateral: Array  # m, the child off its parent's axis, positive to the left


def at_bodies(track: Track, s: ArrayLike, offsets: ArrayLike) -> AtBodies:
    """Curvature and cant at each body: offsets (m along the vehicle from its reference point,
    leading positive) from the reference point at s (m along the track, one or many)."""
    x = np.add.outer(np.asarray(s, dtype=float), np.asarray(offsets, dtype=float))
    return AtBodies(x, track.curvature(x), track.cant(x))


def pre_deflections(track: Track, s: ArrayLike, parent: ArrayLike, child: ArrayLike) -> PreDeflection:
    """The geometric pre-deflections of the element between a parent and a child body whose
    centres sit `parent` and `child` m along the vehicle from its reference point at s: exact,
    from the track's heading and plane position, along any curvature (arrays broadcast)."""
    s = np.asarray(s, dtype=float)
    at_parent = s + np.asarray(parent, dtype=float)
    at_child = s + np.asarray(child, dtype=float)
    heading = track.heading(at_parent)
    d = track.xy(at_child) - track.xy(at_parent)
    lateral = -np.sin(heading) * d[..., 0] + np.cos(heading) * d[..., 1]
    return PreDeflection(track.heading(at_child) - heading, lateral)


def curve_pre_deflections(dx: ArrayLike, curvature: ArrayLike, curvature_rate: ArrayLike = 0.0) -> PreDeflection:
    """The pre-deflections of a child dx ahead of its parent (m; behind: negative) to the
    lowest order in the angles, with the track's curvature at the parent (1/m) changing at
    `curvature_rate` (1/m^2; 0 on a curve, constant along a transition): yaw is the integral of
    the curvature over dx, exact; lateral the integral of (dx - v)*curvature(v), the small-angle
    offset from the tangent, whose error is of order dx*yaw^3/6 (dx^4*k^3/24 on a curve)."""
    dx, k, rate = (np.asarray(a, dtype=float) for a in (dx, curvature, curvature_rate))
    return PreDeflection(dx * k + rate * dx**2 / 2, dx**2 * k / 2 + rate * dx**3 / 6)
