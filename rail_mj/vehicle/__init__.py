"""A checked `Layout` built into a MuJoCo model with the MjSpec API, and its MJCF files.

rounding.py    every number rounded as the MJCF keeps it
joints.py      a moving body's inertia and joints; the joints' names every layer reads
looks.py       geoms, sizes and colours, the wheel mesh asset: nothing of the dynamics
wheel.py       the wheel's mesh, for viewing
planar.py      the nested planar vehicle: car body, bogie frames, wheelsets
train.py       a planar train built flat: suspensions and couplings as fixed tendons
spatial.py     a spatial vehicle built flat: springs, dampers, anti-roll bars, bump stops as tendons
statics.py     a spatial vehicle under gravity: the springs' preload, gravitational stiffness
sensors.py     what a run records (`add_sensors`), and where its readings sit (`Sensors`)
spec.py        `Layout` -> MjSpec -> compiled model with its native block (`Vehicle`)
mjcf.py        the MJCF files: model, scene, assets (`generate`)
loads.py       a spatial vehicle's axle loads from its axlebox tendons
block.py       the one writer of the native block the compiled callback reads (rail_mj.numerics)
curve.py       a vehicle on a curved track: its odometer and the block's track part
poses.py       each body's pose on the track and the tendons' shifts, compiled: the callback's and the records'
rails.py       the rails under each wheelset of an irregular track: the block's irregularity part, its kernels
"""

from rail_mj import _lazy

_EXPORTS = {"Vehicle": "spec", "generate": "mjcf", "set_speed": "block"}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
