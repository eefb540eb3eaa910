"""Wheel geometry: a coned tread with a flange, or a wheel profile's own outline
(rail_mj.contact.profiles), revolved into a mesh by trimesh.

The mesh is for looking at. MuJoCo collides meshes through their convex hulls,
which would fill the flange throat, so wheel-rail contact is computed in
`rail_mj.contact.creep` from the same numbers (r0, conicity, or the profiles' contact
tables), never from this mesh.
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from rail_mj.files import cached_arrays, keep_arrays

if TYPE_CHECKING:
    import trimesh

# Profile dimensions in m, measured from the nominal contact point along the axle
# (positive outward, away from the track centre). Round numbers of the size of a
# standard-gauge wheel (tread width 135 mm, flange 28 mm high): visual only.
FLANGE_HEIGHT = 0.028
FLANGE_ROOT = -0.035  # where the cone meets the flange
FLANGE_BACK = -0.060  # back face of the wheel (inside face, towards the track centre)
TREAD_OUTER = 0.075  # outer face of the wheel
HUB_FRACTION = 0.2  # hub (bore) radius as a fraction of r0
SECTIONS = 48
# A profile's points (an S1002's 1001) are thinned to those the outline needs to stay within
# this of every point (Douglas-Peucker): 48 sections of a thousand points would be a mesh of
# 96,000 triangles per wheel, drawn in every recording, for detail far below a pixel.
PROFILE_TOLERANCE = 0.1e-3  # m


def wheel_profile(rolling_radius: float, conicity: float) -> np.ndarray:
    """Closed (radius, axial) profile of one wheel, counter-clockwise for outward normals.

    The tread is the cone r(u) = r0 - conicity * u, so a wheelset displaced by y rolls
    on radii r0 +/- conicity * y: the geometry behind the linear creep law.
    """
    r0, lam = rolling_radius, conicity
    root = r0 - lam * FLANGE_ROOT
    hub = HUB_FRACTION * r0
    points = [
        (hub, FLANGE_BACK),
        (root + FLANGE_HEIGHT - 0.006, FLANGE_BACK),
        (root + FLANGE_HEIGHT, FLANGE_BACK + 0.006),
        (root + FLANGE_HEIGHT, FLANGE_ROOT - 0.012),
        (root, FLANGE_ROOT),
        (r0 - lam * TREAD_OUTER, TREAD_OUTER),
        (hub, TREAD_OUTER),
    ]
    points.append(points[0])
    return np.asarray(points, dtype=float)


def profile_outline(y: np.ndarray, z: np.ndarray, rolling_radius: float, offset: float = 0.0) -> np.ndarray:
    """Closed (radius, axial) outline of a wheel with the profile (y, z) (rail_mj.contact.profiles'
    convention: y from the taping line towards the field side, z = -(r - r0)), its taping line
    `offset` outward of the axial origin, counter-clockwise as `wheel_profile`'s: from the hub at the
    flange back, along the profile to the outer face, back to the hub."""
    y, z = np.asarray(y, dtype=float), np.asarray(z, dtype=float)
    keep = _thinned(y, z, PROFILE_TOLERANCE)
    hub = HUB_FRACTION * rolling_radius
    # The surface stays well outside the hub (only a profile far from any wheel's could reach it).
    radius = np.maximum(rolling_radius - z[keep], 1.5 * hub)
    axial = y[keep] + offset
    points = [(hub, axial[0]), *zip(radius, axial), (hub, axial[-1]), (hub, axial[0])]
    return np.asarray(points, dtype=float)


def _thinned(y: np.ndarray, z: np.ndarray, tolerance: float) -> np.ndarray:
    """Indices of the points of the polyline (y, z) that keep it within `tolerance` of all of them
    (Ramer-Douglas-Peucker), the ends always."""
    keep = np.zeros(len(y), dtype=bool)
    keep[[0, -1]] = True
    spans = [(0, len(y) - 1)]
    while spans:
        a, b = spans.pop()
        if b - a < 2:
            continue
        dy, dz = y[b] - y[a], z[b] - z[a]
        inner = slice(a + 1, b)
        distance = np.abs(dy * (z[inner] - z[a]) - dz * (y[inner] - y[a])) / math.hypot(dy, dz)
        k = int(np.argmax(distance))
        if distance[k] > tolerance:
            keep[a + 1 + k] = True
            spans += [(a, a + 1 + k), (a + 1 + k, b)]
    return np.flatnonzero(keep)


def revolved_mesh(outline: np.ndarray) -> trimesh.Trimesh:
    """A closed (radius, axial) outline revolved about the axle: a closed mesh, axle along +z."""
    import trimesh  # 0.5 s to import: only where a mesh is made, not for one kept (`_stl`)

    mesh = trimesh.creation.revolve(outline, sections=SECTIONS)
    if not mesh.is_watertight or mesh.volume <= 0:
        raise RuntimeError("wheel profile did not revolve into a closed, outward-facing mesh")
    return mesh


def wheel_mesh(rolling_radius: float, conicity: float) -> trimesh.Trimesh:
    """The wheel as a closed mesh, axle along +z (outward), contact point at z = 0."""
    return revolved_mesh(wheel_profile(rolling_radius, conicity))


def wheel_stl(rolling_radius: float, conicity: float) -> bytes:
    """Binary STL of the coned wheel, byte-for-byte the same for the same inputs."""
    return outline_stl(wheel_profile(rolling_radius, conicity))


def outline_stl(outline: np.ndarray) -> bytes:
    """Binary STL of a wheel revolved from `outline` (made once for each: a sweep builds the
    same wheel for every case)."""
    return _stl(np.ascontiguousarray(outline, dtype=float).tobytes())


@functools.lru_cache(maxsize=64)
def _stl(points: bytes) -> bytes:
    """Kept on disk too (rail_mj.files.cache_folder, named by the sources): every command builds
    its vehicle's model, and trimesh alone takes half a second to import."""
    import hashlib

    key = hashlib.sha256(points).hexdigest()[:32]
    kept = cached_arrays("meshes", key)
    if kept is not None and "stl" in kept:
        return kept["stl"].tobytes()
    import trimesh

    # The exporter `Trimesh.export(file_type="stl")` calls, whose type says it gives bytes.
    stl = trimesh.exchange.stl.export_stl(revolved_mesh(np.frombuffer(points).reshape(-1, 2)))
    keep_arrays("meshes", key, {"stl": np.frombuffer(stl, dtype=np.uint8)})
    return stl
