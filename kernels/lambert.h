/* Lambertian BRDF.
 *
 * | parameter | meaning         | range  |
 * |-----------|-----------------|--------|
 * | kd        | diffuse albedo  | [0, 1], per channel |
 *
 * f = kd / pi; sampled by the cosine-weighted hemisphere, so the weight is kd.
 */
#ifndef CLBRDF_LAMBERT_H
#define CLBRDF_LAMBERT_H

#define lambert_SAMPLE_DIMS 2

ALWAYS_INLINE spec lambert_eval(const lambert_params *p, vec3 wo, vec3 wi)
{
    maskN ok = (wi.z > 0) & (wo.z > 0);
    spec f;
    for (int c = 0; c < CHANNELS; ++c)
        f.c[c] = sel((realN)0, p->kd[c] * INV_PI_R, ok);
    return f;
}

ALWAYS_INLINE realN lambert_pdf(const lambert_params *p, vec3 wo, vec3 wi)
{
    (void)p;   /* the interface's; not every configuration reads it */
    return sel((realN)0, cosine_hemisphere_pdf(wi), wo.z > 0);
}

ALWAYS_INLINE BSample lambert_sample(const lambert_params *p, vec3 wo, rand4 u)
{
    BSample s;
    s.wi = square_to_cosine_hemisphere(u.u0, u.u1);
    s.pdf = lambert_pdf(p, wo, s.wi);
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = sel((realN)0, p->kd[c], wo.z > 0);
    return s;
}

#endif
