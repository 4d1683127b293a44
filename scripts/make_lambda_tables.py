"""Generate kernels/dist_lambda_tables.h (layout) and kernels/data/{gtr,sgd}_lambda.npy (values):
Smith Lambda of the GTR and SGD distributions.

Neither has a closed-form Lambda (GTR has one only for gamma = 1 and gamma = 2), so the kernel
interpolates a table of the logarithm of Lambda relative to a closed-form reference that has the
same asymptotics:

    GTR:  R = ln(Lambda_gtr / (Lambda_gtr1^(1-w) Lambda_ggx^w)), w = gamma - 1
          (closed forms: gamma = 1 derived in docs/models/distributions.md, gamma = 2 is GGX;
          w is extrapolated linearly outside [1, 2] so that the reference is smooth in gamma)
    SGD:  R = ln(Lambda_sgd(t; a, p) / Lambda_beckmann(t; sqrt(a)))  (p = 0 is Beckmann a^2 = alpha)

with t = tan theta. Both ratios tend to constants as t -> 0 and t -> inf (the tails of P22 and of
the reference agree up to a constant, or a power of t for SGD at small t where Lambda is
negligible), so R is smooth and bounded, and the clamped table continues those constants: the
asymptotes at both ends are the reference's closed forms times a tabulated constant. Axes, all
uniform: the shape (gamma step 0.1, p step 1/16), u = log2 a + KA a (step 1/2; KA = 2 for GTR:
finer steps in a near 1, where the family collapses onto D = 1/pi; KA = 0 for SGD) and
log2(scale t) (step 1/2) with the lobe's slope scale (GTR a; SGD the root of the mean
tan^2 theta_h). Every axis has a ghost node beyond the valid range on each side (the distributions are defined there), so that the cubic stencil is
never one-sided inside the range; coordinates are clamped to the grid. Interpolation (kernel and
``interp`` here, the same arithmetic): Catmull-Rom (cubic) in all three coordinates (64 nodes).
The exact special cases stay exact: GTR gamma = 2 and SGD p = 0 are nodes whose R is 0 (at a node
Catmull-Rom returns the node's value exactly), and the kernel uses the closed form at gamma = 1.

Previous version (linear in the shape, step 1 in log2 a and log2 t, w = max(gamma - 1, 0) with its
kink at gamma = 1): max |G1 error| 4.6e-3 (GTR), 2.2e-3 (SGD).

Lambda at every node: ``clbrdf.ref.distributions.lambda_quad`` (adaptive quadrature, rel 1e-11).
The table's error (of the float32 table as the kernel reads it, interpolated here in float64) is
measured against direct quadrature at 1500 random points off the grid plus 120 on the edges of
the parameter ranges (``measure_points``), printed and written into the header.
Run: ``.venv/bin/python scripts/make_lambda_tables.py`` (about 40 s; deterministic: the header is
reproduced byte for byte). Sizes (this version): GTR 38 x 28 x 73 floats (303 kB), SGD
35 x 39 x 53 (283 kB). This script's own 1620 points found max |G1 - G1_quad| 8.8e-5 and 5.5e-5;
that is not the tables' bound: over the whole served range they reach 1.9e-4 and 7.9e-5, and the
documented bounds are 2e-4 and 1e-4 (scripts/measure_lambda_tables.py, docs/models/distributions.md).
"""
from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy import special

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from clbrdf.ref import distributions as R

# axes: shape node i = sref + (i - sidx) / ids, i = 0 .. ns - 1 (written so that the kernel's
# coordinate (shape - sref) ids + sidx is exact at the special nodes: GTR gamma = 1, 2 and SGD
# p = 0); (lo, hi, step) of u = log2 a + ka a and of log2(scale t)
GRIDS = {
    "gtr": dict(s=(0.5, 1, 10.0, 38), la=(-11.0, 2.5, 0.5), lt=(-16.0, 20.0, 0.5), ka=2.0),
    "sgd": dict(s=(0.0, 1, 16.0, 35), la=(-18.0, 1.0, 0.5), lt=(-6.0, 20.0, 0.5), ka=0.0),
}
VALID_S = {"gtr": (0.5, 4.0), "sgd": (0.0, 2.0)}


# the parameter ranges the models accept (the a axes extend one node beyond them)
VALID_A = {"gtr": (1e-3, 0.999), "sgd": (1e-5, 1.0)}


def shape_axis(sref, sidx, ids, ns):
    return sref + (np.arange(ns) - sidx) / ids


def axis(lo, hi, step):
    n = int(round((hi - lo) / step)) + 1
    return lo + step * np.arange(n)


def a_coord(dist, a):
    """The a axis coordinate u = log2 a + ka a."""
    return math.log2(a) + GRIDS[dist]["ka"] * a


def a_of_coord(dist, u):
    """Inverse of a_coord (Newton in l = log2 a from l = u, monotone convex: converges)."""
    ka = GRIDS[dist]["ka"]
    l = u
    for _ in range(100):
        f = l + ka * 2.0 ** l - u
        l_new = l - f / (1 + ka * math.log(2) * 2.0 ** l)
        if l_new == l:
            break
        l = l_new
    return 2.0 ** l


def beck_lambda(t, ab):
    m = 1 / (ab * np.asarray(t, float))
    return (np.exp(-m * m) / (m * math.sqrt(math.pi)) - special.erfc(m)) / 2


def sgd_alpha_b2(a, p):
    """a^2 of the Beckmann reference of SGD: the mean of tan^2 theta_h,
    a (E[y] - a), E[y] = 1 - p + a^(1-p) e^-a / Gamma(1-p, a)."""
    return a * (1 - p + a ** (1 - p) * math.exp(-a) / R.upper_gamma(1 - p, a) - a)


def scale(dist, a, shape):
    """Slope scale: the t axis of the table is log2(scale t), so that the lobe's transition
    stays at the same column for every a. GTR: a; SGD: sqrt of the mean tan^2 theta_h."""
    if dist == "gtr":
        return a
    return math.sqrt(sgd_alpha_b2(a, shape))


def lambda_ref(dist, t, a, shape):
    """The closed-form reference. GTR: Lambda_gtr1^(1-w) Lambda_ggx^w, w = gamma - 1
    (exact at gamma = 1 and 2). SGD: Beckmann with the same mean tan^2 theta_h."""
    t = np.asarray(t, float)
    if dist == "gtr":
        l2 = (np.sqrt(1 + a * a * t * t) - 1) / 2
        if a == 1.0:
            return l2          # every GTR is D = 1/pi there
        l1 = np.asarray(R.lambda_gtr1(t, a), float)
        w = shape - 1.0
        with np.errstate(divide="ignore"):
            return np.exp((1 - w) * np.log(l1) + w * np.log(l2))
    return beck_lambda(t, math.sqrt(a))


def log_ratio(dist, t, a, shape):
    if dist == "gtr" and (shape in (1.0, 2.0) or a == 1.0):
        return 0.0          # exact at gamma = 1 and 2; at a = 1 every GTR is D = 1/pi
    if dist == "sgd" and shape == 0.0:
        return 0.0          # p = 0: P22 = e^(-x/a) / (pi a), Beckmann with alpha_b^2 = a
    lam = R.lambda_quad(dist, t, a, shape)
    ref = float(lambda_ref(dist, t, a, shape))
    if lam <= 0 or ref <= 0:
        return math.nan
    return math.log(lam / ref)


def build(dist):
    g = GRIDS[dist]
    g["dist"] = dist
    S, LA, LT = shape_axis(*g["s"]), axis(*g["la"]), axis(*g["lt"])
    T = np.empty((S.size, LA.size, LT.size))
    for i, s in enumerate(S):
        for j, la in enumerate(LA):
            a = a_of_coord(dist, la)
            sc = scale(dist, a, s)
            for k, lt in enumerate(LT):
                T[i, j, k] = log_ratio(dist, 2.0 ** lt / sc, a, s)
            # where Lambda underflows (SGD, small t) continue the last finite ratio
            row = T[i, j]
            bad = ~np.isfinite(row)
            if bad.any():
                good = np.flatnonzero(~bad)
                row[:good[0]] = row[good[0]]
                row[good[-1] + 1:] = row[good[-1]]
    return S, LA, LT, T


def _cr(p0, p1, p2, p3, f):
    """Catmull-Rom between p1 and p2."""
    return p1 + 0.5 * f * (p2 - p0 + f * (2 * p0 - 5 * p1 + 4 * p2 - p3 + f * (3 * (p1 - p2) + p3 - p0)))


def interp(grid, T, shape, a, t):
    """The kernel's interpolation of R (NumPy, scalar or arrays): Catmull-Rom in the shape, in
    u = log2 a + ka a and in log2 t (end nodes repeated), clamped to the grid."""
    (sref, sidx, ids, _), (la0, _, dla), (lt0, _, dlt) = grid["s"], grid["la"], grid["lt"]
    ns, na, nt = T.shape
    xs = np.clip((np.asarray(shape, float) - sref) * ids + sidx, 0, ns - 1)
    xa = np.clip((np.log2(a) + grid["ka"] * np.asarray(a, float) - la0) / dla, 0, na - 1)
    sc = np.vectorize(lambda a_, s_: scale(grid["dist"], a_, s_))(a, shape)
    xt = np.clip((np.log2(t * sc) - lt0) / dlt, 0, nt - 1)
    i = np.minimum(np.floor(xs), ns - 2).astype(int)
    j = np.minimum(np.floor(xa), na - 2).astype(int)
    k = np.minimum(np.floor(xt), nt - 2).astype(int)
    fs, fa, ft = xs - i, xa - j, xt - k
    si = [np.clip(i + d, 0, ns - 1) for d in (-1, 0, 1, 2)]
    ja = [np.clip(j + d, 0, na - 1) for d in (-1, 0, 1, 2)]
    kt = [np.clip(k + d, 0, nt - 1) for d in (-1, 0, 1, 2)]
    planes = []
    for ii in si:
        cols = [_cr(*[T[ii, jj, kk] for kk in kt], ft) for jj in ja]
        planes.append(_cr(*cols, fa))
    return _cr(*planes, fs)


def lambda_table(dist, grid, T, shape, a, t):
    return np.exp(interp(grid, T, shape, a, t)) * lambda_ref(dist, t, a, shape)


def measure_points(dist, n=1500, seed=1):
    """n random points (shape uniform, log a uniform over the valid ranges, t = tan theta
    log-uniform from 0.004 to 2e6, i.e. cos theta down to 5e-7) plus the edges: every
    combination of shape in {lo, hi}, a in {lo, hi} and 30 values of t over the same range."""
    rng = np.random.default_rng(seed)
    sh = rng.uniform(*VALID_S[dist], n)
    la = rng.uniform(math.log2(VALID_A[dist][0]), math.log2(VALID_A[dist][1]), n)
    lt = rng.uniform(-8, 21, n)
    edges = [(s_, math.log2(a_), l_) for s_ in VALID_S[dist] for a_ in VALID_A[dist]
             for l_ in np.linspace(-8, 21, 30)]
    es, ea, et = (np.array(v) for v in zip(*edges))
    return np.r_[sh, es], np.r_[la, ea], np.r_[lt, et]


def measure(dist, S, LA, LT, T, n=1500, seed=1):
    """Max error of the tabulated Lambda against quadrature at the points of measure_points:
    |G1| absolute and Lambda relative (where Lambda > 1e-6)."""
    g = GRIDS[dist]
    g["dist"] = dist
    sh, la, lt = measure_points(dist, n, seed)
    worst_g, worst_rel, where = 0.0, 0.0, None
    for s, l_a, l_t in zip(sh, la, lt):
        a, t = 2.0 ** l_a, 2.0 ** l_t
        lam = R.lambda_quad(dist, t, a, s)
        tab = float(lambda_table(dist, g, T, s, a, t))
        eg = abs(1 / (1 + lam) - 1 / (1 + tab))
        if eg > worst_g:
            worst_g, where = eg, (float(s), a, t, lam, tab)
        if lam > 1e-6:
            worst_rel = max(worst_rel, abs(tab / lam - 1))
    return worst_g, worst_rel, where, sh.size


def main():
    import warnings
    from scipy.integrate import IntegrationWarning
    # quad's round-off notices at rel 1e-11; its accuracy is checked against closed forms in
    # tests/models/test_distributions.py::test_lambda_quadrature_matches_closed_forms
    warnings.filterwarnings("ignore", category=IntegrationWarning)
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    out = ["/* Generated by scripts/make_lambda_tables.py: do not edit.",
           " *",
           " * R = ln(Lambda / Lambda_ref) on uniform axes (shape, log2 a + KA a, log2(scale t)),",
           " * t = tan theta; GTR: Lambda_ref = Lambda_gtr1^(1-w) Lambda_ggx^w, w = gamma - 1, scale = a;",
           " * SGD: Lambda_ref = Beckmann with alpha_b = sqrt(a), scale = sqrt(mean tan^2 theta_h).",
           " * Interpolation: Catmull-Rom in all three coordinates; clamped at the ends.",
           " * Error against direct quadrature (clbrdf.ref.distributions.lambda_quad) at 1500 random",
           " * off-grid points and 120 on the edges of the parameter ranges, t = tan theta from 0.004",
           " * to 2e6 (also beyond the grid); G1 = 1 / (1 + Lambda):"]
    body = []
    for dist in ("gtr", "sgd"):
        t0 = time.time()
        S, LA, LT, T = build(dist)
        eg, er, where, npts = measure(dist, S, LA, LT, T.astype(np.float32).astype(np.float64))
        print(f"{dist}: table {T.shape} = {T.size} floats ({4 * T.size / 1024:.0f} kB) in "
              f"{time.time() - t0:.0f} s; {npts} points: max |G1 error| {eg:.2e}, "
              f"max relative Lambda error {er:.2e} (worst G1 at shape, a, t, Lambda, table = {where})")
        g = GRIDS[dist]
        up = dist.upper()
        out.append(f" *   {dist}: max |G1 - G1_quad| = {eg:.1e}, max |Lambda/Lambda_quad - 1| = {er:.1e}"
                   f" ({npts} points)")
        body.append(f"#define {up}_LT_NS {S.size}\n#define {up}_LT_NA {LA.size}\n#define {up}_LT_NT {LT.size}\n"
                    f"#define {up}_LT_SREF {g['s'][0]:.9g}\n#define {up}_LT_SIDX {g['s'][1]}\n"
                    f"#define {up}_LT_IDS {g['s'][2]:.9g}\n"
                    f"#define {up}_LT_LA0 {LA[0]:.9g}\n#define {up}_LT_DLA {g['la'][2]:.9g}\n"
                    f"#define {up}_LT_KA {g['ka']:.9g}\n"
                    f"#define {up}_LT_LT0 {LT[0]:.9g}\n#define {up}_LT_DLT {g['lt'][2]:.9g}\n")
        np.save(ROOT / "kernels" / "data" / f"{dist}_lambda.npy", T.astype(np.float32).reshape(-1))
    out += [" * Over the whole served range (scripts/measure_lambda_tables.py): see docs/models/distributions.md.",
            " * Values (float32, row-major (shape, a, t)): kernels/data/gtr_lambda.npy and sgd_lambda.npy,",
            " * passed to the kernels in the tables buffer (clbrdf/runtime/build.py) at TABLE_gtr_lambda and",
            " * TABLE_sgd_lambda."]
    out.append(" */\n#ifndef CLBRDF_DIST_LAMBDA_TABLES_H\n#define CLBRDF_DIST_LAMBDA_TABLES_H\n")
    text = "\n".join(out) + "\n" + "\n".join(body) + "\n#endif\n"
    (ROOT / "kernels" / "dist_lambda_tables.h").write_text(text)
    print("wrote kernels/dist_lambda_tables.h, kernels/data/gtr_lambda.npy, kernels/data/sgd_lambda.npy")


if __name__ == "__main__":
    main()
