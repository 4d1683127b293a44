/* Random and quasi-random numbers keyed by (seed, point, sample index).
 *
 * A number depends only on its key, never on which work-item, work-group, chunk or device
 * computed it, so every result is reproducible bit for bit.
 *
 * - Philox4x32-10 (Salmon et al., "Parallel random numbers: as easy as 1, 2, 3", SC 2011):
 *   counter (sample, point, stream, 0), key (seed_lo, seed_hi); four 32-bit outputs.
 * - Owen-scrambled Sobol (Burley, "Practical hash-based Owen scrambling", JCGT 2020):
 *   the index is shuffled by a nested uniform scramble, then each of the first four
 *   Sobol dimensions (Joe-Kuo direction numbers) is scrambled with its own seed.
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

inline uintN mulhilo32(uintN x, uint m, uintN *hi)
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

inline uint4N philox4x32_10(uint4N c, uint k0, uint k1)
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
inline realN bits_to_unit(uintN x)
{
#if CLBRDF_DOUBLE
    return (convert_realN(x) + (realN)0.5) * (realN)2.3283064365386963e-10;
#else
    return (convert_realN(x >> 9) + (realN)0.5) * (realN)1.1920928955078125e-07;
#endif
}

inline rand4 rand_philox(uintN sample, uint point, uint stream, uint seed_lo, uint seed_hi)
{
    uint4N c = {sample, (uintN)point, (uintN)stream, (uintN)0};
    c = philox4x32_10(c, seed_lo, seed_hi);
    rand4 r = {bits_to_unit(c.c0), bits_to_unit(c.c1), bits_to_unit(c.c2), bits_to_unit(c.c3)};
    return r;
}

/* Sobol generator matrices, dimensions 0-3 (column j: the contribution of index bit j). */
__constant uint SOBOL_V[4][32] = {
    {0x80000000u, 0x40000000u, 0x20000000u, 0x10000000u, 0x08000000u, 0x04000000u, 0x02000000u, 0x01000000u,
     0x00800000u, 0x00400000u, 0x00200000u, 0x00100000u, 0x00080000u, 0x00040000u, 0x00020000u, 0x00010000u,
     0x00008000u, 0x00004000u, 0x00002000u, 0x00001000u, 0x00000800u, 0x00000400u, 0x00000200u, 0x00000100u,
     0x00000080u, 0x00000040u, 0x00000020u, 0x00000010u, 0x00000008u, 0x00000004u, 0x00000002u, 0x00000001u},
    {0x80000000u, 0xc0000000u, 0xa0000000u, 0xf0000000u, 0x88000000u, 0xcc000000u, 0xaa000000u, 0xff000000u,
     0x80800000u, 0xc0c00000u, 0xa0a00000u, 0xf0f00000u, 0x88880000u, 0xcccc0000u, 0xaaaa0000u, 0xffff0000u,
     0x80008000u, 0xc000c000u, 0xa000a000u, 0xf000f000u, 0x88008800u, 0xcc00cc00u, 0xaa00aa00u, 0xff00ff00u,
     0x80808080u, 0xc0c0c0c0u, 0xa0a0a0a0u, 0xf0f0f0f0u, 0x88888888u, 0xccccccccu, 0xaaaaaaaau, 0xffffffffu},
    {0x80000000u, 0xc0000000u, 0x60000000u, 0x90000000u, 0xe8000000u, 0x5c000000u, 0x8e000000u, 0xc5000000u,
     0x68800000u, 0x9cc00000u, 0xee600000u, 0x55900000u, 0x80680000u, 0xc09c0000u, 0x60ee0000u, 0x90550000u,
     0xe8808000u, 0x5cc0c000u, 0x8e606000u, 0xc5909000u, 0x6868e800u, 0x9c9c5c00u, 0xeeee8e00u, 0x5555c500u,
     0x8000e880u, 0xc0005cc0u, 0x60008e60u, 0x9000c590u, 0xe8006868u, 0x5c009c9cu, 0x8e00eeeeu, 0xc5005555u},
    {0x80000000u, 0xc0000000u, 0x20000000u, 0x50000000u, 0xf8000000u, 0x74000000u, 0xa2000000u, 0x93000000u,
     0xd8800000u, 0x25400000u, 0x59e00000u, 0xe6d00000u, 0x78080000u, 0xb40c0000u, 0x82020000u, 0xc3050000u,
     0x208f8000u, 0x51474000u, 0xfbea2000u, 0x75d93000u, 0xa0858800u, 0x914e5400u, 0xdbe79e00u, 0x25db6d00u,
     0x58800080u, 0xe54000c0u, 0x79e00020u, 0xb6d00050u, 0x800800f8u, 0xc00c0074u, 0x200200a2u, 0x50050093u}};

inline uintN sobol_dim(uintN index, int dim)
{
    uintN x = (uintN)0;
    for (int j = 0; j < 32; ++j)
        x ^= (uintN)SOBOL_V[dim][j] & (uintN)0 - ((index >> (uint)j) & (uintN)1);
    return x;
}

inline uintN reverse_bits(uintN x)
{
    x = ((x >> 1) & (uintN)0x55555555u) | ((x & (uintN)0x55555555u) << 1);
    x = ((x >> 2) & (uintN)0x33333333u) | ((x & (uintN)0x33333333u) << 2);
    x = ((x >> 4) & (uintN)0x0F0F0F0Fu) | ((x & (uintN)0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & (uintN)0x00FF00FFu) | ((x & (uintN)0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}

/* Burley 2020, listing 2: the Laine-Karras permutation with better constants, applied in
 * bit-reversed order, is a nested uniform (Owen) scramble. */
inline uintN nested_uniform_scramble(uintN x, uint seed)
{
    x = reverse_bits(x);
    x += (uintN)seed;
    x ^= x * (uintN)0x6c50b47cu;
    x ^= x * (uintN)0xb82f1e52u;
    x ^= x * (uintN)0xc7afe638u;
    x ^= x * (uintN)0x8d22f6e6u;
    return reverse_bits(x);
}

inline uint hash_u32(uint x)
{
    /* lowbias32 (C. Wellons) */
    x ^= x >> 16; x *= 0x7feb352du;
    x ^= x >> 15; x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

inline uint hash_combine(uint seed, uint v) { return seed ^ (v + 0x9e3779b9u + (seed << 6) + (seed >> 2)); }

inline rand4 rand_sobol(uintN sample, uint point, uint stream, uint seed_lo, uint seed_hi)
{
    uint s = hash_u32(hash_combine(hash_combine(hash_combine(hash_u32(seed_lo), seed_hi), point), stream));
    uintN i = nested_uniform_scramble(sample, s);
    rand4 r = {bits_to_unit(nested_uniform_scramble(sobol_dim(i, 0), hash_combine(s, 0u))),
               bits_to_unit(nested_uniform_scramble(sobol_dim(i, 1), hash_combine(s, 1u))),
               bits_to_unit(nested_uniform_scramble(sobol_dim(i, 2), hash_combine(s, 2u))),
               bits_to_unit(nested_uniform_scramble(sobol_dim(i, 3), hash_combine(s, 3u)))};
    return r;
}

#endif
