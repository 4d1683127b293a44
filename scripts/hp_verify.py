"""Numbers for docs/models/holzschuch_pacanowski.md: the diffraction lobe's energy normalisation
(docs/models/holzschuch_pacanowski.md, the diffraction lobe's normalisation) and the nickel example of Figure 12a, by deterministic quadrature
(clbrdf.ref.holzschuch_pacanowski) and, with --mc, by the kernels' Monte Carlo albedo.

    .venv/bin/python scripts/hp_verify.py [--mc]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
from scipy import integrate

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from clbrdf.ref.quadrature import cosine_map, hemisphere_integral
from clbrdf.ref import holzschuch_pacanowski as R

LAMS = R.WAVELENGTHS
NICKEL = dict(a=0.91, sigma=0.027, p=0.51)


def direction(mu):
    return np.array([math.sqrt(1 - mu * mu), 0.0, mu])


def lobe_albedo(a, L, mu, with_G=False, sigma=None, p=None):
    """Albedo of S(f_s) / E_conserving (times G1 G1 when with_G)."""
    wo = direction(mu)

    def g(wi):
        dp = np.hypot(wi[..., 0] + wo[..., 0], wi[..., 1] + wo[..., 1])
        v = 1 / (1 + (dp / L / a) ** 2) ** 2 / R.diffraction_energy(a, L) * wi[..., 2]
        if with_G:
            v = v * R.G1(wi, sigma, p) * R.G1(wo, sigma, p)
        return v
    return hemisphere_integral(g, [cosine_map()], 1e-9)[0]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mc", action="store_true", help="also the kernels' Monte Carlo albedo")
    args = ap.parse_args()
    print("## Diffraction lobe energy (G = 1), c = a^2 lambda^2")
    print("| a | lambda | disk integral at normal incidence | pi c/(1+c) | pi (1+1/c) (paper) | "
          "albedo with paper E | albedo (conserving E) at mu = 1, 0.5, 0.1 |")
    print("|---|---|---|---|---|---|---|")
    for a in (0.3, 0.91, 3.0):
        for L in LAMS:
            disk = integrate.quad(lambda r: 2 * np.pi * r / (1 + (r / (L * a)) ** 2) ** 2, 0, 1,
                                  epsabs=0, epsrel=1e-13)[0]
            alb = [lobe_albedo(a, L, mu) for mu in (1.0, 0.5, 0.1)]
            print(f"| {a} | {L} | {disk:.10f} | {R.diffraction_energy(a, L):.10f} | "
                  f"{R.diffraction_energy_paper(a, L):.6f} | {disk / R.diffraction_energy_paper(a, L):.6f} | "
                  + ", ".join(f"{x:.6f}" for x in alb) + " |")
    print()
    print("## Nickel (a = 0.91, sigma = 0.027, p = 0.51)")
    mus = (1.0, 0.7, 0.3, 0.1, 0.03, 0.01)
    print("| mu | reflection lobe, F = 1, ks = 1 | diffraction lobe with G, kw = lambda^4 (R, G, B) |")
    print("|---|---|---|")
    for mu in mus:
        e, _ = R.albedo(mu, ks=1.0, f0=1.0, kd=0.0, kw=0.0, tol=1e-8, **NICKEL)
        d = [lobe_albedo(NICKEL["a"], L, mu, True, NICKEL["sigma"], NICKEL["p"]) for L in LAMS]
        print(f"| {mu} | {e:.6f} | " + ", ".join(f"{x:.6f}" for x in d) + " |")
    if args.mc:
        import clbrdf
        print()
        print("## Kernel Monte Carlo (single precision, brdf estimator, 2^20 samples)")
        m = clbrdf.Model("holzschuch_pacanowski", ks=1.0, f0=1.0, kd=0.0, kw=0.0, **NICKEL)
        r = clbrdf.albedo(m, np.array(mus), samples=1 << 20, seed=1)
        for mu, v, s in zip(mus, r.albedo, r.stderr):
            print(f"mu {mu}: E = {v:.6f} +- {s:.1g}")


if __name__ == "__main__":
    main()
