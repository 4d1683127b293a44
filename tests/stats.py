"""Helpers shared by the test files: model configurations, direction sets, float-rounding
tolerances, a hemisphere quadrature in the half-vector domain, statistics (Pearson chi-square
with pooling, Sidak correction, binomial acceptance intervals), and the chi-square of samples
over half-vector-map bins.

Apart from draw, nothing here calls the library's own sampling or quadrature code: the
quadrature map below is written from the geometry of reflection (docs/models/microfacet.md), so a test
that integrates the kernel pdf with it checks the kernel against mathematics, not against itself.
"""
from __future__ import annotations

import itertools

import numpy as np
from scipy import stats as sps

from clbrdf.studies.stats import HalfVectorMap, MapChi2, chi2_gof, gl01, make_bins, map_chi2, panel_integrals, pool_small, quantile_groups, sidak

def assert_close(got, ref, rtol, atol=0.0, what="", allow_zero=None, context=None):
    """|got - ref| <= rtol |ref| + atol everywhere (NaN fails; rtol and atol may be arrays); where
    ``allow_zero`` is true, got == 0 passes as well. The message shows the 5 worst values, with
    the entries of ``context`` (name -> array whose leading axes are the values' shape) at each."""
    got, ref = np.asarray(got, float), np.asarray(ref, float)
    shape = np.broadcast_shapes(got.shape, ref.shape)
    got, ref = np.broadcast_to(got, shape).ravel(), np.broadcast_to(ref, shape).ravel()
    err = np.abs(got - ref)
    tol = np.broadcast_to(rtol * np.abs(ref) + atol, got.shape)
    bad = ~(err <= tol)
    if allow_zero is not None:
        bad &= ~(np.broadcast_to(allow_zero, shape).ravel() & (got == 0))
    if not bad.any():
        return
    idx = np.nonzero(bad)[0]
    worst = idx[np.argsort(-np.nan_to_num(err[idx] / np.maximum(tol[idx], 1e-300), nan=np.inf))][:5]
    lines = [f"{what}: {idx.size} of {got.size} values outside tolerance; worst:"]
    for i in worst:
        extra = "" if context is None else " " + "; ".join(
            f"{k}={np.round(np.asarray(v)[np.unravel_index(i, shape)], 8).tolist()}"
            for k, v in context.items())
        lines.append(f"  [{i}] got {got[i]:.9g} ref {ref[i]:.9g} rel {err[i] / max(abs(ref[i]), 1e-300):.3g}"
                     f" tol {tol[i]:.3g}{extra}")
    raise AssertionError("\n".join(lines))


EPS32 = float(np.finfo(np.float32).eps) / 2       # unit roundoff, 2^-24
EPS64 = float(np.finfo(np.float64).eps) / 2       # 2^-53

# ---------------------------------------------------------------------------------------------
# Model configurations
#
# A configuration is a dict: name (lambert | beckmann | ggx) and, for the microfacet models,
# aniso (bool), masking, fresnel, kd (bool: Lambertian term compiled in) and sampler.

DISTS = ("beckmann", "ggx")
ANISO = (False, True)
MASKINGS = ("none", "vcavity", "separable", "correlated")
FRESNELS = ("one", "schlick", "dielectric", "conductor")
KDS = (False, True)
SAMPLERS = ("ndf", "vndf")

FRESNEL_VALUES = {"one": {}, "schlick": {"f0": 0.2}, "dielectric": {"eta": 1.5},
                  "conductor": {"eta": 0.2, "k": 3.0}}
KD_VALUE = 0.3

LAMBERT = {"name": "lambert"}

# A pairwise covering array over (dist, aniso, masking, fresnel, kd, sampler): every pair of
# values of any two factors occurs in at least one row (checked below). 16 rows is the minimum,
# since masking x fresnel alone has 16 pairs.
_COVER_ROWS = [
    (0, 0, 0, 0, 1, 0), (1, 1, 0, 1, 1, 1), (0, 0, 0, 2, 1, 0), (1, 1, 0, 3, 0, 1),
    (1, 0, 1, 0, 0, 1), (0, 0, 1, 1, 0, 0), (1, 0, 1, 2, 1, 0), (0, 1, 1, 3, 1, 0),
    (1, 0, 2, 0, 0, 1), (1, 0, 2, 1, 1, 0), (0, 1, 2, 2, 0, 1), (1, 0, 2, 3, 1, 1),
    (1, 1, 3, 0, 0, 1), (0, 1, 3, 1, 1, 0), (1, 1, 3, 2, 0, 1), (0, 0, 3, 3, 1, 1),
]
_FACTORS = (DISTS, ANISO, MASKINGS, FRESNELS, KDS, SAMPLERS)


def _row_config(row):
    d, a, m, f, k, s = (levels[i] for levels, i in zip(_FACTORS, row))
    return {"name": d, "aniso": a, "masking": m, "fresnel": f, "kd": k, "sampler": s}


def _check_pairwise(rows):
    want = {(a, x, b, y) for a, b in itertools.combinations(range(6), 2)
            for x in range(len(_FACTORS[a])) for y in range(len(_FACTORS[b]))}
    have = {(a, r[a], b, r[b]) for r in rows for a, b in itertools.combinations(range(6), 2)}
    assert have == want, "covering array misses pairs"


_check_pairwise(_COVER_ROWS)

#: default run: Lambert and the 16-row pairwise cover of the microfacet configurations
COVER = [LAMBERT] + [_row_config(r) for r in _COVER_ROWS]
#: slow run: the full product (256 microfacet configurations) and Lambert
FULL = [LAMBERT] + [{"name": d, "aniso": a, "masking": m, "fresnel": f, "kd": k, "sampler": s}
                    for d, a, m, f, k, s in itertools.product(*_FACTORS)]

def config_id(cfg) -> str:
    if cfg["name"] == "lambert":
        return "lambert"
    return "-".join([cfg["name"], "aniso" if cfg["aniso"] else "iso", cfg["masking"], cfg["fresnel"],
                     "kd" if cfg["kd"] else "nokd", cfg["sampler"]])


def full_not_in_cover():
    """The full product minus the default cover (the slow run's extra configurations)."""
    cover = {config_id(c) for c in COVER}
    return [c for c in FULL if config_id(c) not in cover]


def model_kwargs(cfg, alpha=0.3, alpha_y=None, **override):
    """Keyword arguments of clbrdf.Model for a configuration. alpha (and alpha_y for anisotropic
    configurations; default alpha / 3) may be arrays; override replaces parameter values."""
    if cfg["name"] == "lambert":
        return {"kd": override.get("kd", 0.7)}
    kw = {"masking": cfg["masking"], "fresnel": cfg["fresnel"], "sampler": cfg["sampler"]}
    if cfg["aniso"]:
        kw["alpha_x"] = alpha
        kw["alpha_y"] = np.asarray(alpha) / 3 if alpha_y is None else alpha_y
    else:
        kw["alpha"] = alpha
    kw.update(FRESNEL_VALUES[cfg["fresnel"]])
    if cfg["kd"]:
        kw["kd"] = KD_VALUE
    for k, v in override.items():
        if k in kw:
            kw[k] = v
    return kw


def ref_kwargs(kw):
    """clbrdf.ref.microfacet keywords for Model keywords (the reference calls the lobe sampler
    ``lobe_sampler``)."""
    kw = dict(kw)
    if "sampler" in kw:
        kw["lobe_sampler"] = kw.pop("sampler")
    return kw


def alphas(kw):
    """(alpha_x, alpha_y) of Model keywords (1, 1 for Lambert: the scale of its lobe)."""
    if "alpha" in kw:
        return np.asarray(kw["alpha"], float), np.asarray(kw["alpha"], float)
    if "alpha_x" in kw:
        return np.asarray(kw["alpha_x"], float), np.asarray(kw["alpha_y"], float)
    return np.asarray(1.0), np.asarray(1.0)


# ---------------------------------------------------------------------------------------------
# Directions

def unit(theta, phi):
    s = np.sin(theta)
    return np.stack(np.broadcast_arrays(s * np.cos(phi), s * np.sin(phi), np.cos(theta)), -1)


def direction(mu, phi=0.0):
    mu = np.asarray(mu, float)
    s = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    return np.stack(np.broadcast_arrays(s * np.cos(phi), s * np.sin(phi), mu), -1)


def random_pairs(rng, n, ax, ay, min_z=1e-3, below=0.02):
    """n (wi, wo) pairs for value tests: a third uniform on the upper hemisphere, a third with
    log-uniform cos theta in [min_z, 0.1] (grazing, both directions independently), a third near
    the specular peak (h drawn with slopes ~ alpha, so narrow lobes are probed where they are
    large), then min_z exactly for a few, and a fraction ``below`` of wi flipped below the
    horizon (where the value must be exactly 0). ax, ay: per-pair roughness (arrays of n)."""
    def upper(k):
        v = rng.normal(size=(k, 3))
        v[:, 2] = np.abs(v[:, 2])
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    def grazing(k):
        return direction(10 ** rng.uniform(np.log10(min_z), -1, k), rng.uniform(0, 2 * np.pi, k))

    k = n // 3
    wo = np.concatenate([upper(k), grazing(k), upper(n - 2 * k)])
    wi = np.concatenate([upper(k), grazing(k), upper(n - 2 * k)])
    # near-specular third
    sl = rng.normal(size=(n - 2 * k, 2)) * np.stack([ax[2 * k:], ay[2 * k:]], -1)
    h = np.concatenate([-sl, np.ones((n - 2 * k, 1))], -1)
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    r = 2 * np.sum(wo[2 * k:] * h, -1)[:, None] * h - wo[2 * k:]
    ok = r[:, 2] >= min_z
    wi[2 * k:][ok] = r[ok]
    # exactly min_z for a few pairs, both ways
    for w in (wi, wo):
        idx = rng.choice(n, n // 50, replace=False)
        w[idx] = direction(np.full(idx.size, min_z), rng.uniform(0, 2 * np.pi, idx.size))
    flip = rng.choice(n, int(n * below), replace=False)
    wi[flip, 2] *= -1
    return wi, wo


def round_to(dtype, *arrays):
    """Arrays rounded to dtype and back to float64: the values a kernel of that precision sees."""
    return [np.asarray(a, float).astype(dtype).astype(float) if isinstance(a, np.ndarray) else a
            for a in arrays]


# ---------------------------------------------------------------------------------------------
# Float-rounding tolerances
#
# A value that depends on h = normalize(wi + wo) inherits the rounding of h (a few units of
# roundoff eps in the slope s = tan theta_h). The log-derivative of D with respect to the slope is
# at most 2 (1 + sqrt(e)) / alpha (GGX: 4 s / (alpha^2 + s^2) <= 2 / alpha; Beckmann 2 s / alpha^2
# = 2 sqrt(e) / alpha), e = (sx/ax)^2 + (sy/ay)^2, so the relative error of D is about
# eps (1 + sqrt(e)) / alpha_min times a small constant (8 here, for the ~4 roundings on the way
# to h and 2 for the derivative bound). When h is recomputed from a *rounded* wi (a sampled
# direction stored in float32), the rounding of wi enters h amplified by 1 / (2 wo.h), and a
# factor 1 / (wo.h) (the NDF sampler's Jacobian) gets a relative error ~ eps / (wo.h)^2.

def slope_exponent(wi, wo, ax, ay):
    """e = (sx/ax)^2 + (sy/ay)^2 at h = normalize(wi + wo), and wo.h."""
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = ((h[..., 0] / ax) ** 2 + (h[..., 1] / ay) ** 2) / h[..., 2] ** 2
        e = np.where(h[..., 2] > 0, e, np.inf)
    return e, np.sum(h * wo, -1)


def cond_rtol(base, eps, wi, wo, ax, ay, amplify=False):
    """Per-pair relative tolerance: base + 8 eps (1 + sqrt(e)) / alpha_min [/ min(1, 2 wo.h)]."""
    e, woh = slope_exponent(wi, wo, ax, ay)
    e = np.where(np.isfinite(e), e, 0.0)
    r = 8 * eps * (1 + np.sqrt(e)) / np.minimum(ax, ay)
    if amplify:
        # h from a rounded wi: its error eps / (2 wo.h) moves D (above) and, for a density with
        # 1 / (wo.h), that factor by eps / (wo.h)^2 relative
        woh = np.clip(woh, 1e-6, 1)
        r = r / np.minimum(2 * woh, 1) + 4 * eps / woh ** 2
    return base + r


def weight_rtol(base, eps, wi, wo, ax, ay):
    """Relative tolerance of a sample weight against f cos / pdf recomputed from the rounded wi:
    D cancels; G and F remain, with relative sensitivities ~ eps / wi.z (Lambda at grazing wi),
    eps / (wo.h) and, for the V-cavity term's 1 / (wo.h), eps / (wo.h)^2."""
    _, woh = slope_exponent(wi, wo, ax, ay)
    woh = np.clip(woh, 1e-6, 1)
    return base + 8 * eps / np.minimum(wi[..., 2], woh) + 4 * eps / woh ** 2


# ---------------------------------------------------------------------------------------------
# Half-vector quadrature and binning domain
#
# For a fixed wo the map wi -> h = normalize(wi + wo) is a bijection from the upper hemisphere of
# wi onto the cone of half vectors {theta_h < theta_max(phi_h)}: with wo at polar angle theta_o and
# azimuth phi_o, wi.z = R cos(2 theta_h - delta), tan delta = tan theta_o cos(phi_h - phi_o), so
# wi.z > 0 exactly when theta_h < theta_max = (pi/2 + delta) / 2. dw_i = 4 (wo.h) dw_h.
#
# ---------------------------------------------------------------------------------------------
# Philox4x32-10 in pure Python (NumPy), for checking the kernels' generator

PHILOX_M = (0xD2511F53, 0xCD9E8D57)
PHILOX_W = (0x9E3779B9, 0xBB67AE85)


def philox4x32_10(ctr, key):
    """Pure-Python Philox4x32-10 (Salmon et al. 2011), vectorised with NumPy uint64: ctr is four
    arrays (or ints) of 32-bit words, key two ints. Returns four uint32 arrays."""
    m32 = np.uint64(0xFFFFFFFF)
    c = [np.asarray(x, dtype=np.uint64) & m32 for x in np.broadcast_arrays(*ctr)]
    k0, k1 = int(key[0]) & 0xFFFFFFFF, int(key[1]) & 0xFFFFFFFF
    for _ in range(10):
        p0 = c[0] * np.uint64(PHILOX_M[0])
        p1 = c[2] * np.uint64(PHILOX_M[1])
        c = [((p1 >> np.uint64(32)) ^ c[1] ^ np.uint64(k0)) & m32, p1 & m32,
             ((p0 >> np.uint64(32)) ^ c[3] ^ np.uint64(k1)) & m32, p0 & m32]
        k0 = (k0 + PHILOX_W[0]) & 0xFFFFFFFF
        k1 = (k1 + PHILOX_W[1]) & 0xFFFFFFFF
    return [x.astype(np.uint32) for x in c]


def bits_to_unit(x, precision):
    """The kernel's map from 32 bits to a real, evaluated in the kernel's own arithmetic:
    single ((x >> 9) + 0.5f) * 2^-23 in float32 (exact), double (x + 0.5) * 2^-32."""
    x = np.asarray(x, np.uint32)
    if precision == "single":
        return ((x >> np.uint32(9)).astype(np.float32) + np.float32(0.5)) * np.float32(2.0 ** -23)
    return (x.astype(np.float64) + 0.5) * 2.0 ** -32


# ---------------------------------------------------------------------------------------------
# Statistics

def binomial_acceptance(n, p, alpha):
    """Two-sided acceptance interval [lo, hi] for a Binomial(n, p) count at significance alpha:
    P(X < lo) <= alpha/2 and P(X > hi) <= alpha/2."""
    return int(sps.binom.ppf(alpha / 2, n, p)), int(sps.binom.isf(alpha / 2, n, p))


# ---------------------------------------------------------------------------------------------
# Samples against a density: chi-square over bins of a quadrature map

def draw(m, wo, n, seed, chunk=None):
    """n samples (wi as float64, weight, pdf) of Model m for one wo, from the library's Philox
    numbers (m.random), launched in chunks of ``chunk`` samples when given. Workaround for the
    single-precision generator bug (test_kernels.test_random_single_in_open_interval_at_cell_centres):
    a number that comes out as exactly 1.0 (probability 2^-24 each) makes Model.sample raise, so
    it is replaced by the largest float32 below 1; this changes the distribution by < 2^-24."""
    u = m.random(n, seed=seed).astype(np.float64)
    u = np.minimum(u, float(np.nextafter(np.float32(1), np.float32(0))))
    chunk = chunk or n
    parts = [m.sample(np.broadcast_to(wo, (min(chunk, n - i), 3)), u[i:i + chunk])
             for i in range(0, n, chunk)]
    return (np.concatenate([p[0] for p in parts]).astype(np.float64),
            np.concatenate([p[1] for p in parts]), np.concatenate([p[2] for p in parts]))
