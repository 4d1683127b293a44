"""Does a device run our kernels? A compiler can pass a trivial kernel and still hang or abort on
ours: PyPI's PoCL 3.0 (LLVM 14) builds the GGX albedo program at width 16 for over a minute and
then aborts the process ("LLVM ERROR: Cannot emit physreg copy instruction"), where width 1 works.
Such a failure kills the process that meets it, so the check runs in a child process with a
timeout: it builds the GGX albedo program at the width asked and compares E(mu = 0.5) with the
float64 reference. Results are cached on disk per device, driver, width, precision and kernel
sources (``CLBRDF_CACHE_DIR``, else ``$XDG_CACHE_HOME/clbrdf`` or ``~/.cache/clbrdf``).

``python -m clbrdf.runtime.probe_child P:D WIDTH PRECISION`` is the child.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

from ..version import __version__
from .build import kernel_dir

TIMEOUT = 150                   # seconds: a good device builds and runs the check in a few
CHECK = {"alpha": 0.5, "mu": 0.5, "samples": 1 << 12}
TOLERANCE = 1e-3                # |E - E_ref| of the check (its stderr is about 1e-4)


def cache_file() -> Path:
    base = os.environ.get("CLBRDF_CACHE_DIR") or Path(
        os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "clbrdf"
    return Path(base) / "probes.json"


@lru_cache(maxsize=None)
def _sources_digest() -> str:
    h = hashlib.sha256(__version__.encode())
    for p in sorted(kernel_dir().glob("*")):
        if p.is_file() and p.suffix in (".h", ".cl"):
            h.update(p.name.encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _key(info, width: int, precision: str) -> str:
    return "|".join([info.platform, info.name, info.driver, str(width), precision,
                     _sources_digest()])


def _read_cache() -> dict:
    try:
        return json.loads(cache_file().read_text())
    except (OSError, ValueError):
        return {}


def _write_cache(key: str, value) -> None:
    path = cache_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        data = _read_cache()
        data[key] = value
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(data, indent=1, sort_keys=True))
        os.replace(tmp, path)
    except OSError:
        pass                    # a read-only home: the check runs again next time


def cached(info, width: int, precision: str):
    """The cached result: None (works), a reason (fails), or ... (not checked yet)."""
    data = _read_cache()
    key = _key(info, width, precision)
    return data[key] if key in data else ...


_session: dict = {}


def kernel_error(info, width: int, precision: str) -> str | None:
    """None if the device builds and runs the GGX albedo kernel correctly at this width and
    precision (checked in a child process, cached), else what went wrong."""
    key = _key(info, width, precision)
    if key in _session:
        return _session[key]
    hit = cached(info, width, precision)
    if hit is not ...:
        _session[key] = hit
        return hit
    env = dict(os.environ, CLBRDF_IN_PROBE="1")
    env.pop("CLBRDF_WIDTH", None)
    try:
        r = subprocess.run([sys.executable, "-m", "clbrdf.runtime.probe_child", info.selector, str(width),
                            precision], env=env, capture_output=True, text=True,
                           timeout=TIMEOUT)
        if r.returncode == 0 and r.stdout.strip().startswith("ok"):
            err = None
        else:
            lines = [ln for ln in (r.stderr + r.stdout).splitlines() if ln.strip()]
            why = next((ln for ln in reversed(lines) if "error" in ln.lower()),
                       lines[-1] if lines else "")
            how = (f"exit {r.returncode}" if r.returncode >= 0 else
                   f"killed by signal {-r.returncode}")
            err = f"the GGX albedo kernel at width {width} ({precision}) failed: {how}" + \
                (f": {why.strip()}" if why else "")
    except subprocess.TimeoutExpired:
        err = (f"the GGX albedo kernel at width {width} ({precision}) did not build and run "
               f"within {TIMEOUT} s")
    _session[key] = err
    _write_cache(key, err)
    return err
