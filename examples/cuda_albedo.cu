/* Directional albedo of GGX in a CUDA kernel with clbrdf's headers.
 *
 *     nvcc -std=c++17 -O2 -I$(clbrdf --include) examples/cuda_albedo.cu -o cuda_albedo
 *     ./cuda_albedo [alpha mu samples seed]
 *
 * Thread g sums the weights of samples [g B, g B + B); the host adds the partial sums in double.
 * The uniform numbers are clbrdf_random2(k, 0, 0, seed), as in `clbrdf albedo ggx --estimator brdf`
 * (Philox) for its first point: the same samples (examples/run.sh compares where a GPU is). */
#include <cstdio>
#include <cstdlib>
#include <vector>
#include "clbrdf.h"

constexpr unsigned B = 1024;

__global__ void ggx_albedo(float alpha, float mu, unsigned n, unsigned long long seed, float *out)
{
    unsigned g = blockIdx.x * blockDim.x + threadIdx.x;
    if (g * B >= n) return;
    clbrdf::clbrdf_ggx_params p = clbrdf::clbrdf_ggx_defaults();
    p.alpha = alpha;
    clbrdf::vec3 wo = clbrdf::v3(sqrtf(1 - mu * mu), 0.0f, mu);
    float sum = 0;
    for (unsigned k = g * B; k < min(n, g * B + B); ++k)
        sum += clbrdf::clbrdf_ggx_sample(&p, wo, clbrdf::clbrdf_random2(k, 0, 0, seed)).weight.c[0];
    out[g] = sum;
}

int main(int argc, char **argv)
{
    float alpha = argc > 1 ? (float)atof(argv[1]) : 0.3f, mu = argc > 2 ? (float)atof(argv[2]) : 0.5f;
    unsigned n = argc > 3 ? (unsigned)strtoul(argv[3], nullptr, 10) : 1u << 20;
    unsigned long long seed = argc > 4 ? strtoull(argv[4], nullptr, 10) : 0;
    unsigned groups = (n + B - 1) / B;
    float *d = nullptr;
    if (cudaMalloc(&d, groups * sizeof(float)) != cudaSuccess) {
        std::fprintf(stderr, "cudaMalloc failed: no CUDA device?\n");
        return 1;
    }
    ggx_albedo<<<(groups + 127) / 128, 128>>>(alpha, mu, n, seed, d);
    std::vector<float> part(groups);
    if (cudaMemcpy(part.data(), d, groups * sizeof(float), cudaMemcpyDeviceToHost) != cudaSuccess) {
        std::fprintf(stderr, "kernel failed: %s\n", cudaGetErrorString(cudaGetLastError()));
        return 1;
    }
    cudaDeviceProp prop;
    cudaGetDeviceProperties(&prop, 0);
    double sum = 0;
    for (float v : part) sum += v;
    std::printf("%.9f %s\n", sum / n, prop.name);
    cudaFree(d);
    return 0;
}
