"""The albedo kernels' throughput by work-group size on a CPU device, side by side in one run:
PoCL compiles a kernel once per local size, so clbrdf gives each kernel one size on a CPU
(``clbrdf.runtime.launch.ndrange``: 1 for the albedo, walk and LTC kernels). This measures what
that costs against the earlier rule (1 below 256 work-items a compute unit, else 64) and fixed
sizes 8 and 64: GGX alpha 0.3, single precision, at 1, 64 and 4096 points, brdf with Philox and
mis with Sobol points; medians of ``--rounds`` after a warm-up, M samples/s (wall) and per
CPU-second.

    python benchmarks/bench_local_size.py [--rounds 5]
"""
import argparse
import os
import statistics
import time

import numpy as np

import clbrdf
from clbrdf.runtime import albedo as driver, launch

CASES = ((1, 1 << 22), (64, 1 << 20), (4096, 1 << 14))     # (points, samples a point)


def earlier_rule(items, device):
    """The local size before: 64 from 4 * 64 work-items a compute unit, else 1."""
    return launch.ndrange_with(items, (64,) if items >= 256 * device.info.compute_units else (1,))


def rules():
    fixed = {f"{n}": (lambda n: lambda items, dev, heavy=True: launch.ndrange_with(items, (n,)))(n)
             for n in (1, 8, 64)}
    return {"earlier (1 or 64)": lambda items, dev, heavy=True: earlier_rule(items, dev),
            **fixed}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args()
    m = clbrdf.Model("ggx", alpha=0.3)
    print(f"device {m.device.info.name}, width {m.width}, {os.cpu_count()} CPUs\n")
    print("| estimator | points x samples | " + " | ".join(f"local {k}" for k in rules()) + " |")
    print("|---|---|" + "---|" * len(rules()))
    for est, qmc in (("brdf", False), ("mis", True)):
        for npts, n in CASES:
            mu = np.linspace(0.1, 1, npts)
            row = []
            for rule in rules().values():
                driver.ndrange = rule
                clbrdf.albedo(m, mu, samples=n, estimator=est, qmc=qmc)        # compile, warm
                wall, cpu = [], []
                for _ in range(a.rounds):
                    t, c = time.perf_counter(), time.process_time()
                    clbrdf.albedo(m, mu, samples=n, estimator=est, qmc=qmc)
                    wall.append(time.perf_counter() - t)
                    cpu.append(time.process_time() - c)
                total = npts * n / 1e6
                row.append(f"{total / statistics.median(wall):.0f} "
                           f"({total / statistics.median(cpu):.0f}/CPU-s)")
            print(f"| {est}{' + qmc' if qmc else ''} | {npts} x 2^{n.bit_length() - 1} | "
                  + " | ".join(row) + " |")
    driver.ndrange = launch.ndrange


if __name__ == "__main__":
    main()
