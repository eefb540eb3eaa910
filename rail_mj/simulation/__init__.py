"""Stepping MuJoCo with the creep forces: callbacks, timestep, single runs and batches.

callback.py    the contact law as a Python passive-force callback: the readable reference
native.py      the same law as a native (C) callback: no Python in a step, thread-safe
linear.py      the model linearised about its reference state (timestep, eigenvalues)
runner.py      timestep choice, `simulate` -> `Run`, `simulate_many`: several runs in one model
"""

from rail_mj import _lazy

_EXPORTS = {
    "Run": "runner",
    "Request": "runner",
    "SimulationError": "runner",
    "Derailed": "runner",
    "simulate": "runner",
    "simulate_many": "runner",
}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
