"""What the user wrote: a layout file (TOML) read and checked into a `Layout`.

    reader.py      TOML -> `Layout`, one reader per table; every bad input one `LayoutError` line;
                   what the user wrote (`Layout.given`) and what was derived from it (`Layout.derived`)
    practice.py    the table of practice, kept importable here: it lives in rail_mj.practice, a leaf
    kinds.py       which vehicle a layout describes and on which contact, as types (Planar, TrainOfCars,
                   SpatialVehicle; Coned, Hertzian, Profiled)

Example:

    >>> from rail_mj.layout import load_layout
    >>> load_layout("models/bogie/bogie.toml").n_wheelsets
    2
"""

from rail_mj import _lazy
from rail_mj.layout.reader import Layout, LayoutError, layout_from_dict, load_layout

__all__ = ["Layout", "LayoutError", "layout_from_dict", "load_layout"]
__getattr__, _dir = _lazy.exports(__name__, {}, fallback="reader")


def __dir__() -> list[str]:
    return [*__all__, "kinds", "practice", "reader"]
