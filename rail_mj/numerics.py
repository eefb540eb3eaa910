"""The file format between a generated model and the compiled creep callback.

A generated MJCF carries everything its creep forces need in MuJoCo custom numerics, so
that the file alone is enough to run the vehicle (docs/README.md). This module is the one
definition of that format: the numerics' names, the native block's layout and version,
the rows of the contact parameters and the columns of a profiled wheelset's contact table.
The one writer (rail_mj.vehicle) and the readers (the Python and native callbacks in
rail_mj.simulation, the compiled law in rail_mj.contact) take their offsets from here.

The numeric names ("rail_mj/native", "rail_mj/creep", ...) are identifiers in the shipped
MJCF files, not module paths: they stay as they are whatever the package's modules are
called. A change of the native block's layout raises MAGIC's version, so that an older
file is refused rather than misread.

Pure constants and numpy: the numba kernels read these as compile-time globals.
"""

from __future__ import annotations

import numpy as np

# --- the named numerics ------------------------------------------------------------------

# Names of the custom numerics that carry the contact data for the creep forces,
# so that a generated MJCF alone is enough to simulate the vehicle.
# The first numeric: everything the native creep callback needs, per vehicle (its speed,
# contact table, wheelset bodies and their joints), written by rail_mj.simulation.native.
NUMERIC_NATIVE = "rail_mj/native"
NUMERIC_WHEEL = "rail_mj/wheel"  # r0, b, conicity, flangeway clearance
NUMERIC_CREEP = "rail_mj/creep"  # f11, f22, f23, f33
NUMERIC_SATURATION = "rail_mj/saturation"  # creep law number (rail_mj.contact.creep.LAWS), mu*N per wheel,
# and Polach's falling friction: mu_infinity/mu0 and its rate, s/m
NUMERIC_GEOMETRY = "rail_mj/geometry"  # a profiled wheelset's contact table (rail_mj.contact.tables), row-major
NUMERIC_FLANGE = "rail_mj/flange"  # on (1) or off (0), stiffness, damping, tan(flange angle)
# The contact ellipse, for the fastsim law: semi-axes a (rolling) and b, m, wheel load N, shear
# modulus G, GPa (rail_mj.units.PA_PER_GPA), and Kalker's C11, C22, C23; zeros for a layout without [contact].
NUMERIC_ELLIPSE = "rail_mj/ellipse"

# Wheelset weight (N), nominal wheel load (N), axlebox half spacing and height (m), the wheelset's
# spin inertia I_y (kg m^2; 0: no gyroscopic terms), the cones' gravitational stiffness on (1) or off (0);
# then, when the bogies' axleboxes differ ([bogies.N.axlebox]), each wheelset's axlebox half spacing and
# height (2 per wheelset, wheelset 1 first), which take the place of the two above.
NUMERIC_LOADS = "rail_mj/loads"
# Present (one entry, 1): the preloads' shear couples are on (`ShearCouples`, `AxleLoads.shear`).
NUMERIC_COUPLES = "rail_mj/couples"


# --- the native block: the first numeric, "rail_mj/native" -------------------------------

# The block's first number, "this is rail-mj's native block, version 8": six significant
# figures, as MuJoCo's MJCF writer keeps them. Version 5 added the track part (below), version 6
# its speed profile, version 7 its irregularities, version 8 the springs.
MAGIC = 7043.08
# A chain's flag for a hinge of a chain whose hinges all turn its body about the world's z
# (rail_mj.vehicle.block.joint_chain): the callback reads the body's yaw as their angles' sum.
YAW_HINGE = 2.0
# Per vehicle: speed, wheelset count, law, flange (0/1), falling friction (0/1), the number
# of rows of its profile contact table (0: coned wheels), where its track part starts (from
# the vehicle's first entry), then the contact parameters (ContactParameters.table,
# row-major), the profile contact table (rail_mj.contact.tables, row-major), then per wheelset
# its body and the joints from it to the world: count, then (joint, dof, 1 for a hinge / 0 for
# a slide / YAW_HINGE for a hinge of a chain turning the body about z alone); then its weight
# (N), the nominal wheel load (N), its spin inertia (gyroscopic
# terms; 0: off), the cones' gravitational stiffness (0/1) and its axlebox tendons
# (rail_mj.vehicle.loads): count, then (tendon, on P, on M); count 0: the wheels carry the
# static load; then its shear couples: count, then (z tendon, y tendon). After the wheelsets,
# the frames' shear couples (rail_mj.vehicle.loads.ShearCouples): count, then (z, y, x tendon,
# roll dof, pitch dof); then the springs the callback adds itself where the stepped model has no
# tendons for them (rail_mj.vehicle.block.spring_rows): count, then per spring its stiffness,
# damping and number of terms, and (dof, coefficient) per term. Last, the track part (docs/track.md,
# rail_mj.vehicle.curve).
LOADS_HEADER = 5
COUPLE = 5
VEHICLE_HEADER = 7
SPEED = 0  # offset of the speed within a vehicle's entries
TRACK_AT = 6  # offset of the track part's offset within a vehicle's entries

# The track part: the odometer body (a slide along x whose position is the distance along the track
# of the vehicle's origin; -1: straight track, and the counts are 0), the gravity (m/s^2) that the
# cant turns into the track plane, the number of the track's breakpoints, of the bodies the curve
# loads, of the joints its geometry deflects and of the tendons it deflects, the odometer's dof and
# the number of points of the run's speed profile (0: the speed is the vehicle's constant one). Then
# per speed point SPEED_POINT entries, the odometer's station (m) and the speed there (m/s), linear
# between them (rail_mj.track.speed); per breakpoint (curvature and cant linear between them)
# BREAKPOINT entries: x (m), curvature (1/m), cant (m), heading (rad: the integral of the curvature
# from x = 0) and its integral (m); then the entries' index: where each body's, joint's and tendon's
# entry starts and where the last ends, from the part's first entry (so that the callback reads
# entries of different lengths without walking them one after another); then per body: body, x in
# the vehicle (m), height of its centre of mass above the rail (m; 0 in a planar model, whose bodies
# have no height), mass (kg), yaw inertia (kg m^2), then the joints from it to the world as a
# wheelset's; per joint: its dof, stiffness and damping, the number of terms, then (pose,
# coefficient) per term, where pose 3*b + k is body b's lateral offset (k = 0), heading (1) or cant
# roll (2) that the track gives it; per tendon: tendon, its length's terms as a joint's (an axlebox
# tendon's include its wheelset's cant roll, which no joint takes: rail_mj.vehicle.curve), then the
# dofs it acts on: count, then (dof, coefficient). The header's last entry is where the irregularity
# part starts, from the track part's first entry (0: a perfect track, no part).
TRACK_HEADER = 9
IRREGULAR_AT = 8  # offset of the irregularity part's offset within the track part
# The irregularity part (rail_mj.vehicle.rails): the number of spline intervals m, the first
# station x0 (m) and the interval (m), whether the vertical channels act (1: a spatial vehicle with
# gravity; 0: the lateral ones only), the number of wheelsets; then per interval SPLINE entries,
# per channel (rail_mj.track.irregularities.CHANNELS, in order) the cubic's coefficients c0..c3 in
# the distance from the interval's start (m, m/m, 1/m, 1/m^2); then per wheelset its mass (kg),
# roll inertia about the rail level (kg m^2), the height of its centre above the rails (m) and its
# axlebox tendons: count, then (tendon, its length's rate in the wheelset's rise, in its roll about
# its centre).
IRREGULAR_HEADER = 5
SPLINE = 16
BREAKPOINT = 5
SPEED_POINT = 2
# The odometer's mass, kg: it is coupled to no other body, so its mass only has to be positive
# for MuJoCo; a speed profile drives it with the force ODOMETER_MASS * V * dV/ds.
ODOMETER_MASS = 1.0
POSES = 3  # per body: lateral offset, heading, roll
LOADS = 3  # per body, after the poses and rates in the curve's scratch: fy, fz, mz
# The native callback's scratch, in mjData.userdata (its size, `userdata_size`, set by the model's
# builder): the tendons' real lengths, then their real rates (ntendon each), copies made once a call
# on a curve; then per vehicle on a curve its cache of what the track's geometry gives it at one
# station and speed (a pure function of the two, so that a hit changes no bit): CACHE_KEY entries (1
# once filled, the model's address, the station and the speed it was filled at), the bodies' poses,
# rates and loads ((2*POSES + LOADS) per body: rail_mj.vehicle.poses.curve_state), each listed
# tendon's shift and its rate, each dof row's force. RK4 evaluates at each station twice (its second
# and third stages, and its fourth and the next step's first), so half the calls find it filled.
CACHE_KEY = 4


def vehicle_starts(data: np.ndarray) -> list[int]:
    """Where each vehicle's entries start in a native block (the numeric's data)."""
    starts, k = [], 2
    for _ in range(int(data[1])):
        starts.append(k)
        k += int(data[k + TRACK_AT])
        k += track_part_size(data, k)
    return starts


def cache_size(data: np.ndarray, k: int) -> int:
    """The size of the callback's cache for the track part at `k` (0: straight track, none)."""
    if data[k] < 0:
        return 0
    bodies, joints, tendons = (int(v) for v in data[k + 3 : k + 6])
    return CACHE_KEY + (2 * POSES + LOADS) * bodies + 2 * tendons + joints


def userdata_size(data: np.ndarray, ntendon: int) -> int:
    """The mjData.userdata the native callback uses as scratch for the block `data` of a model
    with `ntendon` tendons: 0 where every vehicle is on straight track."""
    caches = [cache_size(data, k + int(data[k + TRACK_AT])) for k in vehicle_starts(data)]
    return 2 * ntendon + sum(caches) if any(caches) else 0


def track_part_size(data: np.ndarray, k: int) -> int:
    """The number of entries of the track part starting at `k`."""
    if data[k] < 0:  # straight track: the header alone
        return TRACK_HEADER
    breakpoints, bodies, joints, tendons = (int(v) for v in data[k + 2 : k + 6])
    index = k + TRACK_HEADER + SPEED_POINT * int(data[k + 7]) + BREAKPOINT * breakpoints
    e = k + int(data[index + bodies + joints + tendons])
    if int(data[k + IRREGULAR_AT]):
        e = k + int(data[k + IRREGULAR_AT])
        intervals, wheelsets = int(data[e]), int(data[e + 4])
        e += IRREGULAR_HEADER + SPLINE * intervals
        for _ in range(wheelsets):
            e += 4 + 3 * int(data[e + 3])
    return e - k


# --- the contact parameters of each wheelset (rail_mj.contact.creep.ContactParameters) ---

# The rows of ContactParameters.table, in order. The native callback's numeric block carries
# ROWS numbers per wheelset (rail_mj.simulation.native).
_FASTSIM_ROWS = ("semi_axis_a", "semi_axis_b", "normal_force", "shear_modulus", "c11", "c22", "c23")
_ROWS = (
    "r0",
    "b",
    "conicity",
    "f11",
    "f22",
    "f23",
    "f33",
    "friction_limit",
    "falling_friction_ratio",
    "falling_friction_rate",
    "clearance",
    "flange_stiffness",
    "flange_damping",
    "flange_slope",
    *_FASTSIM_ROWS,
)
ROWS = len(_ROWS)
(
    _R0,
    _B,
    _LAM,
    _F11,
    _F22,
    _F23,
    _F33,
    _LIMIT,
    _FALL_RATIO,
    _FALL_RATE,
    _CLEARANCE,
    _K_FLANGE,
    _C_FLANGE,
    _SLOPE,
    _SEMI_A,
    _SEMI_B,
    _NORMAL,
    _SHEAR,
    _C11,
    _C22,
    _C23,
) = range(ROWS)


# --- a profiled wheelset's contact table: the "rail_mj/geometry" numeric -----------------

# The table is stored in mm, kN and GPa: MuJoCo's MJCF writer writes as 0 any entry of a
# numeric smaller than 1e-12 of its largest, and in SI a shear modulus of 8e10 Pa beside
# shifts of 5e-5 m would lose them (the native block also carries creep coefficients of 1e7 N).

# Header entries (row 0): y0 and dy (mm), rows, axle load (kN), shear modulus (GPa),
# friction coefficient, r0 (mm), gravitational stiffness and spin creep on (1) or off (0).
(
    HEADER_Y0,
    HEADER_DY,
    HEADER_ROWS,
    HEADER_AXLE_LOAD,
    HEADER_SHEAR_MODULUS,
    HEADER_FRICTION,
    HEADER_R0,
    HEADER_GRAVITY,
    HEADER_SPIN,
) = range(9)
# Per row: y (mm), roll (mrad, left side up), then per side (left, right) per slot POINT entries.
Y, ROLL = range(2)
FIRST_POINT = 2
# Per point: load share, rolling radius less r0 (mm: MJCF's 6 significant figures keep it to
# 1e-9 mm near the centre), contact angle (rad, leaning towards the track centre), lateral
# lever (mm, the contact's y less the wheelset's), Hertz semi-axes per unit load
# (mm/kN^(1/3), a along the rolling direction), Kalker's C11, C22, C23, C33.
WEIGHT, RADIUS, ANGLE, LEVER, SEMI_A, SEMI_B, C11, C22, C23, C33 = range(10)
POINT = 10
SLOTS = 2  # each followed across the rows (_assign_slots): slot 0 starts at the centred outer point
COLUMNS = FIRST_POINT + 2 * SLOTS * POINT


def point_column(side: int, slot: int, field: int) -> int:
    """The column of `field` for side 0 (left) / 1 (right) and slot 0 / 1."""
    return FIRST_POINT + (side * SLOTS + slot) * POINT + field


# --- the guiding forces a packed model records (rail_mj.simulation.stepping._pack) ----------

# A model whose last two sensors are these (a clock, then a user sensor of one entry per body)
# gets from the native callback, at the first stage of every step (the state the step starts
# from, as every sensor), each wheelset's Sigma Y at its body's entry: what the record's EN 14363
# guiding forces are, without evaluating the law again. MuJoCo's sensor types, as mjtSensor
# numbers them (tests/simulation/test_native.py checks them against the installed MuJoCo).
SENSOR_CLOCK = 45  # mjSENS_CLOCK: the time, read in the first stage only
SENSOR_USER = 48  # mjSENS_USER: cleared by MuJoCo in its stage, then the callback's
CLOCK_SENSOR = "rail_mj/clock"
GUIDING_SENSOR = "rail_mj/guiding"
