/* Fresnel reflectance as a function of c = cos(theta_d) = wi . h (docs/models/microfacet.md). */
#ifndef CLBRDF_FRESNEL_H
#define CLBRDF_FRESNEL_H

/* Schlick 1994 eq 11: F0 + (1 - F0)(1 - c)^5. */
FN realN fresnel_schlick(realN f0, realN c)
{
    realN m = clamp(1 - c, (realN)0, (realN)1), m2 = m * m;
    return f0 + (1 - f0) * (m2 * m2 * m);
}

/* Generalised Schlick: F0 + (F90 - F0)(1 - c)^5; F90 = 1 is eq 11. With (F0, F90) = (1, 0) and
 * (0, 1) it splits E(F0) = F0 A + B into the scale A and bias B that real-time renderers tabulate. */
FN realN fresnel_schlick_f90(realN f0, realN f90, realN c)
{
    realN m = clamp(1 - c, (realN)0, (realN)1), m2 = m * m;
    return f0 + (f90 - f0) * (m2 * m2 * m);
}

/* Cycles' generalised Schlick with a free exponent: F0 + (F90 - F0)(1 - c)^e, e > 0. */
FN realN fresnel_gen_schlick(realN f0, realN f90, realN e, realN c)
{
    return f0 + (f90 - f0) * pow_pos(clamp(1 - c, (realN)0, (realN)1), e);
}

/* F82-tint (Hoffman 2023, "Generalization of Adobe's Fresnel model", OpenPBR's metal):
 * Schlick's F minus a c (1 - c)^6, a fixing F(1/7) = tint F_Schlick(1/7):
 * a = (1 - tint) F_Schlick(1/7) / (c' (1 - c')^6), c' = 1/7, 1 / (c' (1 - c')^6) = 7^7 / 6^6.
 * Below tint 0.52 the subtraction can go below 0 (tint 0: for every F0 < 0.995, around
 * c = 1/7; tint 0.25: F0 < 0.085); F is clamped at 0 there (docs/models/microfacet.md). */
FN realN fresnel_f82(realN f0, realN tint, realN c)
{
    realN m = clamp(1 - c, (realN)0, (realN)1), m2 = m * m;
    realN b5 = (realN)0.46266436603796024;                /* (6/7)^5 */
    realN a = (1 - tint) * (f0 + (1 - f0) * b5) * (realN)17.65138460219479;   /* 7^7 / 6^6 */
    return fmax(f0 + (1 - f0) * (m2 * m2 * m) - a * c * m2 * m2 * m2, (realN)0);
}

/* eta^2 - sin^2 theta for c = cos theta, from whichever of (eta - 1)(eta + 1) + c^2 and
 * eta^2 - (1 - c)(1 + c) has the smaller rounding error (eps (|eta^2 - 1| + c^2) against
 * eps (eta^2 + sin^2)): the first is exact at eta = 1, where the second loses c^2 at grazing; the
 * second keeps eta^2 at small eta, where the first cancels (eta = 1e-6, c = 1: 6e-8 for 1e-12). */
FN realN eta2_minus_sin2(realN eta, realN c, realN s2)
{
    realN a = (eta - 1) * (eta + 1), e2 = eta * eta;
    return sel(e2 - s2, a + c * c, fabs(a) + c * c < e2 + s2);
}

/* Exact unpolarised dielectric (Cook & Torrance 1982, eq 8 of their appendix), relative index
 * eta of the inside to the outside; total internal reflection (g^2 < 0) gives 1.
 * g^2 = eta^2 - sin^2 by eta2_minus_sin2 keeps g = c (F = 0) at eta = 1 and g at small eta; the
 * one 0/0 point, eta = 1 and c = 0, takes its limit along c, 0. */
FN realN fresnel_dielectric(realN eta, realN c)
{
    realN s2 = (1 - c) * (1 + c);
    realN g2 = eta2_minus_sin2(eta, c, s2);
    realN g = safe_sqrt(g2);
    realN a = (g - c) / (g + c);
    /* b = (c (g + c) - 1) / (c (g - c) + 1), written without the cancellation of c^2 - 1 */
    realN b = (c * g - s2) / (c * g + s2);
    realN F = sel((realN)0.5 * a * a * (1 + b * b), (realN)0, g + c == 0);
    return sel(F, (realN)1, g2 < 0);
}

/* Cycles' Principled BSDF (its generalised Schlick with exponent < 0): the exact dielectric
 * curve of eta remapped onto [F0, F90], F0 + (F90 - F0) s with
 * s = saturate((F_d(c) - F_d(1)) / (1 - F_d(1))), F_d(1) = ((eta - 1)/(eta + 1))^2; the clamp
 * acts where F_d dips below its normal value (eta above about 4, near Brewster's angle). */
FN realN fresnel_remapped(realN f0, realN f90, realN eta, realN c)
{
    realN r = (eta - 1) / (eta + 1), r0 = r * r;
    realN s = clamp((fresnel_dielectric(eta, c) - r0) / (1 - r0), (realN)0, (realN)1);
    return f0 + (f90 - f0) * s;
}

/* The reflectance F and, in *T, the transmittance 1 - F without the cancellation of 1 - F where
 * F is near 1 (grazing c, or near the critical angle), sharing g: with
 * r_s = (c - g)/(c + g) and r_p = (eta^2 c - g)/(eta^2 c + g), F = (r_s^2 + r_p^2)/2 (Born &
 * Wolf; fresnel_dielectric's value to rounding), 1 - r_s^2 = 4 c g / (c + g)^2 and
 * 1 - r_p^2 = 4 eta^2 c g / (eta^2 c + g)^2. F = 1, T = 0 beyond the critical angle. */
FN realN fresnel_dielectric_FT(realN eta, realN c, realN *T)
{
    realN s2 = (1 - c) * (1 + c);
    realN g2 = eta2_minus_sin2(eta, c, s2);
    realN g = safe_sqrt(g2), e2c = eta * eta * c;
    realN i1 = 1 / (c + g), i2 = 1 / (e2c + g);
    realN rs = (c - g) * i1, rp = (e2c - g) * i2;
    maskN none = (g2 <= 0) | (c <= 0);
    *T = sel(2 * c * g * (i1 * i1 + eta * eta * i2 * i2), (realN)0, none);
    return sel((realN)0.5 * (rs * rs + rp * rp), (realN)1, none);
}

FN realN fresnel_dielectric_T(realN eta, realN c)
{
    realN T;
    fresnel_dielectric_FT(eta, c, &T);
    return T;
}

/* Unpolarised conductor with complex index eta + i k (Born & Wolf, real arithmetic form):
 * with a^2 + b^2 = sqrt(t1^2 + 4 eta^2 k^2), a^2 - b^2 = t1 = eta^2 - k^2 - sin^2,
 *   Rs = ((a - c)^2 + b^2) / ((a + c)^2 + b^2),
 *   Rp = Rs ((a c - s^2)^2 + b^2 c^2) / ((a c + s^2)^2 + b^2 c^2),   F = (Rs + Rp) / 2.
 * Written as sums of squares (not a2 + b2 + c^2 - 2ac, which cancels to F < 0 near eta = 1,
 * k = 0); a^2 and b^2 each from the form without cancellation for the sign of t1. */
FN realN fresnel_conductor(realN eta, realN k, realN c)
{
    realN c2 = c * c, s2 = (1 - c) * (1 + c);
    /* t1 = eta^2 - k^2 - s^2 with eta^2 - s^2 from eta2_minus_sin2: exact at eta = 1, k = 0,
     * where eta^2 - s^2 lost c^2 < 6e-8 in single and F came out 1 at grazing instead of 0 */
    realN t1 = eta2_minus_sin2(eta, c, s2) - k * k, ek2 = 2 * eta * eta * k * k;
    realN a2pb2 = sqrt(t1 * t1 + 2 * ek2);
    realN a2 = sel((realN)0.5 * (a2pb2 + t1), ek2 / (a2pb2 - t1), t1 < 0);
    realN b2 = sel((realN)0.5 * (a2pb2 - t1), ek2 / (a2pb2 + t1), t1 > 0);
    realN a = sqrt(a2);
    realN am = a - c, ap = a + c, pm = a * c - s2, pp = a * c + s2, b2c2 = b2 * c2;
    realN rs = (am * am + b2) / (ap * ap + b2);
    realN rp = rs * (pm * pm + b2c2) / (pp * pp + b2c2);
    return (realN)0.5 * (rp + rs);
}

#endif
