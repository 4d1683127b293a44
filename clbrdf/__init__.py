"""clbrdf: BRDF evaluation, sampling and integration in bulk with OpenCL kernels.

The public namespace. The package's layers, each importing only those below it
(tests/test_architecture.py): ``cli`` -> ``studies`` -> ``tables`` -> ``api`` -> ``runtime`` ->
``ref`` -> ``models``; the kernels (``clbrdf.kernels``, C headers) under all of them.
"""
from .api.albedo import AlbedoResult, albedo, albedo_avg, fresnel_avg
from .api.model import Model, model
from .api.useless import UselessEstimatorWarning
from .api.walk import WalkEvalResult, WalkResult, walk_albedo, walk_eval, walk_sample
from .models import MODELS, presets
from .models.spec import ParameterError
from .runtime.build import get_include
from .runtime.device import DeviceError, get_device, list_devices
from .runtime.launch import WidthFallbackWarning
from .studies.check import check
from .studies.sweep import open_sweep, sweep
from .tables.compute import TargetStderrWarning, albedo_table
from .tables.files import save_tables
from .tables.layouts import make_layout
from .tables.ltc import fit_ltc, ltc_errors
from .tables.table import Table, TableRangeWarning, load_tables
from .version import __version__

__all__ = ["AlbedoResult", "DeviceError", "MODELS", "Model", "ParameterError", "Table", "TableRangeWarning",
           "TargetStderrWarning", "UselessEstimatorWarning", "WidthFallbackWarning",
           "__version__", "albedo", "albedo_avg", "albedo_table", "check", "fit_ltc", "fresnel_avg",
           "get_device", "get_include", "list_devices", "load_tables", "ltc_errors", "make_layout", "model",
           "open_sweep", "presets", "save_tables", "sweep", "walk_albedo", "walk_eval",
           "walk_sample", "WalkEvalResult", "WalkResult"]
