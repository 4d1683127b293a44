/* Löw, Kronander, Ynnerman & Unger 2012, microfacet ABC BRDF (eq 15) with the paper's half-vector
 * sampler (eq 23-28).
 *
 *   f = kd / pi + S(sqrt(1 - n.h)) F(theta_d; eta) G / (pi cos_i cos_o)            (eq 15)
 *   S(f) = a / (1 + b f^2)^c (eq 11), so S = a / (1 + b (1 - n.h))^c; cos theta_d = wi . h;
 *   G the V-cavity term (Cook & Torrance 1982); F the exact dielectric Fresnel. The pi in the
 *   denominator is the one the published fits use (bsdfbenchmark/bbm LowMicrofacetFit).
 *
 * | parameter        | meaning                                          | range        |
 * |------------------|--------------------------------------------------|--------------|
 * | a (per channel)  | A of eq 11: scale of the specular term           | [0, 1e8]     |
 * | b                | B of eq 11: sharpness (1e8: near mirror)         | [1e-6, 1e9]  |
 * | c                | C of eq 11: fall-off of the wide-angle tail      | (0, 50]      |
 * | eta              | Fresnel parameter                                | (0, 1000]    |
 * | kd (per channel) | albedo of the Lambertian term                    | [0, 1]       |
 *
 * Compile-time configuration: LOW_DIFFUSE 0|1 (kd).
 *
 * Sampling: P_h(h) = (1 + b x)^-c / N per unit solid angle of h, x = 1 - cos theta_h (eq 23),
 *   N = 2 pi ((1 + b)^(1-c) - 1) / (b (1 - c)) = 2 pi (L / b) expm1(t) / t,  L = log1p(b),
 *   t = (1 - c) L                                                               (eq 24)
 *   x = ((1 + u0 ((1 + b)^(1-c) - 1))^(1/(1-c)) - 1) / b
 *     = expm1(L log1p(u0 expm1(t)) / t) / b                                     (eq 25)
 *   phi_h = 2 pi u1 (eq 26), wi = reflect(wo, h) (eq 27), pdf(wi) = P_h / (4 wo.h) (eq 28).
 * One formula for every c, C = 1 included (low_abc.h), instead of the paper's switch to the C = 1
 * formula. x is evaluated as |H_t|^2 / (|H| (|H| + H_z)) with H = wi + wo, not 1 - h.z, which
 * cancels for b >~ 1/eps. With kd the cosine lobe is chosen by u2 with probability
 * sum kd / (sum kd + sum a F(cos_o) 8 L expm1(t) / (t b)) and pdf is the mixture density.
 */
#ifndef CLBRDF_LOW_MICROFACET_H
#define CLBRDF_LOW_MICROFACET_H

#include "fresnel.h"
#include "low_abc.h"

#ifndef LOW_DIFFUSE
#define LOW_DIFFUSE 0
#endif
#define low_microfacet_SAMPLE_DIMS (LOW_DIFFUSE ? 3 : 2)

/* x = 1 - cos theta_h from H = wi + wo, without cancellation. */
FN realN low_one_minus_cos_h(vec3 H)
{
    realN t2 = H.x * H.x + H.y * H.y, n = sqrt(t2 + H.z * H.z);
    return t2 / (n * (n + H.z));
}

/* 1 / N of eq 24: P_h = (1 + b x)^-c / N. */
FN realN low_h_norm_inv(realN b, realN c)
{
    realN L = log1p(b);
    return b / (2 * PI_R * L * low_expm1_over((1 - c) * L));
}


FN realN low_mf_diffuse_prob(const low_microfacet_params *p, vec3 wo)
{
    (void)p; (void)wo;   /* the interface's; not every configuration reads it */
#if LOW_DIFFUSE
    realN a = 0, kd = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        a += p->a[c];
        kd += p->kd[c];
    }
    /* specular weight at h = n: 4 a F N / pi */
    realN L = log1p(p->b);
    realN es = a * low_fresnel(p->eta, wo.z) * 8 * L * low_expm1_over((1 - p->c) * L) / p->b;
    realN s = kd + es;
    return sel(kd / s, (realN)0, !(s > 0));
#else
    return (realN)0;
#endif
}

ALWAYS_INLINE spec low_microfacet_eval(const low_microfacet_params *p, vec3 wo, vec3 wi)
{
    vec3 H = add3(wi, wo);
    vec3 h = normalize3(H);
    realN x = low_one_minus_cos_h(H);
    realN lobe = exp(-p->c * log1p(p->b * x))                     /* S / a (eq 11) */
                 * low_fresnel(p->eta, half_cos(wo, wi)) * vcavity_G(wo, wi, h)
                 / (PI_R * wi.z * wo.z);                          /* eq 15 */
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        realN v = p->a[c] * lobe;
#if LOW_DIFFUSE
        v += p->kd[c] * INV_PI_R;
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

/* Density of the half-vector sampler per unit solid angle of wi (eq 23, 28). */
FN realN low_mf_lobe_pdf(const low_microfacet_params *p, vec3 wo, vec3 wi)
{
    realN x = low_one_minus_cos_h(add3(wi, wo));
    realN oh = half_cos(wo, wi);
    return exp(-p->c * log1p(p->b * x)) * low_h_norm_inv(p->b, p->c) / (4 * oh);
}

ALWAYS_INLINE realN low_microfacet_pdf(const low_microfacet_params *p, vec3 wo, vec3 wi)
{
    realN pdf = low_mf_lobe_pdf(p, wo, wi);
#if LOW_DIFFUSE
    realN pd = low_mf_diffuse_prob(p, wo);
    pdf = cosine_mixture_pdf(pd, wi, pdf);
#endif
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

/* Half vector for u0, u1 (eq 25-26). */
FN vec3 low_sample_h(realN b, realN c, realN u0, realN u1, realN *x_out)
{
    realN L = log1p(b);
    realN x = fmin(expm1(L * low_log1p_over(u0, (1 - c) * L)) / b, (realN)1);
    *x_out = x;
    realN st = sqrt(x * (2 - x));
    realN cp, sp = sincos_r(2 * PI_R * u1, &cp);
    return v3(st * cp, st * sp, 1 - x);
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define low_microfacet_LOBES 2
FN void low_microfacet_lobe_ends(const low_microfacet_params *p, vec3 wo, realN *ends)
{
    ends[0] = low_mf_diffuse_prob(p, wo);     /* cosine */
    ends[1] = (realN)1;                       /* microfacet lobe */
}

ALWAYS_INLINE BSample low_microfacet_sample(const low_microfacet_params *p, vec3 wo, rand4 u)
{
    realN x;
    vec3 h = low_sample_h(p->b, p->c, u.u0, u.u1, &x);
    BSample s;
    s.wi = reflect3(wo, h);                                      /* eq 27 */
#if LOW_DIFFUSE
    realN pd = low_mf_diffuse_prob(p, wo);
    s.wi = select3(s.wi, square_to_cosine_hemisphere(u.u0, u.u1), u.u2 < pd);
    s.pdf = low_microfacet_pdf(p, wo, s.wi);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    s.weight = spec_scale(low_microfacet_eval(p, wo, s.wi), s.wi.z / s.pdf);
#else
    /* f cos / pdf with S / P_h = a N: a F G 4 (wo.h) N / (pi cos_o) */
    realN oh = dot3(wo, h);
    realN ninv = low_h_norm_inv(p->b, p->c);
    s.pdf = exp(-p->c * log1p(p->b * x)) * ninv / (4 * oh);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (oh > 0);
    realN g = low_fresnel(p->eta, oh) * vcavity_G(wo, s.wi, h) * 4 * oh
              / (ninv * PI_R * wo.z);
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = p->a[c] * g;
#endif
    return bsample_where(s, ok);
}

#endif
