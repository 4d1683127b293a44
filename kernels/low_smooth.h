/* Löw, Kronander, Ynnerman & Unger 2012, smooth-surface BRDF (eq 12-14), optional two-lobe
 * variant (eq 34), with the paper's disk sampler (eq 17-22).
 *
 *   f = kd / pi + F(theta_d; eta) S(|Dp|)                      (eq 12, G' = 1)
 *   f = kd / pi + S2(|Dp|) + F(theta_d; eta) S(|Dp|)           (eq 34: S2 has no Fresnel factor)
 *   S(f) = a / (1 + b f^2)^c (eq 11), Dp = Lp + Vp (tangent-plane parts of wi, wo; eq 10),
 *   cos theta_d = sqrt(1 - |Lp - Vp|^2 / 4) (eq 13-14), F the exact dielectric Fresnel.
 *
 * | parameter        | meaning                                          | range        |
 * |------------------|--------------------------------------------------|--------------|
 * | a (per channel)  | A of eq 11: scale of the Fresnel lobe            | [0, 1e8]     |
 * | b                | B of eq 11: sharpness (1e8: near mirror)         | [1e-6, 1e9]  |
 * | c                | C of eq 11: fall-off of the wide-angle tail      | (0, 50]      |
 * | eta              | Fresnel parameter (a fitting value, not an index)| (0, 1000]    |
 * | kd (per channel) | albedo of the Lambertian term                    | [0, 1]       |
 * | a2 (per channel) | two-lobe variant: A of the lobe without Fresnel  | [0, 1e8]     |
 * | b2, c2           | two-lobe variant: B, C of that lobe              | as b, c      |
 *
 * Compile-time configuration: LOW_DIFFUSE 0|1 (kd), LOW_TWO_LOBES 0|1 (a2, b2, c2).
 *
 * Sampling (eq 17-22): on the unit disk of Lp the density of the C = 1 lobe,
 *   P_d = b / (pi L (1 + b |Lp + Vp|^2)),  L = ln((1 + b cos^2_o + sqrt(Q)) / 2)   (eq 18-19)
 *   Q = 1 + 2 b (1 + r_o^2) + b^2 cos^4_o, pdf(wi) = P_d cos_i                     (eq 17)
 *   r_i^2 = (E - 2)(E + 2 b r_o^2) / (2 b E), E = 2 exp(u0 L)                       (eq 20, 22)
 *         = e (1 + e + b r_o^2) / (b (1 + e)), e = expm1(u0 L)
 *   phi_i = phi_o + 2 arctan(k tan(pi u1)), k^2 = (1 + b (r_i + r_o)^2) / (1 + b (r_i - r_o)^2)
 *                                                                                 (eq 21)
 * (sqrt(Q) - 1 is taken as (Q - 1)/(sqrt(Q) + 1) and L by log1p, so b -> 0 and b = 1e9 both
 * stay exact.) The density assumes C = 1 for every c; the weight f cos / pdf carries
 * (1 + b |Dp|^2)^(1 - c). With kd or the second lobe the lobes and the cosine lobe are
 * chosen by u2 with probabilities proportional to rough albedos, and pdf is the mixture density.
 */
#ifndef CLBRDF_LOW_SMOOTH_H
#define CLBRDF_LOW_SMOOTH_H

#include "fresnel.h"
#include "low_abc.h"

#ifndef LOW_DIFFUSE
#define LOW_DIFFUSE 0
#endif
#ifndef LOW_TWO_LOBES
#define LOW_TWO_LOBES 0
#endif
#define LOW_MIXTURE (LOW_DIFFUSE || LOW_TWO_LOBES)
#define low_smooth_SAMPLE_DIMS (LOW_MIXTURE ? 3 : 2)

/* |Dp|^2 = |Lp + Vp|^2 (eq 10). */
FN realN low_dp2(vec3 wo, vec3 wi) { return sqr(wi.x + wo.x) + sqr(wi.y + wo.y); }

/* cos theta_d = sqrt(1 - |Lp - Vp|^2 / 4) (eq 13-14), written for unit wi, wo as a sum of
 * squares, 0.5 sqrt(|Lp + Vp|^2 + 2 (cos_i^2 + cos_o^2)): the printed form cancels near the
 * grazing mirror direction (5 % off in single, and F = 1 at eta = 1 where it is 0). */
FN realN low_cos_d(vec3 wo, vec3 wi)
{
    return (realN)0.5 * sqrt(low_dp2(wo, wi) + 2 * (wi.z * wi.z + wo.z * wo.z));
}

/* L of eq 19 for a lobe of sharpness b seen from wo: pi A M_d = b / L. */
FN realN low_disk_log(realN b, vec3 wo)
{
    realN ro2 = wo.x * wo.x + wo.y * wo.y, co2 = wo.z * wo.z;
    realN q1 = 2 * b * (1 + ro2) + sqr(b * co2);          /* Q - 1 */
    realN sq1 = q1 / (sqrt(1 + q1) + 1);                  /* sqrt(Q) - 1 */
    return log1p((realN)0.5 * (b * co2 + sq1));
}

/* Density on the unit disk of the C = 1 lobe (eq 18), given L. */
FN realN low_disk_pdf(realN b, realN L, realN dp2)
{
    return b / (PI_R * L * (1 + b * dp2));
}

/* Lp for u0, u1 (eq 20-22); returns wi (z >= 0). */
FN vec3 low_disk_sample(realN b, realN L, vec3 wo, realN u0, realN u1)
{
    realN ro2 = wo.x * wo.x + wo.y * wo.y, ro = sqrt(ro2);
    realN e = expm1(u0 * L);
    realN ri2 = fmin(e * (1 + e + b * ro2) / (b * (1 + e)), (realN)1);
    realN ri = sqrt(ri2);
    /* tan(Delta / 2) = k tan(pi u1): half angle (p, q) ~ (cos(pi u1), k sin(pi u1)) */
    realN k = sqrt((1 + b * sqr(ri + ro)) / (1 + b * sqr(ri - ro)));
    realN cu, su = sincos_r(PI_R * u1, &cu);
    realN p = cu, q = k * su, n2 = p * p + q * q;
    realN cd = (p * p - q * q) / n2, sd = 2 * p * q / n2;
    /* unit vector of phi_o ((1, 0) at normal incidence) */
    realN inv = sel(1 / ro, (realN)0, ro <= 0);
    realN co = sel(wo.x * inv, (realN)1, ro <= 0), so = wo.y * inv;
    return v3(ri * (co * cd - so * sd), ri * (so * cd + co * sd), sqrt(1 - ri2));
}

/* Mixture probabilities (cosine lobe, lobe 1, lobe 2), proportional to rough albedos. */
typedef struct { realN d, l1, l2, L1, L2; } LowSmoothMix;

FN LowSmoothMix low_smooth_mix(const low_smooth_params *p, vec3 wo)
{
    LowSmoothMix m;
    m.L1 = low_disk_log(p->b, wo);
    m.d = m.l2 = m.L2 = (realN)0;
    m.l1 = (realN)1;
#if LOW_MIXTURE
    realN a1 = 0, a2 = 0, kd = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        a1 += p->a[c];
#if LOW_TWO_LOBES
        a2 += p->a2[c];
#endif
#if LOW_DIFFUSE
        kd += p->kd[c];
#endif
    }
    realN e1 = a1 * low_fresnel(p->eta, wo.z) * low_lobe_mass(p->b, p->c, m.L1);
    realN e2 = (realN)0;
#if LOW_TWO_LOBES
    m.L2 = low_disk_log(p->b2, wo);
    e2 = a2 * low_lobe_mass(p->b2, p->c2, m.L2);
#endif
    realN s = kd + e1 + e2;
    maskN none = !(s > 0);
    m.d = sel(kd / s, (realN)0, none);
    m.l2 = sel(e2 / s, (realN)0, none);
    m.l1 = sel(e1 / s, (realN)1, none);
#endif
    return m;
}

ALWAYS_INLINE spec low_smooth_eval(const low_smooth_params *p, vec3 wo, vec3 wi)
{
    realN dp2 = low_dp2(wo, wi);
    realN F = low_fresnel(p->eta, low_cos_d(wo, wi));
    realN s1 = F * exp(-p->c * log1p(p->b * dp2));           /* F S / a (eq 12) */
#if LOW_TWO_LOBES
    realN s2 = exp(-p->c2 * log1p(p->b2 * dp2));             /* S2 / a2 (eq 34) */
#endif
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        realN v = p->a[c] * s1;
#if LOW_TWO_LOBES
        v += p->a2[c] * s2;
#endif
#if LOW_DIFFUSE
        v += p->kd[c] * INV_PI_R;
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

FN realN low_smooth_pdf_mix(const low_smooth_params *p, LowSmoothMix m, vec3 wo, vec3 wi)
{
    realN dp2 = low_dp2(wo, wi);
    realN pd = m.l1 * low_disk_pdf(p->b, m.L1, dp2);
#if LOW_TWO_LOBES
    pd += m.l2 * low_disk_pdf(p->b2, m.L2, dp2);
#endif
    pd *= wi.z;                                               /* eq 17 */
#if LOW_DIFFUSE
    pd += m.d * wi.z * INV_PI_R;
#endif
    return sel((realN)0, pd, (wi.z > 0) & (wo.z > 0));
}

ALWAYS_INLINE realN low_smooth_pdf(const low_smooth_params *p, vec3 wo, vec3 wi)
{
    return low_smooth_pdf_mix(p, low_smooth_mix(p, wo), wo, wi);
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define low_smooth_LOBES 3
FN void low_smooth_lobe_ends(const low_smooth_params *p, vec3 wo, realN *ends)
{
    LowSmoothMix m = low_smooth_mix(p, wo);
    ends[0] = m.d;                            /* cosine */
    ends[1] = m.d + m.l2;                     /* second lobe */
    ends[2] = (realN)1;                       /* first lobe */
}

ALWAYS_INLINE BSample low_smooth_sample(const low_smooth_params *p, vec3 wo, rand4 u)
{
    LowSmoothMix m = low_smooth_mix(p, wo);
    BSample s;
    s.wi = low_disk_sample(p->b, m.L1, wo, u.u0, u.u1);
#if LOW_MIXTURE
#if LOW_TWO_LOBES
    s.wi = select3(s.wi, low_disk_sample(p->b2, m.L2, wo, u.u0, u.u1),
                   (u.u2 >= m.d) & (u.u2 < m.d + m.l2));
#endif
#if LOW_DIFFUSE
    s.wi = select3(s.wi, square_to_cosine_hemisphere(u.u0, u.u1), u.u2 < m.d);
#endif
    s.pdf = low_smooth_pdf_mix(p, m, wo, s.wi);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    s.weight = spec_scale(low_smooth_eval(p, wo, s.wi), s.wi.z / s.pdf);
#else
    /* f cos / pdf = F a (1 + b |Dp|^2)^(1 - c) L / b, P_d cancelled */
    realN dp2 = low_dp2(wo, s.wi);
    s.pdf = low_smooth_pdf_mix(p, m, wo, s.wi);
    maskN ok = (s.wi.z > 0) & (wo.z > 0);
    realN g = low_fresnel(p->eta, low_cos_d(wo, s.wi)) * low_abc_ratio(p->b, p->c, dp2)
              * PI_R * m.L1 / p->b;
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = p->a[c] * g;
#endif
    return bsample_where(s, ok);
}

#endif
