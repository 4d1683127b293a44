"""Speed against accuracy of every albedo estimator: ``clbrdf accuracy`` and ``chart()``.

For one model per family, at a fixed set of outgoing directions and parameters (each model's ``Facts.sharp``:
each model's defaults and, where it has one, a sharp lobe; mu from grazing to normal), every
estimator (uniform, cosine, brdf, mis, each with Philox and with Sobol points, and the
deterministic quadrature) runs at sample counts from 2^5 to 2^max_log2 per point (the quadrature
at tolerances from 1e-2 down), in single and double precision. Each run's error is
|E - E_ref| against the float64 reference (``clbrdf.ref``, tol 1e-10) at every point; its RMS
and maximum, the wall time of the calls and the samples (or evaluations) per point are recorded.

Outputs in DIR: ``accuracy.csv`` (one row per model, estimator, precision and count), one PNG per
model (log-log: RMS and max error against samples per point and against wall time), and
``README.md``: for each model and target max error (1e-3 .. 1e-6), the fastest estimator that
reached it (or would, extrapolated as N^-1/2 from the largest Monte Carlo count), and the
recommendation drawn from them.
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from ..api.albedo import albedo
from ..api.model import Model
from ..models import MODELS, get_spec
from ..models.choices import MC_ESTIMATORS
from ..ref import reference
from ..tables.outputs import csv_rows
from ..version import __version__
from .campaign import Campaign, CsvTable, measured_note, png


def sharp_cases() -> dict:
    """{model: the parameters of its sharp lobe}: the models whose description names one
    (``Facts.sharp``; {} charts the defaults only)."""
    return {n: s.facts.sharp for n, s in MODELS.items() if s.facts.sharp is not None}


MUS = (0.01, 0.2, 0.5, 0.9, 1.0)


def mus(name: str) -> tuple:
    """The points of a model: MUS, and for a model that transmits also -MUS (wo inside)."""
    return MUS + (tuple(-m for m in MUS) if get_spec(name).transmits else ())
RUNS = [(e, q) for e in MC_ESTIMATORS for q in (False, True)]    # (estimator, qmc)
QUAD_TOLS = {"single": (1e-2, 1e-3, 1e-4, 1e-5, 1e-6), "double": (1e-2, 1e-3, 1e-4, 1e-5,
                                                                   1e-6, 1e-7, 1e-8)}
TARGETS = (1e-3, 1e-4, 1e-5, 1e-6)
FIELDS = ("model", "estimator", "rng", "precision", "samples", "seconds", "rms", "max",
          "points")
NUMERIC = ("samples", "seconds", "rms", "max")      # read back as numbers


def label(estimator: str, qmc: bool) -> str:
    return "quadrature" if estimator == "quadrature" else f"{estimator} {'sobol' if qmc else 'philox'}"


def cases(name: str) -> list[tuple[str, dict]]:
    """The parameter sets of a model: its defaults and, where listed, a sharp lobe."""
    out = [("defaults", {})]
    if get_spec(name).facts.sharp:
        out.append(("sharp", get_spec(name).facts.sharp))
    return out


def references(name: str) -> dict:
    """E_ref per case: an array over ``mus(name)`` (float64 reference, first channel)."""
    return {cid: np.array([float(np.ravel(reference(name, **kw).albedo(mu, 0.0, 1e-10)[0])[0])
                           for mu in mus(name)]) for cid, kw in cases(name)}


def _run(models, estimator, qmc, n):
    """(E per case, seconds, samples per point used) for one estimator at count n (the
    quadrature: tolerance n)."""
    kw = {"tol": n} if estimator == "quadrature" else {"qmc": qmc, "samples": n, "seed": 7}
    es, secs, used = {}, 0.0, []
    for cid, m in models.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            t = time.perf_counter()
            r = _albedo(m, estimator=estimator, **kw)
            secs += time.perf_counter() - t
        used.append(float(np.mean(r.evaluations)) if estimator == "quadrature" else r.samples)
        es[cid] = np.asarray(r.albedo).reshape(len(mus(m.name)), -1)[:, 0]
    return es, secs, float(np.mean(used))


def _albedo(m, **kw):
    return albedo(m, np.asarray(mus(m.name)), **kw)


def measure(name: str, precision: str, max_log2: int, ref: dict, progress=None) -> list[dict]:
    """Rows of FIELDS for one model and precision."""
    models = {cid: Model(name, precision=precision, **kw) for cid, kw in cases(name)}
    rows = []
    runs = [(e, q, [1 << k for k in range(5, max_log2 + 1, 2)] +
             ([1 << max_log2] if (max_log2 - 5) % 2 else [])) for e, q in RUNS]
    runs.append(("quadrature", False, list(QUAD_TOLS[precision])))
    for est, qmc, counts in runs:
        _run(models, est, qmc, counts[0])                   # build the programs (not timed)
        for n in counts:
            es, secs, used = _run(models, est, qmc, n)
            err = np.concatenate([np.abs(es[c] - ref[c]) for c in es])
            rows.append({"model": name, "estimator": est, "rng": "sobol" if qmc else
                         ("none" if est == "quadrature" else "philox"), "precision": precision,
                         "samples": used, "seconds": secs,
                         "rms": float(np.sqrt(np.mean(err ** 2))), "max": float(err.max()),
                         "points": err.size})
            if progress:
                progress(rows[-1])
    return rows


def best(rows: list[dict], target: float) -> list[tuple[str, float, bool]]:
    """Per estimator configuration, the least time from which on it stayed within target: the
    first count whose max error, and that of every larger count, is at most target (one lucky
    Monte Carlo run does not count); (label, seconds, extrapolated?), fastest first. Monte Carlo
    whose largest count is beyond target is extrapolated from it as time ~ (max error /
    target)^2; the quadrature is not extrapolated."""
    out = []
    for key in dict.fromkeys(label(r["estimator"], r["rng"] == "sobol") for r in rows):
        runs = sorted((r for r in rows if label(r["estimator"], r["rng"] == "sobol") == key),
                      key=lambda r: r["samples"])
        ok = [all(r["max"] <= target for r in runs[i:]) for i in range(len(runs))]
        if any(ok):
            out.append((key, runs[ok.index(True)]["seconds"], False))
        elif key != "quadrature" and runs[-1]["max"] > 0:
            out.append((key, runs[-1]["seconds"] * (runs[-1]["max"] / target) ** 2, True))
    return sorted(out, key=lambda t: t[1])


def figure(rows: list[dict], name: str):
    """Log-log chart: max and RMS error against samples per point and against wall time, a row
    of panels per precision measured (one row for --precision single or double)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    precs = [p for p in ("single", "double") if any(r["precision"] == p for r in rows)]
    fig = Figure(figsize=(13, 4.5 * len(precs)))
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(precs), 2, squeeze=False)
    colors = {"uniform": "tab:gray", "cosine": "tab:olive", "brdf": "tab:blue", "mis": "tab:green",
              "quadrature": "tab:red"}
    for j, prec in enumerate(precs):
        for est, qmc in RUNS + [("quadrature", False)]:
            rng = "sobol" if qmc else ("none" if est == "quadrature" else "philox")
            sel = [r for r in rows if r["precision"] == prec and r["estimator"] == est
                   and r["rng"] == rng]
            if not sel:
                continue
            sel.sort(key=lambda r: r["samples"])
            x = np.array([r["samples"] for r in sel])
            t = np.array([r["seconds"] for r in sel])
            mx = np.array([max(r["max"], 1e-17) for r in sel])
            rms = np.array([max(r["rms"], 1e-17) for r in sel])
            ls = "--" if qmc else "-"
            lab = label(est, qmc)
            axes[j, 0].loglog(x, mx, ls, color=colors[est], marker="o", ms=3, label=lab)
            axes[j, 0].loglog(x, rms, ls, color=colors[est], alpha=0.35, lw=1)
            axes[j, 1].loglog(t, mx, ls, color=colors[est], marker="o", ms=3, label=lab)
        axes[j, 0].set_xlabel("samples (quadrature: evaluations) per point")
        axes[j, 1].set_xlabel("wall seconds for all points")
        for a in axes[j]:
            a.set_ylabel(f"|E - E_ref|, {prec}: max (marked), RMS (faint)")
            a.grid(True, which="major", alpha=0.3)
    axes[0, 1].legend(fontsize=7, ncol=2)
    fig.suptitle(f"{name}: error of E against cost ({len(MUS)} mu x {len(cases(name))} "
                 f"parameter sets, float64 reference)")
    fig.tight_layout()
    return fig


def summary(all_rows: list[dict], command: str, seconds: float, measured=None) -> str:
    """README.md: per model and target, the fastest estimators; the recommendation."""
    note = measured_note(all_rows, measured)
    which = f"; {note}" if note else ""
    lines = ["# Speed against accuracy of the albedo estimators", "",
             f"Generated by `{command}` ({seconds:.0f} s{which}, clbrdf {__version__}). Points "
             f"per model: mu = {', '.join(map(str, MUS))} at phi = 0 (and -mu, wo inside, for a "
             f"model that transmits), for each model's defaults and a "
             "sharp lobe (each description's `Facts.sharp`); error = |E - E_ref| against the float64 "
             "reference (tol 1e-10), first channel. `accuracy.csv` has every run; "
             "`MODEL.png` the charts (max error marked, RMS faint; dashed: Sobol).", "",
             "## Fastest estimator per target max error", "",
             "Time for all points of the model; `~` marks a Monte Carlo time extrapolated as "
             "(max error / target)^2 from its largest count; `-`: no estimator got there.", "",
             "| model | precision | " + " | ".join(f"max error {t:g}" for t in TARGETS) + " |",
             "|---|---|" + "---|" * len(TARGETS)]
    wins: dict = {}
    for name in dict.fromkeys(r["model"] for r in all_rows):
        for prec in ("single", "double"):
            rows = [r for r in all_rows if r["model"] == name and r["precision"] == prec]
            if not rows:
                continue
            cells = []
            for t in TARGETS:
                b = best(rows, t)
                if not b:
                    cells.append("-")
                    continue
                k, s, x = b[0]
                wins.setdefault((prec, t), []).append(k)
                second = f"; next {b[1][0]} {'~' if b[1][2] else ''}{b[1][1]:.2g} s" if len(b) > 1 else ""
                cells.append(f"{k} {'~' if x else ''}{s:.2g} s{second}")
            lines.append(f"| {name} | {prec} | " + " | ".join(cells) + " |")
    lines += ["", "## Recommendation", ""]
    for (prec, t), ks in sorted(wins.items(), key=lambda kv: (kv[0][0], -kv[0][1])):
        counts = {k: ks.count(k) for k in dict.fromkeys(ks)}
        top = max(counts, key=counts.get)
        lines.append(f"- {prec}, max error {t:g}: **{top}** fastest for {counts[top]} of "
                     f"{len(ks)} models" + ("" if len(counts) == 1 else " (others: " + ", ".join(
                         f"{k} {v}" for k, v in counts.items() if k != top) + ")"))
    lines += ["", RECOMMENDATION]
    return "\n".join(lines) + "\n"


RECOMMENDATION = """What holds whatever the run: the quadrature has no statistical error, and
its error estimate is an estimate of a bound that `quadrature.md` shows failing in a few places
(grazing Ashikhmin-Shirley; sgd_bagher and gtr at grazing angles do not converge in 2^24
evaluations and warn). The models with tabulated Lambda (gtr, sgd, exppow,
holzschuch_pacanowski) differ from the float64 reference by their tables' accuracy (G1 within
2e-4, 1e-4, 1e-5, 1e-5): below that no estimator reaches the reference, and the extrapolated
Monte Carlo times there mean nothing. Uniform and cosine hemisphere sampling are useless for
sharp lobes (the `sharp` cases: errors of order 1 at 2^20 samples)."""


def summary_from_csv(path, command: str = "", seconds: float = 0.0) -> str:
    """README.md text from an accuracy.csv written by ``chart`` (numbers read back as floats)."""
    return summary(csv_rows(path, NUMERIC), command, seconds)


def chart(models=None, out="accuracy", *, max_log2: int = 20, precisions=("single", "double"),
          command: str = "clbrdf.studies.accuracy.chart()", progress=None) -> Path:
    """Measure and write accuracy.csv, MODEL.png and README.md to ``out``; returns ``out``
    (clbrdf/studies/campaign.py: the rows of the models not measured this time stay; a kill at
    any moment leaves the old files or the new ones)."""
    def measure_one(name):
        ref = references(name)
        rows = [r for prec in precisions for r in measure(name, prec, max_log2, ref, progress)]
        return {"accuracy.csv": rows}, png(figure(rows, name), dpi=90)
    names = [get_spec(n).name for n in (models or list(sharp_cases()))]
    return Campaign({"accuracy.csv": CsvTable(FIELDS, lambda p: csv_rows(p, NUMERIC))},
                    measure_one, lambda t, *a: summary(t["accuracy.csv"], *a)).run(
        names, out, command)
