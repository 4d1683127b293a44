"""Directional albedo and its averages: ``albedo``, ``albedo_avg``, ``fresnel_avg``, with error
bars that include what the samples did not see (docs/accuracy/unseen.md).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..models.microfacet import FRESNEL_NAMES
from ..models.choices import ESTIMATORS
from ..models.spec import (
    ParameterError,
    check_choice,
    check_fraction,
    check_int,
    check_mu,
    finite_or_raise,
    given,
)
from ..runtime.albedo import run_probe, runner
from ..runtime.launch import seed_words
from ..runtime.quadrature import check_max_evals, quadrature_runner
from .model import Model
from .useless import warn_if_useless

QUAD_TOL = {"single": 1e-6, "double": 1e-7}     # default error target of the quadrature


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


def as_model(m) -> Model:
    """A Model, or a model's name (its defaults, single precision)."""
    if isinstance(m, str):
        return Model(m)
    if not isinstance(m, Model):
        raise ParameterError(f"model={m!r} is not valid: give a clbrdf.Model or a model name")
    return m


def albedo(m: Model | str, mu, phi=0.0, *, estimator: str = "brdf", samples: int = 1 << 16,
           seed: int = 0, qmc: bool = False, tol: float | None = None,
           max_evals: int | None = None, progress: bool = False) -> AlbedoResult:
    """Directional albedo E(wo) = integral f(wo, wi) |cos(theta_i)| dwi of a Model (or a model's
    name: its defaults), over the hemisphere, or the sphere for a model that transmits.

    ``mu`` = cos(theta_o) and ``phi`` (azimuth of wo) broadcast with the model's parameters;
    mu < 0 (wo below the surface) for a model that transmits.
    ``estimator``: ``uniform`` / ``cosine`` hemisphere (sphere) sampling, ``brdf`` importance sampling,
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
    m = as_model(m)
    check_choice("estimator", estimator, ESTIMATORS)
    quad = estimator == "quadrature"
    if quad:
        if qmc:
            raise ParameterError("qmc=True is not valid with estimator='quadrature': the "
                                 "quadrature draws no random numbers")
        tol = QUAD_TOL[m.precision] if tol is None else tol
        tol = check_fraction("tol", tol)
        max_evals = check_max_evals(max_evals)
    else:
        samples = check_int("samples", samples, 2, 2**32 - 1, "[2, 2^32)")
        seed_words(seed)
        if tol is not None or max_evals is not None:
            raise ParameterError(f"tol and max_evals are for estimator='quadrature', not "
                                 f"{estimator!r}")
    mu = check_mu(mu, m.precision, below=m.spec.transmits)
    if estimator in ("uniform", "cosine") and np.any(m.spec.deltas(m.config, m.params)):
        raise ParameterError(f"{given('estimator', estimator)} cannot see the delta lobe of "
                             f"{m.spec.deltas_text}: choose brdf, mis or quadrature")
    phi = np.asarray(phi, dtype=np.float64)
    finite_or_raise("phi", phi)
    shape = m.points_shape(np.zeros(np.broadcast_shapes(mu.shape, phi.shape) + (3,)))
    s_theta = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    wo = [s_theta * np.cos(phi), s_theta * np.sin(phi), mu]
    cshape = shape if m.channels == 1 else shape + (m.channels,)
    if quad:
        est, err, evals, seconds = quadrature_runner()(m, shape, wo, tol=tol,
                                                          max_evals=max_evals, progress=progress)
        short = np.max(err, axis=1) > tol
        if short.any():
            warnings.warn(f"quadrature: {int(short.sum())} of {short.size} points stopped at "
                          f"max_evals={max_evals} with an error estimate up to "
                          f"{float(err.max()):.2g} > tol={tol:g}", RuntimeWarning, stacklevel=2)
        return AlbedoResult(est.reshape(cshape), err.reshape(cshape), np.broadcast_to(mu, shape),
                            estimator, int(evals.max(initial=0)), False, 0, m.precision, seconds,
                            m.describe(), tol=tol, evaluations=evals.reshape(shape))
    warn_if_useless(m, np.broadcast_to(mu, shape), estimator)
    est, err, plan, seconds, seen = runner()(m, shape, wo, estimator=estimator, samples=samples,
                                             seed=seed, qmc=qmc, progress=progress)
    scale = weight_scale(m, shape, wo, estimator, est, seen=seen, sampling=err)
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


def weight_scale(m: Model, shape, wo_rows, estimator: str, est=None,
                 seen=None, sampling=None):
    """W of ``unseen`` for each point of ``shape`` (points, channels): the largest weight of
    one sample of the estimator over 108 deterministic probes, the same for every point: the
    model's sampler at a grid of numbers that includes the edges of its domain (its lobe's peak
    and far tail), where the weight is the estimator's own (uniform 2 pi f cos, cosine pi f, brdf
    f cos / pdf, mis twice that: each of its two balance terms is at most f cos / pdf;
    clbrdf/runtime/albedo.py, run_probe), and |E|. Weights are >= 0, so this bounds
    |weight - E| where a missed event has weight 0 as well as where it has a large one. W = 0
    where every probe gives the same weight to within the rounding floor (``rounding_floor``,
    already in the reported error): the estimator is exact there (Lambert with cosine or brdf
    sampling).

    ``seen`` (QMC: the least and greatest weight each scramble drew, and the standard error
    the samples would have as independent ones): W is then the scale of what the samples may
    have missed given what they drew. A missed region of weight w moves the estimate by
    p |E - w|: weights are >= 0, so the low side's scale is E times the share of scrambles that
    drew no weight of 0 (the least any can be); the high side's is the mean over the scrambles
    of the part of the probes' range above the greatest weight each drew. A region every
    scramble drew is seen; one a few drew is nearly unseen. Where the Sobol points gave no gain
    over independent samples (a kinked or heavy-tailed integrand: their spread s near the
    independent one s_ind) the plain W applies in that proportion:
    W = max(low, high) + W_plain s / s_ind (docs/accuracy/unseen.md, "With Sobol points")."""
    hi, lo = run_probe(m, shape, wo_rows, estimator=estimator)
    flat = rounding_floor(m.precision, hi)
    e = None if est is None else np.abs(np.asarray(est, np.float64).reshape(hi.shape))
    if e is not None:
        hi = np.maximum(hi, e)
    if seen is not None and e is not None and sampling is not None:
        k = np.shape(seen[0])[1]                    # scrambles
        least, greatest = (np.asarray(x, np.float64).reshape(hi.shape[:1] + (k,) + hi.shape[1:])
                           for x in seen[:2])
        independent = np.asarray(seen[2], np.float64).reshape(hi.shape)
        floor = rounding_floor(m.precision, hi)[:, None]
        low = e * np.mean(least > floor, axis=1)          # scrambles that drew no zero
        short = np.maximum(hi[:, None] - greatest, 0.0)
        high = np.mean(np.where(short <= floor, 0.0, short), axis=1)
        s = np.asarray(sampling, np.float64).reshape(hi.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(independent > 0, np.minimum(s / independent, 1.0), 0.0)
        w = np.maximum(low, high) + hi * share
        return np.where(hi - lo <= flat, 0.0, w)
    return np.where(hi - lo <= flat, 0.0, hi)


GAUSS_NODES = 32
PHI_NODES = 16      # azimuths of wo in averages of anisotropic models (periodic trapezoid rule)


def avg_rule(nodes: int, phi_nodes: int):
    """Nodes (mu, phi) and weights of E_avg = (1 / pi) int_0^2pi int_0^1 E(mu, phi) mu dmu dphi:
    Gauss-Legendre in mu; in phi the periodic trapezoid rule (spectrally accurate for a smooth
    periodic E), or phi = 0 alone for an isotropic model."""
    nodes = check_int("nodes", nodes, 1, 1024)
    phi_nodes = check_int("phi_nodes", phi_nodes, 1, 4096)
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
    m = as_model(m)
    if phi_nodes is None:
        phi_nodes = PHI_NODES if m.anisotropic else 1
    mu, phi, c = avg_rule(nodes, phi_nodes)
    pshape = m.points_shape()
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
    takes = ("fresnel",) + FRESNEL_NAMES + ("channels",)
    fres = {k: v for k, v in params.items() if k in takes}
    extra = sorted(set(params) - set(fres))
    if extra:
        raise ParameterError(f"fresnel_avg takes the Fresnel parameters ({', '.join(takes)}), "
                             f"not {', '.join(extra)}")
    m = Model(name, precision=precision, device=device, **fres)
    if m.options.get("fresnel") is None:
        raise ParameterError(f"model {name} has no Fresnel term")
    ones = Model(name, precision=precision, device=device, fresnel="one",
                 **({"channels": fres["channels"]} if "channels" in fres else {}))
    pshape = m.points_shape()
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
