"""What runs and linearisations show.

    motion.py          amplitude, growth, frequency; EN 14363's running-instability and Y/Q quantities
    stability.py       eigenvalues, named modes, critical speeds (eigen and time)
    train_modes.py     the names of a train's modes
    spatial_modes.py   the names of a spatial vehicle's modes
    bifurcation.py     limit cycles: the nonlinear critical speed and the bifurcation diagram

The names of rail-mj 0.1's `rail_mj.analysis` (`summary`, ...) are still found here.
"""

from rail_mj import _lazy

_EXPORTS = {
    "summary": "motion",
    "Stability": "stability",
    "CriticalSpeed": "stability",
    "time_critical_speed": "stability",
    "nonlinear_critical_speed": "bifurcation",
    "bifurcation": "bifurcation",
}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS, fallback="motion")
