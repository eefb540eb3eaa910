"""Every number of the model rounded as MuJoCo's MJCF writer prints it: 6 significant figures.

Each builder of rail_mj.vehicle passes its physical numbers through `_g6`, so that the model the
runner steps and the one its written MJCF compiles to are the same (rail_mj.vehicle.mjcf checks it).
"""

from __future__ import annotations


def _g6(*values: float) -> list[float]:
    """Numbers as MuJoCo's MJCF writer prints them, to 6 significant figures: every
    physical number goes into the model through this, so that the written MJCF compiles
    to exactly the model the runner simulates."""
    return [float(f"{v:.6g}") for v in values]


def _pos(x: float, z: float) -> list[float]:
    return _g6(x, 0.0, z)
