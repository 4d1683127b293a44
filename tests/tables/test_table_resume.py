"""clbrdf table --resume: a run killed (SIGKILL) at random moments and resumed writes the same
table, bit for bit, as an uninterrupted run; a resume checks that it is the same job."""
import os
import random
import signal
import subprocess
import sys
import time

import numpy as np

from cliutil import run_inprocess

ARGS = ["table", "ggx", "--axis", "mu=0.05:1:8", "--axis", "r=0:1:6:centres", "--samples", "65536"]
ENV = dict(os.environ, PYTHONUNBUFFERED="1", CLBRDF_CHUNK_SAMPLES=str(1 << 17))   # 2 cells a chunk


def _cli(args):
    return subprocess.Popen([sys.executable, "-m", "clbrdf.cli", *args], env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _chunks(d):
    try:
        return len([p for p in os.listdir(d) if p.endswith(".npz")])
    except OSError:
        return 0


def _arrays(path):
    with np.load(path) as z:
        return {k: z[k] for k in z.files if z[k].dtype != object and k != "metadata"}


def test_killed_table_resumes_bit_identical(tmp_path):
    ref = tmp_path / "ref.npz"
    p = _cli(ARGS + ["--out", str(tmp_path / "ref.h"), "--out", str(ref)])
    assert p.wait(300) == 0, p.stderr.read().decode()
    assert not (tmp_path / ".ref.h.resume").exists()          # removed once written
    out = tmp_path / "k.npz"
    ck = tmp_path / ".k.h.resume"
    rng = random.Random(5)
    kills = []
    for attempt in range(8):
        resume = ["--resume"] if (ck / "job.json").exists() else []
        p = _cli(ARGS + ["--out", str(tmp_path / "k.h"), "--out", str(out)] + resume)
        if attempt < 3:
            target = _chunks(ck) + rng.randint(2, 8)
            t0 = time.monotonic()
            while _chunks(ck) < target and p.poll() is None and time.monotonic() - t0 < 120:
                time.sleep(0.002)
            if p.poll() is None:
                p.send_signal(signal.SIGKILL)
                p.wait(30)
                kills.append(_chunks(ck))
                assert not out.exists()
                continue
        assert p.wait(300) == 0, p.stderr.read().decode()
        break
    assert len(kills) >= 2 and kills == sorted(kills) and kills[0] > 0, kills
    a, b = _arrays(ref), _arrays(out)
    assert a.keys() == b.keys() and "E" in a
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    assert not ck.exists()


def test_resume_checks_the_job(tmp_path):
    out = tmp_path / "t.npz"
    r = run_inprocess(*ARGS, "--out", out, "--resume")
    assert r.returncode == 2 and "nothing to resume" in r.stderr, r.stderr
    p = _cli(ARGS + ["--out", str(out)])
    ck = tmp_path / ".t.npz.resume"
    t0 = time.monotonic()
    while _chunks(ck) < 2 and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.002)
    p.send_signal(signal.SIGKILL)
    p.wait(30)
    other = [a if a != "65536" else "32768" for a in ARGS]
    r = run_inprocess(*other, "--out", out, "--resume")
    assert r.returncode == 2 and "cannot resume" in r.stderr and "samples" in r.stderr, r.stderr
    assert (ck / "job.json").exists() and not out.exists()     # nothing lost or written


def _kill_after_chunks(args, ck, n):
    p = _cli(args)
    t0 = time.monotonic()
    while _chunks(ck) < n and p.poll() is None and time.monotonic() - t0 < 120:
        time.sleep(0.002)
    return p


def test_rerun_without_resume_keeps_the_checkpoint(tmp_path):
    """Rerunning a killed table without --resume deleted its checkpoint at start-up (hours lost,
    no warning). Now it stops before any work, says how to continue and where the checkpoint is,
    and leaves it; --resume then finishes the table."""
    out = tmp_path / "t.npz"
    ck = tmp_path / ".t.npz.resume"
    p = _kill_after_chunks(ARGS + ["--out", str(out)], ck, 3)
    p.send_signal(signal.SIGKILL)
    p.wait(30)
    before = sorted(os.listdir(ck))
    r = run_inprocess(*ARGS, "--out", out)
    assert r.returncode == 2 and "--resume" in r.stderr and str(ck) in r.stderr, r.stderr
    assert sorted(os.listdir(ck)) == before and not out.exists()
    p = _cli(ARGS + ["--out", str(out), "--resume"])
    assert p.wait(300) == 0, p.stderr.read().decode()
    assert out.exists() and not ck.exists()


def test_two_runs_with_one_output_do_not_share_a_checkpoint(tmp_path):
    """Two runs with the same --out shared the checkpoint with no lock, and one died with a
    --resume error it was never given. The second now stops at once, naming the other process's
    checkpoint; the first finishes undisturbed."""
    out = tmp_path / "t.npz"
    ck = tmp_path / ".t.npz.resume"
    p = _kill_after_chunks(ARGS + ["--out", str(out)], ck, 1)
    assert p.poll() is None
    for extra in ([], ["--resume"]):
        r = run_inprocess(*ARGS, "--out", out, *extra)
        assert r.returncode == 2 and "another clbrdf process" in r.stderr, r.stderr
    assert p.wait(300) == 0, p.stderr.read().decode()
    assert out.exists() and not ck.exists()
