/* clbrdf common definitions: scalar type, lane width, vectors, math helpers.
 *
 * Build options (all optional):
 *   -DCLBRDF_DOUBLE=1   double precision (needs cl_khr_fp64); single otherwise
 *   -DW=16              lanes per work-item: 1 (scalar, GPU), 2, 4, 8 or 16 (CPU SIMD)
 *   -DCHANNELS=3        colour channels of a model's value (1 by default)
 *
 * Every function works on `realN`, a vector of W lanes (or a scalar when W == 1),
 * and is branch-free: lane masks come from comparisons and are consumed by sel(), which is
 * select() on vectors and ?: on scalars. A comparison yields 1/0 on scalars and -1/0 on
 * vectors; sel(a, b, m) picks b where m is true in both cases, and &, |, ! combine masks
 * correctly in both cases.
 */
#ifndef CLBRDF_COMMON_H
#define CLBRDF_COMMON_H

#include "portable.h"

#ifndef W
#define W 1
#endif
#ifndef CLBRDF_DOUBLE
#define CLBRDF_DOUBLE 0
#endif
#ifndef CLBRDF_TABLES
#define CLBRDF_TABLES 0
#endif

/* ALWAYS_INLINE (portable.h) is for the functions an estimator calls once per sample (each
 * model's eval, pdf and sample, and albedo_estimate): LLVM's inliner leaves them as calls once
 * they grow, and then the 16-lane vectors of a call's arguments and BSample result go through
 * memory (GGX albedo 578 -> 330 M samples/s when microfacet_sample stopped being inlined;
 * benchmarks/RESULTS.md). */
#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)

#if CLBRDF_DOUBLE
#if CLBRDF_OPENCL
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif
#define REAL double
#define MASK long
#define REAL_EPS DBL_EPSILON
#define REAL_MIN DBL_MIN
#else
#define REAL float
#define MASK int
#define REAL_EPS FLT_EPSILON
#define REAL_MIN FLT_MIN
#endif

typedef REAL real_t;

#if W == 1
typedef real_t realN;
typedef int maskN;                 /* scalar comparisons give int in both precisions */
typedef uint uintN;
typedef ulong ulongN;
#define convert_uintN convert_uint
#define convert_ulongN convert_ulong
#define LANE_IDS ((uint)0)
#define VLOAD(p) (*(p))
#define VSTORE(v, p) (*(p) = (v))
#define HSUM(v) (v)
#define FIRST_LANE(v) (v)
#define TO_MASK(m) (m)
/* scalar comparisons give int even for doubles, which select() rejects: use ?: */
#define sel(a, b, m) ((m) ? (b) : (a))
#else
typedef CAT(REAL, W) realN;
typedef CAT(MASK, W) maskN;
typedef CAT(uint, W) uintN;
typedef CAT(ulong, W) ulongN;
#define convert_uintN CAT(convert_uint, W)
#define convert_ulongN CAT(convert_ulong, W)
#define VLOAD(p) CAT(vload, W)(0, (p))
#define VSTORE(v, p) CAT(vstore, W)((v), 0, (p))
/* an integer comparison's mask, as the mask type of realN (long lanes in double) */
#define TO_MASK(m) CAT(convert_, CAT(MASK, W))(m)
#define sel(a, b, m) select((a), (b), (m))
#endif

#if W == 1
#define convert_realN CAT(convert_, REAL)
#else
#define convert_realN CAT(convert_, CAT(REAL, W))
#endif

#if W == 2
#define LANE_IDS ((uint2)(0, 1))
#elif W == 4
#define LANE_IDS ((uint4)(0, 1, 2, 3))
#elif W == 8
#define LANE_IDS ((uint8)(0, 1, 2, 3, 4, 5, 6, 7))
#elif W == 16
#define LANE_IDS ((uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#endif

/* Horizontal sum in a fixed order, so that a result does not depend on the device. */
#if W == 2
#define HSUM(v) ((v).s0 + (v).s1)
#elif W == 4
#define HSUM(v) (((v).s0 + (v).s1) + ((v).s2 + (v).s3))
#elif W == 8
#define HSUM(v) (HSUM4((v).lo) + HSUM4((v).hi))
#elif W == 16
#define HSUM(v) (HSUM8((v).lo) + HSUM8((v).hi))
#endif
#if W > 1
#define FIRST_LANE(v) ((v).s0)
#endif
#define HSUM4(v) (((v).s0 + (v).s1) + ((v).s2 + (v).s3))
#define HSUM8(v) (HSUM4((v).lo) + HSUM4((v).hi))

#define PI_R ((real_t)3.14159265358979323846)
#define INV_PI_R ((real_t)0.31830988618379067154)
#define INV_SQRT_PI_R ((real_t)0.56418958354775628695)

typedef struct { realN x, y, z; } vec3;

/* Generated tables (kernels/data/NAME.npy, float32) in one buffer per program, passed to every model
 * kernel after the parameters; table NAME starts at offset TABLE_NAME (defined by
 * clbrdf/runtime/build.py for the tables a program's source names). */
typedef const global float *Tables;

/* T[i] per lane (OpenCL has no vector gather: one load per lane). */
FN realN table_gather(Tables T, uintN i)
{
#if W == 1
    return (realN)T[i];
#elif W == 2
    return (realN)((real_t)T[i.s0], (real_t)T[i.s1]);
#elif W == 4
    return (realN)((real_t)T[i.s0], (real_t)T[i.s1], (real_t)T[i.s2], (real_t)T[i.s3]);
#elif W == 8
    return (realN)((real_t)T[i.s0], (real_t)T[i.s1], (real_t)T[i.s2], (real_t)T[i.s3],
                   (real_t)T[i.s4], (real_t)T[i.s5], (real_t)T[i.s6], (real_t)T[i.s7]);
#elif W == 16
    return (realN)((real_t)T[i.s0], (real_t)T[i.s1], (real_t)T[i.s2], (real_t)T[i.s3],
                   (real_t)T[i.s4], (real_t)T[i.s5], (real_t)T[i.s6], (real_t)T[i.s7],
                   (real_t)T[i.s8], (real_t)T[i.s9], (real_t)T[i.sa], (real_t)T[i.sb],
                   (real_t)T[i.sc], (real_t)T[i.sd], (real_t)T[i.se], (real_t)T[i.sf]);
#endif
}

/* Catmull-Rom between p1 (t = 0) and p2 (t = 1). */
FN realN catmull_rom(realN p0, realN p1, realN p2, realN p3, realN t)
{
    return p1 + (realN)0.5 * t * (p2 - p0 + t * (2 * p0 - 5 * p1 + 4 * p2 - p3
                                                 + t * (3 * (p1 - p2) + p3 - p0)));
}

FN vec3 v3(realN x, realN y, realN z) { vec3 r = {x, y, z}; return r; }
FN vec3 add3(vec3 a, vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
FN vec3 sub3(vec3 a, vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
FN vec3 scale3(vec3 a, realN s) { return v3(a.x * s, a.y * s, a.z * s); }
FN realN dot3(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
FN vec3 normalize3(vec3 a) { return scale3(a, rsqrt(dot3(a, a))); }
FN vec3 select3(vec3 a, vec3 b, maskN m)
{
    return v3(sel(a.x, b.x, m), sel(a.y, b.y, m), sel(a.z, b.z, m));
}
/* Mirror reflection of w about the unit normal m. */
FN vec3 reflect3(vec3 w, vec3 m) { return sub3(scale3(m, 2 * dot3(w, m)), w); }
/* The same about a normal m of any length, times |m|^2: no square root or division. */
FN vec3 reflect_scaled(vec3 w, vec3 m) { return sub3(scale3(m, 2 * dot3(w, m)), scale3(w, dot3(m, m))); }

FN realN sqr(realN x) { return x * x; }

/* sin(x), and cos(x) in *c. -DCLBRDF_SEPARATE_SINCOS=1 calls sin and cos apart (about 20%
 * slower on PoCL), for oclgrind, whose uninitialised-memory checker rejects sincos's pointer. */
FN realN sincos_r(realN x, realN *c)
{
#if CLBRDF_SEPARATE_SINCOS
    *c = cos(x);
    return sin(x);
#else
    return sincos(x, c);
#endif
}
FN realN safe_sqrt(realN x) { return sqrt(fmax(x, (realN)0)); }

/* x^y for x >= 0, y > 0. PoCL 3.1's pow on double8 and double16 returns wrong values in other
 * lanes when a lane has x = 0 (pow((1.5, 88, 0, ...), 1) gives (1.5, 0.6875, 0, ...)); those
 * widths use exp(y log x) instead (log 0 = -inf gives 0). */
FN realN pow_pos(realN x, realN y)
{
#if CLBRDF_DOUBLE && W >= 8
    return exp(y * log(x));
#else
    return pow(x, y);
#endif
}

/* sin(2 pi u), and cos(2 pi u) in *c, for |u| < 2^22 (samplers' azimuths, u in [0, 1)).
 * The argument is reduced exactly in u (r = u - q/4, q = rint(4u)), so 2 pi r is in
 * [-pi/4, pi/4], where Taylor polynomials of degree 9 (sin) and 10 (cos) err by < 4e-9 in
 * single precision (series in r with the coefficients (2 pi)^k / k!); the quadrant q rotates
 * (s, c). Double precision calls sincos. */
FN realN sincos_2pi(realN u, realN *c)
{
#if CLBRDF_DOUBLE
    return sincos_r(2 * PI_R * u, c);
#else
    realN q = rint(4 * u);
    realN r = u - (realN)0.25 * q;                 /* exact */
    realN a = (realN)6.28318530717958647692 * r, a2 = a * a;
    realN sn = a * (1 + a2 * ((realN)-1.66666666666666667e-1 + a2 * ((realN)8.33333333333333333e-3
              + a2 * ((realN)-1.98412698412698413e-4 + a2 * (realN)2.75573192239858907e-6))));
    realN cs = 1 + a2 * ((realN)-0.5 + a2 * ((realN)4.16666666666666667e-2 + a2 * ((realN)-1.38888888888888889e-3
              + a2 * ((realN)2.48015873015873016e-5 + a2 * (realN)-2.75573192239858907e-7))));
    realN k = q - 4 * floor((realN)0.25 * q);      /* quadrant 0..3 */
    maskN odd = (k == 1) | (k == 3), neg_s = (k >= 2), neg_c = (k == 1) | (k == 2);
    realN s2 = sel(sn, cs, odd), c2 = sel(cs, sn, odd);
    *c = sel(c2, -c2, neg_c);
    return sel(s2, -s2, neg_s);
#endif
}

/* A spectrum: CHANNELS values (1, or 3 for RGB; the host defines CHANNELS). Models loop over
 * channels with `for (int c = 0; c < CHANNELS; ++c)`, which the compiler unrolls. */
#ifndef CHANNELS
#define CHANNELS 1
#endif
typedef struct { realN c[CHANNELS]; } spec;

FN spec spec_splat(realN v)
{
    spec s;
    for (int c = 0; c < CHANNELS; ++c)
        s.c[c] = v;
    return s;
}

FN spec spec_scale(spec s, realN v)
{
    for (int c = 0; c < CHANNELS; ++c)
        s.c[c] *= v;
    return s;
}

FN spec spec_add(spec a, spec b)
{
    for (int c = 0; c < CHANNELS; ++c)
        a.c[c] += b.c[c];
    return a;
}

FN spec spec_sel(spec a, spec b, maskN m)
{
    for (int c = 0; c < CHANNELS; ++c)
        a.c[c] = sel(a.c[c], b.c[c], m);
    return a;
}

/* A sampled direction: wi, the estimator weight f cos(theta_i) / pdf per channel, and pdf (1/sr). */
typedef struct { vec3 wi; spec weight; realN pdf; } BSample;

/* s where ok, else the zero sample (weight and pdf 0): the last step of every sampler. */
FN BSample bsample_where(BSample s, maskN ok)
{
    s.weight = spec_sel(spec_splat((realN)0), s.weight, ok);
    s.pdf = sel((realN)0, s.pdf, ok);
    return s;
}

/* Inverse error function. Giles, "Approximating the erfinv function" (GPU Gems 4, 2010),
 * single-precision polynomials; in double precision refined by two Newton steps on erf. */
FN realN erfinv_r(realN x)
{
    realN w = -log((1 - x) * (1 + x));
    realN a = w - (realN)2.5;
    realN p = (realN)2.81022636e-08;
    p = (realN)3.43273939e-07 + p * a;
    p = (realN)-3.5233877e-06 + p * a;
    p = (realN)-4.39150654e-06 + p * a;
    p = (realN)0.00021858087 + p * a;
    p = (realN)-0.00125372503 + p * a;
    p = (realN)-0.00417768164 + p * a;
    p = (realN)0.246640727 + p * a;
    p = (realN)1.50140941 + p * a;
    realN b = sqrt(w) - 3;
    realN q = (realN)-0.000200214257;
    q = (realN)0.000100950558 + q * b;
    q = (realN)0.00134934322 + q * b;
    q = (realN)-0.00367342844 + q * b;
    q = (realN)0.00573950773 + q * b;
    q = (realN)-0.0076224613 + q * b;
    q = (realN)0.00943887047 + q * b;
    q = (realN)1.00167406 + q * b;
    q = (realN)2.83297682 + q * b;
    realN r = sel(q, p, w < 5) * x;
#if CLBRDF_DOUBLE
    for (int i = 0; i < 2; ++i)
        r -= (erf(r) - x) / (2 * INV_SQRT_PI_R * exp(-r * r));
#endif
    return r;
}

/* wi.h = wo.h for h = normalize(wi + wo): |wi + wo| / 2 (exact for unit directions, > 0).
 * Not the dot product with the normalised sum: at grazing near-mirror pairs wi + wo rounds by
 * 1e-16 in x and y where its z is 2e-12, which tilts h by 5e-5 and moves dot(wo, h) by as much
 * (sign included: Ward's and Schlick's pdf went negative), while |wi + wo| moves by 1e-9. */
FN realN half_cos(vec3 wo, vec3 wi)
{
    vec3 s = add3(wi, wo);
    return (realN)0.5 * sqrt(dot3(s, s));
}

/* V-cavity masking-shadowing, Cook & Torrance 1982 eq 2: min(1, 2 (n.h) min(n.wi, n.wo) / wo.h),
 * with wo.h from half_cos: a rounded wo.h <= 0 used to give G = 0 where the true G is 1. */
FN realN vcavity_G(vec3 wo, vec3 wi, vec3 h)
{
    return fmin((realN)1, 2 * h.z * fmin(wi.z, wo.z) / half_cos(wo, wi));
}

#endif
