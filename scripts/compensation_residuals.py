"""docs/compensation/: the albedo of three energy-compensation methods for GGX metals against
the random walk of Heitz et al. 2016 (clbrdf/ref/heitz_ms.py), all from the float64 references
(issue 30's first residual map; the kernels' walk and the lobe residuals come next).

For each metal preset (n + ik per channel), alpha and mu: the walk's E (WALKS walks, its
standard error), the single-scattering E_F, and
- Kulla & Conty 2017: E_F + F_ms (1 - E), F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg));
- Turquin 2019: E_F (1 + F0 (1 - E) / E);
- Fdez-Aguera 2019 (the split sum): F0 A + B + F_ms' (1 - A - B),
  F_ms' = (F0 A + B) F_avg' / (1 - F_avg' (1 - A - B)), F_avg' = F0 + (1 - F0) / 21
  (Schlick's F with the exact F0 = F(1), A and B of the split);
E, E_avg, A, B of GGX with height-correlated masking by the reference's quadrature, F_avg of
the exact Fresnel by Gauss-Legendre.

    python scripts/compensation_residuals.py [--out docs/compensation] [--walks 131072]
"""
import argparse
import io
import time
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt      # noqa: E402
import numpy as np                   # noqa: E402

import clbrdf                        # noqa: E402
from clbrdf.ref import heitz_ms as H, reference   # noqa: E402
from clbrdf.ref.microfacet import fresnel          # noqa: E402
from clbrdf.tables.outputs import csv_text, write_together   # noqa: E402

METALS = ("gold", "copper", "aluminium")
ALPHAS = (0.05, 0.1, 0.2, 0.4, 0.7, 1.0)
MUS = (0.1, 0.3, 0.5, 0.7, 0.9, 1.0)
METHODS = ("kulla_conty", "turquin", "fdez_aguera", "single")
TOL = 1e-8


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/compensation")
    ap.add_argument("--walks", type=int, default=1 << 17)
    a = ap.parse_args()
    out = Path(a.out)
    t0 = time.perf_counter()
    xq, wq = np.polynomial.legendre.leggauss(200)
    cq, wq = (xq + 1) / 2, wq / 2
    xm, wm = np.polynomial.legendre.leggauss(24)
    mq, wm = (xm + 1) / 2, wm / 2
    rows = []
    for alpha in ALPHAS:
        one = reference("ggx", alpha=alpha)
        e_avg = float(sum(w * 2 * m * one.albedo(m, tol=1e-7)[0] for m, w in zip(mq, wm)))
        for mu in MUS:
            e = float(one.albedo(mu, tol=TOL)[0])
            A = float(reference("ggx", alpha=alpha, fresnel="schlick", f0=1.0, f90=0.0)
                      .albedo(mu, tol=TOL)[0])
            B = float(reference("ggx", alpha=alpha, fresnel="schlick", f0=0.0, f90=1.0)
                      .albedo(mu, tol=TOL)[0])
            wo = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
            for metal in METALS:
                p = clbrdf.presets.get("ggx", metal).params
                for ch, cname in enumerate("RGB"):
                    eta, k = float(p["eta"][ch]), float(p["k"][ch])
                    f0 = float(fresnel("conductor", 1.0, eta=eta, k=k))
                    favg = float(np.sum(wq * 2 * cq * fresnel("conductor", cq, eta=eta, k=k)))
                    ef = float(np.ravel(reference("ggx", alpha=alpha, fresnel="conductor",
                                                  eta=eta, k=k).albedo(mu, tol=TOL)[0])[0])
                    _, wt, _, lost = H.walk(wo, a.walks, alpha_x=alpha, seed=len(rows),
                                            fresnel_kind="conductor", eta=eta, k=k)
                    fms = favg ** 2 * e_avg / (1 - favg * (1 - e_avg))
                    ess, fss = A + B, f0 * A + B
                    fa2 = f0 + (1 - f0) / 21
                    fms2 = fss * fa2 / (1 - fa2 * (1 - ess))
                    est = {"kulla_conty": ef + fms * (1 - e), "turquin": ef * (1 + f0 * (1 - e) / e),
                           "fdez_aguera": fss + fms2 * (1 - ess), "single": ef}
                    rows.append({"metal": metal, "channel": cname, "alpha": alpha, "mu": mu,
                                 "E_walk": float(wt.mean()),
                                 "E_walk_stderr": float(wt.std() / np.sqrt(a.walks)),
                                 "walks_cut": lost,
                                 **{m: est[m] for m in METHODS},
                                 **{f"{m}_error": est[m] - float(wt.mean()) for m in METHODS}})
        print(f"alpha {alpha}: {time.perf_counter() - t0:.0f} s", flush=True)
    fields = list(rows[0])
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.4), sharey=True)
    for ax, m in zip(axes, METHODS[:3]):
        for metal, ls in zip(METALS, ("-", "--", ":")):
            for cname in "RGB":
                sel = [r for r in rows if r["metal"] == metal and r["channel"] == cname]
                worst = [max(abs(r[f"{m}_error"]) for r in sel if r["alpha"] == al)
                         for al in ALPHAS]
                ax.plot(ALPHAS, worst, ls=ls, color=cname.lower(), lw=1,
                        label=f"{metal} {cname}" if m == METHODS[0] else None)
        ax.set_title(m.replace("_", "-"), fontsize=9)
        ax.set_xlabel("alpha", fontsize=8)
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("max over mu of |E_method - E_walk|", fontsize=8)
    axes[0].legend(fontsize=6, ncol=3)
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, dpi=110)
    lines = ["# Energy compensation against the random walk: albedo of GGX metals", "",
             f"Generated by `python scripts/compensation_residuals.py` ({a.walks} walks per "
             f"cell, {time.perf_counter() - t0:.0f} s, float64 references; "
             "`scripts/compensation_residuals.py` gives each method's formula). The walk "
             "(clbrdf/ref/heitz_ms.py) is the multiple-scattering microfacet BRDF itself "
             "(Heitz et al. 2016); each method is what a renderer adds to the single-scattering "
             "lobe. Error = E_method - E_walk (negative: the method is too dark).", "",
             "![max error over mu per alpha](residuals.png)", "",
             "| metal | channel | method | worst error | at alpha, mu | E_walk there | mean abs error |",
             "|---|---|---|---:|---|---:|---:|"]
    for metal in METALS:
        for cname in "RGB":
            sel = [r for r in rows if r["metal"] == metal and r["channel"] == cname]
            for m in METHODS:
                w = max(sel, key=lambda r: abs(r[f"{m}_error"]))
                mean = np.mean([abs(r[f"{m}_error"]) for r in sel])
                lines.append(f"| {metal} | {cname} | {m} | {w[m + '_error']:+.4f} | "
                             f"{w['alpha']:g}, {w['mu']:g} | {w['E_walk']:.4f} +- "
                             f"{w['E_walk_stderr']:.1g} | {mean:.4f} |")
    out.mkdir(parents=True, exist_ok=True)
    write_together({out / "README.md": "\n".join(lines) + "\n",
                    out / "residuals.csv": csv_text(rows, fields),
                    out / "residuals.png": png.getvalue()})
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
