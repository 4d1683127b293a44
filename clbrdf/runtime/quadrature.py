"""Deterministic quadrature on the device (kernels/integrators.cl, quadrature_panels).
"""
from __future__ import annotations

import math
import time

import numpy as np
from numpy.polynomial import legendre as L

from ..models.spec import Setting, check_int
from .albedo import LAUNCH_SECONDS
from .launch import kernel, ndrange, ndrange_with, progress_bar

QUAD_ORDER = 8              # Gauss-Legendre order per axis
QUAD_CHECK_ORDER = 7        # Gauss-Lobatto order of the error check
QUAD_FIRST_PANELS = 16      # panels per axis at the start, equal in v (the kernel's Sidi map
                            # puts the nodes near the edges of the square); 8 missed a kink
                            # (GGX alpha 0.5, mu 0.5: 2.9e-6 off, estimated 8e-8)
QUAD_MAX_EVALS = 1 << 24    # integrand evaluations per point, at most (default)


def check_max_evals(max_evals) -> int:
    """The quadrature's evaluations per point, at most: QUAD_MAX_EVALS for None, else an
    integer in [2^18, 2^34]."""
    return check_int("max_evals", QUAD_MAX_EVALS if max_evals is None else max_evals,
                     1 << 18, 1 << 34, "[2^18, 2^34]")
QUAD_GROUP = 16             # points refined together; host memory is at most about QUAD_GROUP x
                            # max_evals / 405 panels: 64 Ashikhmin-Shirley points at the 2^24 cap
                            # kept 300 MB resident (720 MB with 64 per group); the 32 x 32 GGX
                            # table at 1e-6 took 2.6 s (3.1 s and 850 MB with 4096)


def _lobatto(n):
    """Gauss-Lobatto nodes and weights on [0, 1] (n points, both ends included)."""
    p = L.Legendre.basis(n - 1)
    x = np.concatenate([[-1.0], np.sort(p.deriv().roots().real), [1.0]])
    w = 2 / (n * (n - 1) * p(x) ** 2)
    return (x + 1) / 2, w / 2


def _gauss(n):
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1) / 2, w / 2


def quad_rule(width: int) -> np.ndarray:
    """(5, nodes) rows x, y, w_fine, w_coarse, w_check on [0,1]^2: the fine rule is the
    QUAD_ORDER^2 Gauss-Legendre product rule on each quarter of the panel, the coarse one the same
    rule on the whole panel, the check a 7 x 7 Gauss-Lobatto rule on the whole panel (its nodes
    include the panel's edges). The error estimate is the larger difference between the fine rule
    and the other two. Each addition answers a case where the estimate was fooled:
    - comparing two Gauss orders on the same panel missed a curved kink (GGX alpha 0.5 at normal
      incidence: 4.5e-7 off, estimated 1e-8);
    - the whole panel against its quarters alone missed a kink running along a panel row, where
      both err alike in every panel of the row (GGX alpha 1, mu 0.81, whose weight in the
      sampler's square depends on u1 alone and drops to 0 along a line: 1.05e-4 off, estimated
      3.1e-6), and a sliver of the integrand between a panel's edge and its first Gauss node
      (GGX alpha 1, mu 0.368: weight > 0 for u1 < 0.73113, a panel edge at 0.7306: 2.3e-6 off,
      estimated 2e-13), which only nodes on the edges see.
    Nodes are padded to a multiple of ``width`` with zero weights."""
    cols = []

    def tensor(x, w, x0, y0, size, which, scale):
        X, Y = (a.ravel() for a in np.meshgrid(x, x, indexing="ij"))
        ws = np.zeros((3, X.size))
        ws[which] = np.outer(w, w).ravel() * scale
        cols.append(np.concatenate([np.stack([x0 + size * X, y0 + size * Y]), ws]))
    xg, wg = _gauss(QUAD_ORDER)
    for a in (0.0, 0.5):
        for b in (0.0, 0.5):
            tensor(xg, wg, a, b, 0.5, 0, 0.25)
    tensor(xg, wg, 0.0, 0.0, 1.0, 1, 1.0)
    tensor(*_lobatto(QUAD_CHECK_ORDER), 0.0, 0.0, 1.0, 2, 1.0)
    r = np.concatenate(cols, axis=1)
    pad = -r.shape[1] % width
    return np.concatenate([r, np.tile([[0.5], [0.5], [0.0], [0.0], [0.0]], (1, pad))], axis=1)


class _Panels:
    """The panels of a group of points: point index, box (s0, s1, t0, t1), value and error per
    channel (NaN until evaluated)."""

    def __init__(self, pt, box, nch):
        self.pt, self.box = pt, box
        self.val = np.full((pt.size, nch), np.nan)
        self.err = np.full((pt.size, nch), np.nan)

    def take(self, keep):
        out = _Panels(self.pt[keep], self.box[:, keep], self.val.shape[1])
        out.val, out.err = self.val[keep], self.err[keep]
        return out

    @staticmethod
    def concat(a, b):
        out = _Panels(np.concatenate([a.pt, b.pt]), np.concatenate([a.box, b.box], axis=1),
                      a.val.shape[1])
        out.val, out.err = np.concatenate([a.val, b.val]), np.concatenate([a.err, b.err])
        return out


def _split4(box):
    """Each box (4, k) cut in half along both axes: (4, 4k), children of box j at 4j .. 4j + 3."""
    s0, s1, t0, t1 = box
    sm, tm = (s0 + s1) / 2, (t0 + t1) / 2
    kids = [(s0, sm, t0, tm), (sm, s1, t0, tm), (s0, sm, tm, t1), (sm, s1, tm, t1)]
    return np.stack([np.stack(k) for k in kids], axis=-1).reshape(4, -1)


def run_quadrature(m, shape, wo_rows, *, tol: float, max_evals: int = QUAD_MAX_EVALS,
                   progress: bool = False, integrand: str = "albedo"):
    """E at every point of ``shape`` by quadrature_panels: QUAD_FIRST_PANELS^2 panels per point,
    then, while a point's error estimate (the sum of its panels' |higher - lower order|, largest
    over channels) exceeds ``tol``, its panels with the largest errors (enough that the others
    sum to at most tol / 2) are cut in four, as in clbrdf.ref.quadrature.adaptive_gl2. Panels are not
    cut below 2^-20 (single) or 2^-40 (double) of the square's side, nor past ``max_evals``
    evaluations per point. ``tol``: one target, or one per point (an array of ``shape``).
    Returns (E, err, evaluations per point, seconds); err > tol where the refinement stopped
    first. ``integrand="schlick"``: int f cos (1 - wo.h)^5 instead of E."""
    import pyopencl as cl
    npts = math.prod(shape)
    nch = m.channels
    prog = m.program(part="quadrature", integrand=integrand)
    kern = kernel(prog.program, "quadrature_panels")
    ctx, q = m.device.context, m.device.queue
    mf = cl.mem_flags
    params_full = m.param_block(shape, npts)
    wo_full = m.soa(shape, wo_rows, npts)
    rule = np.ascontiguousarray(quad_rule(m.width).astype(m.dtype))
    nodes = rule.shape[1]
    per_panel = 5 * QUAD_ORDER ** 2 + QUAD_CHECK_ORDER ** 2
    brule = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=rule)
    min_side = 2.0 ** (-20 if m.dtype == np.float32 else -40)
    E = np.zeros((npts, nch))
    err = np.zeros((npts, nch))
    evals = np.zeros(npts, dtype=np.int64)
    t0 = time.perf_counter()
    bar = progress_bar(npts, progress, unit="point")
    e0 = np.linspace(0, 1, QUAD_FIRST_PANELS + 1)
    S0, T0 = np.meshgrid(e0[:-1], e0[:-1], indexing="ij")
    S1, T1 = np.meshgrid(e0[1:], e0[1:], indexing="ij")
    first = np.stack([S0.ravel(), S1.ravel(), T0.ravel(), T1.ravel()])
    local = None
    rate = None                           # panels per second, measured

    def evaluate(pan: _Panels, bp, bw, k):
        nonlocal local, rate
        n = pan.pt.size
        i = 0
        while i < n:
            c = n - i if rate is None and n - i <= 4096 else \
                min(n - i, max(256, int((rate or 4096 / LAUNCH_SECONDS) * LAUNCH_SECONDS)))
            sl = slice(i, i + c)
            bpt = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                            hostbuf=np.ascontiguousarray(pan.pt[sl], dtype=np.uint32))
            bbox = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                             hostbuf=np.ascontiguousarray(pan.box[:, sl], dtype=m.dtype))
            out = np.empty(c * nch * 2, dtype=m.dtype)
            bo = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
            if local is None:     # one local size for the job (PoCL compiles one per size)
                local = ndrange(max(c, 1 << 12), m.device)[1]
            tl = time.perf_counter()
            kern(q, *ndrange_with(c, local), bp, prog.tables, bw, np.uint64(k), bpt, bbox,
                 np.uint64(c), np.uint32(nodes), brule, bo)
            cl.enqueue_copy(q, out, bo)
            q.finish()
            rate = c / max(time.perf_counter() - tl, 1e-6)
            o = out.astype(np.float64).reshape(c, nch, 2)
            pan.val[sl], pan.err[sl] = o[..., 0], o[..., 1]
            i += c

    tols = np.broadcast_to(np.asarray(tol, dtype=float), shape).reshape(-1)
    for g0 in range(0, npts, QUAD_GROUP):
        idx = np.arange(g0, min(npts, g0 + QUAD_GROUP))
        k = idx.size
        tol = tols[idx]
        Pb = np.ascontiguousarray(params_full[:, idx])
        bp = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=Pb) if Pb.size else \
            cl.Buffer(ctx, mf.READ_ONLY, 8)
        bw = cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                       hostbuf=np.ascontiguousarray(wo_full[:, idx]))
        nf = first.shape[1]
        pan = _Panels(np.repeat(np.arange(k), nf), np.tile(first, (1, k)), nch)
        evaluate(pan, bp, bw, k)
        ev = np.full(k, nf * per_panel, dtype=np.int64)
        while True:
            # totals per point, in a fixed order (panels sorted by point, then box)
            order = np.lexsort((pan.box[3], pan.box[2], pan.box[1], pan.box[0], pan.pt))
            pan = pan.take(order)
            starts = np.searchsorted(pan.pt, np.arange(k))
            tot_err = np.add.reduceat(pan.err, starts, axis=0) if pan.pt.size else err[idx]
            pe = pan.err.max(axis=1)
            side = np.minimum(pan.box[1] - pan.box[0], pan.box[3] - pan.box[2])
            splittable = side > 2 * min_side
            active = (tot_err.max(axis=1) > tol) & (ev + 4 * per_panel <= max_evals)
            cand = active[pan.pt] & splittable
            if not cand.any():
                break
            # per point: panels by decreasing error; split the first ones until the error of
            # the rest (splittable or not) is at most tol / 2, and at least one
            o2 = np.lexsort((-pe, pan.pt))
            pt2, pe2, c2 = pan.pt[o2], pe[o2], cand[o2]
            csum = np.cumsum(np.where(c2, pe2, 0.0))
            base = np.concatenate([[0.0], csum])[np.searchsorted(pt2, np.arange(k))]
            done_before = csum - np.where(c2, pe2, 0.0) - base[pt2]   # split error before this
            rest = tot_err.max(axis=1)[pt2] - done_before
            pick = c2 & (rest > tol[pt2] / 2)
            # the evaluation budget: at most (max_evals - ev) / (4 per_panel) panels per point
            rank = np.cumsum(pick) - np.concatenate([[0], np.cumsum(pick)])[np.searchsorted(pt2, np.arange(k))][pt2]
            allow = (max_evals - ev) // (4 * per_panel)
            pick &= rank <= allow[pt2]
            split = np.zeros(pan.pt.size, bool)
            split[o2[pick]] = True
            if not split.any():
                break
            kids = _Panels(np.repeat(pan.pt[split], 4), _split4(pan.box[:, split]), nch)
            evaluate(kids, bp, bw, k)
            ev += 4 * per_panel * np.bincount(pan.pt[split], minlength=k)
            pan = _Panels.concat(pan.take(~split), kids)
        order = np.lexsort((pan.box[3], pan.box[2], pan.box[1], pan.box[0], pan.pt))
        pan = pan.take(order)
        starts = np.searchsorted(pan.pt, np.arange(k))
        E[idx] = np.add.reduceat(pan.val, starts, axis=0)
        err[idx] = np.add.reduceat(pan.err, starts, axis=0)
        evals[idx] = ev
        bar.update(k)
    bar.close()
    return E, err, evals, time.perf_counter() - t0


# the quadrature's driver: ``quadrature_runner()`` is ``run_quadrature`` unless a ``with
# using_quadrature(run):`` block installed another with the same signature (a cluster's)
_RUNNER = Setting("clbrdf_quadrature_runner")
using_quadrature = _RUNNER.using


def quadrature_runner():
    return _RUNNER.get() or run_quadrature
