"""The `rail-mj` command: a thin layer over the Python API (`rail_mj.cli:main`).

options.py     failures and exit statuses, loading a layout, the checks every command shares
run.py         generate, run (along a track too)
curving.py     curving: the steady state on constant curves
stability.py   eigen, critical-speed, root-locus, bifurcation
studies.py     sweep, map
contact.py     contact, creep, profile, conicity, contact-geometry
track.py       track: a track file's irregularities written and drawn
response.py    response: transfer functions to track irregularities, rms under a spectrum
main.py        the command group, registering the commands; `main`
"""

from rail_mj import _lazy
from rail_mj.cli.main import cli, main

__all__ = ["cli", "main"]
# What rail_mj.cli.main held before the commands moved to a module a job.
_EXPORTS = {
    **dict.fromkeys(("Failure", "EXIT_BAD_INPUT", "EXIT_RUN_FAILED"), "options"),
    **dict.fromkeys(("generate_cmd", "run_cmd"), "run"),
    **dict.fromkeys(("eigen_cmd", "critical_speed_cmd", "root_locus_cmd", "bifurcation_cmd"), "stability"),
    **dict.fromkeys(("sweep_cmd", "map_cmd"), "studies"),
    **dict.fromkeys(("contact_cmd", "creep_cmd", "profile_cmd", "conicity_cmd", "contact_geometry_cmd"), "contact"),
}
__getattr__, _dir = _lazy.exports(__name__, _EXPORTS, fallback="main")


def __dir__() -> list[str]:
    return list(__all__)
