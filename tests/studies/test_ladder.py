"""The ladder of cheaper variants and ``clbrdf simplest`` (clbrdf/studies/ladder.py): the variants a
configuration offers, their errors against independent float64 references, the choice, the CLI."""
import json

import numpy as np
import clbrdf
import pytest

from clbrdf.studies import ladder as L
from clbrdf.ref import reference
from cliutil import run_inprocess


def labels(name, **kw):
    return [v.label for v in L.variants(*L.full_config(name, **kw))]


def test_variants_follow_the_configuration():
    got = labels("ggx", alpha=0.3, fresnel="dielectric", eta=1.5, kd=0.2)
    assert got[:2] == ["full", "single"]
    for want in ("masking=separable", "masking=vcavity", "masking=none", "fresnel=schlick",
                 "fresnel=one", "kd=0", "masking=vcavity, fresnel=schlick, kd=0, single"):
        assert want in got
    assert len(got) == len(set(got)) == 2 * 4 * 3 * 2
    # nothing to drop: only the precision and the masking
    assert set(labels("ggx", alpha=0.3)) == {"full", "single"} | {
        f"masking={m}{s}" for m in ("separable", "vcavity", "none") for s in ("", ", single")}
    assert labels("lambert") == ["full", "single"]
    got = labels("schlick", **L.configs()["schlick"])
    for want in ("directional=eq17", "directional=eq15", "directional=eq12", "spectral=constant",
                 "material=single", "directional=eq12, spectral=constant, material=single"):
        assert want in got
    assert "lobes=one" in labels("low_smooth", lobes="two")
    assert "kw=0" in labels("holzschuch_pacanowski", kw=1.0)
    assert "model=ggx" in labels("gtr", gamma=1.5)
    assert "model=beckmann" in labels("exppow", p=0.7)


def _rel(f, ref):
    return float(np.max(np.abs(f - ref) / np.maximum(np.abs(ref), L.REL_FLOOR * np.abs(ref).max())))


def test_value_errors_against_the_float64_references():
    """Each variant's error is the max relative difference of the references of the variant
    and of the full configuration (clbrdf.ref, independent of the kernels), within what the
    kernels' own error against the references allows."""
    name, kw = L.full_config("ggx", alpha=0.3, fresnel="dielectric", eta=1.5, kd=0.2)
    vs = L.measure_errors(L.variants(name, kw), "value")
    wo, wi = L.pairs()
    full = reference(name, **kw).eval(wo, wi)
    for v in vs:
        want = _rel(reference(v.name, **v.kw).eval(wo, wi), full)
        tol = 1e-5 if v.precision == "double" else 1e-3
        assert abs(v.error - want) <= tol * max(want, 1), (v.label, v.error, want)
    # the exact Fresnel term of eta = 1.5 against Schlick's: 17 % at grazing pairs
    by = {v.label: v for v in vs}
    assert 0.1 < by["fresnel=schlick"].error < 0.3
    assert by["single"].error < 1e-5


@pytest.mark.parametrize("name, kw, to, bound", [
    ("gtr", {"alpha": 0.3, "gamma": 2.0}, "model=ggx", 2e-4),       # GTR gamma 2 is GGX
    # exp-power p 1 is Beckmann (tests/models/test_holzschuch_pacanowski.py holds the kernels to it)
    pytest.param("exppow", {"alpha": 0.3, "p": 1.0}, "model=beckmann", 1e-4, marks=pytest.mark.slow),
])
def test_analytic_rung_is_the_same_distribution(name, kw, to, bound):
    """Where the tabulated model is the analytic one, the rung's error is the table's (docs:
    max |G1 error| 2e-4 gtr, 1e-5 exppow), both in f and in E; away from it, it is not."""
    for metric in ("value", "albedo"):
        vs = L.variants(*L.full_config(name, **kw), precisions=("double",))
        vs = {v.label: v for v in L.measure_errors([vs[0]] + [v for v in vs if v.label == to],
                                                   metric)}
        assert vs[to].error <= bound, (metric, vs[to].error)
    far = dict(kw, **({"gamma": 1.0} if name == "gtr" else {"p": 0.5}))
    vs = {v.label: v for v in L.measure_errors(L.variants(*L.full_config(name, **far)), "value")}
    assert vs[to].error > 0.05


def test_simplest_picks_the_fastest_within_tolerance():
    r = L.simplest("ggx", 1e-3, "value", alpha=0.3, fresnel="dielectric", eta=1.5)
    assert r.variant.error <= 1e-3
    timed = [c for c in r.candidates if np.isfinite(c.speedup)]
    assert all(c.error <= 1e-3 for c in timed[1:])
    assert r.variant.speedup == max(c.speedup for c in timed)
    assert {c.label for c in timed} == {"full", "single"}
    # nothing within 0: the full configuration itself
    r0 = L.simplest("ggx", 0.0, "albedo", alpha=0.3)
    assert r0.variant.label == "full" and r0.variant.error == 0 and r0.variant.speedup == 1


def test_albedo_metric_against_reference():
    """metric=albedo: dropping the diffuse term of kd = 0.2 changes E by the Lambertian's
    albedo over E (the reference's E of both configurations)."""
    kw = {"alpha": 0.3, "kd": 0.2}
    vs = L.variants(*L.full_config("ggx", **kw), precisions=("double",))
    by = {v.label: v for v in L.measure_errors([vs[0]] + [v for v in vs if v.label == "kd=0"],
                                               "albedo")}
    want = max(abs(float(reference("ggx", alpha=0.3).albedo(mu)[0])
                   - float(reference("ggx", **kw).albedo(mu)[0]))
               / float(reference("ggx", **kw).albedo(mu)[0]) for mu in L.ALBEDO_MUS)
    assert abs(by["kd=0"].error - want) < 1e-5


def test_cli_json_and_text():
    r = run_inprocess("simplest", "ggx", "--tolerance", "1e-3", "-p", "alpha=0.3", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert set(d) >= {"model", "variant", "error", "speedup", "candidates"}
    assert d["model"] == "ggx" and d["variant"]["precision"] in ("single", "double")
    assert d["error"] <= 1e-3
    assert {c["label"] for c in d["candidates"]} >= {"full", "single", "masking=vcavity"}
    r = run_inprocess("simplest", "ashikhmin_shirley", "-t", "0.5", "-p", "fresnel=dielectric",
                      "--metric", "albedo")
    assert r.returncode == 0, r.stderr
    assert "cheapest variant within 0.5" in r.stdout and "fresnel=schlick" in r.stdout


def test_cli_preset():
    """A preset is an RGB configuration: its variants keep its channels and values."""
    r = run_inprocess("simplest", "low_microfacet", "--preset", "alum-bronze", "-t", "1e-3",
                      "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["variant"]["channels"] == 3 and len(d["variant"]["a"]) == 3
    assert "kd=0" in {c["label"] for c in d["candidates"]}


def test_cli_refuses_bad_input():
    for args, msg in ((("--tolerance", "-1"), "tolerance"), (("--tolerance", "nan"), "tolerance"),
                      (("-t", "1e-3", "-p", "alpha=0"), "alpha")):
        r = run_inprocess("simplest", "ggx", *args)
        assert r.returncode == 2 and msg in r.stderr, (args, r.stderr)
    r = run_inprocess("simplest", "ggx", "-t", "1e-3", "--metric", "bogus")
    assert r.returncode == 2


def test_cli_ladder_refuses_bad_input_before_work(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    r = run_inprocess("ladder", "ggx", "--out", str(f))
    assert r.returncode == 2 and "is a file" in r.stderr
    r = run_inprocess("ladder", "lambert", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "no ladder configuration" in r.stderr
    assert not (tmp_path / "o").exists()


def test_a_dropped_diffuse_term_beside_a_sharp_lobe_is_not_within_tolerance():
    """`clbrdf simplest ggx -t 0.01 -p alpha=0.05 -p kd=0.1` listed "kd=0, single" at a max
    relative error of f of 1.08e-3: the floor 1e-3 max f (max f 8e4 at the grazing mirror pair)
    was above kd / pi. Away from the lobe f is the Lambertian term alone: dropping it is a
    relative error near 1 there (against an independent count of the pairs)."""
    r = L.simplest("ggx", 0.01, "value", alpha=0.05, kd=0.1)
    assert all("kd=0" not in c.label or c.error > 0.5 for c in r.candidates)
    assert "kd=0" not in r.variant.label
    from clbrdf import Model
    m = Model("ggx", alpha=0.05, kd=0.1, precision="double")
    wo, wi = L.pairs()
    f = m.eval(wo, wi)
    assert np.median(np.abs(f - 0.1 / np.pi) / f) < 0.5      # most pairs: the diffuse term


def test_ladder_chart_labels_do_not_overprint():
    """The shipped ladder charts' labels overprinted (every variant annotated at its point);
    the chart now labels the Pareto front in a column beside each panel. Rendered from the
    shipped measurements of every model: no text over another, none cut off."""
    import csv
    from pathlib import Path
    from figures import assert_texts_readable
    rows = list(csv.DictReader(open(Path(__file__).parents[2] / "docs/ladder/ladder.csv")))
    for r in rows:
        for k in ("value_error", "albedo_error", "evals_per_s", "samples_per_s"):
            r[k] = float(r[k])
    for name in ("ggx", "schlick"):             # the most variants; a model of its own
        mine = [r for r in rows if r["model"] == name]
        assert mine, name
        fig = L.figure(mine, name, L.configs().get(name, {}))
        assert_texts_readable(fig)
        front = L.pareto(mine, "value_error", "evals_per_s")
        assert front and all(not (o["evals_per_s"] > f["evals_per_s"] and
                                  o["value_error"] < f["value_error"])
                             for f in front for o in mine)


def test_a_reflection_only_variant_of_glass_is_scored_over_the_whole_sphere():
    """The interface rung offers glass's reflection lobe alone (ggx with the dielectric Fresnel
    term): above the surface it is the dielectric's f to rounding, so over upper pairs alone
    (the pairs of a BRDF) it would look exact; over the whole sphere its value error is 1 (f = 0
    for a refracted wi) and its E error is max E_T / E over the ladder's mu (E_T by the
    dielectric's own lobes=transmission quadrature), where the full model's masking variant is
    measured the same way."""
    kw = L.configs()["ggx_dielectric"]
    name, full = L.full_config("ggx_dielectric", **kw)
    vs = [v for v in L.variants(name, full, precisions=("double",))
          if v.label in ("full", "reflection only: ggx")]
    assert [v.label for v in vs] == ["full", "reflection only: ggx"]
    assert vs[1].name == "ggx" and vs[1].kw["fresnel"] == "dielectric"
    L.measure_errors(vs, "value")
    assert vs[1].error == 1.0
    wo, wi = L.pairs()
    f_glass = np.asarray(clbrdf.Model(name, precision="double", **kw).eval(wo, wi), float)
    f_refl = np.asarray(clbrdf.Model("ggx", precision="double", **vs[1].kw).eval(wo, wi), float)
    np.testing.assert_allclose(f_refl, f_glass, rtol=1e-10, atol=0)
    L.measure_errors(vs, "albedo")
    mus = np.asarray(L.ALBEDO_MUS)
    e = clbrdf.albedo(clbrdf.Model(name, precision="double", **kw), mus, estimator="quadrature",
                      tol=1e-9).albedo
    et = clbrdf.albedo(clbrdf.Model(name, precision="double", lobes="transmission", **kw), mus,
                       estimator="quadrature", tol=1e-9).albedo
    assert abs(vs[1].error - np.max(et / e)) < 1e-6, (vs[1].error, et / e)


def test_a_partial_chart_run_keeps_the_other_models_rows(tmp_path):
    """``chart(models)`` of some models keeps the rows ladder.csv holds for the others (the
    whole ladder takes half an hour), and the README says which models this run measured."""
    import csv
    from pathlib import Path
    from clbrdf.tables.outputs import csv_rows
    shipped = Path(__file__).parents[2] / "docs/ladder/ladder.csv"
    (tmp_path / "ladder.csv").write_text(shipped.read_text())
    kept = csv_rows(tmp_path / "ladder.csv", L.FIELDS[4:], without=["ggx"])
    models = {r["model"] for r in kept}
    assert "ggx" not in models and {"beckmann", "gtr"} <= models
    with open(shipped, newline="") as f:
        want = [r for r in csv.DictReader(f) if r["model"] != "ggx"]
    assert [r["label"] for r in kept] == [r["label"] for r in want]
    assert all(isinstance(r["evals_per_s"], float) for r in kept)
    text = L.summary(kept, "clbrdf ladder --models beckmann", 1.0, ["beckmann"])
    assert "this run measured beckmann" in text and "## gtr" in text
