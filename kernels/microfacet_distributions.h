/* Microfacet normal distributions: Beckmann and GGX (Trowbridge-Reitz), anisotropic.
 *
 * Each distribution provides, in the manner of pbrt-v4's TrowbridgeReitzDistribution:
 *   D(m)                    density of normals, integral D(m) (m . n) dm = 1
 *   Lambda(w)               Smith auxiliary function, G1(w) = 1 / (1 + Lambda(w))
 *   sample_ndf(u0, u1)      m with density D(m) (m . n)
 *   sample_vndf(w, u0, u1)  m with density G1(w) max(0, w . m) D(m) / (w . n), returned up to a
 *                           positive factor (a reflection needs no unit normal: reflect_scaled)
 *   LAMBDA_SCALE_FREE       1 where Lambda(k w) = Lambda(w) for k > 0 (a function of tan theta
 *                           written without |w| = 1), so that it takes an unnormalised direction
 *   Lambda_parts(w, &d)     optional (HAS_LAMBDA_PARTS 1): t with Lambda = t / d
 * Roughness: alpha_x, alpha_y scale the slopes along x and y (docs/models/microfacet.md).
 */
#ifndef CLBRDF_MICROFACET_DISTRIBUTIONS_H
#define CLBRDF_MICROFACET_DISTRIBUTIONS_H

/* ax, ay: roughness along x and y; shape: a second parameter of the NDFs that have one
 * (GTR gamma, SGD p, exponential-power p). */
#if CLBRDF_TABLES      /* the program has generated tables (clbrdf/runtime/build.py) */
typedef struct { realN ax, ay, shape; Tables tables; } Microfacet;
#define MICROFACET(ax, ay, shape, P) {ax, ay, shape, (P)->tables}
#else
typedef struct { realN ax, ay, shape; } Microfacet;
#define MICROFACET(ax, ay, shape, P) {ax, ay, shape}
#endif

/* Squared roughness along the azimuth of w, times tan^2 theta_w: (wx^2 ax^2 + wy^2 ay^2) / wz^2. */
FN realN projected_roughness2(Microfacet m, vec3 w)
{
    return sqr(w.x * m.ax) + sqr(w.y * m.ay);
}

/* The normal of the slope (sx, sy), unnormalised, and the unit normal. */
FN vec3 slope_normal(realN sx, realN sy) { return v3(-sx, -sy, (realN)1); }
FN vec3 slope_to_normal(realN sx, realN sy) { return normalize3(slope_normal(sx, sy)); }

/* ---- GGX: Walter et al. 2007 eq 33, anisotropic form of Heitz 2014 eq 85 ----
 * D = 1 / (pi ax ay (x^2/ax^2 + y^2/ay^2 + z^2)^2), which needs no division by cos theta. */
FN realN ggx_D(Microfacet m, vec3 h)
{
    realN e = sqr(h.x / m.ax) + sqr(h.y / m.ay) + h.z * h.z;
    return sel((realN)0, INV_PI_R / (m.ax * m.ay * e * e), h.z > 0);
}

/* Lambda = (-1 + sqrt(1 + a^2 tan^2))/2, written as t / (2 (z^2 + z sqrt(z^2 + t))) with
 * t = a^2 tan^2 z^2: no cancellation for small t; homogeneous of degree 0 in w. */
#define ggx_LAMBDA_SCALE_FREE 1
#define ggx_HAS_LAMBDA_PARTS 1           /* Lambda = t / d, for c / (c + Lambda) in one division */
FN realN ggx_Lambda_parts(Microfacet m, vec3 w, realN *d)
{
    realN t = projected_roughness2(m, w), z = fabs(w.z);
    *d = 2 * (z * z + z * sqrt(z * z + t));
    return t;
}

FN realN ggx_Lambda(Microfacet m, vec3 w)
{
    realN d, t = ggx_Lambda_parts(m, w, &d);
    return t / d;
}

/* Slopes of GGX are a bivariate Student-t with 2 degrees of freedom: r^2 = u / (1 - u). */
FN vec3 ggx_sample_ndf(Microfacet m, realN u0, realN u1)
{
    realN r = sqrt(u0 / (1 - u0));
    realN c, s = sincos_2pi(u1, &c);
    return slope_to_normal(m.ax * r * c, m.ay * r * s);
}

/* Visible normals by spherical caps (Dupuy & Benyoub 2023): uniform point on the cap of the
 * unit sphere around the stretched direction, unstretched (not normalised). */
FN vec3 ggx_sample_vndf(Microfacet m, vec3 w, realN u0, realN u1)
{
    vec3 ws = normalize3(v3(w.x * m.ax, w.y * m.ay, w.z));
    realN z = (1 - u1) * (1 + ws.z) - ws.z;
    realN sin_t = safe_sqrt(1 - z * z);
    realN c, s = sincos_2pi(u0, &c);
    vec3 hs = v3(sin_t * c + ws.x, sin_t * s + ws.y, z + ws.z);
    return v3(hs.x * m.ax, hs.y * m.ay, fmax(hs.z, (realN)0));
}

/* ---- Beckmann: Walter et al. 2007 eq 25, anisotropic ----
 * D = exp(-e) / (pi ax ay cos^4), e = (x^2/ax^2 + y^2/ay^2) / z^2. Where exp(-e) underflows
 * the value is an exact 0 (this also avoids 0/0 at grazing h). */
FN realN beckmann_D(Microfacet m, vec3 h)
{
    realN z2 = h.z * h.z;
    realN e = (sqr(h.x / m.ax) + sqr(h.y / m.ay)) / z2;
    realN d = exp(-e) / (PI_R * m.ax * m.ay * z2 * z2);
    return sel((realN)0, d, (h.z > 0) & (e < (realN)(CLBRDF_DOUBLE ? 700 : 85)));
}

/* Lambda = (erf(a) - 1)/2 + exp(-a^2) / (2 a sqrt(pi)), a = 1 / (alpha tan theta) (Walter 2007
 * eq 27 with Smith), written with erfc to avoid 1 - erf(a) cancellation. */
#define beckmann_LAMBDA_SCALE_FREE 1
FN realN beckmann_Lambda(Microfacet m, vec3 w)
{
    realN a = fabs(w.z) * rsqrt(projected_roughness2(m, w));   /* inf at normal incidence */
    realN l = (realN)0.5 * (exp(-a * a) * INV_SQRT_PI_R / a - erfc(a));
    return sel(l, (realN)0, isinf(a));
}

/* Slopes of Beckmann are Gaussian with variance alpha^2 / 2 per axis. */
FN vec3 beckmann_sample_ndf(Microfacet m, realN u0, realN u1)
{
    realN r = sqrt(-log1p(-u0));
    realN c, s = sincos_2pi(u1, &c);
    return slope_to_normal(m.ax * r * c, m.ay * r * s);
}

/* Newton steps from the fitted first guess: |CDF(s) - u| about 1e-9 after 3 steps and at rounding
 * level (1e-15) after 5, for cos theta in [1e-6, 1] and u in [1e-15, 1 - 1e-15] (float64
 * emulation); single needs 3 (one more for margin). test_beckmann_vndf_inverts_visible_slope_cdf
 * fails with 3 in double. */
#ifndef BECKMANN_NEWTON_STEPS
#define BECKMANN_NEWTON_STEPS (CLBRDF_DOUBLE ? 5 : 4)
#endif

/* Visible slopes of the unit isotropic Beckmann distribution for a direction at cos theta
 * in the x-z plane (Heitz & d'Eon 2014 section 4, with Jakob's safeguarded Newton inversion of
 * the x-slope CDF in the erf domain, as in Mitsuba and pbrt-v3; here branch-free, fixed steps).
 * Returns the slopes in (sx, sy). */
FN void beckmann_visible_slopes11(realN cos_t, realN u0, realN u1, realN *sx, realN *sy)
{
    realN sin_t = safe_sqrt(1 - cos_t * cos_t);
    realN tan_t = sin_t / cos_t, cot_t = cos_t / sin_t;      /* cot = inf at normal incidence */
    realN lo = -1 + REAL_EPS, hi = fmin(erf(cot_t), 1 - REAL_EPS);
    realN th = acos(cos_t);
    realN fit = 1 + th * ((realN)-0.876 + th * ((realN)0.4265 - (realN)0.0594 * th));
    realN b = hi - (1 + hi) * exp(fit * log1p(-u0));
    realN tail = sel(tan_t * exp(-cot_t * cot_t), (realN)0, isinf(cot_t));
    realN norm = 1 / (1 + hi + INV_SQRT_PI_R * tail);
    for (int i = 0; i < BECKMANN_NEWTON_STEPS; ++i) {
        b = sel(b, (realN)0.5 * (lo + hi), !((b >= lo) & (b <= hi)));
        realN s = erfinv_r(b);
        realN value = norm * (1 + b + INV_SQRT_PI_R * tan_t * exp(-s * s)) - u0;
        realN deriv = norm * (1 - s * tan_t);
        maskN above = value > 0;
        hi = sel(hi, b, above);
        lo = sel(b, lo, above);
        b -= value / deriv;
    }
    b = clamp(b, lo, hi);
    *sx = erfinv_r(b);
    *sy = erfinv_r(fmax(2 * u1 - 1, -1 + REAL_EPS));     /* u1 = 0: the next number's slope */
}

FN vec3 beckmann_sample_vndf(Microfacet m, vec3 w, realN u0, realN u1)
{
    vec3 ws = normalize3(v3(w.x * m.ax, w.y * m.ay, w.z));
    realN sx, sy;
    beckmann_visible_slopes11(ws.z, u0, u1, &sx, &sy);
    /* rotate from the x-z plane to the azimuth of ws, then unstretch */
    realN rxy = sqrt(ws.x * ws.x + ws.y * ws.y);
    realN cp = sel(ws.x / rxy, (realN)1, rxy == 0), sp = sel(ws.y / rxy, (realN)0, rxy == 0);
    realN tx = cp * sx - sp * sy, ty = sp * sx + cp * sy;
    return slope_normal(m.ax * tx, m.ay * ty);
}

#endif
