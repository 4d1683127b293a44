/* Shade a quad light with an LTC table fitted by clbrdf (docs/ltc.md):
 *
 *     clbrdf ltc charlie --axis sqrt1m_mu=0:1:16:max=0.999602 --axis alpha=0.05:1:16 \
 *         --out charlie_ltc.h
 *     cc -std=c99 -I$(clbrdf --include) -I. ltc_quad.c -lm && ./a.out MU ALPHA
 *
 * prints E * int_quad D, the lobe's integral over the quad as the LTC approximates it (the
 * radiance of a unit-radiance light times the BRDF's F = 1 lobe), for wo = (sin, 0, mu) in the
 * shading frame (z the normal): what a renderer's area-light shader computes per pixel.
 */
#include <stdio.h>
#include <stdlib.h>

#include "clbrdf.h"
#include "charlie_ltc.h"

int main(int argc, char **argv)
{
    float mu = argc > 1 ? (float)atof(argv[1]) : 0.5f;
    float alpha = argc > 2 ? (float)atof(argv[2]) : 0.5f;
    float v = sqrtf(1.0f - mu);                       /* the table's view axis */
    mat3r minv;
    for (int k = 0; k < 9; ++k)
        minv.m[k] = charlie_ltc_lookup(v, alpha, k);  /* channels minv00 .. minv22 */
    float E = charlie_ltc_lookup(v, alpha, 9);        /* channel E; 12 is the cell's L1 error */
    /* a 1 x 1 quad light above and in front of the point, counter-clockwise seen from above */
    vec3 quad[4] = {v3(0.5f, -0.5f, 0.5f), v3(1.5f, -0.5f, 0.5f), v3(1.5f, 0.5f, 1.0f),
                    v3(0.5f, 0.5f, 1.0f)};
    float lo = E * ltc_polygon(&minv, quad, 4);
    printf("%.7f (E %.6f, L1 %.4f)\n", lo, E, charlie_ltc_lookup(v, alpha, 12));
    return 0;
}
