"""The C API (kernels/clbrdf.h): compiled as C99, C11 and C++17 (gcc/g++ -Wall -Wextra -Werror
-pedantic), CUDA (nvcc to PTX for sm_75 and sm_90) and OpenCL C (PoCL, 1.2 and 3.0); and the C99
build run against the Python package: for every model the C API serves, in the configurations
below, eval, pdf and sample (with the same uniform numbers) agree with ``clbrdf.Model`` (width 1)
within ULPS units in the last place of the larger magnitude (or of the largest value of the
batch, for values that cancel)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import OCLGRIND_BUILD_OPTIONS

import clbrdf
from clbrdf.studies import capi
from clbrdf.runtime.build import kernel_dir
from clbrdf.runtime.device import compiler_error, list_devices
from clbrdf.models import MODELS

ROOT = Path(__file__).resolve().parents[2]
KERNELS = kernel_dir()
WARN = capi.WARN
# measured: at most 35 (single), 49 (double; Beckmann's pdf, anisotropic GGX's sampled wi.z)
ULPS = {"single": 64, "double": 64}
N = 400
TABLES = [n for n in MODELS if capi.uses_tables(clbrdf.Model(n))]
TABLES_PREFIXES = {MODELS[n].prefix for n in TABLES}


def _have(tool):
    return shutil.which(tool) is not None


def test_generated_header_is_current():
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "gen_capi.py"), "--check"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_every_model_has_a_case():
    assert {c[1] for c in capi.cases()} == set(MODELS)


@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
# double precision in the slow tier (each case is a C build and a kernel build)
@pytest.mark.parametrize("precision", ["single", pytest.param("double", marks=pytest.mark.slow)])
@pytest.mark.parametrize("case", [c[0] for c in capi.cases()])
def test_c99_agrees_with_python(case, precision, tmp_path):
    """The C99 build against the package's kernels; and sample() finite at the edges of u in
    the same build: a Sobol point 0 or rand() / RAND_MAX = 0 made clbrdf_beckmann_sample return
    NaN at u1 = 0 (exp-power and Holzschuch-Pacanowski at u0 = 0)."""
    m = capi.model(case, precision)
    wo, wi, u = capi.inputs(N, m=m)
    ewo, eu = _u_edges()
    got = capi.run_c(case, precision, np.concatenate([wo, ewo]),
                     np.concatenate([wi, ewo * [-1, -1, 1]]), np.concatenate([u, eu]),
                     workdir=tmp_path)
    edges, got = got[N:], got[:N]
    assert np.all(np.isfinite(edges)), edges[~np.all(np.isfinite(edges), axis=1)][:3]
    want = capi.run_python(case, precision, wo, wi, u)
    assert got.shape == want.shape, (got.shape, want.shape)
    worst = capi.ulps(got, want, m.channels, precision)
    assert max(worst.values()) <= ULPS[precision], worst


def _u_edges():
    """(wo, u): zeros and the largest value below 1 in each slot of u, at normal incidence,
    60 degrees and grazing directions."""
    edges = np.array([[a, b, c, d] for a in (0.0, 0.99999994) for b in (0.0, 0.99999994)
                      for c in (0.0, 0.5) for d in (0.0, 0.99999994)])
    wos = np.array([[0.0, 0.0, 1.0], [0.866, 0.0, 0.5], [0.999, 0.0, 0.0447], [0.9998, 0.0, 0.02],
                    [0.3, 0.5, 0.1]])
    wos /= np.linalg.norm(wos, axis=1, keepdims=True)
    return np.repeat(wos, len(edges), 0), np.tile(edges, (len(wos), 1))


def _platforms():
    return [f"{i.platform_index}:{i.device_index}" for i in list_devices()
            if compiler_error((i.platform_index, i.device_index)) is None]


@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
@pytest.mark.parametrize("device", _platforms())
@pytest.mark.parametrize("case", ["ggx-schlick-rgb", "gtr"] + [
    pytest.param(c, marks=pytest.mark.slow)           # each a build per platform
    for c in ("beckmann", "charlie", "holzschuch_pacanowski", "schlick-aniso")])
def test_c_api_on_every_platform(device, case, tmp_path):
    """The C API compiled as OpenCL C in a user's kernel, on every platform present: bit for
    bit the Python package's own kernels at width 1 on the same device (one source), and within
    ULPS of the C99 build (single, and double where the device has fp64): the per-platform
    agreement that docs/kernels.md records (scripts/capi_platforms.py)."""
    from clbrdf.runtime.device import get_device
    precisions = ["single"] + (["double"] if get_device(device).info.has_fp64 else [])
    for precision in precisions:
        m = capi.model(case, precision)
        wo, wi, u = capi.inputs(128, m=m)
        got = capi.run_opencl(case, precision, wo, wi, u, device=device)
        assert np.array_equal(got, capi.run_python(case, precision, wo, wi, u, device=device))
        want = capi.run_c(case, precision, wo, wi, u, workdir=tmp_path)
        worst = capi.ulps(got, want, m.channels, precision)
        assert max(worst.values()) <= ULPS[precision], (precision, worst)


OCLGRIND = """
import sys, numpy as np
from clbrdf import capi
got = capi.run_opencl(sys.argv[1], "single", *capi.inputs(16, m=capi.model(sys.argv[1], "single")),
                      device="oclgrind")
np.save(sys.argv[2], got)
"""


@pytest.mark.slow
@pytest.mark.skipif(not (_have("oclgrind") and _have("gcc")), reason="oclgrind not installed")
@pytest.mark.parametrize("case", ["ggx-schlick-rgb", "gtr", "holzschuch_pacanowski"])
def test_c_api_clean_under_oclgrind(case, tmp_path, oclgrind_serial):
    """The C API in a user's OpenCL kernel under oclgrind (16 inputs): no out-of-bounds access,
    uninitialised read or race reported, and the values agree with the C99 build."""
    out = tmp_path / "got.npy"
    env = dict(os.environ, CLBRDF_BUILD_OPTIONS=OCLGRIND_BUILD_OPTIONS)
    r = subprocess.run(["oclgrind", "--uninitialized", "--data-races",
                        sys.executable, "-c", OCLGRIND, case, str(out)],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    report = [ln for ln in r.stderr.splitlines()
              if any(w in ln for w in ("Invalid", "Uninitialized", "race", "error"))]
    assert not report, "\n".join(report[:20])
    m = capi.model(case, "single")
    want = capi.run_c(case, "single", *capi.inputs(16, m=m), workdir=tmp_path)
    worst = capi.ulps(np.load(out), want, m.channels, "single")
    assert max(worst.values()) <= ULPS["single"], worst


@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
@pytest.mark.parametrize("compiler, std", [("gcc", "c99"), ("gcc", "c11"), ("g++", "c++17")])
@pytest.mark.parametrize("precision", ["0", "1"])
@pytest.mark.parametrize("dist", ["ggx", "gtr"] + [pytest.param(d, marks=pytest.mark.slow)
                                                    for d in ("beckmann", "sgd", "exppow")])
def test_c_api_compiles_warning_free(compiler, std, precision, dist, tmp_path):
    """Every model of the C API in one translation unit (the microfacet one chosen by MF_DIST),
    RGB, with non-default configurations, under -Wall -Wextra -Werror -pedantic."""
    ext = "cpp" if compiler == "g++" else "c"
    src = tmp_path / f"all.{ext}"
    calls = []
    def on(s):          # the distribution of a model on the microfacet distributions, or None
        return dict(s.configure()[0].defines).get("MF_DIST")
    models = [n for n, s in MODELS.items() if on(s) in (None, dist)]
    for model in models:
        set_t = " p.tables = T;" if on(MODELS[model]) or MODELS[model].prefix in TABLES_PREFIXES \
            else ""
        calls.append(f"    {{ clbrdf_{model}_params p = clbrdf_{model}_defaults();{set_t}"
                     f" spec f = clbrdf_{model}_eval(&p, wo, wi);"
                     f" BSample s = clbrdf_{model}_sample(&p, wo, clbrdf_random(1, 2, 3, 4));"
                     f" sum += f.c[0] + s.weight.c[2] + clbrdf_{model}_pdf(&p, wo, wi); }}")
    src.write_text("#include <stdio.h>\n#include \"clbrdf.h\"\n#include \"clbrdf_tables.h\"\n"
                   + ("using namespace clbrdf;\n" if ext == "cpp" else "")
                   + "int main(void)\n{\n    vec3 wo = v3(0.6f, 0.0f, 0.8f), wi = v3(-0.6f, 0.0f, 0.8f);\n"
                   f"    float *T = clbrdf_tables_load(\"{KERNELS / 'data'}\");\n"
                   "    if (!T) return 1;\n"
                   "    double sum = 0;\n"
                   "    int W = 1, sel = 2, CAT = 3, clamp = 4, rsqrt = 5, global = 6;  /* the user's names */\n"
                   "    sum += W + sel + CAT + clamp + rsqrt + global;\n" + "\n".join(calls)
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


@pytest.mark.parametrize("std", ["CL1.2", "CL3.0"])
def test_c_api_as_opencl_c(std):
    """clbrdf.h in a user's own OpenCL kernel on the default device (clbrdf.studies.capi.run_opencl):
    GGX's value equals the Python package's at width 1 to 4 ulps."""
    wo, wi, u = capi.inputs(256, seed=1)
    out = capi.run_opencl("ggx", "single", wo, wi, u, std=std)[:, 0]
    want = clbrdf.Model("ggx", alpha=0.3, width=1).eval(wo, wi)
    eps = float(np.finfo(np.float32).eps)
    ulps = np.abs(out - want) / (eps * np.maximum(np.abs(want), np.max(np.abs(want)) * eps))
    assert ulps.max() <= 4, ulps.max()


@pytest.mark.slow       # the default run has it with the installed wheel (tests/test_wheel.py)
@pytest.mark.skipif(not _have("gcc"), reason="gcc not found")
def test_examples_run_and_agree_with_python():
    """bash examples/run.sh: the C99 and OpenCL albedo programs draw the Python package's samples
    (clbrdf_random2) and agree with `clbrdf albedo` to 1e-5 relative; the energy-compensation
    example's lookup equals clbrdf.Table.lookup."""
    env = dict(os.environ, CLBRDF_PYTHON=sys.executable)
    r = subprocess.run(["bash", str(ROOT / "examples" / "run.sh")], capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = {ln.split()[0]: ln for ln in r.stdout.splitlines() if ln and not ln.startswith(" ")}
    assert "agree" in lines["c99_albedo"] and "agree" in lines["energy_compensation"], r.stdout
    if Path("/usr/include/CL/cl.h").exists():
        assert "agree" in lines["opencl_albedo"], r.stdout
    if _have("nvcc"):               # built here; run (and compared) where a CUDA device answers
        assert "built; not run" in lines["cuda_albedo"] or "agree" in lines["cuda_albedo"], \
            r.stdout

