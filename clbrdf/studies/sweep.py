"""Energy-conservation sweeps: the directional albedo of a model at many parameter points, each
with a verdict (gains energy, conserves, undecided), written chunk by chunk to a zarr store.

    s = clbrdf.sweep("ggx", "ggx.zarr", axes={"alpha": (1e-3, 1, 256, "log")}, samples=4096)
    s.summary()          # {"points", "gains", "conserves", "undecided", "worst": {...}}
    s["E_max"][:10]      # the arrays (zarr), sliced into NumPy

Points are a grid over the axes (C order, the last axis fastest) or, with ``random=N``, the first
N points of a scrambled Sobol sequence over the axes' box. At each point the albedo is estimated
at D outgoing directions (``directions``: Gauss-Legendre nodes in mu, times azimuths for
anisotropic models), giving E_max (the largest over directions, per channel), the direction where
it occurs and E_avg (the quadrature over the directions), each with its standard error.

Decision rule (``decide``): with K = D x channels estimates per point and at most R looks (the
first estimate and up to R - 1 refinements, each quadrupling a direction's samples, up to
``max_samples``), every estimate gets the interval [E - z s - u_lo, E + z s + u_hi] with z the
normal quantile of 1 - e / (2 R K), e = ``error_rate`` (Student's t with 15 degrees of freedom
for quasi-Monte Carlo, whose error comes from 16 scrambles), and u the allowances for events the
N samples did not draw (``unseen_bound``): a region of the sampler's domain with probability
above ln(2 R K / e) / N is missed by all N samples with probability below e / (2 R K), and
weights are >= 0, so a missed region lowers E by at most u_lo = ln(2 R K / e) |E| / N and raises
it by at most u_hi = ln(2 R K / e) W / N (W the estimator's weight scale, core.weight_scale).
A point *gains* energy when some lower bound exceeds 1, *conserves*
when every upper bound is at most 1, and is *undecided* otherwise. Between looks only the
estimates of undecided points whose interval contains 1 and whose |E - 1| exceeds the rounding
allowance (``rounding``: below it no sample count decides) get more samples (and, with
``target_stderr``, any estimate whose standard error exceeds it). By the union bound over the K
estimates, R looks and the two parts of each interval, a point's verdict is wrong with
probability at most e, to the extent that each estimate is normal (t) with its standard error
wherever its samples saw the integrand. The stored ``E_stderr`` (and ``E_max_stderr``,
``E_avg_stderr``) is the standard error with ``core.unseen`` at alpha = 1e-3 in quadrature, as
``clbrdf.albedo`` reports it. The verdict is about the D directions
computed: max E over all directions can only be larger.

Random numbers are keyed by position: the first look of direction d at point i uses the
generator at (seed, i D + d), as ``clbrdf.albedo`` over the (points, directions) grid would;
refinement r of chunk c uses a seed derived from (seed, r, c) and the estimate's position in the
chunk's list. So a chunk's values depend only on the job, never on the device that ran it, the
order chunks ran in, or restarts: the store is bit-identical for the same device kind, driver
and width (see docs/sweeps.md).

Store (zarr v3, one chunk of every array per sweep chunk, written only by the process that
computed it; zarr writes lock-free when writes align with chunks): ``params/<axis>`` (points,),
``E`` and ``E_stderr`` (points, D[, 3]) in float32, ``samples`` (points, D), ``E_max``,
``E_max_stderr``, ``E_max_dir``, ``E_avg``, ``E_avg_stderr`` (points[, 3]) in float64,
``verdict`` (points,) int8 (-1 not computed, 0 undecided, 1 conserves, 2 gains),
``directions/{mu,phi,weight}``; the job and its provenance in the group's attributes
(``clbrdf_sweep``), and ``ledger/cNNNNNNNNN.json`` per completed chunk, written after its data.
The ledger, not the chunk files, says what is done: zarr does not write chunks equal to the
fill value, and a killed process can leave a partial chunk file.

Stored data is checksummed twice: each chunk file by zarr's crc32c codec (after zstd), and each
sweep chunk's values, as stored, by a SHA-256 per array in its ledger entry. ``open_sweep``
(so ``clbrdf report``) and ``sweep(resume=True)`` read every completed chunk back against both
(``damaged_chunks``): the first refuses a damaged store naming the chunk, its points and what is
wrong; the second recomputes the damaged chunks. Stores of clbrdf <= 0.4 have neither checksum:
they are verified as far as reading them back goes.
"""
from __future__ import annotations

import hashlib
import json
import os
import platform
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ..models.spec import ParameterError, called, given, switch
from ..runtime.device import resolve_devices
from ..runtime.launch import environment, progress_bar
from ..tables.outputs import alive, lock_dir
from ..version import __version__
from .cluster import run_on_cluster, worker_width
from .sweepjob import (
    NOT_DONE,
    VERDICTS,
    chunk_bounds,
    compute_chunk,
    device_fingerprint,
    job_difference,
    looks,
    make_job,
    n_chunks,
    point_values,
    rule_text,
    z_value,
)

# ---------------------------------------------------------------------------------------------
# the store

def _array_specs(job: dict) -> dict:
    """name -> (shape, dtype, fill) of every per-point array."""
    N, D, c = job["points"], len(job["directions"]["mu"]), job["channels"]
    ch = (c,) if c > 1 else ()
    specs = {"E": ((N, D) + ch, "float32", np.nan), "E_stderr": ((N, D) + ch, "float32", np.nan),
             "samples": ((N, D), "uint32" if job["max_samples"] < 2**32 else "uint64", 0),
             "E_max": ((N,) + ch, "float64", np.nan), "E_max_stderr": ((N,) + ch, "float64", np.nan),
             "E_max_dir": ((N,) + ch, "int16", -1), "E_avg": ((N,) + ch, "float64", np.nan),
             "E_avg_stderr": ((N,) + ch, "float64", np.nan), "verdict": ((N,), "int8", NOT_DONE)}
    for a in job["axes"]:
        specs["params/" + a["name"]] = ((N,), "float64", np.nan)
    return specs


def _create(path: Path, job: dict, manifest: dict) -> None:
    """The empty store, built beside ``path`` and renamed into place."""
    import zarr
    for old in path.parent.glob(f".{path.name}.*.creating"):        # left by a killed process
        pid = old.name[len(path.name) + 2:].split(".", 1)[0]
        if pid.isdigit() and not alive(int(pid)):
            import shutil
            shutil.rmtree(old, ignore_errors=True)
    tmp = path.parent / f".{path.name}.{os.getpid()}.creating"
    from zarr.codecs import Crc32cCodec, ZstdCodec
    root = zarr.open_group(str(tmp), mode="w")
    root.attrs["clbrdf_sweep"] = manifest
    C = job["chunk"]
    checked = [ZstdCodec(), Crc32cCodec()]         # a chunk file's checksum, verified on read
    for name, (shape, dtype, fill) in _array_specs(job).items():
        root.create_array(name, shape=shape, dtype=dtype, chunks=(C,) + shape[1:],
                          fill_value=fill, config={"write_empty_chunks": True},
                          compressors=checked,
                          dimension_names=("point", "direction", "channel")[:len(shape)])
    for k in ("mu", "phi"):
        root.create_array(f"directions/{k}", data=np.asarray(job["directions"][k]),
                          compressors=checked)
    w = job["directions"]["weight"]
    root.create_array("directions/weight", data=np.asarray(
        w if w is not None else [np.nan] * len(job["directions"]["mu"])), compressors=checked)
    (tmp / "ledger").mkdir()
    os.rename(tmp, path)


def _ledger_path(path: Path, index: int) -> Path:
    return Path(path) / "ledger" / f"c{index:09d}.json"


def done_chunks(path) -> set[int]:
    """Chunks whose ledger entry exists (written after all their data)."""
    d = Path(path) / "ledger"
    return {int(p.name[1:10]) for p in d.glob("c*.json") if len(p.name) == 15}


def _digest(values: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()


def _write_chunk(root, path: Path, job: dict, index: int, arrays: dict, info: dict) -> None:
    i0, i1 = chunk_bounds(job, index)
    sums = {}
    for k, v in arrays.items():
        a = root[k]
        stored = np.asarray(v, dtype=a.dtype)
        a[i0:i1] = stored
        sums[k] = _digest(stored)
    entry = {"chunk": index, "points": [i0, i1], "sha256": sums, **info}
    led = _ledger_path(path, index)
    tmp = led.with_name(f".{led.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    tmp.write_text(json.dumps(entry))
    os.replace(tmp, led)


def damaged_chunks(root, path, job: dict, chunks=None) -> dict:
    """{chunk index: what is wrong} over the completed chunks (or ``chunks``): every array of
    the chunk read back (zarr checks each chunk file's crc32c) and compared with the SHA-256 its
    ledger entry holds. One chunk in memory at a time."""
    bad = {}
    names = list(_array_specs(job))
    for index in sorted(done_chunks(path) if chunks is None else chunks):
        i0, i1 = chunk_bounds(job, index)
        try:
            entry = json.loads(_ledger_path(path, index).read_text())
            sums = entry.get("sha256", {})
        except (OSError, ValueError) as e:
            bad[index] = f"its ledger entry is unreadable ({type(e).__name__}: {e})"
            continue
        for k in names:
            try:
                v = np.asarray(root[k][i0:i1])
            except Exception as e:          # noqa: BLE001 - zarr, codecs, the file system
                bad[index] = f"array {k} cannot be read ({type(e).__name__}: {e})"
                break
            if k in sums and _digest(v) != sums[k]:
                bad[index] = f"array {k} differs from the checksum written with it"
                break
    return bad


def damage_text(path, job: dict, bad: dict) -> str:
    """One line per damaged chunk: its index, points and what is wrong."""
    return "; ".join(f"chunk {i} (points {chunk_bounds(job, i)[0]} to "
                     f"{chunk_bounds(job, i)[1] - 1}): {why}" for i, why in sorted(bad.items()))


class DamagedStoreError(ParameterError):
    """A sweep store whose data does not read back as written (``damaged_chunks``)."""

    def __init__(self, path, job, bad: dict):
        self.chunks = dict(bad)
        super().__init__(f"sweep store {str(path)!r} is damaged: {damage_text(path, job, bad)}; "
                         f"'clbrdf sweep {path} --resume' (sweep(resume=True)) recomputes the "
                         f"damaged chunks")


# ---------------------------------------------------------------------------------------------
# running

class DamagedChunkWarning(UserWarning):
    """sweep(resume=True) found a damaged chunk and computes it again."""


class _Stop:
    """Set by the caller's event, an exception in the calling thread (KeyboardInterrupt) or a
    failed worker: workers finish their chunk and return."""

    def __init__(self, event: threading.Event | None = None):
        self.event = event if event is not None else threading.Event()
        self.reason: BaseException | None = None


def _local_worker(root, path, job, device, todo, lock, stop: _Stop, bar, errors):
    try:
        while not stop.event.is_set():
            with lock:
                if not todo:
                    return
                index = todo.popleft()
            t0 = time.perf_counter()
            arrays = compute_chunk(job, index, device)
            seconds = time.perf_counter() - t0
            _write_chunk(root, path, job, index, arrays,
                         {"seconds": seconds, **device_fingerprint(device), "host": platform.node()})
            i0, i1 = chunk_bounds(job, index)
            bar.update(i1 - i0)
    except BaseException as e:          # noqa: BLE001 - re-raised in the main thread
        errors.append(e)
        stop.event.set()


def sweep(model: str | None = None, out=None, *, resume: bool = False, device=None,
          client=None, progress: bool = False, command: str | None = None,
          stop: threading.Event | None = None, **kw):
    """Run (or, with ``resume=True``, continue) a sweep into the zarr store ``out`` and return it
    opened (``Sweep``). Arguments as ``make_job``: ``axes`` (dict name -> (start, stop, count[,
    spacing]) or values or (start, stop[, spacing]) with ``random=N``), ``directions``,
    ``samples``, ``max_samples``, ``target_stderr``, ``estimator``, ``qmc``, ``error_rate``, ``seed``,
    ``precision``, ``width``, ``chunk``, ``preset`` and fixed parameters and options.
    ``device``: a selector, a Device, or a list of them (chunks are dealt out as devices
    finish); ``client``: a dask.distributed Client whose workers compute the chunks (see
    clbrdf.studies.cluster). With ``resume=True`` and no model, the store's own job continues.
    ``stop``: a threading.Event; once it is set the run ends after the chunks in progress, all
    of them written, and returns the store as far as it got (``Sweep.done()``). A
    KeyboardInterrupt (or any exception) in the calling thread does the same and is re-raised.
    Signals are the caller's: the command line turns SIGTERM into such an exception."""
    if out is None:
        raise ParameterError("out (the store path) is required")
    path = Path(out)
    if resume:
        if not (path / "zarr.json").exists():
            raise ParameterError(f"{given('resume', True)}: {str(path)!r} is not a sweep store "
                                 f"(no zarr.json); start it {switch('resume', False)}")
        old = open_sweep(path, verify=False).manifest
        if model is None:
            job = old["job"]
        else:
            job = make_job(model, device=None if client is not None else
                           resolve_devices(device)[0], **kw)
            why = job_difference(old["job"], job)
            if why:
                raise ParameterError(f"cannot resume {str(path)!r}: {why}; resume with the "
                                     f"store's arguments or write a new store")
    else:
        if model is None:
            raise ParameterError(f"a {called('model')} is required (or {given('resume', True)} for an "
                                 f"existing store)", "model")
        if path.exists():
            raise ParameterError(f"{given('out', str(path))} exists: continue it "
                                 f"{switch('resume', True)} or choose a new path", "out")
        if not path.parent.is_dir():
            raise ParameterError(f"{given('out', str(path))}: directory {str(path.parent)!r} "
                                 f"does not exist", "out")
        if client is not None and kw.get("width") is None:
            kw["width"] = worker_width(client, kw.get("precision", "single"))
        job = make_job(model, device=None if client is not None else resolve_devices(device)[0],
                       **kw)
    if not resume:
        _create(path, job, _manifest(job, command))
    lock = lock_dir(path)       # one process per store: a second --resume redid every chunk
    try:
        import zarr
        root = zarr.open_group(str(path), mode="r+")
        if resume:              # a damaged chunk is not done: its ledger entry goes, it reruns
            for index, why in damaged_chunks(root, path, job).items():
                i0, i1 = chunk_bounds(job, index)
                warnings.warn(f"sweep store {str(path)!r}: chunk {index} (points {i0} to "
                              f"{i1 - 1}) is damaged ({why}): computing it again",
                              DamagedChunkWarning, stacklevel=2)
                _ledger_path(path, index).unlink()
        return _sweep_run(root, path, job, client, device, progress, stop)
    finally:
        os.close(lock)


def _manifest(job: dict, command) -> dict:
    import scipy
    import zarr
    return {"job": job, "clbrdf": __version__, "created": time.strftime(
        "%Y-%m-%dT%H:%M:%SZ", time.gmtime()), "command": command, "host": platform.node(),
        "rule": rule_text(job), "z": z_value(job), "looks": looks(job),
        "software": {"numpy": np.__version__, "scipy": scipy.__version__,
                     "zarr": zarr.__version__},
        "environment": environment()}


def _sweep_run(root, path, job, client, device, progress, event=None):
    done = done_chunks(path)
    todo = [i for i in range(n_chunks(job)) if i not in done]
    total = job["points"]
    bar = progress_bar(total, progress, unit="pt")
    bar.update(total - sum(chunk_bounds(job, i)[1] - chunk_bounds(job, i)[0] for i in todo))
    stop = _Stop(event)
    try:
        if client is not None:
            run_on_cluster(client, root, path, job, todo, stop, bar, _write_chunk, device)
        else:
            _run_local(root, path, job, resolve_devices(device), todo, stop, bar)
    finally:
        bar.close()
    return open_sweep(path, verify=False)   # verified before a resume; new chunks carry sums


def _run_local(root, path, job, devices, todo, stop, bar):
    from collections import deque
    todo = deque(todo)
    lock = threading.Lock()
    errors: list = []
    threads = [threading.Thread(target=_local_worker, daemon=True, name=f"clbrdf-sweep-{i}",
                                args=(root, path, job, d, todo, lock, stop, bar, errors))
               for i, d in enumerate(devices)]
    for t in threads:
        t.start()
    try:
        while any(t.is_alive() for t in threads):
            for t in threads:
                t.join(0.1)
    except BaseException:               # SIGINT / SIGTERM: finish the chunks in progress
        stop.event.set()
        for t in threads:
            while t.is_alive():
                t.join(0.1)
        raise
    if errors:
        raise errors[0]


# ---------------------------------------------------------------------------------------------
# reading

class Sweep:
    """An opened sweep store: ``s["E_max"]`` and the other arrays (zarr, sliced into NumPy),
    ``s.job``, ``s.manifest``, ``s.directions``, ``s.complete``, ``s.summary()``."""

    def __init__(self, path, verify: bool = True):
        import zarr
        self.path = Path(path)
        if not (self.path / "zarr.json").exists():
            raise ParameterError(f"{str(self.path)!r} is not a sweep store (no zarr.json)")
        self.root = zarr.open_group(str(self.path), mode="r")
        self.manifest = dict(self.root.attrs.get("clbrdf_sweep") or {})
        if not self.manifest:
            raise ParameterError(f"{str(self.path)!r} is a zarr store but not a clbrdf sweep")
        self.job = self.manifest["job"]
        if verify:
            self.verify()

    def verify(self) -> None:
        """Read every completed chunk back against its checksums; a damaged one raises
        ``DamagedStoreError`` naming it (``damaged_chunks``)."""
        bad = damaged_chunks(self.root, self.path, self.job)
        if bad:
            raise DamagedStoreError(self.path, self.job, bad)

    def __getitem__(self, name):
        """An array of the store by name (``s["E_max"]``, ``s["params/alpha"]``); slice it into
        NumPy. Points are not items: ``s["E_max"][i]`` is point i's."""
        if not isinstance(name, str):
            raise ParameterError(f"sweep[{name!r}]: index a sweep by array name ("
                                 f"{', '.join(self.arrays())}), then the array by point")
        if name not in self:
            raise ParameterError(f"sweep {str(self.path)!r} has no array {name!r}: it has "
                                 f"{', '.join(self.arrays())}")
        return self.root[name]

    def __contains__(self, name) -> bool:
        return isinstance(name, str) and name in self.arrays()

    def arrays(self) -> list:
        """The names of the store's arrays (parameters as params/NAME, directions/NAME)."""
        return sorted(list(_array_specs(self.job)) + [f"directions/{k}" for k in
                                                      ("mu", "phi", "weight")])

    @property
    def points(self) -> int:
        return self.job["points"]

    @property
    def axes(self) -> list[str]:
        return [a["name"] for a in self.job["axes"]]

    @property
    def directions(self) -> dict:
        return {k: self.root[f"directions/{k}"][:] for k in ("mu", "phi", "weight")}

    def done(self) -> set[int]:
        return done_chunks(self.path)

    @property
    def complete(self) -> bool:
        return len(self.done()) == n_chunks(self.job)

    def chunks(self, arrays=("E_max", "E_max_stderr", "E_max_dir", "verdict")):
        """(i0, {name: values}) of every completed chunk, in order: memory per chunk only."""
        for index in sorted(self.done()):
            i0, i1 = chunk_bounds(self.job, index)
            yield i0, {k: self.root[k][i0:i1] for k in arrays}

    def point(self, i: int) -> dict:
        """The parameters of point i (axes and fixed ones)."""
        vals = point_values(self.job, i, i + 1)
        return {**self.job["fixed"], **({"preset": self.job["preset"]} if self.job["preset"]
                                        else {}), **{k: float(v[0]) for k, v in vals.items()}}

    def summary(self, worst: int = 1) -> dict:
        """Counts of verdicts over the computed points and the worst points (largest E_max);
        with target_stderr, ``above_target``: the points with an estimate still above it (at
        max_samples)."""
        counts = {v: 0 for v in VERDICTS.values()}
        best: list = []                     # (E, i, channel)
        computed = above = 0
        target = self.job.get("target_stderr")
        arrays = ("E_max", "E_max_stderr", "E_max_dir", "verdict") + (
            ("E_stderr",) if target is not None else ())
        for i0, a in self.chunks(arrays):
            v = a["verdict"]
            ok = v != NOT_DONE
            computed += int(ok.sum())
            if target is not None:      # stored as float32: above by more than its rounding
                se = a["E_stderr"].reshape(len(v), -1).astype(np.float64)
                above += int(np.sum(ok & np.any(se > target * (1 + 2 ** -23), axis=1)))
            for code, name in VERDICTS.items():
                counts[name] += int((v == code).sum())
            em = a["E_max"].reshape(len(v), -1)
            flat = np.where(ok[:, None], em, -np.inf)
            k = min(worst, flat.size)
            top = np.argpartition(-flat.ravel(), k - 1)[:k] if flat.size else []
            for t in top:
                i, c = divmod(int(t), em.shape[1])
                best.append((float(flat[i, c]), i0 + i, c,
                             float(a["E_max_stderr"].reshape(len(v), -1)[i, c]),
                             int(a["E_max_dir"].reshape(len(v), -1)[i, c]), int(v[i])))
            best = sorted(best, reverse=True)[:worst]
        d = self.directions
        out = {"points": self.points, "computed": computed, **counts, "worst": None,
               **({"above_target": above} if target is not None else {})}
        rows = []
        for e, i, c, s, j, v in best:
            rows.append({"point": i, "parameters": self.point(i),
                         "direction": {"index": j, "mu": float(d["mu"][j]),
                                       "phi": float(d["phi"][j])},
                         **({"channel": "RGB"[c]} if self.job["channels"] > 1 else {}),
                         "E": e, "stderr": s, "verdict": VERDICTS[v]})
        if rows:
            out["worst"] = rows[0] if worst == 1 else rows
        return out


def open_sweep(path, verify: bool = True) -> Sweep:
    """Open a sweep store written by ``clbrdf sweep`` / ``clbrdf.sweep``, every completed chunk
    read back against its checksums first (``verify=False``: not; a damaged store raises
    ``DamagedStoreError``, which names the chunks)."""
    return Sweep(path, verify=verify)
