"""Running the command line in the test process: clbrdf.cli.main with captured output and its
exit status, as a subprocess.CompletedProcess. It spares the interpreter and OpenCL start of a
subprocess (about 1 s each); tests of process behaviour (exit codes of a real process, signals,
environment variables read at start) use subprocesses."""
import contextlib
import io
import signal
import subprocess


def run_inprocess(*args) -> subprocess.CompletedProcess:
    from clbrdf import cli
    argv = [str(a) for a in args]
    out, err = io.StringIO(), io.StringIO()
    old = signal.getsignal(signal.SIGTERM)            # main() installs its own handler
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                rc = cli.main(argv)
            except SystemExit as e:                   # argparse errors
                rc = e.code if isinstance(e.code, int) else 1
    finally:
        signal.signal(signal.SIGTERM, old)
    return subprocess.CompletedProcess(argv, rc, out.getvalue(), err.getvalue())
