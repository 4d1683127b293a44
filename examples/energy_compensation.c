/* GGX energy compensation with clbrdf's tables in the Cycles layout:
 *
 *     clbrdf table --layout cycles --out ggx_E.h
 *     cc -std=c99 -I. examples/energy_compensation.c -lm
 *
 * Turquin 2019 (Cycles, Filament, UE): scale the single-scattering lobe by 1 / E(mu_o).
 * Kulla & Conty 2017 (OSPRay, OpenPBR): add the lobe
 *     f_ms(mu_o, mu_i) = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)).
 * r is the roughness with alpha = r^2; mu = cos(theta). */
#include <stdio.h>
#include "ggx_E.h"

static float turquin_scale(float mu_o, float r)
{
    return 1.0f / cycles_table_ggx_E_lookup(mu_o, r);
}

static float kulla_conty_f_ms(float mu_o, float mu_i, float r)
{
    const float pi = 3.14159265358979f;
    float e_o = cycles_table_ggx_E_lookup(mu_o, r);
    float e_i = cycles_table_ggx_E_lookup(mu_i, r);
    float e_avg = cycles_table_ggx_Eavg_lookup(r);
    return (1.0f - e_o) * (1.0f - e_i) / (pi * (1.0f - e_avg));
}

int main(void)
{
    /* the multiple-scattering lobe returns the energy the single-scattering lobe loses:
     * int f_ms mu_i dw_i = 1 - E(mu_o), here by the midpoint rule in mu_i */
    const float r = 0.75f, mu_o = 0.5f;
    const int n = 4096;
    float sum = 0.0f;
    for (int k = 0; k < n; k++) {
        float mu_i = (k + 0.5f) / n;
        sum += kulla_conty_f_ms(mu_o, mu_i, r) * mu_i * 2.0f * 3.14159265358979f / n;
    }
    printf("r %.2f mu_o %.2f: E %.6f, Turquin scale %.6f, int f_ms cos = %.6f (1 - E = %.6f)\n",
           r, mu_o, cycles_table_ggx_E_lookup(mu_o, r), turquin_scale(mu_o, r), sum,
           1.0f - cycles_table_ggx_E_lookup(mu_o, r));
    return 0;
}
