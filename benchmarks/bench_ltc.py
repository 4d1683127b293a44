#!/usr/bin/env python3
"""LTC table fits (clbrdf.fit_ltc): time per table and per cell, where the time goes, and the
error of the result, side by side in one run.

Rows:
  ggx-threejs        GGX (height-correlated, F = 1) on three.js's 64 x 64 grid (the threejs
                     layout's axes), 1024 quasi-random samples per loss: the job ltc_code's
                     fitLTC.cpp does serially ("several minutes" on a desktop CPU); compared cell
                     by cell with ltc_code's shipped table (tests/data/renderers/ltc_code_ggx.csv)
                     under the same metric and samples (clbrdf.ltc_errors)
  ggx-threejs-256    the same with 256 samples per loss (cheaper, noisier loss)
  charlie-32         Charlie sheen on a 32 x 32 grid (sqrt(1 - mu), alpha in [0.05, 1]): the size
                     of Zeltner et al.'s sheen LTC table, fitted to our Charlie (not to Zeltner's
                     volumetric sheen)

    python benchmarks/bench_ltc.py [--write]
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

BEGIN = "<!-- bench_ltc:begin -->"
END = "<!-- bench_ltc:end -->"
SHIPPED = HERE.parent / "tests" / "data" / "renderers" / "ltc_code_ggx.csv"


def shipped_minv():
    d = np.loadtxt(SHIPPED, delimiter=",", comments="#", skiprows=4).reshape(64, 64, 8)
    m = np.zeros((64, 64, 3, 3))
    m[..., 0, 0], m[..., 2, 0], m[..., 0, 2], m[..., 2, 2] = (d[..., k] for k in range(4))
    m[..., 1, 1] = 1
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="write the section of RESULTS.md")
    args = ap.parse_args()
    import clbrdf
    from clbrdf.tables.ltc_layouts import ltc_layouts
    from clbrdf.tables.axes import parse_axis
    three = {parse_axis(t)["name"]: t.split("=", 1)[1] for t in ltc_layouts()["threejs"]["axes"]}
    rows = [("ggx-threejs", "ggx", three, 1024),
            ("ggx-threejs-256", "ggx", three, 256),
            ("charlie-32", "charlie", {"sqrt1m_mu": "0:1:32:max=0.999602",
                                       "alpha": "0.05:1:32"}, 1024)]
    clbrdf.fit_ltc("ggx", {"mu": [0.5], "alpha": [0.5]})       # build the programs first
    shipped = clbrdf.ltc_errors("ggx", three, shipped_minv())
    out = []
    for key, model, axes, samples in rows:
        t, c = time.perf_counter(), time.process_time()
        tab = clbrdf.fit_ltc(model, axes, samples=samples)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        m = tab.computed
        n = int(np.prod(tab.shape))
        line = {"row": key, "cells": n, "wall": wall, "cpu": cpu, "m": m,
                "L1_med": float(np.median(tab["L1"])), "L1_max": float(np.max(tab["L1"]))}
        if model == "ggx":
            se = np.hypot(tab["L3_stderr"], shipped["L3_stderr"])
            line["worse"] = int(np.sum(tab["L3"] - shipped["L3"] > 3 * se))
            line["better"] = int(np.sum(shipped["L3"] - tab["L3"] > 3 * se))
            line["ratio"] = float(np.median(tab["L3"] / shipped["L3"]))
        out.append(line)
        print(key, f"{wall:.1f} s wall, {cpu:.1f} s CPU, {1e3 * wall / n:.2f} ms/cell, "
              f"moments {m['seconds_moments']:.1f} s, fit {m['seconds_fit']:.1f} s, report "
              f"{m['seconds_report']:.1f} s, {m['loss_evaluations']} loss evaluations, "
              f"L1 median {line['L1_med']:.3g} max {line['L1_max']:.3g}"
              + (f", L3 vs shipped: median ratio {line['ratio']:.3f}, worse {line['worse']}, "
                 f"better {line['better']} (3 se)" if "worse" in line else ""), flush=True)
    sh_l1 = float(np.median(shipped["L1"]))
    lines = [BEGIN, "## LTC table fits (bench_ltc.py)", "",
             f"Machine: {cpu_model()}, {os.cpu_count()} logical cores; "
             f"{clbrdf.get_device().info.name}; clbrdf {clbrdf.__version__}, commit "
             f"{git_commit()}. One run each (`python benchmarks/bench_ltc.py "
             f"--write`, {time.strftime('%Y-%m-%d')}); single precision, report with 2^16 "
             f"Philox samples per cell. ltc_code's shipped GGX table under the same metric: L1 "
             f"median {sh_l1:.3g}, max {float(np.max(shipped['L1'])):.3g}.", "",
             "| row | cells | wall s | CPU s | ms per cell | moments s (of them E, B by quadrature) | "
             "Nelder-Mead s | report s "
             "| loss evaluations | L1 median | L1 max | L3 ours/shipped (median) | cells worse / "
             "better than shipped (3 se) |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in out:
        m = r["m"]
        lines.append(f"| {r['row']} | {r['cells']} | {r['wall']:.1f} | {r['cpu']:.1f} | "
                     f"{1e3 * r['wall'] / r['cells']:.2f} | {m['seconds_moments']:.1f} "
                     f"({m.get('magnitude_seconds', 0):.1f}) | "
                     f"{m['seconds_fit']:.1f} | {m['seconds_report']:.1f} | "
                     f"{m['loss_evaluations']} | {r['L1_med']:.3g} | {r['L1_max']:.3g} | "
                     + (f"{r['ratio']:.3f} | {r['worse']} / {r['better']} |" if "worse" in r
                        else "- | - |"))
    lines += ["", "The magnitudes E and B are the double-precision quadrature's to 2e-7 (a Monte "
              "Carlo pass of about 1 s before, with a standard error near 1e-3); of the rest the "
              "Nelder-Mead steps dominate: each is one or two launches of one candidate "
              "per active cell, each candidate's loss 2 x samples lobe and LTC evaluations; the "
              "host's share (sorting simplices) is small.", END]
    text = "\n".join(lines)
    print(text)
    if args.write:
        write_section(BEGIN, END, text)


if __name__ == "__main__":
    main()
