/* Schlick 1994, "An inexpensive BRDF model for physically-based rendering" (customizable
 * reflectance model); docs/models/schlick.md.
 *
 * | parameter         | meaning                                                  | range        |
 * |-------------------|----------------------------------------------------------|--------------|
 * | c (per channel)   | reflection factor C at normal incidence, layer 1         | [0, 1]       |
 * | r                 | roughness, layer 1 (0 mirror .. 1 Lambertian)            | [1e-7, 1]    |
 * | p                 | isotropy, layer 1 (0 fully anisotropic .. 1 isotropic)   | [1e-6, 1]    |
 * | psi               | scratch direction, layer 1: (cos psi, sin psi, 0)        | [-2pi, 2pi]  |
 * | c2, r2, p2, psi2  | the same for layer 2 of a DOUBLE material                |              |
 *
 * t = n.h, u = wo.h, v = n.wo, v' = n.wi, w = cos phi (phi: azimuth of h from the scratch).
 *   S(u) = C (eq 10) | C + (1 - C)(1 - u)^5 (eq 11)
 *   Z(t) = r / (1 + r t^2 - t^2)^2,  A(w) = sqrt(p / (p^2 - p^2 w^2 + w^2))  (eq 14)
 *   G(v) = v / (r - r v + v)  (eq 16)
 *   D = Z A / (4 pi v v') (eq 12) | G G' Z A / (4 pi v v') (eq 15)
 *     | r A / pi + (1 - r) Z A / (4 pi v v') (eq 17) | (1 - G G') A / pi + G G' Z A / (4 pi v v') (eq 18)
 *   SINGLE R = S D;  DOUBLE R = S D + (1 - S) S2 D2  (eq 9)
 * At h = n (phi undefined) w = 1: A = sqrt(p).
 *
 * Compile-time configuration (clbrdf/models/schlick.py):
 *   SCH_DOUBLE 0 | 1, SCH_FRESNEL 0 (eq 10) | 1 (eq 11), SCH_EQ 12 | 15 | 17 | 18,
 *   SCH_ANISO1, SCH_ANISO2 0 | 1 (p, psi of the layer compiled; otherwise p = 1, A = 1).
 *
 * Sampler (ours; docs/models/schlick.md): per layer the half vector has density
 * t Z(t) A(phi) / (pi <A>), <A> = sqrt(p) / AGM(1, p) the azimuthal mean of A: t by inverting
 * the CDF of 2 t Z(t) (tan^2 theta_h = r u / (1 - u)), phi exactly by Gauss's AGM
 * transformation (sch_azimuth); wi = reflect(wo, h), pdf = t Z A / (pi <A> 4 wo.h). Eq 17/18
 * mix in the cosine lobe with probability r (eq 17) or 1 - G(v) 2 / (2 + r) (eq 18); DOUBLE
 * picks layer 1 with probability sum S(v) / (sum S(v) + sum (1 - S(v)) S2(v)).
 */
#ifndef CLBRDF_SCHLICK_H
#define CLBRDF_SCHLICK_H

#include "fresnel.h"

#define SCH_DIFFUSE (SCH_EQ == 17 || SCH_EQ == 18)
#define schlick_SAMPLE_DIMS ((SCH_DOUBLE || SCH_DIFFUSE) ? 3 : 2)
#define SCH_AGM_STEPS 9          /* AGM(1, p) to double precision for p >= 1e-7 */

typedef struct { realN r, p, ct, st; } SchLayer;

FN SchLayer sch_layer(realN r, realN p, realN psi)
{
    SchLayer L;
    L.r = r;
    L.p = p;
    L.st = sincos_r(psi, &L.ct);
    return L;
}

FN SchLayer sch_layer1(const schlick_params *p)
{
#if SCH_ANISO1
    return sch_layer(p->r, p->p, p->psi);
#else
    SchLayer L = {p->r, (realN)1, (realN)1, (realN)0};
    return L;
#endif
}

#if SCH_DOUBLE
FN SchLayer sch_layer2(const schlick_params *p)
{
#if SCH_ANISO2
    return sch_layer(p->r2, p->p2, p->psi2);
#else
    SchLayer L = {p->r2, (realN)1, (realN)1, (realN)0};
    return L;
#endif
}
#endif

/* S(u), eq 10 / eq 11; eq 11 is fresnel_schlick, which keeps 1 - u in [0, 1]: a rounded
 * u = wo.h < 0 made S > 1 and R = S D + (1 - S) S2 D2 negative (-1e5 /sr with a sharp layer 2) */
FN realN sch_S(realN C, realN u)
{
    (void)u;   /* the interface's; not every configuration reads it */
#if SCH_FRESNEL
    return fresnel_schlick(C, u);
#else
    return C;
#endif
}

/* Z(t), eq 14, with 1 - t^2 = hx^2 + hy^2 (h unit) */
FN realN sch_Z(realN r, vec3 h)
{
    realN d = h.x * h.x + h.y * h.y + r * h.z * h.z;
    return r / (d * d);
}

/* A(w), eq 14: A^2 = p (ht^2 + hb^2) / (ht^2 + p^2 hb^2), (ht, hb) the components of h along
 * and across the scratch; sqrt(p) at h = n. */
FN realN sch_A(SchLayer L, vec3 h, int aniso)
{
    if (!aniso)
        return (realN)1;
    realN ht = h.x * L.ct + h.y * L.st, hb = h.y * L.ct - h.x * L.st;
    realN ht2 = ht * ht, hb2 = hb * hb;
    realN den = ht2 + L.p * L.p * hb2;
    return sel(sqrt(L.p * (ht2 + hb2) / den), sqrt(L.p), den <= 0);
}

/* G(v), eq 16, and 1 - G(v) = r (1 - v) / (r - r v + v) without the cancellation of 1 - G at
 * small r (r = 1e-7: 1 - G G' was 35 % off in single precision) */
FN realN sch_G(realN r, realN v) { return v / (r - r * v + v); }
FN realN sch_1mG(realN r, realN v) { return r * (1 - v) / (r - r * v + v); }

/* directional factor D of one layer (eq 12 / 15 / 17 / 18) */
FN realN sch_D(SchLayer L, int aniso, vec3 wo, vec3 wi, vec3 h)
{
    realN A = sch_A(L, h, aniso);
    realN za = sch_Z(L.r, h) * A * (realN)(0.25 * INV_PI_R) / (wo.z * wi.z);
#if SCH_EQ == 12
    return za;
#elif SCH_EQ == 15
    return sch_G(L.r, wo.z) * sch_G(L.r, wi.z) * za;
#elif SCH_EQ == 17
    return L.r * A * INV_PI_R + (1 - L.r) * za;
#else
    realN go = sch_G(L.r, wo.z), gi = sch_G(L.r, wi.z);
    /* 1 - go gi = (1 - go) + go (1 - gi) */
    return (sch_1mG(L.r, wo.z) + go * sch_1mG(L.r, wi.z)) * A * INV_PI_R + go * gi * za;
#endif
}

/* R (eq 9) with a given half vector h (unit, h = normalize(wi + wo)) and u = wo.h */
FN spec sch_eval_h(const schlick_params *p, vec3 wo, vec3 wi, vec3 h, realN u)
{
    realN d1 = sch_D(sch_layer1(p), SCH_ANISO1, wo, wi, h);
#if SCH_DOUBLE
    realN d2 = sch_D(sch_layer2(p), SCH_ANISO2, wo, wi, h);
#endif
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        realN s1 = sch_S(p->c[c], u);
        realN v = s1 * d1;
#if SCH_DOUBLE
        v += (1 - s1) * sch_S(p->c2[c], u) * d2;
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

ALWAYS_INLINE spec schlick_eval(const schlick_params *p, vec3 wo, vec3 wi)
{
    return sch_eval_h(p, wo, wi, normalize3(add3(wi, wo)), half_cos(wo, wi));
}

/* ---- sampling ---- */

/* AGM(1, p): <A> = sqrt(p) / AGM(1, p) */
FN realN sch_agm(realN p)
{
    realN a = 1, b = p;
    for (int n = 0; n < SCH_AGM_STEPS; ++n) {
        realN an = (a + b) / 2;
        b = sqrt(a * b);
        a = an;
    }
    return a;
}

/* Solid-angle density of wi for the half-vector lobe of one layer: t Z A / (pi <A> 4 wo.h) */
FN realN sch_lobe_pdf(SchLayer L, int aniso, vec3 wo, vec3 h, realN u)
{
    (void)wo;   /* the interface's; not every configuration reads it */
    realN a_rel = aniso ? sch_A(L, h, aniso) * sch_agm(L.p) * rsqrt(L.p) : (realN)1;
    return h.z * sch_Z(L.r, h) * a_rel * (realN)(0.25 * INV_PI_R) / u;
}

/* probability of the cosine lobe within a layer */
FN realN sch_diffuse_prob(SchLayer L, realN v)
{
#if SCH_EQ == 17
    return L.r;
#elif SCH_EQ == 18
    /* 1 - G q with q = 2 / (2 + r): (1 - G) + G (1 - q) */
    return sch_1mG(L.r, v) + sch_G(L.r, v) * L.r / (2 + L.r);
#else
    return (realN)0;
#endif
}

/* probability of layer 1 */
FN realN sch_layer_prob(const schlick_params *p, realN v)
{
    (void)p; (void)v;   /* the interface's; not every configuration reads it */
#if SCH_DOUBLE
    realN w1 = 0, w2 = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        realN s1 = sch_S(p->c[c], v);
        w1 += s1;
        w2 += (1 - s1) * sch_S(p->c2[c], v);
    }
    realN w = w1 + w2;
    return sel(w1 / w, (realN)0.5, w <= 0);
#else
    return (realN)1;
#endif
}

FN realN sch_layer_mix_pdf(SchLayer L, int aniso, vec3 wo, vec3 wi, vec3 h, realN u)
{
    realN lobe = sch_lobe_pdf(L, aniso, wo, h, u);
#if SCH_DIFFUSE
    realN pd = sch_diffuse_prob(L, wo.z);
    lobe = cosine_mixture_pdf(pd, wi, lobe);
#endif
    return lobe;
}

FN realN sch_pdf_h(const schlick_params *p, vec3 wo, vec3 wi, vec3 h, realN u)
{
    realN pdf = sch_layer_mix_pdf(sch_layer1(p), SCH_ANISO1, wo, wi, h, u);
#if SCH_DOUBLE
    realN P1 = sch_layer_prob(p, wo.z);
    pdf = P1 * pdf + (1 - P1) * sch_layer_mix_pdf(sch_layer2(p), SCH_ANISO2, wo, wi, h, u);
#endif
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

ALWAYS_INLINE realN schlick_pdf(const schlick_params *p, vec3 wo, vec3 wi)
{
    return sch_pdf_h(p, wo, wi, normalize3(add3(wi, wo)), half_cos(wo, wi));
}

/* Azimuth of h with density A(phi) / (2 pi <A>): (cos phi, sin phi) relative to the scratch.
 * Quadrant from 4 u; within it chi = distance from the peak of A at phi = pi/2 has density
 * ~ 1 / sqrt(p^2 cos^2 chi + sin^2 chi). Gauss's transformation sin chi = 2 a sin chi' /
 * ((a + b) + (a - b) sin^2 chi') maps that measure with (a, b) onto the one with
 * ((a + b)/2, sqrt(a b)); from (p, 1) the AGM steps reach a = b, where chi is uniform:
 * chi_N = pi/2 frac(4 u). Back, in T = tan chi (no cancellation):
 * T_n = 2 a_n T sqrt(1 + T^2) / sqrt((a_n + b_n)^2 + 4 a_n b_n T^2). */
FN realN sch_azimuth(realN p, realN u, realN *sin_phi)
{
    realN a[SCH_AGM_STEPS], b[SCH_AGM_STEPS];
    realN an = p, bn = 1;
    for (int n = 0; n < SCH_AGM_STEPS; ++n) {
        a[n] = an;
        b[n] = bn;
        realN t = (an + bn) / 2;
        bn = sqrt(an * bn);
        an = t;
    }
    realN q = floor(4 * u);
    realN tau = 4 * u - q;
    realN tm = fmin(tau, 1 - tau);
    realN tn = tan((realN)(0.5 * PI_R) * tm);
    realN T = sel(tn, 1 / tn, tau > (realN)0.5);
    for (int n = SCH_AGM_STEPS - 1; n >= 0; --n)
        T = 2 * a[n] * T * sqrt(1 + T * T) / sqrt(sqr(a[n] + b[n]) + 4 * a[n] * b[n] * T * T);
    realN cos_chi = rsqrt(1 + T * T), sin_chi = T * cos_chi;
    /* quadrants 0..3: phi = pi/2 - chi, pi/2 + chi, 3pi/2 - chi, 3pi/2 + chi */
    maskN q12 = (q == 1) | (q == 2), q23 = q >= 2;
    *sin_phi = sel(cos_chi, -cos_chi, q23);
    return sel(sin_chi, -sin_chi, q12);
}

/* half vector of one layer's lobe */
FN vec3 sch_sample_h(SchLayer L, int aniso, realN u0, realN u1)
{
    /* eq 14: CDF of 2 t Z from the peak: tan^2 theta = r u / (1 - u) */
    realN d = 1 - u1 + L.r * u1;
    realN cos_t = sqrt((1 - u1) / d), sin_t = sqrt(L.r * u1 / d);
    realN cp, sp;
    if (aniso) {
        cp = sch_azimuth(L.p, u0, &sp);
        realN x = cp * L.ct - sp * L.st, y = cp * L.st + sp * L.ct;
        cp = x;
        sp = y;
    } else {
        sp = sincos_r(2 * PI_R * u0, &cp);
    }
    return v3(sin_t * cp, sin_t * sp, cos_t);
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define schlick_LOBES (SCH_DOUBLE && SCH_DIFFUSE ? 4 : 2)
FN void schlick_lobe_ends(const schlick_params *p, vec3 wo, realN *ends)
{
#if SCH_DOUBLE && SCH_DIFFUSE
    realN P1 = sch_layer_prob(p, wo.z);
    ends[0] = P1 * sch_diffuse_prob(sch_layer1(p), wo.z);              /* layer 1: cosine, */
    ends[1] = P1;                                                        /* lobe */
    ends[2] = P1 + (1 - P1) * sch_diffuse_prob(sch_layer2(p), wo.z);   /* layer 2: cosine, */
#elif SCH_DOUBLE
    ends[0] = sch_layer_prob(p, wo.z);                                   /* layer 1, layer 2 */
#else
    ends[0] = sch_diffuse_prob(sch_layer1(p), wo.z);                     /* cosine, lobe */
#endif
    ends[schlick_LOBES - 1] = (realN)1;
}

ALWAYS_INLINE BSample schlick_sample(const schlick_params *p, vec3 wo, rand4 u)
{
#if SCH_DOUBLE
    /* u2 picks the layer, then, rescaled to [0, 1), the lobe within it */
    realN P1 = sch_layer_prob(p, wo.z);
    maskN first = u.u2 < P1;
    SchLayer L1 = sch_layer1(p), L2 = sch_layer2(p);
    vec3 h = select3(sch_sample_h(L2, SCH_ANISO2, u.u0, u.u1),
                     sch_sample_h(L1, SCH_ANISO1, u.u0, u.u1), first);
#if SCH_DIFFUSE
    realN ud = sel((u.u2 - P1) / fmax(1 - P1, (realN)REAL_EPS), u.u2 / fmax(P1, (realN)REAL_EPS), first);
    realN pd = sel(sch_diffuse_prob(L2, wo.z), sch_diffuse_prob(L1, wo.z), first);
#endif
#else
    vec3 h = sch_sample_h(sch_layer1(p), SCH_ANISO1, u.u0, u.u1);
#if SCH_DIFFUSE
    realN ud = u.u2;
    realN pd = sch_diffuse_prob(sch_layer1(p), wo.z);
#endif
#endif
    BSample s;
    s.wi = reflect3(wo, h);
    realN uh = dot3(wo, h);
#if SCH_DIFFUSE
    maskN diffuse = ud < pd;
    vec3 wc = square_to_cosine_hemisphere(u.u0, u.u1);
    s.wi = select3(s.wi, wc, diffuse);
    h = mixture_half(wo, h, wc, diffuse, &uh);
#endif
    s.pdf = sch_pdf_h(p, wo, s.wi, h, uh);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    s.weight = spec_scale(sch_eval_h(p, wo, s.wi, h, uh), s.wi.z / s.pdf);
    return bsample_where(s, ok);
}

#endif
