"""Reports of sweep stores (``clbrdf report STORE [--out DIR] [--json]``): a markdown summary,
maps of max E over every pair of axes (the other axes reduced by their maximum) with the gain
region outlined, the worst points and a histogram of max E, each read chunk by chunk."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..tables.axes import unwarp, warp
from .sweep import Sweep
from .sweepjob import GAINS, NOT_DONE, VERDICTS, point_values

BINS = 40            # cells per axis of a map of random points
WORST = 10


def _cells(job, i0, vals, n):
    """The cell of each point of a chunk on every axis: its grid index, or for random points
    its bin of BINS equal steps in the axis's spacing."""
    if job["random"] is None:
        counts = [len(a["values"]) for a in job["axes"]]
        idx = np.unravel_index(np.arange(i0, i0 + n), counts)
        return {a["name"]: ix for a, ix in zip(job["axes"], idx)}
    return {a["name"]: np.clip((unwarp(vals[a["name"]], a["start"], a["stop"], a["spacing"])
                                * BINS).astype(int), 0, BINS - 1) for a in job["axes"]}


def _reduce(s: Sweep):
    """One pass: per pair of axes the max of E_max and whether any point gains; per axis the
    same (1-D); the histogram data range; the worst points."""
    job = s.job
    names = s.axes
    size = {a["name"]: (len(a["values"]) if job["random"] is None else BINS) for a in job["axes"]}
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]]
    M = {p: np.full((size[p[0]], size[p[1]]), -np.inf) for p in pairs}
    G = {p: np.zeros((size[p[0]], size[p[1]]), bool) for p in pairs}
    M1 = {a: np.full(size[a], -np.inf) for a in names}
    G1 = {a: np.zeros(size[a], bool) for a in names}
    lo, hi = np.inf, -np.inf
    for i0, a in s.chunks(("E_max", "verdict")):
        v = a["verdict"]
        ok = v != NOT_DONE
        em = a["E_max"].reshape(len(v), -1).max(axis=1)
        em = np.where(ok, em, -np.inf)
        if ok.any():
            lo, hi = min(lo, float(em[ok].min())), max(hi, float(em[ok].max()))
        vals = point_values(job, i0, i0 + len(v))
        cells = _cells(job, i0, vals, len(v))
        g = v == GAINS
        for p in pairs:
            ix = (cells[p[0]], cells[p[1]])
            np.maximum.at(M[p], ix, em)
            np.logical_or.at(G[p], ix, g)
        for n in names:
            np.maximum.at(M1[n], cells[n], em)
            np.logical_or.at(G1[n], cells[n], g)
    return pairs, M, G, M1, G1, (lo, hi)


def _axis_coords(job, name):
    """(cell edges, centres, log scale?) of an axis for plotting."""
    a = next(x for x in job["axes"] if x["name"] == name)
    log = a.get("spacing") == "log"
    if job["random"] is None:
        c = np.asarray(a["values"], dtype=np.float64)
        if len(c) == 1:
            e = np.array([c[0] * 0.9, c[0] * 1.1]) if log else np.array([c[0] - 0.5, c[0] + 0.5])
            return e, c, log
        t = np.log(c) if log else c
        mid = (t[1:] + t[:-1]) / 2
        e = np.concatenate([[t[0] - (mid[0] - t[0])], mid, [t[-1] + (t[-1] - mid[-1])]])
        return (np.exp(e) if log else e), c, log

    u = np.linspace(0, 1, BINS + 1)
    e = warp(u, a["start"], a["stop"], a["spacing"])
    c = warp((u[1:] + u[:-1]) / 2, a["start"], a["stop"], a["spacing"])
    return e, c, log


def _plots(s: Sweep, out: Path, pairs, M, G, M1, G1, rng) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import TwoSlopeNorm
    job = s.job
    files = []
    lo, hi = rng
    if not np.isfinite(lo):
        return files
    vmin, vmax = min(lo, 0.999), max(hi, 1.001)
    norm = TwoSlopeNorm(vmin=vmin, vcenter=1.0, vmax=vmax)
    for a, b in pairs:
        ea, ca, la = _axis_coords(job, a)
        eb, cb, lb = _axis_coords(job, b)
        fig, ax = plt.subplots(figsize=(6, 4.8))
        Z = np.ma.masked_invalid(np.where(np.isfinite(M[(a, b)]), M[(a, b)], np.nan))
        pc = ax.pcolormesh(eb, ea, Z, cmap="RdBu_r", norm=norm, shading="flat")
        fig.colorbar(pc, ax=ax, label="max E over the other axes and directions")
        if G[(a, b)].any() and min(G[(a, b)].shape) > 1:
            ax.contour(cb, ca, G[(a, b)].astype(float), levels=[0.5], colors="k", linewidths=1.5)
        elif G[(a, b)].any():
            ia, ib = np.nonzero(G[(a, b)])
            ax.plot(cb[ib], ca[ia], "k+", ms=6)
        ax.set_xlabel(b)
        ax.set_ylabel(a)
        if la:
            ax.set_yscale("log")
        if lb:
            ax.set_xscale("log")
        ax.set_title(f"{job['model']}: max E (black: gains energy)", fontsize=10)
        fig.tight_layout()
        name = f"map_{a}_{b}.png"
        fig.savefig(out / name, dpi=90)
        plt.close(fig)
        files.append(name)
    if len(s.axes) == 1:
        a = s.axes[0]
        _, c, log = _axis_coords(job, a)
        fig, ax = plt.subplots(figsize=(6, 4))
        y = np.where(np.isfinite(M1[a]), M1[a], np.nan)
        ax.plot(c, y, "-", color="0.3")
        ax.plot(c[G1[a]], y[G1[a]], "o", color="C3", ms=4, label="gains energy")
        ax.axhline(1.0, color="k", lw=0.8, ls=":")
        ax.set_xlabel(a)
        ax.set_ylabel("max E")
        if log:
            ax.set_xscale("log")
        if G1[a].any():
            ax.legend()
        fig.tight_layout()
        fig.savefig(out / f"max_E_{a}.png", dpi=90)
        plt.close(fig)
        files.append(f"max_E_{a}.png")
    # histogram of max E (a second pass with the range known)
    edges = np.linspace(lo, hi if hi > lo else lo + 1e-9, 61)
    counts = np.zeros((3, 60))
    for _, arr in s.chunks(("E_max", "verdict")):
        v = arr["verdict"]
        em = arr["E_max"].reshape(len(v), -1).max(axis=1)
        for k, code in enumerate(VERDICTS):
            sel = v == code
            counts[k] += np.histogram(em[sel], bins=edges)[0]
    fig, ax = plt.subplots(figsize=(6, 3.6))
    bottom = np.zeros(60)
    colours = {"undecided": "0.6", "conserves": "C0", "gains": "C3"}
    for k, name in enumerate(VERDICTS.values()):
        ax.bar(edges[:-1], counts[k], width=np.diff(edges), align="edge", bottom=bottom,
               color=colours[name], label=name)
        bottom += counts[k]
    if lo <= 1 <= hi:
        ax.axvline(1.0, color="k", lw=0.8, ls=":")
    ax.set_xlabel("max E over directions (and channels)")
    ax.set_ylabel("points")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "histogram.png", dpi=90)
    plt.close(fig)
    files.append("histogram.png")
    return files


def _fmt(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list):
        return "(" + ", ".join(_fmt(x) for x in v) + ")"
    return str(v)


def _axis_text(a) -> str:
    if a.get("spacing") == "list":
        return f"{a['name']} = {', '.join(_fmt(x) for x in a['values'])}"
    if "count" in a:
        return f"{a['name']}: {_fmt(a['start'])} .. {_fmt(a['stop'])}, {a['count']} values, {a['spacing']}"
    return f"{a['name']}: {_fmt(a['start'])} .. {_fmt(a['stop'])}, {a['spacing']}"


def markdown(s: Sweep, summary: dict, worst: list, files: list[str]) -> str:
    job, man = s.job, s.manifest
    dev = sorted({(e.get("device"), e.get("platform")) for e in _ledger(s)})
    title = job["model"] + (f", preset {job['preset']}" if job["preset"] else "")
    lines = [f"# Energy sweep: {title}", ""]
    if man.get("command"):
        lines += [f"`{man['command']}`", ""]
    pts = (f"{job['random']} scrambled-Sobol points" if job["random"] is not None else
           f"a grid of {job['points']} points")
    fixed = ", ".join(f"{k}={_fmt(v)}" for k, v in job["fixed"].items()) or "none"
    lines += [f"- points: {pts} over " + ("; ".join(_axis_text(a) for a in job["axes"]) or
                                          "no axes") + f"; fixed: {fixed}",
              f"- directions: {job['directions']['spec']} ({len(job['directions']['mu'])} per "
              f"point); estimator {job['estimator']}" + (" (Sobol)" if job["qmc"] else
                                                         " (Philox)") +
              f", {job['samples']} samples per direction, up to {job['max_samples']}; seed "
              f"{job['seed']}; {job['precision']} precision, width {job['width']}",
              f"- rule: {man.get('rule', '')}",
              f"- computed by clbrdf {man.get('clbrdf')} on " +
              ("; ".join(f"{d} [{p}]" for d, p in dev) or "no device yet") +
              f"; {summary['computed']} of {summary['points']} points done", "",
              "| points | gains | conserves | undecided |", "|---:|---:|---:|---:|",
              f"| {summary['computed']} | {summary['gains']} | {summary['conserves']} | "
              f"{summary['undecided']} |", ""]
    if summary.get("above_target"):
        lines += [f"{summary['above_target']} points kept an estimate above the target standard "
                  f"error {job['target_stderr']:g} at {job['max_samples']} samples.", ""]
    if worst:
        keys = s.axes or []
        ch = job["channels"] > 1
        lines += [f"## The {len(worst)} largest max E", "",
                  "| " + " | ".join(keys + ["mu", "phi"] + (["channel"] if ch else []) +
                                    ["E", "stderr", "verdict"]) + " |",
                  "|" + "---:|" * (len(keys) + 5 + ch)]
        for w in worst:
            p = w["parameters"]
            lines.append("| " + " | ".join([_fmt(p[k]) for k in keys] +
                                           [f"{w['direction']['mu']:.4g}",
                                            f"{w['direction']['phi']:.4g}"] +
                                           ([w["channel"]] if ch else []) +
                                           [f"{w['E']:.6f}", f"{w['stderr']:.2g}",
                                            w["verdict"]]) + " |")
        lines.append("")
    if files:
        lines += ["## Maps", ""] + [f"![{f}]({f})" for f in files] + [""]
    return "\n".join(lines)


def _ledger(s: Sweep) -> list[dict]:
    out = []
    for p in sorted((s.path / "ledger").glob("c*.json")):
        try:
            out.append(json.loads(p.read_text()))
        except (OSError, ValueError):
            pass
    return out


def report(path, out=None) -> dict:
    """The summary of a store (a path, verified on opening, or an opened ``Sweep``); with
    ``out`` also DIR/README.md and the PNGs. Returns the summary with ``worst`` the single
    worst point, as ``clbrdf report --json`` prints it."""
    s = path if isinstance(path, Sweep) else Sweep(path)
    many = s.summary(worst=WORST)
    worst = many["worst"] or []
    if isinstance(worst, dict):
        worst = [worst]
    summary = {**many, "worst": worst[0] if worst else None}
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        files = _plots(s, out, *_reduce(s)) if summary["computed"] else []
        text = markdown(s, summary, worst, files)
        tmp = out / ".README.md.tmp"
        tmp.write_text(text)
        tmp.replace(out / "README.md")
        for old in (*out.glob("map_*.png"), *out.glob("max_E_*.png")):   # an earlier report's
            if old.name not in files:
                old.unlink()
        summary["files"] = [str(out / "README.md")] + [str(out / f) for f in files]
    return summary
