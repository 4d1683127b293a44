"""The child process of ``probe.kernel_error``: builds the GGX albedo program at one width and
precision and compares E(mu) with the float64 reference (``probe.CHECK``, ``probe.TOLERANCE``).

    python -m clbrdf.runtime.probe_child P:D WIDTH PRECISION
"""
from __future__ import annotations

import sys

import numpy as np

from ..models import get_spec
from ..ref import reference
from .albedo import run_albedo
from .bound import Bound
from .device import get_device
from .probe import CHECK, TOLERANCE


def main(argv) -> int:
    selector, width, precision = argv[0], int(argv[1]), argv[2]
    config, params = get_spec("ggx").configure(channels=1, alpha=CHECK["alpha"])
    m = Bound(config, params, precision, get_device(selector), width)
    mu = CHECK["mu"]
    wo = [np.sqrt(1 - mu * mu), 0.0, mu]
    est, *_ = run_albedo(m, (), wo, estimator="brdf", samples=CHECK["samples"], seed=0,
                              qmc=True, progress=False)
    want = float(reference("ggx", alpha=CHECK["alpha"]).albedo(mu)[0])
    got = float(est[0, 0])
    if not abs(got - want) <= TOLERANCE:
        print(f"error: E = {got!r} where the reference is {want!r}", file=sys.stderr)
        return 1
    print(f"ok {got!r} {want!r}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
