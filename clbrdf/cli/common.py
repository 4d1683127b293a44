"""What the commands share: argument parsing (parameters, vectors, models), the options
several commands take, notes and error messages (the library's parameter names as flags)."""
from __future__ import annotations

import argparse
import re
import sys

import numpy as np

from ..models import MODELS, get_spec
from ..models.choices import ESTIMATORS, PRECISIONS, WIDTHS
from ..models.spec import ParameterError
from ..runtime.device import (
    NO_DEVICE_HELP,
    DeviceError,
    compiler_error,
)

EXIT_INPUT = 2
EXIT_DEVICE = 3
EXIT_CHECK_FAILED = 4

DEVICE_HELP = ("OpenCL device: P:D as 'clbrdf devices' lists it, or a substring of the device or "
               "platform name (default: env CLBRDF_DEVICE, else the first GPU, else the CPU of "
               "the newest PoCL, else the first CPU, whose compiler works)")


class Once(argparse.Action):
    """An option that may be given once: a second --wi is an error, as a repeated --param is."""

    def __call__(self, parser, namespace, values, option_string=None):
        if getattr(namespace, f"_seen_{self.dest}", False):
            parser.error(f"{option_string} is given twice ({getattr(namespace, self.dest)} and "
                         f"{values}); give it once")
        setattr(namespace, f"_seen_{self.dest}", True)
        setattr(namespace, self.dest, values)


class Include(argparse.Action):
    """--include: print the C header directory and exit (as --version does)."""

    def __call__(self, parser, namespace, values, option_string=None):
        from ..runtime.build import get_include
        print(get_include())
        parser.exit()


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error message and exit code 2."""

    def error(self, message):
        self.exit(EXIT_INPUT, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


# ---------------------------------------------------------------------------------------------
# argument parsing helpers (all raise ParameterError on bad input)

def number(text: str, what: str) -> float:
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
    return np.array([number(p.strip(), name) for p in parts])


def parse_list(text: str, name: str) -> np.ndarray:
    parts = [p.strip() for p in text.split(",")]
    if not text.strip() or any(not p for p in parts):
        raise ParameterError(f"{name}={text!r} is malformed: expected comma-separated numbers "
                             f"(e.g. {name}=0.1,0.5,1)")
    return np.array([number(p, name) for p in parts])


# ---------------------------------------------------------------------------------------------
# device helpers

def usable(device) -> None:
    """DeviceError unless the device's compiler works (one cached probe per device)."""
    info = device.info
    err = compiler_error((info.platform_index, info.device_index))
    if err is not None:
        raise DeviceError(f"device {info.selector} ({info.name} [{info.platform}]) cannot compile "
                          f"kernels: {err}. {NO_DEVICE_HELP}")


def device_for(args):
    """The device of --device, before any work: one whose compiler works, with cl_khr_fp64 for
    --precision double."""
    from ..runtime.device import get_device
    dev = get_device(args.device)
    usable(dev)
    if getattr(args, "precision", "single") == "double" and not dev.info.has_fp64:
        raise DeviceError(f"--precision double needs cl_khr_fp64, which {dev.info.name} lacks; "
                          f"use --precision single or another --device")
    return dev


def model_for(name, args, params):
    from ..api.model import Model
    m = Model(name, precision=getattr(args, "precision", "single"), device=args.device,
              width=getattr(args, "width", None), preset=getattr(args, "preset", None), **params)
    usable(m.device)
    return m


def spec_of(name):
    return get_spec(name)


# ---------------------------------------------------------------------------------------------
# commands

def no_resume(cmd: str) -> str:
    """The command as recorded in a table's metadata: a resumed run's result is the same."""
    return " ".join(w for w in cmd.split(" ") if w != "--resume")


def target_args(args) -> dict:
    out = {}
    if getattr(args, "target_stderr", None) is not None:
        out["target_stderr"] = args.target_stderr
    if getattr(args, "max_samples", None) is not None:
        out["max_samples"] = args.max_samples
    return out


def c_name(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", s)


# the options of `sweep` that are part of its job (the store's); the others say how to run it
RECOMMENDED = ("brdf", True)
RECOMMENDED_WHY = ("brdf with Sobol points, the fastest estimator to a max error of 1e-3 for 10 "
                   "of 13 models and to 1e-4 for 7 (as `clbrdf accuracy` measures); --estimator "
                   "chooses another")


def note(args, text: str) -> None:
    """A note for the user on stderr (stdout carries the results)."""
    print(f"clbrdf {args.command}: note: {text}", file=sys.stderr)


def choose_estimator(args) -> str | None:
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


def quad_args(args) -> dict:
    """--tol and --max-evals for the quadrature estimator; refused with the others."""
    given = {k: v for k, v in (("tol", args.tol), ("max_evals", args.max_evals)) if v is not None}
    if args.estimator != "quadrature":
        if given:
            raise ParameterError(f"--{next(iter(given)).replace('_', '-')} is for --estimator "
                                 f"quadrature, not {args.estimator}")
        return {}
    return given


def quote(a: str) -> str:
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




# the library names its Python parameters; the command line names them as its flags: each
# message is written with these names while a command runs (models/spec.py ``spelling``)
FLAGS = {
    "axis": "--axis", "axes": "--axis", "directions": "--directions", "random": "--random",
    "fixed parameter": "--param", "model": "MODEL", "preset": "--preset", "out": "--out",
    "resume": "--resume", "estimator": "--estimator", "qmc": "--qmc", "samples": "--samples",
    "max_samples": "--max-samples", "target_stderr": "--target-stderr", "tol": "--tol",
    "max_evals": "--max-evals", "error_rate": "--error-rate", "seed": "--seed",
    "precision": "--precision", "width": "--width", "chunk": "--chunk",
    "report_samples": "--report-samples", "magnitude_tol": "--magnitude-tol",
    "layout": "--layout", "form": "--form", "match_published": "--match-published",
    "only": "--only",
}


def clean(e) -> str:
    """One line; NumPy scalar reprs (np.float64(0.5)) shown as plain numbers."""
    msg = re.sub(r"(?<!['\"])np\.(?:float|int|uint)\d+\(([^()]*)\)", r"\1", str(e))
    return " ".join(msg.split())


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that staged files are discarded on the way out."""


def dev_parent() -> argparse.ArgumentParser:
    """The --device option of every command that runs kernels (an argparse parent)."""
    dev = argparse.ArgumentParser(add_help=False)
    dev.add_argument("--device", metavar="SELECTOR", default=None, help=DEVICE_HELP)
    return dev


def model_arg(p, optional: str | None = None):
    """MODEL (optional, with the help's reason, where another argument can name it),
    --param and --preset."""
    models = ", ".join(MODELS)
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
    p.add_argument("--width", type=int, choices=WIDTHS, default=None,
                   help="lanes per work-item (default: 16 single / 8 double on a CPU, 1 on a "
                        "GPU, or CLBRDF_WIDTH); results are bit-identical per device and width")


# sweeps stopped by a signal (their stores written), for entry()'s exit
STOPPED: list = []


def bars() -> bool:
    """Progress bars only on a terminal: a piped or redirected stderr (a log) gets none."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False
