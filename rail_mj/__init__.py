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

import hashlib
import importlib
import os
from pathlib import Path


def _numba_cache_dir() -> None:
    """Numba's on-disk cache, in a folder named by a hash of the package's sources.

    Numba checks only the modification time of the file that defines a cached function,
    yet the compiled law inlines constants and functions from other modules (the contact
    tables' layout, the laws' numbers, the law itself inside the native callback): after
    an edit elsewhere a stale cache would give wrong forces without a word. A folder per
    version of the sources cannot be stale. NUMBA_CACHE_DIR set by the user is respected.
    """
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for source in sorted(here.glob("*.py")):
        digest.update(source.name.encode() + source.read_bytes())
    base = here / "__pycache__"
    if not os.access(here, os.W_OK):  # an installed, read-only package
        base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "rail-mj"
    os.environ["NUMBA_CACHE_DIR"] = str(base / f"numba-{digest.hexdigest()[:16]}")


_numba_cache_dir()

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
