/* GGX directional albedo through the C API in CUDA (or, built by a C++ compiler, on the host:
 * the CPU test of this program): the samples per second, and Blender Cycles' table_ggx_E end to
 * end. Built by scripts/gpu_check/gpu_check.sh with the defines of clbrdf.Model('ggx',
 * masking='correlated', fresnel='one') (cycles/defines in the bundle).
 *
 *   bench_cuda rate ALPHA LOG2_SAMPLES REPEATS    one JSON line: samples/s (median of REPEATS
 *                                                 launches), block size, occupancy, E at 64 mu
 *   bench_cuda cycles CELLS SAMPLES OUT           E and its standard error per cell (mu alpha
 *                                                 per line of CELLS) with SAMPLES samples each,
 *                                                 to OUT; one JSON line: the seconds end to end
 *                                                 (read, copy, kernel, copy back, write) and of
 *                                                 the kernel alone
 * Thread g is one sample stream: STREAM samples k = s STREAM .. of point j (s = g mod the
 * streams per point), numbers clbrdf_random2(k, j, 0, seed), the brdf estimator of `clbrdf
 * albedo ggx --estimator brdf`; it writes its first weight w0 and the sums of w - w0 and of
 * (w - w0)^2 (float sums of w^2 cancel where every weight is near 1: low roughness), which the
 * host combines in double (the parallel form of the variance). */
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>
#include "clbrdf.h"

using namespace clbrdf;

#define STREAM 256u
#define SEED 0ull      /* make_layout's default seed: the same samples as the bundle's table */

#ifdef __CUDACC__
#define DEV __device__
#else
#define DEV
#endif

DEV static void stream_sums(const float *mu, const float *alpha, unsigned per_point, unsigned g,
                            float *out)
{
    unsigned j = g / per_point, s = g % per_point;
    clbrdf_ggx_params p = clbrdf_ggx_defaults();
    p.alpha = alpha[j];
    float m = mu[j];
    vec3 wo = v3(sqrtf(1 - m * m), 0.0f, m);
    float w0 = 0, sum = 0, sq = 0;
    for (unsigned k = s * STREAM; k < s * STREAM + STREAM; ++k) {
        float w = clbrdf_ggx_sample(&p, wo, clbrdf_random2(k, j, 0, SEED)).weight.c[0];
        if (k == s * STREAM) w0 = w;
        sum += w - w0;
        sq += (w - w0) * (w - w0);
    }
    out[3 * g] = w0;
    out[3 * g + 1] = sum;
    out[3 * g + 2] = sq;
}

static double now()
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

#ifdef __CUDACC__
__global__ void sums_kernel(const float *mu, const float *alpha, unsigned per_point, unsigned items,
                            float *out)
{
    unsigned g = blockIdx.x * blockDim.x + threadIdx.x;
    if (g < items) stream_sums(mu, alpha, per_point, g, out);
}

static void check(cudaError_t e, const char *what)
{
    if (e != cudaSuccess) {
        std::fprintf(stderr, "bench_cuda: %s: %s\n", what, cudaGetErrorString(e));
        std::exit(3);
    }
}
#endif

/* The sums of every stream of every point; returns the kernel's seconds (one launch). */
static double run(const std::vector<float> &mu, const std::vector<float> &alpha, unsigned per_point,
                  std::vector<float> &out, int *block, double *occupancy)
{
    unsigned items = (unsigned)mu.size() * per_point;
    out.assign(3 * (size_t)items, 0.0f);
#ifdef __CUDACC__
    static int bs = 0;
    static double occ = 0;
    if (!bs) {
        int grid_min = 0, active = 0;
        check(cudaOccupancyMaxPotentialBlockSize(&grid_min, &bs, sums_kernel), "occupancy");
        check(cudaOccupancyMaxActiveBlocksPerMultiprocessor(&active, sums_kernel, bs, 0), "occupancy");
        cudaDeviceProp prop;
        check(cudaGetDeviceProperties(&prop, 0), "device properties");
        occ = (double)active * bs / prop.maxThreadsPerMultiProcessor;
    }
    *block = bs;
    *occupancy = occ;
    float *dmu, *dal, *dout;
    check(cudaMalloc(&dmu, mu.size() * 4), "cudaMalloc");
    check(cudaMalloc(&dal, alpha.size() * 4), "cudaMalloc");
    check(cudaMalloc(&dout, out.size() * 4), "cudaMalloc");
    check(cudaMemcpy(dmu, mu.data(), mu.size() * 4, cudaMemcpyHostToDevice), "copy");
    check(cudaMemcpy(dal, alpha.data(), alpha.size() * 4, cudaMemcpyHostToDevice), "copy");
    cudaEvent_t a, b;
    cudaEventCreate(&a);
    cudaEventCreate(&b);
    cudaEventRecord(a);
    sums_kernel<<<(items + bs - 1) / bs, bs>>>(dmu, dal, per_point, items, dout);
    cudaEventRecord(b);
    check(cudaEventSynchronize(b), "kernel");
    check(cudaGetLastError(), "kernel");
    float ms = 0;
    cudaEventElapsedTime(&ms, a, b);
    check(cudaMemcpy(out.data(), dout, out.size() * 4, cudaMemcpyDeviceToHost), "copy back");
    cudaFree(dmu);
    cudaFree(dal);
    cudaFree(dout);
    return ms / 1e3;
#else
    *block = 1;
    *occupancy = 1;
    double t = now();
    for (unsigned g = 0; g < items; ++g) stream_sums(mu.data(), alpha.data(), per_point, g, out.data());
    return now() - t;
#endif
}

static void reduce(const std::vector<float> &out, unsigned points, unsigned per_point, unsigned n,
                   std::vector<double> &e, std::vector<double> &se)
{
    e.assign(points, 0);
    se.assign(points, 0);
    for (unsigned j = 0; j < points; ++j) {
        double mean = 0, m2 = 0;
        for (unsigned i = 0; i < per_point; ++i) {            /* each stream's mean */
            const float *o = &out[3 * ((size_t)j * per_point + i)];
            mean += o[0] + (double)o[1] / STREAM;
        }
        mean /= per_point;
        for (unsigned i = 0; i < per_point; ++i) {            /* within and between streams */
            const float *o = &out[3 * ((size_t)j * per_point + i)];
            double mi = o[0] + (double)o[1] / STREAM;
            m2 += std::max((double)o[2] - (double)o[1] * o[1] / STREAM, 0.0)
                  + STREAM * (mi - mean) * (mi - mean);
        }
        e[j] = mean;
        se[j] = std::sqrt(m2 / (n - 1) / n);
    }
}

int main(int argc, char **argv)
{
    std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "rate" && argc == 5) {
        float alpha = (float)std::atof(argv[2]);
        unsigned n = 1u << std::atoi(argv[3]), reps = (unsigned)std::atoi(argv[4]), points = 64;
        std::vector<float> mu(points), al(points, alpha), out;
        for (unsigned j = 0; j < points; ++j) mu[j] = (j + 1.0f) / points;
        unsigned per_point = std::max(1u, n / STREAM);
        int block = 0;
        double occ = 0;
        std::vector<double> t;
        run(mu, al, per_point, out, &block, &occ);                   /* warm-up */
        for (unsigned r = 0; r < reps; ++r) t.push_back(run(mu, al, per_point, out, &block, &occ));
        std::sort(t.begin(), t.end());
        std::vector<double> e, se;
        reduce(out, points, per_point, per_point * STREAM, e, se);
        double samples = (double)points * per_point * STREAM, med = t[t.size() / 2];
#ifdef __CUDACC__
        int sm = 0, khz = 0, cc = 0;
        cudaDeviceGetAttribute(&sm, cudaDevAttrMultiProcessorCount, 0);
        cudaDeviceGetAttribute(&khz, cudaDevAttrClockRate, 0);
        cudaDeviceGetAttribute(&cc, cudaDevAttrComputeCapabilityMajor, 0);
        std::printf("{\"sm\": %d, \"clock_khz\": %d, \"cc\": %d, ", sm, khz, cc);
#else
        std::printf("{");
#endif
        std::printf("\"samples\": %.0f, \"seconds_median\": %.6g, \"seconds_min\": %.6g, "
                    "\"samples_per_s\": %.6g, \"block\": %d, \"occupancy\": %.3f, \"stream\": %u, "
                    "\"alpha\": %g, \"mu\": [%g, %g], \"E\": [%.9g, %.9g], \"stderr\": [%.3g, %.3g]}\n",
                    samples, med, t[0], samples / med, block, occ, STREAM, alpha, mu[0],
                    mu[points - 1], e[0], e[points - 1], se[0], se[points - 1]);
        return 0;
    }
    if (mode == "cycles" && argc == 5) {
        double t0 = now();
        std::FILE *f = std::fopen(argv[2], "r");
        if (!f) { std::fprintf(stderr, "bench_cuda: cannot read %s\n", argv[2]); return 1; }
        std::vector<float> mu, al;
        float a, b;
        while (std::fscanf(f, "%f %f", &a, &b) == 2) { mu.push_back(a); al.push_back(b); }
        std::fclose(f);
        unsigned n = (unsigned)std::strtoul(argv[3], nullptr, 10), per_point = std::max(1u, n / STREAM);
        std::vector<float> out;
        int block = 0;
        double occ = 0;
        double kernel = run(mu, al, per_point, out, &block, &occ);
        std::vector<double> e, se;
        reduce(out, (unsigned)mu.size(), per_point, per_point * STREAM, e, se);
        std::FILE *o = std::fopen(argv[4], "w");
        if (!o) { std::fprintf(stderr, "bench_cuda: cannot write %s\n", argv[4]); return 1; }
        for (size_t j = 0; j < mu.size(); ++j) std::fprintf(o, "%.9g %.3g\n", e[j], se[j]);
        std::fclose(o);
        std::printf("{\"cells\": %zu, \"samples_per_cell\": %u, \"seconds_end_to_end\": %.6g, "
                    "\"seconds_kernel\": %.6g, \"block\": %d, \"occupancy\": %.3f}\n", mu.size(),
                    per_point * STREAM, now() - t0, kernel, block, occ);
        return 0;
    }
    std::fprintf(stderr, "usage: bench_cuda rate ALPHA LOG2_SAMPLES REPEATS | cycles CELLS SAMPLES OUT\n");
    return 2;
}
