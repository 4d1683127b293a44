"""Command line interface: ``clbrdf devices | models | eval | albedo | table | sweep | report | ...``.

Exit codes: 0 success, 2 bad input (unknown model or parameter, value out of range, malformed
argument), 3 no usable OpenCL device, 1 anything else. Errors are one line on stderr; set
``CLBRDF_DEBUG=1`` to see the traceback as well.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import shutil
import sys
import textwrap
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ..api.albedo import ESTIMATORS, albedo
from ..api.model import PRECISIONS, Model
from ..models import MODELS, get_spec, presets
from ..models.spec import ParameterError, check_directions, check_int
from ..runtime import probe
from ..runtime.build import get_include
from ..runtime.device import (
    NO_DEVICE_HELP,
    DeviceError,
    compiler_error,
    get_device,
    list_devices,
    natural_width,
    resolve_devices,
    split_device,
)
from ..studies import accuracy, ladder, stability
from ..studies.check import check
from ..studies.cluster import connect
from ..studies.furnace import white_furnace
from ..studies.report import report
from ..studies.sweep import open_sweep, sweep
from ..studies.sweepjob import (
    ERROR_RATE,
    ESTIMATORS as SWEEP_ESTIMATORS,
    MAX_GROWTH,
    chunk_bounds,
    make_job,
)
from ..tables.axes import parse_axis
from ..tables.checkpoint import checkpoint
from ..tables.compute import albedo_table, table_axes
from ..tables.files import check_out, save_tables
from ..tables.layouts import (
    get_layout,
    layouts,
    layouts as _layouts,
    make_layout,
)
from ..tables.table import load_tables
from ..version import __version__

EXIT_INPUT = 2
EXIT_DEVICE = 3
EXIT_CHECK_FAILED = 4

DEVICE_HELP = ("OpenCL device: P:D as 'clbrdf devices' lists it, or a substring of the device or "
               "platform name (default: env CLBRDF_DEVICE, else the first GPU, else the CPU of "
               "the newest PoCL, else the first CPU, whose compiler works)")


class _Once(argparse.Action):
    """An option that may be given once: a second --wi is an error, as a repeated --param is."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, f"_seen_{self.dest}", False):
            parser.error(f"{option_string} is given twice ({getattr(namespace, self.dest)} and "
                         f"{values}); give it once")
        setattr(namespace, f"_seen_{self.dest}", True)
        setattr(namespace, self.dest, values)


class _Include(argparse.Action):
    """--include: print the C header directory and exit (as --version does)."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(get_include())
        parser.exit()


class _Parser(argparse.ArgumentParser):
    """argparse with a one-line error message and exit code 2."""

    def error(self, message):
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# ---------------------------------------------------------------------------------------------
# argument parsing helpers (all raise ParameterError on bad input)

def _number(text: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ParameterError(f"{what}={text!r} is not a number") from None


def parse_params(spec, items) -> dict:
    """``NAME=VALUE`` strings -> keyword arguments: options stay strings, parameters become
    floats (range checks are the model's). A per-channel parameter given as three values
    (``kd=0.2,0.3,0.4``) makes the model RGB (``channels=3``)."""
    out: dict = {}
    option_names = {o.name for o in spec.options}
    for item in items or ():
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise ParameterError(f"--param {item!r} is malformed: expected NAME=VALUE "
                                 f"(e.g. alpha=0.3 or masking=vcavity)")
        if name in out:
            raise ParameterError(f"parameter {name} is given twice ({name}={out[name]!r} and "
                                 f"{name}={value!r})")
        if name in option_names:
            out[name] = value
            continue
        if name == "channels":          # RGB with every per-channel parameter grey
            if value not in ("1", "3"):
                raise ParameterError(f"parameter channels={value!r} is not valid: channels is 1 "
                                     f"or 3 (RGB)")
            out[name] = int(value)
            continue
        p = spec.param(name)            # unknown names: ParameterError listing the valid ones
        parts = value.split(",")
        if len(parts) > 1 and not (p.spectral and len(parts) == 3):
            raise ParameterError(f"parameter {name}={value!r}: " + (
                "a per-channel parameter takes one value or three (R,G,B)" if p.spectral else
                f"{name} takes one value (it is not per channel)"))
        try:
            v = [float(x) for x in parts]
        except ValueError:
            raise ParameterError(f"parameter {name}={value!r} is not a number: valid {name} is in "
                                 f"{p.range_text()} ({p.meaning})") from None
        out[name] = v[0] if len(v) == 1 else v
        if len(v) == 3:
            if out.get("channels", 3) != 3:
                raise ParameterError(f"parameter {name}={value!r} has three values (R,G,B) but "
                                     f"channels=1 is given")
            out["channels"] = 3
    return out


def parse_vector(text: str, name: str) -> np.ndarray:
    parts = text.split(",")
    if len(parts) != 3:
        raise ParameterError(f"{name}={text!r} is malformed: expected three numbers X,Y,Z "
                             f"(a unit vector with Z > 0)")
    return np.array([_number(p.strip(), name) for p in parts])


def parse_list(text: str, name: str) -> np.ndarray:
    parts = [p.strip() for p in text.split(",")]
    if not text.strip() or any(not p for p in parts):
        raise ParameterError(f"{name}={text!r} is malformed: expected comma-separated numbers "
                             f"(e.g. {name}=0.1,0.5,1)")
    return np.array([_number(p, name) for p in parts])


# ---------------------------------------------------------------------------------------------
# device helpers

def _usable(device) -> None:
    """DeviceError unless the device's compiler works (one cached probe per device)."""
    info = device.info
    err = compiler_error((info.platform_index, info.device_index))
    if err is not None:
        raise DeviceError(f"device {info.selector} ({info.name} [{info.platform}]) cannot compile "
                          f"kernels: {err}. {NO_DEVICE_HELP}")


def _model(name, args, params):
    m = Model(name, precision=getattr(args, "precision", "single"), device=args.device,
              width=getattr(args, "width", None), preset=getattr(args, "preset", None), **params)
    _usable(m.device)
    return m


def _spec(name):
    return get_spec(name)


# ---------------------------------------------------------------------------------------------
# commands

def _kernel_state(info, run: bool):
    """(column text, note) of whether the device runs the kernels at its default width in single
    precision: ok W<width>, "width 1 only", FAILS, or untested (clbrdf.probe's cache; ``run``
    checks the untested)."""
    w = natural_width(info, "single")
    look = probe.kernel_error if run else probe.cached
    err = look(info, w, "single")
    if err is ...:
        return "untested", None
    if err is None:
        return f"ok W{w}", None
    err1 = look(info, 1, "single") if w != 1 else err
    if err1 is None:
        return "width 1 only", err
    return ("FAILS" if err1 is not ... else "untested"), err


def cmd_devices(args) -> int:
    devs = list_devices()
    if not devs:
        raise DeviceError(NO_DEVICE_HELP)
    try:
        chosen = get_device(args.device).info.selector
        why = None
    except DeviceError as e:
        chosen, why = None, str(e)
    rows, kernel_notes = [], []
    for d in devs:
        err = compiler_error((d.platform_index, d.device_index))
        # --probe checks the devices --device selects (all without it)
        run = args.probe and (not args.device or d.selector == chosen)
        kern, note = _kernel_state(d, run) if err is None else ("-", None)
        rows.append((d.selector, "GPU" if d.is_gpu else "CPU", "yes" if d.has_fp64 else "no",
                     "ok" if err is None else "FAILS", kern, d.compute_units,
                     f"{d.name} [{d.platform}]" + ("  <- default" if d.selector == chosen else ""),
                     err))
        kernel_notes.append(note)
    if args.json:
        print(json.dumps({"devices": [
            {"selector": r[0], "type": r[1], "fp64": r[2] == "yes", "compiler_ok": r[7] is None,
             "compiler_error": r[7], "kernels": r[4], "kernel_error": note,
             "compute_units": r[5], "name": d.name, "platform": d.platform,
             "default": r[0] == chosen}
            for r, d, note in zip(rows, devs, kernel_notes)], "default": chosen}, indent=2))
    else:
        head = ("P:D", "type", "fp64", "compiler", "kernels", "units", "device [platform]")
        w = [max(len(str(x)) for x in col) for col in zip(head, *[r[:6] for r in rows])]
        print("  ".join(str(h).ljust(n) for h, n in zip(head, w)) + "  " + head[6])
        for r, note in zip(rows, kernel_notes):
            print("  ".join(str(x).ljust(n) for x, n in zip(r[:6], w)) + "  " + r[6])
            if r[7]:
                print(" " * (sum(w) + 2 * len(w)) + f"compiler: {r[7]}")
            if note:
                print(" " * (sum(w) + 2 * len(w)) + f"kernels: {note}")
        if any(r[4] == "untested" for r in rows):
            print(f"kernels: untested devices are checked on first use, or now with "
                  f"--probe (a child process per device and width, up to {probe.TIMEOUT} s)")
        src = ("--device" if args.device else "CLBRDF_DEVICE" if os.environ.get("CLBRDF_DEVICE")
               else "first working GPU, else newest PoCL's CPU, else CPU")
        print(f"default: {chosen or 'none'} ({src})")
    if chosen is None:
        print(f"clbrdf devices: error: {why}", file=sys.stderr)
        return EXIT_DEVICE
    return 0


def cmd_presets(args) -> int:
    summary = presets.summary()
    if args.model:
        _spec(args.model)
        summary = {args.model: summary.get(args.model, {"sources": [], "materials": []})}
    if args.json:
        print(json.dumps(summary, indent=2))
        return 0
    for i, (model, d) in enumerate(summary.items()):
        if i:
            print()
        if not d["sources"]:
            print(f"{model}: no presets")
            continue
        print(f"{model}: {len(d['materials'])} materials (--preset MATERIAL[:SOURCE])")
        for j, src in enumerate(d["sources"]):
            print(f"  source {src['label']}{' (default)' if j == 0 else ''}: {src['file']}, "
                  f"{src['attribution']}")
        names, line = d["materials"], "   "
        for n in names:
            if len(line) + len(n) + 1 > 100:
                print(line)
                line = "   "
            line += " " + n
        print(line)
    return 0


def cmd_models(args) -> int:
    if args.presets:
        return cmd_presets(args)
    specs = [_spec(args.model)] if args.model else list(MODELS.values())
    if args.json:
        print(json.dumps({s.name: {
            "title": s.title, "reference": s.reference,
            "params": {p.name: {"meaning": p.meaning, "range": p.range_text(), "lo": p.lo,
                                "hi": p.hi, "lo_open": p.lo_open,
                                "default": None if p.computed else p.default,
                                **({"default_computed": p.computed} if p.computed else {}),
                                "per_channel": p.spectral}
                       for p in s.params},
            "options": {o.name: {"meaning": o.meaning, "choices": list(o.choices),
                                 "default": o.default} for o in s.options},
            "notes": s.notes}
            for s in specs}, indent=2))
        return 0
    for i, s in enumerate(specs):
        if i:
            print()
        print(f"{s.name}: {s.title}")
        print(f"  reference: {s.reference}")
        print("  parameters (--param NAME=VALUE):")
        wn = max(len(p.name) for p in s.params)
        wr = max(len(p.range_text()) for p in s.params)
        for p in s.params:
            dflt = "computed" if p.computed else f"{p.default:<7g}"
            print(f"    {p.name.ljust(wn)}  {p.range_text().ljust(wr)}  default {dflt:<8} "
                  f"{p.meaning}{f' (default: {p.computed})' if p.computed else ''}"
                  f"{' (per channel: one value or R,G,B)' if p.spectral else ''}")
        if s.options:
            print("  options (--param NAME=CHOICE):")
            wo = max(len(o.name) for o in s.options)
            wc = max(len("|".join(o.choices)) for o in s.options)
            wd = max(len(o.default) for o in s.options)
            for o in s.options:
                print(f"    {o.name.ljust(wo)}  {'|'.join(o.choices).ljust(wc)}  "
                      f"default {o.default.ljust(wd)}  {o.meaning}")
        if s.notes:
            print(textwrap.fill(s.notes, 100, initial_indent="  ", subsequent_indent="  "))
    return 0


def cmd_eval(args) -> int:
    spec = _spec(args.model)
    params = parse_params(spec, args.param)
    wi = check_directions("wi", parse_vector(args.wi, "wi"))
    wo = check_directions("wo", parse_vector(args.wo, "wo"))
    m = _model(spec.name, args, params)
    f = np.asarray(m.eval(wo, wi), dtype=float)
    value = f.tolist()
    if args.json:
        d = m.describe()
        print(json.dumps({"model": d.pop("model"), "params": d, "wi": wi.tolist(),
                          "wo": wo.tolist(), "value": value, "precision": m.precision,
                          "device": m.device.info.name}))
    else:
        print(" ".join(f"{x:.9g}" for x in np.ravel(f)))
    return 0


def _describe(d: dict) -> str:
    def fmt(v):
        if isinstance(v, float):
            return f"{v:g}"
        if isinstance(v, list):
            return ",".join(f"{x:g}" for x in v)
        return str(v)
    return " ".join(f"{k}={fmt(v)}" for k, v in d.items() if k != "model")


def cmd_albedo(args) -> int:
    spec = _spec(args.model)
    params = parse_params(spec, args.param)
    mu = parse_list(args.mu, "mu")
    phi = _number(args.phi, "phi")
    m = _model(spec.name, args, params)
    why = _choose_estimator(args)
    r = albedo(m, mu, phi, estimator=args.estimator, samples=args.samples, seed=args.seed,
               qmc=args.qmc, progress=True, **_quad_args(args))
    if args.json:
        out = r.to_json()
        out.update({"estimator": args.estimator, "qmc": args.qmc, "phi": phi,
                    **({"estimator_chosen": why} if why else {}),
                    "device": m.device.info.name, "version": __version__})
        print(json.dumps(out))
        return 0
    print(f"{spec.name}  {_describe(m.describe())}")
    how = (f"quadrature to tol {r.tol:g}, up to {r.samples} evaluations per point" if r.tol
           else f"{args.estimator}{' (qmc)' if args.qmc else ''}, {r.samples} samples per "
                f"point, seed {args.seed}")
    print(f"estimator {how}, {m.precision} precision, phi {phi:g}, {m.device.info.name}, "
          f"{r.seconds:.3g} s")
    if why:
        _note(args, f"no --estimator: {why}")
    err = "error" if r.tol else "stderr"
    d = 9 if r.tol else 6                   # digits the error estimate supports
    w = d + 4
    if m.channels == 1:
        print(f"{'mu':>10}  {'albedo':>{w}}  {err:>10}")
        for x, e, s in zip(np.ravel(r.mu), np.ravel(r.albedo), np.ravel(r.stderr)):
            print(f"{x:>10.6g}  {e:>{w}.{d}f}  {s:>10.2e}")
        return 0
    print(f"{'mu':>10}  " + "  ".join(f"{'albedo ' + c:>{w}}  {err:>8}" for c in "RGB"))
    E, S = r.albedo.reshape(-1, 3), r.stderr.reshape(-1, 3)
    for x, e, s in zip(np.ravel(r.mu), E, S):
        print(f"{x:>10.6g}  " + "  ".join(f"{a:>{w}.{d}f}  {b:>8.1e}" for a, b in zip(e, s)))
    return 0


def cmd_check(args) -> int:
    spec = _spec(args.model)
    params = parse_params(spec, args.param)
    out = None
    if args.out:
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    m = _model(spec.name, args, params)
    check_int("samples", args.samples, 1024, 2**32 - 1, "[1024, 2^32)")
    r = check(m, samples=args.samples, seed=args.seed, out=out)
    if args.json:
        print(json.dumps(r.to_json(), indent=2))
    else:
        print(f"clbrdf check {spec.name} ({', '.join(f'{k}={v}' for k, v in r.params.items() if k != 'model')}; "
              f"{m.precision} precision, {m.device.info.name})")
        print(r.table())
        for c in r.checks:
            for f in c.details.get("files", []):
                print(f"  wrote {f}")
    return 0 if r.passed else EXIT_CHECK_FAILED


def cmd_furnace(args) -> int:
    path = Path(args.file)
    if not path.is_file():
        raise ParameterError(f"FILE {args.file!r} does not exist")
    tables = load_tables(path)
    r = white_furnace(tables, samples=args.samples, device=args.device)
    if args.json:
        print(json.dumps({k: np.asarray(v).tolist() for k, v in r.items()}))
        return 0
    kc = "kulla_conty" in r
    print(f"white furnace of {path.name}: albedo before and after compensation "
          f"({args.samples} Sobol samples per E_ss)")
    print(f"{'r':>5} {'mu':>5} {'E_ss':>9} {'+-':>8} {'Turquin':>9}" + (f" {'Kulla-Conty':>12}" if kc else ""))
    for idx in np.ndindex(r["r"].shape):
        line = (f"{r['r'][idx]:5.2f} {r['mu'][idx]:5.2f} {r['E_ss'][idx]:9.6f} "
                f"{r['E_ss_stderr'][idx]:8.1e} {r['turquin'][idx]:9.6f}")
        if kc:
            line += f" {r['kulla_conty'][idx]:12.6f}"
        print(line)
    return 0


def cmd_layouts(args) -> int:
    all_ = layouts()
    if args.json:
        print(json.dumps(all_, indent=1))
        return 0
    for name, lay in all_.items():
        print(f"{name}: {lay['consumer']}")
        for t in lay["tables"]:
            q = t["quantity"] if isinstance(t["quantity"], str) else ", ".join(
                x if isinstance(x, str) else f"{x.get('label', x['quantity'])} ({x['model']})"
                for x in t["quantity"])
            print(f"    {t['name']}: {q} over {' x '.join(t['axes'])} "
                  f"({lay.get('encoding', 'float32')})")
        print(f"    source: {lay['source']}")
    return 0


@contextlib.contextmanager
def _resumable(args, out: Path):
    """The table's computations checkpointed beside its first output (clbrdf.checkpoint), so
    that a killed run continues with --resume; the checkpoint goes once the files are written."""
    where = out.with_name(f".{out.name}.resume")
    job = {k: v for k, v in sorted(vars(args).items())
           if k not in ("resume", "argv", "func", "command") and not callable(v)}
    try:
        with checkpoint(where, json.loads(json.dumps(job, default=str)),
                        resume=args.resume) as ck:
            yield ck
    except (KeyboardInterrupt, Terminated):
        print(f"clbrdf table: stopped; finished chunks are kept in {where}; continue with the "
              f"same command and --resume", file=sys.stderr)
        raise
    shutil.rmtree(where, ignore_errors=True)


def _layout_table(args, outs) -> int:
    cmd = " ".join(["clbrdf"] + [_quote(a) for a in args.argv])
    for o in outs:
        check_out(o)
    lay = get_layout(args.layout)
    given = any(a in ("--samples", "-n") or a.startswith(("--samples=", "-n")) for a in args.argv)
    samples = args.samples if given else lay.get("samples", 1 << 16)
    why = _choose_estimator(args)          # brdf with Sobol points unless --estimator
    est = args.estimator
    _model(lay["model"], args, dict(lay.get("fixed", {})))      # no device: fail before work
    t0 = time.perf_counter()
    with _resumable(args, outs[0]):
        # the user's --estimator for every channel; without it, a channel of another model
        # keeps the layout's choice (Filament's cloth: mis)
        tables = make_layout(args.layout, samples=samples,
                             estimator=None if why and est != "quadrature" else est,
                             seed=args.seed,
                             qmc=args.qmc, precision=args.precision, device=args.device,
                             width=args.width, progress=True, command=_no_resume(cmd),
                             **_quad_args(args), **_target_args(args))
        seconds = time.perf_counter() - t0
        written = save_tables(tables, outs, prefix=_c_name(args.layout))
    for name, t in tables.items():
        print(f"{name}: {', '.join(t.quantity)} {' x '.join(str(n) for n in t.shape)} "
              f"({t.encoding}), largest stderr {float(t.stderr.max()):.2g}")
    how = (f"quadrature (tol {next(iter(tables.values())).meta['computed'].get('tol')})"
           if est == "quadrature" else
           f"{samples} samples per cell, {est}{' + qmc' if args.qmc else ''}")
    print(f"layout {args.layout}: {how}, {seconds:.1f} s; wrote {', '.join(map(str, written))}")
    if why:
        _note(args, f"no --estimator: {why}")
    return 0


def cmd_table(args) -> int:
    outs = [Path(o) for o in args.out]
    if args.layout:
        if args.model or args.axis or args.param or args.preset:
            raise ParameterError("--layout names the model, parameters and axes itself: give no "
                                 "MODEL, --param, --preset or --axis with it")
        return _layout_table(args, outs)
    if args.model is None:
        raise ParameterError("MODEL is required (or --layout NAME)")
    if not args.axis:
        raise ParameterError("a table needs axes: --axis mu=START:STOP:COUNT (and more)")
    spec = _spec(args.model)
    params = parse_params(spec, args.param)
    for o in outs:
        check_out(o)
    axes = {}
    for text in args.axis:
        ax = parse_axis(text)
        if ax["name"] in axes:
            raise ParameterError(f"axis {ax['name']} is given twice")
        axes[ax["name"]] = ax
    fixed = {**params, **({"preset": args.preset} if args.preset else {})}
    # every axis against the model, and the model on the device, before any work
    table_axes(spec, axes, fixed, args.precision)
    _model(spec.name, args, params)
    t0 = time.perf_counter()
    why = _choose_estimator(args)
    cmd = _no_resume(" ".join(["clbrdf"] + [_quote(a) for a in args.argv]))
    with _resumable(args, outs[0]):
        table = albedo_table(spec.name, axes, samples=args.samples,
                             estimator=args.estimator, seed=args.seed, qmc=args.qmc,
                             precision=args.precision, device=args.device, width=args.width,
                             progress=True, command=cmd, **_quad_args(args),
                             **_target_args(args), **fixed)
        seconds = time.perf_counter() - t0
        written = save_tables(table, outs, prefix=_c_name(spec.name))
    print(_table_summary(table, seconds, written))
    if why:
        _note(args, f"no --estimator: {why}")
    return 0


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
        others = [n for n in names if n not in ("mu", "theta", "phi")]
        if others and A.ndim:
            j0 = np.unravel_index(int(np.argmin(A)), A.shape)
            j1 = np.unravel_index(int(np.argmax(A)), A.shape)
            lines.append(f"  E_avg  min {A.min():.5f} ({at(j0, others)}), max {A.max():.5f} "
                         f"({at(j1, others)}), max {err} {np.max(t['E_avg_stderr']):.1e}")
        else:
            lines.append(f"  E_avg  {float(A):.5f} +- {float(np.max(t['E_avg_stderr'])):.1e}")
    lines.append("  wrote " + ", ".join(str(p) for p in written))
    return "\n".join(lines)


def _no_resume(cmd: str) -> str:
    """The command as recorded in a table's metadata: a resumed run's result is the same."""
    return " ".join(w for w in cmd.split(" ") if w != "--resume")


def _target_args(args) -> dict:
    out = {}
    if getattr(args, "target_stderr", None) is not None:
        out["target_stderr"] = args.target_stderr
    if getattr(args, "max_samples", None) is not None:
        out["max_samples"] = args.max_samples
    return out


def _c_name(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", s)


# the options of `sweep` that are part of its job (the store's); the others say how to run it
JOB_FLAGS = ("--param", "-p", "--axis", "--random", "--directions", "--samples", "-n",
             "--max-samples", "--target-stderr", "--estimator", "--qmc", "--error-rate", "--seed",
             "--precision", "--width", "--chunk", "--preset")


def cmd_sweep(args) -> int:
    kw = {}
    if args.model is not None:
        spec = _spec(args.model)
        kw = dict(parse_params(spec, args.param), axes=args.axis, random=args.random,
                  directions=args.directions, samples=args.samples, max_samples=args.max_samples,
                  target_stderr=args.target_stderr, estimator=args.estimator, qmc=args.qmc,
                  error_rate=args.error_rate, seed=args.seed, precision=args.precision, width=args.width,
                  chunk=args.chunk, preset=args.preset)
    elif not args.resume:
        raise ParameterError("MODEL is required (it may be left out only with --resume)")
    else:       # --resume without MODEL continues the store's job as it is
        given = sorted({a.split("=", 1)[0] for a in args.argv if a.split("=", 1)[0] in JOB_FLAGS})
        if given:
            raise ParameterError(f"{', '.join(given)} with --resume and no MODEL: the store's "
                                 f"job fixes them; leave them out, or give MODEL and every "
                                 f"argument of the job to have them checked")
    client = None
    devices = None
    if args.cluster:
        if args.split is not None:
            raise ParameterError("--split is for local devices, not with --cluster")
        if args.device and len(args.device) > 1:
            raise ParameterError("--cluster takes one --device selector (each worker's)")
        if args.model is not None:       # every argument checked before the cluster starts
            make_job(spec.name, device=None, **{**kw, "width": kw["width"] or 16})
        client = connect(args.cluster)
        devices = args.device[0] if args.device else None
    else:
        devices = resolve_devices(args.device if args.device else None)
        for d in devices:
            _usable(d)
        if args.split is not None:
            devices = [s for d in devices for s in split_device(d, args.split)]
    t0 = time.perf_counter()
    try:
        s = sweep(spec.name if args.model else None, args.out, resume=args.resume,
                  device=devices, client=client, progress=not args.quiet,
                  command=" ".join(["clbrdf"] + [_quote(a) for a in args.argv]), **kw)
    except (KeyboardInterrupt, Terminated):
        try:
            s = open_sweep(args.out)
            done = sum(chunk_bounds(s.job, i)[1] - chunk_bounds(s.job, i)[0] for i in s.done())
            print(f"clbrdf sweep: stopped; {done} of {s.points} points are written to {args.out}; "
                  f"continue with --resume", file=sys.stderr)
            _STOPPED.append(args.out)
        except ParameterError:
            pass
        raise
    finally:
        if client is not None:
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None and args.cluster.startswith("local:"):
                cluster.close()
    seconds = time.perf_counter() - t0
    summ = s.summary()
    if args.json:
        print(json.dumps(summ))
        return 0
    print(_sweep_text(s, summ, seconds))
    return 0


def _sweep_text(s, summ, seconds=None) -> str:
    job = s.job
    lines = [f"{job['model']}{' ' + job['preset'] if job['preset'] else ''}: {summ['computed']} "
             f"of {summ['points']} points: {summ['gains']} gain energy, {summ['conserves']} "
             f"conserve, {summ['undecided']} undecided (error rate {job['error_rate']:g} per point, "
             f"{len(job['directions']['mu'])} directions each)"]
    w = summ["worst"]
    if w:
        p = ", ".join(f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v}"
                      for k, v in w["parameters"].items())
        lines.append(f"largest max E = {w['E']:.6f} +- {w['stderr']:.2g} at {p}, mu = "
                     f"{w['direction']['mu']:.4g}, phi = {w['direction']['phi']:.4g}"
                     + (f", channel {w['channel']}" if "channel" in w else "")
                     + f" ({w['verdict']})")
    if summ.get("above_target"):
        lines.append(f"{summ['above_target']} points kept an estimate above --target-stderr "
                     f"{job['target_stderr']:g} at --max-samples {job['max_samples']}: raise it "
                     f"to reach the target")
    if seconds is not None:
        lines.append(f"store {s.path} written in {seconds:.1f} s")
    return "\n".join(lines)


def cmd_report(args) -> int:
    s = open_sweep(args.store)
    if args.out:
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    summ = report(args.store, args.out)
    if args.json:
        summ.pop("files", None)
        print(json.dumps(summ))
        return 0
    print(_sweep_text(s, summ))
    for f in summ.get("files", []):
        print(f"wrote {f}")
    return 0


def _chart_job(args):
    """(model names or None, output directory, command line, precisions) of a command that
    measures and writes a directory of charts (accuracy, stability, ladder), checked before
    any work."""
    names = [_spec(n).name for n in args.model] or None
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    prec = getattr(args, "precision", "both")
    precisions = ("single", "double") if prec == "both" else (prec,)
    return names, out, " ".join(["clbrdf"] + [_quote(a) for a in args.argv]), precisions


def cmd_accuracy(args) -> int:
    names, out, command, precisions = _chart_job(args)
    check_int("max-log2-samples", args.max_log2_samples, 6, 30)

    def show(r):
        print(f"{r['model']:22s} {r['precision']:6s} {accuracy.label(r['estimator'], r['rng'] == 'sobol'):15s} "
              f"{r['samples']:>12.0f} per point {r['seconds']:8.3f} s  max error {r['max']:.2e}  "
              f"rms {r['rms']:.2e}", flush=True)
    accuracy.chart(names, out, max_log2=args.max_log2_samples, precisions=precisions,
                   command=command, progress=None if args.quiet else show)
    print(f"wrote {out / 'accuracy.csv'}, {out / 'README.md'} and one PNG per model")
    return 0


def cmd_stability(args) -> int:
    names, out, command, precisions = _chart_job(args)
    check_int("samples", args.samples, 1024, 1 << 24, "[1024, 2^24]")
    if args.before and not Path(args.before).is_file():
        raise ParameterError(f"--before {args.before!r} is not a file; give an earlier "
                             "stability.csv")
    stability.stability_map(names, out, samples=args.samples, precisions=precisions,
                            before=args.before, command=command,
                            progress=None if args.quiet else lambda s: print(s, flush=True))
    print(f"wrote {out / 'stability.csv'}, {out / 'checks.csv'}, {out / 'README.md'} and one "
          "PNG per model")
    return 0


def cmd_simplest(args) -> int:
    spec = _spec(args.model)
    params = parse_params(spec, args.param)
    if not math.isfinite(args.tolerance) or not 0 <= args.tolerance < 1e6:
        raise ParameterError(f"--tolerance {args.tolerance!r} is out of range: valid tolerance "
                             "is in [0, 1e6) (relative error)")
    _usable(_model(spec.name, args, params).device)         # the configuration is valid
    if args.preset:
        params["preset"] = args.preset
    r = ladder.simplest(spec.name, args.tolerance, args.metric, device=args.device, **params)
    if args.json:
        print(json.dumps(r.to_json()))
        return 0
    v = r.variant
    what = "f over direction pairs" if r.metric == "value" else "E(mu) over mu 0.02..1"
    print(f"{r.model}: cheapest variant within {r.tolerance:g} (max relative error of {what}, "
          f"against the full model in double precision): {v.label} "
          f"({json.dumps(v.to_json()['variant'])})")
    print(f"error {v.error:.3g}, speed-up {v.speedup:.2f}x "
          f"({'eval kernel' if r.metric == 'value' else 'albedo, brdf estimator'})")
    print()
    print(r.table())
    return 0


def cmd_ladder(args) -> int:
    names, out, command, _ = _chart_job(args)
    for n in names or ():
        if n not in ladder.LADDER_CONFIGS:
            raise ParameterError(f"model={n!r} has no ladder configuration: valid models are "
                                 f"{', '.join(ladder.LADDER_CONFIGS)}")
    ladder.chart(names, out, device=args.device, command=command,
                 progress=None if args.quiet else lambda s: print(s, flush=True))
    print(f"wrote {out / 'ladder.csv'}, {out / 'README.md'} and one PNG per model")
    return 0


RECOMMENDED = ("brdf", True)
RECOMMENDED_WHY = ("brdf with Sobol points, the fastest estimator to a max error of 1e-3 for 10 "
                   "of 13 models and to 1e-4 for 7 (as `clbrdf accuracy` measures); --estimator "
                   "chooses another")


def _note(args, text: str) -> None:
    """A note for the user on stderr (stdout carries the results)."""
    print(f"clbrdf {args.command}: note: {text}", file=sys.stderr)


def _choose_estimator(args) -> str | None:
    """The estimator when --estimator is not given: RECOMMENDED (with --qmc implied); returns
    the sentence that says so, or None when the user chose."""
    if args.estimator is not None:
        return None
    if args.tol is not None or args.max_evals is not None:
        args.estimator = "quadrature"
        return "--tol or --max-evals given: the quadrature"
    args.estimator, qmc = RECOMMENDED
    args.qmc = args.qmc or qmc
    return RECOMMENDED_WHY


def _quad_args(args) -> dict:
    """--tol and --max-evals for the quadrature estimator; refused with the others."""
    given = {k: v for k, v in (("tol", args.tol), ("max_evals", args.max_evals)) if v is not None}
    if args.estimator != "quadrature":
        if given:
            raise ParameterError(f"--{next(iter(given)).replace('_', '-')} is for --estimator "
                                 f"quadrature, not {args.estimator}")
        return {}
    return given


def _quote(a: str) -> str:
    import shlex
    return shlex.quote(a)


# ---------------------------------------------------------------------------------------------

def chart_args(p, default_out: str, models_help: str, line: str, precision: bool = True):
    """MODEL ..., --out DIR, [--precision], --quiet of a command that writes a chart directory."""
    p.add_argument("model", metavar="MODEL", nargs="*", help=models_help)
    p.add_argument("--out", "-o", default=default_out, metavar="DIR",
                   help=f"output directory (default ./{default_out}; docs/{default_out} in the "
                        "repository)")
    if precision:
        p.add_argument("--precision", choices=PRECISIONS + ("both",), default="both",
                       help="kernel arithmetic (default both)")
    p.add_argument("--quiet", "-q", action="store_true", help=f"no line per {line}")


def build_parser() -> argparse.ArgumentParser:
    top = _Parser(prog="clbrdf", description="Evaluate, sample and integrate BRDFs in bulk with "
                  "OpenCL kernels (PoCL on the CPU out of the box).",
                  epilog="Exit codes: 0 ok, 2 bad input, 3 no usable OpenCL device, 4 a check failed "
                         "(clbrdf check), 1 other errors.")
    top.add_argument("--version", action="version", version=f"clbrdf {__version__}")
    top.add_argument("--include", action=_Include, nargs=0,
                     help="print the directory of the C headers (clbrdf.h and the model "
                          "headers) for C, C++, CUDA and OpenCL builds: cc -I$(clbrdf --include)")
    sub = top.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    dev = argparse.ArgumentParser(add_help=False)
    dev.add_argument("--device", metavar="SELECTOR", default=None, help=DEVICE_HELP)
    models = ", ".join(MODELS)

    def model_arg(p, optional: str | None = None):
        """MODEL (optional, with the help's reason, where another argument can name it),
        --param and --preset."""
        if optional:
            p.add_argument("model", metavar="MODEL", nargs="?",
                           help=f"one of {models} ({optional})")
        else:
            p.add_argument("model", metavar="MODEL", help=f"one of {models}")
        p.add_argument("--param", "-p", action="append", default=[], metavar="NAME=VALUE",
                       help="a parameter (alpha=0.3) or option (masking=vcavity); repeat for "
                            "several; see 'clbrdf models'")
        p.add_argument("--preset", metavar="MATERIAL[:SOURCE]",
                       help="a published fit of MODEL to a MERL material (RGB), e.g. alum-bronze; "
                            "--param values override it; see 'clbrdf models --presets'")

    def sampling_args(p):
        p.add_argument("--estimator", choices=ESTIMATORS, default=None,
                       help="uniform or cosine hemisphere sampling, brdf importance sampling, "
                            "mis (balance heuristic of brdf and cosine), or quadrature "
                            "(deterministic, adaptive Gauss-Legendre in the sampler's unit "
                            "square) (default: brdf with Sobol points, the fastest for most "
                            "models at the errors of the default sample count, as `clbrdf "
                            "accuracy` measures; quadrature when --tol is given)")
        p.add_argument("--tol", type=float, default=None, metavar="T",
                       help="quadrature: error target per point (default 1e-6 single, 1e-7 "
                            "double)")
        p.add_argument("--max-evals", type=int, default=None, metavar="N",
                       help="quadrature: integrand evaluations per point, at most (default 2^24)")
        p.add_argument("--qmc", action="store_true",
                       help="Owen-scrambled Sobol points in 16 scrambles instead of Philox")
        p.add_argument("--samples", "-n", type=int, default=1 << 16, metavar="N",
                       help="samples per point (default 65536)")
        p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
        p.add_argument("--precision", choices=PRECISIONS, default="single",
                       help="kernel arithmetic (default single)")
        p.add_argument("--width", type=int, choices=(1, 2, 4, 8, 16), default=None,
                       help="lanes per work-item (default: 16 single / 8 double on a CPU, 1 on a "
                            "GPU, or CLBRDF_WIDTH); results are bit-identical per device and width")

    p = sub.add_parser("devices", parents=[dev], help="list OpenCL devices",
                       description="Every OpenCL platform and device, whether its compiler works, "
                                   "and which one clbrdf uses by default.")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--probe", action="store_true",
                   help="check now that each device (with --device: that one) builds and runs "
                        "the kernels (a child process per device and width; otherwise untested "
                        "devices are checked on first use and the result is cached)")
    p.set_defaults(func=cmd_devices)

    p = sub.add_parser("models", parents=[dev], help="list models, parameters and options",
                       description="Each model with its parameters (meaning, range, default) "
                                   "and options (choices, default).")
    p.add_argument("model", metavar="MODEL", nargs="?", help="only this model")
    p.add_argument("--presets", action="store_true",
                   help="list the material presets (published fits) of each model instead")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.set_defaults(func=cmd_models)

    p = sub.add_parser("eval", parents=[dev], help="BRDF value for one pair of directions",
                       description="Print the BRDF value f(wo, wi) in 1/sr.")
    model_arg(p)
    p.add_argument("--wi", required=True, action=_Once, metavar="X,Y,Z", help="direction to the light (unit, Z > 0)")
    p.add_argument("--wo", required=True, action=_Once, metavar="X,Y,Z", help="direction to the viewer (unit, Z > 0)")
    p.add_argument("--precision", choices=PRECISIONS, default="single",
                   help="kernel arithmetic (default single)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_eval)

    p = sub.add_parser("albedo", parents=[dev], help="directional albedo E(mu) by Monte Carlo",
                       description="Directional albedo E(wo) = integral of f(wo, wi) cos(theta_i) "
                                   "over wi, for wo with cos(theta_o) = mu and azimuth phi.")
    model_arg(p)
    p.add_argument("--mu", required=True, action=_Once, metavar="LIST",
                   help="comma-separated cos(theta_o) values in [1e-6, 1] (single) or [1e-12, 1] "
                        "(double), e.g. 0.1,0.5,1")
    p.add_argument("--phi", default="0", action=_Once, metavar="P", help="azimuth of wo in radians (default 0)")
    sampling_args(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_albedo)

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
    p.add_argument("--layout", choices=sorted(_layouts()), default=None,
                   help="a renderer's tables in its layout (default samples: the layout's "
                        "published count)")
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
                   help="the most samples a refined cell takes (default 64 x --samples)")
    p.add_argument("--out", "-o", required=True, metavar="FILE", action="append",
                   help="output .npz, .csv, .h or .exr; with --layout or .h/.exr it may be "
                        "repeated (one computation, several files)")
    p.add_argument("--resume", action="store_true",
                   help="continue a killed run of the same command: its finished chunks are "
                        "kept in .FILE.resume/ beside the first --out until the files are written")
    p.set_defaults(func=cmd_table)

    p = sub.add_parser("furnace", parents=[dev],
                       help="white furnace of GGX energy compensation with a layout's tables",
                       description="E_ss(mu, r) estimated directly, and the albedo after Turquin's "
                                   "(f_ss / E) and Kulla-Conty's (f_ss + f_ms) compensation with "
                                   "the tables of FILE (.npz or .exr from 'clbrdf table --layout'): "
                                   "1 for a perfect table.")
    p.add_argument("file", metavar="FILE")
    p.add_argument("--samples", "-n", type=int, default=1 << 20, metavar="N",
                   help="samples per direct estimate of E_ss (default 2^20)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_furnace)

    p = sub.add_parser("layouts", help="the renderers' table layouts of 'clbrdf table --layout'")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_layouts)

    p = sub.add_parser("sweep", help="energy-conservation sweep over many parameter points, "
                       "to a resumable zarr store",
                       description="At every point (a grid over the axes, or --random N "
                                   "scrambled-Sobol points over their box) the directional albedo "
                                   "at D outgoing directions, its maximum and E_avg with standard "
                                   "errors, and a verdict: gains energy, conserves or undecided "
                                   "(the store's attributes state the rule and its error rate). Chunks are "
                                   "written as they finish; Ctrl-C or SIGTERM stops after the "
                                   "chunks in progress; --resume continues.")
    model_arg(p, "may be left out with --resume: the store's own job")
    p.add_argument("--axis", action="append", default=[], metavar="NAME=START:STOP:COUNT[:SPACING]",
                   help="a grid axis over a parameter (SPACING lin, log or sqrt), or NAME=v1,v2,...; "
                        "with --random: NAME=START:STOP[:SPACING]; repeat for each axis")
    p.add_argument("--random", type=int, default=None, metavar="N",
                   help="N scrambled-Sobol points over the axes' box instead of a grid")
    p.add_argument("--directions", default=None, metavar="SPEC",
                   help="gauss:N (N Gauss-Legendre mu nodes; default 32), gauss:NxM (times M "
                        "azimuths; default 16x8 for anisotropic models) or mu=v1,...[;phi=p1,...]")
    p.add_argument("--samples", "-n", type=int, default=4096, metavar="N",
                   help="samples per direction in the first look (default 4096)")
    p.add_argument("--max-samples", type=int, default=None, metavar="N",
                   help=f"most samples per direction for undecided points (default "
                        f"{MAX_GROWTH} x --samples)")
    p.add_argument("--target-stderr", type=float, default=None, metavar="S",
                   help="also refine every direction whose standard error exceeds S")
    p.add_argument("--estimator", choices=SWEEP_ESTIMATORS, default="brdf",
                   help="Monte Carlo estimator (default brdf)")
    p.add_argument("--qmc", action="store_true", help="Owen-scrambled Sobol points (16 scrambles)")
    p.add_argument("--error-rate", type=float, default=ERROR_RATE, metavar="E",
                   help=f"probability that a point's verdict is wrong, at most (default "
                        f"{ERROR_RATE:g})")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--precision", choices=PRECISIONS, default="single", help="default single")
    p.add_argument("--width", type=int, choices=(1, 2, 4, 8, 16), default=None,
                   help="lanes per work-item (default: the device's)")
    p.add_argument("--chunk", type=int, default=None, metavar="POINTS",
                   help="points per chunk (default: about 131072 directions' worth)")
    p.add_argument("--out", "-o", required=True, metavar="STORE", help="the zarr store (a directory)")
    p.add_argument("--resume", action="store_true", help="continue the store at --out")
    p.add_argument("--device", action="append", default=None, metavar="SELECTOR",
                   help=DEVICE_HELP + "; repeat to share the sweep among several devices")
    p.add_argument("--split", type=int, default=None, metavar="N",
                   help="split each device into N sub-devices (OpenCL device fission)")
    p.add_argument("--cluster", metavar="ADDRESS", default=None,
                   help="run the chunks on a dask.distributed cluster: a scheduler address, or "
                        "local:N for N single-threaded local workers (pip install 'clbrdf[cluster]')")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("report", help="report of a sweep store: markdown, maps, worst points",
                       description="Prints the summary (points, gains, conserves, undecided, the "
                                   "worst point); with --out DIR writes DIR/README.md and PNG maps "
                                   "of max E over every pair of axes, and a histogram of max E.")
    p.add_argument("store", metavar="STORE")
    p.add_argument("--out", "-o", metavar="DIR", help="directory for README.md and the PNGs")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("accuracy", parents=[dev], help="chart error against cost for every "
                       "albedo estimator",
                       description="For one model per family (or the MODELs given) at fixed "
                                   "directions and parameters: the error of E against the float64 "
                                   "reference, against samples per point and wall time, for every "
                                   "estimator (uniform, cosine, brdf, mis with Philox and Sobol "
                                   "points; quadrature), single and double precision. Writes "
                                   "DIR/accuracy.csv, DIR/MODEL.png and DIR/README.md (the fastest "
                                   "estimator per target error).")
    chart_args(p, "accuracy", f"models (default: all of {models})", "run")
    p.add_argument("--max-log2-samples", type=int, default=20, metavar="K",
                   help="largest Monte Carlo count per point, 2^K (default 20)")
    p.set_defaults(func=cmd_accuracy)

    p = sub.add_parser("stability", parents=[dev], help="map where each albedo estimator "
                       "fails", description="For every model (or the MODELs given), sweep its "
                       "lobe parameters to the edges of their ranges against mu, run every Monte "
                       "Carlo estimator and sampler in single and double precision against the "
                       "float64 reference, and record non-finite results, bias beyond 4 standard "
                       "errors, efficiency against the best estimator (useless below 1e-2) and "
                       "precision lost in single; with clbrdf check's finite, non-negative and "
                       "weight checks at each swept value. Writes DIR/stability.csv, "
                       "DIR/checks.csv, DIR/MODEL.png (heat maps) and DIR/README.md.")
    chart_args(p, "stability", f"models (default: all of {models})", "sweep")
    p.add_argument("--samples", type=int, default=1 << 16, metavar="N",
                   help="Monte Carlo samples per cell (default 65536)")
    p.add_argument("--before", metavar="CSV", help="an earlier stability.csv: README.md then "
                   "compares the failure counts")
    p.set_defaults(func=cmd_stability)

    p = sub.add_parser("simplest", parents=[dev], help="the cheapest variant of a "
                       "configuration within a tolerance",
                       description="Measure every cheaper variant of the configuration "
                                   "(masking, Fresnel, lobes, Schlick's formulations, diffraction, "
                                   "analytic Lambda, single precision; clbrdf/ladder.py) against "
                                   "the full configuration in double precision and print the "
                                   "fastest whose max relative error is within the tolerance, with "
                                   "its error and measured speed-up.")
    p.add_argument("model", metavar="MODEL")
    p.add_argument("--tolerance", "-t", type=float, required=True, metavar="T",
                   help="max relative error allowed")
    p.add_argument("--param", "-p", action="append", metavar="NAME=VALUE",
                   help="parameter or option (repeatable)")
    p.add_argument("--preset", metavar="MATERIAL[:SOURCE]", help="a published fit")
    p.add_argument("--metric", choices=("value", "albedo"), default="value",
                   help="value: f over direction pairs (default); albedo: E(mu)")
    p.add_argument("--json", action="store_true", help="one JSON object")
    p.set_defaults(func=cmd_simplest)

    p = sub.add_parser("ladder", parents=[dev], help="chart every cheaper variant's cost "
                       "against its error",
                       description="For each model's ladder configuration "
                                   "(clbrdf.ladder.LADDER_CONFIGS): every cheaper variant's max "
                                   "relative error of f and of E against the full model in double, "
                                   "and its measured evaluations and albedo samples per second. "
                                   "Writes DIR/ladder.csv, DIR/MODEL.png and DIR/README.md.")
    chart_args(p, "ladder", "models (default: all with a ladder configuration)", "model",
               precision=False)
    p.set_defaults(func=cmd_ladder)

    p = sub.add_parser("check", parents=[dev], help="property checks of one configuration",
                       description="Run the conformance checks on the device for one "
                                   "configuration: finite and non-negative values, weight = f cos "
                                   "/ pdf, chi-square of the sampler against its pdf, the pdf's "
                                   "integral, albedo against a sampler-free quadrature, honest "
                                   "standard errors, and energy (max E with confidence bounds). "
                                   "Exit 0 when every check passes, 4 when any fails.")
    model_arg(p)
    p.add_argument("--precision", choices=PRECISIONS, default="single",
                   help="kernel arithmetic (default single)")
    p.add_argument("--samples", "-n", type=int, default=1 << 16, metavar="N",
                   help="samples per direction (default 65536)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--width", type=int, choices=(1, 2, 4, 8, 16), default=None,
                   help="lanes per work-item")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--out", metavar="DIR", help="directory for the chi-square histograms (PNG) "
                   "and worst bins (CSV) when that check fails")
    p.set_defaults(func=cmd_check)
    return top


# the library names its Python parameters; the command line names them as its flags
FLAG_WORDS = [
    (r"\baxis (?=')", "--axis "), (r"\baxis (\w+) differs", r"--axis \1 differs"),
    (r"\baxes differ\b", "--axis differs"), (r"\bdirections (?=')", "--directions "),
    (r"\bdirections differ\b", "--directions differs"),
    (r"\bfixed parameter (\w+) differs", r"--param \1 differs"),
    (r"\b(?:with )?resume=False\b", "without --resume"), (r"\bresume=True\b", "--resume"),
    (r"\bout=(?=')", "--out "), (r"\brandom=N\b", "--random N"),
    (r"\(mu=START:STOP:COUNT\)", "(--axis mu=START:STOP:COUNT)"),
    (r"(?<![\w-])(max_samples|target_stderr|error_rate)\b",
     lambda m: "--" + m.group(1).replace("_", "-")),
    (r"(?<=: )(preset|estimator|qmc|samples|seed|precision|width|chunk|random) differs",
     r"--\1 differs"),
    (r"(?<=: )model differs", "MODEL differs"),
]


def _clean(e) -> str:
    """One line; NumPy scalar reprs (np.float64(0.5)) shown as plain numbers; the library's
    parameter names as the flags that set them (FLAG_WORDS)."""
    msg = re.sub(r"(?<!['\"])np\.(?:float|int|uint)\d+\(([^()]*)\)", r"\1", str(e))
    for pattern, repl in FLAG_WORDS:
        msg = re.sub(pattern, repl, msg)
    return " ".join(msg.split())


VALUE_OPTIONS = ("--wi", "--wo", "--mu", "--phi", "--param", "-p", "--axis")


def _join_negative(argv):
    """``--wo -0.6,0,0.8`` -> ``--wo=-0.6,0,0.8``: argparse would take the value for an option."""
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        if (a in VALUE_OPTIONS and i + 1 < len(argv) and re.match(r"-[\d.]", argv[i + 1])):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
        else:
            out.append(a)
            i += 1
    return out


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that staged files are discarded on the way out."""


def _on_sigterm(signum, frame):
    raise Terminated()


def main(argv=None) -> int:
    import signal
    argv = list(sys.argv[1:] if argv is None else argv)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _on_sigterm)
    parser = build_parser()
    args = parser.parse_args(_join_negative(argv))
    args.argv = argv
    with warnings.catch_warnings():     # restored for callers of main() in the same process
        warnings.filterwarnings("ignore", message=r".*has been retrieved more than once")
        warnings.showwarning = lambda message, category, *a, **k: print(
            f"clbrdf {args.command}: warning: {_clean(message)}", file=sys.stderr)
        return _run(args)


def _run(args) -> int:
    try:
        return args.func(args)
    except ParameterError as e:
        print(f"clbrdf {args.command}: error: {_clean(e)}", file=sys.stderr)
        return EXIT_INPUT
    except DeviceError as e:
        print(f"clbrdf {args.command}: error: {_clean(e)}", file=sys.stderr)
        return EXIT_DEVICE
    except BrokenPipeError:             # e.g. clbrdf albedo ... | head
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except KeyboardInterrupt:
        print("clbrdf: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print("clbrdf: terminated", file=sys.stderr)
        return 143
    except OSError as e:            # a full or read-only disk, a missing directory: say where
        if os.environ.get("CLBRDF_DEBUG"):
            raise
        print(f"clbrdf {args.command}: error: {_os_error(e, args)}", file=sys.stderr)
        return 1
    except Exception as e:
        if os.environ.get("CLBRDF_DEBUG"):
            raise
        kind = "error" if isinstance(e, (ValueError, OSError)) else f"error ({type(e).__name__})"
        msg = _clean(e) or type(e).__name__
        print(f"clbrdf {args.command}: {kind}: {msg}", file=sys.stderr)
        return EXIT_INPUT if isinstance(e, ValueError) else 1


def _os_error(e: OSError, args) -> str:
    """An OSError as a sentence with the file it concerns: its own filename, else the
    command's outputs (a write into a temporary file or a checkpoint beside them)."""
    what = e.strerror or str(e)
    if e.filename is not None:
        where = str(e.filename) + (f" -> {e.filename2}" if e.filename2 is not None else "")
        return f"{what}: {where}"
    out = getattr(args, "out", None)
    outs = [str(o) for o in (out if isinstance(out, list) else [out])] if out else []
    return f"{what} while writing {', '.join(outs)}" if outs else what


def entry() -> None:
    """The console script. After a sweep stopped by SIGINT or SIGTERM (its chunks and ledger
    written), the process leaves with os._exit: a normal interpreter exit then aborted in 4 of 12
    runs on a loaded 2-core machine ('terminate called without an active exception' from a C++
    library's static destructors, exit status 134 instead of 143), never after a completed run."""
    code = main()
    if code in (130, 143) and _STOPPED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


_STOPPED: list = []


if __name__ == "__main__":
    entry()
