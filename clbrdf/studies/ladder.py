"""The least model a job needs: cheaper variants of a configuration, their cost and their error.

A configuration (a model with its parameters and options, as ``Model`` takes them) has a ladder of
cheaper variants, built from the rungs that apply to it (``RUNGS``), each alone and all
combinations of them, in single and double precision:

- ``masking``: height-correlated Smith masking -> separable, V-cavity, none;
- ``fresnel``: exact (dielectric, conductor) -> Schlick's approximation with the same normal
  reflectance; a conductor also -> F82-tint and generalised Schlick fitted to it
  (``clbrdf.studies.fresnel_fits``: Schlick < generalised Schlick < F82-tint < exact);
  F82-tint or generalised Schlick -> Schlick with the same F0; any Fresnel term -> F = 1;
- ``diffuse``: the Lambertian term (kd > 0) dropped (one lobe against two);
- ``lobes``: Löw et al.'s second smooth lobe dropped;
- ``directional``, ``spectral``, ``material``: Schlick 1994's directional factor eq 18 -> eq 17,
  15, 12 (Schlick's four formulations); Fresnel-like spectral factor -> constant; a DOUBLE
  material -> SINGLE (layer 1 alone);
- ``diffraction``: Holzschuch & Pacanowski's diffraction lobe (kw > 0) dropped;
- ``analytic``: a tabulated Smith Lambda replaced by the analytic one of the distribution it
  generalises (GTR -> GGX, exponential power -> Beckmann, same alpha);
- ``interface``: a rough dielectric (reflection and refraction) -> its reflection lobe alone, the
  BRDF of the same distribution with the dielectric Fresnel term (``ggx_dielectric`` -> ``ggx``
  with ``fresnel="dielectric"``, same alpha, eta and masking): f = 0 for every wi below the
  surface, E = E_R;
- ``precision``: double -> single;
- the width (lanes per work-item), in the charted ladder only: the full configuration in single
  precision at widths 1, 4 and 8 besides the device's default (it changes the speed, not the
  model).

Each candidate's error is measured against the full configuration in double precision: for
``metric="value"`` the max relative error of f over a grid of direction pairs (``pairs()``, wi
on both sides of the surface where the full model transmits;
relative to max(f, 1e-12 max f): every value above the underflow of the tails counts; a floor
of 1e-3 max f hid a dropped Lambertian term of 0.03 beside a sharp lobe whose grazing mirror
value is 8e4, f off by 83 % to 96 %), for
``metric="albedo"`` the max relative error of E over ``ALBEDO_MUS`` (device quadrature to
``ALBEDO_TOL``: 1e-7 in double, 1e-6 in single; E errors below those are not resolved). Its
cost is measured: evaluations per second (the ``eval`` kernel alone, 16 launches over 2^20
direction pairs already on the device: the host's checks and copies would hide the difference
between variants, and one launch of a few ms varies by 2x) and albedo samples per second
(``brdf`` estimator, Philox, 64 points x 2^16 samples), the median of ``REPEATS`` (5) runs, on
the device's default width.

``simplest(model, tolerance, metric, **params)`` returns the fastest candidate within tolerance
with the evidence; ``chart(models, out)`` writes the ladder of each model (at
``configs()``) to ``docs/ladder/``.
"""
from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..api.albedo import albedo
from ..api.model import Model
from ..models import MODELS, get_spec
from ..models.spec import ParameterError
from ..tables.outputs import csv_rows
from .campaign import Campaign, CsvTable, measured_note, png
from .compensation import recommend
from .fresnel_fits import fit_conductor

ALBEDO_MUS = (0.02, 0.1, 0.25, 0.5, 0.75, 1.0)
PAIR_MUS = (0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0)
PAIR_PHIS = (0.0, 0.5 * np.pi, np.pi, 1.25 * np.pi)
EVAL_PAIRS, EVAL_LAUNCHES = 1 << 20, 16     # one timing: 16 launches over 2^20 pairs
ALBEDO_POINTS, ALBEDO_SAMPLES = 64, 1 << 16
REPEATS = 5
REL_FLOOR = 1e-12
ALBEDO_TOL = {"double": 1e-7, "single": 1e-6}     # the quadrature's tolerance for E errors
METRICS = ("value", "albedo")
WIDTHS = (1, 4, 8)            # the ladder also times the full configuration at these widths
def configs() -> dict:
    """{model: the full configuration charted under docs/ladder} (each description's
    ``Facts.ladder``: one per family, every rung exercised)."""
    return {n: s.facts.ladder for n, s in MODELS.items() if s.facts.ladder is not None}


@dataclass
class Variant:
    label: str                     # the rungs taken, "full" for none
    name: str                      # model name
    kw: dict                       # options and parameters
    precision: str
    error: float = float("nan")
    evals_per_s: float = float("nan")
    samples_per_s: float = float("nan")
    speedup: float = float("nan")
    width: int | None = None       # lanes per work-item (None: the device's default)

    def to_json(self) -> dict:
        return {"label": self.label, "variant": {"model": self.name, **_plain(self.kw),
                                                 "precision": self.precision},
                "error": self.error, "speedup": self.speedup,
                "evals_per_s": self.evals_per_s, "samples_per_s": self.samples_per_s}


def _plain(kw):
    return {k: (v if isinstance(v, str) else int(v) if k == "channels" else
                float(np.ravel(v)[0]) if np.size(v) == 1 else np.asarray(v, float).tolist())
            for k, v in kw.items()}


def full_config(name: str, **params) -> tuple[str, dict]:
    """(model name, options, every used parameter and ``channels``) of a configuration as
    given (a preset's values included)."""
    m = Model(name, **params)
    return m.name, {**m.options, **m.params, "channels": m.channels}


def _fresnel_f0(kw):
    eta = np.asarray(kw.get("eta", 1.5), float)
    k = np.asarray(kw.get("k", 0.0), float) if kw.get("fresnel") == "conductor" else 0.0
    return ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)


def _drop(kw, *names):
    return {k: v for k, v in kw.items() if k not in names}


# Each rung: (name, function (model name, kw) -> [(label, model name, kw)], the choices it offers)
def _masking(name, kw):
    m = kw.get("masking")
    order = ("correlated", "separable", "vcavity", "none")
    if m not in order[:-1]:              # none, or unshadowed (a table's quantity, not a surface)
        return []
    return [(f"masking={c}", name, {**kw, "masking": c}) for c in order[order.index(m) + 1:]
            if c != m]


SCHLICK_F0 = {"ashikhmin_shirley": "rs"}        # the model's Schlick normal reflectance
# models with the microfacet Fresnel terms (kernels/fresnel.h: f82, gen_schlick)
MICROFACET_FRESNEL = {n for n, s in MODELS.items() if {"f82", "exponent"} <= {p.name for p in s.params}}


def _fresnel(name, kw):
    f = kw.get("fresnel")
    if f is None or f == "one":
        return []
    out = []
    if f == "conductor" and name in MICROFACET_FRESNEL:
        # F82-tint and generalised Schlick fitted to the exact curve (studies/fresnel_fits.py)
        bare = _drop(kw, "eta", "k")
        for kind in ("f82", "gen_schlick"):
            p = fit_conductor(np.ravel(kw["eta"]), np.ravel(kw["k"]), kind)
            one = np.size(kw["eta"]) == 1
            p = {a: (b[0] if one and isinstance(b, list) else b) for a, b in p.items()}
            out.append((f"fresnel={kind}", name, {**bare, "fresnel": kind, **p}))
    if f in ("f82", "gen_schlick"):
        out.append(("fresnel=schlick", name, {**_drop(kw, "f82", "f90", "exponent"),
                                              "fresnel": "schlick"}))
    if f in ("dielectric", "conductor"):
        out.append(("fresnel=schlick", name, {**_drop(kw, "eta", "k"), "fresnel": "schlick",
                                              SCHLICK_F0.get(name, "f0"): _fresnel_f0(kw)}))
    out.append(("fresnel=one", name, {**_drop(kw, "eta", "k", "f0"), "fresnel": "one"}))
    return out


def _diffuse(name, kw):
    if "kd" not in kw or not np.any(np.asarray(kw["kd"]) > 0) or name == "lambert":
        return []
    return [("kd=0", name, {**kw, "kd": 0.0})]


def _lobes(name, kw):
    if kw.get("lobes") != "two":
        return []
    return [("lobes=one", name, {**_drop(kw, "a2", "b2", "c2"), "lobes": "one"})]


def _directional(name, kw):
    if name != "schlick":
        return []
    order = ("eq18", "eq17", "eq15", "eq12")
    d = kw.get("directional", "eq18")
    return [(f"directional={c}", name, {**kw, "directional": c})
            for c in order[order.index(d) + 1:]]


def _spectral(name, kw):
    if name != "schlick" or kw.get("spectral") != "fresnel":
        return []
    return [("spectral=constant", name, {**kw, "spectral": "constant"})]


def _material(name, kw):
    if name != "schlick" or kw.get("material") != "double":
        return []
    return [("material=single", name, {**_drop(kw, "c2", "r2", "p2", "psi2"),
                                       "material": "single"})]


def _diffraction(name, kw):
    if name != "holzschuch_pacanowski" or not np.any(np.asarray(kw.get("kw", 0)) > 0):
        return []
    return [("kw=0", name, {**kw, "kw": 0.0})]


ANALYTIC = {"gtr": ("ggx", ("gamma",)), "exppow": ("beckmann", ("p",))}


def _analytic(name, kw):
    if name not in ANALYTIC:
        return []
    to, drop = ANALYTIC[name]
    return [(f"model={to}", to, _drop(kw, *drop))]


def _interface(name, kw):
    if not get_spec(name).transmits or not name.endswith("_dielectric") or \
            kw.get("lobes", "both") == "transmission":
        return []
    to = name.removesuffix("_dielectric")
    keep = {k: v for k, v in kw.items() if k in ("alpha", "alpha_x", "alpha_y", "eta",
                                                 "masking", "sampler", "channels")}
    return [(f"reflection only: {to}", to, {**keep, "fresnel": "dielectric"})]


RUNGS = (("masking", _masking), ("fresnel", _fresnel), ("diffuse", _diffuse),
         ("lobes", _lobes), ("directional", _directional), ("spectral", _spectral),
         ("material", _material), ("diffraction", _diffraction),
         ("analytic", _analytic), ("interface", _interface))


def variants(name: str, kw: dict, precisions=("double", "single")) -> list[Variant]:
    """The full configuration and every combination of the rungs' choices (at most one choice
    per rung), in each precision; the full one in double first."""
    combos = [("full", name, kw)]
    for _, rung in RUNGS:
        grown = []
        for label, n, k in combos:
            for l2, n2, k2 in rung(n, k):
                grown.append((l2 if label == "full" else f"{label}, {l2}", n2, k2))
        combos += grown
    out = []
    for label, n, k in combos:
        try:
            get_spec(n).configure(**k)
        except ParameterError:
            continue                     # a combination the model refuses
        for prec in precisions:
            out.append(Variant(label if prec == "double" else
                               ("single" if label == "full" else f"{label}, single"),
                               n, k, prec))
    return out


def _dir(mu, phi):
    mu, phi = np.asarray(mu, float), np.asarray(phi, float)
    s = np.sqrt(1 - mu * mu)
    return np.stack([s * np.cos(phi), s * np.sin(phi), mu], -1)


def pairs(sphere: bool = False):
    """(wo, wi): every grid direction against every other, plus the mirror pairs; with
    ``sphere`` (a model that transmits) also every wo against every wi mirrored below the
    surface, and the straight-through pairs wi = -wo."""
    M, P = np.meshgrid(PAIR_MUS, PAIR_PHIS, indexing="ij")
    d = _dir(M.ravel(), P.ravel())
    wo = np.concatenate([np.repeat(d, len(d), 0), d])
    wi = np.concatenate([np.tile(d, (len(d), 1)), d * np.array([-1.0, -1.0, 1.0])])
    if sphere:
        wo = np.concatenate([wo, wo])
        wi = np.concatenate([wi, wi * np.array([1.0, 1.0, -1.0])])
    return wo, wi


def _eval(m, wo, wi):
    """f at the pairs; a model that does not transmit is 0 for a wi below the surface (its
    eval refuses such directions)."""
    if m.spec.transmits:
        return np.asarray(m.eval(wo, wi), float)
    up = wi[:, 2] > 0
    f = np.zeros((len(wo),) + np.shape(m.eval(wo[:1], wi[:1]))[1:])
    f[up] = np.asarray(m.eval(wo[up], wi[up]), float)
    return f


def _model(v: Variant, device=None):
    return Model(v.name, precision=v.precision, device=device, width=v.width, **v.kw)


def _median_time(fn) -> float:
    fn()                                            # build and warm up, not timed
    ts = []
    for _ in range(REPEATS):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return float(np.median(ts))


def _check_metric(metric):
    if metric not in METRICS:
        raise ParameterError(f"metric={metric!r} is not valid: choose one of {', '.join(METRICS)}")


def measure_errors(vs: list[Variant], metric: str, device=None) -> list[Variant]:
    """Fill in each variant's error against vs[0], the full configuration in double."""
    _check_metric(metric)
    wo, wi = pairs(get_spec(vs[0].name).transmits)
    ref = None
    for v in vs:
        m = _model(v, device)
        if metric == "value":
            f = _eval(m, wo, wi)
            ref = f if ref is None else ref
            floor = REL_FLOOR * np.max(np.abs(ref))
            v.error = float(np.max(np.abs(f - ref) / np.maximum(np.abs(ref), floor)))
        else:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                e = np.asarray(albedo(m, np.asarray(ALBEDO_MUS), estimator="quadrature",
                                      tol=ALBEDO_TOL[v.precision]).albedo,
                               float)
            ref = e if ref is None else ref
            v.error = float(np.max(np.abs(e - ref) / np.maximum(np.abs(ref), 1e-12)))
    return vs


def measure_speed(vs: list[Variant], metric: str, device=None) -> list[Variant]:
    """Fill in evaluations and albedo samples per second, and the speed-up over vs[0] for the
    metric's operation (value: eval, albedo: the brdf estimator)."""
    _check_metric(metric)
    rng = np.random.default_rng(3)
    bwo = _dir(rng.uniform(0.01, 1, EVAL_PAIRS), rng.uniform(0, 2 * np.pi, EVAL_PAIRS))
    bwi = _dir(rng.uniform(0.01, 1, EVAL_PAIRS), rng.uniform(0, 2 * np.pi, EVAL_PAIRS))
    amu = np.linspace(0.05, 1, ALBEDO_POINTS)
    for v in vs:
        m = _model(v, device)
        launch, _ = m.batch_prepare("eval_batch", (EVAL_PAIRS,), [bwo.T, bwi.T], [m.channels])
        v.evals_per_s = EVAL_PAIRS * EVAL_LAUNCHES / _median_time(
            lambda: [launch() for _ in range(EVAL_LAUNCHES)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            v.samples_per_s = ALBEDO_POINTS * ALBEDO_SAMPLES / _median_time(
                lambda: albedo(m, amu, samples=ALBEDO_SAMPLES, seed=1))
    key = "evals_per_s" if metric == "value" else "samples_per_s"
    for v in vs:
        v.speedup = getattr(v, key) / getattr(vs[0], key)
    return vs


@dataclass
class Simplest:
    model: str
    metric: str
    tolerance: float
    variant: Variant
    candidates: list = field(default_factory=list)

    def to_json(self) -> dict:
        return {"model": self.model, "metric": self.metric, "tolerance": self.tolerance,
                "variant": self.variant.to_json()["variant"], "label": self.variant.label,
                "error": self.variant.error, "speedup": self.variant.speedup,
                "candidates": [c.to_json() for c in self.candidates]}

    def table(self) -> str:
        key = "evals/s" if self.metric == "value" else "samples/s"
        lines = [f"{'candidate':58s} {'error':>9s} {key:>10s} {'speed-up':>8s}"]
        for c in sorted(self.candidates, key=lambda c: (np.isnan(c.speedup), -c.speedup,
                                                          c.error)):
            rate = c.evals_per_s if self.metric == "value" else c.samples_per_s
            mark = " <= chosen" if c is self.variant else ("" if c.error <= self.tolerance
                                                          else " (beyond tolerance, not timed)")
            lines.append(f"{c.label[:58]:58s} {c.error:9.2e} {rate:10.3g} {c.speedup:8.2f}{mark}")
        return "\n".join(lines)


def simplest(model: str, tolerance: float, metric: str = "value", *, device=None,
             **params) -> Simplest:
    """The cheapest variant of a configuration whose error against the full configuration (in
    double precision) is at most ``tolerance`` (relative; ``metric`` ``value``: f over a grid
    of direction pairs, ``albedo``: E over ALBEDO_MUS), with every candidate measured.
    ``metric="compensation"``: which energy compensation and table size the configuration
    needs, against the random walk (clbrdf.studies.compensation.recommend)."""
    if metric == "compensation":
        return recommend(model, tolerance, device=device, **params)
    if isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or \
            not 0 <= float(tolerance) < 1e6:
        raise ParameterError(f"tolerance={tolerance!r} is out of range: valid tolerance is in "
                             "[0, 1e6) (relative error)")
    if metric not in METRICS:
        raise ParameterError(f"metric={metric!r} is not valid: choose one of {', '.join(METRICS)}")
    name, kw = full_config(model, **params)
    vs = measure_errors(variants(name, kw), metric, device)
    ok = [vs[0]] + [v for v in vs[1:] if v.error <= tolerance]
    measure_speed(ok, metric, device)              # only the candidates within tolerance
    best = max(ok, key=lambda v: v.speedup)
    return Simplest(name, metric, float(tolerance), best, vs)


# ---- docs/ladder

FIELDS = ("model", "label", "variant", "precision", "value_error", "albedo_error",
          "evals_per_s", "samples_per_s")


def ladder(name: str, kw: dict, device=None) -> list[dict]:
    """Rows of FIELDS: every variant with both errors and both rates."""
    mname, full = full_config(name, **kw)
    rows = {}
    for metric in METRICS:
        vs = variants(mname, full)
        vs += [Variant(f"single, width {w}", mname, full, "single", width=w) for w in WIDTHS]
        measure_errors(vs, metric, device)
        if metric == "value":
            measure_speed(vs, metric, device)
        for v in vs:
            r = rows.setdefault(v.label, {"model": mname, "label": v.label,
                                          "variant": json.dumps(v.to_json()["variant"]),
                                          "precision": v.precision})
            r[f"{metric}_error"] = v.error
            if metric == "value":
                r["evals_per_s"], r["samples_per_s"] = v.evals_per_s, v.samples_per_s
    return list(rows.values())


def pareto(rows, err: str, rate: str) -> list:
    """The rows no other row beats on both speed (``rate``, higher) and error (lower)."""
    out, best = [], math.inf
    for r in sorted(rows, key=lambda r: (-r[rate], r[err])):
        if r[err] < best:
            out.append(r)
            best = r[err]
    return out


def _callouts(ax, points, labels, fontsize=6):
    """Labels in a column right of the axes, each at its point's height where there is room,
    at least a line apart, joined to its point by a thin line. Heights are in axes fractions;
    the labels shrink the axes (constrained layout), so they are placed again once drawn."""
    if not points:
        return
    fig = ax.figure
    to_axes = ax.transAxes.inverted()
    notes = []
    for _ in range(3):
        fig.canvas.draw()                       # the layout, with the labels placed so far
        h = 1.8 * fontsize / 72 * fig.dpi / ax.get_window_extent().height
        ys = np.array([to_axes.transform(ax.transData.transform(p))[1] for p in points])
        h = min(h, 1.0 / len(ys))
        order = np.argsort(ys)
        y = np.clip(ys[order], h / 2, 1 - h / 2)
        for k in range(1, len(y)):              # bottom up: at least h apart
            y[k] = max(y[k], y[k - 1] + h)
        y[-1] = min(y[-1], 1 - h / 2)
        for k in range(len(y) - 2, -1, -1):     # top down: back under the top
            y[k] = min(y[k], y[k + 1] - h)
        placed = np.empty(len(ys))
        placed[order] = y
        if not notes:
            notes = [ax.annotate(lab, p, xytext=(1.03, yy), textcoords="axes fraction",
                                 fontsize=fontsize, va="center", annotation_clip=False,
                                 arrowprops=dict(arrowstyle="-", lw=0.4, alpha=0.5, shrinkA=0,
                                                 shrinkB=2))
                     for p, lab, yy in zip(points, labels, placed)]
        else:
            for a, yy in zip(notes, placed):
                a.xyann = (1.03, yy)


def figure(rows, name, kw):
    """The ladder's chart: cost against error of every variant; the variants that no other
    beats on both (the Pareto front) are labelled, the others are in ladder.csv."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    fig = Figure(figsize=(14, 5.6), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 2)
    for ax, err, rate, what in ((axes[0], "value_error", "evals_per_s", "evaluations / s"),
                                (axes[1], "albedo_error", "samples_per_s", "albedo samples / s")):
        for r in rows:
            ax.scatter(r[rate], max(r[err], 1e-17),
                       c="C0" if r["precision"] == "double" else "C1", s=18)
        front = pareto(rows, err, rate)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(_no_labels())
        ax.set_xlabel(what)
        ax.set_ylabel("max relative error against the full model in double"
                      if err == "value_error" else "max relative error of E")
        ax.grid(True, which="both", alpha=0.3)
        _callouts(ax, [(r[rate], max(r[err], 1e-17)) for r in front],
                  [r["label"] for r in front])
    axes[0].set_title("f over direction pairs (blue double, orange single)", fontsize=9)
    axes[1].set_title("E(mu) over mu 0.02..1", fontsize=9)
    fig.suptitle(f"{name} {json.dumps(_plain(kw))}: cost against error of each variant "
                 f"(labelled: those no other is both faster and more accurate than; all in "
                 f"ladder.csv)", fontsize=9)
    return fig


def _no_labels():
    from matplotlib.ticker import NullFormatter
    return NullFormatter()


def chart(models=None, out="ladder", *, device=None, command="clbrdf.studies.ladder.chart()",
          progress=None) -> Path:
    """Measure the ladder of each model at its configuration (``configs()``) and write
    ladder.csv, MODEL.png and README.md to ``out`` (clbrdf/studies/campaign.py: a kill leaves
    the old files or the new ones; the rows of models not measured this time that
    ``out/ladder.csv`` already holds stay, with their charts, in ``configs()`` order)."""
    def measure_one(name):
        kw = configs().get(name, {})
        rows = ladder(name, kw, device)
        return {"ladder.csv": rows}, png(figure(rows, name, kw), bbox_inches="tight")
    return Campaign({"ladder.csv": CsvTable(FIELDS, lambda p: csv_rows(p, FIELDS[4:]))},
                    measure_one, lambda t, *a: summary(t["ladder.csv"], *a),
                    order=tuple(configs())).run(list(models or configs()), out, command, progress)


def summary(rows, command, seconds, measured=None) -> str:
    note = measured_note(rows, measured)
    which = f" ({note})" if note else ""
    lines = ["# The ladder: cheaper variants, their cost and their error", "",
             f"Generated by `{command}` in {seconds:.0f} s{which} on one device (its default "
             f"width). "
             "For each model's configuration (each description's `Facts.ladder`), every combination "
             "of cheaper rungs (`clbrdf/studies/ladder.py`) in double and single precision: the max "
             "relative error of f over direction pairs and of E(mu) against the full "
             "configuration in double precision, and the measured evaluations and albedo "
             "samples per second (median of 5). `clbrdf simplest` picks from the same "
             "candidates for a user's own parameters and tolerance.", ""]
    for name in dict.fromkeys(r["model"] for r in rows):
        rs = [r for r in rows if r["model"] == name]
        full = rs[0]
        lines += [f"## {name}", "", f"![{name}]({name}.png)", "",
                  "| variant | f error | E error | eval speed-up | albedo speed-up |",
                  "|---|---:|---:|---:|---:|"]
        for r in sorted(rs, key=lambda r: -r["evals_per_s"]):
            lines.append(f"| {r['label']} | {r['value_error']:.2g} | {r['albedo_error']:.2g} | "
                         f"{r['evals_per_s'] / full['evals_per_s']:.2f} | "
                         f"{r['samples_per_s'] / full['samples_per_s']:.2f} |")
        lines.append("")
    return "\n".join(lines)
