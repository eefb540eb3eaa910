"""Wheel-rail contact, from the bodies in contact to the creep forces: no MuJoCo, no layout.

    pair.py        [profiles]: the pair of profiles a layout names and how the track places them
    profiles.py    wheel and rail profiles: S1002 and 60E1 generated, measured ones read (CSV, SIMPACK)
    geometry.py    the rigid wheelset's contact geometry on two rails, Delta r, where a flange touches
    conicity.py    equivalent conicity (EN 15302) from a rolling-radius-difference function
    hertz.py       Hertz's contact ellipse and Kalker's creep coefficients from materials and radii
    tables.py      a profiled wheelset's contact tables for the compiled law; linearised at an amplitude
    laws.py        the creep laws by name and number
    parameters.py  what the law takes of each wheelset and what it gives: plain data
    creep.py       the contact law: Kalker's creep, saturation, FASTSIM, flanges, wheel loads
    law.py         the same law as numba compiles it (creep.py gives its names; a library holds it)
    derived.py     what a layout leaves to its contact: the profiles' conicity and flange shift, f11..f33, wheel load

The names of rail-mj 0.1's `rail_mj.contact` (Hertz and Kalker) are still found here.
"""

from rail_mj import _lazy

_EXPORTS = {
    "ContactError": "hertz",
    "ContactPatch": "hertz",
    "contact_patch": "hertz",
    "ellipse_patch": "hertz",
    "hertz_ellipse": "hertz",
    "kalker_coefficients": "hertz",
    "equivalent_conicity": "conicity",
    "ContactParameters": "creep",
    "ContactForces": "creep",
    "contact_forces": "creep",
    "wheelset_forces": "creep",
    "LAWS": "laws",
}
__getattr__, __dir__ = _lazy.exports(__name__, _EXPORTS, fallback="hertz")
