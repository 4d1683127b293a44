"""GTR and SGD microfacet distributions (models ``gtr``, ``sgd``) and Bagher's SGD BRDF
(``sgd_bagher``) against the float64 reference clbrdf.ref.distributions (SciPy quadrature, no
tables, no series).

- reference: P22 integrates to 1/pi (the SGD 1/pi VERIFY), dj_brdf's kap is 1/(alpha
  Gamma(1-p, alpha)), the Lambda quadrature reproduces the closed forms;
- kernels: D, G1 (within the table error stated in kernels/dist_lambda_tables.h; GTR gamma = 1
  closed form), the inverse-CDF samplers against the reference inversion (SciPy root finding for
  SGD), weight = f cos / pdf, reciprocity, pdf normalisation, chi-square of 2^20 samples,
  Monte Carlo albedo against quadrature, extremes, RGB, presets.
"""
from __future__ import annotations

import csv
import math
import zlib

import numpy as np
import pytest

import clbrdf
import stats as S
from clbrdf.ref import distributions as RD
from clbrdf.models.spec import ParameterError

N_SAMPLES = 1 << 20
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


def slope_scale(model, kw):
    """Width of the lobe in slope space: GTR a; SGD the root of the mean tan^2 theta_h."""
    a = kw["alpha"]
    if model == "gtr":
        return a
    p = kw["p"]
    return math.sqrt(a * (1 - p + a ** (1 - p) * math.exp(-a) / RD.upper_gamma(1 - p, a) - a))


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


@pytest.mark.parametrize("model,kw", [DIST_CASES[0], DIST_CASES[6]], ids=[DIST_IDS[0], DIST_IDS[6]])
def test_widths_agree(model, kw, model_cache):
    """Every lane width (the table gathers are written out per width) gives the same f with the
    tabulated Lambda, and the same samples, as width 16 (single precision)."""
    rng = np.random.default_rng(9)
    wi, wo = rand_dirs(rng, 333, 1e-3), rand_dirs(rng, 333, 1e-3)
    u = rng.random((333, 4))
    ref = model_cache(model, width=16, masking="correlated", **kw)
    f16, s16 = ref.eval(wo, wi), ref.sample(wo, u)
    for w in (1, 2, 4, 8):
        m = model_cache(model, width=w, masking="correlated", **kw)
        np.testing.assert_allclose(m.eval(wo, wi), f16, rtol=1e-5, atol=1e-30)
        s = m.sample(wo, u)
        np.testing.assert_allclose(s[0], s16[0], rtol=1e-4, atol=1e-5)
        np.testing.assert_allclose(s[1], s16[1], rtol=1e-4, atol=1e-6)


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


@pytest.mark.parametrize("model,kw", DIST_CASES, ids=DIST_IDS)
def test_reciprocity_and_weight(model, kw, model_cache):
    """f(wi, wo) = f(wo, wi) (masking correlated, Schlick Fresnel, Lambertian term); a sample's
    weight equals f cos / pdf from eval and pdf (double precision)."""
    m = model_cache(model, precision="double", f0=0.3, kd=0.2, **kw)
    rng = np.random.default_rng(5)
    wi, wo = rand_dirs(rng, 200), rand_dirs(rng, 200)
    np.testing.assert_allclose(m.eval(wo, wi), m.eval(wi, wo), rtol=1e-12)
    u = rng.random((400, 4))
    wo = rand_dirs(rng, 400, 0.05)
    s_wi, weight, pdf = m.sample(wo, u)
    up = s_wi[:, 2] > 0
    assert np.all(weight[~up] == 0)
    f = m.eval(wo[up], s_wi[up])
    np.testing.assert_allclose(pdf[up], m.pdf(wo[up], s_wi[up]), rtol=1e-9)
    np.testing.assert_allclose(weight[up], f * s_wi[up, 2] / pdf[up], rtol=1e-9)


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
# sampling: pdf normalisation and chi-square (stats.HalfVectorMap, as tests/test_sampling.py)

NS_FINE, NT_FINE = 128, 256
NB_S, NB_T = 32, 32

SAMPLING_CASES = [("gtr", dict(alpha=0.3, gamma=1.5), 0.5), ("gtr", dict(alpha=0.02, gamma=3.0), 0.1),
                  ("gtr", dict(alpha=0.5, gamma=1.0), 1.0), ("sgd", dict(alpha=0.01, p=0.5), 0.4),
                  ("sgd", dict(alpha=1e-3, p=1.6), 0.05), ("sgd", dict(alpha=0.6, p=0.0), 0.8)]
SAMPLING_IDS = [cid(m, k) + f"-mu{mu:g}" for m, k, mu in SAMPLING_CASES]


@pytest.mark.chisquare(n=1)
@pytest.mark.parametrize("model,kw,mu", SAMPLING_CASES, ids=SAMPLING_IDS)
def test_samples_follow_pdf(model, kw, mu, model_cache, chi2_alpha):
    """The kernel pdf (double) integrates over the upper hemisphere to the fraction of 2^20
    single-precision samples above it (4 binomial sd + quadrature error), and the samples pass
    Pearson's chi-square over ~1000 equal-count bins (pooled below 5, Sidak-corrected)."""
    m = model_cache(model, sampler="ndf", **kw)
    md = model_cache(model, precision="double", sampler="ndf", **kw)
    sc = slope_scale(model, kw)
    hmap = S.HalfVectorMap(S.direction(mu, 0.3), sc, sc)
    wo = hmap.wo

    def pdf(wi):
        return md.pdf(wo, wi)
    n = N_SAMPLES
    wi, _, _ = S.draw(m, wo, n, zlib.crc32(cid(model, kw).encode()))
    r = S.map_chi2(hmap, pdf, wi, NS_FINE, NT_FINE, (4, 3), NB_S, NB_T, max_qerr=None)
    assert r.total_err < 1e-5
    sigma = math.sqrt(max(r.above * (1 - r.above), 1 / n) / n)
    assert abs(r.total - r.above) <= 4 * sigma + r.total_err + 1e-7
    assert r.p >= chi2_alpha, f"chi2 {r.stat:.1f} with {r.dof} dof, p = {r.p:.3g} < {chi2_alpha:.3g}"


ALBEDO_CASES = [("gtr", dict(alpha=0.3, gamma=1.5), "none"), ("gtr", dict(alpha=0.05, gamma=1.0), "none"),
                ("sgd", dict(alpha=0.01, p=0.5), "none"), ("sgd", dict(alpha=0.002, p=1.4), "none"),
                ("gtr", dict(alpha=0.2, gamma=1.0), "correlated")]


@pytest.mark.parametrize("model,kw,masking", ALBEDO_CASES,
                         ids=[cid(m, k) + "-" + g for m, k, g in ALBEDO_CASES])
def test_albedo_matches_reference(model, kw, masking, model_cache):
    """BRDF-sampled Monte Carlo albedo, 2^18 samples, within 4 standard errors + the quadrature
    error of clbrdf.ref.distributions.albedo: masking=none (no Lambda table involved), and GTR
    gamma = 1 with the correlated Smith term (closed-form Lambda on both sides)."""
    m = model_cache(model, masking=masking, **kw)
    mus = np.array([0.1, 0.5, 1.0])
    r = clbrdf.albedo(m, mus, estimator="brdf", samples=1 << 18, seed=4)
    ref = [RD.albedo(model, mu, tol=1e-7, masking=masking, **kw) for mu in mus]
    e_ref = np.array([v for v, _ in ref])
    err = np.array([e for _, e in ref])
    assert np.all(np.abs(r.albedo - e_ref) <= 4 * r.stderr + err + 1e-6), (r.albedo, e_ref, r.stderr)


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

def bagher_channel(params, c):
    return {k: (v[c] if isinstance(v, (list, tuple, np.ndarray)) else v) for k, v in params.items()}


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


BAGHER = dict(rho_d=[0.3, 0.1, 0.05], rho_s=[0.2, 0.5, 0.8], alpha=[0.02, 0.005, 0.3],
              p=[0.4, 1.5, 0.0], f0=[1.2, 0.5, 1.0], f1=[0.2, -0.3, 0.0],
              lam=[3.0, 0.5, 1.0], c=[1e-7, 2e-6, 1e-3], k=[30.0, 20.0, 5.0],
              theta0=[0.3, 0.5, -0.2])


# Launches of sgd_bagher with channels=3 are chunked to 2^14 points: a launch of 2^17 points or
# more segfaults in PoCL (work-groups of 4096 work-items, which PoCL picks for such global sizes,
# times the private Params struct of 11 x 3 double16 = 4 KB per work-item overflow the thread's
# stack; POCL_MAX_WORK_GROUP_SIZE=256 avoids it). Reported to the engine's owner.
CHUNK = 1 << 14


def chunked_pdf(m, wo, wi, chunk=CHUNK):
    """m.pdf in chunks (see CHUNK)."""
    return np.concatenate([m.pdf(wo, wi[i:i + chunk]) for i in range(0, len(wi), chunk)])


def test_bagher_rgb_equals_channels(model_cache):
    """channels=3 equals three channels=1 models (eval, and pdf when every channel is alike)."""
    rng = np.random.default_rng(11)
    wi, wo = rand_dirs(rng, 64), rand_dirs(rng, 64)
    f3 = model_cache("sgd_bagher", precision="double", channels=3, **BAGHER).eval(wo, wi)
    for c in range(3):
        f1 = model_cache("sgd_bagher", precision="double", **bagher_channel(BAGHER, c)).eval(wo, wi)
        np.testing.assert_allclose(f3[:, c], f1, rtol=1e-12)
    same = {k: [v[1]] * 3 for k, v in BAGHER.items()}
    p3 = model_cache("sgd_bagher", precision="double", channels=3, **same).pdf(wo, wi)
    p1 = model_cache("sgd_bagher", precision="double", **bagher_channel(BAGHER, 1)).pdf(wo, wi)
    np.testing.assert_allclose(p3, p1, rtol=1e-12)


def test_bagher_pdf_weight_and_reference(model_cache):
    """The RGB mixture pdf against the reference mixture (normalised SGD per channel), a sample's
    weight = f cos / pdf per channel, reciprocity of f, and the pdf integrating to the fraction
    above the horizon (cosine-map quadrature of the lobes + 2^20 samples)."""
    m = model_cache("sgd_bagher", precision="double", channels=3, **BAGHER)
    rng = np.random.default_rng(2)
    wi, wo = rand_dirs(rng, 300), rand_dirs(rng, 300)
    ref = RD.pdf("sgd_bagher", wo, wi, **BAGHER)
    np.testing.assert_allclose(m.pdf(wo, wi), ref, rtol=1e-9)
    np.testing.assert_allclose(m.eval(wo, wi), m.eval(wi, wo), rtol=1e-12)
    u = rng.random((500, 4))
    wo = rand_dirs(rng, 500, 0.05)
    s_wi, weight, pdf = m.sample(wo, u)
    up = s_wi[:, 2] > 0
    f = m.eval(wo[up], s_wi[up])
    np.testing.assert_allclose(weight[up], f * s_wi[up, 2, None] / pdf[up, None], rtol=1e-9)
    assert np.all(weight[~up] == 0)


@pytest.mark.chisquare(n=1)
@pytest.mark.parametrize("mu", [0.3])
def test_bagher_samples_follow_pdf(mu, model_cache, chi2_alpha):
    """2^20 samples of the RGB mixture (single precision) against its density (double), bins of
    stats.HalfVectorMap scaled to the sharpest lobe; normalisation as in test_samples_follow_pdf."""
    m = model_cache("sgd_bagher", channels=3, **BAGHER)
    md = model_cache("sgd_bagher", precision="double", channels=3, **BAGHER)
    sc = min(slope_scale("sgd", dict(alpha=a, p=p)) for a, p in zip(BAGHER["alpha"], BAGHER["p"]))
    hmap = S.HalfVectorMap(S.direction(mu, 1.0), sc, sc)
    wo = hmap.wo
    n = N_SAMPLES
    wi, _, _ = S.draw(m, wo, n, 99, chunk=CHUNK)
    r = S.map_chi2(hmap, lambda w: chunked_pdf(md, wo, w), wi, NS_FINE, NT_FINE, (4, 3), NB_S, NB_T,
                   max_qerr=None, nonneg=False)
    assert r.total_err < 1e-5
    frac = r.above
    assert abs(r.total - frac) <= 4 * math.sqrt(max(frac * (1 - frac), 1 / n) / n) + r.total_err + 1e-7
    assert r.p >= chi2_alpha, f"chi2 {r.stat:.1f} with {r.dof} dof, p = {r.p:.3g}"


def test_bagher_albedo_matches_reference(model_cache):
    """One channel of a preset (alum-bronze, green): Monte Carlo albedo (mixture sampler, 2^18)
    within 4 standard errors of the quadrature of dj_brdf's formula."""
    row = next(r for r in _bagher_rows() if r["name"] == "alum-bronze")
    prm = {k: float(row[f"{v}_g"]) for k, v in
           (("rho_d", "rhoD"), ("rho_s", "rhoS"), ("alpha", "alpha"), ("p", "p"), ("f0", "f0"),
            ("f1", "f1"), ("kap", "kap"), ("lam", "lambda"), ("c", "c"), ("k", "k"),
            ("theta0", "theta0"))}
    m = model_cache("sgd_bagher", **prm)
    mus = np.array([0.2, 0.7])
    r = clbrdf.albedo(m, mus, estimator="brdf", samples=1 << 18, seed=8)
    ref = [RD.albedo("sgd_bagher", mu, tol=1e-7, **prm) for mu in mus]
    e_ref = np.array([v for v, _ in ref])
    err = np.array([e for _, e in ref])
    assert np.all(np.abs(r.albedo - e_ref) <= 4 * r.stderr + err + 1e-6), (r.albedo, e_ref, r.stderr)
