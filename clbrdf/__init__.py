"""clbrdf: BRDF evaluation, sampling and integration in bulk with OpenCL kernels."""
__version__ = "0.1.0"

from .core import (AlbedoResult, Model, TargetStderrWarning, albedo, albedo_avg,  # noqa: F401
                   albedo_table, fresnel_avg, model)
from .device import DeviceError, get_device, list_devices  # noqa: F401
from .models import MODELS  # noqa: F401
from . import presets  # noqa: F401
from .spec import ParameterError  # noqa: F401
from .check import check  # noqa: F401,E402  (clbrdf.check(model, ...): the property battery)
from .sweep import open_sweep, sweep  # noqa: F401,E402  (clbrdf.sweep(model, store, ...): energy sweeps)
from .table import Table, load_tables, save_tables  # noqa: F401,E402  (renderer-layout tables)
from .layouts import make_layout, white_furnace  # noqa: F401,E402
