"""Multiple scattering between microfacets by a random walk on the microsurface (Heitz, Hanika,
d'Eon & Dachsbacher 2016, "Multiple-scattering microfacet BSDFs with the Smith model"), in
float64 NumPy, one walk per array element: the reference of energy compensation.

The microsurface is the Smith model's: heights uniform in [-1, 1] (C1(h) = (h + 1) / 2), slopes
of the GGX or Beckmann distribution (alpha_x, alpha_y). A walk starts above the surface going
down along -wo (the paper's wi is our wo: the direction the light leaves toward), and repeats
(the paper's Algorithm 1 and section 4):

- the next height: along a direction w of Lambda(w) (Lambda(-w) = -1 - Lambda(w) for w going
  down), the ray from height h0 leaves without hitting with probability G1(w, h0) = C1(h0)^Lambda
  (w going up; 0 going down); else it hits at h = C1^-1(C1(h0) / (1 - U)^(1 / Lambda)) (eq 12-14);
- at a hit, a normal m from the visible normals of the reversed ray -w, valid for -w on either
  side (GGX: spherical caps, Dupuy & Benyoub 2023; Beckmann: the visible-slope CDF of Heitz &
  d'Eon 2014 inverted by bisection), the reflection about m, and the throughput times
  F(-w . m).

Where it leaves, the walk's direction is wi and its throughput the weight: the mean weight is the
directional albedo of the multiple-scattering BRDF, the weights of the walks that left after k
hits that of the k-th order (k = 1 is the single-scattering BRDF with height-correlated masking
G2 = 1 / (1 + Lambda(wo) + Lambda(wi)), the paper's section 4.3). A walk still on the surface after
``max_order`` hits is cut: its energy is lost and counted (``lost``).
"""
from __future__ import annotations

import numpy as np
from scipy.special import erf, erfc, erfinv

from .microfacet import D as D_, fresnel

H_START = 1.0 + 1e-4        # above the highest microfacet (heights in [-1, 1])


def _lambda(dist, w, ax, ay):
    """Smith Lambda of direction w for either sign of w.z: Lambda(-w) = -1 - Lambda(w)."""
    z = w[..., 2]
    s2 = (ax * w[..., 0]) ** 2 + (ay * w[..., 1]) ** 2          # alpha^2 sin^2 theta
    up = np.abs(z)
    with np.errstate(divide="ignore", invalid="ignore"):
        if dist == "ggx":
            lam = 0.5 * (np.sqrt(1 + s2 / (up * up)) - 1)
        elif dist == "beckmann":
            a = up / np.sqrt(s2)
            lam = 0.5 * (erf(a) - 1) + np.exp(-a * a) / (2 * a * np.sqrt(np.pi))
        else:
            raise ValueError(f"dist={dist!r}: ggx or beckmann")
    lam = np.where(s2 == 0, 0.0, lam)
    return np.where(z >= 0, lam, -1 - lam)


def _next_height(dist, w, h0, u, ax, ay):
    """Height of the next hit along w from h0, or +inf where the ray leaves (eq 12-14)."""
    z = w[..., 2]
    c0 = (np.clip(h0, -1, 1) + 1) / 2
    lam = _lambda(dist, w, ax, ay)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        g1 = np.where(z > 0, c0 ** lam, 0.0)                    # leaves without a hit
        c = c0 / (1 - u) ** (1 / lam)
        h = 2 * np.clip(c, 0, 1) - 1
    leave = (z >= 0) & (u > 1 - g1)
    return np.where(leave, np.inf, h)


def _vndf(wv, u1, u2, ax, ay):
    """A normal m of GGX's visible normals of wv (either side), by spherical caps (Dupuy &
    Benyoub 2023)."""
    v = np.stack([ax * wv[..., 0], ay * wv[..., 1], wv[..., 2]], -1)
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    phi = 2 * np.pi * u1
    cz = (1 - u2) * (1 + v[..., 2]) - v[..., 2]                 # uniform in (-v.z, 1]
    sz = np.sqrt(np.clip(1 - cz * cz, 0, None))
    c = np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], -1)
    h = v + c
    m = np.stack([ax * h[..., 0], ay * h[..., 1], np.maximum(h[..., 2], 0)], -1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def _vndf_beckmann(wv, u1, u2, ax, ay):
    """A normal m of Beckmann's visible normals of wv, either side. In the stretched frame
    (alpha 1) with wv at polar angle theta, the visible slopes have the density
    max(0, cot theta - x) P2(x) P2(y), P2(x) = exp(-x^2) / sqrt(pi) (Heitz & d'Eon 2014, whose
    form holds for theta up to pi: cot theta < 0 keeps the slopes facing a wv below the
    horizon); x inverts the CDF G(x) / G(c), G(x) = c erfc(-x) / 2 + exp(-x^2) / (2 sqrt(pi)),
    c = cot theta, by bisection; y = erfinv(2 u2 - 1). cot theta is held above -25 (wv within
    2.3 degrees of straight down, where G(c) underflows; such rays almost never hit)."""
    s = np.stack([ax * wv[..., 0], ay * wv[..., 1], wv[..., 2]], -1)
    s /= np.linalg.norm(s, axis=-1, keepdims=True)
    sin_t = np.hypot(s[..., 0], s[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.clip(np.where(sin_t > 0, s[..., 2] / sin_t, np.inf), -25.0, 1e8)
    G = lambda x: c * erfc(-x) / 2 + np.exp(-x * x) / (2 * np.sqrt(np.pi))   # noqa: E731
    target = u1 * G(c)
    lo, hi = np.minimum(c, 0.0) - 30.0, np.minimum(c, 30.0)
    for _ in range(90):
        mid = (lo + hi) / 2
        below = G(mid) < target
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    x = (lo + hi) / 2
    y = erfinv(2 * u2 - 1)
    phi = np.arctan2(s[..., 1], s[..., 0])
    cp, sp = np.cos(phi), np.sin(phi)
    tx, ty = ax * (cp * x - sp * y), ay * (sp * x + cp * y)
    m = np.stack([-tx, -ty, np.ones_like(tx)], -1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def _normal(dist, wv, u1, u2, ax, ay):
    """A visible normal of wv (either side) for the distribution."""
    return (_vndf if dist == "ggx" else _vndf_beckmann)(wv, u1, u2, ax, ay)


def _advance(dist, w, h0, u0, order, max_order, ax, ay):
    """The next height of each walk and which ones stop: (h, left, over), left where the ray
    leaves the surface, over where it hits again beyond max_order (cut)."""
    h = _next_height(dist, w, h0, u0, ax, ay)
    left = ~np.isfinite(h)
    return h, left, ~left & (order >= max_order)


def walk(wo, n, *, dist="ggx", alpha_x=0.5, alpha_y=None, max_order=64, seed=0,
         fresnel_kind="one", **fresnel_params):
    """n random walks from wo (a unit vector above the surface): (wi, weight, order, lost), wi
    the direction each leaves along ((n, 3), NaN where cut), weight its throughput (0 where
    cut), order its number of hits, lost the number of walks cut at max_order."""
    return _walk(wo, n, None, dist, alpha_x, alpha_y, max_order, seed, fresnel_kind,
                 fresnel_params)[:4]


def evaluate(wo, wi, n, *, dist="ggx", alpha_x=0.5, alpha_y=None, max_order=64, seed=0,
             fresnel_kind="one", **fresnel_params):
    """The paper's stochastic evaluation (its section 4.2, next-event estimation): n walks from
    wo, each adding at every hit k the throughput before it times F(v.m) p(v -> wi) G1(wi, h_k),
    v the reversed ray, m = normalize(v + wi), the phase function p = D(m) / (4 A(v)) (v.m > 0;
    A(v) = v.z (1 + Lambda(v)), the projected area, for v on either side) and G1(wi, h) =
    C1(h)^Lambda(wi) the chance that wi leaves from height h. Returns (n, 3) per-walk estimates of
    f(wo, wi) cos(theta_i) by the order of the hit (1, 2, 3 and more): unbiased, their mean over
    walks is the BRDF times the cosine, their spread its noise."""
    return _walk(wo, n, np.asarray(wi, float), dist, alpha_x, alpha_y, max_order, seed,
                 fresnel_kind, fresnel_params)[4]


def _walk(wo, n, toward, dist, alpha_x, alpha_y, max_order, seed, fresnel_kind, fresnel_params):
    ay = alpha_x if alpha_y is None else alpha_y
    ax = alpha_x
    rng = np.random.default_rng(seed)
    w = np.broadcast_to(-np.asarray(wo, float), (n, 3)).copy()
    h = np.full(n, H_START)
    weight = np.ones(n)
    order = np.zeros(n, dtype=np.int64)
    alive = np.ones(n, dtype=bool)
    cut = np.zeros(n, dtype=bool)
    nee = np.zeros((n, 3))
    if toward is not None:
        lam_i = _lambda(dist, toward[None, :], ax, ay)[0]
    while alive.any():
        idx = np.flatnonzero(alive)
        u = rng.random((idx.size, 3))
        hn, left, over = _advance(dist, w[idx], h[idx], u[:, 0], order[idx], max_order, ax, ay)
        alive[idx[left | over]] = False                         # left: w is wi
        cut[idx[over]] = True
        on = ~(left | over)
        go, uk = idx[on], u[on]
        h[go] = hn[on]
        order[go] += 1
        wv = -w[go]
        if toward is not None:                                  # next-event estimation
            mh = wv + toward
            mh /= np.linalg.norm(mh, axis=-1, keepdims=True)
            vm = np.einsum("ij,ij->i", wv, mh)
            area = wv[:, 2] * (1 + _lambda(dist, wv, ax, ay))
            with np.errstate(divide="ignore", invalid="ignore"):
                p = np.where((vm > 0) & (mh[:, 2] > 0),
                             D_(dist, mh, ax, ay) / (4 * area), 0.0)
                g1 = ((np.clip(h[go], -1, 1) + 1) / 2) ** lam_i
            c = weight[go] * fresnel(fresnel_kind, np.clip(vm, 0, 1), **fresnel_params) * p * g1
            nee[go, np.minimum(order[go], 3) - 1] += np.where(np.isfinite(c), c, 0.0)
        m = _normal(dist, wv, uk[:, 1], uk[:, 2], ax, ay)
        c = np.einsum("ij,ij->i", wv, m)
        weight[go] *= fresnel(fresnel_kind, c, **fresnel_params)
        w[go] = -wv + 2 * c[:, None] * m
    w[cut] = np.nan
    weight[cut] = 0.0
    return w, weight, order, int(np.count_nonzero(cut)), nee


def _refract(wi, m, eta):
    """The refraction of wi (pointing away from the interface, on m's side) through the facet
    m into a medium of relative index eta, as a unit vector; total reflection is excluded by
    the caller (F = 1 there)."""
    eta = np.asarray(eta, float)
    c = np.einsum("ij,ij->i", wi, m)
    ct = -np.sqrt(np.maximum(1 - (1 - c * c) / (eta * eta), 0))
    t = m * (c / eta + ct)[:, None] - wi / eta[..., None]
    return t / np.linalg.norm(t, axis=-1, keepdims=True)


def walk_dielectric(wo, n, *, dist="ggx", alpha_x=0.5, alpha_y=None, eta=1.5, max_order=64,
                    seed=0):
    """n random walks on a rough dielectric interface (the paper's section 5): from above, eta
    the index below relative to above. At each hit, the normal from the visible normals of the
    reversed ray on its own side (the microsurface seen from below is the mirror image, heights
    negated), then reflection with probability F (the exact dielectric Fresnel of the side's
    relative index) or refraction to the other side. Returns (wi, side, order, lost): the
    direction each walk leaves along (z > 0 reflected, z < 0 transmitted), +1 / -1 for the side
    it leaves on, its number of hits, the number cut at max_order (wi NaN, side 0). Every
    weight is 1 (energy: the Fresnel picks the branch)."""
    ay = alpha_x if alpha_y is None else alpha_y
    ax = alpha_x
    rng = np.random.default_rng(seed)
    w = np.broadcast_to(-np.asarray(wo, float), (n, 3)).copy()
    h = np.full(n, H_START)
    outside = np.ones(n, dtype=bool)
    order = np.zeros(n, dtype=np.int64)
    alive = np.ones(n, dtype=bool)
    cut = np.zeros(n, dtype=bool)
    flip = np.array([1.0, 1.0, -1.0])
    while alive.any():
        idx = np.flatnonzero(alive)
        u = rng.random((idx.size, 4))
        out_i = outside[idx]
        # from below: the mirror-image microsurface (z and heights negated)
        wl = np.where(out_i[:, None], w[idx], w[idx] * flip)
        hl = np.where(out_i, h[idx], -h[idx])
        hn, left, over = _advance(dist, wl, hl, u[:, 0], order[idx], max_order, ax, ay)
        alive[idx[left | over]] = False
        cut[idx[over]] = True
        on = ~(left | over)
        go, uk, ok = idx[on], u[on], out_i[on]
        h[go] = np.where(ok, hn[on], -hn[on])
        order[go] += 1
        wv = -np.where(ok[:, None], w[go], w[go] * flip)         # in the side's own frame
        m = _normal(dist, wv, uk[:, 1], uk[:, 2], ax, ay)
        e = np.where(ok, eta, 1 / eta)
        c = np.einsum("ij,ij->i", wv, m)
        F = fresnel("dielectric", c, eta=e)
        refl = uk[:, 3] < F
        new = np.where(refl[:, None], -wv + 2 * c[:, None] * m, _refract(wv, m, e))
        w[go] = np.where(ok[:, None], new, new * flip)          # back to the fixed frame
        outside[go] = np.where(refl, ok, ~ok)
    w[cut] = np.nan
    side = np.where(cut, 0, np.where(outside, 1, -1))
    return w, side, order, int(np.count_nonzero(cut))

