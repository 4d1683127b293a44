#!/usr/bin/env python3
"""The energy-conservation reports in docs/energy/: one sweep per model over its parameter
ranges (MODEL_SWEEPS), with `clbrdf report`'s README and maps in docs/energy/NAME/, and a sweep
of every published preset (docs/energy/presets.md); docs/energy/README.md tabulates them.

    python scripts/energy_reports.py [--out docs/energy] [--points 2048] [--samples 4096]

Stores go to a temporary directory (they are reproducible from the commands in the reports).
"""
import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import clbrdf
from clbrdf.models.presets import load, source_label, sources
from clbrdf.studies.report import report
from clbrdf.studies.sweep import sweep

# name -> (model, fixed parameters and options, axes as START:STOP[:SPACING] for random points[,
# overrides of --points and the sample cap for models whose samplers are slow: SGD 5, Bagher's
# SGD 6, Holzschuch-Pacanowski 9, exponential power 17, GTR 20 M samples/s against GGX's 640 on
# the 2-core Xeon, where 2048 points refined 64x took over 25 minutes each]).
# The lobes alone (kd = 0, F = 1, ks = 1 unless an axis says otherwise): the added Lambertian
# term kd of the microfacet models adds kd to E, so with it any kd > 1 - E_spec gains (ggx-kd
# shows it once). Shape parameters over their whole valid range; scale parameters (A of Löw's
# ABC lobes, up to 1e8) over a few decades around 1, where the question is not trivial.
MODEL_SWEEPS = {
    "lambert": ("lambert", {}, ["kd=0:1"]),
    "ggx": ("ggx", {}, ["alpha=1e-4:10:log"]),
    "ggx-separable": ("ggx", {"masking": "separable"}, ["alpha=1e-4:10:log"]),
    "ggx-vcavity": ("ggx", {"masking": "vcavity"}, ["alpha=1e-4:10:log"]),
    "ggx-no-masking": ("ggx", {"masking": "none"}, ["alpha=1e-4:10:log"]),
    "ggx-schlick": ("ggx", {"fresnel": "schlick"}, ["alpha=1e-4:10:log", "f0=0:1"]),
    "ggx-kd": ("ggx", {}, ["alpha=1e-4:10:log", "kd=0:1"]),
    "beckmann": ("beckmann", {}, ["alpha=1e-4:10:log"]),
    "exppow": ("exppow", {}, ["alpha=1e-4:10:log", "p=0.1:5"], {"points": 512, "growth": 16}),
    "gtr": ("gtr", {}, ["alpha=0.001:0.999:log", "gamma=0.5:4"], {"points": 512, "growth": 16}),
    "sgd": ("sgd", {}, ["alpha=1e-5:1:log", "p=0:2"], {"points": 256, "growth": 4}),
    "ashikhmin_shirley": ("ashikhmin_shirley", {}, ["nu=0.01:1e7:log", "nv=0.01:1e7:log",
                                                     "rs=0:1", "rd=0:1"]),
    "holzschuch_pacanowski": ("holzschuch_pacanowski", {},
                              ["f0=0:1.2", "kw=0:1", "a=0.01:100:log", "sigma=1e-4:10:log",
                               "p=0.1:5"], {"points": 256, "growth": 4}),
    "low_smooth": ("low_smooth", {}, ["a=1e-3:1e3:log", "b=1e-6:1e9:log", "c=0.01:50:log",
                                      "eta=1.001:1000:log"]),
    "low_microfacet": ("low_microfacet", {}, ["a=1e-3:1e3:log", "b=1e-6:1e9:log",
                                              "c=0.01:50:log", "eta=1.001:1000:log"]),
    "sgd_bagher": ("sgd_bagher", {"rho_d": 0.0}, ["rho_s=0:1", "alpha=1e-5:1:log", "p=0:2"],
                   {"points": 256, "growth": 4}),
    "schlick": ("schlick", {}, ["c=0:1", "r=1e-7:1:log", "p=1e-6:1:log", "psi=0:3.14159"]),
    "ward": ("ward", {}, ["alpha_x=0.001:1:log", "alpha_y=0.001:1:log", "ks=0:1"]),
    "oren_nayar": ("oren_nayar", {}, ["rho=0:1", "r=0:1"]),
    "oren_nayar-approx": ("oren_nayar", {"albedo": "approx"}, ["rho=0:1", "r=0:1"]),
    "oren_nayar-fon": ("oren_nayar", {"form": "fon"}, ["rho=0:1", "r=0:1"]),
    "oren_nayar-qon": ("oren_nayar", {"form": "qon"}, ["rho=0:1", "r=0:1"]),
    "ggx-f82": ("ggx", {"fresnel": "f82"}, ["alpha=1e-4:10:log", "f0=0:1", "f82=0:1"]),
    "ggx-gen-schlick": ("ggx", {"fresnel": "gen_schlick"},
                        ["alpha=1e-4:10:log", "f0=0:1", "f90=0:1", "exponent=0.1:100:log"]),
}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/energy")
    ap.add_argument("--points", type=int, default=2048)
    ap.add_argument("--samples", type=int, default=4096)
    ap.add_argument("--only", nargs="*", help="these MODEL_SWEEPS names (and 'presets')")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="clbrdf-energy."))
    rows = []
    summary_path = out / "summary.json"
    old = json.loads(summary_path.read_text()) if summary_path.exists() else {}
    try:
        for name, (model, fixed, axes, *more) in MODEL_SWEEPS.items():
            if a.only and name not in a.only:
                continue
            over = more[0] if more else {}
            points = over.get("points", a.points)
            cap = a.samples * over.get("growth", 64)
            t0 = time.perf_counter()
            cmd = (f"clbrdf sweep {model} --random {points} "
                   + " ".join(f"--axis {x}" for x in axes)
                   + "".join(f" -p {k}={v}" for k, v in fixed.items())
                   + f" --samples {a.samples} --max-samples {cap} --out {name}.zarr")
            sweep(model, tmp / f"{name}.zarr", axes=axes, random=points, samples=a.samples,
                  max_samples=cap, command=cmd, **fixed)
            summ = report(tmp / f"{name}.zarr", out / name)
            summ.pop("files", None)
            summ["seconds"] = time.perf_counter() - t0
            summ["command"] = cmd
            old[name] = summ
            print(f"{name}: {summ['gains']} gain, {summ['conserves']} conserve, "
                  f"{summ['undecided']} undecided; max E {summ['worst']['E']:.4f} "
                  f"({summ['seconds']:.0f} s)", flush=True)
            summary_path.write_text(json.dumps(old, indent=1))     # after each sweep
        if not a.only or "presets" in a.only:
            old["presets"] = presets(tmp, out, a.samples)
        summary_path.write_text(json.dumps(old, indent=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def presets(tmp, out, samples):
    """Every preset of every source: one point each (RGB), the default 32 directions."""
    lines = ["# Energy of the published presets", "",
             f"Each preset (a published fit to a MERL material, `clbrdf models MODEL --presets`) "
             f"swept as one point: `clbrdf sweep MODEL --preset MATERIAL:SOURCE --samples "
             f"{samples}` (32 Gauss-Legendre directions, RGB, error rate 1e-3 per preset). "
             f"Generated by `scripts/energy_reports.py`.", "",
             "| model | source | presets | gain | conserve | undecided | largest max E (material, "
             "channel, mu) |", "|---|---|---:|---:|---:|---:|---|"]
    gainers = []
    total = {}
    for model, srcs in sources().items():
        for src, _ in srcs:
            label = source_label(src)
            counts = {"gains": 0, "conserves": 0, "undecided": 0}
            worst = None
            mats = sorted(load(src))
            for mat in mats:
                p = tmp / f"preset-{model}-{label}-{mat}.zarr"
                s = sweep(model, p, preset=f"{mat}:{label}", samples=samples)
                summ = s.summary()
                for k in counts:
                    counts[k] += summ[k]
                w = summ["worst"]
                if worst is None or w["E"] > worst[1]["E"]:
                    worst = (mat, w)
                if summ["gains"]:
                    gainers.append((model, label, mat, w))
                shutil.rmtree(p)
            total[f"{model}:{label}"] = {**counts, "presets": len(mats),
                                         "worst": {"material": worst[0], **worst[1]}}
            m, w = worst
            lines.append(f"| {model} | {label} | {len(mats)} | {counts['gains']} | "
                         f"{counts['conserves']} | {counts['undecided']} | {w['E']:.4f} +- "
                         f"{w['stderr']:.1g} ({m}, {w.get('channel', '')}, mu "
                         f"{w['direction']['mu']:.3g}) |")
            print(lines[-1], flush=True)
    lines += ["", "## Presets that gain energy", "",
              "| model | source | material | max E | channel | mu |", "|---|---|---|---:|---|---:|"]
    for model, label, mat, w in sorted(gainers, key=lambda g: -g[3]["E"]):
        lines.append(f"| {model} | {label} | {mat} | {w['E']:.4f} | {w.get('channel', '')} | "
                     f"{w['direction']['mu']:.3g} |")
    (out / "presets.md").write_text("\n".join(lines) + "\n")
    return total


if __name__ == "__main__":
    main()
