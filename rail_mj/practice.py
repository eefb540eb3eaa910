"""What is impossible and what is merely unusual: the ranges rail-mj checks inputs against.

A value outside `refuse` cannot describe a rail vehicle on rails (or breaks the model's
assumptions) and is an error; a value inside `refuse` but outside `usual` is legal and
far from railway practice, and gets a one-line warning. Each range says where it comes
from; docs/practice.md explains them. One table serves the layout checks
(`rail_mj.layout`), the track checks (`rail_mj.track`: radii, cant, steps between sections)
and the command line (speeds, initial disturbances, one contact ellipse's semi-axes,
creepages and Poisson's ratio, the bifurcation step). It is a leaf
of the package (it imports nothing of rail-mj), so every folder may check against it;
`rail_mj.layout.practice` forwards it for code written against 0.2's path.

Example:

    >>> RANGES["wheelset.rolling_radius"].check(0.001)
    'must be between 0.01 and 1.5 m (wheels of 20 mm to 3 m diameter), got 0.001; check the units (m)'
    >>> RANGES["wheelset.rolling_radius"].check(0.2) is None
    True
"""

from __future__ import annotations

import dataclasses
import math

__all__ = ["CANT_STEP", "CURVATURE_STEP", "DERAILMENT_LATERAL", "FLANGE_HEIGHT", "RANGES", "Range", "max_initial_yaw"]

# A wheel further off-centre than the width of a UIC60 (60E1) rail head, 72 mm
# (EN 13674-1), has left the rail: the runner calls that a derailment.
DERAILMENT_LATERAL = 0.072  # m

# The disturbance a run starts from unless told otherwise (`rail-mj run`, `simulate`, sweeps):
# the whole vehicle shifted 2 mm, about a quarter of a usual flangeway clearance: small enough
# for the linear behaviour, large enough to read the motion far above round-off.
INITIAL_LATERAL = 0.002  # m

# The factors a recording's 3D view may draw lateral motion and yaw at: from true size to where
# a 13 mm hunting motion is drawn 13 m wide and the bodies leave the scene.
EXAGGERATION_LIMITS = (1.0, 1000.0)
# How far an S1002 flange stands above the tread at the taping line (EN 13715): the
# flange's front edge is sqrt((r0 + h)^2 - r0^2) ahead of the axle at rail-top level.
FLANGE_HEIGHT = 0.028  # m


@dataclasses.dataclass(frozen=True)
class Range:
    """`refuse`: the closed interval a value must lie in; `usual`: railway practice."""

    refuse: tuple[float, float]
    usual: tuple[float, float]
    unit: str
    why: str  # where the refusal bounds come from
    practice: str  # where the usual range comes from

    def check(self, value: float) -> str | None:
        """The error for a value outside `refuse` (None when it is inside)."""
        lo, hi = self.refuse
        if lo <= value <= hi:
            return None
        units = f"; check the units ({self.unit})" if self.unit else ""
        bounds = f"at least {lo:g}" if hi == math.inf else f"between {lo:g} and {hi:g}"
        return f"must be {bounds} {self.unit} ({self.why}), got {value:g}{units}"

    def warning(self, value: float) -> str | None:
        """The warning for a legal value outside railway practice (None inside it)."""
        lo, hi = self.usual
        if lo <= value <= hi:
            return None
        usual = (
            f"{lo:g} {self.unit} or more"
            if hi == math.inf
            else f"{lo:g} to {hi:g} {self.unit}"
            if lo < 0
            else f"{lo:g}-{hi:g} {self.unit}"
        )
        return f"{value:g} {self.unit} is outside railway practice, {usual} ({self.practice})"


RANGES = {
    # The wheel-on-rail speed record is 159.7 m/s (574.8 km/h, TGV V150, 2007); twice it
    # is far beyond any wheel-rail contact the creep laws were measured for.
    "speed": Range(
        (0.0, 320.0), (0.0, 160.0), "m/s", "twice the wheel-on-rail record of 160 m/s", "up to the 160 m/s speed record"
    ),
    # 20 mm wheels are smaller than any roller-rig scale model; 3 m wheels larger than
    # any built (the largest steam drivers were 2.3 m). Practice: 330 mm (piggyback
    # wagons) to 1250 mm (locomotives) in diameter.
    "wheelset.rolling_radius": Range(
        (0.01, 1.5), (0.16, 0.65), "m", "wheels of 20 mm to 3 m diameter", "wheels of 330-1300 mm diameter"
    ),
    # Half the distance between the contact points, about half the gauge plus a few cm:
    # 2b from 0.1 m (scale rigs) to 4 m. Practice: 600 mm to 1676 mm gauges.
    "wheelset.contact_half_spacing": Range(
        (0.05, 2.0), (0.28, 0.9), "m", "contact points 0.1 m to 4 m apart", "gauges of 600-1676 mm"
    ),
    # Practice: light-rail wheelsets of a few hundred kg to locomotive wheelsets with
    # gears and brake discs.
    "wheelset.mass": Range((0.0, math.inf), (300.0, 4000.0), "kg", "a mass", "light-rail to locomotive wheelsets"),
    # The flange must meet the rail before the wheel leaves it. Practice: new S1002
    # wheels on nominal standard gauge have (1435 - 1360 - 2*32.5)/2 = 5 mm a side,
    # worn flanges on widened gauge up to about 25 mm.
    "wheelset.flangeway_clearance": Range(
        (0.0, DERAILMENT_LATERAL),
        (0.001, 0.025),
        "m",
        f"the wheel leaves a rail head {DERAILMENT_LATERAL * 1e3:g} mm wide",
        "new to worn flanges on standard gauge",
    ),
    # Practice: 2 t to 40 t (heavy-haul) axle loads.
    "wheelset.wheel_load": Range((0.0, math.inf), (10e3, 200e3), "N", "a load", "axle loads of 2-40 t"),
    # Equivalent conicities of new and worn wheels on real track (EN 15302 practice:
    # 0.02 to about 0.4; above 0.5 the small-angle contact model does not hold).
    "wheelset.conicity": Range(
        (0.0, 0.5), (0.01, 0.4), "", "the small-angle contact model", "new and worn wheel-rail pairs"
    ),
    # Dry rail 0.3-0.5, wet 0.1-0.2, leaves and grease down to 0.05; sand raises it.
    "creep.friction": Range((0.0, 2.0), (0.05, 0.6), "", "a friction coefficient", "contaminated to sanded rail"),
    # The frame and what it carries: a light-rail frame of half a tonne to a Co-Co
    # locomotive's three-axle bogie with its traction motors, 25-30 t.
    "bogie.mass": Range(
        (0.0, math.inf), (500.0, 30000.0), "kg", "a mass", "light-rail frames to locomotive bogies with their motors"
    ),
    "carbody.mass": Range((0.0, math.inf), (1000.0, 150000.0), "kg", "a mass", "tram modules to locomotive bodies"),
    # A spatial vehicle's springs, their mean static deflection under the weight (its hard bound,
    # the spring's height above the rail, is checked in rail_mj.layout). Practice: stiff
    # freight primaries of a few mm to soft coil or air secondaries of about 250 mm.
    "spatial.static_deflection": Range(
        (0.0, math.inf), (0.002, 0.3), "m", "a deflection", "freight primaries to soft secondary suspensions"
    ),
    # One contact ellipse (`rail-mj creep`). Its semi-axes: a micrometre and a metre are far
    # beyond any rolling contact either way; wheel-rail ellipses run from about 0.5 mm (a
    # flange) to 30 mm (a worn tread).
    "contact.semi_axis": Range(
        (1e-6, 1.0), (0.5e-3, 30e-3), "m", "far beyond any rolling contact either way", "wheel-rail contacts"
    ),
    # Beyond a creepage of 1 the surfaces slide faster than they roll; not warned about
    # within it (saturated creep up to full slip is what the laws are for).
    "contact.creepage": Range(
        (-1.0, 1.0), (-1.0, 1.0), "", "beyond, the surfaces slide faster than they roll", "any creepage"
    ),
    # Spin of a radian per millimetre rolled; not warned about within it.
    "contact.spin": Range((-1000.0, 1000.0), (-1000.0, 1000.0), "rad/m", "a radian per millimetre rolled", "any spin"),
    # [contact]'s Young's modulus, wheel and rail alike. Steels are 200-215 GPa, cast iron and
    # cast steel wheels down to about 170 GPa. Below 1 GPa (a soft polymer) a 60 kN wheel's
    # Hertz ellipse grows past 35 mm, off the railhead; above 1000 GPa is stiffer than any
    # metal (tungsten carbide is about 700 GPa).
    "contact.young_modulus": Range(
        (1e9, 1e12),
        (150e9, 230e9),
        "Pa",
        "a polymer's to stiffer than any metal; beyond, the Hertz ellipse leaves the railhead",
        "cast iron to steel",
    ),
    # The transverse radii of the rail head's crown and of the wheel's tread (rail_mj.contact.
    # hertz). Rail heads are crowned at 80-600 mm (60E1's 300 mm, its corners 80 mm); a coned
    # tread's radius is infinite, a worn one's a few hundred mm. Below a millimetre the contact
    # is a knife edge, above 1000 km flat to any precision Hertz needs.
    "contact.rail_transverse_radius": Range(
        (1e-3, 1e6), (0.08, 1.0), "m", "a knife edge to flat", "rail heads crowned at 80-600 mm"
    ),
    "contact.wheel_transverse_radius": Range(
        (1e-3, 1e6), (0.1, 1e6), "m", "a knife edge to flat", "worn treads of 100 mm and more, new ones flat"
    ),
    # Kalker's coefficients are tabulated at nu = 0, 0.25 and 0.5 (an incompressible solid, the
    # largest an isotropic elastic solid has) and interpolated between: outside, extrapolated.
    # Steels are about 0.28-0.30; not warned about within the table.
    "contact.poisson_ratio": Range(
        (0.0, 0.5), (0.0, 0.5), "", "Kalker's table, from 0 to an incompressible 0.5", "Kalker's table"
    ),
    # The nonlinear critical speed's speed step, a fraction of the speed (rail_mj.analysis.
    # bifurcation.STEP, 0.02, is the one rail-mj reports with): below 0.001 a descent from
    # 150 to 5 m/s takes ln(30)/0.001 = 3400 dwells of 6 s simulated; above 0.2 the critical
    # speed is known only to within a fifth. Not warned about within it.
    "bifurcation.step": Range(
        (0.001, 0.2), (0.001, 0.2), "", "3400 dwells from 150 to 5 m/s to within a fifth", "any step"
    ),
    # The ramp's deceleration through the nonlinear critical speed (critical-speed --method ramp):
    # below 1e-3 m/s^2 a ramp from 150 to 5 m/s is 1.5e5 s simulated; above 5 m/s^2 it exceeds
    # what adhesion allows a braked train (mu*g = 2.9 m/s^2 at mu 0.3). Usual: the limit cycle's
    # collapse lags the fold by a few seconds, so above 0.5 m/s^2 the ramp's critical speed lies
    # more than 1 % below the slow limit (docs/track.md, measured on the shipped vehicles).
    "ramp.deceleration": Range(
        (0.001, 5.0),
        (0.001, 0.5),
        "m/s^2",
        "1.5e5 s simulated from 150 to 5 m/s; beyond a braked train's adhesion",
        "the ramp lags the fold by more than 1 % above 0.5 m/s^2",
    ),
    # The track (rail_mj.track). A curve's radius, its size (the sign says which way it turns).
    # EN 13803 sets 150 m as the least radius of any track that different vehicles use, station,
    # depot and siding tracks included; tighter curves are those of trams, metros and industrial
    # sidings. Below 10 m no vehicle runs (trams go down to about 15 m), and a 2.5 m wheelbase
    # would turn through a quarter of a radian: beyond the small angles between a body and the
    # track that the track-following frame and the contact geometry assume.
    "track.radius": Range(
        (10.0, math.inf),
        (150.0, math.inf),
        "m",
        "tighter than trams run; a 2.5 m wheelbase would turn through 0.25 rad",
        "EN 13803's least radius on tracks that different vehicles use",
    ),
    # Cant, the outer rail over the inner over 1.5 m (negative: the inner rail higher). EN 13803
    # allows at most 180 mm on ballasted track (160 mm recommended): a train stopped in the curve
    # must not lean too far onto its inner wheels. Negative cant is found only on a turnout
    # curving off a canted curve. The most steeply canted lines, Japan's high-speed lines, have
    # 200 mm: beyond it, either way, no standard-gauge track is laid.
    "track.cant": Range(
        (-0.2, 0.2),
        (0.0, 0.18),
        "m",
        "200 mm, the most any standard-gauge track is canted",
        "EN 13803's 180 mm on ballasted track; negative only on turnouts off canted curves",
    ),
    # Cant deficiency (outward, +) or excess (-), mm: 1.5 m * (V^2/(g R)) - cant, at a run's speed.
    # Nothing refuses it (a run may study any speed), but EN 13803 limits it for vehicles without
    # tilt to 150 mm (130 mm recommended on new lines) and the cant excess, a slow train leaning on
    # its inner rail, to 110 mm; tilting trains run up to about 300 mm.
    "track.cant_deficiency": Range(
        (-math.inf, math.inf),
        (-110.0, 150.0),
        "mm",
        "",
        "EN 13803 for vehicles without tilt: 150 mm deficiency, 110 mm excess",
    ),
}

# A change of curvature or cant from one section of a track to the next with no transition
# between is warned about (rail_mj.track): the vehicle is kicked sideways, and EN 13803 runs
# curvature and cant up along transitions except where a layout leaves no room (switches).
# Smaller changes are taken as rounding. A curvature step of 1e-6 1/m (a 1000 km radius) steps
# the lateral acceleration by V^2 * 1e-6, 0.01 m/s^2 at 100 m/s: nothing a vehicle feels. A
# cant step of 1 mm is below the few millimetres to which cross level is laid and measured.
CURVATURE_STEP = 1e-6  # 1/m
CANT_STEP = 1e-3  # m


def max_initial_yaw(rolling_radius: float, clearance: float) -> float:
    """The largest yaw (rad) a wheelset can have in the gauge before its flange fronts
    reach the rails: clearance / (the flange front's lead ahead of the axle)."""
    lead = math.sqrt((rolling_radius + FLANGE_HEIGHT) ** 2 - rolling_radius**2)
    return clearance / lead
