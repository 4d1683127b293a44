"""Measure the error of the kernels' tabulated Smith Lambda (GTR, SGD: kernels/dist_lambda.h;
exponential power: kernels/dist_exppow.h) over the whole range they serve, against direct
quadrature (clbrdf.ref.distributions.lambda_quad, clbrdf.ref.holzschuch_pacanowski.lambda_quad).

The kernel functions themselves run (gtr_Lambda, sgd_Lambda, exppow_Lambda in a small program,
double precision so that the error is the table's, not float32 rounding), at N random points
(alpha log-uniform and the shape uniform over the ranges of the models' descriptions, tan theta
log-uniform over [1e-4, 1e12], i.e. cos theta down to 1e-12, the smallest mu in double
precision) plus the corners: alpha and shape at both ends of their ranges x 40 values of
tan theta; then ``--refine`` rounds of 2000 points around the 20 worst so far (alpha and tan
theta within a factor 1.5, the shape within 5 % of its range). Prints max |G1 - G1_quad| with
where it occurs, and the 99.9th percentile of the random points.

    .venv/bin/python scripts/measure_lambda_tables.py [--n 30000] [--refine 3] [--models gtr,sgd,exppow]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
import clbrdf  # noqa: E402
from clbrdf.runtime import build
from clbrdf.ref import distributions as RD
from clbrdf.ref import holzschuch_pacanowski as HP

HEADERS = {"gtr": "dist_gtr.h", "sgd": "dist_sgd.h", "exppow": "dist_exppow.h"}
SHAPE = {"gtr": "gamma", "sgd": "p", "exppow": "p"}

SRC = """
__kernel void lam(Tables TABLES, const global real_t *A, const global real_t *S,
                  const global real_t *T, global real_t *out)
{
    size_t i = get_global_id(0);
    realN a = A[i], s = S[i], t = T[i];
    Microfacet m = {a, a, s, TABLES};
    realN c = 1 / sqrt(1 + t * t);
    out[i] = LAMBDA(m, v3(t * c, (realN)0, c));
}
"""


def kernel_lambda(model, a, s, t):
    return build.run_functions(("common.h", "rng.h", "warp.h", HEADERS[model]), SRC, "lam",
                               (a, s, t), defines=[f"#define LAMBDA {model}_Lambda"])[0]


def quad_lambda(model, a, s, t):
    if model == "exppow":
        return HP.lambda_quad(a * t, s)
    return RD.lambda_quad(model, t, a, s)


def points(model, n, seed):
    spec = clbrdf.MODELS[model]
    pa, ps = spec.param("alpha"), spec.param(SHAPE[model])
    rng = np.random.default_rng(seed)
    a = np.exp(rng.uniform(math.log(pa.lo), math.log(pa.hi), n))
    s = rng.uniform(ps.lo, ps.hi, n)
    t = np.exp(rng.uniform(math.log(1e-4), math.log(1e12), n))
    corners = [(a_, s_, t_) for a_ in (pa.lo, pa.hi) for s_ in (ps.lo, ps.hi)
               for t_ in np.geomspace(1e-4, 1e12, 40)]
    ca, cs, ct = (np.array(v) for v in zip(*corners))
    return np.r_[a, ca], np.r_[s, cs], np.r_[t, ct], (pa.lo, pa.hi), (ps.lo, ps.hi)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=30000)
    ap.add_argument("--refine", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--models", default="gtr,sgd,exppow")
    args = ap.parse_args()
    warnings.filterwarnings("ignore")
    for model in args.models.split(","):
        t0 = time.time()
        a, s, t, ar, sr = points(model, args.n, args.seed)
        def errors(a, s, t):
            k = kernel_lambda(model, a, s, t)
            q = np.array([quad_lambda(model, *x) for x in zip(a, s, t)])
            return np.abs(1 / (1 + k) - 1 / (1 + q)), q
        err, q = errors(a, s, t)
        p999 = np.quantile(err, 0.999)
        rng = np.random.default_rng(args.seed + 100)
        for _ in range(args.refine):
            top = np.argsort(err)[-20:]
            j = rng.choice(top, 2000)
            ra = np.clip(a[j] * np.exp(rng.uniform(-0.4, 0.4, j.size)), *ar)
            rs = np.clip(s[j] + rng.uniform(-0.05, 0.05, j.size) * (sr[1] - sr[0]), *sr)
            rt = np.clip(t[j] * np.exp(rng.uniform(-0.4, 0.4, j.size)), 1e-4, 1e12)
            e2, q2 = errors(ra, rs, rt)
            a, s, t = np.r_[a, ra], np.r_[s, rs], np.r_[t, rt]
            err, q = np.r_[err, e2], np.r_[q, q2]
        i = int(np.argmax(err))
        print(f"{model}: {a.size} points (alpha in [{ar[0]:g}, {ar[1]:g}], {SHAPE[model]} in "
              f"[{sr[0]:g}, {sr[1]:g}], tan theta in [1e-4, 1e12]): max |G1 - G1_quad| = "
              f"{err[i]:.2g} at alpha = {a[i]:.4g}, {SHAPE[model]} = {s[i]:.4g}, tan theta = "
              f"{t[i]:.4g} (G1 = {1 / (1 + q[i]):.6g}); 99.9th percentile of the random points "
              f"{p999:.2g}; {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
