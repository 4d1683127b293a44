"""Models in bulk: evaluation, sampling, densities and directional albedo on an OpenCL device.

Arrays in, arrays out: parameters, directions and cosines broadcast together as in NumPy.
"""
from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from . import build, runtime
from .device import Device, get_device
from .models import get_spec
from .spec import ParameterError, check_directions, check_mu, finite_or_raise

PRECISIONS = ("single", "double")
ESTIMATORS = ("uniform", "cosine", "brdf", "mis", "quadrature")
MC_ESTIMATORS = ESTIMATORS[:4]
QUAD_TOL = {"single": 1e-6, "double": 1e-7}     # default error target of the quadrature
QMC_STREAMS = runtime.QMC_STREAMS


def _dtype(precision: str):
    return np.float32 if precision == "single" else np.float64


def _check_choice(name, value, choices):
    if value not in choices:
        raise ParameterError(f"{name}={value!r} is not valid: choose one of {', '.join(choices)}")
    return value


class Model:
    """A model configuration on a device.

    >>> m = Model("ggx", alpha=0.3, fresnel="schlick", f0=0.04)
    >>> m.eval(wo, wi)                  # BRDF values, 1/sr
    >>> wi, weight, pdf = m.sample(wo, seed=1)

    Parameters may be arrays; they broadcast with the directions. ``precision`` is ``single`` or
    ``double``; ``width`` the lanes per work-item (default: 16 single / 8 double on a CPU, 1 on
    a GPU); ``device`` a selector (see ``clbrdf.device``). ``channels=3`` makes the model RGB:
    parameters marked per channel take a trailing axis of 3 (``kd=[0.2, 0.3, 0.4]``), and values,
    sample weights and albedos get a trailing axis of 3.
    """

    def __init__(self, name: str, *, precision: str = "single", device=None, width: int | None = None,
                 channels: int | None = None, preset: str | None = None, **params):
        self.spec = get_spec(name)
        self.preset = None
        if preset is not None:          # a published fit (clbrdf.presets); params override it
            from . import presets
            self.preset = presets.get(self.spec.name, preset)
            params = {**self.preset.options, **self.preset.params, **params}
            channels = 3 if channels is None else channels
        self.config, self.params = self.spec.configure(channels=channels or 1, **params)
        self.precision = _check_choice("precision", precision, PRECISIONS)
        self.device: Device = get_device(device)
        self.width = runtime.working_width(self.device, precision) if width is None else width
        if isinstance(self.width, bool) or self.width not in (1, 2, 4, 8, 16):
            raise ParameterError(f"width={self.width!r} is not valid: choose one of 1, 2, 4, 8, 16")
        self.dtype = _dtype(precision)

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def channels(self) -> int:
        return self.config.channels

    @property
    def anisotropic(self) -> bool:
        """Whether E(wo) may depend on the azimuth of wo (see ModelSpec.anisotropic)."""
        return self.spec.anisotropic(self.config, self.params)

    @property
    def options(self) -> dict:
        return dict(self.config.options)

    def describe(self) -> dict:
        """Model name, preset, options and parameters (scalars as floats, arrays as lists)."""
        pre = {"preset": f"{self.preset.material} ({self.preset.source})"} if self.preset else {}
        return {"model": self.name, **pre, **self.options,
                **{k: (v.item() if v.ndim == 0 else v.tolist()) for k, v in self.params.items()}}

    def __repr__(self):
        d = ", ".join(f"{k}={v}" for k, v in self.describe().items() if k != "model")
        return f"Model({self.name!r}, {d}, precision={self.precision!r}, width={self.width})"

    # ---- plumbing ----
    def program(self, **kw):
        return build.get_program(self.device, self.config, self.precision, self.width, **kw)

    def _soa(self, shape, arrays, n_pad):
        """Stack arrays broadcast to shape as rows of a (len, n_pad) structure-of-arrays block."""
        out = np.zeros((len(arrays), n_pad), dtype=self.dtype)
        n = math.prod(shape)
        for j, a in enumerate(arrays):
            out[j, :n] = np.broadcast_to(a, shape).reshape(-1)
            out[j, n:] = out[j, n - 1] if n else 0    # pad with a valid value
        return out

    def _param_rows(self):
        """The parameter block's rows: one per scalar parameter, one per channel of a spectral one."""
        rows = []
        for k in self.config.param_names:
            v = self.params[k]
            rows += [v[..., c] for c in range(self.channels)] if k in self.config.spectral and \
                self.channels > 1 else [v]
        return rows

    def _param_block(self, shape, n_pad):
        return self._soa(shape, self._param_rows(), n_pad)

    def _channel_axis(self, a):
        """(channels, ...) -> (...) for one channel, (..., channels) otherwise."""
        return a[0] if self.channels == 1 else np.moveaxis(a, 0, -1)

    def _batch(self, kernel: str, shape, inputs: list[np.ndarray], outputs: list[int]):
        launch, fetch = self._batch_prepare(kernel, shape, inputs, outputs)
        launch()
        return fetch()

    def _batch_prepare(self, kernel: str, shape, inputs: list[np.ndarray], outputs: list[int]):
        """Device buffers of one batch call and two closures: ``launch()`` runs the kernel and
        waits for it (repeatable: clbrdf.ladder times it alone), ``fetch()`` reads the outputs."""
        import pyopencl as cl
        n = math.prod(shape)
        w = self.width
        n_pad = max(w, -(-n // w) * w)
        ctx, q = self.device.context, self.device.queue
        mf = cl.mem_flags
        bufs = [cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=self._param_block(shape, n_pad))]
        for arr in inputs:     # each (k, ...) -> SoA (k, n_pad)
            bufs.append(cl.Buffer(ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                                  hostbuf=self._soa(shape, list(arr), n_pad)))
        host_out = [np.empty((k, n_pad), dtype=self.dtype) for k in outputs]
        out_bufs = [cl.Buffer(ctx, mf.WRITE_ONLY, h.nbytes) for h in host_out]
        prog = self.program(part="batch")
        knl = runtime.kernel(prog.program, kernel)

        def launch():
            knl(q, *runtime.ndrange(n_pad // w, self.device), bufs[0], prog.tables, *bufs[1:],
                np.uint64(n_pad), *out_bufs)
            q.finish()

        def fetch():
            for h, b in zip(host_out, out_bufs):
                cl.enqueue_copy(q, h, b)
            q.finish()
            return [h[:, :n].reshape((h.shape[0],) + shape) for h in host_out]
        return launch, fetch

    def _shape(self, *dirs):
        shapes = [r.shape for r in self._param_rows()] + [d.shape[:-1] for d in dirs]
        try:
            return np.broadcast_shapes(*shapes)
        except ValueError as e:
            raise ParameterError(f"parameters and directions do not broadcast: {e}") from None

    # ---- public API ----
    def eval(self, wo, wi) -> np.ndarray:
        """BRDF value f(wo, wi) in 1/sr (shape (..., 3) for an RGB model); 0 where either
        direction is below the horizon."""
        wo = check_directions("wo", wo, allow_below=True)
        wi = check_directions("wi", wi, allow_below=True)
        shape = self._shape(wo, wi)
        (f,) = self._batch("eval_batch", shape, [np.moveaxis(wo, -1, 0), np.moveaxis(wi, -1, 0)],
                           [self.channels])
        return self._channel_axis(f)

    def pdf(self, wo, wi) -> np.ndarray:
        """Density (1/sr) of wi under the model's sampler, given wo."""
        wo = check_directions("wo", wo, allow_below=True)
        wi = check_directions("wi", wi, allow_below=True)
        shape = self._shape(wo, wi)
        (p,) = self._batch("pdf_batch", shape, [np.moveaxis(wo, -1, 0), np.moveaxis(wi, -1, 0)], [1])
        return p[0]

    def sample(self, wo, u=None, *, seed: int = 0, qmc: bool = False):
        """Importance-sample wi given wo. ``u``: uniform numbers of shape (..., 4); if omitted they
        are drawn from the library's generator keyed by (seed, index). Returns (wi, weight, pdf),
        weight = f cos(theta_i) / pdf (0 for a sample below the horizon; (..., 3) for RGB)."""
        wo = check_directions("wo", wo)
        shape = self._shape(wo) if u is None else self._shape(wo, np.asarray(u)[..., :3])
        if u is None:
            u = self.random(math.prod(shape), seed=seed, qmc=qmc).reshape(shape + (4,))
        u = np.asarray(u, dtype=np.float64)
        if u.shape[-1:] != (4,):
            raise ParameterError(f"u must have shape (..., 4), got {u.shape}")
        if np.any(~(u >= 0) | ~(u < 1)):
            raise ParameterError("u must lie in [0, 1)")
        if self.dtype == np.float32:            # 1 - 1e-9 would round to 1.0f
            u = np.minimum(u, float(np.nextafter(np.float32(1), np.float32(0))))
        wi, weight, pdf = self._batch("sample_batch", shape,
                                      [np.moveaxis(wo, -1, 0), np.moveaxis(u, -1, 0)],
                                      [3, self.channels, 1])
        return np.moveaxis(wi, 0, -1), self._channel_axis(weight), pdf[0]

    def random(self, n: int, *, seed: int = 0, point: int = 0, stream: int = 0, qmc: bool = False):
        """(n, 4) uniform numbers of sample indices 0..n-1 from the kernels' generator
        (Philox4x32-10, or Owen-scrambled Sobol with ``qmc``)."""
        import pyopencl as cl
        n = runtime.check_int("n", n, 0, 2**32 - 1)
        point = runtime.check_int("point", point, 0, 2**32 - 1)
        stream = runtime.check_int("stream", stream, 0, 2**32 - 1)
        w = self.width
        n_pad = max(w, -(-n // w) * w)
        prog = self.program(part="random", rng="sobol" if qmc else "philox")
        buf = cl.Buffer(self.device.context, cl.mem_flags.WRITE_ONLY, 4 * n_pad * np.dtype(self.dtype).itemsize)
        lo, hi = runtime.seed_words(seed)
        runtime.kernel(prog.program, "random_batch")(self.device.queue, *runtime.ndrange(n_pad // w, self.device), np.uint64(n_pad), np.uint32(point),
                          np.uint32(stream), lo, hi, buf)
        out = np.empty((4, n_pad), dtype=self.dtype)
        cl.enqueue_copy(self.device.queue, out, buf)
        return out[:, :n].T.copy()


def model(name: str, **kw) -> Model:
    """Shorthand for ``Model(name, **kw)``."""
    return Model(name, **kw)


@dataclass
class AlbedoResult:
    """Directional albedo E(wo) with its standard error, and how it was computed."""
    albedo: np.ndarray
    stderr: np.ndarray
    mu: np.ndarray
    estimator: str
    samples: int                     # samples per point actually taken (quadrature: the
                                     # most integrand evaluations at any point)
    qmc: bool
    seed: int
    precision: str
    seconds: float
    model: dict = field(default_factory=dict)
    tol: float | None = None         # quadrature: the error target
    evaluations: np.ndarray | None = None   # quadrature: integrand evaluations per point
    sampling_stderr: np.ndarray | None = None   # Monte Carlo: the spread of the samples alone
    weight_scale: np.ndarray | None = None      # Monte Carlo: W of the unseen-event allowance

    @property
    def unseen(self):
        """The allowance for events the samples did not draw, ln(1000) W / N (``unseen``);
        ``stderr`` is it and ``sampling_stderr`` in quadrature. 0 for the quadrature."""
        if self.weight_scale is None:
            return np.zeros_like(np.asarray(self.stderr))
        return unseen(self.weight_scale, self.samples)

    def to_json(self) -> dict:
        return {"model": self.model.get("model"),
                "params": {k: v for k, v in self.model.items() if k != "model"},
                "estimator": self.estimator + ("+qmc" if self.qmc else ""), "samples": self.samples,
                "precision": self.precision, "mu": np.asarray(self.mu).tolist(),
                "albedo": np.asarray(self.albedo).tolist(), "stderr": np.asarray(self.stderr).tolist(),
                "seconds": self.seconds, "seed": self.seed,
                **({} if self.sampling_stderr is None else
                   {"sampling_stderr": np.asarray(self.sampling_stderr).tolist(),
                    "unseen": np.asarray(self.unseen).tolist()}),
                **({} if self.tol is None else
                   {"tol": self.tol, "evaluations": np.asarray(self.evaluations).tolist()})}


def _as_model(m) -> Model:
    """A Model, or a model's name (its defaults, single precision)."""
    if isinstance(m, str):
        return Model(m)
    if not isinstance(m, Model):
        raise ParameterError(f"model={m!r} is not valid: give a clbrdf.Model or a model name")
    return m


def albedo(m: Model | str, mu, phi=0.0, *, estimator: str = "brdf", samples: int = 1 << 16,
           seed: int = 0, qmc: bool = False, tol: float | None = None,
           max_evals: int | None = None, progress: bool = False) -> AlbedoResult:
    """Directional albedo E(wo) = integral f(wo, wi) cos(theta_i) dwi of a Model (or a model's
    name: its defaults).

    ``mu`` = cos(theta_o) and ``phi`` (azimuth of wo) broadcast with the model's parameters.
    ``estimator``: ``uniform`` / ``cosine`` hemisphere sampling, ``brdf`` importance sampling,
    ``mis`` (balance heuristic, one brdf and one cosine sample per estimate), all by Monte Carlo
    with ``samples`` per point; or ``quadrature``: deterministic adaptive Gauss-Legendre panels in
    the sampler's own unit square until the error estimate is at most ``tol`` (default 1e-6
    single, 1e-7 double) or ``max_evals`` integrand evaluations per point (default 2^24) are
    spent (a RuntimeWarning says how many points stopped short); ``stderr`` is then that error
    estimate and ``samples`` the most evaluations any point took. ``qmc``: Owen-scrambled Sobol
    points in 16 independent scrambles (the error estimate is their spread) instead of Philox.
    The result is bit-identical for the same arguments, device kind and width, whatever the
    chunking or work-group size. Host memory does not grow with ``samples``.
    """
    m = _as_model(m)
    _check_choice("estimator", estimator, ESTIMATORS)
    quad = estimator == "quadrature"
    if quad:
        if qmc:
            raise ParameterError("qmc=True is not valid with estimator='quadrature': the "
                                 "quadrature draws no random numbers")
        tol = QUAD_TOL[m.precision] if tol is None else tol
        if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating, np.integer)) \
                or not 0 < float(tol) < 1:
            raise ParameterError(f"tol={tol!r} is out of range: valid tol is in (0, 1)")
        tol = float(tol)
        max_evals = runtime.check_int("max_evals", runtime.QUAD_MAX_EVALS if max_evals is None
                                      else max_evals, 1 << 18, 1 << 34, "[2^18, 2^34]")
    else:
        samples = runtime.check_int("samples", samples, 2, 2**32 - 1, "[2, 2^32)")
        runtime.seed_words(seed)
        if tol is not None or max_evals is not None:
            raise ParameterError(f"tol and max_evals are for estimator='quadrature', not "
                                 f"{estimator!r}")
    mu = check_mu(mu, m.precision)
    phi = np.asarray(phi, dtype=np.float64)
    finite_or_raise("phi", phi)
    shape = m._shape(np.zeros(np.broadcast_shapes(mu.shape, phi.shape) + (3,)))
    s_theta = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    wo = [s_theta * np.cos(phi), s_theta * np.sin(phi), mu]
    cshape = shape if m.channels == 1 else shape + (m.channels,)
    if quad:
        est, err, evals, seconds = runtime.run_quadrature(m, shape, wo, tol=tol,
                                                          max_evals=max_evals, progress=progress)
        short = np.max(err, axis=1) > tol
        if short.any():
            warnings.warn(f"quadrature: {int(short.sum())} of {short.size} points stopped at "
                          f"max_evals={max_evals} with an error estimate up to "
                          f"{float(err.max()):.2g} > tol={tol:g}", RuntimeWarning, stacklevel=2)
        return AlbedoResult(est.reshape(cshape), err.reshape(cshape), np.broadcast_to(mu, shape),
                            estimator, int(evals.max(initial=0)), False, 0, m.precision, seconds,
                            m.describe(), tol=tol, evaluations=evals.reshape(shape))
    from .stability import warn_if_useless
    warn_if_useless(m, np.broadcast_to(mu, shape), estimator)
    from .checkpoint import current
    ck = current()
    run = runtime.run_albedo if ck is None else ck.run_albedo
    est, err, plan, seconds = run(m, shape, wo, estimator=estimator, samples=samples,
                                  seed=seed, qmc=qmc, progress=progress)
    scale = weight_scale(m, shape, wo, estimator, est, qmc)
    honest = reported_error(err, unseen(scale, plan.samples), rounding_floor(m.precision, est))
    return AlbedoResult(est.reshape(cshape), honest.reshape(cshape), np.broadcast_to(mu, shape),
                        estimator, plan.samples, qmc, int(seed), m.precision, seconds,
                        m.describe(), sampling_stderr=err.reshape(cshape),
                        weight_scale=scale.reshape(cshape))


# ---------------------------------------------------------------------------------------------
# What N samples cannot see (docs/accuracy/unseen.md)

UNSEEN_ALPHA = 1e-3
# Rounding floor of an albedo estimate, in units of max(|E|, 1): each sample's weight carries a
# few ulps of rounding that do not average out (a bias, not noise; GGX with kd = 1, ks = 0:
# E = 1 - 7.5e-9 +- 7.7e-11 in single), so the reported error has ROUND_ULPS ulps in quadrature.
ROUND_ULPS = 8
EPS = {"single": 2.0 ** -24, "double": 2.0 ** -53}


def rounding_floor(precision: str, e):
    return ROUND_ULPS * EPS[precision] * np.maximum(np.abs(e), 1.0)


def reported_error(sampling, unseen_part, floor):
    """The error a Monte Carlo result reports: the sampling error, the unseen-event allowance
    and the rounding floor in quadrature (docs/accuracy/unseen.md)."""
    return np.sqrt(np.square(sampling) + np.square(unseen_part) + np.square(floor))


def unseen(scale, n, alpha: float = UNSEEN_ALPHA):
    """The allowance for events that n samples did not draw: a region of the sampler's domain
    fixed by the integrand (the numbers that map below the horizon, or onto a sharp lobe), of
    probability p, is missed by all n samples with probability (1 - p)^n < exp(-p n). So either
    p < ln(1 / alpha) / n, and the region changes E by at most p W, W (``weight_scale``)
    bounding |weight - E| there, or the run draws it but with probability alpha."""
    return math.log(1 / alpha) * np.asarray(scale, dtype=np.float64) / np.asarray(n, np.float64)


def weight_scale(m: Model, shape, wo_rows, estimator: str, est=None, qmc: bool = False):
    """W of ``unseen`` for each point of ``shape`` (points, channels): the largest weight of
    one sample of the estimator over 108 deterministic probes, the same for every point: the
    model's sampler at a grid of numbers that includes the edges of its domain (its lobe's peak
    and far tail), where the weight is the estimator's own (uniform 2 pi f cos, cosine pi f, brdf
    f cos / pdf, mis twice that: each of its two balance terms is at most f cos / pdf;
    kernels/integrators.cl, albedo_probe), and |E|. Weights are >= 0, so this bounds
    |weight - E| where a missed event has weight 0 as well as where it has a large one. W = 0
    where every probe gives the same weight to within the rounding floor (``rounding_floor``,
    already in the reported error): the estimator is exact there (Lambert with cosine or brdf
    sampling)."""
    hi, lo = runtime.run_probe(m, shape, wo_rows, estimator=estimator, qmc=qmc)
    if est is not None:
        hi = np.maximum(hi, np.abs(np.asarray(est, np.float64).reshape(hi.shape)))
    return np.where(hi - lo <= rounding_floor(m.precision, hi), 0.0, hi)


GAUSS_NODES = 32
PHI_NODES = 16      # azimuths of wo in averages of anisotropic models (periodic trapezoid rule)


def _avg_rule(nodes: int, phi_nodes: int):
    """Nodes (mu, phi) and weights of E_avg = (1 / pi) int_0^2pi int_0^1 E(mu, phi) mu dmu dphi:
    Gauss-Legendre in mu; in phi the periodic trapezoid rule (spectrally accurate for a smooth
    periodic E), or phi = 0 alone for an isotropic model."""
    nodes = runtime.check_int("nodes", nodes, 1, 1024)
    phi_nodes = runtime.check_int("phi_nodes", phi_nodes, 1, 4096)
    x, wgt = np.polynomial.legendre.leggauss(nodes)
    mu = 0.5 * (x + 1)
    phi = 2 * np.pi * np.arange(phi_nodes) / phi_nodes
    c = (wgt * mu)[:, None] * np.full(phi_nodes, 1.0 / phi_nodes)[None, :]   # sums to 1
    return mu, phi, c


def _split_rule(nodes: int, kinks: np.ndarray):
    """Composite Gauss-Legendre in mu on [0, 1] split at the kinks (shape (..., K), NaN: none,
    placed at the K-quantiles instead, where a smooth E loses nothing): K + 1 panels of
    nodes // (K + 1) nodes (at least 4) per point. A panel that starts at a kink maps its nodes
    by mu = lo + (hi - lo) t^2: Fresnel beyond the critical angle grows like sqrt(mu - mu_c),
    which the map makes smooth in t (8 plain nodes were 2e-4 off there). Returns mu and the
    weights of E, shape (n, ...), the weights summing to 1 (2 int E mu dmu)."""
    K = kinks.shape[-1]
    per = max(nodes // (K + 1), 4)
    real = np.isfinite(kinks) & (kinks > 0) & (kinks < 1)
    b = np.where(real, kinks, np.arange(1, K + 1) / (K + 1))
    order = np.argsort(b, axis=-1)
    b = np.take_along_axis(b, order, -1)
    real = np.take_along_axis(real, order, -1)
    zeros = np.zeros(b.shape[:-1] + (1,))
    edges = np.concatenate([zeros, b, zeros + 1], -1)
    starts_at_kink = np.concatenate([zeros.astype(bool), real], -1)
    x, w = np.polynomial.legendre.leggauss(per)
    t, wt = (x + 1) / 2, w / 2                         # Gauss-Legendre on [0, 1]
    mus, ws = [], []
    for p in range(K + 1):
        lo, hi, sq = edges[..., p], edges[..., p + 1], starts_at_kink[..., p]
        for ti, wi in zip(t, wt):
            m = np.where(sq, lo + (hi - lo) * ti * ti, lo + (hi - lo) * ti)
            jac = np.where(sq, 2 * ti * (hi - lo), hi - lo)
            mus.append(m)
            ws.append(2 * wi * jac * m)
    return np.stack(mus), np.stack(ws)


def albedo_avg(m: Model | str, *, nodes: int = GAUSS_NODES, phi_nodes: int | None = None,
               _parts: dict | None = None, **kw):
    """E_avg = (1/pi) integral E(wo) cos(theta_o) dwo = 2 integral_0^1 E(mu) mu dmu for an
    isotropic model; returns (E_avg, stderr) broadcast over the model's parameters. Gauss-Legendre
    in mu (``nodes``), split into panels at the kinks of E in mu that the model declares (the
    critical angle of a dielectric with eta < 1, where one 32-node rule was 0.013 off at
    alpha = 1e-4, eta = 0.556); where E depends on the azimuth of wo (anisotropic models,
    Schlick's scratches: ``m.anisotropic``) also the mean over ``phi_nodes`` azimuths (default
    PHI_NODES). The error estimate is the Monte Carlo error only (with
    ``estimator='quadrature'``, the sum of the weighted error estimates), not the rule's error in
    mu and phi: the nodes' sampling errors in quadrature and, with it in quadrature, the unseen-
    event allowance of the weighted sum of their weight scales (``unseen``)."""
    m = _as_model(m)
    if phi_nodes is None:
        phi_nodes = PHI_NODES if m.anisotropic else 1
    mu, phi, c = _avg_rule(nodes, phi_nodes)
    pshape = m._shape()
    kinks = m.spec.mu_kinks(m.config, m.params)
    if kinks is not None:
        kinks = np.asarray(kinks, dtype=np.float64)
        kinks = np.broadcast_to(kinks, np.broadcast_shapes(kinks.shape[:-1], pshape)
                                + kinks.shape[-1:])
        mu_k, w_k = _split_rule(nodes, kinks)              # (n, *pshape)
        pshape = np.broadcast_shapes(pshape, mu_k.shape[1:])
        mu_in = mu_k[:, None]
        c = w_k[:, None] * np.full(phi_nodes, 1.0 / phi_nodes).reshape((1, -1) + (1,) * len(pshape))
        lead = c.shape
    else:
        lead = (len(mu), len(phi)) + (1,) * len(pshape)
        mu_in = mu.reshape((-1, 1) + (1,) * len(pshape))
    r = albedo(m, mu_in, phi.reshape((1, -1) + (1,) * len(pshape)), **kw)
    cw = np.reshape(c, lead + (1,) * (r.albedo.ndim - len(lead)))
    avg = (cw * r.albedo).sum(axis=(0, 1))
    if r.tol is not None:           # quadrature: error bounds add up
        return avg, (cw * r.stderr).sum(axis=(0, 1))
    s, scale = _avg_parts(cw, r.sampling_stderr, r.weight_scale)
    if _parts is not None:
        _parts.update(sampling_stderr=s, weight_scale=scale, samples=r.samples)
    return avg, reported_error(s, unseen(scale, r.samples), rounding_floor(m.precision, avg))


def _avg_parts(cw, sampling_stderr, scale):
    """A weighted sum's sampling error (independent: in quadrature) and its unseen-event scale
    (the nodes may all miss alike: the scales add up)."""
    return (np.sqrt(((cw * sampling_stderr) ** 2).sum(axis=(0, 1))),
            (cw * scale).sum(axis=(0, 1)))


FRESNEL_AVG_NODES = 64


def fresnel_avg(name: str = "ggx", *, nodes: int = FRESNEL_AVG_NODES, precision: str = "double",
                device=None, **params):
    """F_avg = 2 int_0^1 F(mu) mu dmu, the average Fresnel reflectance of a microfacet model's
    Fresnel configuration (``fresnel`` with f0, f90, eta, k; per channel in an RGB model), which
    Kulla-Conty's F_ms and Cycles' and OSPRay's compensation use. F is the kernel's own: read as
    eval / eval with F = 1 at the mirror pair wo = (sin, 0, mu), wi = (-sin, 0, mu) (h = z,
    wi.h = mu; D, G and 4 cos_i cos_o cancel), by Gauss-Legendre in mu split at the critical
    angle (as ``albedo_avg``). Parameters other than the Fresnel ones are not used."""
    fres = {k: v for k, v in params.items() if k in ("fresnel", "f0", "f90", "eta", "k",
                                                     "channels")}
    extra = sorted(set(params) - set(fres))
    if extra:
        raise ParameterError(f"fresnel_avg takes the Fresnel parameters (fresnel, f0, f90, eta, "
                             f"k, channels), not {', '.join(extra)}")
    m = Model(name, precision=precision, device=device, **fres)
    if m.options.get("fresnel") is None:
        raise ParameterError(f"model {name} has no Fresnel term")
    ones = Model(name, precision=precision, device=device, fresnel="one",
                 **({"channels": fres["channels"]} if "channels" in fres else {}))
    pshape = m._shape()
    kinks = m.spec.mu_kinks(m.config, m.params)
    if kinks is None:
        kinks = np.full(pshape + (1,), np.nan)
    kinks = np.asarray(kinks, dtype=np.float64)
    kinks = np.broadcast_to(kinks, np.broadcast_shapes(kinks.shape[:-1], pshape) + kinks.shape[-1:])
    mu, w = _split_rule(nodes, kinks)                      # (n, *pshape)
    s_t = np.sqrt(np.maximum(0.0, (1 - mu) * (1 + mu)))
    wo = np.stack([s_t, np.zeros_like(mu), mu], -1)
    wi = np.stack([-s_t, np.zeros_like(mu), mu], -1)
    f = np.asarray(m.eval(wo, wi), dtype=np.float64)
    f1 = np.asarray(ones.eval(wo, wi), dtype=np.float64)
    if f.ndim > f1.ndim:
        f1 = f1[..., None]
    F = f / f1
    ww = w.reshape(w.shape + (1,) * (F.ndim - w.ndim))
    return (ww * F).sum(axis=0)


def _table_axes(spec, axes, spacing=None) -> list:
    """Validated axes as axis dicts (clbrdf.axes): from a dict name -> 1-D values, axis text or
    an axis dict; named mu or theta (exactly one), phi, r (alpha = r^2, for a model with alpha)
    or a numeric parameter of the model."""
    from . import axes as ax_mod
    if not isinstance(axes, dict) or not axes:
        raise ParameterError(f"axes={axes!r} is not valid: give a dict of axis name -> 1-D values "
                             f"with at least a mu axis")
    pnames = [p.name for p in spec.params]
    out = []
    for k, v in axes.items():
        if k not in ("mu", "phi") and k not in ax_mod.MAPPED and k not in pnames:
            opts = [o.name for o in spec.options]
            why = "an option: give it as a fixed argument" if k in opts else "not a parameter"
            raise ParameterError(f"axis {k!r} of model {spec.name} is {why}; axes are mu, theta, "
                                 f"phi, r and the parameters {', '.join(pnames)}")
        if k == "r" and "alpha" not in pnames:
            raise ParameterError(f"axis r (alpha = r^2) needs a model with a parameter alpha; "
                                 f"{spec.name} has {', '.join(pnames)}")
        if isinstance(v, (dict, str, tuple)):
            ax = ax_mod.axis_from_python(k, v)
        else:
            try:
                a = np.asarray(v, dtype=np.float64)
            except (TypeError, ValueError):
                raise ParameterError(f"axis {k}={v!r} is not valid: values must be numbers") \
                    from None
            if a.ndim != 1 or a.size == 0:
                raise ParameterError(f"axis {k} must be a non-empty 1-D list of numbers, got "
                                     f"shape {a.shape}")
            finite_or_raise(f"axis {k}", a)
            ax = {"name": k, "values": a.tolist()}
        ax = ax_mod.check_form(ax)
        if (spacing or {}).get(k) and ax["spacing"] == "list":
            ax["spacing"] = spacing[k]      # values made by the caller with this spacing
        out.append(ax)
    names = [a["name"] for a in out]
    if ("mu" in names) == ("theta" in names):
        raise ParameterError("a table needs one axis of the outgoing direction: mu (--axis "
                             "mu=START:STOP:COUNT) or theta (radians, mu = cos theta)")
    if "r" in names and "alpha" in names:
        raise ParameterError("give axis r (alpha = r^2) or axis alpha, not both")
    return out


def _runtime_environment() -> dict:
    """Environment variables that change a result's bits or the device used."""
    import os
    keys = ("CLBRDF_DEVICE", "CLBRDF_WIDTH", "CLBRDF_BUILD_OPTIONS", "POCL_CPU_MAX_CU_COUNT",
            "POCL_MAX_PTHREAD_COUNT", "POCL_DEVICES", "POCL_AFFINITY", "OCL_ICD_VENDORS", "OCL_ICD_FILENAMES")
    return {k: os.environ[k] for k in keys if k in os.environ}


SPLIT = {"f0": [1.0, 0.0, 1.0], "f90": [0.0, 1.0, 1.0]}   # channels A, B, E = A + B
GROWTH = 4          # a refined cell's samples grow by this factor per look


class TargetStderrWarning(UserWarning):
    """A table's refinement stopped at max_samples with cells above target_stderr."""


def _refine(est, err, scale, shape, run, samples, target, max_samples, seed, precision,
            what="cells"):
    """Refine the cells of ``shape`` (est, err: the sampling error, scale: the unseen-event
    scale W; that shape, channels last for an RGB model) whose error, the sampling error and
    ``unseen(W, n)`` in quadrature (largest over channels), is above ``target``: per look r
    each draws (GROWTH - 1) x its samples with the seed derived from (seed, r), pooled by sample
    counts, until it meets the target or reaches ``max_samples``. ``run(flat cell indices,
    samples, seed) -> (est, sampling error, W)`` of those cells. Returns est, the error (sampling
    and unseen in quadrature) and the samples per cell; warns (TargetStderrWarning) of cells
    left above the target at the cap."""
    from .sweep import derive_seed
    est, err = np.array(est, dtype=np.float64), np.array(err, dtype=np.float64)
    rgb = est.ndim > len(shape)
    e2 = est.reshape((-1,) + est.shape[len(shape):])
    s2 = err.reshape((-1,) + err.shape[len(shape):])
    w2 = np.array(np.broadcast_to(scale, est.shape), np.float64).reshape(e2.shape)
    n = np.full(e2.shape[0], samples, dtype=np.int64)
    look = 0
    while True:
        # the standard error, and what n samples cannot see (``unseen``: a near-mirror cell of
        # 1024 samples reported E = 1 - 6e-8 +- 2e-8 for a true 1 - 1e-4)
        nn = n.reshape((-1,) + (1,) * (e2.ndim - 1))
        eff = reported_error(s2, unseen(w2, nn), rounding_floor(precision, e2))
        worst = eff.max(axis=-1) if rgb else eff
        need = np.flatnonzero((worst > target) & (n < max_samples))
        if need.size == 0:
            break
        look += 1
        add = int(min(n[need[0]] * (GROWTH - 1), max_samples - n[need[0]]))
        e_new, s_new, w_new_scale = run(need, add, derive_seed(seed, look))
        e_new = np.asarray(e_new, np.float64).reshape(e2[need].shape)
        s_new = np.asarray(s_new, np.float64).reshape(s2[need].shape)
        w_new_scale = np.asarray(w_new_scale, np.float64).reshape(w2[need].shape)
        w_old = (n[need] / (n[need] + add)).reshape((-1,) + (1,) * (e2.ndim - 1))
        w_new = 1 - w_old
        e2[need] = w_old * e2[need] + w_new * e_new
        s2[need] = np.sqrt((w_old * s2[need]) ** 2 + (w_new * s_new) ** 2)
        w2[need] = np.maximum(w2[need], w_new_scale)
        n[need] += add
    missed = worst > target
    if missed.any():
        warnings.warn(
            f"target_stderr={target:g} not reached in {int(missed.sum())} of {missed.size} "
            f"{what} at max_samples={max_samples} (standard error with what that many samples "
            f"cannot resolve up to {float(worst.max()):.2g}); raise max_samples "
            f"(--max-samples)", TargetStderrWarning, stacklevel=3)
    return e2.reshape(est.shape), eff.reshape(err.shape), n.reshape(shape)


def albedo_table(name: str, axes: dict, *, samples: int = 1 << 16, estimator: str = "brdf",
                 seed: int = 0, qmc: bool = False, precision: str = "single", device=None,
                 width: int | None = None, progress: bool = False, avg_nodes: int = GAUSS_NODES,
                 tol: float | None = None, max_evals: int | None = None,
                 phi_nodes: int | None = None, spacing: dict | None = None,
                 split: bool = False, average: bool = True, target_stderr: float | None = None,
                 max_samples: int | None = None, command: str | None = None, **fixed):
    """A table of E over the grid of ``axes`` (an ordered dict name -> 1-D values, axis text
    such as ``"0:1:32:centres"`` or an axis dict, see clbrdf.axes: ``mu`` or ``theta``, ``phi``
    (azimuth of wo, default 0), ``r`` (alpha = r^2) and any numeric model parameter, per-channel
    ones included), with fixed parameters, options and ``preset`` in ``fixed``. Returns a dict
    with ``E``, ``E_stderr`` (axes in the given order, then ``channel`` for an RGB model), one
    array per axis (its own values; the model is evaluated at ``clbrdf.axes.evaluated``),
    ``E_avg`` and ``E_avg_stderr`` over the axes other than mu, theta and phi (averaged over the
    azimuth for anisotropic models, see ``albedo_avg``), and ``metadata`` (a JSON string,
    everything the bits depend on).

    ``split=True`` (Schlick-Fresnel models) also gives ``A`` and ``B`` (and ``A_avg``, ``B_avg``,
    each with ``_stderr``): E(F0) = F0 A + B, A with F = 1 - (1 - c)^5, B with F = (1 - c)^5 and
    E = A + B with F = 1, all three from the same samples (channels of one RGB model with
    (f0, f90) = (1, 0), (0, 1), (1, 1)): the scale and bias tables of Filament, UE and three.js.
    ``average=False`` leaves out the averages (and their cost).

    ``target_stderr``: cells (and averages) whose standard error (the largest over channels,
    with the allowance for what N samples cannot see, ``unseen``, in quadrature) is above
    it get GROWTH times their samples per look from independent numbers (seed derived from
    (seed, look)), pooled with what they have, until they meet it or reach ``max_samples``
    (default 64 x samples); ``E_samples`` (and ``E_avg_samples``) say how many each took. Not
    with the quadrature, whose ``tol`` is its target."""
    from . import __version__
    from . import axes as ax_mod
    spec = get_spec(name)
    axl = _table_axes(spec, axes, spacing)
    if target_stderr is not None:
        if estimator == "quadrature":
            raise ParameterError("target_stderr is for the Monte Carlo estimators; the "
                                 "quadrature's target is tol")
        if isinstance(target_stderr, bool) or not 0 < float(target_stderr) < 1:
            raise ParameterError(f"target_stderr={target_stderr!r} is out of range: valid is "
                                 f"(0, 1)")
        samples = runtime.check_int("samples", samples, 2, 2**32 - 1, "[2, 2^32)")
        max_samples = runtime.check_int("max_samples", 64 * samples if max_samples is None
                                        else max_samples, samples, 2**32 - 1,
                                        f"[samples={samples}, 2^32)")
    elif max_samples is not None:
        raise ParameterError("max_samples is the cap of target_stderr's refinement: give "
                             "target_stderr too")
    names = [a["name"] for a in axl]
    evals = {a["name"]: ax_mod.evaluated(a) for a in axl}
    model_name = {a["name"]: ax_mod.MAPPED[a["name"]][0] if a["name"] in ax_mod.MAPPED
                  else a["name"] for a in axl}
    for k in names:
        if k in fixed or model_name[k] in fixed:
            raise ParameterError(f"parameter {model_name[k]} is given both as an axis ({k}) and "
                                 f"as a fixed value")
    if split:
        bad = sorted(set(fixed) & {"f0", "f90", "preset", "channels", "eta", "k"})
        if bad or fixed.get("fresnel", "schlick") != "schlick" or \
                not any(p.name == "f90" for p in spec.params):
            raise ParameterError(f"split=True needs a model with Schlick Fresnel (f0 and f90) "
                                 f"and sets f0, f90 and channels itself; {name} with "
                                 f"{', '.join(bad) or 'fresnel=' + str(fixed.get('fresnel'))}")
        fixed = {**fixed, "fresnel": "schlick", "channels": 3, **SPLIT}
    dir_axes = ("mu", "theta", "phi")
    pnames = [k for k in names if k not in dir_axes]
    # a model at the first grid point tells which parameters are per channel
    probe = Model(name, precision=precision, device=device, width=width, **fixed,
                  **{model_name[k]: evals[k][0] for k in pnames})
    grids = dict(zip(names, np.meshgrid(*[evals[k] for k in names], indexing="ij")))
    spectral = set(probe.config.spectral) if probe.channels > 1 else set()

    def param_grid(g):      # a per-channel axis: one value for all channels (trailing axis 1)
        return {model_name[k]: (g[k][..., None] if model_name[k] in spectral else g[k])
                for k in pnames}
    m = Model(name, precision=precision, device=device, width=width, **fixed, **param_grid(grids))
    t0 = time.perf_counter()
    out = {k: np.asarray(a["values"], dtype=np.float64) for k, a in zip(names, axl)}
    quad = {"tol": tol, "max_evals": max_evals} if estimator == "quadrature" else {}
    mu_grid = grids["mu"] if "mu" in grids else grids["theta"]
    phi_grid = grids.get("phi", np.zeros_like(mu_grid))
    r = albedo(m, mu_grid, phi_grid, samples=samples, estimator=estimator,
               seed=seed, qmc=qmc, progress=progress, **quad)
    out["E"], out["E_stderr"] = r.albedo, r.stderr
    mc = dict(estimator=estimator, qmc=qmc)
    if target_stderr is not None:
        def run_e(idx, n, sd):
            g = {k: v.reshape(-1)[idx] for k, v in grids.items()}
            sub = Model(name, precision=precision, device=device, width=width, **fixed,
                        **param_grid(g))
            d = albedo(sub, mu_grid.reshape(-1)[idx], phi_grid.reshape(-1)[idx], samples=n,
                       seed=sd, **mc)
            return d.albedo, d.sampling_stderr, d.weight_scale
        out["E"], out["E_stderr"], out["E_samples"] = _refine(
            out["E"], r.sampling_stderr, r.weight_scale, mu_grid.shape, run_e, samples,
            target_stderr, max_samples, seed, precision)
    channels = m.channels
    if split:
        full, full_s = out["E"], out["E_stderr"]
        for i, q in enumerate("ABE"):
            out[q], out[q + "_stderr"] = full[..., i], full_s[..., i]
        channels = 1
    all_names = names + (["channel"] if channels > 1 else [])
    if channels > 1:                    # RGB: a last axis "channel" (0, 1, 2 = R, G, B)
        out["channel"] = np.arange(m.channels, dtype=np.float64)
    # E_avg over the parameter axes: the model at the first direction index
    n_phi = 0
    if average:
        sub = dict(grids)
        for i in sorted((names.index(k) for k in dir_axes if k in names), reverse=True):
            sub = {n: v.take(0, axis=i) for n, v in sub.items()}
        ma = Model(name, precision=precision, device=device, width=width, **fixed,
                   **param_grid(sub))
        parts = {}
        avg, avg_s = albedo_avg(ma, nodes=avg_nodes, phi_nodes=phi_nodes, samples=samples,
                                estimator=estimator, seed=seed, qmc=qmc, progress=progress,
                                _parts=parts, **quad)
        n_phi = (PHI_NODES if ma.anisotropic else 1) if phi_nodes is None else phi_nodes
        if target_stderr is not None:
            pshape = np.broadcast_shapes(*[v.shape for v in sub.values()]) if sub else ()

            def run_a(idx, n, sd):
                g = {k: np.broadcast_to(v, pshape).reshape(-1)[idx] for k, v in sub.items()}
                sm = Model(name, precision=precision, device=device, width=width, **fixed,
                           **param_grid(g))
                pa = {}
                a, _ = albedo_avg(sm, nodes=avg_nodes, phi_nodes=phi_nodes, samples=n, seed=sd,
                                  _parts=pa, **mc)
                return a, pa["sampling_stderr"], pa["weight_scale"]
            avg, avg_s, out["E_avg_samples"] = _refine(
                np.asarray(avg), parts["sampling_stderr"], parts["weight_scale"], pshape, run_a,
                samples, target_stderr, max_samples, seed, precision, what="averages")
        if split:
            for i, q in enumerate("ABE"):
                out[q + "_avg"], out[q + "_avg_stderr"] = avg[..., i], avg_s[..., i]
        else:
            out["E_avg"], out["E_avg_stderr"] = avg, avg_s
    fixed_all = {k: (v.item() if v.ndim == 0 else v.tolist()) for k, v in probe.params.items()
                 if k not in model_name.values() and not (split and k in SPLIT)}
    dev = m.device.info
    options = dict(m.options)
    meta = {"model": name, "fixed": {**fixed_all, **options}, "options": options,
            "axes": all_names, "spacing": {a["name"]: a["spacing"] for a in axl},
            "axis_specs": [{k: v for k, v in a.items() if k != "values"} for a in axl],
            "channels": channels, "estimator": estimator, "qmc": qmc, "samples": r.samples,
            **({} if target_stderr is None else
               {"target_stderr": float(target_stderr), "max_samples": max_samples,
                "refinement": f"cells above target_stderr get {GROWTH}x their samples per look "
                              f"(independent numbers), up to max_samples"}),
            "seed": int(seed),
            **({} if r.tol is None else {"tol": r.tol, "max_evals": max_evals or
                                         runtime.QUAD_MAX_EVALS}),
            "precision": precision, "width": m.width, "device": dev.name,
            "platform": dev.platform, "driver": dev.driver, "version": __version__,
            "environment": _runtime_environment(), "seconds": time.perf_counter() - t0,
            "E": "E(mu, phi) = int f(wo, wi) cos(theta_i) dwi" + ("" if "phi" in names else
                                                                    " at phi = 0"),
            **({"E_avg": f"(1/pi) int E(wo) cos(theta_o) dwo: Gauss-Legendre with {avg_nodes} "
                         f"nodes in mu" + (f" x {n_phi} azimuths (trapezoid)" if n_phi > 1 else
                                           " (isotropic: phi = 0)")} if average else {})}
    mapped = {a["name"]: ax_mod.MAPPED[a["name"]][1] for a in axl if a["name"] in ax_mod.MAPPED}
    if mapped:
        meta["mapped"] = mapped
    if split:
        meta["split"] = ("E(F0) = F0 A + B: A with F = 1 - (1 - wi.h)^5, B with F = (1 - wi.h)^5, "
                         "E with F = 1, from the same samples")
        meta["fixed"].pop("channels", None)
    if m.preset is not None:
        meta["preset"] = {"material": m.preset.material, "source": m.preset.source,
                          "attribution": m.preset.attribution}
    if command is not None:
        meta["command"] = command
    out["metadata"] = json.dumps(meta)
    return out
