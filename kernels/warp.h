/* Square-to-hemisphere warps and their densities (solid angle, 1/sr). */
#ifndef CLBRDF_WARP_H
#define CLBRDF_WARP_H

FN vec3 polar_dir(realN cos_t, realN sin_t, realN u_phi)
{
    realN c, s = sincos_2pi(u_phi, &c);
    return v3(sin_t * c, sin_t * s, cos_t);
}

/* Uniform on the upper hemisphere: pdf = 1 / (2 pi). */
FN vec3 square_to_uniform_hemisphere(realN u0, realN u1)
{
    return polar_dir(u0, sqrt((1 - u0) * (1 + u0)), u1);
}
FN realN uniform_hemisphere_pdf(vec3 w) { return sel((realN)0, (realN)(0.5 * INV_PI_R), w.z > 0); }

/* Cosine-weighted (Malley's method, polar map): pdf = cos(theta) / pi. */
FN vec3 square_to_cosine_hemisphere(realN u0, realN u1)
{
    return polar_dir(sqrt(1 - u0), sqrt(u0), u1);
}
FN realN cosine_hemisphere_pdf(vec3 w) { return fmax(w.z, (realN)0) * INV_PI_R; }

/* The whole sphere, for the models that transmit (P_TRANSMITS): uniform (pdf 1 / (4 pi)), and
 * cosine-weighted on the side u0 picks, the upper for u0 < 1/2 (pdf |cos(theta)| / (2 pi)). */
FN vec3 square_to_uniform_sphere(realN u0, realN u1)
{
    realN z = 1 - 2 * u0;
    return polar_dir(z, sqrt(4 * u0 * (1 - u0)), u1);
}
FN vec3 square_to_cosine_sphere(realN u0, realN u1)
{
    maskN lower = u0 >= (realN)0.5;
    vec3 w = square_to_cosine_hemisphere(sel(2 * u0, 2 * u0 - 1, lower), u1);
    w.z = sel(w.z, -w.z, lower);
    return w;
}
FN realN cosine_sphere_pdf(vec3 w) { return fabs(w.z) * (realN)(0.5 * INV_PI_R); }

/* Density of a mixture that draws the cosine lobe with probability pd and a lobe of density
 * lobe otherwise (wi above the horizon): the samplers of the models with a diffuse term. */
FN realN cosine_mixture_pdf(realN pd, vec3 wi, realN lobe)
{
    return pd * wi.z * INV_PI_R + (1 - pd) * lobe;
}

/* The half vector at which such a mixture weighs its sample, and *oh = wo.h there: the drawn h
 * of a lobe sample (recomputing it from a rounded wi misses a near-mirror lobe at grazing angles
 * in single precision), normalize(wc + wo) with |wc + wo| / 2 (half_cos) for a cosine sample wc. */
FN vec3 mixture_half(vec3 wo, vec3 h, vec3 wc, maskN cosine, realN *oh)
{
    *oh = sel(dot3(wo, h), half_cos(wo, wc), cosine);
    return select3(h, normalize3(add3(wc, wo)), cosine);
}

#endif
