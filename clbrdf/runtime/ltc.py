"""The LTC fit's launches (kernels/integrators.cl, ltc_moments and ltc_loss): many cells, and
many candidate matrices per cell, per launch; the host (clbrdf/tables/ltc.py) only steers.
"""
from __future__ import annotations

import numpy as np

from .launch import kernel, ndrange, seed_words

LAUNCH_ITEMS = 1 << 16      # candidates per loss launch, at most
MOMENTS = 16                # numbers per cell from ltc_moments (13 used)


def _buffers(bound, wo):
    """The cells' parameter block and wo (ncells, 3) as device buffers."""
    import pyopencl as cl
    n = len(wo)
    mf = cl.mem_flags
    ctx = bound.device.context
    params = bound.param_block((n,), n)
    wob = np.ascontiguousarray(np.asarray(wo, np.float64).T, dtype=bound.dtype)
    return (cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=params),
            cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=wob))


class LTCRunner:
    """The cells of one fit (a Bound whose parameters have shape (ncells,), and wo (ncells, 3))
    on its device, with the generator ``rng`` (``sobol`` for the fit's common random numbers,
    ``philox`` for independent estimates with error bars); ``cell0``: the first cell's index in
    the whole grid, which keys the cells' random numbers (a part of a grid draws the numbers of
    the same cells of the whole)."""

    def __init__(self, bound, wo, rng: str = "sobol", cell0: int = 0):
        self.bound, self.n, self.cell0 = bound, len(wo), np.uint32(cell0)
        self.prog = bound.program(part="ltc", rng=rng)
        self.P, self.WO = _buffers(bound, wo)

    def moments(self, samples: int, seed: int, frames=None) -> np.ndarray:
        """(ncells, 13) float64 sums (ltc_moments) over ``samples`` BRDF samples per cell, the
        directions in the cells' ``frames`` (ncells, 3, 3), columns X, Y, Z (default: z up)."""
        import pyopencl as cl
        b = self.bound
        q = b.device.queue
        frames = np.broadcast_to(np.eye(3), (self.n, 3, 3)) if frames is None else frames
        rows = np.ascontiguousarray(np.swapaxes(frames, 1, 2).reshape(self.n, 9).T, dtype=b.dtype)
        fb = cl.Buffer(b.device.context, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR,
                       hostbuf=rows)
        out = cl.Buffer(b.device.context, cl.mem_flags.WRITE_ONLY,
                        MOMENTS * self.n * np.dtype(b.dtype).itemsize)
        lo, hi = seed_words(seed)
        kernel(self.prog.program, "ltc_moments")(
            q, *ndrange(self.n, b.device, heavy=True), self.P, self.prog.tables, self.WO, np.uint64(self.n),
            self.cell0, fb, np.uint32(samples), lo, hi, out)
        h = np.empty(MOMENTS * self.n, b.dtype)
        cl.enqueue_copy(q, h, out)
        q.finish()
        return h.reshape(self.n, MOMENTS)[:, :13].astype(np.float64)

    def loss(self, cells, m, minv, magnitude, scale, samples: int, seed: int) -> np.ndarray:
        """(k, 4) float64 sums (sum e3, sum e3^2, sum e1, sum e1^2; ltc_loss) for k candidates:
        cell indices ``cells`` (k,), matrices ``m`` and ``minv`` (k, 3, 3), the cells' E and
        scale s (k,): e3 is s^3 times the L3 integrand."""
        import pyopencl as cl
        b = self.bound
        q, ctx = b.device.queue, b.device.context
        mf = cl.mem_flags
        lo, hi = seed_words(seed)
        k_all = len(cells)
        res = np.empty((k_all, 4))
        for a in range(0, k_all, LAUNCH_ITEMS):
            sl = slice(a, min(k_all, a + LAUNCH_ITEMS))
            k = sl.stop - sl.start
            mat = np.concatenate([np.asarray(m[sl], np.float64).reshape(k, 9).T,
                                  np.asarray(minv[sl], np.float64).reshape(k, 9).T,
                                  np.asarray(magnitude[sl], np.float64)[None],
                                  np.asarray(scale[sl], np.float64)[None]])
            cb = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                           hostbuf=np.ascontiguousarray(cells[sl], dtype=np.uint32))
            mb = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                           hostbuf=np.ascontiguousarray(mat, dtype=b.dtype))
            out = cl.Buffer(ctx, mf.WRITE_ONLY, 4 * k * np.dtype(b.dtype).itemsize)
            kernel(self.prog.program, "ltc_loss")(
                q, *ndrange(k, b.device, heavy=True), self.P, self.prog.tables, self.WO, np.uint64(self.n),
                self.cell0, cb, mb, np.uint64(k), np.uint32(samples), lo, hi, out)
            h = np.empty(4 * k, b.dtype)
            cl.enqueue_copy(q, h, out)
            res[sl] = h.reshape(k, 4)
        q.finish()
        return res
