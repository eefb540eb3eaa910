"""What runs and linearisations show.

    motion.py          amplitude, growth, frequency, flange strikes; the summary of a run
    streaming.py       a run summarised as it is stepped: a sweep's row without the run's record
    en14363.py         EN 14363: the running-instability criterion on Sigma Y, Y/Q, wheel safety,
                       the on-track statistics per section
    ride.py            ride comfort: floor accelerations, EN 12299's weightings, N_MV, Sperling's Wz
    response.py        the frequency response to track irregularities, and the rms under a spectrum
    curving.py         a run through curves: per curve, angle of attack, guiding force, Y/Q, cant deficiency
    stability.py       eigenvalues, named modes, critical speeds (eigen and time)
    train_modes.py     the names of a train's modes
    spatial_modes.py   the names of a spatial vehicle's modes
    bifurcation.py     limit cycles: the nonlinear critical speed and the bifurcation diagram
    filters.py         Butterworth band-pass (zero phase) and periodogram, compiled, held to scipy.signal's

The names of rail-mj 0.1's `rail_mj.analysis` (`summary`, ...) are still found here.
"""

from rail_mj import _lazy

_EXPORTS = {
    "summary": "motion",
    "derailment_quotients": "en14363",
    "wheel_safety": "en14363",
    "hunting": "en14363",
    "hunting_assessable": "en14363",
    "hunting_rms": "en14363",
    "hunting_limit": "en14363",
    "band_pass": "en14363",
    "dominant_frequency": "en14363",
    "sliding_rms": "en14363",
    "sliding_mean": "en14363",
    "Y_OVER_Q_LIMIT": "en14363",
    "Y_OVER_Q_WINDOW": "en14363",
    "HUNTING_WINDOW": "en14363",
    "HUNTING_BAND": "en14363",
    "FILTER_ORDER": "en14363",
    "WHEELS": "en14363",
    "Stability": "stability",
    "CriticalSpeed": "stability",
    "time_critical_speed": "stability",
    "nonlinear_critical_speed": "bifurcation",
    "bifurcation": "bifurcation",
    "curves": "curving",
    "Response": "response",
}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS, fallback="motion")
