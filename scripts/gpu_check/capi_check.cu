/* The C API over one model configuration, on a CUDA device or (built by a C++ compiler: the
 * CPU test of this program) on the host: scripts/gpu_check/gpu_check.sh builds it once per case
 * and precision with the case's defines and its generated case.h (CASE_* below).
 *
 *   capi_check TABLES_DIR < rows.txt          rows of 10 numbers (wo, wi, u): per row f, pdf,
 *                                             the sampled wi, its weight and pdf (%.17g), the
 *                                             columns of clbrdf.studies.capi.columns
 *   capi_check TABLES_DIR albedo N SEED MU...  per mu (point j = its index), the mean over k < N
 *                                             of the sample weight at wo = (sqrt(1 - mu^2), 0, mu)
 *                                             with clbrdf_random(k, j, 0, SEED), per channel
 * One thread per row; for the albedo one thread per ALBEDO_B samples of a point, partial sums in
 * double, added on the host; compensated (Kahan) both, as report.py's reference is exact
 * (math.fsum), so that the comparison sees the samples' rounding, not the summation order's. */
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <string>
#include <vector>
#include "clbrdf.h"
#include "clbrdf_tables.h"
#include "case.h"

using namespace clbrdf;

#define NOUT (2 * CHANNELS + 5)
#define ALBEDO_B 256u

#ifdef __CUDACC__
#define DEV __device__
#define HOST_DEV __host__ __device__
#else
#define DEV
#define HOST_DEV
#endif

DEV static void row(const double *a, double *o, const float *T)
{
    CASE_PARAMS p = CASE_DEFAULTS();
    CASE_ASSIGN(p, T);
    vec3 wo = v3((real_t)a[0], (real_t)a[1], (real_t)a[2]);
    vec3 wi = v3((real_t)a[3], (real_t)a[4], (real_t)a[5]);
    rand4 u = {(real_t)a[6], (real_t)a[7], (real_t)a[8], (real_t)a[9]};
    spec f = CASE_EVAL(&p, wo, wi);
    real_t pdf = CASE_PDF(&p, wo, wi);
    BSample s = CASE_SAMPLE(&p, wo, u);
    int k = 0;
    for (int c = 0; c < CHANNELS; ++c) o[k++] = f.c[c];
    o[k++] = pdf; o[k++] = s.wi.x; o[k++] = s.wi.y; o[k++] = s.wi.z;
    for (int c = 0; c < CHANNELS; ++c) o[k++] = s.weight.c[c];
    o[k++] = s.pdf;
}

HOST_DEV static void kahan(double *sum, double *lost, double x)
{
    double y = x - *lost, t = *sum + y;
    *lost = (t - *sum) - y;
    *sum = t;
}

/* the weights of samples [k0, k1) of point j, per channel, summed in double */
DEV static void albedo_part(double mu, unsigned j, unsigned k0, unsigned k1, unsigned long long seed,
                            double *sum, const float *T)
{
    CASE_PARAMS p = CASE_DEFAULTS();
    CASE_ASSIGN(p, T);
    real_t m = (real_t)mu;
    vec3 wo = v3(sqrt(1 - m * m), (real_t)0, m);
    double lost[CHANNELS];
    for (int c = 0; c < CHANNELS; ++c) sum[c] = lost[c] = 0;
    for (unsigned k = k0; k < k1; ++k) {
        BSample s = CASE_SAMPLE(&p, wo, clbrdf_random(k, j, 0, seed));
        for (int c = 0; c < CHANNELS; ++c) kahan(sum + c, lost + c, (double)s.weight.c[c]);
    }
}

#ifdef __CUDACC__
__global__ void rows_kernel(const double *in, double *out, unsigned n, const float *T)
{
    unsigned i = blockIdx.x * blockDim.x + threadIdx.x;
    if (i < n) row(in + 10 * i, out + NOUT * i, T);
}

__global__ void albedo_kernel(const double *mu, unsigned points, unsigned n, unsigned long long seed,
                              double *out, const float *T)
{
    unsigned g = blockIdx.x * blockDim.x + threadIdx.x, per = (n + ALBEDO_B - 1) / ALBEDO_B;
    if (g >= points * per) return;
    unsigned j = g / per, b = g % per;
    unsigned k1 = (b + 1) * ALBEDO_B < n ? (b + 1) * ALBEDO_B : n;
    albedo_part(mu[j], j, b * ALBEDO_B, k1, seed, out + CHANNELS * g, T);
}

static void check(cudaError_t e, const char *what)
{
    if (e != cudaSuccess) {
        std::fprintf(stderr, "capi_check: %s: %s\n", what, cudaGetErrorString(e));
        std::exit(3);
    }
}

template <class X> static X *to_device(const X *h, size_t n)
{
    X *d = nullptr;
    check(cudaMalloc(&d, n * sizeof(X) + 1), "cudaMalloc");
    if (h) check(cudaMemcpy(d, h, n * sizeof(X), cudaMemcpyHostToDevice), "cudaMemcpy to device");
    return d;
}
#endif

int main(int argc, char **argv)
{
    if (argc < 2) {
        std::fprintf(stderr, "usage: capi_check TABLES_DIR [albedo N SEED MU...] < rows\n");
        return 2;
    }
    float *T = clbrdf_tables_load(argv[1]);
    if (!T) return 1;
    const float *Tp = T;
#ifdef __CUDACC__
    Tp = to_device(T, CLBRDF_TABLES_SIZE);
#endif
    if (argc > 2 && std::string(argv[2]) == "albedo") {
        unsigned n = (unsigned)std::strtoul(argv[3], nullptr, 10);
        unsigned long long seed = std::strtoull(argv[4], nullptr, 10);
        std::vector<double> mu;
        for (int i = 5; i < argc; ++i) mu.push_back(std::atof(argv[i]));
        unsigned points = (unsigned)mu.size(), per = (n + ALBEDO_B - 1) / ALBEDO_B;
        std::vector<double> part((size_t)points * per * CHANNELS);
#ifdef __CUDACC__
        double *dmu = to_device(mu.data(), points), *dout = to_device<double>(nullptr, part.size());
        unsigned items = points * per;
        albedo_kernel<<<(items + 127) / 128, 128>>>(dmu, points, n, seed, dout, Tp);
        check(cudaGetLastError(), "albedo kernel launch");
        check(cudaMemcpy(part.data(), dout, part.size() * sizeof(double), cudaMemcpyDeviceToHost),
              "albedo kernel");
#else
        for (unsigned g = 0; g < points * per; ++g) {
            unsigned j = g / per, b = g % per;
            albedo_part(mu[j], j, b * ALBEDO_B, std::min((b + 1) * ALBEDO_B, n), seed,
                        &part[(size_t)CHANNELS * g], Tp);
        }
#endif
        for (unsigned j = 0; j < points; ++j) {
            for (int c = 0; c < CHANNELS; ++c) {
                double s = 0, lost = 0;
                for (unsigned b = 0; b < per; ++b) kahan(&s, &lost, part[((size_t)j * per + b) * CHANNELS + c]);
                std::printf("%.17g ", s / n);
            }
            std::printf("\n");
        }
    } else {
        std::vector<double> in;
        double x;
        while (std::scanf("%lf", &x) == 1) in.push_back(x);
        unsigned n = (unsigned)(in.size() / 10);
        std::vector<double> out((size_t)n * NOUT);
#ifdef __CUDACC__
        double *din = to_device(in.data(), in.size()), *dout = to_device<double>(nullptr, out.size());
        rows_kernel<<<(n + 127) / 128, 128>>>(din, dout, n, Tp);
        check(cudaGetLastError(), "rows kernel launch");
        check(cudaMemcpy(out.data(), dout, out.size() * sizeof(double), cudaMemcpyDeviceToHost),
              "rows kernel");
#else
        for (unsigned i = 0; i < n; ++i) row(&in[10 * (size_t)i], &out[NOUT * (size_t)i], Tp);
#endif
        for (unsigned i = 0; i < n; ++i) {
            for (int j = 0; j < NOUT; ++j) std::printf("%.17g ", out[NOUT * (size_t)i + j]);
            std::printf("\n");
        }
    }
    std::free(T);
    return 0;
}
