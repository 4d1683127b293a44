"""clbrdf: BRDF evaluation, sampling and integration in bulk with OpenCL kernels.

The public namespace. The package's layers, each importing only those below it
(tests/test_architecture.py): ``cli`` -> ``studies`` -> ``tables`` -> ``api`` -> ``runtime`` ->
``ref`` -> ``models``; the kernels (``clbrdf.kernels``, C headers) under all of them.

Each name is imported on first use (``PUBLIC`` says from where), so that ``import clbrdf`` and
a command that needs none of them start at once.
"""
from __future__ import annotations

import importlib

from .version import __version__

# name -> the module that defines it (read by tests/test_architecture.py as this module's imports)
PUBLIC = {
    "AlbedoResult": "clbrdf.api.albedo", "albedo": "clbrdf.api.albedo",
    "albedo_avg": "clbrdf.api.albedo", "fresnel_avg": "clbrdf.api.albedo",
    "Model": "clbrdf.api.model", "model": "clbrdf.api.model",
    "UselessEstimatorWarning": "clbrdf.api.useless",
    "WalkEvalResult": "clbrdf.api.walk", "WalkResult": "clbrdf.api.walk",
    "walk_albedo": "clbrdf.api.walk", "walk_eval": "clbrdf.api.walk",
    "walk_sample": "clbrdf.api.walk",
    "MODELS": "clbrdf.models", "presets": "clbrdf.models.presets",
    "ParameterError": "clbrdf.models.spec",
    "get_include": "clbrdf.runtime.build",
    "DeviceError": "clbrdf.runtime.device", "get_device": "clbrdf.runtime.device",
    "list_devices": "clbrdf.runtime.device",
    "WidthFallbackWarning": "clbrdf.runtime.launch",
    "check": "clbrdf.studies.check",
    "open_sweep": "clbrdf.studies.sweep", "sweep": "clbrdf.studies.sweep",
    "TargetStderrWarning": "clbrdf.tables.compute", "albedo_table": "clbrdf.tables.compute",
    "save_tables": "clbrdf.tables.files",
    "make_layout": "clbrdf.tables.layouts",
    "fit_ltc": "clbrdf.tables.ltc", "ltc_errors": "clbrdf.tables.ltc",
    "Table": "clbrdf.tables.table", "TableRangeWarning": "clbrdf.tables.table",
    "load_tables": "clbrdf.tables.table",
}

__all__ = sorted(PUBLIC) + ["__version__"]


def __getattr__(name: str):
    where = PUBLIC.get(name)
    if where is None:
        raise AttributeError(f"module 'clbrdf' has no attribute {name!r}")
    module = importlib.import_module(where)
    value = module if name == "presets" else getattr(module, name)
    globals()[name] = value             # later look-ups skip this function
    return value


def __dir__():
    return sorted(set(globals()) | set(PUBLIC))
