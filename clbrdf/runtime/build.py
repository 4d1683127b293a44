"""Assemble and build kernel programs, cached per (configuration, precision, width, device).

The sources are the OpenCL C files in ``kernels/`` (shipped inside the package as
``clbrdf.kernels``). ``#include "x.h"`` lines are expanded here, once each, so that the source
handed to the compiler is self-contained and its text is the cache key. Generated tables
(kernels/data/*.npy) are data, not source: a program gets them in one device buffer, created
once per device, with the offsets as ``#define TABLE_name``.
"""
from __future__ import annotations

import os
import re
from functools import lru_cache
from importlib import resources
from pathlib import Path

from ..models.spec import Config
from .device import Device, DeviceError, get_device

_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$', re.M)
BLOCK = 1024          # samples per work-item in the albedo kernel, at most


def kernel_dir() -> Path:
    try:
        p = Path(str(resources.files("clbrdf.kernels")))
        if (p / "common.h").exists():
            return p
    except (ModuleNotFoundError, TypeError):
        pass
    p = Path(__file__).resolve().parents[2] / "kernels"        # a source checkout
    if (p / "common.h").exists():
        return p
    raise FileNotFoundError("clbrdf kernel sources not found (expected clbrdf/kernels or ./kernels)")


def get_include() -> str:
    """The directory of the C headers (``clbrdf.h`` and the model headers) for C, C++, CUDA and
    OpenCL builds: ``cc -I$(clbrdf --include)``, like ``numpy.get_include()``."""
    return str(kernel_dir())


@lru_cache(maxsize=None)
def read_kernel(name: str) -> str:
    """A header of clbrdf.kernels, or a model's header given by its absolute path."""
    path = Path(name)
    return (path if path.is_absolute() else kernel_dir() / name).read_text()


def expand(name: str, seen: set | None = None) -> str:
    """The file's text with its #include "..." lines replaced by the files (once each)."""
    seen = set() if seen is None else seen
    if name in seen:
        return ""
    seen.add(name)

    def sub(m):
        return expand(m.group(1), seen)
    return f'// ---- {name} ----\n' + _INCLUDE.sub(sub, read_kernel(name))


PARTS = ("batch", "random", "albedo", "quadrature", "ltc", "walk")
INTEGRANDS = ("albedo", "schlick")      # of the quadrature: f cos, f cos (1 - wo.h)^5
_TABLE = re.compile(r"\bTABLE_([a-z][a-z0-9_]*)\b")


@lru_cache(maxsize=None)
def table_data(name: str):
    """Generated table ``name``: float32 values of kernels/data/NAME.npy (read once)."""
    import numpy as np
    a = np.load(kernel_dir() / "data" / f"{name}.npy")
    if a.dtype != np.float32 or a.ndim != 1:
        raise RuntimeError(f"kernels/data/{name}.npy: expected 1-D float32, got {a.dtype} {a.shape}")
    return a


def _table_names(source: str) -> tuple[str, ...]:
    code = re.sub(r"/\*.*?\*/|//[^\n]*", "", source, flags=re.S)     # names in comments do not count
    return tuple(dict.fromkeys(_TABLE.findall(code)))


def with_tables(source: str) -> tuple[str, tuple[str, ...]]:
    """The source with ``#define TABLE_name offset`` for every table it names (in order of first
    use) and ``CLBRDF_TABLES`` (whether there are any: only then do ``Params`` and ``Microfacet``
    carry the tables pointer, which halved PoCL's width-1 speed for GGX), and those names: the
    program's tables buffer is their concatenation (``tables``)."""
    names = _table_names(source)
    lines, off = [f"#define CLBRDF_TABLES {int(bool(names))}"], 0
    for n in names:
        lines.append(f"#define TABLE_{n} {off}")
        off += table_data(n).size
    return "\n".join(lines + [source]), names


def tables(names: tuple[str, ...]):
    """The float32 contents of a program's tables buffer (one 0 when it uses none)."""
    import numpy as np
    if not names:
        return np.zeros(1, np.float32)
    return np.concatenate([table_data(n) for n in names])


@lru_cache(maxsize=1024)
def program_source(cfg: Config, precision: str, width: int, *, part: str = "batch",
                   estimator: str = "brdf", rng: str = "philox",
                   integrand: str = "albedo") -> tuple[str, tuple[str, ...]]:
    """The self-contained source of one program. ``part`` picks its kernels, so that a program
    holds only the code its caller runs: ``batch`` (eval_batch, pdf_batch, sample_batch),
    ``albedo`` (for one estimator: albedo_blocks with Philox, albedo_qmc with Sobol points), ``quadrature`` (quadrature_panels),
    ``ltc`` (ltc_moments and ltc_loss for one generator: the LTC fit), ``walk`` (walk_albedo
    and walk_sample: Heitz et al. 2016's random walk, kernels/heitz_ms.h) or ``random`` (random_batch for one
    generator; it contains no model, so one program serves every model). ``integrand`` of the
    quadrature: ``albedo`` (f cos) or ``schlick`` (f cos (1 - wo.h)^5). Returns the source and
    the names of the tables it reads (``with_tables``); assembled once per configuration."""
    if part not in PARTS:
        raise ValueError(f"part={part!r}: choose one of {', '.join(PARTS)}")
    lines = [f"#define CLBRDF_DOUBLE {int(precision == 'double')}", f"#define W {width}",
             f"#define KERNELS KERNELS_{part.upper()}"]
    seen: set = set()
    body = [expand(f, seen) for f in ("common.h", "rng.h", "warp.h")]
    if part == "random":
        lines += [f"#define RNG rand_{rng}"]
        body.append(expand("integrators.cl", seen))
        return with_tables("\n".join(lines) + "\n" + "\n".join(body))
    lines += [f"#define MODEL {cfg.prefix}", f"#define CHANNELS {cfg.channels}"]
    if part == "ltc":
        body.append(expand("ltc.h", seen))
    if part == "quadrature":
        if integrand not in INTEGRANDS:
            raise ValueError(f"integrand={integrand!r}: choose one of {', '.join(INTEGRANDS)}")
        lines.append(f"#define QUAD_SCHLICK {int(integrand == 'schlick')}")
    if part == "albedo":        # both generators' kernels: albedo_blocks uses Philox
        rng = "philox"
    if part in ("albedo", "ltc"):
        lines += [f"#define ESTIMATOR ESTIMATOR_{estimator.upper()}",
                  f"#define RNG rand_{rng}", f"#define RNG_PHILOX {int(rng == 'philox')}"]
    lines += [f"#define {k} {v}" for k, v in cfg.defines]
    # X(name, row) for scalars, XS(name, first row) for spectral parameters (CHANNELS rows)
    items, fields, row = [], [], 0
    for n in cfg.param_names:
        spectral = n in cfg.spectral
        items.append(f"{'XS' if spectral else 'X'}({n}, {row})")
        fields.append(f"    realN {n}{'[CHANNELS]' if spectral else ''};")
        row += cfg.rows(n)
    lines.append(f"#define PARAMS(X, XS) {' '.join(items)}")
    model = [expand(h, seen) for h in cfg.headers] + [expand(cfg.header, seen)]
    if _table_names("\n".join(model)):
        fields.append("    Tables tables;")
    body.append("typedef struct {\n" + "\n".join(fields) + "\n} Params;\n"
                f"#define {cfg.prefix}_params Params\n")     # the model header's name for it
    body += model
    if part == "walk":          # the walk extends the model's distribution and Fresnel
        body.append(expand("heitz_ms.h", seen))
    body.append(expand("integrators.cl", seen))
    return with_tables("\n".join(lines) + "\n" + "\n".join(body))


class Built:
    """A built program and its tables buffer (the second argument of every model kernel)."""
    def __init__(self, program, tables):
        self.program, self.tables = program, tables


@lru_cache(maxsize=256)
def _build(device: Device, source: str):
    import pyopencl as cl
    # CLBRDF_BUILD_OPTIONS: extra compiler options, e.g. -cl-opt-disable for oclgrind
    options = ["-cl-std=CL1.2"] + os.environ.get("CLBRDF_BUILD_OPTIONS", "").split()
    try:
        return cl.Program(device.context, source).build(options=options)
    except cl.RuntimeError as e:  # compiler errors: keep the first few
        lines = [ln for ln in str(e).splitlines() if "error" in ln][:12]
        raise RuntimeError(f"kernel build failed on {device.info.name}:\n" + "\n".join(lines)) from e


@lru_cache(maxsize=64)
def tables_buffer(device: Device, names: tuple[str, ...]):
    """The tables buffer of ``names`` on ``device``, created once per device."""
    import pyopencl as cl
    return cl.Buffer(device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                     hostbuf=tables(names))


@lru_cache(maxsize=256)
def _built(device: Device, source: str, names: tuple[str, ...]) -> Built:
    return Built(_build(device, source), tables_buffer(device, names))


def get_program(device: Device, cfg: Config, precision: str, width: int, **kw) -> Built:
    if precision == "double" and not device.info.has_fp64:
        raise DeviceError(f"precision='double' needs cl_khr_fp64, which {device.info.name} lacks; "
                          "use precision='single' or another device")
    source, names = program_source(cfg, precision, width, **kw)
    return _built(device, source, names)


def run_functions(headers, source: str, kernel: str, inputs, outputs: int = 1, *,
                  precision: str = "double", width: int = 1, defines=(), device=None):
    """Run kernel functions directly, for tests and scripts: build ``headers`` (expanded, e.g.
    ``("common.h", "special.h")``) and ``source``, whose ``kernel`` takes the tables buffer
    (``Tables TABLES``) when the program uses tables, then one ``real_t`` buffer per input and per
    output, and handles ``W`` consecutive values per work-item (``VLOAD``/``VSTORE`` at
    ``get_global_id(0) * W``). ``inputs``: equal-length 1-D arrays, padded to a multiple of
    ``width`` with their last value. Returns the ``outputs`` arrays as float64."""
    import numpy as np
    import pyopencl as cl
    device = device or get_device()
    seen: set = set()
    body = [f"#define CLBRDF_DOUBLE {int(precision == 'double')}", f"#define W {width}",
            *defines, *(expand(h, seen) for h in headers), source]
    src, names = with_tables("\n".join(body))
    built = _built(device, src, names)
    dt = np.float64 if precision == "double" else np.float32
    n = len(inputs[0])
    npad = -(-n // width) * width
    mf = cl.mem_flags
    bufs = [built.tables] if names else []
    for v in inputs:
        h = np.empty(npad, dt)
        h[:n] = v
        h[n:] = h[n - 1]
        bufs.append(cl.Buffer(device.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=h))
    outs = [np.empty(npad, dt) for _ in range(outputs)]
    obufs = [cl.Buffer(device.context, mf.WRITE_ONLY, o.nbytes) for o in outs]
    cl.Kernel(built.program, kernel)(device.queue, (npad // width,), None, *bufs, *obufs)
    for o, b in zip(outs, obufs):
        cl.enqueue_copy(device.queue, o, b)
    device.queue.finish()
    return [o[:n].astype(np.float64) for o in outs]
