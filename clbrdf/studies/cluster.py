"""Sweeps on a dask.distributed cluster: ``pip install 'clbrdf[cluster]'``.

    from clbrdf.studies.cluster import local_cluster, connect
    client = connect("local:2")                 # or connect("tcp://scheduler:8786")
    clbrdf.sweep("ggx", "ggx.zarr", axes=..., client=client)

Tasks carry the job (a few KB of JSON-like dict, inline in each task: scattered data lives on
the workers and is gone with them, since the scheduler's memory manager drops broadcast
replicas) and a chunk index; nothing else crosses the network but the chunk's arrays, which the
client writes to the store with its ledger entry. Each worker
holds its own OpenCL context, built once by a worker plugin (``DevicePlugin``): contexts cannot
be pickled, and a context made before a fork breaks the child. A worker killed mid-chunk loses
only that chunk, which the scheduler runs again elsewhere; random numbers are keyed by position
(clbrdf.sweep), so the store is bit-identical to a local run on the same device kind and width.

PoCL reads its thread count when the library loads, so it must be in a worker's environment
before the worker process starts: ``local_cluster`` puts it in
``distributed.nanny.pre-spawn-environ``. The variable is ``POCL_CPU_MAX_CU_COUNT`` from PoCL 4
on and ``POCL_MAX_PTHREAD_COUNT`` before: PoCL 3.0 and 3.1 (PyPI's and Debian's here) report 2
compute units on 2 cores with ``POCL_CPU_MAX_CU_COUNT=1`` and 1 with ``POCL_MAX_PTHREAD_COUNT=1``
(tests/test_sweep_cluster.py), so both are set (``POCL_THREAD_VARIABLES``). For workers you
start yourself: ``POCL_CPU_MAX_CU_COUNT=T POCL_MAX_PTHREAD_COUNT=T dask worker ADDRESS
--nthreads 1`` (T cores per worker).
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import time

try:                                    # the optional [cluster] extra
    import dask
    from distributed import Client, LocalCluster, WorkerPlugin, as_completed, get_worker
except ImportError:
    dask = None
    WorkerPlugin = object
from ..models.spec import ParameterError
from ..runtime.device import get_device
from ..runtime.launch import working_width
from .sweepjob import compute_chunk, device_fingerprint

_STATE: dict = {}
POCL_THREAD_VARIABLES = ("POCL_CPU_MAX_CU_COUNT", "POCL_MAX_PTHREAD_COUNT")


class DevicePlugin(WorkerPlugin):
    """Opens the worker's OpenCL device (``device``: a selector; None for the default) once."""

    name = "clbrdf-device"

    def __init__(self, device=None):
        self.device = device

    def setup(self, worker):
        _STATE["device"] = get_device(self.device)


def _device(selector):
    if "device" not in _STATE:          # a worker that joined without the plugin's setup
        _STATE["device"] = get_device(selector)
    return _STATE["device"]


def _chunk_task(job: dict, index: int, selector):
    dev = _device(selector)
    t0 = time.perf_counter()
    arrays = compute_chunk(job, index, dev)
    try:
        worker = get_worker().address
    except ValueError:
        worker = None
    return index, arrays, {"seconds": time.perf_counter() - t0, **device_fingerprint(dev),
                           "host": platform.node(), "worker": worker,
                           **{k: os.environ.get(k) for k in POCL_THREAD_VARIABLES}}


def _width(selector, precision):
    return working_width(_device(selector), precision)


def worker_width(client: Client, precision: str, device=None) -> int:
    """The default vector width of a worker's device (the job fixes one width for all)."""
    client.register_plugin(DevicePlugin(device), name=DevicePlugin.name)
    return client.submit(_width, device, precision, pure=False).result()


def run_on_cluster(client: Client, root, path, job: dict, todo: list, stop, bar, write, device):
    """Compute chunks ``todo`` on the cluster, at most two per worker in flight, and write each
    as it arrives. On KeyboardInterrupt no more are submitted; those in flight are written."""
    if device is not None and not isinstance(device, (str, int)):
        raise ValueError("device: give a selector string for cluster workers")
    client.register_plugin(DevicePlugin(device), name=DevicePlugin.name)
    token = hashlib.sha1(json.dumps(job, sort_keys=True).encode()).hexdigest()[:16]
    workers = max(1, len(client.scheduler_info().get("workers", {})))
    pending = iter(todo)

    def submit(i):
        return client.submit(_chunk_task, job, i, device, key=f"clbrdf-sweep-{token}-{i}")
    ac = as_completed([submit(i) for _, i in zip(range(2 * workers), pending)])
    interrupted = None
    while True:
        try:
            fut = next(ac)
        except StopIteration:
            break
        except BaseException as e:      # SIGINT / SIGTERM: drain what is in flight
            if interrupted is not None:
                raise
            interrupted = e
            stop.event.set()
            continue
        try:
            index, arrays, info = fut.result()
        except BaseException as e:
            if interrupted is None and isinstance(e, (KeyboardInterrupt,)):
                interrupted = e
                stop.event.set()
                continue
            raise
        write(root, path, job, index, arrays, info)
        bar.update(int(arrays["verdict"].shape[0]))
        fut.release()
        if not stop.event.is_set():
            nxt = next(pending, None)
            if nxt is not None:
                ac.add(submit(nxt))
    if interrupted is not None:
        raise interrupted


def _need_distributed():
    if dask is None:
        raise ImportError("sweeps on a cluster need dask.distributed: pip install "
                          "'clbrdf[cluster]'")


def local_cluster(n_workers: int = 2, threads_per_worker: int = 1, **kw) -> LocalCluster:
    """A LocalCluster of worker processes whose PoCL uses ``threads_per_worker`` cores each
    (set before the workers spawn, and for workers the nanny restarts later)."""
    _need_distributed()
    dask.config.set({f"distributed.nanny.pre-spawn-environ.{k}": str(threads_per_worker)
                     for k in POCL_THREAD_VARIABLES})
    kw.setdefault("dashboard_address", None)
    return LocalCluster(n_workers=n_workers, threads_per_worker=threads_per_worker,
                        processes=True, **kw)


def connect(address: str) -> Client:
    """``local:N`` (a LocalCluster of N single-threaded workers on this machine) or a scheduler
    address (``tcp://host:8786``)."""
    _need_distributed()
    if address.startswith("local:"):
        n = address[6:]
        if not n.isdigit() or not 1 <= int(n) <= 1024:
            raise ParameterError(f"address={address!r} is not valid: local:N needs N in [1, "
                                 f"1024]")
        return Client(local_cluster(int(n)))
    return Client(address)
