"""The public API of one computation: ``Model`` (evaluate, sample, densities), ``albedo``,
``albedo_avg`` and ``fresnel_avg`` with their error bars. Tables (clbrdf.tables) and studies
(clbrdf.studies) are built on it; it runs on clbrdf.runtime.
"""
