"""How honest and how tight the error bars of Sobol-point (QMC) albedo estimates are, over the
stability map's cells (every model's sweeps of clbrdf/data/stability.csv, mu >= 1e-4, single
precision, its float64 reference values), for the brdf and mis estimators at 2^12 and 2^16
samples over SEEDS seeds: z = (E - E_ref) / sqrt(stderr^2 + ref_err^2) per cell and seed.

Reported per model and overall: the rms of z (1 for bars that match the error), the share of
|z| > 4 (under 0.1 % for bars that cover it) and the largest |z|; cells whose every seed is
exact (no spread, E = E_ref within the rounding floor: Lambert-like weights) are counted apart.

    python scripts/qmc_error_bars.py --out docs/accuracy/qmc_error_bars   (about 4 minutes)
"""
import argparse
import csv
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import clbrdf
from clbrdf.api.useless import MAP, read_csv, sweep_label
from clbrdf.studies.stability import sweeps

SEEDS = 8
SIZES = (1 << 12, 1 << 16)
ESTIMATORS = ("brdf", "mis")
MU_MIN = 1e-4


def refs():
    """{(model, sweep, value, mu): (E_ref, ref_err)} and the set of (model, sweep, value, mu,
    estimator, sampler) the map marks useless (albedo warns there: UselessEstimatorWarning)."""
    out, useless = {}, set()
    for r in read_csv(MAP):
        if r["precision"] == "single" and float(r["mu"]) >= MU_MIN:
            key = (r["model"], r["sweep"], float(r["value"]), float(r["mu"]))
            out[key] = (float(r["E_ref"]), float(r["ref_err"]))
            if r["useless"]:
                useless.add(key + (r["estimator"], r["sampler"]))
    return out, useless


def measure(models=None, seeds=SEEDS):
    ref, useless = refs()
    rows = []
    names = sorted({k[0] for k in ref}) if models is None else models
    for name in names:
        for params, values in sweeps(name):
            sweep = sweep_label(params)
            vals = np.asarray(values, float)
            mus = np.array(sorted({k[3] for k in ref if k[0] == name and k[1] == sweep}))
            if not len(mus):
                continue
            e_ref = np.array([[ref[(name, sweep, float(v), float(m))][0] for m in mus]
                              for v in vals])
            r_err = np.array([[ref[(name, sweep, float(v), float(m))][1] for m in mus]
                              for v in vals])
            kw = {p: vals[:, None] for p in params}
            m = clbrdf.Model(name, **kw)
            smp = m.options.get("sampler", "-")
            for est in ESTIMATORS:
                for n in SIZES:
                    zs, exact, bound = [], [], []
                    for seed in range(seeds):
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            r = clbrdf.albedo(m, mus[None, :], estimator=est, samples=n,
                                              seed=seed, qmc=True)
                        e = np.broadcast_to(np.asarray(r.albedo, float), e_ref.shape)
                        s = np.broadcast_to(np.asarray(r.stderr, float), e_ref.shape)
                        sp = np.broadcast_to(np.asarray(r.sampling_stderr, float), e_ref.shape)
                        with np.errstate(divide="ignore", invalid="ignore"):
                            zs.append((e - e_ref) / np.hypot(s, r_err))
                        exact.append((sp == 0) & (np.abs(e - e_ref) <= s))
                        un = np.broadcast_to(np.asarray(r.unseen, float), e_ref.shape)
                        bound.append(un > sp)
                    zs, exact = np.array(zs), np.all(exact, axis=0)
                    bound = np.mean(bound, axis=0) > 0.5
                    for i, v in enumerate(vals):
                        for j, mu in enumerate(mus):
                            z = zs[:, i, j]
                            warned = (name, sweep, float(v), float(mu), est,
                                      smp if est in ("brdf", "mis") else "-") in useless
                            rows.append({"model": name, "sweep": sweep, "value": float(v),
                                         "mu": float(mu), "estimator": est, "samples": n,
                                         "exact": bool(exact[i, j]), "warned": warned,
                                         "bound": bool(bound[i, j] and not exact[i, j]),
                                         "rms_z": float(np.sqrt(np.mean(z ** 2))),
                                         "max_abs_z": float(np.max(np.abs(z))),
                                         "beyond_4": int(np.sum(np.abs(z) > 4)),
                                         "z": [round(float(x), 4) for x in z]})
        print(f"{name} done", file=sys.stderr, flush=True)
    return rows


def summarise(rows):
    """Statistics of the cells the map does not mark useless, per set; the useless (warned)
    cells apart."""
    def stats(rs):
        live = [r for r in rs if not r["exact"]]
        z = np.array([x for r in live for x in r["z"]])
        if not len(z):
            return {"cells": 0, "exact_cells": len(rs)}
        return {"cells": len(live), "exact_cells": len(rs) - len(live),
                "estimates": int(z.size), "rms_z": float(np.sqrt(np.mean(z ** 2))),
                "beyond_4": int(np.sum(np.abs(z) > 4)),
                "beyond_4_share": float(np.mean(np.abs(z) > 4)),
                "max_abs_z": float(np.max(np.abs(z))),
                "cells_rms_z_below_0.67": int(sum(r["rms_z"] < 0.67 for r in live)),
                "cells_rms_z_above_1.5": int(sum(r["rms_z"] > 1.5 for r in live))}
    used = [r for r in rows if not r["warned"]]
    out = {"all": stats(used),
           "statistical (allowance below the spread)": stats([r for r in used if not r["bound"]]),
           "bound (allowance above the spread)": stats([r for r in used if r["bound"]])}
    for key in ("model", "estimator", "samples"):
        for val in sorted({r[key] for r in used}, key=str):
            out[f"{key}={val}"] = stats([r for r in used if r[key] == val])
    out["useless (warned)"] = stats([r for r in rows if r["warned"]])
    return out


def markdown(summary, seconds, seeds):
    lines = ["# Error bars of Sobol-point estimates over the stability map",
             "",
             f"`python scripts/qmc_error_bars.py` ({seconds:.0f} s): every model's stability-map "
             f"cells (mu >= {MU_MIN:g}, single precision, the map's float64 references), the brdf "
             f"and mis estimators with Sobol points at {' and '.join(str(n) for n in SIZES)} "
             f"samples, {seeds} seeds each. z = (E - E_ref) / sqrt(stderr^2 + ref_err^2). "
             "Exact cells (every seed without spread and within its bar: constant weights) are "
             "counted apart, and so are the cells where the stability map marks the estimator "
             "useless (`clbrdf.albedo` warns there: UselessEstimatorWarning). rms z is 1 for "
             "bars that match the error; |z| > 4 should be under 0.1 % of the estimates. "
             "'bound': cells where the unseen-event allowance (the bar's part for what the "
             "samples may have missed, docs/accuracy/unseen.md) exceeds the spread in most "
             "seeds: there the bar is a bound, not a standard error, and rms z below 1 is its "
             "cost.",
             "",
             "| set | cells | exact | estimates | rms z | \\|z\\| > 4 | max \\|z\\| | cells rms z < 0.67 | > 1.5 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for k, s in summary.items():
        if not s.get("cells"):
            lines.append(f"| {k} | 0 | {s['exact_cells']} | | | | | | |")
            continue
        lines.append(f"| {k} | {s['cells']} | {s['exact_cells']} | {s['estimates']} | "
                     f"{s['rms_z']:.3f} | {s['beyond_4']} ({100 * s['beyond_4_share']:.3f} %) | "
                     f"{s['max_abs_z']:.2f} | {s['cells_rms_z_below_0.67']} | "
                     f"{s['cells_rms_z_above_1.5']} |")
    return "\n".join(lines) + "\n"


def adaptive(target=1e-5, start=1 << 12, cap=1 << 22):
    """Samples a GGX table (mu 0.05 .. 1 x alpha 0.05 .. 1, 16 x 16, Sobol points) spends to
    reach ``target`` with --target-stderr, with the allowance that reads what the samples drew
    and with the earlier one (W the probes' largest weight, the samples' range ignored), and
    each table's largest error against the double-precision quadrature."""
    import clbrdf.runtime.albedo as ra
    axes = {"mu": np.linspace(0.05, 1, 16), "alpha": np.linspace(0.05, 1, 16)}
    ref = clbrdf.albedo_table("ggx", axes, estimator="quadrature", precision="double",
                              average=False)["E"]
    out = {}
    real = ra.run_albedo
    for rule in ("reads the samples", "earlier (probes only)"):
        if rule.startswith("earlier"):      # the same run, its samples' range not passed on
            ra.run_albedo = lambda *a, **k: real(*a, **k)[:4] + (None,)
        try:
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t = clbrdf.albedo_table("ggx", axes, samples=start, qmc=True, average=False,
                                        target_stderr=target, max_samples=cap)
            seconds = time.perf_counter() - t0
        finally:
            ra.run_albedo = real
        err = np.abs(t["E"] - ref)
        out[rule] = {"samples": int(np.sum(t["E_samples"])),
                     "median_cell_samples": int(np.median(t["E_samples"])),
                     "max_cell_samples": int(np.max(t["E_samples"])),
                     "cells_above_target": int(np.sum(t["E_stderr"] > target)),
                     "max_error": float(err.max()), "max_z": float(np.max(err / t["E_stderr"])),
                     "seconds": seconds}
    return {"target": target, "start": start, "cap": cap, "rules": out}


def adaptive_text(a):
    lines = ["", f"## Refining a table to a target: --target-stderr {a['target']:g}", "",
             f"GGX, mu 0.05 .. 1 x alpha 0.05 .. 1 (16 x 16 cells), Sobol points from "
             f"{a['start']} samples a cell, 4x per look, at most {a['cap']}; errors against the "
             "double-precision quadrature.", "",
             "| allowance | samples (all cells) | median per cell | most | cells above target | "
             "max error | max z | seconds |", "|---|---|---|---|---|---|---|---|"]
    for rule, r in a["rules"].items():
        lines.append(f"| {rule} | {r['samples']} | {r['median_cell_samples']} | "
                     f"{r['max_cell_samples']} | {r['cells_above_target']} | "
                     f"{r['max_error']:.2g} | {r['max_z']:.2f} | {r['seconds']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=None, help="directory for rows.csv, summary.json, README.md")
    ap.add_argument("--models", nargs="*", default=None)
    ap.add_argument("--seeds", type=int, default=SEEDS)
    ap.add_argument("--probes-only", action="store_true",
                    help="the earlier allowance (W from the probes alone), for comparison")
    a = ap.parse_args(argv)
    if a.probes_only:
        import clbrdf.runtime.albedo as ra
        real = ra.run_albedo
        ra.run_albedo = lambda *x, **k: real(*x, **k)[:4] + (None,)
    t0 = time.perf_counter()
    rows = measure(a.models, a.seeds)
    seconds = time.perf_counter() - t0
    summary = summarise(rows)
    text = markdown(summary, seconds, a.seeds)
    if a.models is None and not a.probes_only:
        summary["adaptive"] = adaptive()
        text += adaptive_text(summary["adaptive"])
    print(text)
    if a.out:
        out = Path(a.out)
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "rows.csv", "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            for r in rows:
                w.writerow({**r, "z": " ".join(map(str, r["z"]))})
        (out / "summary.json").write_text(json.dumps(summary, indent=1))
        (out / "README.md").write_text(text)


if __name__ == "__main__":
    main()
