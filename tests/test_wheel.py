"""The package as a user installs it: an sdist and a wheel built by ``python -m build``, the wheel
installed (not editable) into a fresh virtual environment and run from outside the checkout:
every command, ``Table.load`` of every file written, and the C example built against the
installed headers (``clbrdf --include``). The new environment's dependencies are this one's
(a path entry, without this environment's editable clbrdf), so no download but the build's."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd, **kw):
    r = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=600, **kw)
    assert r.returncode == 0, (cmd, r.stdout[-2000:], r.stderr[-2000:])
    return r


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(python, clbrdf, work directory) of a fresh venv with the built wheel."""
    if shutil.which("git") is None:
        pytest.skip("needs git to copy the checkout")
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"          # the tracked and untracked files, as a clean clone would have
    files = _run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT).stdout.split()
    for f in files:
        if (ROOT / f).is_file():
            (src / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / f, src / f)
    try:
        import build  # noqa: F401
    except ImportError:
        pytest.skip("needs the build package (pip install build)")
    _run([sys.executable, "-m", "build", "--outdir", tmp / "dist", src])
    dist = sorted(p.name for p in (tmp / "dist").iterdir())
    assert any(n.endswith(".tar.gz") for n in dist) and any(n.endswith(".whl") for n in dist), dist
    env_dir = tmp / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    py = env_dir / "bin" / "python"
    site = Path(_run([py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]
                     ).stdout.strip())
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    wheel = next((tmp / "dist").glob("*.whl"))
    _run([py, "-m", "pip", "install", "-q", "--no-deps", "--no-index", wheel])
    work = tmp / "work"
    work.mkdir()
    return py, env_dir / "bin" / "clbrdf", work


def test_the_installed_package_is_the_wheel(installed):
    py, _, work = installed
    where = _run([py, "-c", "import clbrdf; print(clbrdf.__file__, clbrdf.__version__)"],
                 cwd=work).stdout.split()
    assert Path(where[0]).is_relative_to(work.parent / "venv"), where
    # the version is one fact: the wheel's metadata reads clbrdf/version.py
    meta = _run([py, "-c", "import importlib.metadata as m; print(m.version('clbrdf'))"],
                cwd=work).stdout.strip()
    assert meta == where[1]


def test_every_command_runs_from_the_wheel(installed):
    py, clbrdf, work = installed
    _run([clbrdf, "models"], cwd=work)
    _run([clbrdf, "layouts"], cwd=work)
    r = _run([clbrdf, "albedo", "gtr", "--mu", "0.5", "--samples", "4096", "--json"], cwd=work)
    assert 0 < json.loads(r.stdout)["albedo"][0] < 1
    _run([clbrdf, "check", "lambert", "--samples", "4096"], cwd=work)
    outs = [work / f"t{s}" for s in (".npz", ".csv", ".h", ".exr")]
    _run([clbrdf, "table", "ggx", "--axis", "mu=0.2:1:3", "--axis", "alpha=0.1:0.5:2",
          "--samples", "256"] + [a for o in outs for a in ("--out", o)], cwd=work)
    lay = [work / f"ue5{s}" for s in (".npz", ".csv", ".h", ".exr")]
    _run([clbrdf, "table", "--layout", "ue5", "--samples", "64"]
         + [a for o in lay for a in ("--out", o)], cwd=work)
    _run([clbrdf, "furnace", work / "ue5.npz", "--samples", "4096"], cwd=work)
    _run([clbrdf, "sweep", "ggx", "--axis", "alpha=0.1:1:3", "--samples", "64", "--out",
          work / "s.zarr", "-q"], cwd=work)
    _run([clbrdf, "report", work / "s.zarr", "--out", work / "report"], cwd=work)
    r = _run([clbrdf, "ltc", "--help"], cwd=work)          # the LTC layouts' data file ships
    assert "threejs" in r.stdout
    ltc = [work / f"ltc{s}" for s in (".npz", ".h")]
    _run([clbrdf, "ltc", "charlie", "--axis", "sqrt1m_mu=0:0.9:3", "--axis", "alpha=0.2:1:2",
          "--samples", "256", "--report-samples", "4096"]
         + [a for o in ltc for a in ("--out", o)], cwd=work)
    outs.append(ltc[0])
    # Table.load reads every file written, and the plain table looks up
    code = ("import sys, clbrdf\n"
            "for p in sys.argv[1:]:\n"
            "    for t in clbrdf.load_tables(p).values():\n"
            "        assert t.values.size, p\n"
            "t = clbrdf.Table.load(sys.argv[1])\n"
            "print(float(t.lookup(mu=0.6, alpha=0.3)))\n")
    r = _run([py, "-c", code] + [o for o in outs + lay if o.suffix != ".h"], cwd=work)
    assert 0 < float(r.stdout) < 1


def test_examples_build_against_the_installed_headers(installed):
    """examples/run.sh with the wheel's Python: the C, OpenCL and CUDA examples compiled with
    -I$(clbrdf --include), each result against the installed package's."""
    py, clbrdf, work = installed
    if shutil.which("gcc") is None:
        pytest.skip("no gcc")
    inc = _run([clbrdf, "--include"], cwd=work).stdout.strip()
    assert Path(inc, "clbrdf.h").is_file() and Path(inc).is_relative_to(work.parent / "venv")
    r = _run(["bash", ROOT / "examples" / "run.sh"], env={**os.environ, "CLBRDF_PYTHON": str(py)})
    lines = {ln.split()[0]: ln for ln in r.stdout.splitlines() if ln and not ln.startswith(" ")}
    assert "agree" in lines["c99_albedo"] and "agree" in lines["energy_compensation"], r.stdout
    if Path("/usr/include/CL/cl.h").exists():
        assert "agree" in lines["opencl_albedo"], r.stdout
    if shutil.which("nvcc"):        # built here; run (and compared) where a CUDA device answers
        assert "built; not run" in lines["cuda_albedo"] or "agree" in lines["cuda_albedo"], \
            r.stdout
    assert "DISAGREE" not in r.stdout, r.stdout
