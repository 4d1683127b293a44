"""Accuracy of estimator='quadrature' against the float64 reference (clbrdf.ref) over every
model at its defaults and at roughness 1e-3, mu from grazing to normal, single and double
precision at their default tolerances. Writes docs/accuracy/quadrature.csv and prints a markdown
summary (docs/accuracy/quadrature.md quotes it).

    python scripts/measure_quadrature.py [--out docs/accuracy] [--models ggx,beckmann]
"""
import argparse
import csv
import time
import warnings
from pathlib import Path

import numpy as np

import clbrdf
from clbrdf.api.albedo import QUAD_TOL
from clbrdf.models import MODELS
from clbrdf.ref import reference

MUS = (1e-3, 0.02, 0.05, 0.2, 0.5, 0.8, 1.0)
ROUGH = {n: s.facts.roughest for n, s in MODELS.items() if s.facts.roughest}


def cases(models):
    for name in models:
        yield name, "defaults", {}
        if name in ROUGH:
            yield name, "roughness 1e-3", ROUGH[name]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/accuracy")
    ap.add_argument("--models", default=",".join(MODELS))
    a = ap.parse_args()
    rows = []
    for name, label, kw in cases(a.models.split(",")):
        ref = reference(name, **kw)
        R = np.array([float(np.ravel(ref.albedo(mu, 0.0, 1e-11)[0])[0]) for mu in MUS])
        for prec in ("single", "double"):
            m = clbrdf.Model(name, precision=prec, **kw)
            mus = np.array(MUS)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                r = clbrdf.albedo(m, mus, estimator="quadrature")
            E = np.asarray(r.albedo).reshape(len(MUS), -1)[:, 0]
            err = np.asarray(r.stderr).reshape(len(MUS), -1)[:, 0]
            for i, mu in enumerate(MUS):
                rows.append({"model": name, "case": label, "precision": prec, "mu": mu,
                             "tol": QUAD_TOL[prec], "E": E[i], "reference": R[i],
                             "error": E[i] - R[i], "estimate": err[i],
                             "evaluations": int(np.ravel(r.evaluations)[i]),
                             "seconds_all_mu": r.seconds})
            bad = [f"{row['mu']:g}: {row['error']:+.1e} (est {row['estimate']:.0e})"
                   for row in rows[-len(MUS):] if abs(row["error"]) > row["tol"]]
            print(f"| {name} | {label} | {prec} | "
                  f"{max(abs(row['error']) for row in rows[-len(MUS):]):.1e} | "
                  f"{max(row['evaluations'] for row in rows[-len(MUS):])} | {r.seconds:.2f} | "
                  f"{'; '.join(bad) or 'all within tol'} |", flush=True)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "quadrature.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    t = time.time()
    print("| model | case | precision | max abs error | most evaluations | seconds (7 mu) | beyond tol at mu |")
    print("|---|---|---|---|---|---|---|")
    main()
    print(f"\n{time.time() - t:.0f} s")
