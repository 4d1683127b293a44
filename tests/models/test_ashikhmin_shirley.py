"""Ashikhmin & Shirley 2000 (``ashikhmin_shirley``): specular eq 16, diffuse eq 14, the sampler of
eq 19-20 with the lobe mixture, the paper's energy claims, and Löw et al.'s fits as presets.

What every model gets (values and densities against the reference, single against double
precision, RGB, the sampler's chi-square and weights, the albedo) is the conformance battery's
(tests/models/test_conformance.py) and clbrdf check's (tests/studies/test_check.py); this file keeps what is
specific to the paper.

``python tests/models/test_ashikhmin_shirley.py`` prints the numbers of docs/models/ashikhmin_shirley.md
(energy sweep of the specular term, Figure 2 furnace value).
"""
from __future__ import annotations

import sys
from pathlib import Path

import math

import numpy as np
import pytest

import clbrdf

if __name__ == "__main__":     # run as a script: the tests' helpers are a folder up
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import stats as S  # noqa: E402
from clbrdf.models import presets
from clbrdf.ref import ashikhmin_shirley as A

F32 = np.float32
NAME = "ashikhmin_shirley"


def rounded(precision, **kw):
    if precision == "double":
        return kw
    return {k: float(F32(v)) for k, v in kw.items()}


def rdirs(rng, n, min_z=1e-3):
    """Unit vectors above the horizon, a quarter of them grazing (z in [min_z, 0.05])."""
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    k = n // 4
    v[:k] = S.direction(rng.uniform(min_z, 0.05, k), rng.uniform(0, 2 * np.pi, k))
    return v


def near_lobe(rng, wo, kw):
    """wi = reflect(wo, h) with h at the lobe's scale (slopes ~ 1/sqrt(n)), above the horizon."""
    n = len(wo)
    sl = rng.normal(size=(n, 2)) * np.array([1 / math.sqrt(kw["nu"] + 1), 1 / math.sqrt(kw["nv"] + 1)])
    h = np.concatenate([sl, np.ones((n, 1))], 1)
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    wi = 2 * np.sum(wo * h, 1, keepdims=True) * h - wo
    bad = wi[:, 2] < 1e-3
    wi[bad] = wo[bad] * np.array([-1, -1, 1])
    return wi / np.linalg.norm(wi, axis=1, keepdims=True)


def cond(kw, wi, wo, eps):
    """Relative sensitivity of f and pdf to the rounding of the inputs and the kernel's arithmetic:
    exp of the lobe's exponent log P = -e log1p(t^2)/2 (2 eps |log P|), the slope t = tan theta_h
    of s = wi + wo, whose rounding (~eps/|s|) moves log P by e t dt / (1 + t^2) (4 eps (1 + e t) /
    |s|, e the largest exponent), and k.h = |s|/2 of unnormalised inputs against the reference's
    normalised ones (2 eps / |s|^2)."""
    s = wi + wo
    ns = np.linalg.norm(s, axis=-1)
    t = np.hypot(s[..., 0], s[..., 1]) / s[..., 2]
    e = max(kw["nu"], kw["nv"])
    logp = 0.5 * e * np.log1p(t * t)
    return 2 * eps * logp + 4 * eps * (1 + e * t) / ns + 2 * eps / ns ** 2


assert_close = S.assert_close


# ---------------------------------------------------------------------------------------------
# values


def test_value_at_h_equal_n():
    """At h = n the exponent of eq 16 is 0/0 and (n.h)^e = 1: wi = mirror of wo (h = n exactly)
    gives sqrt((nu+1)(nv+1))/(8 pi) F(cos) / cos^2 for nu != nv, in both precisions, including
    wi = wo = n, and f is continuous there (h tilted by 1e-4 rad changes f by < 1e-3 relative)."""
    for prec, rt in (("double", 1e-13), ("single", 1e-6)):
        for nu, nv in ((1.0, 1e4), (1e7, 0.0), (3.0, 3.0)):
            m = clbrdf.Model(NAME, precision=prec, nu=nu, nv=nv, rs=0.25)
            mu = np.array([1.0, 0.9, 0.3, 1e-3])
            wo = S.direction(mu, 0.7)
            wi = wo * np.array([-1, -1, 1])
            f = m.eval(wo, wi)
            F = 0.25 + 0.75 * (1 - mu) ** 5
            ref = math.sqrt((nu + 1) * (nv + 1)) / (8 * np.pi) * F / mu ** 2
            assert_close(f, ref, rt, 0, f"h = n, nu={nu}, nv={nv}, {prec}")
            d = 1e-4 / math.sqrt(1 + max(nu, nv))
            tilt = S.direction(np.cos(2 * d), 0.3)        # h at polar angle d for wo = n
            f2 = m.eval(np.array([0, 0, 1.0]), tilt)
            assert abs(f2 / (math.sqrt((nu + 1) * (nv + 1)) / (8 * np.pi) * 0.25) - 1) < 1e-3


def test_sampler_is_the_papers_quadrant_map():
    """The kernel's h (read off wi for wo = n, double precision) equals the paper's four-branch
    quadrant construction of eq 19-20 (reference ``sample_h``) at the same (xi1, xi2), to 1e-12,
    for isotropic and strongly anisotropic exponents; u0 includes the quadrant boundaries."""
    g = np.concatenate([np.linspace(0, 1, 257)[:-1], [0.25 - 1e-12, 0.5 + 1e-12, 0.75 - 1e-9]])
    U0, U1 = np.meshgrid(g, np.linspace(0.01, 0.99, 7), indexing="ij")
    u = np.stack([U0.ravel(), U1.ravel(), np.zeros(U0.size), np.zeros(U0.size)], -1)
    wo = np.broadcast_to([0.0, 0.0, 1.0], (U0.size, 3))
    for nu, nv in ((10.0, 10.0), (1e4, 1.0), (0.0, 300.0)):
        m = clbrdf.Model(NAME, precision="double", nu=nu, nv=nv, rs=0.5)
        wi, _, _ = m.sample(wo, u)
        h = wi + wo
        h /= np.linalg.norm(h, axis=1, keepdims=True)
        hr = A.sample_h(nu, nv, u[:, 0], u[:, 1])
        assert np.max(np.abs(h - hr)) < 1e-12, (nu, nv, np.max(np.abs(h - hr)))


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("extra", [dict(rs=0.0), dict(rs=1.0, rd=1.0), dict(eta=1e-3, ks=1e6, kd=1.0)],
                         ids=["spec", "diffuse", "low"])
def test_no_nan_or_inf_at_extremes(extra, precision, model_cache):
    """nu, nv each in {0, 1e-3, 1, 1e4, 1e7}, cos theta of wi and wo in {1e-6, 1e-3, 0.5, 1} with
    mirror (h = n exactly), backscatter and other azimuths: eval, pdf, sample finite and >= 0;
    albedo finite."""
    NU, NV = np.meshgrid([0.0, 1e-3, 1.0, 1e4, 1e7], [0.0, 1e-3, 1.0, 1e4, 1e7], indexing="ij")
    P = dict(nu=NU.ravel(), nv=NV.ravel())
    zs = [1e-6, 1e-3, 0.5, 1.0]
    dirs = [(S.direction(zi, dphi), S.direction(zo, 0.0)) for zi in zs for zo in zs
            for dphi in (0.0, np.pi, 2.0)]
    wi = np.array([d[0] for d in dirs])[:, None, :]
    wo = np.array([d[1] for d in dirs])[:, None, :]
    m = model_cache(NAME, precision=precision, **P, **extra)
    f, p = m.eval(wo, wi), m.pdf(wo, wi)
    assert np.all(np.isfinite(f)) and np.all(f >= 0), "eval"
    assert np.all(np.isfinite(p)) and np.all(p >= 0), "pdf"
    rng = np.random.default_rng(5)
    u = rng.uniform(0, 1, (len(dirs), 1, 4))
    u[0, 0] = [0, 0, 0, 0]
    u[1, 0] = [1 - 1e-9, 1 - 1e-9, 1 - 1e-9, 0.5]
    u[2, 0] = [0.25, 0.5, 0.5, 0.5]
    shape = (len(dirs), NU.size)
    s_wi, s_w, s_p = m.sample(np.broadcast_to(wo, shape + (3,)), np.broadcast_to(u, shape + (4,)))
    for a, what in ((s_wi, "wi"), (s_w, "weight"), (s_p, "sample pdf")):
        assert np.all(np.isfinite(a)), what
    assert np.all(s_w >= 0) and np.all(s_p >= 0)
    r = clbrdf.albedo(m, np.array([1e-6, 0.5, 1.0])[:, None], samples=1024)
    assert np.all(np.isfinite(r.albedo)) and np.all(np.isfinite(r.stderr))


# ---------------------------------------------------------------------------------------------
# sampling: normalisation, chi-square, albedo


def diffuse_prob(kw, mu):
    return float(A.diffuse_prob(S.direction(mu, 0.0), A.configure(**kw)))


_REF: dict = {}


# ---------------------------------------------------------------------------------------------
# the paper's claims

def albedo_normal_iso(n, a=1 / math.sqrt(2)):
    """Specular albedo at normal incidence, nu = nv = n, F = 1, in closed form: wi.z = cos 2 theta_h
    < 1 = wo.z, so E = int_0^{pi/4} (n+1) cos^n sin cos 2 theta dtheta
    = (n+1) [2 (1 - a^(n+3))/(n+3) - (1 - a^(n+1))/(n+1)], a = cos(pi/4)."""
    return (n + 1) * (2 * (1 - a ** (n + 3)) / (n + 3) - (1 - a ** (n + 1)) / (n + 1))


def test_reference_albedo_closed_forms():
    """The reference quadrature against closed forms: the specular albedo at normal incidence for
    n = 0, 1, 10, 1e4 (rs = 1) to 1e-9, and the diffuse term's albedo rd (1 - rs)(1 - (1 -
    mu/2)^5) (the 28/23 normalisation of eq 14) to 1e-9."""
    for n in (0.0, 1.0, 10.0, 1e4):
        v, e = A.albedo(1.0, 0.0, 1e-10, nu=n, nv=n, rs=1.0)
        assert abs(v - albedo_normal_iso(n)) <= e + 1e-9, (n, v, albedo_normal_iso(n))
    for mu in (1.0, 0.3, 1e-3):
        v, e = A.albedo(mu, 0.0, 1e-10, nu=10.0, nv=10.0, rs=0.3, rd=0.8, ks=0.0)
        assert abs(v - 0.8 * 0.7 * (1 - (1 - mu / 2) ** 5)) <= e + 1e-9


def test_figure2_furnace_centre(model_cache):
    """Figure 2: 'for the center of the darkest sphere, nu = nv = 10, the luminance is about 68%'.
    The centre of a sphere seen head-on is the directional albedo at normal incidence of the
    specular term with F = 1 (rs = 1; a furnace of radiance 1). Closed form 0.695707, reference
    quadrature to 1e-10, kernel Monte Carlo (2^20 samples) within 4 standard errors; about 68-70%
    as the paper says (|E - 0.68| < 0.02)."""
    e_cf = albedo_normal_iso(10)
    v, err = A.albedo(1.0, 0.0, 1e-11, nu=10.0, nv=10.0, rs=1.0)
    assert abs(v - e_cf) <= err + 1e-10
    m = model_cache(NAME, nu=10.0, nv=10.0, rs=1.0)
    r = clbrdf.albedo(m, 1.0, samples=1 << 20, seed=4)
    assert abs(float(r.albedo) - e_cf) <= 4 * float(r.stderr) + 1e-6
    assert abs(e_cf - 0.68) < 0.02


ENERGY_FAST = [(1.0, 1.0), (10.0, 1e4), (1e4, 1e4), (1.0, 100.0)]


@pytest.mark.parametrize("nu,nv", ENERGY_FAST)
def test_specular_energy_conservation(nu, nv):
    """eq 6-9: the specular albedo with rs = 1 is at most 1 (reference quadrature, tol 1e-8) at
    mu in {1, 0.5, 0.1, 1e-3} and phi in {0, pi/4, pi/2}; the full sweep is the slow test."""
    for mu in (1.0, 0.5, 0.1, 1e-3):
        for phi in (0.0, np.pi / 4, np.pi / 2):
            v, e = A.albedo(mu, phi, 1e-8, nu=nu, nv=nv, rs=1.0)
            assert v <= 1 + e, (nu, nv, mu, phi, v)


SWEEP_N = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1e3, 3e3, 1e4)
SWEEP_MU = (1.0, 0.7, 0.4, 0.2, 0.1, 0.03, 0.01, 1e-3)


def energy_sweep(ns=SWEEP_N, mus=SWEEP_MU, phis=(0.0, np.pi / 4, np.pi / 2), tol=1e-7,
                 log=None):
    """Specular albedo (rs = 1) over nu <= nv in ns, mu in mus, phi in phis (E(nu, nv, phi) =
    E(nv, nu, pi/2 - phi), so nu > nv is covered by phis symmetric about pi/4; one phi when
    nu = nv). Returns (max, argmax, min, argmin, max err, count)."""
    best, worst, emax, count = (-1.0, None), (2.0, None), 0.0, 0
    for i, nu in enumerate(ns):
        for nv in ns[i:]:
            for mu in mus:
                for phi in (phis if nu != nv else phis[:1]):
                    v, e = A.albedo(mu, phi, tol, nu=nu, nv=nv, rs=1.0)
                    emax, count = max(emax, e), count + 1
                    if log:
                        log(f"{nu:g} {nv:g} {mu:g} {phi:.4f} {v:.10f} {e:.2g}")
                    if v > best[0]:
                        best = (v, (nu, nv, mu, phi))
                    if v < worst[0]:
                        worst = (v, (nu, nv, mu, phi))
    return best[0], best[1], worst[0], worst[1], emax, count


@pytest.mark.slow
def test_specular_energy_sweep():
    """The full sweep (nu, nv from 1 to 1e4, 8 mu, 3 phi; 936 quadratures): max albedo <= 1."""
    vmax, where, vmin, wmin, emax, _ = energy_sweep()
    assert vmax <= 1 + emax, (vmax, where)


# ---------------------------------------------------------------------------------------------
# presets

def cook_fresnel(eta, c):
    """bbm fresnel::cook (Cook & Torrance 1982), transcribed for the preset check."""
    g = np.sqrt(np.maximum(eta * eta + c * c - 1, 0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1) / (c * (g - c) + 1)
    return np.maximum(0.5 * a * a * (1 + b * b), 0)


def bbm_low_ashikhmin_shirley(fit, wi, wo):
    """bbm Aggregate(Lambertian, LowAshikhminShirley) (bsdfmodel/low.h: scaledmodel of the
    isotropic ashikhminshirley with fresnel::cook and an ior), RGB:
    albedo/pi + A (n+1)/(8 pi) (h.z)^n F_cook(eta, wi.h) / ((wi.h) max(wi.z, wo.z))."""
    a, kd = fit["LowAshikhminShirley"], np.array(fit["Lambertian"]["albedo"])
    n = a["sharpness"]
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    hi = np.sum(h * wi, 1)
    spec = ((n + 1) / (8 * np.pi) * h[:, 2] ** n * cook_fresnel(a["fresnelReflectance"], hi)
            / (hi * np.maximum(wi[:, 2], wo[:, 2])))
    return kd / np.pi + np.array(a["albedo"]) * spec[:, None]


@pytest.mark.parametrize("source", ["low_ashikhminshirley_E2.fit", "low_ashikhminshirley_E1.fit"])
def test_presets_match_fitters_formula(source):
    """Every material of each fit file, as ``Model(..., preset=...)`` in double precision, against
    bbm's formula written out above from the fit's numbers: relative 1e-9 at 8 direction pairs
    (3 near the specular peak, 2 exact mirrors, the rest random)."""
    rng = np.random.default_rng(2)
    wo = np.concatenate([rdirs(rng, 6, 0.05), [[0, 0, 1.0], [0.6, 0, 0.8]]])
    wi = np.concatenate([rdirs(rng, 6, 0.05), [[0, 0, 1.0], [-0.6, 0.0, 0.8]]])
    wi[:3] = near_lobe(rng, wo[:3], dict(nu=1e3, nv=1e3))
    fits = presets.load(source)
    assert len(fits) == 100
    tag = ":E1" if "E1" in source else ""
    for name, fit in fits.items():
        m = clbrdf.Model(NAME, preset=name + tag, precision="double")
        assert m.preset.source == source
        got = m.eval(wo, wi)
        ref = bbm_low_ashikhmin_shirley(fit, wi, wo)
        assert_close(got, ref, 1e-9, 1e-300, f"{name} ({source})")


VARIANCE_CASES = [("plastic", dict(nu=100.0, nv=20.0, rs=0.05, rd=0.7)),
                  ("sharp + rd", dict(nu=1e4, nv=1e4, rs=0.05, rd=0.7)),
                  ("sharp, specular only", dict(nu=1e4, nv=1e4, rs=0.05))]


def variance_table(mus=(1.0, 0.5, 0.1), n=1 << 20):
    """Relative variance per sample (stderr^2 N / E^2) of the cosine, brdf (mixture) and MIS
    estimators, single precision, phi = 0.3, seed 1."""
    rows = []
    for name, kw in VARIANCE_CASES:
        m = clbrdf.Model(NAME, **kw)
        for mu in mus:
            rv = []
            for est in ("cosine", "brdf", "mis"):
                r = clbrdf.albedo(m, mu, 0.3, estimator=est, samples=n, seed=1)
                rv.append(float(r.stderr) ** 2 * r.samples / float(r.albedo) ** 2)
            rows.append((name, mu, *rv))
    return rows


if __name__ == "__main__":
    import time
    t = time.time()
    for row in variance_table():
        print("relative variance %-22s mu %-4g cosine %.3g brdf %.3g mis %.3g" % row)
    print(f"Figure 2: E(mu=1; nu=nv=10, rs=1) = {albedo_normal_iso(10):.6f} (closed form), "
          f"quadrature {A.albedo(1.0, 0.0, 1e-11, nu=10.0, nv=10.0, rs=1.0)}")
    vmax, where, vmin, wmin, emax, count = energy_sweep(log=lambda m: print(m, flush=True))
    print(f"energy sweep ({count} quadratures): max {vmax:.9f} at (nu, nv, mu, phi) = {where}; "
          f"min {vmin:.6f} at {wmin}; max quadrature error {emax:.2g}; {time.time() - t:.0f} s")
