"""Cross-checks of the C API (kernels/clbrdf.h): the same model configuration built as C99 with
gcc, as OpenCL C on any platform (or under oclgrind), and run by the Python package, on the
same inputs. Used by tests/runtime/test_capi.py and scripts/capi_platforms.py (docs/kernels.md).

A case is (name, model, Python keywords); the C and OpenCL builds get the Python
configuration's defines, so the three compute the same configuration. ``outputs`` per input
row: f (per channel), pdf, the sampled wi (3), its weight (per channel) and pdf.
"""
from __future__ import annotations

import os
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ..api.model import Model
from ..models import MODELS
from ..runtime.build import kernel_dir, program_source, table_data
from ..runtime.device import get_device


def cases() -> list:
    """(case name, model, keywords) of every model's description (``Facts.capi``)."""
    return [(c, s.name, kw) for s in MODELS.values() for c, kw in s.facts.capi]


WARN = ["-Wall", "-Wextra", "-Werror", "-pedantic"]

_BODY = r"""
    vec3 wo = v3((real_t)a[0], (real_t)a[1], (real_t)a[2]);
    vec3 wi = v3((real_t)a[3], (real_t)a[4], (real_t)a[5]);
    rand4 u = {(real_t)a[6], (real_t)a[7], (real_t)a[8], (real_t)a[9]};
    spec f = clbrdf_%(model)s_eval(&p, wo, wi);
    real_t pdf = clbrdf_%(model)s_pdf(&p, wo, wi);
    BSample s = clbrdf_%(model)s_sample(&p, wo, u);
    int k = 0;
    for (int c = 0; c < CHANNELS; ++c) o[k++] = f.c[c];
    o[k++] = pdf; o[k++] = s.wi.x; o[k++] = s.wi.y; o[k++] = s.wi.z;
    for (int c = 0; c < CHANNELS; ++c) o[k++] = s.weight.c[c];
    o[k++] = s.pdf;
"""
C_PROGRAM = r"""
#include <stdio.h>
#include "clbrdf.h"
#include "clbrdf_tables.h"
int main(void)
{
    clbrdf_%(prefix)s_params p = clbrdf_%(model)s_defaults();
    float *T = clbrdf_tables_load("%(data)s");
    if (!T) return 1;
%(assign)s
    double a[10];
    real_t o[2 * CHANNELS + 5];
    while (scanf("%%lf %%lf %%lf %%lf %%lf %%lf %%lf %%lf %%lf %%lf", a, a + 1, a + 2, a + 3, a + 4,
                 a + 5, a + 6, a + 7, a + 8, a + 9) == 10) {
%(body)s
        for (int j = 0; j < k; ++j) printf("%%.17g ", (double)o[j]);
        printf("\n");
    }
    free(T);
    return 0;
}
"""
CL_PROGRAM = r"""
#include "clbrdf.h"
kernel void run(global const real_t *in, Tables T, global real_t *out)
{
    size_t i = get_global_id(0);
    global const real_t *a = in + 10 * i;
    global real_t *o = out + (2 * CHANNELS + 5) * i;
    clbrdf_%(prefix)s_params p = clbrdf_%(model)s_defaults();
%(assign)s
%(body)s
}
"""


def case(name: str):
    return next(c for c in cases() if c[0] == name)


def model(name: str, precision: str, device=None) -> Model:
    _, m, kw = case(name)
    return Model(m, precision=precision, width=1, device=device, **kw)


def uses_tables(m: Model) -> bool:
    return bool(program_source(m.config, "single", 1)[1])


def table_names() -> list:
    """The C API's table order (CLBRDF_TABLE_NAMES of kernels/clbrdf_models.h)."""
    text = (kernel_dir() / "clbrdf_models.h").read_text()
    return re.findall(r'"([a-z0-9_]+)"', re.search(r"#define CLBRDF_TABLE_NAMES (.*)", text)[1])


def tables_buffer() -> np.ndarray:
    return np.concatenate([table_data(n) for n in table_names()])


def _assign(m: Model) -> str:
    lines = ["    p.tables = T;"] if uses_tables(m) else []
    for k, v in m.params.items():
        v = np.asarray(v, np.float64)
        if k in m.config.spectral:
            vals = np.broadcast_to(v, (m.channels,))
            lines += [f"    p.{k}[{c}] = (real_t){float(x)!r};" for c, x in enumerate(vals)]
        else:
            lines.append(f"    p.{k} = (real_t){float(v)!r};")
    return "\n".join(lines)


def defines(m: Model) -> list:
    return ([f"-D{k}={v}" for k, v in m.config.defines] + [f"-DCHANNELS={m.channels}",
            f"-DCLBRDF_DOUBLE={int(m.precision == 'double')}"])


def inputs(n: int, seed: int = 7, m: Model | None = None):
    """wo, wi (unit, above the horizon: uniform, grazing to mu 1e-4, mirror pairs) and u (the
    model's own Philox numbers), rounded to the model's precision."""
    rng = np.random.default_rng(seed)

    def hemi(k):
        mu = rng.uniform(0, 1, k)
        mu[: k // 4] = 10 ** rng.uniform(-4, -1, k // 4)
        phi = rng.uniform(0, 2 * np.pi, k)
        s = np.sqrt(1 - mu * mu)
        return np.stack([s * np.cos(phi), s * np.sin(phi), mu], -1)
    wo, wi = hemi(n), hemi(n)
    wi[: n // 8] = wo[: n // 8] * [-1, -1, 1]
    u = m.random(n, seed=3) if m is not None else rng.uniform(0, 1, (n, 4))
    dt = np.float32 if (m is None or m.precision == "single") else np.float64
    return tuple(np.asarray(x, dt).astype(np.float64) for x in (wo, wi, u))


def run_c(name: str, precision: str, wo, wi, u, workdir=None, compiler: str = "gcc") -> np.ndarray:
    """The outputs of the C99 build (gcc -std=c99 with WARN)."""
    m = model(name, precision)
    with tempfile.TemporaryDirectory(dir=workdir) as d:
        src, exe = Path(d) / "t.c", Path(d) / "t"
        src.write_text(C_PROGRAM % {"prefix": m.spec.prefix, "model": m.name,
                                    "assign": _assign(m), "data": kernel_dir() / "data",
                                    "body": _BODY % {"model": m.name}})
        r = subprocess.run([compiler, "-std=c99", *WARN, "-O2", f"-I{kernel_dir()}",
                            *defines(m), str(src), "-lm", "-o", str(exe)],
                           capture_output=True, text=True)
        if r.returncode:
            raise RuntimeError(f"{compiler} failed:\n{r.stderr[-3000:]}")
        text = "\n".join(" ".join(repr(float(x)) for x in row)
                         for row in np.concatenate([wo, wi, u], 1))
        out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
    return np.array([[float(x) for x in ln.split()] for ln in out.stdout.splitlines()])


def run_opencl(name: str, precision: str, wo, wi, u, device=None,
               std: str = "CL1.2") -> np.ndarray:
    """The outputs of the C API compiled as OpenCL C (``std``) on ``device`` (a selector)."""
    import pyopencl as cl
    dev = get_device(device)
    m = model(name, precision, device=dev)
    src = CL_PROGRAM % {"prefix": m.spec.prefix, "model": m.name, "assign": _assign(m),
                        "body": _BODY % {"model": m.name}}
    # CLBRDF_BUILD_OPTIONS as for the package's programs (e.g. -cl-opt-disable for oclgrind)
    opts = [f"-cl-std={std}", "-I", str(kernel_dir()), *defines(m),
            *os.environ.get("CLBRDF_BUILD_OPTIONS", "").split()]
    prg = cl.Program(dev.context, src).build(options=opts)
    dt = np.float64 if precision == "double" else np.float32
    a = np.ascontiguousarray(np.concatenate([wo, wi, u], 1), dt)
    n, k = len(a), 2 * m.channels + 5
    mf = cl.mem_flags
    b_in = cl.Buffer(dev.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=a)
    b_t = cl.Buffer(dev.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tables_buffer())
    out = np.empty((n, k), dt)
    b_out = cl.Buffer(dev.context, mf.WRITE_ONLY, out.nbytes)
    prg.run(dev.queue, (n,), None, b_in, b_t, b_out)
    cl.enqueue_copy(dev.queue, out, b_out)
    dev.queue.finish()
    return out.astype(np.float64)


def run_python(name: str, precision: str, wo, wi, u, device=None) -> np.ndarray:
    """The same outputs from clbrdf.Model (width 1)."""
    m = model(name, precision, device=device)
    n, C = len(wo), m.channels
    f = np.asarray(m.eval(wo, wi), np.float64).reshape(n, C)
    pdf = np.asarray(m.pdf(wo, wi), np.float64).reshape(n, 1)
    s_wi, s_w, s_pdf = m.sample(wo, u)
    return np.concatenate([f, pdf, np.asarray(s_wi, np.float64).reshape(n, 3),
                           np.asarray(s_w, np.float64).reshape(n, C),
                           np.asarray(s_pdf, np.float64).reshape(n, 1)], 1)


def columns(channels: int) -> list:
    return ([f"f{c}" for c in range(channels)] + ["pdf", "wi.x", "wi.y", "wi.z"]
            + [f"weight{c}" for c in range(channels)] + ["sample pdf"])


def ulps(got: np.ndarray, want: np.ndarray, channels: int, precision: str) -> dict:
    """Per output column, the largest difference in units of the precision's eps times the
    larger magnitude (values: at least eps x the column's largest; sampled directions: units of
    1, being unit vectors). A sampled wi's z is known to a few eps absolutely (reflect subtracts
    unit vectors), and a weight or density that goes like a power of wi.z near the horizon
    inherits |dz| / z relatively: that part (4 |dz| / z |value|) is not counted."""
    eps = float(np.finfo(np.float32 if precision == "single" else np.float64).eps)
    C = channels
    dz = np.abs(got[:, C + 3] - want[:, C + 3])
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = np.where(dz > 0, 4 * dz / np.maximum(np.abs(want[:, C + 3]), 1e-300), 0.0)
    out = {}
    for j, name in enumerate(columns(C)):
        a, b = got[:, j], want[:, j]
        if not np.all(np.isfinite(a)):
            out[name] = float("inf")
            continue
        if "wi" in name:
            scale = np.ones_like(a)
        else:
            scale = np.maximum(np.maximum(np.abs(a), np.abs(b)), np.max(np.abs(b)) * eps)
        err = np.abs(a - b)
        if name.startswith(("weight", "sample")):
            err = np.maximum(err - cond * np.abs(b), 0)
        out[name] = float(np.max(err / (eps * scale)))
    return out
