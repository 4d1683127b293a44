"""The C API (kernels/clbrdf.h): compiled as C99, C11 and C++17 (gcc/g++ -Wall -Wextra -Werror
-pedantic), CUDA (nvcc to PTX for sm_75 and sm_90) and OpenCL C (PoCL, 1.2 and 3.0); and the C99
build run against the Python package: for every model the C API serves, in the configurations
below, eval, pdf and sample (with the same uniform numbers) agree with ``clbrdf.Model`` (width 1)
within ULPS units in the last place of the larger magnitude (or of the largest value of the
batch, for values that cancel)."""
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import clbrdf
import clbrdf.build
import clbrdf.models
from clbrdf.build import kernel_dir

ROOT = Path(__file__).resolve().parent.parent
KERNELS = kernel_dir()
WARN = ["-Wall", "-Wextra", "-Wno-unused-parameter", "-Werror", "-pedantic"]
# (case name, model, Python keywords): the C build gets the Python configuration's defines
CASES = [
    ("lambert", "lambert", {}),
    ("lambert-rgb", "lambert", {"kd": [0.2, 0.5, 0.9], "channels": 3}),
    ("ggx", "ggx", {"alpha": 0.3}),
    ("ggx-schlick-rgb", "ggx", {"alpha": 0.15, "f0": [0.9, 0.6, 0.3], "channels": 3}),
    ("ggx-aniso-conductor", "ggx", {"alpha_x": 0.05, "alpha_y": 0.4, "eta": 0.2, "k": 3.0}),
    ("ggx-dielectric-diffuse", "ggx", {"alpha": 0.5, "eta": 1.5, "kd": 0.3}),
    ("ggx-separable-ndf", "ggx", {"alpha": 0.2, "masking": "separable", "sampler": "ndf"}),
    ("beckmann", "beckmann", {"alpha": 0.25}),
    ("beckmann-vcavity", "beckmann", {"alpha": 0.6, "masking": "vcavity", "f0": 0.5}),
    ("ashikhmin_shirley", "ashikhmin_shirley", {"nu": 20.0, "nv": 200.0, "rs": 0.3, "rd": 0.4}),
    ("charlie", "charlie", {"alpha": 0.4}),
    ("charlie-ashikhmin", "charlie", {"alpha": 0.2, "visibility": "ashikhmin"}),
    ("low_smooth", "low_smooth", {}),
    ("low_microfacet", "low_microfacet", {}),
    ("schlick", "schlick", {}),
    ("schlick-aniso", "schlick", {"p": 0.2, "psi": 0.5}),
    ("ward", "ward", {"alpha_x": 0.1, "alpha_y": 0.3, "kd": 0.2}),
    # models that read the generated tables (clbrdf_tables.h loads them)
    ("gtr", "gtr", {"alpha": 0.3, "gamma": 1.5}),
    ("sgd", "sgd", {"alpha": 0.2, "p": 0.8}),
    ("exppow", "exppow", {"alpha": 0.3, "p": 0.7, "f0": 0.2}),
    ("holzschuch_pacanowski", "holzschuch_pacanowski", {}),
    ("sgd_bagher", "sgd_bagher", {}),
]
TABLES = [n for n, s in clbrdf.models.MODELS.items()
          if clbrdf.build.program_source(s.configure(channels=1)[0], "single", 1)[1]]
ULPS = {"single": 64, "double": 64}   # measured: at most 35 (single), 49 (double; Beckmann pdf,
                                      # anisotropic GGX sampled wi.z)
N = 400

PROGRAM = r"""
#include <stdio.h>
#include "clbrdf.h"
#include "clbrdf_tables.h"
int main(void)
{
    clbrdf_%(prefix)s_params p = clbrdf_%(model)s_defaults();
%(assign)s
    double a[10];
    while (scanf("%%lf %%lf %%lf %%lf %%lf %%lf %%lf %%lf %%lf %%lf", a, a + 1, a + 2, a + 3, a + 4,
                 a + 5, a + 6, a + 7, a + 8, a + 9) == 10) {
        vec3 wo = v3((real_t)a[0], (real_t)a[1], (real_t)a[2]);
        vec3 wi = v3((real_t)a[3], (real_t)a[4], (real_t)a[5]);
        rand4 u = {(real_t)a[6], (real_t)a[7], (real_t)a[8], (real_t)a[9]};
        spec f = clbrdf_%(model)s_eval(&p, wo, wi);
        real_t pdf = clbrdf_%(model)s_pdf(&p, wo, wi);
        BSample s = clbrdf_%(model)s_sample(&p, wo, u);
        for (int c = 0; c < CHANNELS; ++c) printf("%%.17g ", (double)f.c[c]);
        printf("%%.17g %%.17g %%.17g %%.17g ", (double)pdf, (double)s.wi.x, (double)s.wi.y,
               (double)s.wi.z);
        for (int c = 0; c < CHANNELS; ++c) printf("%%.17g ", (double)s.weight.c[c]);
        printf("%%.17g\n", (double)s.pdf);
    }
    return 0;
}
"""


def _have(tool):
    return shutil.which(tool) is not None


def _assign(m) -> str:
    lines = []
    if m.name in TABLES:
        lines.append(f'    p.tables = clbrdf_tables_load("{KERNELS / "data"}");\n'
                     f'    if (!p.tables) return 1;')
    for k, v in m.params.items():
        v = np.asarray(v, np.float64)
        if k in m.config.spectral:
            vals = np.broadcast_to(v, (m.channels,))
            lines += [f"    p.{k}[{c}] = (real_t){float(x)!r};" for c, x in enumerate(vals)]
        else:
            lines.append(f"    p.{k} = (real_t){float(v)!r};")
    return "\n".join(lines)


def _defines(m, precision) -> list:
    return ([f"-D{k}={v}" for k, v in m.config.defines] + [f"-DCHANNELS={m.channels}",
            f"-DCLBRDF_DOUBLE={int(precision == 'double')}"])


def _directions(rng, n):
    """Unit wo, wi above the horizon: uniform, grazing (mu down to 1e-4) and mirror pairs."""
    def hemi(k, lo=0.0):
        mu = rng.uniform(lo, 1, k)
        mu[: k // 4] = 10 ** rng.uniform(-4, -1, k // 4)
        phi = rng.uniform(0, 2 * np.pi, k)
        s = np.sqrt(1 - mu * mu)
        return np.stack([s * np.cos(phi), s * np.sin(phi), mu], -1)
    wo, wi = hemi(n), hemi(n)
    wi[: n // 8] = wo[: n // 8] * [-1, -1, 1]           # mirror pairs
    return wo, wi


def test_generated_header_is_current():
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "gen_capi.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("case", [c[0] for c in CASES])
def test_c99_agrees_with_python(case, precision, tmp_path):
    _, model, kw = next(c for c in CASES if c[0] == case)
    m = clbrdf.Model(model, precision=precision, width=1, **kw)
    src = tmp_path / "t.c"
    src.write_text(PROGRAM % {"prefix": m.spec.prefix, "model": model, "assign": _assign(m)})
    exe = tmp_path / "t"
    r = subprocess.run(["gcc", "-std=c99", *WARN, "-O2", f"-I{KERNELS}", *_defines(m, precision),
                        str(src), "-lm", "-o", str(exe)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    rng = np.random.default_rng(7)
    wo, wi = _directions(rng, N)
    u = m.random(N, seed=3)
    dt = np.float32 if precision == "single" else np.float64
    # the inputs as the C program reads them: rounded to the precision, then printed exactly
    wo, wi, u = (np.asarray(x, dt).astype(np.float64) for x in (wo, wi, u))
    text = "\n".join(" ".join(repr(float(x)) for x in row)
                     for row in np.concatenate([wo, wi, u], 1))
    out = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
    got = np.array([[float(x) for x in line.split()] for line in out.stdout.splitlines()])
    C = m.channels
    f_py = np.asarray(m.eval(wo, wi), np.float64).reshape(N, C)
    pdf_py = np.asarray(m.pdf(wo, wi), np.float64).reshape(N)
    s_wi, s_w, s_pdf = m.sample(wo, u)
    s_wi = np.asarray(s_wi, np.float64).reshape(N, 3)
    want = np.concatenate([f_py, pdf_py[:, None], s_wi, np.asarray(s_w, np.float64).reshape(N, C),
                           np.asarray(s_pdf, np.float64).reshape(N, 1)], 1)
    # a sampled wi is a difference of unit vectors (reflect): its z is known to a few eps
    # absolutely, and a weight or density that goes like a power of wi.z near the horizon
    # (G1(wi), the cosine lobe) inherits |dz| / z relatively: that much more is allowed there
    dz = np.abs(got[:, C + 3] - s_wi[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = np.where(dz > 0, 4 * dz / np.maximum(np.abs(s_wi[:, 2]), 1e-300), 0.0)
    assert got.shape == want.shape, (got.shape, want.shape)
    eps = float(np.finfo(dt).eps)
    names = [f"f{c}" for c in range(C)] + ["pdf", "wi.x", "wi.y", "wi.z"] + \
        [f"weight{c}" for c in range(C)] + ["sample pdf"]
    worst = {}
    for j, name in enumerate(names):
        a, b = got[:, j], want[:, j]
        assert np.all(np.isfinite(a)), name
        scale = np.maximum(np.maximum(np.abs(a), np.abs(b)),
                           np.max(np.abs(b)) * (eps if "wi" not in name else 1.0))
        if "wi" in name:                # unit vectors: units of 1
            scale = np.ones_like(scale)
        err = np.abs(a - b)
        if name.startswith(("weight", "sample")):
            err = np.maximum(err - cond * np.abs(b), 0)
        ulps = err / (eps * scale)
        worst[name] = float(ulps.max())
    assert max(worst.values()) <= ULPS[precision], worst


@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
@pytest.mark.parametrize("compiler, std", [("gcc", "c99"), ("gcc", "c11"), ("g++", "c++17")])
@pytest.mark.parametrize("precision", ["0", "1"])
@pytest.mark.parametrize("dist", ["ggx", "beckmann", "gtr", "sgd", "exppow"])
def test_c_api_compiles_warning_free(compiler, std, precision, dist, tmp_path):
    """Every model of the C API in one translation unit (the microfacet one chosen by MF_DIST),
    RGB, with non-default configurations, under -Wall -Wextra -Werror -pedantic."""
    ext = "cpp" if compiler == "g++" else "c"
    src = tmp_path / f"all.{ext}"
    calls = []
    others = [n for n, s in clbrdf.models.MODELS.items() if s.prefix != "microfacet"]
    with_tables = {clbrdf.models.MODELS[n].prefix for n in TABLES}
    for model in [dist] + others:
        set_t = " p.tables = T;" if clbrdf.models.MODELS[model].prefix in with_tables else ""
        calls.append(f"    {{ clbrdf_{model}_params p = clbrdf_{model}_defaults();{set_t}"
                     f" spec f = clbrdf_{model}_eval(&p, wo, wi);"
                     f" BSample s = clbrdf_{model}_sample(&p, wo, clbrdf_random(1, 2, 3, 4));"
                     f" sum += f.c[0] + s.weight.c[2] + clbrdf_{model}_pdf(&p, wo, wi); }}")
    src.write_text("#include <stdio.h>\n#include \"clbrdf.h\"\n#include \"clbrdf_tables.h\"\n"
                   + ("using namespace clbrdf;\n" if ext == "cpp" else "")
                   + "int main(void)\n{\n    vec3 wo = v3(0.6f, 0.0f, 0.8f), wi = v3(-0.6f, 0.0f, 0.8f);\n"
                   f"    float *T = clbrdf_tables_load(\"{KERNELS / 'data'}\");\n"
                   "    if (!T) return 1;\n"
                   "    double sum = 0;\n" + "\n".join(calls)
                   + "\n    printf(\"%g\\n\", sum);\n    free(T);\n    return 0;\n}\n")
    exe = tmp_path / "all"
    r = subprocess.run([compiler, f"-std={std}", *WARN, "-O2", f"-I{KERNELS}", "-DCHANNELS=3",
                        f"-DMF_DIST={dist}",
                        f"-DCLBRDF_DOUBLE={precision}", "-DMF_FRESNEL=FRESNEL_SCHLICK",
                        "-DMF_DIFFUSE=1", "-DAS_FRESNEL=1", str(src), "-lm", "-o", str(exe)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True)
    assert np.isfinite(float(out.stdout))


CUDA = r"""
#include "clbrdf.h"
__global__ void ggx_albedo(float alpha, float mu, unsigned n, float *out)
{
    unsigned i = blockIdx.x * blockDim.x + threadIdx.x;
    clbrdf::clbrdf_ggx_params p = clbrdf::clbrdf_ggx_defaults();
    p.alpha = alpha;
    clbrdf::vec3 wo = clbrdf::v3(sqrtf(1 - mu * mu), 0.0f, mu);
    float sum = 0;
    for (unsigned k = 0; k < n; ++k)
        sum += clbrdf::clbrdf_ggx_sample(&p, wo, clbrdf::clbrdf_random(k, i, 0, 1)).weight.c[0];
    clbrdf::clbrdf_charlie_params q = clbrdf::clbrdf_charlie_defaults();
    out[i] = sum / n + clbrdf::clbrdf_charlie_eval(&q, wo, wo).c[0];
}
"""


@pytest.mark.skipif(not _have("nvcc"), reason="nvcc not found")
@pytest.mark.parametrize("arch", ["sm_75", "sm_90"])
@pytest.mark.parametrize("precision", ["0", "1"])
def test_c_api_compiles_for_cuda(arch, precision, tmp_path):
    src = tmp_path / "k.cu"
    src.write_text(CUDA)
    out = tmp_path / "k.ptx"
    r = subprocess.run(["nvcc", "-std=c++17", f"-arch={arch}", "-ptx", "-Werror", "all-warnings",
                        f"-I{KERNELS}", f"-DCLBRDF_DOUBLE={precision}", str(src), "-o", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert ".entry" in out.read_text() and "ggx_albedo" in out.read_text()


OPENCL = r"""
#include "clbrdf.h"
kernel void ggx_eval(global const float *in, global float *out)
{
    size_t i = get_global_id(0);
    clbrdf_ggx_params p = clbrdf_ggx_defaults();
    p.alpha = 0.3f;
    vec3 wo = v3(in[6 * i], in[6 * i + 1], in[6 * i + 2]);
    vec3 wi = v3(in[6 * i + 3], in[6 * i + 4], in[6 * i + 5]);
    out[i] = clbrdf_ggx_eval(&p, wo, wi).c[0];
}
"""


@pytest.mark.parametrize("std", ["CL1.2", "CL3.0"])
def test_c_api_as_opencl_c(std):
    """clbrdf.h in a user's own OpenCL kernel on the default device: GGX's value equals the
    Python package's at width 1 to 4 ulps."""
    import pyopencl as cl
    dev = clbrdf.get_device()
    prg = cl.Program(dev.context, OPENCL).build(options=[f"-cl-std={std}", "-I", str(KERNELS)])
    wo, wi = _directions(np.random.default_rng(1), 256)
    buf = np.concatenate([wo, wi], 1).astype(np.float32)
    mf = cl.mem_flags
    b_in = cl.Buffer(dev.context, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=buf)
    out = np.empty(256, np.float32)
    b_out = cl.Buffer(dev.context, mf.WRITE_ONLY, out.nbytes)
    prg.ggx_eval(dev.queue, (256,), None, b_in, b_out)
    cl.enqueue_copy(dev.queue, out, b_out)
    want = clbrdf.Model("ggx", alpha=0.3, width=1).eval(buf[:, :3].astype(np.float64),
                                                          buf[:, 3:].astype(np.float64))
    eps = float(np.finfo(np.float32).eps)
    ulps = np.abs(out - want) / (eps * np.maximum(np.abs(want), np.max(np.abs(want)) * eps))
    assert ulps.max() <= 4, ulps.max()


@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
def test_examples_run_and_agree_with_python():
    """bash examples/run.sh: the C99 and OpenCL albedo programs draw the Python package's samples
    (clbrdf_random2) and agree with `clbrdf albedo` to 1e-5 relative; the energy-compensation
    example's lookup equals clbrdf.Table.lookup."""
    env = dict(__import__("os").environ, CLBRDF_PYTHON=sys.executable)
    r = subprocess.run(["bash", str(ROOT / "examples" / "run.sh")], capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = {ln.split()[0]: ln for ln in r.stdout.splitlines() if ln and not ln.startswith(" ")}
    assert "agree" in lines["c99_albedo"] and "agree" in lines["energy_compensation"], r.stdout
    if Path("/usr/include/CL/cl.h").exists():
        assert "agree" in lines["opencl_albedo"], r.stdout
