"""Output files: checked before any work, committed together (all old files or all new ones),
no temporary file left after SIGTERM, stale ones from a killed run removed by the next."""
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from clbrdf.tables import files, outputs
from clbrdf.tables.table import from_albedo
from cliutil import run_inprocess

TABLE = ["table", "ggx", "--axis", "mu=0.1:1:4", "--axis", "alpha=0.1:1:3"]


def run(*args, **kw):
    return subprocess.run([sys.executable, "-m", "clbrdf.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300, **kw)


def small_table():
    return from_albedo({"mu": np.array([0.5, 1.0]), "E": np.array([0.9, 0.8]),
                        "E_stderr": np.array([0.01, 0.01]), "E_avg": np.array(0.85),
                        "E_avg_stderr": np.array(0.01)}, {"model": "ggx", "axes": ["mu"]})


@pytest.mark.parametrize("setup, out, words", [
    (lambda d: None, "nodir/t.npz", ["does not exist"]),
    (lambda d: (d / "t.npz").mkdir(), "t.npz", ["is a directory"]),
    (lambda d: (d / "t.png").mkdir(), "t.npz", ["t.png", "is a directory"]),
    (lambda d: (d / "t.avg.csv").mkdir(), "t.csv", ["t.avg.csv", "is a directory"]),
    (lambda d: None, "t.txt", ["unknown output suffix '.txt'"]),
    (lambda d: (d / "ro").mkdir() or os.chmod(d / "ro", 0o555), "ro/t.npz", ["cannot write"]),
])
def test_bad_output_fails_before_computing(tmp_path, setup, out, words):
    """Exit 2 at once (a 2^30-sample table would take minutes if it were computed first)."""
    setup(tmp_path)
    path = tmp_path / out
    if out.startswith("ro/") and os.geteuid() == 0:
        path = "/proc/self/t.npz"     # root writes in a 0555 directory; /proc does not take files
    t0 = time.perf_counter()
    r = run(*TABLE, "--samples", 1 << 30, "--out", path)
    assert r.returncode == 2, r.stderr
    assert time.perf_counter() - t0 < 30
    for w in words:
        assert w in r.stderr, (w, r.stderr)


def test_commit_restores_old_files_when_a_replace_fails(tmp_path, monkeypatch):
    """If the second file cannot be moved into place, the first is put back: no existing file
    changes."""
    out = tmp_path / "x.npz"
    out.write_text("old data")
    (tmp_path / "x.png").write_text("old chart")
    real = os.replace
    calls = []

    def failing(src, dst):
        calls.append(dst)
        if str(dst).endswith(".png") and ".tmp" not in str(dst):
            raise OSError(28, "No space left on device")
        return real(src, dst)
    monkeypatch.setattr(outputs.os, "replace", failing)
    with pytest.raises(OSError):
        files.save_tables(small_table(), out)
    monkeypatch.undo()
    assert out.read_text() == "old data" and (tmp_path / "x.png").read_text() == "old chart"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.npz", "x.png"]


def test_sigterm_leaves_no_temporary_file(tmp_path):
    """SIGTERM during the work: exit 143, the old files unchanged, nothing else in the directory
    but the checkpoint that --resume continues from (clbrdf.tables.checkpoint), which stderr names."""
    out = tmp_path / "t.npz"
    out.write_text("old")
    p = subprocess.Popen([sys.executable, "-m", "clbrdf.cli", *TABLE, "--samples", str(1 << 30),
                          "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    t0 = time.monotonic()           # into the work: the checkpoint begun, then a while longer
    while not (tmp_path / ".t.npz.resume" / "job.json").exists() and p.poll() is None:
        assert time.monotonic() - t0 < 120
        time.sleep(0.01)
    time.sleep(2)
    p.send_signal(signal.SIGTERM)
    t0 = time.perf_counter()
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert time.perf_counter() - t0 < 5          # launches are short: answered within seconds
    assert out.read_text() == "old"
    assert sorted(q.name for q in tmp_path.iterdir()) == [".t.npz.resume", "t.npz"]
    assert "--resume" in err.decode()
    ck = tmp_path / ".t.npz.resume"
    assert not any(q.name.endswith(".tmp") for q in ck.iterdir())


def test_stale_temporary_files_are_removed(tmp_path):
    """A SIGKILLed run leaves .NAME.PID.*.tmp files; the next write removes those of dead
    processes and keeps those of live ones."""
    out = tmp_path / "x.npz"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".x.npz.{dead.pid}.abcd1234.tmp"
    stale.write_text("partial")
    live = tmp_path / f".x.npz.{os.getppid()}.abcd1234.tmp"
    live.write_text("someone else's")
    files.save_tables(small_table(), out)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert stale.name not in names and live.name in names
    assert "x.npz" in names and "x.png" in names


@pytest.fixture
def full_disk(tmp_path):
    """A 16 kB tmpfs (root only; skipped where mounting is not allowed)."""
    d = tmp_path / "full"
    d.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16k", "tmpfs", str(d)],
                       capture_output=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here: {r.stderr.decode().strip()}")
    yield d
    subprocess.run(["umount", str(d)], capture_output=True)


def test_full_disk_names_the_output(full_disk):
    """A table or sweep onto a full disk printed the raw "[Errno 28] No space left on device"
    without the path; the error now says what it was writing (exit 1), and nothing half-written
    is left in the output's place."""
    out = full_disk / "t.npz"
    r = run_inprocess("table", "ggx", "--axis", "mu=0.1:1:64", "--axis", "alpha=0.1:1:64",
                      "-n", "64", "--out", out)
    assert r.returncode == 1, r.stderr
    assert "No space left on device" in r.stderr and str(out) in r.stderr, r.stderr
    assert "Errno" not in r.stderr and not out.exists()
    s = full_disk / "s.zarr"
    r = run_inprocess("sweep", "ggx", "--axis", "alpha=0.01:1:2000", "-n", "64", "--out", s, "-q")
    assert r.returncode == 1 and "No space left on device" in r.stderr and str(s) in r.stderr, \
        r.stderr
