"""Generate kernels/dist_lambda_tables.h: Smith Lambda of the GTR and SGD distributions.

Neither has a closed-form Lambda (GTR has one only for gamma = 1 and gamma = 2), so the kernel
interpolates a table of the logarithm of Lambda relative to a closed-form reference that has the
same asymptotics:

    GTR:  R = ln(Lambda_gtr / (Lambda_gtr1^(1-w) Lambda_ggx^w)), w = max(gamma - 1, 0)
          (closed forms: gamma = 1 derived in docs/models/distributions.md, gamma = 2 is GGX)
    SGD:  R = ln(Lambda_sgd(t; a, p) / Lambda_beckmann(t; sqrt(a)))  (p = 0 is Beckmann a^2 = alpha)

with t = tan theta. Both ratios tend to constants as t -> 0 and t -> inf (the tails of P22 and of
the reference agree up to a constant, or a power of t for SGD at small t where Lambda is
negligible), so R is smooth and bounded. Axes: the shape (gamma or p) linear, log2 a, and
log2(scale t) with the lobe's slope scale (GTR a; SGD the root of the mean tan^2 theta_h), all
uniform; coordinates are clamped to the grid (the a axes reach one node beyond the valid range). Interpolation (kernel and
``interp`` here, the same arithmetic): linear in shape, Catmull-Rom (cubic) in log2 a and log2 t.

Lambda at every node: ``clbrdf.ref.distributions.lambda_quad`` (adaptive quadrature, rel 1e-11).
The table's error is measured against direct quadrature at random points off the grid and
written into the header. Run: ``.venv/bin/python scripts/make_lambda_tables.py`` (about a minute).
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
from clbrdf.ref import distributions as R  # noqa: E402

# (lo, hi, step) of the axes: shape, log2 a, log2(scale t)
GRIDS = {
    "gtr": dict(s=(0.5, 4.0, 0.125), la=(-11.0, 0.0, 1.0), lt=(-16.0, 20.0, 1.0)),
    "sgd": dict(s=(0.0, 2.0, 0.125), la=(-18.0, 1.0, 1.0), lt=(-6.0, 20.0, 1.0)),
}


# the parameter ranges the models accept (the a axes extend one node beyond them)
VALID_A = {"gtr": (1e-3, 1.0), "sgd": (1e-5, 1.0)}


def axis(lo, hi, step):
    n = int(round((hi - lo) / step)) + 1
    return lo + step * np.arange(n)


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
    """The closed-form reference. GTR: Lambda_gtr1^(1-w) Lambda_ggx^w, w = max(gamma - 1, 0)
    (exact at gamma = 1 and 2). SGD: Beckmann with the same mean tan^2 theta_h."""
    t = np.asarray(t, float)
    if dist == "gtr":
        l1 = np.asarray(R.lambda_gtr1(t, a), float)
        l2 = (np.sqrt(1 + a * a * t * t) - 1) / 2
        w = max(shape - 1.0, 0.0)
        with np.errstate(divide="ignore"):
            return np.exp((1 - w) * np.log(l1) + w * np.log(l2))
    return beck_lambda(t, math.sqrt(a))


def log_ratio(dist, t, a, shape):
    if dist == "gtr" and (shape in (1.0, 2.0) or a == 1.0):
        return 0.0          # exact at gamma = 1 and 2; at a = 1 every GTR is D = 1/pi
    lam = R.lambda_quad(dist, t, a, shape)
    ref = float(lambda_ref(dist, t, a, shape))
    if lam <= 0 or ref <= 0:
        return math.nan
    return math.log(lam / ref)


def build(dist):
    g = GRIDS[dist]
    g["dist"] = dist
    S, LA, LT = axis(*g["s"]), axis(*g["la"]), axis(*g["lt"])
    T = np.empty((S.size, LA.size, LT.size))
    for i, s in enumerate(S):
        for j, la in enumerate(LA):
            a = 2.0 ** la
            sc = scale(dist, a, s)
            for k, lt in enumerate(LT):
                T[i, j, k] = log_ratio(dist, 2.0 ** lt / sc, a, s)
            # where Lambda underflows (SGD, small t) continue the last finite ratio
            row = T[i, j]
            bad = ~np.isfinite(row)
            if bad.any():
                first = np.argmax(~bad)
                row[:first] = row[first]
    return S, LA, LT, T


def _cr(p0, p1, p2, p3, f):
    """Catmull-Rom between p1 and p2."""
    return p1 + 0.5 * f * (p2 - p0 + f * (2 * p0 - 5 * p1 + 4 * p2 - p3 + f * (3 * (p1 - p2) + p3 - p0)))


def interp(grid, T, shape, a, t):
    """The kernel's interpolation of R (NumPy, scalar or arrays): linear in shape, Catmull-Rom in
    log2 a and in log2 t (end nodes repeated), clamped to the grid."""
    (s0, _, ds), (la0, _, dla), (lt0, _, dlt) = grid["s"], grid["la"], grid["lt"]
    ns, na, nt = T.shape
    xs = np.clip((np.asarray(shape, float) - s0) / ds, 0, ns - 1)
    xa = np.clip((np.log2(a) - la0) / dla, 0, na - 1)
    sc = np.vectorize(lambda a_, s_: scale(grid["dist"], a_, s_))(a, shape)
    xt = np.clip((np.log2(t * sc) - lt0) / dlt, 0, nt - 1)
    i = np.minimum(np.floor(xs), ns - 2).astype(int)
    j = np.minimum(np.floor(xa), na - 2).astype(int)
    k = np.minimum(np.floor(xt), nt - 2).astype(int)
    fs, fa, ft = xs - i, xa - j, xt - k
    ja = [np.clip(j + d, 0, na - 1) for d in (-1, 0, 1, 2)]
    kt = [np.clip(k + d, 0, nt - 1) for d in (-1, 0, 1, 2)]
    out = 0.0
    for di, wi in ((0, 1 - fs), (1, fs)):
        cols = [_cr(*[T[i + di, jj, kk] for kk in kt], ft) for jj in ja]
        out = out + wi * _cr(*cols, fa)
    return out


def lambda_table(dist, grid, T, shape, a, t):
    return np.exp(interp(grid, T, shape, a, t)) * lambda_ref(dist, t, a, shape)


def measure(dist, S, LA, LT, T, n=1500, seed=1):
    """Max error of the tabulated Lambda against quadrature at n random points: |G1| absolute
    and Lambda relative (where Lambda > 1e-6). t log-uniform over the grid plus beyond it."""
    g = GRIDS[dist]
    g["dist"] = dist
    rng = np.random.default_rng(seed)
    sh = rng.uniform(S[0], S[-1], n)
    la = rng.uniform(math.log2(VALID_A[dist][0]), math.log2(VALID_A[dist][1]), n)
    lt = rng.uniform(-8, 21, n)          # t = tan theta from 0.004 to 2e6 (cos 5e-7)
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
    return worst_g, worst_rel, where


def _c_float(v):
    s = f"{float(v):.8g}"
    return s + (".0f" if s.lstrip("-").isdigit() else "f")


def c_array(name, T):
    vals = T.reshape(-1)
    lines = []
    for i in range(0, vals.size, 8):
        lines.append("    " + ", ".join(_c_float(v) for v in vals[i:i + 8]) + ",")
    return f"__constant float {name}[{vals.size}] = {{\n" + "\n".join(lines) + "\n};\n"


def main():
    import warnings
    from scipy.integrate import IntegrationWarning
    # quad's round-off notices at rel 1e-11; its accuracy is checked against closed forms in
    # tests/test_distributions.py::test_lambda_quadrature_matches_closed_forms
    warnings.filterwarnings("ignore", category=IntegrationWarning)
    warnings.filterwarnings("ignore", category=RuntimeWarning)
    out = ["/* Generated by scripts/make_lambda_tables.py: do not edit.",
           " *",
           " * R = ln(Lambda / Lambda_ref) on uniform axes (shape, log2 a, log2(scale t)), t = tan theta;",
           " * GTR: Lambda_ref = Lambda_gtr1^(1-w) Lambda_ggx^w, w = max(gamma - 1, 0), scale = a;",
           " * SGD: Lambda_ref = Beckmann with alpha_b = sqrt(a), scale = sqrt(mean tan^2 theta_h).",
           " * Interpolation: linear in shape, Catmull-Rom in log2 a and log2 t; clamped at the ends.",
           " * Error against direct quadrature (clbrdf.ref.distributions.lambda_quad) at random",
           " * off-grid points, t also beyond the grid:"]
    body = []
    for dist in ("gtr", "sgd"):
        t0 = time.time()
        S, LA, LT, T = build(dist)
        eg, er, where = measure(dist, S, LA, LT, T)
        print(f"{dist}: table {T.shape} in {time.time() - t0:.0f} s; max |G1 error| {eg:.2e}, "
              f"max relative Lambda error {er:.2e} (worst G1 at shape, a, t, Lambda, table = {where})")
        g = GRIDS[dist]
        up = dist.upper()
        out.append(f" *   {dist}: max |G1 - G1_quad| = {eg:.1e}, max |Lambda/Lambda_quad - 1| = {er:.1e}"
                   f" (1500 points)")
        body.append(f"#define {up}_LT_NS {S.size}\n#define {up}_LT_NA {LA.size}\n#define {up}_LT_NT {LT.size}\n"
                    f"#define {up}_LT_S0 {S[0]:.9g}\n#define {up}_LT_DS {g['s'][2]:.9g}\n"
                    f"#define {up}_LT_LA0 {LA[0]:.9g}\n#define {up}_LT_DLA {g['la'][2]:.9g}\n"
                    f"#define {up}_LT_LT0 {LT[0]:.9g}\n#define {up}_LT_DLT {g['lt'][2]:.9g}\n")
        body.append(c_array(f"{dist}_lambda_table", T.astype(np.float32)))
    out.append(" */\n#ifndef CLBRDF_DIST_LAMBDA_TABLES_H\n#define CLBRDF_DIST_LAMBDA_TABLES_H\n")
    text = "\n".join(out) + "\n" + "\n".join(body) + "\n#endif\n"
    (ROOT / "kernels" / "dist_lambda_tables.h").write_text(text)
    print("wrote kernels/dist_lambda_tables.h")


if __name__ == "__main__":
    main()
