"""The GPU check (scripts/gpu_check/) as far as a CPU machine allows: the bundle, the test
program over the C API and the CUDA benchmark built by g++ from the same sources (the script's
CPU backend) and compared by the report writer with the Python package's values; a wrong value
is reported and fails the run; a missing tool stops it at once, saying what; the sources compile
as CUDA with nvcc (to PTX and a binary, where nvcc is); the report's arithmetic of the
physical limit. The slow test carries the wheels for this Python and installs from them
offline, then runs the package through OpenCL (PoCL standing in for NVIDIA's driver)."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
GC = ROOT / "scripts" / "gpu_check"
sys.path.insert(0, str(GC))
import report  # noqa: E402


def _bundle(out: Path, *extra):
    subprocess.run([sys.executable, str(GC / "make_bundle.py"), "--out", str(out), "--cases",
                    "ggx-aniso-conductor,lambert-rgb", "--cycles-samples", "4096", *extra],
                   check=True, capture_output=True, text=True)
    return out


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    return _bundle(tmp_path_factory.mktemp("gc") / "bundle", "--no-wheels", "--no-checks")


def _run(bundle, out, env=None, **kw):
    e = {**os.environ, "PYTHON": sys.executable, "CLBRDF_GPU_CHECK_BACKEND": "cpu",
         "CLBRDF_GPU_CHECK_OPENCL": "skip", "CLBRDF_GPU_CHECK_NO_INSTALL": "1", **(env or {})}
    return subprocess.run(["bash", str(bundle / "gpu_check.sh"), str(out)], env=e,
                          capture_output=True, text=True, timeout=600, **kw)


@pytest.mark.skipif(shutil.which("g++") is None, reason="g++ not found")
def test_cpu_backend_agrees_and_reports(bundle, tmp_path):
    r = _run(bundle, tmp_path / "out")
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert {(c["case"], c["precision"]) for c in rep["capi"]} == {
        (c, p) for c in ("ggx-aniso-conductor", "lambert-rgb") for p in ("single", "double")}
    for c in rep["capi"]:
        assert c["status"] == "agree" and c["ulps"] <= c["bound"], c
        assert c["albedo_ulps"] <= c["bound"], c
    cy = rep["bench"]["cycles"]
    assert cy["status"] == "agree" and cy["cells"] == 1024 and cy["max_rel_diff"] <= 1e-5
    assert rep["bench"]["rate"]["samples_per_s"] > 0
    assert 0.9 < rep["bench"]["rate"]["E"][0] < 1          # GGX alpha 0.5, F = 1, grazing
    assert rep["failures"] == []
    md = (tmp_path / "out" / "report.md").read_text()
    assert "every check that ran passed" in md and "opencl" in md.lower()


@pytest.mark.skipif(shutil.which("g++") is None, reason="g++ not found")
def test_a_wrong_value_fails_the_run(bundle, tmp_path):
    """One expected f changed by 1e-4 relative (about 840 eps in single): DISAGREE, exit 1."""
    b = tmp_path / "b"
    shutil.copytree(bundle, b)
    p = b / "cases" / "ggx-aniso-conductor-single" / "expected.txt"
    x = np.loadtxt(p)
    x[17, 0] *= 1 + 1e-4
    np.savetxt(p, x, fmt="%.17g")
    r = _run(b, tmp_path / "out")
    assert r.returncode == 1
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    bad = [c for c in rep["capi"] if c["status"] != "agree"]
    assert [(c["case"], c["precision"], c["worst"]) for c in bad] == [
        ("ggx-aniso-conductor", "single", "f0")]
    assert "capi ggx-aniso-conductor single: DISAGREE" in rep["failures"]


@pytest.mark.parametrize("what, env, msg", [
    ("nvidia-smi", {"CLBRDF_GPU_CHECK_BACKEND": "cuda", "NVCC": "true"}, "nvidia-smi"),
    ("nvcc", {"CLBRDF_GPU_CHECK_BACKEND": "cuda", "NVCC": "/nonexistent/nvcc"}, "nvcc"),
    ("wheels", {"CLBRDF_GPU_CHECK_NO_INSTALL": "0"}, "wheels/"),
    ("python", {"PYTHON": "/nonexistent/python3"}, "python")])
def test_missing_tools_stop_it_early(bundle, tmp_path, what, env, msg):
    e = dict(env)
    if what == "nvidia-smi":                    # a PATH with bash and python but no nvidia-smi
        bindir = tmp_path / "bin"
        bindir.mkdir()
        for tool in ("bash", "env", "dirname", "mkdir", "date", "nproc", "head", "tail", "cat"):
            if shutil.which(tool):
                os.symlink(shutil.which(tool), bindir / tool)
        e["PATH"] = str(bindir)
    r = _run(bundle, tmp_path / "out", env=e)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert "MISSING" in r.stderr and msg in r.stderr, r.stderr
    assert not (tmp_path / "out" / "cases").exists()          # before any work


@pytest.mark.skipif(shutil.which("nvcc") is None, reason="nvcc not found")
def test_sources_compile_as_cuda(bundle, tmp_path):
    """capi_check.cu for both cases and precisions and bench_cuda.cu build with nvcc for
    sm_90 (the H100 / H200); the PTX counter finds the sample loop's arithmetic."""
    inc = bundle / "include"
    for d in sorted((bundle / "cases").iterdir()):
        r = subprocess.run(["nvcc", "-std=c++17", "-O2", "-arch=sm_90",
                            *(d / "defines").read_text().split(), "-I", str(inc), "-I", str(d),
                            "-x", "cu", str(bundle / "capi_check.cu"), "-o", str(tmp_path / d.name)],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr[-3000:]
    ptx = tmp_path / "bench.ptx"
    r = subprocess.run(["nvcc", "-std=c++17", "-O2", "-arch=sm_90",
                        *(bundle / "cycles" / "defines").read_text().split(), "-I", str(inc),
                        "-ptx", "-x", "cu", str(bundle / "bench_cuda.cu"), "-o", str(ptx)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-3000:]
    c = report.ptx_counts(ptx)
    # GGX's VNDF sample: dozens of FP32 operations; Philox4x32-10 (one call per two samples):
    # 10 rounds of two 32 x 32 -> 64-bit multiplies and xors
    assert c["fp32"] > 50 and c["int"] > 60 and c["mufu"] >= 1, c


def test_ptx_counts_and_the_physical_limit(tmp_path):
    ptx = tmp_path / "k.ptx"
    ptx.write_text("""
.visible .entry other(
)
{
	add.f32 	%f1, %f2, %f3;
}
.visible .entry _Z11sums_kernelPKfS0_jjPf(
)
{
	fma.rn.f32 	%f1, %f2, %f3, %f4;
	@%p1 add.f32 	%f1, %f2, %f3;
	sqrt.rn.f32 	%f5, %f6;
	ex2.approx.ftz.f32 	%f7, %f8;
	mul.wide.u32 	%rd1, %r1, %r2;
	xor.b32 	%r3, %r4, %r5;
	xor.b64 	%rd2, %rd3, %rd4;
	ld.global.f32 	%f9, [%rd5];
	bra.uni 	$L__BB0_1;
}
""")
    # fma, add: 2; sqrt.rn: 7 FP32 + 1 MUFU; ex2.approx: 1 MUFU; mul.wide 2, xor.b32 1, xor.b64 2
    assert report.ptx_counts(ptx) == {"fp32": 9, "mufu": 2, "int": 5}
    rate = {"sm": 132, "clock_khz": 1980000, "cc": 9, "samples_per_s": 50e9}
    note = report.physical_note({"fp32": 150, "mufu": 8, "int": 250}, rate)
    # FP32: 128 x 132 x 1.98e9 / 150 = 223 G/s; MUFU: 16 x ... / 8 = 523; INT32: 64 x ... / 250
    # = 67: the integer work bounds it, and 50 G/s is 75 % of it
    assert "INT32's 67 G samples/s" in note and "measured 75% of it" in note, note
    assert "FP32 33.5 T instr/s" in note


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("g++") is None, reason="g++ not found")
def test_offline_install_from_the_carried_wheels_and_opencl_step(tmp_path):
    """The bundle with wheels for this Python (downloaded from PyPI here), installed offline
    by the script (pip --no-index), and step 2 on PoCL: the battery's GGX cases, clbrdf check
    with the CPU's verdicts, bench_albedo.py --quick."""
    v = f"{sys.version_info.major}.{sys.version_info.minor}"
    b = _bundle(tmp_path / "bundle", "--python", v)
    assert list((b / "wheels").glob("clbrdf-*.whl")) and list((b / "wheels").glob("pyopencl-*"))
    r = _run(b, tmp_path / "out", env={"CLBRDF_GPU_CHECK_NO_INSTALL": "0",
                                        "CLBRDF_GPU_CHECK_OPENCL": "any",
                                        "CLBRDF_GPU_CHECK_QUICK": "1", "PIP_NO_INDEX": "1"})
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    rep = json.loads((tmp_path / "out" / "report.json").read_text())
    assert rep["opencl"]["conformance"]["rc"] == 0
    assert all(c["status"] == "same verdicts" for c in rep["opencl"]["check"].values())
    assert (tmp_path / "out" / "site" / "clbrdf").is_dir()
