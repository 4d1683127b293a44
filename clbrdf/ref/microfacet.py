"""Double-precision NumPy reference of the Lambertian and microfacet (Beckmann, GGX) models.

Written from the equations in docs/models/microfacet.md,
independently of the OpenCL kernels, so that the kernels can be tested against it. Everything is
float64 and broadcasts: directions are arrays of shape (..., 3) in the local frame (normal z,
tangent x); ``wi`` points towards the light, ``wo`` towards the viewer, both away from the
surface. Parameters broadcast against the leading (...) shape of the directions.

Models: ``lambert`` (f = kd/pi) and the microfacet models ``beckmann`` and ``ggx``:

    f = F(wi.h) D(h) G(wo, wi, h) / (4 cos_i cos_o) + kd/pi,    h = normalize(wi + wo).

Parameters: ``alpha`` or ``alpha_x``/``alpha_y``, ``f0``, ``eta``, ``k``, ``kd``; options:
``masking`` (none, vcavity, separable, correlated), ``fresnel`` (one, schlick, dielectric,
conductor), ``lobe_sampler`` (ndf, vndf). When ``fresnel`` is not given it follows the Fresnel
parameters given, as the model specs do: eta and k -> conductor, eta -> dielectric,
f0 -> schlick, none -> one. A parameter that the configuration does not use is an error.

``albedo`` and ``albedo_avg`` are deterministic: ``clbrdf.ref.quadrature`` over the half-vector map
of the lobe (``halfvector_map``) and the cosine map.
"""
import numpy as np
from scipy import special

from .quadrature import (
    INV_PI,
    gauss01,
    as_float64,
    adaptive_gl1,
    cosine_map,
    direction,
    dot,
    half_cos,
    hemisphere_integral,
    normalize,
    reflect,
)

MODELS = ("lambert", "beckmann", "ggx")
DISTRIBUTIONS = ("beckmann", "ggx")
MASKINGS = ("none", "vcavity", "separable", "correlated", "unshadowed")
FRESNELS = ("one", "schlick", "gen_schlick", "f82", "remapped", "dielectric", "conductor")
LOBE_SAMPLERS = ("ndf", "vndf")
SAMPLERS = ("uniform", "cosine", "ndf", "vndf", "brdf", "mis")

DEFAULTS = {"alpha": 0.5, "f0": 0.04, "eta": 1.5, "k": 3.0, "f90": 1.0, "exponent": 5.0, "f82": 1.0}
FRESNEL_PARAMS = {"one": (), "schlick": ("f0",), "gen_schlick": ("f0", "f90", "exponent"),
                  "f82": ("f0", "f82"), "remapped": ("f0", "f90", "eta"), "dielectric": ("eta",),
                  "conductor": ("eta", "k")}


# ---------------------------------------------------------------------------------------------
# Building blocks (docs/models/microfacet.md)

def D(dist, h, alpha_x, alpha_y):
    """Distribution of normals, integral D(h) (h.n) dw_h = 1; 0 for h.z <= 0.

    Slopes (tx, ty) = (-h.x/h.z, -h.y/h.z), e = tx^2/ax^2 + ty^2/ay^2:
    Beckmann exp(-e) / (pi ax ay cos^4), GGX 1 / (pi ax ay cos^4 (1 + e)^2).
    """
    h = normalize(as_float64(h))
    ax, ay = np.asarray(alpha_x, float), np.asarray(alpha_y, float)
    x, y, z = h[..., 0], h[..., 1], h[..., 2]
    up = z > 0
    zs = np.where(up, z, 1.0)
    if dist == "beckmann":
        e = ((x / ax) ** 2 + (y / ay) ** 2) / zs ** 2
        d = np.exp(-e) / (np.pi * ax * ay * zs ** 4)
    elif dist == "ggx":
        # cos^4 (1 + e)^2 = (x^2/ax^2 + y^2/ay^2 + z^2)^2: no division by cos
        q = (x / ax) ** 2 + (y / ay) ** 2 + z ** 2
        d = 1 / (np.pi * ax * ay * q ** 2)
    else:
        raise ValueError(f"unknown distribution {dist!r}; choose one of {DISTRIBUTIONS}")
    return np.where(up, d, 0.0)


def Lambda(dist, w, alpha_x, alpha_y):
    """Smith Lambda of direction w; 0 at normal incidence, inf for w.z <= 0.

    a0^2 tan^2 theta = (wx^2 ax^2 + wy^2 ay^2) / wz^2, a0 the roughness along the azimuth of w.
    """
    w = normalize(as_float64(w))
    ax, ay = np.asarray(alpha_x, float), np.asarray(alpha_y, float)
    z = w[..., 2]
    up = z > 0
    zs = np.where(up, z, 1.0)
    t2 = ((w[..., 0] * ax) ** 2 + (w[..., 1] * ay) ** 2) / zs ** 2       # a0^2 tan^2 theta
    if dist == "ggx":
        lam = t2 / (2 * (1 + np.sqrt(1 + t2)))          # (-1 + sqrt(1 + t2)) / 2
    elif dist == "beckmann":
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
            m = 1 / np.sqrt(t2)
            lam = (-special.erfc(m) + np.exp(-m * m) / (m * np.sqrt(np.pi))) / 2
        lam = np.where(t2 > 0, lam, 0.0)
    else:
        raise ValueError(f"unknown distribution {dist!r}; choose one of {DISTRIBUTIONS}")
    return np.where(up, lam, np.inf)


def G1(dist, w, alpha_x, alpha_y):
    """Smith masking 1 / (1 + Lambda(w))."""
    return 1 / (1 + Lambda(dist, w, alpha_x, alpha_y))


def G(masking, dist, wo, wi, h, alpha_x, alpha_y):
    """Masking-shadowing term for the given option."""
    wi, wo, h = as_float64(wi), as_float64(wo), as_float64(h)
    shape = np.broadcast_shapes(wi.shape, wo.shape, h.shape)[:-1]
    if masking == "none":
        return np.ones(shape)
    if masking == "vcavity":                              # Cook-Torrance 1982
        nh, c = h[..., 2], half_cos(wo, wi)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.minimum(1, np.minimum(2 * nh * wo[..., 2] / c, 2 * nh * wi[..., 2] / c))
        return np.where(c > 0, g, 0.0)
    side = half_cos(wo, wi) > 0            # wo.h = wi.h for the half vector h of (wo, wi)
    li = Lambda(dist, wi, alpha_x, alpha_y)
    lo = Lambda(dist, wo, alpha_x, alpha_y)
    if masking == "unshadowed":                          # masking of wo alone
        g = 1 / (1 + lo)
    elif masking == "separable":
        g = 1 / ((1 + li) * (1 + lo))
    elif masking == "correlated":
        g = 1 / (1 + li + lo)
    else:
        raise ValueError(f"unknown masking {masking!r}; choose one of {MASKINGS}")
    return np.where(side, g, 0.0)


def fresnel(kind, c, f0=None, eta=None, k=None, f90=None, exponent=None, f82=None):
    """Unpolarised Fresnel reflectance at cos(angle) c (c = wi.h); Schlick's with f90 (default 1)
    is the generalised F0 + (F90 - F0)(1 - c)^5; gen_schlick has a free exponent (Cycles);
    remapped carries the dielectric curve of eta from [F(1), 1] onto [F0, F90] (Cycles);
    f82 is Hoffman 2023's F82-tint, Schlick's minus a c (1 - c)^6 with F(1/7) = f82 times
    Schlick's there, clamped at 0 (docs/models/microfacet.md)."""
    c = np.asarray(c, float)
    if kind == "one":
        return np.ones_like(c)
    if kind == "gen_schlick":
        return f0 + ((1.0 if f90 is None else f90) - f0) * np.clip(1 - c, 0, 1) ** exponent
    if kind == "f82":
        cb = 1 / 7
        schlick = lambda x: f0 + (1 - f0) * (1 - x) ** 5           # noqa: E731
        a = (schlick(cb) - f82 * schlick(cb)) / (cb * (1 - cb) ** 6)
        return np.maximum(schlick(c) - a * c * (1 - c) ** 6, 0)
    if kind == "schlick":
        return f0 + ((1.0 if f90 is None else f90) - f0) * (1 - c) ** 5
    if kind == "remapped":
        # Cycles' Principled BSDF: where the exact dielectric curve lies between its normal
        # value and 1, as a fraction, carried onto [F0, F90]
        fd, fn = fresnel("dielectric", c, eta=eta), fresnel("dielectric", 1.0, eta=eta)
        return f0 + (f90 - f0) * np.clip((fd - fn) / (1 - fn), 0, 1)
    if kind == "dielectric":
        # Cook-Torrance 1982: g = sqrt(eta^2 + c^2 - 1); total internal reflection when g^2 < 0
        g2 = eta ** 2 + c ** 2 - 1
        g = np.sqrt(np.maximum(g2, 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            f = 0.5 * ((g - c) / (g + c)) ** 2 * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)
        return np.where(g2 < 0, 1.0, f)
    if kind == "conductor":
        # complex index n = eta + i k, as pbrt-v4 FrComplex
        n = np.asarray(eta, float) + 1j * np.asarray(k, float)
        ci = np.clip(c, 0, 1).astype(complex)
        sin2_t = (1 - ci ** 2) / n ** 2
        ct = np.sqrt(1 - sin2_t)
        r_parl = (n * ci - ct) / (n * ci + ct)
        r_perp = (ci - n * ct) / (ci + n * ct)
        return (np.abs(r_parl) ** 2 + np.abs(r_perp) ** 2) / 2
    raise ValueError(f"unknown fresnel {kind!r}; choose one of {FRESNELS}")


# ---------------------------------------------------------------------------------------------
# Parameters

def fresnel_avg_closed(kind, f0, f90=1.0, exponent=5.0, f82=1.0):
    """F_avg = 2 int F(c) c dc in closed form: gen_schlick F0 + (F90 - F0) 2 / ((n + 1)(n + 2));
    f82 Schlick's F0 + (1 - F0) / 21 minus a / 126 (2 int c^2 (1 - c)^6 dc = 1/126), valid
    where the F82-tint term is not clamped (tint >= 0.52 for every F0)."""
    if kind == "gen_schlick":
        return f0 + (f90 - f0) * 2 / ((exponent + 1) * (exponent + 2))
    if kind == "f82":
        cb = 1 / 7
        a = (1 - f82) * (f0 + (1 - f0) * (1 - cb) ** 5) / (cb * (1 - cb) ** 6)
        return f0 + (1 - f0) / 21 - a / 126
    raise ValueError(f"no closed form here for fresnel={kind!r}")

def configure(model, **kw):
    """Resolve options and parameters: a dict with every value the formulas need."""
    kw = dict(kw)
    if model == "lambert":
        cfg = {"kd": np.asarray(kw.pop("kd", 1.0), float)}
        if kw:
            raise TypeError(f"lambert takes only kd, got {sorted(kw)}")
        return cfg
    if model not in DISTRIBUTIONS:
        raise ValueError(f"unknown model {model!r}; choose one of {MODELS}")
    masking = kw.pop("masking", "correlated")
    lobe = kw.pop("lobe_sampler", "vndf")
    kind = kw.pop("fresnel", None)
    if kind is None:
        kind = ("conductor" if {"eta", "k"} <= set(kw) else "dielectric" if "eta" in kw
                else "gen_schlick" if "exponent" in kw else "f82" if "f82" in kw
                else "schlick" if {"f0", "f90"} & set(kw) else "one")
    for name, value, choices in (("masking", masking, MASKINGS), ("fresnel", kind, FRESNELS),
                                 ("lobe_sampler", lobe, LOBE_SAMPLERS)):
        if value not in choices:
            raise ValueError(f"{name}={value!r} is not one of {choices}")
    if "alpha_x" in kw or "alpha_y" in kw:
        if "alpha" in kw:
            raise TypeError("give alpha or alpha_x and alpha_y, not both")
        ax, ay = kw.pop("alpha_x", DEFAULTS["alpha"]), kw.pop("alpha_y", DEFAULTS["alpha"])
    else:
        ax = ay = kw.pop("alpha", DEFAULTS["alpha"])
    cfg = {"dist": model, "masking": masking, "fresnel": kind, "lobe_sampler": lobe,
           "ax": np.asarray(ax, float), "ay": np.asarray(ay, float),
           "kd": np.asarray(kw.pop("kd", 0.0), float)}
    for name in FRESNEL_PARAMS[kind]:
        cfg[name] = np.asarray(kw.pop(name, DEFAULTS[name]), float)
    if kind == "schlick" and "f90" in kw:
        cfg["f90"] = np.asarray(kw.pop("f90"), float)
    if kw:
        raise TypeError(f"parameters {sorted(kw)} are not used by {model} with fresnel={kind}")
    return cfg


def _fresnel(cfg, c):
    return fresnel(cfg["fresnel"], c, cfg.get("f0"), cfg.get("eta"), cfg.get("k"), cfg.get("f90"),
                   cfg.get("exponent"), cfg.get("f82"))


def _isotropic(cfg):
    return "ax" not in cfg or bool(np.all(cfg["ax"] == cfg["ay"]))


# ---------------------------------------------------------------------------------------------
# BRDF value

def eval_specular(cfg, wo, wi):
    """Microfacet term F D G / (4 cos_i cos_o); 0 outside the upper hemisphere."""
    wi, wo = as_float64(wi), as_float64(wo)
    ci, co = wi[..., 2], wo[..., 2]
    valid = (ci > 0) & (co > 0)
    h = normalize(wi + wo)
    f = (_fresnel(cfg, dot(wi, h)) * D(cfg["dist"], h, cfg["ax"], cfg["ay"])
         * G(cfg["masking"], cfg["dist"], wo, wi, h, cfg["ax"], cfg["ay"]))
    with np.errstate(divide="ignore", invalid="ignore"):
        f = f / (4 * ci * co)
    return np.where(valid, f, 0.0)


def eval(model, wo, wi, **params):
    """BRDF value f(wo, wi) in 1/sr; 0 when wi.z <= 0 or wo.z <= 0."""
    cfg = configure(model, **params)
    wi, wo = as_float64(wi), as_float64(wo)
    valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    f = cfg["kd"] * INV_PI
    if model != "lambert":
        f = f + eval_specular(cfg, wo, wi)
    return np.where(valid, f, 0.0)


# ---------------------------------------------------------------------------------------------
# Sampling densities (solid angle, of wi given wo)

def pdf_ndf(cfg, wo, wi):
    """Normals sampled with density D(h) (n.h), reflected: D(h) h.z / (4 |wo.h|)."""
    h = normalize(wi + wo)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = D(cfg["dist"], h, cfg["ax"], cfg["ay"]) * h[..., 2] / (4 * half_cos(wo, wi))
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), p, 0.0)


def pdf_vndf(cfg, wo, wi):
    """Visible normals G1(wo) max(0, wo.h) D(h) / cos_o, reflected: / (4 wo.h)."""
    h = normalize(wi + wo)
    co = wo[..., 2]
    valid = (wi[..., 2] > 0) & (co > 0) & (half_cos(wo, wi) > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = G1(cfg["dist"], wo, cfg["ax"], cfg["ay"]) * D(cfg["dist"], h, cfg["ax"], cfg["ay"]) / (4 * co)
    return np.where(valid, p, 0.0)


def pdf(model, wo, wi, sampler="brdf", **params):
    """Solid-angle density of wi for the given sampler; 0 when wi.z <= 0 or wo.z <= 0.

    brdf for microfacets: with probability p_d = kd / (kd + F(cos_o)) the cosine lobe, else the
    lobe sampler (ndf or vndf). mis: 0.5 pdf_brdf + 0.5 pdf_cosine.
    """
    cfg = configure(model, **params)
    wo, wi = as_float64(wo), as_float64(wi)
    ci = wi[..., 2]
    valid = (ci > 0) & (wo[..., 2] > 0)
    shape = np.broadcast_shapes(wo.shape, wi.shape)[:-1]
    cosine = np.where(valid, ci * INV_PI, 0.0)
    if sampler == "uniform":
        return np.where(valid, 0.5 * INV_PI, 0.0)
    if sampler == "cosine":
        return cosine
    if sampler == "mis":
        return 0.5 * pdf(model, wo, wi, "brdf", **params) + 0.5 * cosine
    if sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; choose one of {SAMPLERS}")
    if model == "lambert":
        if sampler == "brdf":
            return cosine
        raise ValueError(f"sampler {sampler!r} needs a microfacet model")
    if sampler == "ndf":
        return pdf_ndf(cfg, wo, wi)
    if sampler == "vndf":
        return pdf_vndf(cfg, wo, wi)
    lobe = (pdf_ndf if cfg["lobe_sampler"] == "ndf" else pdf_vndf)(cfg, wo, wi)
    kd = cfg["kd"]
    fo = _fresnel(cfg, wo[..., 2])
    p_d = np.where(kd > 0, kd / np.where(kd > 0, kd + fo, 1.0), 0.0)
    return np.broadcast_to(p_d * cosine + (1 - p_d) * lobe, shape)


# ---------------------------------------------------------------------------------------------
# Quadrature map of the specular lobe

def rough(params: dict) -> tuple:
    """(alpha_x, alpha_y) of a model's parameters (alpha for both where isotropic)."""
    if "alpha_x" in params:
        return float(params["alpha_x"]), float(params["alpha_y"])
    return float(params["alpha"]), float(params["alpha"])


def halfvector_map(dist, wo, alpha_x, alpha_y):
    """Half vectors by inverting the NDF's CDF, reflected: wi = reflect(wo, h).

    Azimuth: tan phi_h = (ay/ax) tan(2 pi t) on the branch of 2 pi t. Given phi_h the slope
    tan^2 theta_h = a^2 u/(1-u) (GGX) or -a^2 log(1-u) (Beckmann), 1/a^2 = cos^2/ax^2 + sin^2/ay^2.
    u runs over [0, u_max(phi_h)] only, u_max where wi reaches the horizon: with wo at polar angle
    theta_o and azimuth phi_o, wi.z = R cos(2 theta_h - delta), tan delta = tan theta_o cos(phi_h
    - phi_o), so theta_max = (pi/2 + delta)/2. Density p(wi) = D(h) h.z / (4 wo.h).
    """
    wo = as_float64(wo)
    ax, ay = float(alpha_x), float(alpha_y)
    so, co = np.hypot(wo[0], wo[1]), wo[2]
    phi_o = np.arctan2(wo[1], wo[0])

    def points(s, t):
        x = 2 * np.pi * t
        phi = np.arctan2(ay * np.sin(x), ax * np.cos(x))
        a2 = 1 / ((np.cos(phi) / ax) ** 2 + (np.sin(phi) / ay) ** 2)
        delta = np.arctan2(so * np.cos(phi - phi_o), co)
        tan2_max = np.tan((np.pi / 2 + delta) / 2) ** 2
        if dist == "ggx":
            # the rule runs in r = sqrt(1 - u) (u = 1 - r^2 in [0, u_max]): f cos / p grows like
            # 1/h.z ~ 1/r towards grazing h, which matters for grazing wo; in r it is smooth
            r_min = np.sqrt(a2 / (a2 + tan2_max))         # sqrt(1 - u_max)
            r = (1 - s) + s * r_min
            tan2 = a2 * s * (1 - r_min) * (1 + r) / r ** 2     # a^2 u / (1 - u)
            jac = 2 * r * (1 - r_min)
        else:
            # u = s u_max; 1 - u kept without cancellation
            v_max = np.exp(-tan2_max / a2)                # 1 - u_max
            u = s * (1 - v_max)
            with np.errstate(divide="ignore"):
                tan2 = -a2 * np.where(u < 0.5, np.log1p(-u), np.log((1 - s) + s * v_max))
            jac = 1 - v_max
        cos_t = 1 / np.sqrt(1 + tan2)
        sin_t = np.sqrt(tan2) * cos_t
        h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)
        return reflect(wo, h), jac

    def density(wi):
        h = normalize(wi + wo)
        with np.errstate(divide="ignore", invalid="ignore"):
            p = D(dist, h, ax, ay) * h[..., 2] / (4 * dot(wo, h))
        return np.where(wi[..., 2] > 0, p, 0.0)
    return points, density


# ---------------------------------------------------------------------------------------------
# Albedo

def albedo(model, mu, phi=0.0, tol=1e-8, strategy="lobes", **params):
    """E(wo) = integral f(wo, wi) cos_i dw_i for wo = direction(mu, phi); returns (E, err).

    strategy "lobes": each additive term of f is integrated with the map that matches it, the
    specular term with the half-vector map and kd/pi with the cosine map (a trivial partition
    of unity per term; every integrand is then smooth). "balance": all of f over both maps with
    balance-heuristic weights; in the cosine map this leaves a ring of width ~ the lobe's at
    p_h = p_cos, which the adaptive rule can miss for very narrow lobes (alpha << 0.05).
    """
    cfg = configure(model, **params)
    wo = direction(float(mu), float(phi))
    if not 0 < mu <= 1:
        raise ValueError(f"mu={mu!r}: need 0 < mu <= 1")
    cos_map = cosine_map()
    if model == "lambert":
        return hemisphere_integral(lambda wi: cfg["kd"] * INV_PI * wi[..., 2], [cos_map], tol)
    hv_map = halfvector_map(model, wo, cfg["ax"], cfg["ay"])
    kd = float(cfg["kd"])

    def spec(wi):
        return eval_specular(cfg, wo, wi) * wi[..., 2]
    if strategy == "balance":
        return hemisphere_integral(lambda wi: spec(wi) + kd * INV_PI * wi[..., 2],
                                   [cos_map, hv_map], tol)
    if strategy != "lobes":
        raise ValueError(f"strategy={strategy!r}: choose lobes or balance")
    value, err = hemisphere_integral(spec, [hv_map], tol if kd == 0 else tol / 2)
    if kd != 0:
        v, e = hemisphere_integral(lambda wi: kd * INV_PI * wi[..., 2], [cos_map], tol / 2)
        value, err = value + v, err + e
    return value, err


def albedo_avg(model, tol=1e-8, n_phi=8, **params):
    """E_avg = (1/pi) integral E(wo) cos_o dw_o; (value, err).

    Isotropic: 2 integral_0^1 E(mu) mu dmu, with mu = x^2 to grade the rule towards grazing.
    Anisotropic: also the azimuth average over [0, pi/2] (D is symmetric in x and y) by an
    n_phi-point Gauss-Legendre rule, whose error is not included in err.
    """
    cfg = configure(model, **params)
    tol_e = tol / 10

    def over_mu(phi):
        cache = {}                      # a panel's rule has the nodes of its parent's halves

        def g(x):
            if x not in cache:
                mu = x * x
                cache[x] = 4 * albedo(model, mu, phi, tol_e, **params)[0] * mu * x if mu else 0.0
            return cache[x]             # 2 E(mu) mu dmu/dx
        return adaptive_gl1(g, 0.0, 1.0, tol / 2)

    if _isotropic(cfg):
        value, err = over_mu(0.0)
        return value, err + tol_e
    xs, ws = gauss01(n_phi)
    parts = [over_mu(np.pi / 2 * xk) for xk in xs]
    return (sum(wk * v for wk, (v, _) in zip(ws, parts)),
            sum(wk * e for wk, (_, e) in zip(ws, parts)) + tol_e)


# ---------------------------------------------------------------------------------------------
# The registered references (clbrdf.ref.Reference): Lambert, and one microfacet reference for
# every distribution (Beckmann and GGX here, GTR and SGD from distributions.py, the exponential
# power from holzschuch_pacanowski.py).

from . import Reference


class LambertReference(Reference):
    def eval1(self, wo, wi, v, c):
        return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), v["kd"] * INV_PI, 0.0)

    def pdf(self, wo, wi):
        return np.where(wo[..., 2] > 0, cosine_map()[1](wi), 0.0)

    def albedo1(self, mu, phi, tol, v, c):
        return float(v["kd"]), 0.0


class MicrofacetReference(Reference):
    """f = ks F(wi.h) D(h) G(wo, wi, h) / (4 cos_i cos_o) + kd / pi (docs/models/microfacet.md). A
    subclass for another distribution overrides ``D``, ``Lambda`` and ``hv_map``."""

    def __init__(self, spec, config, params):
        super().__init__(spec, config, params)
        # G1(wo) alone (masking without shadowing) is not symmetric in (wo, wi)
        self.reciprocal = self.options.get("masking") != "unshadowed"

    def rough(self):
        return rough(self.params)

    def D(self, h):
        return D(self.name, h, *self.rough())

    def hv_map(self, wo):
        """The quadrature map of the specular lobe (``halfvector_map``)."""
        return halfvector_map(self.name, wo, *self.rough())

    def Lambda(self, w):
        return Lambda(self.name, w, *self.rough())

    def G1(self, w):
        return 1 / (1 + self.Lambda(w))

    def G(self, wo, wi, h):
        masking = self.options["masking"]
        if masking == "none":
            return np.ones(np.broadcast_shapes(wo.shape, wi.shape)[:-1])
        if masking == "vcavity":
            return G("vcavity", None, wo, wi, h, 1.0, 1.0)
        side = half_cos(wo, wi) > 0
        li, lo = self.Lambda(wi), self.Lambda(wo)
        g = (1 / ((1 + li) * (1 + lo)) if masking == "separable" else 1 / (1 + lo)
             if masking == "unshadowed" else 1 / (1 + li + lo))
        return np.where(side, g, 0.0)

    def F(self, c, v):
        """ks times the Fresnel term of the configuration at cosine c."""
        return v.get("ks", 1.0) * fresnel(self.options["fresnel"], c, v.get("f0"), v.get("eta"), v.get("k"),
                                          v.get("f90"), v.get("exponent"), v.get("f82"))

    def eval1(self, wo, wi, v, c):
        ci, co = wi[..., 2], wo[..., 2]
        valid = (ci > 0) & (co > 0)
        h = normalize(wi + wo)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = self.F(half_cos(wo, wi), v) * self.D(h) * self.G(wo, wi, h) / (4 * ci * co)
        return np.where(valid, f + v.get("kd", 0.0) * INV_PI, 0.0)

    def lobe_pdf(self, wo, wi):
        h = normalize(wi + wo)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.options["sampler"] == "vndf":
                p = np.where(half_cos(wo, wi) > 0, self.G1(wo) * self.D(h) / (4 * wo[..., 2]), 0.0)
            else:
                p = self.D(h) * h[..., 2] / (4 * half_cos(wo, wi))
        return p

    def pdf(self, wo, wi):
        """The lobe sampler, mixed with the cosine lobe with probability sum kd / (sum kd +
        sum ks F(cos_o)) (sums over channels) when there is a kd."""
        valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        p = self.lobe_pdf(wo, wi)
        if "kd" in self.params:
            chans = self.channel_values()
            kd = sum(v["kd"] for v in chans)
            fs = sum(self.F(wo[..., 2], v) for v in chans)
            s = kd + fs
            pd = np.where(s > 0, kd / np.where(s > 0, s, 1.0), 0.0)
            p = pd * wi[..., 2] * INV_PI + (1 - pd) * p
        return np.where(valid, p, 0.0)

    def albedo1(self, mu, phi, tol, v, c):
        """The specular term over ``hv_map``; the Lambertian term is kd."""
        wo = direction(mu, phi)
        hv = self.hv_map(wo)
        kd = float(v.get("kd", 0.0))

        def spec(wi):
            return (self.eval1(wo, wi, v, c) - kd * INV_PI * (wi[..., 2] > 0)) * wi[..., 2]
        e, err = hemisphere_integral(spec, [hv], tol)
        return e + kd, err


REFERENCES = {"lambert": LambertReference, "ggx": MicrofacetReference,
              "beckmann": MicrofacetReference}
