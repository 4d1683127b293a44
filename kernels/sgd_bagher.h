/* The SGD BRDF of Bagher, Soler & Holzschuch 2012 as its published MERL fits use it: the formula
 * of jdupuy/dj_brdf djb::sgd (eval, sgd__ndf, sgd__g1, fresnel::sgd), every parameter per channel.
 *
 *   f = (rho_d + rho_s F(wi.h) D(h) G1(wi) G1(wo) / (cos_i cos_o)) / pi
 *   D  = kap e^-y / (pi y^p cos^4 theta_h), y = alpha + tan^2 theta_h / alpha    (Bagher eq 6)
 *   F  = max(0, f0 - f1 c + (1 - c)^5 (1 - f0)), c = clamp(wi.h, 0, 1)           (Bagher eq 8)
 *   G1 = clamp(1 + lambda (1 - exp(c_g max(0, theta - theta0)^k)), 0, 1)          (Bagher eq 10)
 * Note the 1/pi outside: the specular term is (4 rho_s / pi) times the microfacet F D G / (4 ...).
 * The max(0, ...) is ours: the fit goes below 0 near c = 1 when f1 > f0 (3 of the 100 published
 * fits: blue-fabric to -0.073, white-fabric2, white-paint), which made f and E negative.
 *
 * | parameter | meaning (all per channel)                         | range          |
 * |-----------|---------------------------------------------------|----------------|
 * | rho_d     | diffuse albedo                                    | [0, 1]         |
 * | rho_s     | specular scale                                    | [0, 100]       |
 * | alpha, p  | SGD shape (kernels/dist_sgd.h)                    | [1e-5,1], [0,2]|
 * | kap       | NDF scale; absent: 1 / (alpha Gamma(1-p, alpha))  | (0, 1e8]       |
 * | f0, f1    | Fresnel fit                                       | [0,100],[-100,100] |
 * | lam, c, k, theta0 | shadowing fit (lambda, c, k, theta0)      | see the spec   |
 *
 * SGDB_KAP: 1 when kap is given. Sampling: one direction for all channels from the mixture of
 * 2 CHANNELS lobes, the cosine lobe of weight rho_d[c] and the SGD normals of channel c of weight
 * (4/pi) rho_s[c] kap[c] alpha[c] Gamma(1-p[c], alpha[c]) F_c(cos_o); the density is the
 * mixture density.
 */
#ifndef CLBRDF_SGD_BAGHER_H
#define CLBRDF_SGD_BAGHER_H

#define SGD_NO_LAMBDA 1
#include "dist_sgd.h"

#define sgd_bagher_SAMPLE_DIMS 3

FN realN sgdb_fresnel(const sgd_bagher_params *P, realN c, int ch)
{
    realN m = 1 - c, m2 = m * m;
    return fmax(P->f0[ch] - c * P->f1[ch] + m2 * m2 * m * (1 - P->f0[ch]), (realN)0);
}

FN realN sgdb_g1(const sgd_bagher_params *P, vec3 w, int ch)
{
    realN dth = fmax(acos(clamp(w.z, (realN)-1, (realN)1)) - P->theta0[ch], (realN)0);
    realN e = exp(log(P->c[ch]) + P->k[ch] * log(dth));    /* c dth^k; 0 at dth = 0 */
    return clamp(1 - P->lam[ch] * expm1(e), (realN)0, (realN)1);
}

/* a Gamma(1-p, a) of channel ch: 1/kap of the normalised NDF. */
FN realN sgdb_inv_kap(const sgd_bagher_params *P, int ch) { return sgd_inv_kap(P->alpha[ch], P->p[ch]); }

FN realN sgdb_kap(const sgd_bagher_params *P, int ch, realN inv_kap)
{
    (void)P; (void)ch;   /* the interface's; not every configuration reads it */
#if SGDB_KAP
    return P->kap[ch];
#else
    return 1 / inv_kap;
#endif
}

/* f at the half vector h of (wo, wi) with c = wi.h: the sampler passes the h it drew
 * (normalize(wi + wo) of a rounded wi misses a sharp lobe at grazing angles in single
 * precision). */
FN spec sgdb_eval_h(const sgd_bagher_params *P, vec3 wo, vec3 wi, vec3 h, realN c)
{
    realN cd = clamp(c, (realN)0, (realN)1);
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int ch = 0; ch < CHANNELS; ++ch) {
#if SGDB_KAP
        realN kap = P->kap[ch];
#else
        realN kap = 1 / sgdb_inv_kap(P, ch);
#endif
        realN D = sgd_D_kap(P->alpha[ch], P->p[ch], kap, h);
        realN G = sgdb_g1(P, wi, ch) * sgdb_g1(P, wo, ch);
        realN v = (P->rho_d[ch] + P->rho_s[ch] * sgdb_fresnel(P, cd, ch) * D * G / (wi.z * wo.z))
                  * INV_PI_R;
        f.c[ch] = sel((realN)0, v, ok);
    }
    return f;
}

ALWAYS_INLINE spec sgd_bagher_eval(const sgd_bagher_params *P, vec3 wo, vec3 wi)
{
    return sgdb_eval_h(P, wo, wi, normalize3(add3(wi, wo)), half_cos(wo, wi));
}

/* Lobe weights of the sampling mixture; inv_kap[ch] = alpha Gamma(1-p, alpha). Returns the sum. */
FN realN sgdb_weights(const sgd_bagher_params *P, vec3 wo, const realN *inv_kap, realN *wd, realN *ws)
{
    realN tot = 0;
    for (int ch = 0; ch < CHANNELS; ++ch) {
        wd[ch] = P->rho_d[ch];
        ws[ch] = (realN)(4 * 0.31830988618379067154) * P->rho_s[ch]
                 * sgdb_kap(P, ch, inv_kap[ch]) * inv_kap[ch]
                 * sgdb_fresnel(P, clamp(wo.z, (realN)0, (realN)1), ch);
        tot += wd[ch] + ws[ch];
    }
    return tot;
}

/* Mixture density of wi (solid angle) with h its half vector and c = wo.h; the cosine density
 * where every weight is 0. */
FN realN sgdb_pdf_h(const sgd_bagher_params *P, vec3 wo, vec3 wi, vec3 h, realN c, const realN *inv_kap)
{
    realN wd[CHANNELS], ws[CHANNELS];
    realN tot = sgdb_weights(P, wo, inv_kap, wd, ws);
    realN cos_pdf = fmax(wi.z, (realN)0) * INV_PI_R;
    realN spec_geo = h.z / (4 * c);
    realN acc = 0;
    for (int ch = 0; ch < CHANNELS; ++ch)
        acc += wd[ch] * cos_pdf
               + ws[ch] * sgd_D_kap(P->alpha[ch], P->p[ch], 1 / inv_kap[ch], h) * spec_geo;
    realN pdf = sel(cos_pdf, acc / tot, tot > 0);
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

ALWAYS_INLINE realN sgd_bagher_pdf(const sgd_bagher_params *P, vec3 wo, vec3 wi)
{
    realN inv_kap[CHANNELS];
    for (int ch = 0; ch < CHANNELS; ++ch)
        inv_kap[ch] = sgdb_inv_kap(P, ch);
    return sgdb_pdf_h(P, wo, wi, normalize3(add3(wi, wo)), half_cos(wo, wi), inv_kap);
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define sgd_bagher_LOBES (2 * CHANNELS)
FN void sgd_bagher_lobe_ends(const sgd_bagher_params *P, vec3 wo, realN *ends)
{
    realN inv_kap[CHANNELS], wd[CHANNELS], ws[CHANNELS];
    for (int ch = 0; ch < CHANNELS; ++ch)
        inv_kap[ch] = sgdb_inv_kap(P, ch);
    realN tot = sgdb_weights(P, wo, inv_kap, wd, ws), acc = 0;
    for (int ch = 0; ch < CHANNELS; ++ch) {      /* per channel: cosine, then specular */
        ends[2 * ch] = sel((realN)1, (acc + wd[ch]) / tot, tot > 0);
        acc += wd[ch] + ws[ch];
        ends[2 * ch + 1] = sel((realN)1, acc / tot, tot > 0);
    }
    ends[2 * CHANNELS - 1] = (realN)1;
}

ALWAYS_INLINE BSample sgd_bagher_sample(const sgd_bagher_params *P, vec3 wo, rand4 u)
{
    realN inv_kap[CHANNELS], wd[CHANNELS], ws[CHANNELS];
    for (int ch = 0; ch < CHANNELS; ++ch)
        inv_kap[ch] = sgdb_inv_kap(P, ch);
    realN tot = sgdb_weights(P, wo, inv_kap, wd, ws);
    /* pick a lobe with u2: the last channel's specular lobe unless an earlier interval holds x */
    realN x = u.u2 * tot, acc = 0;
    realN a = P->alpha[CHANNELS - 1], pp = P->p[CHANNELS - 1];
    maskN diffuse = tot <= 0, found = diffuse;
    for (int ch = 0; ch < CHANNELS; ++ch) {
        realN end_d = acc + wd[ch], end_s = end_d + ws[ch];
        maskN in_d = !found & (x < end_d);
        maskN in_s = !found & !in_d & (x < end_s);
        diffuse = diffuse | in_d;
        a = sel(a, P->alpha[ch], in_s);
        pp = sel(pp, P->p[ch], in_s);
        found = found | in_d | in_s;
        acc = end_s;
    }
    Microfacet m = MICROFACET(a, a, pp, P);
    vec3 h = sgd_sample_ndf(m, u.u0, u.u1);
    BSample s;
    vec3 wc = square_to_cosine_hemisphere(u.u0, u.u1);
    s.wi = select3(reflect3(wo, h), wc, diffuse);
    /* weight and pdf at the drawn h for a lobe sample, at normalize(wc + wo) for a cosine one */
    realN ch;
    vec3 hh = mixture_half(wo, h, wc, diffuse, &ch);
    s.pdf = sgdb_pdf_h(P, wo, s.wi, hh, ch, inv_kap);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    s.weight = spec_scale(sgdb_eval_h(P, wo, s.wi, hh, ch), s.wi.z / s.pdf);
    return bsample_where(s, ok);
}

#endif
