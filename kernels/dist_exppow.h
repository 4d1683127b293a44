/* Exponential-power distribution of normals (Holzschuch & Pacanowski 2015 eq 18-23).
 *
 * | parameter | meaning                                       | range      |
 * |-----------|-----------------------------------------------|------------|
 * | sigma     | width of the slope distribution (m.ax)        | [1e-4, 10] |
 * | p         | kurtosis: exp(-(tan^2/sigma^2)^p) (m.shape)   | [0.1, 5]   |
 *
 *   P22(x) = beta exp(-(x / sigma^2)^p), beta = p / (pi sigma^2 Gamma(1/p))    (eq 18, 19)
 *   D(h)   = P22(tan^2 theta_h) / cos^4 theta_h                                (eq 2, 26)
 * Isotropic: m.ax is sigma (m.ay is not used), m.shape is p.
 *
 * Smith Lambda (eq 20-21) depends on nu = sigma tan theta and p only. With
 * nu~ = nu Gamma(3/(2p)) / Gamma(1/p) (nu times the mean slope of the unit distribution) it is
 * read from a table of log(1 + Lambda) on a grid in log p and log nu~ (layout
 * kernels/exppow_g1_table.h, values kernels/data/exppow_g1.npy in the tables buffer),
 * Catmull-Rom in both (16 reads); generated and checked against direct quadrature by
 * scripts/exppow_g1_table.py; Lambda = 0 below the table, nu~/pi - 1/2 above it.
 *
 * Sampling (eq 22-23): y = (tan^2 theta_h / sigma^2)^p is Gamma(1/p, 1): y = Q^-1(1/p, u0),
 * tan theta_h = sigma y^(1/(2p)), phi_h = 2 pi u1; density D(h) cos theta_h.
 */
#ifndef CLBRDF_DIST_EXPPOW_H
#define CLBRDF_DIST_EXPPOW_H

#include "microfacet_distributions.h"
#include "special.h"
#include "exppow_g1_table.h"

#if W == 1
typedef int exppow_int;
#define EXPPOW_TO_INT convert_int
#else
typedef CAT(int, W) exppow_int;
#define EXPPOW_TO_INT CAT(convert_int, W)
#endif

/* D(h) (eq 26), in logs so that the exp(-...) -> 0, cos^-4 -> inf limit never forms 0 * inf. */
FN realN exppow_D(Microfacet m, vec3 h)
{
    realN s = m.ax, p = m.shape;
    realN z2 = h.z * h.z;
    realN t2 = (h.x * h.x + h.y * h.y) / z2;                         /* tan^2 theta_h */
    realN e = pow_pos(t2 / (s * s), p);
    realN log_beta = log(p * INV_PI_R / (s * s)) - lgamma(1 / p);       /* eq 19 */
    realN d = exp(log_beta - e - 2 * log(z2));
    return sel((realN)0, d, (h.z > 0) & (e < (realN)(CLBRDF_DOUBLE ? 1400 : 180)));
}

/* One table row at base..base+3, Catmull-Rom in nu~ with parameter t. */
FN realN exppow_row(Tables T, exppow_int base, realN t)
{
    uintN b = convert_uintN(base);
    return catmull_rom(table_gather(T, b), table_gather(T, b + 1), table_gather(T, b + 2),
                       table_gather(T, b + 3), t);
}

/* log(1 + Lambda) at log nu~ = lv (table lookup, see the header comment). */
FN realN exppow_log1p_lambda(Tables T, realN p, realN lv)
{
    realN tp = clamp((log(p) - (realN)EXPPOW_TABLE_P0) / (realN)EXPPOW_TABLE_HP,
                     (realN)0, (realN)(EXPPOW_TABLE_NP - 1));
    realN tv = clamp((lv - (realN)EXPPOW_TABLE_V0) / (realN)EXPPOW_TABLE_HV,
                     (realN)0, (realN)(EXPPOW_TABLE_NV - 1));
    realN fp = fmin(floor(tp), (realN)(EXPPOW_TABLE_NP - 2));
    realN fv = fmin(floor(tv), (realN)(EXPPOW_TABLE_NV - 2));
    /* ghost row and column: table index (i + 1, j + 1) holds grid point (i, j); the integer
     * clamp keeps every read inside the table whatever the input (vector bounds: oclgrind
     * miscomputes clamp(intN, int, int)) */
    exppow_int row = iclamp(EXPPOW_TO_INT(fp), (exppow_int)0, (exppow_int)(EXPPOW_TABLE_NP - 2))
                     * (EXPPOW_TABLE_NV + 2)
                     + iclamp(EXPPOW_TO_INT(fv), (exppow_int)0, (exppow_int)(EXPPOW_TABLE_NV - 2));
    tv -= fv;
    realN r0 = exppow_row(T, row, tv), r1 = exppow_row(T, row + (EXPPOW_TABLE_NV + 2), tv);
    realN r2 = exppow_row(T, row + 2 * (EXPPOW_TABLE_NV + 2), tv);
    realN r3 = exppow_row(T, row + 3 * (EXPPOW_TABLE_NV + 2), tv);
    realN v = catmull_rom(r0, r1, r2, r3, tp - fp);
    realN above = lv - (realN)1.1447298858494002 + log1p((realN)1.5707963267948966 * exp(-lv));  /* log(nu~/pi + 1/2) */
    v = sel(v, above, lv > (realN)(EXPPOW_TABLE_V0 + (EXPPOW_TABLE_NV - 1) * EXPPOW_TABLE_HV));
    return sel(v, (realN)0, lv < (realN)EXPPOW_TABLE_V0);
}

/* Smith Lambda (eq 20-21) of direction w, from the table. */
FN realN exppow_Lambda(Microfacet m, vec3 w)
{
    realN p = m.shape;
    realN r2 = w.x * w.x + w.y * w.y;
    /* log nu~ = log(sigma tan theta) + log Gamma(3/(2p)) - log Gamma(1/p); -inf at the normal */
    realN lv = log(m.ax) + (realN)0.5 * log(r2) - log(fabs(w.z)) + lgamma((realN)1.5 / p) - lgamma(1 / p);
    lv = fmax(lv, (realN)(EXPPOW_TABLE_V0 - 1));
    return expm1(exppow_log1p_lambda(m.tables + TABLE_exppow_g1, p, lv));
}

/* Normals with density D(h) cos theta_h (eq 22-23): y = Q^-1(1/p, u0) is Gamma(1/p, 1). */
FN vec3 exppow_sample_ndf(Microfacet m, realN u0, realN u1)
{
    realN a = 1 / m.shape;
    u0 = fmax(u0, (realN)REAL_MIN);          /* u0 = 0 is the slope at infinity: take the next */
    realN y = gammaincinv_pq(a, 1 - u0, u0);
    realN r = m.ax * exp((realN)0.5 * a * log(y));                      /* tan theta_h */
    realN c, s = sincos_2pi(u1, &c);
    return slope_to_normal(r * c, r * s);
}

#endif
