/* clbrdf C API: the models, random numbers and warps of clbrdf's kernels as scalar functions,
 * for your own OpenCL C, C99, C++17 or CUDA code (docs/kernels.md). `-I kernels` and
 *
 *     #define CHANNELS 3               optional: RGB (default 1)
 *     #define CLBRDF_DOUBLE 1          optional: double precision (default single)
 *     #define MF_FRESNEL FRESNEL_SCHLICK   optional: a model's configuration (its header's table)
 *     #include "clbrdf.h"
 *
 *     clbrdf_ggx_params p = clbrdf_ggx_defaults();
 *     p.alpha = 0.3f;
 *     vec3 wo = v3(0.6f, 0.0f, 0.8f), wi = v3(-0.6f, 0.0f, 0.8f);   unit vectors, z = normal
 *     spec f = clbrdf_ggx_eval(&p, wo, wi);                           f.c[0]: 1/sr
 *     BSample s = clbrdf_ggx_sample(&p, wo, clbrdf_random(sample, point, 0, seed));
 *     s.wi, s.weight.c[0] (= f cos(theta_i) / pdf), s.pdf
 *
 * Directions are unit vectors in the shading frame (z the normal, x the tangent of anisotropic
 * models), both pointing away from the surface, in the order (wo, wi). Per model (generated in
 * clbrdf_models.h from the same descriptions as the Python package): clbrdf_NAME_params,
 * clbrdf_NAME_defaults(), clbrdf_NAME_eval, clbrdf_NAME_pdf, clbrdf_NAME_sample. The functions
 * are the ones the Python package's kernels run (one lane per call here).
 *
 * ltc.h's LTC functions come with it (mat3r, ltc_eval, ltc_sample, ltc_polygon: an area light
 * shaded with a fitted table, `clbrdf ltc`; examples/ltc_quad.c).
 *
 * In C++ and CUDA everything is in namespace clbrdf. The microfacet models take one
 * configuration per translation unit (MF_DIST, MF_FRESNEL, ...). gtr, sgd, exppow,
 * holzschuch_pacanowski and sgd_bagher read generated tables: set params.tables to the buffer
 * that clbrdf_tables.h loads (on a GPU, a device copy of it).
 */
#ifndef CLBRDF_H
#define CLBRDF_H

#include "portable.h"          /* system headers, outside the namespace */
#undef CLBRDF_TABLES
#define CLBRDF_TABLES 1             /* models take the generated tables through params.tables */

#if defined(__cplusplus)
namespace clbrdf {
#endif

#include "common.h"
#include "rng.h"
#include "warp.h"
#include "ltc.h"               /* linearly transformed cosines: ltc_eval, ltc_sample, ltc_polygon */

/* Four numbers in (0, 1) for sample `sample` of point `point`, stream `stream`, from a 64-bit
 * seed: Philox4x32-10 keyed as the Python package keys its estimators (rng.h). */
FN rand4 clbrdf_random(uint sample, uint point, uint stream, ulong seed)
{
    return rand_philox(sample, point, stream, (uint)(seed & 0xFFFFFFFFu), (uint)(seed >> 32));
}

/* The same for an estimator that uses two numbers per sample, keyed as the Python package's
 * albedo estimators key them with Philox (uniform, cosine, and brdf where the sampler takes
 * two: MODEL_SAMPLE_DIMS == 2): `clbrdf albedo MODEL --estimator brdf --seed S` averages the
 * weights of clbrdf_random2(k, 0, 0, S), k < samples, for its first point. */
FN rand4 clbrdf_random2(uint sample, uint point, uint stream, ulong seed)
{
    return rand_philox_pair(sample, point, stream, (uint)(seed & 0xFFFFFFFFu), (uint)(seed >> 32));
}

/* The same for an estimator that uses three numbers per sample (brdf where the sampler's u2
 * picks a lobe or a branch: kd with a microfacet lobe, ggx_dielectric): four samples per three
 * Philox calls, keyed as the Python package's albedo estimators key them. */
FN rand4 clbrdf_random3(uint sample, uint point, uint stream, ulong seed)
{
    return rand_philox_triple(sample, point, stream, (uint)(seed & 0xFFFFFFFFu), (uint)(seed >> 32));
}

#include "clbrdf_models.h"

#if defined(__cplusplus)
}   /* namespace clbrdf */
#endif

/* the helper macros are not needed past this point: leave the names to the user (the
 * configuration macros MF_*, AS_*, ... and CHANNELS, CLBRDF_DOUBLE stay) */
#undef W
#undef sel
#undef CAT
#undef CAT_
#undef HSUM
#undef HSUM4
#undef HSUM8
#undef FIRST_LANE
#undef LANE_IDS
#undef TO_MASK
#undef VLOAD
#undef VSTORE
#undef REAL
#undef MASK
#undef MF
#if !CLBRDF_OPENCL
#undef clamp
#undef iclamp
#undef rsqrt
#undef global
#undef constant
#undef __global
#undef __constant
#undef convert_int
#undef convert_uint
#undef convert_ulong
#undef convert_float
#undef convert_double
#endif

#endif
