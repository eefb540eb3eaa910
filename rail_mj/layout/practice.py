"""The table of practice, kept importable here: it lives in `rail_mj.practice` (a leaf, so that
the track below the layout can check against it too). Every name of it is forwarded.

Example:

    >>> from rail_mj.layout.practice import RANGES
    >>> from rail_mj import practice
    >>> RANGES is practice.RANGES
    True
"""

from rail_mj.practice import *  # noqa: F403
from rail_mj.practice import __all__ as __all__
