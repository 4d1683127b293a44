"""The choices every layer offers, each defined here once: the albedo estimators, the kernel
arithmetic and the lanes per work-item (the command line's choices are these)."""

MC_ESTIMATORS = ("uniform", "cosine", "brdf", "mis")     # Monte Carlo: uniform or cosine
#                  hemisphere, the model's sampler, or the balance heuristic of the two
ESTIMATORS = MC_ESTIMATORS + ("quadrature",)             # + the deterministic quadrature
PRECISIONS = ("single", "double")
WIDTHS = (1, 2, 4, 8, 16)                                # lanes per work-item

# defaults of refined estimates (tables and sweeps) and of a sweep's verdicts
MAX_GROWTH = 64           # max_samples = MAX_GROWTH x samples: 3 looks of 4x the samples
ERROR_RATE = 1e-3         # probability that a sweep point's verdict is wrong
MAGNITUDE_TOL = 2e-7      # error target of an LTC's magnitudes E and B (tables/ltc.py magnitudes)
