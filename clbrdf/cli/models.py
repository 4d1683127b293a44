"""Commands about devices and models: ``devices``, ``models``, ``eval``, ``albedo``, ``check``."""
from __future__ import annotations

import json
import os
import sys
import textwrap
from pathlib import Path

import numpy as np

from ..models import MODELS, presets
from ..models.choices import PRECISIONS, WIDTHS
from ..models.spec import ParameterError, check_directions, check_int
from ..runtime import probe
from ..runtime.device import (
    NO_DEVICE_HELP,
    DeviceError,
    compiler_error,
    get_device,
    list_devices,
    natural_width,
)
from ..version import __version__
from .common import (
    EXIT_CHECK_FAILED,
    EXIT_DEVICE,
    Once,
    bars,
    choose_estimator,
    dev_parent,
    model_arg,
    model_for,
    note,
    number,
    parse_list,
    parse_params,
    parse_vector,
    quad_args,
    sampling_args,
    spec_of,
)


def _kernel_state(info, run: bool):
    """(column text, note) of whether the device runs the kernels at its default width in single
    precision: ok W<width>, "width 1 only", FAILS, or untested (clbrdf.runtime.probe's cache; ``run``
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
        spec_of(args.model)
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
    specs = [spec_of(args.model)] if args.model else list(MODELS.values())
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
    spec = spec_of(args.model)
    params = parse_params(spec, args.param)
    below = spec.transmits          # a BSDF takes directions on both sides
    wi = check_directions("wi", parse_vector(args.wi, "wi"), allow_below=below)
    wo = check_directions("wo", parse_vector(args.wo, "wo"), allow_below=below)
    m = model_for(spec.name, args, params)
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
    from ..api.albedo import albedo
    spec = spec_of(args.model)
    params = parse_params(spec, args.param)
    mu = parse_list(args.mu, "mu")
    phi = number(args.phi, "phi")
    m = model_for(spec.name, args, params)
    why = choose_estimator(args)
    r = albedo(m, mu, phi, estimator=args.estimator, samples=args.samples, seed=args.seed,
               qmc=args.qmc, progress=bars(), **quad_args(args))
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
        note(args, f"no --estimator: {why}")
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
    from ..studies.check import check
    spec = spec_of(args.model)
    params = parse_params(spec, args.param)
    out = None
    if args.out:
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    m = model_for(spec.name, args, params)
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


def add_parsers(sub) -> None:
    dev = dev_parent()

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
    p.add_argument("--wi", required=True, action=Once, metavar="X,Y,Z", help="direction to the light (unit, Z > 0)")
    p.add_argument("--wo", required=True, action=Once, metavar="X,Y,Z", help="direction to the viewer (unit, Z > 0)")
    p.add_argument("--precision", choices=PRECISIONS, default="single",
                   help="kernel arithmetic (default single)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_eval)

    p = sub.add_parser("albedo", parents=[dev], help="directional albedo E(mu) by Monte Carlo",
                       description="Directional albedo E(wo) = integral of f(wo, wi) cos(theta_i) "
                                   "over wi, for wo with cos(theta_o) = mu and azimuth phi.")
    model_arg(p)
    p.add_argument("--mu", required=True, action=Once, metavar="LIST",
                   help="comma-separated cos(theta_o) values in [1e-6, 1] (single) or [1e-12, 1] "
                        "(double), e.g. 0.1,0.5,1; negative for a wo below the surface of a "
                        "model that transmits (ggx_dielectric: --mu=-0.5,0.5)")
    p.add_argument("--phi", default="0", action=Once, metavar="P", help="azimuth of wo in radians (default 0)")
    sampling_args(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_albedo)

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
    p.add_argument("--width", type=int, choices=WIDTHS, default=None,
                   help="lanes per work-item")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--out", metavar="DIR", help="directory for the chi-square histograms (PNG) "
                   "and worst bins (CSV) when that check fails")
    p.set_defaults(func=cmd_check)
