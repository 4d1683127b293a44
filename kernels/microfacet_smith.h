/* Smith masking-shadowing of a microfacet distribution MF_DIST (microfacet_distributions.h),
 * shared by the reflection model (microfacet.h) and the rough dielectric (dielectric.h):
 * G1 = 1 / (1 + Lambda), and G2 by MF_MASKING: height-correlated 1 / (1 + Lambda(wo) +
 * Lambda(wi)) (Heitz 2014, section 6), separable G1(wo) G1(wi), Cook-Torrance's V-cavity, or
 * G1(wo) alone (unshadowed: the visible normals' own measure, whose albedo is the mean over
 * visible normals of F times wi above the horizon, as Cycles' gen-Schlick tables; not
 * reciprocal).
 * Lambda takes |w.z|, so that a direction below the surface is masked as its mirror image
 * (docs/models/microfacet.md, docs/models/dielectric.md).
 */
#ifndef CLBRDF_MICROFACET_SMITH_H
#define CLBRDF_MICROFACET_SMITH_H

#define MASKING_NONE 0
#define MASKING_VCAVITY 1
#define MASKING_SEPARABLE 2
#define MASKING_CORRELATED 3
#define MASKING_UNSHADOWED 4
#define MASKING_BETA 5          /* correlated; the dielectric's refraction: B(1 + Lo, 1 + Lt) */
#define SAMPLER_NDF 0
#define SAMPLER_VNDF 1

#define MF(fn) CAT(MF_DIST, CAT(_, fn))

/* c / (c + Lambda(w)): G1(w) for c = 1; for c = 1 + Lambda(wo) the correlated G2 / G1(wo).
 * With Lambda = t / d: c d / (c d + t) with one division, written 1 - t / (c d + t) where it is
 * above 1/2 (one rounding near 1, where a sharp lobe's weights lie: c d r rounds three times and
 * near-mirror GGX's single-precision stderr was 1.75x double's; 1 - t r everywhere cancels at
 * grazing: G1 at mu 1e-6 was 1e-3 off). t = 0: 1, also where w underflowed (t = d = 0). */
FN realN mf_G1c(Microfacet m, vec3 w, realN c)
{
#if MF(HAS_LAMBDA_PARTS)
    realN d, t = MF(Lambda_parts)(m, w, &d);
    realN cd = c * d, r = 1 / (cd + t);
    return sel(sel(cd * r, 1 - t * r, t < cd), (realN)1, t == 0);
#else
    return c / (c + MF(Lambda)(m, w));
#endif
}

FN realN mf_G1(Microfacet m, vec3 w) { return mf_G1c(m, w, (realN)1); }

/* Masking-shadowing G(wo, wi, h) (docs/models/microfacet.md). */
FN realN mf_G(Microfacet m, vec3 wo, vec3 wi, vec3 h)
{
    (void)h; (void)m;   /* the interface's; not every configuration reads it */
#if MF_MASKING == MASKING_CORRELATED || MF_MASKING == MASKING_BETA
    return 1 / (1 + MF(Lambda)(m, wi) + MF(Lambda)(m, wo));
#elif MF_MASKING == MASKING_SEPARABLE
    return mf_G1(m, wi) * mf_G1(m, wo);
#elif MF_MASKING == MASKING_VCAVITY
    return vcavity_G(wo, wi, h);
#elif MF_MASKING == MASKING_UNSHADOWED
    return mf_G1(m, wo);
#else
    return (realN)1;
#endif
}

/* G(wo, wi, h) / G1(wo): the visible-normal sampler's weight without Fresnel. */
FN realN mf_G_over_G1(Microfacet m, vec3 wo, vec3 wi, vec3 h)
{
    (void)h; (void)wo;   /* the interface's; not every configuration reads it */
#if MF_MASKING == MASKING_CORRELATED || MF_MASKING == MASKING_BETA
    return mf_G1c(m, wi, 1 + MF(Lambda)(m, wo));
#elif MF_MASKING == MASKING_SEPARABLE
    return mf_G1(m, wi);
#elif MF_MASKING == MASKING_UNSHADOWED
    (void)m;
    return (realN)1;
#else
    return mf_G(m, wo, wi, h) * (1 + MF(Lambda)(m, wo));
#endif
}

#endif
