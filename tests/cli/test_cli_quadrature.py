"""The command line's quadrature estimator: --estimator quadrature with --tol / --max-evals on
albedo and table, their JSON and metadata, and refusals (exit 2)."""
import json

import numpy as np
import pytest

import clbrdf

from clbrdf.ref import reference
from cliutil import run_inprocess


def test_albedo_quadrature_json():
    r = run_inprocess("albedo", "ggx", "--param", "alpha=0.3", "--param", "kd=0.2", "--mu",
                      "0.1,0.7", "--estimator", "quadrature", "--precision", "double",
                      "--tol", "1e-7", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["estimator"] == "quadrature" and d["tol"] == 1e-7 and d["qmc"] is False
    assert len(d["evaluations"]) == 2 and d["samples"] == max(d["evaluations"])
    ref = reference("ggx", alpha=0.3, kd=0.2)
    for mu, e, err in zip(d["mu"], d["albedo"], d["stderr"]):
        assert err <= 1e-7
        assert abs(e - ref.albedo(mu, 0.0, 1e-11)[0]) <= 1e-7


def test_albedo_quadrature_text_shows_the_error_estimate():
    r = run_inprocess("albedo", "lambert", "--param", "kd=0.25", "--mu", "0.5",
                      "--estimator", "quadrature")
    assert r.returncode == 0, r.stderr
    assert "quadrature to tol 1e-06" in r.stdout
    row = [ln.split() for ln in r.stdout.splitlines() if ln.strip().startswith("0.5")][0]
    assert float(row[1]) == pytest.approx(0.25, abs=1e-7) and float(row[2]) <= 1e-6
    assert len(row[1].split(".")[1]) == 9                  # digits the estimate supports


def test_table_quadrature_metadata(tmp_path):
    out = tmp_path / "q.npz"
    r = run_inprocess("table", "ggx", "--axis", "mu=0.2:1:3", "--axis", "alpha=0.1:0.7:2",
                      "--estimator", "quadrature", "--tol", "1e-5", "--out", out)
    assert r.returncode == 0, r.stderr
    assert "quadrature to tol 1e-05" in r.stdout and "max error" in r.stdout
    z = clbrdf.Table.load(out)
    meta = z.computed
    assert meta["estimator"] == "quadrature" and meta["tol"] == 1e-5 and meta["max_evals"] > 0
    assert np.all(z["E_stderr"] <= 1e-5)
    ref = reference("ggx", alpha=0.7)
    assert abs(z["E"][1, 1] - ref.albedo(0.6, 0.0, 1e-10)[0]) <= 1e-5


@pytest.mark.parametrize("args, msg", [
    (("--estimator", "brdf", "--tol", "1e-5"), "--tol is for --estimator quadrature, not brdf"),
    (("--estimator", "mis", "--max-evals", "100000"), "--max-evals is for --estimator quadrature"),
    (("--estimator", "quadrature", "--qmc"), "qmc=True is not valid with estimator='quadrature'"),
    (("--estimator", "quadrature", "--tol", "-1"), "tol=-1.0 is out of range"),
    (("--estimator", "quadrature", "--max-evals", "7"), "--max-evals=7 is out of range")])
def test_quadrature_refusals(args, msg):
    r = run_inprocess("albedo", "ggx", "--mu", "0.5", *args)
    assert r.returncode == 2 and msg in r.stderr, (r.returncode, r.stderr)


def test_no_estimator_picks_the_recommended_one_and_says_so():
    """Without --estimator: brdf with Sobol points (docs/accuracy/README.md), said on the output
    and recorded (JSON: estimator, qmc, estimator_chosen); with --tol: the quadrature."""
    r = run_inprocess("albedo", "ggx", "--mu", "0.5", "--json")
    d = json.loads(r.stdout)
    assert d["estimator"] == "brdf" and d["qmc"] is True and "clbrdf accuracy" in d["estimator_chosen"]
    r = run_inprocess("albedo", "ggx", "--mu", "0.5")
    assert "estimator brdf (qmc)" in r.stdout and "no --estimator" not in r.stdout
    assert "clbrdf albedo: note: no --estimator: brdf with Sobol points" in r.stderr
    r = run_inprocess("albedo", "ggx", "--mu", "0.5", "--estimator", "brdf", "--json")
    d = json.loads(r.stdout)
    assert d["qmc"] is False and "estimator_chosen" not in d
    r = run_inprocess("albedo", "ggx", "--mu", "0.5", "--tol", "1e-5", "--json")
    d = json.loads(r.stdout)
    assert d["estimator"] == "quadrature" and d["tol"] == 1e-5


def test_table_without_estimator_uses_the_recommended_one(tmp_path):
    out = tmp_path / "t.npz"
    r = run_inprocess("table", "lambert", "--axis", "mu=0.2:1:2", "--samples", 4096, "--out", out)
    assert r.returncode == 0, r.stderr
    assert "brdf + QMC" in r.stdout and "no --estimator" not in r.stdout
    assert "note: no --estimator: brdf with Sobol points" in r.stderr
    meta = clbrdf.Table.load(out).computed
    assert meta["estimator"] == "brdf" and meta["qmc"] is True
