/* Directional albedo of GGX, or of rough glass, in a CUDA kernel with clbrdf's headers.
 *
 *     nvcc -std=c++17 -O2 -I$(clbrdf --include) examples/cuda_albedo.cu -o cuda_albedo
 *     ./cuda_albedo [alpha mu samples seed [eta]]
 *
 * Thread g sums the weights of samples [g B, g B + B); the host adds the partial sums in double.
 * Without eta, GGX reflection with the numbers clbrdf_random2(k, 0, 0, seed), as in `clbrdf
 * albedo ggx --estimator brdf` (Philox) for its first point; with eta, ggx_dielectric (E = E_R +
 * E_T, mu < 0 inside the glass) with clbrdf_random3, as `clbrdf albedo ggx_dielectric -p
 * eta=ETA --estimator brdf`: the same samples (examples/run.sh compares where a GPU is). */
#include <cstdio>
#include <cstdlib>
#include <vector>
#include "clbrdf.h"

constexpr unsigned B = 1024;

__global__ void albedo(float alpha, float mu, float eta, unsigned n, unsigned long long seed,
                       float *out)
{
    unsigned g = blockIdx.x * blockDim.x + threadIdx.x;
    if (g * B >= n) return;
    clbrdf::clbrdf_ggx_params p = clbrdf::clbrdf_ggx_defaults();
    clbrdf::clbrdf_ggx_dielectric_params d = clbrdf::clbrdf_ggx_dielectric_defaults();
    p.alpha = d.alpha = alpha;
    d.eta = eta;
    clbrdf::vec3 wo = clbrdf::v3(sqrtf(1 - mu * mu), 0.0f, mu);
    float sum = 0;
    for (unsigned k = g * B; k < min(n, g * B + B); ++k)
        sum += (eta > 0 ? clbrdf::clbrdf_ggx_dielectric_sample(&d, wo, clbrdf::clbrdf_random3(k, 0, 0, seed))
                        : clbrdf::clbrdf_ggx_sample(&p, wo, clbrdf::clbrdf_random2(k, 0, 0, seed))).weight.c[0];
    out[g] = sum;
}

int main(int argc, char **argv)
{
    float alpha = argc > 1 ? (float)atof(argv[1]) : 0.3f, mu = argc > 2 ? (float)atof(argv[2]) : 0.5f;
    unsigned n = argc > 3 ? (unsigned)strtoul(argv[3], nullptr, 10) : 1u << 20;
    unsigned long long seed = argc > 4 ? strtoull(argv[4], nullptr, 10) : 0;
    float eta = argc > 5 ? (float)atof(argv[5]) : 0.0f;       /* 0: GGX reflection */
    unsigned groups = (n + B - 1) / B;
    float *d = nullptr;
    if (cudaMalloc(&d, groups * sizeof(float)) != cudaSuccess) {
        std::fprintf(stderr, "cudaMalloc failed: no CUDA device?\n");
        return 1;
    }
    albedo<<<(groups + 127) / 128, 128>>>(alpha, mu, eta, n, seed, d);
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
