/* Rough dielectric interface: microfacet reflection and refraction (Walter et al. 2007, "Microfacet
 * models for refraction through rough surfaces", eqs 13-21), directions on the whole sphere.
 *
 * | parameter        | meaning                                                | range        |
 * |------------------|--------------------------------------------------------|--------------|
 * | alpha            | roughness (isotropic)                                  | [1e-4, 10]   |
 * | alpha_x, alpha_y | roughness along x and y (anisotropic)                  | [1e-4, 10]   |
 * | eta              | index of the side below (z < 0) relative to the side above | [0.01, 100] |
 *
 * In the frame where wo is above (z of both directions negated when wo.z < 0, and eta -> 1/eta:
 * eta is then the index of wi's side relative to wo's when wi is below), with F the exact
 * dielectric Fresnel at wo.h (1 beyond the critical angle):
 *   reflection (wi.z > 0), h = normalize(wo + wi):
 *     f = F D G / (4 |cos_i| cos_o)                                          (eq 20)
 *   refraction (wi.z < 0), h = +-normalize(wo + eta wi) with h.z > 0, wo.h > 0 > wi.h:
 *     f = (1 - F) D G |wi.h| wo.h / (|cos_i| cos_o (wi.h + wo.h / eta)^2)   (eq 21 times eta^2)
 *         and the same / eta^2 with DI_TRANSPORT_RADIANCE (eq 21: radiance, Walter's BTDF).
 * The first form (importance, energy) integrates to the energy that crosses the interface
 * (what renderers' glass tables hold, e.g. Cycles' ggx_glass_E); the radiance form keeps the
 * 1/eta^2 by which radiance changes across it. Generalised reciprocity: radiance
 * f(wo, wi) / n_o^2 = f(wi, wo) / n_i^2, importance f(wo, wi) / n_i^2 = f(wi, wo) / n_o^2 (n_o, n_i
 * the indices of the sides of wo and wi).
 * G: MF_MASKING correlated 1 / (1 + Lambda(wo) + Lambda(wi)) for both branches, as Cycles and
 * pbrt-v4; separable G1(wo) G1(wi), as Walter 2007 and Mitsuba 3 (microfacet_smith.h); beta:
 * height-correlated exactly, 1 / (1 + Lambda(wo) + Lambda(wi)) for reflection and the Beta
 * function B(1 + Lambda(wo), 1 + Lambda(wi)) for refraction (Heitz 2014, uniform heights: a
 * refracted ray goes down, where the surface masks it less the deeper it starts), the single
 * scattering of Heitz et al. 2016's random walk (clbrdf/ref/heitz_ms.py).
 * eta = 1 exactly is no interface: no reflection, and transmission is the delta wi = -wo with
 * weight 1 (eval and pdf 0, the sampler's pdf infinite), as Cycles treats |eta - 1| < 1e-4; or,
 * with DI_ETA1_LIMIT, the limit eta -> 1 of the microfacet model, the same delta of weight
 * G(wo, -wo) / G1(wo) (as OpenPBR's tables hold it).
 *
 * Compile-time configuration:
 *   MF_DIST       ggx | beckmann (microfacet_distributions.h)
 *   MF_ANISO      0: alpha; 1: alpha_x, alpha_y
 *   MF_MASKING    MASKING_CORRELATED | MASKING_SEPARABLE | MASKING_BETA
 *   MF_SAMPLER    SAMPLER_VNDF | SAMPLER_NDF
 *   DI_LOBES      DI_BOTH | DI_REFLECTION | DI_TRANSMISSION: the terms f has (E_R + E_T, E_R, E_T)
 *   DI_TRANSPORT  DI_IMPORTANCE | DI_RADIANCE
 *   DI_ETA1       DI_ETA1_NONE | DI_ETA1_LIMIT: eta = 1 as no interface or as the limit
 *
 * Sampling: h from the (visible) normals of wo, then reflection with probability F(wo.h) and
 * refraction otherwise (DI_BOTH; one branch only otherwise), so that the weight is G / G1(wo)
 * (VNDF) for either branch. pdf: reflection P_r D_vis(h) / (4 wo.h); refraction
 * P_t D_vis(h) |wi.h| / (wi.h + wo.h / eta)^2 (Walter eq 17), D_vis = G1(wo) D(h) wo.h / cos_o,
 * or D(h) h.z for the NDF sampler.
 */
#ifndef CLBRDF_DIELECTRIC_H
#define CLBRDF_DIELECTRIC_H

#include "fresnel.h"
#include "microfacet_distributions.h"
#include "microfacet_smith.h"
#include "special.h"

#define DI_BOTH 3
#define DI_REFLECTION 1
#define DI_TRANSMISSION 2
#define DI_IMPORTANCE 0
#define DI_RADIANCE 1
#define DI_ETA1_NONE 0
#define DI_ETA1_LIMIT 1

#define dielectric_SAMPLE_DIMS (DI_LOBES == DI_BOTH ? 3 : 2)
#define dielectric_TRANSMITS 1       /* directions on both sides (integrators.cl) */
#define dielectric_SAMPLE_MEAN 1     /* dielectric_sample_mean: the weight averaged over u2 */

FN Microfacet di_distribution(const dielectric_params *p)
{
#if MF_ANISO
    Microfacet m = MICROFACET(p->alpha_x, p->alpha_y, (realN)0, p);
#else
    Microfacet m = MICROFACET(p->alpha, p->alpha, (realN)0, p);
#endif
    return m;
}

/* The frame where wo is above: *s = -1 where wo.z < 0 (the z of both directions negated), 1
 * elsewhere; returns the relative index of the side opposite wo. */
ALWAYS_INLINE realN di_frame(const dielectric_params *p, vec3 *wo, vec3 *wi, realN *s)
{
    maskN below = wo->z < 0;
    *s = sel((realN)1, (realN)-1, below);
    wo->z *= *s;
    wi->z *= *s;
    return sel(p->eta, 1 / p->eta, below);
}

/* The probabilities of the reflection and refraction branches where the Fresnel reflectance is F
 * and the transmittance T = 1 - F (each computed without cancellation). */
FN void di_branch_probs(realN F, realN T, realN *pr, realN *pt)
{
    (void)F; (void)T;
#if DI_LOBES == DI_BOTH
    *pr = F;
    *pt = T;
#elif DI_LOBES == DI_REFLECTION
    *pr = (realN)1;
    *pt = (realN)0;
#else
    *pr = (realN)0;
    *pt = (realN)1;
#endif
}

/* The fraction of F (reflection) and 1 - F (refraction) that f keeps. */
#define DI_KEEPS_R (DI_LOBES != DI_TRANSMISSION)
#define DI_KEEPS_T (DI_LOBES != DI_REFLECTION)

/* The radiance form's factor on refraction, 1 / eta^2 (eta: wi's side relative to wo's). */
FN realN di_transport(realN eta)
{
#if DI_TRANSPORT == DI_RADIANCE
    return 1 / (eta * eta);
#else
    (void)eta;
    return (realN)1;
#endif
}

/* G of the branch (reflection where refl) and G / G1(wo). */
FN realN di_G(Microfacet m, vec3 wo, vec3 wi, vec3 h, maskN refl)
{
#if MF_MASKING == MASKING_BETA
    realN a = 1 + MF(Lambda)(m, wo), b = 1 + MF(Lambda)(m, wi);
    return sel(beta_scaled(a, b, (realN)1), mf_G(m, wo, wi, h), refl);
#else
    (void)refl;
    return mf_G(m, wo, wi, h);
#endif
}

FN realN di_G_over_G1(Microfacet m, vec3 wo, vec3 wi, vec3 h, maskN refl)
{
#if MF_MASKING == MASKING_BETA
    realN a = 1 + MF(Lambda)(m, wo);
    return sel(beta_scaled(a, 1 + MF(Lambda)(m, wi), a), mf_G1c(m, wi, a), refl);
#else
    (void)refl;
    return mf_G_over_G1(m, wo, wi, h);
#endif
}

/* Density of the normals the sampler draws, per unit solid angle of h, at wo.h = oh > 0. */
FN realN di_normal_pdf(Microfacet m, vec3 wo, vec3 h, realN oh)
{
#if MF_SAMPLER == SAMPLER_VNDF
    return mf_G1(m, wo) * MF(D)(m, h) * oh / wo.z;
#else
    (void)wo; (void)oh;
    return MF(D)(m, h) * h.z;
#endif
}

/* f and pdf in the frame where wo is above (wo.z > 0); eta of wi's side when below. The
 * generalised half vector h = (wo + e wi) / |wo + e wi| (e = 1 for reflection, eta for
 * refraction), turned to h.z > 0: with L = |wo + e wi|, (wi.h + wo.h / eta)^2 = L^2 / eta^2,
 * which needs no difference of nearly equal cosines where eta is near 1. */
ALWAYS_INLINE realN di_eval_pdf(const dielectric_params *p, vec3 wo, vec3 wi, realN eta, realN *pdf)
{
    Microfacet m = di_distribution(p);
    maskN refl = wi.z > 0;
    realN e = sel(eta, (realN)1, refl);
    vec3 hv = add3(wo, scale3(wi, e));
    realN L = sqrt(dot3(hv, hv));
    vec3 h = scale3(hv, sel((realN)1, (realN)-1, hv.z < 0) / L);
    realN oh = sel(dot3(wo, h), (realN)0.5 * L, refl);        /* half_cos for reflection */
    realN ih = dot3(wi, h);
    /* a refracted pair's T from the side where the relative index exceeds 1: from the other
     * side F(c) has an infinite slope at the critical angle, where transmission from a dense
     * medium (eta 0.01) lives (the wo side gave 4e-9 relative, wi's 2e-16) */
    maskN flip = (eta < 1) & !refl;
    realN F = fresnel_dielectric(eta, oh);
    realN T = fresnel_dielectric_T(sel(eta, 1 / eta, flip), sel(oh, -ih, flip));
    realN D = MF(D)(m, h);
    realN G = di_G(m, wo, wi, h, refl);
    realN ci = fabs(wi.z), co = wo.z;
    realN jac_t = fabs(ih) * eta * eta / (L * L);             /* |wi.h| / (wi.h + wo.h/eta)^2 */
    realN fr = (DI_KEEPS_R ? F : (realN)0) * D * G / (4 * ci * co);
    realN ft = (DI_KEEPS_T ? T : (realN)0) * D * G * oh * jac_t / (ci * co) * di_transport(eta);
    realN pr, pt;
    di_branch_probs(F, T, &pr, &pt);
    realN ph = di_normal_pdf(m, wo, h, oh);
    realN pd = sel(pt * ph * jac_t, pr * ph / (4 * oh), refl);
    maskN ok = (co > 0) & (wi.z != 0) & (oh > 0) & (sel(ih < 0, ih > 0, refl))
               & (L > 0) & (h.z > 0) & (refl | (eta != 1));
    *pdf = sel((realN)0, pd, ok);
    return sel((realN)0, sel(ft, fr, refl), ok);
}

ALWAYS_INLINE spec dielectric_eval(const dielectric_params *p, vec3 wo, vec3 wi)
{
    realN s, pdf, eta = di_frame(p, &wo, &wi, &s);
    return spec_splat(di_eval_pdf(p, wo, wi, eta, &pdf));
}

ALWAYS_INLINE realN dielectric_pdf(const dielectric_params *p, vec3 wo, vec3 wi)
{
    realN s, pdf, eta = di_frame(p, &wo, &wi, &s);
    di_eval_pdf(p, wo, wi, eta, &pdf);
    return pdf;
}

/* The sampler's microfacet normal, drawn from (u0, u1) in the frame where wo is above, and what
 * both branches need of it: c = wo.h, g^2 = eta^2 cos_t^2, the Fresnel F and T, the branches'
 * probabilities and the density of h. */
typedef struct { Microfacet m; vec3 h; realN c, g2, g, F, T, pr, pt, ph; } DiNormal;

ALWAYS_INLINE DiNormal di_normal(const dielectric_params *p, vec3 wo, realN eta, rand4 u)
{
    DiNormal n;
    n.m = di_distribution(p);
#if MF_SAMPLER == SAMPLER_VNDF
    n.h = normalize3(MF(sample_vndf)(n.m, wo, u.u0, u.u1));
#else
    n.h = MF(sample_ndf)(n.m, u.u0, u.u1);
#endif
    n.c = dot3(wo, n.h);
    n.g2 = eta2_minus_sin2(eta, n.c, (1 - n.c) * (1 + n.c));
    n.g = safe_sqrt(n.g2);
    n.F = fresnel_dielectric_FT(eta, n.c, &n.T);
    di_branch_probs(n.F, n.T, &n.pr, &n.pt);
    n.ph = di_normal_pdf(n.m, wo, n.h, n.c);
    return n;
}

/* The sample of the branch ``refl`` picks per lane (reflection where true): its direction, its
 * weight f |cos_i| / pdf (the branch's share of F or T over its probability, 1 for DI_BOTH,
 * times G / G1(wo); 0 where the branch is impossible) and density. Refraction: wi = -wo / eta +
 * k h with k = wo.h / eta - cos_t = (1 - eta^2) / (eta (wo.h + eta cos_t)) (no cancellation near
 * eta = 1), and (wi.h + wo.h / eta)^2 = k^2. One direction and one masking term per sample: the
 * branch is chosen first (computing both cost GGX glass 25 % of its speed). */
ALWAYS_INLINE BSample di_branch(const DiNormal *n, vec3 wo, realN eta, maskN refl)
{
    vec3 h = n->h;
    realN c = n->c;
    realN k = (1 - eta) * (1 + eta) / (eta * (c + n->g));
    BSample b;
    b.wi = select3(sub3(scale3(h, k), scale3(wo, 1 / eta)), reflect3(wo, h), refl);
#if MF_SAMPLER == SAMPLER_VNDF
    realN g = di_G_over_G1(n->m, wo, b.wi, h, refl);
#else
    realN g = di_G(n->m, wo, b.wi, h, refl) * c / (wo.z * h.z);   /* (.) G wo.h / (cos_o h.z) */
#endif
#if DI_LOBES == DI_BOTH
    realN share = (realN)1;
#else
    realN share = sel((DI_KEEPS_T ? n->T : (realN)0) / n->pt,
                      (DI_KEEPS_R ? n->F : (realN)0) / n->pr, refl);
#endif
    b.weight = spec_splat(g * share * sel(di_transport(eta), (realN)1, refl));
    b.pdf = n->ph * sel(n->pt * n->g / (eta * k * k), n->pr / (4 * c), refl);
    maskN up = (wo.z > 0) & (c > 0);
    /* eta = 1: the delta wi = -wo (k = 0), of weight 1 (no interface) or G / G1(wo) (the limit
     * eta -> 1 of the microfacet model, DI_ETA1_LIMIT) */
    maskN none = (eta == 1) & !refl;
    b.wi = select3(b.wi, scale3(wo, (realN)-1), none);
#if DI_ETA1 == DI_ETA1_LIMIT
    realN g1 = g;
#else
    realN g1 = (realN)1;
#endif
    b.weight = spec_sel(b.weight, spec_splat(g1 * (realN)(DI_KEEPS_T ? 1 : 0)), none);
    b.pdf = sel(b.pdf, (realN)INFINITY, none);
    maskN ok = sel((up | none) & (b.wi.z < 0) & (n->g2 > 0) & (n->pt > 0),
                   up & (b.wi.z > 0) & (n->pr > 0), refl);
    return bsample_where(b, ok);
}

ALWAYS_INLINE BSample dielectric_sample(const dielectric_params *p, vec3 wo, rand4 u)
{
    realN s;
    vec3 wi = wo;
    realN eta = di_frame(p, &wo, &wi, &s);
    DiNormal n = di_normal(p, wo, eta, u);
    BSample b = di_branch(&n, wo, eta, u.u2 < n.pr);
    b.wi.z *= s;
    return b;
}

/* The sampler's weight averaged over u2 (which picks the branch) at (u0, u1): the integrand of
 * the deterministic quadrature (integrators.cl), whose panels then see both branches. */
FN spec dielectric_sample_mean(const dielectric_params *p, vec3 wo, rand4 u)
{
    realN s;
    vec3 wi = wo;
    realN eta = di_frame(p, &wo, &wi, &s);
    DiNormal n = di_normal(p, wo, eta, u);
    BSample r = di_branch(&n, wo, eta, TO_MASK((uintN)1 == (uintN)1));
    BSample t = di_branch(&n, wo, eta, TO_MASK((uintN)1 == (uintN)0));
    return spec_add(spec_scale(r.weight, n.pr), spec_scale(t.weight, n.pt));
}

#endif
