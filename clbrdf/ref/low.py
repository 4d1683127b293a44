"""Double-precision NumPy reference for the Löw et al. 2012 models (``low_smooth``,
``low_microfacet``), written from the paper (eq 11-28, 34) and docs/models/low.md, independently
of the kernels: the Fresnel factor from Snell's law and the s/p amplitudes (not the Cook-Torrance
g form), the samplers in the paper's printed forms (pow/exp/log, with the C = 1 case of eq 24-25
taken exactly where C == 1), and quadrature maps that follow each lobe.

Directions: arrays (..., 3), local frame (normal z); wi towards the light, wo towards the viewer.
Parameters are scalars (one channel) and broadcast with the directions.

    eval(wo, wi, model="low_smooth", **params)     BRDF (1/sr)
    pdf(wo, wi, model="low_smooth", **params)      solid-angle density of the kernels' sampler
    albedo(mu, phi=0.0, tol=1e-8, model=..., **params) -> (E, err)

Maps (``DiskMap`` for the smooth model, ``HalfMap`` for the microfacet model) send (s, t) in
[0, 1]^2 onto the upper hemisphere, graded by asinh around the lobe centre, with the horizon a
boundary of the domain; they give ``points(s, t) -> (wi, dw/dsdt)`` and the inverse ``coords``.
"""
from __future__ import annotations

import numpy as np

from . import quadrature as R

INV_PI = 1 / np.pi
SMOOTH_DEFAULTS = dict(a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0, a2=0.0, b2=10.0, c2=1.0)
MICROFACET_DEFAULTS = dict(a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0)


def _v(w):
    return np.asarray(w, float)


def fresnel(eta, c):
    """Unpolarised reflectance of a dielectric interface (relative index eta) at cos(incidence)
    c, from Snell's law: (|r_s|^2 + |r_p|^2)/2; 1 under total internal reflection."""
    eta = np.asarray(eta, float)
    c = np.clip(np.asarray(c, float), 0.0, 1.0)
    s2t = (1 - c * c) / (eta * eta)
    tir = s2t >= 1
    ct = np.sqrt(np.maximum(1 - s2t, 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = (c - eta * ct) / (c + eta * ct)
        rp = (eta * c - ct) / (eta * c + ct)
    return np.where(tir, 1.0, 0.5 * (rs * rs + rp * rp))


def abc(a, b, c, f2):
    """S(f) = A / (1 + B f^2)^C (eq 11), argument f^2."""
    return a * (1 + b * f2) ** (-c)


# ---------------------------------------------------------------------------------------------
# Smooth-surface model (eq 12-14, 34)

def smooth_eval(wo, wi, a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0, a2=0.0, b2=10.0, c2=1.0):
    wi, wo = _v(wi), _v(wo)
    Lp, Vp = wi[..., :2], wo[..., :2]
    dp2 = np.sum((Lp + Vp) ** 2, -1)                        # |Dp|^2 (eq 10)
    sin_d = np.linalg.norm(Lp - Vp, axis=-1) / 2            # eq 13
    cos_d = np.sqrt(np.maximum(1 - sin_d ** 2, 0))          # eq 14
    f = kd * INV_PI + fresnel(eta, cos_d) * abc(a, b, c, dp2) + abc(a2, b2, c2, dp2)
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), f, 0.0)


def disk_norm_log(b, wo):
    """ln term of eq 19: pi A M_d = B / ln(...)."""
    wo = _v(wo)
    ro2 = wo[..., 0] ** 2 + wo[..., 1] ** 2
    Q = 1 + 2 * b * (1 + ro2) + b ** 2 * (1 - ro2) ** 2
    return -np.log(2) + np.log(1 + b * (1 - ro2) + np.sqrt(Q))


def disk_pdf(b, wo, wi):
    """Solid-angle density of the eq 17-22 sampler (C = 1 lobe of sharpness b)."""
    wi, wo = _v(wi), _v(wo)
    Md = b / (np.pi * disk_norm_log(b, wo))                 # M_d A (eq 19)
    dp2 = np.sum((wi[..., :2] + wo[..., :2]) ** 2, -1)
    return np.where(wi[..., 2] > 0, Md / (1 + b * dp2) * wi[..., 2], 0.0)   # eq 17-18


def disk_sample(b, wo, u0, u1):
    """eq 20-22 as printed: E = exp(xi1 B / (pi A M_d) + ln 2), r_i, phi_i."""
    wo = _v(wo)
    ro2 = wo[..., 0] ** 2 + wo[..., 1] ** 2
    ro = np.sqrt(ro2)
    E = np.exp(u0 * disk_norm_log(b, wo) + np.log(2))       # eq 22
    ri = np.sqrt(np.minimum((E - 2) * (E + 2 * b * ro2) / (2 * b * E), 1.0))   # eq 20
    k = np.sqrt((1 + b * (ri + ro) ** 2) / (1 + b * (ri - ro) ** 2))
    phi_i = 2 * np.arctan(np.tan(u1 * np.pi) * k) + np.arctan2(wo[..., 1], wo[..., 0])  # eq 21
    return np.stack([ri * np.cos(phi_i), ri * np.sin(phi_i), np.sqrt(1 - ri * ri)], -1)


def _mass(b, c, L):
    """The kernels' rough lobe albedo for the mixture: pi L ((e^t - 1)/t) / b, t = (1 - c) L."""
    t = (1 - c) * L
    phi = np.where(t == 0, 1.0, np.expm1(t) / np.where(t == 0, 1.0, t))
    return np.pi * L * phi / b


def smooth_mixture(wo, a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0, a2=0.0, b2=10.0, c2=1.0,
                   channels_a=None, channels_a2=None, channels_kd=None):
    """Probabilities (cosine, lobe 1, lobe 2) of the kernels' mixture. a, a2, kd may be the sums
    over channels (the kernels use the channel sums)."""
    wo = _v(wo)
    L1, L2 = disk_norm_log(b, wo), disk_norm_log(b2, wo)
    e1 = a * fresnel(eta, wo[..., 2]) * _mass(b, c, L1)
    e2 = a2 * _mass(b2, c2, L2)
    s = kd + e1 + e2
    if np.all(s > 0):
        return kd / s, e1 / s, e2 / s
    return (np.where(s > 0, kd / np.where(s > 0, s, 1), 0.0), np.where(s > 0, e1 / np.where(s > 0, s, 1), 1.0),
            np.where(s > 0, e2 / np.where(s > 0, s, 1), 0.0))


def smooth_pdf(wo, wi, a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0, a2=0.0, b2=10.0, c2=1.0):
    wi, wo = _v(wi), _v(wo)
    pd, p1, p2 = smooth_mixture(wo, a, b, c, eta, kd, a2, b2, c2)
    p = p1 * disk_pdf(b, wo, wi) + pd * np.maximum(wi[..., 2], 0) * INV_PI
    if np.any(p2 != 0):
        p = p + p2 * disk_pdf(b2, wo, wi)
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), p, 0.0)


# ---------------------------------------------------------------------------------------------
# Microfacet ABC model (eq 15, 23-28)

def half(wo, wi):
    h = _v(wi) + _v(wo)
    return h / np.linalg.norm(h, axis=-1, keepdims=True)


def vcavity(wo, wi, h):
    ih = np.sum(wi * h, -1)
    oh = np.sum(wo * h, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.minimum(1, np.minimum(2 * h[..., 2] * wi[..., 2] / ih, 2 * h[..., 2] * wo[..., 2] / oh))
    return np.where((ih > 0) & (oh > 0), g, 0.0)


def microfacet_eval(wo, wi, a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0):
    wi, wo = _v(wi), _v(wo)
    h = half(wo, wi)
    # 1 - n.h from the tangent part of h: sin^2 / (1 + cos)
    x = (h[..., 0] ** 2 + h[..., 1] ** 2) / (1 + h[..., 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        spec = abc(a, b, c, x) * fresnel(eta, np.sum(wi * h, -1)) * vcavity(wo, wi, h) / (
            np.pi * wi[..., 2] * wo[..., 2])
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), kd * INV_PI + spec, 0.0)


def h_norm(b, c):
    """M_h A of eq 24: P_h = M_h A / (1 + B (1 - cos))^C."""
    if c == 1:
        return b / (2 * np.pi * np.log1p(b))
    return b * (c - 1) / (2 * np.pi * (1 - (1 + b) ** (1 - c)))


def h_pdf(b, c, wo, wi):
    """Solid-angle density of wi under the eq 23-28 sampler."""
    wi, wo = _v(wi), _v(wo)
    h = half(wo, wi)
    x = (h[..., 0] ** 2 + h[..., 1] ** 2) / (1 + h[..., 2])
    oh = np.sum(wo * h, -1)
    return np.where(wi[..., 2] > 0, h_norm(b, c) * (1 + b * x) ** (-c) / (4 * oh), 0.0)


def h_sample_x(b, c, u0):
    """1 - cos theta_h of eq 25 as printed (C = 1 branch only where C == 1)."""
    u0 = np.asarray(u0, float)
    if c == 1:
        return np.expm1(u0 * np.log1p(b)) / b
    return ((1 + u0 * ((1 + b) ** (1 - c) - 1)) ** (1 / (1 - c)) - 1) / b


def h_sample_x_exact(b, c, u0, digits=40):
    """eq 25 as printed, in decimal arithmetic with ``digits`` digits (b, c, u0 taken exactly as
    the binary floats they are). In double precision the printed form loses ~1e-16 / (u t)
    relative near C = 1 (the base 1 + u ((1+B)^(1-C) - 1) is rounded before the power
    1/(1-C)); this does not."""
    import decimal
    ctx = decimal.Context(prec=digits)
    D = decimal.Decimal
    b_, c_ = D(float(b)), D(float(c))
    one = D(1)
    out = []
    for u in np.ravel(np.asarray(u0, float)):
        u_ = D(float(u))
        if c_ == one:
            x = ctx.divide(ctx.subtract(ctx.exp(ctx.multiply(u_, ctx.ln(one + b_))), one), b_)
        else:
            e = ctx.subtract(one, c_)
            t = ctx.subtract(ctx.exp(ctx.multiply(e, ctx.ln(one + b_))), one)   # (1+B)^(1-C) - 1
            base = ctx.add(one, ctx.multiply(u_, t))
            x = ctx.divide(ctx.subtract(ctx.exp(ctx.divide(ctx.ln(base), e)), one), b_)
        out.append(float(x))
    return np.array(out).reshape(np.shape(u0))


def h_sample(b, c, wo, u0, u1):
    x = h_sample_x(b, c, u0)
    st = np.sqrt(x * (2 - x))
    phi = 2 * np.pi * np.asarray(u1, float)
    h = np.stack([st * np.cos(phi), st * np.sin(phi), 1 - x], -1)
    wo = _v(wo)
    return 2 * np.sum(wo * h, -1)[..., None] * h - wo      # eq 27


def microfacet_diffuse_prob(wo, a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0):
    """The kernels' probability of the cosine lobe: kd / (kd + 4 a F(cos_o) M_h^-1 / pi)."""
    es = a * fresnel(eta, _v(wo)[..., 2]) * 4 / (np.pi * h_norm(b, c))
    s = kd + es
    return np.where(s > 0, kd / np.where(s > 0, s, 1), 0.0)


def microfacet_pdf(wo, wi, a=1.0, b=100.0, c=1.0, eta=1.5, kd=0.0):
    wi, wo = _v(wi), _v(wo)
    pd = microfacet_diffuse_prob(wo, a, b, c, eta, kd)
    p = pd * np.maximum(wi[..., 2], 0) * INV_PI + (1 - pd) * h_pdf(b, c, wo, wi)
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), p, 0.0)


# ---------------------------------------------------------------------------------------------
# Dispatch

def _params(model, params):
    d = dict(SMOOTH_DEFAULTS if model == "low_smooth" else MICROFACET_DEFAULTS)
    params = {k: v for k, v in params.items() if k != "lobes"}
    unknown = set(params) - set(d)
    if unknown:
        raise ValueError(f"{model}: unknown parameters {sorted(unknown)}")
    d.update(params)
    return d


def eval(wo, wi, model="low_smooth", **params):
    p = _params(model, params)
    return (smooth_eval if model == "low_smooth" else microfacet_eval)(wo, wi, **p)


def pdf(wo, wi, model="low_smooth", **params):
    p = _params(model, params)
    return (smooth_pdf if model == "low_smooth" else microfacet_pdf)(wo, wi, **p)


# ---------------------------------------------------------------------------------------------
# Quadrature maps

class DiskMap:
    """Polar coordinates on the unit disk of Lp around the lobe centre -Vp: Lp = -Vp + rho (cos
    psi, sin psi), rho = w sinh(s X(psi)), X = asinh(rho_max(psi)/w), psi = 2 pi t, w = 1/sqrt(b);
    rho_max is the distance to the unit circle (the horizon). dw_i = dA / cos_i."""

    def __init__(self, wo, b):
        self.wo = _v(wo)
        self.c = -self.wo[:2]
        self.w = 1 / np.sqrt(max(float(b), 1e-300))
        self.w = min(self.w, 1.0)

    def _rmax(self, psi):
        ce = self.c[0] * np.cos(psi) + self.c[1] * np.sin(psi)
        cz2 = self.wo[2] ** 2                                  # 1 - |c|^2
        sq = np.sqrt(ce * ce + cz2)
        # the positive root of rho^2 + 2 ce rho - cz2 in the form that does not cancel: at
        # grazing wo (cz2 = 1e-24) and ce < 0, ce + sq rounds to 0 (E came out 0 for 0.19)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(ce > 0, cz2 / (ce + sq), sq - ce)

    def points(self, s, t):
        psi = 2 * np.pi * t
        X = np.arcsinh(self._rmax(psi) / self.w)
        rho = self.w * np.sinh(s * X)
        lx = self.c[0] + rho * np.cos(psi)
        ly = self.c[1] + rho * np.sin(psi)
        z = np.sqrt(np.maximum(1 - lx * lx - ly * ly, 0))
        wi = np.stack([lx, ly, z], -1)
        with np.errstate(divide="ignore", invalid="ignore"):
            jac = rho * self.w * np.cosh(s * X) * X * 2 * np.pi / z
        return wi, np.where(z > 0, jac, 0.0)

    def coords(self, wi):
        wi = _v(wi)
        dx, dy = wi[..., 0] - self.c[0], wi[..., 1] - self.c[1]
        psi = np.mod(np.arctan2(dy, dx), 2 * np.pi)
        X = np.arcsinh(self._rmax(psi) / self.w)
        s = np.arcsinh(np.hypot(dx, dy) / self.w) / X
        return np.clip(s, 0, 1 - 1e-12), np.clip(psi / (2 * np.pi), 0, 1 - 1e-12)

    def density(self, wi):
        return np.ones(np.shape(wi)[:-1])


class HalfMap:
    """Half vectors in polar slope coordinates: tan theta_h = a sinh(s X(phi)), phi = 2 pi t,
    X = asinh(tan theta_max(phi) / a), theta_max where wi = reflect(wo, h) meets the horizon;
    wi = reflect(wo, h), dw_i = 4 (wo.h) cos^3 theta_h a^2 rho drho dphi. For the ABC lobe
    a = sqrt(2/b) (1 - cos theta ~ tan^2 theta / 2)."""

    def __init__(self, wo, a):
        self.wo = _v(wo)
        self.a = float(a)
        self.so = np.hypot(self.wo[0], self.wo[1])
        self.co = self.wo[2]
        self.phio = np.arctan2(self.wo[1], self.wo[0])

    def _xmax(self, phi):
        delta = np.arctan2(self.so * np.cos(phi - self.phio), self.co)
        return np.arcsinh(np.tan((np.pi / 2 + delta) / 2) / self.a)

    def points(self, s, t):
        # s -> 1 - (1 - s)^2 puts nodes into the horizon edge, where the integrand has a
        # square-root endpoint (Gauss rules of two orders agreed there on a value 4e-7 off, with
        # an error estimate of 2e-17: low_microfacet B = 1 at normal incidence)
        ds = 2 * (1 - s)
        s = 1 - (1 - s) ** 2
        phi = 2 * np.pi * t
        X = self._xmax(phi)
        rho = np.sinh(s * X)
        tan_t = self.a * rho
        ct = 1 / np.sqrt(1 + tan_t ** 2)
        st = tan_t * ct
        h = np.stack([st * np.cos(phi), st * np.sin(phi), ct], -1)
        oh = h @ self.wo
        wi = 2 * oh[..., None] * h - self.wo
        jac = 4 * oh * ct ** 3 * self.a ** 2 * rho * np.cosh(s * X) * X * 2 * np.pi * ds
        return wi, jac

    def coords(self, wi):
        h = half(self.wo, wi)
        t = np.mod(np.arctan2(h[..., 1], h[..., 0]) / (2 * np.pi), 1.0)
        rho = np.hypot(h[..., 0], h[..., 1]) / h[..., 2] / self.a
        s = np.arcsinh(rho) / self._xmax(2 * np.pi * t)
        s = 1 - np.sqrt(np.clip(1 - s, 0, 1))                  # the inverse of the edge map
        return np.clip(s, 0, 1 - 1e-12), np.clip(t, 0, 1 - 1e-12)

    def density(self, wi):
        return np.ones(np.shape(wi)[:-1])


def half_width(b):
    return min(np.sqrt(2 / b), 1.0)


def albedo(mu, phi=0.0, tol=1e-8, model="low_smooth", **params):
    """E(wo) = integral f cos_i dw_i, wo = (mu, phi); (value, err). Each lobe over its own map
    (DiskMap with that lobe's b for the smooth model, HalfMap for the microfacet model); the
    Lambertian term exactly (kd)."""
    p = _params(model, params)
    wo = R.direction(float(mu), float(phi))
    kd = p.pop("kd")
    value, err = float(kd), 0.0
    if model == "low_smooth":
        lobes = [(DiskMap(wo, p["b"]), lambda wi: fresnel(p["eta"], _cos_d(wo, wi))
                  * abc(p["a"], p["b"], p["c"], _dp2(wo, wi)) * wi[..., 2])]
        if p["a2"] != 0:
            lobes.append((DiskMap(wo, p["b2"]),
                          lambda wi: abc(p["a2"], p["b2"], p["c2"], _dp2(wo, wi)) * wi[..., 2]))
    else:
        lobes = [(HalfMap(wo, half_width(p["b"])),
                  lambda wi: microfacet_eval(wo, wi, **p) * wi[..., 2])]
    for m, g in lobes:
        v, e = R.hemisphere_integral(g, [(m.points, m.density)], tol / len(lobes))
        value += v
        err += e
    return value, err


def _dp2(wo, wi):
    return np.sum((wi[..., :2] + wo[:2]) ** 2, -1)


def _cos_d(wo, wi):
    return np.sqrt(np.maximum(1 - np.sum((wi[..., :2] - wo[:2]) ** 2, -1) / 4, 0))


def albedo_variance(mu, phi=0.0, tol=1e-8, **params):
    """Smooth model, one lobe, kd = 0, a = 1: (E, second moment M2 = integral (f cos)^2 / pdf dw)
    of the brdf estimator f cos / pdf under the eq 17-22 sampler, by quadrature. The relative
    variance per sample is M2 / E^2 - 1."""
    p = _params("low_smooth", params)
    wo = R.direction(float(mu), float(phi))
    m = DiskMap(wo, p["b"])

    def fc(wi):
        return fresnel(p["eta"], _cos_d(wo, wi)) * abc(p["a"], p["b"], p["c"], _dp2(wo, wi)) * wi[..., 2]

    def m2(wi):
        q = disk_pdf(p["b"], wo, wi)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(q > 0, fc(wi) ** 2 / q, 0.0)
    E, eE = R.hemisphere_integral(fc, [(m.points, m.density)], tol)
    M2, eM = R.hemisphere_integral(m2, [(m.points, m.density)], tol)
    return E, M2, eE, eM


# ---------------------------------------------------------------------------------------------
# The registered references (clbrdf.ref.Reference)

from . import Reference


class LowReference(Reference):
    """low_smooth and low_microfacet. The sampler's mixture weights are linear in a, a2 and kd,
    so an RGB model's density is the density with those summed over the channels."""
    def _kw(self, v):
        return {k: float(x) for k, x in v.items()}

    def eval1(self, wo, wi, v, c):
        return eval(wo, wi, model=self.name, **self._kw(v))

    def pdf(self, wo, wi):
        chans = self.channel_values()
        kw = self._kw(chans[0])
        for k in set(self.config.spectral):
            kw[k] = sum(float(v[k]) for v in chans)
        return pdf(np.asarray(wo, float), np.asarray(wi, float), model=self.name, **kw)

    def albedo1(self, mu, phi, tol, v, c):
        return albedo(mu, phi, tol, model=self.name, **self._kw(v))


REFERENCES = {"low_smooth": LowReference, "low_microfacet": LowReference}
