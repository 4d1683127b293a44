"""Launching kernels: widths, seeds, launch geometry, kernel objects and progress bars.

The rest of the runtime (``albedo``, ``quadrature``, ``bound``) and the layers above launch
through these.
"""
from __future__ import annotations

import os
import warnings

import numpy as np

from ..models.spec import check_int
from . import probe
from .device import Device, DeviceError

LOCAL_SIZE = 64           # work-items per work-group, at most

_KERNELS: dict = {}


class WidthFallbackWarning(UserWarning):
    """The device's compiler fails on the kernels at the default width; width 1 is used."""


_WARNED: set = set()


def working_width(device: Device, precision: str) -> int:
    """The default width of ``device`` (Device.default_width) if the kernels build and compute
    right there (clbrdf.runtime.probe, in a child process, cached), else 1 with a warning that says how
    to get the fast path; a DeviceError if width 1 fails too. CLBRDF_WIDTH and GPUs (width 1)
    are taken as they are."""
    w = device.default_width(precision)
    if os.environ.get("CLBRDF_WIDTH") or os.environ.get("CLBRDF_IN_PROBE") or w == 1:
        return w
    err = probe.kernel_error(device.info, w, precision)
    if err is None:
        return w
    err1 = probe.kernel_error(device.info, 1, precision)
    if err1 is not None:
        raise DeviceError(f"device {device.info.selector} ({device.info.name} [{device.info.platform}]) "
                          f"cannot run the kernels: {err}; and at width 1: {err1}. Install "
                          f"Debian's PoCL (apt-get install pocl-opencl-icd) or choose another "
                          f"device (clbrdf devices)")
    if (device.info.selector, precision) not in _WARNED:
        _WARNED.add((device.info.selector, precision))
        warnings.warn(f"device {device.info.selector} ({device.info.platform}): {err}; running at "
                      f"width 1, about 12x slower. For the fast path install Debian's PoCL "
                      f"(apt-get install pocl-opencl-icd), which clbrdf then prefers",
                      WidthFallbackWarning, stacklevel=3)
    return 1


def seed_words(seed) -> tuple[np.uint32, np.uint32]:
    s = check_int("seed", seed, 0, 2**64 - 1, "[0, 2^64)")
    return np.uint32(s & 0xFFFFFFFF), np.uint32(s >> 32)


def derive_seed(seed: int, *words: int) -> int:
    """A 64-bit seed from (seed, words) by SplitMix64 steps (Steele et al. 2014)."""
    x = seed & 0xFFFFFFFFFFFFFFFF
    for w in words:
        x = (x ^ (w & 0xFFFFFFFFFFFFFFFF)) + 0x9E3779B97F4A7C15 & 0xFFFFFFFFFFFFFFFF
        x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9 & 0xFFFFFFFFFFFFFFFF
        x = (x ^ (x >> 27)) * 0x94D049BB133111EB & 0xFFFFFFFFFFFFFFFF
        x ^= x >> 31
    return x


def ndrange_with(items: int, local: tuple) -> tuple:
    """(global size, local size) for ``items`` work-items with a given local size."""
    return (-(-items // local[0]) * local[0],), local


def ndrange(items: int, device: Device, heavy: bool = False):
    """(global size, local size) for ``items`` work-items; the kernels ignore the padding items.

    The local size is explicit: left to itself PoCL makes work-groups of up to 4096 items whose
    contexts live on an 8 MB thread stack, which overflows for models with many parameters
    (an RGB Holzschuch-Pacanowski launch crashed). On a CPU it is one size per kernel, since
    PoCL compiles a kernel once per local size (0.2 to 1.5 s at W = 16; two sizes per kernel
    were 280 of the 1861 compilations of a cold test run): 1 for a ``heavy`` kernel, whose
    work-item is a block of samples (albedo, random walk, LTC: as fast as 8, 16 or 64 from 1 to
    4096 points, GGX on 2 cores), LOCAL_SIZE for the others (eval, pdf, sample: W values a
    work-item). On a GPU: a power of two up to LOCAL_SIZE, smaller for small launches so that
    every compute unit gets work groups."""
    if not device.info.is_gpu:
        return ndrange_with(items, (1,) if heavy else (LOCAL_SIZE,))
    cu = device.info.compute_units
    local = 1
    while local < LOCAL_SIZE and local * 2 * 4 * cu <= items:
        local *= 2
    return ndrange_with(items, (local,))


def kernel(prog, name: str):
    """One kernel object per (program, name): pyopencl creates a new one on every attribute access."""
    key = (id(prog), name)
    if key not in _KERNELS:
        import pyopencl as cl
        _KERNELS[key] = (prog, cl.Kernel(prog, name))
    return _KERNELS[key][1]


def progress_bar(total: int, enabled: bool, unit: str = "sample"):
    try:
        from tqdm import tqdm
    except ImportError:
        enabled = False
    if not enabled:
        class _Null:
            def update(self, n): pass
            def close(self): pass
        return _Null()
    return tqdm(total=total, unit=unit, unit_scale=True, delay=2.0, leave=False)


def environment() -> dict:
    """Environment variables that change a result's bits or the device used."""
    keys = ("CLBRDF_DEVICE", "CLBRDF_WIDTH", "CLBRDF_BUILD_OPTIONS", "POCL_CPU_MAX_CU_COUNT",
            "POCL_MAX_PTHREAD_COUNT", "POCL_DEVICES", "POCL_AFFINITY", "OCL_ICD_VENDORS", "OCL_ICD_FILENAMES")
    return {k: os.environ[k] for k in keys if k in os.environ}
