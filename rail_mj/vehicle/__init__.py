"""A checked `Layout` built into a MuJoCo model with the MjSpec API, and its MJCF files.

model.py       bodies, joints, suspension tendons; `Vehicle`, `generate`
wheel.py       the wheel's mesh, for viewing
loads.py       a spatial vehicle's axle loads from its axlebox tendons
block.py       the one writer of the native block the compiled callback reads (rail_mj.numerics)
"""

from rail_mj import _lazy

_EXPORTS = {"Vehicle": "model", "generate": "model", "set_speed": "block"}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
