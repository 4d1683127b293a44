"""Multiple scattering between microfacets by the random walk of Heitz, Hanika, d'Eon &
Dachsbacher 2016 on the microsurface, in the kernels (kernels/heitz_ms.h; the float64 reference
is clbrdf.ref.heitz_ms): ``walk_albedo``, the directional albedo split by scattering order with
error bars, and ``walk_sample``, walks as samples (direction, weight, order).

The walk extends a model's microsurface: ``ggx`` or ``beckmann`` (any Fresnel, isotropic or
anisotropic; its single scattering is the model with masking=correlated) or ``ggx_dielectric``
or ``beckmann_dielectric`` (its single scattering is the model with masking=beta, the exact
height-correlated transmission). Every other option of those models is what the walk has no
counterpart for, and is refused.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..models.spec import ParameterError, check_directions, check_int, check_mu, finite_or_raise
from ..runtime.launch import seed_words
from ..runtime.walk import ORDERS, walk_batch, walk_sums
from .albedo import as_model
from .model import Model

# model -> the options its configuration must have for the walk to extend it
_CONDUCTOR = {"masking": "correlated"}
_GLASS = {"masking": "beta", "lobes": "both", "transport": "importance", "eta_one": "no_interface"}
WALK_MODELS = {"ggx": _CONDUCTOR, "beckmann": _CONDUCTOR, "ggx_dielectric": _GLASS,
               "beckmann_dielectric": _GLASS}
MAX_ORDER = 64


def check_walk_model(m: Model) -> None:
    """A ParameterError unless the walk extends ``m``'s configuration."""
    need = WALK_MODELS.get(m.name)
    if need is None:
        raise ParameterError(f"model={m.name!r}: the random walk extends "
                             f"{', '.join(WALK_MODELS)}")
    for k, v in need.items():
        if m.options.get(k) != v:
            raise ParameterError(f"{k}={m.options.get(k)!r} is not valid for the walk of "
                                 f"{m.name}: its single scattering is {k}={v!r}")
    if dict(m.config.defines).get("MF_DIFFUSE", "0") != "0":
        raise ParameterError("kd is not valid for the walk: it has no Lambertian term")


@dataclass
class WalkResult:
    """``albedo`` E(wo) of the multiple-scattering BSDF and its ``stderr``; ``orders`` the part
    of E of the walks that left after 1, 2, 3 or more hits (trailing axis of 3, before the
    channels), with ``orders_stderr``; ``reflected`` and ``transmitted`` E_R, E_T: the walks
    that leave on wo's side and on the other (from inside, mu < 0, reflection is below);
    ``above`` and ``below`` the same by side of the surface; ``cut`` the fraction of walks cut
    at ``max_order`` (energy lost to the bound), ``mean_hits`` the mean number of hits per
    walk."""
    albedo: np.ndarray
    stderr: np.ndarray
    orders: np.ndarray
    orders_stderr: np.ndarray
    above: np.ndarray
    below: np.ndarray
    cut: np.ndarray
    mean_hits: np.ndarray
    mu: np.ndarray
    walks: int
    max_order: int
    seed: int
    precision: str
    seconds: float
    model: dict

    def _wo_side(self, same: bool) -> np.ndarray:
        inside = np.asarray(self.mu) < 0
        if np.ndim(self.above) > np.ndim(inside):      # channels last
            inside = inside[..., None]
        return np.where(inside == same, self.below, self.above)

    @property
    def reflected(self) -> np.ndarray:
        """E_R: the walks that leave on wo's side (above for mu > 0, below from inside)."""
        return self._wo_side(True)

    @property
    def transmitted(self) -> np.ndarray:
        """E_T: the walks that leave on the side opposite wo's."""
        return self._wo_side(False)


def _mean_err(s, q, n):
    mean = s / n
    var = np.maximum(q / n - mean * mean, 0.0)
    return mean, np.sqrt(var / (n - 1))


def walk_albedo(m: Model | str, mu, phi=0.0, *, walks: int = 1 << 20, seed: int = 0,
                max_order: int = MAX_ORDER, progress: bool = False) -> WalkResult:
    """Directional albedo of the multiple-scattering BSDF by ``walks`` random walks per point,
    split by scattering order (1, 2, 3+) and by side. ``mu`` (negative: from below, for the
    dielectric) and ``phi`` broadcast with the model's parameters. Walk j of point p is keyed
    (seed, j, p): the result is bit-identical for the same arguments, device kind and width."""
    m = as_model(m)
    check_walk_model(m)
    walks = check_int("walks", walks, 2, 2**32 - 1, "[2, 2^32)")
    max_order = check_int("max_order", max_order, 1, 1 << 20, "[1, 2^20]")
    seed_words(seed)
    mu = check_mu(mu, m.precision, below=m.spec.transmits)
    phi = np.asarray(phi, dtype=np.float64)
    finite_or_raise("phi", phi)
    shape = m.points_shape(np.zeros(np.broadcast_shapes(mu.shape, phi.shape) + (3,)))
    st = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    wo = [st * np.cos(phi), st * np.sin(phi), mu]
    sums, cut, hits, seconds = walk_sums(m, shape, wo, walks, seed, max_order, progress)
    sums = sums.reshape(len(sums), 2, ORDERS, *sums.shape[2:])
    s, q = sums[..., 0], sums[..., 1]                      # (n, side, order, channel)
    e, err = _mean_err(s.sum(axis=(1, 2)), q.sum(axis=(1, 2)), walks)
    eo, erro = _mean_err(s.sum(axis=1), q.sum(axis=1), walks)
    er, et = s[:, 0].sum(axis=1) / walks, s[:, 1].sum(axis=1) / walks

    def out(a, extra=()):
        a = a.reshape(shape + extra + (m.channels,))
        return a[..., 0] if m.channels == 1 else a
    return WalkResult(out(e), out(err), out(eo, (ORDERS,)), out(erro, (ORDERS,)), out(er),
                      out(et), (cut / walks).reshape(shape), (hits / walks).reshape(shape),
                      np.broadcast_to(mu, shape), walks, max_order, int(seed), m.precision,
                      seconds, m.describe())


@dataclass
class WalkEvalResult:
    """``f`` the multiple-scattering BRDF f(wo, wi) (1/sr, without the cosine) by the paper's
    stochastic evaluation and its ``stderr`` (the spread of the walks' estimates over sqrt(walks)),
    ``orders`` the part of f from the hits of order 1, 2, 3 or more (trailing axis of 3, before
    the channels) with ``orders_stderr``; ``cut`` the fraction of walks cut at ``max_order``,
    ``mean_hits`` the mean number of hits per walk."""
    f: np.ndarray
    stderr: np.ndarray
    orders: np.ndarray
    orders_stderr: np.ndarray
    cut: np.ndarray
    mean_hits: np.ndarray
    walks: int
    max_order: int
    seed: int
    precision: str
    seconds: float
    model: dict


def walk_eval(m: Model | str, wo, wi, *, walks: int = 1 << 16, seed: int = 0,
              max_order: int = MAX_ORDER, progress: bool = False) -> WalkEvalResult:
    """The multiple-scattering BRDF at (wo, wi) by the paper's stochastic evaluation (Heitz et
    al. 2016 section 4.2, next-event estimation; clbrdf.ref.heitz_ms.evaluate is its float64
    reference): ``walks`` walks from wo per pair, each adding at every hit the chance that its
    path continues toward wi and leaves. Unbiased; the estimate of order 1 is the model's f
    (masking=correlated) in expectation. ``wo``, ``wi`` (..., 3), above the surface, broadcast
    with the parameters. Conductors (ggx, beckmann) only: the dielectric's evaluation is not in
    the kernels. Walk j of pair p is keyed (seed, j, p), as walk_albedo's."""
    m = as_model(m)
    check_walk_model(m)
    if m.spec.transmits:
        raise ParameterError(f"model={m.name!r}: the stochastic evaluation in the kernels is for "
                             "conductors (ggx, beckmann); sample the dielectric with walk_albedo "
                             "or walk_sample")
    wo = check_directions("wo", wo)
    wi = check_directions("wi", wi)
    walks = check_int("walks", walks, 2, 2**32 - 1, "[2, 2^32)")
    max_order = check_int("max_order", max_order, 1, 1 << 20, "[1, 2^20]")
    seed_words(seed)
    wo, wi = np.broadcast_arrays(wo, wi)
    shape = m.points_shape(wo)
    sums, cut, hits, seconds = walk_sums(m, shape, np.moveaxis(wo, -1, 0), walks, seed,
                                         max_order, progress, wi_rows=np.moveaxis(wi, -1, 0))
    s, q = sums[..., 0], sums[..., 1]                      # (n, class, channel)
    cos_i = np.broadcast_to(wi[..., 2], shape).reshape(-1, 1)
    e, err = _mean_err(s[:, ORDERS], q[:, ORDERS], walks)
    eo, erro = _mean_err(s[:, :ORDERS], q[:, :ORDERS], walks)

    def out(a, extra=()):
        a = a.reshape(shape + extra + (m.channels,))
        return a[..., 0] if m.channels == 1 else a
    c3 = cos_i[:, None]
    return WalkEvalResult(out(e / cos_i), out(err / cos_i), out(eo / c3, (ORDERS,)),
                          out(erro / c3, (ORDERS,)), (cut / walks).reshape(shape),
                          (hits / walks).reshape(shape), walks, max_order, int(seed),
                          m.precision, seconds, m.describe())


def walk_sample(m: Model | str, wo, *, seed: int = 0, stream: int = 0, first: int = 0,
                max_order: int = MAX_ORDER):
    """One walk per direction of ``wo`` (..., 3), as samples of the multiple-scattering BSDF:
    (wi, weight, order): the direction it leaves along (NaN where cut at ``max_order``), its
    throughput (per channel; 0 where cut), its number of hits (the scattering order; 0 where
    cut). Walk first + i is keyed (seed, first + i, stream)."""
    m = as_model(m)
    check_walk_model(m)
    wo = check_directions("wo", wo, allow_below=m.spec.transmits)
    max_order = check_int("max_order", max_order, 1, 1 << 20, "[1, 2^20]")
    stream = check_int("stream", stream, 0, 2**32 - 1)
    seed_words(seed)
    shape = m.points_shape(wo)
    first = check_int("first", first, 0, 2**32 - 1 - math.prod(shape))
    wi, weight, order = walk_batch(m, shape, np.moveaxis(wo, -1, 0), first, stream, seed,
                                   max_order)
    return np.moveaxis(wi, 0, -1), m.channel_axis(weight), order[0]
