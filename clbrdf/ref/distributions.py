"""Double-precision reference for the GTR and SGD microfacet distributions and Bagher's SGD BRDF.

Written from Holzschuch & Pacanowski 2015 Table 1 (docs/models/microfacet.md), Bagher, Soler &
Holzschuch 2012, and, for the full SGD BRDF of the published fits, jdupuy/dj_brdf ``djb::sgd``;
independently of the OpenCL kernels (no tables, no series: SciPy quadrature and root finding).

Slope density ``P22(x)``, ``x = tan^2 theta_h``, normalised so that ``integral_0^inf P22 = 1/pi``;
``D(h) = P22(tan^2) / cos^4``.

- GTR, gamma != 1: ``c (1 + x)^(gamma - 2) / (pi (a^2 + x)^gamma)``,
  ``c = (gamma - 1)(1 - a^2) a^(2(gamma - 1)) / (1 - a^(2(gamma - 1)))``;
  gamma = 1: ``(1 - a^2) / (2 pi ln(1/a)) / ((1 + x)(a^2 + x))``.
- SGD: ``a^(p - 1) / (pi Gamma(1 - p, a)) exp(-(a^2 + x)/a) / (a^2 + x)^p`` (upper incomplete
  gamma; the shape 1 - p may be negative). With ``y = a + x/a``: ``D = kap e^-y / (pi y^p cos^4)``,
  ``kap = 1 / (a Gamma(1 - p, a))`` (dj_brdf's ``sgd__ndf`` with its tabulated ``kap``).

Smith ``Lambda`` by direct quadrature of the slope integral (polar slopes, azimuth done in closed
form): ``Lambda(t) = integral_{1/t^2}^inf (sqrt(x t^2 - 1) - acos(1/(t sqrt x))) P22(x) dx``,
``t = tan theta``; GTR gamma = 1 also in closed form (``lambda_gtr1``).
"""
from __future__ import annotations

import math

import numpy as np
from scipy import integrate, optimize, special

from . import microfacet as REF
from .quadrature import half_cos

INV_PI = 1 / np.pi


# ---------------------------------------------------------------------------------------------
# Special functions

def upper_gamma(s: float, x: float) -> float:
    """Gamma(s, x) = integral_x^inf t^(s-1) e^-t dt for any real s and x > 0 (quadrature in
    v = ln t: integral_{ln x}^inf exp(s v - e^v) dv, smooth and doubly-exponentially decaying)."""
    s, x = float(s), float(x)
    if s > 0 and x < 700:
        return float(special.gammaincc(s, x) * special.gamma(s))
    v0 = math.log(x)
    # the integrand peaks at v = ln(s) (s > 0) or at the lower limit; e^v > 800 is negligible
    hi = max(v0, math.log(800.0))
    f = lambda v: math.exp(s * v - math.exp(v))
    pts = [p for p in (math.log(max(s, 1e-300)), 0.0) if v0 < p < hi]
    val, _ = integrate.quad(f, v0, hi, points=pts or None, epsabs=0, epsrel=1e-13, limit=400)
    return val


def sgd_kap(alpha, p):
    """Normalisation kap = 1 / (alpha Gamma(1 - p, alpha)) of dj_brdf's SGD NDF."""
    return 1.0 / (alpha * upper_gamma(1.0 - p, alpha))


def gtr_c(a, gamma):
    """GTR normalisation c (Holzschuch & Pacanowski Table 1); gamma = 1: (1 - a^2)/(2 ln(1/a))."""
    a2 = a * a
    if gamma == 1:
        return (1 - a2) / (2 * math.log(1 / a))
    e = a2 ** (gamma - 1)
    return (gamma - 1) * (1 - a2) * e / (1 - e)


# ---------------------------------------------------------------------------------------------
# P22 and D

def p22(dist: str, x, alpha: float, shape: float):
    """Slope density P22(x), x = tan^2 theta (arrays); ``shape`` is GTR gamma or SGD p."""
    x = np.asarray(x, float)
    a = float(alpha)
    if dist == "gtr":
        c = gtr_c(a, shape)
        return c * (1 + x) ** (shape - 2) / (np.pi * (a * a + x) ** shape)
    if dist == "sgd":
        p = float(shape)
        y = a + x / a
        return np.exp(-y) / (np.pi * a * upper_gamma(1 - p, a) * y ** p)
    raise ValueError(f"unknown distribution {dist!r}")


def D(dist: str, h, alpha: float, shape: float):
    """Distribution of normals P22(tan^2) / cos^4 for unit h (..., 3); 0 for h.z <= 0."""
    h = np.asarray(h, float)
    z = h[..., 2]
    up = z > 0
    zs = np.where(up, z, 1.0)
    x = (h[..., 0] ** 2 + h[..., 1] ** 2) / zs ** 2
    return np.where(up, p22(dist, x, alpha, shape) / zs ** 4, 0.0)


# ---------------------------------------------------------------------------------------------
# Smith Lambda

def _k(tau):
    """tau - atan(tau), by its series below 0.05 (cancellation)."""
    tau = float(tau)
    if tau < 0.05:
        t2 = tau * tau
        return tau * t2 * (1 / 3 - t2 * (1 / 5 - t2 * (1 / 7 - t2 / 9)))
    return tau - math.atan(tau)


def lambda_quad(dist: str, tan_theta: float, alpha: float, shape: float, epsrel=1e-11):
    """Smith Lambda(theta) of the isotropic P22 by direct quadrature, in v = ln x:
    Lambda = integral_{-2 ln t}^inf k(t sqrt(x)) P22(x) x dv, k(r) = sqrt(r^2-1) - acos(1/r)
    (= tau - atan(tau), tau = sqrt(x t^2 - 1)). Returns 0 at t = 0, inf at t = inf."""
    t = float(tan_theta)
    if t <= 0:
        return 0.0
    if not math.isfinite(t):
        return math.inf
    a = float(alpha)
    if dist == "sgd":
        norm = 1.0 / (np.pi * a * upper_gamma(1 - shape, a))

        def P(x):
            y = a + x / a
            return norm * math.exp(-y - shape * math.log(y))
        scales = [math.log(a * a), math.log(a)]
        # exp(-x/a) < e^-745 beyond x = 745 a
        v_hi_abs = math.log(745 * a)
    else:
        c = gtr_c(a, shape)

        def P(x):
            return c * math.exp((shape - 2) * math.log1p(x) - shape * math.log(a * a + x)) / math.pi
        scales = [math.log(a * a), 0.0]
        v_hi_abs = None
    v0 = -2 * math.log(t)

    def f(v):
        x = math.exp(v)
        tau = math.sqrt(max(x * t * t - 1, 0.0))
        return _k(tau) * P(x) * x
    if v_hi_abs is not None:
        if v0 >= v_hi_abs:
            return 0.0
        v_hi = v_hi_abs
        tail = 0.0
    else:
        # GTR: P22 ~ c x^-2, the integrand ~ c t x^-1/2 / pi: integrate to x = X, then the tail
        # analytically with the first terms of k ~ t sqrt(x) - pi/2 + 1/(t sqrt x)
        v_hi = max(v0, max(scales)) + 60
        X = math.exp(v_hi)
        # tail: integral_X^inf (t sqrt x - pi/2) P22(x) dx with P22 = (c/pi) x^-2 (1 + O(1/x))
        tail = c / math.pi * (2 * t / math.sqrt(X) - math.pi / (2 * X))
    # split at the distribution's scales, but not within rounding of v0 (a piece 1e-15 long
    # gave quad's "extremely bad integrand" warning at t = 10, alpha = 0.01: ln(a) = -2 ln t)
    pts = sorted(s for s in scales if v0 + 1e-9 < s < v_hi - 1e-9)
    parts = [v0] + pts + [v_hi]
    val = 0.0
    for lo, hi in zip(parts[:-1], parts[1:]):
        r, _ = integrate.quad(f, lo, hi, epsabs=0, epsrel=epsrel, limit=400)
        val += r
    return val + tail


def lambda_gtr1(tan_theta, alpha):
    """Closed form of Lambda for GTR gamma = 1 (derived here; see docs/models/distributions.md):
    [asinh(mu/a) - asinh(mu) - ln(1/a) - sqrt(1 + a^2 t^2) + sqrt(1 + t^2)] / (2 ln(1/a)),
    mu = 1/t."""
    t = np.asarray(tan_theta, float)
    a = float(alpha)
    with np.errstate(divide="ignore", invalid="ignore"):    # t = 0: inf - inf, replaced by 0
        mu = 1 / t
        num = (np.arcsinh(mu / a) - np.arcsinh(mu) - math.log(1 / a)
               - np.sqrt(1 + a * a * t * t) + np.sqrt(1 + t * t))
    return np.where(t > 0, num / (2 * math.log(1 / a)), 0.0)


def Lambda(dist: str, w, alpha: float, shape: float):
    """Smith Lambda of unit directions w (..., 3); inf for w.z <= 0."""
    w = np.asarray(w, float)
    z = w[..., 2]
    s = np.hypot(w[..., 0], w[..., 1])
    out = np.empty(z.shape)
    flat_z, flat_s, flat_o = z.reshape(-1), s.reshape(-1), out.reshape(-1)
    for i in range(flat_z.size):
        if flat_z[i] <= 0:
            flat_o[i] = np.inf
        else:
            flat_o[i] = lambda_quad(dist, flat_s[i] / flat_z[i], alpha, shape)
    return out


# ---------------------------------------------------------------------------------------------
# Sampling the distribution of normals: cos^2 theta_h from u (inverse CDF in x = tan^2)

def sample_tan2(dist: str, u, alpha: float, shape: float):
    """x = tan^2 theta_h with P(X <= x) = u under the density pi P22(x) (Table 1 integrals).

    GTR: w = (a^2 + x)/(1 + x) has w^(1-gamma) uniform between a^(2(1-gamma)) and 1 (gamma = 1:
    ln w uniform between ln a^2 and 0). SGD: y = a + x/a has density y^-p e^-y on [a, inf); the
    upper tail integral_y^inf is Gamma(1 - p, y), so Gamma(1-p, y) = (1 - u) Gamma(1-p, a), solved
    by Brent's method on the (quadrature) upper_gamma."""
    u = np.atleast_1d(np.asarray(u, float))
    a = float(alpha)
    if dist == "gtr":
        a2 = a * a
        if shape == 1:
            w = a2 ** (1 - u)
        else:
            g = 1 - shape
            w = (a2 ** g * (1 - u) + u) ** (1 / g)
        return (w - a2) / (1 - w)
    if dist == "sgd":
        s = 1 - shape
        qa = upper_gamma(s, a)
        out = np.empty(u.shape)
        for i, ui in enumerate(u):
            target = (1 - ui) * qa
            if target >= qa:
                out[i] = 0.0
                continue
            f = lambda ly: math.log(upper_gamma(s, math.exp(ly))) - math.log(target)
            lo, hi = math.log(a), math.log(a) + 1
            while f(hi) > 0:
                hi += 2
            y = math.exp(optimize.brentq(f, lo, hi, xtol=1e-15, rtol=1e-14))
            out[i] = a * (y - a)
        return out
    raise ValueError(f"unknown distribution {dist!r}")


def cdf_tan2(dist: str, x, alpha: float, shape: float):
    """P(X <= x) = pi integral_0^x P22 by quadrature (for tests of sample_tan2 and the kernel)."""
    return float(np.pi * integrate.quad(lambda t: float(p22(dist, t, alpha, shape)), 0, float(x),
                                        epsabs=0, epsrel=1e-12, limit=400)[0])


# ---------------------------------------------------------------------------------------------
# Bagher et al. 2012 SGD BRDF as in dj_brdf djb::sgd (all parameters per channel)

def bagher_g1(w, theta0, c, k, lam):
    """dj_brdf sgd__g1: clamp(1 + lambda (1 - exp(c max(0, theta - theta0)^k)), 0, 1), with
    1 - exp(e) as -expm1(e): 1 - exp(e) lost 3e-7 of G1 at lam = 1e9 (e about 1e-10)."""
    w = np.asarray(w, float)
    th = np.arccos(np.clip(w[..., 2], -1, 1))
    d = np.maximum(0.0, th - theta0)
    with np.errstate(over="ignore", invalid="ignore"):
        e = c * d ** k
        g = 1 - lam * np.expm1(e)
    g = np.where(np.isnan(g), 0.0, g)      # lam (1 - inf) with lam = 0 cannot occur in the fits
    return np.clip(g, 0.0, 1.0)


def bagher_fresnel(cos_d, f0, f1):
    """dj_brdf fresnel::sgd, f0 - c f1 + (1 - c)^5 (1 - f0), and not below 0 (ours: 3 of the
    published fits go below 0 near c = 1)."""
    c = np.asarray(cos_d, float)
    return np.maximum(f0 - c * f1 + (1 - c) ** 5 * (1 - f0), 0.0)


def bagher_ndf(h, alpha, p, kap):
    """dj_brdf sgd__ndf: kap exp(-y) / (pi y^p cos^4), y = alpha + tan^2 / alpha."""
    h = np.asarray(h, float)
    c2 = h[..., 2] ** 2
    t2 = (1 - c2) / c2
    y = alpha + t2 / alpha
    return kap * np.exp(-y) / (np.pi * y ** p * c2 * c2)


def bagher_eval(wo, wi, rho_d, rho_s, alpha, p, f0, f1, lam, c, k, theta0, kap=None):
    """One channel of dj_brdf djb::sgd::eval:
    (rhoD + rhoS F D G1(wi) G1(wo) / (cos_i cos_o)) / pi; 0 below the horizon."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    if kap is None:                      # the kernel's default: the normalised NDF
        kap = sgd_kap(alpha, p)
    ok = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    F = bagher_fresnel(np.clip(np.sum(wi * h, -1), 0, 1), f0, f1)
    G = bagher_g1(wi, theta0, c, k, lam) * bagher_g1(wo, theta0, c, k, lam)
    Dv = bagher_ndf(h, alpha, p, kap)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = (rho_d + rho_s * F * Dv * G / (wi[..., 2] * wo[..., 2])) / np.pi
    return np.where(ok, f, 0.0)


# ---------------------------------------------------------------------------------------------
# Models: eval, pdf, albedo (float64; directions (..., 3), one set of scalar parameters)

def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _shape_name(model):
    return {"gtr": "gamma", "sgd": "p"}[model]


def _lambda_fn(model, alpha, shape):
    """Lambda of directions by quadrature (GTR gamma = 1: the closed form)."""
    def lam(w):
        if model == "gtr" and shape == 1:
            w = np.asarray(w, float)
            z = w[..., 2]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.hypot(w[..., 0], w[..., 1]) / z
            return np.where(z > 0, lambda_gtr1(t, alpha), np.inf)
        return Lambda(model, w, alpha, shape)
    return lam


def eval(model, wo, wi, *, alpha, masking="correlated", **params):
    """f(wo, wi) of ``gtr`` (gamma=...) or ``sgd`` (p=...): D G / (4 cos_i cos_o), F = 1;
    masking none, separable or correlated (Smith, Lambda by quadrature); ``sgd_bagher``: see
    bagher_eval (every parameter a scalar: one channel)."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    if model == "sgd_bagher":
        return bagher_eval(wo, wi, alpha=alpha, **params)
    shape = float(params.pop(_shape_name(model)))
    if params:
        raise TypeError(f"unused parameters {sorted(params)}")
    ok = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    h = _unit(wi + wo)
    f = D(model, h, alpha, shape)
    if masking != "none":
        lam = _lambda_fn(model, alpha, shape)
        li, lo = lam(wi), lam(wo)
        f = f * (1 / (1 + li + lo) if masking == "correlated" else 1 / ((1 + li) * (1 + lo)))
    with np.errstate(divide="ignore", invalid="ignore"):
        f = f / (4 * wi[..., 2] * wo[..., 2])
    return np.where(ok, f, 0.0)


def bagher_weights(wo, rho_d, rho_s, alpha, p, kap, f0, f1):
    """Lobe weights of the sgd_bagher sampling mixture (per channel): cosine rho_d; SGD normals
    (4/pi) rho_s kap alpha Gamma(1-p, alpha) F(cos_o) (F not below 0: bagher_fresnel)."""
    co = np.clip(np.asarray(wo, float)[..., 2], 0, 1)
    inv_kap = alpha * upper_gamma(1 - p, alpha)
    ws = 4 / np.pi * rho_s * kap * inv_kap * bagher_fresnel(co, f0, f1)
    return rho_d, ws


def pdf(model, wo, wi, *, alpha, **params):
    """Solid-angle density of the samplers: gtr/sgd D(h) h.z / (4 wo.h); sgd_bagher (lists of
    per-channel parameters) the mixture sum_c [wd_c cos/pi + ws_c D_c(h) h.z/(4 wo.h)] / sum."""
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    ok = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    h = _unit(wi + wo)
    geo = h[..., 2] / (4 * half_cos(wo, wi))
    if model == "sgd_bagher":
        alpha = np.atleast_1d(np.asarray(alpha, float))
        params = dict(params)
        if "kap" not in params:          # the kernel's default: the normalised NDF
            params["kap"] = [sgd_kap(a, p) for a, p in
                             zip(alpha, np.broadcast_to(np.atleast_1d(params["p"]), alpha.shape))]
        ch = {k: np.broadcast_to(np.atleast_1d(np.asarray(params[k], float)), alpha.shape)
              for k in ("rho_d", "rho_s", "p", "kap", "f0", "f1")}
        num, tot = 0.0, 0.0
        cos_pdf = np.maximum(wi[..., 2], 0) / np.pi
        for c in range(alpha.size):
            wd, ws = bagher_weights(wo, ch["rho_d"][c], ch["rho_s"][c], alpha[c], ch["p"][c],
                                    ch["kap"][c], ch["f0"][c], ch["f1"][c])
            num = num + wd * cos_pdf + ws * D("sgd", h, alpha[c], ch["p"][c]) * geo
            tot = tot + wd + ws
        return np.where(ok, num / tot, 0.0)
    shape = float(params.pop(_shape_name(model)))
    return np.where(ok, D(model, h, alpha, shape) * geo, 0.0)


def albedo(model, mu, phi=0.0, tol=1e-8, **params):
    """E(wo) = integral f cos_i dw_i by clbrdf.ref.quadrature.hemisphere_integral, (value, err).
    gtr/sgd with masking="none" (the default here: Lambda by quadrature at every node would be
    slow) or a Smith masking; the half-vector map of GGX (GTR: same tails x^-2) or of Beckmann with
    a^2 = alpha (SGD: same tail e^-x/alpha). sgd_bagher (scalar parameters): specular term over
    that map, rho_d / pi over the cosine map."""
    wo = REF.direction(float(mu), float(phi))
    params = dict(params)
    alpha = float(params.pop("alpha"))
    if model == "gtr":
        hv = REF.halfvector_map("ggx", wo, alpha, alpha)
    else:
        hv = REF.halfvector_map("beckmann", wo, math.sqrt(alpha), math.sqrt(alpha))
    if model == "sgd_bagher":
        rho_d = float(params["rho_d"])
        spec = dict(params, rho_d=0.0)
        v1, e1 = REF.hemisphere_integral(
            lambda wi: bagher_eval(wo, wi, alpha=alpha, **spec) * wi[..., 2], [hv], tol / 2)
        v2, e2 = REF.hemisphere_integral(lambda wi: rho_d / np.pi * wi[..., 2],
                                         [REF.cosine_map()], tol / 2)
        return v1 + v2, e1 + e2
    params.setdefault("masking", "none")
    return REF.hemisphere_integral(
        lambda wi: eval(model, wo, wi, alpha=alpha, **params) * wi[..., 2], [hv], tol)


# ---------------------------------------------------------------------------------------------
# The registered references (clbrdf.ref.Reference)

from . import microfacet as _mf


class TabulatedReference(_mf.MicrofacetReference):
    """gtr and sgd: the microfacet reference with D of this module and Lambda by quadrature (GTR
    gamma = 1 in closed form); quadrature map: GGX's (GTR, same x^-2 tails) or Beckmann's with
    a^2 = alpha (SGD, same e^-x/alpha tail)."""
    def rough(self):
        return float(self.params["alpha"]), float(self.params["alpha"])

    def shape(self):
        return float(self.params[_shape_name(self.name)])

    def D(self, h):
        return D(self.name, h, float(self.params["alpha"]), self.shape())

    _spline = None

    def Lambda(self, w):
        if self._spline is None:
            return _lambda_fn(self.name, float(self.params["alpha"]), self.shape())(w)
        w = np.asarray(w, float)
        z = w[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.log(np.hypot(w[..., 0], w[..., 1]) / z)
        lo, hi = self._spline.x[0], self._spline.x[-1]
        # beyond hi (cos theta < 1e-15) Lambda grows like tan theta
        lam = np.exp(self._spline(np.clip(u, lo, hi)) + np.maximum(u - hi, 0)) - 1e-300
        return np.where(z > 0, np.where(u < lo, 0.0, lam), np.inf)

    def albedo1(self, mu, phi, tol, v, c):
        """As the microfacet reference's, with Lambda from a cubic spline of log Lambda over
        log tan theta in [-12, 36] (961 nodes of ``lambda_quad``; relative error about 1e-8):
        Lambda by quadrature at every node of the 2-D rule would take minutes."""
        from scipy.interpolate import CubicSpline
        if self.options["masking"] in ("separable", "correlated") and self._spline is None:
            u = np.linspace(-12, 36, 961)
            lam = _lambda_fn(self.name, float(self.params["alpha"]), self.shape())
            t = np.exp(u)
            vals = lam(np.stack([t, 0 * u, np.ones_like(u)], -1) / np.sqrt(1 + t * t)[:, None])
            self._spline = CubicSpline(u, np.log(vals + 1e-300))
        try:
            return super().albedo1(mu, phi, tol, v, c)
        finally:
            self._spline = None

    def hv_map(self, wo):
        a = float(self.params["alpha"])
        if self.name == "gtr":
            return _mf.halfvector_map("ggx", wo, a, a)
        return _mf.halfvector_map("beckmann", wo, math.sqrt(a), math.sqrt(a))


class BagherReference(_mf.Reference):
    """sgd_bagher: ``bagher_eval`` per channel; the sampler's channel and lobe mixture (``pdf``)."""
    def _kw(self, v):
        return {k: float(x) for k, x in v.items()}

    def eval1(self, wo, wi, v, c):
        return bagher_eval(wo, wi, **self._kw(v))

    def pdf(self, wo, wi):
        chans = self.channel_values()
        kw = {k: [float(v[k]) for v in chans] for k in chans[0]}
        alpha = kw.pop("alpha")
        for k in ("lam", "c", "k", "theta0"):
            kw.pop(k)
        return pdf("sgd_bagher", wo, wi, alpha=alpha, **kw)

    def albedo1(self, mu, phi, tol, v, c):
        kw = self._kw(v)
        return albedo("sgd_bagher", mu, phi, tol, **kw)


REFERENCES = {"gtr": TabulatedReference, "sgd": TabulatedReference, "sgd_bagher": BagherReference}
