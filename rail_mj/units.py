"""Units and shared physical constants: the one place a conversion factor is defined.

Each factor is named for what it converts, so that a factor of 10^6 cannot hide behind a
name like "MM": multiply a length in metres by MM_PER_M to get millimetres, a stored
length in millimetres by M_PER_MM to get metres. rail-mj computes in SI (kg, m, N, s,
rad); the other units appear only where numbers are stored (the model's numerics,
rail_mj.numerics) or shown (recordings, summaries).
"""

M_PER_MM = 1e-3
MM_PER_M = 1e3
N_PER_KN = 1e3
PA_PER_GPA = 1e9
RAD_PER_MRAD = 1e-3
MRAD_PER_RAD = 1e3

# Standard gravity as railway practice rounds it (EN 14363 and the Manchester benchmark use 9.81).
GRAVITY = 9.81  # m/s^2

# The two rails, by name and the sign of their y (docs/frames.md: y to the left).
SIDES = (("left", 1.0), ("right", -1.0))
