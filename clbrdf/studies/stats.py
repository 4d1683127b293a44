"""Statistics for sampler checks, shared by ``clbrdf check`` and the test suite: a quadrature
map of the hemisphere in stretched half-vector slopes, panel integrals of a density at two
orders, equal-mass bins, and Pearson's chi-square with pooling and a Sidak correction.

Nothing here calls the library's sampling code: the map is written from the geometry of
reflection (docs/models/microfacet.md), so a check that integrates a kernel pdf with it compares the
kernel against mathematics, not against itself.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.polynomial.legendre import leggauss

# Coordinates: stretched slopes (sx, sy) = (ax rho cos phi, ay rho sin phi), so that a lobe of
# roughness (ax, ay) has width ~1 in rho whatever alpha; dw_h = cos^3 theta_h dsx dsy
# = cos^3 theta_h ax ay rho drho dphi. rho = sinh(x) grades the rule towards the lobe centre and
# spreads the tail logarithmically; x runs over [0, x_max(phi)], x_max = asinh(rho_max(phi)) at
# the horizon, so (s, t) = (x / x_max(phi), phi / 2 pi) in [0, 1]^2 covers exactly the upper
# hemisphere: the horizon, where the pdf may jump to 0, is a boundary of the domain, never inside
# a quadrature panel. The integrand is smooth in (s, t).

class HalfVectorMap:
    def __init__(self, wo, ax=1.0, ay=1.0):
        self.wo = np.asarray(wo, float)
        self.ax, self.ay = float(ax), float(ay)
        self.so = math.hypot(self.wo[0], self.wo[1])
        self.co = float(self.wo[2])
        self.phio = math.atan2(self.wo[1], self.wo[0])

    def frame(self, t):
        """(azimuth of h, tan theta_h / rho, the largest x) along t: the map's part that depends
        on t only."""
        phi = 2 * np.pi * t
        c, s = np.cos(phi), np.sin(phi)
        phih = np.arctan2(self.ay * s, self.ax * c)           # azimuth of h
        a = np.hypot(self.ax * c, self.ay * s)                 # tan theta_h = a rho
        delta = np.arctan2(self.so * np.cos(phih - self.phio), self.co)
        tmax = (np.pi / 2 + delta) / 2
        xmax = np.arcsinh(np.tan(tmax) / a)
        return phih, a, xmax

    def points(self, s, t, frame=None):
        """Directions wi for (s, t) and the Jacobian dw_i / (ds dt); ``frame``: ``frame(t)``
        computed once where t repeats (a grid's rows), broadcast against s."""
        phih, a, xmax = self.frame(t) if frame is None else frame
        x = s * xmax
        rho = np.sinh(x)
        tan_t = a * rho
        cos_t = 1 / np.sqrt(1 + tan_t * tan_t)
        sin_t = tan_t * cos_t
        h = np.stack([sin_t * np.cos(phih), sin_t * np.sin(phih), cos_t], -1)
        woh = h @ self.wo
        wi = 2 * woh[..., None] * h - self.wo
        wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
        jac = 4 * woh * cos_t ** 3 * self.ax * self.ay * rho * np.cosh(x) * xmax * 2 * np.pi
        return wi, jac

    def coords(self, wi):
        """(s, t) of directions wi above the horizon (the inverse of points)."""
        h = np.asarray(wi, float) + self.wo
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        px = h[..., 0] / (h[..., 2] * self.ax)
        py = h[..., 1] / (h[..., 2] * self.ay)
        t = np.mod(np.arctan2(py, px) / (2 * np.pi), 1.0)
        _, _, xmax = self.frame(t)
        s = np.arcsinh(np.hypot(px, py)) / xmax
        return np.clip(s, 0, 1 - 1e-12), np.clip(t, 0, 1 - 1e-12)


def gl01(order):
    x, w = leggauss(order)
    return (x + 1) / 2, w / 2


def panel_integrals(hmap, pdf, ns, nt, order):
    """Integral of pdf(wi) dw_i over each of ns x nt equal panels of the (s, t) square, by an
    order x order Gauss-Legendre rule per panel. pdf: function of an (..., 3) array of wi."""
    x, w = gl01(order)
    t = ((np.arange(nt)[:, None] + x) / nt).reshape(-1)
    # a map whose directions depend on t through frame(t) (HalfVectorMap): once, not per row
    frame = hmap.frame(t) if hasattr(hmap, "frame") else None
    rows = max(1, (1 << 20) // (order * order * nt))      # panel rows per call: memory stays flat
    out = np.empty((ns, nt))
    for i0 in range(0, ns, rows):
        i1 = min(ns, i0 + rows)
        s = ((np.arange(i0, i1)[:, None] + x) / ns).reshape(-1)
        S, T = np.meshgrid(s, t, indexing="ij")
        wi, jac = hmap.points(S, T) if frame is None else hmap.points(S, T, frame)
        v = np.asarray(pdf(wi.reshape(-1, 3)), float).reshape(S.shape) * jac
        v = np.where(np.isfinite(v), v, np.nan)   # a non-finite pdf poisons the sums visibly
        out[i0:i1] = np.einsum("iajb,a,b->ij", v.reshape(i1 - i0, order, nt, order), w, w)
    return out / (ns * nt)


def sidak(alpha, k):
    """Per-test significance that keeps the family-wise error at alpha over k independent tests."""
    return 1 - (1 - alpha) ** (1 / max(1, k))


def pool_small(observed, expected, min_expected=5.0):
    """Pool bins whose expected count is below min_expected into one bin; if that pool is still
    below min_expected, merge it with the smallest remaining bins until it is not."""
    observed = np.asarray(observed, float)
    expected = np.asarray(expected, float)
    small = expected < min_expected
    if not small.any():
        return observed, expected
    po, pe = observed[small].sum(), expected[small].sum()
    o, e = observed[~small], expected[~small]
    order = np.argsort(e)
    k = 0
    while pe < min_expected and k < order.size:
        po += o[order[k]]
        pe += e[order[k]]
        k += 1
    keep = np.ones(o.size, bool)
    keep[order[:k]] = False
    return np.append(o[keep], po), np.append(e[keep], pe)


def chi2_gof(observed, expected, min_expected=5.0):
    """Pearson's chi-square of counts against expected counts (which sum to the number of
    draws), after pooling small bins. Returns (statistic, degrees of freedom, p-value). With
    one bin left (every draw below the horizon, as for exppow p = 0.1, where the pdf above it
    integrates to 1e-9) there is nothing to compare: 0 degrees of freedom, p = 1."""
    from scipy import stats as sps      # scipy.stats: 0.9 s to import, on use only
    o, e = pool_small(observed, expected, min_expected)
    stat = float(np.sum((o - e) ** 2 / e))
    dof = o.size - 1
    return stat, dof, float(sps.chi2.sf(stat, dof)) if dof > 0 else 1.0


def quantile_groups(mass, k):
    """Group consecutive cells into k groups of about equal mass (by the mid-point quantile of
    each cell): contiguous, possibly fewer than k when one cell is heavy; all in group 0 when
    the total mass is not positive."""
    c = np.cumsum(mass)
    tot = c[-1]
    if not tot > 0:
        return np.zeros(mass.size, int)
    mid = (c - mass / 2) / tot
    return np.minimum((mid * k).astype(int), k - 1)


def make_bins(P, nb_s, nb_t):
    """Bin id of each panel of P (ns x nt panel integrals): nb_t columns of equal mass in t, and
    within each column nb_s rows of equal mass in s. Bins are unions of panels, so their expected
    counts are sums of panel integrals, with no interpolation."""
    binmap = np.zeros(P.shape, int)
    col = quantile_groups(P.sum(axis=0), nb_t)
    for g in np.unique(col):
        cols = col == g
        rows = quantile_groups(P[:, cols].sum(axis=1), nb_s)
        binmap[:, cols] = (g * nb_s + rows)[:, None]
    return binmap


class MapChi2(NamedTuple):
    """Result of map_chi2. obs, exp: counts per bin, the last bin below the horizon."""
    stat: float
    dof: int
    p: float
    qerr: float         # max over bins of |E_hi - E_lo| / sqrt(max(E_hi, 5)), E at the two orders
    total: float        # integral of the pdf over the upper hemisphere (order hi)
    total_err: float    # |total at order hi - total at order lo|
    above: float        # fraction of the samples with wi.z > 0
    obs: np.ndarray
    exp: np.ndarray
    binmap: np.ndarray


def map_chi2(hmap, pdf, wi, ns=128, nt=256, orders=(4, 3), nb_s=32, nb_t=32, max_qerr=0.1,
             nonneg=True):
    """Pearson chi-square of samples wi (n x 3) against the density pdf (function of an (m, 3)
    array of wi), over bins on the (s, t) square of hmap (HalfVectorMap or any map with points
    and coords).

    The pdf is integrated over ns x nt panels by panel_integrals at orders[0] and orders[1];
    asserts the panels are finite (and >= 0 if nonneg). Bins: make_bins(P, nb_s, nb_t) of the
    orders[0] panels; expected count n x (sum of panels); one more bin for wi below the horizon,
    expecting n (1 - integral). If max_qerr is not None, asserts every bin's expected count
    agrees between the two orders to max_qerr sample standard deviations. Returns MapChi2
    (chi2_gof pools bins expecting < 5)."""
    n = len(wi)
    P = panel_integrals(hmap, pdf, ns, nt, orders[0])
    P2 = panel_integrals(hmap, pdf, ns, nt, orders[1])
    if not (np.all(np.isfinite(P)) and (not nonneg or np.all(P >= 0))):
        raise ValueError("the pdf integrates to a non-finite or negative value over some panel")
    binmap = make_bins(P, nb_s, nb_t)
    nb = int(binmap.max()) + 1
    expected = n * np.bincount(binmap.ravel(), weights=P.ravel(), minlength=nb)
    expected2 = n * np.bincount(binmap.ravel(), weights=P2.ravel(), minlength=nb)
    qerr = float(np.max(np.abs(expected - expected2) / np.sqrt(np.maximum(expected, 5))))
    if max_qerr is not None and not qerr < max_qerr:
        raise ValueError(f"expected counts not converged: {qerr:.3g} sd")
    up = wi[:, 2] > 0
    s, t = hmap.coords(wi[up])
    i_s = np.minimum((s * ns).astype(int), ns - 1)
    i_t = np.minimum((t * nt).astype(int), nt - 1)
    obs = np.append(np.bincount(binmap[i_s, i_t], minlength=nb), n - up.sum())
    exp = np.append(expected, n * max(0.0, 1 - P.sum()))
    stat, dof, p = chi2_gof(obs, exp)
    return MapChi2(stat, dof, p, qerr, P.sum(), abs(P.sum() - P2.sum()), up.mean(), obs, exp,
                   binmap)
