"""What the benchmark scripts share: timing and writing their section of RESULTS.md."""
import os
import statistics
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"


def _cpu(children: bool) -> float:
    if not children:
        return time.process_time()
    t = os.times()
    return time.process_time() + t.children_user + t.children_system


def timed(fn, rounds: int = 1, children: bool = False):
    """(median wall s, median CPU s, the last result) of ``rounds`` calls of fn; ``children``:
    the CPU time includes that of finished child processes (a program fn runs)."""
    ws, cs, out = [], [], None
    for _ in range(rounds):
        t, c = time.perf_counter(), _cpu(children)
        out = fn()
        ws.append(time.perf_counter() - t)
        cs.append(_cpu(children) - c)
    return statistics.median(ws), statistics.median(cs), out


def write_section(begin: str, end: str, section: str) -> None:
    """Put ``section`` (which starts with ``begin`` and ends with ``end``) in RESULTS.md in place
    of the old one, or at the end."""
    old = RESULTS.read_text() if RESULTS.exists() else "# Benchmark results\n"
    section = section.strip("\n")
    if begin in old and end in old:
        new = old[:old.index(begin)] + section + old[old.index(end) + len(end):]
    else:
        new = old.rstrip("\n") + "\n\n" + section + "\n"
    RESULTS.write_text(new)
