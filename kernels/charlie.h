/* Charlie sheen (Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF"), as glTF
 * KHR_materials_sheen and Enterprise PBR use it.
 *
 * | parameter | meaning                                         | range               |
 * |-----------|-------------------------------------------------|---------------------|
 * | alpha     | roughness (glTF: sheenRoughness^2)              | [1e-3, 1]           |
 * | ks        | sheen colour, scale of the lobe                 | [0, 1e6], per channel |
 *
 *   D(h) = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)                    (Estevez-Kulla eq 2)
 *   CHARLIE_V 0 (charlie):   f = ks D G / (4 cos_i cos_o), G = 1 / (1 + Lambda(wo) + Lambda(wi)),
 *       Lambda(mu) = exp(L(mu)) for mu < 1/2, exp(2 L(1/2) - L(1 - mu)) above,
 *       L(x) = a / (1 + b x^c) + d x + e, the coefficients interpolated in t = (1 - alpha)^2
 *       between (21.5473, 3.82987, 0.19823, -1.97760, -4.32054) at t = 0 and (25.3245, 3.32435,
 *       0.16801, -1.27393, -4.85967) at t = 1 (their fit of the exact Lambda, Table 1; without
 *       the terminator softening);
 *   CHARLIE_V 1 (ashikhmin): f = ks D / (4 (cos_i + cos_o - cos_i cos_o)) (Neubelt & Pettineo
 *       2013's visibility, Filament's cloth).
 * Sampling: h from D cos(theta_h): the CDF of s = sin(theta_h) is s^(2 + 1/alpha), so
 * s = u1^(alpha / (2 alpha + 1)), 1 - s by expm1; wi = reflect(wo, h), pdf = D h_z / (4 wo.h).
 */
#ifndef CLBRDF_CHARLIE_H
#define CLBRDF_CHARLIE_H

#define charlie_SAMPLE_DIMS 2

/* D(h) from log(sin^2 theta_h): sin^(1/alpha) multiplies the rounding of sin^2 by 1/(2 alpha)
 * (500 at alpha 1e-3), so the log comes from whichever of sin^2 and cos^2 is small. */
FN realN charlie_D_log(const charlie_params *p, realN log_sin2)
{
    realN inv = 1 / p->alpha;
    return (2 + inv) * exp((realN)0.5 * inv * log_sin2) * ((realN)0.5 * INV_PI_R);
}

/* log(sin^2 theta_h) for h along s (any positive multiple): log1p(-cos^2) where h is near the
 * horizon (the sheen's lobe; sin^2 near 1 rounded lost 30x the single-precision D there),
 * log(sin^2) where it is near the normal. */
FN realN charlie_log_sin2(vec3 s)
{
    realN n2 = dot3(s, s);
    realN sin2 = (sqr(s.x) + sqr(s.y)) / n2, cos2 = sqr(s.z) / n2;
    return sel(log1p(-cos2), log(sin2), sin2 < (realN)0.5);
}

FN realN charlie_L(realN x, realN t)
{
    realN a = (realN)21.5473 + ((realN)25.3245 - (realN)21.5473) * t;
    realN b = (realN)3.82987 + ((realN)3.32435 - (realN)3.82987) * t;
    realN c = (realN)0.19823 + ((realN)0.16801 - (realN)0.19823) * t;
    realN d = (realN)-1.97760 + ((realN)-1.27393 + (realN)1.97760) * t;
    realN e = (realN)-4.32054 + ((realN)-4.85967 + (realN)4.32054) * t;
    return a / (1 + b * pow_pos(x, c)) + d * x + e;
}

FN realN charlie_Lambda(const charlie_params *p, realN mu)
{
    realN t = sqr(1 - p->alpha);
    realN lo = charlie_L(mu, t);
    realN hi = 2 * charlie_L((realN)0.5, t) - charlie_L(1 - mu, t);
    return exp(sel(hi, lo, mu < (realN)0.5));
}

/* f / (ks D): the visibility term G / (4 cos_i cos_o) or Ashikhmin's. */
FN realN charlie_V(const charlie_params *p, realN ci, realN co)
{
    (void)p;   /* the interface's; not every configuration reads it */
#if CHARLIE_V == 1
    return 1 / (4 * (ci + co - ci * co));
#else
    return 1 / (4 * ci * co * (1 + charlie_Lambda(p, ci) + charlie_Lambda(p, co)));
#endif
}

ALWAYS_INLINE spec charlie_eval(const charlie_params *p, vec3 wo, vec3 wi)
{
    vec3 s = add3(wi, wo);
    maskN ok = (wi.z > 0) & (wo.z > 0);
    realN lobe = charlie_D_log(p, charlie_log_sin2(s)) * charlie_V(p, wi.z, wo.z);
    spec f;
    for (int c = 0; c < CHANNELS; ++c)
        f.c[c] = sel((realN)0, p->ks[c] * lobe, ok);
    return f;
}

ALWAYS_INLINE realN charlie_pdf(const charlie_params *p, vec3 wo, vec3 wi)
{
    vec3 s = add3(wi, wo);
    realN hz = s.z * rsqrt(dot3(s, s));
    realN pdf = charlie_D_log(p, charlie_log_sin2(s)) * hz / (4 * half_cos(wo, wi));
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

ALWAYS_INLINE BSample charlie_sample(const charlie_params *p, vec3 wo, rand4 u)
{
    realN k = p->alpha / (2 * p->alpha + 1);
    realN lu = k * log(u.u1);
    realN sn = exp(lu), one_minus = -expm1(lu);
    realN hz = sqrt(one_minus * (1 + sn));
    realN c, s2 = sincos_2pi(u.u0, &c);
    vec3 h = v3(sn * c, sn * s2, hz);
    BSample s;
    s.wi = reflect3(wo, h);
    realN oh = dot3(wo, h);
    s.pdf = charlie_D_log(p, 2 * lu) * hz / (4 * oh);      /* log sin^2 = 2 k log u1 */
    /* weight f cos_i / pdf = ks V cos_i 4 (wo.h) / h_z, from the drawn h */
    realN g = charlie_V(p, s.wi.z, wo.z) * s.wi.z * 4 * oh / hz;
    for (int ch = 0; ch < CHANNELS; ++ch)
        s.weight.c[ch] = p->ks[ch] * g;
    return bsample_where(s, (s.wi.z > 0) & (wo.z > 0) & (oh > 0) & (hz > 0) & (s.pdf > 0));
}

#endif
