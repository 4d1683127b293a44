"""Sampling densities and the albedo integrators.

- The kernel pdf integrates, by a quadrature the tests control (stats.HalfVectorMap: the upper
  hemisphere of wi as the cone of half vectors, in stretched-slope coordinates graded towards the
  lobe, with the horizon a boundary of the domain), to the fraction of samples above the horizon.
- Samples follow the kernel pdf: Pearson chi-square over bins chosen on that lobe-centred grid so
  that each expects about the same count (see test_samples_follow_pdf), 2^20 samples per test,
  Sidak-corrected significance 0.01 over the run (conftest.chi2_alpha).
- Monte Carlo albedo, every estimator with Philox and with Sobol, agrees with the deterministic
  quadrature of clbrdf.ref.microfacet within 4 standard errors; the standard errors are honest
  (coverage over 200 seeds); the albedo kernel draws the documented random stream; results are
  bit-identical across chunkings and runs.

Default run: alpha down to 0.05 and cos theta_o from 1 to 0.05; ``-m slow``: alpha down to 1e-3
and a product over the sampling options.
"""
from __future__ import annotations

import math
import zlib

import numpy as np
import pytest
from scipy import stats as sps

import clbrdf
import stats as S
from clbrdf.ref import microfacet as R

N_SAMPLES = 1 << 20


# ---------------------------------------------------------------------------------------------
# Cases: a configuration, its roughness and wo

def mf(name, aniso, masking, fresnel, kd, sampler):
    return {"name": name, "aniso": aniso, "masking": masking, "fresnel": fresnel, "kd": kd,
            "sampler": sampler}


def case(cfg, alpha=0.3, alpha_y=None, mu=0.5, phi=0.0, precision="single"):
    kw = S.model_kwargs(cfg, alpha=alpha, alpha_y=alpha_y)
    ident = (f"{S.config_id(cfg)}-a{alpha:g}" + (f"x{alpha_y:g}" if cfg.get("aniso") else "")
             + f"-mu{mu:g}-phi{phi:g}-{precision}")
    return {"cfg": cfg, "kw": kw, "mu": mu, "phi": phi, "precision": precision, "id": ident}


def default_cases():
    out = [case(S.LAMBERT, mu=0.5)]
    for dist in S.DISTS:
        for sampler in S.SAMPLERS:
            out += [
                # sharp and grazing
                case(mf(dist, False, "correlated", "one", False, sampler), alpha=0.05, mu=0.05),
                # anisotropic, wo off the axes, lobe mixture with the Lambertian term
                case(mf(dist, True, "separable", "conductor", True, sampler), alpha=0.4, alpha_y=0.05,
                     mu=0.5, phi=1.0),
                # rough, normal incidence, mixture
                case(mf(dist, False, "vcavity", "schlick", True, sampler), alpha=0.6, mu=1.0),
                # moderately grazing anisotropic; the VNDF ones in double precision
                case(mf(dist, True, "none", "dielectric", False, sampler), alpha=0.1, alpha_y=0.2,
                     mu=0.2, phi=2.5, precision="double" if sampler == "vndf" else "single"),
            ]
    return out


def slow_cases():
    out = []
    kd_fresnel = [(False, "one"), (True, "schlick"), (True, "conductor")]
    i = 0
    for dist in S.DISTS:
        for sampler in S.SAMPLERS:
            for aniso in (False, True):
                for kd, fresnel in kd_fresnel:
                    for alpha in (1e-3, 0.05, 0.5):
                        for mu in (0.05, 0.4, 1.0):
                            masking = S.MASKINGS[i % 4]
                            i += 1
                            out.append(case(mf(dist, aniso, masking, fresnel, kd, sampler), alpha=alpha,
                                            alpha_y=alpha * 4 if aniso else None, mu=mu,
                                            phi=0.7 if aniso else 0.0))
    return out


_DEFAULT = default_cases()
_SLOW = [c for c in slow_cases() if c["id"] not in {d["id"] for d in _DEFAULT}]
CASES = ([pytest.param(c, id=c["id"]) for c in _DEFAULT]
         + [pytest.param(c, id=c["id"], marks=pytest.mark.slow) for c in _SLOW])


def case_model(c, model_cache):
    return model_cache(c["cfg"]["name"], precision=c["precision"], **c["kw"])


def case_density(c, model_cache):
    """The kernel pdf used for quadrature: the same configuration built in double precision.
    In single precision the pdf carries the rounding of h = normalize(wi + wo), relative
    ~eps / alpha (5e-5 at alpha = 1e-3, test_kernels), which would dominate the quadrature
    error; test_kernels checks single against double."""
    return model_cache(c["cfg"]["name"], precision="double", **c["kw"])


def case_map(c):
    ax, ay = S.alphas(c["kw"])
    return S.HalfVectorMap(S.direction(c["mu"], c["phi"]), float(ax), float(ay))


def case_seed(c, salt):
    return (zlib.crc32(c["id"].encode()) << 8) + salt


# ---------------------------------------------------------------------------------------------
# 3. the pdf integrates to the fraction of samples above the horizon

@pytest.mark.parametrize("c", CASES)
def test_pdf_integrates_to_fraction_above_horizon(c, model_cache):
    """Integral of the kernel pdf (case_density) over the upper hemisphere (48 x 192 panels in
    (s, t), 8 x 8 Gauss-Legendre each; t gets more panels because at grazing wo the horizon
    boundary x_max(t) turns sharply where wo.h changes sign; the 6 x 6 rule gives the quadrature
    error estimate, required < 1e-6) against the fraction of 2^20 samples (the case's precision)
    with wi.z > 0. Tolerance: 4 binomial standard deviations of that fraction (at least as if one
    sample were below), plus the quadrature error estimate, plus 1e-7."""
    m = case_model(c, model_cache)
    md = case_density(c, model_cache)
    hmap = case_map(c)
    wo = hmap.wo

    def pdf(wi):
        return md.pdf(wo, wi)
    total = S.panel_integrals(hmap, pdf, 48, 192, 8).sum()
    coarse = S.panel_integrals(hmap, pdf, 48, 192, 6).sum()
    quad_err = abs(total - coarse)
    assert np.isfinite(total) and quad_err < 1e-6, f"quadrature not converged: {total} vs {coarse}"
    wi, _, _ = S.draw(m, wo, N_SAMPLES, case_seed(c, 1))
    frac = float(np.mean(wi[:, 2] > 0))
    sigma = math.sqrt(max(frac * (1 - frac), 1.0 / N_SAMPLES) / N_SAMPLES)
    assert abs(total - frac) <= 4 * sigma + quad_err + 1e-7, \
        f"integral of pdf {total:.7f}, fraction above the horizon {frac:.7f} (sigma {sigma:.2g})"
    assert total <= 1 + quad_err + 1e-7


# ---------------------------------------------------------------------------------------------
# 5. chi-square goodness of fit

NS_FINE, NT_FINE = 128, 256        # quadrature panels in s and t (t: see the pdf test)
NB_S, NB_T = 32, 32                # bins: NB_T columns in t, NB_S rows in s per column


@pytest.mark.chisquare(n=1)
@pytest.mark.parametrize("c", CASES)
def test_samples_follow_pdf(c, model_cache, chi2_alpha):
    """Pearson chi-square of 2^20 samples against the kernel pdf.

    Bins: the sample directions are mapped to (s, t) of stats.HalfVectorMap (half vector in
    stretched-slope polar coordinates, radius graded by asinh, the horizon at s = 1), where the
    lobe has width ~1 for any alpha: the grid is lobe-centred and resolves alpha down to 1e-3.
    On a 128 x 256 grid of panels the kernel pdf (case_density) is integrated (4 x 4
    Gauss-Legendre per panel), and the
    bins are unions of panels chosen so each expects about the same count: 32 columns of equal
    mass in t, 32 rows of equal mass in s within each column (~1000 bins, ~1000 samples each; not
    equal solid angle, which is not needed: the test only needs the expected count of each bin,
    and equal counts give it the most power). Samples below the horizon form one more bin, which
    expects N (1 - integral of the pdf). Bins expecting fewer than 5 are pooled; the degrees of
    freedom are (bins - 1). A second rule (3 x 3) checks the expected counts: they must agree to
    0.1 sample standard deviation in every bin."""
    m = case_model(c, model_cache)
    md = case_density(c, model_cache)
    hmap = case_map(c)
    wo = hmap.wo

    def pdf(wi):
        return md.pdf(wo, wi)
    wi, _, _ = S.draw(m, wo, N_SAMPLES, case_seed(c, 2))
    r = S.map_chi2(hmap, pdf, wi, NS_FINE, NT_FINE, (4, 3), NB_S, NB_T)
    if r.p < chi2_alpha:
        nb = r.obs.size - 1          # the last bin: below the horizon
        contrib = (r.obs - r.exp) ** 2 / np.maximum(r.exp, 1e-300)
        worst = np.argsort(-contrib)[:6]
        desc = []
        for b in worst:
            if b == nb:
                desc.append(f"below horizon: obs {r.obs[b]} exp {r.exp[b]:.1f}")
                continue
            ii, tt = np.nonzero(r.binmap == b)
            desc.append(f"s [{ii.min() / NS_FINE:.3f}, {(ii.max() + 1) / NS_FINE:.3f}) "
                        f"t [{tt.min() / NT_FINE:.3f}, {(tt.max() + 1) / NT_FINE:.3f}): "
                        f"obs {r.obs[b]} exp {r.exp[b]:.1f}")
        pytest.fail(f"chi2 {r.stat:.1f} with {r.dof} dof, p = {r.p:.3g} < {chi2_alpha:.3g}; "
                    f"integral of pdf {r.total:.6f}, fraction above {r.above:.6f}; worst bins:\n  "
                    + "\n  ".join(desc))


# ---------------------------------------------------------------------------------------------
# 9. albedo against the deterministic reference

ESTIMATORS = [(e, q) for e in ("uniform", "cosine", "brdf", "mis") for q in (False, True)]

ALBEDO_CASES = [
    ("ggx-sharp", mf("ggx", False, "correlated", "one", False, "vndf"), dict(alpha=0.05), [0.05, 0.3, 1.0], 0.0),
    ("beckmann-aniso-conductor", mf("beckmann", True, "separable", "conductor", False, "ndf"),
     dict(alpha=0.1, alpha_y=0.5), [0.05, 0.5, 0.9], 0.8),
    ("ggx-aniso-kd", mf("ggx", True, "vcavity", "schlick", True, "ndf"), dict(alpha=0.3, alpha_y=1.0),
     [0.1, 0.6, 1.0], 2.0),
    ("beckmann-rough-kd", mf("beckmann", False, "none", "dielectric", True, "vndf"), dict(alpha=1.0),
     [0.05, 0.5, 1.0], 0.0),
    ("lambert", S.LAMBERT, {}, [0.05, 0.5, 1.0], 0.0),
    ("ggx-dielectric-ndf", mf("ggx", False, "separable", "dielectric", False, "ndf"), dict(alpha=0.5),
     [0.05, 0.7], 0.0),
    ("beckmann-sharp-kd", mf("beckmann", False, "correlated", "schlick", True, "vndf"), dict(alpha=0.05),
     [0.05, 0.4, 1.0], 0.0),
]
ALBEDO_SLOW = [(f"cover-{S.config_id(c)}", c, dict(alpha=a), [0.05, 0.35, 0.8], 1.1)
               for c, a in zip(S.COVER[1:], np.geomspace(0.05, 1.0, 16))]

_REF_CACHE: dict = {}


def reference_albedo(name, kw, mu, phi):
    key = (name, repr(sorted(kw.items())), mu, phi)
    if key not in _REF_CACHE:
        _REF_CACHE[key] = R.albedo(name, mu, phi, tol=1e-8, **S.ref_kwargs(kw))
    return _REF_CACHE[key]


def _albedo_params():
    """Every (case, estimator, generator); each is an albedo program of its own, so the default
    run takes two per case, rotating so that the cases together cover all eight (every estimator
    with Philox and with Sobol), and the slow tier the rest."""
    for i, case in enumerate(ALBEDO_CASES + ALBEDO_SLOW):
        for j, (e, q) in enumerate(ESTIMATORS):
            fast = i < len(ALBEDO_CASES) and j in ((2 * i) % 8, (2 * i + 5) % 8)
            yield pytest.param(*case, e, q, marks=[] if fast else [pytest.mark.slow],
                               id=f"{case[0]}-{e}-{'qmc' if q else 'mc'}")


@pytest.mark.parametrize("label,cfg,params,mus,phi,estimator,qmc", list(_albedo_params()))
def test_albedo_matches_reference(label, cfg, params, mus, phi, estimator, qmc, model_cache):
    """|E - E_ref| <= 4 stderr + err_ref + 2e-6 E_ref with 2^18 samples per point (phi != 0 for
    the anisotropic cases). 4 standard errors: a false failure has probability 6e-5 per
    comparison for a normal estimate. 2e-6 E_ref: a zero-variance estimator (cosine sampling of a
    Lambertian) reports stderr 0, and its value carries the float32 rounding of the sums (1024
    samples per work-item, added in float32: measured 1e-7 relative)."""
    kw = S.model_kwargs(cfg, **params)
    m = model_cache(cfg["name"], **kw)
    mu = np.asarray(mus, float)
    r = clbrdf.albedo(m, mu, phi, estimator=estimator, qmc=qmc, samples=1 << 18, seed=12)
    assert r.albedo.shape == mu.shape
    ref = np.array([reference_albedo(cfg["name"], kw, float(x), phi) for x in mu])
    e_ref, err_ref = ref[:, 0], ref[:, 1]
    assert np.all(np.isfinite(r.albedo)) and np.all(r.stderr >= 0)
    tol = 4 * r.stderr + err_ref + 2e-6 * np.abs(e_ref)
    assert np.all(np.abs(r.albedo - e_ref) <= tol), \
        f"albedo {r.albedo} reference {e_ref} stderr {r.stderr} (|diff|/stderr {np.abs(r.albedo - e_ref) / np.maximum(r.stderr, 1e-300)})"


HONESTY = [("brdf", False), ("uniform", False), ("brdf", True), ("mis", True)]


@pytest.mark.parametrize("estimator,qmc", HONESTY, ids=[f"{e}-{'qmc' if q else 'mc'}" for e, q in HONESTY])
def test_albedo_stderr_is_honest(estimator, qmc, model_cache):
    """Over 200 independent seeds at one configuration, the number of estimates within 2 stated
    standard errors of the reference is Binomial(200, p): p = P(|Z| < 2) = 0.9545 for Monte Carlo
    (the stderr comes from 2^13 samples, a normal limit), p = P(|T_15| < 2) = 0.936 for QMC (the
    stderr is the spread of 16 scrambles: Student t with 15 degrees of freedom). The count must
    lie in the two-sided acceptance interval at significance 1e-3; the same for the count within
    1 stderr (p = 0.683 / 0.667), which gives the test power against an overstated error: an
    error estimate 1.5 times too small moves the first p to 0.82, one 1.5 times too large moves
    the second to 0.87 (acceptance intervals about +-6%). This is the sampling error
    (``sampling_stderr``); the reported ``stderr`` adds what the samples cannot see
    (tests/api/test_unseen.py)."""
    kw = S.model_kwargs(mf("ggx", False, "correlated", "schlick", False, "vndf"), alpha=0.3)
    m = model_cache("ggx", **kw)
    mu = 0.5
    e_ref, err_ref = reference_albedo("ggx", kw, mu, 0.0)
    seeds = 200
    zs = []
    for seed in range(seeds):
        r = clbrdf.albedo(m, mu, estimator=estimator, qmc=qmc, samples=1 << (14 if qmc else 13),
                          seed=1000 + seed)
        zs.append((float(r.albedo) - e_ref) / float(r.sampling_stderr))
    zs = np.abs(np.array(zs))
    for k in (2, 1):
        inside = int(np.sum(zs < k))
        p = 2 * sps.t.cdf(k, 15) - 1 if qmc else 2 * sps.norm.cdf(k) - 1
        lo, hi = S.binomial_acceptance(seeds, p, 1e-3)
        assert lo <= inside <= hi, (f"{inside}/{seeds} within {k} stderr, expected {p * seeds:.1f} "
                                    f"(accept [{lo}, {hi}]); rms of z = {np.sqrt(np.mean(zs ** 2)):.3f}")


# ---------------------------------------------------------------------------------------------
# the albedo kernel draws the documented random stream

def uniform_hemisphere_estimates(kw, wo, u0, u1):
    """f cos / (1 / 2 pi) at the uniform-hemisphere directions of u0, u1 (reference f)."""
    s = np.sqrt((1 - u0) * (1 + u0))
    wi = np.stack([s * np.cos(2 * np.pi * u1), s * np.sin(2 * np.pi * u1), u0], -1)
    return R.eval("ggx", wo, wi, **S.ref_kwargs(kw)) * wi[:, 2] * 2 * np.pi


# 4097: blocks of 1024 and an odd count (the last pair half used); 45: one short block
@pytest.mark.parametrize("samples", [4097, 45])
def test_albedo_uses_documented_philox_stream_pairs(samples, model_cache):
    """An estimator that needs two numbers (uniform hemisphere) takes them two samples per Philox
    call: counter (c, point, stream 0, 0), words (0, 1) for sample 2c and (2, 3) for sample 2c+1
    (kernels/integrators.cl). Recomputing the estimate in Python from that stream (directions from
    the float32 numbers, f from the reference) must give the kernel's albedo to float rounding
    (1e-4 relative); any other stream differs by about one standard error (~1e-2 here)."""
    kw = {"alpha": 0.5, "masking": "correlated", "fresnel": "one", "sampler": "vndf"}
    m = model_cache("ggx", **kw)
    mu = np.array([0.3, 0.8, 0.55])            # points 0, 1, 2
    seed = (7 << 32) + 123
    r = clbrdf.albedo(m, mu, estimator="uniform", samples=samples, seed=seed)
    for point, x in enumerate(mu):
        c = np.arange((samples + 1) // 2)
        w = S.philox4x32_10((c, point, 0, 0), (seed & 0xFFFFFFFF, seed >> 32))
        u = [S.bits_to_unit(x_, "single").astype(np.float64) for x_ in w]
        u0 = np.stack([u[0], u[2]], 1).reshape(-1)[:samples]
        u1 = np.stack([u[1], u[3]], 1).reshape(-1)[:samples]
        e_py = uniform_hemisphere_estimates(kw, S.direction(x), u0, u1).mean()
        assert abs(r.albedo[point] - e_py) <= 1e-4 * e_py, (point, r.albedo[point], e_py)
        assert 1e-4 * e_py < 0.05 * r.stderr[point]       # the check can tell streams apart


@pytest.mark.parametrize("samples", [3000, 77])
def test_albedo_uses_documented_philox_stream_mis(samples, model_cache):
    """A four-number estimator (MIS) takes one Philox call per sample: counter (sample, point, 0,
    0), words 0-3 = u0..u3. Rebuilt in Python: the BRDF sample from the sample kernel with those
    u, the cosine sample from (u3, u2) (this sampler uses three numbers), the estimate the sum of
    both balance-heuristic terms; must match to 1e-4."""
    kw = {"alpha_x": 0.2, "alpha_y": 0.6, "masking": "separable", "fresnel": "schlick", "f0": 0.3,
          "kd": 0.4, "sampler": "ndf"}
    m = model_cache("ggx", **kw)
    mu, phi = np.array([0.4, 0.9]), 0.6
    seed = 99
    r = clbrdf.albedo(m, mu, phi, estimator="mis", samples=samples, seed=seed)
    for point, x in enumerate(mu):
        wo = S.direction(x, phi)
        w = S.philox4x32_10((np.arange(samples), point, 0, 0), (seed, 0))
        u = np.stack([S.bits_to_unit(x_, "single").astype(np.float64) for x_ in w], -1)
        wob = np.broadcast_to(wo, (samples, 3))
        wb, vb_w, pb = m.sample(wob, u)
        wb, vb_w, pb = wb.astype(float), vb_w.astype(float), pb.astype(float)
        with np.errstate(divide="ignore", invalid="ignore"):
            vb = np.where(pb > 0, vb_w / (0.5 + 0.5 * np.maximum(wb[:, 2], 0) / np.pi / pb), 0.0)
        s0 = np.sqrt(u[:, 3])
        wc = np.stack([s0 * np.cos(2 * np.pi * u[:, 2]), s0 * np.sin(2 * np.pi * u[:, 2]),
                       np.sqrt(1 - u[:, 3])], -1)
        rk = S.ref_kwargs(kw)
        qc = 0.5 * (R.pdf("ggx", wo, wc, "brdf", **rk) + wc[:, 2] / np.pi)
        with np.errstate(divide="ignore", invalid="ignore"):
            vc = np.where(qc > 0, R.eval("ggx", wo, wc, **rk) * wc[:, 2] / qc, 0.0)
        e_py = (0.5 * (vb + vc)).mean()
        assert abs(r.albedo[point] - e_py) <= 1e-4 * e_py, (point, r.albedo[point], e_py)
        assert 1e-4 * e_py < 0.05 * r.stderr[point]


# 16 scrambles of 1100 (a block of 1024 and a partial one) and of 40 (one short block each)
@pytest.mark.parametrize("samples", [16 * 1100, 16 * 40])
def test_albedo_uses_documented_sobol_streams(samples, model_cache):
    """With qmc the estimate is the mean of 16 scrambles (streams 0-15) of samples / 16 Sobol
    points each, the points those of Model.random(n, seed, point, stream, qmc=True); the stderr is
    the scrambles' spread over sqrt(16), scaled by sqrt(15/13). Rebuilt in Python for the uniform-hemisphere estimator:
    albedo to 1e-4 relative, stderr to 1e-3 (it is a difference of nearly equal numbers)."""
    kw = {"alpha": 0.1, "masking": "separable", "fresnel": "one", "sampler": "vndf"}
    m = model_cache("ggx", **kw)
    mu = np.array([0.25, 0.7])
    seed, n = 11, samples // 16
    r = clbrdf.albedo(m, mu, estimator="uniform", samples=samples, seed=seed, qmc=True)
    for point, x in enumerate(mu):
        means = []
        for stream in range(16):
            u = m.random(n, seed=seed, point=point, stream=stream, qmc=True).astype(np.float64)
            means.append(uniform_hemisphere_estimates(kw, S.direction(x), u[:, 0], u[:, 1]).mean())
        e_py, se_py = np.mean(means), np.std(means, ddof=1) / 4 * np.sqrt(15 / 13)  # t, 15 dof
        assert abs(r.albedo[point] - e_py) <= 1e-4 * e_py, (point, r.albedo[point], e_py)
        se = r.sampling_stderr[point]
        assert abs(se - se_py) <= 1e-3 * se_py, (point, se, se_py)
        assert 1e-4 * e_py < 0.05 * se_py             # the check can tell point sets apart


# ---------------------------------------------------------------------------------------------
# 10. determinism

@pytest.mark.parametrize("qmc", [False, True])
@pytest.mark.parametrize("estimator", ["brdf", "mis"])
def test_albedo_bit_identical(estimator, qmc, model_cache, monkeypatch):
    """The albedo of point k uses the stream of point index k, its position in the flattened
    broadcast of (parameters, mu, phi) in one call (core.albedo: point0 + local index). So a
    prefix of the points, computed alone, must reproduce their values bit for bit; so must the
    same call split into launches of one block, three blocks or about two points (runtime.LAUNCH_SAMPLES), and a second run.
    (An arbitrary subset cannot be reproduced: the API has no way to give its point indices.)"""
    kw = {"alpha": np.array([0.05, 0.3, 0.3, 0.6, 0.9, 0.9, 0.2]), "fresnel": "conductor", "kd": 0.2}
    m = model_cache("beckmann", **kw)
    args = dict(estimator=estimator, qmc=qmc, samples=20_001, seed=(5 << 40) + 3)
    full = clbrdf.albedo(m, 0.45, 0.3, **args)
    again = clbrdf.albedo(m, 0.45, 0.3, **args)
    np.testing.assert_array_equal(full.albedo, again.albedo)
    np.testing.assert_array_equal(full.stderr, again.stderr)
    head = model_cache("beckmann", **{**kw, "alpha": kw["alpha"][:3]})
    part = clbrdf.albedo(head, 0.45, 0.3, **args)
    np.testing.assert_array_equal(part.albedo, full.albedo[:3])
    np.testing.assert_array_equal(part.stderr, full.stderr[:3])
    from clbrdf.runtime import albedo as runtime
    for cap in (1, 3 * 1024, 50_000):   # one block per launch; 3 blocks; about 2 points
        monkeypatch.setattr(runtime, "LAUNCH_SAMPLES", cap)
        one = clbrdf.albedo(m, 0.45, 0.3, **args)
        np.testing.assert_array_equal(one.albedo, full.albedo)
        np.testing.assert_array_equal(one.stderr, full.stderr)
    # equal parameters at points 1 and 2 (and 4, 5): different streams, different estimates
    assert full.albedo[1] != full.albedo[2] and full.albedo[4] != full.albedo[5]
