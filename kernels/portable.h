/* clbrdf portability: the kernel sources compile as OpenCL C (1.2, 3.0), C99, C++17 and CUDA.
 *
 * The sources are written in OpenCL C. For the other targets this header maps what they use:
 *   FN, ALWAYS_INLINE   function qualifiers: OpenCL `inline`; C `static inline`; C++ `inline`;
 *                       CUDA `__device__ inline` (device code only)
 *   global, constant    address spaces: nothing (CUDA: constant tables are __constant__)
 *   uint, ulong         unsigned 32- and 64-bit integers
 *   convert_T(x)        OpenCL conversions (float to integer rounds toward zero, as a C cast)
 *   rsqrt, clamp, iclamp (clamp of integers)  as macros (clbrdf.h removes them, and the address-space and conversion
 *                       macros, once the sources are read)
 *   sqrt, exp, log, ... the precision's own overload: <tgmath.h> in C, <cmath> in C++, CUDA's
 *                       device overloads; never the native_* or fast-math functions
 * Outside OpenCL only W = 1 (one lane: realN is real_t) is supported; CLBRDF_SEPARATE_SINCOS is
 * set (sin and cos apart). Results agree with OpenCL's to a few ulps (the math libraries differ;
 * tests/runtime/test_capi.py states how many), not bit for bit.
 */
#ifndef CLBRDF_PORTABLE_H
#define CLBRDF_PORTABLE_H

#if defined(__OPENCL_C_VERSION__) || defined(__OPENCL_VERSION__)
#define CLBRDF_OPENCL 1
#define FN inline
#if CLBRDF_NO_FORCED_INLINE     /* oclgrind: forced inlining emits an LLVM intrinsic
                                 * (noalias.scope.decl) that it cannot run */
#define ALWAYS_INLINE inline
#else
#define ALWAYS_INLINE inline __attribute__((always_inline))
#endif
#define iclamp clamp                    /* clamp of integers */

#else /* C99, C++17, CUDA */
#define CLBRDF_OPENCL 0
#if defined(W) && W != 1
#error "clbrdf: W (lanes per work-item) must be 1 outside OpenCL"
#endif
#undef W
#define W 1
#ifndef CLBRDF_SEPARATE_SINCOS
#define CLBRDF_SEPARATE_SINCOS 1
#endif

#include <float.h>
#include <stdint.h>
#if defined(__cplusplus)
#include <cmath>
#else
#include <math.h>
#include <tgmath.h>
#endif

#if defined(__CUDACC__)
#define FN __device__ inline
#define ALWAYS_INLINE __device__ __forceinline__
#define __constant __constant__ const
#elif defined(__cplusplus)
#define FN inline
#define ALWAYS_INLINE inline __attribute__((always_inline))
#define __constant static const
#else
#define FN static inline
#define ALWAYS_INLINE static inline __attribute__((always_inline))
#define __constant static const
#endif
#define __global
#define global
#define constant

#if defined(__cplusplus) && !defined(__CUDACC__)
using std::acos; using std::asinh; using std::atan2; using std::cos; using std::erf;
using std::erfc; using std::exp; using std::expm1; using std::fabs; using std::floor;
using std::fmax; using std::fmin; using std::lgamma; using std::log; using std::log1p;
using std::log2; using std::pow; using std::rint; using std::sin; using std::sqrt; using std::tan;
using std::isinf; using std::isnan;
#endif

typedef uint32_t uint;
typedef uint64_t ulong;
#define convert_int(x) ((int)(x))
#define convert_uint(x) ((uint)(x))
#define convert_ulong(x) ((ulong)(x))
#define convert_float(x) ((float)(x))
#define convert_double(x) ((double)(x))
#define rsqrt(x) (1 / sqrt(x))
#define clamp(x, lo, hi) fmin(fmax((x), (lo)), (hi))
#define iclamp(x, lo, hi) ((x) < (lo) ? (lo) : (x) > (hi) ? (hi) : (x))
#endif

#endif
