"""Albedo tables in the layouts renderers load (``clbrdf table --layout NAME``).

A layout (clbrdf/data/layouts.json) names the consumer's tables: each table's quantity (E, 1-E,
E_avg, 1-E_avg, the Fresnel scale A and bias B, or a list of them as interleaved channels), its
axes in the consumer's memory order (slowest first, ``clbrdf.tables.axes`` text: spacing, nodes or
texel centres, r for alpha = r^2, min= for the values the consumer evaluates at a clamped
argument), the range it clamps to and its encoding (float32, float16, unorm16). ``make_layout``
computes every table with ``albedo_table`` and returns ``clbrdf.Table`` objects.
"""
from __future__ import annotations

import json

import numpy as np

from ..api.albedo import fresnel_avg
from ..api.model import Model
from ..models.microfacet import FRESNEL_NAMES
from ..models.spec import ParameterError, given
from .catalog import get_layout, layouts
from .axes import VIEW, check_form, evaluated, midpoints, parse_axis
from .compute import albedo_table
from .table import ENCODINGS, Table, encode

CHECK_SAMPLES = 1 << 18   # samples per midpoint of the interpolation check (at most)
QUANTITIES = ("E", "1-E", "E_avg", "1-E_avg", "A", "B", "A_avg", "B_avg", "F_avg", "E_kc", "1-E_kc",
              "E_kc_avg", "1-E_kc_avg", "M", "M_avg")
F82_K = 7 ** 7 / 6 ** 6        # the F82-tint's a at tint 0 and F0 = 1 (kernels/fresnel.h)
FRESNEL_AXES = FRESNEL_NAMES           # axes the Kulla-Conty F_ms splits off


def _quantities(q) -> list:
    qs = [q] if isinstance(q, str) else list(q)
    for x in qs:
        if x not in QUANTITIES:
            raise ParameterError(f"quantity {x!r} is not known: choose from {', '.join(QUANTITIES)}")
    return qs


def _run(model, axl, qs, fixed, **kw):
    """albedo_table over the axes for quantities qs -> (values, stderr, metadata) with channels
    last when there are several quantities or an RGB model's one (R, G, B)."""
    names = [a["name"] for a in axl]
    if any(q.split("_")[0] == "M" for q in qs):
        if len(qs) > 1:
            raise ParameterError(f"quantities {qs}: M is a table of its own (or a channel given "
                                 f"as a dict)")
        return _run_metal_bias(model, axl, qs[0], fixed, **kw)
    kc = ["_kc" in q for q in qs]
    if any(kc):
        if not all(kc) or len(qs) > 1:
            raise ParameterError(f"quantities {qs}: E_kc is a table of its own")
        return _run_kc(model, axl, qs[0], fixed, **kw)
    avg = qs[0].endswith("_avg")
    split = any(q.removeprefix("1-").split("_")[0] in ("A", "B") for q in qs)
    t_axes = {a["name"]: a for a in axl}
    if avg:         # the average needs no direction axis: one mu node, then the E_avg arrays
        t_axes = {"mu": {"name": "mu", "values": [1.0]}, **t_axes}
    fixed = dict(fixed or {})
    if split:
        fixed.pop("fresnel", None)
    t = albedo_table(model, t_axes, split=split, average=avg, **fixed, **kw)
    chans, errs = [], []
    for q in qs:
        base = q.removeprefix("1-")
        v, s = np.asarray(t[base], np.float64), np.asarray(t[base + "_stderr"], np.float64)
        if v.ndim != len(names) and len(qs) > 1:
            raise ParameterError(f"quantities {qs} of an RGB model: its channels are the table's "
                                 f"channels, so one quantity per table")
        chans.append(1 - v if q.startswith("1-") else v)
        errs.append(s)
    stack = (lambda x: np.stack(x, -1)) if len(qs) > 1 else (lambda x: x[0])
    return stack(chans), stack(errs), t


def _expand(arr, have, names):
    """arr over the axes ``have`` (a subsequence of ``names``, in that order) reshaped to
    broadcast over ``names``."""
    dims = iter(np.shape(arr))
    return np.reshape(arr, [next(dims) if a["name"] in have else 1 for a in names])


def _run_metal_bias(model, axl, q, fixed, **kw):
    """M = int c (1 - c)^6 f cos dwi with F = 1, c = wi.h: EEVEE's metal_bias, the F82-tint's
    term of the split sum E = F0 A + F90 B - a M (a the tint's coefficient, kernels/fresnel.h).
    Computed as (E - E_82) / 7^7 6^-6 with E_82 the albedo of the F82-tint at F0 = 1 and tint
    0, F = 1 - 7^7 6^-6 c (1 - c)^6, which is never below 0 (its minimum, at c = 1/7, is 0), so
    its clamp never acts; same seeds for both. The stderr adds the two estimates' in quadrature
    (they correlate positively, so it is an upper bound). M_avg likewise from E_avg."""
    base = {k: v for k, v in (fixed or {}).items() if k not in FRESNEL_AXES + ("fresnel",)}
    if Model(model, **base, **{k: kw[k] for k in ("device", "precision") if k in kw}).channels > 1:
        raise ParameterError(f"{q} of an RGB model: not made; give a single-channel configuration")
    bad = [a["name"] for a in axl if a["name"] in FRESNEL_AXES]
    if bad:
        raise ParameterError(f"{q} is the lobe's own (F = 1): no Fresnel axis ({', '.join(bad)})")
    plain = "E_avg" if q.endswith("_avg") else "E"
    v1, s1, t = _run(model, axl, [plain], {**base, "fresnel": "one"}, **kw)
    v2, s2, _ = _run(model, axl, [plain], {**base, "fresnel": "f82", "f0": 1.0, "f82": 0.0}, **kw)
    meta = json.loads(json.dumps(t.computed))
    meta["quantity"] = {q: "int c (1 - c)^6 f cos dwi (F = 1, c = wi.h) = (E - E_82) 6^6 / 7^7, "
                           "E_82 with the F82-tint at F0 = 1, tint 0 (EEVEE's metal_bias)"}
    t.meta = {**t.meta, "computed": meta}
    return (v1 - v2) / F82_K, np.hypot(s1, s2) / F82_K, t


def _run_kc(model, axl, q, fixed, **kw):
    """E_kc(mu) = E_F(mu) + F_ms (1 - E(mu)): the albedo of a microfacet lobe with its Fresnel
    F plus Kulla-Conty's multiple-scattering lobe (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg))
    weighted by F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)) (Kulla & Conty 2017; Enterprise
    PBR's Base_E). The MS lobe's albedo at mu is 1 - E(mu) exactly (its cosine-weighted integral
    over wi is (1 - E(mu)) (1 - E_avg) / (1 - E_avg)). E and E_avg are the lobe's with F = 1 over
    the axes other than the Fresnel ones (f0, f90, eta, k); F_avg is the kernel's own
    (``clbrdf.api.albedo.fresnel_avg``). E_kc_avg is the same with E_F_avg and E_avg for E_F and E.
    The stderr adds the three estimates' in quadrature (first order; E_F and E share seeds and
    correlate positively, so it is an upper bound)."""
    avg = q.endswith("_avg")
    plain = "E_avg" if avg else "E"
    fixed = dict(fixed or {})
    if Model(model, **fixed, **{k: kw[k] for k in ("device", "precision") if k in kw}).channels > 1:
        raise ParameterError(f"{q} of an RGB model: not made (its F_ms would mix channels); give "
                             f"a single-channel configuration")
    fres = [a for a in axl if a["name"] in FRESNEL_AXES]
    rest = [a for a in axl if a["name"] not in FRESNEL_AXES]
    one = {k: v for k, v in fixed.items() if k not in FRESNEL_AXES and k != "fresnel"}
    one["fresnel"] = "one"
    vF, sF, t = _run(model, axl, [plain], fixed, **kw)
    v1, s1, _ = _run(model, rest, [plain], one, **kw)
    keep = [a for a in rest if a["name"] not in VIEW]
    if avg:
        va, sa = v1, s1
    else:
        va, sa, _ = _run(model, keep, ["E_avg"], one, **kw)
    fa_axes = [check_form(a) for a in fres]
    grids = np.meshgrid(*[evaluated(a) for a in fa_axes], indexing="ij")
    fres_fixed = {k: v for k, v in fixed.items() if k in FRESNEL_AXES + ("fresnel",)}
    Fa = fresnel_avg(model, **fres_fixed, **{a["name"]: g for a, g in zip(fa_axes, grids)},
                     **{k: kw[k] for k in ("device",) if k in kw})
    fn = [a["name"] for a in fres]
    v1, s1 = (_expand(x, [a["name"] for a in rest], axl) for x in (v1, s1))
    va, sa = (_expand(x, [a["name"] for a in keep], axl) for x in (va, sa))
    Fa = _expand(Fa, fn, axl)
    den = 1 - Fa * (1 - va)
    Fms = Fa ** 2 * va / den
    values = vF + Fms * (1 - v1)
    dFms = Fa ** 2 * (1 - Fa) / den ** 2
    stderr = np.sqrt(sF ** 2 + (Fms * s1) ** 2 + ((1 - v1) * dFms * sa) ** 2)
    values, stderr = np.broadcast_to(values, vF.shape), np.broadcast_to(stderr, vF.shape)
    if q.startswith("1-"):
        values = 1 - values
    meta = json.loads(json.dumps(t.computed))
    meta["quantity"] = {q: "E_F + F_ms (1 - E), F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)); "
                           "E, E_avg with F = 1; F_avg by clbrdf.fresnel_avg (Kulla-Conty)"}
    t.meta = {**t.meta, "computed": meta}
    return np.array(values), np.array(stderr), t


def compute_table(model: str, name: str, quantity, axes: list, *, fixed=None, value_range=None,
                  encoding: str = "float32", layout: str | None = None,
                  check_interpolation: bool = True, **kw):
    """One table: ``quantity`` over ``axes`` (axis text or dicts, memory order) from
    ``albedo_table``; returns a ``clbrdf.Table``. ``check_interpolation`` also estimates
    E halfway between neighbouring samples on every axis (``clbrdf.tables.axes.midpoints``) and records
    the largest difference from the table's own lookup there (interpolation and encoding error,
    plus both estimates' noise; at most CHECK_SAMPLES samples per midpoint) in
    ``meta["interpolation"]``."""
    qs = _quantities(quantity)
    if encoding not in ENCODINGS:
        raise ParameterError(f"encoding={encoding!r} is not valid: choose one of "
                             f"{', '.join(ENCODINGS)}")
    axl = [parse_axis(a) if isinstance(a, str) else dict(a) for a in axes]
    names = [a["name"] for a in axl]
    avg = [q.endswith("_avg") for q in qs]
    if "F_avg" in qs and len(qs) > 1:
        raise ParameterError(f"table {name}: F_avg is a table of its own")
    if any(avg) and not all(avg):
        raise ParameterError(f"table {name}: quantities {qs} mix directional and average values")
    if all(avg) and ((set(VIEW) | {"phi"}) & set(names)):
        raise ParameterError(f"table {name}: an average ({qs[0]}) has no mu, theta or phi axis")
    if not all(avg) and not (set(VIEW) & set(names)):
        raise ParameterError(f"table {name}: {qs[0]} needs a mu or theta axis")
    if "F_avg" in qs:
        return _fresnel_table(model, name, qs, axl, fixed, value_range, encoding, layout, kw)
    values, stderr, t = _run(model, axl, qs, fixed, **kw)
    meta = t.computed
    labels = qs                 # the channels; an RGB model's one quantity Q: Q.R, Q.G, Q.B
    if values.ndim > len(names) + (len(qs) > 1):
        labels = [f"{qs[0]}.{c}" for c in "RGB"]
    specs = {a["name"]: a for a in meta["axis_specs"]}
    axes_out = [dict(specs[n], values=np.asarray(t[n], np.float64).tolist()) for n in names]
    values, stderr, clamped = clamp_cells(values, stderr, value_range, labels, axes_out)
    raw = encode(values, encoding)
    info = {"name": name, "quantity": labels, "encoding": encoding, "range": value_range,
            "clamped_cells": sum(c["cells"] for c in clamped.values()), "clamped": clamped,
            "layout": layout, "computed": meta}
    table = Table(name=name, axes=axes_out, quantity=labels, raw=raw, stderr=stderr,
                  encoding=encoding, meta=info)
    if check_interpolation and any(len(a["values"]) > 1 for a in axes_out):
        mids = []
        for a in axes_out:
            m = midpoints(a) or a["values"]
            mids.append(check_form({"name": a["name"], "values": m,
                                    **{k: a[k] for k in ("min", "max") if a.get(k) is not None}}))
        # independent samples, at most CHECK_SAMPLES (Sobol points for a quadrature table: the
        # midpoints' own quadrature took 4x the table's time for an error of ~1e-5 beside
        # interpolation errors of ~1e-3)
        ck = {k: v for k, v in kw.items() if k not in ("target_stderr", "max_samples", "tol",
                                                       "max_evals")}
        quad = kw.get("estimator") == "quadrature"
        ck.update(progress=False, seed=kw.get("seed", 0) + 1,
                  samples=CHECK_SAMPLES if quad else min(kw.get("samples", CHECK_SAMPLES),
                                                         CHECK_SAMPLES),
                  **({"estimator": "brdf", "qmc": True} if quad else {}))
        mv, ms, _ = _run(model, mids, qs, fixed, **ck)
        if value_range is not None:
            mv = np.clip(mv, *value_range)
        grids = np.meshgrid(*[np.asarray(a["values"]) for a in mids], indexing="ij")
        err = np.abs(table.lookup(*grids) - mv)
        i = np.unravel_index(int(np.argmax(err)), err.shape)
        table.meta["interpolation"] = {
            "max_error": float(err[i]), "rms_error": float(np.sqrt(np.mean(err ** 2))),
            "at": {a["name"]: float(a["values"][k]) for a, k in zip(mids, i)},
            "stderr_there": float(np.hypot(ms[i], table.stderr[tuple(
                min(int(round(table.index(d, a["values"][k]))), n - 1)
                for d, (a, k, n) in enumerate(zip(mids, i, table.shape))) + i[len(mids):]])),
            "how": "|lookup - direct estimate| halfway between neighbouring samples on every "
                   "axis (independent samples)"}
    return table


def clamp_cells(values, stderr, value_range, labels, axes) -> tuple:
    """(values clamped to the consumer's range, their standard errors with the clamp's shift
    added in quadrature, {channel: {"cells", "above", "below", "max_excess", "at",
    "model_value"}} for each channel that was clamped): a clamped cell's error covers the
    distance to the estimate, so z against the model stays honest (the consumer's clamp is
    kept: it is what the renderer loads)."""
    if value_range is None:
        return values, stderr, {}
    lo, hi = value_range
    v = np.asarray(values, np.float64)
    c = np.clip(v, lo, hi)
    shift = np.abs(v - c)
    info = {}
    chans = v.reshape(v.shape[:len(axes)] + (-1,))
    sh = shift.reshape(chans.shape)
    for k, label in enumerate(labels if chans.shape[-1] == len(labels) else labels[:1]):
        n = int(np.count_nonzero(sh[..., k]))
        if n:
            i = np.unravel_index(int(np.argmax(sh[..., k])), sh.shape[:-1])
            info[label] = {"cells": n, "above": int(np.count_nonzero(chans[..., k] > hi)),
                           "below": int(np.count_nonzero(chans[..., k] < lo)),
                           "max_excess": float(sh[..., k][i]),
                           "at": {a["name"]: float(a["values"][j]) for a, j in zip(axes, i)},
                           "model_value": float(chans[..., k][i])}
    return c, np.hypot(stderr, shift), info


def table_config(lay: dict, tab: dict) -> tuple:
    """(model, fixed parameters and options) of one table of a layout: the layout's, or the
    table's own model (a sheen table in a GGX layout) with the table's options."""
    model = tab.get("model", lay["model"])
    base = lay.get("fixed", {}) if model == lay["model"] else {}
    return model, {**base, **tab.get("fixed", {})}


def _fresnel_table(model, name, qs, axl, fixed, value_range, encoding, layout, kw):
    """F_avg over axes of Fresnel parameters (``clbrdf.api.albedo.fresnel_avg``: deterministic, the
    kernel's own F; stderr 0)."""
    axl = [check_form(a) for a in axl]
    bad = [a["name"] for a in axl if a["name"] not in FRESNEL_NAMES]
    if bad:
        raise ParameterError(f"table {name}: F_avg has axes of Fresnel parameters "
                             f"({', '.join(FRESNEL_NAMES)}), not {', '.join(bad)}")
    grids = np.meshgrid(*[evaluated(a) for a in axl], indexing="ij")
    fres = {k: v for k, v in (fixed or {}).items() if k in ("fresnel",) + FRESNEL_NAMES}
    values = fresnel_avg(model, **fres, **{a["name"]: g for a, g in zip(axl, grids)},
                         **{k: kw[k] for k in ("device",) if k in kw})
    if value_range is not None:
        values = np.clip(values, *value_range)
    meta = {"name": name, "quantity": qs, "encoding": encoding, "range": value_range,
            "layout": layout, "computed": {"model": model, "fixed": fres,
                                           "F_avg": "2 int F(mu) mu dmu by clbrdf.fresnel_avg"}}
    return Table(name=name, axes=axl, quantity=qs, raw=encode(values, encoding),
                 stderr=np.zeros_like(values), encoding=encoding, meta=meta)


def layout_table(lay: dict, tab: dict, *, layout: str | None = None, **kw):
    """One table of a layout. Its quantity is a name, a list of names (channels of one
    computation), or a list whose entries may be dicts {"quantity", "label", "model", "fixed",
    "axes", "estimator"}: a channel of another model or on other axes over the same grid
    (Filament's cloth channel is the Charlie sheen beside GGX's B and E; UE5's glass table holds E
    at eta and at 1/eta), computed apart and interleaved. A channel of the table's own model
    keeps the table's options."""
    model, fixed = table_config(lay, tab)
    qs = tab["quantity"] if isinstance(tab["quantity"], list) else [tab["quantity"]]
    chosen = kw.pop("estimator", None)      # the caller's, for every channel; None: the layout's
    common = dict(value_range=tab.get("range"), encoding=lay.get("encoding", "float32"),
                  layout=layout, estimator=chosen or "brdf", **kw)
    if common["estimator"] == "quadrature":     # no samples, seed, Sobol points or target
        for k in ("samples", "seed", "qmc", "target_stderr", "max_samples"):
            common.pop(k, None)
    plain = [q for q in qs if isinstance(q, str)]
    parts = []                      # (labels, Table) in channel order
    if plain:
        parts.append((plain, compute_table(model, tab["name"], plain, tab["axes"], fixed=fixed,
                                           **common)))
    for q in qs:
        if isinstance(q, dict):
            own = dict(common, **{k: q[k] for k in ("estimator",) if k in q and chosen is None})
            qm = q.get("model", model)     # the table's options where it is the same model
            t = compute_table(qm, tab["name"], q["quantity"], q.get("axes", tab["axes"]),
                              fixed={**(fixed if qm == model else {}), **q.get("fixed", {})},
                              **own)
            parts.append(([q.get("label", q["quantity"])], t))
    if len(parts) == 1 and plain:
        return parts[0][1]
    # interleave: the channels in the order given
    order = [q if isinstance(q, str) else q.get("label", q["quantity"]) for q in qs]
    chans, errs, info, clamped = {}, {}, [], {}
    base = parts[0][1]
    for labels, t in parts:
        if t.shape != base.shape or any(
                not np.allclose(a["values"], b["values"]) for a, b in zip(t.axes, base.axes)):
            raise ParameterError(f"table {tab['name']}: channel {labels} is on another grid")
        raw = t.raw if len(labels) > 1 else t.raw[..., None]
        err = t.stderr if len(labels) > 1 else t.stderr[..., None]
        for i, lab in enumerate(labels):
            chans[lab], errs[lab] = raw[..., i], err[..., i]
        info.append({"channels": labels, "computed": t.meta.get("computed"),
                     "interpolation": t.meta.get("interpolation"),
                     "clamped_cells": t.meta.get("clamped_cells", 0)})
        clamped.update({(labels[0] if len(labels) == 1 else k): c
                        for k, c in t.meta.get("clamped", {}).items()})
    interp = [i["interpolation"] for i in info if i["interpolation"]]
    # every part's clamped cells (Filament's cloth channel clamps 447 at 1024 samples, its GGX
    # channels none)
    meta = dict(base.meta, quantity=order, parts=info, clamped=clamped,
                clamped_cells=sum(i["clamped_cells"] for i in info))
    if interp:
        meta["interpolation"] = max(interp, key=lambda i: i["max_error"])
    return Table(name=tab["name"], axes=base.axes, quantity=order,
                 raw=np.stack([chans[q] for q in order], -1),
                 stderr=np.stack([errs[q] for q in order], -1), encoding=base.encoding,
                 meta=meta)


START_SAMPLES = 1 << 12     # the first look of a table refined to its layout's target


def table_plan(lay: dict, tab: dict, *, samples=None, match_published=False,
               target_stderr=None, max_samples=None, estimator=None) -> dict:
    """How one table of a layout is computed: {"samples", "target_stderr", "max_samples",
    "estimator", "basis"}. ``samples``: that many a cell. ``match_published``: the consumer's
    published count. Default: the layout's (or table's) ``target_stderr``, the consumer's shipped
    error, reached by refining from START_SAMPLES with Sobol points up to the published count
    (or the table's own estimator, the quadrature for Cycles' GGX tables); a layout without a
    target: its published count."""
    published = tab.get("samples", lay.get("samples")) or 1 << 16
    target = tab.get("target_stderr", lay.get("target_stderr"))
    basis = tab.get("target_basis", lay.get("target_basis", ""))
    if samples is not None or match_published or estimator == "quadrature":
        n = samples if samples is not None else published
        why = f"{n} samples a cell" + (" (the published count)" if samples is None else "")
        return {"samples": n, "target_stderr": target_stderr, "max_samples": max_samples,
                "estimator": estimator, "basis": why}
    if tab.get("estimator") == "quadrature" and estimator is None and target_stderr is None:
        return {"samples": published, "target_stderr": None, "max_samples": None,
                "estimator": "quadrature", "basis": basis or "the deterministic quadrature"}
    if target is None and target_stderr is None:
        return {"samples": published, "target_stderr": None, "max_samples": max_samples,
                "estimator": estimator, "basis": f"{published} samples a cell (the published "
                                                 f"count)"}
    t = target_stderr if target_stderr is not None else target
    return {"samples": START_SAMPLES, "target_stderr": t,
            "max_samples": max_samples if max_samples is not None else max(published, 1 << 16),
            "estimator": estimator,
            "basis": f"refined to a standard error of {t:g} a cell"
                     + (f": {basis}" if basis and target_stderr is None else "")}


def check_only(name: str, only) -> list | None:
    """``only`` (a table name or a list of them) as a list of tables of layout ``name``; None:
    all."""
    if only is None:
        return None
    names = [t["name"] for t in get_layout(name)["tables"]]
    only = [only] if isinstance(only, str) else list(only)
    unknown = [n for n in only if n not in names]
    if unknown:
        raise ParameterError(f"{given('only', unknown[0])} is not a table of layout {name}: "
                             f"choose from {', '.join(names)}", "only")
    return only


def make_layout(name: str, *, samples=None, estimator=None, progress=False, command=None,
                only=None, match_published: bool = False, **kw):
    """Every table of layout ``name`` (clbrdf/data/layouts.json); returns {table name: Table}.
    How many samples (``table_plan``): ``samples`` a cell if given; the consumer's published
    count with ``match_published``; by default the layout's error target (its consumer's
    shipped error, where the layout states one: ``target_stderr`` and ``target_basis``),
    reached by refinement, or the published count where it states none. ``estimator``: every
    channel's; None: brdf, and a table or channel with its own (Cycles' GGX tables: the
    quadrature; Filament's cloth channel: mis). ``only``: the names of the tables to make
    (default: all). ``target_stderr`` and ``max_samples`` in ``kw`` replace the layout's."""
    lay = get_layout(name)
    only = check_only(name, only)
    user_target, user_max = kw.pop("target_stderr", None), kw.pop("max_samples", None)
    out = {}
    for tab in lay["tables"]:
        if only is not None and tab["name"] not in only:
            continue
        plan = table_plan(lay, tab, samples=samples, match_published=match_published,
                          target_stderr=user_target, max_samples=user_max, estimator=estimator)
        extra = {k: plan[k] for k in ("target_stderr", "max_samples") if plan[k] is not None}
        t = layout_table(lay, tab, layout=name, samples=plan["samples"],
                         estimator=plan["estimator"], progress=progress, command=command,
                         **extra, **kw)
        published = tab.get("samples", lay.get("samples"))
        t.meta.update({"consumer": lay["consumer"], "source": lay["source"],
                       "notes": lay.get("notes", ""), "published_samples": published,
                       "how": plan["basis"],
                       **({"target_stderr": plan["target_stderr"]}
                          if plan["target_stderr"] is not None else {})})
        out[tab["name"]] = t
    return out
