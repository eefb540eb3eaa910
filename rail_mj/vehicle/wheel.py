"""Wheel geometry: a coned tread with a flange, revolved into a mesh by trimesh.

The mesh is for looking at. MuJoCo collides meshes through their convex hulls,
which would fill the flange throat, so wheel-rail contact is computed in
`rail_mj.contact.creep` from the same numbers (r0, conicity), never from this mesh.
"""

from __future__ import annotations

import functools

import numpy as np
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


def wheel_mesh(rolling_radius: float, conicity: float) -> trimesh.Trimesh:
    """The wheel as a closed mesh, axle along +z (outward), contact point at z = 0."""
    mesh = trimesh.creation.revolve(wheel_profile(rolling_radius, conicity), sections=SECTIONS)
    if not mesh.is_watertight or mesh.volume <= 0:
        raise RuntimeError("wheel profile did not revolve into a closed, outward-facing mesh")
    return mesh


@functools.lru_cache(maxsize=64)
def wheel_stl(rolling_radius: float, conicity: float) -> bytes:
    """Binary STL of the wheel, byte-for-byte the same for the same inputs (made once for
    them: a sweep builds the same wheel for every case)."""
    # The exporter `Trimesh.export(file_type="stl")` calls, whose type says it gives bytes.
    return trimesh.exchange.stl.export_stl(wheel_mesh(rolling_radius, conicity))
