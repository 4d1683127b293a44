/* Random and quasi-random numbers keyed by (seed, point, sample index).
 *
 * A number depends only on its key, never on which work-item, work-group, chunk or device
 * computed it, so every result is reproducible bit for bit.
 *
 * - Philox4x32-10 (Salmon et al., "Parallel random numbers: as easy as 1, 2, 3", SC 2011):
 *   counter (sample, point, stream, 0), key (seed_lo, seed_hi); four 32-bit outputs.
 * - Owen-scrambled Sobol (Burley, "Practical hash-based Owen scrambling", JCGT 2020, with
 *   Vegdahl's hash): each of the first four Sobol dimensions (Joe-Kuo direction numbers) is
 *   scrambled with its own seed, keyed by (seed, point, stream); the index is not shuffled
 *   (see rand_sobol).
 */
#ifndef CLBRDF_RNG_H
#define CLBRDF_RNG_H

typedef struct { realN u0, u1, u2, u3; } rand4;

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

typedef struct { uintN c0, c1, c2, c3; } uint4N;

/* hi and lo words of the 32 x 32 -> 64-bit products x * m, lane by lane. With vectors the high
 * words of even and odd lanes are formed in place as 64-bit lanes (one vpmuludq each on x86)
 * and blended back, without widening and narrowing the vector; the low words are the 32-bit
 * products. */
#if W == 2
typedef ulong ulongH;
#define as_ulongH as_ulong
#elif W == 4
typedef ulong2 ulongH;
#define as_ulongH as_ulong2
#elif W == 8
typedef ulong4 ulongH;
#define as_ulongH as_ulong4
#elif W == 16
typedef ulong8 ulongH;
#define as_ulongH as_ulong8
#endif
#define as_uintN CAT(as_uint, W)

FN uintN mulhilo32(uintN x, uint m, uintN *hi)
{
#if W == 1
    ulong p = (ulong)x * m;
    *hi = (uint)(p >> 32);
    return (uint)p;
#else
    ulongH x64 = as_ulongH(x);
    ulongH e = (x64 & (ulongH)0xFFFFFFFFul) * (ulongH)m;     /* lanes 0, 2, 4, ... */
    ulongH o = (x64 >> 32) * (ulongH)m;                        /* lanes 1, 3, 5, ... */
    *hi = as_uintN((e >> 32) | (o & (ulongH)0xFFFFFFFF00000000ul));
    return x * (uintN)m;                                       /* low words: 32-bit products */
#endif
}

FN uint4N philox4x32_10(uint4N c, uint k0, uint k1)
{
    for (int r = 0; r < 10; ++r) {
        uintN hi0, hi1;
        uintN lo0 = mulhilo32(c.c0, PHILOX_M0, &hi0);
        uintN lo1 = mulhilo32(c.c2, PHILOX_M1, &hi1);
        uint4N n = {hi1 ^ c.c1 ^ k0, lo1, hi0 ^ c.c3 ^ k1, lo0};
        c = n;
        k0 += PHILOX_W0;
        k1 += PHILOX_W1;
    }
    return c;
}

/* 32 random bits to a real in the open interval (0, 1): the centre of one of 2^23
 * (single) or 2^32 (double) equal cells, so log(u) and log(1 - u) are always finite.
 * Single precision keeps 23 bits: a centre (k + 1/2) 2^-24 with k >= 2^23 is not a float. */
FN realN bits_to_unit(uintN x)
{
#if CLBRDF_DOUBLE
    return (convert_realN(x) + (realN)0.5) * (realN)2.3283064365386963e-10;
#else
    return (convert_realN(x >> 9) + (realN)0.5) * (realN)1.1920928955078125e-07;
#endif
}

FN rand4 rand_philox(uintN sample, uint point, uint stream, uint seed_lo, uint seed_hi)
{
    uint4N c = {sample, (uintN)point, (uintN)stream, (uintN)0};
    c = philox4x32_10(c, seed_lo, seed_hi);
    rand4 r = {bits_to_unit(c.c0), bits_to_unit(c.c1), bits_to_unit(c.c2), bits_to_unit(c.c3)};
    return r;
}

/* Two numbers of sample `sample` as the albedo estimators that use two per estimate draw them
 * with Philox (integrators.cl, RNG_PAIRS: uniform, cosine, and brdf with a two-dimensional
 * sampler): one call serves samples 2c and 2c + 1, words 0-1 and 2-3 of counter (c, point,
 * stream, 0); u2 = u3 = 1/2. albedo_blocks draws them two at a time. */
FN rand4 rand_philox_pair(uintN sample, uint point, uint stream, uint seed_lo, uint seed_hi)
{
    uint4N c = {sample >> 1, (uintN)point, (uintN)stream, (uintN)0};
    c = philox4x32_10(c, seed_lo, seed_hi);
    maskN odd = TO_MASK((sample & 1u) != 0);
    rand4 r = {sel(bits_to_unit(c.c0), bits_to_unit(c.c2), odd),
               sel(bits_to_unit(c.c1), bits_to_unit(c.c3), odd), (realN)0.5, (realN)0.5};
    return r;
}

/* Three numbers of sample `sample` as the albedo estimators that use three per estimate draw them
 * with Philox (integrators.cl, RNG_TRIPLES: brdf with a sampler whose u2 picks a lobe or a
 * branch): three calls, counters (3 g + j, point, stream, 0) for j = 0, 1, 2, serve the four
 * samples 4 g .. 4 g + 3, sample 4 g + i taking words 3 i, 3 i + 1, 3 i + 2 of the twelve;
 * u3 = 1/2. albedo_blocks draws them four at a time. */
FN rand4 rand_philox_triple(uintN sample, uint point, uint stream, uint seed_lo, uint seed_hi)
{
    uintN g = sample >> 2, i = sample & 3u;
    realN w[12];
    for (uint j = 0; j < 3; ++j) {
        uint4N c = {3 * g + j, (uintN)point, (uintN)stream, (uintN)0};
        c = philox4x32_10(c, seed_lo, seed_hi);
        w[4 * j] = bits_to_unit(c.c0);
        w[4 * j + 1] = bits_to_unit(c.c1);
        w[4 * j + 2] = bits_to_unit(c.c2);
        w[4 * j + 3] = bits_to_unit(c.c3);
    }
    rand4 r = {w[0], w[1], w[2], (realN)0.5};
    for (uint k = 1; k < 4; ++k) {
        maskN m = TO_MASK(i == (uintN)k);
        r.u0 = sel(r.u0, w[3 * k], m);
        r.u1 = sel(r.u1, w[3 * k + 1], m);
        r.u2 = sel(r.u2, w[3 * k + 2], m);
    }
    return r;
}

/* Sobol generator matrices of dimensions 0-3 (Joe & Kuo's direction numbers), bit-reversed:
 * column j, the contribution of index bit j, holds the direction number v_j with its bits
 * reversed (bit k of the column is bit 31 - k of v_j). A point is built reversed, scrambled there
 * and reversed once (sobol_scrambled). */
__constant uint SOBOL_VR[4][32] = {
    {0x00000001u, 0x00000002u, 0x00000004u, 0x00000008u, 0x00000010u, 0x00000020u, 0x00000040u, 0x00000080u,
     0x00000100u, 0x00000200u, 0x00000400u, 0x00000800u, 0x00001000u, 0x00002000u, 0x00004000u, 0x00008000u,
     0x00010000u, 0x00020000u, 0x00040000u, 0x00080000u, 0x00100000u, 0x00200000u, 0x00400000u, 0x00800000u,
     0x01000000u, 0x02000000u, 0x04000000u, 0x08000000u, 0x10000000u, 0x20000000u, 0x40000000u, 0x80000000u},
    {0x00000001u, 0x00000003u, 0x00000005u, 0x0000000fu, 0x00000011u, 0x00000033u, 0x00000055u, 0x000000ffu,
     0x00000101u, 0x00000303u, 0x00000505u, 0x00000f0fu, 0x00001111u, 0x00003333u, 0x00005555u, 0x0000ffffu,
     0x00010001u, 0x00030003u, 0x00050005u, 0x000f000fu, 0x00110011u, 0x00330033u, 0x00550055u, 0x00ff00ffu,
     0x01010101u, 0x03030303u, 0x05050505u, 0x0f0f0f0fu, 0x11111111u, 0x33333333u, 0x55555555u, 0xffffffffu},
    {0x00000001u, 0x00000003u, 0x00000006u, 0x00000009u, 0x00000017u, 0x0000003au, 0x00000071u, 0x000000a3u,
     0x00000116u, 0x00000339u, 0x00000677u, 0x000009aau, 0x00001601u, 0x00003903u, 0x00007706u, 0x0000aa09u,
     0x00010117u, 0x0003033au, 0x00060671u, 0x000909a3u, 0x00171616u, 0x003a3939u, 0x00717777u, 0x00a3aaaau,
     0x01170001u, 0x033a0003u, 0x06710006u, 0x09a30009u, 0x16160017u, 0x3939003au, 0x77770071u, 0xaaaa00a3u},
    {0x00000001u, 0x00000003u, 0x00000004u, 0x0000000au, 0x0000001fu, 0x0000002eu, 0x00000045u, 0x000000c9u,
     0x0000011bu, 0x000002a4u, 0x0000079au, 0x00000b67u, 0x0000101eu, 0x0000302du, 0x00004041u, 0x0000a0c3u,
     0x0001f104u, 0x0002e28au, 0x000457dfu, 0x000c9baeu, 0x0011a105u, 0x002a7289u, 0x0079e7dbu, 0x00b6dba4u,
     0x0100011au, 0x030002a7u, 0x0400079eu, 0x0a000b6du, 0x1f001001u, 0x2e003003u, 0x45004004u, 0xc900a00au}};

/* Dimension d of Sobol point `index`, bit-reversed. */
FN uintN sobol_rev(uintN index, int d)
{
    uintN x = (uintN)0;
    for (int j = 0; j < 32; ++j)
        x ^= (uintN)SOBOL_VR[d][j] & ((uintN)0 - ((index >> (uint)j) & (uintN)1));
    return x;
}

FN uintN reverse_bits(uintN x)
{
    x = ((x >> 1) & (uintN)0x55555555u) | ((x & (uintN)0x55555555u) << 1);
    x = ((x >> 2) & (uintN)0x33333333u) | ((x & (uintN)0x33333333u) << 2);
    x = ((x >> 4) & (uintN)0x0F0F0F0Fu) | ((x & (uintN)0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & (uintN)0x00FF00FFu) | ((x & (uintN)0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}

/* A bit-reversed Sobol coordinate xr, Owen-scrambled (nested uniform scramble) with `seed`, as a
 * real in (0, 1). In bit-reversed order a permutation whose output bit k depends only on input
 * bits 0..k is a nested uniform scramble (Burley 2020); this one is N. Vegdahl's hash ("Building
 * a better LK hash", 2021). Burley's listing 2 hash (x += seed, then x ^= x * c for four
 * constants) leaves the low-order digits of the first 2^m points poorly randomised: on unshuffled
 * points its estimates were biased (GGX dielectric, cosine estimator, mu 0.05, 2^18 samples:
 * -2.1e-5 +- 2.6e-6 over 100 seeds; this hash -3.7e-6 +- 3.0e-6; tests/runtime/test_qmc.py). The bits
 * are then put back in order. */
FN realN sobol_scrambled(uintN xr, uintN seed)
{
    uintN x = xr;
    x ^= x * (uintN)0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | (uintN)1;
    x ^= x * (uintN)0x05526c56u;
    x ^= x * (uintN)0x53a22864u;
    return bits_to_unit(reverse_bits(x));
}

FN uintN hash_u32(uintN x)
{
    /* lowbias32 (C. Wellons) */
    x ^= x >> 16; x *= (uintN)0x7feb352du;
    x ^= x >> 15; x *= (uintN)0x846ca68bu;
    x ^= x >> 16;
    return x;
}

FN uintN hash_combine(uintN seed, uintN v)
{
    return seed ^ (v + (uintN)0x9e3779b9u + (seed << 6) + (seed >> 2));
}

/* The scramble seed of dimension d of the sequence (seed, point, stream). */
FN uintN sobol_seed(uint seed_lo, uint seed_hi, uint point, uintN stream, uint d)
{
    uintN s = hash_combine(hash_combine((uintN)hash_u32((uintN)seed_lo), (uintN)seed_hi), (uintN)point);
    return hash_combine(hash_u32(hash_combine(s, stream)), (uintN)d);
}

/* Point `sample` of the Owen-scrambled Sobol sequence (seed, point, stream), dimensions 0-3. The
 * samples are not shuffled: any 2^m consecutive ones aligned at a multiple of 2^m are a
 * (0, m, 2)-net in dimensions (0, 1) and stratified in each dimension. The albedo kernel visits
 * them in Gray-code order (the same points). */
FN rand4 rand_sobol(uintN sample, uint point, uint stream, uint seed_lo, uint seed_hi)
{
    rand4 r = {sobol_scrambled(sobol_rev(sample, 0), sobol_seed(seed_lo, seed_hi, point, (uintN)stream, 0)),
               sobol_scrambled(sobol_rev(sample, 1), sobol_seed(seed_lo, seed_hi, point, (uintN)stream, 1)),
               sobol_scrambled(sobol_rev(sample, 2), sobol_seed(seed_lo, seed_hi, point, (uintN)stream, 2)),
               sobol_scrambled(sobol_rev(sample, 3), sobol_seed(seed_lo, seed_hi, point, (uintN)stream, 3))};
    return r;
}

#endif
