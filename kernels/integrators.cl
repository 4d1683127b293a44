/* Generic kernels, instantiated per model configuration. They know no model: a model header
 * provides MODEL_eval, MODEL_pdf and MODEL_sample on a Params struct, directions in the order
 * (wo, wi) everywhere (docs/adding-a-model.md).
 *
 * The host defines before this file:
 *   PARAMS(X, XS)  X(name, row) for each scalar parameter of the configuration, XS(name, row)
 *               for each spectral one (rows row .. row + CHANNELS - 1)
 *   CHANNELS    1, or 3 (RGB): a model's value and weight have CHANNELS components
 *   KERNELS     KERNELS_BATCH (eval_batch, pdf_batch, sample_batch), KERNELS_ALBEDO
 *               (albedo_blocks), KERNELS_QUADRATURE (quadrature_panels), KERNELS_LTC
 *               (ltc_moments, ltc_loss: the fit of kernels/ltc.h, clbrdf/tables/ltc.py), KERNELS_WALK
 *               (walk_albedo, walk_sample: the random walk of kernels/heitz_ms.h) or KERNELS_RANDOM
 *               (random_batch: no model, no Params)
 *   MODEL       the model's function prefix (lambert, microfacet, ...)
 *   ESTIMATOR   ESTIMATOR_UNIFORM | ESTIMATOR_COSINE | ESTIMATOR_BRDF | ESTIMATOR_MIS (albedo)
 *   RNG         rand_philox | rand_sobol (RNG_PHILOX 1 for the first; ltc and random; albedo: Philox, its
 *               program holding albedo_qmc too)
 * and includes the model header after common.h, rng.h, warp.h (see clbrdf/runtime/build.py).
 * A program holds one part only, so it compiles no code its caller does not run.
 *
 * Every model kernel takes the parameters P and then TABLES, the program's generated tables
 * (clbrdf/runtime/build.py; one float when it has none).
 * Parameter arrays are structure-of-arrays: row j of query i at P[j * stride + i]; outputs with
 * channels likewise (channel c of query i at out[c * stride + i]).
 */

#define KERNELS_BATCH 0
#define KERNELS_ALBEDO 1
#define KERNELS_RANDOM 2
#define KERNELS_QUADRATURE 3
#define KERNELS_LTC 4
#define KERNELS_WALK 5

#define ESTIMATOR_UNIFORM 0
#define ESTIMATOR_COSINE 1
#define ESTIMATOR_BRDF 2
#define ESTIMATOR_MIS 3

#if KERNELS == KERNELS_RANDOM

/* Uniform numbers from the library's generators, 4 per query (for tests and users). */
__kernel void random_batch(const ulong n, const uint point, const uint stream, const uint seed_lo,
                           const uint seed_hi, global real_t *U)
{
    ulong i = get_global_id(0) * W;
    if (i >= n) return;
    rand4 u = RNG((uintN)(uint)i + LANE_IDS, point, stream, seed_lo, seed_hi);
    VSTORE(u.u0, U + i);
    VSTORE(u.u1, U + n + i);
    VSTORE(u.u2, U + 2 * n + i);
    VSTORE(u.u3, U + 3 * n + i);
}

#else /* KERNELS_BATCH or KERNELS_ALBEDO: a model's kernels */

#define BRDF(fn) CAT(MODEL, CAT(_, fn))

#if KERNELS == KERNELS_ALBEDO
/* How many of the four numbers an estimate uses (a model header defines MODEL_SAMPLE_DIMS). */
#if ESTIMATOR == ESTIMATOR_UNIFORM || ESTIMATOR == ESTIMATOR_COSINE
#define ESTIMATOR_DIMS 2
#elif ESTIMATOR == ESTIMATOR_BRDF
#define ESTIMATOR_DIMS BRDF(SAMPLE_DIMS)
#else
#define ESTIMATOR_DIMS 4
#endif
#define RNG_PAIRS (RNG_PHILOX && ESTIMATOR_DIMS <= 2)
#define RNG_TRIPLES (RNG_PHILOX && ESTIMATOR_DIMS == 3)
#endif

/* W consecutive queries starting at i (batch kernels). */
FN Params load_params(const global real_t *P, Tables TABLES, ulong stride, ulong i)
{
    Params p;
#if CLBRDF_TABLES
    p.tables = TABLES;
#endif
#define LOAD_ONE(name, j) p.name = VLOAD(P + (j) * stride + i);
#define LOAD_SPEC(name, j) for (int c = 0; c < CHANNELS; ++c) p.name[c] = VLOAD(P + ((j) + c) * stride + i);
    PARAMS(LOAD_ONE, LOAD_SPEC)
#undef LOAD_ONE
#undef LOAD_SPEC
    return p;
}

/* One query broadcast to all lanes (albedo kernel: lanes are samples of one point). */
FN Params splat_params(const global real_t *P, Tables TABLES, ulong stride, ulong i)
{
    Params p;
#if CLBRDF_TABLES
    p.tables = TABLES;
#endif
#define SPLAT_ONE(name, j) p.name = (realN)P[(j) * stride + i];
#define SPLAT_SPEC(name, j) for (int c = 0; c < CHANNELS; ++c) p.name[c] = (realN)P[((j) + c) * stride + i];
    PARAMS(SPLAT_ONE, SPLAT_SPEC)
#undef SPLAT_ONE
#undef SPLAT_SPEC
    return p;
}

FN vec3 load_dir(const global real_t *D, ulong stride, ulong i)
{
    return v3(VLOAD(D + i), VLOAD(D + stride + i), VLOAD(D + 2 * stride + i));
}

FN void store_spec(spec v, global real_t *out, ulong stride, ulong i)
{
    for (int c = 0; c < CHANNELS; ++c)
        VSTORE(v.c[c], out + c * stride + i);
}

FN void store_dir(vec3 v, global real_t *D, ulong stride, ulong i)
{
    VSTORE(v.x, D + i);
    VSTORE(v.y, D + stride + i);
    VSTORE(v.z, D + 2 * stride + i);
}

#if KERNELS == KERNELS_BATCH

/* ---- batch kernels: work-item g handles queries [g W, g W + W); n is padded to a multiple of W ---- */

__kernel void eval_batch(const global real_t *P, Tables TABLES, const global real_t *WO, const global real_t *WI,
                         const ulong n, global real_t *out)
{
    ulong i = get_global_id(0) * W;
    if (i >= n) return;
    Params p = load_params(P, TABLES, n, i);
    store_spec(BRDF(eval)(&p, load_dir(WO, n, i), load_dir(WI, n, i)), out, n, i);
}

__kernel void pdf_batch(const global real_t *P, Tables TABLES, const global real_t *WO, const global real_t *WI,
                        const ulong n, global real_t *out)
{
    ulong i = get_global_id(0) * W;
    if (i >= n) return;
    Params p = load_params(P, TABLES, n, i);
    VSTORE(BRDF(pdf)(&p, load_dir(WO, n, i), load_dir(WI, n, i)), out + i);
}

/* U: uniform numbers, 4 per query (structure-of-arrays), so that callers control the stream. */
__kernel void sample_batch(const global real_t *P, Tables TABLES, const global real_t *WO, const global real_t *U,
                           const ulong n, global real_t *WI, global real_t *weight, global real_t *pdf)
{
    ulong i = get_global_id(0) * W;
    if (i >= n) return;
    Params p = load_params(P, TABLES, n, i);
    rand4 u = {VLOAD(U + i), VLOAD(U + n + i), VLOAD(U + 2 * n + i), VLOAD(U + 3 * n + i)};
    BSample s = BRDF(sample)(&p, load_dir(WO, n, i), u);
    store_dir(s.wi, WI, n, i);
    store_spec(s.weight, weight, n, i);
    VSTORE(s.pdf, pdf + i);
}

#endif /* KERNELS_BATCH */

#if KERNELS == KERNELS_ALBEDO

/* ---- directional albedo ---- */

/* One estimate of E(wo) = integral f |cos| dwi (per channel) from the four numbers u, over the
 * hemisphere of a reflection model, over the sphere for a model that transmits (MODEL_TRANSMITS:
 * uniform and cosine-weighted directions on both sides). */
#if BRDF(TRANSMITS)
#define EST_UNIFORM(u0, u1) square_to_uniform_sphere(u0, u1)
#define EST_UNIFORM_WEIGHT(w) (fabs((w).z) * (4 * PI_R))      /* |cos| / pdf */
#define EST_COSINE(u0, u1) square_to_cosine_sphere(u0, u1)
#define EST_COSINE_PDF(w) cosine_sphere_pdf(w)
#define EST_COSINE_WEIGHT (2 * PI_R)
#else
#define EST_UNIFORM(u0, u1) square_to_uniform_hemisphere(u0, u1)
#define EST_UNIFORM_WEIGHT(w) (fmax((w).z, (realN)0) * (2 * PI_R))
#define EST_COSINE(u0, u1) square_to_cosine_hemisphere(u0, u1)
#define EST_COSINE_PDF(w) cosine_hemisphere_pdf(w)
#define EST_COSINE_WEIGHT PI_R
#endif

ALWAYS_INLINE spec albedo_estimate(const Params *p, vec3 wo, rand4 u)
{
#if ESTIMATOR == ESTIMATOR_UNIFORM
    vec3 wi = EST_UNIFORM(u.u0, u.u1);
    return spec_scale(BRDF(eval)(p, wo, wi), EST_UNIFORM_WEIGHT(wi));
#elif ESTIMATOR == ESTIMATOR_COSINE
    vec3 wi = EST_COSINE(u.u0, u.u1);
    return spec_scale(BRDF(eval)(p, wo, wi), EST_COSINE_WEIGHT);
#elif ESTIMATOR == ESTIMATOR_BRDF
    return BRDF(sample)(p, wo, u).weight;
#else
    /* multiple importance sampling, balance heuristic (Veach 1997 section 9.2), one sample of each
     * technique per estimate: E = f |cos| / (pdf_b + pdf_c) at the BRDF sample wb (from u0, u1, u2)
     * + the same at the cosine sample wc (from u3, u2, or u2, u3 where the sampler uses two
     * numbers). Both are computed anyway; choosing one by u3, as before, added the choice's
     * variance (half of it for the Ashikhmin-Shirley plastic, nearly all for a sharp lobe:
     * docs/models/ashikhmin_shirley.md). A BRDF sample reuses its own
     * weight f cos / pdf_b, computed from its half vector: recomputing f and pdf_b from wi + wo
     * loses the lobe in single precision at grazing angles. A delta (pdf_b infinite: a
     * dielectric at eta = 1) keeps its whole weight. */
    BSample sb = BRDF(sample)(p, wo, u);
    realN rb = sel((realN)0, 1 / (1 + EST_COSINE_PDF(sb.wi) / sb.pdf), sb.pdf > 0);
#if BRDF(SAMPLE_DIMS) > 2
    vec3 wc = EST_COSINE(u.u3, u.u2);
#else
    vec3 wc = EST_COSINE(u.u2, u.u3);
#endif
    realN qc = BRDF(pdf)(p, wo, wc) + EST_COSINE_PDF(wc);
    realN rc = sel((realN)0, fabs(wc.z) / qc, qc > 0);   /* wc.z > 0 for a reflection model */
    return spec_add(spec_scale(BRDF(eval)(p, wo, wc), rc), spec_scale(sb.weight, rb));
#endif
}

/* Work-item g of an albedo launch: its point (point0 + g / launch_blocks, whose parameters and
 * wo it loads) and block (block0 + g % launch_blocks); 0 for a padding work-item. */
FN int albedo_work(const global real_t *P, Tables TABLES, const global real_t *WO,
                       ulong npoints, ulong point0, uint block0, uint launch_blocks,
                       Params *p, vec3 *wo, uint *point, uint *block)
{
    ulong g = get_global_id(0), local_point = g / launch_blocks;
    if (local_point >= npoints) return 0;
    *block = block0 + (uint)(g % launch_blocks);
    *point = (uint)(point0 + local_point);
    *p = splat_params(P, TABLES, npoints, local_point);
    *wo = v3((realN)WO[local_point], (realN)WO[npoints + local_point],
             (realN)WO[2 * npoints + local_point]);
    return 1;
}

#if RNG_PHILOX

/* Work-item g of a launch: point g / launch_blocks, block b = block0 + g % launch_blocks of the
 * point's `blocks` (stream b / blocks_per_stream), samples [j L, j L + L) of that stream with
 * j = b % blocks_per_stream and L = block_len (a multiple of 2 W, at most 1024, chosen by the host
 * from the sample count so that small counts waste no lanes); samples at or past `samples` are
 * left out. Per channel the block writes its shift K (the block's first estimate, lane 0) and the
 * shifted sums D = sum (e - K) and Q = sum (e - K)^2 at out[3 (CHANNELS g + c) + 0, 1, 2] = K, D, Q:
 * shifted sums keep the variance exact in single precision where sum e^2 - (sum e)^2 / n cancels.
 * The host combines blocks in double, in a fixed order (clbrdf/runtime/albedo.py). */
__kernel void albedo_blocks(const global real_t *P, Tables TABLES, const global real_t *WO, const ulong npoints,
                            const ulong point0, const uint block0, const uint launch_blocks,
                            const uint samples, const uint seed_lo, const uint seed_hi,
                            const uint blocks_per_stream, const uint block_len, global real_t *out)
{
    ulong g = get_global_id(0);
    Params p;
    vec3 wo;
    uint point, block;
    if (!albedo_work(P, TABLES, WO, npoints, point0, block0, launch_blocks, &p, &wo, &point, &block))
        return;
    uint stream = block / blocks_per_stream;
    uint first = (block % blocks_per_stream) * block_len;
    realN sum[CHANNELS], sum2[CHANNELS];
    real_t shift[CHANNELS];
    for (int c = 0; c < CHANNELS; ++c)
        sum[c] = sum2[c] = 0;
#if RNG_PAIRS
    /* The estimate needs two numbers: one Philox call serves samples 2c and 2c + 1
     * (words 0-1 and 2-3 of counter c), halving the generator's cost: rand_philox_pair's
     * numbers (rng.h), two samples at a time. */
    for (uint k = 0; k < block_len; k += 2 * W) {
        uintN c = (uintN)((first + k) >> 1) + LANE_IDS;
        uint4N r = {c, (uintN)point, (uintN)stream, (uintN)0};
        r = philox4x32_10(r, seed_lo, seed_hi);
        rand4 ua = {bits_to_unit(r.c0), bits_to_unit(r.c1), (realN)0.5, (realN)0.5};
        rand4 ub = {bits_to_unit(r.c2), bits_to_unit(r.c3), (realN)0.5, (realN)0.5};
        spec ea = albedo_estimate(&p, wo, ua), eb = albedo_estimate(&p, wo, ub);
        if (k == 0)
            for (int ch = 0; ch < CHANNELS; ++ch)
                shift[ch] = FIRST_LANE(ea.c[ch]);
        maskN ma = TO_MASK(2 * c < (uintN)samples), mb = TO_MASK(2 * c + 1 < (uintN)samples);
        for (int ch = 0; ch < CHANNELS; ++ch) {
            realN va = sel((realN)0, ea.c[ch] - shift[ch], ma), vb = sel((realN)0, eb.c[ch] - shift[ch], mb);
            sum[ch] += va + vb;
            sum2[ch] += va * va + vb * vb;
        }
    }
#elif RNG_TRIPLES
    /* Three numbers per estimate: three Philox calls serve four samples (rand_philox_triple's
     * numbers, rng.h); a lane takes samples 4 g .. 4 g + 3 (block_len is a multiple of 4 W):
     * one call per sample cost a sampler of three numbers a third of its speed (GGX glass
     * 379 -> 259 M samples/s against its transmission-only two-number configuration). */
    for (uint k = 0; k < block_len; k += 4 * W) {
        uintN gi = (uintN)((first + k) >> 2) + LANE_IDS;
        uint4N r0 = {3 * gi, (uintN)point, (uintN)stream, (uintN)0};
        uint4N r1 = {3 * gi + 1, (uintN)point, (uintN)stream, (uintN)0};
        uint4N r2 = {3 * gi + 2, (uintN)point, (uintN)stream, (uintN)0};
        r0 = philox4x32_10(r0, seed_lo, seed_hi);
        r1 = philox4x32_10(r1, seed_lo, seed_hi);
        r2 = philox4x32_10(r2, seed_lo, seed_hi);
        rand4 uq[4] = {{bits_to_unit(r0.c0), bits_to_unit(r0.c1), bits_to_unit(r0.c2), (realN)0.5},
                       {bits_to_unit(r0.c3), bits_to_unit(r1.c0), bits_to_unit(r1.c1), (realN)0.5},
                       {bits_to_unit(r1.c2), bits_to_unit(r1.c3), bits_to_unit(r2.c0), (realN)0.5},
                       {bits_to_unit(r2.c1), bits_to_unit(r2.c2), bits_to_unit(r2.c3), (realN)0.5}};
        for (uint q = 0; q < 4; ++q) {
            spec e = albedo_estimate(&p, wo, uq[q]);
            if (k == 0 && q == 0)
                for (int ch = 0; ch < CHANNELS; ++ch)
                    shift[ch] = FIRST_LANE(e.c[ch]);
            maskN mq = TO_MASK(4 * gi + q < (uintN)samples);
            for (int ch = 0; ch < CHANNELS; ++ch) {
                realN v = sel((realN)0, e.c[ch] - shift[ch], mq);
                sum[ch] += v;
                sum2[ch] += v * v;
            }
        }
    }
#else
    for (uint k = 0; k < block_len; k += W) {
        uintN idx = (uintN)(first + k) + LANE_IDS;
        rand4 u = RNG(idx, point, stream, seed_lo, seed_hi);
        spec e = albedo_estimate(&p, wo, u);
        if (k == 0)
            for (int ch = 0; ch < CHANNELS; ++ch)
                shift[ch] = FIRST_LANE(e.c[ch]);
        maskN m = TO_MASK(idx < (uintN)samples);
        for (int ch = 0; ch < CHANNELS; ++ch) {
            realN v = sel((realN)0, e.c[ch] - shift[ch], m);
            sum[ch] += v;
            sum2[ch] += v * v;
        }
    }
#endif
    for (int ch = 0; ch < CHANNELS; ++ch) {
        out[3 * (CHANNELS * g + ch)] = shift[ch];
        out[3 * (CHANNELS * g + ch) + 1] = HSUM(sum[ch]);
        out[3 * (CHANNELS * g + ch) + 2] = HSUM(sum2[ch]);
    }
}


#endif /* RNG_PHILOX */

/* quasi-Monte Carlo, in the same program as albedo_blocks (one build for both generators) */

/* Quasi-Monte Carlo: the lanes of a work-item are W of the QMC_STREAMS scrambles, which all take
 * the same sample indices, so the Sobol point is built once for all lanes and scrambled per lane.
 * Work-item g: point g / launch_blocks, block b = block0 + g % launch_blocks: streams
 * [(b / blocks_per_stream) W, + W) (lane l: stream + l), samples [j L, j L + L) of each with
 * j = b % blocks_per_stream and L = block_len, a power of two (at most 1024): the block's indices
 * j L ^ gray(t), t = 0 .. L - 1, are its aligned range in Gray-code order (the same points), so
 * that one XOR per dimension (column ctz(t) of the generator matrix) steps to the next point.
 * Samples at or past `samples` are left out. Per lane and channel the block writes K, D, Q (as
 * albedo_blocks) and the least and greatest weight drawn at out[((CHANNELS g + c) 5 + 0 .. 4)
 * W + l]. */
__kernel void albedo_qmc(const global real_t *P, Tables TABLES, const global real_t *WO, const ulong npoints,
                         const ulong point0, const uint block0, const uint launch_blocks,
                         const uint samples, const uint seed_lo, const uint seed_hi,
                         const uint blocks_per_stream, const uint block_len, global real_t *out)
{
    ulong g = get_global_id(0);
    Params p;
    vec3 wo;
    uint point, block;
    if (!albedo_work(P, TABLES, WO, npoints, point0, block0, launch_blocks, &p, &wo, &point, &block))
        return;
    uintN stream = (uintN)((block / blocks_per_stream) * W) + LANE_IDS;
    uint first = (block % blocks_per_stream) * block_len;
    uintN seed[4], x[4];
    for (uint d = 0; d < 4; ++d) {
        seed[d] = sobol_seed(seed_lo, seed_hi, point, stream, d);
        uint xd = 0;                                   /* sobol_rev(first, d), bit by set bit */
        for (uint b = first; b; b &= b - 1)
            xd ^= SOBOL_VR[d][31 - clz(b & (0u - b))];
        x[d] = (uintN)xd;
    }
    realN sum[CHANNELS], sum2[CHANNELS], shift[CHANNELS], lo[CHANNELS], hi[CHANNELS];
    for (int c = 0; c < CHANNELS; ++c) {
        sum[c] = sum2[c] = 0;
        lo[c] = (realN)INFINITY;               /* the least and greatest weight drawn: the */
        hi[c] = -(realN)INFINITY;              /* unseen-event allowance's evidence (api/albedo.py) */
    }
    for (uint t = 0; t < block_len; ++t) {
        if (t > 0) {
            uint j = 31 - clz(t & (0u - t));                  /* ctz(t): gray(t) ^ gray(t - 1) */
            for (uint d = 0; d < ESTIMATOR_DIMS; ++d)
                x[d] ^= (uintN)SOBOL_VR[d][j];
        }
        rand4 u = {sobol_scrambled(x[0], seed[0]), sobol_scrambled(x[1], seed[1]),
                   ESTIMATOR_DIMS > 2 ? sobol_scrambled(x[2], seed[2]) : (realN)0.5,
                   ESTIMATOR_DIMS > 3 ? sobol_scrambled(x[3], seed[3]) : (realN)0.5};
        spec e = albedo_estimate(&p, wo, u);
        if (t == 0)
            for (int ch = 0; ch < CHANNELS; ++ch)
                shift[ch] = e.c[ch];
        maskN m = TO_MASK((uintN)(first + (t ^ (t >> 1))) < (uintN)samples);
        for (int ch = 0; ch < CHANNELS; ++ch) {
            realN v = sel((realN)0, e.c[ch] - shift[ch], m);
            sum[ch] += v;
            sum2[ch] += v * v;
            lo[ch] = fmin(lo[ch], sel((realN)INFINITY, e.c[ch], m));
            hi[ch] = fmax(hi[ch], sel(-(realN)INFINITY, e.c[ch], m));
        }
    }
    for (int ch = 0; ch < CHANNELS; ++ch) {
        global real_t *o = out + (CHANNELS * g + ch) * 5 * W;
        VSTORE(shift[ch], o);
        VSTORE(sum[ch], o + W);
        VSTORE(sum2[ch], o + 2 * W);
        VSTORE(lo[ch], o + 3 * W);
        VSTORE(hi[ch], o + 4 * W);
    }
}

#endif /* KERNELS_ALBEDO */

#if KERNELS == KERNELS_QUADRATURE

/* ---- directional albedo by deterministic quadrature in the sampler's own unit square ----
 *
 * The sampler maps u in [0,1)^4 onto the hemisphere with density pdf and returns
 * weight = f cos / pdf, so E(wo) = int weight(wo, u) du. A sampler that uses u2 only to pick a
 * lobe (lobe l for u2 in [ends[l - 1], ends[l]), MODEL_lobe_ends) makes the integral over u2 a
 * sum over its lobes: the interval's length times the integral over (u0, u1) with u2 at the
 * interval's midpoint. The sampler flattens its lobe, so the integrand over (u0, u1) is smooth
 * however sharp the lobe, but for kinks where wi crosses the horizon; the host refines the
 * panels where the error estimates are large (clbrdf/runtime/albedo.py, run_quadrature).
 *
 * Panels live in v in [0,1]^2, mapped to u per axis by the sigmoidal map of Sidi (1993),
 * u = v^4 / (v^4 + (1 - v)^4), whose Jacobian vanishes as v^3 at both ends: features attached to
 * an edge of the square at any scale (a lobe's tail squeezed into 1 - u < alpha^2, the pole at
 * u = 0) are reached by the nodes (GGX alpha 1e-3: an E of 1 - 7e-6 was 1 - 1e-10 without it).
 * Work-item g integrates panel g: v0 in [BOX[g], BOX[n + g]), v1 in [BOX[2n + g], BOX[3n + g])
 * (n = npanels) of point PT[g]. RULE holds `nodes` entries (a multiple of W) as five rows: x, y
 * on [0,1]^2 and the weights of three tensor rules (each entry belongs to one rule; its other
 * weights are 0): the fine rule, and two coarser ones (clbrdf/runtime/albedo.py, quad_rule). Per
 * channel the panel writes the fine rule's value at out[2 (CHANNELS g + c)] and the larger of
 * its differences from the coarse rules at + 1, its error estimate.
 *
 * QUAD_SCHLICK 1 integrates weight (1 - wo.h)^5 instead, h the half vector of wo and the
 * sample's wi: the Schlick split's B term int f cos (1 - wo.h)^5 dwi of Heitz et al. 2016's LTC
 * tables (clbrdf/tables/ltc.py). */
#ifndef QUAD_SCHLICK
#define QUAD_SCHLICK 0
#endif
#if QUAD_SCHLICK
#if BRDF(SAMPLE_MEAN)
#error "QUAD_SCHLICK needs each sample's wi: a model with SAMPLE_MEAN has none"
#endif
FN spec quad_weight(vec3 wo, BSample s)
{
    realN c = 1 - half_cos(wo, s.wi);
    return spec_scale(s.weight, sqr(sqr(c)) * c);
}
#else
#define quad_weight(wo, s) ((s).weight)
#endif
FN realN sidi4(realN v, realN *jac)
{
    realN w = 1 - v, v3 = v * v * v, w3 = w * w * w, a = v3 * v, b = w3 * w, d = a + b;
    *jac = 4 * v3 * w3 / (d * d);
    return sel(a / d, (realN)1 - b / d, v > (realN)0.5);
}

__kernel void quadrature_panels(const global real_t *P, Tables TABLES, const global real_t *WO,
                                const ulong npoints, const global uint *PT,
                                const global real_t *BOX, const ulong npanels, const uint nodes,
                                const global real_t *RULE, global real_t *out)
{
    ulong g = get_global_id(0);
    if (g >= npanels) return;
    ulong point = PT[g];
    Params p = splat_params(P, TABLES, npoints, point);
    vec3 wo = v3((realN)WO[point], (realN)WO[npoints + point], (realN)WO[2 * npoints + point]);
#if BRDF(SAMPLE_DIMS) > 2 && !BRDF(SAMPLE_MEAN)
    realN ends[BRDF(LOBES)];
    BRDF(lobe_ends)(&p, wo, ends);
#endif
    real_t s0 = BOX[g], ds = BOX[npanels + g] - s0;
    real_t t0 = BOX[2 * npanels + g], dt = BOX[3 * npanels + g] - t0;
    realN ph[CHANNELS], pl[CHANNELS], pm[CHANNELS];
    for (int ch = 0; ch < CHANNELS; ++ch)
        ph[ch] = pl[ch] = pm[ch] = 0;
    for (uint k = 0; k < nodes; k += W) {
        realN j0, j1;
        rand4 u = {sidi4(s0 + ds * VLOAD(RULE + k), &j0), sidi4(t0 + dt * VLOAD(RULE + nodes + k), &j1),
                   (realN)0.5, (realN)0.5};
        /* 0 < u < 1 as from the generators; the edges of the square (v = 0, 1: nodes of the
         * Lobatto rule) have Jacobian 0 and are left out below */
        u.u0 = clamp(u.u0, (realN)REAL_MIN, (realN)1 - REAL_EPS / 2);
        u.u1 = clamp(u.u1, (realN)REAL_MIN, (realN)1 - REAL_EPS / 2);
        realN jj = j0 * j1;
        realN wh = VLOAD(RULE + 2 * nodes + k) * jj, wl = VLOAD(RULE + 3 * nodes + k) * jj,
              wm = VLOAD(RULE + 4 * nodes + k) * jj;
#if BRDF(SAMPLE_MEAN)
        spec e = BRDF(sample_mean)(&p, wo, u);
#elif BRDF(SAMPLE_DIMS) > 2
        spec e;
        for (int ch = 0; ch < CHANNELS; ++ch)
            e.c[ch] = 0;
        realN lo = 0;
        for (int l = 0; l < BRDF(LOBES); ++l) {
            realN len = ends[l] - lo;
            u.u2 = lo + len / 2;
            spec el = quad_weight(wo, BRDF(sample)(&p, wo, u));
            for (int ch = 0; ch < CHANNELS; ++ch)
                e.c[ch] += sel((realN)0, el.c[ch] * len, len > 0);
            lo = ends[l];
        }
#else
        spec e = quad_weight(wo, BRDF(sample)(&p, wo, u));
#endif
        for (int ch = 0; ch < CHANNELS; ++ch) {
            e.c[ch] = sel((realN)0, e.c[ch], jj > 0);
            ph[ch] += wh * e.c[ch];
            pl[ch] += wl * e.c[ch];
            pm[ch] += wm * e.c[ch];
        }
    }
    real_t area = ds * dt;
    for (int ch = 0; ch < CHANNELS; ++ch) {
        real_t a = HSUM(ph[ch]) * area, b = HSUM(pl[ch]) * area, c = HSUM(pm[ch]) * area;
        out[2 * (CHANNELS * g + ch)] = a;
        out[2 * (CHANNELS * g + ch) + 1] = fmax(fabs(a - b), fabs(a - c));
    }
}

#endif /* KERNELS_QUADRATURE */

#if KERNELS == KERNELS_LTC

/* ---- fitting linearly transformed cosines (kernels/ltc.h) to a lobe: clbrdf/tables/ltc.py ----
 * The lobe of a cell is its (wo, parameters) point's f(wo, wi) cos(theta_i) over wi, first
 * channel; the numbers of sample k of cell c are RNG(k, cell0 + c, 0, seed) for every launch and
 * every candidate matrix, so that a fit sees one deterministic loss (common random numbers);
 * cell0, the first cell's index in the whole grid, keys a part of the cells as the whole. */

/* Work-item g: cell g. Sums over `samples` BRDF samples of the weight w = f cos / pdf, with
 * l = (X.wi, Y.wi, Z.wi) in the cell's frame (FRAME rows X, Y, Z, structure-of-arrays over
 * ncells: moments about the lobe's mean direction stay accurate in single precision, where
 * X^T S X of global moments S cancels): out[16 g + 0..12] = sum w, sum w^2, sum w (1 - wo.h)^5
 * (the Schlick split's B term of Heitz's fit), sum w l (3), sum w l l^T (xx, yy, zz, xy, xz,
 * yz), sum (w (1 - wo.h)^5)^2. */
__kernel void ltc_moments(const global real_t *P, Tables TABLES, const global real_t *WO,
                          const ulong ncells, const uint cell0, const global real_t *FRAME,
                          const uint samples, const uint seed_lo, const uint seed_hi,
                          global real_t *out)
{
    ulong g = get_global_id(0);
    if (g >= ncells) return;
    Params p = splat_params(P, TABLES, ncells, g);
    vec3 wo = v3((realN)WO[g], (realN)WO[ncells + g], (realN)WO[2 * ncells + g]);
    vec3 fx = v3((realN)FRAME[g], (realN)FRAME[ncells + g], (realN)FRAME[2 * ncells + g]);
    vec3 fy = v3((realN)FRAME[3 * ncells + g], (realN)FRAME[4 * ncells + g], (realN)FRAME[5 * ncells + g]);
    vec3 fz = v3((realN)FRAME[6 * ncells + g], (realN)FRAME[7 * ncells + g], (realN)FRAME[8 * ncells + g]);
    realN acc[13];
    for (int j = 0; j < 13; ++j)
        acc[j] = 0;
    for (uint k = 0; k < samples; k += W) {
        uintN idx = (uintN)k + LANE_IDS;
        rand4 u = RNG(idx, cell0 + (uint)g, 0, seed_lo, seed_hi);
        BSample s = BRDF(sample)(&p, wo, u);
        maskN ok = TO_MASK(idx < (uintN)samples) & (s.pdf > 0) & (s.wi.z > 0);
        realN w = sel((realN)0, s.weight.c[0], ok);
        realN c = half_cos(wo, s.wi), s5 = sqr(sqr(1 - c)) * (1 - c);
        vec3 x = v3(fx.x * s.wi.x + fx.y * s.wi.y + fx.z * s.wi.z,
                    fy.x * s.wi.x + fy.y * s.wi.y + fy.z * s.wi.z,
                    fz.x * s.wi.x + fz.y * s.wi.y + fz.z * s.wi.z);
        acc[0] += w;
        acc[1] += w * w;
        acc[2] += w * s5;
        acc[3] += w * x.x; acc[4] += w * x.y; acc[5] += w * x.z;
        acc[6] += w * x.x * x.x; acc[7] += w * x.y * x.y; acc[8] += w * x.z * x.z;
        acc[9] += w * x.x * x.y; acc[10] += w * x.x * x.z; acc[11] += w * x.y * x.z;
        acc[12] += sqr(w * s5);
    }
    for (int j = 0; j < 13; ++j)
        out[16 * g + j] = HSUM(acc[j]);
}

/* Work-item g: candidate g, an LTC for cell CELL[g] given by MAT rows (structure-of-arrays
 * over ncand): M (9, row-major), M^-1 (9), the cell's magnitude E and a scale s (a constant
 * per cell near 1 / max D, so that cubes of sharp lobes' densities stay in single precision's
 * range: e3 below is s^3 times the integrand's). With the normalised lobe t = f cos / E and the
 * LTC's density D, per sample k one BRDF sample wb and one LTC sample wl
 * (from u2, u3) give, by multiple importance sampling with the balance heuristic (Heitz et al.
 * 2016's fit, ltc_code's computeError), estimates of
 *     L3 = int |t - D|^3 dw      e3 = sum over w in (wb, wl) of |t - D|^3 / (pdf_b + D)
 *     L1 = int |t - D| dw        e1 = the same with |t - D|  (the relative L1 error, in [0, 2])
 * out[4 g + 0..3] = sum e3, sum e3^2, sum e1, sum e1^2 over the samples. */
__kernel void ltc_loss(const global real_t *P, Tables TABLES, const global real_t *WO,
                       const ulong ncells, const uint cell0, const global uint *CELL,
                       const global real_t *MAT,
                       const ulong ncand, const uint samples, const uint seed_lo,
                       const uint seed_hi, global real_t *out)
{
    ulong g = get_global_id(0);
    if (g >= ncand) return;
    uint cell = CELL[g];
    Params p = splat_params(P, TABLES, ncells, cell);
    vec3 wo = v3((realN)WO[cell], (realN)WO[ncells + cell], (realN)WO[2 * ncells + cell]);
    mat3r m, minv;
    for (int j = 0; j < 9; ++j) {
        m.m[j] = (realN)MAT[j * ncand + g];
        minv.m[j] = (realN)MAT[(9 + j) * ncand + g];
    }
    realN inv_e = (realN)(1 / MAT[18 * ncand + g]), sc = (realN)MAT[19 * ncand + g];
    realN s3 = 0, q3 = 0, s1 = 0, q1 = 0;
    for (uint k = 0; k < samples; k += W) {
        uintN idx = (uintN)k + LANE_IDS;
        rand4 u = RNG(idx, cell0 + cell, 0, seed_lo, seed_hi);
        maskN live = TO_MASK(idx < (uintN)samples);
        /* the lobe's sample: f cos = weight pdf */
        BSample sb = BRDF(sample)(&p, wo, u);
        maskN okb = (sb.pdf > 0) & (sb.wi.z > 0) & isfinite(sb.pdf);
        realN tb = sel((realN)0, sb.weight.c[0] * sb.pdf * inv_e, okb);
        realN db = ltc_eval(&minv, sb.wi);
        realN pb = sel((realN)0, sb.pdf, okb) + db;
        realN ab = fabs(tb - db), rb = sel((realN)0, 1 / pb, okb & (pb > 0));
        /* the LTC's sample */
        vec3 wl = ltc_sample(&m, u.u2, u.u3);
        realN dl = ltc_eval(&minv, wl);
        realN tl = BRDF(eval)(&p, wo, wl).c[0] * fmax(wl.z, (realN)0) * inv_e;
        realN pl = BRDF(pdf)(&p, wo, wl) + dl;
        realN al = fabs(tl - dl), rl = sel((realN)0, 1 / pl, pl > 0);   /* below the horizon, t = 0: the
                                                                       * LTC's lost mass counts */
        ab *= sc;
        al *= sc;
        realN e3 = sel((realN)0, ab * ab * ab * rb + al * al * al * rl, live);
        ab /= sc;
        al /= sc;
        realN e1 = sel((realN)0, ab * rb + al * rl, live);
        s3 += e3; q3 += e3 * e3;
        s1 += e1; q1 += e1 * e1;
    }
    out[4 * g] = HSUM(s3);
    out[4 * g + 1] = HSUM(q3);
    out[4 * g + 2] = HSUM(s1);
    out[4 * g + 3] = HSUM(q1);
}

#endif /* KERNELS_LTC */



#if KERNELS == KERNELS_WALK

/* ---- the random walk on the microsurface (kernels/heitz_ms.h) ---- */

#if W == 1
#define MS_UMASK(m) (m)
#else
#define MS_UMASK(m) CAT(convert_int, W)(m)     /* a mask for select() on uint lanes */
#endif

/* A work-item's lanes over its block of walks [b L, min(b L + L, walks)) (walk_albedo,
 * walk_eval): each lane's walk, its key (k.walk the walk's index) and event, and the first walk
 * past the block. Lane l starts with walk b L + l. */
typedef struct {
    MsWalk s, fresh;
    MsKey k;
    uintN event;
    uint end;
} MsLanes;

FN MsLanes ms_lanes(vec3 wo, uint point, uint block, uint block_len, uint walks, uint seed_lo,
                    uint seed_hi)
{
    MsLanes l;
    l.end = min(block * block_len + block_len, walks);
    MsKey k = {(uintN)(block * block_len) + LANE_IDS, point, 0, seed_lo, seed_hi};
    l.k = k;
    l.event = (uintN)0;
    l.fresh = ms_start(wo);
    l.s = l.fresh;
    l.s.alive = TO_MASK(k.walk < (uintN)l.end);
    return l;
}

/* The lanes `fin` that finished start their next walk (index + W); the others go to their
 * next event. */
FN void ms_restart(MsLanes *l, maskN fin)
{
    MsWalk *s = &l->s;
    const MsWalk fresh = l->fresh;
    l->k.walk = select(l->k.walk, l->k.walk + (uintN)W, MS_UMASK(fin));
    l->event = select(l->event + (uintN)1, (uintN)0, MS_UMASK(fin));
    s->w = select3(s->w, fresh.w, fin);
    s->h = sel(s->h, fresh.h, fin);
    s->weight = spec_sel(s->weight, fresh.weight, fin);
    s->order = sel(s->order, fresh.order, fin);
    s->inside = sel(s->inside, fresh.inside, fin);
    s->cut = sel(s->cut, fresh.cut, fin);
    s->alive = sel(s->alive, TO_MASK(l->k.walk < (uintN)l->end), fin);
}

#define WALK_SUMS (4 * MS_ORDERS * CHANNELS)
#define WALK_OUT (WALK_SUMS + 2)

/* Work-item g's sums over its lanes: acc, then the walks cut and the hits. */
FN void ms_store(global real_t *out, ulong g, const realN *acc, realN cut, realN hits)
{
    for (int j = 0; j < WALK_SUMS; ++j)
        out[WALK_OUT * g + j] = HSUM(acc[j]);
    out[WALK_OUT * g + WALK_SUMS] = HSUM(cut);
    out[WALK_OUT * g + WALK_SUMS + 1] = HSUM(hits);
}

/* Work-item g: point point0 + g / launch_blocks (its parameters and wo), walks [b L, b L + L)
 * of it, b = block0 + g % launch_blocks and L = block_len (a multiple of W); walks at or past
 * `walks` are left out. Walk j of the point is keyed (j, point, 0, event). Lane l takes walks
 * b L + l, + W, + 2 W, ...: a lane whose walk ends starts its next one at the next event, so
 * that no lane waits for the longest walk of its group (which cost 1.4x). Per class k (the order,
 * min(hits, 3) - 1, plus MS_ORDERS where the walk leaves below the surface) and channel c, the
 * sums of the weight and of its square at out[WALK_OUT g + 2 (k CHANNELS + c) + 0, 1]; then the
 * number of walks cut at max_order and the number of hits of all walks. */
__kernel void walk_albedo(const global real_t *P, Tables TABLES, const global real_t *WO,
                          const ulong npoints, const ulong point0, const uint block0,
                          const uint launch_blocks, const uint walks, const uint seed_lo,
                          const uint seed_hi, const uint max_order, const uint block_len,
                          global real_t *out)
{
    ulong g = get_global_id(0), lp = g / launch_blocks;
    if (lp >= npoints) return;
    uint block = block0 + (uint)(g % launch_blocks), point = (uint)(point0 + lp);
    Params p = splat_params(P, TABLES, npoints, lp);
    vec3 wo = v3((realN)WO[lp], (realN)WO[npoints + lp], (realN)WO[2 * npoints + lp]);
    Microfacet m = ms_distribution(&p);
    realN acc[WALK_SUMS];
    for (int j = 0; j < WALK_SUMS; ++j)
        acc[j] = 0;
    realN cut = 0, hits = 0;
    MsLanes l = ms_lanes(wo, point, block, block_len, walks, seed_lo, seed_hi);
    MsWalk *s = &l.s;
    while (MS_ANY(s->alive)) {
        maskN was = s->alive;
        maskN left = ms_step(&p, m, s, l.k, l.event, max_order);
        maskN over = was & s->cut;
        maskN fin = left | over;
        realN cls = fmin(s->order, (realN)MS_ORDERS) - 1
                    + sel((realN)0, (realN)MS_ORDERS, s->w.z < 0);
        for (int j = 0; j < 2 * MS_ORDERS; ++j) {
            maskN here = left & (cls == (realN)j);
            for (int ch = 0; ch < CHANNELS; ++ch) {
                realN v = sel((realN)0, s->weight.c[ch], here);
                acc[2 * (j * CHANNELS + ch)] += v;
                acc[2 * (j * CHANNELS + ch) + 1] += v * v;
            }
        }
        cut += sel((realN)0, (realN)1, over);
        hits += sel((realN)0, s->order, fin);
        ms_restart(&l, fin);
    }
    ms_store(out, g, acc, cut, hits);
}

#if !CAT(MODEL, _TRANSMITS)
/* The paper's stochastic evaluation (section 4.2, next-event estimation; ms_nee): walks as in
 * walk_albedo from wo (work-item layout, keys and lane refill the same), each summing its
 * estimates of f(wo, wi) cos(theta_i) at every hit. Per class k (the order of the hit, min(hits,
 * 3) - 1; k = MS_ORDERS: the walk's total) and channel c, the sums over walks of the walk's
 * estimate and of its square at out[WALK_OUT g + 2 (k CHANNELS + c) + 0, 1] (the slots of
 * classes past MS_ORDERS are 0); then the walks cut at max_order and the hits of all walks. */
__kernel void walk_eval(const global real_t *P, Tables TABLES, const global real_t *WO,
                        const global real_t *WI, const ulong npoints, const ulong point0,
                        const uint block0, const uint launch_blocks, const uint walks,
                        const uint seed_lo, const uint seed_hi, const uint max_order,
                        const uint block_len, global real_t *out)
{
    ulong g = get_global_id(0), lp = g / launch_blocks;
    if (lp >= npoints) return;
    uint block = block0 + (uint)(g % launch_blocks), point = (uint)(point0 + lp);
    Params p = splat_params(P, TABLES, npoints, lp);
    vec3 wo = v3((realN)WO[lp], (realN)WO[npoints + lp], (realN)WO[2 * npoints + lp]);
    vec3 wi = v3((realN)WI[lp], (realN)WI[npoints + lp], (realN)WI[2 * npoints + lp]);
    Microfacet m = ms_distribution(&p);
    realN lam_i = MF(Lambda)(m, wi);
    realN acc[WALK_SUMS], cur[MS_ORDERS * CHANNELS];
    for (int j = 0; j < WALK_SUMS; ++j)
        acc[j] = 0;
    for (int j = 0; j < MS_ORDERS * CHANNELS; ++j)
        cur[j] = 0;
    realN cut = 0, hits = 0;
    MsLanes l = ms_lanes(wo, point, block, block_len, walks, seed_lo, seed_hi);
    MsWalk *s = &l.s;
    while (MS_ANY(s->alive)) {
        maskN was = s->alive;
        rand4 u = ms_numbers(l.k, l.event);
        maskN left = ms_advance(m, s, u.u0, max_order);
        spec c = ms_nee(&p, m, s, wi, lam_i);
        realN cls = fmin(s->order, (realN)MS_ORDERS) - 1;
        for (int j = 0; j < MS_ORDERS; ++j)
            for (int ch = 0; ch < CHANNELS; ++ch)
                cur[j * CHANNELS + ch] += sel((realN)0, c.c[ch], cls == (realN)j);
        ms_scatter(&p, m, s, u, l.k, l.event);
        maskN over = was & s->cut;
        maskN fin = left | over;
        for (int ch = 0; ch < CHANNELS; ++ch) {
            realN total = 0;
            for (int j = 0; j <= MS_ORDERS; ++j) {
                realN v = j < MS_ORDERS ? sel((realN)0, cur[j * CHANNELS + ch], fin) : total;
                total += v;
                acc[2 * (j * CHANNELS + ch)] += v;
                acc[2 * (j * CHANNELS + ch) + 1] += v * v;
            }
            for (int j = 0; j < MS_ORDERS; ++j)
                cur[j * CHANNELS + ch] = sel(cur[j * CHANNELS + ch], (realN)0, fin);
        }
        cut += sel((realN)0, (realN)1, over);
        hits += sel((realN)0, s->order, fin);
        ms_restart(&l, fin);
    }
    ms_store(out, g, acc, cut, hits);
}
#endif

/* One walk per query i (batch layout, n a multiple of W): walk first + i, keyed (first + i, 0,
 * stream, event). WI the direction it leaves along (NaN where cut), weight its throughput per
 * channel (0 where cut), ORDER its number of hits. */
__kernel void walk_sample(const global real_t *P, Tables TABLES, const global real_t *WO,
                          const ulong n, const uint first, const uint stream, const uint seed_lo,
                          const uint seed_hi, const uint max_order, global real_t *WI,
                          global real_t *weight, global real_t *ORDER)
{
    ulong i = get_global_id(0) * W;
    if (i >= n) return;
    Params p = load_params(P, TABLES, n, i);
    Microfacet m = ms_distribution(&p);
    uintN id = (uintN)(first + (uint)i) + LANE_IDS;
    MsWalk s = ms_start(load_dir(WO, n, i));
    vec3 wi = v3((realN)NAN, (realN)NAN, (realN)NAN);
    realN order = 0;
    MsKey k = {id, 0, stream, seed_lo, seed_hi};
    for (uint e = 0; MS_ANY(s.alive); ++e) {
        maskN left = ms_step(&p, m, &s, k, (uintN)e, max_order);
        wi = select3(wi, s.w, left);
        order = sel(order, s.order, left);
    }
    store_dir(wi, WI, n, i);
    store_spec(spec_sel(s.weight, spec_splat((realN)0), s.cut), weight, n, i);
    VSTORE(order, ORDER + i);
}

#endif /* KERNELS_WALK */

#endif /* a model's kernels */
