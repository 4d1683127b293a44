"""Deterministic quadrature over the hemisphere: the independent integrator of the references.

Gauss-Legendre product rules on adaptively split panels of [0,1]^2 (``adaptive_gl2``), mapped to
directions by quadrature maps and combined with balance-heuristic weights
(``hemisphere_integral``); a one-dimensional rule (``adaptive_gl1``); vector helpers. Every
reference in ``clbrdf/ref/`` integrates its model with these. float64 NumPy throughout;
directions are arrays of shape (..., 3) in the local frame (normal z).
"""
import warnings

import numpy as np
from numpy.polynomial.legendre import leggauss

INV_PI = 1 / np.pi

# ---------------------------------------------------------------------------------------------
# Vector helpers

def as_float64(w):
    return np.asarray(w, dtype=np.float64)


def dot(a, b):
    return np.sum(a * b, axis=-1)


def half_cos(wo, wi):
    """wo.h = wi.h for h = normalize(wi + wo): |wi + wo| / 2 (the dot product with the rounded,
    normalised sum is off by the sum's rounding at grazing near-mirror pairs, sign included)."""
    return 0.5 * np.linalg.norm(np.asarray(wi) + np.asarray(wo), axis=-1)


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


# ---------------------------------------------------------------------------------------------
# Adaptive tensor Gauss-Legendre on [0,1]^2

def gauss01(n):
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
    x, w = gauss01(n)
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
# Albedo helpers

def direction(mu, phi=0.0):
    """Unit vector with cos theta = mu and azimuth phi."""
    s = np.sqrt(1 - mu * mu)
    return np.array([s * np.cos(phi), s * np.sin(phi), mu], float)


def adaptive_gl1(func, a, b, tol, n=8, max_panels=200):
    """Integral of a scalar function over [a, b] by n-point Gauss-Legendre panels; (value, err).

    A panel's estimate is its two halves' sum, its error the difference from the whole-panel
    rule. Globally adaptive: the panel with the largest error is bisected until the errors sum
    to at most tol (noise of order tol/10 in func, as from an inner quadrature, is tolerated).
    """
    x, w = gauss01(n)

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
