"""Resumable tables: ``with checkpoint(DIR, job, resume=...)`` makes every Monte Carlo ``albedo``
call inside it (a table's cells, its averages, its interpolation check, its refinement looks)
compute its points in chunks of about CHUNK_SAMPLES samples and write each chunk to DIR as it
finishes (a file renamed into place: a kill leaves whole chunks only). Run again with
``resume=True`` and the same job, the same calls come in the same order; a call whose fingerprint
(model and parameters, directions, estimator, samples, seed, precision, width, device) matches
the one recorded loads the chunks it finds and computes the rest. The random numbers of a point
are keyed by its flat index (``runtime.run_albedo``'s ``point0``), so the result is bit-identical
to an uninterrupted run on the same device kind and width.

``clbrdf table --resume`` keeps DIR beside the first output (``.NAME.resume/``) and removes it
once every file is written.
"""
from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import math
import os
from pathlib import Path

import numpy as np

from ..models.spec import ParameterError, given, switch
from ..runtime.albedo import AlbedoPlan, runner, using
from ..runtime.launch import progress_bar
from .outputs import lock_dir

# samples per chunk: about 2 s of GGX on 2 cores (CLBRDF_CHUNK_SAMPLES sets another, for tests)
CHUNK_SAMPLES = int(os.environ.get("CLBRDF_CHUNK_SAMPLES", 1 << 30))


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype.str, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _write_atomic(path: Path, write) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    write(tmp)
    os.replace(tmp, path)


class Checkpoint:
    def __init__(self, path: Path):
        self.path = path
        self.compute = runner()     # the driver of a chunk: a cluster's, where one is in effect
        self.calls = 0
        self.loaded = 0         # chunks read back
        self.computed = 0       # chunks computed

    def _call(self, fingerprint: dict) -> int:
        i = self.calls
        self.calls += 1
        text = json.dumps(fingerprint, sort_keys=True)
        f = self.path / f"call{i:05d}.json"
        if f.exists():
            if f.read_text() != text:
                old = json.loads(f.read_text())
                diff = sorted(k for k in set(old) | set(fingerprint)
                              if old.get(k) != fingerprint.get(k))
                raise ParameterError(f"cannot resume from {str(self.path)!r}: computation {i} "
                                     f"differs in {', '.join(diff)} (another device, width or "
                                     f"version?); run {switch('resume', False)} to start again")
        else:
            _write_atomic(f, lambda p: p.write_text(text))
        return i

    def run_albedo(self, m, shape, wo, *, estimator, samples, seed, qmc, progress):
        """run_albedo over ``shape`` in chunks of flat points, each read from or written
        to the checkpoint."""
        npts = math.prod(shape)
        wo = [np.broadcast_to(np.asarray(w, np.float64), shape).reshape(-1) for w in wo]
        dev = m.device.info
        fp = {"model": m.name, "options": m.options, "channels": m.channels,
              "params": _digest(*[np.broadcast_to(np.asarray(m.params[k], np.float64),
                                                  _pshape(m, k, shape))
                                  for k in m.config.param_names]),
              "directions": _digest(*wo), "shape": list(shape), "estimator": estimator,
              "samples": int(samples), "seed": int(seed), "qmc": bool(qmc),
              "precision": m.precision, "width": m.width, "device": dev.name,
              "platform": dev.platform, "driver": dev.driver,
              "chunk_points": max(1, CHUNK_SAMPLES // int(samples))}
        call = self._call(fp)
        per = fp["chunk_points"]
        plan = AlbedoPlan(samples, qmc, m.width)
        bar = progress_bar(npts * plan.samples, progress)
        ests, errs, seens, seconds = [], [], [], 0.0
        for c, i0 in enumerate(range(0, npts, per)):
            i1 = min(npts, i0 + per)
            f = self.path / f"call{call:05d}.c{c:06d}.npz"
            if f.exists():
                with np.load(f) as z:
                    e, s = z["E"], z["stderr"]
                    seen = (z["lo"], z["hi"], z["mc"]) if "mc" in z.files else None
                self.loaded += 1
            else:
                sub = _take(m, shape, i0, i1)
                e, s, plan, secs, seen = self.compute(
                    sub, (i1 - i0,), [w[i0:i1] for w in wo], estimator=estimator,
                    samples=samples, seed=seed, qmc=qmc, progress=False, point0=i0)
                seconds += secs
                _write_atomic(f, lambda p, e=e, s=s, seen=seen: _save(p, e, s, seen))
                self.computed += 1
            ests.append(e)
            errs.append(s)
            seens.append(seen)
            bar.update((i1 - i0) * plan.samples)
        bar.close()
        seen = None if any(x is None for x in seens) else tuple(
            np.concatenate([x[j] for x in seens]) for j in range(3))
        return np.concatenate(ests), np.concatenate(errs), plan, seconds, seen


def _save(path: Path, e, s, seen=None) -> None:
    with open(path, "wb") as fh:        # a file object: np.savez would append .npz to a path
        np.savez(fh, E=e, stderr=s, **({} if seen is None else dict(zip(("lo", "hi", "mc"), seen))))


def _pshape(m, k, shape):
    return shape + (m.channels,) if k in m.config.spectral and m.channels > 1 else shape


def _take(m, shape, i0, i1):
    """The model at flat points i0 .. i1 of shape (parameters broadcast, then sliced)."""
    sub = copy.copy(m)
    sub.params = m.point_params(shape, i0, i1)
    return sub


@contextlib.contextmanager
def checkpoint(path, job: dict, *, resume: bool = False):
    """Checkpoint the albedo calls inside to ``path`` (module docstring). ``job``: what the run
    is (JSON-able); a resume must give the same. The directory is locked while the run holds it
    (a second process with the same output stops at once, naming it), and a checkpoint left by
    an interrupted run is never removed here: without ``resume`` that is an error that says how
    to continue it or where it is to remove it."""
    path = Path(path)
    text = json.dumps(job, sort_keys=True, default=str)
    fresh = False
    if not resume:
        try:
            path.mkdir(parents=True)
            fresh = True
        except FileExistsError:
            pass
    if not path.is_dir():
        if resume:
            raise ParameterError(f"{given('resume', True)}: nothing to resume at {str(path)!r} "
                                 f"(no earlier run left one); run {switch('resume', False)}")
        raise ParameterError(f"{str(path)!r} is in the way of the checkpoint (not a directory)")
    fd = lock_dir(path)
    try:
        if resume:
            if not (path / "job.json").exists():
                raise ParameterError(f"{given('resume', True)}: nothing to resume at {str(path)!r} "
                                     f"(no earlier run left one); run {switch('resume', False)}")
            old = json.loads((path / "job.json").read_text())
            if old != json.loads(text):
                diff = sorted(k for k in set(old) | set(job) if old.get(k) != job.get(k))
                raise ParameterError(f"cannot resume from {str(path)!r}: the earlier run had "
                                     f"other {', '.join(diff)}; give the same arguments, or "
                                     f"remove {str(path)!r} to start again")
        elif not fresh and (path / "job.json").exists():
            done = len(list(path.glob("call*.c*.npz")))
            raise ParameterError(f"an interrupted run left its checkpoint at {str(path)!r} "
                                 f"({done} finished chunks): continue it with the same arguments "
                                 f"and {given('resume', True)}, or remove that directory to start "
                                 f"again")
        else:
            _write_atomic(path / "job.json", lambda p: p.write_text(text))
        ck = Checkpoint(path)
        with using(ck.run_albedo):
            yield ck
    finally:
        os.close(fd)
