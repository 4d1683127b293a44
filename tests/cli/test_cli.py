"""The command line interface, run as a subprocess (python -m clbrdf.cli); the bad-input cases in
the test process (tests/cliutil.py), with one of them also as a subprocess."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import clbrdf

from clbrdf.ref import microfacet as R
from cliutil import run_inprocess

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def cli(*args, cwd=None, env=None):
    env = dict(os.environ, **(env or {}))
    env.pop("CLBRDF_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "clbrdf.cli", *map(str, args)], cwd=cwd,
                          env=env, capture_output=True, text=True, timeout=300)


def ok(*args, **kw):
    r = cli(*args, **kw)
    assert r.returncode == 0, f"clbrdf {' '.join(map(str, args))} failed:\n{r.stderr}"
    return r


@pytest.fixture(scope="module", autouse=True)
def device():
    """Skip (not fail) the module where there is no working OpenCL device at all."""
    import clbrdf
    try:
        clbrdf.get_device()
    except clbrdf.DeviceError as e:
        pytest.skip(f"no OpenCL device: {e}")


# ---------------------------------------------------------------------------------------------
# devices, models

def test_devices():
    r = ok("devices")
    assert "default" in r.stdout
    assert "<- default" in r.stdout
    assert "0:0" in r.stdout or ":0" in r.stdout
    d = json.loads(ok("devices", "--json").stdout)
    assert d["default"] is not None
    default = [x for x in d["devices"] if x["default"]]
    assert len(default) == 1 and default[0]["compiler_ok"]
    assert {"selector", "fp64", "compiler_ok", "name", "platform"} <= set(default[0])


def test_models():
    out = ok("models").stdout
    for word in ("lambert", "ggx", "beckmann", "alpha", "[0.0001, 10]", "(0, 100]", "masking",
                 "vcavity", "conductor", "default"):
        assert word in out, word
    d = json.loads(ok("models", "--json").stdout)
    assert d["ggx"]["params"]["alpha"]["default"] == 0.5
    assert "vcavity" in d["ggx"]["options"]["masking"]["choices"]


# ---------------------------------------------------------------------------------------------
# eval

@pytest.mark.parametrize("model,params,wi,wo", [
    ("beckmann", {"alpha": 0.5, "masking": "vcavity", "fresnel": "schlick", "f0": 0.2},
     (0.6, 0.0, 0.8), (-0.36, 0.48, 0.8)),
    # each a process and a kernel build: the others in the slow tier
    pytest.param("ggx", {"alpha": 0.3}, (0.0, 0.6, 0.8), (0.0, 0.0, 1.0), marks=pytest.mark.slow),
    pytest.param("ggx", {"alpha_x": 0.2, "alpha_y": 0.6, "eta": 1.8, "k": 2.5},
                 (0.28, 0.76, 0.586), (0.0, 0.0, 1.0), marks=pytest.mark.slow),
    pytest.param("lambert", {"kd": 0.7}, (0.0, 0.0, 1.0), (0.6, 0.0, 0.8), marks=pytest.mark.slow),
])
def test_eval_matches_reference(model, params, wi, wo):
    wi = np.array(wi) / np.linalg.norm(wi)
    args = ["eval", model, "--wi", ",".join(repr(float(x)) for x in wi), "--wo",
            ",".join(repr(float(x)) for x in wo)]
    for k, v in params.items():
        args += ["--param", f"{k}={v}"]
    ref = float(R.eval(model, np.array(wo), wi, **params))
    value = float(ok(*args).stdout)
    assert value == pytest.approx(ref, rel=2e-4, abs=1e-6)
    d = json.loads(ok(*args, "--json", "--precision", "double").stdout)
    assert d["model"] == model and d["value"] == pytest.approx(ref, rel=1e-9, abs=1e-12)
    assert {"params", "wi", "wo", "value"} <= set(d)
    for k, v in params.items():
        assert d["params"][k] == v


# ---------------------------------------------------------------------------------------------
# albedo

ALBEDO_KEYS = {"model", "params", "estimator", "samples", "precision", "mu", "albedo", "stderr",
               "seconds"}


@pytest.mark.parametrize("estimator,extra", [
    ("mis", ["--precision", "double"]), ("cosine", ["--qmc"]),
    pytest.param("brdf", [], marks=pytest.mark.slow), pytest.param("uniform", [], marks=pytest.mark.slow)])
def test_albedo_json_matches_reference(estimator, extra):
    mu = [0.15, 0.5, 1.0]
    r = ok("albedo", "ggx", "--param", "alpha=0.3", "--param", "fresnel=schlick", "--param",
           "f0=0.5", "--param", "masking=vcavity", "--mu", ",".join(map(str, mu)),
           "--estimator", estimator, "--samples", 16384, "--seed", 3, "--json", *extra)
    d = json.loads(r.stdout)
    assert ALBEDO_KEYS <= set(d)
    assert d["model"] == "ggx" and d["mu"] == mu and d["samples"] >= 16384
    assert d["estimator"].startswith(estimator)
    assert d["precision"] == ("double" if "double" in extra else "single")
    assert d["params"]["alpha"] == 0.3 and d["params"]["masking"] == "vcavity"
    assert len(d["albedo"]) == len(d["stderr"]) == len(mu)
    for m, e, s in zip(mu, d["albedo"], d["stderr"]):
        ref = R.albedo("ggx", m, alpha=0.3, fresnel="schlick", f0=0.5, masking="vcavity",
                       tol=1e-6)[0]
        assert 0 < s < 0.05
        assert abs(e - ref) <= 4 * s + 1e-5, (m, e, ref, s)


def test_albedo_table_text():
    r = ok("albedo", "lambert", "--param", "kd=0.5", "--mu", "0.2,1", "--samples", 1000)
    lines = r.stdout.splitlines()
    assert any("mu" in ln and "albedo" in ln and "stderr" in ln for ln in lines)
    rows = [ln.split() for ln in lines if ln.strip().startswith(("0.2", "1 "))]
    assert len(rows) == 2 and all(float(row[1]) == pytest.approx(0.5, abs=1e-5) for row in rows)


def test_albedo_reproducible():
    args = ("albedo", "ggx", "--param", "alpha=0.2", "--mu", "0.3,0.7", "--samples", 4096,
            "--seed", 11, "--json")
    a, b = json.loads(ok(*args).stdout), json.loads(ok(*args).stdout)
    assert a["albedo"] == b["albedo"] and a["stderr"] == b["stderr"]


# ---------------------------------------------------------------------------------------------
# table

TABLE_ARGS = ("table", "ggx", "--axis", "mu=0.2:1:3", "--axis", "alpha=0.1:0.7:4:log",
              "--param", "fresnel=schlick", "--param", "f0=0.6", "--samples", 8192, "--seed", 5)


def check_png(path):
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC and len(data) > 5000
    import matplotlib.image
    img = matplotlib.image.imread(str(path))
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 300


def check_reference(mu, alpha, E, S, A, AS):
    for i, j in ((0, 0), (1, 2), (2, 3)):
        ref = R.albedo("ggx", mu[i], alpha=alpha[j], fresnel="schlick", f0=0.6, tol=1e-6)[0]
        assert abs(E[i, j] - ref) <= 4 * S[i, j] + 1e-5, (mu[i], alpha[j], E[i, j], ref)
    ref = R.albedo_avg("ggx", alpha=alpha[1], fresnel="schlick", f0=0.6, tol=1e-4)[0]
    assert abs(A[1] - ref) <= 4 * AS[1] + 2e-3, (A[1], ref)


def test_table_npz(tmp_path):
    out = tmp_path / "g.npz"
    r = ok(*TABLE_ARGS, "--out", out)
    assert "wrote" in r.stdout and "g.npz" in r.stdout and "E_avg" in r.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.npz", "g.png"]
    z = clbrdf.Table.load(out)
    assert {"E", "E_stderr", "E_avg", "E_avg_stderr", "mu", "alpha"} <= set(z.keys())
    assert z["E"].shape == z["E_stderr"].shape == (3, 4)
    assert z["E_avg"].shape == z["E_avg_stderr"].shape == (4,)
    np.testing.assert_allclose(z["mu"], [0.2, 0.6, 1.0])
    np.testing.assert_allclose(z["alpha"], np.geomspace(0.1, 0.7, 4))
    meta = z.computed
    for key in ("model", "fixed", "options", "estimator", "samples", "seed", "precision",
                "version", "device"):
        assert key in meta, key
    assert meta["model"] == "ggx" and meta["seed"] == 5 and meta["samples"] >= 8192
    assert meta["fixed"]["f0"] == 0.6 and meta["options"]["fresnel"] == "schlick"
    check_png(tmp_path / "g.png")
    check_reference(z["mu"], z["alpha"], z["E"], z["E_stderr"], z["E_avg"], z["E_avg_stderr"])


def test_table_csv(tmp_path):
    out = tmp_path / "g.csv"
    ok(*TABLE_ARGS, "--out", out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.avg.csv", "g.csv", "g.png"]
    lines = out.read_text().splitlines()
    assert lines[0].startswith("# clbrdf-tables/2 ")
    meta = json.loads(lines[0].split(" ", 2)[2])["computed"]
    assert meta["model"] == "ggx" and meta["axes"] == ["mu", "alpha"]
    assert lines[1] == "mu,alpha,E,E_stderr"
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[2:]])
    assert rows.shape == (12, 4)
    mu, alpha = np.unique(rows[:, 0]), np.unique(rows[:, 1])
    E, S = rows[:, 2].reshape(3, 4), rows[:, 3].reshape(3, 4)
    np.testing.assert_allclose(rows[:4, 0], 0.2)           # mu outer, alpha inner
    alines = (tmp_path / "g.avg.csv").read_text().splitlines()
    assert alines[0].startswith("# ") and alines[1] == "alpha,E_avg,E_avg_stderr"
    arows = np.array([[float(x) for x in ln.split(",")] for ln in alines[2:]])
    assert arows.shape == (4, 3)
    check_png(tmp_path / "g.png")
    check_reference(mu, alpha, E, S, arows[:, 1], arows[:, 2])
    # the same arguments give the same numbers in .npz
    ok(*TABLE_ARGS, "--out", tmp_path / "same.npz")
    z = clbrdf.Table.load(tmp_path / "same.npz")
    np.testing.assert_array_equal(z["E"], E)
    np.testing.assert_array_equal(z["E_avg"], arows[:, 1])
    # and the .csv loads back to the same table
    back = clbrdf.Table.load(out)
    np.testing.assert_array_equal(back["E"], z["E"])
    np.testing.assert_array_equal(back["E_avg_stderr"], z["E_avg_stderr"])
    same = lambda m: {k: v for k, v in m.items() if k not in ("seconds", "command")}  # noqa: E731
    assert same(back.computed) == same(z.computed)


def test_table_target_stderr_out_of_reach_is_said(tmp_path):
    """--target-stderr that --max-samples cannot reach: the table is written (exit 0) and
    stderr says how many cells stayed above the target, for E and E_avg, and what to raise."""
    r = ok("table", "ggx", "--axis", "mu=0.2:1:3", "--axis", "alpha=0.3:0.6:2", "--samples", 64,
           "--target-stderr", "1e-4", "--max-samples", 256, "--out", tmp_path / "t.npz")
    assert "warning: --target-stderr=0.0001 not reached in 6 of 6 cells at --max-samples=256" \
        in r.stderr, r.stderr
    assert "not reached in 2 of 2 averages" in r.stderr and "raise --max-samples" in r.stderr
    assert int(clbrdf.Table.load(tmp_path / "t.npz")["E_samples"].min()) == 256


def test_table_mu_only(tmp_path):
    r = ok("table", "lambert", "--axis", "mu=0.1:1:5", "--param", "kd=0.25", "--samples", 512,
           "--out", tmp_path / "l.npz")
    z = clbrdf.Table.load(tmp_path / "l.npz")
    assert z["E"].shape == (5,) and z["E_avg"].shape == ()
    np.testing.assert_allclose(z["E"], 0.25, atol=1e-6)
    np.testing.assert_allclose(z["E_avg"], 0.25, atol=1e-5)
    check_png(tmp_path / "l.png")
    assert "E_avg" in r.stdout


# ---------------------------------------------------------------------------------------------
# bad input: exit code 2, one line naming the parameter, its value and the valid range

BAD = [
    (["eval", "phong", "--wi", "0,0,1", "--wo", "0,0,1"], ["phong", "lambert", "ggx"]),
    (["eval", "ggx", "--param", "beta=1", "--wi", "0,0,1", "--wo", "0,0,1"], ["beta", "alpha"]),
    (["eval", "ggx", "--param", "alpha=0", "--wi", "0,0,1", "--wo", "0,0,1"],
     ["alpha=0", "[0.0001, 10]"]),
    (["eval", "ggx", "--param", "alpha=nan", "--wi", "0,0,1", "--wo", "0,0,1"],
     ["alpha=nan", "[0.0001, 10]"]),
    (["eval", "ggx", "--param", "alpha=rough", "--wi", "0,0,1", "--wo", "0,0,1"],
     ["alpha", "rough", "[0.0001, 10]"]),
    (["eval", "ggx", "--param", "eta=0", "--wi", "0,0,1", "--wo", "0,0,1"], ["eta=0", "(0, 100]"]),
    (["eval", "ggx", "--param", "eta=-2", "--wi", "0,0,1", "--wo", "0,0,1"], ["eta=-2", "(0, 100]"]),
    (["eval", "ggx", "--param", "masking=smith", "--wi", "0,0,1", "--wo", "0,0,1"],
     ["masking", "smith", "vcavity"]),
    (["eval", "ggx", "--wi", "0,0,2", "--wo", "0,0,1"], ["wi", "unit"]),
    (["eval", "ggx", "--wi", "0,0.6,-0.8", "--wo", "0,0,1"], ["wi", "horizon"]),
    (["eval", "ggx", "--wi", "0,0,1", "--wo", "0,1"], ["wo", "X,Y,Z"]),
    (["albedo", "ggx", "--mu", "0.5,,1"], ["mu", "0.5,,1"]),
    (["eval", "ggx", "--wi", "0,0,1", "--wi", "0,0.6,0.8", "--wo", "0,0,1"], ["--wi is given twice"]),
    (["albedo", "ggx", "--mu", "0.5", "--mu", "0.7"], ["--mu is given twice"]),
    (["albedo", "ggx", "--mu", "0.5,x"], ["mu", "x"]),
    (["albedo", "ggx", "--mu", "0,0.5"], ["mu=0", "[1e-06, 1] in single"]),
    (["albedo", "ggx", "--mu", "1.5"], ["mu=1.5", "[1e-06, 1]"]),
    (["albedo", "ggx", "--mu", "0.5", "--samples", "1"], ["samples=1", "[2, "]),
    (["albedo", "ggx", "--mu", "0.5", "--estimator", "magic"], ["estimator", "magic", "mis"]),
    (["table", "ggx", "--axis", "mu=0.1:1", "--samples", "64", "--out", "OUT.npz"],
     ["mu=0.1:1", "START:STOP:COUNT"]),
    (["table", "ggx", "--axis", "mu=0.1:1:4", "--axis", "alpha=0:1:4:log", "--samples", "64",
      "--out", "OUT.npz"], ["alpha", "log", "0"]),
    (["table", "ggx", "--axis", "mu=0.1:1:4", "--axis", "alpha=0:1:4", "--samples", "64",
      "--out", "OUT.npz"], ["alpha=0", "[0.0001, 10]"]),
    (["table", "ggx", "--axis", "mu=0.1:1:4", "--axis", "alpha=0.1:1:4:cubic", "--samples", "64",
      "--out", "OUT.npz"], ["cubic", "lin", "log"]),
    (["table", "ggx", "--axis", "mu=0:1:4", "--samples", "64", "--out", "OUT.npz"],
     ["mu=0", "[1e-06, 1] in single"]),
    (["table", "ggx", "--axis", "mu=0.1:1:4", "--samples", "64", "--out", "OUT.txt"],
     [".txt", ".npz", ".csv"]),
]


@pytest.mark.parametrize("args,words", BAD, ids=[" ".join(a[:4]) for a, _ in BAD])
def test_bad_input(tmp_path, args, words):
    args = [a.replace("OUT", str(tmp_path / "out")) for a in args]
    r = run_inprocess(*args)
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert "Traceback" not in err and r.stdout == ""
    for w in words:
        assert w in err, (w, err)
    assert list(tmp_path.iterdir()) == []


def test_bad_input_as_a_process(tmp_path):
    """The same as a real process: exit status 2, one line on stderr, nothing on stdout."""
    r = cli("eval", "ggx", "--param", "alpha=0", "--wi", "0,0,1", "--wo", "0,0,1")
    assert r.returncode == 2 and r.stdout == "" and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "alpha=0" in r.stderr and "[0.0001, 10]" in r.stderr and "Traceback" not in r.stderr


def test_failure_keeps_existing_files(tmp_path):
    out, png = tmp_path / "t.npz", tmp_path / "t.png"
    out.write_bytes(b"precious data")
    png.write_bytes(b"precious chart")
    r = cli("table", "ggx", "--axis", "mu=0.1:1:4", "--axis", "alpha=0.1:20:4", "--samples", 64,
            "--out", out)
    assert r.returncode == 2 and "alpha=0.1:20:4" in r.stderr and "[0.0001, 10]" in r.stderr
    assert out.read_bytes() == b"precious data" and png.read_bytes() == b"precious chart"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.npz", "t.png"]


def test_write_failure_is_atomic(tmp_path, monkeypatch):
    """A failure while writing (here: in the chart) leaves every existing file as it was and no
    temporary file behind."""
    from clbrdf.tables import files
    from clbrdf.tables.table import from_albedo
    table = from_albedo({"mu": np.array([0.5, 1.0]), "E": np.array([0.9, 0.8]),
                         "E_stderr": np.array([0.01, 0.01]), "E_avg": np.array(0.85),
                         "E_avg_stderr": np.array(0.01)}, {"model": "ggx", "axes": ["mu"]})
    for suffix in (".npz", ".csv"):
        out = tmp_path / f"x{suffix}"
        out.write_text("old")
        monkeypatch.setattr(files, "figure_png", lambda *a, **k: 1 / 0)
        with pytest.raises(ZeroDivisionError):
            files.save_tables(table, out)
        assert out.read_text() == "old"
        assert not (tmp_path / "x.png").exists() and not (tmp_path / "x.avg.csv").exists()
        assert [p.name for p in tmp_path.iterdir()] == [out.name]
        monkeypatch.undo()
        written = files.save_tables(table, out)
        assert out in written and (tmp_path / "x.png").exists()
        assert out.read_text() != "old" if suffix == ".csv" else out.read_bytes()[:2] == b"PK"
        for p in tmp_path.iterdir():
            p.unlink()


def test_no_device_exit_3():
    r = cli("albedo", "ggx", "--mu", "0.5", "--device", "no-such-device-xyz")
    assert r.returncode == 3
    assert "no-such-device-xyz" in r.stderr and "Traceback" not in r.stderr


def test_devices_report_whether_the_kernels_run(tmp_path):
    """A compiler that builds a trivial kernel can still fail on ours (PyPI's PoCL 3.0 aborts on
    the GGX albedo program at width 16); clbrdf checks in a child process, caches the answer,
    and `devices` shows it: untested before, ok W16 for the default CPU device after --probe."""
    env = {"CLBRDF_CACHE_DIR": str(tmp_path)}
    d = json.loads(ok("devices", "--json", env=env).stdout)
    assert all(x["kernels"] in ("untested", "-") for x in d["devices"])
    d = json.loads(ok("devices", "--json", "--probe", "--device", d["default"], env=env).stdout)
    default = [x for x in d["devices"] if x["default"]][0]
    assert default["kernels"] in ("ok W16", "ok W1") and default["kernel_error"] is None
    assert (tmp_path / "probes.json").exists()


def test_channels_param_makes_an_rgb_model(tmp_path):
    """The README's `-p channels=3` was rejected by eval, albedo and table ("no parameter
    'channels'"); it makes the model RGB with every per-channel parameter grey."""
    r = ok("eval", "ggx", "-p", "channels=3", "-p", "kd=0.1", "--wi", "0,0,1", "--wo", "0,0,1",
           "--json")
    v = json.loads(r.stdout)["value"]
    assert len(v) == 3 and v[0] == v[1] == v[2] > 0
    r = run_inprocess("table", "ggx", "-p", "channels=3", "--axis", "mu=0.5,1",
                      "--axis", "alpha=0.1,0.5", "-n", "256", "--out", tmp_path / "t.npz")
    assert r.returncode == 0, r.stderr
    assert clbrdf.Table.load(tmp_path / "t.npz")["E"].shape == (2, 2, 3)
    for bad, msg in (("channels=2", "channels is 1 or 3"), ("channels=x", "channels is 1 or 3")):
        r = run_inprocess("eval", "ggx", "-p", bad, "--wi", "0,0,1", "--wo", "0,0,1")
        assert r.returncode == 2 and msg in r.stderr, r.stderr
    r = run_inprocess("eval", "ggx", "-p", "channels=1", "-p", "kd=0.1,0.2,0.3", "--wi", "0,0,1",
                      "--wo", "0,0,1")
    assert r.returncode == 2 and "channels=1" in r.stderr, r.stderr


def test_progress_bars_only_on_a_terminal(monkeypatch):
    """Progress bars went into piped logs: the commands ask for one only when stderr is a
    terminal."""
    import io
    import clbrdf.runtime.albedo as ra
    asked = []
    real = ra.progress_bar
    monkeypatch.setattr(ra, "progress_bar", lambda total, enabled, **k: (
        asked.append(enabled), real(total, False, **k))[1])
    argv = ["table", "ggx", "--axis", "mu=0.5,1", "-n", "256", "--out"]

    class Tty(io.StringIO):
        def isatty(self):
            return True
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        assert run_inprocess(*argv, f"{d}/a.npz").returncode == 0      # stderr: a StringIO
        monkeypatch.setattr("sys.stderr", Tty())
        from clbrdf.cli.common import bars
        assert bars()
    assert asked and not any(asked)
