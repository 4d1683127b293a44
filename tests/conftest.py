"""Shared fixtures for the clbrdf tests.

Chi-square tests carry the marker ``chisquare(n)`` (n statistical tests in one test item). After
collection and deselection (``-m``, ``-k``), the number of chi-square tests that will run is
counted, and the fixture ``chi2_alpha`` gives each the Sidak-corrected significance that keeps
the probability of any false rejection in the run at ``CHI2_FAMILY_ALPHA`` = 0.01.
"""
import functools
import hashlib

import numpy as np
import pytest

import stats

CHI2_FAMILY_ALPHA = 0.01


def _log_builds(path):
    """CLBRDF_BUILD_LOG=FILE: one JSON line per program this worker builds (the test, the
    seconds, the source's hash and #define lines), to see which tests compile what."""
    import json
    import os
    import time

    from clbrdf.runtime import build
    inner = build._build.__wrapped__

    def logged(device, source):
        t = time.perf_counter()
        r = inner(device, source)
        row = {"test": os.environ.get("PYTEST_CURRENT_TEST", ""), "s": time.perf_counter() - t,
               "hash": hashlib.sha1(source.encode()).hexdigest()[:12],
               "defines": [ln for ln in source.splitlines()[:40] if ln.startswith("#define")]}
        with open(path, "a") as f:
            f.write(json.dumps(row) + "\n")
        return r
    build._build = functools.lru_cache(maxsize=256)(logged)


def pytest_configure(config):
    import os
    if os.environ.get("CLBRDF_BUILD_LOG"):
        _log_builds(os.environ["CLBRDF_BUILD_LOG"])
    config.addinivalue_line(
        "markers", "chisquare(n=1): the test performs n chi-square tests; their significance is "
        "Sidak-corrected over all chi-square tests selected in the run")


def _chi2_count(item):
    m = item.get_closest_marker("chisquare")
    if m is None:
        return 0
    return int(m.kwargs.get("n", m.args[0] if m.args else 1))


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(session, config, items):
    # trylast: runs after the mark plugin has removed the deselected items
    config._clbrdf_chi2_tests = sum(_chi2_count(it) for it in items)


@pytest.fixture(scope="session")
def chi2_alpha(request):
    """Per-test significance: Sidak over the chi-square tests of this run."""
    k = getattr(request.config, "_clbrdf_chi2_tests", 1) or 1
    return stats.sidak(CHI2_FAMILY_ALPHA, k)


@pytest.fixture(scope="session")
def clbrdf_device():
    """The library's default device (skips the run's device tests if there is none)."""
    import clbrdf
    try:
        return clbrdf.get_device()
    except clbrdf.DeviceError as e:  # pragma: no cover - depends on the machine
        pytest.skip(f"no OpenCL device: {e}")


@pytest.fixture(scope="module")
def model_cache(clbrdf_device):
    """get(name, precision=..., width=..., **kw) -> clbrdf.Model, one per configuration per
    module. (Programs are also cached by the library per source text, so each kernel
    configuration compiles once per process.)"""
    import clbrdf
    cache = {}

    def get(name, **kw):
        def ident(v):
            if isinstance(v, str):
                return v
            a = np.ascontiguousarray(v, dtype=np.float64)
            return (a.shape, hashlib.sha1(a.tobytes()).hexdigest())
        key = (name, tuple(sorted((k, ident(v)) for k, v in kw.items())))
        if key not in cache:
            cache[key] = clbrdf.Model(name, device=clbrdf_device, **kw)
        return cache[key]
    return get


# Options for programs run under oclgrind: no optimisation, sin and cos apart (its
# uninitialised-memory checker rejects sincos's pointer), and no forced inlining (it emits
# llvm.experimental.noalias.scope.decl even at -cl-opt-disable, which oclgrind cannot run: every
# configuration failed on it before, checked at commit 62eb771).
OCLGRIND_BUILD_OPTIONS = "-cl-opt-disable -DCLBRDF_SEPARATE_SINCOS=1 -DCLBRDF_NO_FORCED_INLINE=1"


@pytest.fixture
def oclgrind_serial():
    """One oclgrind run at a time across pytest workers: a run takes up to 11 GB (RGB models in
    double precision), and two at once were killed for memory on a 24 GB machine."""
    import fcntl
    import tempfile
    from pathlib import Path
    with open(Path(tempfile.gettempdir()) / "clbrdf-oclgrind.lock", "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)
