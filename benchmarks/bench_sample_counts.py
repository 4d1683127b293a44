"""Albedo throughput against the number of samples per point, Philox and Sobol.

Tables for energy compensation often take few samples per point (QMC converges fast), so the
cost per sample must not grow when the count is small. The job: GGX (alpha 256 values in
[0.02, 1], F = 1, correlated G, visible-normal sampling), 64 values of mu, `estimator='brdf'`,
single precision, for each count of samples per point, with pseudo-random (Philox) and
quasi-random (Sobol, 16 scrambles) numbers; interleaved rounds, median M samples/s.

    python benchmarks/bench_sample_counts.py            # prints a markdown table (~1 minute)
    python benchmarks/bench_sample_counts.py --write    # also replaces its section of RESULTS.md
"""
from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_albedo import cpu_flags, cpu_model, git_commit, mem_total_gib  # noqa: E402
from results import write_section  # noqa: E402

BEGIN = "<!-- bench_sample_counts:begin -->"
END = "<!-- bench_sample_counts:end -->"
COUNTS = (64, 256, 1024, 4096, 65536)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--device", default=None)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args(argv)
    import clbrdf
    m = clbrdf.Model("ggx", alpha=np.linspace(0.02, 1, 256)[:, None], device=args.device)
    mu = np.linspace(1 / 64, 1, 64)
    jobs = [(rng, n) for rng in ("philox", "sobol") for n in COUNTS]

    def call(rng, n):
        return clbrdf.albedo(m, mu, samples=n, qmc=rng == "sobol")

    for job in jobs:                                    # compile and warm up
        call(*job)
    times = {job: [] for job in jobs}
    for r in range(args.rounds):
        for job in jobs[r % len(jobs):] + jobs[:r % len(jobs)]:
            t = time.perf_counter()
            call(*job)
            times[job].append(time.perf_counter() - t)
    rate = {job: m.params["alpha"].size * mu.size * job[1] / np.median(times[job]) / 1e6 for job in jobs}
    lines = ["| numbers | " + " | ".join(f"{n} samples/point" for n in COUNTS) + " |",
             "|---|" + "---|" * len(COUNTS)]
    for rng in ("philox", "sobol"):
        lines.append(f"| {rng} | " + " | ".join(f"{rate[(rng, n)]:.0f}" for n in COUNTS) + " |")
    flags = cpu_flags()
    simd = ", ".join(f for f in ("avx2", "avx512f") if f in flags)
    text = (f"M samples/s (median of {args.rounds} interleaved rounds), GGX albedo, 256 alpha x 64 mu "
            f"points, estimator brdf, single precision (W={m.width}), device {m.device.info.name}.\n\n"
            + "\n".join(lines) + "\n\n"
            f"Machine: {cpu_model()} ({simd}), {mem_total_gib():.1f} GiB; clbrdf commit {git_commit()}.\n")
    print(text)
    if args.write:
        date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
        section = (f"{BEGIN}\n## Throughput against samples per point (`benchmarks/bench_sample_counts.py`)\n\n"
                   f"Date: {date}. Command: `python benchmarks/bench_sample_counts.py --write`\n\n{text}{END}")
        write_section(BEGIN, END, section)


if __name__ == "__main__":
    main()
