"""Energy-conservation sweeps: ``sweep`` and ``report``."""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..models.choices import ERROR_RATE, MAX_GROWTH, MC_ESTIMATORS, PRECISIONS, WIDTHS
from ..models.spec import ParameterError
from .common import (
    DEVICE_HELP,
    STOPPED,
    Terminated,
    bars,
    model_arg,
    parse_params,
    quote,
    spec_of,
    usable,
)

JOB_FLAGS = ("--param", "-p", "--axis", "--random", "--directions", "--samples", "-n",
             "--max-samples", "--target-stderr", "--estimator", "--qmc", "--error-rate", "--seed",
             "--precision", "--width", "--chunk", "--preset")


def cmd_sweep(args) -> int:
    from ..runtime.device import resolve_devices, split_device
    from ..studies.cluster import connect
    from ..studies.sweep import open_sweep, sweep
    from ..studies.sweepjob import chunk_bounds, make_job
    kw = {}
    if args.model is not None:
        spec = spec_of(args.model)
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
            usable(d)
        if args.split is not None:
            devices = [s for d in devices for s in split_device(d, args.split)]
    t0 = time.perf_counter()
    try:
        s = sweep(spec.name if args.model else None, args.out, resume=args.resume,
                  device=devices, client=client, progress=not args.quiet and bars(),
                  command=" ".join(["clbrdf"] + [quote(a) for a in args.argv]), **kw)
    except (KeyboardInterrupt, Terminated):
        try:
            s = open_sweep(args.out, verify=False)
            done = sum(chunk_bounds(s.job, i)[1] - chunk_bounds(s.job, i)[0] for i in s.done())
            print(f"clbrdf sweep: stopped; {done} of {s.points} points are written to {args.out}; "
                  f"continue with --resume", file=sys.stderr)
            STOPPED.append(args.out)
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
    from ..studies.report import report
    from ..studies.sweep import open_sweep
    s = open_sweep(args.store)
    if args.out:
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            raise ParameterError(f"--out {args.out!r} is a file; give a directory")
    summ = report(s, args.out)
    if args.json:
        summ.pop("files", None)
        print(json.dumps(summ))
        return 0
    print(_sweep_text(s, summ))
    for f in summ.get("files", []):
        print(f"wrote {f}")
    return 0


def add_parsers(sub) -> None:
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
    p.add_argument("--estimator", choices=MC_ESTIMATORS, default="brdf",
                   help="Monte Carlo estimator (default brdf)")
    p.add_argument("--qmc", action="store_true", help="Owen-scrambled Sobol points (16 scrambles)")
    p.add_argument("--error-rate", type=float, default=ERROR_RATE, metavar="E",
                   help=f"probability that a point's verdict is wrong, at most (default "
                        f"{ERROR_RATE:g})")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--precision", choices=PRECISIONS, default="single", help="default single")
    p.add_argument("--width", type=int, choices=WIDTHS, default=None,
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
