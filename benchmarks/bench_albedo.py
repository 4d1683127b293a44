#!/usr/bin/env python3
"""GGX directional-albedo throughput: clbrdf (OpenCL/PoCL) against plain NumPy and Mitsuba 3.

The job: E(mu) = integral f(wi, wo) cos(theta_i) dwi for the GGX microfacet BRDF with F = 1,
height-correlated Smith G and isotropic roughness alpha, at P values of mu = cos(theta_o) in
(0, 1] (phi = 0), by importance sampling of visible normals. Every sample's estimate is

    weight = G2(wi, wo) / G1(wo) = (1 + Lambda_o) / (1 + Lambda_i + Lambda_o)   if wi.z > 0, else 0

with wi = reflect(wo, h) and h drawn from GGX's distribution of visible normals. Throughput is
samples per second of wall time of one whole call (random numbers, estimates and reduction to a
mean and standard error per mu included); also per CPU-second of this process (all threads),
which other jobs on the machine disturb much less.

Rows:
  clbrdf        clbrdf.albedo(Model('ggx', alpha=A), mu, estimator='brdf', samples=N): single
                precision, VNDF sampling by spherical caps (Dupuy & Benyoub 2023), Philox
                random numbers; also estimator='uniform', qmc=True (Owen-scrambled Sobol),
                precision='double' and width=1 (one sample per work-item, scalar code); and
                Beckmann at the same alpha with visible-normal and with normal sampling (another
                integral: not in the agreement table).
  numpy         the same estimator in plain NumPy (same spherical-cap sampler), float32 and
                float64, chunks of 2^20 samples, one process (one core), PCG64 numbers; and
                float32 in chunks of 2^16, which stay in cache (about twice as fast).
  mitsuba       Mitsuba 3, variant llvm_ad_rgb (Dr.Jit LLVM backend, all cores):
                MicrofacetDistribution(GGX, alpha, sample_visible=True).sample gives h (its VNDF
                sampler is Heitz 2018's, a different map from u to h with the same density),
                smith_g1 gives G1 = 1 / (1 + Lambda), from which the height-correlated
                G2 = 1 / (1/G1(wi) + 1/G1(wo) - 1) is formed (Mitsuba's own G() and the
                roughconductor BSDF use the separable G1 G1, a different estimator, so they are
                not used); numbers from its independent sampler (PCG32 seeded by TEA); one
                vectorised computation per 2^24 samples, float32 sums per 1024 samples.

Rounds are interleaved ([all rows] x rounds, the order rotated each round) after a warm-up call
of every row; the table reports the median throughput and its range over the rounds. Compile
time of each clbrdf program (PoCL's on-disk kernel cache disabled unless --pocl-cache) and the
first (warm-up) call of every row are reported separately. The warm-up results are checked
against each other (per-mu z-scores, combined standard errors) and against clbrdf.ref.microfacet's
deterministic double-precision integral.

    python benchmarks/bench_albedo.py                 # print the table
    python benchmarks/bench_albedo.py --write         # also record it in benchmarks/RESULTS.md
    python benchmarks/bench_albedo.py --quick         # small job, 2 rounds: checks that it runs
"""
from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import platform
import resource
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
from results import RESULTS, write_section  # noqa: E402
BEGIN = "<!-- bench_albedo:begin -->"
END = "<!-- bench_albedo:end -->"
LLVM19 = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
NUMPY_CHUNK = 1 << 20          # samples per NumPy chunk
MITSUBA_CHUNK = 1 << 24        # samples per Dr.Jit launch


# --------------------------------------------------------------------------------------------
# machine and load
# --------------------------------------------------------------------------------------------

def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def cpu_flags() -> set:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def mem_total_gib() -> float:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal"):
                return int(line.split()[1]) / 2**20
    except OSError:
        pass
    return float("nan")


def busy_seconds() -> float | None:
    """CPU time (s) all processes of the machine have used since boot (/proc/stat)."""
    try:
        f = Path("/proc/stat").read_text().splitlines()[0].split()
    except OSError:
        return None
    v = [int(x) for x in f[1:]]
    idle = v[3] + (v[4] if len(v) > 4 else 0)          # idle + iowait
    busy = sum(v[:8]) - idle                          # user nice system idle iowait irq softirq steal
    return busy / os.sysconf("SC_CLK_TCK")


def own_cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime + c.ru_utime + c.ru_stime


def git_commit() -> str:
    try:
        root = HERE.parent
        h = subprocess.run(["git", "--no-optional-locks", "rev-parse", "--short", "HEAD"], cwd=root,
                           capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "--no-optional-locks", "status", "--porcelain", "--untracked-files=no",
                                "--", "clbrdf", "kernels"], cwd=root, capture_output=True, text=True,
                               timeout=10).stdout.strip()
        return h + (" (clbrdf/ or kernels/ modified)" if dirty else "") if h else "unknown"
    except Exception:
        return "unknown"


# --------------------------------------------------------------------------------------------
# rows
# --------------------------------------------------------------------------------------------

class Row:
    """One configuration: prepare() (untimed, compiles), run() -> (E per mu, stderr per mu)."""
    key = ""
    label = ""
    group = ""

    def __init__(self, mus, samples):
        self.mus = mus
        self.samples = samples            # per mu
        self.first_s = None               # warm-up call (wall s)
        self.compile_s = None
        self.times = []                   # timed rounds (wall s)
        self.cpu = []                     # timed rounds (CPU s of this process, all threads)
        self.est = self.err = None        # from the warm-up call

    @property
    def total(self) -> int:
        return len(self.mus) * self.samples

    def prepare(self):
        pass

    def run(self):
        raise NotImplementedError

    def rates(self):
        return [self.total / t / 1e6 for t in self.times]

    def cpu_rates(self):
        return [self.total / t / 1e6 for t in self.cpu]


class ClbrdfRow(Row):
    group = "clbrdf"

    def __init__(self, mus, samples, alpha, key, label, estimator="brdf", qmc=False,
                 precision="single", width=None, device=None, seed=0, model="ggx",
                 sampler=None):
        super().__init__(mus, samples)
        self.seed = seed
        self.alpha, self.key, self.label = alpha, key, label
        self.estimator, self.qmc, self.precision, self.width, self.device = \
            estimator, qmc, precision, width, device
        self.model_name, self.sampler = model, sampler
        self.same_estimator = estimator == "brdf" and model == "ggx"

    def prepare(self):
        import clbrdf
        self.clbrdf = clbrdf
        kw = {} if self.width is None else {"width": self.width}
        if self.sampler is not None:
            kw["sampler"] = self.sampler
        self.model = clbrdf.Model(self.model_name, alpha=self.alpha, precision=self.precision,
                                  device=self.device, **kw)
        t = time.perf_counter()
        self.model.program(part="albedo", estimator=self.estimator, rng="sobol" if self.qmc else "philox")
        self.compile_s = time.perf_counter() - t
        self.label += f" (W={self.model.width})"

    def run(self):
        r = self.clbrdf.albedo(self.model, self.mus, estimator=self.estimator, samples=self.samples,
                               seed=self.seed, qmc=self.qmc)
        return r.albedo, r.sampling_stderr     # the spread, comparable with the other rows


class QuadratureRow(ClbrdfRow):
    """estimator='quadrature' at tol: deterministic, so its rate is in points per second."""
    unit = "points"

    def __init__(self, mus, alpha, tol, device=None):
        super().__init__(mus, 1, alpha, "clbrdf-quadrature", f"clbrdf quadrature, single, tol {tol:g}",
                         estimator="quadrature", device=device)
        self.tol, self.same_estimator = tol, False

    def prepare(self):
        import clbrdf
        self.clbrdf = clbrdf
        self.model = clbrdf.Model("ggx", alpha=self.alpha, device=self.device)
        t = time.perf_counter()
        self.model.program(part="quadrature")
        self.compile_s = time.perf_counter() - t
        self.label += f" (W={self.model.width})"

    def run(self):
        r = self.clbrdf.albedo(self.model, self.mus, estimator="quadrature", tol=self.tol)
        self.max_evals = r.samples
        return r.albedo, r.stderr


class NumpyRow(Row):
    """The estimator in plain NumPy, chunked, in-place arithmetic, one process."""
    group = "numpy"
    same_estimator = True

    def __init__(self, mus, samples, alpha, dtype, chunk=NUMPY_CHUNK, key=None):
        super().__init__(mus, samples)
        import numpy as np
        self.np = np
        self.alpha = alpha
        self.chunk = chunk
        self.dtype = np.dtype(dtype)
        bits = 32 if self.dtype == np.float32 else 64
        self.key = key or f"numpy-f{bits}"
        self.label = f"NumPy float{bits}, 1 process, chunks of 2^{int(math.log2(chunk))}"

    def prepare(self):
        np = self.np
        dt = self.dtype
        mu = np.asarray(self.mus, dtype=np.float64)
        a = float(self.alpha)
        # per-mu constants: wo = (sin, 0, mu); stretched ws = normalize(a wo.x, 0, wo.z); Lambda_o
        wox = np.sqrt(np.maximum(0.0, 1 - mu * mu))
        n = np.sqrt((a * wox) ** 2 + mu * mu)
        t = a * a * wox * wox
        lam_o = t / (2 * (mu * mu + mu * np.sqrt(mu * mu + t)))
        self.const = {k: v.astype(dt) for k, v in
                      dict(wox=wox, woz=mu, wsx=a * wox / n, wsz=mu / n, lam_o=lam_o).items()}
        self.a = dt.type(a)

    def _chunk(self, rng, n, c):
        """Weights of n samples; c: per-mu constants, scalars or arrays of length n."""
        np = self.np
        dt = self.dtype
        a = self.a
        u = rng.random((2, n), dtype=dt)
        u0, u1 = u[0], u[1]
        # spherical caps (Dupuy & Benyoub 2023): z uniform in [-ws.z, 1], phi = 2 pi u0
        z = np.subtract(1, u1, out=u1)
        z *= 1 + c["wsz"]
        z -= c["wsz"]
        sin_t = np.multiply(z, z)
        np.subtract(1, sin_t, out=sin_t)
        np.maximum(sin_t, 0, out=sin_t)
        np.sqrt(sin_t, out=sin_t)
        phi = np.multiply(u0, dt.type(2 * math.pi), out=u0)
        hy = np.sin(phi)
        hx = np.cos(phi, out=phi)
        hx *= sin_t
        hx += c["wsx"]
        hx *= a
        hy *= sin_t
        hy *= a
        hz = np.add(z, c["wsz"], out=z)
        np.maximum(hz, 0, out=hz)
        inv = np.multiply(hx, hx, out=sin_t)
        inv += hy * hy
        inv += hz * hz
        np.sqrt(inv, out=inv)
        np.divide(1, inv, out=inv)
        hx *= inv
        hy *= inv
        hz *= inv
        # wi = 2 (wo . h) h - wo (wo.y = 0)
        d = np.multiply(hx, c["wox"])
        d += c["woz"] * hz
        d *= 2
        wix = np.multiply(d, hx, out=hx)
        wix -= c["wox"]
        wiy = np.multiply(d, hy, out=hy)
        wiz = np.multiply(d, hz, out=hz)
        wiz -= c["woz"]
        # Lambda_i = t / (2 (z^2 + z sqrt(z^2 + t))), t = a^2 (x^2 + y^2), z = |wi.z|
        above = wiz > 0
        np.abs(wiz, out=wiz)
        t = np.multiply(wix, wix, out=wix)
        t += np.multiply(wiy, wiy, out=wiy)
        t *= a * a
        z2 = np.multiply(wiz, wiz, out=d)
        s = np.add(z2, t, out=inv)
        np.sqrt(s, out=s)
        s *= wiz
        s += z2
        s *= 2
        lam = np.divide(t, s, out=t)
        # weight = (1 + Lambda_o) / (1 + Lambda_i + Lambda_o) where wi.z > 0
        num = 1 + c["lam_o"]
        lam += num
        w = np.divide(num, lam, out=lam)      # in [0, 1] (0 where wi.z = 0: Lambda_i = inf)
        w *= above
        return w

    def run(self):
        np = self.np
        rng = np.random.default_rng(12345)
        P, N = len(self.mus), self.samples
        s1 = np.zeros(P)
        s2 = np.zeros(P)
        with np.errstate(all="ignore"):
            if N >= self.chunk:                        # one mu at a time, scalar constants
                for p in range(P):
                    c = {k: v[p] for k, v in self.const.items()}
                    for start in range(0, N, self.chunk):
                        n = min(self.chunk, N - start)
                        w = self._chunk(rng, n, c)
                        s1[p] += float(w.sum())
                        s2[p] += float(np.square(w, out=w).sum())
            else:                                      # k mu per chunk, constants repeated
                k = max(1, self.chunk // N)
                for p0 in range(0, P, k):
                    p1 = min(P, p0 + k)
                    c = {key: np.repeat(v[p0:p1], N) for key, v in self.const.items()}
                    w = self._chunk(rng, (p1 - p0) * N, c).reshape(p1 - p0, N)
                    s1[p0:p1] = w.sum(axis=1)
                    s2[p0:p1] = np.square(w, out=w).sum(axis=1)
        est = s1 / N
        var = np.maximum(s2 / N - est * est, 0) * N / (N - 1)
        return est, np.sqrt(var / N)


class MitsubaRow(Row):
    group = "mitsuba"
    key = "mitsuba"
    same_estimator = True

    def __init__(self, mus, samples, alpha):
        super().__init__(mus, samples)
        self.alpha = alpha
        self.label = "Mitsuba 3 llvm_ad_rgb, MicrofacetDistribution + smith_g1"

    @staticmethod
    def load():
        """(mitsuba, drjit) or raise with the reason."""
        if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM19):
            os.environ["DRJIT_LIBLLVM_PATH"] = LLVM19
        import drjit as dr
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
        return mi, dr

    def prepare(self):
        import numpy as np
        self.mi, self.dr = self.load()
        mi = self.mi
        self.md = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, float(self.alpha), True)
        self.sampler = mi.load_dict({"type": "independent"})
        self.mu_np = np.asarray(self.mus, dtype=np.float32)
        self.label = f"Mitsuba {mi.__version__} llvm_ad_rgb ({self.dr.thread_count()} threads)"

    def _launch(self, p0, k, N, seed):
        mi, dr, md = self.mi, self.dr, self.md
        mu_arr = mi.Float(self.mu_np[p0:p0 + k])
        idx = dr.arange(mi.UInt32, k * N)
        mu = dr.gather(mi.Float, mu_arr, idx // N)
        # Mitsuba's independent sampler: PCG32 per lane, seeded with TEA(seed, lane); PCG32 with
        # sequential stream numbers alone (initseq = lane) gives correlated, visibly biased lanes
        self.sampler.seed(seed + p0, k * N)
        u = self.sampler.next_2d()
        wo = mi.Vector3f(dr.safe_sqrt(1 - mu * mu), 0, mu)
        m, _ = md.sample(wo, u)
        wi = 2 * dr.dot(wo, m) * m - wo
        inv_o = dr.rcp(md.smith_g1(wo, m))
        g1i = md.smith_g1(wi, m)
        # G2 / G1(wo) with G2 = 1 / (1/G1(wi) + 1/G1(wo) - 1) (height-correlated Smith)
        w = dr.select((wi.z > 0) & (g1i > 0), inv_o / (dr.rcp(g1i) + inv_o - 1), 0)
        # float32 sums over blocks of 1024 samples (as clbrdf does), added in float64 on the host:
        # one float32 sum over 2^21 samples loses ~1e-3 relative (rounding at large partial sums)
        b = min(N, 1024)
        s1 = dr.block_reduce(dr.ReduceOp.Add, w, b)
        s2 = dr.block_reduce(dr.ReduceOp.Add, w * w, b)
        dr.eval(s1, s2)
        return (s1.numpy().astype("f8").reshape(k, -1).sum(axis=1),
                s2.numpy().astype("f8").reshape(k, -1).sum(axis=1))

    def run(self):
        import numpy as np
        P, N = len(self.mus), self.samples
        if N > MITSUBA_CHUNK:
            raise ValueError("mitsuba samples per mu must be at most 2^24")
        k = min(P, max(1, MITSUBA_CHUNK // N))
        s1, s2 = np.zeros(P), np.zeros(P)
        for p0 in range(0, P, k):
            kk = min(k, P - p0)
            if kk != k:     # a short last launch would be a new kernel: pad to k points
                a, b = self._launch(p0 - (k - kk), k, N, 7000)
                a, b = a[k - kk:], b[k - kk:]
            else:
                a, b = self._launch(p0, k, N, 7000)
            s1[p0:p0 + kk], s2[p0:p0 + kk] = a, b
        est = s1 / N
        var = np.maximum(s2 / N - est * est, 0) * N / (N - 1)
        return est, np.sqrt(var / N)


# --------------------------------------------------------------------------------------------
# report
# --------------------------------------------------------------------------------------------

def fmt_n(points, per):
    lg = math.log2(per)
    per_s = f"2^{int(lg)}" if lg == int(lg) else f"{per}"
    return f"{points} x {per_s} = {points * per / 1e6:.1f} M"


def agreement(rows, ref, ref_row, reference):
    """Lines comparing each row's warm-up estimate with the reference row and the integral."""
    import numpy as np
    out = []
    P = len(ref_row.mus)

    def mean_se(r):
        return float(np.mean(r.est)), float(np.sqrt(np.sum(r.err ** 2)) / P)

    m0, e0 = mean_se(ref_row)
    out.append("| row | mean of E over the mu | its stderr | max abs z vs clbrdf default | "
               "mean z^2 | max abs z vs reference integral |")
    out.append("|---|---|---|---|---|---|")
    for r in rows:
        if r.est is None or getattr(r, "model_name", "ggx") != "ggx":
            continue                    # not computed, or another model's integral
        m, e = mean_se(r)
        if r is ref_row:
            zc = "-"
            chi = "-"
        else:
            z = (r.est - ref_row.est) / np.sqrt(r.err ** 2 + ref_row.err ** 2)
            zc = f"{np.max(np.abs(z)):.2f}"
            chi = f"{np.mean(z * z):.2f}"
        zr = f"{np.max(np.abs((r.est - reference) / r.err)):.2f}" if reference is not None else "n/a"
        tag = "" if getattr(r, "same_estimator", True) else " (other estimator)"
        out.append(f"| {r.key}{tag} | {m:.6f} | {e:.1e} | {zc} | {chi} | {zr} |")
    if reference is not None:
        out.append(f"| clbrdf.ref.microfacet (deterministic, double) | {float(np.mean(reference)):.6f} | - | - | - | - |")
    return out


def median(xs):
    return statistics.median(xs) if xs else float("nan")


def other_devices(args) -> list:
    """Selectors of the --other-device rows: as given, or every other device whose compiler works."""
    if args.other_device is not None:
        return [d for d in args.other_device if d != "none"]
    from clbrdf.runtime.device import compiler_error, get_device, list_devices
    main = get_device(args.device).info.selector
    return [d.selector for d in list_devices() if d.selector != main
            and compiler_error((d.platform_index, d.device_index)) is None]


def build_report(args, rows, info, reference, skipped, load):
    by = {r.key: r for r in rows}
    base = by["clbrdf"]
    L = []
    L.append(f"GGX directional albedo, alpha = {args.alpha}, F = 1, height-correlated Smith G, "
             f"{args.points} values of mu = linspace(1/{args.points}, 1, {args.points}), phi = 0; "
             f"{args.rounds} interleaved rounds after one warm-up call per row.")
    L.append("")
    L.append("| row | samples per call | M samples/s (median) | range over rounds | s per call (median) | "
             "M samples per CPU-s (median) | CPU-s / wall-s | first call s | compile s |")
    L.append("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if getattr(r, "unit", "samples") != "samples":
            continue
        rt = r.rates()
        comp = f"{r.compile_s:.2f}" if r.compile_s is not None else "-"
        L.append(f"| **{r.key}**: {r.label} | {fmt_n(len(r.mus), r.samples)} | {median(rt):.1f} | "
                 f"{min(rt):.1f} - {max(rt):.1f} | {median(r.times):.3f} | {median(r.cpu_rates()):.1f} | "
                 f"{median([c / t for c, t in zip(r.cpu, r.times)]):.2f} | {r.first_s:.2f} | {comp} |")
    for k, why in skipped:
        L.append(f"| **{k}** | skipped: {why} | | | | | | | |")
    L.append("")
    for r in rows:
        if getattr(r, "unit", "samples") == "points":
            rt = r.rates()
            L.append(f"**{r.key}**: {r.label}: {median(rt) * 1e6:.0f} points/s (median; "
                     f"{min(rt) * 1e6:.0f} - {max(rt) * 1e6:.0f} over rounds), "
                     f"{median(r.cpu_rates()) * 1e6:.0f} points per CPU-s, {len(r.mus)} points "
                     f"in {median(r.times):.3f} s, at most {r.max_evals} integrand evaluations "
                     f"per point (deterministic: its 'stderr' below is its error estimate).")
            L.append("")

    def ratio(a, b):
        ra, rb = a.rates(), b.rates()
        per_round = [x / y for x, y in zip(ra, rb)]
        return median(ra) / median(rb), min(per_round), max(per_round)

    L.append("'compile s' is the clbrdf program build (clCreateProgram + build); 'first call s' is the "
             "warm-up call, which for clbrdf also includes PoCL's compilation of the kernel for its "
             "work-group size at the first launch, and for Mitsuba Dr.Jit's tracing and compilation "
             "(its on-disk kernel cache, ~/.drjit, may make that a cache hit). Neither is in the "
             "timed rounds.")
    L.append("")
    L.append("'M samples per CPU-s' divides by the CPU time this process used during the call (all its "
             "threads): the work per core-second, much less sensitive to other jobs than wall time; "
             "'CPU-s / wall-s' is how many cores the row kept busy.")
    L.append("")
    L.append("Ratios (median throughput / median throughput; range of the per-round ratios):")
    L.append("")
    for k in ("numpy-f32", "numpy-f32-small", "numpy-f64", "mitsuba", "clbrdf-w1", "clbrdf-f64",
              "clbrdf-qmc", "clbrdf-uniform", "clbrdf-cosine", "clbrdf-mis", "clbrdf-mis-qmc"):
        if k in by:
            q, lo, hi = ratio(base, by[k])
            qc = median(base.cpu_rates()) / median(by[k].cpu_rates())
            L.append(f"- clbrdf / {k}: **{q:.1f}x** ({lo:.1f} - {hi:.1f}); per CPU-second {qc:.1f}x")
    for r in rows:
        if r.key.startswith("clbrdf@"):
            q, lo, hi = ratio(base, r)
            qc = median(base.cpu_rates()) / median(r.cpu_rates())
            L.append(f"- clbrdf / {r.key} (the same kernel on another device, "
                     f"{r.model.device.info.platform}): **{q:.1f}x** ({lo:.1f} - {hi:.1f}); "
                     f"per CPU-second {qc:.1f}x")
    for k in ("clbrdf-beckmann-vndf", "clbrdf-beckmann-ndf"):
        if k in by:
            q, lo, hi = ratio(base, by[k])
            qc = median(base.cpu_rates()) / median(by[k].cpu_rates())
            L.append(f"- GGX (clbrdf) / Beckmann {k.rsplit('-', 1)[1]} sampling, same estimator "
                     f"and alpha: **{q:.1f}x** ({lo:.1f} - {hi:.1f}); per CPU-second {qc:.1f}x "
                     "(project target: within 2x with visible normals)")
    L.append("")
    rate = median(base.rates())
    ncu = getattr(base, "model", None)
    ncu = ncu.device.info.compute_units if ncu is not None else os.cpu_count()
    L.append("Targets (project): clbrdf default >= 500 M samples/s: "
             f"**{'met' if rate >= 500 else 'NOT met'}** ({rate:.0f}); ")
    np_rows = [by[k] for k in ("numpy-f32", "numpy-f32-small") if k in by]
    if np_rows:
        best = max(np_rows, key=lambda r: median(r.rates()))
        q = ratio(base, best)[0]
        L[-1] += (f">= 8x a single NumPy process (float32, its faster row {best.key}): "
                  f"**{'met' if q >= 8 else 'NOT met'}** ({q:.1f}x). clbrdf ran on {ncu} compute "
                  f"units (PoCL threads) and Mitsuba on all cores, NumPy on one: per CPU-second "
                  f"the clbrdf / {best.key} ratio is "
                  f"{median(base.cpu_rates()) / median(best.cpu_rates()):.1f}x. On an idle machine "
                  f"clbrdf would reach at most about {ncu} x its rate per CPU-second = "
                  f"{ncu * median(base.cpu_rates()):.0f} M samples/s (an estimate, not a measurement).")
    L.append("")
    L.append("Agreement of the warm-up estimates (z = difference / combined stderr per mu; the clbrdf "
             "rows use distinct seeds (0-10), NumPy PCG64 seed 12345, Mitsuba's independent sampler seeds 7000 + first point of each launch, so the estimates are "
             "independent; for equal estimators max |z| over the mu is typically below ~3.5 and mean "
             "z^2 near 1; the qmc row's stderr is the spread of 16 scrambles, the uniform row is "
             "another estimator of the same integral):")
    L.append("")
    L += agreement(rows, None, base, reference)
    L.append("")
    L.append("Machine and software:")
    L.append("")
    for k, v in info.items():
        L.append(f"- {k}: {v}")
    L.append("")
    L.append(load)
    for note in args.note:
        L.append("")
        L.append(f"Note: {note}")
    return "\n".join(L)


def machine_info(args, rows, mitsuba_versions):
    import numpy as np
    info = {}
    flags = cpu_flags()
    simd = [f for f in ("avx2", "avx512f") if f in flags]
    info["CPU"] = f"{cpu_model()} ({', '.join(simd) or 'no avx2'}), {os.cpu_count()} logical cores " \
                  f"({len(os.sched_getaffinity(0))} usable), {mem_total_gib():.1f} GiB memory"
    info["OS / Python"] = f"{platform.platform()}, Python {platform.python_version()}"
    try:
        import clbrdf
        import pyopencl as cl
        d = clbrdf.get_device(args.device)
        cd = d.cl_device
        info["OpenCL"] = (f"{cd.platform.name.strip()} / {cd.platform.version.strip()}; device "
                          f"{cd.name.strip()}, {cd.version.strip()}, driver {cd.driver_version.strip()}, "
                          f"{cd.max_compute_units} compute units; pyopencl {cl.VERSION_TEXT}")
        info["clbrdf"] = f"{clbrdf.__version__}, commit {git_commit()}"
    except Exception as e:  # pragma: no cover
        info["OpenCL"] = f"unavailable: {e}"
    info["PoCL kernel cache"] = ("on (compile times may be cache hits)" if args.pocl_cache
                                 else "off for this run (POCL_KERNEL_CACHE=0: compile times are cold builds)")
    info["numpy"] = np.__version__
    info["mitsuba"] = mitsuba_versions
    return info


def write_results(text, command, date):
    section = f"{BEGIN}\n## GGX directional albedo throughput (`benchmarks/bench_albedo.py`)\n\n" \
              f"Date: {date}. Command: `{command}`\n\n{text}\n{END}\n"
    write_section(BEGIN, END, section)


# --------------------------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--alpha", type=float, default=0.5, help="GGX roughness (default 0.5)")
    ap.add_argument("--points", type=int, default=64, help="values of mu (default 64)")
    ap.add_argument("--rounds", type=int, default=5, help="timed rounds (default 5)")
    ap.add_argument("--log2-samples", type=int, default=22,
                    help="log2 samples per mu for the single-precision clbrdf rows (default 22)")
    ap.add_argument("--log2-double", type=int, default=21, help="... clbrdf double (default 21)")
    ap.add_argument("--log2-width1", type=int, default=19, help="... clbrdf width 1 (default 19)")
    ap.add_argument("--log2-numpy", type=int, default=17, help="... NumPy rows (default 17)")
    ap.add_argument("--log2-numpy-small-chunk", type=int, default=16,
                    help="chunk of the second NumPy float32 row (default 16: fits in cache, faster "
                         "than the 2^20 chunks of the others)")
    ap.add_argument("--log2-mitsuba", type=int, default=21, help="... Mitsuba (default 21)")
    ap.add_argument("--quick", action="store_true", help="small job, 2 rounds (a smoke test)")
    ap.add_argument("--no-mitsuba", action="store_true", help="leave Mitsuba out")
    ap.add_argument("--no-reference", action="store_true",
                    help="skip the deterministic reference integral (about 0.1 s per mu)")
    ap.add_argument("--pocl-cache", action="store_true",
                    help="keep PoCL's on-disk kernel cache (default: off, so compile times are cold)")
    ap.add_argument("--device", default=None, help="clbrdf device selector")
    ap.add_argument("--other-device", action="append", default=None, metavar="SEL",
                    help="add a 'clbrdf brdf, single' row on this device too (repeatable; default: "
                         "every other working device, e.g. a second PoCL; 'none' for none)")
    ap.add_argument("--note", action="append", default=[],
                    help="a remark to add to the report (repeatable)")
    ap.add_argument("--write", action="store_true", help=f"record the results in {RESULTS.name}")
    args = ap.parse_args(argv)
    if args.quick:
        args.rounds = min(args.rounds, 2)
        args.log2_samples, args.log2_double, args.log2_width1 = 16, 15, 14
        args.log2_numpy, args.log2_mitsuba, args.log2_numpy_small_chunk = 13, 15, 12
    if not args.pocl_cache:
        os.environ["POCL_KERNEL_CACHE"] = "0"          # before PoCL is loaded
    command = "python " + " ".join(shlex.quote(a) for a in [os.path.relpath(__file__)] + sys.argv[1:])
    date = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")

    import numpy as np
    load0 = os.getloadavg()
    busy0, own0, wall0 = busy_seconds(), own_cpu_seconds(), time.perf_counter()

    mus = np.linspace(1.0 / args.points, 1.0, args.points)
    A = args.alpha
    S = 1 << args.log2_samples
    rows = [
        ClbrdfRow(mus, S, A, "clbrdf", "clbrdf brdf, single", device=args.device),
        ClbrdfRow(mus, S, A, "clbrdf-uniform", "clbrdf uniform hemisphere, single", estimator="uniform",
                  device=args.device, seed=1),
        ClbrdfRow(mus, S, A, "clbrdf-qmc", "clbrdf brdf, single, qmc (Sobol, 16 scrambles)", qmc=True,
                  device=args.device, seed=2),
        ClbrdfRow(mus, 1 << args.log2_double, A, "clbrdf-f64", "clbrdf brdf, double", precision="double",
                  device=args.device, seed=3),
        ClbrdfRow(mus, 1 << args.log2_width1, A, "clbrdf-w1", "clbrdf brdf, single, width 1", width=1,
                  device=args.device, seed=4),
        ClbrdfRow(mus, S, A, "clbrdf-cosine", "clbrdf cosine hemisphere, single", estimator="cosine",
                  device=args.device, seed=8),
        ClbrdfRow(mus, S, A, "clbrdf-mis", "clbrdf mis (brdf + cosine, balance), single",
                  estimator="mis", device=args.device, seed=9),
        ClbrdfRow(mus, S, A, "clbrdf-mis-qmc", "clbrdf mis, single, qmc (Sobol, 16 scrambles)",
                  estimator="mis", qmc=True, device=args.device, seed=10),
        QuadratureRow(mus, A, 1e-6, device=args.device),
        ClbrdfRow(mus, 1 << args.log2_double, A, "clbrdf-beckmann-vndf",
                  "clbrdf Beckmann brdf (visible normals), single", device=args.device, seed=5,
                  model="beckmann", sampler="vndf"),
        ClbrdfRow(mus, 1 << args.log2_double, A, "clbrdf-beckmann-ndf",
                  "clbrdf Beckmann brdf (normals), single", device=args.device, seed=6,
                  model="beckmann", sampler="ndf"),
    ]
    for sel in other_devices(args):
        rows.append(ClbrdfRow(mus, S, A, f"clbrdf@{sel}", f"clbrdf brdf, single, on {sel}",
                              device=sel, seed=7))
    rows += [
        NumpyRow(mus, 1 << args.log2_numpy, A, np.float32),
        NumpyRow(mus, 1 << args.log2_numpy, A, np.float32, chunk=1 << args.log2_numpy_small_chunk,
                 key="numpy-f32-small"),
        NumpyRow(mus, 1 << args.log2_numpy, A, np.float64),
    ]
    skipped = []
    mitsuba_versions = "not used (--no-mitsuba)"
    if not args.no_mitsuba:
        try:
            mi, dr = MitsubaRow.load()
            mitsuba_versions = f"{mi.__version__} (drjit {dr.__version__}, variant llvm_ad_rgb, " \
                               f"DRJIT_LIBLLVM_PATH={os.environ.get('DRJIT_LIBLLVM_PATH', 'unset')})"
            rows.append(MitsubaRow(mus, 1 << args.log2_mitsuba, A))
        except Exception as e:
            why = f"not importable: {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
            skipped.append(("mitsuba", why))
            mitsuba_versions = why
            print(f"[mitsuba skipped: {why}]", file=sys.stderr)

    # warm-up: compile, first call, results for the agreement check
    for r in list(rows):
        try:
            r.prepare()
            t = time.perf_counter()
            r.est, r.err = r.run()
            r.first_s = time.perf_counter() - t
        except Exception as e:
            if r.group != "mitsuba":
                raise
            why = f"failed: {type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}"
            rows.remove(r)
            skipped.append((r.key, why))
            print(f"[{r.key} skipped: {why}]", file=sys.stderr)
            continue
        comp = f", compile {r.compile_s:.2f} s" if r.compile_s is not None else ""
        print(f"warm-up {r.key:15s} {r.first_s:7.2f} s{comp}", file=sys.stderr)

    # timed rounds, interleaved, order rotated each round
    for k in range(args.rounds):
        order = rows[k % len(rows):] + rows[:k % len(rows)]
        for r in order:
            t, c = time.perf_counter(), time.process_time()
            r.run()
            r.times.append(time.perf_counter() - t)
            r.cpu.append(time.process_time() - c)
        print(f"round {k + 1}/{args.rounds}: " +
              ", ".join(f"{r.key} {r.total / r.times[-1] / 1e6:.0f}" for r in rows) + " M/s", file=sys.stderr)

    wall = time.perf_counter() - wall0
    busy1, own1 = busy_seconds(), own_cpu_seconds()
    load1 = os.getloadavg()

    reference = None
    if not args.no_reference:
        from clbrdf.ref import microfacet as R
        reference = np.array([R.albedo("ggx", float(m), alpha=A)[0] for m in mus])

    others = None
    if busy0 is not None and busy1 is not None:
        others = max(0.0, (busy1 - busy0) - (own1 - own0)) / wall
    shared = load0[0] > 0.5 or (others is not None and others > 0.25)
    load = (f"Load: load average (1, 5, 15 min) {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} before, "
            f"{load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} after (the latter includes this benchmark); "
            + (f"other processes used {others:.2f} cores on average during the {wall:.0f} s run "
               f"(machine busy time from /proc/stat minus this process's CPU time). " if others is not None else "")
            + ("**The machine was shared with other jobs during this run**: absolute numbers are "
               "pessimistic; the interleaved ratios are the more reliable figures."
               if shared else "The machine was otherwise idle."))

    text = build_report(args, rows, machine_info(args, rows, mitsuba_versions), reference, skipped, load)
    print(text)
    if args.write:
        write_results(text, command, date)
        print(f"\n[written to {RESULTS}]", file=sys.stderr)


if __name__ == "__main__":
    main()
