"""Holzschuch & Pacanowski 2015 (model ``holzschuch_pacanowski``) and the exponential-power
microfacet distribution (model ``exppow``): the reference against the paper's integrals, D and
the G1 table against direct quadrature, the sampler of eq 22-23, the diffraction lobe's energy
(docs/models/holzschuch_pacanowski.md, the lobe's normalisation), and the nickel example of
Figure 12a (a = 0.91, sigma = 0.027, p = 0.51).

What every model gets (values and densities against the reference, single against double
precision, RGB, the sampler's chi-square and weights, the albedo) is the conformance battery's
(tests/models/test_conformance.py) and clbrdf check's (tests/studies/test_check.py); this file keeps what is
specific to the paper.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, special

import clbrdf
import stats as S
from clbrdf.runtime import build
from clbrdf.ref import holzschuch_pacanowski as R

LAMS = R.WAVELENGTHS
NICKEL = dict(a=0.91, sigma=0.027, p=0.51)
# an RGB material on the nickel geometry: diffuse, reflection and diffraction lobes all present;
# kw is given as a fraction of lambda^4 so that each lobe's albedo stays below its weight
RGB = dict(kd=[0.05, 0.04, 0.03], ks=[0.6, 0.55, 0.5], f0=[0.66, 0.6, 0.52],
           kw=[0.3 * LAMS[0] ** 4, 0.25 * LAMS[1] ** 4, 0.2 * LAMS[2] ** 4], **NICKEL)


def dirs(n, seed, zmin=0.02):
    rng = np.random.default_rng(seed)
    z = rng.uniform(zmin, 1, (2, n))
    phi = rng.uniform(0, 2 * np.pi, (2, n))
    s = np.sqrt(1 - z * z)
    w = np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)
    return w[0], w[1]


def near_specular(n, seed, sigma):
    """Pairs with half vectors within a few lobe widths of the normal (where the lobe is)."""
    rng = np.random.default_rng(seed)
    wo = dirs(n, seed)[1]
    t = np.arctan(sigma * rng.uniform(0, 4, n))
    ph = rng.uniform(0, 2 * np.pi, n)
    h = np.stack([np.sin(t) * np.cos(ph), np.sin(t) * np.sin(ph), np.cos(t)], -1)
    wi = 2 * np.sum(wo * h, -1, keepdims=True) * h - wo
    ok = wi[:, 2] > 0.02
    return wi[ok], wo[ok]


# ---------------------------------------------------------------------------------------------
# The reference against the paper

@pytest.mark.parametrize("p", [0.1, 0.3, 0.51, 2.0, 5.0])
def test_p22_integrates_to_one_over_pi(p):
    """eq 19: integral_0^inf P22 = 1/pi (here in y = x^p, where the tail is a Gamma density)."""
    sigma = 0.3
    v, _ = integrate.quad(lambda y: R.p22(sigma ** 2 * y ** (1 / p), sigma, p) * sigma ** 2 / p
                          * y ** (1 / p - 1), 0, np.inf, epsrel=1e-12, limit=400)
    assert abs(v * np.pi - 1) < 1e-9


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
@pytest.mark.parametrize("nu,p", [(0.5, 0.51), (2.0, 0.51), (0.8, 2.0), (3.0, 0.3)])
def test_lambda_1d_form_matches_eq20_21(nu, p):
    """The reference's one-dimensional Lambda (azimuth of the slope in closed form) against the
    literal double integral of eq 20-21 (nested quadrature)."""
    a, b = R.lambda_quad(nu, p), R.lambda_direct(nu, p)
    assert abs(a / b - 1) < 1e-6, (a, b)


def test_lambda_p1_is_beckmann():
    """p = 1 is Beckmann with alpha = sigma: Lambda = (erf(m) - 1)/2 + exp(-m^2)/(2 m sqrt(pi))."""
    for nu in (0.3, 0.7, 1.5, 4.0, 40.0):
        m = 1 / nu
        beck = (-special.erfc(m) + math.exp(-m * m) / (m * math.sqrt(math.pi))) / 2
        assert abs(R.lambda_quad(nu, 1.0) / beck - 1) < 1e-11


def test_reference_lambda_spline():
    """The reference's spline of Lambda against the quadrature (the spline is what the albedo
    reference uses)."""
    rng = np.random.default_rng(5)
    for p in (0.51, 3.0):
        m = float(R.slope_mean(p))
        nut = np.exp(rng.uniform(np.log(1e-3), np.log(1e3), 40))
        theta = np.arctan(nut / m / 0.2)
        w = np.stack([np.sin(theta), 0 * theta, np.cos(theta)], -1)
        got = np.log1p(R.Lambda(w, 0.2, p))
        exact = np.log1p([R.lambda_quad(v / m, p) for v in nut])
        assert np.max(np.abs(got - exact)) < 1e-8


# ---------------------------------------------------------------------------------------------
# Kernel pieces through a test program: Lambda (table) and D

SRC = """
__kernel void lam(Tables TABLES, const global real_t *Sg, const global real_t *Pp,
                  const global real_t *T, global real_t *out, global real_t *d)
{
    size_t i = get_global_id(0) * W;
    realN s = VLOAD(Sg + i), p = VLOAD(Pp + i), t = VLOAD(T + i);
    Microfacet m = {s, s, p, TABLES};
    realN c = 1 / sqrt(1 + t * t);
    vec3 w = v3(t * c, (realN)0, c);
    VSTORE(exppow_Lambda(m, w), out + i);
    VSTORE(exppow_D(m, w), d + i);
}
"""


def run_lambda(sigma, p, tan, precision, width):
    return build.run_functions(("common.h", "dist_exppow.h"), SRC, "lam", (sigma, p, tan), 2,
                               precision=precision, width=width)


@pytest.mark.parametrize("width", [1, 16])
@pytest.mark.parametrize("precision", ["single", "double"])
def test_lambda_table_against_quadrature(precision, width):
    """Kernel Lambda (table, Catmull-Rom) against direct quadrature: |log(1 + Lambda)| error, i.e.
    the relative error of G1, below 1e-5 (the generator measured 5.4e-6 at 8080 points) plus the
    precision's rounding of log nu~ (a few eps times |log nu~|, x the slope of log(1 + Lambda)
    in log nu~, at most 1)."""
    rng = np.random.default_rng(11)
    n = 300
    p = np.exp(rng.uniform(np.log(0.1), np.log(5), n))
    nut = np.exp(rng.uniform(np.log(1e-5), np.log(1e5), n))
    sigma = np.exp(rng.uniform(np.log(1e-3), np.log(3), n))
    dt = np.float64 if precision == "double" else np.float32
    p, sigma = p.astype(dt).astype(float), sigma.astype(dt).astype(float)
    tan = (nut / R.slope_mean(p) / sigma).astype(dt).astype(float)
    lam, _ = run_lambda(sigma, p, tan, precision, width)
    exact = np.array([R.lambda_quad(s * t, q) for s, t, q in zip(sigma, tan, p)])
    err = np.abs(np.log1p(lam) - np.log1p(exact))
    eps = 2.0 ** -24 if precision == "single" else 2.0 ** -53
    tol = 1e-5 + 64 * eps * (1 + np.abs(np.log(nut)))
    assert np.all(np.isfinite(lam))
    assert np.all(err < tol), f"max err {err.max():.3g} at p={p[np.argmax(err / tol)]}"


@pytest.mark.parametrize("precision", ["single", "double"])
def test_D_kernel(precision):
    """exppow_D against eq 26 where it is not negligible, and finite (0) towards the horizon."""
    rng = np.random.default_rng(2)
    n = 400
    p = np.exp(rng.uniform(np.log(0.1), np.log(5), n))
    sigma = np.exp(rng.uniform(np.log(1e-3), np.log(3), n))
    tan = sigma * rng.uniform(0, 3, n) ** (1 / (2 * p)) * 2
    tan[:10] = 1e12
    _, d = run_lambda(sigma, p, tan, precision, 16)
    c = 1 / np.sqrt(1 + tan ** 2)
    h = np.stack([tan * c, 0 * c, c], -1)
    ref = R.D(h, sigma, p)
    assert np.all(np.isfinite(d)) and np.all(d[:10] == 0)
    e = (tan / sigma) ** (2 * p)
    eps = 2.0 ** -24 if precision == "single" else 2.0 ** -53
    tol = 32 * eps * (1 + e + np.abs(np.log(np.maximum(ref, 1e-300))))
    big = ref > 1e-30
    assert np.all(np.abs(d[big] / ref[big] - 1) < tol[big])


# ---------------------------------------------------------------------------------------------
# Models: eval against the reference, reciprocity, RGB

def eval_tol(precision, wi, wo, sigma, p):
    """Two G1 from the table (2 x 1e-5) plus, in single precision, the rounding of the half
    vector: tan theta_h carries ~eps / sin theta_h, and (tan^2/sigma^2)^p multiplies a relative
    error by 2 p e with e that exponent."""
    if precision == "double":
        return np.full(len(wi), 2.5e-5)
    h = R.normalize(wi + wo)
    t2 = (h[:, 0] ** 2 + h[:, 1] ** 2) / h[:, 2] ** 2
    e = (t2 / sigma ** 2) ** p
    sin_h = np.sqrt(t2 / (1 + t2))
    return 2.5e-5 + 16 * 2.0 ** -24 * (1 + 2 * p * e / np.maximum(sin_h, 1e-7) + e)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_exppow_p1_is_beckmann_kernel(precision):
    """p = 1 is Beckmann with alpha = sigma: the exppow kernel (D in closed form, Lambda from the
    table) against the beckmann kernel (D and Lambda in closed form), masking and sampler alike."""
    wi, wo = dirs(400, 12)
    w2, o2 = near_specular(400, 13, 0.2)
    wi, wo = np.concatenate([wi, w2]), np.concatenate([wo, o2])
    kw = dict(alpha=0.2, masking="separable", sampler="ndf", precision=precision)
    fe = clbrdf.Model("exppow", p=1.0, **kw).eval(wo, wi)
    fb = clbrdf.Model("beckmann", **kw).eval(wo, wi)
    big = fb > 1e-20 * fb.max()
    assert np.all(np.abs(fe[big] / fb[big] - 1) < eval_tol(precision, wi[big], wo[big], 0.2, 1.0))
    # sampling densities at exppow's own samples (its sampler maps u0 to Q^-1(1, u0) = -log u0,
    # Beckmann's to -log(1 - u0): the same distribution, not the same points)
    u = np.random.default_rng(3).random((2000, 4)) * 0.999
    se = clbrdf.Model("exppow", p=1.0, **kw).sample(wo[:1].repeat(2000, 0), u)
    pe = clbrdf.Model("exppow", p=1.0, **kw).pdf(wo[:1].repeat(2000, 0), se[0])
    pb = clbrdf.Model("beckmann", **kw).pdf(wo[:1].repeat(2000, 0), se[0])
    ok = pb > 0
    assert ok.mean() > 0.9
    assert np.all(np.abs(pe[ok] / pb[ok] - 1) < (1e-9 if precision == "double" else 1e-3))


@pytest.mark.parametrize("precision", ["single", "double"])
def test_no_nan_at_extremes(precision):
    """sigma 1e-4 and 10, p 0.1 and 5, a 1e-3 and 100, cos theta down to 1e-6: eval, pdf and
    samples finite (and non-negative)."""
    rng = np.random.default_rng(8)
    z = np.concatenate([[1e-6, 1e-5, 1e-3, 1.0], rng.uniform(1e-6, 1, 60)])
    phi = rng.uniform(0, 2 * np.pi, z.size)
    s = np.sqrt(1 - z * z)
    w = np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)
    wi, wo = w, np.roll(w, 1, 0)
    wi = np.concatenate([wi, w, -wo * [1, 1, -1]])      # also wi == wo and the mirror direction
    wo = np.concatenate([wo, w, wo])
    for sigma in (1e-4, 10.0):
        for p in (0.1, 5.0):
            for a in (1e-3, 100.0):
                m = clbrdf.Model("holzschuch_pacanowski", channels=3, precision=precision, sigma=sigma,
                                 p=p, a=a, kd=0.2, ks=0.5, kw=0.1, f0=0.9)
                f = m.eval(wo, wi)
                assert np.all(np.isfinite(f)) and np.all(f >= 0), (sigma, p, a)
                assert np.all(np.isfinite(m.pdf(wo, wi)))
                x, wt, pdf = m.sample(np.broadcast_to(wo[:4], (4096, 4, 3)).reshape(-1, 3), seed=3)
                assert np.all(np.isfinite(x)) and np.all(np.isfinite(wt)) and np.all(np.isfinite(pdf))
                assert np.all(wt >= 0) and np.all(pdf >= 0)
                e = clbrdf.Model("exppow", alpha=sigma, p=p, precision=precision)
                assert np.all(np.isfinite(e.eval(wo, wi))) and np.all(np.isfinite(e.pdf(wo, wi)))
                x, wt, pdf = e.sample(np.broadcast_to(wo[:4], (4096, 4, 3)).reshape(-1, 3), seed=3)
                assert np.all(np.isfinite(wt)) and np.all(np.isfinite(pdf))


# ---------------------------------------------------------------------------------------------
# Sampling

@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("p", [0.1, 0.51, 5.0])
def test_sampler_is_eq23(precision, p):
    """The half vector of a reflection-lobe sample has tan^2 theta_h = sigma^2 y^(1/p), y the
    upper-tail inverse Q^-1(1/p, u0) (eq 23), and azimuth 2 pi u1 (eq 22): pointwise for u0
    over the whole unit interval, both tails."""
    sigma = 0.2
    u0 = np.concatenate([np.geomspace(1e-7, 0.5, 200), 1 - np.geomspace(1e-7, 0.5, 200)])
    dt = np.float64 if precision == "double" else np.float32
    u0 = u0.astype(dt).astype(float)
    u = np.stack([u0, np.full_like(u0, 0.3), np.zeros_like(u0), np.zeros_like(u0)], -1)
    m = clbrdf.Model("exppow", alpha=sigma, p=p, precision=precision)
    wi, _, _ = m.sample(np.broadcast_to([0.0, 0.0, 1.0], (u0.size, 3)), u)
    h = R.normalize(wi.astype(float) + [0, 0, 1])
    with np.errstate(divide="ignore"):         # h.z = 0 in float where tan theta_h > 1e7
        tan = np.hypot(h[:, 0], h[:, 1]) / h[:, 2]
    ref = np.sqrt(R.sample_tan2(u0, sigma, p))
    ok = (ref > 1e-3) & (ref < 1e3)            # where the direction resolves tan theta_h
    # wi = reflect(n, h) has wi.z = 2 cos^2 theta_h - 1: recovering h = normalize(wi + n)
    # cancels for large theta_h, relative error ~ eps tan^2 theta_h
    eps = 2.0 ** -53 if precision == "double" else 2.0 ** -24
    tol = (1e-9 if precision == "double" else 2e-5) + 8 * eps * ref[ok] ** 2
    assert np.all(np.abs(tan[ok] / ref[ok] - 1) < tol)
    phi = np.arctan2(-h[ok, 1], -h[ok, 0]) % (2 * np.pi)
    assert np.allclose(phi, 2 * np.pi * 0.3, atol=1e-4)


NS_FINE, NT_FINE = 128, 256
NB_S, NB_T = 32, 32


@pytest.mark.parametrize("precision,width", [("single", 16), ("double", 8)])
def test_large_rgb_launches(precision, width):
    """2^18 RGB samples and a 64 x 2^16-sample albedo in one launch each: these crashed PoCL
    (stack overflow in work-groups of 4096 items) before the engine fixed the local size."""
    m = clbrdf.Model("holzschuch_pacanowski", channels=3, precision=precision, width=width,
                     kd=[0.1, 0.1, 0.1])
    wo = np.broadcast_to([0.6, 0.0, 0.8], (1 << 18, 3))
    wi, w, p = m.sample(wo, seed=1)
    assert np.all(np.isfinite(w)) and np.all(np.isfinite(p))
    r = clbrdf.albedo(m, np.linspace(0.05, 1, 64), samples=1 << 16)
    assert np.all(np.isfinite(r.albedo))


# ---------------------------------------------------------------------------------------------
# Albedo: Monte Carlo against the deterministic reference; nickel; energy


_REF: dict = {}


def test_nickel_albedo_is_finite_and_below_one():
    """Figure 12a geometry (a = 0.91, sigma = 0.027, p = 0.51): with F = 1 and one lobe at a
    time (unit weights: ks = 1; kw = lambda^4, i.e. the lobe's largest albedo 1; kd = 1) every
    lobe's albedo is finite and at most 1 at every mu down to 1e-3, and the whole RGB material
    stays below 1. The reflection lobe loses energy only by masking (single scattering)."""
    mus = np.array([1e-3, 0.05, 0.3, 0.7, 1.0])
    refl = clbrdf.Model("holzschuch_pacanowski", ks=1.0, f0=1.0, kd=0.0, kw=0.0, **NICKEL)
    diff = clbrdf.Model("holzschuch_pacanowski", ks=0.0, kd=0.0, kw=LAMS[1] ** 4, **NICKEL)
    full = clbrdf.Model("holzschuch_pacanowski", channels=3, **RGB)
    for m in (refl, diff, full):
        r = clbrdf.albedo(m, mus, samples=1 << 16, seed=4)
        assert np.all(np.isfinite(r.albedo)) and np.all(r.albedo <= 1 + 4 * r.stderr)
    r = clbrdf.albedo(refl, mus, samples=1 << 16, seed=4)
    assert np.all(r.albedo[2:] > 0.98)        # sharp lobe: G ~ 1 away from grazing


def test_diffraction_energy_verify():
    """docs/models/holzschuch_pacanowski.md, the lobe's normalisation: the diffraction lobe S(f_s) / E with G = 1, at normal incidence,
    integrated (cos-weighted) over the hemisphere by 1-D quadrature over the projected disk,
    and off normal incidence by the 2-D reference quadrature. E = pi c/(1+c) (c = a^2 lambda^2)
    gives albedo exactly 1 at normal incidence and less elsewhere (S is radially decreasing
    about the disk's centre Vp, so the disk centred on its peak holds the most); the printed
    E = pi (1 + 1/c) gives (c/(1+c))^2."""
    for a in (0.3, 0.91, 3.0):
        for L in LAMS:
            c = (a * L) ** 2
            disk, _ = integrate.quad(lambda r: 2 * np.pi * r / (1 + (r / (L * a)) ** 2) ** 2, 0, 1,
                                     epsabs=0, epsrel=1e-12)
            assert abs(disk / R.diffraction_energy(a, L) - 1) < 1e-10
            assert abs(disk / R.diffraction_energy_paper(a, L) - (c / (1 + c)) ** 2) < 1e-10

    def lobe(wi, wo, a, L):
        dp = np.hypot(wi[..., 0] + wo[..., 0], wi[..., 1] + wo[..., 1])
        return 1 / (1 + (dp / L / a) ** 2) ** 2 / R.diffraction_energy(a, L) * wi[..., 2]
    for mu in (0.9, 0.5, 0.1):
        wo = S.direction(mu, 0.0)
        v, _ = R.hemisphere_integral(lambda wi: lobe(wi, wo, 0.91, LAMS[0]), [R.cosine_map()], 1e-9)
        assert v < 1
