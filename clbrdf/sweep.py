"""Energy-conservation sweeps: the directional albedo of a model at many parameter points, each
with a verdict (gains energy, conserves, undecided), written chunk by chunk to a zarr store.

    s = clbrdf.sweep("ggx", "ggx.zarr", axes={"alpha": (1e-3, 1, 256, "log")}, samples=4096)
    s.summary()          # {"points", "gains", "conserves", "undecided", "worst": {...}}
    s["E_max"][:10]      # the arrays (zarr), sliced into NumPy

Points are a grid over the axes (C order, the last axis fastest) or, with ``random=N``, the first
N points of a scrambled Sobol sequence over the axes' box. At each point the albedo is estimated
at D outgoing directions (``directions``: Gauss-Legendre nodes in mu, times azimuths for
anisotropic models), giving E_max (the largest over directions, per channel), the direction where
it occurs and E_avg (the quadrature over the directions), each with its standard error.

Decision rule (``decide``): with K = D x channels estimates per point and at most R looks (the
first estimate and up to R - 1 refinements, each quadrupling a direction's samples, up to
``max_samples``), every estimate gets the interval [E - z s - u_lo, E + z s + u_hi] with z the
normal quantile of 1 - e / (2 R K), e = ``error_rate`` (Student's t with 15 degrees of freedom
for quasi-Monte Carlo, whose error comes from 16 scrambles), and u the allowances for events the
N samples did not draw (``unseen_bound``): a region of the sampler's domain with probability
above ln(2 R K / e) / N is missed by all N samples with probability below e / (2 R K), and
weights are >= 0, so a missed region lowers E by at most u_lo = ln(2 R K / e) |E| / N and raises
it by at most u_hi = ln(2 R K / e) W / N (W the estimator's weight scale, core.weight_scale).
A point *gains* energy when some lower bound exceeds 1, *conserves*
when every upper bound is at most 1, and is *undecided* otherwise. Between looks only the
estimates of undecided points whose interval contains 1 and whose |E - 1| exceeds the rounding
allowance (``rounding``: below it no sample count decides) get more samples (and, with
``target_stderr``, any estimate whose standard error exceeds it). By the union bound over the K
estimates, R looks and the two parts of each interval, a point's verdict is wrong with
probability at most e, to the extent that each estimate is normal (t) with its standard error
wherever its samples saw the integrand. The stored ``E_stderr`` (and ``E_max_stderr``,
``E_avg_stderr``) is the standard error with ``core.unseen`` at alpha = 1e-3 in quadrature, as
``clbrdf.albedo`` reports it. The verdict is about the D directions
computed: max E over all directions can only be larger.

Random numbers are keyed by position: the first look of direction d at point i uses the
generator at (seed, i D + d), as ``clbrdf.albedo`` over the (points, directions) grid would;
refinement r of chunk c uses a seed derived from (seed, r, c) and the estimate's position in the
chunk's list. So a chunk's values depend only on the job, never on the device that ran it, the
order chunks ran in, or restarts: the store is bit-identical for the same device kind, driver
and width (see docs/sweeps.md).

Store (zarr v3, one chunk of every array per sweep chunk, written only by the process that
computed it; zarr writes lock-free when writes align with chunks): ``params/<axis>`` (points,),
``E`` and ``E_stderr`` (points, D[, 3]) in float32, ``samples`` (points, D), ``E_max``,
``E_max_stderr``, ``E_max_dir``, ``E_avg``, ``E_avg_stderr`` (points[, 3]) in float64,
``verdict`` (points,) int8 (-1 not computed, 0 undecided, 1 conserves, 2 gains),
``directions/{mu,phi,weight}``; the job and its provenance in the group's attributes
(``clbrdf_sweep``), and ``ledger/cNNNNNNNNN.json`` per completed chunk, written after its data.
The ledger, not the chunk files, says what is done: zarr does not write chunks equal to the
fill value, and a killed process can leave a partial chunk file.
"""
from __future__ import annotations

import json
import math
import os
import platform
import signal
import threading
import time
from pathlib import Path

import numpy as np

from . import runtime
from .axes import axis_from_python, check_form, parse_axis, warp
from .spec import ParameterError

FORMAT = 1
NOT_DONE, UNDECIDED, CONSERVES, GAINS = -1, 0, 1, 2
VERDICTS = {UNDECIDED: "undecided", CONSERVES: "conserves", GAINS: "gains"}
ERROR_RATE = 1e-3         # default probability that a point's verdict is wrong
GROWTH = 4                # each refinement multiplies a direction's samples by this
MAX_GROWTH = 64           # default max_samples = MAX_GROWTH x samples (3 refinements)
CHUNK_PAIRS = 1 << 17     # default chunk: about this many (point, direction) pairs
ESTIMATORS = ("uniform", "cosine", "brdf", "mis")
DEFAULT_MU_NODES = 32     # isotropic default directions: Gauss-Legendre nodes in mu
ANISO_DIRECTIONS = (16, 8)  # anisotropic default: 16 mu nodes x 8 azimuths
ARRAYS_1 = ("E_max", "E_max_stderr", "E_max_dir", "E_avg", "E_avg_stderr")


# ---------------------------------------------------------------------------------------------
# the job: everything the bits depend on, as JSON

def _check_axis(ax: dict, spec, random: bool) -> dict:
    name = ax["name"]
    if not any(p.name == name for p in spec.params):
        opts = [o.name for o in spec.options]
        why = "an option: give it as a fixed argument (--param)" if name in opts else "not a parameter"
        raise ParameterError(f"axis {name!r} of model {spec.name} is {why}; axes are the "
                             f"parameters {', '.join(p.name for p in spec.params)}")
    if ax.get("min") is not None:
        raise ParameterError(f"axis {name}: min= is for tables; a sweep evaluates every value "
                             f"it is given")
    ax = check_form(ax, random)
    p = spec.param(name)
    p.check(np.asarray(ax["values"] if "values" in ax else [ax["start"], ax["stop"]]))
    if random and p.lo_open and min(ax["start"], ax["stop"]) <= p.lo:
        raise ParameterError(f"axis {name}: {min(ax['start'], ax['stop'])!r} is out of range: "
                             f"valid {name} is in {p.range_text()}")
    return ax


def gauss_directions(n_mu: int, n_phi: int = 1) -> dict:
    """Gauss-Legendre nodes in mu times n_phi equally spaced azimuths, with the weights of
    E_avg = (1/pi) int E mu dwo (clbrdf.core._avg_rule): mu-major order."""
    from .core import _avg_rule
    mu, phi, c = _avg_rule(n_mu, n_phi)
    M, P = np.meshgrid(mu, phi, indexing="ij")
    return {"spec": f"gauss:{n_mu}" + (f"x{n_phi}" if n_phi > 1 else ""),
            "mu": M.ravel().tolist(), "phi": P.ravel().tolist(), "weight": c.ravel().tolist()}


def parse_directions(text: str, precision: str) -> dict:
    """``gauss:N`` / ``gauss:NxM`` (N Gauss-Legendre mu nodes x M azimuths: E_avg by quadrature)
    or ``mu=v1,v2,...[;phi=p1,p2,...]`` (every mu with every phi; no E_avg)."""
    from .spec import check_mu
    t = text.strip()
    form = "expected gauss:N, gauss:NxM or mu=v1,v2,...[;phi=p1,...]"
    if t.startswith("gauss:"):
        n, _, m = t[6:].partition("x")
        try:
            n_mu, n_phi = int(n), int(m or 1)
        except ValueError:
            raise ParameterError(f"--directions {text!r} is malformed: {form}") from None
        runtime.check_int("directions N (mu nodes)", n_mu, 1, 1024)
        runtime.check_int("directions M (azimuths)", n_phi, 1, 1024)
        return gauss_directions(n_mu, n_phi)
    parts = dict(p.partition("=")[::2] for p in t.split(";"))
    if "mu" not in parts or set(parts) - {"mu", "phi"}:
        raise ParameterError(f"--directions {text!r} is malformed: {form}")
    try:
        mu = np.array([float(x) for x in parts["mu"].split(",")])
        phi = np.array([float(x) for x in parts.get("phi", "0").split(",")])
    except ValueError:
        raise ParameterError(f"--directions {text!r}: values must be numbers ({form})") from None
    check_mu(mu, precision)
    if not np.all(np.isfinite(phi)):
        raise ParameterError(f"--directions {text!r}: phi must be finite")
    M, P = np.meshgrid(mu, phi, indexing="ij")
    return {"spec": t, "mu": M.ravel().tolist(), "phi": P.ravel().tolist(), "weight": None}


def _probe_params(axes, spec) -> dict:
    """A few values per axis (its ends and middle) to build probe models from."""
    out = {}
    for ax in axes:
        v = ax.get("values") or [ax["start"], ax["stop"]]
        out[ax["name"]] = np.unique(np.asarray([v[0], v[len(v) // 2], v[-1]], dtype=np.float64))
    return out


def make_job(model: str, *, axes=None, random=None, directions=None, samples: int = 4096,
             max_samples=None, target_stderr=None, estimator: str = "brdf", qmc: bool = False,
             error_rate: float = ERROR_RATE, seed: int = 0, precision: str = "single", width=None,
             chunk=None, preset=None, device=None, **fixed) -> dict:
    """Validate every argument (nothing is computed) and return the job: a JSON-able dict."""
    from .core import PRECISIONS, _check_choice
    from .models import get_spec
    spec = get_spec(model)
    _check_choice("estimator", estimator, ESTIMATORS)
    _check_choice("precision", precision, PRECISIONS)
    if random is not None:
        random = runtime.check_int("random", random, 1, 2**40, "[1, 2^40]")
    axes = axes or {}
    if isinstance(axes, dict):
        axes = [axis_from_python(k, v) for k, v in axes.items()]
    else:
        axes = [parse_axis(a) if isinstance(a, str) else dict(a) for a in axes]
    names = [a["name"] for a in axes]
    for k in names:
        if names.count(k) > 1:
            raise ParameterError(f"axis {k} is given twice")
        if k in fixed:
            raise ParameterError(f"parameter {k} is given both as an axis and as a fixed value")
    axes = [_check_axis(a, spec, random is not None) for a in axes]
    if random is not None and not axes:
        raise ParameterError("random points need at least one axis range (--axis NAME=START:STOP)")
    npoints = random if random is not None else math.prod(len(a["values"]) for a in axes)
    samples = runtime.check_int("samples", samples, 2, 2**31, "[2, 2^31]")
    max_samples = samples * MAX_GROWTH if max_samples is None else max_samples
    max_samples = runtime.check_int("max_samples", max_samples, samples, 2**40,
                                    f"[samples={samples}, 2^40]")
    if target_stderr is not None:
        if isinstance(target_stderr, bool) or not 0 < float(target_stderr) < 1:
            raise ParameterError(f"target_stderr={target_stderr!r} is out of range: valid is (0, 1)")
        target_stderr = float(target_stderr)
    if isinstance(error_rate, bool) or not isinstance(error_rate, (int, float)) or \
            not 0 < float(error_rate) < 0.5:
        raise ParameterError(f"error_rate={error_rate!r} is out of range: valid error_rate (the "
                             f"probability that a point's verdict is wrong) is in (0, 0.5)")
    runtime.seed_words(seed)
    # the configuration at a few points of the box checks the fixed parameters and axes together
    channels = fixed.pop("channels", None)
    params = dict(fixed)
    if preset is not None:              # a published fit; fixed parameters override it
        from . import presets
        pr = presets.get(spec.name, preset)
        params = {**pr.options, **pr.params, **params}
        channels = 3 if channels is None else channels
    channels = channels or 1
    probe = _probe_params(axes, spec)
    params = {k: v for k, v in params.items() if k not in probe}      # axes override a preset
    grid = [g.reshape(-1) for g in np.meshgrid(*probe.values(), indexing="ij")] if probe else []
    spectral_axes = [k for k in probe if spec.param(k).spectral and channels > 1]
    cfg, values = spec.configure(channels=channels, **params, **{
        k: (g[:, None] if k in spectral_axes else g) for k, g in zip(probe, grid)})
    unused = [a["name"] for a in axes if a["name"] not in cfg.param_names]
    if unused:
        raise ParameterError(f"axis {unused[0]} is not a parameter of model {spec.name} with "
                             f"{', '.join(f'{k}={v}' for k, v in dict(cfg.options).items())}: it "
                             f"uses {', '.join(cfg.param_names)}")
    if width is None:
        width = runtime.working_width(resolve_devices(device)[0], precision)
    if isinstance(width, bool) or width not in (1, 2, 4, 8, 16):
        raise ParameterError(f"width={width!r} is not valid: choose one of 1, 2, 4, 8, 16")
    if directions is None:
        directions = gauss_directions(*ANISO_DIRECTIONS) if spec.anisotropic(cfg, values) \
            else gauss_directions(DEFAULT_MU_NODES)
    elif isinstance(directions, str):
        directions = parse_directions(directions, precision)
    else:
        directions = dict(directions)
    from .spec import check_mu
    check_mu(directions["mu"], precision)
    D = len(directions["mu"])
    if D > 32767:
        raise ParameterError(f"directions: {D} is too many: at most 32767 per point")
    chunk = max(1, CHUNK_PAIRS // D) if chunk is None else chunk
    chunk = runtime.check_int("chunk", chunk, 1, 2**31 // D, f"[1, 2^31 / {D} directions]")
    chunk = min(chunk, npoints)
    fixed_json = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in fixed.items()}
    if channels > 1 and preset is None:
        fixed_json["channels"] = channels
    return {"format": FORMAT, "model": spec.name, "preset": preset, "fixed": fixed_json,
            "axes": axes, "random": random, "points": int(npoints), "directions": directions,
            "estimator": estimator, "qmc": bool(qmc), "samples": samples,
            "max_samples": max_samples, "target_stderr": target_stderr, "error_rate": float(error_rate),
            "seed": int(seed), "precision": precision, "width": int(width), "chunk": int(chunk),
            "channels": channels, "spectral_axes": spectral_axes}


# the job keys a resume compares, with the argument that sets each (CLI form)
ARGUMENTS = {"model": "MODEL", "preset": "--preset", "fixed": "--param", "axes": "--axis",
             "random": "--random", "directions": "--directions", "estimator": "--estimator",
             "qmc": "--qmc", "samples": "--samples", "max_samples": "--max-samples",
             "target_stderr": "--target-stderr", "error_rate": "--error-rate", "seed": "--seed",
             "precision": "--precision", "width": "--width", "chunk": "--chunk"}


def job_difference(old: dict, new: dict) -> str | None:
    """None if two jobs compute the same arrays, else which argument differs and how."""
    for key, arg in ARGUMENTS.items():
        a, b = old.get(key), new.get(key)
        if a == b:
            continue
        if key == "fixed":
            for k in sorted(set(a) | set(b)):
                if a.get(k) != b.get(k):
                    return f"--param {k} differs (store: {a.get(k)!r}, now: {b.get(k)!r})"
        if key == "axes":
            an, bn = [x["name"] for x in a], [x["name"] for x in b]
            if an != bn:
                return f"--axis differs (store: axes {an}, now: {bn})"
            for x, y in zip(a, b):
                if x != y:
                    show = lambda ax: {k: v for k, v in ax.items() if k != "values"} \
                        if "count" in ax else ax
                    return f"--axis {x['name']} differs (store: {show(x)}, now: {show(y)})"
        if key == "directions":
            return f"--directions differs (store: {a['spec']!r}, now: {b['spec']!r})"
        return f"{arg} differs (store: {a!r}, now: {b!r})"
    return None


# ---------------------------------------------------------------------------------------------
# the points of a chunk

def chunk_bounds(job: dict, index: int) -> tuple[int, int]:
    c = job["chunk"]
    return index * c, min(job["points"], (index + 1) * c)


def n_chunks(job: dict) -> int:
    return -(-job["points"] // job["chunk"])


def point_values(job: dict, i0: int, i1: int) -> dict:
    """Axis values of points i0 .. i1 - 1: {name: (i1 - i0,) float64}."""
    axes = job["axes"]
    if job["random"] is None:
        counts = [len(a["values"]) for a in axes]
        idx = np.unravel_index(np.arange(i0, i1), counts) if axes else ()
        return {a["name"]: np.asarray(a["values"], dtype=np.float64)[i] for a, i in zip(axes, idx)}
    import warnings
    from scipy.stats import qmc
    sob = qmc.Sobol(len(axes), scramble=True, seed=job["seed"])
    if i0:
        sob.fast_forward(i0)
    with warnings.catch_warnings():     # balance warnings for counts that are not powers of 2
        warnings.simplefilter("ignore")
        u = sob.random(i1 - i0)
    return {a["name"]: warp(u[:, j], a["start"], a["stop"], a["spacing"])
            for j, a in enumerate(axes)}


def derive_seed(seed: int, *words: int) -> int:
    """A 64-bit seed from (seed, words) by SplitMix64 steps (Steele et al. 2014)."""
    x = seed & 0xFFFFFFFFFFFFFFFF
    for w in words:
        x = (x ^ (w & 0xFFFFFFFFFFFFFFFF)) + 0x9E3779B97F4A7C15 & 0xFFFFFFFFFFFFFFFF
        x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9 & 0xFFFFFFFFFFFFFFFF
        x = (x ^ (x >> 27)) * 0x94D049BB133111EB & 0xFFFFFFFFFFFFFFFF
        x ^= x >> 31
    return x


def looks(job: dict) -> int:
    """R: the first estimate and the refinements that fit under max_samples."""
    r, n = 1, job["samples"]
    while n * GROWTH <= job["max_samples"]:
        n *= GROWTH
        r += 1
    return r


def z_value(job: dict) -> float:
    """The interval half-width in standard errors (module docstring)."""
    from scipy import stats
    K = len(job["directions"]["mu"]) * job["channels"]
    p = job["error_rate"] / (2 * looks(job) * K)
    return float(stats.t.isf(p, runtime.QMC_STREAMS - 1) if job["qmc"] else stats.norm.isf(p))


def rounding(job: dict, E):
    """The rounding allowance added to z s: ROUND_ULPS ulps of max(|E|, 1) (core.rounding_floor), a bias
    of the weights in the working precision that no sample count averages out (GGX with kd = 1,
    ks = 0: E = 1 - 7.5e-9 +- 7.7e-11 in single)."""
    from .core import rounding_floor
    return rounding_floor(job["precision"], E)


def unseen_bound(job: dict, E, W, N):
    """The unseen-event allowances of each estimate at the rule's per-estimate error rate
    (core.unseen with alpha = e / (2 R K)), below and above: weights are >= 0, so events the N
    samples missed lower E by at most ln(2 R K / e) |E| / N and raise it by at most
    ln(2 R K / e) W / N. E, W (n D, channels), N (n D,)."""
    from .core import unseen
    K = len(job["directions"]["mu"]) * job["channels"]
    n = np.asarray(N, np.float64)[:, None]
    a = job["error_rate"] / (2 * looks(job) * K)
    return unseen(np.abs(E), n, alpha=a), unseen(W, n, alpha=a)


def bounds(job: dict, E, s, z, u=(0.0, 0.0)):
    """Lower and upper bounds of each estimate: E - (z s + u[0] + rounding) and
    E + (z s + u[1] + rounding), u the unseen-event allowances below and above
    (``unseen_bound``)."""
    h = z * s + rounding(job, E)
    return E - h - u[0], E + h + u[1]


def decide(lo, hi):
    """Verdicts of points from the bounds, of shape (points, D, channels) (module docstring)."""
    gains = np.any(lo > 1, axis=(1, 2))
    conserves = np.all(hi <= 1, axis=(1, 2))
    return np.where(gains, GAINS, np.where(conserves, CONSERVES, UNDECIDED)).astype(np.int8)


def _model(job, device, vals: dict, rows: np.ndarray):
    """The model at points ``rows`` of a chunk (flat pairs), with its fixed parameters."""
    from .core import Model
    params = {}
    for k, v in vals.items():
        v = v[rows]
        params[k] = v[:, None] if k in job["spectral_axes"] else v
    return Model(job["model"], precision=job["precision"], device=device, width=job["width"],
                 preset=job["preset"], **job["fixed"], **params)


def compute_chunk(job: dict, index: int, device) -> dict:
    """Every array of chunk ``index`` (numpy, keyed as in the store)."""
    from .core import reported_error, unseen, weight_scale
    i0, i1 = chunk_bounds(job, index)
    n = i1 - i0
    dirs = job["directions"]
    mu, phi = np.asarray(dirs["mu"]), np.asarray(dirs["phi"])
    D, nch = len(mu), job["channels"]
    vals = point_values(job, i0, i1)
    pt = np.repeat(np.arange(n), D)                 # flat pair k = point * D + direction
    dr = np.tile(np.arange(D), n)
    s_t = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    wo_all = [s_t * np.cos(phi), s_t * np.sin(phi), mu]
    est = dict(estimator=job["estimator"], qmc=job["qmc"], progress=False)

    def run(rows, samples, seed, id0, scale=False):
        m = _model(job, device, vals, pt[rows])
        wo = [w[dr[rows]] for w in wo_all]
        e, s, plan, _ = runtime.run_albedo(m, (len(rows),), wo, samples=samples, seed=seed,
                                           point0=id0, **est)
        if scale:           # the unseen-event scale W of each estimate (core.weight_scale)
            return e, s, plan.samples, weight_scale(m, (len(rows),), wo, job["estimator"], e,
                                                    job["qmc"])
        return e, s, plan.samples
    # look 0: pair k of point i0 + k // D has generator index (i0 D + k), split where the 32-bit
    # index wraps (the part above 2^32 goes into the seed)
    E = np.empty((n * D, nch))
    S = np.empty((n * D, nch))
    W = np.empty((n * D, nch))
    N = np.zeros(n * D, dtype=np.uint64)
    a, end = i0 * D, i1 * D
    while a < end:
        hi = a >> 32
        b = min(end, (hi + 1) << 32)
        rows = np.arange(a - i0 * D, b - i0 * D)
        seed = job["seed"] if hi == 0 else derive_seed(job["seed"], 0, hi)
        E[rows], S[rows], N[rows], W[rows] = run(rows, job["samples"], seed, a & 0xFFFFFFFF,
                                                 scale=True)
        a = b
    z = z_value(job)
    n_now = job["samples"]
    for r in range(1, looks(job)):
        lo, hi = bounds(job, E, S, z, unseen_bound(job, E, W, N))
        verdict = decide(lo.reshape(n, D, nch), hi.reshape(n, D, nch))
        # more samples can decide an interval around 1 only where |E - 1| exceeds the rounding
        # allowance (GGX at alpha 1e-4: E = 1 - 1e-9, undecided at any sample count)
        open_ = (verdict == UNDECIDED)[pt] & np.any(
            (lo <= 1) & (hi > 1) & (np.abs(E - 1) > rounding(job, E)), axis=1)
        if job["target_stderr"] is not None:
            open_ |= np.any(reported_error(S, unseen(W, N[:, None]), rounding(job, E))
                            > job["target_stderr"], axis=1)
        rows = np.flatnonzero(open_)
        if rows.size == 0:
            break
        e, s, m_r = run(rows, n_now * (GROWTH - 1), derive_seed(job["seed"], r, index), 0)
        n_old = N[rows].astype(np.float64)[:, None]
        tot = n_old + m_r
        E[rows] = (n_old * E[rows] + m_r * e) / tot
        S[rows] = np.sqrt((n_old * S[rows]) ** 2 + (m_r * s) ** 2) / tot
        N[rows] += np.uint64(m_r)
        n_now *= GROWTH
    E3, S3 = E.reshape(n, D, nch), S.reshape(n, D, nch)
    U3 = unseen(W, N[:, None]).reshape(n, D, nch)       # the reported allowance (alpha 1e-3)
    H3 = reported_error(S3, U3, rounding(job, E3))      # the reported error
    am = np.argmax(E3, axis=1)                                      # (n, nch)
    take = lambda a: np.take_along_axis(a, am[:, None, :], axis=1)[:, 0]
    out = {"E": E3.astype(np.float32), "E_stderr": H3.astype(np.float32),
           "samples": N.reshape(n, D).astype(np.uint32 if N.max(initial=0) < 2**32 else np.uint64),
           "E_max": take(E3), "E_max_stderr": take(H3), "E_max_dir": am.astype(np.int16),
           "verdict": decide(*bounds(job, E3, S3, z, [u.reshape(n, D, nch) for u in
                                                       unseen_bound(job, E, W, N)]))}
    if dirs["weight"] is not None:
        w = np.asarray(dirs["weight"])[None, :, None]
        out["E_avg"] = (w * E3).sum(axis=1)
        out["E_avg_stderr"] = reported_error(np.sqrt(((w * S3) ** 2).sum(axis=1)),
                                             (w * U3).sum(axis=1), rounding(job, out["E_avg"]))
    else:
        out["E_avg"] = out["E_avg_stderr"] = np.full((n, nch), np.nan)
    if nch == 1:
        for k in ("E", "E_stderr", *ARRAYS_1):
            out[k] = out[k][..., 0]
    for k, v in vals.items():
        out["params/" + k] = v
    return out


# ---------------------------------------------------------------------------------------------
# the store

def _array_specs(job: dict) -> dict:
    """name -> (shape, dtype, fill) of every per-point array."""
    N, D, c = job["points"], len(job["directions"]["mu"]), job["channels"]
    ch = (c,) if c > 1 else ()
    specs = {"E": ((N, D) + ch, "float32", np.nan), "E_stderr": ((N, D) + ch, "float32", np.nan),
             "samples": ((N, D), "uint32" if job["max_samples"] < 2**32 else "uint64", 0),
             "E_max": ((N,) + ch, "float64", np.nan), "E_max_stderr": ((N,) + ch, "float64", np.nan),
             "E_max_dir": ((N,) + ch, "int16", -1), "E_avg": ((N,) + ch, "float64", np.nan),
             "E_avg_stderr": ((N,) + ch, "float64", np.nan), "verdict": ((N,), "int8", NOT_DONE)}
    for a in job["axes"]:
        specs["params/" + a["name"]] = ((N,), "float64", np.nan)
    return specs


def rule_text(job: dict) -> str:
    from .core import ROUND_ULPS
    K = len(job["directions"]["mu"]) * job["channels"]
    dist = "Student t, 15 dof (16 scrambles)" if job["qmc"] else "normal"
    rate = job["error_rate"] / (2 * looks(job) * K)
    return (f"[E - z s - |E| ln(1 / {rate:.3g}) / N, E + z s + W ln(1 / {rate:.3g}) / N], each "
            f"widened by {ROUND_ULPS} ulps of max(|E|, 1), per estimate, z = {z_value(job):.4f} "
            f"({dist} quantile of 1 - e / (2 R K), error rate e = {job['error_rate']:g}, "
            f"R = {looks(job)} looks, K = {K} estimates per point; the ln(...) / N terms: events "
            f"the N samples did not draw, which lower E by at most that share of |E| and raise "
            f"it by at most that share of W, the estimator's weight scale); "
            f"gains: some lower bound > 1; conserves: every upper bound <= 1; else undecided. "
            f"Undecided estimates whose interval contains 1, with |E - 1| above the rounding "
            f"allowance, get {GROWTH}x the samples per look, up to {job['max_samples']}. "
            f"P(wrong verdict) <= e per point.")


def _create(path: Path, job: dict, manifest: dict) -> None:
    """The empty store, built beside ``path`` and renamed into place."""
    import zarr
    from .tables import _alive
    for old in path.parent.glob(f".{path.name}.*.creating"):        # left by a killed process
        pid = old.name[len(path.name) + 2:].split(".", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            import shutil
            shutil.rmtree(old, ignore_errors=True)
    tmp = path.parent / f".{path.name}.{os.getpid()}.creating"
    root = zarr.open_group(str(tmp), mode="w")
    root.attrs["clbrdf_sweep"] = manifest
    C = job["chunk"]
    for name, (shape, dtype, fill) in _array_specs(job).items():
        root.create_array(name, shape=shape, dtype=dtype, chunks=(C,) + shape[1:],
                          fill_value=fill, config={"write_empty_chunks": True},
                          dimension_names=("point", "direction", "channel")[:len(shape)])
    for k in ("mu", "phi"):
        root.create_array(f"directions/{k}", data=np.asarray(job["directions"][k]))
    w = job["directions"]["weight"]
    root.create_array("directions/weight", data=np.asarray(
        w if w is not None else [np.nan] * len(job["directions"]["mu"])))
    (tmp / "ledger").mkdir()
    os.rename(tmp, path)


def _ledger_path(path: Path, index: int) -> Path:
    return Path(path) / "ledger" / f"c{index:09d}.json"


def done_chunks(path) -> set[int]:
    """Chunks whose ledger entry exists (written after all their data)."""
    d = Path(path) / "ledger"
    return {int(p.name[1:10]) for p in d.glob("c*.json") if len(p.name) == 15}


def _write_chunk(root, path: Path, job: dict, index: int, arrays: dict, info: dict) -> None:
    i0, i1 = chunk_bounds(job, index)
    for k, v in arrays.items():
        root[k][i0:i1] = v
    entry = {"chunk": index, "points": [i0, i1], **info}
    led = _ledger_path(path, index)
    tmp = led.with_name(f".{led.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    tmp.write_text(json.dumps(entry))
    os.replace(tmp, led)


def device_fingerprint(device) -> dict:
    i = device.info
    return {"device": i.name, "platform": i.platform, "driver": i.driver,
            "compute_units": int(device.cl_device.max_compute_units)}


# ---------------------------------------------------------------------------------------------
# running

class _Stop:
    """Set by SIGINT / SIGTERM (or a failed worker): workers finish their chunk and return."""

    def __init__(self):
        self.event = threading.Event()
        self.reason: BaseException | None = None


def _local_worker(root, path, job, device, todo, lock, stop: _Stop, bar, errors):
    try:
        while not stop.event.is_set():
            with lock:
                if not todo:
                    return
                index = todo.popleft()
            t0 = time.perf_counter()
            arrays = compute_chunk(job, index, device)
            seconds = time.perf_counter() - t0
            _write_chunk(root, path, job, index, arrays,
                         {"seconds": seconds, **device_fingerprint(device), "host": platform.node()})
            i0, i1 = chunk_bounds(job, index)
            bar.update(i1 - i0)
    except BaseException as e:          # noqa: BLE001 - re-raised in the main thread
        errors.append(e)
        stop.event.set()


def resolve_devices(device) -> list:
    """A selector, a Device, or a list of them -> Device objects; a device named twice gets a
    second context and queue of its own (two contexts share its compute units)."""
    from .device import Device, get_device
    if device is None or isinstance(device, (str, int)) or hasattr(device, "context"):
        return [get_device(device)]
    out = []
    for d in device:
        d = d if hasattr(d, "context") else get_device(d)
        out.append(Device(d.info, d.cl_device) if any(o is d for o in out) else d)
    return out


def split_device(device, parts: int) -> list:
    """``parts`` sub-devices of equal compute units by OpenCL device fission (PoCL CPUs support
    it), each a Device with its own context and queue."""
    import pyopencl as cl
    from .device import Device, get_device
    device = get_device(device) if not hasattr(device, "context") else device
    cu = device.cl_device.max_compute_units
    parts = runtime.check_int("split", parts, 1, max(1, cu), f"[1, {cu} compute units]")
    try:
        subs = device.cl_device.create_sub_devices(
            [cl.device_partition_property.EQUALLY, cu // parts])[:parts]
    except cl.Error as e:
        raise ParameterError(f"split={parts}: {device.info.name} cannot be split by device "
                             f"fission ({e})") from None
    return [Device(device.info, d) for d in subs]


def _install_sigterm():
    """SIGTERM raises KeyboardInterrupt in the main thread while a sweep runs (unless a handler
    is already installed, as the CLI's)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        return None

    def handler(signum, frame):
        raise KeyboardInterrupt("SIGTERM")
    return signal.signal(signal.SIGTERM, handler)


def sweep(model: str | None = None, out=None, *, resume: bool = False, device=None,
          client=None, progress: bool = False, command: str | None = None, **kw):
    """Run (or, with ``resume=True``, continue) a sweep into the zarr store ``out`` and return it
    opened (``Sweep``). Arguments as ``make_job``: ``axes`` (dict name -> (start, stop, count[,
    spacing]) or values or (start, stop[, spacing]) with ``random=N``), ``directions``,
    ``samples``, ``max_samples``, ``target_stderr``, ``estimator``, ``qmc``, ``error_rate``, ``seed``,
    ``precision``, ``width``, ``chunk``, ``preset`` and fixed parameters and options.
    ``device``: a selector, a Device, or a list of them (chunks are dealt out as devices
    finish); ``client``: a dask.distributed Client whose workers compute the chunks (see
    clbrdf.cluster). With ``resume=True`` and no model, the store's own job continues.
    SIGINT or SIGTERM stop the run after the chunks in progress, with all of them written;
    KeyboardInterrupt is then raised."""
    if out is None:
        raise ParameterError("out (the store path) is required")
    path = Path(out)
    if resume:
        if not (path / "zarr.json").exists():
            raise ParameterError(f"--resume: {str(path)!r} is not a sweep store (no zarr.json); "
                                 f"start it without --resume")
        old = open_sweep(path).manifest
        if model is None:
            job = old["job"]
        else:
            job = make_job(model, device=None if client is not None else
                           resolve_devices(device)[0], **kw)
            why = job_difference(old["job"], job)
            if why:
                raise ParameterError(f"cannot resume {str(path)!r}: {why}; resume with the "
                                     f"store's arguments or write a new store")
    else:
        if model is None:
            raise ParameterError("a model is required (or resume=True for an existing store)")
        if path.exists():
            raise ParameterError(f"--out {str(path)!r} exists: continue it with --resume or "
                                 f"choose a new path")
        if not path.parent.is_dir():
            raise ParameterError(f"--out {str(path)!r}: directory {str(path.parent)!r} does not "
                                 f"exist")
        if client is not None and kw.get("width") is None:
            from .cluster import worker_width
            kw["width"] = worker_width(client, kw.get("precision", "single"))
        job = make_job(model, device=None if client is not None else resolve_devices(device)[0],
                       **kw)
    from .checkpoint import lock_dir
    if not resume:
        _create(path, job, _manifest(job, command))
    lock = lock_dir(path)       # one process per store: a second --resume redid every chunk
    try:
        import zarr
        return _sweep_run(zarr.open_group(str(path), mode="r+"), path, job, client, device,
                          progress)
    finally:
        os.close(lock)


def _manifest(job: dict, command) -> dict:
    import scipy
    import zarr
    from . import __version__
    from .core import _runtime_environment
    return {"job": job, "clbrdf": __version__, "created": time.strftime(
        "%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "command": command, "host": platform.node(),
        "rule": rule_text(job), "z": z_value(job), "looks": looks(job),
        "software": {"numpy": np.__version__, "scipy": scipy.__version__,
                     "zarr": zarr.__version__},
        "environment": _runtime_environment()}


def _sweep_run(root, path, job, client, device, progress):
    done = done_chunks(path)
    todo = [i for i in range(n_chunks(job)) if i not in done]
    total = job["points"]
    bar = runtime.progress_bar(total, progress, unit="pt")
    bar.update(total - sum(chunk_bounds(job, i)[1] - chunk_bounds(job, i)[0] for i in todo))
    stop = _Stop()
    previous = _install_sigterm()
    try:
        if client is not None:
            from .cluster import run_on_cluster
            run_on_cluster(client, root, path, job, todo, stop, bar, _write_chunk, device)
        else:
            _run_local(root, path, job, resolve_devices(device), todo, stop, bar)
    finally:
        bar.close()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    return open_sweep(path)


def _run_local(root, path, job, devices, todo, stop, bar):
    from collections import deque
    todo = deque(todo)
    lock = threading.Lock()
    errors: list = []
    threads = [threading.Thread(target=_local_worker, daemon=True, name=f"clbrdf-sweep-{i}",
                                args=(root, path, job, d, todo, lock, stop, bar, errors))
               for i, d in enumerate(devices)]
    for t in threads:
        t.start()
    try:
        while any(t.is_alive() for t in threads):
            for t in threads:
                t.join(0.1)
    except BaseException:               # SIGINT / SIGTERM: finish the chunks in progress
        stop.event.set()
        for t in threads:
            while t.is_alive():
                t.join(0.1)
        raise
    if errors:
        raise errors[0]


# ---------------------------------------------------------------------------------------------
# reading

class Sweep:
    """An opened sweep store: ``s["E_max"]`` and the other arrays (zarr, sliced into NumPy),
    ``s.job``, ``s.manifest``, ``s.directions``, ``s.complete``, ``s.summary()``."""

    def __init__(self, path):
        import zarr
        self.path = Path(path)
        if not (self.path / "zarr.json").exists():
            raise ParameterError(f"{str(self.path)!r} is not a sweep store (no zarr.json)")
        self.root = zarr.open_group(str(self.path), mode="r")
        self.manifest = dict(self.root.attrs.get("clbrdf_sweep") or {})
        if not self.manifest:
            raise ParameterError(f"{str(self.path)!r} is a zarr store but not a clbrdf sweep")
        self.job = self.manifest["job"]

    def __getitem__(self, name):
        """An array of the store by name (``s["E_max"]``, ``s["params/alpha"]``); slice it into
        NumPy. Points are not items: ``s["E_max"][i]`` is point i's."""
        if not isinstance(name, str):
            raise ParameterError(f"sweep[{name!r}]: index a sweep by array name ("
                                 f"{', '.join(self.arrays())}), then the array by point")
        if name not in self:
            raise ParameterError(f"sweep {str(self.path)!r} has no array {name!r}: it has "
                                 f"{', '.join(self.arrays())}")
        return self.root[name]

    def __contains__(self, name) -> bool:
        return isinstance(name, str) and name in self.arrays()

    def arrays(self) -> list:
        """The names of the store's arrays (parameters as params/NAME, directions/NAME)."""
        return sorted(list(_array_specs(self.job)) + [f"directions/{k}" for k in
                                                      ("mu", "phi", "weight")])

    @property
    def points(self) -> int:
        return self.job["points"]

    @property
    def axes(self) -> list[str]:
        return [a["name"] for a in self.job["axes"]]

    @property
    def directions(self) -> dict:
        return {k: self.root[f"directions/{k}"][:] for k in ("mu", "phi", "weight")}

    def done(self) -> set[int]:
        return done_chunks(self.path)

    @property
    def complete(self) -> bool:
        return len(self.done()) == n_chunks(self.job)

    def chunks(self, arrays=("E_max", "E_max_stderr", "E_max_dir", "verdict")):
        """(i0, {name: values}) of every completed chunk, in order: memory per chunk only."""
        for index in sorted(self.done()):
            i0, i1 = chunk_bounds(self.job, index)
            yield i0, {k: self.root[k][i0:i1] for k in arrays}

    def point(self, i: int) -> dict:
        """The parameters of point i (axes and fixed ones)."""
        vals = point_values(self.job, i, i + 1)
        return {**self.job["fixed"], **({"preset": self.job["preset"]} if self.job["preset"]
                                        else {}), **{k: float(v[0]) for k, v in vals.items()}}

    def summary(self, worst: int = 1) -> dict:
        """Counts of verdicts over the computed points and the worst points (largest E_max);
        with target_stderr, ``above_target``: the points with an estimate still above it (at
        max_samples)."""
        counts = {v: 0 for v in VERDICTS.values()}
        best: list = []                     # (E, i, channel)
        computed = above = 0
        target = self.job.get("target_stderr")
        arrays = ("E_max", "E_max_stderr", "E_max_dir", "verdict") + (
            ("E_stderr",) if target is not None else ())
        for i0, a in self.chunks(arrays):
            v = a["verdict"]
            ok = v != NOT_DONE
            computed += int(ok.sum())
            if target is not None:      # stored as float32: above by more than its rounding
                se = a["E_stderr"].reshape(len(v), -1).astype(np.float64)
                above += int(np.sum(ok & np.any(se > target * (1 + 2 ** -23), axis=1)))
            for code, name in VERDICTS.items():
                counts[name] += int((v == code).sum())
            em = a["E_max"].reshape(len(v), -1)
            flat = np.where(ok[:, None], em, -np.inf)
            k = min(worst, flat.size)
            top = np.argpartition(-flat.ravel(), k - 1)[:k] if flat.size else []
            for t in top:
                i, c = divmod(int(t), em.shape[1])
                best.append((float(flat[i, c]), i0 + i, c,
                             float(a["E_max_stderr"].reshape(len(v), -1)[i, c]),
                             int(a["E_max_dir"].reshape(len(v), -1)[i, c]), int(v[i])))
            best = sorted(best, reverse=True)[:worst]
        d = self.directions
        out = {"points": self.points, "computed": computed, **counts, "worst": None,
               **({"above_target": above} if target is not None else {})}
        rows = []
        for e, i, c, s, j, v in best:
            rows.append({"point": i, "parameters": self.point(i),
                         "direction": {"index": j, "mu": float(d["mu"][j]),
                                       "phi": float(d["phi"][j])},
                         **({"channel": "RGB"[c]} if self.job["channels"] > 1 else {}),
                         "E": e, "stderr": s, "verdict": VERDICTS[v]})
        if rows:
            out["worst"] = rows[0] if worst == 1 else rows
        return out


def open_sweep(path) -> Sweep:
    """Open a sweep store written by ``clbrdf sweep`` / ``clbrdf.sweep``."""
    return Sweep(path)
