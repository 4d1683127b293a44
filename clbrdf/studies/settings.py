"""The studies' settings that the command line shows as its defaults: read, never computed, so
that ``clbrdf --help`` needs none of the studies' imports."""

# clbrdf compensation (studies/compensation.py): the grid of the map
ALPHAS = (0.05, 0.1, 0.2, 0.4, 0.7, 1.0)        # GGX roughness
MUS = (0.1, 0.3, 0.5, 0.7, 0.9, 1.0)            # view cosines of the albedo
LOBE_MUS = (0.2, 0.5, 0.9)                      # view cosines of the lobe errors
METALS = ("gold", "copper", "aluminium")        # presets of ggx
GLASS_ETAS = (1.33, 1.5, 2.0)                   # glass indices
