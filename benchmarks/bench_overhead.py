"""Per-call overhead and build time of small kernel calls, side by side for several checkouts;
with --startup, the command line's start instead.

    python benchmarks/bench_overhead.py --env old=/path/to/old/venv/bin/python \
        --env new=.venv/bin/python [--rounds 3]
    python benchmarks/bench_overhead.py --startup --env old=... --env new=... [--rounds 9]

--startup: the wall time of commands that answer at once (``clbrdf --version``, ``clbrdf
models``, a bad ``--out``, an unknown model), each environment's interpreter running
``clbrdf.cli.main`` in a fresh process, alternating environments, median of the rounds; then
each environment's slowest imports of ``--version`` (``python -X importtime``, cumulative).

Each environment's interpreter runs the same probe in a subprocess (alternating environments,
``--rounds`` times): for each model, the program's source size and the number of tables it
reads, the first ``eval`` call with an empty PoCL cache (source assembly + compilation + the
call), and the median of 200 ``eval`` calls of 4 direction pairs afterwards (assembly, cache
lookups, buffers, launch). Medians over rounds and the ratio of the first environment to each
other one are printed as a Markdown table; results in benchmarks/RESULTS.md.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

MODELS = ("ggx", "gtr", "sgd", "exppow", "sgd_bagher")

PROBE = r"""
import json, os, sys, time
import numpy as np
t0 = time.perf_counter()
import clbrdf
from clbrdf.runtime import build
out = {"import_s": time.perf_counter() - t0}
wo = np.array([[0.0, 0.6, 0.8]] * 4); wi = np.array([[0.0, -0.6, 0.8]] * 4)
for name in sys.argv[1].split(","):
    m = clbrdf.Model(name)
    src = build.program_source(m.config, m.precision, m.width)
    text = src[0] if isinstance(src, tuple) else src
    t = time.perf_counter(); m.eval(wo, wi); first = time.perf_counter() - t
    calls = []
    for _ in range(200):
        t = time.perf_counter(); m.eval(wo, wi); calls.append(time.perf_counter() - t)
    calls.sort()
    out[name] = {"source_kB": len(text) / 1024, "first_s": first, "call_ms": 1e3 * calls[100]}
print(json.dumps(out))
"""


def run(python, models):
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, POCL_CACHE_DIR=cache)
        r = subprocess.run([python, "-c", PROBE, ",".join(models)], capture_output=True,
                           text=True, env=env, cwd=tempfile.gettempdir())
    if r.returncode:
        raise SystemExit(f"{python}: {r.stderr[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


COMMANDS = (("--version",), ("models",),
            ("table", "ggx", "--axis", "mu=0.1:1:4", "--out", "/nonexistent/t.npz"),
            ("table", "nosuch", "--axis", "mu=0.1:1:4", "--out", "t.npz"))
START = "import sys; from clbrdf.cli import main; sys.exit(main(sys.argv[1:]))"


def startup(envs, rounds):
    import time
    walls = {(n, c): [] for n, _ in envs for c in COMMANDS}
    for _ in range(rounds):
        for c in COMMANDS:
            for name, py in envs:
                t = time.perf_counter()
                subprocess.run([py, "-c", START, *c], capture_output=True,
                               cwd=tempfile.gettempdir())
                walls[name, c].append(time.perf_counter() - t)
    print(f"| command | {' | '.join(f'{n}: wall s' for n, _ in envs)} |")
    print("|---|" + "---|" * len(envs))
    for c in COMMANDS:
        print(f"| `clbrdf {' '.join(c)}` | "
              + " | ".join(f"{statistics.median(walls[n, c]):.3f}" for n, _ in envs) + " |")
    for name, py in envs:
        r = subprocess.run([py, "-X", "importtime", "-c", START, "--version"],
                           capture_output=True, text=True, cwd=tempfile.gettempdir())
        rows = []
        for line in r.stderr.splitlines():
            parts = line.split("|")
            if len(parts) == 3 and parts[1].strip().isdigit():
                rows.append((int(parts[1]), parts[2].strip()))
        top = sorted(rows, reverse=True)[:8]
        print(f"\n{name}: slowest imports of --version (cumulative ms): "
              + ", ".join(f"{m} {us / 1e3:.0f}" for us, m in top))
    print(f"\n{rounds} rounds, medians; machine: {os.cpu_count()} CPUs, {sys.platform}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--env", action="append", required=True, help="NAME=PYTHON")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--startup", action="store_true", help="time the command line's start")
    a = ap.parse_args()
    envs = [e.split("=", 1) for e in a.env]
    if a.startup:
        return startup(envs, a.rounds)
    models = a.models.split(",")
    res = {name: [] for name, _ in envs}
    for _ in range(a.rounds):
        for name, py in envs:
            res[name].append(run(py, models))
    med = {name: {m: {k: statistics.median(r[m][k] for r in rs) for k in rs[0][m]} for m in models}
           for name, rs in res.items()}
    base = envs[0][0]
    ratio_head = (f" call ratio {base} / {' / '.join(n for n, _ in envs[1:])} |"
                  if len(envs) > 1 else "")
    print(f"| model | {' | '.join(f'{n}: source kB, first call s, call ms' for n, _ in envs)} |"
          + ratio_head)
    print("|---|" + "---|" * (len(envs) + (len(envs) > 1)))
    for m in models:
        cells = [f"{med[n][m]['source_kB']:.0f}, {med[n][m]['first_s']:.2f}, {med[n][m]['call_ms']:.3f}"
                 for n, _ in envs]
        ratios = [f"{med[base][m]['call_ms'] / med[n][m]['call_ms']:.1f}" for n, _ in envs[1:]]
        print(f"| {m} | {' | '.join(cells)} |" + (f" {' / '.join(ratios)} |" if ratios else ""))
    print(f"\n{a.rounds} rounds, medians; machine: {os.cpu_count()} CPUs, {sys.platform}")


if __name__ == "__main__":
    main()
