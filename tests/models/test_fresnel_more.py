"""The generalised Schlick (free exponent, Cycles) and F82-tint (Hoffman 2023) Fresnel terms of
the microfacet models (kernels/fresnel.h): their exact F_avg for Kulla-Conty, the F82 design
property F(1/7) = tint F_Schlick(1/7), and where F82-tint is clamped. The battery
(tests/models/test_conformance.py, test_check.py) draws fresnel=gen_schlick and f82 by itself."""
import numpy as np
import pytest

import clbrdf
from clbrdf.ref.microfacet import fresnel, fresnel_avg_closed


@pytest.mark.parametrize("f0, f90, n, tol", [(0.3, 0.9, 2.5, 1e-12), (0.04, 1.0, 5.0, 1e-12),
                                             (0.5, 0.2, 0.7, 3e-7), (0.9, 1.0, 40.0, 1e-12)])
def test_gen_schlick_average(f0, f90, n, tol):
    """The kernel's F_avg (clbrdf.fresnel_avg: Gauss-Legendre of its own F) against
    F0 + (F90 - F0) 2 / ((n + 1)(n + 2)); a non-integer exponent below 1 puts a singular
    derivative at c = 1, where the rule is 1.6e-7 off (exponent 0.7)."""
    got = clbrdf.fresnel_avg("ggx", fresnel="gen_schlick", f0=f0, f90=f90, exponent=n)
    assert abs(float(got) - fresnel_avg_closed("gen_schlick", f0, f90, n)) < tol


@pytest.mark.parametrize("f0, tint", [(0.9, 0.6), (0.7, 1.0), (0.95, 0.5), (0.2, 0.8)])
def test_f82_average_and_design_point(f0, tint):
    """F_avg = F0 + (1 - F0)/21 - a/126, and F(1/7) = tint times Schlick's there."""
    got = clbrdf.fresnel_avg("ggx", fresnel="f82", f0=f0, f82=tint)
    assert abs(float(got) - fresnel_avg_closed("f82", f0, f82=tint)) < 1e-12
    cb = 1 / 7
    assert abs(fresnel("f82", cb, f0=f0, f82=tint) - tint * (f0 + (1 - f0) * (1 - cb) ** 5)) < 1e-15


def test_f82_clamp_region():
    """F82-tint goes below 0 at tint 0 for any F0 < 0.995 (F(1/7) = 0 with a nonzero slope), at
    tint 0.25 for F0 < 0.085, never from tint 0.52 on (docs/models/microfacet.md); the kernel
    returns 0 there, as the reference, and never a negative value."""
    c = np.linspace(0, 1, 4001)
    raw = lambda f0, t: (f0 + (1 - f0) * (1 - c) ** 5                     # noqa: E731
                         - (1 - t) * (f0 + (1 - f0) * (6 / 7) ** 5) * 7 ** 7 / 6 ** 6 * c * (1 - c) ** 6)
    assert raw(0.98, 0.0).min() < 0 and raw(0.08, 0.25).min() < 0 and raw(0.09, 0.25).min() >= 0
    assert all(raw(f0, 0.52).min() >= 0 for f0 in np.linspace(0, 1, 101))
    assert raw(0.0, 0.5).min() < 0
    s = np.sqrt(1 - c * c)
    wo = np.stack([s, 0 * c, c], -1)
    wi = np.stack([-s, 0 * c, c], -1)                # the mirror pair: wi.h = c
    for prec in ("single", "double"):
        m = clbrdf.Model("ggx", alpha=0.3, fresnel="f82", f0=0.1, f82=0.0, precision=prec)
        ones = clbrdf.Model("ggx", alpha=0.3, precision=prec)
        ok = c > 1e-3
        F = m.eval(wo[ok], wi[ok]) / ones.eval(wo[ok], wi[ok])
        assert F.min() >= 0
        assert np.allclose(F, fresnel("f82", c[ok], f0=0.1, f82=0.0), atol=2e-6)
