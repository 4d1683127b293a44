/* Microfacet reflection BRDF (Cook & Torrance 1982; Walter et al. 2007), optional Lambertian term.
 *
 *   f(wo, wi) = [ks] F(wi . h) D(h) G(wo, wi, h) / (4 cos_i cos_o)  [+ kd / pi]
 *
 * | parameter        | meaning                                   | range        |
 * |------------------|-------------------------------------------|--------------|
 * | alpha            | roughness (isotropic)                     | [1e-4, 10]   |
 * | alpha_x, alpha_y | roughness along x and y (anisotropic)     | [1e-4, 10]   |
 * | gamma / p        | shape of the GTR / SGD / exp-power NDF    | per header   |
 * | f0 (per channel) | Schlick reflectance at normal incidence   | [0, 1]       |
 * | f90 (per channel)| Schlick reflectance at grazing (MF_F90)   | [0, 1]       |
 * | exponent         | generalised Schlick's exponent            | (0, 1e5]     |
 * | f82 (per channel)| F82-tint (FRESNEL_F82)                    | [0, 1]       |
 * | eta (per channel)| relative index (dielectric), or real part | (0, 100]     |
 * | k (per channel)  | extinction coefficient (conductor)        | [0, 100]     |
 * | ks (per channel) | scale of the specular term                | [0, 1e6]     |
 * | kd (per channel) | albedo of the Lambertian term             | [0, 1]       |
 *
 * Compile-time configuration; only the chosen terms are compiled:
 *   MF_DIST     ggx | beckmann (here) | gtr | sgd | exppow (dist_*.h, included by the host)
 *   MF_SHAPE    the parameter that fills Microfacet.shape (gamma, p), if the NDF has one
 *   MF_KS       0 | 1: the specular scale ks
 *   MF_F90      0 | 1: Schlick's F with f90 (else f90 = 1)
 *   MF_ANISO    0: alpha; 1: alpha_x, alpha_y
 *   MF_MASKING  MASKING_NONE | MASKING_VCAVITY | MASKING_SEPARABLE | MASKING_CORRELATED |
 *               MASKING_UNSHADOWED (G1(wo) alone)
 *   MF_FRESNEL  FRESNEL_ONE | FRESNEL_SCHLICK | FRESNEL_GEN_SCHLICK | FRESNEL_F82 |
 *               FRESNEL_REMAPPED | FRESNEL_DIELECTRIC | FRESNEL_CONDUCTOR
 *   MF_DIFFUSE  0 | 1
 *   MF_SAMPLER  SAMPLER_NDF | SAMPLER_VNDF
 *
 * Sampling: h from the distribution of normals or of visible normals, wi = reflect(wo, h),
 * pdf(wi) = pdf(h) / (4 wo . h). With the Lambertian term the cosine lobe is chosen with
 * probability sum kd / (sum kd + sum ks F(cos_o)) (sums over channels) and the density is the
 * mixture of both.
 */
#ifndef CLBRDF_MICROFACET_H
#define CLBRDF_MICROFACET_H

#include "fresnel.h"
#include "microfacet_distributions.h"
#include "microfacet_smith.h"

#define FRESNEL_ONE 0
#define FRESNEL_SCHLICK 1
#define FRESNEL_DIELECTRIC 2
#define FRESNEL_CONDUCTOR 3
#define FRESNEL_GEN_SCHLICK 4
#define FRESNEL_F82 5
#define FRESNEL_REMAPPED 6
#define microfacet_SAMPLE_DIMS (MF_DIFFUSE ? 3 : 2)   /* numbers microfacet_sample uses */

FN Microfacet mf_distribution(const microfacet_params *p)
{
#if MF_ANISO
    Microfacet m = MICROFACET(p->alpha_x, p->alpha_y, (realN)0, p);
#else
    Microfacet m = MICROFACET(p->alpha, p->alpha, (realN)0, p);
#endif
#ifdef MF_SHAPE
    m.shape = p->MF_SHAPE;
#endif
    return m;
}

/* ks F(c) of channel ch. */
FN realN mf_fresnel(const microfacet_params *p, realN c, int ch)
{
    (void)c; (void)ch; (void)p;   /* the interface's; not every configuration reads it */
#if MF_FRESNEL == FRESNEL_SCHLICK && MF_F90
    realN F = fresnel_schlick_f90(p->f0[ch], p->f90[ch], c);
#elif MF_FRESNEL == FRESNEL_SCHLICK
    realN F = fresnel_schlick(p->f0[ch], c);
#elif MF_FRESNEL == FRESNEL_GEN_SCHLICK
    realN F = fresnel_gen_schlick(p->f0[ch], p->f90[ch], p->exponent, c);
#elif MF_FRESNEL == FRESNEL_F82
    realN F = fresnel_f82(p->f0[ch], p->f82[ch], c);
#elif MF_FRESNEL == FRESNEL_REMAPPED
    realN F = fresnel_remapped(p->f0[ch], p->f90[ch], p->eta[ch], c);
#elif MF_FRESNEL == FRESNEL_DIELECTRIC
    realN F = fresnel_dielectric(p->eta[ch], c);
#elif MF_FRESNEL == FRESNEL_CONDUCTOR
    realN F = fresnel_conductor(p->eta[ch], p->k[ch], c);
#else
    realN F = (realN)1;
#endif
#if MF_KS
    F *= p->ks[ch];
#endif
    return F;
}

/* Probability of the Lambertian lobe in the sampling mixture. */
FN realN mf_diffuse_prob(const microfacet_params *p, vec3 wo)
{
    (void)p; (void)wo;   /* the interface's; not every configuration reads it */
#if MF_DIFFUSE
    realN kd = 0, fs = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        kd += p->kd[c];
        fs += mf_fresnel(p, wo.z, c);
    }
    realN s = kd + fs;
    return sel(kd / s, (realN)0, s <= 0);
#else
    return (realN)0;
#endif
}

ALWAYS_INLINE spec microfacet_eval(const microfacet_params *p, vec3 wo, vec3 wi)
{
    Microfacet m = mf_distribution(p);
    vec3 h = normalize3(add3(wi, wo));
    realN lobe = MF(D)(m, h) * mf_G(m, wo, wi, h) / (4 * wi.z * wo.z);
    realN c_d = half_cos(wo, wi);
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        realN v = mf_fresnel(p, c_d, c) * lobe;
#if MF_DIFFUSE
        v += p->kd[c] * INV_PI_R;
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

/* Density of the specular lobe's sampler, per unit solid angle of wi; oh = wo.h. */
FN realN mf_lobe_pdf(Microfacet m, vec3 wo, vec3 h, realN oh)
{
    (void)oh; (void)wo;   /* the interface's; not every configuration reads it */
#if MF_SAMPLER == SAMPLER_VNDF
    return mf_G1(m, wo) * MF(D)(m, h) / (4 * wo.z);
#else
    return MF(D)(m, h) * h.z / (4 * oh);
#endif
}

ALWAYS_INLINE realN microfacet_pdf(const microfacet_params *p, vec3 wo, vec3 wi)
{
    Microfacet m = mf_distribution(p);
    vec3 h = normalize3(add3(wi, wo));
    realN pdf = mf_lobe_pdf(m, wo, h, half_cos(wo, wi));
#if MF_DIFFUSE
    realN pd = mf_diffuse_prob(p, wo);
    pdf = cosine_mixture_pdf(pd, wi, pdf);
#endif
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define microfacet_LOBES 2
FN void microfacet_lobe_ends(const microfacet_params *p, vec3 wo, realN *ends)
{
    ends[0] = mf_diffuse_prob(p, wo);         /* cosine */
    ends[1] = (realN)1;                       /* specular */
}

ALWAYS_INLINE BSample microfacet_sample(const microfacet_params *p, vec3 wo, rand4 u)
{
    Microfacet m = mf_distribution(p);
    BSample s;
#if MF_SAMPLER == SAMPLER_VNDF
    /* wr = |hs|^2 wi from the unnormalised hs; where the weight needs neither wi nor h (no Fresnel,
     * no diffuse term, a scale-free Lambda) the compiler drops both normalisations */
    vec3 hs = MF(sample_vndf)(m, wo, u.u0, u.u1);
    vec3 h = normalize3(hs), wr = reflect_scaled(wo, hs);
#if MF_DIFFUSE
    s.wi = reflect3(wo, h);        /* from h, as the mixture's weight is (the check's f cos / pdf
                                    * at mu 1e-6 was off 1e-3 in 5% of samples from wr) */
#else
    s.wi = normalize3(wr);
#endif
#else
    vec3 h = MF(sample_ndf)(m, u.u0, u.u1), wr = reflect3(wo, h);
    s.wi = wr;
#endif
    maskN ok = (wr.z > 0) & (wo.z > 0);
#if MF_DIFFUSE
    /* mixture with the cosine lobe: weight = f cos / mixture pdf, evaluated with the half vector
     * of the chosen direction: the drawn h for a lobe sample (normalize(wi + wo) of the rounded
     * wi misses a near-mirror lobe at grazing angles in single precision: exppow alpha 1e-3,
     * kd 0.2, mu 1e-6 was 0.83 % low, 9 sd), normalize(wc + wo) for a cosine sample. */
    realN pd = mf_diffuse_prob(p, wo);
    maskN diffuse = u.u2 < pd;
    vec3 wc = square_to_cosine_hemisphere(u.u0, u.u1);
    s.wi = select3(s.wi, wc, diffuse);
    realN c_h;
    vec3 hh = mixture_half(wo, h, wc, diffuse, &c_h);
    s.pdf = cosine_mixture_pdf(pd, s.wi, mf_lobe_pdf(m, wo, hh, c_h));
    ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    /* f cos_i = F D G / (4 cos_o) + kd cos_i / pi */
    realN lobe = MF(D)(m, hh) * mf_G(m, wo, s.wi, hh) / (4 * wo.z);
    realN inv = 1 / s.pdf;
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = (mf_fresnel(p, c_h, c) * lobe + p->kd[c] * INV_PI_R * s.wi.z) * inv;
#else
    /* f cos_i / pdf with D cancelled: vndf F G / G1(wo); ndf F G (wo.h) / (cos_o cos_h) */
    realN c_d = dot3(wo, h);
#if MF(LAMBDA_SCALE_FREE) && (MF_MASKING == MASKING_CORRELATED || MF_MASKING == MASKING_SEPARABLE)
    vec3 wl = wr;                             /* the direction Lambda(wi) takes */
#else
    vec3 wl = s.wi;
#endif
    s.pdf = mf_lobe_pdf(m, wo, h, c_d);
#if MF_SAMPLER == SAMPLER_VNDF
    realN g = mf_G_over_G1(m, wo, wl, h);
#else
    realN g = mf_G(m, wo, wl, h) * c_d / (wo.z * h.z);
#endif
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = mf_fresnel(p, c_d, c) * g;
#endif
    return bsample_where(s, ok);
}

#endif
