"""The metal presets (clbrdf/data/published_fits/metals_rgb.md) against the tabulated optical
constants they come from, and the fits of clbrdf.studies.fresnel_fits: what each matches
exactly, the kernel's F_avg of each fit against the fit's own, and the ladder's Fresnel rungs."""
import csv
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import simpson

import clbrdf
from clbrdf.ref.microfacet import fresnel
from clbrdf.studies import ladder
from clbrdf.studies.fresnel_fits import FITS, fit_conductor, fresnel_errors

NK = Path(__file__).parents[1] / "data" / "metals_nk.csv"
RGB_UM = (0.645, 0.526, 0.444)         # docs/models/microfacet.md
METALS = ("gold", "silver", "copper", "chromium", "aluminium")


def _tabulated():
    rows = [r for r in csv.DictReader(ln for ln in NK.read_text().splitlines()
                                      if not ln.startswith("#"))]
    out = {}
    for r in rows:
        out.setdefault(r["name"], []).append([float(r[k]) for k in ("wavelength_um", "n", "k")])
    return {k: np.array(v) for k, v in out.items()}


def test_presets_are_the_tabulated_constants_at_the_rgb_wavelengths():
    tab = _tabulated()
    assert sorted(tab) == sorted(METALS) == clbrdf.presets.materials("ggx")     # the default source
    for m in METALS:
        t = tab[m]
        p = clbrdf.presets.get("ggx", m)
        assert p.options == {"fresnel": "conductor"}
        for key, col in (("eta", 1), ("k", 2)):
            want = [np.interp(w, t[:, 0], t[:, col]) for w in RGB_UM]
            np.testing.assert_allclose(p.params[key], want, rtol=1e-5, err_msg=(m, key))
    # the same material for beckmann, whose default source is Löw's fits
    assert clbrdf.Model("beckmann", preset="gold").preset.source == "metals_rgb.csv"
    assert clbrdf.Model("beckmann", preset="alum-bronze").preset.source != "metals_rgb.csv"


@pytest.mark.parametrize("metal", METALS)
def test_fits_match_the_conductor_where_they_are_defined_to(metal):
    """Schlick and F82 take F(1); F82 also F(1/7) unless its tint clips at 1 (gold's green
    channel: F(1/7) is 1.2 % above Schlick's there); the generalised Schlick exponent is a
    least-squares minimum; the kernel's F_avg of each fit equals the fit's own quadrature."""
    p = clbrdf.presets.get("ggx", metal).params
    eta, k = np.ravel(p["eta"]), np.ravel(p["k"])
    exact = lambda c: fresnel("conductor", c, eta=eta, k=k)          # noqa: E731
    for kind in FITS:
        q = fit_conductor(eta, k, kind)
        np.testing.assert_allclose(q["f0"], exact(1.0), rtol=1e-14)
        e = fresnel_errors(eta, k, kind, q)
        kern = clbrdf.fresnel_avg("ggx", fresnel=kind, channels=3,
                                  **{a: b for a, b in q.items()})
        np.testing.assert_allclose(np.ravel(kern), e["F_avg_fit"], atol=1e-7)
    f82 = fit_conductor(eta, k, "f82")
    got = fresnel("f82", 1 / 7, f0=np.array(f82["f0"]), f82=np.array(f82["f82"]))
    free = np.array(f82["f82"]) < 1
    np.testing.assert_allclose(got[free], exact(1 / 7)[free], rtol=1e-12)
    gs = fit_conductor(eta, k, "gen_schlick")
    loss = lambda n: _ls(eta, k, gs, n)                             # noqa: E731
    assert loss(gs["exponent"]) <= min(loss(gs["exponent"] * 0.99), loss(gs["exponent"] * 1.01))


def _ls(eta, k, gs, n):
    c = np.linspace(0, 1, 4001)[:, None]
    d = fresnel("gen_schlick", c, f0=np.array(gs["f0"]), f90=1.0, exponent=n) \
        - fresnel("conductor", c, eta=eta, k=k)
    return float(simpson((2 * c * d * d).sum(axis=1), x=c[:, 0]))


def test_gold_green_tint_clips_at_one():
    p = clbrdf.presets.get("ggx", "gold").params
    eta, k = np.ravel(p["eta"]), np.ravel(p["k"])
    f0 = fresnel("conductor", 1.0, eta=eta, k=k)
    ratio = fresnel("conductor", 1 / 7, eta=eta, k=k) / (f0 + (1 - f0) * (6 / 7) ** 5)
    assert ratio[1] > 1 and fit_conductor(eta, k, "f82")["f82"][1] == 1.0


def test_ladder_offers_the_fitted_fresnel_terms_of_a_conductor():
    """Copper at alpha 0.5 (docs/fresnel/README.md): F82-tint within 1 % of the exact
    conductor's albedo, Schlick not; the rungs carry the fits' parameters."""
    name, kw = ladder.full_config("ggx", preset="copper", alpha=0.5)
    vs = [v for v in ladder.variants(name, kw, precisions=("double",))
          if v.label in ("full", "fresnel=f82", "fresnel=gen_schlick", "fresnel=schlick")]
    assert [v.label for v in vs] == ["full", "fresnel=f82", "fresnel=gen_schlick",
                                     "fresnel=schlick"]
    f82 = fit_conductor(np.ravel(kw["eta"]), np.ravel(kw["k"]), "f82")
    np.testing.assert_allclose(vs[1].kw["f82"], f82["f82"])
    ladder.measure_errors(vs, "albedo")
    err = {v.label: v.error for v in vs}
    assert err["fresnel=f82"] < 0.01 < err["fresnel=schlick"], err


def test_openpbr_defaults():
    """published_fits/openpbr.md: OpenPBR Surface's defaults as presets of its lobes; at rho 0.8
    and r 0 EON is Lambert's 0.8 (its quadrature, to 1e-6); each model has only its own rows."""
    base = clbrdf.Model("oren_nayar", preset="openpbr-base", precision="double")
    assert base.options["form"] == "eon"
    e = clbrdf.albedo(base, [0.1, 0.5, 1.0], estimator="quadrature").albedo
    np.testing.assert_allclose(e, 0.8, atol=1e-6)
    spec = clbrdf.Model("ggx", preset="openpbr-specular")
    assert spec.options["fresnel"] == "dielectric" and float(spec.params["alpha"]) == 0.09
    np.testing.assert_allclose(spec.params["eta"], 1.5)
    metal = clbrdf.Model("ggx", preset="openpbr-metal", alpha=0.2)
    assert metal.options["fresnel"] == "f82" and float(metal.params["alpha"]) == 0.2
    np.testing.assert_allclose(metal.params["f0"], 0.8)
    np.testing.assert_allclose(metal.params["f82"], 1.0)
    with pytest.raises(clbrdf.ParameterError, match="not a material of ggx"):
        clbrdf.Model("ggx", preset="openpbr-base")
    with pytest.raises(clbrdf.ParameterError, match="not a material of oren_nayar"):
        clbrdf.Model("oren_nayar", preset="openpbr-metal")
