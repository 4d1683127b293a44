"""A new model is its kernel header, its description, its reference and its doc page, with no edit
anywhere else (docs/adding-a-model.md): a small model written into a temporary directory,
registered with ``clbrdf.models.register``, runs the conformance battery, ``clbrdf.check``, a
table (written and read back) and an energy sweep like the models that ship.

The model: f = kd (cos_i cos_o)^m / pi, sampled uniformly over the hemisphere (weight
2 kd (cos_i cos_o)^m cos_i), so E(mu) = 2 kd mu^m / (m + 2) in closed form."""
from __future__ import annotations

import sys
import textwrap

import numpy as np
import pytest

import clbrdf
import test_conformance as battery
from clbrdf.models import MODELS, register
from clbrdf.models.spec import Facts, ModelSpec, Param
from clbrdf.studies.check import configurations

HEADER = """\
/* powdiffuse: f = kd (cos_i cos_o)^m / pi, sampled uniformly over the hemisphere. */
#ifndef POWDIFFUSE_H
#define POWDIFFUSE_H

#define powdiffuse_SAMPLE_DIMS 2

ALWAYS_INLINE spec powdiffuse_eval(const powdiffuse_params *p, vec3 wo, vec3 wi)
{
    maskN ok = (wi.z > 0) & (wo.z > 0);
    realN g = pow(fmax(wi.z * wo.z, (realN)1e-30), p->m) * INV_PI_R;
    spec f;
    for (int c = 0; c < CHANNELS; ++c)
        f.c[c] = sel((realN)0, p->kd[c] * g, ok);
    return f;
}

ALWAYS_INLINE realN powdiffuse_pdf(const powdiffuse_params *p, vec3 wo, vec3 wi)
{
    (void)p;
    return sel((realN)0, uniform_hemisphere_pdf(wi), wo.z > 0);
}

ALWAYS_INLINE BSample powdiffuse_sample(const powdiffuse_params *p, vec3 wo, rand4 u)
{
    BSample s;
    s.wi = square_to_uniform_hemisphere(u.u0, u.u1);
    s.pdf = powdiffuse_pdf(p, wo, s.wi);
    spec f = powdiffuse_eval(p, wo, s.wi);
    for (int c = 0; c < CHANNELS; ++c)
        s.weight.c[c] = sel((realN)0, f.c[c] * s.wi.z * (realN)(2 * 3.14159265358979323846), wo.z > 0);
    return s;
}

#endif
"""

REFERENCE = '''
"""float64 reference of powdiffuse, written from its formula."""
import numpy as np

from clbrdf.ref import Reference


class PowDiffuse(Reference):
    def eval1(self, wo, wi, v, c):
        ok = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        g = np.maximum(wi[..., 2] * wo[..., 2], 1e-30) ** v["m"] / np.pi
        return np.where(ok, v["kd"] * g, 0.0)

    def pdf(self, wo, wi):
        return np.where((wo[..., 2] > 0) & (wi[..., 2] > 0), 1 / (2 * np.pi), 0.0)

    def albedo1(self, mu, phi, tol, v, c):
        return float(2 * v["kd"] * mu ** v["m"] / (v["m"] + 2)), 0.0


REFERENCES = {"powdiffuse": PowDiffuse}
'''


@pytest.fixture(scope="module")
def powdiffuse(tmp_path_factory):
    d = tmp_path_factory.mktemp("powdiffuse")
    (d / "powdiffuse.h").write_text(HEADER)
    (d / "powdiffuse_ref.py").write_text(textwrap.dedent(REFERENCE))
    sys.path.insert(0, str(d))
    spec = ModelSpec(
        name="powdiffuse", title="cosine-power diffuse (a test of a model from outside)",
        reference="f = kd (cos_i cos_o)^m / pi", header=str(d / "powdiffuse.h"),
        prefix="powdiffuse", ref="powdiffuse_ref",
        params=(Param("kd", "albedo at normal incidence and m = 0", 0.0, 1.0, 0.8,
                      spectral=True),
                Param("m", "power of cos_i cos_o", 0.0, 4.0, 0.5)),
        facts=Facts(sweeps=((("m",), (0.0, 1.0, 4.0)),), sharp={"m": 4.0}))
    register(spec)
    try:
        yield spec.name
    finally:
        MODELS.pop(spec.name, None)
        sys.path.remove(str(d))


def test_the_conformance_battery_runs_on_it(powdiffuse):
    cases = configurations(powdiffuse)
    assert {cid for cid, _ in cases} >= {"defaults", "rgb", "kd=lo", "m=hi"}
    for cid, kw in cases:
        battery.test_kernel_matches_reference(powdiffuse, cid, kw)
        battery.test_single_precision_matches_double(powdiffuse, cid, kw)
        battery.test_sample_is_finite_at_the_edges_of_u(powdiffuse, cid, kw)
    for cid, kw in cases[:2]:
        battery.test_albedo_matches_reference(powdiffuse, cid, kw)


def test_check_passes_on_it(powdiffuse):
    r = clbrdf.check(powdiffuse)
    assert all(c.passed for c in r.checks), r.table()


def test_a_broken_kernel_is_caught(powdiffuse, tmp_path):
    """The battery is not vacuous for a registered model: the same description with a sampler
    whose weights are 5 % high fails clbrdf check's weight and albedo checks and the battery's
    albedo test."""
    from dataclasses import replace
    bad = tmp_path / "bad.h"
    bad.write_text(HEADER.replace("(2 * 3.14159265358979323846)", "(2.1 * 3.14159265358979323846)"))
    register(replace(MODELS[powdiffuse], name="powdiffuse_bad", header=str(bad)))
    sys.modules["powdiffuse_ref"].REFERENCES["powdiffuse_bad"] = \
        sys.modules["powdiffuse_ref"].REFERENCES[powdiffuse]
    try:
        failed = {c.name for c in clbrdf.check("powdiffuse_bad").checks if not c.passed}
        assert {"weight = f cos / pdf", "albedo vs quadrature"} <= failed, failed
        with pytest.raises(AssertionError):
            battery.test_albedo_matches_reference("powdiffuse_bad", "defaults", {})
    finally:
        MODELS.pop("powdiffuse_bad", None)


def test_tables_and_sweeps_take_it(powdiffuse, tmp_path):
    t = clbrdf.albedo_table(powdiffuse, {"mu": [0.25, 0.5, 1.0], "m": [0.0, 2.0]},
                            samples=1 << 14, qmc=True)
    mu, m = np.meshgrid([0.25, 0.5, 1.0], [0.0, 2.0], indexing="ij")
    want = 2 * 0.8 * mu ** m / (m + 2)
    assert np.all(np.abs(t["E"] - want) < 5 * t["E_stderr"] + 1e-6), (t["E"], want)
    want_avg = 4 * 0.8 / (np.array([0.0, 2.0]) + 2) ** 2      # 2 int E mu dmu
    assert np.all(np.abs(t["E_avg"] - want_avg) < 5 * t["E_avg_stderr"] + 1e-6), t["E_avg"]
    written = clbrdf.save_tables(t, tmp_path / "p.npz")
    back = clbrdf.Table.load(written[0])
    np.testing.assert_array_equal(back["E"], t["E"])
    s = clbrdf.sweep(powdiffuse, tmp_path / "p.zarr", axes={"m": (0.0, 4.0, 5)}, samples=512)
    summary = s.summary()
    assert summary["points"] == 5 and summary["gains"] == 0
