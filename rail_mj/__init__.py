"""rail-mj: railway vehicles on rails in MuJoCo.

Data flows through one module each (README.md, "How the code is laid out"):

    layout.py, practice.py  layout file (TOML) -> checked `Layout`; what is refused or warned
    model.py, wheel.py      `Layout` -> MuJoCo model (MjSpec), generated MJCF (`Vehicle`, `generate`)
    contact.py, creep.py    Hertz and Kalker; the wheel-rail contact law (compiled with numba)
    forces.py, native.py    that law as MuJoCo's passive-force callback, in Python and native
    runner.py               timestep choice and headless runs (`simulate` -> `Run`, `simulate_many`)
    analysis.py             what a run shows: amplitude, growth, frequency, EN 14363
    recording.py            Rerun recording of a run
    linear.py, stability.py, bifurcation.py   eigenvalues, modes, critical speeds, limit cycles
    sweep.py, plots.py      parameter studies and stability maps; figures
    files.py, cli.py        safe outputs; the `rail-mj` command
"""

import importlib

# Where each public name lives. Imported on first use (PEP 562), so that `rail-mj --help`
# and a layout error do not wait for MuJoCo, numba and scipy to load.
_EXPORTS = {
    "Layout": "layout", "LayoutError": "layout", "layout_from_dict": "layout", "load_layout": "layout",
    "Vehicle": "model", "generate": "model",
    "Run": "runner", "SimulationError": "runner", "simulate": "runner",
}


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"rail_mj.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'rail_mj' has no attribute {name!r}")


__all__ = [
    "Layout",
    "LayoutError",
    "Run",
    "SimulationError",
    "Vehicle",
    "generate",
    "layout_from_dict",
    "load_layout",
    "simulate",
]
