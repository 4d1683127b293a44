"""Kernel values, sampling arithmetic, precisions, widths, extremes and random numbers.

Every model configuration is checked against the independent float64 NumPy reference
(clbrdf.ref.microfacet). The default run covers Lambert and a 16-row pairwise covering array of the
microfacet options (dist x iso/aniso x masking x fresnel x kd x sampler: every pair of values of
any two options occurs); ``-m slow`` adds the rest of the full product (256 configurations).

Tolerances (stats.py explains the conditioning terms):
- single precision: relative 1e-4, plus 8 eps (1 + sqrt(e)) / alpha_min for the rounding of the
  half vector (e the slope exponent); the kernel sees float32-rounded inputs, so the reference is
  evaluated at exactly those inputs. Absolute floor 1e-36: float32 has no relative precision below
  its smallest normal number 1.2e-38; every value that matters is 30 orders of magnitude larger.
  Where Beckmann's exp(-e) is flushed to 0 on purpose (e >= 85 single, 700 double: the kernel
  does that to avoid 0/0 at grazing h) a kernel 0 is accepted; the reference value there is below
  exp(-85) / (pi alpha^2 cos^4 theta_h 4 cos_i cos_o) < 1e-27.
- double precision: relative 1e-10 plus the same conditioning term with eps = 2^-53; floor 1e-300.
"""
import numpy as np
import pytest
from scipy.special import erf

import clbrdf
import stats as S
from clbrdf.ref import microfacet as R
from stats import assert_close

PREC = {  # dtype, unit roundoff, base rtol, absolute floor, Beckmann flush exponent
    "single": (np.float32, S.EPS32, 1e-4, 1e-36, 85.0),
    "double": (np.float64, S.EPS64, 1e-10, 1e-300, 700.0),
}

COVER = S.COVER
SLOW_EXTRA = [pytest.param(c, marks=pytest.mark.slow, id=S.config_id(c)) for c in S.full_not_in_cover()]
ALL_CONFIGS = [pytest.param(c, id=S.config_id(c)) for c in COVER] + SLOW_EXTRA


def random_params(cfg, rng, n, log_alpha=(-3, 1)):
    """Per-pair parameters: alpha log-uniform over log_alpha, Fresnel parameters and kd uniform.
    Dielectric eta in [1.05, 3] (eta < 1 has total internal reflection, a kink in F, covered in
    the extremes test), conductor eta in [0.1, 3], k in [0.5, 5] (eta ~ 1 with k ~ 0 is the
    cancellation case of test_conductor_fresnel_nonnegative)."""
    ax = 10 ** rng.uniform(*log_alpha, n)
    ay = 10 ** rng.uniform(*log_alpha, n) if cfg.get("aniso") else ax
    over = {"f0": rng.uniform(0, 1, n), "kd": rng.uniform(0, 1, n)}
    if cfg.get("fresnel") == "dielectric":
        over["eta"] = rng.uniform(1.05, 3, n)
    if cfg.get("fresnel") == "conductor":
        over["eta"] = rng.uniform(0.1, 3, n)
        over["k"] = rng.uniform(0.5, 5, n)
    kw = S.model_kwargs(cfg, alpha=ax, alpha_y=ay, **over)
    return kw, S.alphas(kw)


# ---------------------------------------------------------------------------------------------
# 1. eval and pdf against the reference

@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("cfg", ALL_CONFIGS)
def test_eval_pdf_match_reference(cfg, precision, model_cache):
    dtype, eps, base, atol, cut = PREC[precision]
    rng = np.random.default_rng(101)
    n = 6000
    kw, (ax, ay) = random_params(cfg, rng, n)
    ax, ay = np.broadcast_to(ax, (n,)), np.broadcast_to(ay, (n,))
    wi, wo = S.random_pairs(rng, n, ax, ay, min_z=1e-3)
    wi, wo = S.round_to(dtype, wi, wo)
    kw = {k: (S.round_to(dtype, v)[0] if isinstance(v, np.ndarray) else v) for k, v in kw.items()}
    m = model_cache(cfg["name"], precision=precision, **kw)
    rkw = S.ref_kwargs(kw)
    f_ref = R.eval(cfg["name"], wo, wi, **rkw)
    p_ref = R.pdf(cfg["name"], wo, wi, "brdf", **rkw)
    f = m.eval(wo, wi)
    p = m.pdf(wo, wi)
    assert f.dtype == dtype and p.dtype == dtype
    e, _ = S.slope_exponent(wi, wo, ax, ay)
    rtol = S.cond_rtol(base, eps, wi, wo, ax, ay)
    flush = (e >= cut - 0.01) if cfg["name"] == "beckmann" else None
    ctx = {"wi": wi, "wo": wo, "alpha_x": ax, "alpha_y": ay}
    assert_close(f, f_ref, rtol, atol, allow_zero=flush, what="eval", context=ctx)
    assert_close(p, p_ref, rtol, atol, allow_zero=flush, what="pdf", context=ctx)
    below = wi[:, 2] <= 0
    assert below.any() and np.all(f[below] == 0) and np.all(p[below] == 0)


# ---------------------------------------------------------------------------------------------
# 2. reciprocity

@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("cfg", ALL_CONFIGS)
def test_reciprocity(cfg, precision, model_cache):
    """f(wi, wo) == f(wo, wi). Tolerance: 128 eps (the dielectric Fresnel term cancels in
    g - c for eta near 1: relative error ~ 2 eps c / (g - c), up to ~40 eps at eta = 1.05,
    squared in F; measured 34 eps) plus the half-vector conditioning term, plus
    8 eps / (wo.h)^2: float inputs have length 1 +- eps, for which wi.h and wo.h (used by Fresnel
    and the V-cavity term) differ by (|wi|^2 - |wo|^2) / |wi + wo| ~ eps / (wo.h) -- relative
    eps / (wo.h)^2. For wo.h > 0.1 this is below 1e-4 (single): an asymmetric formula gives O(1)."""
    dtype, eps, *_ = PREC[precision]
    rng = np.random.default_rng(202)
    n = 6000
    kw, (ax, ay) = random_params(cfg, rng, n)
    ax, ay = np.broadcast_to(ax, (n,)), np.broadcast_to(ay, (n,))
    wi, wo = S.random_pairs(rng, n, ax, ay, min_z=1e-3, below=0)
    wi, wo = S.round_to(dtype, wi, wo)
    m = model_cache(cfg["name"], precision=precision, **kw)
    a = m.eval(wo, wi)
    b = m.eval(wi, wo)
    _, woh = S.slope_exponent(wi, wo, ax, ay)
    rtol = S.cond_rtol(128 * eps, eps, wi, wo, ax, ay) + 8 * eps / woh ** 2
    assert_close(a, b, rtol, PREC[precision][3], what="f(wi,wo) vs f(wo,wi)",
                 context={"wi": wi, "wo": wo, "alpha_x": ax, "alpha_y": ay})


# ---------------------------------------------------------------------------------------------
# 4. weight == f cos / pdf, and the sampled pdf == the pdf kernel

def sample_directions(rng, n, min_mu=0.05):
    """wo with log-uniform cos theta in [min_mu, 1] and uniform azimuth."""
    return S.direction(10 ** rng.uniform(np.log10(min_mu), 0, n), rng.uniform(0, 2 * np.pi, n))


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("cfg", ALL_CONFIGS)
def test_sample_weight_and_pdf_consistent(cfg, precision, model_cache):
    """For samples of Model.sample (the library's generator): pdf == pdf kernel at (wo, wi) and
    weight == eval(wo, wi) wi.z / pdf(wo, wi), each from a separate kernel call; weight = pdf = 0
    below the horizon. The sample computes its values from its own half vector h, the separate
    calls from normalize(wi + wo) with wi rounded to the output precision: the pdf then carries
    the half-vector conditioning, amplified by 1 / (2 wo.h) (stats.cond_rtol, amplify); in the
    weight D cancels and what remains is G and F (stats.weight_rtol)."""
    dtype, eps, base, atol, _ = PREC[precision]
    rng = np.random.default_rng(303)
    n = 20000
    kw, (ax, ay) = random_params(cfg, rng, n, log_alpha=(np.log10(0.02), 0.5))
    ax, ay = np.broadcast_to(ax, (n,)), np.broadcast_to(ay, (n,))
    wo = S.round_to(dtype, sample_directions(rng, n))[0]
    m = model_cache(cfg["name"], precision=precision, **kw)
    wi, weight, pdf = m.sample(wo, seed=17)
    wi = wi.astype(float)
    assert np.all(np.isfinite(wi)) and np.all(np.isfinite(weight)) and np.all(np.isfinite(pdf))
    below = ~(wi[:, 2] > 0)
    assert np.all(weight[below] == 0) and np.all(pdf[below] == 0)
    assert np.all(weight >= 0) and np.all(pdf >= 0)
    up = ~below
    p2 = m.pdf(wo, wi)[up]          # per-pair parameters: evaluate all pairs, then select
    f2 = m.eval(wo, wi)[up]
    ctx = {"wi": wi[up], "wo": wo[up], "alpha_x": ax[up], "alpha_y": ay[up]}
    rtol_p = S.cond_rtol(base, eps, wi[up], wo[up], ax[up], ay[up], amplify=True)
    assert_close(pdf[up], p2, rtol_p, atol, what="sample pdf vs pdf kernel", context=ctx)
    rtol_w = S.weight_rtol(base, eps, wi[up], wo[up], ax[up], ay[up])
    with np.errstate(divide="ignore", invalid="ignore"):
        w2 = f2.astype(float) * wi[up, 2] / p2.astype(float)
    assert_close(weight[up], w2, rtol_w, atol, what="weight vs f cos / pdf", context=ctx)


# ---------------------------------------------------------------------------------------------
# 6. single vs double precision, and lane widths

def exact_float32_u(rng, n):
    """Uniform numbers k 2^-24, 0 < k < 2^24: exactly representable in float32, so that single
    and double kernels see the same u."""
    return rng.integers(1, 1 << 24, (n, 4)) * 2.0 ** -24


PRECISION_CONFIGS = [pytest.param(c, id=S.config_id(c)) for c in COVER] + SLOW_EXTRA


@pytest.mark.parametrize("cfg", PRECISION_CONFIGS)
def test_single_matches_double(cfg, model_cache):
    """Same inputs and the same u in both precisions.
    - eval/pdf: single-precision tolerance at identical (float32) inputs.
    - sample directions: 99.9% within 1e-5 and all within 1e-4 (3e-4 for Beckmann's visible-normal
      sampler). The sampler's inverse maps amplify float32 rounding: Beckmann VNDF inverts the
      slope CDF in the erf domain, where the slope s has d s / d b = sqrt(pi)/2 exp(s^2): at the
      extreme u (s ~ 3) one ulp of b moves s by ~5e-4 alpha. Measured worst cases: GGX 1.7e-5,
      Beckmann NDF 1.2e-6, Beckmann VNDF 2.3e-4. The bound on the maximum applies where u0, u1
      are in [1e-4, 1 - 1e-4]: beyond, Beckmann VNDF in float32 loses the slope entirely
      (direction errors 5e-4 .. 3e-3 at u0 = 7e-7, up to 8e-2 at u0 = 2^-24; probability ~1e-6,
      harmless for the distribution, which the chi-square tests check).
    - sample weight and pdf: the single values against the double model evaluated at the single
      precision direction (which separates the value error from the direction error), with the
      tolerances of test_sample_weight_and_pdf_consistent."""
    rng = np.random.default_rng(404)
    n = 20000
    kw, (ax, ay) = random_params(cfg, rng, n, log_alpha=(np.log10(0.02), 0.5))
    kw = {k: (S.round_to(np.float32, v)[0] if isinstance(v, np.ndarray) else v) for k, v in kw.items()}
    ax, ay = S.alphas(kw)
    ax, ay = np.broadcast_to(ax, (n,)), np.broadcast_to(ay, (n,))
    ms = model_cache(cfg["name"], precision="single", **kw)
    md = model_cache(cfg["name"], precision="double", **kw)
    eps = S.EPS32
    wi, wo = S.random_pairs(rng, n, ax, ay, min_z=1e-3)
    wi, wo = S.round_to(np.float32, wi, wo)
    rtol = S.cond_rtol(1e-4, eps, wi, wo, ax, ay)
    ctx = {"wi": wi, "wo": wo, "alpha_x": ax, "alpha_y": ay}
    flush = None
    if cfg["name"] == "beckmann":
        flush = S.slope_exponent(wi, wo, ax, ay)[0] >= 85 - 0.01
    assert_close(ms.eval(wo, wi), md.eval(wo, wi), rtol, 1e-36, allow_zero=flush,
                 what="eval single vs double", context=ctx)
    assert_close(ms.pdf(wo, wi), md.pdf(wo, wi), rtol, 1e-36, allow_zero=flush,
                 what="pdf single vs double", context=ctx)

    wo = S.round_to(np.float32, sample_directions(rng, n, min_mu=0.01))[0]
    u = exact_float32_u(rng, n)
    ws, vs, ps = ms.sample(wo, u)
    wd, vd, pd = md.sample(wo, u)
    dw = np.abs(ws.astype(float) - wd).max(axis=1)
    worst = 3e-4 if (cfg["name"] == "beckmann" and cfg["sampler"] == "vndf") else 1e-4
    core = np.all((u[:, :2] >= 1e-4) & (u[:, :2] <= 1 - 1e-4), axis=1)
    i = int(np.argmax(np.where(core, dw, 0)))
    assert np.quantile(dw, 0.999) <= 1e-5 and dw[core].max() <= worst, \
        f"directions differ: q99.9 {np.quantile(dw, 0.999):.3g}, max {dw[core].max():.3g} at u={u[i]}, wo={wo[i]}"
    ws = ws.astype(float)
    up = (ws[:, 2] > 0)
    # above/below the horizon the same way, except where the directions straddle it
    assert np.all(((wd[:, 2] > 0) == up) | (np.abs(wd[:, 2]) <= dw))
    ctx = {"wi": ws[up], "wo": wo[up], "u": u[up], "alpha_x": ax[up], "alpha_y": ay[up]}
    p2 = md.pdf(wo, ws)[up]
    f2 = md.eval(wo, ws)[up]
    assert_close(ps[up], p2, S.cond_rtol(1e-4, eps, ws[up], wo[up], ax[up], ay[up], amplify=True),
                 1e-36, what="single sample pdf vs double pdf at the same wi", context=ctx)
    with np.errstate(divide="ignore", invalid="ignore"):
        w2 = f2 * ws[up, 2] / p2
    assert_close(vs[up], w2, S.weight_rtol(1e-4, eps, ws[up], wo[up], ax[up], ay[up]), 1e-36,
                 what="single sample weight vs double f cos / pdf at the same wi", context=ctx)


WIDTH_CONFIGS = [pytest.param(c, id=S.config_id(c)) for c in (
    S.LAMBERT,
    {"name": "beckmann", "aniso": True, "masking": "correlated", "fresnel": "conductor", "kd": True,
     "sampler": "vndf"},
    {"name": "ggx", "aniso": True, "masking": "vcavity", "fresnel": "dielectric", "kd": False,
     "sampler": "vndf"},
    {"name": "beckmann", "aniso": False, "masking": "separable", "fresnel": "schlick", "kd": False,
     "sampler": "ndf"},
    {"name": "ggx", "aniso": False, "masking": "none", "fresnel": "one", "kd": True, "sampler": "ndf"},
)] + [pytest.param(c, id=S.config_id(c), marks=pytest.mark.slow) for c in COVER[1:]]


@pytest.mark.slow       # the default run has every model's widths (tests/models/test_all_models.py)
@pytest.mark.parametrize("width", [1, 4, 8])
@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("cfg", WIDTH_CONFIGS)
def test_widths_agree(cfg, precision, width, model_cache):
    """Width 1 (scalar), 4 and 8 against 16 lanes, same inputs and u. Vector and scalar math
    functions may differ by an ulp or two, so values agree to 16 eps plus the half-vector
    conditioning; sampled directions to 99.9% within 64 eps, all within 2e-4 single / 1e-11
    double (the Beckmann VNDF amplification of test_single_matches_double, ~4e3). Random numbers
    must be identical (integer arithmetic). n = 1001 is not a multiple of any width: the padded
    tail is exercised."""
    dtype, eps, *_ = PREC[precision]
    rng = np.random.default_rng(505)
    n = 1001
    kw, (ax, ay) = random_params(cfg, rng, n, log_alpha=(-2, 0.5))
    ax, ay = np.broadcast_to(ax, (n,)), np.broadcast_to(ay, (n,))
    a = model_cache(cfg["name"], precision=precision, width=16, **kw)
    b = model_cache(cfg["name"], precision=precision, width=width, **kw)
    wi, wo = S.random_pairs(rng, n, ax, ay, min_z=1e-3)
    wi, wo = S.round_to(dtype, wi, wo)
    rtol = S.cond_rtol(16 * eps, eps, wi, wo, ax, ay)
    ctx = {"wi": wi, "wo": wo}
    assert_close(b.eval(wo, wi), a.eval(wo, wi), rtol, PREC[precision][3], what=f"eval w{width}", context=ctx)
    assert_close(b.pdf(wo, wi), a.pdf(wo, wi), rtol, PREC[precision][3], what=f"pdf w{width}", context=ctx)
    wo = S.round_to(dtype, sample_directions(rng, n, 0.01))[0]
    u = exact_float32_u(rng, n)
    sa, sb = a.sample(wo, u), b.sample(wo, u)
    dw = np.abs(sa[0].astype(float) - sb[0]).max(axis=1)
    assert np.quantile(dw, 0.999) <= 64 * eps and dw.max() <= (2e-4 if precision == "single" else 1e-11), dw.max()
    # values: the conditioning tolerances of test_sample_weight_and_pdf_consistent, with the
    # directions' difference dw in place of eps
    wa = sa[0].astype(float)
    up = (wa[:, 2] > 0) & (sb[0][:, 2] > 0)
    e_i = np.maximum(16 * eps, dw[up])
    ctx = {"wi": wa[up], "wo": wo[up], "u": u[up]}
    assert_close(sb[2][up], sa[2][up], S.cond_rtol(16 * eps, e_i, wa[up], wo[up], ax[up], ay[up], amplify=True),
                 PREC[precision][3], what=f"sample pdf w{width}", context=ctx)
    assert_close(sb[1][up], sa[1][up], S.weight_rtol(16 * eps, e_i, wa[up], wo[up], ax[up], ay[up]),
                 PREC[precision][3], what=f"sample weight w{width}", context=ctx)
    for qmc in (False, True):
        np.testing.assert_array_equal(a.random(1001, seed=3, point=2, qmc=qmc),
                                      b.random(1001, seed=3, point=2, qmc=qmc))


# ---------------------------------------------------------------------------------------------
# 7. no NaN or Inf at the extremes

EXT_ALPHA = np.array([1e-4, 1e-3, 1e-2, 0.1, 1.0, 3.0, 10.0])
EXT_MU = np.array([1e-6, 1e-5, 1e-3, 0.05, 0.5, 1.0])
EXT_FRESNEL = {"one": {}, "schlick": {"f0": [0.0, 0.5, 1.0]},
               "dielectric": {"eta": [0.5, 1.0, 1.5, 100.0]},
               "conductor": {"eta": [0.01, 1.5, 100.0], "k": [0.0, 5.0, 100.0]}}
# (masking, sampler, kd, aniso) rotated over (dist, fresnel, precision): 4 rows, each used 4 times
EXT_ROWS = [("correlated", "vndf", False, True), ("separable", "ndf", True, True),
            ("vcavity", "vndf", True, False), ("none", "ndf", False, True)]


def extreme_cases():
    out = []
    for i, (dist, fresnel, precision) in enumerate(
            (d, f, p) for d in S.DISTS for f in S.FRESNELS for p in ("single", "double")):
        masking, sampler, kd, aniso = EXT_ROWS[(i + i // 4) % 4]
        # double precision in the slow tier (each case is a kernel build)
        out.append(pytest.param(dist, fresnel, precision, masking, sampler, kd, aniso,
                                marks=[pytest.mark.slow] if precision == "double" else [],
                                id=f"{dist}-{fresnel}-{precision}-{masking}-{sampler}-"
                                   f"{'kd' if kd else 'nokd'}-{'aniso' if aniso else 'iso'}"))
    return out


def extreme_model_kwargs(fresnel, masking, sampler, kd, aniso, extra_dims=2):
    """Parameter grid: alpha (x alpha_y when anisotropic) x Fresnel parameters; leading dims,
    with extra_dims trailing singleton axes for the directions."""
    grids = [EXT_ALPHA] + ([EXT_ALPHA] if aniso else []) + [np.asarray(v, float) for v in EXT_FRESNEL[fresnel].values()]
    mesh = [g.reshape(-1, *([1] * extra_dims)) for g in np.meshgrid(*grids, indexing="ij")]
    kw = {"masking": masking, "fresnel": fresnel, "sampler": sampler}
    if aniso:
        kw["alpha_x"], kw["alpha_y"] = mesh[0], mesh[1]
        rest = mesh[2:]
    else:
        kw["alpha"] = mesh[0]
        rest = mesh[1:]
    kw.update(zip(EXT_FRESNEL[fresnel].keys(), rest))
    if kd:
        kw["kd"] = 0.5
    return kw


@pytest.mark.parametrize("dist,fresnel,precision,masking,sampler,kd,aniso", extreme_cases())
def test_no_nan_or_inf_at_extremes(dist, fresnel, precision, masking, sampler, kd, aniso, model_cache):
    """alpha 1e-4 .. 10 (anisotropic: every pair, so ratios 1e-5 .. 1e5), cos theta 1e-6 .. 1 for
    both directions at several azimuths (same, opposite, perpendicular), every Fresnel term with
    extreme parameters: eval, pdf, sample (wi, weight, pdf) and albedo (every estimator, Philox
    and Sobol) are finite, and non-negative except where a known bug makes them negative
    (conductor Fresnel near eta = 1, k = 0: test_conductor_fresnel_nonnegative; V-cavity at
    grazing back-scatter: test_vcavity_nonnegative_at_grazing_backscatter)."""
    phis = np.array([0.0, 0.3, np.pi / 2, np.pi, 4.0])
    M, P = np.meshgrid(EXT_MU, phis, indexing="ij")
    dirs = S.direction(M.ravel(), P.ravel())                         # 30 directions
    kw = extreme_model_kwargs(fresnel, masking, sampler, kd, aniso)
    m = model_cache(dist, precision=precision, **kw)
    wi, wo = dirs[None, :, None, :], dirs[None, None, :, :]
    f = m.eval(wo, wi)
    p = m.pdf(wo, wi)
    assert np.all(np.isfinite(f)) and np.all(np.isfinite(p)), "eval/pdf not finite"
    nonneg_ok = fresnel != "conductor" and masking != "vcavity"
    if nonneg_ok:
        assert np.all(f >= 0) and np.all(p >= 0)
    npar = np.size(kw.get("alpha", kw.get("alpha_x")))
    wo_s = np.ascontiguousarray(np.broadcast_to(dirs[None, :, None, :], (npar, dirs.shape[0], 64, 3)))
    wi_s, w, ps = m.sample(wo_s, seed=3)
    assert np.all(np.isfinite(wi_s)), "sampled directions not finite"
    assert np.all(np.isfinite(w)) and np.all(np.isfinite(ps)), "sample weight/pdf not finite"
    assert np.all(ps >= 0) and (not nonneg_ok or np.all(w >= 0))
    ka = extreme_model_kwargs(fresnel, masking, sampler, kd, aniso, extra_dims=1)
    ma = model_cache(dist, precision=precision, **ka)
    for estimator, qmc in (("uniform", False), ("cosine", True), ("brdf", False), ("brdf", True),
                           ("mis", False)):
        r = clbrdf.albedo(ma, EXT_MU[None, :], 0.4, estimator=estimator, samples=2048, qmc=qmc, seed=5)
        assert np.all(np.isfinite(r.albedo)) and np.all(np.isfinite(r.stderr)), (estimator, qmc)
        if nonneg_ok:
            assert np.all(r.albedo >= 0), (estimator, qmc)


def test_conductor_fresnel_nonnegative(model_cache):
    """At h = n (wi, wo mirror images) with masking none, f = F / (4 pi alpha^2 cos^2), so F is
    read off the BRDF. F >= 0, and within 2e-3 relative + 1e-7 absolute of the reference near the
    index-matched case (eta ~ 1, k = 0), where the formula is ill-conditioned."""
    c = np.linspace(0.01, 1, 100)
    s = np.sqrt(1 - c * c)
    wi, wo = np.stack([s, 0 * s, c], -1), np.stack([-s, 0 * s, c], -1)
    eta = np.array([1.0, 1.0001, 0.9999])[:, None]
    m = model_cache("ggx", precision="single", alpha=0.5, masking="none", fresnel="conductor",
                    eta=eta, k=0.0)
    F = m.eval(wo, wi).astype(float) * 4 * c * c * np.pi * 0.25
    F_ref = R.fresnel("conductor", c, eta=eta, k=0.0)
    assert np.all(F >= 0), f"negative F: min {F.min():.3g}"
    assert np.all(np.abs(F - F_ref) <= 2e-3 * F_ref + 1e-7), np.max(np.abs(F - F_ref) / F_ref)


def test_vcavity_nonnegative_at_grazing_backscatter(model_cache):
    m = model_cache("ggx", precision="single", alpha=0.1, masking="vcavity")
    wo = np.array([[0.866904941, 0.498473484, 1e-4]])
    wi = np.array([[-0.866906816, -0.498470223, 9.34564237e-05]])
    f = m.eval(wo, wi)
    assert f[0] >= 0, f"f = {f[0]!r} (reference {R.eval('ggx', wo, wi, alpha=0.1, masking='vcavity')[0]:.4g})"


# ---------------------------------------------------------------------------------------------
# 8. random numbers

def python_random(n, seed, point, stream, precision):
    w = S.philox4x32_10((np.arange(n), point, stream, 0), (seed & 0xFFFFFFFF, seed >> 32))
    return np.stack([S.bits_to_unit(x, precision) for x in w], -1)


KAT = [  # Random123 kat_vectors, philox4x32_10
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF, 0xFFFFFFFF), (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]


@pytest.mark.parametrize("ctr,key,expect", KAT)
def test_philox_python_known_answers(ctr, key, expect):
    assert tuple(int(x) for x in S.philox4x32_10(ctr, key)) == expect


@pytest.mark.parametrize("width", [1, 16])
@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("seed,point,stream", [(0, 0, 0), (1, 7, 3), (2**32 + 5, 123456, 0),
                                               (2**64 - 1, 2**32 - 1, 2**32 - 1)])
def test_random_matches_python_philox(seed, point, stream, precision, width, model_cache):
    """Model.random == Philox4x32-10 with counter (sample, point, stream, 0) and key
    (seed_lo, seed_hi), through the kernel's float map, bit for bit."""
    m = model_cache("lambert", precision=precision, width=width, kd=0.5)
    n = 4099
    got = m.random(n, seed=seed, point=point, stream=stream)
    np.testing.assert_array_equal(got, python_random(n, seed, point, stream, precision))


def _find_all_ones_index():
    """(sample index, word) of the first Philox output (seed 0, point 0, stream 0) whose top 24
    bits are all ones (in single precision, the largest number the generator gives), found with
    the Python generator (so it is the documented stream)."""
    n = 1 << 23
    words = S.philox4x32_10((np.arange(n), 0, 0, 0), (0, 0))
    best = None
    for j, w in enumerate(words):
        idx = np.nonzero((w >> np.uint32(8)) == 0xFFFFFF)[0]
        if idx.size and (best is None or idx[0] < best[0]):
            best = (int(idx[0]), j)
    assert best is not None
    return best


def test_random_single_in_open_interval_at_cell_centres(model_cache):
    """rng.h documents each number as the centre of its cell, in the open interval (0, 1): in
    single precision the centre (k + 1/2) 2^-23 of cell k = x >> 9, exactly. The batch reaches
    a number whose top bits are all ones (u = 1 - 2^-24)."""
    idx, word = _find_all_ones_index()
    m = model_cache("lambert", precision="single", kd=0.5)
    u = m.random(idx + 1, seed=0).astype(np.float64)
    x = S.philox4x32_10((np.arange(idx + 1), 0, 0, 0), (0, 0))
    centres = np.stack([((w >> np.uint32(9)).astype(np.float64) + 0.5) * 2.0 ** -23 for w in x], -1)
    np.testing.assert_array_equal(u, centres)
    assert u[idx, word] == 1 - 2.0 ** -24
    assert np.all(u > 0) and np.all(u < 1), f"u[{idx}, {word}] = {u[idx, word]!r}"


@pytest.mark.parametrize("name,kw", [("ggx", {"sampler": "ndf"}), ("beckmann", {"sampler": "ndf"}),
                                     ("beckmann", {"sampler": "vndf"})])
def test_sample_u_just_below_one_is_finite(name, kw, model_cache):
    m = model_cache(name, precision="single", alpha=0.3, **kw)
    wo = np.array([[0.6, 0.0, 0.8]] * 2)
    u = np.array([[1 - 1e-9, 0.3, 0.5, 0.5], [0.3, 1 - 1e-9, 0.5, 0.5]])
    wi, w, p = m.sample(wo, u)
    assert np.all(np.isfinite(wi)), wi


def beckmann_visible_slope_cdf(s, cos_t):
    """CDF of the x-slope s of unit Beckmann normals visible from a direction at cos_t in the x-z
    plane (Heitz & d'Eon 2014 section 4): (1 + erf s + tan/sqrt(pi) exp(-s^2)) / (the same at
    s = cot), in float64 with SciPy's erf."""
    tan_t = np.sqrt(1 - cos_t ** 2) / cos_t
    cot_t = cos_t / np.sqrt(1 - cos_t ** 2)
    c = lambda x: 1 + erf(x) + tan_t / np.sqrt(np.pi) * np.exp(-x * x)
    return c(s) / c(cot_t)


def test_beckmann_vndf_inverts_visible_slope_cdf(model_cache):
    """Double precision: the sampled half vector's slopes, mapped back to the unit-roughness frame
    of wo, satisfy CDF(s_x) = u0 and erf(s_y) = 2 u1 - 1 to 1e-12 (the Newton inversion has
    converged) plus the cost of the round trip wi -> h -> slopes. u in [1e-6, 1 - 1e-6], incidence
    down to cos theta = 1e-3, alpha_x != alpha_y."""
    rng = np.random.default_rng(77)
    n = 20000
    ax, ay = 0.3, 0.07
    m = model_cache("beckmann", precision="double", alpha_x=ax, alpha_y=ay, sampler="vndf",
                    masking="none")
    wo = sample_directions(rng, n, min_mu=1e-3)
    u = np.concatenate([rng.uniform(1e-6, 1 - 1e-6, (n, 2)), np.full((n, 2), 0.5)], axis=1)
    u[: n // 4, 0] = 10 ** rng.uniform(-6, -1, n // 4)            # both tails of u0
    u[n // 4: n // 2, 0] = 1 - 10 ** rng.uniform(-6, -1, n // 4)
    wi, _, _ = m.sample(wo, u)
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    ws = wo * [ax, ay, 1]
    ws /= np.linalg.norm(ws, axis=1, keepdims=True)
    r = np.hypot(ws[:, 0], ws[:, 1])
    cp, sp = ws[:, 0] / r, ws[:, 1] / r
    tx, ty = -h[:, 0] / h[:, 2] / ax, -h[:, 1] / h[:, 2] / ay      # unit-roughness slopes
    sx, sy = cp * tx + sp * ty, -sp * tx + cp * ty                   # in wo's azimuth frame
    # the round trip wi -> h -> slope costs eps (1 + t^2) / (wo.h alpha) in the slope (wi + wo
    # has length 2 wo.h); both CDFs have slope derivative <= 1.2 here
    woh = np.sum(wo * h, axis=1)
    atol = 1e-12 + 16 * S.EPS64 * (1 + tx * tx + ty * ty) / (woh * min(ax, ay))
    ctx = {"wo": wo, "u": u}
    assert_close(beckmann_visible_slope_cdf(sx, ws[:, 2]), u[:, 0], 0, atol, what="CDF(s_x) vs u0", context=ctx)
    assert_close(erf(sy), 2 * u[:, 1] - 1, 0, atol, what="erf(s_y) vs 2 u1 - 1", context=ctx)


def test_sample_with_own_generator_large_batch(model_cache):
    idx, _ = _find_all_ones_index()
    m = model_cache("lambert", precision="single", kd=0.5)
    wo = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (idx + 1, 3))
    wi, w, p = m.sample(wo, seed=0)
    assert np.all(np.isfinite(wi))


def elementary_interval_counts(u, m, j):
    """Counts of points in the 2^m elementary intervals [a 2^-j, (a+1) 2^-j) x
    [b 2^-(m-j), (b+1) 2^-(m-j)) of dims (0, 1)."""
    a = np.floor(u[:, 0] * 2 ** j).astype(np.int64)
    b = np.floor(u[:, 1] * 2 ** (m - j)).astype(np.int64)
    return np.bincount(a * 2 ** (m - j) + b, minlength=2 ** m)


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("m", [8, 10])
def test_sobol_is_a_net(m, precision, model_cache):
    """The first 2^m scrambled Sobol points are a (0, m, 2)-net in dims (0, 1): every elementary
    interval of volume 2^-m holds exactly one point (nested uniform scrambling and Burley's index
    shuffle preserve this); each of the 4 dims alone is stratified into 2^m cells. Several seeds,
    points and streams."""
    model = model_cache("lambert", precision=precision, kd=0.5)
    for seed, point, stream in ((0, 0, 0), (1, 0, 0), (0, 5, 0), (0, 0, 9), (2**40 + 3, 77, 2)):
        u = model.random(2 ** m, seed=seed, point=point, stream=stream, qmc=True).astype(np.float64)
        for j in range(m + 1):
            c = elementary_interval_counts(u, m, j)
            assert np.all(c == 1), (seed, point, stream, j, np.unique(c))
        for d in range(4):
            assert np.all(np.bincount(np.floor(u[:, d] * 2 ** m).astype(int), minlength=2 ** m) == 1), d


def test_sobol_scrambles_differ(model_cache):
    """Different seeds, points and streams give different scrambles (and not mere permutations of
    the same point set), while the same key reproduces bit for bit."""
    model = model_cache("lambert", precision="double", kd=0.5)
    n = 1024
    keys = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 1, 1), (2**32, 0, 0)]
    sets = {k: model.random(n, seed=k[0], point=k[1], stream=k[2], qmc=True) for k in keys}
    np.testing.assert_array_equal(sets[keys[0]], model.random(n, qmc=True))
    for a in range(len(keys)):
        for b in range(a + 1, len(keys)):
            x, y = sets[keys[a]], sets[keys[b]]
            assert np.mean(x == y) < 0.01, (keys[a], keys[b])
            sx, sy = np.sort(x[:, 0]), np.sort(y[:, 0])
            assert np.mean(sx == sy) < 0.01, (keys[a], keys[b])


@pytest.mark.chisquare(n=10)
def test_philox_uniform_and_independent(model_cache, chi2_alpha):
    """10^6 draws of the 4 outputs: each output uniform (chi-square, 1000 equal bins), and each of
    the 6 pairs of outputs independent (chi-square over a 50 x 50 grid of equal cells, 400
    expected per cell). Sidak-corrected significance (conftest)."""
    m = model_cache("lambert", precision="single", kd=0.5)
    n = 1_000_000
    u = m.random(n, seed=2024, point=3).astype(np.float64)
    results = []
    for d in range(4):
        c = np.bincount(np.floor(u[:, d] * 1000).astype(int), minlength=1000)
        results.append((f"dim {d}",) + S.chi2_gof(c, np.full(1000, n / 1000)))
    for a in range(4):
        for b in range(a + 1, 4):
            k = np.floor(u[:, a] * 50).astype(int) * 50 + np.floor(u[:, b] * 50).astype(int)
            c = np.bincount(k, minlength=2500)
            results.append((f"dims {a},{b}",) + S.chi2_gof(c, np.full(2500, n / 2500)))
    bad = [r for r in results if r[3] < chi2_alpha]
    assert not bad, f"rejected at {chi2_alpha:.3g}: {bad}"


# ---------------------------------------------------------------------------------------------
# 9. sin and cos of sampled azimuths (common.h sincos_2pi)

@pytest.mark.parametrize("width", [1, 16])
@pytest.mark.parametrize("precision", ["single", "double"])
def test_sampled_azimuth_sin_cos_accurate(precision, width, model_cache):
    """Lambert's sampler is the cosine warp: wi = (sqrt(u0) cos 2 pi u1, sqrt(u0) sin 2 pi u1,
    sqrt(1 - u0)). With u0 = 1 - 2^-24... (sin theta = 1 within rounding) the x, y components are
    cos and sin of 2 pi u1: absolute error within 2.5e-7 (single; sincos(2 pi u) in float errs by
    up to 4e-7 from rounding 2 pi u alone) or 1e-15 (double), at quadrant edges, near them, and
    at 2^16 points spread over [0, 1)."""
    m = model_cache("lambert", precision=precision, width=width, kd=1.0)
    edges = np.array([0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875])
    eps = 2.0 ** -24
    u1 = np.concatenate([edges, edges + eps, np.maximum(edges - eps, 0), [1 - eps, 1 - 2 * eps],
                         (np.arange(1 << 16) + 0.5) / (1 << 16)])
    dt = np.float32 if precision == "single" else np.float64
    u1 = u1.astype(dt).astype(np.float64)         # the values the kernel sees
    u0 = np.full_like(u1, 1.0 - 2.0 ** -24 if precision == "single" else 1.0 - 2.0 ** -53)
    u = np.stack([u0, u1, np.full_like(u1, 0.5), np.full_like(u1, 0.5)], -1)
    wo = np.broadcast_to([0.0, 0.0, 1.0], u1.shape + (3,))
    wi, _, _ = m.sample(wo, u)
    r = np.sqrt(u0.astype(dt).astype(np.float64))
    tol = 2.5e-7 if precision == "single" else 1e-15
    np.testing.assert_allclose(wi[:, 0], r * np.cos(2 * np.pi * u1), rtol=0, atol=tol)
    np.testing.assert_allclose(wi[:, 1], r * np.sin(2 * np.pi * u1), rtol=0, atol=tol)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_dielectric_fresnel_index_matched(precision, model_cache):
    """eta = 1 (no interface) reflects nothing at every angle, grazing included (F read off the
    BRDF at h = n as in test_conductor_fresnel_nonnegative); near eta = 1 F matches the
    reference within 1e-3 relative + 1e-7. Single precision used to give F = 1 for c < 3e-4
    (eta^2 - 1 + c^2 lost c^2) and NaN at c = 0 (0/0)."""
    c = np.concatenate([[1e-6, 1e-5, 1e-4, 3e-4, 1e-3], np.linspace(0.01, 1, 50)])
    s = np.sqrt(1 - c * c)
    wi, wo = np.stack([s, 0 * s, c], -1), np.stack([-s, 0 * s, c], -1)
    eta = np.array([1.0, 1.001, 0.999, 1.5])[:, None]
    m = model_cache("ggx", precision=precision, alpha=0.5, masking="none", fresnel="dielectric",
                    eta=eta)
    F = m.eval(wo, wi).astype(float) * 4 * c * c * np.pi * 0.25
    F_ref = R.fresnel("dielectric", c, eta=eta)
    assert np.all(np.isfinite(F))
    np.testing.assert_array_equal(F[0], 0.0)
    rtol = 1e-3 if precision == "single" else 1e-9
    np.testing.assert_allclose(F[1:], F_ref[1:], rtol=rtol, atol=1e-7)
