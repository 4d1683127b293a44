"""docs/models/oren_nayar_energy.png and the numbers beside it in docs/models/oren_nayar.md:
the white furnace (rho = 1) of Lambert, the qualitative Oren-Nayar (QON), Fujii's (FON) and the
energy-preserving EON (exact and quartic albedo), each from its own kernel by the device
quadrature: left E(mu) at roughness 1, right the average albedo E_avg against roughness.

    python scripts/eon_figures.py [--out docs/models/oren_nayar_energy.png]
"""
import argparse
import io
import time
import warnings
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt      # noqa: E402
import numpy as np                   # noqa: E402

import clbrdf                        # noqa: E402
from clbrdf.tables.outputs import write_together   # noqa: E402

FORMS = (("Lambert", "lambert", {"kd": 1.0}),
         ("QON (Oren & Nayar 1994; sigma = r)", "oren_nayar", {"form": "qon"}),
         ("FON (Fujii)", "oren_nayar", {"form": "fon"}),
         ("EON, exact E_F", "oren_nayar", {"form": "eon"}),
         ("EON, quartic E_F (the paper's)", "oren_nayar", {"form": "eon", "albedo": "approx"}))
MUS = np.concatenate([np.geomspace(1e-3, 0.05, 12), np.linspace(0.06, 1, 48)])
RS = np.linspace(0, 1, 41)


def model(name, kw, **extra):
    if name == "oren_nayar":
        return clbrdf.Model(name, rho=1.0, precision="double", **kw, **extra)
    return clbrdf.Model(name, precision="double", **kw)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/models/oren_nayar_energy.png")
    out = Path(ap.parse_args().out)
    t0 = time.perf_counter()
    fig, (a, b) = plt.subplots(1, 2, figsize=(9.5, 3.6))
    lines = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for label, name, kw in FORMS:
            m = model(name, kw, **({"r": 1.0} if name == "oren_nayar" else {}))
            e = np.ravel(clbrdf.albedo(m, MUS, estimator="quadrature").albedo)
            a.plot(MUS, e, label=label, lw=1.3, ls="--" if "quartic" in label else "-")
            if name == "oren_nayar":
                m = model(name, kw, r=RS)
                avg = np.ravel(clbrdf.albedo_avg(m, estimator="quadrature")[0])
            else:
                avg = np.full_like(RS, float(np.ravel(clbrdf.albedo_avg(m)[0])[0]))
            b.plot(RS, avg, label=label, lw=1.3, ls="--" if "quartic" in label else "-")
            lines.append(f"{label}: E(mu) at r = 1 from {e.min():.4f} to {e.max():.4f}; "
                         f"E_avg at r = 0.5 {np.interp(0.5, RS, avg):.4f}, at r = 1 {avg[-1]:.4f}")
    a.set_xscale("log")
    a.set_xlabel("mu = cos theta_o")
    a.set_ylabel("E(mu), rho = 1, r = 1")
    b.set_xlabel("roughness r (QON: sigma)")
    b.set_ylabel("E_avg (white furnace), rho = 1")
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=8)
    a.legend(fontsize=7)
    fig.suptitle("White furnace of the Oren-Nayar forms against Lambert (device quadrature)",
                 fontsize=9)
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, dpi=110)
    write_together({out: png.getvalue()})
    print("\n".join(lines))
    print(f"wrote {out} in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
