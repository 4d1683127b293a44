"""GTR and SGD with Smith masking (correlated and separable): Monte Carlo albedo of the kernels
(their tabulated Lambda, kernels/dist_lambda_tables.h) against a deterministic reference in which
Lambda comes from direct quadrature (clbrdf.ref.distributions.lambda_quad).

The reference albedo needs Lambda at every node of the hemisphere rule; quadrature there would be
slow, so per (model, alpha, shape) Lambda is computed by quadrature at N_NODES values of
tan theta (log-spaced over [1e-3, 1e5]) and interpolated by a cubic spline of log(1 + Lambda) in
log tan theta (beyond: Lambda ~ t^2 below, log(1 + Lambda) ~ log t + const above). This
interpolant is independent of the kernel's table; its own G1 error is measured against
quadrature at the midpoints between nodes and asserted below REF_G1_ERR.

Error budget of |E_mc - E_ref|: 4 standard errors of the Monte Carlo estimate + the quadrature
error of the hemisphere rule + the effect of the G1 errors (table and reference interpolant) on
the albedo: with |dG1| <= d for both directions, |dG2| <= 2 d for both the correlated form
1 / (1 + Lambda_i + Lambda_o) (dG2 = G2^2 (dG1_i / G1_i^2 + dG1_o / G1_o^2), G2 <= G1) and the
separable G1_i G1_o, so |dE| <= 2 d E_none (E_none: the albedo without masking).
The configurations are those where the previous tables' G1 error (up to 2e-3) was largest: with
2^21 samples the previous tables fail this test (see docs/models/distributions.md).
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

import clbrdf
from clbrdf.ref import microfacet as REF
from clbrdf.ref import distributions as RD

ROOT = Path(__file__).resolve().parents[2]

# The documented bound of max |G1 - G1_quad| of the kernels' tables over the whole range they
# serve (docs/models/distributions.md): scripts/measure_lambda_tables.py measured 1.9e-4 (GTR,
# at alpha = 1e-3, gamma 1.32, tan theta 191) and 7.9e-5 (SGD, alpha 0.93, p = 2) at 36160 points,
# the kernels in double precision, cos theta down to 1e-12; the generator's own 1620 points had
# found 8.8e-5 and 5.5e-5 (the bound was 1e-4 for both until then). Exp-power: 7.8e-6.
TABLE_G1_ERR = {"gtr": 2e-4, "sgd": 1e-4, "exppow": 1e-5}
REF_G1_ERR = 2e-6          # the reference interpolant's bound (asserted per configuration)
N_NODES = 321
SAMPLES = 1 << 23
MUS = np.array([0.1, 0.35])

CASES = [("gtr", dict(alpha=0.6, gamma=0.5)), ("gtr", dict(alpha=0.6, gamma=1.5)),
         ("gtr", dict(alpha=0.3, gamma=3.0)),
         ("sgd", dict(alpha=0.01, p=0.3)), ("sgd", dict(alpha=0.2, p=1.2)),
         ("sgd", dict(alpha=0.2, p=1.8))]


def cid(model, kw):
    return model + "-" + "-".join(f"{k}{v:g}" for k, v in kw.items())


def shape_of(model, kw):
    return kw["gamma"] if model == "gtr" else kw["p"]


def lambda_interp(model, alpha, shape):
    """Lambda(w) of unit directions from the spline of log(1 + Lambda_quad) in log tan theta, and
    the spline's max G1 error at the midpoints between its nodes."""
    lt = np.linspace(math.log(1e-3), math.log(1e5), N_NODES)
    L = np.array([math.log1p(RD.lambda_quad(model, math.exp(x), alpha, shape)) for x in lt])
    sp = CubicSpline(lt, L)
    mid = 0.5 * (lt[1:] + lt[:-1])
    exact = np.array([1 / (1 + RD.lambda_quad(model, math.exp(x), alpha, shape)) for x in mid])
    err = float(np.max(np.abs(np.exp(-sp(mid)) - exact)))

    def lam(w):
        w = np.asarray(w, float)
        z = w[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.log(np.hypot(w[..., 0], w[..., 1]) / z)
        xc = np.clip(np.nan_to_num(x, nan=lt[0], neginf=lt[0], posinf=lt[-1]), lt[0], lt[-1])
        v = sp(xc)
        v = np.where(x < lt[0], L[0] * np.exp(2 * (x - lt[0])), v)          # Lambda ~ t^2
        v = np.where(x > lt[-1], L[-1] + (x - lt[-1]), v)                   # Lambda ~ c t
        return np.where(z > 0, np.expm1(v), np.inf)
    return lam, err


def ref_albedo(model, kw, mu, masking, lam, tol=1e-7):
    """E(mu) = integral D G / (4 cos_i cos_o) cos_i dw_i (F = 1) over the half-vector map of
    clbrdf.ref.distributions.albedo, with G from ``lam``; (value, err)."""
    a, s = kw["alpha"], shape_of(model, kw)
    wo = REF.direction(float(mu), 0.0)
    if model == "gtr":
        hv = REF.halfvector_map("ggx", wo, a, a)
    else:
        hv = REF.halfvector_map("beckmann", wo, math.sqrt(a), math.sqrt(a))
    lo = float(lam(wo))

    def integrand(wi):
        h = wi + wo
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        f = RD.D(model, h, a, s)
        if masking != "none":
            li = lam(wi)
            f = f * (1 / (1 + li + lo) if masking == "correlated" else 1 / ((1 + li) * (1 + lo)))
        with np.errstate(divide="ignore", invalid="ignore"):
            f = f / (4 * wi[..., 2] * wo[2]) * wi[..., 2]
        return np.where(wi[..., 2] > 0, f, 0.0)
    return REF.hemisphere_integral(integrand, [hv], tol)


def test_stated_table_error():
    """The header states (scripts/make_lambda_tables.py measured) errors within TABLE_G1_ERR."""
    text = (ROOT / "kernels" / "dist_lambda_tables.h").read_text()
    for model, bound in TABLE_G1_ERR.items():
        if model == "exppow":
            continue
        m = re.search(rf"{model}: max \|G1 - G1_quad\| = ([0-9.e+-]+)", text)
        assert m, model
        assert float(m.group(1)) <= bound, (model, m.group(1), bound)


def _measure():
    import importlib.util
    spec = importlib.util.spec_from_file_location("measure_lambda_tables",
                                                  ROOT / "scripts" / "measure_lambda_tables.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# the worst points found by scripts/measure_lambda_tables.py (alpha, shape, tan theta)
WORST = {"gtr": [(1e-3, 1.322, 190.7), (1.363e-3, 1.525, 563.5), (1.077e-3, 1.432, 519.3)],
         "sgd": [(0.9345, 2.0, 3.325), (0.3651, 1.993, 9.192), (1.0, 2.0, 3.257)],
         "exppow": [(2.285, 4.975, 0.4437), (0.4247, 4.982, 2.46)]}


@pytest.mark.parametrize("model", ["gtr", "sgd", "exppow"])
def test_table_error_within_bound_over_the_served_range(model):
    """The kernels' tabulated Lambda (double precision) against quadrature, |dG1| <= the documented
    bound, at 400 random points over the whole served range (alpha, shape from the model's
    description; tan theta in [1e-4, 1e12]), its corners and the worst points the measurement
    found. With the old bound 1e-4 GTR fails (1.9e-4 at its worst point)."""
    M = _measure()
    a, s, t, _, _ = M.points(model, 400, seed=5)
    w = np.array(WORST[model])
    a, s, t = np.r_[a, w[:, 0]], np.r_[s, w[:, 1]], np.r_[t, w[:, 2]]
    k = M.kernel_lambda(model, a, s, t)
    q = np.array([M.quad_lambda(model, *x) for x in zip(a, s, t)])
    err = np.abs(1 / (1 + k) - 1 / (1 + q))
    i = int(np.argmax(err))
    assert err[i] <= TABLE_G1_ERR[model], (model, err[i], a[i], s[i], t[i])


@pytest.fixture(scope="module")
def references():
    cache = {}

    def get(model, kw):
        key = cid(model, kw)
        if key not in cache:
            lam, err = lambda_interp(model, kw["alpha"], shape_of(model, kw))
            assert err <= REF_G1_ERR, (key, err)
            out = {}
            for masking in ("none", "correlated", "separable"):
                out[masking] = [ref_albedo(model, kw, mu, masking, lam) for mu in MUS]
            cache[key] = out
        return cache[key]
    return get


@pytest.mark.parametrize("masking", ["correlated", pytest.param("separable", marks=pytest.mark.slow)])
@pytest.mark.parametrize("model,kw", [pytest.param(m, k, id=cid(m, k), marks=[] if i in (1, 4) else
                                                   [pytest.mark.slow])
                                      for i, (m, k) in enumerate(CASES)])
def test_albedo_with_masking(model, kw, masking, references, model_cache):
    """BRDF-sampled Monte Carlo albedo (2^21 samples, F = 1) of the kernel with the tabulated
    Lambda, against the reference with quadrature Lambda (see the module docstring)."""
    ref = references(model, kw)
    e_ref = np.array([v for v, _ in ref[masking]])
    e_none = np.array([v for v, _ in ref["none"]])
    q_err = np.array([e for _, e in ref[masking]])
    m = model_cache(model, masking=masking, **kw)
    r = clbrdf.albedo(m, MUS, estimator="brdf", samples=SAMPLES, seed=12)
    g_err = 2 * (TABLE_G1_ERR[model] + REF_G1_ERR) * e_none
    tol = 4 * r.stderr + q_err + g_err + 1e-6
    assert np.all(np.abs(r.albedo - e_ref) <= tol), (r.albedo, e_ref, r.stderr, g_err)
