"""Many cases: parameter sweeps and stability maps, on local threads or a Dask cluster.

sweep.py       cases over layout keys and speeds, their rows, resumable journals
"""

from rail_mj import _lazy

_EXPORTS = {"sweep": "sweep", "SweepError": "sweep"}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
