#!/usr/bin/env python3
"""Energy-conservation sweeps (clbrdf.sweep): throughput against the raw albedo kernel, a
1e6-point GGX sweep, peak memory at 1e5 / 1e6 / 1e7 points, a two-worker LocalCluster against
a local run.

1. **Overhead**: the same (points x 32 directions x samples) job as ``clbrdf.albedo`` over the
   (points, directions) grid (the raw kernel and its reduction) and as a sweep (plus the
   per-chunk model set-up, verdicts, zarr writes and ledger), interleaved, --rounds each,
   no refinement (max_samples = samples) so both do the same samples; the median ratio is
   the sweep's fraction of the raw throughput. Also the default sweep (with refinement).
2. **1e6 GGX points** (alpha 1e-3..1 log x f0 0..1, 1000 x 1000) x 32 directions x 4096 samples,
   the default rule (refinement up to 64x for undecided points), Sobol points: wall time, and
   the samples actually drawn.
3. **Peak memory**: ``clbrdf sweep`` in a child process at 1e5, 1e6 and 1e7 points (GGX, 4
   directions, 64 samples, no refinement): max resident set size of the child.
4. **LocalCluster**: two single-threaded workers (PoCL one thread each) against the local run
   (one PoCL device of two threads), same sweep.

    python benchmarks/bench_sweep.py [--write] [--rounds 3] [--skip-million]
"""
import argparse
import datetime as _dt
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
from results import write_section  # noqa: E402
BEGIN, END = "<!-- bench_sweep:begin -->", "<!-- bench_sweep:end -->"


def cpu_name():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


from results import timed  # noqa: E402


def overhead(tmp, rounds, points, samples):
    import clbrdf
    from clbrdf.studies.sweep import sweep
    axes = {"alpha": (0.02, 1, points, "log")}
    alpha = np.geomspace(0.02, 1, points)
    mu = np.asarray(__import__("clbrdf.sweep", fromlist=["x"]).gauss_directions(32)["mu"])

    def raw():
        m = clbrdf.Model("ggx", alpha=alpha[:, None])
        return clbrdf.albedo(m, mu[None, :], samples=samples)

    def sw(i, **kw):
        p = tmp / f"o{i}.zarr"
        shutil.rmtree(p, ignore_errors=True)
        return sweep("ggx", p, axes=axes, samples=samples, **kw)
    raw(), sw("w", max_samples=samples)            # warm-up: builds and caches
    rows = {"raw": [], "sweep": [], "adaptive": []}
    for r in range(rounds):
        rows["raw"].append(timed(raw)[:2])
        rows["sweep"].append(timed(lambda: sw(r, max_samples=samples))[:2])
        rows["adaptive"].append(timed(lambda: sw(f"a{r}"))[:2])
    s = sweep("ggx", tmp / "count.zarr", axes=axes, samples=samples)
    drawn = int(s["samples"][:].sum())
    return rows, drawn


def million(tmp):
    from clbrdf.studies.sweep import sweep
    p = tmp / "million.zarr"
    shutil.rmtree(p, ignore_errors=True)
    w, c, s = timed(lambda: sweep("ggx", p, axes={"alpha": (1e-3, 1, 1000, "log"),
                                                  "f0": (0, 1, 1000)},
                                  samples=4096, qmc=True))
    summ = s.summary()
    drawn = 0
    for i0, a in s.chunks(("samples",)):
        drawn += int(a["samples"].sum(dtype=np.uint64))
    size = sum(f.stat().st_size for f in p.rglob("*") if f.is_file())
    return w, c, summ, drawn, size


def peak_memory(tmp, n):
    side = int(round(n ** 0.5))
    out = tmp / f"mem{n}.zarr"
    shutil.rmtree(out, ignore_errors=True)
    cmd = [sys.executable, "-c",
           "import resource, sys; from clbrdf.cli import main; rc = main(sys.argv[1:]); "
           "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss); sys.exit(rc)",
           "sweep", "ggx", "--axis", f"alpha=0.001:1:{side}:log", "--axis", f"f0=0:1:{n // side}",
           "--samples", "64", "--max-samples", "64", "--directions", "gauss:4", "--qmc", "-q",
           "--json", "--out", str(out)]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, check=True)
    w = time.perf_counter() - t
    rss_kb = int(r.stdout.strip().splitlines()[-1])
    size = sum(f.stat().st_size for f in out.rglob("*") if f.is_file())
    shutil.rmtree(out, ignore_errors=True)
    return side * (n // side), rss_kb / 1024, w, size


def cluster_vs_local(tmp, rounds):
    from clbrdf.studies.cluster import local_cluster
    from clbrdf.studies.sweep import sweep
    from distributed import Client
    kw = dict(axes={"alpha": (0.01, 1, 64, "log"), "f0": (0, 1, 16)}, samples=4096,
              max_samples=4096, chunk=64)
    cl = local_cluster(2, threads_per_worker=1)
    client = Client(cl)
    try:
        def run(name, **extra):
            p = tmp / f"{name}.zarr"
            shutil.rmtree(p, ignore_errors=True)
            return sweep("ggx", p, **kw, **extra)
        run("lw"), run("cw", client=client)
        loc, dist = [], []
        for r in range(rounds):
            loc.append(timed(lambda: run(f"l{r}"))[:2])
            dist.append(timed(lambda: run(f"c{r}", client=client))[:2])
    finally:
        client.close()
        cl.close()
    return loc, dist, 64 * 16


def med(rows, i=0):
    return statistics.median(r[i] for r in rows)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--write", action="store_true")
    ap.add_argument("--skip-million", action="store_true")
    ap.add_argument("--memory", default="1e5,1e6,1e7")
    a = ap.parse_args()
    import clbrdf
    dev = clbrdf.get_device()
    tmp = Path(tempfile.mkdtemp(prefix="bench_sweep."))
    lines = []
    try:
        points, samples = 4096, 4096
        rows, drawn = overhead(tmp, a.rounds, points, samples)
        work = points * 32 * samples
        raw, swp = med(rows["raw"]), med(rows["sweep"])
        lines += ["### Sweep against the raw albedo kernel", "",
                  f"GGX, alpha 0.02..1 (log, {points} points) x 32 Gauss-Legendre directions x "
                  f"{samples} samples, Philox; medians of {a.rounds} interleaved rounds.", "",
                  "| row | wall s | CPU s | M samples/s | points/s |", "|---|---|---|---|---|"]
        for k, what in (("raw", "clbrdf.albedo over (points, directions)"),
                        ("sweep", "clbrdf.sweep, max_samples = samples"),
                        ("adaptive", "clbrdf.sweep, default refinement")):
            w, c = med(rows[k]), med(rows[k], 1)
            lines.append(f"| {what} | {w:.3f} | {c:.3f} | {work / w / 1e6:.1f} | {points / w:.0f} |")
        frac = statistics.median(r[0] / s[0] for r, s in zip(rows["raw"], rows["sweep"]))
        lines += ["", f"Sweep throughput = **{100 * frac:.1f} %** of the raw kernel's (median of "
                      f"the per-round ratios; {100 * raw / swp:.1f} % from the medians). The "
                      f"default rule drew {drawn / (points * 32):.0f} samples per direction on "
                      f"average ({drawn / 1e6:.0f} M in all).", ""]
        print("\n".join(lines), flush=True)
        if not a.skip_million:
            w, c, summ, drawn, size = million(tmp)
            lines += ["### 1e6 GGX points", "",
                      "`clbrdf.sweep('ggx', axes={'alpha': (1e-3, 1, 1000, 'log'), 'f0': (0, 1, "
                      "1000)}, samples=4096, qmc=True)`: 32 directions, default rule.", "",
                      f"- wall **{w:.1f} s** ({c:.1f} CPU s); {summ['gains']} gain, "
                      f"{summ['conserves']} conserve, {summ['undecided']} undecided",
                      f"- samples drawn: {drawn / 1e9:.1f} G ({drawn / (1e6 * 32):.0f} per "
                      f"direction on average; 1e6 x 32 x 4096 = 131 G), "
                      f"{drawn / w / 1e6:.0f} M samples/s", f"- store: {size / 2**20:.0f} MiB", ""]
            print("\n".join(lines[-6:]), flush=True)
        lines += ["### Peak memory", "",
                  "`clbrdf sweep ggx` in a child process: alpha x f0 grid, 4 directions, 64 "
                  "samples, Sobol, no refinement.", "",
                  "| points | peak RSS MiB | wall s | store MiB |", "|---|---|---|---|"]
        for n in a.memory.split(","):
            n_, rss, w, size = peak_memory(tmp, int(float(n)))
            lines.append(f"| {n_:.3g} | {rss:.0f} | {w:.1f} | {size / 2**20:.0f} |")
            print(lines[-1], flush=True)
        try:
            loc, dist, npts = cluster_vs_local(tmp, a.rounds)
            lines += ["", "### LocalCluster against a local run", "",
                      f"GGX, {npts} points x 32 directions x 4096 samples, chunks of 64 points; "
                      f"local: one PoCL device ({dev.cl_device.max_compute_units} threads); "
                      f"cluster: `local_cluster(2, threads_per_worker=1)` (PoCL one thread per "
                      f"worker); medians of {a.rounds} rounds after a warm-up each.", "",
                      "| run | wall s | client CPU s |", "|---|---|---|",
                      f"| local | {med(loc):.2f} | {med(loc, 1):.2f} |",
                      f"| LocalCluster, 2 workers | {med(dist):.2f} | {med(dist, 1):.2f} |", "",
                      f"Cluster / local wall time: {med(dist) / med(loc):.2f}.", ""]
            print("\n".join(lines[-8:]), flush=True)
        except ImportError as e:
            lines += ["", f"LocalCluster skipped: {e}", ""]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    head = [BEGIN, "## Energy-conservation sweeps (`benchmarks/bench_sweep.py`)", "",
            f"Date: {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC. Machine: "
            f"{os.cpu_count()} cores, {cpu_name()}; device {dev.info.name} "
            f"[{dev.info.platform}]. Command: `python benchmarks/bench_sweep.py"
            f"{' --write' if a.write else ''}`", ""]
    text = "\n".join(head + lines + [END])
    if a.write:
        write_section(BEGIN, END, text)


if __name__ == "__main__":
    main()
