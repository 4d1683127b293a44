"""Double-precision NumPy reference for the clbrdf models, and a deterministic albedo integrator.

Written from the equations in ``shared/MODELS.md`` ("Conventions", "1. Building blocks"),
independently of the OpenCL kernels, so that the kernels can be tested against it. Everything is
float64 and broadcasts: directions are arrays of shape (..., 3) in the local frame (normal z,
tangent x); ``wi`` points towards the light, ``wo`` towards the viewer, both away from the
surface. Parameters broadcast against the leading (...) shape of the directions.

Models: ``lambert`` (f = kd/pi) and the microfacet models ``beckmann`` and ``ggx``:

    f = F(wi.h) D(h) G(wi, wo, h) / (4 cos_i cos_o) + kd/pi,    h = normalize(wi + wo).

Parameters: ``alpha`` or ``alpha_x``/``alpha_y``, ``f0``, ``eta``, ``k``, ``kd``; options:
``masking`` (none, vcavity, separable, correlated), ``fresnel`` (one, schlick, dielectric,
conductor), ``lobe_sampler`` (ndf, vndf). When ``fresnel`` is not given it follows the Fresnel
parameters given, as the model specs do: eta and k -> conductor, eta -> dielectric,
f0 -> schlick, none -> one. A parameter that the configuration does not use is an error.

The integrator (``albedo``, ``albedo_avg``, ``hemisphere_integral``) is deterministic:
Gauss-Legendre product rules on adaptively split panels over quadrature maps from [0,1]^2 to
directions, combined with balance-heuristic weights (see ``hemisphere_integral``).
"""
import warnings

import numpy as np
from numpy.polynomial.legendre import leggauss
from scipy import special

INV_PI = 1 / np.pi

MODELS = ("lambert", "beckmann", "ggx")
DISTRIBUTIONS = ("beckmann", "ggx")
MASKINGS = ("none", "vcavity", "separable", "correlated")
FRESNELS = ("one", "schlick", "dielectric", "conductor")
LOBE_SAMPLERS = ("ndf", "vndf")
SAMPLERS = ("uniform", "cosine", "ndf", "vndf", "brdf", "mis")

DEFAULTS = {"alpha": 0.5, "f0": 0.04, "eta": 1.5, "k": 3.0}
FRESNEL_PARAMS = {"one": (), "schlick": ("f0",), "dielectric": ("eta",), "conductor": ("eta", "k")}


# ---------------------------------------------------------------------------------------------
# Vector helpers

def _vec(w):
    return np.asarray(w, dtype=np.float64)


def dot(a, b):
    return np.sum(a * b, axis=-1)


def normalize(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / n


def reflect(wo, h):
    """Mirror wo about h: 2 (wo.h) h - wo."""
    return 2 * dot(wo, h)[..., None] * h - wo


def spherical(theta, phi):
    """Unit vector with polar angle theta and azimuth phi (arrays broadcast)."""
    s = np.sin(theta)
    return np.stack(np.broadcast_arrays(s * np.cos(phi), s * np.sin(phi), np.cos(theta)), -1)


# ---------------------------------------------------------------------------------------------
# Building blocks (MODELS.md section 1)

def D(dist, h, alpha_x, alpha_y):
    """Distribution of normals, integral D(h) (h.n) dw_h = 1; 0 for h.z <= 0.

    Slopes (tx, ty) = (-h.x/h.z, -h.y/h.z), e = tx^2/ax^2 + ty^2/ay^2:
    Beckmann exp(-e) / (pi ax ay cos^4), GGX 1 / (pi ax ay cos^4 (1 + e)^2).
    """
    h = normalize(_vec(h))
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
    w = normalize(_vec(w))
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


def G(masking, dist, wi, wo, h, alpha_x, alpha_y):
    """Masking-shadowing term for the given option."""
    wi, wo, h = _vec(wi), _vec(wo), _vec(h)
    shape = np.broadcast_shapes(wi.shape, wo.shape, h.shape)[:-1]
    if masking == "none":
        return np.ones(shape)
    if masking == "vcavity":                              # Cook-Torrance 1982
        nh, c = h[..., 2], dot(wo, h)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.minimum(1, np.minimum(2 * nh * wo[..., 2] / c, 2 * nh * wi[..., 2] / c))
        return np.where(c > 0, g, 0.0)
    side = (dot(wi, h) > 0) & (dot(wo, h) > 0)
    li = Lambda(dist, wi, alpha_x, alpha_y)
    lo = Lambda(dist, wo, alpha_x, alpha_y)
    if masking == "separable":
        g = 1 / ((1 + li) * (1 + lo))
    elif masking == "correlated":
        g = 1 / (1 + li + lo)
    else:
        raise ValueError(f"unknown masking {masking!r}; choose one of {MASKINGS}")
    return np.where(side, g, 0.0)


def fresnel(kind, c, f0=None, eta=None, k=None):
    """Unpolarised Fresnel reflectance at cos(angle) c (c = wi.h)."""
    c = np.asarray(c, float)
    if kind == "one":
        return np.ones_like(c)
    if kind == "schlick":
        return f0 + (1 - f0) * (1 - c) ** 5
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
                else "schlick" if "f0" in kw else "one")
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
    if kw:
        raise TypeError(f"parameters {sorted(kw)} are not used by {model} with fresnel={kind}")
    return cfg


def _fresnel(cfg, c):
    return fresnel(cfg["fresnel"], c, cfg.get("f0"), cfg.get("eta"), cfg.get("k"))


def _isotropic(cfg):
    return "ax" not in cfg or bool(np.all(cfg["ax"] == cfg["ay"]))


# ---------------------------------------------------------------------------------------------
# BRDF value

def eval_specular(cfg, wi, wo):
    """Microfacet term F D G / (4 cos_i cos_o); 0 outside the upper hemisphere."""
    wi, wo = _vec(wi), _vec(wo)
    ci, co = wi[..., 2], wo[..., 2]
    valid = (ci > 0) & (co > 0)
    h = normalize(wi + wo)
    f = (_fresnel(cfg, dot(wi, h)) * D(cfg["dist"], h, cfg["ax"], cfg["ay"])
         * G(cfg["masking"], cfg["dist"], wi, wo, h, cfg["ax"], cfg["ay"]))
    with np.errstate(divide="ignore", invalid="ignore"):
        f = f / (4 * ci * co)
    return np.where(valid, f, 0.0)


def eval(model, wi, wo, **params):
    """BRDF value f(wi, wo) in 1/sr; 0 when wi.z <= 0 or wo.z <= 0."""
    cfg = configure(model, **params)
    wi, wo = _vec(wi), _vec(wo)
    valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    f = cfg["kd"] * INV_PI
    if model != "lambert":
        f = f + eval_specular(cfg, wi, wo)
    return np.where(valid, f, 0.0)


# ---------------------------------------------------------------------------------------------
# Sampling densities (solid angle, of wi given wo)

def pdf_ndf(cfg, wo, wi):
    """Normals sampled with density D(h) (n.h), reflected: D(h) h.z / (4 |wo.h|)."""
    h = normalize(wi + wo)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = D(cfg["dist"], h, cfg["ax"], cfg["ay"]) * h[..., 2] / (4 * np.abs(dot(wo, h)))
    return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), p, 0.0)


def pdf_vndf(cfg, wo, wi):
    """Visible normals G1(wo) max(0, wo.h) D(h) / cos_o, reflected: / (4 wo.h)."""
    h = normalize(wi + wo)
    co = wo[..., 2]
    valid = (wi[..., 2] > 0) & (co > 0) & (dot(wo, h) > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = G1(cfg["dist"], wo, cfg["ax"], cfg["ay"]) * D(cfg["dist"], h, cfg["ax"], cfg["ay"]) / (4 * co)
    return np.where(valid, p, 0.0)


def pdf(model, wo, wi, sampler="brdf", **params):
    """Solid-angle density of wi for the given sampler; 0 when wi.z <= 0 or wo.z <= 0.

    brdf for microfacets: with probability p_d = kd / (kd + F(cos_o)) the cosine lobe, else the
    lobe sampler (ndf or vndf). mis: 0.5 pdf_brdf + 0.5 pdf_cosine.
    """
    cfg = configure(model, **params)
    wo, wi = _vec(wo), _vec(wi)
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
# Quadrature maps: [0,1]^2 -> upper hemisphere
#
# A map is a pair of functions (points, density):
#   points(s, t) -> (wi, jac): the direction for (s, t) in [0,1]^2 and |du/d(s,t)|, the Jacobian
#       from (s, t) to the map's own unit square u, on which wi has solid-angle density p;
#   density(wi) -> p(wi), the same density at any wi (needed by the balance heuristic).

def cosine_map():
    """Cosine-weighted hemisphere: sin^2 theta = s, phi = 2 pi t; p = cos_i / pi."""
    def points(s, t):
        r, phi = np.sqrt(s), 2 * np.pi * t
        wi = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - s)], -1)
        return wi, np.ones_like(s)

    def density(wi):
        return np.maximum(wi[..., 2], 0) * INV_PI
    return points, density


def halfvector_map(dist, wo, alpha_x, alpha_y):
    """Half vectors by inverting the NDF's CDF, reflected: wi = reflect(wo, h).

    Azimuth: tan phi_h = (ay/ax) tan(2 pi t) on the branch of 2 pi t. Given phi_h the slope
    tan^2 theta_h = a^2 u/(1-u) (GGX) or -a^2 log(1-u) (Beckmann), 1/a^2 = cos^2/ax^2 + sin^2/ay^2.
    u runs over [0, u_max(phi_h)] only, u_max where wi reaches the horizon: with wo at polar angle
    theta_o and azimuth phi_o, wi.z = R cos(2 theta_h - delta), tan delta = tan theta_o cos(phi_h
    - phi_o), so theta_max = (pi/2 + delta)/2. Density p(wi) = D(h) h.z / (4 wo.h).
    """
    wo = _vec(wo)
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
# Adaptive tensor Gauss-Legendre on [0,1]^2

def _rule(n):
    x, w = leggauss(n)
    return (x + 1) / 2, w / 2


def _panel_sums(func, s0, s1, t0, t1, x, w):
    """Gauss-Legendre product rule on each panel [s0,s1] x [t0,t1] (arrays of panels)."""
    ds, dt = (s1 - s0)[:, None], (t1 - t0)[:, None]
    s = s0[:, None] + ds * x                     # (P, n)
    t = t0[:, None] + dt * x
    S = np.broadcast_to(s[:, :, None], s.shape + (len(x),))
    T = np.broadcast_to(t[:, None, :], S.shape)
    v = func(S.ravel(), T.ravel()).reshape(S.shape)
    return np.einsum("pij,i,j->p", v, w, w) * (ds * dt)[:, 0]


def _panels(func, s0, s1, t0, t1, x, w):
    """Estimate and error per panel: the n x n rule I0 against the rule on the panel halved in
    s (Is) and halved in t (It). The estimate is Is + It - I0 (both refinements), the error
    es + et, with es = |Is - I0| and et = |It - I0| the errors in s and in t."""
    sm, tm = (s0 + s1) / 2, (t0 + t1) / 2
    i0 = _panel_sums(func, s0, s1, t0, t1, x, w)
    i_s = _panel_sums(func, s0, sm, t0, t1, x, w) + _panel_sums(func, sm, s1, t0, t1, x, w)
    i_t = _panel_sums(func, s0, s1, t0, tm, x, w) + _panel_sums(func, s0, s1, tm, t1, x, w)
    return i_s + i_t - i0, np.abs(i_s - i0), np.abs(i_t - i0)


def graded_edges(levels=30):
    """Panel edges on [0,1] graded geometrically towards both ends: 0, 2^-levels, ..., 1/4,
    1/2, 3/4, ..., 1 - 2^-levels, 1. Features attached to an end at any scale down to 2^-levels
    (a lobe's tail squeezed against the horizon, a kink near it) then fall on small panels,
    where the error estimates see them."""
    g = 2.0 ** -np.arange(levels, 1, -1)
    return np.concatenate([[0], g, [0.25, 0.5, 0.75], 1 - g[::-1], [1]])


def adaptive_gl2(func, tol=1e-8, n=6, s_edges=None, t_edges=None, max_evals=5e7):
    """Integral of func(s, t) over [0,1]^2 by n x n Gauss-Legendre panels, and an error estimate.

    The initial panels are s_edges x t_edges (default: ``graded_edges()`` and eighths x 32 equal
    panels). The estimates only see what the nodes see: a feature that falls between all the
    nodes of a panel (a sliver where vcavity's min(1, ...) drops below 1) is missed, so the
    initial grid is kept fine.
    Globally adaptive: while the panels' errors (see ``_panels``) sum to more than tol, the
    panels with the largest errors, enough that the others sum to at most tol/2, are split in
    the variable(s) whose error dominates. The returned error is that sum: on every panel two
    successive refinements agree within its share.
    """
    x, w = _rule(n)
    if s_edges is None:
        s_edges = np.union1d(graded_edges(), np.linspace(0, 1, 9))
    if t_edges is None:
        t_edges = np.linspace(0, 1, 33)
    S0, T0 = np.meshgrid(s_edges[:-1], t_edges[:-1], indexing="ij")
    S1, T1 = np.meshgrid(s_edges[1:], t_edges[1:], indexing="ij")
    s0, s1, t0, t1 = S0.ravel(), S1.ravel(), T0.ravel(), T1.ravel()
    val, es, et = _panels(func, s0, s1, t0, t1, x, w)
    evals = 5 * n * n * s0.size
    while True:
        e = es + et
        total = np.sum(e)
        if total <= tol:
            break
        if evals > max_evals:
            warnings.warn(f"adaptive_gl2: stopped after {evals} evaluations with error "
                          f"{total:.3g} > tol {tol:.3g}", RuntimeWarning, stacklevel=2)
            break
        order = np.argsort(-e)
        rest = total - np.cumsum(e[order])          # error left if the first k+1 are split
        k = np.searchsorted(-rest, -tol / 2) + 1    # first k with rest <= tol/2
        split, keep = order[:k], order[k:]
        ps, pt = s1[split] - s0[split], t1[split] - t0[split]
        ns = 1 + (es[split] >= et[split] / 4)
        nt = 1 + (et[split] >= es[split] / 4)
        # children of each split panel: 1 x 2, 2 x 1 or 2 x 2
        reps = ns * nt
        idx = np.repeat(np.arange(split.size), reps)
        c = np.arange(idx.size) - np.repeat(np.cumsum(reps) - reps, reps)
        cs, ct = c % ns[idx], c // ns[idx]
        ws, wt = ps[idx] / ns[idx], pt[idx] / nt[idx]
        c0 = s0[split][idx] + cs * ws
        d0 = t0[split][idx] + ct * wt
        cv, ces, cet = _panels(func, c0, c0 + ws, d0, d0 + wt, x, w)
        evals += 5 * n * n * c0.size
        s0, s1 = np.concatenate([s0[keep], c0]), np.concatenate([s1[keep], c0 + ws])
        t0, t1 = np.concatenate([t0[keep], d0]), np.concatenate([t1[keep], d0 + wt])
        val = np.concatenate([val[keep], cv])
        es, et = np.concatenate([es[keep], ces]), np.concatenate([et[keep], cet])
    return np.sum(val), np.sum(es + et)


def hemisphere_integral(integrand, maps, tol=1e-8, weights=None, **kw):
    """Integral of integrand(wi) over the upper hemisphere by balance-heuristic quadrature maps.

    With maps k of densities p_k and weights c_k (default 1) the weights c_k p_k / sum_j c_j p_j
    are a partition of unity, so

        integral g dw = sum_k integral_[0,1]^2 g(wi_k(u)) c_k / sum_j c_j p_j(wi_k(u)) du.

    Each map's integral runs on ``adaptive_gl2`` with its share of tol. Returns (value, err).
    """
    c = np.ones(len(maps)) if weights is None else np.asarray(weights, float)
    value = err = 0.0
    for k, (points, _) in enumerate(maps):
        if c[k] == 0:
            continue

        def func(s, t, points=points, ck=c[k]):
            wi, jac = points(s, t)
            p = sum(cj * dens(wi) for cj, (_, dens) in zip(c, maps) if cj != 0)
            g = integrand(wi)
            with np.errstate(divide="ignore", invalid="ignore"):
                r = g * ck * jac / p
            return np.where((p > 0) & (wi[..., 2] > 0), r, 0.0)
        v, e = adaptive_gl2(func, tol / np.count_nonzero(c), **kw)
        value += v
        err += e
    return value, err


# ---------------------------------------------------------------------------------------------
# Albedo

def direction(mu, phi=0.0):
    """Unit vector with cos theta = mu and azimuth phi."""
    s = np.sqrt(1 - mu * mu)
    return np.array([s * np.cos(phi), s * np.sin(phi), mu], float)


def albedo(model, mu, phi=0.0, tol=1e-8, strategy="lobes", **params):
    """E(wo) = integral f(wi, wo) cos_i dw_i for wo = direction(mu, phi); returns (E, err).

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
        return eval_specular(cfg, wi, wo) * wi[..., 2]
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


def _adaptive_gl1(func, a, b, tol, n=8, max_panels=200):
    """Integral of a scalar function over [a, b] by n-point Gauss-Legendre panels; (value, err).

    A panel's estimate is its two halves' sum, its error the difference from the whole-panel
    rule. Globally adaptive: the panel with the largest error is bisected until the errors sum
    to at most tol (noise of order tol/10 in func, as from an inner quadrature, is tolerated).
    """
    x, w = _rule(n)

    def panel(lo, hi):
        mid = (lo + hi) / 2
        q0, q1, q2 = (sum(wk * func(l + (h - l) * xk) for xk, wk in zip(x, w)) * (h - l)
                      for l, h in ((lo, hi), (lo, mid), (mid, hi)))
        return [abs(q1 + q2 - q0), q1 + q2, lo, hi]
    panels = [panel(a, b)]
    while sum(p[0] for p in panels) > tol and len(panels) < max_panels:
        panels.sort()
        _, _, lo, hi = panels.pop()
        panels += [panel(lo, (lo + hi) / 2), panel((lo + hi) / 2, hi)]
    return sum(p[1] for p in panels), sum(p[0] for p in panels)


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
        return _adaptive_gl1(g, 0.0, 1.0, tol / 2)

    if _isotropic(cfg):
        value, err = over_mu(0.0)
        return value, err + tol_e
    xs, ws = _rule(n_phi)
    parts = [over_mu(np.pi / 2 * xk) for xk in xs]
    return (sum(wk * v for wk, (v, _) in zip(ws, parts)),
            sum(wk * e for wk, (_, e) in zip(ws, parts)) + tol_e)
