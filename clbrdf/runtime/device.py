"""OpenCL device selection.

The device is chosen, in this order, by the ``device=`` argument of the Python API or the CLI's
``--device``, the environment variable ``CLBRDF_DEVICE``, or else the first GPU, else the CPU of
the newest PoCL, else the first CPU. Two PoCLs side by side are common: PyPI's (3.0-rc2, LLVM 14,
from ``pyopencl[pocl]``) and Debian's (3.1, LLVM 15); on a 2-core Xeon Debian's ran the GGX brdf
estimator 1.2x faster per CPU-second, and 2.0x before the kernels forced inlining
(benchmarks/RESULTS.md, bench_albedo's ``clbrdf@`` row). A selector is ``P:D`` (platform and
device indices as ``clbrdf devices`` lists them) or a case-insensitive substring of the device or
platform name (``pocl``, ``nvidia``).
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass
from functools import lru_cache

from ..models.spec import ParameterError, check_int

NO_DEVICE_HELP = (
    "No working OpenCL device found. clbrdf runs on the CPU through PoCL: "
    "pip install 'pyopencl[pocl]' gives one without root; where its compiler (LLVM 14) does not "
    "know the CPU ('unknown target CPU'), install Debian's PoCL: apt-get install pocl-opencl-icd. "
    "A GPU needs its vendor's OpenCL driver (ICD)."
)


class DeviceError(RuntimeError):
    pass


@dataclass(frozen=True)
class DeviceInfo:
    platform_index: int
    device_index: int
    name: str
    platform: str
    is_gpu: bool
    has_fp64: bool
    compute_units: int
    driver: str = ""

    @property
    def selector(self) -> str:
        return f"{self.platform_index}:{self.device_index}"


def _cl():
    try:
        import pyopencl as cl
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise DeviceError(NO_DEVICE_HELP) from e
    return cl


def _all_devices():
    cl = _cl()
    try:
        platforms = cl.get_platforms()
    except cl.Error as e:
        raise DeviceError(f"{NO_DEVICE_HELP} (OpenCL said: {e})") from e
    out = []
    for pi, p in enumerate(platforms):
        try:
            devs = p.get_devices()
        except cl.Error:
            continue
        for di, d in enumerate(devs):
            out.append((DeviceInfo(pi, di, d.name.strip(), f"{p.name.strip()} ({p.version.strip()})",
                                   bool(d.type & cl.device_type.GPU),
                                   "cl_khr_fp64" in d.extensions, d.max_compute_units,
                                   d.driver_version.strip()), d))
    return out


def list_devices() -> list[DeviceInfo]:
    """All OpenCL devices of all platforms."""
    return [info for info, _ in _all_devices()]


@lru_cache(maxsize=None)
def compiler_error(key: tuple[int, int]) -> str | None:
    """None if the device compiles and runs a trivial kernel, else the error text."""
    cl = _cl()
    for info, d in _all_devices():
        if (info.platform_index, info.device_index) != key:
            continue
        try:
            ctx = cl.Context([d])
            prg = cl.Program(ctx, "__kernel void probe(__global float *a) { a[0] = 2.0f; }").build()
            q = cl.CommandQueue(ctx)
            buf = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, 4)
            prg.probe(q, (1,), None, buf)
            q.finish()
            return None
        except Exception as e:  # build failures, missing compilers
            lines = [ln for ln in str(e).splitlines() if ln.strip()]
            return next((ln for ln in lines if "error" in ln.lower()), lines[-1] if lines else repr(e))
    return "no such device"


def pocl_version(info: DeviceInfo) -> tuple[int, ...] | None:
    """(major, minor, patch, final) from a PoCL platform's version text ('PoCL 3.1+debian',
    'PoCL 3.0-rc2': final is 0 for a release candidate); None for other platforms."""
    m = re.search(r"PoCL (\d+)\.(\d+)(?:\.(\d+))?(-rc)?", info.platform)
    if m is None:
        return None
    return int(m[1]), int(m[2]), int(m[3] or 0), 0 if m[4] else 1


def default_order(infos: list[DeviceInfo]) -> list[DeviceInfo]:
    """The order in which the default device is looked for: GPUs as enumerated, then PoCL CPUs
    from the newest PoCL, then the other CPUs as enumerated."""
    gpus = [i for i in infos if i.is_gpu]
    cpus = [i for i in infos if not i.is_gpu]
    pocl = sorted((i for i in cpus if pocl_version(i) is not None), key=pocl_version, reverse=True)
    return gpus + pocl + [i for i in cpus if pocl_version(i) is None]


def _pick(selector: str | None):
    devs = _all_devices()
    if not devs:
        raise DeviceError(NO_DEVICE_HELP)
    if isinstance(selector, str) and not selector.strip():
        valid = ", ".join(f"{i.selector} ({i.name})" for i, _ in devs)
        raise ParameterError(f"device={selector!r} is empty: give P:D or a part of a device's or "
                             f"platform's name; valid: {valid}")
    if selector is None:
        selector = os.environ.get("CLBRDF_DEVICE") or None
    if selector is None:
        # the first device in default_order whose compiler works
        errors = []
        by_info = dict(devs)
        for info in default_order([i for i, _ in devs]):
            err = compiler_error((info.platform_index, info.device_index))
            if err is None:
                return info, by_info[info]
            errors.append(f"{info.selector} {info.name} [{info.platform}]: {err}")
        raise DeviceError(NO_DEVICE_HELP + " Devices tried: " + "; ".join(errors))
    sel = str(selector).strip()
    if ":" in sel and all(part.isdigit() for part in sel.split(":", 1)):
        pi, di = (int(x) for x in sel.split(":", 1))
        matches = [(i, d) for i, d in devs if (i.platform_index, i.device_index) == (pi, di)]
    else:
        matches = [(i, d) for i, d in devs
                   if sel.lower() in i.name.lower() or sel.lower() in i.platform.lower()]
    broken = []
    for info, d in matches:       # the first match whose compiler works
        err = compiler_error((info.platform_index, info.device_index))
        if err is None:
            return info, d
        broken.append(f"{info.selector} {info.name} [{info.platform}]: {err}")
    if broken:
        raise DeviceError(f"device={selector!r} matches only devices whose OpenCL compiler "
                          f"fails: {'; '.join(broken)}")
    valid = ", ".join(f"{i.selector} ({i.name})" for i, _ in devs)
    raise DeviceError(f"device={selector!r} matches no OpenCL device; valid: {valid}")


def natural_width(info: DeviceInfo, precision: str) -> int:
    """The lanes per work-item a device gets unless told otherwise: 1 on a GPU; on a CPU a
    512-bit register (16 floats, 8 doubles), since PoCL does not vectorise scalar code."""
    if info.is_gpu:
        return 1
    return 16 if precision == "single" else 8


class Device:
    """A device with its context and in-order queue."""

    def __init__(self, info: DeviceInfo, cl_device):
        cl = _cl()
        self.info = info
        self.cl_device = cl_device
        self.context = cl.Context([cl_device])
        self.queue = cl.CommandQueue(self.context)

    def default_width(self, precision: str) -> int:
        env = os.environ.get("CLBRDF_WIDTH")
        if env:
            if env.strip() not in ("1", "2", "4", "8", "16"):
                raise ParameterError(f"environment variable CLBRDF_WIDTH={env!r} is not valid: "
                                     f"choose one of 1, 2, 4, 8, 16 (lanes per work-item)")
            return int(env)
        return natural_width(self.info, precision)

    def __repr__(self):
        return f"Device({self.info.selector}: {self.info.name} [{self.info.platform}])"


@lru_cache(maxsize=None)
def _device_for(key: tuple[int, int]) -> Device:
    for info, d in _all_devices():
        if (info.platform_index, info.device_index) == key:
            return Device(info, d)
    raise DeviceError(NO_DEVICE_HELP)


def get_device(selector: str | Device | None = None) -> Device:
    """The device for a selector (see module docstring); one shared instance per device."""
    if isinstance(selector, Device):
        return selector
    info, _ = _pick(selector)
    return _device_for((info.platform_index, info.device_index))


def resolve_devices(device) -> list:
    """A selector, a Device, or a list of them -> Device objects; a device named twice gets a
    second context and queue of its own (two contexts share its compute units)."""
    if device is None or isinstance(device, (str, int)) or hasattr(device, "context"):
        return [get_device(device)]
    out = []
    for d in device:
        d = d if hasattr(d, "context") else get_device(d)
        out.append(Device(d.info, d.cl_device) if any(o is d for o in out) else d)
    return out


def split_device(device, parts: int) -> list:
    """``parts`` sub-devices of equal compute units by OpenCL device fission (PoCL CPUs support
    it), each a Device with its own context and queue."""
    import pyopencl as cl
    device = get_device(device) if not hasattr(device, "context") else device
    cu = device.cl_device.max_compute_units
    parts = check_int("split", parts, 1, max(1, cu), f"[1, {cu} compute units]")
    try:
        subs = device.cl_device.create_sub_devices(
            [cl.device_partition_property.EQUALLY, cu // parts])[:parts]
    except cl.Error as e:
        raise ParameterError(f"split={parts}: {device.info.name} cannot be split by device "
                             f"fission ({e})") from None
    return [Device(device.info, d) for d in subs]
