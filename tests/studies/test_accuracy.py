"""clbrdf accuracy: the speed-against-accuracy chart on a small job (two models, counts up to
2^10, single precision): its files, the rows' contents against the reference, and the pick of
the fastest estimator per target."""
import csv

import numpy as np
import pytest

from clbrdf.studies import accuracy
from cliutil import run_inprocess


def test_accuracy_command_writes_chart_csv_and_summary(tmp_path):
    r = run_inprocess("accuracy", "lambert", "ggx", "--out", tmp_path, "--max-log2-samples", 9,
                      "--precision", "single", "--quiet")
    assert r.returncode == 0, r.stderr
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["README.md", "accuracy.csv", "ggx.png", "lambert.png"]
    assert (tmp_path / "ggx.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = list(csv.DictReader(open(tmp_path / "accuracy.csv")))
    kinds = {(x["model"], x["estimator"], x["rng"]) for x in rows}
    for model in ("lambert", "ggx"):
        for est in ("uniform", "cosine", "brdf", "mis"):
            assert {(model, est, "philox"), (model, est, "sobol")} <= kinds
        assert (model, "quadrature", "none") in kinds
    lam = [x for x in rows if x["model"] == "lambert"]
    # a Lambertian's cosine estimate is exact: f cos / pdf = kd for every sample
    assert all(float(x["max"]) < 1e-6 for x in lam if x["estimator"] == "cosine")
    q = [x for x in rows if x["model"] == "ggx" and x["estimator"] == "quadrature"]
    tols = accuracy.QUAD_TOLS["single"]
    for x, tol in zip(q, tols):
        assert float(x["max"]) <= tol                 # the quadrature meets its tolerance here
    # importance sampling: more samples, less error (uniform sampling of the sharp lobe, alpha
    # 0.01, is off by 5.7 at 2^9 samples and by 0.69 at 2^5, which never hit the lobe)
    mc = sorted((float(x["samples"]), float(x["rms"])) for x in rows
                if x["model"] == "ggx" and x["estimator"] == "brdf" and x["rng"] == "philox")
    assert mc[-1][1] < 0.25 * mc[0][1]
    text = (tmp_path / "README.md").read_text()
    assert "| ggx | single |" in text and "## Recommendation" in text


def test_best_picks_the_fastest_and_extrapolates_monte_carlo():
    rows = [{"estimator": "brdf", "rng": "philox", "samples": 1024, "seconds": 1.0, "max": 1e-3},
            {"estimator": "brdf", "rng": "philox", "samples": 4096, "seconds": 4.0, "max": 5e-4},
            {"estimator": "quadrature", "rng": "none", "samples": 1e5, "seconds": 0.5, "max": 1e-5}]
    b = accuracy.best(rows, 1e-4)
    assert b[0] == ("quadrature", 0.5, False)
    k, s, x = b[1]
    assert k == "brdf philox" and x and np.isclose(s, 4.0 * (5e-4 / 1e-4) ** 2)
    assert accuracy.best(rows, 1e-3)[0] == ("quadrature", 0.5, False)


def test_single_precision_chart_has_no_empty_panels():
    """`clbrdf accuracy --precision single` drew two empty double-precision panels; the chart
    has a row per precision measured. From the shipped measurements: every panel has data."""
    import csv
    from pathlib import Path
    from clbrdf.studies import accuracy as A
    rows = []
    with open(Path(__file__).parents[2] / "docs/accuracy/accuracy.csv", newline="") as f:
        for r in csv.DictReader(f):
            for k in ("samples", "seconds", "rms", "max"):
                r[k] = float(r[k])
            rows.append(r)
    ggx = [r for r in rows if r["model"] == "ggx"]
    for precs, panels in ((("single",), 2), (("double",), 2), (("single", "double"), 4)):
        fig = A.figure([r for r in ggx if r["precision"] in precs], "ggx")
        assert len(fig.axes) == panels
        assert all(ax.lines for ax in fig.axes), precs


def test_the_points_of_a_model_that_transmits_are_on_both_sides():
    assert accuracy.mus("ggx_dielectric") == accuracy.MUS + tuple(-m for m in accuracy.MUS)
    assert accuracy.mus("ggx") == accuracy.MUS
    rows = [{"model": m, "estimator": "brdf", "rng": "sobol", "precision": "single",
             "samples": 32.0, "seconds": 1.0, "max": 1e-3, "rms": 1e-3} for m in ("ggx", "lambert")]
    text = accuracy.summary(rows, "clbrdf accuracy lambert", 1.0, ["lambert"])
    assert "this run measured lambert" in text and "| ggx | single |" in text
    assert "this run measured" not in accuracy.summary(rows, "c", 1.0, ["ggx", "lambert"])


@pytest.mark.slow
def test_a_model_that_transmits_is_measured_from_both_sides_and_runs_merge(tmp_path,
                                                                            monkeypatch):
    """For rough glass the points include wo inside (mu < 0), against the float64 reference
    from inside; a later run of another model keeps these rows and says which it measured.
    (One mu and the defaults only: the float64 reference of the sharp glass lobe, alpha 0.01,
    takes 190 s for the chart's 20 points.)"""
    assert accuracy.mus("ggx_dielectric") == accuracy.MUS + tuple(-m for m in accuracy.MUS)
    assert accuracy.mus("ggx") == accuracy.MUS
    monkeypatch.setattr(accuracy, "MUS", (0.5,))
    monkeypatch.setattr(accuracy, "cases", lambda name: [("defaults", {})])
    r = run_inprocess("accuracy", "ggx_dielectric", "--out", tmp_path, "--max-log2-samples", 7,
                      "--precision", "single", "--quiet")
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader(open(tmp_path / "accuracy.csv")))
    assert {int(x["points"]) for x in rows} == {2}                  # mu = 0.5 and -0.5
    q = [float(x["max"]) for x in rows if x["estimator"] == "quadrature"]
    assert min(q) < 1e-5                  # the inside points against the reference from inside
    r = run_inprocess("accuracy", "lambert", "--out", tmp_path, "--max-log2-samples", 7,
                      "--precision", "single", "--quiet")
    assert r.returncode == 0, r.stderr
    again = list(csv.DictReader(open(tmp_path / "accuracy.csv")))
    assert [x for x in again if x["model"] == "ggx_dielectric"] == rows
    assert {x["model"] for x in again} == {"ggx_dielectric", "lambert"}
    text = (tmp_path / "README.md").read_text()
    assert "this run measured lambert" in text and "| ggx_dielectric | single |" in text
