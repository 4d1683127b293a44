/* Special functions: the regularised incomplete gamma functions P(a, x), Q(a, x) = 1 - P and
 * their inverse in x, for the exponential-power sampler (Holzschuch & Pacanowski 2015 eq 23).
 *
 * | function                   | meaning                                              |
 * |----------------------------|------------------------------------------------------|
 * | gamma_log_pq(a, x, lga,..) | log P(a, x) and log Q(a, x); lga = lgamma(a)         |
 * | gammaincinv_pq(a, p, q)    | x with P(a, x) = p, given p and q = 1 - p both       |
 * | gammaincinv_r(a, p)        | x with P(a, x) = p   (scipy.special.gammaincinv)     |
 * | gammainccinv_r(a, q)       | x with Q(a, x) = q   (scipy.special.gammainccinv)    |
 * | beta_scaled(a, b, c)       | c B(a, b) for a, b >= 1 (the dielectric's masking)   |
 *
 * Shape a in [0.2, 10], p in (0, 1). Branch-free, fixed iteration counts (below). P by its
 * power series where x < a + 1, Q by its continued fraction (modified Lentz) elsewhere
 * (Numerical Recipes 3rd ed. 6.2, gser/gcf); the other one as log1p(-exp(.)), which loses
 * nothing there (P(a, a+1) and Q(a, a+1) are at least 0.05 for a in [0.2, 10]).
 * The inverse solves the equation in the smaller of the two tails, so that both u -> 0 and
 * u -> 1 keep full relative precision in x: for p <= q Newton on log P(a, e^t) = log p in
 * t = log x (nearly linear in t as p -> 0, where log P ~ a t - lgamma(a + 1)); for p > q Newton
 * on log Q(a, x) = log q in x (nearly linear as q -> 0, where log Q ~ (a-1) log x - x - lgamma(a)).
 * Starting points: the lower-tail limit x = (p Gamma(a + 1))^(1/a), Wilson-Hilferty with the
 * normal quantile of Abramowitz & Stegun 26.2.23, and the upper-tail limit.
 * Measured against SciPy (tests/runtime/test_special.py): max relative error of x 1.2e-13 in double
 * precision, 1.2e-5 in single (where log p itself carries |log p| eps, amplified by 1/a; the
 * sampler uses x^(a/2), whose error is at most 3.6e-6).
 */
#ifndef CLBRDF_SPECIAL_H
#define CLBRDF_SPECIAL_H

#if CLBRDF_DOUBLE
#define GAMMA_SERIES_TERMS 56
#define GAMMA_CF_TERMS 56
#define GAMMAINV_NEWTON 4
#else
#define GAMMA_SERIES_TERMS 20
#define GAMMA_CF_TERMS 12
#define GAMMAINV_NEWTON 3
#endif

/* log P(a, x) and log Q(a, x) for x >= 0. */
FN void gamma_log_pq(realN a, realN x, realN lga, realN *logP, realN *logQ)
{
    /* series: P = x^a e^-x / Gamma(a) sum_n x^n / (a (a+1) ... (a+n)), at xs = min(x, a+1) */
    realN xs = fmin(x, a + 1);
    realN term = 1 / a, sum = term;
    for (int n = 1; n <= GAMMA_SERIES_TERMS; ++n) {
        term *= xs / (a + n);
        sum += term;
    }
    realN lps = a * log(xs) - xs - lga + log(sum);
    /* continued fraction: Q = x^a e^-x / Gamma(a) / (x+1-a - 1(1-a)/(x+3-a - 2(2-a)/(x+5-a - ...))),
     * at xc = max(x, a+1) */
    realN xc = fmax(x, a + 1);
    realN b = xc + 1 - a, c = (realN)1 / (realN)(CLBRDF_DOUBLE ? 1e-300 : 1e-30), d = 1 / b, h = d;
    for (int i = 1; i <= GAMMA_CF_TERMS; ++i) {
        realN an = -i * (i - a);
        b += 2;
        d = an * d + b;
        c = b + an / c;
        d = 1 / d;
        h *= d * c;
    }
    realN lqc = a * log(xc) - xc - lga + log(h);
    maskN series = x < a + 1;
    *logP = sel(log1p(-exp(lqc)), lps, series);
    *logQ = sel(lqc, log1p(-exp(lps)), series);
}

/* x with P(a, x) = p and Q(a, x) = q; the caller gives both (p + q = 1), each to full precision. */
FN realN gammaincinv_pq(realN a, realN p, realN q)
{
    realN lga = lgamma(a);
    maskN lower = p <= q;
    realN lp = log(p), lq = log(q);
    /* starting point */
    realN t = sqrt(-2 * fmin(lp, lq));
    realN z = t - ((realN)2.30753 + (realN)0.27061 * t) / (1 + t * ((realN)0.99229 + (realN)0.04481 * t));
    z = sel(z, -z, lower);
    realN wh = 1 - 1 / (9 * a) + z / (3 * sqrt(a));
    wh = a * wh * wh * wh;
    realN x_lo = exp((lp + lga + log(a)) / a);                /* (p Gamma(a+1))^(1/a) */
    realN x_up = -lq - lga + (a - 1) * log(fmax(-lq - lga, (realN)1));
    realN x = sel(fmax(wh, x_up), fmax(x_lo, fmin(wh, a)), lower);
    x = fmax(x, (realN)(CLBRDF_DOUBLE ? 1e-300 : 1e-37));
    for (int k = 0; k < GAMMAINV_NEWTON; ++k) {
        realN lP, lQ;
        gamma_log_pq(a, x, lga, &lP, &lQ);
        realN lx = log(x);
        /* lower: d log P / d log x = x^a e^-x / (Gamma(a) P) */
        realN x_l = exp(lx - (lP - lp) * exp(lP - (a * lx - x - lga)));
        /* upper: d log Q / dx = -x^(a-1) e^-x / (Gamma(a) Q); no step below x / 4 */
        realN x_u = fmax(x + (lQ - lq) * exp(lQ - ((a - 1) * lx - x - lga)), (realN)0.25 * x);
        x = fmax(sel(x_u, x_l, lower), (realN)(CLBRDF_DOUBLE ? 1e-300 : 1e-37));
    }
    return x;
}

FN realN gammaincinv_r(realN a, realN p) { return gammaincinv_pq(a, p, 1 - p); }
FN realN gammainccinv_r(realN a, realN q) { return gammaincinv_pq(a, 1 - q, q); }

/* Stirling's correction lgamma(x) - ((x - 1/2) log x - x + log(2 pi) / 2) for x >= 10: the
 * asymptotic series (Abramowitz & Stegun 6.1.41), six terms (the seventh is below 6e-16 at 10). */
FN realN lgamma_corr(realN x)
{
    realN r = 1 / x, r2 = r * r;
    return r * ((realN)(1.0 / 12) - r2 * ((realN)(1.0 / 360) - r2 * ((realN)(1.0 / 1260)
               - r2 * ((realN)(1.0 / 1680) - r2 * ((realN)(1.0 / 1188)
               - r2 * (realN)(691.0 / 360360))))));
}

/* c B(a, b) for a, b >= 1 (the Beta function times c > 0, c inside the exponent so that c = a
 * and B ~ 1/a do not underflow at a large a): Gamma's ratio where both are below 10; else log B
 * by Stirling's series with the large terms in log1p, none cancelling another (p = min,
 * q = max, s = p + q): log Gamma(p) - (q - 1/2) log1p(p / q) - p log s + p + corr(q) - corr(s) for p < 10,
 * log(2 pi) / 2 - (p - 1/2) log1p(q / p) - q log1p(p / q) - log(q) / 2 + corr(p) + corr(q) -
 * corr(s) for p >= 10. 0 where a or b is infinite. */
FN realN beta_scaled(realN a, realN b, realN c)
{
    realN p = fmin(a, b), q = fmax(a, b), s = p + q;
    realN direct = c * tgamma(p) * (tgamma(q) / tgamma(s));
    realN corr = lgamma_corr(q) - lgamma_corr(s);
    realN lq = log1p(p / q);
    realN mixed = log(tgamma(p)) - (q - (realN)0.5) * lq - p * log(s) + p;
    realN both = (realN)0.91893853320467274178 - (p - (realN)0.5) * log1p(q / p) - q * lq
                 - (realN)0.5 * log(q) + lgamma_corr(p);
    realN big = exp(sel(mixed, both, p >= 10) + corr + log(c));
    return sel(sel(big, direct, q < 10), (realN)0, q == (realN)INFINITY);
}

#endif
