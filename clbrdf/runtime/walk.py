"""The random walk's launches (kernels/integrators.cl, walk_albedo, walk_eval and walk_sample;
the walk is kernels/heitz_ms.h): per point the sums of the walks' weights by order and side (or
of their next-event estimates toward wi, by order), reduced in float64 on the host block by
block, so memory stays flat as the number of walks grows.
"""
from __future__ import annotations

import math
import time

import numpy as np

from .launch import kernel, ndrange, progress_bar, seed_words

ORDERS = 3                  # MS_ORDERS of kernels/heitz_ms.h: orders 1, 2, 3 and more
BLOCK_LEN = 1024            # walks per work-item
LAUNCH_ITEMS = 1 << 14      # work-items per launch, at most


def walk_sums(bound, shape, wo_rows, walks: int, seed: int, max_order: int,
              progress: bool = False, wi_rows=None):
    """Sums over ``walks`` walks per point of ``shape`` (the parameters' and the rows' broadcast
    shape): (sums, cut, hits, seconds), sums (npoints, 2 ORDERS, channels, 2) float64 (class,
    channel, sum of x / of x^2), cut and hits (npoints,) the walks cut at max_order and the hits
    of all walks. Without wi_rows x is the weight and the classes (side up / down) x (order); with
    them (walk_eval) x is the walk's estimate of f cos toward wi, the classes the orders and
    the total, then zeros."""
    import pyopencl as cl
    b = bound
    npoints = math.prod(shape)
    params = b.param_block(shape, npoints)
    wos = b.soa(shape, list(wo_rows), npoints)
    wis = None if wi_rows is None else b.soa(shape, list(wi_rows), npoints)
    q, ctx = b.device.queue, b.device.context
    ch = b.channels
    nout = 4 * ORDERS * ch + 2
    block_len = min(BLOCK_LEN, -(-walks // b.width) * b.width)
    nblocks = -(-walks // block_len)
    prog = b.program(part="walk")
    knl = kernel(prog.program, "walk_albedo" if wis is None else "walk_eval")
    lo, hi = seed_words(seed)
    total = np.zeros((npoints, nout))
    per_launch_blocks = max(1, min(nblocks, LAUNCH_ITEMS))
    per_launch_points = max(1, LAUNCH_ITEMS // per_launch_blocks)
    bar = progress_bar(npoints * walks, progress, unit="walk")
    t0 = time.perf_counter()
    for p0 in range(0, npoints, per_launch_points):
        np_ = min(per_launch_points, npoints - p0)
        P = cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                      hostbuf=np.ascontiguousarray(params[:, p0:p0 + np_]))
        WO = cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                       hostbuf=np.ascontiguousarray(wos[:, p0:p0 + np_]))
        dirs = [WO]
        if wis is not None:
            dirs.append(cl.Buffer(ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                                  hostbuf=np.ascontiguousarray(wis[:, p0:p0 + np_])))
        for b0 in range(0, nblocks, per_launch_blocks):
            lb = min(per_launch_blocks, nblocks - b0)
            items = np_ * lb
            out = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, items * nout * np.dtype(b.dtype).itemsize)
            knl(q, *ndrange(items, b.device, heavy=True), P, prog.tables, *dirs, np.uint64(np_), np.uint64(p0),
                np.uint32(b0), np.uint32(lb), np.uint32(walks), lo, hi, np.uint32(max_order),
                np.uint32(block_len), out)
            h = np.empty(items * nout, b.dtype)
            cl.enqueue_copy(q, h, out)
            q.finish()
            total[p0:p0 + np_] += h.reshape(np_, lb, nout).astype(np.float64).sum(axis=1)
            bar.update(np_ * min(walks, lb * block_len))
    bar.close()
    seconds = time.perf_counter() - t0
    sums = total[:, :4 * ORDERS * ch].reshape(npoints, 2 * ORDERS, ch, 2)
    return sums, total[:, -2], total[:, -1], seconds


def walk_batch(bound, shape, wo_rows, first: int, stream: int, seed: int, max_order: int):
    """One walk per query: (wi (3, ...), weight (channels, ...), order (...)), walk first + i
    keyed (first + i, 0, stream, event)."""
    import pyopencl as cl
    b = bound
    n = math.prod(shape)
    w = b.width
    n_pad = max(w, -(-n // w) * w)
    ctx, q = b.device.context, b.device.queue
    mf = cl.mem_flags
    P = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=b.param_block(shape, n_pad))
    WO = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=b.soa(shape, list(wo_rows), n_pad))
    outs = [np.empty((k, n_pad), dtype=b.dtype) for k in (3, b.channels, 1)]
    bufs = [cl.Buffer(ctx, mf.WRITE_ONLY, o.nbytes) for o in outs]
    prog = b.program(part="walk")
    lo, hi = seed_words(seed)
    kernel(prog.program, "walk_sample")(q, *ndrange(n_pad // w, b.device, heavy=True), P, prog.tables, WO,
                                        np.uint64(n_pad), np.uint32(first), np.uint32(stream),
                                        lo, hi, np.uint32(max_order), *bufs)
    for o, buf in zip(outs, bufs):
        cl.enqueue_copy(q, o, buf)
    q.finish()
    return [o[:, :n].reshape((o.shape[0],) + shape).astype(np.float64) for o in outs]
