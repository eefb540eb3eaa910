"""Stepping MuJoCo with the creep forces: callbacks, timestep, single runs and batches.

callback.py    the contact law as a Python passive-force callback: the readable reference
native.py      the same law as a native (C) callback: no Python in a step, thread-safe
kernel.py      that callback's code, as numba compiles it into the installation's library
curve.py       what a curved, canted track adds in the native callback, each body at its own station
linear.py      the model linearised about its reference state (timestep, eigenvalues)
timestep.py    the timestep: RK4's limit for the fastest linear mode
run.py         `Request` (a run to make) and `Run` (its samples, their kinematics and contact forces)
stepping.py    MuJoCo stepped in chunks: a model holding one run or a pack of several, the checks
unbiased.py    MuJoCo's RK4 step to the same bits without its bias-force pass, for a flat twin's pack
runner.py      `simulate`: one run, checked and prepared (`prepare`)
batch.py       `simulate_many`: many runs, packed several to a model, on several threads
"""

from rail_mj import _lazy

_EXPORTS = {
    "Run": "run",
    "Request": "run",
    "SimulationError": "run",
    "Derailed": "run",
    "simulate": "runner",
    "simulate_many": "batch",
}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
