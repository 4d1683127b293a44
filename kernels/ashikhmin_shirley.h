/* Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model" (JGT 5(2)).
 *
 *   f(wo, wi) = [ks] rho_s + [rho_d] + [kd / pi]
 *   rho_s = sqrt((nu+1)(nv+1)) / (8 pi) (n.h)^e F(k.h) / ((k.h) max(n.wi, n.wo))       (eq 16)
 *   e     = (nu h_u^2 + nv h_v^2) / (1 - (n.h)^2) = nu cos^2 phi_h + nv sin^2 phi_h
 *   rho_d = 28 rd / (23 pi) (1 - rs) (1 - (1 - n.wi/2)^5) (1 - (1 - n.wo/2)^5)         (eq 14)
 *
 * | parameter        | meaning                                              | range       |
 * |------------------|------------------------------------------------------|-------------|
 * | nu, nv           | Phong exponents along the tangent u = x, bitangent v | [0, 1e7]    |
 * | rs (per channel) | specular reflectance at normal incidence (Schlick F0)| [0, 1]      |
 * | eta (per channel)| index of the exact dielectric Fresnel (AS_FRESNEL 1) | (0, 100]    |
 * | ks (per channel) | scale of rho_s (Löw et al.'s fits: their "albedo")   | [0, 1e6]    |
 * | rd (per channel) | diffuse albedo of eq 14                              | [0, 1]      |
 * | kd (per channel) | albedo of an added Lambertian term                   | [0, 1]      |
 *
 * Configuration: AS_FRESNEL 0 (Schlick, eq 11, F0 = rs) | 1 (dielectric, eta); AS_KS, AS_RD,
 * AS_KD 0 | 1 (terms compiled in).
 *
 * Numerics: (n.h)^e is exp(-(nu sx^2 + nv sy^2)/2 * log1p(t2)/t2) with the slopes sx = h_u/h_n,
 * sy = h_v/h_n, t2 = sx^2 + sy^2 (since log(n.h) = -log1p(t2)/2 and e = (nu sx^2 + nv sy^2)/t2):
 * no 0/0 at h = n (log1p(t2)/t2 -> 1) and no pow of a rounded n.h near 1. For wi, wo the slopes
 * come from s = wi + wo unnormalised and k.h = |s|/2 (exact for unit vectors), without the
 * cancellation of dot(wi, normalize(s)) when wi ~ -wo.
 *
 * Sampling: with probability 1 - p_d the half vector of eq 19-20 (eq 19 on the whole circle:
 * phi = atan2(sqrt(nu+1) sin 2 pi u0, sqrt(nv+1) cos 2 pi u0), which is the paper's quadrant
 * mapping with each quadrant run so that phi is continuous in u0), wi = reflect(wo, h), density
 * p_h(h) / (4 wo.h) (eq 5, 18); with probability p_d the cosine density. p_d = w_d / (w_d + w_s)
 * with w_d = sum_c rd (1 - rs)(1 - (1 - n.wo/2)^5) + kd (the diffuse terms' exact albedo) and
 * w_s = sum_c ks F(n.wo) (the albedo of a mirror with this Fresnel factor).
 */
#ifndef CLBRDF_ASHIKHMIN_SHIRLEY_H
#define CLBRDF_ASHIKHMIN_SHIRLEY_H

#include "fresnel.h"

#define AS_DIFFUSE (AS_RD || AS_KD)
#define ashikhmin_shirley_SAMPLE_DIMS (AS_DIFFUSE ? 3 : 2)   /* numbers the sampler uses */

/* (n.h)^e of eq 16 from any positive multiple of h (h.z > 0). */
FN realN as_lobe(const ashikhmin_shirley_params *p, vec3 h)
{
    realN iz = 1 / h.z;
    realN sx = h.x * iz, sy = h.y * iz;
    realN sx2 = sx * sx, sy2 = sy * sy, t2 = sx2 + sy2;
    realN l = sel(log1p(t2) / t2, (realN)1, t2 <= 0);          /* log1p(t2)/t2 -> 1 at h = n */
    return exp((realN)-0.5 * (p->nu * sx2 + p->nv * sy2) * l);
}

/* sqrt((nu+1)(nv+1)) */
FN realN as_norm(const ashikhmin_shirley_params *p) { return sqrt(p->nu + 1) * sqrt(p->nv + 1); }

/* ks F(c) of channel ch (eq 11 or the dielectric Fresnel). */
FN realN as_fresnel(const ashikhmin_shirley_params *p, realN c, int ch)
{
#if AS_FRESNEL
    realN F = fresnel_dielectric(p->eta[ch], c);
#else
    realN F = fresnel_schlick(p->rs[ch], c);
#endif
#if AS_KS
    F *= p->ks[ch];
#endif
    return F;
}

/* 1 - (1 - x/2)^5 without cancellation for small x: a (5 - 10 a + 10 a^2 - 5 a^3 + a^4), a = x/2. */
FN realN as_one_minus_pow5(realN x)
{
    realN a = (realN)0.5 * x;
    return a * (5 + a * (-10 + a * (10 + a * (-5 + a))));
}

/* Diffuse terms of channel ch at cos_i, cos_o (eq 14, and kd / pi). */
FN realN as_diffuse(const ashikhmin_shirley_params *p, realN ci, realN co, int ch)
{
    (void)ch; (void)ci; (void)co; (void)p;   /* the interface's; not every configuration reads it */
    realN d = 0;
#if AS_RD
    d += (realN)(28.0 / 23.0) * INV_PI_R * p->rd[ch] * (1 - p->rs[ch])
         * as_one_minus_pow5(ci) * as_one_minus_pow5(co);
#endif
#if AS_KD
    d += p->kd[ch] * INV_PI_R;
#endif
    return d;
}

/* f given h (any positive multiple) and k.h. */
FN spec as_eval_h(const ashikhmin_shirley_params *p, vec3 wo, vec3 wi, vec3 h, realN kh)
{
    realN s = as_norm(p) * (realN)(0.125) * INV_PI_R * as_lobe(p, h)
              / (kh * fmax(wi.z, wo.z));                                   /* eq 16 */
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        realN v = as_fresnel(p, kh, c) * s;
#if AS_DIFFUSE
        v += as_diffuse(p, wi.z, wo.z, c);
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

ALWAYS_INLINE spec ashikhmin_shirley_eval(const ashikhmin_shirley_params *p, vec3 wo, vec3 wi)
{
    vec3 s = add3(wi, wo);
    return as_eval_h(p, wo, wi, s, (realN)0.5 * sqrt(dot3(s, s)));
}

/* Exact albedo of the diffuse terms of channel ch at cos_o: the integral of
 * (1 - (1 - n.wi/2)^5) n.wi over the hemisphere is 23 pi / 28, so rd (1 - rs)(1 - (1 - cos_o/2)^5) + kd. */
FN realN as_diffuse_albedo(const ashikhmin_shirley_params *p, realN co, int ch)
{
    (void)ch; (void)co; (void)p;   /* the interface's; not every configuration reads it */
    realN d = 0;
#if AS_RD
    d += p->rd[ch] * (1 - p->rs[ch]) * as_one_minus_pow5(co);
#endif
#if AS_KD
    d += p->kd[ch];
#endif
    return d;
}

/* Probability of the cosine lobe in the sampling mixture. */
FN realN as_diffuse_prob(const ashikhmin_shirley_params *p, vec3 wo)
{
    (void)p; (void)wo;   /* the interface's; not every configuration reads it */
#if AS_DIFFUSE
    realN wd = 0, ws = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        wd += as_diffuse_albedo(p, wo.z, c);
        ws += as_fresnel(p, wo.z, c);
    }
    realN sum = wd + ws;
    return sel(wd / sum, (realN)0, sum <= 0);
#else
    return (realN)0;
#endif
}

/* Specular lobe density p_h(h) / (4 k.h) (eq 5, 18) from h (any positive multiple) and k.h. */
FN realN as_lobe_pdf(const ashikhmin_shirley_params *p, vec3 h, realN kh)
{
    return as_norm(p) * (realN)0.125 * INV_PI_R * as_lobe(p, h) / kh;
}

FN realN as_pdf_h(const ashikhmin_shirley_params *p, vec3 wo, vec3 wi, vec3 h, realN kh)
{
    realN pdf = as_lobe_pdf(p, h, kh);
#if AS_DIFFUSE
    realN pd = as_diffuse_prob(p, wo);
    pdf = cosine_mixture_pdf(pd, wi, pdf);
#endif
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

ALWAYS_INLINE realN ashikhmin_shirley_pdf(const ashikhmin_shirley_params *p, vec3 wo, vec3 wi)
{
    vec3 s = add3(wi, wo);
    return as_pdf_h(p, wo, wi, s, (realN)0.5 * sqrt(dot3(s, s)));
}

/* Half vector of eq 19-20 from (u0, u1). */
FN vec3 as_sample_h(const ashikhmin_shirley_params *p, realN u0, realN u1)
{
    realN c, s = sincos_2pi(u0, &c);
    realN x = sqrt(p->nv + 1) * c, y = sqrt(p->nu + 1) * s;        /* eq 19: tan phi = y / x */
    realN r = rsqrt(x * x + y * y);
    realN cp = x * r, sp = y * r;
    realN e1 = p->nu * cp * cp + p->nv * sp * sp + 1;
    realN lg = log1p(-u1) / e1;                                     /* eq 20: log cos theta */
    realN ct = exp(lg), st = sqrt(-expm1(2 * lg));
    return v3(st * cp, st * sp, ct);
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define ashikhmin_shirley_LOBES 2
FN void ashikhmin_shirley_lobe_ends(const ashikhmin_shirley_params *p, vec3 wo, realN *ends)
{
    ends[0] = as_diffuse_prob(p, wo);         /* cosine */
    ends[1] = (realN)1;                       /* specular */
}

ALWAYS_INLINE BSample ashikhmin_shirley_sample(const ashikhmin_shirley_params *p, vec3 wo, rand4 u)
{
    vec3 h = as_sample_h(p, u.u0, u.u1);
    BSample s;
    s.wi = reflect3(wo, h);
    realN kh = dot3(wo, h);
#if AS_DIFFUSE
    /* mixture with the cosine lobe: weight = f cos / mixture pdf; a specular sample keeps its
     * own h, a cosine sample takes h = wi + wo and k.h = |wi + wo| / 2 */
    realN pd = as_diffuse_prob(p, wo);
    maskN diff = u.u2 < pd;
    s.wi = select3(s.wi, square_to_cosine_hemisphere(u.u0, u.u1), diff);
    vec3 hs = add3(s.wi, wo);
    h = select3(h, hs, diff);
    kh = sel(kh, (realN)0.5 * sqrt(dot3(hs, hs)), diff);
    s.pdf = as_pdf_h(p, wo, s.wi, h, kh);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    s.weight = spec_scale(as_eval_h(p, wo, s.wi, h, kh), s.wi.z / s.pdf);
#else
    /* f cos_i / pdf = ks F(k.h) cos_i / max(cos_i, cos_o) (eq 16 over eq 18) */
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (kh > 0);
    s.pdf = as_lobe_pdf(p, h, kh);
    realN g = s.wi.z / fmax(s.wi.z, wo.z);
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = as_fresnel(p, kh, c) * g;
#endif
    return bsample_where(s, ok);
}

#endif
