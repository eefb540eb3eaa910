"""rail-mj: railway bogies on rails in MuJoCo.

Data flows through one module each:

    layout.py   layout file (TOML) -> checked `Layout`
    model.py    `Layout` -> MuJoCo model (MjSpec), generated MJCF (`Vehicle`, `generate`)
    creep.py    wheel-rail contact and creep law (compiled with numba), over wheelsets
    forces.py   the creep law bound to MuJoCo's passive-force callback
    runner.py   timestep choice and the headless run (`simulate` -> `Run`)
    analysis.py what a run shows: amplitude, growth rate, wavelength, frequency
    recording.py  Rerun recording of a run
    cli.py      the `rail-mj` command, a thin layer over the above
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
