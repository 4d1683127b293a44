/* Holzschuch & Pacanowski 2015: diffuse + reflection (exponential-power Cook-Torrance) +
 * diffraction lobes (Holzschuch & Pacanowski 2015, eq 24-27).
 *
 * | parameter       | meaning                                                 | range       |
 * |-----------------|---------------------------------------------------------|-------------|
 * | kd (per channel)| diffuse albedo                                          | [0, 1]      |
 * | ks (per channel)| reflection (Cook-Torrance) lobe scale                   | [0, 1e6]    |
 * | f0 (per channel)| Schlick reflectance at normal incidence (eq 27)         | [0, 1.2]    |
 * | kw (per channel)| diffraction lobe scale (times 1/lambda^4, lambda in um) | [0, 1e6]    |
 * | a               | diffraction lobe width (spatial frequency, 1/um)        | (0, 100]    |
 * | sigma           | exponential-power width (eq 18)                         | [1e-4, 10]  |
 * | p               | exponential-power kurtosis (eq 18)                      | [0.1, 5]    |
 *
 *   f = kd/pi + G1(wi) G1(wo) (ks D(theta_h) F(theta_d) / (4 cos_i cos_o) + kw/lambda^4 S(f_s)/E)
 *   S(f_s) = 1 / (1 + f_s^2/a^2)^2,  f_s = |(wi + wo) x n| / lambda                 (eq 10, 25)
 * D, G1: kernels/dist_exppow.h. Wavelengths (um): R, G, B = 0.645, 0.526, 0.444 (section 5.5);
 * a one-channel model uses HP_LAMBDA1 (the option band: green by default).
 * E = E_a_lambda (eq 17): HP_ENERGY 0 "conserving": pi c / (1 + c), c = a^2 lambda^2, the
 * integral of S cos over the hemisphere at normal incidence, where it is largest, so the lobe
 * S/E has albedo <= 1 (exactly 1 at normal incidence without G); HP_ENERGY 1 "paper": as printed,
 * pi (1 + 1/c), whose lobe has albedo (c / (1 + c))^2 < 1 (docs/models/holzschuch_pacanowski.md).
 *
 * Sampling (section 5.5): a lobe with probability proportional to its largest albedo summed over
 * channels: ks (reflection, eq 22-23 normals), kw/lambda^4 times the lobe's albedo at normal
 * incidence (diffraction, cosine), kd (diffuse, cosine); the density is the mixture.
 */
#ifndef CLBRDF_HOLZSCHUCH_PACANOWSKI_H
#define CLBRDF_HOLZSCHUCH_PACANOWSKI_H

#include "dist_exppow.h"
#include "fresnel.h"

#define holzschuch_pacanowski_SAMPLE_DIMS 3

#if CHANNELS == 3
#define HP_LAMBDA(c) ((c) == 0 ? (real_t)0.645 : (c) == 1 ? (real_t)0.526 : (real_t)0.444)
#else
#define HP_LAMBDA(c) ((real_t)HP_LAMBDA1)
#endif

/* kw / (lambda^4 E_a_lambda) of channel c, and the diffraction lobe's albedo at normal incidence
 * (without G) in *albedo. */
FN realN hp_diffraction_scale(const holzschuch_pacanowski_params *p, int c, realN *albedo)
{
    real_t L = HP_LAMBDA(c);
    realN x = sqr(p->a * L);                                   /* c = a^2 lambda^2 */
    realN k = p->kw[c] / (L * L * L * L);
#if HP_ENERGY == 0
    *albedo = k;
    return k * (1 + x) / (PI_R * x);                           /* E = pi c / (1 + c) */
#else
    *albedo = k * sqr(x / (1 + x));
    return k * x / (PI_R * (1 + x));                           /* E = pi (1 + 1/c) */
#endif
}

/* f with the half vector h and c = wi.h given (the sampler passes the h it drew: recomputing
 * it from a rounded wi misses a near-mirror lobe at grazing angles in single precision). */
FN spec hp_eval_h(const holzschuch_pacanowski_params *p, vec3 wo, vec3 wi, vec3 h, realN ch)
{
    Microfacet m = MICROFACET(p->sigma, p->sigma, p->p, p);
    realN G = 1 / ((1 + exppow_Lambda(m, wi)) * (1 + exppow_Lambda(m, wo)));   /* eq 6-7 */
    realN refl = exppow_D(m, h) / (4 * wi.z * wo.z);                            /* eq 24, 26 */

    realN dp2 = sqr(wi.x + wo.x) + sqr(wi.y + wo.y);                             /* |Dp|^2 */
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        real_t L = HP_LAMBDA(c);
        realN alb;
        realN kw = hp_diffraction_scale(p, c, &alb);
        realN S = 1 / sqr(1 + dp2 / sqr(L * p->a));                              /* eq 25 */
        realN F = fresnel_schlick(p->f0[c], ch);                                 /* eq 27 */
        realN v = p->kd[c] * INV_PI_R + G * (p->ks[c] * F * refl + kw * S);
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

ALWAYS_INLINE spec holzschuch_pacanowski_eval(const holzschuch_pacanowski_params *p, vec3 wo, vec3 wi)
{
    return hp_eval_h(p, wo, wi, normalize3(add3(wi, wo)), half_cos(wo, wi));
}

/* Probabilities of the reflection lobe (*ps) and of the cosine lobes (returned). */
FN realN hp_lobe_probs(const holzschuch_pacanowski_params *p, realN *ps)
{
    realN s = 0, w = 0, d = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        realN alb;
        hp_diffraction_scale(p, c, &alb);
        s += p->ks[c];
        w += alb;
        d += p->kd[c];
    }
    realN t = s + w + d;
    *ps = sel(s / t, (realN)1, t <= 0);
    return sel((w + d) / t, (realN)0, t <= 0);
}

FN realN hp_pdf_h(const holzschuch_pacanowski_params *p, vec3 wo, vec3 wi, vec3 h, realN oh)
{
    Microfacet m = MICROFACET(p->sigma, p->sigma, p->p, p);
    realN ps, pc = hp_lobe_probs(p, &ps);
    realN lobe = sel((realN)0, exppow_D(m, h) * h.z / (4 * oh), oh > 0);
    realN pdf = ps * lobe + pc * wi.z * INV_PI_R;
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

ALWAYS_INLINE realN holzschuch_pacanowski_pdf(const holzschuch_pacanowski_params *p, vec3 wo, vec3 wi)
{
    return hp_pdf_h(p, wo, wi, normalize3(add3(wi, wo)), half_cos(wo, wi));
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define holzschuch_pacanowski_LOBES 2
FN void holzschuch_pacanowski_lobe_ends(const holzschuch_pacanowski_params *p, vec3 wo, realN *ends)
{
    (void)wo;   /* the interface's; not every configuration reads it */
    hp_lobe_probs(p, ends);                   /* reflection lobe */
    ends[1] = (realN)1;                       /* cosine */
}

ALWAYS_INLINE BSample holzschuch_pacanowski_sample(const holzschuch_pacanowski_params *p, vec3 wo, rand4 u)
{
    Microfacet m = MICROFACET(p->sigma, p->sigma, p->p, p);
    realN ps;
    hp_lobe_probs(p, &ps);
    vec3 h = exppow_sample_ndf(m, u.u0, u.u1);
    BSample s;
    vec3 wc = square_to_cosine_hemisphere(u.u0, u.u1);
    maskN refl = u.u2 < ps;
    s.wi = select3(wc, reflect3(wo, h), refl);
    realN ch;
    vec3 hh = mixture_half(wo, h, wc, u.u2 >= ps, &ch);
    s.pdf = hp_pdf_h(p, wo, s.wi, hh, ch);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    s.weight = spec_scale(hp_eval_h(p, wo, s.wi, hh, ch), s.wi.z / s.pdf);
    return bsample_where(s, ok);
}

#endif
