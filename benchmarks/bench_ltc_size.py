#!/usr/bin/env python3
"""How large must an anisotropic LTC table be? A 4-D table-size study for anisotropic GGX
(height-correlated, F = 1): axes alpha_x and alpha_y (sqrt-spaced nodes on [0.05, 1]), the
view axis v = sqrt(1 - mu) (nodes on [0, 0.95]) and wo's azimuth phi (nodes on [0, pi/2]: the
lobe's mirror symmetries give the rest), N nodes each.

For each N: the table's fit time, and at held-out points (a 4^4 grid at t = (k + 0.37) / 4 of
each axis, off every node of every N) the relative L1 error of the LTC that a renderer gets by
multilinear interpolation of the table's normalised M^-1 entries (clbrdf.Table.lookup), beside
the error of an LTC fitted directly at the point (clbrdf.fit_ltc on the held-out grid): the
excess is the table's interpolation error, the rest the LTC's own.

    python benchmarks/bench_ltc_size.py [--sizes 3,5,7] [--write]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_albedo import cpu_model, git_commit  # noqa: E402
from results import write_section  # noqa: E402

BEGIN = "<!-- bench_ltc_size:begin -->"
END = "<!-- bench_ltc_size:end -->"
RANGES = {"alpha_x": (0.05, 1.0, "sqrt"), "alpha_y": (0.05, 1.0, "sqrt"),
          "sqrt1m_mu": (0.0, 0.95, "lin"), "phi": (0.0, np.pi / 2, "lin")}


def held_out():
    t = (np.arange(4) + 0.37) / 4
    out = {}
    for k, (a, b, sp) in RANGES.items():
        out[k] = list((np.sqrt(a) + t * (np.sqrt(b) - np.sqrt(a))) ** 2 if sp == "sqrt"
                      else a + t * (b - a))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="3,5,7", help="nodes per axis, comma-separated")
    ap.add_argument("--write", action="store_true", help="write the section of RESULTS.md")
    args = ap.parse_args()
    import clbrdf
    from clbrdf.tables.ltc import ENTRIES
    pts = held_out()
    t = time.perf_counter()
    direct = clbrdf.fit_ltc("ggx", pts)
    t_direct = time.perf_counter() - t
    d1 = np.asarray(direct["L1"])
    grid = np.meshgrid(*[np.asarray(v) for v in pts.values()], indexing="ij")
    rows = []
    for n in [int(s) for s in args.sizes.split(",")]:
        axes = {k: f"{a}:{b}:{n}:{sp}" for k, (a, b, sp) in RANGES.items()}
        t, c = time.perf_counter(), time.process_time()
        tab = clbrdf.fit_ltc("ggx", axes)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        look = tab.lookup(*grid)                          # all quantities at the held-out grid
        q = list(tab.quantity)
        minv = np.stack([look[..., q.index(e)] for e in ENTRIES], -1).reshape(grid[0].shape + (3, 3))
        err = clbrdf.ltc_errors("ggx", pts, minv)
        i1 = np.asarray(err["L1"])
        excess = i1 - d1
        rows.append({"n": n, "cells": int(np.prod(tab.shape)), "wall": wall, "cpu": cpu,
                     "node_med": float(np.median(tab["L1"])),
                     "med": float(np.median(i1)), "p95": float(np.percentile(i1, 95)),
                     "max": float(i1.max()), "ex_med": float(np.median(excess)),
                     "ex_p95": float(np.percentile(excess, 95))})
        r = rows[-1]
        print(f"N={n}: {r['cells']} cells, {wall:.1f} s wall, {cpu:.1f} s CPU; interpolated L1 "
              f"median {r['med']:.3g}, p95 {r['p95']:.3g}, max {r['max']:.3g}; excess over "
              f"direct median {r['ex_med']:.3g}, p95 {r['ex_p95']:.3g}", flush=True)
    lines = [BEGIN, "## Anisotropic LTC table size (bench_ltc_size.py)", "",
             f"Machine: {cpu_model()}, {os.cpu_count()} logical cores; "
             f"{clbrdf.get_device().info.name}; clbrdf {clbrdf.__version__}, commit "
             f"{git_commit()}. `python benchmarks/bench_ltc_size.py --sizes {args.sizes}` ({time.strftime('%Y-%m-%d')}); single precision, 1024 samples per loss, "
             f"2^16 per reported error. Anisotropic GGX over alpha_x, alpha_y (sqrt-spaced, "
             f"[0.05, 1]), v = sqrt(1 - mu) ([0, 0.95]) and phi ([0, pi/2]), N nodes each; "
             f"held out: 256 points (a 4^4 grid off all nodes). LTCs fitted directly at them "
             f"({t_direct:.1f} s): relative L1 median {np.median(d1):.3g}, p95 "
             f"{np.percentile(d1, 95):.3g}, max {d1.max():.3g}.", "",
             "| N per axis | cells | wall s | CPU s | ms per cell | L1 at nodes (median) | "
             "interpolated L1 median | p95 | max | excess over direct: median | p95 |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['n']} | {r['cells']} | {r['wall']:.1f} | {r['cpu']:.1f} | "
                     f"{1e3 * r['wall'] / r['cells']:.2f} | {r['node_med']:.3g} | {r['med']:.3g} | "
                     f"{r['p95']:.3g} | {r['max']:.3g} | {r['ex_med']:.3g} | {r['ex_p95']:.3g} |")
    lines.append(END)
    text = "\n".join(lines)
    print(text)
    if args.write:
        write_section(BEGIN, END, text)


if __name__ == "__main__":
    main()
