"""Charts of the methods: ``accuracy``, ``stability``, ``simplest``, ``ladder``,
``compensation``."""
from __future__ import annotations

import json
import math
from pathlib import Path

from ..models import MODELS
from ..models.spec import ParameterError, check_int
from ..studies import settings
from .common import (
    chart_args,
    dev_parent,
    model_for,
    parse_params,
    quote,
    spec_of,
    usable,
)


def _chart_job(args):
    """(model names or None, output directory, command line, precisions) of a command that
    measures and writes a directory of charts (accuracy, stability, ladder), checked before
    any work."""
    names = [spec_of(n).name for n in args.model] or None
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    prec = getattr(args, "precision", "both")
    precisions = ("single", "double") if prec == "both" else (prec,)
    return names, out, " ".join(["clbrdf"] + [quote(a) for a in args.argv]), precisions


def cmd_accuracy(args) -> int:
    from ..studies import accuracy
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
    from ..studies import stability
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
    from ..studies import ladder
    spec = spec_of(args.model)
    params = parse_params(spec, args.param)
    if not math.isfinite(args.tolerance) or not 0 <= args.tolerance < 1e6:
        raise ParameterError(f"--tolerance {args.tolerance!r} is out of range: valid tolerance "
                             "is in [0, 1e6) (relative error)")
    usable(model_for(spec.name, args, params).device)         # the configuration is valid
    if args.preset:
        params["preset"] = args.preset
    r = ladder.simplest(spec.name, args.tolerance, args.metric, device=args.device, **params)
    if args.json:
        print(json.dumps(r.to_json()))
        return 0
    if args.metric == "compensation":
        print(r.text())
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
    from ..studies import ladder
    names, out, command, _ = _chart_job(args)
    for n in names or ():
        if n not in ladder.configs():
            raise ParameterError(f"model={n!r} has no ladder configuration: valid models are "
                                 f"{', '.join(ladder.configs())}")
    ladder.chart(names, out, device=args.device, command=command,
                 progress=None if args.quiet else lambda s: print(s, flush=True))
    print(f"wrote {out / 'ladder.csv'}, {out / 'README.md'} and one PNG per model")
    return 0


def _floats(flag: str, text: str) -> tuple:
    try:
        return tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise ParameterError(f"{flag} {text!r} is not valid: give comma-separated numbers") from None


def cmd_compensation(args) -> int:
    from ..studies import compensation
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    check_int("walks", args.walks, 1024, 1 << 30, "[1024, 2^30]")
    check_int("lobe-walks", args.lobe_walks, 1024, 1 << 26, "[1024, 2^26]")
    materials = [{"preset": p} for p in args.preset or ()]
    for text in args.f0 or ():
        f0 = _floats("--f0", text)
        if len(f0) not in (1, 3):
            raise ParameterError(f"--f0 {text!r} is not valid: give one value or R,G,B")
        materials.append({"fresnel": "schlick", "f0": list(f0 * (3 // len(f0)))})
    glass = () if args.glass_eta.strip().lower() == "none" else _floats("--glass-eta",
                                                                      args.glass_eta)
    command = " ".join(["clbrdf"] + [quote(a) for a in args.argv])
    compensation.compensation_map(
        out, materials or None, alphas=_floats("--alphas", args.alphas),
        mus=_floats("--mus", args.mus), lobe_mus=_floats("--lobe-mus", args.lobe_mus),
        glass_etas=glass, walks=args.walks, lobe_walks=args.lobe_walks, seed=args.seed,
        device=args.device, command=command,
        progress=None if args.quiet else lambda s: print(s, flush=True))
    print(f"wrote {out / 'README.md'}, residuals.csv, lobes.csv"
          f"{', glass.csv' if glass else ''} and the charts")
    return 0


def add_parsers(sub) -> None:
    dev = dev_parent()
    models = ", ".join(MODELS)

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
                                   "analytic Lambda, single precision; clbrdf/studies/ladder.py) against "
                                   "the full configuration in double precision and print the "
                                   "fastest whose max relative error is within the tolerance, with "
                                   "its error and measured speed-up.")
    p.add_argument("model", metavar="MODEL")
    p.add_argument("--tolerance", "-t", type=float, required=True, metavar="T",
                   help="max relative error allowed")
    p.add_argument("--param", "-p", action="append", metavar="NAME=VALUE",
                   help="parameter or option (repeatable)")
    p.add_argument("--preset", metavar="MATERIAL[:SOURCE]", help="a published fit")
    p.add_argument("--metric", choices=("value", "albedo", "compensation"), default="value",
                   help="value: f over direction pairs (default); albedo: E(mu); compensation: "
                        "which energy compensation and table size (ggx, ggx_dielectric), "
                        "against the random walk")
    p.add_argument("--json", action="store_true", help="one JSON object")
    p.set_defaults(func=cmd_simplest)

    p = sub.add_parser("ladder", parents=[dev], help="chart every cheaper variant's cost "
                       "against its error",
                       description="For each model's ladder configuration "
                                   "(each model description's Facts.ladder): every cheaper variant's max "
                                   "relative error of f and of E against the full model in double, "
                                   "and its measured evaluations and albedo samples per second. "
                                   "Writes DIR/ladder.csv, DIR/MODEL.png and DIR/README.md.")
    chart_args(p, "ladder", "models (default: all with a ladder configuration)", "model",
               precision=False)
    p.set_defaults(func=cmd_ladder)

    p = sub.add_parser("compensation", parents=[dev], help="chart each energy-compensation "
                       "method against the random walk",
                       description="For GGX conductors (metal presets, or Schlick F0 colours) and "
                                   "rough glass: the albedo of Kulla-Conty, Turquin and "
                                   "Fdez-Aguera compensation (and of none) against Heitz et al. "
                                   "2016's random walk (the multiple-scattering BSDF itself), "
                                   "per alpha, mu and channel; the relative L1 error of each "
                                   "method's lobe against the walk's multiple-scattering lobe; "
                                   "for glass the reflected and transmitted energy of albedo "
                                   "scaling. Writes DIR/README.md, DIR/residuals.csv, "
                                   "DIR/lobes.csv, DIR/glass.csv and the charts.")
    p.add_argument("--out", "-o", default="compensation", metavar="DIR",
                   help="output directory (default ./compensation; docs/compensation in the "
                        "repository)")
    p.add_argument("--preset", action="append", metavar="NAME",
                   help="a metal preset of ggx (repeatable; default gold, copper, aluminium)")
    p.add_argument("--f0", action="append", metavar="R,G,B",
                   help="a Schlick reflectance at normal incidence (repeatable)")
    p.add_argument("--alphas", default=",".join(map(str, settings.ALPHAS)), metavar="A,..",
                   help="GGX roughness values (default %(default)s)")
    p.add_argument("--mus", default=",".join(map(str, settings.MUS)), metavar="MU,..",
                   help="cosines of the view direction for the albedo (default %(default)s)")
    p.add_argument("--lobe-mus", default=",".join(map(str, settings.LOBE_MUS)),
                   metavar="MU,..", help="view cosines of the lobe errors (default %(default)s)")
    p.add_argument("--glass-eta", default=",".join(map(str, settings.GLASS_ETAS)),
                   metavar="ETA,..", help="glass indices (default %(default)s; none: no glass)")
    p.add_argument("--walks", type=int, default=1 << 20, metavar="N",
                   help="walks per albedo cell (default 2^20)")
    p.add_argument("--lobe-walks", type=int, default=1 << 20, metavar="N",
                   help="walks per lobe cell (default 2^20)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--quiet", "-q", action="store_true", help="no line per material and alpha")
    p.set_defaults(func=cmd_compensation)
