"""Writing albedo tables (from ``clbrdf.albedo_table``) to .npz or .csv, with a PNG chart.

``save_table(table, "ggx.npz")`` writes ``ggx.npz`` and ``ggx.png``; ``save_table(table,
"ggx.csv")`` writes ``ggx.csv`` (long format: one row per grid point), ``ggx.avg.csv`` (E_avg)
and ``ggx.png``. Every file is written to a temporary file in the same directory and moved into
place with ``os.replace`` only once all of them have been written, so a failure leaves no
truncated file and leaves existing files as they were.
"""
from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np

from .outputs import _Staged, _sync_close, _tmp_prefix

FORMATS = (".npz", ".csv")


def check_output(out) -> dict:
    """Before any work: the suffix is known, the directory exists and takes new files (a probe
    file is created and removed, which also catches read-only file systems), and no output path
    is a directory. Raises ValueError naming the problem; returns the paths (``paths_for``)."""
    paths = paths_for(out)
    parent = Path(out).parent if str(Path(out).parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"directory {str(parent)!r} does not exist")
    for p in paths.values():
        if p.is_dir():
            raise ValueError(f"{str(p)!r} is a directory; give a file name")
        if p.exists() and not os.access(p, os.W_OK):
            raise ValueError(f"{str(p)!r} is not writable")
    try:
        fd, probe = tempfile.mkstemp(dir=str(parent), prefix=_tmp_prefix(Path(out)), suffix=".tmp")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise ValueError(f"cannot write in directory {str(parent)!r}: {e.strerror or e}") from None
    return paths


# ---------------------------------------------------------------------------------------------
# table structure

def _meta(table) -> dict:
    m = table["metadata"]
    return json.loads(m if isinstance(m, str) else str(np.asarray(m)))


def _axes(table) -> list[str]:
    return list(_meta(table)["axes"])


def _avg_axes(table) -> list[str]:
    """The axes of E_avg: all but mu and phi (channel last for an RGB table)."""
    return [a for a in _axes(table) if a not in ("mu", "theta", "phi")]


def _dir_axis(names) -> str:
    """The axis of the outgoing direction: mu, or theta (mu = cos theta)."""
    return "mu" if "mu" in names else "theta"


def paths_for(out) -> dict:
    """The files ``save_table`` writes for an output name: data, avg (csv only), chart."""
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(f"unknown output suffix {out.suffix!r}: valid suffixes are "
                         f"{', '.join(FORMATS)}")
    paths = {"data": out, "chart": out.with_suffix(".png")}
    if suffix == ".csv":
        paths["avg"] = out.with_suffix(".avg.csv")
    return paths


def _fmt(x) -> str:
    return repr(float(x))


def _write_npz(f, table):
    arrays = {k: np.asarray(v) for k, v in table.items() if k != "metadata"}
    np.savez(f, metadata=np.asarray(table["metadata"]), **arrays)


def _write_csv(f, table):
    names = _axes(table)
    f.write("# " + table["metadata"].replace("\n", " ") + "\n")
    f.write(",".join(names + ["E", "E_stderr"]) + "\n")
    E, S = np.asarray(table["E"]), np.asarray(table["E_stderr"])
    for idx in np.ndindex(E.shape):
        row = [_fmt(table[n][i]) for n, i in zip(names, idx)] + [_fmt(E[idx]), _fmt(S[idx])]
        f.write(",".join(row) + "\n")


def _write_avg_csv(f, table):
    names = _avg_axes(table)
    f.write("# " + table["metadata"].replace("\n", " ") + "\n")
    f.write(",".join(names + ["E_avg", "E_avg_stderr"]) + "\n")
    A, S = np.asarray(table["E_avg"]), np.asarray(table["E_avg_stderr"])
    for idx in np.ndindex(A.shape):
        row = [_fmt(table[n][i]) for n, i in zip(names, idx)] + [_fmt(A[idx]), _fmt(S[idx])]
        f.write(",".join(row) + "\n")


def save_table(table: dict, out) -> list[Path]:
    """Write the table and its chart (see the module docstring); returns the paths written."""
    paths = check_output(out)
    staged = _Staged()
    try:
        if "avg" in paths:
            f = staged.open(paths["data"], "w")
            _write_csv(f, table)
            _sync_close(f)
            f = staged.open(paths["avg"], "w")
            _write_avg_csv(f, table)
            _sync_close(f)
        else:
            f = staged.open(paths["data"], "wb")
            _write_npz(f, table)
            _sync_close(f)
        f = staged.open(paths["chart"], "wb")
        plot_table(table, f)
        _sync_close(f)
        return staged.commit()
    except BaseException:
        staged.discard()
        raise


# ---------------------------------------------------------------------------------------------
# chart

def _title(meta) -> str:
    opts = ", ".join(f"{k}={v}" for k, v in meta.get("options", {}).items())
    axes = set(meta.get("axes", ()))
    fixed = ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}"
                      for k, v in meta.get("fixed", {}).items()
                      if k not in meta.get("options", {}) and k not in axes)
    head = meta.get("model", "?") + (f" ({opts})" if opts else "")
    if meta.get("preset"):
        head += f", preset {meta['preset'].get('material')} ({meta['preset'].get('source')})"
    line2 = (f"{fixed}; " if fixed else "") + f"{_how(meta, short=True)}, {meta.get('precision')} precision"
    return f"Directional albedo E: {head}\n{line2}"


def _how(meta: dict, short: bool = False) -> str:
    """How a table was computed, from its metadata."""
    if meta.get("estimator") == "quadrature":
        return (f"quadrature to tol {meta.get('tol'):g}" +
                ("" if short else f", up to {meta.get('samples')} evaluations per point"))
    est = meta.get("estimator", "?") + (" + QMC" if meta.get("qmc") else "")
    if short:
        return f"{meta.get('samples')} samples/point, {est}"
    return f"{meta.get('samples')} samples per point, estimator {est}, seed {meta.get('seed')}"


CHANNEL_NAMES = ("R", "G", "B")


def table_figure(table: dict):
    """The chart as a matplotlib Figure: per channel (one row each for an RGB table), E(mu) for
    up to 7 values of the first parameter (or phi) axis, and E_avg along the first parameter
    axis; further axes are shown at their first value, which the title states."""
    import matplotlib
    from matplotlib import cm, colors
    from matplotlib.figure import Figure

    meta = _meta(table)
    names = _axes(table)
    rgb = "channel" in names
    d = _dir_axis(names)
    e_axes = [a for a in names if a not in (d, "channel")]         # E's axes besides mu
    a_axes = [a for a in names if a not in (d, "phi", "channel")]
    spacing = meta.get("spacing", {})
    mu = np.asarray(table[d], dtype=float)
    xlabel = r"$\mu = \cos\theta_o$" if d == "mu" else r"$\theta_o$ (radians)"
    E_all = np.asarray(table["E"], dtype=float)
    S_all = np.asarray(table["E_stderr"], dtype=float)
    A_all = np.asarray(table["E_avg"], dtype=float)
    AS_all = np.asarray(table["E_avg_stderr"], dtype=float)
    nrows = 3 if rgb else 1
    fig = Figure(figsize=(11, 4.6 * nrows), dpi=110, layout="constrained")
    title = _title(meta)
    sliced = sorted(set(e_axes[1:]) | set(a_axes[1:]), key=names.index)
    if sliced:
        title += "; shown at " + ", ".join(f"{a}={float(np.asarray(table[a])[0]):g}"
                                            for a in sliced)
    fig.suptitle(title, fontsize=11)
    cmap = matplotlib.colormaps["viridis"]
    for row in range(nrows):
        E, S = (E_all[..., row], S_all[..., row]) if rgb else (E_all, S_all)
        A, AS = (A_all[..., row], AS_all[..., row]) if rgb else (A_all, AS_all)
        lead = f"channel {CHANNEL_NAMES[row]}: " if rgb else ""
        order = [names.index(d)] + [names.index(a) for a in e_axes]
        E, S = np.transpose(E, order), np.transpose(S, order)
        while E.ndim > 2:
            E, S = E[..., 0], S[..., 0]
        while A.ndim > 1:
            A, AS = A[..., 0], AS[..., 0]
        if not e_axes:
            ax = fig.add_subplot(nrows, 1, row + 1)
            ax.plot(mu, E, "o-", ms=3, color="C0", label=r"$E(\mu)$")
            ax.fill_between(mu, E - 2 * S, E + 2 * S, color="C0", alpha=0.25, lw=0)
            ax.axhline(float(A), color="C1", ls="--", label=f"$E_{{avg}}$ = {float(A):.4f}")
            ax.set_xlabel(xlabel)
            ax.set_ylabel(r"$E(\mu)$")
            ax.set_title(lead.rstrip(": "), fontsize=10)
            ax.set_xlim(0, 1)
            ax.grid(alpha=0.3)
            ax.legend()
            continue
        p = e_axes[0]
        pv = np.asarray(table[p], dtype=float)
        log = spacing.get(p) == "log"
        ax1, ax2 = fig.add_subplot(nrows, 2, 2 * row + 1), fig.add_subplot(nrows, 2, 2 * row + 2)
        n = len(pv)
        pick = np.unique(np.round(np.linspace(0, n - 1, min(n, 7))).astype(int))
        lo, hi = float(pv.min()), float(pv.max())
        if hi <= lo:
            hi = lo + (abs(lo) or 1) * 1e-6
        norm = colors.LogNorm(lo, hi) if log and lo > 0 else colors.Normalize(lo, hi)
        for j in pick:
            c = cmap(norm(pv[j]))
            ax1.plot(mu, E[:, j], "-", color=c, lw=1.6, label=f"{p} = {pv[j]:.3g}")
            ax1.fill_between(mu, E[:, j] - 2 * S[:, j], E[:, j] + 2 * S[:, j], color=c,
                             alpha=0.25, lw=0)
        cb = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax1, pad=0.01)
        cb.set_label(p)
        ax1.legend(fontsize=8, loc="best", ncol=1 if len(pick) <= 4 else 2)
        ax1.set_xlabel(xlabel)
        ax1.set_ylabel(r"$E(\mu)$")
        ax1.set_title(f"{lead}$E(\\mu)$ for {len(pick)} of {n} values of {p} "
                      f"(bands: $\\pm 2$ stderr)", fontsize=10)
        ax1.set_xlim(0, 1)
        ax1.grid(alpha=0.3)
        ax2.set_ylabel(r"$E_{avg}$")
        ax2.grid(alpha=0.3)
        if not a_axes:           # a phi axis only: E_avg is one number
            ax2.axhline(float(A), color="C3", ls="--")
            ax2.set_title(f"{lead}$E_{{avg}}$ = {float(A):.5f} (averaged over azimuth)",
                          fontsize=10)
            continue
        q = a_axes[0]
        qv = np.asarray(table[q], dtype=float)
        ax2.plot(qv, A, "o-", ms=3, color="C3")
        ax2.fill_between(qv, A - 2 * AS, A + 2 * AS, color="C3", alpha=0.25, lw=0)
        if spacing.get(q) == "log":
            ax2.set_xscale("log")
        ax2.set_xlabel(q)
        ax2.set_title(f"{lead}$E_{{avg}}$ against {q}", fontsize=10)
    return fig


def plot_table(table: dict, fileobj) -> None:
    """PNG chart (table_figure)."""
    table_figure(table).savefig(fileobj, format="png")


# ---------------------------------------------------------------------------------------------
# summary

def _axis_text(name, values, spacing) -> str:
    v = np.asarray(values, dtype=float)
    sp = f", {spacing}" if spacing == "log" else ""
    return f"{name} {len(v)} values in [{v.min():g}, {v.max():g}]{sp}"


def summary(table: dict, seconds: float, written) -> str:
    """A few lines: grid, time, min/max E, E_avg range, files written."""
    meta = _meta(table)
    names = _axes(table)
    spacing = meta.get("spacing", {})
    E = np.asarray(table["E"], dtype=float)
    A = np.asarray(table["E_avg"], dtype=float)
    grid = " x ".join(_axis_text(n, table[n], spacing.get(n, "lin")) for n in names)

    def at(idx):
        return ", ".join(f"{n}={float(np.asarray(table[n])[i]):.3g}" for n, i in zip(names, idx))
    imin = np.unravel_index(int(np.argmin(E)), E.shape)
    imax = np.unravel_index(int(np.argmax(E)), E.shape)
    err = "error" if meta.get("estimator") == "quadrature" else "stderr"
    lines = [
        f"{meta.get('model')} albedo table: {grid} = {E.size} points",
        f"  {_how(meta)}, {meta.get('precision')} precision, {meta.get('device')}: {seconds:.1f} s",
        f"  E      min {E.min():.5f} ({at(imin)}), max {E.max():.5f} ({at(imax)}), "
        f"max {err} {np.max(table['E_stderr']):.1e}",
    ]
    others = _avg_axes(table)
    if others and A.ndim:
        j0 = np.unravel_index(int(np.argmin(A)), A.shape)
        j1 = np.unravel_index(int(np.argmax(A)), A.shape)

        def at2(idx):
            return ", ".join(f"{n}={float(np.asarray(table[n])[i]):.3g}"
                             for n, i in zip(others, idx))
        lines.append(f"  E_avg  min {A.min():.5f} ({at2(j0)}), max {A.max():.5f} ({at2(j1)}), "
                     f"max {err} {np.max(table['E_avg_stderr']):.1e}")
    else:
        lines.append(f"  E_avg  {float(A):.5f} +- {float(np.max(table['E_avg_stderr'])):.1e}")
    lines.append("  wrote " + ", ".join(str(p) for p in written))
    return "\n".join(lines)
