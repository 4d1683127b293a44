#!/usr/bin/env python3
"""Time for a 32 x 32 GGX albedo table (E over mu = 0.02..1 x alpha = 0.02..1, 32 values each,
single precision) at a target max error of 1e-4, 1e-5 and 1e-6, for each estimator.

- quadrature: estimator='quadrature' with tol = the target; its max |E - E_ref| is measured.
- brdf, mis (Philox) and brdf with qmc: the sample count is doubled from 2^10 (each count
  timed once) until 4 x max stderr <= target (four standard errors over 1024 cells: a cell
  beyond them has probability 6e-5 for a normal estimate); past 2^20 samples per cell the time
  is extrapolated from the largest count as (4 max stderr / target)^2 (stderr ~ N^-1/2, which
  overstates QMC's cost), and marked so.
E_ref is clbrdf.ref's float64 quadrature (tol 1e-10), computed once (about 2 minutes). The
quadrature's times are the median of --rounds runs; wall and CPU seconds side by side.

    python benchmarks/bench_table_error.py [--write] [--rounds 3]
"""
import argparse
import datetime as _dt
import os
import sys
import time
import warnings

import numpy as np

from results import timed, write_section  # noqa: E402
BEGIN, END = "<!-- bench_table_error:begin -->", "<!-- bench_table_error:end -->"
TARGETS = (1e-4, 1e-5, 1e-6)
MAX_LOG2 = 20


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--ref-cache", default="/tmp/clbrdf_bench_ggx32_ref.npy",
                    help="where the reference table is kept between runs")
    a = ap.parse_args()
    import clbrdf
    from clbrdf.ref import reference
    mu = np.linspace(0.02, 1, 32)
    alpha = np.linspace(0.02, 1, 32)
    M, A = np.meshgrid(mu, alpha, indexing="ij")
    t0 = time.perf_counter()
    if os.path.exists(a.ref_cache):
        ref = np.load(a.ref_cache)
    else:
        ref = np.array([[reference("ggx", alpha=float(al)).albedo(float(m), 0.0, 1e-10)[0]
                         for al in alpha] for m in mu])
        np.save(a.ref_cache, ref)
    print(f"reference: {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    model = clbrdf.Model("ggx", alpha=A)
    rows = []
    for target in TARGETS:
        model_q = model
        clbrdf.albedo(model_q, M, estimator="quadrature", tol=target)      # warm-up (build)
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            wall, cpu, r = timed(lambda: clbrdf.albedo(model_q, M, estimator="quadrature",
                                                       tol=target), a.rounds)
        err = np.abs(r.albedo - ref).max()
        rows.append((target, "quadrature", f"tol {target:g}, up to {r.samples} evaluations",
                     wall, cpu, err, "" if not w else "did not converge everywhere"))
        print(rows[-1], file=sys.stderr)
    for est, qmc in (("brdf", False), ("mis", False), ("brdf", True)):
        runs, n = [], 1 << 10                    # (n, wall, cpu, 4 max stderr, max error)
        while n <= 1 << MAX_LOG2:
            wall, cpu, rr = timed(lambda: clbrdf.albedo(model, M, estimator=est, qmc=qmc,
                                                        samples=n, seed=2), 1)
            runs.append((n, wall, cpu, 4 * rr.stderr.max(), np.abs(rr.albedo - ref).max()))
            print(est, qmc, runs[-1], file=sys.stderr)
            if runs[-1][3] <= min(TARGETS):
                break
            n *= 2
        for target in TARGETS:
            ok = [r for r in runs if r[3] <= target]
            if ok:
                n, wall, cpu, s, err = ok[0]
                note = ""
            else:
                n, wall, cpu, s, err = runs[-1]
                f = (s / target) ** 2
                wall, cpu, n = wall * f, cpu * f, int(n * f)
                note = f"extrapolated from 2^{MAX_LOG2} (x{f:.3g}); max error there {err:.2g}"
                err = float("nan")
            rows.append((target, est + (" qmc" if qmc else ""), f"{n} samples per cell", wall,
                         cpu, err, note))
    rows.sort(key=lambda r: -r[0])
    dev = model.device.info
    lines = [f"GGX E table 32 x 32 (mu, alpha in [0.02, 1]), single precision, device {dev.name} "
             f"(W={model.width}); {os.cpu_count()} cores; median of {a.rounds} runs; load average "
             f"{os.getloadavg()[0]:.2f} after the run.", "",
             "| target max error | estimator | work | wall s | CPU s | measured max error | note |",
             "|---|---|---|---|---|---|---|"]
    for t, est, work, wall, cpu, err, note in rows:
        lines.append(f"| {t:g} | {est} | {work} | {wall:.3g} | {cpu:.3g} | {err:.2g} | {note} |")
    text = "\n".join(lines)
    print(text)
    if a.write:
        date = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
        section = (f"{BEGIN}\n## 32 x 32 GGX table at a target error (`benchmarks/bench_table_error.py`)"
                   f"\n\nDate: {date}. Command: `python benchmarks/bench_table_error.py --write`\n\n"
                   f"{text}\n{END}\n")
        write_section(BEGIN, END, section)


if __name__ == "__main__":
    main()
