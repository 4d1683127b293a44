"""Every kernel under oclgrind (Debian package `oclgrind`): no out-of-bounds access,
uninitialised read or data race, at scalar and vector widths, both precisions.

Slow (from 20 s to over 20 minutes per configuration, up to 11 GB each: one at a time, the
oclgrind_serial fixture); skipped where oclgrind is not installed. The programs are built with
conftest.OCLGRIND_BUILD_OPTIONS.
"""
import os
import shutil
import subprocess
import sys
import textwrap

import pytest
from conftest import OCLGRIND_BUILD_OPTIONS

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(shutil.which("oclgrind") is None, reason="oclgrind not installed")]

SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np, clbrdf
    name, width, precision = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    kw = dict(lambert=dict(kd=0.5),
              ggx=dict(alpha_x=0.3, alpha_y=0.1, kd=0.2, fresnel='conductor'),
              ggx_rgb=dict(channels=3, alpha=0.3, kd=[0.1, 0.2, 0.3], f0=[0.04, 0.5, 0.9],
                           ks=[1.0, 0.5, 2.0]),
              beckmann=dict(alpha=0.2, fresnel='dielectric', sampler='vndf', masking='separable'),
              schlick_rgb=dict(channels=3, material='double', spectral='fresnel', directional='eq18',
                               c=[0.04, 0.3, 0.9], r=0.1, p=0.3, psi=0.5, c2=[0.8, 0.4, 0.1],
                               r2=0.7, p2=0.5, psi2=1.0),
              low_smooth_rgb=dict(preset='alum-bronze', lobes='two', a2=[1.0, 2.0, 3.0], b2=50.0, c2=0.7),
              low_microfacet_rgb=dict(preset='alum-bronze'),
              holzschuch_pacanowski_rgb=dict(channels=3, kd=[0.1, 0.2, 0.3]),
              sgd_bagher_rgb=dict(preset='alum-bronze'),
              gtr=dict(alpha=0.3, gamma=1.5, kd=0.2, fresnel='schlick'),
              sgd=dict(alpha=0.05, p=1.2),
              ashikhmin_shirley_rgb=dict(channels=3, nu=100.0, nv=10.0, rs=[0.05, 0.5, 0.9],
                                         rd=[0.2, 0.5, 0.7]),
              ashikhmin_shirley=dict(preset='alum-bronze:E1'),
              )[name]
    m = clbrdf.Model(name.replace('_rgb', ''), width=width, precision=precision, device='oclgrind', **kw)
    rng = np.random.default_rng(0)
    v = rng.normal(size=(7, 3)); v[:, 2] = abs(v[:, 2]); v /= np.linalg.norm(v, axis=1, keepdims=True)
    m.eval(v[::-1], v); m.pdf(v, v[::-1]); m.sample(v, seed=1)
    for est in ('uniform', 'brdf', 'mis'):
        clbrdf.albedo(m, [0.3, 0.9], samples=1500, estimator=est)
    clbrdf.albedo(m, [0.3], samples=1500, qmc=True)
    clbrdf.runtime.quadrature.QUAD_FIRST_PANELS = 1       # one panel, then one refinement: a small job
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', RuntimeWarning)
        clbrdf.albedo(m, [0.3], estimator='quadrature', tol=0.5, max_evals=1 << 18)
        clbrdf.albedo(m, [0.3], estimator='quadrature', tol=1e-3, max_evals=1 << 18)
    print('done')
""")

# Without forced inlining (OCLGRIND_BUILD_OPTIONS) two RGB double configurations outgrow a 24 GB
# machine under oclgrind (2026-12-03): sgd_bagher_rgb 22.5 GB and growing after 10 minutes,
# schlick_rgb out of memory at 19.6 GB after 11 minutes under a 20 GB limit.
BIG = pytest.mark.skipif(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") < 48 << 30,
                         reason="needs more than 20 GB under oclgrind (measured on 24 GB)")
ERRORS = ("Invalid read", "Invalid write", "Uninitialized", "data race", "FATAL", "out of bounds")


@pytest.mark.parametrize("name,width,precision", [
    ("ggx", 1, "single"), ("ggx", 4, "single"), ("ggx", 2, "double"),
    ("beckmann", 4, "single"), ("lambert", 1, "double"), ("ggx_rgb", 4, "single"),
    ("ggx_rgb", 1, "double"), ("schlick_rgb", 4, "single"), pytest.param("schlick_rgb", 1, "double", marks=BIG),
    ("low_smooth_rgb", 4, "single"), ("low_microfacet_rgb", 1, "double"),
    ("holzschuch_pacanowski_rgb", 4, "single"), pytest.param("sgd_bagher_rgb", 1, "double", marks=BIG), ("gtr", 4, "single"),
    ("sgd", 1, "double"), ("ashikhmin_shirley_rgb", 4, "single"), ("ashikhmin_shirley", 1, "double")])
def test_kernels_clean_under_oclgrind(tmp_path, name, width, precision, oclgrind_serial):
    script = tmp_path / "run.py"
    script.write_text(SCRIPT)
    env = dict(os.environ, CLBRDF_BUILD_OPTIONS=OCLGRIND_BUILD_OPTIONS)
    r = subprocess.run(["oclgrind", "--data-races", "--uninitialized", sys.executable, "-W", "ignore",
                        str(script), name, str(width), precision],
                       capture_output=True, text=True, env=env, timeout=1800)
    out = r.stdout + r.stderr
    assert r.returncode == 0, out[-3000:]
    assert "done" in r.stdout
    found = [ln for ln in out.splitlines() if any(e.lower() in ln.lower() for e in ERRORS)]
    assert not found, "\n".join(found[:20])
