"""Many cases: parameter sweeps and stability maps, on local threads or a Dask cluster.

span.py        one range type for every A:B:N[:log] (`Span`), with the rules of each option
sweep.py       cases over layout keys and speeds, their rows, resumable journals
"""

from rail_mj import _lazy

_EXPORTS = {"sweep": "sweep", "SweepError": "sweep", "Span": "span", "SpanError": "span"}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
