"""The albedo driver: streams blocks of samples through the device and reduces them on the host.

Memory stays flat in the number of samples per point: the host keeps three numbers per point,
stream and channel, whatever the sample count, and a point with many samples is split into
several launches (about ``LAUNCH_SECONDS`` each) so that progress and Ctrl-C answer quickly.
The result does not depend on how the work is split: blocks are combined in double precision
in one fixed order (block index within its stream), by sequential sums.

``runner()`` is the driver the API calls: ``run_albedo``, or the one a ``using(runner)`` block
installs (clbrdf.tables.checkpoint runs it chunk by chunk and saves each chunk).
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..models import get_spec
from ..models.spec import ParameterError, Setting
from . import build
from .bound import Bound
from .launch import kernel, ndrange, ndrange_with, progress_bar, seed_words

QMC_STREAMS = 16          # independent scrambles behind a quasi-Monte Carlo error estimate
LAUNCH_SAMPLES = 1 << 30  # samples per kernel launch, at most (at least one block)
FIRST_LAUNCH = 1 << 20    # samples in the first launch; later ones are sized from its speed
LAUNCH_SECONDS = 0.25     # target duration of one launch
LAUNCH_PROBES = 1 << 20   # probes per launch (run_probe), at most


class AlbedoPlan:
    """How the samples of one point are cut: ``streams`` independent streams (16 scrambles with
    QMC) of ``per_stream`` samples, each in ``bps`` blocks of ``block_len`` (the last may be
    partial). A block holds ``lanes`` streams: 1 with Philox, whose block length is BLOCK or
    fewer (a multiple of 4 W: a Philox call serves two samples of two numbers, three calls four
    of three) when a stream is shorter, so
    that short streams waste no lanes; W with QMC (albedo_qmc: the lanes are W scrambles of the
    same sample indices), whose block length is a power of two, at most BLOCK. A point has
    ``groups`` = streams / lanes groups of ``bps`` blocks."""

    def __init__(self, samples: int, qmc: bool, width: int):
        self.streams = QMC_STREAMS if qmc else 1
        self.per_stream = -(-samples // self.streams)
        if self.per_stream < 2:
            raise ParameterError(f"samples={samples} is out of range: each of the {self.streams} "
                                 f"streams needs at least 2 samples")
        if qmc:
            self.lanes = width
            self.block_len = min(build.BLOCK, 1 << (self.per_stream - 1).bit_length())
        else:
            self.lanes = 1
            step = 4 * width        # a Philox call serves two samples, three calls four
            self.block_len = min(build.BLOCK, -(-self.per_stream // step) * step)
        self.groups = self.streams // self.lanes
        self.bps = -(-self.per_stream // self.block_len)
        self.blocks = self.groups * self.bps

    def counts(self, j0: int, nb: int) -> np.ndarray:
        """Samples in blocks j0 .. j0 + nb - 1 of a stream (only the last block may be short)."""
        j = np.arange(j0, j0 + nb, dtype=np.float64)
        return np.clip(self.per_stream - j * self.block_len, 0, self.block_len)

    @property
    def samples(self) -> int:
        return self.per_stream * self.streams


class _Reducer:
    """Per (point, stream, channel): the shift C (the first estimate of the stream), and the
    sequential sums S = sum (e - C) and T = sum (e - C)^2, from the blocks' K, D, Q (see
    albedo_blocks in kernels/integrators.cl):
        sum over a block of (e - C)   = D + n (K - C)
        sum over a block of (e - C)^2 = Q + 2 (K - C) D + n (K - C)^2.
    With QMC the error comes from the streams' means; T (the spread within each scramble) and the
    least and greatest weight drawn (``lo``, ``hi`` per point, scramble and channel) are what the
    unseen-event allowance reads (``seen``)."""

    def __init__(self, npts, plan: AlbedoPlan, nch):
        shape = (npts, plan.streams, nch)
        self.plan = plan
        self.C = np.zeros(shape)
        self.S = np.zeros(shape)
        self.T = np.zeros(shape)
        qmc = plan.streams > 1
        self.lo = np.full(shape, np.inf) if qmc else None       # per scramble
        self.hi = np.full(shape, -np.inf) if qmc else None

    def add(self, points: slice, stream: slice, first_block: int, kdq: np.ndarray):
        """kdq: (points, streams, blocks, channels, 3 or 5) for blocks first_block.. of these
        streams (QMC: K, D, Q, least and greatest weight)."""
        K, D = kdq[..., 0].astype(np.float64), kdq[..., 1].astype(np.float64)
        Q = kdq[..., 2].astype(np.float64)
        if self.lo is not None:
            self.lo[points, stream] = np.minimum(self.lo[points, stream], kdq[..., 3].min(axis=2))
            self.hi[points, stream] = np.maximum(self.hi[points, stream], kdq[..., 4].max(axis=2))
        if first_block == 0:
            self.C[points, stream] = K[:, :, 0]
            if K.shape[2] == 1:       # one block per stream: C = K, the sums are D and Q (+ 0.0
                self.S[points, stream] = D[:, :, 0] + 0.0     # as 0 + D in the general case)
                self.T[points, stream] = Q[:, :, 0] + 0.0
                return
        n = self.plan.counts(first_block, K.shape[2])[None, None, :, None]
        dk = K - self.C[points, stream][:, :, None]
        sums = [(self.S, D + n * dk), (self.T, Q + 2 * dk * D + n * dk * dk)]
        for acc, t in sums:
            seq = np.concatenate([acc[points, stream][:, :, None], t], axis=2)
            acc[points, stream] = np.cumsum(seq, axis=2)[:, :, -1]    # sequential: split-independent

    def result(self, qmc: bool):
        n = self.plan.per_stream
        means = self.C + self.S / n                      # (points, streams, channels)
        if qmc:         # the spread of the scrambles' means (einsum: 6x faster than std here)
            k = self.plan.streams
            mean = means.mean(axis=1)
            d = means - mean[:, None]
            var = np.einsum("psc,psc->pc", d, d) / (k - 1)
            # (E - mean) / sqrt(var / k) is Student's t with k - 1 = 15 degrees of freedom, of
            # variance (k - 1) / (k - 3): scaled by its square root z has variance 1 (rms z
            # 1.074 before, and |z| > 4 in 0.12 % of estimates where a normal has 0.006 %)
            return mean, np.sqrt(var / k * (k - 1) / (k - 3))
        var = np.maximum(self.T[:, 0] - self.S[:, 0] ** 2 / n, 0.0) / (n - 1)
        return means[:, 0], np.sqrt(var / n)

    def seen(self):
        """With QMC: the least and greatest weight each scramble drew (points, streams,
        channels), and per (point, channel) the standard error the same samples would have as
        independent ones (the pooled spread of the weights within the scrambles, over
        sqrt(N)); None with Philox."""
        if self.lo is None:
            return None
        n, k = self.plan.per_stream, self.plan.streams
        within = np.maximum(self.T - self.S ** 2 / n, 0.0).sum(axis=1) / (k * (n - 1))
        return self.lo, self.hi, np.sqrt(within / (n * k))


def _point_buffers(ctx, params_full, wo_full, a: int, k: int):
    """Device copies of the parameter and wo blocks of points a .. a + k (a model without
    parameters gets a placeholder buffer)."""
    import pyopencl as cl
    mf = cl.mem_flags
    P = np.ascontiguousarray(params_full[:, a:a + k])
    WO = np.ascontiguousarray(wo_full[:, a:a + k])
    bp = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=P) if P.size else \
        cl.Buffer(ctx, mf.READ_ONLY, 8)
    return bp, cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=WO)


def run_albedo(m, shape, wo_rows, *, estimator: str, samples: int, seed: int, qmc: bool,
               progress: bool, point0: int = 0):
    """E and its standard error at every point of ``shape`` (model parameters broadcast with the
    outgoing directions ``wo_rows`` = [x, y, z]). Returns (E, stderr) of shape (points, channels),
    the plan, the seconds spent and, with QMC, (least weight drawn, greatest, per scramble; the
    standard error of independent samples) at each point (``_Reducer.seen``; None with
    Philox). The random numbers of flat point i are keyed by (seed,
    point0 + i): a caller that computes part of a larger set passes the part's first index."""
    import pyopencl as cl
    plan = AlbedoPlan(samples, qmc, m.width)
    npts = math.prod(shape)
    if not (0 <= point0 and point0 + npts <= 2**32):
        raise ParameterError(f"point0={point0} with {npts} points: the generator keys points by "
                             f"32-bit indices (point0 + points <= 2^32)")
    nch = m.channels
    prog = m.program(part="albedo", estimator=estimator, rng="sobol" if qmc else "philox")
    kern = kernel(prog.program, "albedo_qmc" if qmc else "albedo_blocks")
    lo, hi = seed_words(seed)
    ctx, q = m.device.context, m.device.queue
    mf = cl.mem_flags
    params_full = m.param_block(shape, npts)
    wo_full = m.soa(shape, wo_rows, npts)
    red = _Reducer(npts, plan, nch)
    bar = progress_bar(npts * plan.samples, progress)
    budget = min(FIRST_LAUNCH, LAUNCH_SAMPLES)
    t0 = time.perf_counter()
    # one local size for every launch of the job (PoCL compiles a kernel per local size; the
    # split into launches must not add compilations)
    local = ndrange(npts * plan.blocks, m.device, heavy=True)[1]
    L = plan.lanes
    nout = 5 if qmc else 3          # per block: K, D, Q (and with QMC the least, greatest weight)
    block_samples = plan.block_len * L
    point, block = 0, 0            # next block to launch (block in the point's 0 .. blocks - 1)
    while point < npts:
        budget_blocks = max(1, budget // block_samples)
        if block == 0 and budget_blocks >= plan.blocks:      # whole points
            k = min(npts - point, budget_blocks // plan.blocks)
            nb = plan.blocks
        else:                                                # part of one point's group
            k = 1
            nb = min(budget_blocks, plan.bps - block % plan.bps)
        bp, bw = _point_buffers(ctx, params_full, wo_full, point, k)
        out = np.empty(k * nb * nch * nout * L, dtype=m.dtype)
        bo = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
        tl = time.perf_counter()
        kern(q, *ndrange_with(k * nb, local), bp, prog.tables, bw, np.uint64(k), np.uint64(point0 + point),
             np.uint32(block), np.uint32(nb), np.uint32(plan.per_stream), lo, hi,
             np.uint32(plan.bps), np.uint32(plan.block_len), bo)
        cl.enqueue_copy(q, out, bo)
        q.finish()
        dt = time.perf_counter() - tl
        pts = slice(point, point + k)
        # (points, groups, blocks, lanes, channels, nout) -> (points, streams, blocks, channels,
        # nout)
        ng = nb // plan.bps if nb == plan.blocks else 1
        kdq = out.reshape(k, ng, nb // ng, nch, nout, L).transpose(0, 1, 5, 2, 3, 4)
        kdq = kdq.reshape(k, ng * L, nb // ng, nch, nout)
        if nb == plan.blocks:
            red.add(pts, slice(None), 0, kdq)
            point += k
            done = k * plan.samples
        else:
            grp, j0 = divmod(block, plan.bps)
            red.add(pts, slice(grp * L, grp * L + L), j0, kdq)
            block += nb
            done = int(plan.counts(j0, nb).sum()) * L
            if block == plan.blocks:
                point, block = point + 1, 0
        bar.update(done)
        launched = k * nb * block_samples
        rate = launched / max(dt, 1e-6)
        budget = int(min(LAUNCH_SAMPLES, max(block_samples, rate * LAUNCH_SECONDS)))
    bar.close()
    est, err = red.result(qmc)
    return est, err, plan, time.perf_counter() - t0, red.seen()


PROBES = 108              # probes of the estimator's weight per point (``probe_numbers``)


def probe_numbers(dtype) -> np.ndarray:
    """The (PROBES, 4) numbers every point's probes use, in the kernels' precision: u0, u1 on
    the grid 2^-20, 1/8, 3/8, 5/8, 7/8, 1 - 2^-20 (the sampler's edges: its lobe's peak and far
    tail), u2 in 0.1, 0.5, 0.9 (a mixture's lobes), u3 = 0.5."""
    i = np.arange(PROBES)

    def grid(j):
        x = (2 * j - 1) * 0.125
        return np.where(j == 0, 2.0 ** -20, np.where(j == 5, 1 - 2.0 ** -20, x))
    one = dtype(1)
    u2 = dtype(0.1) + dtype(0.4) * (i // 36).astype(dtype)
    return np.stack([grid(i % 6).astype(dtype), grid((i // 6) % 6).astype(dtype), u2,
                     np.full(PROBES, 0.5 * one, dtype)], axis=1)


def run_probe(m, shape, wo_rows, *, estimator: str):
    """The largest and smallest weight of the estimator over its probes at every point of
    ``shape``: two arrays (points, channels), each non-finite weight counted as 0. A probe is
    one sample of the model's sampler at ``probe_numbers``: its weight for brdf, twice it for
    mis (each balance term is at most f cos / pdf of the sampler), and f at the sampled
    direction times the estimator's own |cos| / pdf for uniform and cosine (where a sharp lobe
    is, which their own directions rarely reach). It runs the batch program's sample kernel
    (and eval's), which every configuration has: no kernel of its own to compile (it was 264
    of 1861 compilations of a cold test run): the same probes for either generator."""
    npts = math.prod(shape)
    nch = m.channels
    u = probe_numbers(m.dtype)
    hi = np.empty((npts, nch))
    lo = np.empty((npts, nch))
    wo = [np.broadcast_to(np.asarray(r, np.float64), shape).reshape(-1) for r in wo_rows]
    step = max(1, LAUNCH_PROBES // PROBES)
    transmits = get_spec(m.config.model).transmits      # uniform and cosine on the sphere
    for a in range(0, npts, step):
        k = min(npts - a, step)
        params = {n: v[:, None] for n, v in m.point_params(shape, a, a + k).items()}
        sub = Bound(m.config, params, m.precision, m.device, m.width)
        grid = (k, PROBES)
        wo_k = [np.broadcast_to(r[a:a + k, None], grid) for r in wo]
        u_k = [np.broadcast_to(u[:, c], grid) for c in range(4)]
        wi, weight, _ = sub.batch("sample_batch", grid, [wo_k, u_k], [3, nch, 1])
        w = weight.astype(np.float64)
        if estimator == "mis":
            w = 2 * w
        elif estimator in ("uniform", "cosine"):
            f = sub.batch("eval_batch", grid, [wo_k, list(wi)], [nch])[0].astype(np.float64)
            z = wi[2].astype(np.float64)
            if estimator == "uniform":
                scale = np.abs(z) * 4 * np.pi if transmits else np.maximum(z, 0) * 2 * np.pi
            else:
                scale = 2 * np.pi if transmits else np.pi
            w = f * scale
        v = np.where(np.isfinite(w), w, 0.0)                 # (channels, k, PROBES)
        hi[a:a + k] = np.maximum(v.max(axis=-1), 0.0).T
        lo[a:a + k] = v.min(axis=-1).T
    return hi, lo


# ---------------------------------------------------------------------------------------------


# the albedo driver of the API's Monte Carlo calls: ``runner()`` is ``run_albedo`` unless a
# ``with using(run):`` block installed another with the same signature (a checkpoint's, a
# cluster's)
_RUNNER = Setting("clbrdf_albedo_runner")
using = _RUNNER.using


def runner():
    return _RUNNER.get() or run_albedo      # looked up at each call (a test may replace it)
