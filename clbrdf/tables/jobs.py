"""One validated job per table product: ``table_job`` (an albedo table over a grid),
``layout_job`` (a renderer's tables, clbrdf/data/layouts.json) and ``ltc_job`` (an LTC fit over
a grid, or an engine's LTC layout). A job is a frozen value whose canonical JSON holds
everything the numbers depend on: it is a resumed run's key (clbrdf.tables.checkpoint) and each
table's provenance (``meta["job"]``). The constructors are the only validators: they check every
argument before any work and build nothing; ``run_job(job)`` computes it and returns
{name: Table}, which ``save_tables`` writes. Where it runs (a device, a cluster) and whether it
shows progress are arguments of ``run_job``, not of the job.
"""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from ..api.albedo import GAUSS_NODES
from ..models import get_spec, presets
from ..models.choices import ESTIMATORS, MAGNITUDE_TOL, MC_ESTIMATORS, PRECISIONS, WIDTHS
from ..models.spec import ParameterError, called, check_choice, check_fraction, check_int, given
from ..runtime.launch import seed_words
from ..runtime.quadrature import check_max_evals
from . import axes as ax_mod
from .catalog import get_layout, get_ltc_layout
from .compute import albedo_table, table_axes
from .layouts import check_only, make_layout, table_plan
from .ltc import FORMS, check_magnitude_tol, fit_ltc
from .ltc_layouts import layout_axes, ltc_layout

PRODUCTS = ("table", "layout", "ltc")
FORMAT = 1


@dataclass(frozen=True)
class Job:
    """A validated job: ``product`` (one of PRODUCTS) and ``text``, the canonical JSON of its
    arguments. ``arguments`` gives them back as a dict, ``to_json`` / ``from_json`` the whole
    job."""
    product: str
    text: str

    @property
    def arguments(self) -> dict:
        return json.loads(self.text)

    def to_json(self) -> dict:
        return {"format": FORMAT, "product": self.product, **self.arguments}

    @classmethod
    def from_json(cls, d: dict) -> Job:
        """The job of ``to_json``'s dict, validated again (a job read from a file)."""
        d = dict(d)
        fmt = d.pop("format", FORMAT)
        if fmt != FORMAT:
            raise ParameterError(f"job format {fmt!r} is not known: this clbrdf reads format "
                                 f"{FORMAT}", "job")
        product = d.pop("product", None)
        check_choice("product", product, PRODUCTS)
        fixed = d.pop("fixed", {})
        if "axes" in d:
            d["axes"] = {ax["name"]: ax for ax in d["axes"]}
        if product == "ltc" and d.get("layout") is not None:
            d.pop("axes", None), d.pop("form", None)      # the layout's
        make = {"table": table_job, "layout": layout_job, "ltc": ltc_job}[product]
        return make(**d, **fixed)

    def __repr__(self):
        return f"Job({self.product!r}, {self.text})"


def _job(product: str, args: dict) -> Job:
    return Job(product, json.dumps(args, sort_keys=True, separators=(",", ":")))


def _plain(v):
    """A JSON value of a parameter (arrays as lists)."""
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    return v


def _common(samples, seed, precision, width) -> dict:
    check_choice("precision", precision, PRECISIONS)
    if width is not None and (isinstance(width, bool) or width not in WIDTHS):
        raise ParameterError(f"{given('width', width)} is not valid: choose one of "
                             f"{', '.join(map(str, WIDTHS))}", "width")
    seed_words(seed)
    out = {"seed": int(seed), "precision": precision, "width": width}
    if samples is not None:
        out["samples"] = check_int("samples", samples, 2, 2**32 - 1, "[2, 2^32)")
    return out


def _estimator(estimator, qmc, tol, max_evals, target_stderr, max_samples) -> dict:
    """The estimator's arguments: the quadrature's tol and max_evals only with it, a target
    only with Monte Carlo."""
    check_choice("estimator", estimator, ESTIMATORS)
    out = {"estimator": estimator, "qmc": bool(qmc)}
    if estimator == "quadrature":
        for k, v in (("target_stderr", target_stderr), ("max_samples", max_samples)):
            if v is not None:
                raise ParameterError(f"{called(k)} is for the Monte Carlo estimators; the "
                                     f"quadrature's target is {called('tol')}", k)
        return {**out, "qmc": False, "tol": None if tol is None else check_fraction("tol", tol),
                "max_evals": None if max_evals is None else check_max_evals(max_evals)}
    for k, v in (("tol", tol), ("max_evals", max_evals)):
        if v is not None:
            raise ParameterError(f"{called(k)} is for {given('estimator', 'quadrature')}, not "
                                 f"{given('estimator', estimator)}", k)
    check_choice("estimator", estimator, MC_ESTIMATORS)
    if target_stderr is not None:
        out["target_stderr"] = check_fraction("target_stderr", target_stderr)
        out["max_samples"] = max_samples
    elif max_samples is not None:
        raise ParameterError(f"{called('max_samples')} is the cap of "
                             f"{called('target_stderr')}'s refinement: give "
                             f"{called('target_stderr')} too", "max_samples")
    return out


def _check_parameters(spec, axl, fixed: dict) -> None:
    """The fixed parameters, options and preset together with each axis's ends and middle:
    the model's own checks, with nothing built."""
    fixed = dict(fixed)
    channels = fixed.pop("channels", None)
    fixed, channels = presets.applied(spec.name, fixed.pop("preset", None), fixed, channels)
    probe = {}
    for a in axl:
        if a["name"] in ax_mod.VIEW or a["name"] == "phi":
            continue
        v = ax_mod.evaluated(a)
        target = ax_mod.MAPPED[a["name"]][0] if a["name"] in ax_mod.MAPPED else a["name"]
        probe[target] = np.unique(v[[0, len(v) // 2, -1]])
    grid = [g.reshape(-1) for g in np.meshgrid(*probe.values(), indexing="ij")] if probe else []
    spectral = {k for k in probe if spec.param(k).spectral and channels > 1}
    spec.configure(channels=channels, **{k: v for k, v in fixed.items() if k not in probe},
                   **{k: (g[:, None] if k in spectral else g) for k, g in zip(probe, grid)})


def table_job(model: str, axes, *, samples: int = 1 << 16, estimator: str = "brdf",
              seed: int = 0, qmc: bool = False, precision: str = "single",
              width: int | None = None, tol: float | None = None, max_evals: int | None = None,
              target_stderr: float | None = None, max_samples: int | None = None,
              avg_nodes: int = GAUSS_NODES, phi_nodes: int | None = None, split: bool = False,
              average: bool = True, **fixed) -> Job:
    """The job of ``clbrdf.albedo_table`` (its arguments, the same names; ``preset`` and the
    model's parameters and options in ``fixed``), validated: the axes against the model, every
    fixed parameter with each axis's ends, the estimator's arguments."""
    spec = get_spec(model)
    args = {"model": spec.name, **_common(samples, seed, precision, width),
            **_estimator(estimator, qmc, tol, max_evals, target_stderr, max_samples)}
    axl = table_axes(spec, axes, fixed, precision)
    _check_parameters(spec, axl, fixed)
    args.update(axes=[dict(a) for a in axl], avg_nodes=check_int("avg_nodes", avg_nodes, 1, 4096),
                phi_nodes=None if phi_nodes is None else check_int("phi_nodes", phi_nodes, 1, 4096),
                split=bool(split), average=bool(average),
                fixed={k: _plain(v) for k, v in sorted(fixed.items())})
    return _job("table", args)


def layout_job(layout: str, *, samples: int | None = None, match_published: bool = False,
               estimator: str | None = None, seed: int = 0, qmc: bool = False,
               precision: str = "single", width: int | None = None, tol: float | None = None,
               max_evals: int | None = None, target_stderr: float | None = None,
               max_samples: int | None = None, only=None) -> Job:
    """The job of ``make_layout`` (clbrdf/data/layouts.json): ``samples`` a cell, the
    consumer's published count (``match_published``) or, by default, each table's target or
    count; ``estimator`` None keeps each table's and channel's own."""
    lay = get_layout(layout)
    if samples is not None and match_published:
        raise ParameterError(f"{called('samples')} and {called('match_published')} both set "
                             f"the samples a cell: give one", "samples")
    args = {"layout": layout, "match_published": bool(match_published),
            **_common(samples, seed, precision, width)}
    args.setdefault("samples", None)
    if estimator is None and (tol is not None or max_evals is not None):
        estimator = "quadrature"            # the quadrature's arguments choose it
    # None: each table's and channel's own estimator (Monte Carlo's arguments checked)
    est = _estimator(estimator or "brdf", qmc, tol, max_evals, target_stderr, max_samples)
    args.update({"tol": None, "max_evals": None, "target_stderr": None, "max_samples": None,
                 **est, "estimator": estimator})
    args["only"] = check_only(layout, only)
    for tab in lay["tables"]:           # each table's plan: its own checks
        table_plan(lay, tab, samples=args["samples"], match_published=match_published,
                   target_stderr=args.get("target_stderr"), max_samples=args.get("max_samples"),
                   estimator=args["estimator"])
    return _job("layout", args)


def ltc_job(model: str | None = None, axes=None, *, layout: str | None = None,
            form: str | None = None, samples: int = 1024, report_samples: int = 1 << 16,
            seed: int = 0, precision: str = "single", width: int | None = None,
            max_iter: int = 600, restarts: int = 1, magnitude_tol: float = MAGNITUDE_TOL,
            **fixed) -> Job:
    """The job of ``clbrdf.fit_ltc`` over ``axes``, or of an engine's LTC ``layout``
    (clbrdf/data/ltc_layouts.json: its axes and form; ``model`` replaces its model)."""
    if "preset" in fixed:
        raise ParameterError(f"{called('preset')} is a published RGB fit; an LTC fits one "
                             f"channel: give its parameters", "preset")
    if layout is not None:
        lay = get_ltc_layout(layout)
        if axes is not None or form is not None:
            raise ParameterError(f"{called('layout')} names the axes and the LTC's form itself: "
                                 f"give no {called('axes')} or {called('form')} with it", "layout")
        model = model or lay["model"]
        axes = layout_axes(layout)
        form = lay.get("form", "general")
    elif model is None or not axes:
        raise ParameterError(f"an LTC fit needs {called('model')} and its {called('axes')} "
                             f"(sqrt1m_mu=0:1:64 and r=0:1:64:min=0.01, say), or "
                             f"{called('layout')}", "axes")
    form = form or "general"
    if form not in FORMS:
        raise ParameterError(f"{given('form', form)} is not valid: choose one of "
                             f"{', '.join(FORMS)}", "form")
    spec = get_spec(model)
    if spec.transmits:
        raise ParameterError(f"{given('model', spec.name)} transmits; an LTC approximates a "
                             f"reflection lobe over the upper hemisphere: choose a reflection "
                             f"model", "model")
    if fixed.get("channels", 1) != 1:
        raise ParameterError(f"{given('channels', fixed['channels'])}: an LTC fits one "
                             f"channel: leave channels at 1", "channels")
    samples = check_int("samples", samples, 16, 1 << 24, "[16, 2^24]")
    if samples % 16:
        raise ParameterError(f"{given('samples', samples)} is not valid: give a multiple of 16",
                             "samples")
    args = {"model": spec.name, "layout": layout, "form": form, "samples": samples,
            **_common(None, seed, precision, width),
            "report_samples": check_int("report_samples", report_samples, 16, 1 << 28,
                                        "[16, 2^28]"),
            "max_iter": check_int("max_iter", max_iter, 1, 100000),
            "restarts": check_int("restarts", restarts, 0, 100),
            "magnitude_tol": check_magnitude_tol(magnitude_tol)}
    axl = table_axes(spec, axes, fixed, precision)
    _check_parameters(spec, axl, fixed)
    args.update(axes=[dict(a) for a in axl],
                fixed={k: _plain(v) for k, v in sorted(fixed.items())})
    return _job("ltc", args)


def run_job(job: Job, *, device=None, progress: bool = False,
            command: str | None = None) -> dict:
    """Compute ``job`` on ``device`` (the drivers in effect: a checkpoint, a cluster) and return
    its tables {name: Table}, each with the job in ``meta["job"]``."""
    if not isinstance(job, Job):
        raise ParameterError(f"job={job!r} is not a Job: make one with table_job, layout_job or "
                             f"ltc_job", "job")
    a = job.arguments
    common = dict(seed=a["seed"], precision=a["precision"], width=a["width"], device=device)
    if job.product == "table":
        mc = {k: a[k] for k in ("target_stderr", "max_samples") if k in a}
        quad = {k: a[k] for k in ("tol", "max_evals") if k in a}
        axes = {ax["name"]: ax for ax in a["axes"]}
        t = albedo_table(a["model"], axes, samples=a["samples"],
                                    estimator=a["estimator"], qmc=a["qmc"], progress=progress,
                                    avg_nodes=a["avg_nodes"], phi_nodes=a["phi_nodes"],
                                    split=a["split"], average=a["average"], command=command,
                                    **common, **mc, **quad, **a["fixed"])
        tables = {t.name: t}
    elif job.product == "layout":
        quad = {k: a[k] for k in ("tol", "max_evals") if a.get(k) is not None}
        mc = {k: a[k] for k in ("target_stderr", "max_samples") if a.get(k) is not None}
        tables = make_layout(a["layout"], samples=a["samples"],
                             match_published=a["match_published"], estimator=a["estimator"],
                             qmc=a["qmc"], only=a["only"], progress=progress, command=command,
                             **common, **quad, **mc)
    else:
        kw = dict(samples=a["samples"], report_samples=a["report_samples"],
                  max_iter=a["max_iter"], restarts=a["restarts"],
                  magnitude_tol=a["magnitude_tol"], command=command, **common, **a["fixed"])
        if a["layout"] is not None:
            tables = ltc_layout(a["layout"], a["model"], **kw)
        else:
            axes = {ax["name"]: ax for ax in a["axes"]}
            tables = {"ltc": fit_ltc(a["model"], axes, form=a["form"], **kw)}
    provenance = job.to_json()
    for t in tables.values():
        t.meta["job"] = provenance
    return tables
