/* Directional albedo of GGX, or of rough glass, by importance sampling, in plain C99 with
 * clbrdf's headers: no OpenCL.
 *
 *     gcc -std=c99 -O2 -I$(clbrdf --include) examples/c99_albedo.c -lm -o c99_albedo
 *     ./c99_albedo [alpha mu samples seed [eta]]
 *
 * E(wo) = mean of the sample weights f |cos(theta_i)| / pdf. Without eta: GGX reflection, whose
 * sampler takes two numbers; the numbers of sample k are clbrdf_random2(k, point 0, stream 0,
 * seed), those of `clbrdf albedo ggx --estimator brdf` (Philox, not --qmc) for its first point.
 * With eta: ggx_dielectric (E = E_R + E_T; mu < 0 is a wo inside the glass), whose sampler takes
 * three (u2 picks reflection or refraction): clbrdf_random3, those of `clbrdf albedo
 * ggx_dielectric -p eta=ETA --estimator brdf`. Either way the two estimates use the same samples
 * and differ only by rounding (examples/run.sh compares them). */
#include <stdio.h>
#include <stdlib.h>
#include "clbrdf.h"

int main(int argc, char **argv)
{
    double alpha = argc > 1 ? atof(argv[1]) : 0.3, mu = argc > 2 ? atof(argv[2]) : 0.5;
    unsigned long n = argc > 3 ? strtoul(argv[3], NULL, 10) : 1UL << 20;
    unsigned long long seed = argc > 4 ? strtoull(argv[4], NULL, 10) : 0;
    int glass = argc > 5;
    clbrdf_ggx_params p = clbrdf_ggx_defaults();
    clbrdf_ggx_dielectric_params g = clbrdf_ggx_dielectric_defaults();
    p.alpha = g.alpha = (real_t)alpha;
    if (glass)
        g.eta = (real_t)atof(argv[5]);
    vec3 wo = v3((real_t)sqrt(1 - mu * mu), 0, (real_t)mu);
    double sum = 0, sum2 = 0;
    for (unsigned long k = 0; k < n; ++k) {
        BSample s = glass ? clbrdf_ggx_dielectric_sample(&g, wo, clbrdf_random3((uint)k, 0, 0, seed))
                          : clbrdf_ggx_sample(&p, wo, clbrdf_random2((uint)k, 0, 0, seed));
        sum += s.weight.c[0];
        sum2 += (double)s.weight.c[0] * s.weight.c[0];
    }
    double e = sum / n, var = (sum2 / n - e * e) / (n - 1);
    printf("%.9f %.3g\n", e, sqrt(var > 0 ? var : 0));
    return 0;
}
