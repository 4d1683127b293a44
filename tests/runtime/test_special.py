"""kernels/special.h: the inverse regularised incomplete gamma function against SciPy.

The kernel is run through a small test program (common.h + special.h + a batch kernel), in
single and double precision, at widths 1 and 16, on shapes a in [0.2, 10] (the exponential-power
shape 1/p for p in [0.1, 5]) and probabilities over the whole open unit interval: both tails,
down to 1e-30 (lower) and 1e-300 / 1e-16 (upper, double), and 2^-24 in single precision (the
smallest number the generator produces). Reference: scipy.special.gammaincinv (p <= 1/2) and
gammainccinv (q < 1/2), given the same p, q as the kernel.

Measured (2 x 20000 points like these): max relative error of x 1.2e-13 (double), 1.2e-5 (single; log p
carries |log p| eps and x ~ p^(1/a) multiplies that by 1/a <= 5).
"""
import numpy as np
import pytest
from scipy import special as sp

from clbrdf.runtime import build

SRC = """
__kernel void ginv(const global real_t *A, const global real_t *Pr, const global real_t *Qr,
                   global real_t *out, global real_t *lp, global real_t *lq)
{
    size_t i = get_global_id(0) * W;
    realN a = VLOAD(A + i), p = VLOAD(Pr + i), q = VLOAD(Qr + i);
    VSTORE(gammaincinv_pq(a, p, q), out + i);
    realN x = VLOAD(out + i), P, Q;
    gamma_log_pq(a, x, lgamma(a), &P, &Q);
    VSTORE(P, lp + i);
    VSTORE(Q, lq + i);
}
"""

TOL = {"double": 1e-12, "single": 2e-5}


def run(a, p, q, precision, width):
    return build.run_functions(("common.h", "special.h"), SRC, "ginv", (a, p, q), 3,
                               precision=precision, width=width)


def points(precision, n=4000, seed=7):
    """Shapes log-uniform on [0.2, 10] (and the ends), tail probabilities log-uniform down to
    the precision's floor, half of them lower tails (p given), half upper (q given)."""
    rng = np.random.default_rng(seed)
    a = np.exp(rng.uniform(np.log(0.2), np.log(10), n))
    a[:40] = np.repeat([0.2, 10.0], 20)
    floor_lo, floor_up = (-30, -300) if precision == "double" else (np.log10(2.0 ** -24),) * 2
    e = rng.uniform(0, 1, n)
    lower = rng.random(n) < 0.5
    t = 10 ** np.where(lower, floor_lo * e, floor_up * e) * 0.5      # tail probability <= 1/2
    dt = np.float64 if precision == "double" else np.float32
    t = t.astype(dt).astype(np.float64)                             # representable inputs
    a = a.astype(dt).astype(np.float64)
    p = np.where(lower, t, 1 - t)
    q = np.where(lower, 1 - t, t)
    p, q = p.astype(dt).astype(np.float64), q.astype(dt).astype(np.float64)
    ref = np.where(lower, sp.gammaincinv(a, p), sp.gammainccinv(a, q))
    return a, p, q, ref, lower


@pytest.mark.parametrize("width", [1, 16])
@pytest.mark.parametrize("precision", ["single", "double"])
def test_inverse_matches_scipy(precision, width):
    a, p, q, ref, lower = points(precision)
    x, _, _ = run(a, p, q, precision, width)
    # single: skip points whose answer is not a normal float (x < 1e-37: a <= 0.3 and p < 1e-6)
    ok = ref > (1e-300 if precision == "double" else 1e-37)
    assert ok.sum() > 0.9 * ok.size
    assert np.all(np.isfinite(x))
    err = np.abs(x[ok] - ref[ok]) / ref[ok]
    i = np.argmax(err)
    assert err.max() < TOL[precision], \
        f"max rel err {err.max():.3g} at a={a[ok][i]}, p={p[ok][i]}, q={q[ok][i]}: {x[ok][i]} vs {ref[ok][i]}"
    # both tails are represented, deep into each
    assert p[lower].min() < (1e-29 if precision == "double" else 1e-7)
    assert q[~lower].min() < (1e-299 if precision == "double" else 1e-7)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_log_p_q_match_scipy(precision):
    """The forward functions at the kernel's own roots: log P and log Q against SciPy's."""
    a, p, q, ref, lower = points(precision, n=2000, seed=3)
    x, lP, lQ = run(a, p, q, precision, 16)
    ok = ref > (1e-300 if precision == "double" else 1e-37)
    P, Q = sp.gammainc(a[ok], x[ok]), sp.gammaincc(a[ok], x[ok])
    with np.errstate(divide="ignore"):
        rP = np.log(P)
        rQ = np.log(Q)
    # the exponent a log x - x - lgamma(a) is formed in the working precision: its rounding,
    # units of (a |log x| + x + |lgamma a| + 1) eps, is the floor of any such evaluation; the
    # series / continued fraction add their own (measured: at most 18 units in single, 6 in
    # double); the bound is 32 units
    unit = (2.0 ** -53 if precision == "double" else 2.0 ** -24)
    xs = x[ok]
    scale = unit * (a[ok] * np.abs(np.log(xs)) + xs + np.abs(sp.gammaln(a[ok])) + 1)
    fin = np.isfinite(rP) & np.isfinite(rQ)
    # absolute error in log = relative error in P, Q
    assert np.max(np.abs(lP[ok][fin] - rP[fin]) / scale[fin]) < 32
    assert np.max(np.abs(lQ[ok][fin] - rQ[fin]) / scale[fin]) < 32


@pytest.mark.parametrize("precision", ["single", "double"])
def test_ends_are_finite(precision):
    """p = 0 gives a tiny positive x (not NaN); p and q at the generator's extremes are finite."""
    eps = 2.0 ** -24 if precision == "single" else 2.0 ** -33
    a = np.array([0.2, 0.2, 10, 10, 1, 1, 0.2, 10])
    p = np.array([0, eps, 0, eps, 0.5, 1 - eps, 1 - eps, 1 - eps])
    x, _, _ = run(a, p, 1 - p, precision, 1)
    assert np.all(np.isfinite(x)) and np.all(x >= 0)
    assert x[0] < 1e-30 and x[2] < 1e-3
    np.testing.assert_allclose(x[4], np.log(2), rtol=1e-5)


def _lgamma_decimal(x):
    """log Gamma(x), x > 0, to about 40 digits: Stirling's series (10 terms) at x + n >= 40 and
    the recurrence down (Python's decimal), a reference independent of the kernel's splitting
    and of scipy.special.betaln (which is 2.4e-9 off at a = 6.5e5, b = 1.8: its large-argument
    branch cancels)."""
    from decimal import Decimal as Dec, localcontext
    with localcontext() as ctx:
        ctx.prec = 45
        bern = [Dec(n) / d for n, d in ((1, 6), (-1, 30), (1, 42), (-1, 30), (5, 66),
                                         (-691, 2730), (7, 6), (-3617, 510), (43867, 798),
                                         (-174611, 330))]
        x, shift = Dec(x), Dec(0)
        while x < 40:
            shift += x.ln()
            x += 1
        s = (x - Dec("0.5")) * x.ln() - x + (2 * Dec("3.14159265358979323846264338327950288419716939937510")).ln() / 2
        for k, b in enumerate(bern, 1):
            s += b / (2 * k * (2 * k - 1) * x ** (2 * k - 1))
        return s - shift


def _lbeta_decimal(a, b):
    from decimal import Decimal as Dec
    return float(_lgamma_decimal(a) + _lgamma_decimal(b) - _lgamma_decimal(Dec(a) + Dec(b)))


BETA_SRC = """
__kernel void beta(const global real_t *A, const global real_t *B, const global real_t *C,
                   global real_t *out)
{
    size_t i = get_global_id(0) * W;
    VSTORE(beta_scaled(VLOAD(A + i), VLOAD(B + i), VLOAD(C + i)), out + i);
}
"""


@pytest.mark.parametrize("precision", ["single", "double"])
def test_beta_scaled_matches_scipy(precision):
    """c B(a, b) (the dielectric's exact transmission masking, a = 1 + Lambda_o, b = 1 +
    Lambda_t, c = 1 or a) against a 40-digit log B (_lbeta_decimal) over a, b in [1, 1e6] log-uniform (both
    below 10, one, both above) where the result is a normal number: relative error within 64 eps
    of the precision, or 8 |log B| eps where that is larger (the rounding of log B carries
    |log B| eps into any exp(log B) form). Measured: 26 eps where both are below 10 (Gamma's
    ratio), at most 8.2 |log B| eps elsewhere, in either precision."""
    rng = np.random.default_rng(11)
    n = 1000
    a = np.exp(rng.uniform(0, np.log(1e6), n))
    b = np.exp(rng.uniform(0, np.log(1e6), n))
    b[:500] = np.exp(rng.uniform(0, np.log(10), 500))
    a[:250] = np.exp(rng.uniform(0, np.log(10), 250))
    a[250:270], b[250:270] = 1.0, np.geomspace(1, 1e6, 20)
    a[270:280], b[270:280] = 9.999, 10.0
    c = np.where(rng.random(n) < 0.5, 1.0, a)
    dt = np.float64 if precision == "double" else np.float32
    a, b, c = (x.astype(dt).astype(np.float64) for x in (a, b, c))
    (out,) = build.run_functions(("common.h", "special.h"), BETA_SRC, "beta", (a, b, c), 1,
                                 precision=precision, width=16)
    lref = np.array([_lbeta_decimal(x, y) for x, y in zip(a, b)]) + np.log(c)
    eps = np.finfo(dt).eps
    ok = lref > np.log(np.finfo(dt).tiny) + 1
    rel = np.abs(out[ok] / np.exp(lref[ok]) - 1)
    bound = eps * np.maximum(64, 8 * np.abs(lref[ok]))
    assert np.all(rel <= bound), (np.max(rel / bound), a[ok][np.argmax(rel / bound)],
                                  b[ok][np.argmax(rel / bound)])
    assert np.all(out[~ok] < 4 * np.finfo(dt).tiny)
    (inf,) = build.run_functions(("common.h", "special.h"), BETA_SRC, "beta",
                                 (np.array([np.inf, 2.0]), np.array([3.0, np.inf]),
                                  np.array([1.0, 2.0])), 1, precision=precision, width=1)
    assert np.all(inf == 0)
