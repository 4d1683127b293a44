/* GTR, the generalised Trowbridge-Reitz distribution (Burley 2012; Holzschuch & Pacanowski 2015
 * Table 1), isotropic, for the microfacet model (MF_DIST gtr; docs/models/microfacet.md).
 *
 * | parameter | meaning                                        | range        |
 * |-----------|------------------------------------------------|--------------|
 * | alpha     | roughness a (Microfacet.ax)                    | [1e-3, 0.999]|
 * | gamma     | tail exponent (Microfacet.shape); 2 is GGX     | [0.5, 4]     |
 *
 * P22(x) = c (1 + x)^(gamma-2) / (pi (a^2 + x)^gamma), x = tan^2 theta (Table 1), so that
 *   D = P22 / cos^4 = c / (pi (a^2 cos^2 + sin^2)^gamma)            (Burley 2012 eq 4)
 *   c = (gamma-1)(1-a^2) a^(2(gamma-1)) / (1 - a^(2(gamma-1)))      (Table 1)
 *     = exp(-g L) h(L) / h(-g L),  g = 1 - gamma, L = ln a^2, h(z) = expm1(z)/z (h(0) = 1),
 * the same expression for gamma = 1 (c = (1 - a^2)/(2 ln(1/a)), Table 1's second column).
 * Lambda: gamma = 1 in closed form (derived in docs/models/distributions.md); otherwise the
 * table of kernels/dist_lambda_tables.h relative to Lambda_gtr1^(1-w) Lambda_ggx^w, w = gamma - 1
 * (exact at gamma = 2, a node of the table whose values are 0).
 * Sampling: the CDF of x is closed form: w = (a^2 + x)/(1 + x) has w^g uniform between a^(2g)
 * and 1 (gamma = 1: ln w uniform between L and 0); no visible-normal sampler.
 */
#ifndef CLBRDF_DIST_GTR_H
#define CLBRDF_DIST_GTR_H

#include "microfacet_distributions.h"
#include "dist_lambda.h"

/* expm1(z)/z, 1 at z = 0. */
FN realN gtr_h(realN z) { return sel(expm1(z) / z, (realN)1, z == 0); }

FN realN gtr_c(realN a, realN gamma)
{
    realN L = 2 * log(a), g = 1 - gamma;
    return exp(-g * L) * gtr_h(L) / gtr_h(-g * L);
}

FN realN gtr_D(Microfacet m, vec3 h)
{
    realN a = m.ax, gamma = m.shape;
    realN e = a * a * h.z * h.z + (h.x * h.x + h.y * h.y);
    return sel((realN)0, gtr_c(a, gamma) * INV_PI_R * exp(-gamma * log(e)), h.z > 0);
}

/* Lambda of GTR gamma = 1 and of GGX for the same a, from z = cos theta and s2 = sin^2 theta.
 * With A = sqrt(z^2 + a^2 s2), d = a^2 - 1 = expm1(L), X = d s2 / ((1 + A)(1 + z)):
 *   Lambda_1 = (d / L) s2 / (1 + A) [1/z - log1p(X)/(X (1 + z))]
 * (the closed form [asinh(mu/a) - asinh(mu) - ln(1/a) - sqrt(1 + a^2 t^2) + sqrt(1 + t^2)] /
 * (2 ln(1/a)), mu = 1/t = cot theta, without its cancellations);
 *   Lambda_ggx = a^2 s2 / (2 z (z + A)). */
FN realN gtr_lambda1(realN a, realN z, realN s2, realN *lambda_ggx)
{
    realN L = 2 * log(a);
    realN A = sqrt(z * z + a * a * s2);
    realN d = expm1(L);
    realN X = d * s2 / ((1 + A) * (1 + z));
    realN lp = sel(log1p(X) / X, (realN)1, X == 0);
    *lambda_ggx = a * a * s2 / (2 * z * (z + A));
    return gtr_h(L) * s2 / (1 + A) * (1 / z - lp / (1 + z));
}

FN realN gtr_Lambda(Microfacet m, vec3 w)
{
    realN a = m.ax, gamma = m.shape;
    realN z = fabs(w.z), s2 = w.x * w.x + w.y * w.y;
    realN lg, l1 = gtr_lambda1(a, z, s2, &lg);
    /* table coordinates: gamma, log2 a + KA a, log2(a tan theta) */
    realN xs = (gamma - (realN)GTR_LT_SREF) * (realN)GTR_LT_IDS + (realN)GTR_LT_SIDX;
    realN xa = (log2(a) + (realN)GTR_LT_KA * a - (realN)GTR_LT_LA0) / (realN)GTR_LT_DLA;
    realN xt = (log2(a * sqrt(s2) / z) - (realN)GTR_LT_LT0) / (realN)GTR_LT_DLT;
    realN R = lambda_table_R(m.tables + TABLE_gtr_lambda, GTR_LT_NS, GTR_LT_NA, GTR_LT_NT, xs, xa, xt);
    realN wgt = gamma - 1;
    realN lam = l1 * exp(wgt * log(lg / l1) + R);
    lam = sel(lam, l1, gamma == 1);                  /* the closed form, exactly */
    return sel(lam, (realN)0, (l1 <= 0) | (lg <= 0));
}

/* Inverse CDF in x = tan^2 theta (see the header): with E = expm1(g L),
 *   ln(w / a^2) = log1p(u expm1(-g L)) / g,  ln w = log1p((1 - u) E) / g   (g = 0: -u L, (1-u) L)
 *   (the log1p arguments written as sums of positive terms where they approach -1)
 *   sin^2 = a^2 expm1(ln(w/a^2)) / (1 - a^2),  cos^2 = -expm1(ln w) / (1 - a^2). */
FN vec3 gtr_sample_ndf(Microfacet m, realN u0, realN u1)
{
    realN a = m.ax, g = 1 - m.shape;
    realN L = 2 * log(a);
    realN v0 = 1 - u0;
    /* log1p(u E) where u is small; log(1 - u + u e^z) (positive terms) where 1 - u is small */
    realN la = sel(log1p(u0 * expm1(-g * L)), log(v0 + u0 * exp(-g * L)), u0 > (realN)0.5);
    realN lb = sel(log1p(v0 * expm1(g * L)), log(u0 + v0 * exp(g * L)), v0 > (realN)0.5);
    realN lwa = sel(la / g, -u0 * L, g == 0);
    realN lw = sel(lb / g, v0 * L, g == 0);
    realN inv = 1 / -expm1(L);
    realN sin_t = sqrt(a * a * expm1(lwa) * inv);
    realN cos_t = sqrt(-expm1(lw) * inv);
    realN c, s = sincos_r(2 * PI_R * u1, &c);
    return normalize3(v3(sin_t * c, sin_t * s, cos_t));
}

#endif
