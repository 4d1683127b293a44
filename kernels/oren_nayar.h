/* Rough diffuse reflection: the energy-preserving Oren-Nayar model EON (Portsmouth, Kutz &
 * Hill 2025, JCGT 14(1), the OpenPBR diffuse lobe), its single-scattering part FON (Fujii's
 * Oren-Nayar) and the qualitative Oren-Nayar QON (Oren & Nayar 1994, MaterialX's form).
 *
 * | parameter | meaning                                   | range               |
 * |-----------|-------------------------------------------|---------------------|
 * | rho       | diffuse albedo                            | [0, 1], per channel |
 * | r         | roughness (QON: sigma, in radians)        | [0, 1]              |
 *
 * With s = wi.wo - cos_i cos_o (the cosine of the azimuth difference times sin_i sin_o):
 *
 *   FON:  f_ss = rho / pi A_F (1 + r s / t),  t = max(cos_i, cos_o) for s > 0, else 1,
 *         A_F = 1 / (1 + c1 r),  c1 = 1/2 - 2 / (3 pi)                           (eq 4, 5)
 *   EON:  f = f_ss + rho_ms / pi (1 - E_F(cos_o)) (1 - E_F(cos_i)) / (1 - Ebar_F)    (eq 13)
 *         E_F(mu) = A_F (1 + r G(mu) / pi),  Ebar_F = A_F (1 + c2 r),  c2 = 2/3 - 28 / (15 pi),
 *         G(mu) = sin (acos mu - sin mu) + 2/3 ((sin / mu)(1 - sin^3) - sin)     (eq 6, 7, 10)
 *         rho_ms = rho^2 Ebar_F / (1 - rho (1 - Ebar_F))                          (eq 12)
 *   QON:  f = rho / pi (A + B max(0, s) / max(cos_i, cos_o)),
 *         A = 1 - sigma^2 / (2 (sigma^2 + 0.33)), B = 0.45 sigma^2 / (sigma^2 + 0.09)
 *
 * ON_ALBEDO 1 replaces G / pi by the paper's quartic in 1 - mu (their Listing 1, E_FON_approx).
 * The multiple-scattering factors are written as 1 - E_F(mu) = r (c1 - G / pi) / (1 + c1 r)
 * and 1 - Ebar_F = r (c1 - c2) / (1 + c1 r), so r cancels and f is finite at r = 0 (the
 * listing clamps each factor at 1e-7 instead); the quartic's c1 - G / pi, below 0 by 5e-4 at
 * grazing, is clamped at 0 as the listing's max(eps, 1 - E) does.
 *
 * Sampling (ON_SAMPLER 0, the paper's section 5): u2 picks the uniform hemisphere with
 * probability P_u = r^0.1 (0.162925 + mu (-0.372058 + (0.538233 - 0.290822 mu) mu)), else the
 * clipped linearly transformed cosine (CLTC): the cosine disk clipped to x <= vz sqrt(1 - y^2),
 * vz = 1 / sqrt(1 + d^2), sent through M = [[a, 0, b], [0, c, 0], [d, 0, 1]] in the frame of
 * wo's azimuth, with a, b, c, d the paper's rational fits in (mu, r) (Listing 3, ltc_terms);
 * ON_SAMPLER 1 draws the cosine hemisphere.
 */
#ifndef CLBRDF_OREN_NAYAR_H
#define CLBRDF_OREN_NAYAR_H

#define oren_nayar_SAMPLE_DIMS (ON_SAMPLER == 0 ? 3 : 2)

#define ON_C1 ((real_t)0.2877934092108062)     /* 1/2 - 2 / (3 pi) */
#define ON_C2 ((real_t)0.07248821245692394)     /* 2/3 - 28 / (15 pi) */

/* c1 - G(mu) / pi >= 0 (eq 7, 10): 1 - E_F(mu) = r (c1 - G / pi) / (1 + c1 r). The term
 * (sin / mu)(1 - sin^3) is written sin mu (1 + sin + sin^2) / (1 + sin), exact at mu -> 0. */
FN realN on_one_minus_g(realN mu)
{
#if ON_ALBEDO == 0
    realN si = sqrt((1 - mu) * (1 + mu));
    realN g = si * (acos(mu) - si * mu)
              + (realN)(2.0 / 3.0) * (si * mu * (1 + si + si * si) / (1 + si) - si);
    return fmax(ON_C1 - g * INV_PI_R, (realN)0);
#else
    realN m = 1 - mu;
    realN gpi = m * ((realN)0.0571085289 + m * ((realN)0.491881867
                + m * ((realN)-0.332181442 + m * (realN)0.0714429953)));
    return fmax(ON_C1 - gpi, (realN)0);
#endif
}

ALWAYS_INLINE spec oren_nayar_eval(const oren_nayar_params *p, vec3 wo, vec3 wi)
{
    maskN ok = (wi.z > 0) & (wo.z > 0);
    realN r = p->r;
    realN s = dot3(wi, wo) - wi.z * wo.z;
    spec f;
#if ON_FORM == 2                                 /* QON */
    realN s2 = r * r;
    realN A = 1 - (realN)0.5 * s2 / (s2 + (realN)0.33);
    realN B = (realN)0.45 * s2 / (s2 + (realN)0.09);
    realN lobe = (A + B * fmax(s, (realN)0) / fmax(wi.z, wo.z)) * INV_PI_R;
    for (int c = 0; c < CHANNELS; ++c)
        f.c[c] = sel((realN)0, p->rho[c] * lobe, ok);
#else
    realN af = 1 / (1 + ON_C1 * r);
    realN ss = af * (1 + r * sel(s, s / fmax(wi.z, wo.z), s > 0)) * INV_PI_R;
#if ON_FORM == 0                                 /* EON: + the multiple-scattering lobe */
    realN ebar = af * (1 + ON_C2 * r);
    realN ms = r * on_one_minus_g(wo.z) * on_one_minus_g(wi.z)
               / ((1 + ON_C1 * r) * (ON_C1 - ON_C2)) * INV_PI_R;
#endif
    for (int c = 0; c < CHANNELS; ++c) {
        realN v = p->rho[c] * ss;
#if ON_FORM == 0
        realN rho = p->rho[c];
        v += rho * rho * ebar / (1 - rho * (1 - ebar)) * ms;
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
#endif
    return f;
}

#if ON_SAMPLER == 0
/* The CLTC's M (a, b, c, d) at mu = cos(theta_o) and r (the paper's Listing 3). */
FN void on_ltc_terms(realN mu, realN r, realN *a, realN *b, realN *c, realN *d)
{
    *a = 1 + r * ((realN)0.303392 + ((realN)-0.518982 + (realN)0.111709 * mu) * mu
                  + ((realN)-0.276266 + (realN)0.335918 * mu) * r);
    *b = r * ((realN)-1.16407 + (realN)1.15859 * mu + ((realN)0.150815 - (realN)0.150105 * mu) * r)
         / (mu * mu * mu - (realN)1.43545);
    *c = 1 + ((realN)0.20013 + ((realN)-0.506373 + (realN)0.261777 * mu) * mu) * r;
    *d = ((realN)0.540852 + ((realN)-1.01625 + (realN)0.475392 * mu) * mu) * r
         / ((realN)-1.0743 + mu * ((realN)0.0725628 + mu));
}

/* The probability of the uniform lobe (the paper's P_u). */
FN realN on_uniform_prob(const oren_nayar_params *p, vec3 wo)
{
    realN mu = wo.z;
    return pow_pos(p->r, (realN)0.1)
           * ((realN)0.162925 + mu * ((realN)-0.372058 + ((realN)0.538233 - (realN)0.290822 * mu) * mu));
}

/* wo's azimuth frame: X toward wo's tangential part (x when wo is the normal), Y = z x X. */
FN void on_frame(vec3 wo, realN *cx, realN *sx)
{
    realN l2 = wo.x * wo.x + wo.y * wo.y;
    maskN flat = l2 > 0;
    realN inv = rsqrt(sel((realN)1, l2, flat));
    *cx = sel((realN)1, wo.x * inv, flat);
    *sx = sel((realN)0, wo.y * inv, flat);
}

/* Density of the CLTC lobe at wi (solid angle): det(M)^2 (adj(M) w).z / (pi s |adj(M) w|^4). */
FN realN on_cltc_pdf(const oren_nayar_params *p, vec3 wo, vec3 wi)
{
    realN a, b, c, d, cx, sx;
    on_ltc_terms(wo.z, p->r, &a, &b, &c, &d);
    on_frame(wo, &cx, &sx);
    realN x = cx * wi.x + sx * wi.y, y = cx * wi.y - sx * wi.x, z = wi.z;
    realN det = c * (a - b * d);
    vec3 h = v3(c * (x - b * z), (a - b * d) * y, -c * (d * x - a * z));
    realN l2 = dot3(h, h);
    realN sc = (realN)0.5 * (1 + rsqrt(d * d + 1));
    return sqr(det / l2) * fmax(h.z, (realN)0) * INV_PI_R / sc;
}
#endif

ALWAYS_INLINE realN oren_nayar_pdf(const oren_nayar_params *p, vec3 wo, vec3 wi)
{
    maskN ok = (wi.z > 0) & (wo.z > 0);
#if ON_SAMPLER == 0
    realN pu = on_uniform_prob(p, wo);
    realN pdf = pu * (realN)(0.5 * INV_PI_R) + (1 - pu) * on_cltc_pdf(p, wo, wi);
#else
    (void)p;   /* the interface's; not every configuration reads it */
    realN pdf = cosine_hemisphere_pdf(wi);
#endif
    return sel((realN)0, pdf, ok);
}

#if ON_SAMPLER == 0
/* The lobes the sampler picks with u2: uniform for u2 < P_u, then the CLTC. */
#define oren_nayar_LOBES 2
FN void oren_nayar_lobe_ends(const oren_nayar_params *p, vec3 wo, realN *ends)
{
    ends[0] = on_uniform_prob(p, wo);
    ends[1] = (realN)1;
}
#endif

ALWAYS_INLINE BSample oren_nayar_sample(const oren_nayar_params *p, vec3 wo, rand4 u)
{
    BSample s;
#if ON_SAMPLER == 0
    realN a, b, c, d, cx, sx;
    on_ltc_terms(wo.z, p->r, &a, &b, &c, &d);
    on_frame(wo, &cx, &sx);
    realN cp, sp = sincos_2pi(u.u1, &cp);
    realN R = sqrt(u.u0);
    realN x = R * cp, y = R * sp;
    realN sc = (realN)0.5 * (1 + rsqrt(d * d + 1));
    /* the clipped disk, on the side away from the horizon for either sign of d: the listing's
     * x = -mix(sqrt(1 - y^2), x, sc) assumes d <= 0, but the fit of d is positive for
     * mu > 0.99978, where that clip sent samples below the horizon (E low by 4.3e-7 at r = 1,
     * mu = 1; docs/models/oren_nayar.md) */
    realN side = sel((realN)-1, (realN)1, d > 0);
    x = side * (sqrt((1 - y) * (1 + y)) * (1 - sc) + x * sc);
    realN hz = sqrt(fmax(1 - (x * x + y * y), (realN)0));
    vec3 l = v3(a * x + b * hz, c * y, d * x + hz);                /* M w_h, in wo's frame */
    vec3 wc = normalize3(v3(cx * l.x - sx * l.y, sx * l.x + cx * l.y, l.z));
    vec3 wu = square_to_uniform_hemisphere(u.u0, u.u1);
    s.wi = select3(wc, wu, u.u2 < on_uniform_prob(p, wo));
#else
    s.wi = square_to_cosine_hemisphere(u.u0, u.u1);
#endif
    s.pdf = oren_nayar_pdf(p, wo, s.wi);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    spec f = oren_nayar_eval(p, wo, s.wi);
    realN k = s.wi.z / sel((realN)1, s.pdf, ok);
    for (int ch = 0; ch < CHANNELS; ++ch)
        s.weight.c[ch] = f.c[ch] * k;
    return bsample_where(s, ok);
}

#endif
