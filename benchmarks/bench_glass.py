#!/usr/bin/env python3
"""Rough-glass directional-albedo throughput: clbrdf's ggx_dielectric against its own GGX
reflection and against Mitsuba 3's roughdielectric, sampled the same way.

The job: E(mu) = E_R + E_T = integral f(wo, wi) |cos(theta_i)| dwi over the sphere for GGX glass
(relative index eta, isotropic alpha, importance transport: no 1/eta^2) at P values of mu, by
sampling visible normals and choosing reflection with probability F(wo.h): every sample's
estimate is G2 / G1(wo) (0 where the chosen direction lands on the wrong side).

Rows (interleaved rounds, medians, as benchmarks/bench_albedo.py):
  clbrdf-ggx          clbrdf.albedo(Model('ggx', alpha)), brdf, single: the reflection job of
                      bench_albedo.py at the same alpha and mu, the cost to compare glass with
  clbrdf-glass        Model('ggx_dielectric', alpha, eta), brdf, single (height-correlated G)
  clbrdf-glass-sep    the same with masking='separable' (Mitsuba's G: like with like)
  clbrdf-glass-qmc    the same as clbrdf-glass with Sobol points (16 scrambles)
  clbrdf-glass-f64    the same in double precision
  mitsuba             Mitsuba 3 llvm_ad_rgb, roughdielectric (GGX, sample_visible, int_ior eta),
                      BSDF.sample in TransportMode.Importance, the first channel of its weight:
                      Mitsuba's separable Smith G, so it is compared with clbrdf-glass-sep

    python benchmarks/bench_glass.py [--write] [--quick]
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
from bench_albedo import (  # noqa: E402
    ClbrdfRow,
    MitsubaRow,
    Row,
    fmt_n,
    machine_info,
    median,
)
from results import write_section  # noqa: E402

BEGIN = "<!-- bench_glass:begin -->"
END = "<!-- bench_glass:end -->"
MITSUBA_CHUNK = 1 << 22


class GlassRow(ClbrdfRow):
    def __init__(self, mus, samples, alpha, eta, key, label, masking="correlated", **kw):
        super().__init__(mus, samples, alpha, key, label, model="ggx_dielectric", **kw)
        self.eta, self.masking = eta, masking
        self.same_estimator = True

    def prepare(self):
        import clbrdf
        self.clbrdf = clbrdf
        kw = {} if self.width is None else {"width": self.width}
        self.model = clbrdf.Model("ggx_dielectric", alpha=self.alpha, eta=self.eta,
                                  masking=self.masking, precision=self.precision,
                                  device=self.device, **kw)
        t = time.perf_counter()
        self.model.program(part="albedo", estimator=self.estimator,
                           rng="sobol" if self.qmc else "philox")
        self.compile_s = time.perf_counter() - t
        self.label += f" (W={self.model.width})"


class MitsubaGlassRow(Row):
    group = "mitsuba"
    key = "mitsuba"
    masking = "separable"

    def __init__(self, mus, samples, alpha, eta):
        super().__init__(mus, samples)
        self.alpha, self.eta = alpha, eta
        self.label = "Mitsuba 3 llvm_ad_rgb, roughdielectric"

    def prepare(self):
        import numpy as np
        self.mi, self.dr = MitsubaRow.load()
        mi = self.mi
        self.bsdf = mi.load_dict({"type": "roughdielectric", "distribution": "ggx",
                                  "alpha": float(self.alpha), "int_ior": float(self.eta),
                                  "ext_ior": 1.0, "sample_visible": True})
        self.sampler = mi.load_dict({"type": "independent"})
        self.ctx = mi.BSDFContext(mi.TransportMode.Importance)
        self.mu_np = np.asarray(self.mus, dtype=np.float32)
        self.label = f"Mitsuba {mi.__version__} llvm_ad_rgb, roughdielectric ({self.dr.thread_count()} threads)"

    def _launch(self, p0, k, N, seed):
        mi, dr = self.mi, self.dr
        mu_arr = mi.Float(self.mu_np[p0:p0 + k])
        idx = dr.arange(mi.UInt32, k * N)
        mu = dr.gather(mi.Float, mu_arr, idx // N)
        self.sampler.seed(seed + p0, k * N)
        s1, s2 = self.sampler.next_1d(), self.sampler.next_2d()
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(dr.safe_sqrt(1 - mu * mu), 0, mu)
        _, w = self.bsdf.sample(self.ctx, si, s1, s2)
        w = w[0]
        b = min(N, 1024)
        a = dr.block_reduce(dr.ReduceOp.Add, w, b)
        q = dr.block_reduce(dr.ReduceOp.Add, w * w, b)
        dr.eval(a, q)
        return (a.numpy().astype("f8").reshape(k, -1).sum(axis=1),
                q.numpy().astype("f8").reshape(k, -1).sum(axis=1))

    def run(self):
        import numpy as np
        P, N = len(self.mus), self.samples
        k = min(P, max(1, MITSUBA_CHUNK // N))
        s1, s2 = np.zeros(P), np.zeros(P)
        for p0 in range(0, P, k):
            kk = min(k, P - p0)
            a, b = self._launch(p0 - (k - kk), k, N, 9000)
            s1[p0:p0 + kk], s2[p0:p0 + kk] = a[k - kk:], b[k - kk:]
        est = s1 / N
        var = np.maximum(s2 / N - est * est, 0) * N / (N - 1)
        return est, np.sqrt(var / N)


def references(mus, alpha, eta):
    """E(mu) by clbrdf.ref.dielectric's quadrature (double), correlated and separable."""
    import numpy as np
    from clbrdf.ref import reference
    out = {}
    for masking in ("correlated", "separable"):
        r = reference("ggx_dielectric", alpha=alpha, eta=eta, masking=masking)
        out[masking] = np.array([r.albedo(float(m), tol=1e-7)[0] for m in mus])
    return out


def report(args, rows, refs, info, skipped):
    import numpy as np
    by = {r.key: r for r in rows}
    L = [f"GGX glass (E_R + E_T, importance), alpha = {args.alpha}, eta = {args.eta}, "
         f"{args.points} values of mu = linspace(1/{args.points}, 1, {args.points}), phi = 0; "
         f"{args.rounds} interleaved rounds after one warm-up call per row; GGX reflection "
         f"(F = 1) at the same alpha and mu for the cost ratio.", "",
         "| row | samples per call | M samples/s (median) | range over rounds | "
         "M samples per CPU-s (median) | CPU-s / wall-s | first call s | compile s |",
         "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        rt = r.rates()
        comp = f"{r.compile_s:.2f}" if r.compile_s is not None else "-"
        L.append(f"| **{r.key}**: {r.label} | {fmt_n(len(r.mus), r.samples)} | {median(rt):.1f} | "
                 f"{min(rt):.1f} - {max(rt):.1f} | {median(r.cpu_rates()):.1f} | "
                 f"{median([c / t for c, t in zip(r.cpu, r.times)]):.2f} | {r.first_s:.2f} | {comp} |")
    for k, why in skipped:
        L.append(f"| **{k}** | skipped: {why} | | | | | | |")
    L += ["", "Ratios (median throughput / median throughput; range of the per-round ratios):", ""]

    def ratio(a, b):
        per = [x / y for x, y in zip(a.rates(), b.rates())]
        return median(a.rates()) / median(b.rates()), min(per), max(per), \
            median(a.cpu_rates()) / median(b.cpu_rates())
    q = ratio(by["clbrdf-ggx"], by["clbrdf-glass"])
    L.append(f"- cost of glass: clbrdf-ggx / clbrdf-glass: **{q[0]:.2f}x** ({q[1]:.2f} - {q[2]:.2f}); "
             f"per CPU-second {q[3]:.2f}x (target: at most 1.5x)")
    if "mitsuba" in by:
        q = ratio(by["clbrdf-glass-sep"], by["mitsuba"])
        L.append(f"- clbrdf-glass-sep / mitsuba (the same BSDF and masking): **{q[0]:.1f}x** "
                 f"({q[1]:.1f} - {q[2]:.1f}); per CPU-second {q[3]:.1f}x")
    for k in ("clbrdf-glass-qmc", "clbrdf-glass-f64"):
        if k in by:
            q = ratio(by["clbrdf-glass"], by[k])
            L.append(f"- clbrdf-glass / {k}: {q[0]:.1f}x ({q[1]:.1f} - {q[2]:.1f})")
    L += ["", "Agreement of the warm-up estimates with clbrdf.ref.dielectric's quadrature (double) "
          "of the same masking (z = difference / stderr per mu; independent seeds):", "",
          "| row | masking | mean of E over the mu | max abs z vs reference | mean z^2 |",
          "|---|---|---|---|---|"]
    for r in rows:
        masking = getattr(r, "masking", None)
        if masking is None or r.est is None:
            continue
        z = (r.est - refs[masking]) / np.maximum(r.err, 1e-300)
        L.append(f"| {r.key} | {masking} | {float(np.mean(r.est)):.6f} | "
                 f"{float(np.max(np.abs(z))):.2f} | {float(np.mean(z * z)):.2f} |")
    for masking, v in refs.items():
        L.append(f"| clbrdf.ref.dielectric | {masking} | {float(np.mean(v)):.6f} | - | - |")
    L += ["", "Machine and software:", ""] + [f"- {k}: {v}" for k, v in info.items()]
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--alpha", type=float, default=0.5)
    ap.add_argument("--eta", type=float, default=1.5)
    ap.add_argument("--points", type=int, default=64)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--log2-samples", type=int, default=21)
    ap.add_argument("--log2-double", type=int, default=19)
    ap.add_argument("--log2-mitsuba", type=int, default=19)
    ap.add_argument("--quick", action="store_true", help="small job, 2 rounds (a smoke test)")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--pocl-cache", action="store_true")
    ap.add_argument("--device", default=None)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args(argv)
    if args.quick:
        args.rounds, args.log2_samples, args.log2_double, args.log2_mitsuba = 2, 15, 14, 14
        args.points = 16
    if not args.pocl_cache:
        os.environ["POCL_KERNEL_CACHE"] = "0"
    command = "python " + " ".join(shlex.quote(a) for a in [os.path.relpath(__file__)] + sys.argv[1:])
    date = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    import numpy as np
    mus = np.linspace(1.0 / args.points, 1.0, args.points)
    A, E, S = args.alpha, args.eta, 1 << args.log2_samples
    rows = [
        ClbrdfRow(mus, S, A, "clbrdf-ggx", "clbrdf GGX reflection brdf, single", device=args.device),
        GlassRow(mus, S, A, E, "clbrdf-glass", "clbrdf ggx_dielectric brdf, single",
                 device=args.device, seed=1),
        GlassRow(mus, S, A, E, "clbrdf-glass-sep", "clbrdf ggx_dielectric separable, single",
                 masking="separable", device=args.device, seed=2),
        GlassRow(mus, S, A, E, "clbrdf-glass-qmc", "clbrdf ggx_dielectric brdf, single, qmc",
                 qmc=True, device=args.device, seed=3),
        GlassRow(mus, 1 << args.log2_double, A, E, "clbrdf-glass-f64",
                 "clbrdf ggx_dielectric brdf, double", precision="double", device=args.device,
                 seed=4),
    ]
    skipped, versions = [], "not used (--no-mitsuba)"
    if not args.no_mitsuba:
        try:
            mi, dr = MitsubaRow.load()
            versions = (f"{mi.__version__} (drjit {dr.__version__}, variant llvm_ad_rgb, "
                        f"DRJIT_LIBLLVM_PATH={os.environ.get('DRJIT_LIBLLVM_PATH', 'unset')})")
            rows.append(MitsubaGlassRow(mus, 1 << args.log2_mitsuba, A, E))
        except Exception as e:
            why = f"not importable: {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
            skipped.append(("mitsuba", why))
            versions = why
    for r in list(rows):
        try:
            r.prepare()
            t = time.perf_counter()
            r.est, r.err = r.run()
            r.first_s = time.perf_counter() - t
        except Exception as e:
            if r.group != "mitsuba":
                raise
            rows.remove(r)
            skipped.append((r.key, f"failed: {type(e).__name__}: {e}"))
            continue
        print(f"warm-up {r.key:18s} {r.first_s:7.2f} s", file=sys.stderr)
    for k in range(args.rounds):
        order = rows[k % len(rows):] + rows[:k % len(rows)]
        for r in order:
            t, c = time.perf_counter(), time.process_time()
            r.run()
            r.times.append(time.perf_counter() - t)
            r.cpu.append(time.process_time() - c)
        print(f"round {k + 1}/{args.rounds}: " + ", ".join(
            f"{r.key} {r.total / r.times[-1] / 1e6:.0f}" for r in rows) + " M/s", file=sys.stderr)
    refs = references(mus, A, E)
    text = report(args, rows, refs, machine_info(args, rows, versions), skipped)
    print(text)
    if args.write:
        write_section(BEGIN, END, f"{BEGIN}\n## Rough glass albedo throughput "
                      f"(`benchmarks/bench_glass.py`)\n\nDate: {date}. Command: `{command}`\n\n"
                      f"{text}\n{END}\n")


if __name__ == "__main__":
    main()
