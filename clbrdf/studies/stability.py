"""The stability map: where each estimator fails, ``clbrdf stability`` and ``stability_map()``.

For every model, each parameter that sets the lobe is swept to the edges of its range and past
where users go (its description's ``Facts.sweeps``; the other parameters at their defaults), against mu from the smallest
value the precision accepts to 1 (``MUS``). At every cell each Monte Carlo estimator (uniform,
cosine, brdf, mis; brdf and mis with each of the model's samplers; Philox points) runs in single
and double precision, and is compared with the float64 reference (``clbrdf.ref``, its error below
a thousandth of the estimate's standard error). A cell records:

- ``nonfinite``: E or its standard error is NaN or Inf;
- ``biased``: |E - E_ref| beyond Z_BIAS standard errors (the standard error widened by the
  rounding floor and the resolution of ``clbrdf.check``, and by the reference's own error);
- ``efficiency``: 1 / (mean squared error x time) of the estimator against the best estimator
  at that cell and precision, where the squared error per sample is the larger of the variance
  and the squared deviation from the reference (so that an estimator whose rare events were not
  drawn, and whose error bar is therefore too small, is not rated by that error bar; an
  estimate of 0 +- 0 where E > 0, no sample having contributed, has efficiency 0);
  ``useless`` below USELESS;
- ``precision_loss`` (single only): the estimate is non-finite where double precision's is not,
  or biased (and not useless) where double precision, same estimator and sampler, is neither
  biased nor useless and the two estimates differ by more than 2 of double's standard errors
  (their streams draw the same numbers, rounded to 2^-23 or 2^-32, so that heavy-tailed
  weights do not make two independent-looking errors of the same estimate).

At every swept value and precision, ``clbrdf.check``'s finite, non-negative and weight checks
run over their direction grid (grazing to normal, mirror pairs included).

``stability_map()`` writes ``stability.csv`` (one row per cell and estimator), ``checks.csv``,
one PNG heat map per model and ``README.md`` (the failures by kind, the useless regions, and,
given an earlier CSV, the counts before and after). ``warn_if_useless()`` reads the map that
ships with the package (``clbrdf/data/stability.csv``) and warns when ``albedo`` is asked for an
estimator in a cell the map marks useless or biased.
"""
from __future__ import annotations

import math
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..api.albedo import albedo
from ..api.model import Model
from ..api.useless import FLAGS, USELESS, Z_BIAS, read_csv, samplers, sweep_label
from ..models import MODELS, get_spec
from ..models.choices import ESTIMATORS, MC_ESTIMATORS
from ..models.spec import MU_MIN
from ..ref import reference
from .campaign import Campaign, CsvTable, png
from .check import (
    floor_of,
    resolution,
    probe_values,
    check_finite,
    check_nonnegative,
    check_weight,
)


def sweeps(name: str) -> tuple:
    """The model's sweeps ((parameters set together, values), ...) from its description
    (``Facts.sweeps``); a model without one is mapped at its defaults."""
    return get_spec(name).facts.sweeps or (((), (0.0,)),)


MUS = (1e-12, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 0.3, 0.6, 1.0)
SAMPLES = 1 << 16
QUAD_MAX_EVALS = 1 << 20     # the quadrature's evaluations per cell at most
SEED = 11
REF_TOL = 1e-8          # first reference tolerance; refined to REF_REL of the standard error
REF_REL = 1e-3
FIELDS = ("model", "sweep", "value", "mu", "estimator", "sampler", "precision", "E", "stderr",
          "E_ref", "ref_err", "z", "efficiency", "nonfinite", "biased", "useless",
          "precision_loss", "seconds", "ref_version")
CHECK_FIELDS = ("model", "sweep", "value", "precision", "check", "passed", "statistic", "worst")


def _kw(names, value, sampler="-") -> dict:
    kw = {n: value for n in names}
    if sampler != "-":
        kw["sampler"] = sampler
    return kw


def _ref_cell(args):
    """(E_ref, err) of one cell; the tolerance tightened to REF_REL of what 2^16 samples resolve
    (at least 1e-3 of E's own size) when the first pass is looser."""
    name, names, value, mu, samples = args
    r = reference(name, **_kw(names, value))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        e, err = (float(np.ravel(x)[0]) for x in r.albedo(mu, 0.0, REF_TOL))
        want = max(REF_REL * abs(e) / math.sqrt(samples), 1e-15)
        if err > want and abs(e) > 0:
            e, err = (float(np.ravel(x)[0]) for x in r.albedo(mu, 0.0, want))
    return e, err


@lru_cache(maxsize=None)
def ref_version(name: str) -> str:
    """A hash of what a model's reference values depend on: the reference modules it uses and
    the model's default parameters. An earlier map's reference values are reused only where
    it matches."""
    import hashlib
    import json
    spec = get_spec(name)
    here = Path(__file__).resolve().parents[1]
    files = dict.fromkeys([here / "ref" / "quadrature.py", here / "ref" / "__init__.py",
                           here / "ref" / "microfacet.py", here / "ref" / "distributions.py",
                           here / "ref" / f"{spec.ref}.py"])
    h = hashlib.sha1()
    for f in files:
        h.update(f.read_bytes())
    _, values = spec.configure()
    h.update(json.dumps({k: np.asarray(v).tolist() for k, v in values.items()},
                        sort_keys=True).encode())
    return h.hexdigest()[:12]


def references(name: str, samples: int = SAMPLES, cache: dict | None = None,
               workers: int | None = None) -> dict:
    """{(sweep, value, mu): (E_ref, err)} for every cell of the model, computed in a pool of
    processes; cells in ``cache`` (from an earlier map) are not recomputed."""
    cells = [(name, names, v, mu, samples) for names, values in sweeps(name) for v in values
             for mu in MUS]
    out, todo = {}, []
    for c in cells:
        key = (sweep_label(c[1]), float(c[2]), float(c[3]))
        if cache is not None and (name,) + key in cache:
            out[key] = cache[(name,) + key]
        else:
            todo.append((key, c))
    if todo:
        with ProcessPoolExecutor(workers) as pool:
            for (key, _), res in zip(todo, pool.map(_ref_cell, [c for _, c in todo])):
                out[key] = res
    return out


def _run_checks(name, names, value, precision):
    m = Model(name, precision=precision, **_kw(names, value))
    v = probe_values(m, SEED)
    return [check_finite(m, v), check_nonnegative(m, v), check_weight(m, v)]


def measure(name: str, refs: dict, *, samples: int = SAMPLES, precisions=("single", "double"),
            progress=None) -> tuple[list[dict], list[dict]]:
    """Rows of FIELDS (one per cell, estimator, sampler and precision) and of CHECK_FIELDS."""
    rows, checks = [], []
    for names, values in sweeps(name):
        sweep = sweep_label(names)
        vals = np.asarray(values, float)
        for prec in precisions:
            mus = np.array([mu for mu in MUS if mu >= MU_MIN[prec]])
            e_ref = np.array([[refs[(sweep, float(v), float(mu))][0] for mu in mus] for v in vals])
            r_err = np.array([[refs[(sweep, float(v), float(mu))][1] for mu in mus] for v in vals])
            runs = []
            for est in MC_ESTIMATORS:
                for smp in (samplers(name) if est in ("brdf", "mis") else ("-",)):
                    kw = _kw(names, vals[:, None] if names else None, smp) if names else \
                        ({"sampler": smp} if smp != "-" else {})
                    m = Model(name, precision=prec, **kw)
                    with warnings.catch_warnings():     # the map's own warnings
                        warnings.simplefilter("ignore")
                        albedo(m, mus[:1], estimator=est, samples=64, seed=SEED)   # build
                        t = time.perf_counter()
                        r = albedo(m, mus, estimator=est, samples=samples, seed=SEED)
                        secs = time.perf_counter() - t
                    e = np.broadcast_to(np.asarray(r.albedo, float), e_ref.shape)
                    se = np.broadcast_to(np.asarray(r.stderr, float), e_ref.shape)
                    runs.append((est, smp, e, se, secs / e.size / samples, m))
            eps_floor = floor_of(runs[0][5], e_ref)
            effs = []
            for est, smp, e, se, t, m in runs:
                dev = np.abs(e - e_ref)
                sigma = np.sqrt(se ** 2 + eps_floor ** 2 + resolution(e_ref, samples) ** 2
                                + r_err ** 2)
                with np.errstate(invalid="ignore", divide="ignore"):
                    z = np.where(np.isfinite(e), dev / sigma, np.inf)
                    mse = samples * np.maximum(se ** 2, np.maximum(dev - eps_floor, 0) ** 2) \
                        + samples * eps_floor ** 2
                    eff = np.where(np.isfinite(mse) & np.isfinite(e), 1 / (mse * t), 0.0)
                # no sample contributed (0 +- 0) where E > 0: no estimate at all, efficiency 0
                eff = np.where((e == 0) & (se == 0) & (e_ref > 0), 0.0, eff)
                effs.append(eff)
            best = np.max(effs, axis=0)
            for (est, smp, e, se, t, m), eff in zip(runs, effs):
                rel = np.where(best > 0, eff / np.where(best > 0, best, 1), 1.0)
                for i, v in enumerate(vals):
                    for j, mu in enumerate(mus):
                        dev = abs(e[i, j] - e_ref[i, j])
                        sigma = math.sqrt(se[i, j] ** 2 + eps_floor[i, j] ** 2
                                          + resolution(e_ref[i, j], samples) ** 2
                                          + r_err[i, j] ** 2)
                        fin = bool(np.isfinite(e[i, j]) and np.isfinite(se[i, j]))
                        z = dev / sigma if fin and sigma > 0 else (0.0 if fin and dev == 0
                                                                    else math.inf)
                        rows.append({
                            "model": name, "sweep": sweep, "value": float(v), "mu": float(mu),
                            "estimator": est, "sampler": smp, "precision": prec,
                            "E": float(e[i, j]), "stderr": float(se[i, j]),
                            "E_ref": float(e_ref[i, j]), "ref_err": float(r_err[i, j]),
                            "z": float(z), "efficiency": float(rel[i, j]),
                            "nonfinite": int(not fin), "biased": int(fin and z > Z_BIAS),
                            "useless": int(rel[i, j] < USELESS), "precision_loss": 0,
                            "seconds": t * samples, "ref_version": ref_version(name)})
            rows += _quadrature_rows(name, names, vals, mus, prec, e_ref, r_err, eps_floor,
                                     sweep)
            for v in vals:
                for c in _run_checks(name, names, float(v), prec):
                    checks.append({"model": name, "sweep": sweep, "value": float(v),
                                   "precision": prec, "check": c.name, "passed": int(c.passed),
                                   "statistic": c.statistic, "worst": c.worst})
            if progress:
                progress(f"{name} {sweep} {prec}")
    _mark_precision_loss(rows)
    return rows, checks


def _quadrature_rows(name, names, vals, mus, prec, e_ref, r_err, eps_floor, sweep):
    """The deterministic quadrature at every cell, to its default tolerance and at most
    QUAD_MAX_EVALS evaluations per point: biased when it is further from the reference than
    its own error estimate (or the tolerance) plus what the Lambda tables allow (3 |dG1| E) and
    the reference's error; useless when it stopped short of the tolerance. Its efficiency is
    not comparable with Monte Carlo's (NaN)."""
    m = Model(name, precision=prec, **_kw(names, vals[:, None] if names else None)) if names \
        else Model(name, precision=prec)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        r = albedo(m, mus, estimator="quadrature", max_evals=QUAD_MAX_EVALS)
        secs = time.perf_counter() - t
    e = np.broadcast_to(np.asarray(r.albedo, float), e_ref.shape)
    err = np.broadcast_to(np.asarray(r.stderr, float), e_ref.shape)
    ev = np.broadcast_to(np.asarray(r.evaluations, float), e_ref.shape)
    table = 3 * get_spec(name).facts.lambda_g1_error * np.abs(e_ref)
    allowed = np.maximum(err, r.tol) + table + r_err + eps_floor
    rows = []
    for i, v in enumerate(vals):
        for j, mu in enumerate(mus):
            fin = bool(np.isfinite(e[i, j]) and np.isfinite(err[i, j]))
            dev = abs(e[i, j] - e_ref[i, j])
            rows.append({
                "model": name, "sweep": sweep, "value": float(v), "mu": float(mu),
                "estimator": "quadrature", "sampler": "-", "precision": prec,
                "E": float(e[i, j]), "stderr": float(err[i, j]), "E_ref": float(e_ref[i, j]),
                "ref_err": float(r_err[i, j]),
                "z": float(dev / allowed[i, j]) if fin else math.inf,
                "efficiency": math.nan, "nonfinite": int(not fin),
                "biased": int(fin and dev > allowed[i, j]),
                "useless": int(fin and err[i, j] > r.tol), "precision_loss": 0,
                "seconds": secs * ev[i, j] / max(ev.sum(), 1), "ref_version": ref_version(name)})
    return rows


def _key(r):
    return (r["model"], r["sweep"], r["value"], r["mu"], r["estimator"], r["sampler"])


def _mark_precision_loss(rows):
    double = {_key(r): r for r in rows if r["precision"] == "double"}
    for r in rows:
        d = double.get(_key(r))
        if r["precision"] == "single" and d is not None:
            if r["nonfinite"]:
                r["precision_loss"] = int(not d["nonfinite"])
                continue
            sound = not (d["nonfinite"] or d["biased"] or d["useless"])
            # both streams draw the same numbers (rounded to 2^-23 or 2^-32): their estimates
            # differ by far less than a standard error unless single precision loses digits
            apart = abs(r["E"] - d["E"]) > 2 * d["stderr"]
            r["precision_loss"] = int(bool(r["biased"]) and not r["useless"] and sound and apart)


# ---- output

def ref_cache(path) -> dict:
    """{(model, sweep, value, mu): (E_ref, err)} from an earlier stability.csv, where its
    reference version is this code's."""
    try:
        rows = read_csv(path)
    except (OSError, KeyError, ValueError):
        return {}
    return {(r["model"], r["sweep"], r["value"], r["mu"]): (r["E_ref"], r["ref_err"])
            for r in rows if r.get("ref_version") == ref_version(r["model"])}


def _fmt(v):
    return f"{v:.3g}" if v not in (1 - 1e-7, 1 + 1e-7, 1 - 1e-4, 1 + 1e-4) else \
        f"1{'-' if v < 1 else '+'}{abs(1 - v):.0e}"


def figure(rows: list[dict], name: str):
    """Heat maps of one model: per sweep and precision a row of panels, one per estimator and
    sampler; colour log10 relative efficiency, letters the failures (N non-finite, B biased,
    P precision loss in single), grey the cells the precision does not accept."""
    import textwrap

    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure
    combos = list(dict.fromkeys((r["estimator"], r["sampler"]) for r in rows))
    panels = list(dict.fromkeys((r["sweep"], r["precision"]) for r in rows))
    width = 2.3 * len(combos) + 1
    fig = Figure(figsize=(width, 2.4 * len(panels) + 0.9), dpi=90, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(panels), len(combos), squeeze=False, sharey=True)
    norm = Normalize(-6, 0)
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad="0.85")
    idx = {}
    for r in rows:
        idx[(r["sweep"], r["precision"], r["estimator"], r["sampler"], r["value"], r["mu"])] = r
    im = None
    for pi, (sweep, prec) in enumerate(panels):
        values = sorted({r["value"] for r in rows if r["sweep"] == sweep})
        for ci, (est, smp) in enumerate(combos):
            ax = axes[pi, ci]
            grid = np.full((len(MUS), len(values)), np.nan)
            for j, mu in enumerate(MUS):
                for i, v in enumerate(values):
                    r = idx.get((sweep, prec, est, smp, v, mu))
                    if r is None:
                        continue
                    quad = r["estimator"] == "quadrature"
                    grid[j, i] = (-6.0 if r["useless"] else 0.0) if quad else \
                        math.log10(max(r["efficiency"], 1e-6))
                    mark = "N" if r["nonfinite"] else "P" if r["precision_loss"] else \
                        "B" if r["biased"] else ""
                    if mark:
                        ax.text(i, j, mark, ha="center", va="center", fontsize=7,
                                color="red" if mark != "B" or not r["useless"] else "white")
            im = ax.imshow(np.ma.masked_invalid(grid), origin="lower", cmap=cmap, norm=norm,
                           aspect="auto")
            ax.set_xticks(range(len(values)), [_fmt(v) for v in values], rotation=90,
                          fontsize=6)
            ax.set_yticks(range(len(MUS)), [f"{m:g}" for m in MUS], fontsize=6)
            if pi == 0:
                ax.set_title(est + ("" if smp == "-" else f" ({smp})"), fontsize=8)
            if ci == 0:
                ax.set_ylabel(f"{prec}\nmu", fontsize=7)
            ax.set_xlabel(sweep, fontsize=7)
    title = (f"{name}: log10 efficiency relative to the best estimator (N non-finite, "
             f"B biased > {Z_BIAS:g} se, red where the estimator is not useless; "
             "P precision lost in single; grey: mu not accepted; quadrature: dark where "
             "it stopped short of its tolerance)")
    # wrapped to the figure's width (a 9 pt character is about 0.07 in): a narrow figure cut
    # the one-line title off
    fig.suptitle(textwrap.fill(title, max(40, int(width / 0.075))), fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.6, label="log10 relative efficiency")
    return fig


def _counts(rows) -> dict:
    out = {}
    for r in rows:
        c = out.setdefault(r["model"], {f: 0 for f in FLAGS + ("cells",)})
        c["cells"] += 1
        for f in FLAGS:
            c[f] += r[f]
    return out


def summary(rows, checks, command, seconds, before=None, samples=SAMPLES,
            findings=False) -> str:
    lines = ["# Stability map", ""] + (
        ["What the map found, and what was fixed: [findings.md](findings.md).", ""]
        if findings else []) + [
             f"Generated by `{command}` in {seconds:.0f} s ({samples} samples per cell, "
             f"seed {SEED}). Each model's lobe parameters are swept "
             "(others at their defaults) against mu; every Monte Carlo estimator runs with "
             "Philox points in single and double precision against the float64 reference "
             "(`clbrdf/studies/stability.py` says how each flag is decided). `stability.csv`: one row "
             "per cell; `checks.csv`: `clbrdf check`'s finite, non-negative and weight checks "
             "at each swept value; `MODEL.png`: heat maps (colour: log10 efficiency against the "
             "best estimator at the cell; N non-finite, B biased, P precision lost in single).",
             "", f"A cell is *useless* for an estimator when its efficiency is below {USELESS:g} "
             "of the best estimator's there (it needs over 100 times the time for the same "
             "error), and the quadrature where it stopped short of its tolerance (at most "
             f"{QUAD_MAX_EVALS} evaluations per cell; it is biased where further from the "
             "reference than its error estimate, the tolerance and the Lambda tables' accuracy "
             "allow); `clbrdf albedo` and `clbrdf.albedo` warn when asked for such a cell "
             f"(the map ships as `clbrdf/data/stability.csv`). *Biased*: more than {Z_BIAS:g} "
             "standard errors from the reference; by chance alone about "
             f"{len(rows) * 2 * 3.17e-5:.1f} of the {len(rows)} cells.", ""]
    counts = _counts(rows)
    lines += ["## Failures per model (cells over all estimators, samplers and precisions)", "",
              "| model | cells | non-finite | biased | biased, not useless | precision loss | "
              "useless |", "|---|---:|---:|---:|---:|---:|---:|"]
    for name, c in counts.items():
        bu = sum(1 for r in rows if r["model"] == name and r["biased"] and not r["useless"])
        lines.append(f"| {name} | {c['cells']} | {c['nonfinite']} | {c['biased']} | {bu} | "
                     f"{c['precision_loss']} | {c['useless']} |")
    if before:
        bc = _counts(before)
        had = {(r["model"], r["estimator"]) for r in before}
        ac = _counts([r for r in rows if (r["model"], r["estimator"]) in had])
        lines += ["", "## Before and after", "", "Over the estimators both maps have.", "",
                  "| model | non-finite | biased | precision loss | useless |",
                  "|---|---:|---:|---:|---:|"]
        for name, c in ac.items():
            b = bc.get(name)
            if b:
                lines.append(f"| {name} | " + " | ".join(
                    f"{b[f]} -> {c[f]}" for f in FLAGS) + " |")
    defects = [r for r in rows if (r["nonfinite"] or r["biased"]) and not r["useless"]]
    lines += ["", "## Non-finite or biased where the estimator is otherwise useful", ""]
    if defects:
        lines += ["| model | sweep | value | mu | estimator | sampler | precision | E | stderr "
                  "| E_ref | z |", "|---|---|---:|---:|---|---|---|---:|---:|---:|---:|"]
        for r in defects:
            lines.append(f"| {r['model']} | {r['sweep']} | {_fmt(r['value'])} | {r['mu']:g} | "
                         f"{r['estimator']} | {r['sampler']} | {r['precision']} | "
                         f"{r['E']:.7g} | {r['stderr']:.2g} | {r['E_ref']:.7g} | "
                         f"{r['z']:.3g} |")
    else:
        lines.append("None.")
    lines += ["", "## Useless regions (estimator: where, per model)", ""]
    for name in counts:
        parts = []
        for est in ESTIMATORS:
            bad = [r for r in rows if r["model"] == name and r["estimator"] == est
                   and r["useless"]]
            if bad:
                sw = sorted({(r["sweep"], r["sampler"]) for r in bad})
                desc = "; ".join(
                    f"{s}{'' if smp == '-' else f' ({smp})'} "
                    f"{_fmt(min(r['value'] for r in bad if r['sweep'] == s))}.."
                    f"{_fmt(max(r['value'] for r in bad if r['sweep'] == s))}"
                    for s, smp in sw)
                parts.append(f"{est}: {sum(1 for _ in bad)} cells ({desc})")
        lines.append(f"- {name}: " + (", ".join(parts) if parts else "none"))
    failed = [c for c in checks if not c["passed"]]
    lines += ["", "## `clbrdf check` (finite, non-negative, weight) at each swept value", ""]
    if failed:
        lines += ["| model | sweep | value | precision | check | statistic | worst |",
                  "|---|---|---:|---|---|---:|---|"]
        for c in failed:
            lines.append(f"| {c['model']} | {c['sweep']} | {_fmt(float(c['value']))} | "
                         f"{c['precision']} | {c['check']} | {c['statistic']} | "
                         f"{str(c['worst'])[:120]} |")
    else:
        lines.append(f"All {len(checks)} pass.")
    return "\n".join(lines) + "\n"


def stability_map(models=None, out="stability", *, samples: int = SAMPLES,
                  precisions=("single", "double"), before=None,
                  command: str = "clbrdf.studies.stability.stability_map()", progress=None) -> Path:
    """Measure and write stability.csv, checks.csv, MODEL.png and README.md to ``out``
    (clbrdf/studies/campaign.py: a kill leaves the old files or the new ones; the rows of models
    not measured this time stay). References are taken from ``out``'s earlier stability.csv
    where it has the cell. ``before``: an earlier stability.csv to compare with."""
    names = [get_spec(n).name for n in (models or list(MODELS))]
    out = Path(out)
    cache = ref_cache(out / "stability.csv")

    def measure_one(name):
        refs = references(name, samples, cache)
        if progress:
            progress(f"{name}: references")
        rows, checks = measure(name, refs, samples=samples, precisions=precisions,
                               progress=progress)
        return ({"stability.csv": rows, "checks.csv": checks},
                png(figure(rows, name), dpi=90))

    before_rows = read_csv(before) if before else None
    if before_rows:
        _mark_precision_loss(before_rows)        # the rule of this code, for comparison

    def report(tables, cmd, seconds, measured):
        return summary(tables["stability.csv"], tables["checks.csv"], cmd, seconds, before_rows,
                       samples, (out / "findings.md").exists())
    return Campaign({"stability.csv": CsvTable(FIELDS, read_csv),
                     "checks.csv": CsvTable(CHECK_FIELDS)}, measure_one, report).run(
        names, out, command)


# ---- warnings from the shipped map
