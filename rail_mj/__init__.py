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

from rail_mj.layout import Layout, LayoutError, layout_from_dict, load_layout
from rail_mj.model import Vehicle, generate
from rail_mj.runner import Run, SimulationError, simulate

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
