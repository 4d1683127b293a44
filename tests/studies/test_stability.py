"""The stability map (clbrdf/studies/stability.py): its flags against an independent recomputation,
the shipped map's coverage, the warnings it drives, and ``clbrdf stability``."""
import csv
import math
import warnings

import numpy as np
import pytest

import clbrdf
from clbrdf.api import useless as U
from clbrdf.studies import stability as S
from clbrdf.models import get_spec
from clbrdf.ref import reference
from cliutil import run_inprocess


def test_sweeps_cover_every_model_within_range():
    for name in clbrdf.MODELS:
        sweeps = S.sweeps(name)
        spec = get_spec(name)
        for names, values in sweeps:
            for n in names:
                p = spec.param(n)
                for v in values:        # every swept value is one the model accepts
                    p.check(np.asarray(v))


def test_shipped_map_covers_every_cell():
    rows = U.read_csv(U.MAP)
    have = {(r["model"], r["sweep"], r["value"], r["mu"], r["estimator"], r["sampler"],
             r["precision"]) for r in rows}
    from clbrdf.models.spec import MU_MIN
    for name in clbrdf.MODELS:
        for names, values in S.sweeps(name):
            for v in values:
                for prec in ("single", "double"):
                    for mu in (m for m in S.MUS if m >= MU_MIN[prec]):
                        for est in S.ESTIMATORS:
                            for smp in (U.samplers(name) if est in ("brdf", "mis") else ("-",)):
                                key = (name, U.sweep_label(names), float(v), float(mu), est, smp,
                                       prec)
                                assert key in have, key
    # at every cell and precision the best estimator has efficiency 1
    best = {}
    for r in rows:
        k = (r["model"], r["sweep"], r["value"], r["mu"], r["precision"])
        best[k] = max(best.get(k, 0.0), r["efficiency"])
    assert all(b == 1.0 for b in best.values())


@pytest.fixture(scope="module")
def small_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("stab")
    r = run_inprocess("stability", "ggx", "--out", str(out), "--samples", "4096", "--quiet")
    assert r.returncode == 0, r.stderr
    return out


def test_small_map_files_and_flags(small_map):
    rows = U.read_csv(small_map / "stability.csv")
    assert {r["model"] for r in rows} == {"ggx"}
    assert (small_map / "ggx.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (small_map / "README.md").read_text()
    assert "| ggx |" in text
    with open(small_map / "checks.csv") as f:
        checks = list(csv.DictReader(f))
    assert len(checks) == 3 * 2 * len(S.sweeps("ggx")[0][1])
    # the reference column is the float64 reference, within its own error estimate
    for r in rows[::197]:
        e, err = reference("ggx", alpha=r["value"]).albedo(r["mu"], 0.0, 1e-7)
        assert abs(float(e) - r["E_ref"]) <= 4 * (r["ref_err"] + float(err)) + 1e-12
    from clbrdf.api.albedo import QUAD_TOL
    for r in rows:
        # the flags follow from the numbers in the row
        if r["estimator"] == "quadrature":
            assert r["biased"] == int(r["z"] > 1)
            assert r["useless"] == int(r["stderr"] > QUAD_TOL[r["precision"]])
            continue
        assert r["biased"] == int(math.isfinite(r["E"]) and r["z"] > U.Z_BIAS)
        assert r["useless"] == int(r["efficiency"] < U.USELESS)
        if r["precision"] == "double":
            assert r["precision_loss"] == 0
    by = {(r["value"], r["mu"], r["estimator"], r["sampler"], r["precision"]): r for r in rows}
    # the example: uniform sampling of a near-mirror lobe is useless, visible normals are not
    for prec in ("single", "double"):
        assert by[(1e-4, 0.6, "uniform", "-", prec)]["useless"]
        assert not by[(1e-4, 0.6, "brdf", "vndf", prec)]["useless"]
        assert by[(1e-4, 0.6, "brdf", "vndf", prec)]["efficiency"] == 1.0
        assert not by[(1.0, 0.6, "uniform", "-", prec)]["useless"]


def test_small_map_reuses_references(small_map):
    cache = S.ref_cache(small_map / "stability.csv")
    assert len(cache) == len(S.sweeps("ggx")[0][1]) * len(S.MUS)


def test_precision_loss_is_single_biased_where_double_is_sound():
    def row(prec, E=1.0, stderr=0.01, **flags):
        r = {"model": "m", "sweep": "a", "value": 1.0, "mu": 0.5, "estimator": "brdf",
             "sampler": "-", "precision": prec, "nonfinite": 0, "biased": 0, "useless": 0,
             "precision_loss": 0, "E": E, "stderr": stderr}
        r.update(flags)
        return r
    cases = [((row("single", biased=1), row("double", E=0.5)), 1),
             ((row("single", nonfinite=1), row("double")), 1),
             ((row("single", nonfinite=1), row("double", nonfinite=1)), 0),
             # the same draws, the same estimate: heavy tails, not lost digits
             ((row("single", biased=1), row("double", E=1.01)), 0),
             ((row("single", biased=1), row("double", E=0.5, biased=1)), 0),
             ((row("single", biased=1, useless=1), row("double", E=0.5)), 0),
             ((row("single", biased=1), row("double", E=0.5, useless=1)), 0),
             ((row("single"), row("double", E=0.5)), 0)]
    for pair, want in cases:
        S._mark_precision_loss(list(pair))
        assert pair[0]["precision_loss"] == want, pair


def test_warns_where_the_map_marks_useless():
    m = clbrdf.Model("ggx", alpha=1e-3)
    with pytest.warns(U.UselessEstimatorWarning, match=r"uniform.*ggx.*alpha=0.001"):
        r = clbrdf.albedo(m, 0.6, estimator="uniform", samples=1 << 12)
    # and the warning is deserved: the estimate misses the reference far beyond its sampling
    # error; the reported error, which covers what the samples cannot see, says so (it is larger
    # than E itself)
    e_ref = float(reference("ggx", alpha=1e-3).albedo(0.6)[0])
    assert abs(float(r.albedo) - e_ref) > 4 * float(r.sampling_stderr)
    assert abs(float(r.albedo) - e_ref) < 4 * float(r.stderr) and float(r.stderr) > 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", U.UselessEstimatorWarning)
        clbrdf.albedo(m, 0.6, estimator="brdf", samples=1 << 12)
        clbrdf.albedo(clbrdf.Model("ggx", alpha=0.5), 0.6, estimator="uniform", samples=1 << 12)
        clbrdf.albedo(m, 0.6, estimator="quadrature")


def test_warning_counts_only_the_useless_points():
    m = clbrdf.Model("ggx", alpha=np.array([1e-3, 0.5, 0.5, 0.5]))
    with pytest.warns(U.UselessEstimatorWarning, match=r"at 25% of these points"):
        clbrdf.albedo(m, 0.6, estimator="uniform", samples=1 << 10)


def test_cli_warns_and_succeeds():
    with warnings.catch_warnings():     # shown as a user's process shows it (pyproject.toml)
        warnings.simplefilter("default", U.UselessEstimatorWarning)
        r = run_inprocess("albedo", "ggx", "-p", "alpha=1e-3", "--mu", "0.6", "--estimator",
                          "uniform", "--samples", "4096")
    assert r.returncode == 0, r.stderr
    assert "clbrdf albedo: warning: estimator='uniform' is marked useless" in r.stderr


def test_cli_refuses_bad_input_before_work(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    r = run_inprocess("stability", "ggx", "--out", str(f))
    assert r.returncode == 2 and "is a file" in r.stderr
    r = run_inprocess("stability", "ggx", "--out", str(tmp_path / "o"), "--samples", "10")
    assert r.returncode == 2 and "samples" in r.stderr
    r = run_inprocess("stability", "nosuch", "--out", str(tmp_path / "o"))
    assert r.returncode == 2
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("b", [1e-6, 100.0, 1e8])
def test_low_smooth_reference_at_grazing(b):
    """Fixed by the map: the reference's half-vector map lost the horizon distance to
    cancellation at mu = 1e-12 (E = 0 for a true 0.19). E is continuous from mu = 1e-6 down and
    agrees with the kernel's brdf estimate in double precision there."""
    r = reference("low_smooth", b=b)
    e12, err12 = (float(x) for x in r.albedo(1e-12, 0.0, 1e-10))
    e6, _ = (float(x) for x in r.albedo(1e-6, 0.0, 1e-10))
    assert e12 > 0 and abs(e12 - e6) <= 1e-5 * e6
    k = clbrdf.albedo(clbrdf.Model("low_smooth", b=b, precision="double"), 1e-12,
                      samples=1 << 16, seed=3)
    assert abs(float(k.albedo) - e12) <= 4 * float(k.stderr) + 1e-4 * e12


def test_shipped_map_claims():
    """What README.md and docs/stability/findings.md say of the shipped map."""
    rows = U.read_csv(U.MAP)
    assert not any(r["nonfinite"] for r in rows)
    assert not any(r["precision_loss"] for r in rows)
    with open(U.MAP.resolve().parent / "checks.csv") as f:
        assert all(c["passed"] == "1" for c in csv.DictReader(f))
    # biased where the estimator is efficient (within 10x of the best, as the reproduction test
    # below): Monte Carlo in Schlick 1994 at grazing angles only; between 1e-2 and 1e-1 of the
    # best, rare events (and the timing) decide (findings.md: the useless threshold is not a
    # reliability guarantee); the quadrature (converged) in one cell at normal incidence
    bad = [r for r in rows if r["biased"] and not r["useless"]]
    mc = [r for r in bad if r["estimator"] != "quadrature"]
    assert mc and all(r["model"] == "schlick" and r["mu"] <= 1e-6 and r["value"] <= 1e-3
                      for r in mc if r["efficiency"] >= 10 * U.USELESS)
    assert sum(r["model"] != "schlick" for r in mc) <= 2, [r for r in mc if r["model"] != "schlick"]
    # an estimate of 0 +- 0 where E is representable (no sample contributed) is never useful
    tiny = {"single": float(np.finfo(np.float32).smallest_subnormal), "double": 0.0}
    assert not any(r["E"] == 0 and r["stderr"] == 0 and r["E_ref"] > tiny[r["precision"]]
                   and not r["useless"] for r in rows if r["estimator"] != "quadrature")
    quad = {(r["model"], r["value"], r["mu"], r["precision"]) for r in bad
            if r["estimator"] == "quadrature"}
    assert quad == {("schlick", 1e-4, 1.0, "single")}


@pytest.mark.slow
@pytest.mark.parametrize("name", ["ggx", "low_smooth", "schlick"])
def test_map_reproduces_with_another_seed(name, monkeypatch):
    """A fresh measurement with another seed (references from the shipped map) finds no
    non-finite estimate, no precision loss, and no biased cell of an efficient estimator (within
    10x of the best at the cell) outside Schlick's grazing region; the useless cells agree with
    the shipped map's at 90 %. Between 1e-2 and 1e-1 of the best, rare events still decide some
    cells: seed 12345 puts low_smooth B = 1e6, mu = 0.1, cosine sampling at 6.2e-6 +- 1.1e-6 for
    1.2e-5 (efficiency 0.015), a miss of the weights' tail, not a defect of the kernel."""
    monkeypatch.setattr(S, "SEED", 12345)
    # the shipped map's references where they are this code's (ref_version), else computed
    refs = S.references(name, cache=S.ref_cache(U.MAP))
    rows, checks = S.measure(name, refs)
    assert not any(r["nonfinite"] or r["precision_loss"] for r in rows)
    assert all(c["passed"] for c in checks)
    for r in rows:
        if r["biased"] and r["efficiency"] >= 10 * U.USELESS:
            assert name == "schlick" and r["mu"] <= 1e-6 and r["value"] <= 1e-3, r
    shipped = {S._key(r) + (r["precision"],): r["useless"] for r in U.read_csv(U.MAP)
               if r["model"] == name}
    same = np.mean([shipped[S._key(r) + (r["precision"],)] == r["useless"] for r in rows])
    assert same >= 0.9, same


def test_stability_chart_title_fits_every_model():
    """The stability chart's one-line title ran off narrow figures; it is wrapped to the
    figure's width. Rendered from the shipped map, every model: no text cut off."""
    from pathlib import Path
    from figures import text_boxes
    rows = U.read_csv(Path(__file__).parents[2] / "docs/stability/stability.csv")
    width = {}
    for r in rows:
        width.setdefault(r["model"], set()).add((r["estimator"], r["sampler"]))
    # the narrowest figure (fewest estimator panels: the title cut off there) and the widest
    for name in (min(width, key=lambda n: len(width[n])), max(width, key=lambda n: len(width[n]))):
        fig = S.figure([r for r in rows if r["model"] == name], name)
        W, H = fig.bbox.width, fig.bbox.height
        cut = [t for t, b in text_boxes(fig)
               if b.x0 < -0.5 or b.y0 < -0.5 or b.x1 > W + 0.5 or b.y1 > H + 0.5]
        assert not cut, (name, cut[:3])
