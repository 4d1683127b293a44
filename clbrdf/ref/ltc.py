"""float64 reference of linearly transformed cosines (Heitz, Dupuy, Hill & Neubelt 2016), written
without the kernel (kernels/ltc.h): the density by its Jacobian (eq. 2-3) and the polygon
integral by explicit clipping of the vertex list (Sutherland-Hodgman) and the arc-cosine edge
sum (eq. 11), where the kernel uses a branch-free form. Matrices are (..., 3, 3), row-major as
NumPy's; directions (..., 3)."""
from __future__ import annotations

import numpy as np


def ltc_eval(minv, w):
    """D(w) = D_o(w_o) dw_o/dw with w_o = M^-1 w / |M^-1 w|, D_o = max(z, 0) / pi, and the
    Jacobian |det M^-1| / |M^-1 w|^3 (unit w)."""
    minv = np.asarray(minv, float)
    w = np.asarray(w, float)
    v = np.einsum("...ij,...j->...i", minv, w)
    lv = np.linalg.norm(v, axis=-1)
    wo = v / lv[..., None]
    jac = np.abs(np.linalg.det(minv)) / lv ** 3
    return np.maximum(wo[..., 2], 0) / np.pi * jac


def ltc_sample(m, u0, u1):
    """Directions distributed as D: cosine-weighted directions of (u0, u1) through m."""
    r, phi = np.sqrt(u0), 2 * np.pi * np.asarray(u1, float)
    wo = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u0)], axis=-1)
    w = np.einsum("...ij,...j->...i", np.asarray(m, float), wo)
    return w / np.linalg.norm(w, axis=-1, keepdims=True)


def clip_to_horizon(poly):
    """The polygon (k, 3) clipped to z >= 0 (Sutherland-Hodgman), as a vertex list."""
    out = []
    k = len(poly)
    for i in range(k):
        a, b = poly[i], poly[(i + 1) % k]
        if a[2] >= 0:
            out.append(a)
        if (a[2] >= 0) != (b[2] >= 0):
            t = a[2] / (a[2] - b[2])
            x = a + (b - a) * t
            x[2] = 0.0
            out.append(x)
    return np.array(out).reshape(-1, 3)


def polygon_cosine(poly):
    """(1 / 2 pi) sum over the edges of the clipped polygon of acos(a.b) (a x b).z / |a x b|
    (a, b normalised): the clamped cosine's integral over its solid angle, signed by winding
    (positive counter-clockwise about +z)."""
    p = clip_to_horizon(np.asarray(poly, float))
    if len(p) < 3:
        return 0.0
    p = p / np.linalg.norm(p, axis=1, keepdims=True)
    s = 0.0
    for i in range(len(p)):
        a, b = p[i], p[(i + 1) % len(p)]
        c = np.cross(a, b)
        n = np.linalg.norm(c)
        if n > 0:
            s += np.arccos(np.clip(a @ b, -1, 1)) * c[2] / n
    return s / (2 * np.pi)


def ltc_polygon(minv, poly):
    """The integral of D over the polygon (k, 3): the cosine's over M^-1 P (eq. 10)."""
    return polygon_cosine(np.asarray(poly, float) @ np.asarray(minv, float).T)


def ltc_polygon_mc(minv, m, poly, n=1 << 20, rng=None):
    """The same by Monte Carlo: the fraction of n samples of D that fall inside the polygon
    (signed by its winding), and its standard error; the independent check of both forms."""
    rng = np.random.default_rng(0) if rng is None else rng
    u = rng.random((n, 2))
    w = ltc_sample(m, u[:, 0], u[:, 1])
    inside = inside_polygon(w, np.asarray(poly, float))
    p = inside.mean()
    sign = np.sign(polygon_cosine(poly @ np.asarray(minv, float).T) or 1.0)
    return sign * p, np.sqrt(p * (1 - p) / n)


def inside_polygon(w, poly):
    """Whether the rays w (n, 3) from the origin pass through the convex planar polygon."""
    nrm = np.cross(poly[1] - poly[0], poly[2] - poly[0])
    d = nrm @ poly[0]
    t = d / (w @ nrm)
    x = w * t[:, None]
    ok = t > 0
    s = None
    for i in range(len(poly)):
        a, b = poly[i], poly[(i + 1) % len(poly)]
        side = np.cross(b - a, x - a) @ nrm
        s = side >= 0 if s is None else s & (side >= 0)
        s2 = side <= 0 if i == 0 else s2 & (side <= 0)
    return ok & (s | s2)
