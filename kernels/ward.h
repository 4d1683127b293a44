/* Ward 1992 anisotropic Gaussian BRDF, sampled as in Walter 2005 ("Notes on the Ward BRDF").
 *
 * | parameter | meaning                                   | range               |
 * |-----------|-------------------------------------------|---------------------|
 * | alpha_x   | slope deviation along the tangent x        | [1e-3, 1]           |
 * | alpha_y   | slope deviation along the bitangent y      | [1e-3, 1]           |
 * | ks        | specular reflectance                       | [0, 1], per channel |
 * | kd        | diffuse albedo (WARD_DIFFUSE: when given)  | [0, 1], per channel |
 *
 *   f(wo, wi) = kd / pi + ks exp(-(h_x^2 / alpha_x^2 + h_y^2 / alpha_y^2) / h_z^2)
 *                         / (4 pi alpha_x alpha_y sqrt(cos_i cos_o))            (Ward eq 5b)
 *
 * with h = wi + wo (the exponent is invariant under scaling h). Sampling (Walter 2005 eq 6-7):
 * the slopes (h_x, h_y) / h_z are Gaussian, (alpha_x r cos psi, alpha_y r sin psi) with
 * r^2 = -log(1 - u1), psi = 2 pi u0; wi = reflect(wo, h). Density of h (solid angle)
 * exp(-...) / (pi alpha_x alpha_y h_z^3), of wi that over 4 wo.h (Walter eq 9), so the weight
 * f cos_i / pdf of a lobe sample is ks (wo.h) h_z^3 sqrt(cos_i / cos_o). With kd the cosine lobe
 * is drawn with probability sum kd / (sum kd + sum ks) (sums over channels).
 */
#ifndef CLBRDF_WARD_H
#define CLBRDF_WARD_H

#define ward_SAMPLE_DIMS (WARD_DIFFUSE ? 3 : 2)   /* numbers ward_sample uses */

/* The Gaussian's exponent for h = s / |s| (s any positive multiple of h). */
FN realN ward_exponent(const ward_params *p, vec3 s)
{
    return (sqr(s.x / p->alpha_x) + sqr(s.y / p->alpha_y)) / sqr(s.z);
}

/* Density of the lobe sampler per unit solid angle of wi, from s (a positive multiple of h)
 * and oh = wo.h. */
FN realN ward_lobe_pdf(const ward_params *p, vec3 s, realN oh)
{
    realN hz = s.z * rsqrt(dot3(s, s));
    return exp(-ward_exponent(p, s)) / (4 * PI_R * p->alpha_x * p->alpha_y * hz * hz * hz * oh);
}

FN realN ward_diffuse_prob(const ward_params *p)
{
    (void)p;   /* the interface's; not every configuration reads it */
#if WARD_DIFFUSE
    realN kd = 0, ks = 0;
    for (int c = 0; c < CHANNELS; ++c) {
        kd += p->kd[c];
        ks += p->ks[c];
    }
    return sel(kd / (kd + ks), (realN)0, kd + ks <= 0);
#else
    return (realN)0;
#endif
}

ALWAYS_INLINE spec ward_eval(const ward_params *p, vec3 wo, vec3 wi)
{
    vec3 s = add3(wi, wo);
    realN lobe = exp(-ward_exponent(p, s))
                 / (4 * PI_R * p->alpha_x * p->alpha_y * sqrt(wi.z * wo.z));
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c) {
        realN v = p->ks[c] * lobe;
#if WARD_DIFFUSE
        v += p->kd[c] * INV_PI_R;
#endif
        f.c[c] = sel((realN)0, v, ok);
    }
    return f;
}

ALWAYS_INLINE realN ward_pdf(const ward_params *p, vec3 wo, vec3 wi)
{
    realN pdf = ward_lobe_pdf(p, add3(wi, wo), half_cos(wo, wi));
#if WARD_DIFFUSE
    realN pd = ward_diffuse_prob(p);
    pdf = cosine_mixture_pdf(pd, wi, pdf);
#endif
    return sel((realN)0, pdf, (wi.z > 0) & (wo.z > 0));
}

/* The lobes the sampler picks with u2: lobe l for u2 in [ends[l - 1], ends[l]) (ends[-1] = 0,
 * the last end 1); the deterministic quadrature (integrators.cl) integrates each lobe's map. */
#define ward_LOBES 2
FN void ward_lobe_ends(const ward_params *p, vec3 wo, realN *ends)
{
    (void)wo;   /* the interface's; not every configuration reads it */
    ends[0] = ward_diffuse_prob(p);           /* cosine */
    ends[1] = (realN)1;                       /* Gaussian lobe */
}

ALWAYS_INLINE BSample ward_sample(const ward_params *p, vec3 wo, rand4 u)
{
    realN c, sn = sincos_2pi(u.u0, &c);
    realN r = sqrt(-log1p(-u.u1));
    vec3 h = normalize3(v3(p->alpha_x * r * c, p->alpha_y * r * sn, (realN)1));
    BSample s;
    s.wi = reflect3(wo, h);
#if WARD_DIFFUSE
    /* mixture: the weight from the drawn h for a lobe sample, f cos / pdf for a cosine one */
    realN pd = ward_diffuse_prob(p);
    maskN diffuse = u.u2 < pd;
    vec3 wc = square_to_cosine_hemisphere(u.u0, u.u1);
    s.wi = select3(s.wi, wc, diffuse);
    realN osh;
    vec3 sh = mixture_half(wo, h, wc, diffuse, &osh);
    s.pdf = cosine_mixture_pdf(pd, s.wi, ward_lobe_pdf(p, sh, osh));
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (s.pdf > 0);
    realN lobe = exp(-ward_exponent(p, sh)) * sqrt(s.wi.z / wo.z)
                 / (4 * PI_R * p->alpha_x * p->alpha_y);
    realN inv = 1 / s.pdf;
    for (int ch = 0; ch < CHANNELS; ++ch)
        s.weight.c[ch] = (p->ks[ch] * lobe + p->kd[ch] * INV_PI_R * s.wi.z) * inv;
#else
    realN oh = dot3(wo, h);
    maskN ok = (s.wi.z > 0) & (wo.z > 0) & (oh > 0);
    s.pdf = ward_lobe_pdf(p, h, oh);
    realN g = oh * h.z * h.z * h.z * sqrt(s.wi.z / wo.z);
    for (int ch = 0; ch < CHANNELS; ++ch)
        s.weight.c[ch] = p->ks[ch] * g;
#endif
    return bsample_where(s, ok);
}

#endif
