"""Tables of directional albedo over a grid of parameters and directions: ``albedo_table``,
with refinement of the cells above a target error (``target_stderr``).
"""
from __future__ import annotations

import json
import time
import warnings

import numpy as np

from ..api.albedo import (
    GAUSS_NODES,
    PHI_NODES,
    albedo,
    albedo_avg,
    reported_error,
    rounding_floor,
    unseen,
)
from ..api.model import Model
from ..models import get_spec
from ..models.choices import MAX_GROWTH
from ..models.spec import (
    ParameterError,
    called,
    check_fraction,
    check_int,
    check_mu,
    finite_or_raise,
    given,
)
from ..runtime.launch import derive_seed, environment
from ..runtime.quadrature import QUAD_MAX_EVALS
from ..version import __version__
from . import axes as ax_mod
from .table import from_albedo


def table_axes(spec, axes, fixed=None, precision: str = "single", spacing=None) -> list:
    """Validated axes as axis dicts (clbrdf.tables.axes): from a dict name -> 1-D values, axis
    text or an axis dict; named mu or theta (exactly one), phi, r (alpha = r^2, for a model with
    alpha) or a numeric parameter of the model (of ``spec``, a ModelSpec or a name) that is not
    also in ``fixed``; the values the model is evaluated at within the parameter's range (mu
    within the ``precision``'s). Everything ``albedo_table`` checks of its axes, before any
    work."""
    spec = get_spec(spec) if isinstance(spec, str) else spec
    fixed = fixed or {}
    if not isinstance(axes, dict) or not axes:
        raise ParameterError(f"axes={axes!r} is not valid: give a dict of axis name -> 1-D values "
                             f"with at least a mu axis")
    pnames = [p.name for p in spec.params]
    out = []
    for k, v in axes.items():
        if k not in ("mu", "phi") and k not in ax_mod.MAPPED and k not in pnames:
            opts = [o.name for o in spec.options]
            why = "an option: give it as a fixed argument" if k in opts else "not a parameter"
            raise ParameterError(f"{called('axis')} {k!r} of model {spec.name} is {why}; axes are mu, theta, "
                                 f"phi, r and the parameters {', '.join(pnames)}")
        if k == "r" and "alpha" not in pnames:
            raise ParameterError(f"{called('axis')} r (alpha = r^2) needs a model with a parameter alpha; "
                                 f"{spec.name} has {', '.join(pnames)}")
        if isinstance(v, (dict, str, tuple)):
            ax = ax_mod.axis_from_python(k, v)
        else:
            try:
                a = np.asarray(v, dtype=np.float64)
            except (TypeError, ValueError):
                raise ParameterError(f"{called('axis')} {k}={v!r} is not valid: values must be numbers") \
                    from None
            if a.ndim != 1 or a.size == 0:
                raise ParameterError(f"{called('axis')} {k} must be a non-empty 1-D list of numbers, got "
                                     f"shape {a.shape}")
            finite_or_raise(f"{called('axis')} {k}", a)
            ax = {"name": k, "values": a.tolist()}
        try:
            ax = ax_mod.check_form(ax)
        except ParameterError as e:
            why = str(e).removeprefix(f"{called('axis')} {k}: ")
            raise ParameterError(f"{called('axis')} {ax_mod.axis_text(ax)}: {why}") from None
        if (spacing or {}).get(k) and ax["spacing"] == "list":
            ax["spacing"] = spacing[k]      # values made by the caller with this spacing
        out.append(ax)
    names = [a["name"] for a in out]
    if sum(n in ax_mod.VIEW for n in names) != 1:
        raise ParameterError("a table needs one axis of the outgoing direction: mu ("
                             f"{called('axis')} mu=START:STOP:COUNT), theta (radians, mu = cos theta) or sqrt1m_mu "
                             "(mu = 1 - v^2)")
    if "r" in names and "alpha" in names:
        raise ParameterError("give axis r (alpha = r^2) or axis alpha, not both")
    for ax in out:
        name = ax["name"]
        target = ax_mod.MAPPED[name][0] if name in ax_mod.MAPPED else name
        if name in fixed or target in fixed:
            raise ParameterError(f"parameter {target} is given both as an axis ({name}) and "
                                 f"as a fixed value")
        try:
            v = ax_mod.evaluated(ax)
            if target == "mu":
                check_mu(v, precision, below=spec.transmits)
            elif name != "phi":
                spec.param(target).check(v)
        except ParameterError as e:
            hint = ("" if ax.get("min") is not None or ax.get("max") is not None
                    or ax.get("spacing") == "list" else
                    "; an axis can keep its values and be evaluated at max(value, LO) with "
                    ":min=LO, or at min(value, HI) with :max=HI")
            raise ParameterError(f"{called('axis')} {ax_mod.axis_text(ax)}: {e}{hint}") from None
    return out


SPLIT = {"f0": [1.0, 0.0, 1.0], "f90": [0.0, 1.0, 1.0]}   # channels A, B, E = A + B
GROWTH = 4          # a refined cell's samples grow by this factor per look


class TargetStderrWarning(UserWarning):
    """A table's refinement stopped at max_samples with cells above target_stderr."""


def _refine(est, err, scale, shape, run, samples, target, max_samples, seed, precision,
            what="cells", qmc=False):
    """Refine the cells of ``shape`` (est, err: the sampling error, scale: the unseen-event
    scale W; that shape, channels last for an RGB model) whose error, the sampling error and
    ``unseen(W, n)`` in quadrature (largest over channels), is above ``target``: per look r
    each draws (GROWTH - 1) x its samples with the seed derived from (seed, r), pooled by sample
    counts, until it meets the target or reaches ``max_samples``. ``run(flat cell indices,
    samples, seed) -> (est, sampling error, W)`` of those cells. Returns est, the error (sampling
    and unseen in quadrature) and the samples per cell; warns (TargetStderrWarning) of cells
    left above the target at the cap."""
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
        # the scale of what every look missed: Philox's W is the same each look; with Sobol
        # points a look that drew a zero, or the probes' greatest weight, has seen it
        w2[need] = np.minimum(w2[need], w_new_scale) if qmc else np.maximum(w2[need], w_new_scale)
        n[need] += add
    missed = worst > target
    if missed.any():
        warnings.warn(
            f"{called('target_stderr')}={target:g} not reached in {int(missed.sum())} of "
            f"{missed.size} {what} at {called('max_samples')}={max_samples} (standard error "
            f"with what that many samples cannot resolve up to {float(worst.max()):.2g}); raise "
            f"{called('max_samples')}", TargetStderrWarning, stacklevel=3)
    return e2.reshape(est.shape), eff.reshape(err.shape), n.reshape(shape)


def albedo_table(name: str, axes: dict, *, samples: int = 1 << 16, estimator: str = "brdf",
                 seed: int = 0, qmc: bool = False, precision: str = "single", device=None,
                 width: int | None = None, progress: bool = False, avg_nodes: int = GAUSS_NODES,
                 tol: float | None = None, max_evals: int | None = None,
                 phi_nodes: int | None = None, spacing: dict | None = None,
                 split: bool = False, average: bool = True, target_stderr: float | None = None,
                 max_samples: int | None = None, command: str | None = None, **fixed):
    """A table of E over the grid of ``axes`` (an ordered dict name -> 1-D values, axis text
    such as ``"0:1:32:centres"`` or an axis dict, see clbrdf.tables.axes: ``mu`` or ``theta``,
    ``phi`` (azimuth of wo, default 0), ``r`` (alpha = r^2) and any numeric model parameter,
    per-channel ones included), with fixed parameters, options and ``preset`` in ``fixed``.
    Returns a ``clbrdf.Table`` named "E": ``t["E"]``, ``t["E_stderr"]`` over the axes in the
    given order (then a channel axis for an RGB model), ``t[axis]`` each axis's own values (the
    model is evaluated at ``clbrdf.tables.axes.evaluated``), and its ``average`` "E_avg"
    (``t["E_avg"]``, ``t["E_avg_stderr"]``) over the axes other than mu, theta and phi
    (averaged over the azimuth for anisotropic models, see ``albedo_avg``); ``t.computed``
    holds everything the bits depend on.

    ``split=True`` (Schlick-Fresnel models) gives the quantities ``A``, ``B`` and ``E`` (and
    ``A_avg``, ``B_avg``, ``E_avg``, each with ``_stderr``): E(F0) = F0 A + B, A with
    F = 1 - (1 - c)^5, B with F = (1 - c)^5 and E = A + B with F = 1, all three from the same
    samples (channels of one RGB model with (f0, f90) = (1, 0), (0, 1), (1, 1)): the scale and
    bias tables of Filament, UE and three.js. ``average=False`` leaves out the averages (and
    their cost).

    ``target_stderr``: cells (and averages) whose standard error (the largest over channels,
    with the allowance for what N samples cannot see, ``unseen``, in quadrature) is above
    it get GROWTH times their samples per look from independent numbers (seed derived from
    (seed, look)), pooled with what they have, until they meet it or reach ``max_samples``
    (default 64 x samples); ``t["E_samples"]`` (and ``t["E_avg_samples"]``) say how many each
    took. Not with the quadrature, whose ``tol`` is its target."""
    spec = get_spec(name)
    axl = table_axes(spec, axes, fixed, precision, spacing)
    if target_stderr is not None:
        if estimator == "quadrature":
            raise ParameterError(f"{called('target_stderr')} is for the Monte Carlo "
                                 f"estimators; the quadrature's target is {called('tol')}",
                                 "target_stderr")
        check_fraction("target_stderr", target_stderr)
        samples = check_int("samples", samples, 2, 2**32 - 1, "[2, 2^32)")
        max_samples = check_int("max_samples", MAX_GROWTH * samples if max_samples is None
                                        else max_samples, samples, 2**32 - 1,
                                        f"[{given('samples', samples)}, 2^32)")
    elif max_samples is not None:
        raise ParameterError(f"{called('max_samples')} is the cap of "
                             f"{called('target_stderr')}'s refinement: give "
                             f"{called('target_stderr')} too", "max_samples")
    names = [a["name"] for a in axl]
    evals = {a["name"]: ax_mod.evaluated(a) for a in axl}
    model_name = {a["name"]: ax_mod.MAPPED[a["name"]][0] if a["name"] in ax_mod.MAPPED
                  else a["name"] for a in axl}
    if split:
        bad = sorted(set(fixed) & {"f0", "f90", "preset", "channels", "eta", "k"})
        if bad or fixed.get("fresnel", "schlick") != "schlick" or \
                not any(p.name == "f90" for p in spec.params):
            raise ParameterError(f"split=True needs a model with Schlick Fresnel (f0 and f90) "
                                 f"and sets f0, f90 and channels itself; {name} with "
                                 f"{', '.join(bad) or 'fresnel=' + str(fixed.get('fresnel'))}")
        fixed = {**fixed, "fresnel": "schlick", "channels": 3, **SPLIT}
    dir_axes = ax_mod.VIEW + ("phi",)
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
    mu_grid = next(grids[n] for n in ax_mod.VIEW if n in grids)
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
            target_stderr, max_samples, seed, precision, qmc=qmc)
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
                samples, target_stderr, max_samples, seed, precision, what="averages", qmc=qmc)
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
                                         QUAD_MAX_EVALS}),
            "precision": precision, "width": m.width, "device": dev.name,
            "platform": dev.platform, "driver": dev.driver, "version": __version__,
            "environment": environment(), "seconds": time.perf_counter() - t0,
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
    return from_albedo(out, json.loads(json.dumps(meta)))
