"""Commands that write tables: ``table`` (plain and ``--layout``), ``furnace``, ``layouts``."""
from __future__ import annotations

import contextlib
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np

from ..models.choices import MAGNITUDE_TOL, MAX_GROWTH
from ..models.spec import ParameterError
from ..tables.catalog import PRODUCTS, layouts, ltc_formats, ltc_layouts
from .common import (
    Terminated,
    bars,
    c_name,
    choose_estimator,
    dev_parent,
    device_for,
    model_arg,
    no_resume,
    note,
    parse_params,
    quote,
    sampling_args,
    spec_of,
)


def cmd_furnace(args) -> int:
    from ..studies.furnace import glass_furnace, has_glass, white_furnace
    from ..tables.table import load_tables
    path = Path(args.file)
    if not path.is_file():
        raise ParameterError(f"FILE {args.file!r} does not exist")
    tables = load_tables(path)
    glass = has_glass(tables)
    try:
        r = white_furnace(tables, samples=args.samples, device=args.device)
    except ParameterError:
        if not glass:
            raise
        r = None            # glass tables only
    g = glass_furnace(tables, samples=args.samples, device=args.device) if glass else None
    if args.json:
        d = {k: v if k == "left_out" else np.asarray(v).tolist() for k, v in (r or {}).items()}
        if g is not None:
            d["glass"] = {k: np.asarray(v).tolist() for k, v in g.items()}
        print(json.dumps(d))
        return 0
    if r is not None:
        _print_furnace(path, r, args.samples)
        for k, v in r["left_out"].items():
            print(f"  {k} = {', '.join(f'{x:g}' for x in v)} left out: outside the tables' "
                  f"range (the furnace reads no table outside it)")
    if g is not None:
        _print_glass_furnace(path, g, args.samples)
    return 0


def _print_glass_furnace(path, g, samples):
    print(f"white furnace of the glass in {path.name}: E_R + E_T before and after compensation "
          f"({samples} Sobol samples per E_ss; x: Kulla-Conty's energy split)")
    print(f"{'side':>8} {'ior':>5} {'r':>5} {'mu':>5} {'E_ss':>9} {'+-':>8} {'Turquin':>9} "
          f"{'Kulla-Conty':>12} {'x':>7}")
    for s, i, j, k in np.ndindex(g["E_ss"].shape):
        print(f"{('entering', 'exiting')[s]:>8} {g['ior'][i]:5.2f} {g['r'][j]:5.2f} "
              f"{g['mu'][k]:5.2f} {g['E_ss'][s, i, j, k]:9.6f} {g['E_ss_stderr'][s, i, j, k]:8.1e} "
              f"{g['turquin'][s, i, j, k]:9.6f} {g['kulla_conty'][s, i, j, k]:12.6f} "
              f"{g['x'][i, j]:7.4f}")


def _print_furnace(path, r, samples):
    kc = "kulla_conty" in r
    print(f"white furnace of {path.name}: albedo before and after compensation "
          f"({samples} Sobol samples per E_ss)")
    print(f"{'r':>5} {'mu':>5} {'E_ss':>9} {'+-':>8} {'Turquin':>9}" + (f" {'Kulla-Conty':>12}" if kc else ""))
    for idx in np.ndindex(r["r"].shape):
        line = (f"{r['r'][idx]:5.2f} {r['mu'][idx]:5.2f} {r['E_ss'][idx]:9.6f} "
                f"{r['E_ss_stderr'][idx]:8.1e} {r['turquin'][idx]:9.6f}")
        if kc:
            line += f" {r['kulla_conty'][idx]:12.6f}"
        print(line)


def cmd_layouts(args) -> int:
    every = {"albedo": layouts(), "ltc": ltc_layouts()}       # one schema (tables.catalog)
    if args.json:
        print(json.dumps(every, indent=1))
        return 0
    for product, lays in every.items():
        print(f"{PRODUCTS[product]} NAME:")
        for name, lay in lays.items():
            print(f"  {name}: {lay['consumer']}")
            for t in lay["tables"]:
                q = t["quantity"] if isinstance(t["quantity"], str) else ", ".join(
                    x if isinstance(x, str) else
                    f"{x.get('label', x['quantity'])} ({x.get('model', t.get('model', lay['model']))})"
                    for x in t["quantity"])
                print(f"      {t['name']}: {q} over {' x '.join(t['axes'])} "
                      f"({lay.get('encoding', 'float32')})")
            print(f"      source: {lay['source']}")
    return 0


@contextlib.contextmanager
def _where(args):
    """The computation's albedo and quadrature calls on the cluster of --cluster, else here."""
    if not getattr(args, "cluster", None):
        yield None
        return
    from ..studies.cluster import session
    with session(args.cluster, args.device) as d:
        yield d


def _estimators(tables) -> str:
    """The estimators the tables' channels used: 'brdf + qmc', or 'brdf + qmc (cloth: mis +
    qmc)' where a channel of another model used its own."""
    def how(c):
        return f"{c.get('estimator')}{' + qmc' if c.get('qmc') else ''}"
    main, other = None, {}
    for t in tables.values():
        for p in t.meta.get("parts") or [{"channels": [t.name], "computed": t.computed}]:
            h = how(p.get("computed") or {})
            main = main or h
            if h != main:
                other.setdefault(h, []).extend(p["channels"])
    return main + "".join(f" ({', '.join(ch)}: {h})" for h, ch in other.items())


def _axes(texts) -> dict:
    """--axis texts -> {name: axis dict}, each name once."""
    from ..tables.axes import parse_axis
    axes = {}
    for text in texts:
        ax = parse_axis(text)
        if ax["name"] in axes:
            raise ParameterError(f"axis {ax['name']} is given twice")
        axes[ax["name"]] = ax
    return axes


def _axis_text(name, values, spacing) -> str:
    v = np.asarray(values, dtype=float)
    sp = f", {spacing}" if spacing == "log" else ""
    return f"{name} {len(v)} values in [{v.min():g}, {v.max():g}]{sp}"


def _how(meta: dict) -> str:
    if meta.get("estimator") == "quadrature":
        return (f"quadrature to tol {meta.get('tol'):g}, up to {meta.get('samples')} "
                f"evaluations per point")
    est = meta.get("estimator", "?") + (" + QMC" if meta.get("qmc") else "")
    return f"{meta.get('samples')} samples per point, estimator {est}, seed {meta.get('seed')}"


def _table_summary(t, seconds: float, written) -> str:
    """A few lines: grid, time, min/max E, E_avg range, files written."""
    from ..tables.table import DIRECTION_AXES
    meta = t.computed
    names = [n for n in meta["axes"] if n != "channel"] + \
        (["channel"] if "channel" in meta["axes"] else [])
    spacing = meta.get("spacing", {})
    E = np.asarray(t["E"], dtype=float)
    coords = {n: (t[n] if n != "channel" else np.arange(E.shape[-1])) for n in names}
    grid = " x ".join(_axis_text(n, coords[n], spacing.get(n, "lin")) for n in names)

    def at(idx, axes):
        return ", ".join(f"{n}={float(coords[n][i]):.3g}" for n, i in zip(axes, idx))
    imin = np.unravel_index(int(np.argmin(E)), E.shape)
    imax = np.unravel_index(int(np.argmax(E)), E.shape)
    err = "error" if meta.get("estimator") == "quadrature" else "stderr"
    lines = [
        f"{meta.get('model')} albedo table: {grid} = {E.size} points",
        f"  {_how(meta)}, {meta.get('precision')} precision, {meta.get('device')}: {seconds:.1f} s",
        f"  E      min {E.min():.5f} ({at(imin, names)}), max {E.max():.5f} ({at(imax, names)}), "
        f"max {err} {np.max(t['E_stderr']):.1e}",
    ]
    if t.average is not None:
        A = np.asarray(t["E_avg"], dtype=float)
        others = [n for n in names if n not in DIRECTION_AXES]
        if others and A.ndim:
            j0 = np.unravel_index(int(np.argmin(A)), A.shape)
            j1 = np.unravel_index(int(np.argmax(A)), A.shape)
            lines.append(f"  E_avg  min {A.min():.5f} ({at(j0, others)}), max {A.max():.5f} "
                         f"({at(j1, others)}), max {err} {np.max(t['E_avg_stderr']):.1e}")
        else:
            lines.append(f"  E_avg  {float(A):.5f} +- {float(np.max(t['E_avg_stderr'])):.1e}")
    lines.append("  wrote " + ", ".join(str(p) for p in written))
    return "\n".join(lines)


def _table_job(args):
    """--layout or MODEL with --axis -> the job (clbrdf.tables.jobs: its only validation), and
    the note when the estimator is the recommended one."""
    why = choose_estimator(args)          # brdf with Sobol points unless --estimator
    kw = dict(estimator=args.estimator, qmc=args.qmc, seed=args.seed, precision=args.precision,
              width=args.width, tol=args.tol, max_evals=args.max_evals,
              target_stderr=args.target_stderr, max_samples=args.max_samples)
    if args.layout:
        if args.model or args.axis or args.param or args.preset:
            raise ParameterError("--layout names the model, parameters and axes itself: give no "
                                 "MODEL, --param, --preset or --axis with it")
        given = any(a in ("--samples", "-n") or a.startswith(("--samples=", "-n"))
                    for a in args.argv)
        from ..tables.jobs import layout_job
        # without --estimator, a channel of another model keeps the layout's (Filament's cloth)
        return layout_job(args.layout, samples=args.samples if given else None,
                          match_published=args.match_published, only=args.only,
                          **dict(kw, estimator=None if why and args.estimator != "quadrature"
                                 else args.estimator)), why
    if args.only:
        raise ParameterError("--only picks tables of a layout: give it with --layout NAME")
    if args.model is None:
        raise ParameterError("MODEL is required (or --layout NAME)")
    if not args.axis:
        raise ParameterError("a table needs axes: --axis mu=START:STOP:COUNT (and more)")
    params = parse_params(spec_of(args.model), args.param)
    from ..tables.jobs import table_job
    return table_job(args.model, _axes(args.axis), samples=args.samples, **kw, **params,
                     **({"preset": args.preset} if args.preset else {})), why


def cmd_table(args) -> int:
    from ..tables.files import check_outputs, save_tables
    outs = check_outputs(args.out)
    job, why = _table_job(args)
    device_for(args)                        # a device that compiles, before any work
    from ..tables.jobs import run_job
    t0 = time.perf_counter()
    with _where(args), _resumable(args, job, outs[0]):
        tables = run_job(job, device=args.device, progress=bars(), command=_command(args))
        seconds = time.perf_counter() - t0
        written = save_tables(tables, outs, prefix=c_name(args.layout or job.arguments["model"]))
    if args.layout:
        print(_layout_summary(job, tables, seconds, written))
    else:
        print(_table_summary(next(iter(tables.values())), seconds, written))
    if why:
        note(args, f"no --estimator: {why}")
    return 0


def _layout_summary(job, tables, seconds, written) -> str:
    """A line per table (its size, error and how), its clamped cells, and the run's line."""
    a = job.arguments
    lines = []
    for name, t in tables.items():
        err = "error" if t.computed.get("estimator") == "quadrature" else "stderr"
        lines.append(f"{name}: {', '.join(t.quantity)} {' x '.join(str(n) for n in t.shape)} "
                     f"({t.encoding}), largest {err} {float(t.stderr.max()):.2g}; "
                     f"{t.meta.get('how', '')}")
        for label, c in t.meta.get("clamped", {}).items():
            lo, hi = t.meta["range"]
            at = ", ".join(f"{k}={v:.3g}" for k, v in c["at"].items())
            lines.append(f"  {name}: {c['cells']} cells of {label} clamped to [{lo:g}, {hi:g}] "
                         f"as the consumer does, by up to {c['max_excess']:.3g} (estimate "
                         f"{c['model_value']:.4g} at {at}); their stderr includes the clamp")
    published = sorted({t.meta.get("published_samples") or 1 << 16 for t in tables.values()},
                       reverse=True)
    if a["estimator"] == "quadrature":
        how = f"quadrature (tol {next(iter(tables.values())).meta['computed'].get('tol')})"
    elif a["samples"] is not None or a["match_published"]:
        n = a["samples"] or " or ".join(map(str, published))
        how = f"{n} samples per cell, {_estimators(tables)}"
    else:                       # each table as its line says: a target, the quadrature, a count
        how = f"each table to its target or count above, {_estimators(tables)}"
    lines.append(f"layout {a['layout']}: {how}, {seconds:.1f} s; wrote "
                 f"{', '.join(map(str, written))}")
    return "\n".join(lines)


def cmd_ltc(args) -> int:
    from ..tables.files import SUFFIXES, check_outputs, save_tables
    outs = check_outputs(args.out, ltc_formats(args.layout) if args.layout else SUFFIXES,
                         f"layout {args.layout}'s tables" if args.layout else "tables")
    model = args.model or (ltc_layouts()[args.layout]["model"] if args.layout else None)
    params = parse_params(spec_of(model), args.param) if model else {}
    from ..tables.jobs import ltc_job, run_job
    job = ltc_job(args.model, _axes(args.axis) or None, layout=args.layout, form=args.form,
                  samples=args.samples, report_samples=args.report_samples, seed=args.seed,
                  magnitude_tol=args.magnitude_tol, precision=args.precision, width=args.width,
                  **params, **({"preset": args.preset} if args.preset else {}))
    device_for(args)
    t0 = time.perf_counter()
    with _where(args):
        tables = run_job(job, device=args.device, command=_command(args))
        seconds = time.perf_counter() - t0
    written = save_tables(tables, outs, prefix=c_name(args.layout or job.arguments["model"]))
    print(_ltc_summary(tables["ltc"], seconds, written))
    return 0


def _ltc_summary(table, seconds, written) -> str:
    c = table.computed
    e1, se1 = np.asarray(table["L1"]), np.asarray(table["L1_stderr"])
    i = np.unravel_index(int(np.argmax(e1)), e1.shape)
    at = ", ".join(f"{n}={table[n][k]:.3g}" for n, k in zip(table.axis_names, i))
    return (f"{c['model']} LTC fit: {' x '.join(str(n) for n in table.shape)} cells, "
            f"{c['samples']} samples per loss, {c['iterations_mean']} Nelder-Mead iterations "
            f"per cell on average, {c['device']}: {seconds:.1f} s\n"
            f"  relative L1 error of the LTC: median {np.median(e1):.3g}, max {e1.max():.3g} "
            f"+- {se1[i]:.1g} ({at})\n  wrote {', '.join(map(str, written))}")


@contextlib.contextmanager
def _resumable(args, job, out: Path):
    """The table's computations checkpointed beside its first output (clbrdf.tables.checkpoint),
    keyed by the job and the device, so that a killed run continues with --resume; the
    checkpoint goes once the files are written (--cluster changes where, not what: a run started
    here may resume on a cluster)."""
    from ..tables.checkpoint import checkpoint
    where = out.with_name(f".{out.name}.resume")
    try:
        with checkpoint(where, {**job.to_json(), "device": args.device},
                        resume=args.resume) as ck:
            yield ck
    except (KeyboardInterrupt, Terminated):
        print(f"clbrdf table: stopped; finished chunks are kept in {where}; continue with the "
              f"same command and --resume", file=sys.stderr)
        raise
    shutil.rmtree(where, ignore_errors=True)


def _command(args) -> str:
    """The command as a table's metadata records it (without --resume: a resumed run's result
    is the same)."""
    return no_resume(" ".join(["clbrdf"] + [quote(a) for a in args.argv]))


CLUSTER = ("run the albedo and quadrature calls on a dask.distributed cluster: a scheduler "
           "address, or local:N for N single-threaded local workers (pip install "
           "'clbrdf[cluster]'); the result is the local run's, bit for bit, on the same device "
           "kind and width")


def add_parsers(sub) -> None:
    dev = dev_parent()

    p = sub.add_parser("table", parents=[dev], help="albedo table over a grid, or a renderer's "
                       "tables (--layout), to .npz, .csv, .h or .exr",
                       description="E over the grid of the axes and E_avg = 2 int E(mu) mu dmu over "
                                   "the non-mu axes; writes FILE (.npz or .csv, plus FILE.avg.csv "
                                   "for .csv, and a chart FILE with suffix .png; or .h, a C header "
                                   "for C99, C++17, CUDA and OpenCL C; or .exr), atomically. "
                                   "--layout NAME writes a renderer's tables exactly in its layout "
                                   "(axes, mapping, quantity, placement, encoding) to .h, .npz or "
                                   ".exr; 'clbrdf layouts' lists them.")
    model_arg(p, "not with --layout: the layout names it")
    p.add_argument("--layout", choices=sorted(layouts()), default=None,
                   help="a renderer's tables in its layout; by default each table to its "
                        "consumer's shipped error where the layout states it (Cycles), else "
                        "the published sample count")
    p.add_argument("--match-published", action="store_true",
                   help="with --layout: each table at its consumer's published sample count "
                        "(Cycles: 2^23 a cell, 10 to 15 minutes here)")
    p.add_argument("--only", action="append", default=None, metavar="TABLE",
                   help="with --layout: only this table of the layout (repeat for more; "
                        "'clbrdf layouts' lists them)")
    p.add_argument("--axis", action="append", default=[],
                   metavar="NAME=START:STOP:COUNT[:SPACING][:PLACEMENT][:min=LO]",
                   help="a grid axis: mu or theta (radians), phi, r (alpha = r^2) or a numeric "
                        "parameter; SPACING lin (default), log or sqrt; PLACEMENT nodes (default) "
                        "or centres (texel centres); min=LO evaluates at max(value, LO); or "
                        "NAME=v1,v2,...; repeat for each axis")
    sampling_args(p)
    p.add_argument("--target-stderr", type=float, default=None, metavar="S",
                   help="refine each cell (and average) whose standard error is above S: 4x "
                        "its samples per look, independent numbers, up to --max-samples")
    p.add_argument("--max-samples", type=int, default=None, metavar="N",
                   help=f"the most samples a refined cell takes (default {MAX_GROWTH} x --samples)")
    p.add_argument("--out", "-o", required=True, metavar="FILE", action="append",
                   help="output .npz, .csv, .h or .exr; with --layout or .h/.exr it may be "
                        "repeated (one computation, several files)")
    p.add_argument("--resume", action="store_true",
                   help="continue a killed run of the same command: its finished chunks are "
                        "kept in .FILE.resume/ beside the first --out until the files are written")
    p.add_argument("--cluster", metavar="ADDRESS", default=None, help=CLUSTER)
    p.set_defaults(func=cmd_table)

    p = sub.add_parser("furnace", parents=[dev],
                       help="white furnace of energy compensation (GGX, and glass) with a "
                            "layout's tables",
                       description="E_ss(mu, r) estimated directly, and the albedo after Turquin's "
                                   "(f_ss / E) and Kulla-Conty's (f_ss + f_ms) compensation with "
                                   "the tables of FILE (.npz or .exr from 'clbrdf table --layout'): "
                                   "1 for a perfect table. With a dielectric's tables from both "
                                   "sides (Cycles' glass tables) also E_R + E_T entering and "
                                   "exiting, with Kulla-Conty's reflection/transmission split.")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--samples", "-n", type=int, default=1 << 20, metavar="N",
                   help="samples per direct estimate of E_ss (default 2^20)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_furnace)

    p = sub.add_parser("ltc", parents=[dev], help="LTC tables (linearly transformed cosines) "
                       "fitted to a model, for area lights",
                       description="Per cell of the grid: the LTC (Heitz et al. 2016) fitted to "
                                   "the model's lobe f cos / E (its M^-1, normalised), the "
                                   "magnitude E, the Schlick split's B term, and the fit's L3 "
                                   "and relative L1 errors with their standard errors "
                                   "(clbrdf.fit_ltc). --layout NAME writes an engine's textures "
                                   "(threejs: .js ES module, .h, .npz, .exr; cycles_sheen: .h, "
                                   ".npz, .exr); without it, the fit as a table (.npz, .csv, .h, "
                                   ".exr).")
    model_arg(p, "with --layout: default the layout's")
    p.add_argument("--layout", choices=sorted(ltc_layouts()), default=None,
                   help="an engine's LTC textures in its layout")
    p.add_argument("--axis", action="append", default=[], metavar="NAME=START:STOP:COUNT",
                   help="a grid axis: mu, theta or sqrt1m_mu (mu = 1 - v^2), r (alpha = r^2) or "
                        "a numeric parameter (as 'clbrdf table --axis'); repeat for each axis")
    p.add_argument("--form", default=None, metavar="FORM",
                   help="general: all free entries (default); zeltner: the two-parameter LTC of "
                        "Zeltner et al. 2022 (Cycles' sheen)")
    p.add_argument("--samples", "-n", type=int, default=1024, metavar="N",
                   help="quasi-random samples per loss evaluation (default 1024)")
    p.add_argument("--report-samples", type=int, default=1 << 16, metavar="N",
                   help="Philox samples of the lobe's moments and the reported errors (default 2^16; "
                        "E and B are the deterministic quadrature's, to 2e-7)")
    p.add_argument("--magnitude-tol", type=float, default=MAGNITUDE_TOL, metavar="T",
                   help=f"error target of E and B, the deterministic quadrature's (default "
                        f"{MAGNITUDE_TOL:g})")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--precision", choices=("single", "double"), default="single")
    p.add_argument("--width", type=int, default=None, help="lanes per work-item")
    p.add_argument("--out", "-o", required=True, metavar="FILE", action="append",
                   help="output file; may be repeated")
    p.add_argument("--cluster", metavar="ADDRESS", default=None,
                   help=CLUSTER.replace("albedo and quadrature calls", "fit's cells"))
    p.set_defaults(func=cmd_ltc)

    p = sub.add_parser("layouts", help="the renderers' table layouts of 'clbrdf table --layout'")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_layouts)
