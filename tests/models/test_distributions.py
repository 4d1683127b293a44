"""GTR and SGD microfacet distributions (models ``gtr``, ``sgd``) and Bagher's SGD BRDF
(``sgd_bagher``) against the float64 reference clbrdf.ref.distributions (SciPy quadrature, no
tables, no series).

- reference: P22 integrates to 1/pi (the SGD 1/pi VERIFY), dj_brdf's kap is 1/(alpha
  Gamma(1-p, alpha)), the Lambda quadrature reproduces the closed forms;
- kernels: D, G1 (within the table error stated in kernels/dist_lambda_tables.h; GTR gamma = 1
  closed form), the inverse-CDF samplers against the reference inversion (SciPy root finding for
  SGD), extremes, presets.

What every model gets (values and densities against the reference, single against double
precision, RGB, the sampler's chi-square and weights, the albedo) is the conformance battery's
(tests/models/test_conformance.py) and clbrdf check's (tests/studies/test_check.py); this file keeps what is
specific to the paper.
"""
from __future__ import annotations

import csv
import math
import zlib

import numpy as np
import pytest

import clbrdf
from clbrdf.ref import distributions as RD
from clbrdf.models.spec import ParameterError

# max |G1 - G1_quad| of the Lambda tables (stated in kernels/dist_lambda_tables.h), rounded up
from test_distributions_lambda import TABLE_G1_ERR  # noqa: E402

GTR_CASES = [dict(alpha=0.3, gamma=1.5), dict(alpha=0.01, gamma=3.3), dict(alpha=0.9, gamma=0.7),
             dict(alpha=0.2, gamma=1.0), dict(alpha=0.05, gamma=2.0)]
SGD_CASES = [dict(alpha=0.01, p=0.5), dict(alpha=1e-4, p=1.5), dict(alpha=0.5, p=0.0),
             dict(alpha=0.05, p=1.0), dict(alpha=0.3, p=1.9)]
DIST_CASES = [("gtr", c) for c in GTR_CASES] + [("sgd", c) for c in SGD_CASES]


def cid(model, kw):
    return model + "-" + "-".join(f"{k}{v:g}" for k, v in kw.items())


DIST_IDS = [cid(m, k) for m, k in DIST_CASES]


def shape_of(model, kw):
    return kw["gamma"] if model == "gtr" else kw["p"]


def rand_dirs(rng, n, min_z=1e-2):
    z = rng.uniform(min_z, 1, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)


# ---------------------------------------------------------------------------------------------
# reference

@pytest.mark.parametrize("model,alpha,shape", [
    ("gtr", a, g) for a in (1e-3, 0.1, 0.5, 0.999) for g in (0.5, 1.0, 1.5, 2.0, 3.0, 4.0)] + [
    ("sgd", a, p) for a in (1e-5, 1e-3, 0.1, 1.0) for p in (0.0, 0.5, 1.0, 1.5, 2.0)])
def test_p22_integrates_to_inv_pi(model, alpha, shape):
    """integral_0^inf P22(x) dx = 1/pi (Table 1 with the 1/pi for SGD; p > 1 gives a negative
    incomplete-gamma shape, still finite), by quadrature in ln x."""
    f = lambda v: float(RD.p22(model, math.exp(v), alpha, shape)) * math.exp(v)
    from scipy import integrate
    pts = sorted({math.log(alpha * alpha), math.log(alpha), 0.0})
    val = sum(integrate.quad(f, lo, hi, epsabs=0, epsrel=1e-12, limit=500)[0]
              for lo, hi in zip([-80.0] + pts, pts + [80.0]))
    assert abs(val * math.pi - 1) < 1e-9


def _bagher_rows():
    path = clbrdf.presets.data_dir() / "sgd_bagher2012_fits.csv"
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_bagher_kap_is_the_normalisation():
    """dj_brdf's tabulated kap equals 1 / (alpha Gamma(1 - p, alpha)) for 99 materials x 3
    channels within their 6 printed digits (this also settles the 1/pi: dj_brdf's D carries it
    explicitly); chrome's parameters are rounded in the table (2200 vs 5938)."""
    worst = 0.0
    for row in _bagher_rows():
        for ch in "rgb":
            a, p, kap = (float(row[f"{k}_{ch}"]) for k in ("alpha", "p", "kap"))
            rel = abs(RD.sgd_kap(a, p) / kap - 1)
            if row["name"] == "chrome":
                assert rel > 0.5
            else:
                worst = max(worst, rel)
    assert worst < 1e-5


@pytest.mark.parametrize("a", [0.01, 0.3, 0.9])
@pytest.mark.parametrize("t", [0.1, 1.0, 10.0, 1e3])
def test_lambda_quadrature_matches_closed_forms(a, t):
    """lambda_quad against GGX (GTR gamma = 2), the GTR gamma = 1 closed form, and Beckmann with
    alpha_b = sqrt(a) (SGD p = 0)."""
    ggx = (math.sqrt(1 + a * a * t * t) - 1) / 2
    assert RD.lambda_quad("gtr", t, a, 2.0) == pytest.approx(ggx, rel=1e-9)
    assert RD.lambda_quad("gtr", t, a, 1.0) == pytest.approx(float(RD.lambda_gtr1(t, a)), rel=1e-9)
    m = 1 / (math.sqrt(a) * t)
    from scipy import special
    beck = (math.exp(-m * m) / (m * math.sqrt(math.pi)) - special.erfc(m)) / 2
    assert RD.lambda_quad("sgd", t, a, 0.0) == pytest.approx(beck, rel=1e-8, abs=1e-300)


# ---------------------------------------------------------------------------------------------
# kernels against the reference

@pytest.mark.parametrize("precision,width", [("single", 1), ("single", 16), ("double", 16)])
@pytest.mark.parametrize("model,kw", DIST_CASES, ids=DIST_IDS)
def test_D_matches_reference(model, kw, precision, width, model_cache):
    """masking=none: f = D / (4 cos_i cos_o), kernel against the reference at 400 random pairs."""
    m = model_cache(model, precision=precision, width=width, masking="none", **kw)
    rng = np.random.default_rng(zlib.crc32(cid(model, kw).encode()))
    wi, wo = rand_dirs(rng, 400), rand_dirs(rng, 400)
    f = m.eval(wo, wi)
    ref = RD.eval(model, wo, wi, masking="none", **kw)
    rtol = 2e-5 if precision == "single" else 1e-10
    np.testing.assert_allclose(f, ref, rtol=rtol, atol=1e-30 + 1e-12 * ref.max())


def mirror_pairs(mus):
    mus = np.asarray(mus, float)
    s = np.sqrt(1 - mus * mus)
    wo = np.stack([s, 0 * s, mus], -1)
    wi = np.stack([-s, 0 * s, mus], -1)
    return wi, wo


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("model,kw", DIST_CASES, ids=DIST_IDS)
def test_G1_matches_quadrature(model, kw, precision, model_cache):
    """G1 of the kernel at the mirror configuration (h = n, where D never underflows):
    f_separable / f_none = G1(w)^2. Against 1 / (1 + Lambda) by direct quadrature, within the
    table's stated error (GTR gamma = 1: the closed form, to rounding)."""
    mus = np.concatenate([np.geomspace(1e-4, 0.1, 6), np.linspace(0.15, 0.99, 8)])
    wi, wo = mirror_pairs(mus)
    f_none = model_cache(model, precision=precision, masking="none", **kw).eval(wo, wi)
    f_sep = model_cache(model, precision=precision, masking="separable", **kw).eval(wo, wi)
    g1 = np.sqrt(f_sep / f_none)
    lam = RD.Lambda(model, wo, kw["alpha"], shape_of(model, kw))
    ref = 1 / (1 + lam)
    exact = model == "gtr" and kw["gamma"] in (1.0, 2.0)
    tol = (2e-5 if precision == "single" else 1e-9) if exact else TABLE_G1_ERR[model]
    assert np.all(np.isfinite(g1))
    assert np.max(np.abs(g1 - ref)) <= tol, np.c_[mus, g1, ref]


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("model,kw", DIST_CASES, ids=DIST_IDS)
def test_sampler_inverts_cdf(model, kw, precision, model_cache):
    """wo = n: the sampled wi makes theta_i = 2 theta_h; tan^2 theta_h against the reference
    inversion of the CDF (GTR closed form; SGD: Brent's method on the quadrature Gamma(1-p, y)),
    and the reference CDF of that x gives back u0 (u0 from 1e-7 to 1 - 2^-23)."""
    m = model_cache(model, precision=precision, sampler="ndf", **kw)
    u0 = np.array([1e-7, 1e-4, 0.01, 0.2, 0.5, 0.7, 0.95, 0.999, 1 - 2 ** -20, 1 - 2 ** -23])
    u0 = u0.astype(np.float32).astype(np.float64)
    u = np.stack([u0, np.full_like(u0, 0.3), np.full_like(u0, 0.5), np.full_like(u0, 0.5)], -1)
    wi, _, _ = m.sample(np.array([0.0, 0.0, 1.0]), u)
    th = np.arctan2(np.hypot(wi[:, 0], wi[:, 1]), wi[:, 2]) / 2
    x = np.tan(th) ** 2
    ref = RD.sample_tan2(model, u0, kw["alpha"], shape_of(model, kw))
    rtol = 5e-4 if precision == "single" else 1e-7
    np.testing.assert_allclose(x, ref, rtol=rtol)


def test_vndf_sampler_rejected():
    for model, kw in (("gtr", {"gamma": 1.5}), ("sgd", {"p": 0.5})):
        with pytest.raises(ParameterError, match="sampler"):
            clbrdf.Model(model, sampler="vndf", **kw)


def test_gtr_continuous_at_gamma_one(model_cache):
    """gamma = 1 +- 1e-6 (general formulas and the table) against gamma = 1 (closed forms)."""
    rng = np.random.default_rng(3)
    wi, wo = rand_dirs(rng, 100), rand_dirs(rng, 100)
    f1 = model_cache("gtr", precision="double", alpha=0.2, gamma=1.0).eval(wo, wi)
    for g in (1 - 1e-6, 1 + 1e-6):
        f = model_cache("gtr", precision="double", alpha=0.2, gamma=g).eval(wo, wi)
        np.testing.assert_allclose(f, f1, rtol=1e-4)


# ---------------------------------------------------------------------------------------------
# sampling: pdf normalisation and chi-square (stats.HalfVectorMap, as tests/runtime/test_sampling.py)

NS_FINE, NT_FINE = 128, 256
NB_S, NB_T = 32, 32


@pytest.mark.parametrize("precision", ["single", "double"])
def test_extremes_finite(precision, model_cache):
    """Extreme valid parameters, cos theta down to 1e-6: eval, pdf and samples finite."""
    mus = np.array([1e-6, 1e-4, 0.01, 0.5, 1.0])
    s = np.sqrt(1 - mus ** 2)
    dirs = np.stack([s, 0 * s, mus], -1)
    wi = np.repeat(dirs, len(mus), 0)
    wo = np.tile(dirs * [-1, 1, 1], (len(mus), 1))
    u = np.random.default_rng(0).random((wi.shape[0], 4))
    u[:3, 0] = [0.0, 1e-7, 1 - 2 ** -24]
    cases = [("gtr", dict(alpha=a, gamma=g)) for a in (1e-3, 0.999) for g in (0.5, 1.0, 4.0)]
    cases += [("sgd", dict(alpha=a, p=p)) for a in (1e-5, 1.0) for p in (0.0, 1.0, 2.0)]
    for model, kw in cases:
        for masking in ("correlated", "separable"):
            m = model_cache(model, precision=precision, masking=masking, **kw)
            f = m.eval(wo, wi)
            pdf = m.pdf(wo, wi)
            swi, weight, spdf = m.sample(wo, u)
            for name, v in (("f", f), ("pdf", pdf), ("wi", swi), ("weight", weight), ("spdf", spdf)):
                assert np.all(np.isfinite(v)), (model, kw, masking, name)
            assert np.all(f >= 0) and np.all(weight >= 0)


# ---------------------------------------------------------------------------------------------
# sgd_bagher: dj_brdf's formula, presets, RGB mixture sampler


def test_bagher_presets_match_dj_brdf_formula():
    """Every preset of sgd_bagher2012_fits.csv, evaluated by the kernel (channels=3, double) at
    16 direction pairs, against bagher_eval (dj_brdf djb::sgd::eval written out in NumPy)."""
    from clbrdf.models import presets
    rng = np.random.default_rng(7)
    wi, wo = rand_dirs(rng, 16, 0.05), rand_dirs(rng, 16, 0.05)
    rows = _bagher_rows()
    assert len(rows) == 100
    for row in rows:
        pre = presets.get("sgd_bagher", row["name"])
        m = clbrdf.Model("sgd_bagher", precision="double", preset=row["name"])
        f = m.eval(wo, wi)
        for c, ch in enumerate("rgb"):
            prm = {k: float(row[f"{v}_{ch}"]) for k, v in
                   (("rho_d", "rhoD"), ("rho_s", "rhoS"), ("alpha", "alpha"), ("p", "p"),
                    ("f0", "f0"), ("f1", "f1"), ("kap", "kap"), ("lam", "lambda"), ("c", "c"),
                    ("k", "k"), ("theta0", "theta0"))}
            ref = RD.bagher_eval(wo, wi, **prm)
            np.testing.assert_allclose(f[:, c], ref, rtol=1e-9, atol=1e-300,
                                       err_msg=f"{row['name']} {ch}")
        assert pre.params["lam"][0] == float(row["lambda_r"])


@pytest.mark.parametrize("precision", ["single", "double"])
def test_bagher_negative_fresnel_fit_is_clamped(precision):
    """F = f0 - f1 c + (1 - c)^5 (1 - f0) goes below 0 near c = 1 when f1 > f0 (3 of the 100
    published fits; f0 = 0.1, f1 = 0.5 here: F(1) = -0.4): the kernel and the reference take
    max(F, 0), so f and E are never negative (before: f(n, n) = -12.7 /sr, E(1) = -0.157). At c = 1
    only the diffuse term is left: f(n, n) = rho_d / pi."""
    m = clbrdf.Model("sgd_bagher", precision=precision, f0=0.1, f1=0.5)
    n = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(m.eval(n, n), 0.1 / np.pi, rtol=1e-6)
    assert np.all(clbrdf.albedo(m, [1.0, 0.5, 0.1], samples=1 << 14).albedo >= 0)
    mp = clbrdf.Model("sgd_bagher", precision=precision, preset="blue-fabric")
    assert np.all(mp.eval(n, n) >= 0) and np.all(clbrdf.albedo(mp, 1.0, samples=1 << 14).albedo >= 0)


