"""The creep laws by name and by the number the generated model stores for the compiled law
(docs/creep.md, "Saturation"). The numbers are part of the model file format (rail_mj.numerics)."""

# Creep laws (docs/creep.md, saturation), by the number the model stores for the compiled law.
LINEAR, SHEN_HEDRICK_ELKINS, POLACH, FASTSIM = 0, 1, 2, 3
LAWS = {"linear": LINEAR, "shen-hedrick-elkins": SHEN_HEDRICK_ELKINS, "polach": POLACH, "fastsim": FASTSIM}
