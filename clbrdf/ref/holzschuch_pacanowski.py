"""Double-precision reference for the exponential-power distribution and the Holzschuch &
Pacanowski 2015 BRDF (docs/models/holzschuch_pacanowski.md, docs/models/microfacet.md). Written from the paper, independently of the kernels (no G1 table: Lambda by
adaptive quadrature, SciPy's incomplete gamma functions).

Exponential power (eq 18-19): ``P22(x) = beta exp(-(x/sigma^2)^p)``,
``beta = p / (pi sigma^2 Gamma(1/p))``, ``D(h) = P22(tan^2 theta_h) / cos^4 theta_h``.

Smith Lambda (eq 20-21) depends on ``nu = sigma tan theta`` and ``p``. With the azimuth of the
slope done in closed form and ``y = (slope / sigma)^(2p)`` (a Gamma(1/p, 1) variable):

    Lambda(nu) = (1/pi) integral_{y0}^inf y^(a-1) e^-y / Gamma(a) K(nu^2 y^a) dy,
    a = 1/p, y0 = nu^(-2p), K(z) = sqrt(z - 1) - arctan(sqrt(z - 1)),

(``lambda_quad``; checked against the literal double integral of eq 20-21 and against Beckmann's
closed form at p = 1 in tests/models/test_holzschuch_pacanowski.py). For large nu,
``Lambda -> nu m / pi - 1/2`` with ``m = E[slope / sigma] = Gamma(3/(2p)) / Gamma(1/p)``.

Full model (eq 24-27), per channel with wavelength lambda (um):

    f = kd/pi + G(wi, wo) (ks D(theta_h) F(theta_d) / (4 cos_i cos_o) + kw / lambda^4 S(f_s) / E)
    S(f_s) = 1 / (1 + f_s^2 / a^2)^2,  f_s = |Dp| / lambda = 2 sin theta_h cos theta_d / lambda,
    G = G1(wi) G1(wo), F = Schlick(f0, wi.h),
    E = E_a_lambda = pi a^2 lambda^2 / (1 + a^2 lambda^2) (``diffraction_energy``; the paper
    prints pi (1 + 1/(a^2 lambda^2)), see docs/models/holzschuch_pacanowski.md).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy import integrate, special
from scipy.interpolate import CubicSpline

from .quadrature import (
    INV_PI,
    cosine_map,
    dot,
    half_cos,
    hemisphere_integral,
    normalize,
    reflect,
)

WAVELENGTHS = (0.645, 0.526, 0.444)     # um, R G B (paper section 5.5)


# ---------------------------------------------------------------------------------------------
# Exponential-power distribution

def beta(sigma, p):
    """eq 19: p / (pi sigma^2 Gamma(1/p))."""
    return p / (np.pi * sigma ** 2 * special.gamma(1 / p))


def p22(x, sigma, p):
    """eq 18: beta exp(-(x / sigma^2)^p), x = tan^2 theta."""
    return beta(sigma, p) * np.exp(-(np.asarray(x, float) / sigma ** 2) ** p)


def D(h, sigma, p):
    """eq 26 (2): P22(tan^2 theta_h) / cos^4 theta_h; 0 for h.z <= 0."""
    h = normalize(np.asarray(h, float))
    z = h[..., 2]
    up = z > 0
    zs = np.where(up, z, 1.0)
    x = (h[..., 0] ** 2 + h[..., 1] ** 2) / zs ** 2
    with np.errstate(over="ignore"):
        d = p22(x, sigma, p) / zs ** 4
    return np.where(up, np.nan_to_num(d, nan=0.0, posinf=0.0), 0.0)


def _K(z):
    """sqrt(z - 1) - arctan(sqrt(z - 1)), by its series where the two cancel."""
    s = np.sqrt(np.maximum(z - 1, 0.0))
    s2 = s * s
    series = s * s2 * (1 / 3 - s2 * (1 / 5 - s2 * (1 / 7 - s2 * (1 / 9 - s2 / 11))))
    return np.where(s < 0.05, series, s - np.arctan(s))


def lambda_quad(nu: float, p: float, epsrel: float = 1e-13) -> float:
    """Smith Lambda of the unit exponential-power distribution at nu = sigma tan theta, by
    adaptive quadrature (see the module docstring) in s = log y = s0 + w^2, where the integrand
    is smooth (K ~ (y - y0)^(3/2) at the lower end). Upper end: y = max(a, 1) + 80 + 15 sqrt(a),
    beyond which the Gamma density is below e^-80 of its bulk."""
    if nu <= 0:
        return 0.0
    a = 1 / p
    s0 = -2 * p * math.log(nu)
    smax = math.log(max(a, 1) + 80 + 15 * math.sqrt(a))
    if s0 >= smax:
        return 0.0
    lg = special.gammaln(a)
    l2nu = 2 * math.log(nu)

    def f(w):
        s = s0 + w * w
        return 2 * w * math.exp(a * s - math.exp(s) - lg) * float(_K(math.exp(l2nu + a * s)))
    v, _ = integrate.quad(f, 0, math.sqrt(smax - s0), epsabs=0, epsrel=epsrel, limit=400)
    return v / math.pi


def lambda_direct(nu: float, p: float) -> float:
    """eq 20-21 as printed, with sigma = 1: P2(r) = p/(pi Gamma(1/p)) int exp(-(r^2+q^2)^p) dq,
    Lambda = int_{1/nu}^inf (r nu - 1) P2(r) dr (nested quadrature; slow, for tests)."""
    c = p / (np.pi * special.gamma(1 / p))

    def P2(r):
        return 2 * c * integrate.quad(lambda q: math.exp(-(r * r + q * q) ** p), 0, np.inf,
                                      epsabs=0, epsrel=1e-12, limit=200)[0]
    return integrate.quad(lambda r: (r * nu - 1) * P2(r), 1 / nu, np.inf, epsabs=0,
                          epsrel=1e-11, limit=200)[0]


def slope_mean(p):
    """m = E[|slope| / sigma] = Gamma(3/(2p)) / Gamma(1/p)."""
    return np.exp(special.gammaln(1.5 / p) - special.gammaln(1 / p))


@lru_cache(maxsize=64)
def _lambda_spline(p: float):
    """log1p(Lambda) as a cubic spline in log(nu m) on [1e-5, 1e5] (1201 quadrature nodes);
    Lambda = 0 below, nu m / pi - 1/2 above (relative error < 1e-9 there)."""
    m = float(slope_mean(p))
    lv = np.linspace(math.log(1e-5), math.log(1e5), 1201)
    ell = np.array([math.log1p(lambda_quad(math.exp(v) / m, p)) for v in lv])
    return CubicSpline(lv, ell), lv[0], lv[-1], m


def Lambda(w, sigma, p):
    """Smith Lambda of direction w (spline of lambda_quad, see _lambda_spline); inf for w.z <= 0."""
    w = normalize(np.asarray(w, float))
    z = w[..., 2]
    up = z > 0
    zs = np.where(up, z, 1.0)
    tan = np.hypot(w[..., 0], w[..., 1]) / zs
    spl, lo, hi, m = _lambda_spline(float(p))
    with np.errstate(divide="ignore"):
        lv = np.log(sigma * tan * m)
    mid = np.exp(spl(np.clip(lv, lo, hi))) - 1
    big = sigma * tan * m / np.pi - 0.5
    lam = np.where(lv < lo, 0.0, np.where(lv > hi, big, mid))
    return np.where(up, np.maximum(lam, 0.0), np.inf)


def G1(w, sigma, p):
    return 1 / (1 + Lambda(w, sigma, p))


# ---------------------------------------------------------------------------------------------
# Full model

def diffraction_energy(a, lam):
    """E_a_lambda that makes the diffraction lobe S/E integrate to at most 1 (cos-weighted, at
    normal incidence, G = 1): pi a^2 lambda^2 / (1 + a^2 lambda^2)."""
    x = (a * lam) ** 2
    return np.pi * x / (1 + x)


def diffraction_energy_paper(a, lam):
    """E_a_lambda as printed: pi (1 + 1/(a^2 lambda^2))."""
    return np.pi * (1 + 1 / (a * lam) ** 2)


def _channel(v, c):
    v = np.asarray(v, float)
    return v[..., c] if v.ndim and v.shape[-1] == 3 else v


def eval(wo, wi, *, kd=0.0, ks=1.0, f0=1.0, kw=0.0, a=1.0, sigma=0.1, p=1.0, channels=1,
         lam=None, energy="conserving"):
    """BRDF (1/sr), shape (...) for channels=1 (wavelength lam, default the green 0.526 um) or
    (..., 3) for channels=3 (R, G, B wavelengths; kd, ks, f0, kw per channel)."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    ci, co = wi[..., 2], wo[..., 2]
    valid = (ci > 0) & (co > 0)
    h = normalize(wi + wo)
    cd = dot(wi, h)
    Dh = D(h, sigma, p)
    G = G1(wi, sigma, p) * G1(wo, sigma, p)
    dp = np.hypot(wi[..., 0] + wo[..., 0], wi[..., 1] + wo[..., 1])      # |Dp| = 2 sin th cos td
    Efn = diffraction_energy if energy == "conserving" else diffraction_energy_paper
    out = []
    lams = (WAVELENGTHS[1] if lam is None else lam,) if channels == 1 else WAVELENGTHS
    for c, L in enumerate(lams):
        kd_c, ks_c, f0_c, kw_c = (_channel(v, c) if channels == 3 else np.asarray(v, float)
                                  for v in (kd, ks, f0, kw))
        F = f0_c + (1 - f0_c) * (1 - cd) ** 5
        with np.errstate(divide="ignore", invalid="ignore"):
            spec = ks_c * Dh * F / (4 * ci * co)
        S = 1 / (1 + (dp / L / a) ** 2) ** 2
        diff = kw_c / L ** 4 * S / Efn(a, L)
        f = kd_c * INV_PI + G * (spec + diff)
        out.append(np.where(valid, f, 0.0))
    return out[0] if channels == 1 else np.stack(out, -1)


def lobe_weights(kd=0.0, ks=1.0, kw=0.0, a=1.0, channels=1, lam=None, energy="conserving"):
    """Selection probabilities of the (reflection, diffraction, diffuse) lobes: proportional to
    each lobe's largest albedo summed over channels (paper section 5.5, "overall energy"):
    ks, kw / lambda^4 times the diffraction lobe's albedo at normal incidence (1 with the
    conserving E, (c/(1+c))^2 with the paper's, c = a^2 lambda^2), kd."""
    lams = (WAVELENGTHS[1] if lam is None else lam,) if channels == 1 else WAVELENGTHS
    ks_, kw_, kd_ = (np.broadcast_to(np.asarray(v, float), (len(lams),)) for v in (ks, kw, kd))
    w = 0.0
    for c, L in enumerate(lams):
        x = (a * L) ** 2
        alb = 1.0 if energy == "conserving" else (x / (1 + x)) ** 2
        w += kw_[c] / L ** 4 * alb
    s, d = float(ks_.sum()), float(kd_.sum())
    t = s + w + d
    if t <= 0:
        return 1.0, 0.0, 0.0
    return s / t, w / t, d / t


def pdf(wo, wi, *, kd=0.0, ks=1.0, kw=0.0, a=1.0, sigma=0.1, p=1.0, channels=1, lam=None,
        energy="conserving", **_):
    """Mixture density of the sampler: P_s D(h) cos theta_h / (4 wo.h) + (P_w + P_d) cos_i / pi."""
    wo, wi = np.asarray(wo, float), np.asarray(wi, float)
    valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    Ps, Pw, Pd = lobe_weights(kd, ks, kw, a, channels, lam, energy)
    h = normalize(wi + wo)
    with np.errstate(divide="ignore", invalid="ignore"):
        ph = D(h, sigma, p) * h[..., 2] / (4 * half_cos(wo, wi))
    ph = np.nan_to_num(ph, nan=0.0, posinf=0.0)
    return np.where(valid, Ps * ph + (Pw + Pd) * wi[..., 2] * INV_PI, 0.0)


def sample_tan2(u, sigma, p):
    """eq 22-23: tan^2 theta_h = sigma^2 y^(1/p), y = gammainccinv(1/p, u) (Gamma(1/p, 1))."""
    return sigma ** 2 * special.gammainccinv(1 / p, u) ** (1 / p)


# ---------------------------------------------------------------------------------------------
# Albedo

def halfvector_map(wo, sigma, p):
    """Half vectors from the exponential-power CDF in y = (tan^2 / sigma^2)^p (s = Q(1/p, y),
    restricted to wi above the horizon), phi_h = 2 pi t; reflected about h. Density of wi:
    D(h) cos_h / (4 wo.h)."""
    wo = np.asarray(wo, float)
    so, co = np.hypot(wo[0], wo[1]), wo[2]
    phi_o = math.atan2(wo[1], wo[0])
    a = 1 / p

    def points(s, t):
        phi = 2 * np.pi * t
        delta = np.arctan2(so * np.cos(phi - phi_o), co)
        tan2_max = np.tan((np.pi / 2 + delta) / 2) ** 2
        y_max = (tan2_max / sigma ** 2) ** p
        q_max = special.gammaincc(a, y_max)              # Q at the horizon
        q = 1 - s * (1 - q_max)                          # Q(a, y) in [q_max, 1]
        y = special.gammainccinv(a, q)
        tan2 = sigma ** 2 * y ** a
        cos_t = 1 / np.sqrt(1 + tan2)
        sin_t = np.sqrt(tan2) * cos_t
        h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)
        return reflect(wo, h), 1 - q_max

    def density(wi):
        h = normalize(wi + wo)
        with np.errstate(divide="ignore", invalid="ignore"):
            pr = D(h, sigma, p) * h[..., 2] / (4 * dot(wo, h))
        return np.where(wi[..., 2] > 0, np.nan_to_num(pr, nan=0.0, posinf=0.0), 0.0)
    return points, density


def albedo(mu, phi=0.0, tol=1e-8, **params):
    """E(wo) per channel: (value, err), arrays of shape () or (3,). The reflection lobe over the
    half-vector map, the diffraction and diffuse lobes over the cosine map (each term with the
    map that follows it)."""
    channels = params.get("channels", 1)
    s = math.sqrt(1 - mu * mu)
    wo = np.array([s * math.cos(phi), s * math.sin(phi), mu])
    sigma, p = params.get("sigma", 0.1), params.get("p", 1.0)
    hv = [halfvector_map(wo, sigma, p)]
    cm = [cosine_map()]
    zero = dict(kd=0.0, kw=0.0)

    def term(which, maps, tol_t):
        if which == "spec":
            kw_ = {**params, **zero}
        elif which == "diff":
            kw_ = {**params, "kd": 0.0, "ks": 0.0}
        else:
            kw_ = {**params, "ks": 0.0, "kw": 0.0}
        vals, errs = [], []
        for c in range(channels):
            def g(wi, c=c):
                f = eval(wo, wi, **kw_)
                return (f[..., c] if channels == 3 else f) * wi[..., 2]
            v, e = hemisphere_integral(g, maps, tol_t)
            vals.append(v)
            errs.append(e)
        return np.array(vals), np.array(errs)
    v1, e1 = term("spec", hv, tol / 3)
    v2, e2 = term("diff", cm, tol / 3)
    v3, e3 = term("kd", cm, tol / 3)
    v, e = v1 + v2 + v3, e1 + e2 + e3
    return (v[0], e[0]) if channels == 1 else (v, e)


# ---------------------------------------------------------------------------------------------
# The registered references (clbrdf.ref.Reference)

from . import Reference, microfacet as _mf

_BANDS = {"red": WAVELENGTHS[0], "green": WAVELENGTHS[1], "blue": WAVELENGTHS[2]}


class HPReference(Reference):
    """The model of this module; a one-channel model at the wavelength of ``band``."""
    def _kw(self):
        kw = {k: v for k, v in self.params.items()}
        kw.update(channels=self.channels, energy=self.options["diffraction_norm"])
        if self.channels == 1:
            kw["lam"] = _BANDS[self.options["band"]]
        return kw

    def eval(self, wo, wi):
        return eval(np.asarray(wo, float), np.asarray(wi, float), **self._kw())

    def pdf(self, wo, wi):
        return pdf(np.asarray(wo, float), np.asarray(wi, float), **self._kw())

    def albedo(self, mu, phi=0.0, tol=1e-8):
        return albedo(float(mu), float(phi), tol, **self._kw())


class ExpPowReference(_mf.MicrofacetReference):
    """exppow: the microfacet reference with this module's D (sigma = alpha) and Lambda."""
    def D(self, h):
        return D(h, float(self.params["alpha"]), float(self.params["p"]))

    def Lambda(self, w):
        return Lambda(w, float(self.params["alpha"]), float(self.params["p"]))

    def hv_map(self, wo):
        return halfvector_map(wo, float(self.params["alpha"]), float(self.params["p"]))


REFERENCES = {"holzschuch_pacanowski": HPReference, "exppow": ExpPowReference}
