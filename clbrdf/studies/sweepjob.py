"""The job of an energy-conservation sweep (``clbrdf.studies.sweep``): its points, directions and
decision rule, and the computation of one chunk of points, which runs wherever a chunk is
computed (this process, a thread per device, or a Dask worker: clbrdf.studies.cluster).
"""
from __future__ import annotations

import math

import numpy as np

from ..api.albedo import (
    ROUND_ULPS,
    avg_rule,
    reported_error,
    rounding_floor,
    unseen,
    weight_scale,
)
from ..api.model import Model
from ..models import get_spec, presets
from ..models.choices import ERROR_RATE, MAX_GROWTH, MC_ESTIMATORS, PRECISIONS, WIDTHS
from ..models.spec import (
    ParameterError,
    called,
    check_choice,
    check_fraction,
    check_int,
    check_mu,
)
from ..runtime.albedo import QMC_STREAMS, run_albedo
from ..runtime.device import resolve_devices
from ..runtime.launch import derive_seed, seed_words, working_width
from ..tables.axes import axis_from_python, check_form, parse_axis, warp

FORMAT = 1
NOT_DONE, UNDECIDED, CONSERVES, GAINS = -1, 0, 1, 2
VERDICTS = {UNDECIDED: "undecided", CONSERVES: "conserves", GAINS: "gains"}
GROWTH = 4                # each refinement multiplies a direction's samples by this
CHUNK_PAIRS = 1 << 17     # default chunk: about this many (point, direction) pairs
DEFAULT_MU_NODES = 32     # isotropic default directions: Gauss-Legendre nodes in mu
ANISO_DIRECTIONS = (16, 8)  # anisotropic default: 16 mu nodes x 8 azimuths
ARRAYS_1 = ("E_max", "E_max_stderr", "E_max_dir", "E_avg", "E_avg_stderr")


# ---------------------------------------------------------------------------------------------
# the job: everything the bits depend on, as JSON

def _check_axis(ax: dict, spec, random: bool) -> dict:
    name = ax["name"]
    if not any(p.name == name for p in spec.params):
        opts = [o.name for o in spec.options]
        why = "an option: give it as a fixed argument" if name in opts else "not a parameter"
        raise ParameterError(f"{called('axis')} {name!r} of model {spec.name} is {why}; axes are the "
                             f"parameters {', '.join(p.name for p in spec.params)}")
    for k in ("min", "max"):
        if ax.get(k) is not None:
            raise ParameterError(f"{called('axis')} {name}: {k}= is for tables; a sweep evaluates every "
                                 f"value it is given")
    ax = check_form(ax, random)
    p = spec.param(name)
    p.check(np.asarray(ax["values"] if "values" in ax else [ax["start"], ax["stop"]]))
    if random and p.lo_open and min(ax["start"], ax["stop"]) <= p.lo:
        raise ParameterError(f"{called('axis')} {name}: {min(ax['start'], ax['stop'])!r} is out of range: "
                             f"valid {name} is in {p.range_text()}")
    return ax


def gauss_directions(n_mu: int, n_phi: int = 1, below: bool = False) -> dict:
    """Gauss-Legendre nodes in mu times n_phi equally spaced azimuths, with the weights of
    E_avg = (1/pi) int E mu dwo (clbrdf.api.albedo._avg_rule): mu-major order. ``below`` (a
    model that transmits): the same directions mirrored below the surface follow (wo inside),
    with weight 0: E_avg stays the average from above."""
    mu, phi, c = avg_rule(n_mu, n_phi)
    M, P = np.meshgrid(mu, phi, indexing="ij")
    out = {"spec": f"gauss:{n_mu}" + (f"x{n_phi}" if n_phi > 1 else ""),
           "mu": M.ravel().tolist(), "phi": P.ravel().tolist(), "weight": c.ravel().tolist()}
    if below:
        out = {k: v + [-x for x in v] if k == "mu" else v + v if k == "phi" else
               v + [0.0] * len(v) if k == "weight" else v for k, v in out.items()}
    return out


def parse_directions(text: str, precision: str, below: bool = False) -> dict:
    """``gauss:N`` / ``gauss:NxM`` (N Gauss-Legendre mu nodes x M azimuths: E_avg by quadrature;
    ``below``: and the same below the surface) or ``mu=v1,v2,...[;phi=p1,p2,...]`` (every mu
    with every phi; no E_avg; mu < 0 with ``below``)."""
    t = text.strip()
    form = "expected gauss:N, gauss:NxM or mu=v1,v2,...[;phi=p1,...]"
    if t.startswith("gauss:"):
        n, _, m = t[6:].partition("x")
        try:
            n_mu, n_phi = int(n), int(m or 1)
        except ValueError:
            raise ParameterError(f"{called('directions')} {text!r} is malformed: {form}") from None
        check_int("directions N (mu nodes)", n_mu, 1, 1024)
        check_int("directions M (azimuths)", n_phi, 1, 1024)
        return gauss_directions(n_mu, n_phi, below)
    parts = dict(p.partition("=")[::2] for p in t.split(";"))
    if "mu" not in parts or set(parts) - {"mu", "phi"}:
        raise ParameterError(f"{called('directions')} {text!r} is malformed: {form}")
    try:
        mu = np.array([float(x) for x in parts["mu"].split(",")])
        phi = np.array([float(x) for x in parts.get("phi", "0").split(",")])
    except ValueError:
        raise ParameterError(f"{called('directions')} {text!r}: values must be numbers ({form})") from None
    check_mu(mu, precision, below)
    if not np.all(np.isfinite(phi)):
        raise ParameterError(f"{called('directions')} {text!r}: phi must be finite")
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
    spec = get_spec(model)
    check_choice("estimator", estimator, MC_ESTIMATORS)
    check_choice("precision", precision, PRECISIONS)
    if random is not None:
        random = check_int("random", random, 1, 2**40, "[1, 2^40]")
    axes = axes or {}
    if isinstance(axes, dict):
        axes = [axis_from_python(k, v) for k, v in axes.items()]
    else:
        axes = [parse_axis(a) if isinstance(a, str) else dict(a) for a in axes]
    names = [a["name"] for a in axes]
    for k in names:
        if names.count(k) > 1:
            raise ParameterError(f"{called('axis')} {k} is given twice")
        if k in fixed:
            raise ParameterError(f"parameter {k} is given both as an axis and as a fixed value")
    axes = [_check_axis(a, spec, random is not None) for a in axes]
    if random is not None and not axes:
        raise ParameterError("random points need at least one axis range (NAME=START:STOP)")
    npoints = random if random is not None else math.prod(len(a["values"]) for a in axes)
    samples = check_int("samples", samples, 2, 2**31, "[2, 2^31]")
    max_samples = samples * MAX_GROWTH if max_samples is None else max_samples
    max_samples = check_int("max_samples", max_samples, samples, 2**40,
                                    f"[samples={samples}, 2^40]")
    if target_stderr is not None:
        target_stderr = check_fraction("target_stderr", target_stderr)
    check_fraction("error_rate", error_rate, 0.5,
                   " (the probability that a point's verdict is wrong)")
    seed_words(seed)
    # the configuration at a few points of the box checks the fixed parameters and axes together
    channels = fixed.pop("channels", None)     # a published fit; fixed parameters override it
    params, channels = presets.applied(spec.name, preset, fixed, channels)
    probe = _probe_params(axes, spec)
    params = {k: v for k, v in params.items() if k not in probe}      # axes override a preset
    grid = [g.reshape(-1) for g in np.meshgrid(*probe.values(), indexing="ij")] if probe else []
    spectral_axes = [k for k in probe if spec.param(k).spectral and channels > 1]
    cfg, values = spec.configure(channels=channels, **params, **{
        k: (g[:, None] if k in spectral_axes else g) for k, g in zip(probe, grid)})
    unused = [a["name"] for a in axes if a["name"] not in cfg.param_names]
    if unused:
        raise ParameterError(f"{called('axis')} {unused[0]} is not a parameter of model {spec.name} with "
                             f"{', '.join(f'{k}={v}' for k, v in dict(cfg.options).items())}: it "
                             f"uses {', '.join(cfg.param_names)}")
    if width is None:
        width = working_width(resolve_devices(device)[0], precision)
    if isinstance(width, bool) or width not in WIDTHS:
        raise ParameterError(f"width={width!r} is not valid: choose one of 1, 2, 4, 8, 16")
    if directions is None:
        directions = gauss_directions(*ANISO_DIRECTIONS, below=spec.transmits) \
            if spec.anisotropic(cfg, values) else \
            gauss_directions(DEFAULT_MU_NODES, below=spec.transmits)
    elif isinstance(directions, str):
        directions = parse_directions(directions, precision, spec.transmits)
    else:
        directions = dict(directions)
    check_mu(directions["mu"], precision, spec.transmits)
    D = len(directions["mu"])
    if D > 32767:
        raise ParameterError(f"directions: {D} is too many: at most 32767 per point")
    chunk = max(1, CHUNK_PAIRS // D) if chunk is None else chunk
    chunk = check_int("chunk", chunk, 1, 2**31 // D, f"[1, 2^31 / {D} directions]")
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


# the job keys a resume compares: the arguments of ``sweep`` that set them
ARGUMENTS = ("model", "preset", "fixed", "axes", "random", "directions", "estimator", "qmc",
             "samples", "max_samples", "target_stderr", "error_rate", "seed", "precision",
             "width", "chunk")


def job_difference(old: dict, new: dict) -> str | None:
    """None if two jobs compute the same arrays, else which argument differs and how."""
    for key in ARGUMENTS:
        a, b = old.get(key), new.get(key)
        if a == b:
            continue
        if key == "fixed":
            for k in sorted(set(a) | set(b)):
                if a.get(k) != b.get(k):
                    return (f"{called('fixed parameter')} {k} differs (store: {a.get(k)!r}, "
                            f"now: {b.get(k)!r})")
        if key == "axes":
            an, bn = [x["name"] for x in a], [x["name"] for x in b]
            if an != bn:
                return f"{called('axes')} differs (store: axes {an}, now: {bn})"
            for x, y in zip(a, b):
                if x != y:
                    show = lambda ax: {k: v for k, v in ax.items() if k != "values"} \
                        if "count" in ax else ax
                    return f"{called('axis')} {x['name']} differs (store: {show(x)}, now: {show(y)})"
        if key == "directions":
            return f"{called('directions')} differs (store: {a['spec']!r}, now: {b['spec']!r})"
        return f"{called(key)} differs (store: {a!r}, now: {b!r})"
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
    return float(stats.t.isf(p, QMC_STREAMS - 1) if job["qmc"] else stats.norm.isf(p))


def rounding(job: dict, E):
    """The rounding allowance added to z s: ROUND_ULPS ulps of max(|E|, 1) (core.rounding_floor), a bias
    of the weights in the working precision that no sample count averages out (GGX with kd = 1,
    ks = 0: E = 1 - 7.5e-9 +- 7.7e-11 in single)."""
    return rounding_floor(job["precision"], E)


def unseen_bound(job: dict, E, W, N):
    """The unseen-event allowances of each estimate at the rule's per-estimate error rate
    (core.unseen with alpha = e / (2 R K)), below and above: weights are >= 0, so events the N
    samples missed lower E by at most ln(2 R K / e) |E| / N and raise it by at most
    ln(2 R K / e) W / N. E, W (n D, channels), N (n D,)."""
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


def decide(lo, hi, bound=1.0):
    """Verdicts of points from the bounds, of shape (points, D, channels), against the most E
    may be without creating energy (``energy_bound``; module docstring)."""
    gains = np.any(lo > bound, axis=(1, 2))
    conserves = np.all(hi <= bound, axis=(1, 2))
    return np.where(gains, GAINS, np.where(conserves, CONSERVES, UNDECIDED)).astype(np.int8)


def _model(job, device, vals: dict, rows: np.ndarray):
    """The model at points ``rows`` of a chunk (flat pairs), with its fixed parameters."""
    params = {}
    for k, v in vals.items():
        v = v[rows]
        params[k] = v[:, None] if k in job["spectral_axes"] else v
    return Model(job["model"], precision=job["precision"], device=device, width=job["width"],
                 preset=job["preset"], **job["fixed"], **params)


def energy_bound(job: dict, device, vals: dict, pt, mu) -> np.ndarray:
    """The most E may be at each pair without creating energy, (pairs, 1): 1, or the model's
    own bound (``ModelSpec.energy_bound``: a dielectric in radiance transport, E <= max(1,
    (n_o / n_i)^2))."""
    m = _model(job, device, vals, pt)
    bound = np.asarray(m.spec.energy_bound(m.config, m.params, mu), float)
    return np.broadcast_to(bound.reshape(-1, 1), (len(pt), 1))


def compute_chunk(job: dict, index: int, device) -> dict:
    """Every array of chunk ``index`` (numpy, keyed as in the store)."""
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
        e, s, plan, _, seen = run_albedo(m, (len(rows),), wo, samples=samples, seed=seed,
                                         point0=id0, **est)
        if scale:           # the unseen-event scale W of each estimate (core.weight_scale)
            return e, s, plan.samples, weight_scale(m, (len(rows),), wo, job["estimator"], e,
                                                    seen=seen, sampling=s)
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
    B = energy_bound(job, device, vals, pt, mu[dr])           # (n D, 1)
    B3 = B.reshape(n, D, 1)
    n_now = job["samples"]
    for r in range(1, looks(job)):
        lo, hi = bounds(job, E, S, z, unseen_bound(job, E, W, N))
        verdict = decide(lo.reshape(n, D, nch), hi.reshape(n, D, nch), B3)
        # more samples can decide an interval around the bound only where |E - bound| exceeds
        # the rounding allowance (GGX at alpha 1e-4: E = 1 - 1e-9, undecided at any count)
        open_ = (verdict == UNDECIDED)[pt] & np.any(
            (lo <= B) & (hi > B) & (np.abs(E - B) > rounding(job, E)), axis=1)
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
                                                       unseen_bound(job, E, W, N)]), B3)}
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


def rule_text(job: dict) -> str:
    K = len(job["directions"]["mu"]) * job["channels"]
    dist = "Student t, 15 dof (16 scrambles)" if job["qmc"] else "normal"
    rate = job["error_rate"] / (2 * looks(job) * K)
    return (f"[E - z s - |E| ln(1 / {rate:.3g}) / N, E + z s + W ln(1 / {rate:.3g}) / N], each "
            f"widened by {ROUND_ULPS} ulps of max(|E|, 1), per estimate, z = {z_value(job):.4f} "
            f"({dist} quantile of 1 - e / (2 R K), error rate e = {job['error_rate']:g}, "
            f"R = {looks(job)} looks, K = {K} estimates per point; the ln(...) / N terms: events "
            f"the N samples did not draw, which lower E by at most that share of |E| and raise "
            f"it by at most that share of W, the estimator's weight scale); "
            f"gains: some lower bound > B; conserves: every upper bound <= B; else undecided, B "
            f"the most E may be without creating energy (1; a dielectric in radiance transport: "
            f"max(1, (n_o / n_i)^2)). "
            f"Undecided estimates whose interval contains B, with |E - B| above the rounding "
            f"allowance, get {GROWTH}x the samples per look, up to {job['max_samples']}. "
            f"P(wrong verdict) <= e per point.")


def device_fingerprint(device) -> dict:
    i = device.info
    return {"device": i.name, "platform": i.platform, "driver": i.driver,
            "compute_units": int(device.cl_device.max_compute_units)}
