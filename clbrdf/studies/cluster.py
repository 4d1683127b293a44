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
(tests/studies/test_sweep_cluster.py), so both are set (``POCL_THREAD_VARIABLES``). For workers you
start yourself: ``POCL_CPU_MAX_CU_COUNT=T POCL_MAX_PTHREAD_COUNT=T dask worker ADDRESS
--nthreads 1`` (T cores per worker).
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import platform
import time

import numpy as np

try:                                    # the optional [cluster] extra
    import dask
    from distributed import Client, LocalCluster, WorkerPlugin, as_completed, get_worker
except ImportError:
    dask = None
    WorkerPlugin = object
from ..models.spec import ParameterError
from ..runtime.albedo import AlbedoPlan, run_albedo, using
from ..runtime.bound import Bound
from ..runtime.device import get_device
from ..runtime.launch import working_width
from ..runtime.quadrature import QUAD_MAX_EVALS, run_quadrature, using_quadrature
from ..tables.ltc import fit_ltc_part, using_ltc_parts
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


# ---------------------------------------------------------------------------------------------
# tables and layouts (their albedo and quadrature calls) and LTC fits (their cells) on the cluster

def _albedo_task(config, params, precision, width, selector, wo, kw, point0):
    """One part of an albedo call on the worker's device: run_albedo over its points, keyed by
    the part's first point, so that the parts make up the local call bit for bit."""
    dev = _device(selector)
    b = Bound(config, params, precision, dev, width)
    e, s, _, secs, seen = run_albedo(b, (len(wo[0]),), wo, progress=False, point0=point0, **kw)
    return e, s, secs, seen, dev.info.name


def _quadrature_task(config, params, precision, width, selector, wo, kw):
    dev = _device(selector)
    b = Bound(config, params, precision, dev, width)
    E, err, evals, secs = run_quadrature(b, (len(wo[0]),), wo, progress=False, **kw)
    return E, err, evals, secs, dev.info.name


def _ltc_task(spec, i0, i1, selector):
    dev = _device(selector)
    return fit_ltc_part(spec, i0, i1, dev)


class ClusterDriver:
    """The albedo and quadrature calls of a table or a layout, and an LTC fit's cells, each cut
    into parts of its points and computed on a dask.distributed cluster, ``parts_per_worker``
    parts per worker (``on_cluster``). Random numbers are keyed by a point's (a cell's) flat
    index, the quadrature refines each point by itself and Nelder-Mead steps each cell by
    itself, so the result is bit-identical to the local run when the workers' device is the
    local one's kind (checked: a worker on another device is an error) and the width is the
    same."""

    def __init__(self, client, device=None, parts_per_worker: int = 4):
        if device is not None and not isinstance(device, (str, int)):
            raise ParameterError("device: give a selector string for cluster workers")
        self.client, self.device, self.per = client, device, parts_per_worker
        client.register_plugin(DevicePlugin(device), name=DevicePlugin.name)
        self.tasks = 0

    def _parts(self, npts: int):
        workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        step = max(1, math.ceil(npts / (self.per * workers)))
        return [(i, min(npts, i + step)) for i in range(0, npts, step)]

    def _map(self, fn, m, shape, wo, kw, point0: int | None = None):
        """fn on each part of the points; ``kw(i0, i1)``: the part's keyword arguments."""
        npts = math.prod(shape)
        wo = [np.broadcast_to(np.asarray(w, np.float64), shape).reshape(-1) for w in wo]
        futs = []
        for i0, i1 in self._parts(npts):
            args = (m.config, m.point_params(shape, i0, i1), m.precision, m.width, self.device,
                    [w[i0:i1] for w in wo], kw(i0, i1)) + (() if point0 is None else (point0 + i0,))
            futs.append(self.client.submit(fn, *args, pure=False))
        self.tasks += len(futs)
        out = self.client.gather(futs)
        self._same_device(m, [r[-1] for r in out])
        return out

    @staticmethod
    def _same_device(m, names):
        local = m.device.info.name
        for name in names:
            if name != local:
                raise ParameterError(f"a cluster worker computed on {name!r}, this process on "
                                     f"{local!r}: the results would differ from a local run; "
                                     f"give the workers' device (--device) here as well")

    def run_albedo(self, m, shape, wo, *, estimator, samples, seed, qmc, progress,
                   point0: int = 0):
        kw = dict(estimator=estimator, samples=samples, seed=seed, qmc=qmc)
        out = self._map(_albedo_task, m, shape, wo, lambda i0, i1: kw, point0=point0)
        seens = [r[3] for r in out]
        seen = None if any(x is None for x in seens) else tuple(
            np.concatenate([x[j] for x in seens]) for j in range(3))
        return (np.concatenate([r[0] for r in out]), np.concatenate([r[1] for r in out]),
                AlbedoPlan(samples, qmc, m.width), sum(r[2] for r in out), seen)

    def run_quadrature(self, m, shape, wo, *, tol, max_evals=QUAD_MAX_EVALS, progress=False,
                       integrand="albedo"):
        tols = np.broadcast_to(np.asarray(tol, float), shape).reshape(-1)
        out = self._map(_quadrature_task, m, shape, wo, lambda i0, i1: dict(
            tol=tols[i0:i1], max_evals=max_evals, integrand=integrand))
        return (np.concatenate([r[0] for r in out]), np.concatenate([r[1] for r in out]),
                np.concatenate([r[2] for r in out]), sum(r[3] for r in out))


    def run_ltc(self, grid, spec):
        """fit_ltc's cells in parts (clbrdf.tables.ltc.fit_ltc_part on the workers)."""
        futs = [self.client.submit(_ltc_task, spec, i0, i1, self.device, pure=False)
                for i0, i1 in self._parts(grid.n)]
        self.tasks += len(futs)
        out = self.client.gather(futs)
        self._same_device(grid.model, [r["device"] for r in out])
        return out


@contextlib.contextmanager
def on_cluster(client, device=None):
    """Inside the block every albedo and quadrature call (clbrdf.albedo_table, make_layout,
    ...) and every LTC fit's cells run on the cluster (``ClusterDriver``)."""
    d = ClusterDriver(client, device)
    with using(d.run_albedo), using_quadrature(d.run_quadrature), using_ltc_parts(d.run_ltc):
        yield d


@contextlib.contextmanager
def session(address: str, device=None):
    """``on_cluster`` with a client of ``connect(address)``, closed at the end (with the
    LocalCluster of ``local:N``)."""
    client = connect(address)
    try:
        with on_cluster(client, device) as d:
            yield d
    finally:
        cluster = getattr(client, "cluster", None)
        client.close()
        if cluster is not None and address.startswith("local:"):
            cluster.close()


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
