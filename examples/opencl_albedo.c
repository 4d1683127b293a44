/* Directional albedo of GGX in your own OpenCL kernel, with the system's OpenCL ICD loader
 * (Debian: ocl-icd-opencl-dev) and clbrdf's headers: no Python.
 *
 *     gcc -std=c99 -O2 examples/opencl_albedo.c -lOpenCL -o opencl_albedo
 *     ./opencl_albedo $(clbrdf --include) [alpha mu samples seed]
 *
 * Work-item g sums the weights of samples [g B, g B + B); the host adds the partial sums in
 * double. The uniform numbers are clbrdf_random2(k, 0, 0, seed), as in `clbrdf albedo ggx
 * --estimator brdf` (Philox) for its first point: the same samples (examples/run.sh compares). */
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>

#define B 1024u
static const char *SOURCE =
    "#include \"clbrdf.h\"\n"
    "kernel void ggx_albedo(float alpha, float mu, uint n, ulong seed, global float *out)\n"
    "{\n"
    "    uint g = get_global_id(0);\n"
    "    clbrdf_ggx_params p = clbrdf_ggx_defaults();\n"
    "    p.alpha = alpha;\n"
    "    vec3 wo = v3(sqrt(1 - mu * mu), 0.0f, mu);\n"
    "    float sum = 0;\n"
    "    for (uint k = g * 1024u; k < min(n, g * 1024u + 1024u); ++k)\n"
    "        sum += clbrdf_ggx_sample(&p, wo, clbrdf_random2(k, 0, 0, seed)).weight.c[0];\n"
    "    out[g] = sum;\n"
    "}\n";

#define CHECK(x) do { cl_int e_ = (x); if (e_ != CL_SUCCESS) { \
    fprintf(stderr, "%s failed: %d\n", #x, e_); return 1; } } while (0)

int main(int argc, char **argv)
{
    if (argc < 2) { fprintf(stderr, "usage: %s KERNELS_DIR [alpha mu samples seed]\n", argv[0]); return 2; }
    float alpha = argc > 2 ? (float)atof(argv[2]) : 0.3f, mu = argc > 3 ? (float)atof(argv[3]) : 0.5f;
    cl_uint n = argc > 4 ? (cl_uint)strtoul(argv[4], NULL, 10) : 1u << 20;
    cl_ulong seed = argc > 5 ? strtoull(argv[5], NULL, 10) : 0;
    cl_platform_id plat[8]; cl_uint np = 0;
    CHECK(clGetPlatformIDs(8, plat, &np));
    cl_device_id dev = NULL;
    for (cl_uint i = 0; i < np && !dev; ++i)       /* the first platform with a device */
        if (clGetDeviceIDs(plat[i], CL_DEVICE_TYPE_ALL, 1, &dev, NULL) != CL_SUCCESS) dev = NULL;
    if (!dev) { fprintf(stderr, "no OpenCL device\n"); return 1; }
    char name[256];
    clGetDeviceInfo(dev, CL_DEVICE_NAME, sizeof name, name, NULL);
    cl_int err;
    cl_context ctx = clCreateContext(NULL, 1, &dev, NULL, NULL, &err); CHECK(err);
    cl_command_queue q = clCreateCommandQueue(ctx, dev, 0, &err); CHECK(err);
    cl_program prg = clCreateProgramWithSource(ctx, 1, &SOURCE, NULL, &err); CHECK(err);
    char opts[4096];
    snprintf(opts, sizeof opts, "-cl-std=CL1.2 -I %s", argv[1]);
    if (clBuildProgram(prg, 1, &dev, opts, NULL, NULL) != CL_SUCCESS) {
        char log[16384];
        clGetProgramBuildInfo(prg, dev, CL_PROGRAM_BUILD_LOG, sizeof log, log, NULL);
        fprintf(stderr, "build failed:\n%s\n", log);
        return 1;
    }
    cl_kernel k = clCreateKernel(prg, "ggx_albedo", &err); CHECK(err);
    size_t groups = (n + B - 1) / B;
    cl_mem out = clCreateBuffer(ctx, CL_MEM_WRITE_ONLY, groups * sizeof(float), NULL, &err); CHECK(err);
    CHECK(clSetKernelArg(k, 0, sizeof alpha, &alpha));
    CHECK(clSetKernelArg(k, 1, sizeof mu, &mu));
    CHECK(clSetKernelArg(k, 2, sizeof n, &n));
    CHECK(clSetKernelArg(k, 3, sizeof seed, &seed));
    CHECK(clSetKernelArg(k, 4, sizeof out, &out));
    CHECK(clEnqueueNDRangeKernel(q, k, 1, NULL, &groups, NULL, 0, NULL, NULL));
    float *part = malloc(groups * sizeof(float));
    CHECK(clEnqueueReadBuffer(q, out, CL_TRUE, 0, groups * sizeof(float), part, 0, NULL, NULL));
    double sum = 0;
    for (size_t i = 0; i < groups; ++i) sum += part[i];
    printf("%.9f %s\n", sum / n, name);
    free(part);
    clReleaseMemObject(out); clReleaseKernel(k); clReleaseProgram(prg);
    clReleaseCommandQueue(q); clReleaseContext(ctx);
    return 0;
}
