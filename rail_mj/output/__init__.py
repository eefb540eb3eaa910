"""Files a person opens: Rerun recordings, run tables and figures.

samples.py     a run's samples as a table: the CSV columns of `rail-mj run --out`
recording.py   the Rerun recording of a run
plots.py       root loci, bifurcation diagrams, stability maps, profiles (matplotlib)
"""

from rail_mj import _lazy

_EXPORTS = {"write_recording": "recording", "save_recording": "recording"}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS)
