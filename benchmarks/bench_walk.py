#!/usr/bin/env python3
"""Random-walk throughput (Heitz et al. 2016's multiple-scattering BSDF, kernels/heitz_ms.h)
side by side with single scattering, in one run.

The job: E(mu) at P values of mu, one point each, GGX alpha (default 0.5), F = 1 unless said:
  ss-ggx        clbrdf.albedo(Model('ggx', alpha)), brdf (visible normals), single: the
                single-scattering albedo the walk's first order equals
  walk-ggx      clbrdf.walk_albedo(Model('ggx', alpha)), single: walks per second and hits
                (scattering events) per second
  walk-gold     the same with the gold preset (RGB conductor Fresnel at each hit)
  walk-glass    ggx_dielectric, eta 1.5, masking='beta' (the dielectric walk: reflection or
                refraction at each hit)
  walk-f64      walk-ggx in double precision
  walk-beckmann walk-ggx with Beckmann (rejection for the visible normals below the horizon)
  eval-ggx      clbrdf.walk_eval(Model('ggx', alpha)), single: the stochastic evaluation at
                (wo, wi) pairs (wo at each mu, wi its mirror direction turned by 90 degrees),
                walks per second (a walk adds its next-event estimate at every hit)
  numpy-walk    clbrdf.ref.heitz_ms.walk (float64 NumPy, one process), fewer walks
Interleaved rounds after one warm-up call per row; medians and ranges; per CPU-second.

    python benchmarks/bench_walk.py [--write] [--quick]
"""
from __future__ import annotations

import argparse
import datetime as _dt
import os
import shlex
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_albedo import fmt_n, machine_info, median  # noqa: E402
from results import write_section  # noqa: E402

BEGIN = "<!-- bench_walk:begin -->"
END = "<!-- bench_walk:end -->"


def rows(args):
    import numpy as np
    import clbrdf
    from clbrdf.ref import heitz_ms as H
    mus = np.linspace(1 / args.points, 1, args.points)
    n, nw = 1 << args.log2_samples, 1 << args.log2_walks
    a = args.alpha
    ggx = clbrdf.Model("ggx", alpha=a, device=args.device)
    gold = clbrdf.Model("ggx", alpha=a, preset="gold", device=args.device)
    glass = clbrdf.Model("ggx_dielectric", alpha=a, eta=1.5, masking="beta", device=args.device)
    f64 = clbrdf.Model("ggx", alpha=a, precision="double", device=args.device)
    bk = clbrdf.Model("beckmann", alpha=a, device=args.device)
    st = np.sqrt(1 - mus * mus)
    wo = np.stack([st, 0 * st, mus], -1)
    wi = np.stack([0 * st, st, mus], -1)

    def ss():
        r = clbrdf.albedo(ggx, mus, samples=n)
        return len(mus) * n, None, r.albedo

    def walk(m):
        def fn():
            r = clbrdf.walk_albedo(m, mus, walks=nw)
            return len(mus) * nw, float(np.sum(r.mean_hits) * nw), r
        return fn

    def ev():
        r = clbrdf.walk_eval(ggx, wo, wi, walks=nw)
        return len(mus) * nw, float(np.sum(r.mean_hits) * nw), None

    def ref():
        k = 1 << args.log2_numpy
        hits = 0
        for mu in mus[:: max(1, len(mus) // 8)]:
            s = np.sqrt(1 - mu * mu)
            hits += H.walk(np.array([s, 0, mu]), k, alpha_x=a)[2].sum()
        return len(mus[:: max(1, len(mus) // 8)]) * k, float(hits), None
    return mus, [("ss-ggx", "clbrdf.albedo, ggx, brdf (VNDF), single", len(mus), n, ss),
                 ("walk-ggx", "clbrdf.walk_albedo, ggx (F = 1), single", len(mus), nw, walk(ggx)),
                 ("walk-gold", "clbrdf.walk_albedo, ggx, gold preset (RGB conductor), single",
                  len(mus), nw, walk(gold)),
                 ("walk-glass", "clbrdf.walk_albedo, ggx_dielectric eta 1.5, masking=beta, single",
                  len(mus), nw, walk(glass)),
                 ("walk-f64", "clbrdf.walk_albedo, ggx (F = 1), double", len(mus), nw, walk(f64)),
                 ("walk-beckmann", "clbrdf.walk_albedo, beckmann (F = 1), single", len(mus), nw,
                  walk(bk)),
                 ("eval-ggx", "clbrdf.walk_eval, ggx (F = 1), single", len(mus), nw, ev),
                 ("numpy-walk", "clbrdf.ref.heitz_ms.walk, float64 NumPy", 8, 1 << args.log2_numpy,
                  ref)]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument("--points", type=int, default=32)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--log2-samples", type=int, default=21)
    ap.add_argument("--log2-walks", type=int, default=18)
    ap.add_argument("--log2-numpy", type=int, default=16)
    ap.add_argument("--quick", action="store_true", help="small job, 2 rounds (a smoke test)")
    ap.add_argument("--device", default=None)
    ap.add_argument("--pocl-cache", action="store_true")
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args(argv)
    if args.quick:
        args.rounds, args.points = 2, 8
        args.log2_samples, args.log2_walks, args.log2_numpy = 16, 13, 12
    if not args.pocl_cache:
        os.environ.setdefault("POCL_KERNEL_CACHE", "0")
    mus, table = rows(args)
    stats = {}
    for key, label, pts, per, fn in table:             # warm-up (compiles)
        t = time.perf_counter()
        out = fn()
        stats[key] = {"first": time.perf_counter() - t, "wall": [], "cpu": [], "n": out[0],
                      "hits": out[1], "res": out[2]}
    for _ in range(args.rounds):
        for key, label, pts, per, fn in table:
            t, c = time.perf_counter(), time.process_time()
            fn()
            stats[key]["wall"].append(time.perf_counter() - t)
            stats[key]["cpu"].append(time.process_time() - c)
    import numpy as np
    L = [f"GGX alpha = {args.alpha}, {args.points} values of mu = linspace(1/{args.points}, 1, "
         f"{args.points}), phi = 0; {args.rounds} interleaved rounds after one warm-up call per "
         f"row. A walk is one sample of the multiple-scattering BSDF (several hits); ss-ggx's "
         f"unit is one single-scattering sample.", "",
         "| row | samples per call | M samples/s (median) | range over rounds | M samples per CPU-s "
         "| M hits/s | mean hits per walk | first call s |", "|---|---|---|---|---|---|---|---|"]
    for key, label, pts, per, fn in table:
        s = stats[key]
        rates = [s["n"] / w / 1e6 for w in s["wall"]]
        cpu = [s["n"] / max(c, 1e-9) / 1e6 for c in s["cpu"]]
        hr = f"{s['hits'] / median(s['wall']) / 1e6:.1f}" if s["hits"] else "-"
        mh = f"{s['hits'] / s['n']:.2f}" if s["hits"] else "1"
        L.append(f"| **{key}**: {label} | {fmt_n(pts, per)} | {median(rates):.2f} | "
                 f"{min(rates):.2f} - {max(rates):.2f} | {median(cpu):.2f} | {hr} | {mh} | "
                 f"{s['first']:.2f} |")
    base = stats["ss-ggx"]["n"] / median(stats["ss-ggx"]["wall"])
    L += ["", "Ratios (median samples/s of ss-ggx over the row's):", ""]
    for key, *_ in table[1:]:
        s = stats[key]
        L.append(f"- ss-ggx / {key}: {base / (s['n'] / median(s['wall'])):.1f}x")
    r = stats["walk-ggx"]["res"]
    ss = stats["ss-ggx"]["res"]
    z = (r.orders[:, 0] - ss) / np.hypot(r.orders_stderr[:, 0], 1e-12)
    L += ["", f"Check: walk-ggx's first order against ss-ggx's E: max |difference| "
          f"{float(np.max(np.abs(r.orders[:, 0] - ss))):.2g} (walk stderr up to "
          f"{float(np.max(r.orders_stderr[:, 0])):.2g}); walk-ggx's E = 1 at every mu: "
          f"{bool(np.all(r.albedo == 1))}; cut at max_order {r.max_order}: "
          f"{float(np.max(r.cut)):.2g}.", "",
          "Machine and software:", ""]
    info = machine_info(argparse.Namespace(device=args.device, pocl_cache=args.pocl_cache), [], "not used")
    info.pop("mitsuba", None)
    L += [f"- {k}: {v}" for k, v in info.items()]
    text = "\n".join(L)
    print(text)
    if args.write:
        cmd = "python benchmarks/bench_walk.py " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))
        section = (f"{BEGIN}\n## Random walk against single scattering (`benchmarks/bench_walk.py`)\n\n"
                   f"Date: {_dt.date.today()}. Command: `{cmd.strip()}`\n\n{text}\n{END}\n")
        write_section(BEGIN, END, section)
    del z
    return 0


if __name__ == "__main__":
    sys.exit(main())
