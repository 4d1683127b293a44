/* SGD, the shifted gamma distribution of Bagher, Soler & Holzschuch 2012 (Holzschuch &
 * Pacanowski 2015 Table 1), isotropic, for the microfacet model (MF_DIST sgd) and for
 * kernels/sgd_bagher.h.
 *
 * | parameter | meaning                                          | range        |
 * |-----------|--------------------------------------------------|--------------|
 * | alpha     | a, the shift and scale (Microfacet.ax)           | [1e-5, 1]    |
 * | p         | power of the shifted slope (Microfacet.shape)    | [0, 2]       |
 *
 * P22(x) = a^(p-1) / (pi Gamma(1-p, a)) exp(-(a^2 + x)/a) / (a^2 + x)^p   (Table 1, with the 1/pi
 * that the extracted table lacks: without it the integral is 1, not 1/pi). With y = a + x/a:
 *   D = P22 / cos^4 = kap e^-y / (pi y^p cos^4),  kap = 1 / (a Gamma(1-p, a))    (Bagher eq 6)
 * Gamma(s, a) is the upper incomplete gamma function; its shape s = 1 - p is negative for p > 1,
 * which is fine for a > 0. Q(y) = Gamma(1-p, y) = integral_y^inf t^-p e^-t dt here:
 *   y < 2: Q(2) + S(y, 2), S(x, y) = integral_x^y by the series of e^-t (all terms stable);
 *   y >= 2: the continued fraction of Gamma(s, y) (Lentz, fixed number of terms).
 * Sampling: y has density y^-p e^-y / Q(a) on [a, inf); tan^2 theta = a (y - a). d = y - a is found
 * by Newton's method on the logit ln(I(a, y) / Q(y)) = ln(u / (1 - u)) (I = Q(a) - Q(y), both
 * computed without cancellation) in ln d, bracketed by bounds from t^-p e^-t <= t^-p and
 * <= y^-p e^-t. Lambda: the table of kernels/dist_lambda_tables.h relative to Beckmann with
 * alpha_b = sqrt(a) (exact for p = 0). No visible-normal sampler.
 */
#ifndef CLBRDF_DIST_SGD_H
#define CLBRDF_DIST_SGD_H

#include "microfacet_distributions.h"

#if CLBRDF_DOUBLE
#define SGD_SERIES_TERMS 26
#define SGD_CF_TERMS 50
#define SGD_NEWTON 7
#else
#define SGD_SERIES_TERMS 16
#define SGD_CF_TERMS 14
#define SGD_NEWTON 6
#endif

/* expm1(m l) / m, l at m = 0. */
FN realN sgd_em1div(realN m, realN l) { return sel(expm1(m * l) / m, l, m == 0); }

/* integral_x^y t^-p e^-t dt for 0 < x <= y <= 2, given l = ln(y/x) and dd = y - x accurately:
 * sum_n (-1)^n / n! (y^(n+s) - x^(n+s)) / (n+s), s = 1 - p; the differences D_n for n >= 2 by
 * D_n = y D_(n-1) + x^(n-1+s) (y - x), whose terms are positive (no cancellation for x ~ y). */
FN realN sgd_S(realN x, realN y, realN l, realN dd, realN p)
{
    realN s = 1 - p;
    realN xs = exp(s * log(x));
    realN tot = xs * (sgd_em1div(s, l) - x * sgd_em1div(s + 1, l));
    realN Dn = xs * x * expm1((s + 1) * l);
    realN xn = xs * x, fact = (realN)0.5, sign = 1;
    for (int n = 2; n < SGD_SERIES_TERMS; ++n) {
        Dn = y * Dn + xn * dd;
        xn *= x;
        tot += sign * fact * Dn / ((realN)n + s);
        fact /= (realN)(n + 1);
        sign = -sign;
    }
    return tot;
}

/* Gamma(1-p, y) for y >= 2: modified Lentz on the continued fraction (Numerical Recipes gcf). */
FN realN sgd_CF(realN y, realN p)
{
    realN s = 1 - p;
    realN b = y + 1 - s, c = (realN)(CLBRDF_DOUBLE ? 1e300 : 1e37), d = 1 / b, h = d;
    for (int i = 1; i <= SGD_CF_TERMS; ++i) {
        realN an = -(realN)i * ((realN)i - s);
        b += 2;
        d = an * d + b;
        c = b + an / c;
        d = 1 / d;
        h *= d * c;
    }
    return exp(-y - p * log(y)) * y * h;
}

/* Q(y) = Gamma(1-p, y) for any y > 0, given q2 = Q(2). */
FN realN sgd_Q(realN y, realN p, realN q2)
{
    realN yc = fmin(y, (realN)2);
    realN lo = q2 + sgd_S(yc, (realN)2, log((realN)2 / yc), 2 - yc, p);
    return sel(lo, sgd_CF(fmax(y, (realN)2), p), y >= 2);
}

/* 1 / kap = a Gamma(1-p, a). */
FN realN sgd_inv_kap(realN a, realN p)
{
    return a * sgd_Q(a, p, sgd_CF((realN)2, p));
}

/* D with a given kap (Bagher eq 6; dj_brdf sgd__ndf): kap e^-y / (pi y^p cos^4), y = a + tan^2/a;
 * an exact 0 where e^-y y^-p underflows (also where cos^4 would). */
FN realN sgd_D_kap(realN a, realN p, realN kap, vec3 h)
{
    realN z2 = h.z * h.z;
    realN y = a + (h.x * h.x + h.y * h.y) / (z2 * a);
    realN e = y + p * log(y);
    realN d = kap * exp(-e) * INV_PI_R / (z2 * z2);
    return sel((realN)0, d, (h.z > 0) & (e < (realN)(CLBRDF_DOUBLE ? 700 : 85)));
}

FN realN sgd_D(Microfacet m, vec3 h)
{
    return sgd_D_kap(m.ax, m.shape, 1 / sgd_inv_kap(m.ax, m.shape), h);
}

#ifndef SGD_NO_LAMBDA
#include "dist_lambda.h"

/* Lambda from the table: R at (p, log2 a + KA a, log2(sqrt(m2) tan theta)), m2 = a (E[y] - a) the mean
 * tan^2 theta_h, E[y] = 1 - p + a^(1-p) e^-a / Q(a), times Beckmann Lambda with alpha_b = sqrt(a). */
FN realN sgd_Lambda(Microfacet m, vec3 w)
{
    realN a = m.ax, p = m.shape;
    realN z = fabs(w.z), sn = sqrt(w.x * w.x + w.y * w.y);
    realN qa = sgd_Q(a, p, sgd_CF((realN)2, p));
    realN m2 = a * (1 - p + exp((1 - p) * log(a) - a) / qa - a);
    realN xs = (p - (realN)SGD_LT_SREF) * (realN)SGD_LT_IDS + (realN)SGD_LT_SIDX;
    realN xa = (log2(a) + (realN)SGD_LT_KA * a - (realN)SGD_LT_LA0) / (realN)SGD_LT_DLA;
    realN xt = (log2(sqrt(m2) * sn / z) - (realN)SGD_LT_LT0) / (realN)SGD_LT_DLT;
    realN R = lambda_table_R(m.tables + TABLE_sgd_lambda, SGD_LT_NS, SGD_LT_NA, SGD_LT_NT, xs, xa, xt);
    /* Beckmann (microfacet_distributions.h), mu = 1 / (sqrt(a) tan theta) */
    realN mu = z / (sqrt(a) * sn);
    realN lb = (realN)0.5 * (exp(-mu * mu) * INV_SQRT_PI_R / mu - erfc(mu));
    lb = sel(lb, (realN)0, isinf(mu));
    return lb * exp(R);
}
#endif

/* d = y - a with lower-CDF mass v (see the header), and Q(a). */
FN realN sgd_sample_d(realN a, realN p, realN v)
{
    realN q2 = sgd_CF((realN)2, p);
    realN qa = sgd_Q(a, p, q2);
    realN s = 1 - p, w = 1 - v;
    /* lower bound from t^-p e^-t <= t^-p: y^s = a^s + s v Q(a) */
    realN r = v * qa * exp(-s * log(a));
    realN d_lo = a * expm1(sel(log1p(s * r) / s, r, s == 0));
    realN y_lo = a + d_lo;
    /* upper bounds: Q(y) <= y_lo^-p e^-y, and for p > 1 Q(y) <= y^(1-p) / (p - 1) */
    realN d_hi = -log(w * qa) - p * log(y_lo) - a;
    realN pm = fmax(p - 1, (realN)REAL_EPS);
    realN d_pow = exp(log(pm * w * qa) / -pm) - a;
    d_hi = fmax(sel(d_hi, fmin(d_hi, d_pow), p > 1), d_lo);
    realN lo = log(d_lo), hi = log(d_hi);
    realN z = sel(lo, hi, v > (realN)0.5);
    realN target = log(v) - log(w);
    for (int it = 0; it < SGD_NEWTON; ++it) {
        realN d = exp(z), y = a + d;
        maskN big = y >= 2;
        realN yc = fmin(y, (realN)2);
        realN cfy = sgd_CF(fmax(y, (realN)2), p);
        realN Ia = sgd_S(a, yc, sel(log1p(d / a), log(yc / a), big), sel(d, yc - a, big), p);
        realN Qy = sel(q2 + sgd_S(yc, (realN)2, log((realN)2 / yc), 2 - yc, p), cfy, big);
        realN Iy = sel(Ia, qa - cfy, big);
        realN phi = log(Iy) - log(Qy) - target;
        realN dphi = d * exp(-y - p * log(y)) * (1 / Iy + 1 / Qy);
        maskN above = phi > 0;
        hi = sel(hi, fmin(hi, z), above);
        lo = sel(fmax(lo, z), lo, above);
        z = clamp(z - phi / dphi, lo, hi);
    }
    return sel(exp(z), (realN)0, v <= 0);
}

FN vec3 sgd_sample_ndf(Microfacet m, realN u0, realN u1)
{
    realN a = m.ax;
    realN x = a * sgd_sample_d(a, m.shape, u0);       /* tan^2 theta */
    realN cos_t = rsqrt(1 + x);
    realN sin_t = sqrt(x) * cos_t;
    realN c, s = sincos_r(2 * PI_R * u1, &c);
    return v3(sin_t * c, sin_t * s, cos_t);
}

#endif
