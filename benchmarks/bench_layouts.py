#!/usr/bin/env python3
"""Time for each renderer layout (clbrdf table --layout NAME) at its published sample count, with
the brdf estimator on Philox numbers (the layout's default) and with Sobol points (the estimator
docs/accuracy/README.md recommends: brdf + qmc), and the max error of the stored values against
a reference: the same table by the double-precision quadrature (tol 1e-8, at most 2^20
evaluations per cell; where a cell stops short its error estimate says so) on every node of
tables up to 1024 cells, on every 4th node of each axis of the larger ones.

Times are wall and CPU seconds of make_layout without the interpolation check, median of
--rounds runs (the reference once). The error includes the stored encoding's rounding.
``--match`` adds a row per layout: the least power of two of samples per cell at which brdf +
qmc reaches the max error of brdf (Philox) at the published count, and its time.

    python benchmarks/bench_layouts.py [--write] [--rounds 1] [--only cycles threejs] [--match]
"""
import argparse
import datetime as _dt
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from results import RESULTS, timed, write_section
BEGIN, END = "<!-- bench_layouts:begin -->", "<!-- bench_layouts:end -->"
REF_MAX_EVALS = 1 << 20   # per cell: near a critical angle (eta < 1, small r) tol 1e-8 needs more


def subgrid(t):
    """Axis values of the reference grid and their indices in the table."""
    step = 1 if np.prod(t.shape) <= 1024 else 4
    idx = [np.arange(0, n, step) for n in t.shape]
    axes = []
    for a, i in zip(t.axes, idx):
        ax = {"name": a["name"], "values": np.asarray(a["values"])[i].tolist()}
        ax.update({k: a[k] for k in ("min", "max") if a.get(k) is not None})
        axes.append(ax)
    return axes, idx


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--match", action="store_true",
                    help="also the least 2^k samples at which brdf + qmc reaches brdf's max error")
    a = ap.parse_args()
    import clbrdf
    from clbrdf.tables.axes import parse_axis
    from clbrdf.tables.layouts import layout_table, layouts, make_layout
    warnings.simplefilter("ignore")
    rows = []
    for name, lay in layouts().items():
        if a.only and name not in a.only:
            continue
        n = lay["samples"]
        runs = {}
        for label, qmc in (("brdf", False), ("brdf + qmc", True)):
            runs[label] = timed(lambda: make_layout(name, samples=n, qmc=qmc,
                                                    check_interpolation=False), a.rounds)
        t_ref = time.perf_counter()
        refs = {}
        for tab in lay["tables"]:
            t = runs["brdf"][2][tab["name"]]
            axes, idx = subgrid(t)
            def clamps(x):          # a channel's own axis: its min= and max=
                x = parse_axis(x) if isinstance(x, str) else x
                return {k: x[k] for k in ("min", "max") if x.get(k) is not None}
            sub = dict(tab, axes=axes, quantity=[
                dict(q, axes=[dict(name=x["name"] if isinstance(x, dict) else
                                   parse_axis(x)["name"], values=a["values"], **clamps(x))
                              for a, x in zip(axes, q["axes"])])
                if isinstance(q, dict) and "axes" in q else q
                for q in (tab["quantity"] if isinstance(tab["quantity"], list)
                          else [tab["quantity"]])])
            r = layout_table(lay, sub, estimator="quadrature", precision="double", tol=1e-8,
                             max_evals=REF_MAX_EVALS, check_interpolation=False)
            refs[tab["name"]] = (r.values, np.ix_(*idx))
        t_ref = time.perf_counter() - t_ref
        def score(tables):
            errs = [float(np.max(np.abs(tables[k].values[ix] - ref)))
                    for k, (ref, ix) in refs.items()]
            return max(errs), max(float(np.max(t.stderr)) for t in tables.values())

        def report(label, n_, w, c, tables):
            err, sd = score(tables)
            cells = sum(int(np.prod(t.shape)) * len(t.quantity) for t in tables.values())
            rows.append((name, label, n_, cells, w, c, err, sd))
            print(f"{name:15s} {label:11s} {n_:>9d} samples  {cells:6d} values  {w:7.2f} s wall "
                  f"{c:7.2f} s CPU  max error {err:.2e}  max stderr {sd:.1e}", flush=True)
            return err
        target = None
        for label, (w, c, tables) in runs.items():
            e = report(label, n, w, c, tables)
            target = e if label == "brdf" else target
        k = 8
        while a.match and (1 << k) < n:     # the least 2^k at which qmc reaches brdf's error
            w, c, tables = timed(lambda: make_layout(name, samples=1 << k, qmc=True,
                                                     check_interpolation=False), a.rounds)
            if score(tables)[0] <= target:
                report("brdf + qmc, same max error as brdf", 1 << k, w, c, tables)
                break
            k += 1
        print(f"{'':15s} reference {t_ref:.0f} s", flush=True)
        if a.write:
            write(rows, layouts, clbrdf)


def write(rows, layouts, clbrdf):
    if True:
        import platform
        dev = clbrdf.get_device().info
        text = [BEGIN, "## Renderer layouts (`benchmarks/bench_layouts.py`)", "",
                f"Measured {_dt.date.today()} on {platform.processor() or platform.machine()} "
                f"({dev.name}; {dev.platform}), {__import__('os').cpu_count()} cores, single "
                f"precision, width 16. Each layout's tables at its published sample count per "
                f"cell, without the interpolation check; max error of the stored (encoded) "
                f"values against the double-precision quadrature (tol 1e-8, at most 2^20 "
                f"evaluations per cell) on every node "
                f"(tables up to 1024 cells) or every 4th node of each axis. Run: "
                f"`python benchmarks/bench_layouts.py --write` (`--only NAME` re-runs one "
                f"layout and replaces its rows; last: `{' '.join(['python', 'benchmarks/' + Path(sys.argv[0]).name] + sys.argv[1:])}`).", "",
                "| layout | estimator | samples per cell | values | wall s | CPU s | max error | "
                "max stderr |", "|---|---|---:|---:|---:|---:|---:|---:|"]
        old = RESULTS.read_text() if RESULTS.exists() else ""
        kept = []          # rows of layouts not run this time (--only) stay
        if BEGIN in old:
            for line in old[old.index(BEGIN):old.index(END)].splitlines():
                cells_ = [c.strip() for c in line.strip("|").split("|")]
                if line.startswith("| ") and len(cells_) == 8 and cells_[0] in layouts() \
                        and cells_[0] not in {r[0] for r in rows}:
                    kept.append(line)
        for name, label, n, cells, w, c, e, s in rows:
            kept.append(f"| {name} | {label} | {n} | {cells} | {w:.2f} | {c:.2f} | {e:.1e} | "
                        f"{s:.1e} |")
        order = list(layouts())          # rows in the layouts' order, stably
        text += sorted(kept, key=lambda line: order.index(line.split("|")[1].strip()))
        text.append(END)
        write_section(BEGIN, END, "\n".join(text))


if __name__ == "__main__":
    main()
