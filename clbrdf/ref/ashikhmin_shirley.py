"""Double-precision NumPy reference for the Ashikhmin & Shirley 2000 anisotropic Phong BRDF
(``ashikhmin_shirley``), written from the paper (eq 5, 10-11, 14, 16, 18-20) and docs/models/ashikhmin_shirley.md, independently of the kernel: eq 16 evaluated as printed on the unit half vector
(exponent (nu h_u^2 + nv h_v^2) / (1 - (n.h)^2), its 0/0 at h = n taken as its limit), the
sampler in the paper's four-branch quadrant form, and a quadrature map that follows the lobe.

Directions: arrays (..., 3), local frame (normal z, tangent u = x, bitangent v = y); wi towards the
light, wo towards the viewer; both are normalised here. Parameters are scalars (one channel) and
broadcast with the directions.

    f = ks rho_s + rho_d + kd / pi
    rho_s = sqrt((nu+1)(nv+1)) / (8 pi) (n.h)^e(h) F(k.h) / ((k.h) max(n.wi, n.wo))   (eq 16)
    rho_d = 28 rd / (23 pi) (1 - rs) (1 - (1 - n.wi/2)^5) (1 - (1 - n.wo/2)^5)        (eq 14)
    F = rs + (1 - rs)(1 - k.h)^5 (eq 11, fresnel="schlick"), or the exact dielectric Fresnel of
    index eta (fresnel="dielectric", Löw et al.'s fits); ks (default 1) scales rho_s.

Sampling (the kernel's): the specular lobe by eq 19-20 with pdf p_h(h) / (4 wo.h) (eq 5, 18),
the diffuse terms by the cosine density; mixture probability of the cosine lobe
p_d = w_d / (w_d + w_s), w_d = rd (1 - rs) (1 - (1 - n.wo/2)^5) + kd (the diffuse terms' exact
albedo), w_s = ks F(n.wo) (the specular albedo of a mirror with this Fresnel factor).

    eval(wo, wi, **params), pdf(wo, wi, **params), albedo(mu, phi=0.0, tol=1e-8, **params)
"""
from __future__ import annotations

import numpy as np

from . import quadrature as R

INV_PI = 1 / np.pi
DEFAULTS = dict(nu=10.0, nv=10.0, rs=0.05, rd=0.0, kd=0.0, ks=1.0, eta=1.5)


def _unit(w):
    w = np.asarray(w, float)
    return w / np.linalg.norm(w, axis=-1, keepdims=True)


def configure(**kw):
    """Resolve options and parameters: fresnel = schlick (rs) or dielectric (eta)."""
    kw = dict(kw)
    fres = kw.pop("fresnel", "dielectric" if "eta" in kw else "schlick")
    if fres not in ("schlick", "dielectric"):
        raise ValueError(f"fresnel={fres!r}: choose schlick or dielectric")
    cfg = {"fresnel": fres}
    for k, v in DEFAULTS.items():
        cfg[k] = np.asarray(kw.pop(k, v), float)
    if kw:
        raise TypeError(f"unknown parameters {sorted(kw)}")
    if fres == "dielectric":
        cfg["rs"] = np.asarray(0.0)      # (not used by F; rd is not defined with this Fresnel)
    return cfg


def fresnel(cfg, c):
    c = np.clip(np.asarray(c, float), 0, 1)
    if cfg["fresnel"] == "schlick":
        rs = cfg["rs"]
        return rs + (1 - rs) * (1 - c) ** 5                          # eq 11
    # Snell's law and the s/p amplitudes; 1 under total internal reflection
    eta = cfg["eta"]
    s2t = (1 - c * c) / (eta * eta)
    ct = np.sqrt(np.maximum(1 - s2t, 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r_s = (c - eta * ct) / (c + eta * ct)
        r_p = (eta * c - ct) / (eta * c + ct)
    return np.where(s2t >= 1, 1.0, 0.5 * (r_s * r_s + r_p * r_p))


def lobe_power(h, nu, nv):
    """(n.h)^((nu h_u^2 + nv h_v^2) / (1 - (n.h)^2)) of eq 16 on unit h; at h = n the exponent is
    0/0 but (n.h)^e = 1 for any bounded e (its limit lies in [min(nu, nv), max(nu, nv)])."""
    hx, hy, hz = h[..., 0], h[..., 1], h[..., 2]
    den = 1 - hz * hz
    at_n = den <= 0
    with np.errstate(divide="ignore", invalid="ignore"):
        e = (nu * hx * hx + nv * hy * hy) / np.where(at_n, 1.0, den)
        p = np.where(hz > 0, np.abs(hz) ** e, 0.0)
    return np.where(at_n & (hz > 0), 1.0, p)


def norm_const(nu, nv):
    return np.sqrt((nu + 1) * (nv + 1))


def specular(wo, wi, cfg):
    """rho_s of eq 16 (without ks)."""
    wi, wo = _unit(wi), _unit(wo)
    h = _unit(wi + wo)
    kh = np.sum(wi * h, -1)
    ci, co = wi[..., 2], wo[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = (norm_const(cfg["nu"], cfg["nv"]) / (8 * np.pi) * lobe_power(h, cfg["nu"], cfg["nv"])
             * fresnel(cfg, kh) / (kh * np.maximum(ci, co)))
    return np.where((ci > 0) & (co > 0), f, 0.0)


def one_minus_pow5(x):
    """1 - (1 - x/2)^5."""
    return 1 - (1 - np.asarray(x, float) / 2) ** 5


def diffuse(wo, wi, cfg):
    """rho_d of eq 14 plus kd / pi."""
    wi, wo = _unit(wi), _unit(wo)
    ci, co = wi[..., 2], wo[..., 2]
    f = (28 * cfg["rd"] / (23 * np.pi) * (1 - cfg["rs"]) * one_minus_pow5(ci) * one_minus_pow5(co)
         + cfg["kd"] * INV_PI)
    return np.where((ci > 0) & (co > 0), f, 0.0)


def eval(wo, wi, **params):
    """BRDF value (1/sr); 0 unless both directions are above the horizon."""
    cfg = configure(**params)
    return cfg["ks"] * specular(wo, wi, cfg) + diffuse(wo, wi, cfg)


def diffuse_albedo(mu, **params):
    """Exact albedo of rho_d + kd/pi at cos theta_o = mu: integral (1 - (1 - mu_i/2)^5) mu_i
    dw_i = 23 pi / 28, so E_d = rd (1 - rs)(1 - (1 - mu/2)^5) + kd."""
    cfg = configure(**params)
    return cfg["rd"] * (1 - cfg["rs"]) * one_minus_pow5(mu) + cfg["kd"]


def p_h(h, nu, nv):
    """Half-vector density of eq 5 (per unit solid angle of h)."""
    return norm_const(nu, nv) / (2 * np.pi) * lobe_power(h, nu, nv)


def spec_pdf(wo, wi, nu, nv):
    """eq 18: p(wi) = p_h(h) / (4 wo.h); 0 below the horizon."""
    wi, wo = _unit(wi), _unit(wo)
    h = _unit(wi + wo)
    oh = np.sum(wo * h, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = p_h(h, nu, nv) / (4 * oh)
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0) & (oh > 0), p, 0.0)


def diffuse_prob(wo, cfg):
    co = _unit(wo)[..., 2]
    wd = cfg["rd"] * (1 - cfg["rs"]) * one_minus_pow5(co) + cfg["kd"]
    ws = cfg["ks"] * fresnel(cfg, co)
    s = wd + ws
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(s > 0, wd / np.where(s > 0, s, 1.0), 0.0)


def pdf(wo, wi, **params):
    """Solid-angle density of the kernel's sampler (the lobe mixture)."""
    cfg = configure(**params)
    wi, wo = _unit(wi), _unit(wo)
    pd = diffuse_prob(wo, cfg)
    ps = spec_pdf(wo, wi, cfg["nu"], cfg["nv"])
    cosine = np.maximum(wi[..., 2], 0) * INV_PI
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), pd * cosine + (1 - pd) * ps, 0.0)


# ---------------------------------------------------------------------------------------------
# The paper's sampler (eq 19-20), in its printed four-branch quadrant form

def sample_h(nu, nv, xi1, xi2):
    """h for (xi1, xi2): phi in the first quadrant by eq 19, the quadrant by xi1 in [0, .25),
    [.25, .5), [.5, .75), [.75, 1) with xi1 mapped back to [0, 1) and phi flipped about pi/2
    (second), shifted by pi (third), flipped about 3 pi/2 (fourth) (pbrt-v2's reading: each
    quadrant's xi1 runs so that phi is continuous in xi1); cos theta by eq 20."""
    xi1, xi2 = np.asarray(xi1, float), np.asarray(xi2, float)
    k = np.sqrt((nu + 1) / (nv + 1))

    def first(x):
        return np.arctan(k * np.tan(np.pi * x / 2))                   # eq 19
    phi = np.select([xi1 < 0.25, xi1 < 0.5, xi1 < 0.75],
                    [first(4 * xi1), np.pi - first(4 * (0.5 - xi1)), np.pi + first(4 * (xi1 - 0.5))],
                    2 * np.pi - first(4 * (1 - xi1)))
    e = nu * np.cos(phi) ** 2 + nv * np.sin(phi) ** 2
    cos_t = (1 - xi2) ** (1 / (e + 1))                                # eq 20
    sin_t = np.sqrt(np.maximum(0, 1 - cos_t ** 2))
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)


# ---------------------------------------------------------------------------------------------
# Quadrature

class HalfMap:
    """(s, t) in [0,1]^2 -> wi = reflect(wo, h) with h from the inverse of the sampler's CDF:
    phi = atan2(sqrt(nu+1) sin 2 pi t, sqrt(nv+1) cos 2 pi t) (the CDF of eq 19 over the circle),
    xi2 = s xi2_max(phi), cos theta_h = (1 - xi2)^(1/(e+1)); xi2_max = 1 - cos(theta_max)^(e+1),
    theta_max(phi) the half-vector angle at which wi reaches the horizon (as in
    clbrdf.ref.microfacet.halfvector_map), so the domain is exactly the upper hemisphere.
    Density: the lobe density p_h(h) / (4 wo.h); Jacobian xi2_max."""

    def __init__(self, wo, nu, nv):
        self.wo = np.asarray(wo, float)
        self.nu, self.nv = float(nu), float(nv)
        self.so = np.hypot(self.wo[0], self.wo[1])
        self.co = float(self.wo[2])
        self.phio = np.arctan2(self.wo[1], self.wo[0])

    def points(self, s, t):
        nu, nv = self.nu, self.nv
        x = 2 * np.pi * t
        phi = np.arctan2(np.sqrt(nu + 1) * np.sin(x), np.sqrt(nv + 1) * np.cos(x))
        e1 = nu * np.cos(phi) ** 2 + nv * np.sin(phi) ** 2 + 1
        delta = np.arctan2(self.so * np.cos(phi - self.phio), self.co)
        tmax = (np.pi / 2 + delta) / 2
        log_v = e1 * np.log(np.cos(tmax))                # log(1 - xi2_max)
        xmax = -np.expm1(log_v)
        a = s * xmax
        with np.errstate(divide="ignore"):
            lg = np.where(a < 0.5, np.log1p(-a), np.log((1 - s) + s * np.exp(log_v)))
        cos_t = np.exp(lg / e1)
        sin_t = np.sqrt(-np.expm1(2 * lg / e1))
        h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)
        return R.reflect(self.wo, h), xmax

    def density(self, wi):
        return spec_pdf(self.wo, wi, self.nu, self.nv)


def albedo(mu, phi=0.0, tol=1e-8, **params):
    """E(wo) = integral f cos_i dw_i at wo = (mu, phi): the specular term over ``HalfMap`` and
    the diffuse terms over the cosine map (each term with the map that matches it). (E, err)."""
    cfg = configure(**params)
    wo = R.direction(float(mu), float(phi))
    value = err = 0.0
    parts = []
    if np.any(cfg["ks"] != 0):
        hm = HalfMap(wo, cfg["nu"], cfg["nv"])
        parts.append((lambda wi: cfg["ks"] * specular(wo, wi, cfg) * wi[..., 2],
                      [(hm.points, hm.density)]))
    if np.any(cfg["rd"] != 0) or np.any(cfg["kd"] != 0):
        parts.append((lambda wi: diffuse(wo, wi, cfg) * wi[..., 2], [R.cosine_map()]))
    for g, maps in parts:
        v, e = R.hemisphere_integral(g, maps, tol / max(1, len(parts)))
        value += v
        err += e
    return value, err


# ---------------------------------------------------------------------------------------------
# The registered reference (clbrdf.ref.Reference)

from . import Reference


class ASReference(Reference):
    """The sampler mixes the cosine lobe with probability sum wd / (sum wd + sum ws) over the
    channels (``diffuse_prob`` per channel)."""
    def _kw(self, v):
        return {**{k: float(x) for k, x in v.items()}, "fresnel": self.options["fresnel"]}

    def eval1(self, wo, wi, v, c):
        return eval(wo, wi, **self._kw(v))

    def pdf(self, wo, wi):
        wo, wi = _unit(wo), _unit(wi)
        co = wo[..., 2]
        wd = ws = 0.0
        for v in self.channel_values():
            cfg = configure(**self._kw(v))
            wd = wd + cfg["rd"] * (1 - cfg["rs"]) * one_minus_pow5(co) + cfg["kd"]
            ws = ws + cfg["ks"] * fresnel(cfg, co)
        s = wd + ws
        with np.errstate(divide="ignore", invalid="ignore"):
            pd = np.where(s > 0, wd / np.where(s > 0, s, 1.0), 0.0)
        ps = spec_pdf(wo, wi, float(self.params["nu"]), float(self.params["nv"]))
        cosine = np.maximum(wi[..., 2], 0) * INV_PI
        return np.where((wi[..., 2] > 0) & (co > 0), pd * cosine + (1 - pd) * ps, 0.0)

    def albedo1(self, mu, phi, tol, v, c):
        return albedo(mu, phi, tol, **self._kw(v))


REFERENCES = {"ashikhmin_shirley": ASReference}
