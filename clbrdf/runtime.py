"""The runtime under the public API: launch geometry, kernel objects, progress, and the albedo
driver that streams blocks of samples through the device and reduces them on the host.

Memory stays flat in the number of samples per point: the host keeps three numbers per point,
stream and channel, whatever the sample count, and a point with many samples is split into
several launches (about ``LAUNCH_SECONDS`` each) so that progress and Ctrl-C answer quickly.
The result does not depend on how the work is split: blocks are combined in double precision
in one fixed order (block index within its stream), by sequential sums.
"""
from __future__ import annotations

import math
import time

import numpy as np

from . import build
from .device import Device
from .spec import ParameterError

QMC_STREAMS = 16          # independent scrambles behind a quasi-Monte Carlo error estimate
LAUNCH_SAMPLES = 1 << 30  # samples per kernel launch, at most (at least one block)
FIRST_LAUNCH = 1 << 20    # samples in the first launch; later ones are sized from its speed
LAUNCH_SECONDS = 0.25     # target duration of one launch
LOCAL_SIZE = 64           # work-items per work-group, at most
LAUNCH_POINTS = 1 << 18   # points per probe launch (run_probe), at most

_KERNELS: dict = {}


class WidthFallbackWarning(UserWarning):
    """The device's compiler fails on the kernels at the default width; width 1 is used."""


_WARNED: set = set()


def working_width(device: Device, precision: str) -> int:
    """The default width of ``device`` (Device.default_width) if the kernels build and compute
    right there (clbrdf.probe, in a child process, cached), else 1 with a warning that says how
    to get the fast path; a DeviceError if width 1 fails too. CLBRDF_WIDTH and GPUs (width 1)
    are taken as they are."""
    import os
    import warnings
    from . import probe
    from .device import DeviceError
    w = device.default_width(precision)
    if os.environ.get("CLBRDF_WIDTH") or os.environ.get("CLBRDF_IN_PROBE") or w == 1:
        return w
    err = probe.kernel_error(device.info, w, precision)
    if err is None:
        return w
    err1 = probe.kernel_error(device.info, 1, precision)
    if err1 is not None:
        raise DeviceError(f"device {device.info.selector} ({device.info.name} [{device.info.platform}]) "
                          f"cannot run the kernels: {err}; and at width 1: {err1}. Install "
                          f"Debian's PoCL (apt-get install pocl-opencl-icd) or choose another "
                          f"device (clbrdf devices)")
    if (device.info.selector, precision) not in _WARNED:
        _WARNED.add((device.info.selector, precision))
        warnings.warn(f"device {device.info.selector} ({device.info.platform}): {err}; running at "
                      f"width 1, about 12x slower. For the fast path install Debian's PoCL "
                      f"(apt-get install pocl-opencl-icd), which clbrdf then prefers",
                      WidthFallbackWarning, stacklevel=3)
    return 1


def seed_words(seed) -> tuple[np.uint32, np.uint32]:
    s = check_int("seed", seed, 0, 2**64 - 1, "[0, 2^64)")
    return np.uint32(s & 0xFFFFFFFF), np.uint32(s >> 32)


def check_int(name: str, value, lo: int, hi: int, text: str | None = None) -> int:
    """An integer in [lo, hi]: 3 and 3.0 are accepted, 1.5, True, '3' and NaN are not."""
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if not ok and isinstance(value, (float, np.floating)) and float(value).is_integer():
        value, ok = int(value), True
    rng = text or f"[{lo}, {hi}]"
    if not ok:
        raise ParameterError(f"{name}={value!r} is not valid: {name} must be an integer in {rng}")
    if not lo <= int(value) <= hi:
        raise ParameterError(f"{name}={int(value)} is out of range: valid {name} is in {rng}")
    return int(value)


def ndrange_with(items: int, local: tuple) -> tuple:
    """(global size, local size) for ``items`` work-items with a given local size."""
    return (-(-items // local[0]) * local[0],), local


def ndrange(items: int, device: Device):
    """(global size, local size) for ``items`` work-items; the kernels ignore the padding items.

    The local size is explicit: left to itself PoCL makes work-groups of up to 4096 items whose
    contexts live on an 8 MB thread stack, which overflows for models with many parameters
    (an RGB Holzschuch-Pacanowski launch crashed). On a CPU it is 1 or LOCAL_SIZE and nothing in
    between: PoCL compiles a kernel once per local size (about 0.1 s at W = 16), and 1 keeps
    every compute unit busy in small launches. On a GPU: a power of two up to LOCAL_SIZE, smaller
    for small launches so that every compute unit gets work groups."""
    cu = device.info.compute_units
    if not device.info.is_gpu:
        return ndrange_with(items, (LOCAL_SIZE,) if items >= LOCAL_SIZE * 4 * cu else (1,))
    local = 1
    while local < LOCAL_SIZE and local * 2 * 4 * cu <= items:
        local *= 2
    return ndrange_with(items, (local,))


def kernel(prog, name: str):
    """One kernel object per (program, name): pyopencl creates a new one on every attribute access."""
    key = (id(prog), name)
    if key not in _KERNELS:
        import pyopencl as cl
        _KERNELS[key] = (prog, cl.Kernel(prog, name))
    return _KERNELS[key][1]


def progress_bar(total: int, enabled: bool, unit: str = "sample"):
    try:
        from tqdm import tqdm
    except ImportError:
        enabled = False
    if not enabled:
        class _Null:
            def update(self, n): pass
            def close(self): pass
        return _Null()
    return tqdm(total=total, unit=unit, unit_scale=True, delay=2.0, leave=False)


class AlbedoPlan:
    """How the samples of one point are cut: ``streams`` independent streams (16 scrambles with
    QMC) of ``per_stream`` samples, each in ``bps`` blocks of ``block_len`` (the last may be
    partial). A block holds ``lanes`` streams: 1 with Philox, whose block length is BLOCK or
    fewer (a multiple of 2 W: a Philox call serves two samples) when a stream is shorter, so
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
            self.block_len = min(build.BLOCK, -(-self.per_stream // (2 * width)) * 2 * width)
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
    With QMC the error comes from the streams' means alone: T is not kept."""

    def __init__(self, npts, plan: AlbedoPlan, nch):
        shape = (npts, plan.streams, nch)
        self.plan = plan
        self.C = np.zeros(shape)
        self.S = np.zeros(shape)
        self.T = np.zeros(shape) if plan.streams == 1 else None

    def add(self, points: slice, stream: slice, first_block: int, kdq: np.ndarray):
        """kdq: (points, streams, blocks, channels, 3) for blocks first_block.. of these streams."""
        K, D = kdq[..., 0].astype(np.float64), kdq[..., 1].astype(np.float64)
        Q = None if self.T is None else kdq[..., 2].astype(np.float64)
        if first_block == 0:
            self.C[points, stream] = K[:, :, 0]
            if K.shape[2] == 1:       # one block per stream: C = K, the sums are D and Q (+ 0.0
                self.S[points, stream] = D[:, :, 0] + 0.0     # as 0 + D in the general case)
                if self.T is not None:
                    self.T[points, stream] = Q[:, :, 0] + 0.0
                return
        n = self.plan.counts(first_block, K.shape[2])[None, None, :, None]
        dk = K - self.C[points, stream][:, :, None]
        sums = [(self.S, D + n * dk)]
        if self.T is not None:
            sums.append((self.T, Q + 2 * dk * D + n * dk * dk))
        for acc, t in sums:
            seq = np.concatenate([acc[points, stream][:, :, None], t], axis=2)
            acc[points, stream] = np.cumsum(seq, axis=2)[:, :, -1]    # sequential: split-independent

    def result(self, qmc: bool):
        n = self.plan.per_stream
        means = self.C + self.S / n                      # (points, streams, channels)
        if qmc:         # the spread of the scrambles' means (einsum: 6x faster than std here)
            mean = means.mean(axis=1)
            d = means - mean[:, None]
            var = np.einsum("psc,psc->pc", d, d) / (self.plan.streams - 1)
            return mean, np.sqrt(var / self.plan.streams)
        var = np.maximum(self.T[:, 0] - self.S[:, 0] ** 2 / n, 0.0) / (n - 1)
        return means[:, 0], np.sqrt(var / n)


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
    the plan and the seconds spent. The random numbers of flat point i are keyed by (seed,
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
    params_full = m._param_block(shape, npts)
    wo_full = m._soa(shape, wo_rows, npts)
    red = _Reducer(npts, plan, nch)
    bar = progress_bar(npts * plan.samples, progress)
    budget = min(FIRST_LAUNCH, LAUNCH_SAMPLES)
    t0 = time.perf_counter()
    # one local size for every launch of the job (PoCL compiles a kernel per local size; the
    # split into launches must not add compilations)
    local = ndrange(npts * plan.blocks, m.device)[1]
    L = plan.lanes
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
        out = np.empty(k * nb * nch * 3 * L, dtype=m.dtype)
        bo = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
        tl = time.perf_counter()
        kern(q, *ndrange_with(k * nb, local), bp, prog.tables, bw, np.uint64(k), np.uint64(point0 + point),
             np.uint32(block), np.uint32(nb), np.uint32(plan.per_stream), lo, hi,
             np.uint32(plan.bps), np.uint32(plan.block_len), bo)
        cl.enqueue_copy(q, out, bo)
        q.finish()
        dt = time.perf_counter() - tl
        pts = slice(point, point + k)
        # (points, groups, blocks, lanes, channels, 3) -> (points, streams, blocks, channels, 3)
        ng = nb // plan.bps if nb == plan.blocks else 1
        kdq = out.reshape(k, ng, nb // ng, nch, 3, L).transpose(0, 1, 5, 2, 3, 4)
        kdq = kdq.reshape(k, ng * L, nb // ng, nch, 3)
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
    return est, err, plan, time.perf_counter() - t0


def run_probe(m, shape, wo_rows, *, estimator: str, qmc: bool):
    """The largest and smallest weight of the estimator over its probes (albedo_probe in
    kernels/integrators.cl) at every point of ``shape``: two arrays (points, channels). Runs in
    the albedo program of the same estimator and generator (no other program), in launches
    of at most LAUNCH_POINTS points."""
    import pyopencl as cl
    npts = math.prod(shape)
    nch, W = m.channels, m.width
    prog = m.program(part="albedo", estimator=estimator, rng="sobol" if qmc else "philox")
    kern = kernel(prog.program, "albedo_probe")
    ctx, q = m.device.context, m.device.queue
    mf = cl.mem_flags
    hi = np.empty((npts, nch))
    lo = np.empty((npts, nch))
    params_full = m._param_block(shape, npts)
    wo_full = m._soa(shape, wo_rows, npts)
    for a in range(0, npts, LAUNCH_POINTS):
        k = min(npts - a, LAUNCH_POINTS)
        bp, bw = _point_buffers(ctx, params_full, wo_full, a, k)
        out = np.empty(k * nch * 2 * W, dtype=m.dtype)
        bo = cl.Buffer(ctx, mf.WRITE_ONLY, out.nbytes)
        # one local size on a CPU (PoCL compiles a kernel per local size): 1
        geo = ndrange(k, m.device) if m.device.info.is_gpu else ndrange_with(k, (1,))
        kern(q, *geo, bp, prog.tables, bw, np.uint64(k), bo)
        cl.enqueue_copy(q, out, bo)
        q.finish()
        out = out.reshape(k, nch, 2, W).astype(np.float64)
        hi[a:a + k] = out[:, :, 0].max(axis=-1)
        lo[a:a + k] = out[:, :, 1].min(axis=-1)
    return hi, lo



# ---------------------------------------------------------------------------------------------
# Deterministic quadrature (kernels/integrators.cl, quadrature_panels)

QUAD_ORDER = 8              # Gauss-Legendre order per axis
QUAD_CHECK_ORDER = 7        # Gauss-Lobatto order of the error check
QUAD_FIRST_PANELS = 16      # panels per axis at the start, equal in v (the kernel's Sidi map
                            # puts the nodes near the edges of the square); 8 missed a kink
                            # (GGX alpha 0.5, mu 0.5: 2.9e-6 off, estimated 8e-8)
QUAD_MAX_EVALS = 1 << 24    # integrand evaluations per point, at most (default)
QUAD_GROUP = 16             # points refined together; host memory is at most about QUAD_GROUP x
                            # max_evals / 405 panels: 64 Ashikhmin-Shirley points at the 2^24 cap
                            # kept 300 MB resident (720 MB with 64 per group); the 32 x 32 GGX
                            # table at 1e-6 took 2.6 s (3.1 s and 850 MB with 4096)


def _lobatto(n):
    """Gauss-Lobatto nodes and weights on [0, 1] (n points, both ends included)."""
    from numpy.polynomial import legendre as L
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
                   progress: bool = False):
    """E at every point of ``shape`` by quadrature_panels: QUAD_FIRST_PANELS^2 panels per point,
    then, while a point's error estimate (the sum of its panels' |higher - lower order|, largest
    over channels) exceeds ``tol``, its panels with the largest errors (enough that the others
    sum to at most tol / 2) are cut in four, as in clbrdf.quadrature.adaptive_gl2. Panels are not
    cut below 2^-20 (single) or 2^-40 (double) of the square's side, nor past ``max_evals``
    evaluations per point. Returns (E, err, evaluations per point, seconds); err > tol where the
    refinement stopped first."""
    import pyopencl as cl
    npts = math.prod(shape)
    nch = m.channels
    prog = m.program(part="quadrature")
    kern = kernel(prog.program, "quadrature_panels")
    ctx, q = m.device.context, m.device.queue
    mf = cl.mem_flags
    params_full = m._param_block(shape, npts)
    wo_full = m._soa(shape, wo_rows, npts)
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

    for g0 in range(0, npts, QUAD_GROUP):
        idx = np.arange(g0, min(npts, g0 + QUAD_GROUP))
        k = idx.size
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
            pick = c2 & (rest > tol / 2)
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
