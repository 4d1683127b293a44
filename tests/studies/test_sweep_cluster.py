"""Sweeps on a real dask.distributed LocalCluster of two single-threaded worker processes: the
store equals a local run's bit for bit, also when a worker is killed mid-sweep; PoCL's thread
count reaches the workers before they start."""
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

pytest.importorskip("distributed")

from clbrdf.studies.cluster import POCL_THREAD_VARIABLES, local_cluster
from clbrdf.studies.sweep import open_sweep, sweep
from distributed import Client  # noqa: E402
from test_sweep import same_store  # noqa: E402

KW = dict(axes={"alpha": (0.01, 1, 12, "log"), "f0": (0, 1, 4)}, samples=1 << 15, chunk=2,
          directions="gauss:16")


@pytest.fixture(scope="module")
def client():
    cluster = local_cluster(2, threads_per_worker=1)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def _compute_units(env):
    code = ("import clbrdf; d = clbrdf.get_device(); print(d.cl_device.max_compute_units)")
    r = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env},
                       capture_output=True, text=True, timeout=120)
    return int(r.stdout.strip())


def test_pocl_thread_variables_limit_compute_units():
    """Both names are set: POCL_MAX_PTHREAD_COUNT for PoCL < 4 (3.0 and 3.1 ignore
    POCL_CPU_MAX_CU_COUNT), POCL_CPU_MAX_CU_COUNT from PoCL 4 on."""
    import clbrdf
    if clbrdf.get_device().cl_device.max_compute_units < 2:
        pytest.skip("one compute unit: nothing to limit")
    assert _compute_units({k: "1" for k in POCL_THREAD_VARIABLES}) == 1


def test_workers_get_the_thread_count_before_they_start(client):
    env = client.run(lambda: {k: os.environ.get(k) for k in POCL_THREAD_VARIABLES})
    assert len(env) == 2 and all(v == {k: "1" for k in POCL_THREAD_VARIABLES}
                                 for v in env.values())


def test_cluster_sweep_is_bit_identical_to_local(client, tmp_path):
    local = sweep("ggx", tmp_path / "local.zarr", **KW)
    dist = sweep("ggx", tmp_path / "dist.zarr", client=client, **KW)
    same_store(local, dist)
    import json
    led = [json.loads(p.read_text()) for p in (tmp_path / "dist.zarr/ledger").glob("*.json")]
    assert len({e["worker"] for e in led}) == 2        # both workers took chunks
    assert {e["compute_units"] for e in led} == {1}


def test_a_worker_killed_mid_sweep(client, tmp_path):
    """SIGKILL to one worker process while chunks run, later to both at once (so whatever the
    tasks need that lived only on workers is gone: scattered data was, in CI): the nannies
    restart them, the scheduler reruns their chunks, and the sweep finishes with the local
    run's store."""
    local = sweep("ggx", tmp_path / "local.zarr", **KW)
    out = tmp_path / "dist.zarr"
    done = {}

    def run():
        try:
            done["sweep"] = sweep("ggx", out, client=client, **KW)
        except BaseException as e:      # noqa: BLE001
            done["error"] = e

    def ledger():
        return len(list((out / "ledger").glob("*.json")) if (out / "ledger").exists() else [])
    t = threading.Thread(target=run)
    t.start()
    t0 = time.monotonic()
    victims = []
    for at in (4, 10):
        while ledger() < at:
            assert time.monotonic() - t0 < 120 and t.is_alive(), done.get("error")
            time.sleep(0.01)
        pids = sorted(client.run(os.getpid).values())
        for pid in pids[:1] if not victims else pids:
            os.kill(pid, signal.SIGKILL)
            victims.append(pid)
    t.join(300)
    assert "error" not in done, done.get("error")
    n = ledger()
    assert n == 24, n
    same_store(local, open_sweep(out))
    assert not set(victims) & set(client.run(os.getpid).values())     # new worker processes


def test_a_layout_and_an_ltc_fit_on_the_cluster_are_the_local_results(client):
    """Inside ``on_cluster`` the albedo calls of a layout (three.js' DFG table: Monte Carlo),
    the quadrature of a table and an LTC fit's cells (moments, magnitudes, Nelder-Mead and the
    reported errors) run as parts on the workers; each result equals the local run bit for bit,
    and the workers took parts."""
    from clbrdf.studies.cluster import on_cluster
    from clbrdf.tables.compute import albedo_table
    from clbrdf.tables.layouts import make_layout
    from clbrdf.tables.ltc import fit_ltc

    def run():
        lay = make_layout("threejs", samples=1 << 10)
        quad = albedo_table("ggx", {"mu": "0.1:1:5", "alpha": "0.05:1:4"}, estimator="quadrature",
                            tol=1e-5)
        ltc = fit_ltc("ggx", {"sqrt1m_mu": "0:0.9:3", "r": "0.2:1:3"}, samples=64,
                      report_samples=256)
        return lay, quad, ltc
    local = run()
    with on_cluster(client) as d:
        dist = run()
    assert d.tasks >= 3 * 8
    for a, b in zip(local[0].values(), dist[0].values()):
        assert np.array_equal(a.raw, b.raw) and np.array_equal(a.stderr, b.stderr), a.name
    assert np.array_equal(local[1].raw, dist[1].raw)
    assert np.array_equal(local[1].stderr, dist[1].stderr)
    assert dist[2].computed["parts"] == 5 > local[2].computed["parts"] == 1   # 9 cells by 2
    assert np.array_equal(local[2].raw, dist[2].raw)
    assert np.array_equal(local[2].stderr, dist[2].stderr)
    for k in ("iterations_max", "iterations_mean", "loss_evaluations"):
        assert local[2].computed[k] == dist[2].computed[k], k
