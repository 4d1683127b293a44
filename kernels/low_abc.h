/* Löw, Kronander, Ynnerman & Unger 2012: the condensed ABC function and the stable helpers
 * both Löw models share (kernels/low_smooth.h, kernels/low_microfacet.h).
 *
 *   S(f) = A / (1 + B f^2)^C                     (eq 11; only f^2 is ever needed)
 *
 * Near C = 1 the closed forms of eq 19/24/25 are 0/0; they are written with expm1/log1p so that
 * one formula holds for every C (no switch): with t = (1 - C) L,
 *   ((1 + B)^(1-C) - 1) / (1 - C) = L expm1(t) / t            (L = log1p(B))
 *   x = expm1(L log1p(u expm1(t)) / t) / B                     (inverse CDF, eq 25)
 * and expm1(t)/t, log1p(u expm1(t))/t take their limits 1, u only where t == 0 exactly.
 */
#ifndef CLBRDF_LOW_ABC_H
#define CLBRDF_LOW_ABC_H

#include "fresnel.h"

#if CLBRDF_DOUBLE
#define LOW_TINY DBL_MIN
#else
#define LOW_TINY FLT_MIN
#endif

/* Dielectric Fresnel F(theta_d; eta) at c = cos theta_d >= 0. c = 0 (grazing mirror) is moved
 * to the smallest normal number: fresnel_dielectric(1, 0) is 0/0 (g = c = 0); every other eta
 * has F(eta, 0+) = F(eta, tiny) = 1 (eta != 1) to rounding. */
FN realN low_fresnel(realN eta, realN c)
{
    return fresnel_dielectric(eta, fmax(c, (realN)LOW_TINY));
}

/* S = a (1 + b x2)^(-c), x2 = f^2 (eq 11). */
FN realN low_abc(realN a, realN b, realN c, realN x2)
{
    return a * exp(-c * log1p(b * x2));
}

/* (1 + b x2)^(1 - c): the ratio S / (a (1 + b x2)^-1) that the C = 1 sampler leaves in a weight. */
FN realN low_abc_ratio(realN b, realN c, realN x2)
{
    return exp((1 - c) * log1p(b * x2));
}

/* expm1(t) / t, 1 at t = 0 (exact limit, continuous). */
FN realN low_expm1_over(realN t)
{
    return sel(expm1(t) / t, (realN)1, t == 0);
}

/* log1p(u expm1(t)) / t, u at t = 0 (exact limit, continuous). */
FN realN low_log1p_over(realN u, realN t)
{
    return sel(log1p(u * expm1(t)) / t, u, t == 0);
}

/* Rough albedo of an ABC lobe over the plane of its argument, used only to pick mixture
 * probabilities: integral_0^{R2} pi (1 + b s)^-c ds = pi L expm1((1 - c) L) / ((1 - c) L) / b with
 * L = log1p(b R2); here L is given. */
FN realN low_lobe_mass(realN b, realN c, realN L)
{
    return PI_R * L * low_expm1_over((1 - c) * L) / b;
}

#endif
