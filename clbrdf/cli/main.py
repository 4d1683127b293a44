"""Command line interface: ``clbrdf devices | models | eval | albedo | table | sweep | report | ...``.

Exit codes: 0 success, 2 bad input (unknown model or parameter, value out of range, malformed
argument), 3 no usable OpenCL device, 1 anything else. Errors are one line on stderr; set
``CLBRDF_DEBUG=1`` to see the traceback as well.
"""
from __future__ import annotations

import argparse
import os
import re
import sys
import threading
import warnings

from ..models.spec import ParameterError, spelling
from ..runtime.device import DeviceError
from ..version import __version__
from . import models, studies, sweeps, tables
from .common import (
    EXIT_DEVICE,
    EXIT_INPUT,
    FLAGS,
    STOPPED,
    Include,
    Parser,
    Terminated,
    clean,
)


def build_parser() -> argparse.ArgumentParser:
    top = Parser(prog="clbrdf", description="Evaluate, sample and integrate BRDFs in bulk with "
                  "OpenCL kernels (PoCL on the CPU out of the box).",
                  epilog="Exit codes: 0 ok, 2 bad input, 3 no usable OpenCL device, 4 a check failed "
                         "(clbrdf check), 1 other errors.")
    top.add_argument("--version", action="version", version=f"clbrdf {__version__}")
    top.add_argument("--include", action=Include, nargs=0,
                     help="print the directory of the C headers (clbrdf.h and the model "
                          "headers) for C, C++, CUDA and OpenCL builds: cc -I$(clbrdf --include)")
    sub = top.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for group in (models, tables, sweeps, studies):
        group.add_parsers(sub)
    return top

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
        # PoCL's remarks on a build that succeeded (pyopencl.CompilerWarning): not the user's
        warnings.filterwarnings("ignore", message=r"Non-empty compiler output encountered")
        warnings.showwarning = lambda message, category, *a, **k: print(
            f"clbrdf {args.command}: warning: {clean(message)}", file=sys.stderr)
        with spelling(FLAGS):           # the library's messages name the flags
            return _run(args)


def _run(args) -> int:
    try:
        return args.func(args)
    except ParameterError as e:
        print(f"clbrdf {args.command}: error: {clean(e)}", file=sys.stderr)
        return EXIT_INPUT
    except DeviceError as e:
        print(f"clbrdf {args.command}: error: {clean(e)}", file=sys.stderr)
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
        msg = clean(e) or type(e).__name__
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
    if code in (130, 143) and STOPPED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)



