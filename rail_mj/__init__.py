"""rail-mj: railway vehicles on rails in MuJoCo.

Data flows through one folder each, in this order (README.md, "How the code is laid out");
a folder imports only from those before it (tests/test_architecture.py, import-linter in CI):

    units, numerics, files   shared units, the model<->callback file format, safe output files
    practice      the table of practice: what the checks refuse and what they warn about
    contact/      wheel-rail contact: profiles, geometry, conicity, Hertz and Kalker, creep laws
    track/        the track: a track file (TOML sections, CSV) -> checked `Track`; curvature and cant along it
    layout/       a layout file (TOML) -> checked `Layout`
    vehicle/      `Layout` -> MuJoCo model (MjSpec) and its MJCF files (`Vehicle`, `generate`)
    simulation/   the creep forces as MuJoCo callbacks; timestep, runs and batches (`simulate`)
    analysis/     what runs and linearisations show: motion, EN 14363, modes, stability, limit cycles
    output/       recordings (Rerun), run tables and figures
    studies/      sweeps and maps over many cases
    cli/          the `rail-mj` command

Example:

    >>> import rail_mj
    >>> layout = rail_mj.load_layout("models/wheelset/wheelset.toml")
    >>> layout.n_wheelsets
    1
"""

from __future__ import annotations

import os

from rail_mj import _compat, _lazy, files

__version__ = "0.2.0"


def _numba_cache_dir() -> None:
    """Numba's on-disk cache, in a folder named by a hash of the package's sources.

    Numba checks only the modification time of the file that defines a cached function,
    yet the compiled law inlines constants and functions from other modules (the contact
    tables' layout in rail_mj.numerics, the laws' numbers, the law itself inside the native
    callback): after an edit elsewhere a stale cache would give wrong forces without a
    word. A folder per version of the sources, every file of every subpackage included,
    cannot be stale (rail_mj.files.cache_folder). NUMBA_CACHE_DIR set by the user is respected.
    """
    if "NUMBA_CACHE_DIR" in os.environ:
        return
    os.environ["NUMBA_CACHE_DIR"] = str(files.cache_folder("numba"))


_numba_cache_dir()
_compat.install()

# Where each public name lives, imported on first use.
_EXPORTS = {
    # contact
    "equivalent_conicity": "contact.conicity",
    "contact_patch": "contact.hertz",
    "contact_forces": "contact.creep",
    "wheelset_forces": "contact.creep",
    "ContactParameters": "contact.creep",
    "ContactForces": "contact.creep",
    # track
    "Track": "track",
    "TrackError": "track",
    "track_from_dict": "track",
    "load_track": "track",
    # layout
    "Layout": "layout",
    "LayoutError": "layout",
    "layout_from_dict": "layout",
    "load_layout": "layout",
    # vehicle
    "Vehicle": "vehicle.spec",
    "generate": "vehicle.mjcf",
    # simulation
    "Run": "simulation.run",
    "SimulationError": "simulation.run",
    "simulate": "simulation.runner",
    "simulate_many": "simulation.batch",
    "Request": "simulation.run",
    # analysis
    "summary": "analysis.motion",
    "Stability": "analysis.stability",
    "CriticalSpeed": "analysis.stability",
    "time_critical_speed": "analysis.stability",
    "nonlinear_critical_speed": "analysis.bifurcation",
    "bifurcation": "analysis.bifurcation",
    # output
    "write_recording": "output.recording",
    # studies
    "sweep": "studies.sweep",
}
__getattr__, _dir = _lazy.exports("rail_mj", _EXPORTS)
__all__ = list(_EXPORTS)


def __dir__() -> list[str]:
    return [*_dir(), "__version__"]
