#!/usr/bin/env python3
"""The C API's speed beside the Python package's, on the same job: GGX (alpha 0.3) directional
albedo at mu 0.5 by BRDF sampling with Philox numbers, 2^24 samples, the same samples everywhere
(clbrdf_random2). Rows: examples/c99_albedo.c (one thread; gcc -O2, and -O3 -march=native),
examples/opencl_albedo.c (the C API in a scalar OpenCL kernel on the default device) and
clbrdf.albedo at width 1 and at the default width. Medians of --rounds runs, in M samples per
wall second and per CPU second (these machines are shared), and each row's ratio to the
package's default.

    python benchmarks/bench_capi.py [--rounds 5] [--write]
"""
import argparse
import datetime as _dt
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results import timed, write_section  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- bench_capi:begin -->", "<!-- bench_capi:end -->"
N, ALPHA, MU, SEED = 1 << 24, 0.3, 0.5, 7


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--write", action="store_true")
    a = ap.parse_args()
    import clbrdf
    k = ROOT / "kernels"
    rows = []
    with tempfile.TemporaryDirectory() as d:
        exe = {}
        for tag, flags in (("-O2", ["-O2"]), ("-O3 -march=native", ["-O3", "-march=native"])):
            exe[tag] = Path(d) / f"c99{len(exe)}"
            subprocess.run(["gcc", "-std=c99", *flags, f"-I{k}", str(ROOT / "examples" / "c99_albedo.c"),
                            "-lm", "-o", str(exe[tag])], check=True)
        ocl = Path(d) / "ocl"
        subprocess.run(["gcc", "-std=c99", "-O2", str(ROOT / "examples" / "opencl_albedo.c"),
                        "-lOpenCL", "-lm", "-o", str(ocl)], check=True)
        args = [str(ALPHA), str(MU), str(N), str(SEED)]

        def prog(cmd):
            return lambda: float(subprocess.run(cmd, capture_output=True, text=True,
                                                check=True).stdout.split()[0])
        jobs = [(f"C99, gcc {t}, 1 thread (examples/c99_albedo.c)", prog([str(e), *args]))
                for t, e in exe.items()]
        jobs.append(("C API in an OpenCL kernel, scalar (examples/opencl_albedo.c)",
                     prog([str(ocl), str(k), *args])))
        for w in (1, None):
            m = clbrdf.Model("ggx", alpha=ALPHA, width=w)
            clbrdf.albedo(m, MU, samples=1024, estimator="brdf", seed=SEED)        # build
            jobs.append((f"clbrdf.albedo, width {m.width}",
                         lambda m=m: float(clbrdf.albedo(m, MU, samples=N, estimator="brdf",
                                                         seed=SEED).albedo)))
        for label, fn in jobs:
            fn()                                    # warm: the OpenCL program's build
            w, c, e = timed(fn, a.rounds, children=True)
            rows.append((label, w, c, e))
            print(f"{label:62s} {N / w / 1e6:8.1f} M/s wall {N / c / 1e6:8.1f} M/CPU-s  E {e:.9f}",
                  flush=True)
    base = rows[-1]
    dev = clbrdf.get_device().info
    text = [BEGIN, "## The C API beside the package (`benchmarks/bench_capi.py`)", "",
            f"Measured {_dt.date.today()} on {platform.processor() or platform.machine()} "
            f"({dev.name}; {dev.platform}), {os.cpu_count()} cores. GGX alpha {ALPHA}, mu {MU}, "
            f"brdf sampling with Philox, {N} samples, the same samples in every row "
            f"(clbrdf_random2); median of {a.rounds} runs (programs: wall and CPU time of the "
            f"process, start-up and, for OpenCL, the kernel build included). Ratio: to the "
            f"package at its default width, per CPU second. "
            f"Run: `python benchmarks/bench_capi.py --write`.", "",
            "| how | M samples / wall s | M samples / CPU s | per CPU s vs package | E |",
            "|---|---:|---:|---:|---:|"]
    for label, w, c, e in rows:
        text.append(f"| {label} | {N / w / 1e6:.1f} | {N / c / 1e6:.1f} | "
                    f"{base[2] / c:.3f} | {e:.9f} |")
    text.append(END)
    if a.write:
        write_section(BEGIN, END, "\n".join(text))
        print("wrote benchmarks/RESULTS.md")


if __name__ == "__main__":
    main()
