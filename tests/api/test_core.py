"""Core properties of the kernels against the independent float64 reference (clbrdf.ref.microfacet).

Tolerances: single precision values agree to 2e-4 relative (float rounding through ~20 operations
and transcendental calls, plus the ill-conditioning of h = normalize(wi + wo) near grazing);
double precision to 1e-9 relative. Monte Carlo results agree within 4 standard errors
(two-sided probability of a false failure 6e-5 per comparison).
"""
import numpy as np
import pytest

import clbrdf
from clbrdf.ref import microfacet as R

CONFIGS = [
    ("lambert", dict(kd=0.7)),
    ("ggx", dict(alpha=0.3)),
    ("ggx", dict(alpha_x=0.5, alpha_y=0.1, fresnel="schlick", f0=0.2, kd=0.3)),
    ("ggx", dict(alpha=0.05, masking="separable", fresnel="dielectric", eta=1.5, sampler="ndf")),
    ("beckmann", dict(alpha=0.4, masking="vcavity", fresnel="conductor", eta=0.2, k=3.0)),
    ("beckmann", dict(alpha_x=0.2, alpha_y=0.6, masking="none", kd=0.1)),
    ("beckmann", dict(alpha=0.1, sampler="ndf", masking="correlated")),
]


def ref_params(kw):
    """Reference keywords for a kernel configuration (the reference calls the lobe sampler
    `lobe_sampler`)."""
    kw = dict(kw)
    if "sampler" in kw:
        kw["lobe_sampler"] = kw.pop("sampler")
    return kw


def directions(rng, n, min_z=1e-3):
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v[:, 2] = np.maximum(v[:, 2], min_z)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("name,kw", CONFIGS)
@pytest.mark.parametrize("precision,rtol", [("single", 2e-4), ("double", 1e-9)])
def test_eval_pdf_match_reference(name, kw, precision, rtol):
    rng = np.random.default_rng(1)
    wi, wo = directions(rng, 4000), directions(rng, 4000)
    m = clbrdf.Model(name, precision=precision, **kw)
    f = m.eval(wo, wi).astype(np.float64)
    fr = R.eval(name, wo, wi, **ref_params(kw))
    np.testing.assert_allclose(f, fr, rtol=rtol, atol=rtol * 1e-3 * np.max(fr))
    p = m.pdf(wo, wi).astype(np.float64)
    pr = R.pdf(name, wo, wi, sampler="brdf", **ref_params(kw))
    np.testing.assert_allclose(p, pr, rtol=rtol, atol=rtol * 1e-3 * np.max(pr))


@pytest.mark.parametrize("name,kw", CONFIGS)
def test_sample_weight_is_f_cos_over_pdf(name, kw):
    rng = np.random.default_rng(3)
    wo = directions(rng, 20000, min_z=0.05)
    m = clbrdf.Model(name, precision="double", **kw)
    wi, weight, pdf = m.sample(wo, seed=5)
    ok = wi[:, 2] > 0
    assert np.all(weight[~ok] == 0)
    np.testing.assert_allclose(pdf[ok], m.pdf(wo[ok], wi[ok]), rtol=1e-9)
    expect = m.eval(wo[ok], wi[ok]) * wi[ok, 2] / m.pdf(wo[ok], wi[ok])
    np.testing.assert_allclose(weight[ok], expect, rtol=1e-8)


@pytest.mark.parametrize("name,kw", CONFIGS)
@pytest.mark.parametrize("estimator,qmc", [("brdf", False)] + [
    pytest.param(e, q, marks=pytest.mark.slow)    # every estimator: tests/runtime/test_sampling.py
    for e, q in (("uniform", False), ("cosine", True), ("brdf", True), ("mis", False))])
def test_albedo_within_4_stderr_of_reference(name, kw, estimator, qmc):
    mu = np.array([0.08, 0.4, 0.95])
    phi = 0.7 if "alpha_x" in kw else 0.0
    m = clbrdf.Model(name, **kw)
    r = clbrdf.albedo(m, mu, phi, estimator=estimator, qmc=qmc, samples=1 << 18, seed=11)
    ref = np.array([R.albedo(name, u, phi, **ref_params(kw))[0] for u in mu])
    assert np.all(np.isfinite(r.albedo)) and np.all(r.stderr >= 0)
    # 4 standard errors, plus single-precision rounding of the sums (a zero-variance estimator,
    # such as cosine sampling of a Lambertian, has stderr 0)
    assert np.all(np.abs(r.albedo - ref) <= 4 * r.stderr + 2e-6 * np.abs(ref)), (r.albedo, ref, r.stderr)


@pytest.mark.parametrize("width", [1, 4, 8])
def test_widths_agree(width):
    """Scalar and vector lanes compute the same values (to float rounding) from the same numbers."""
    rng = np.random.default_rng(4)
    wi, wo = directions(rng, 999), directions(rng, 999)
    u = rng.random((999, 4))
    kw = dict(alpha_x=0.3, alpha_y=0.1, fresnel="conductor", kd=0.2)
    a, b = clbrdf.Model("ggx", width=16, **kw), clbrdf.Model("ggx", width=width, **kw)
    np.testing.assert_allclose(a.eval(wo, wi), b.eval(wo, wi), rtol=1e-5)
    sa, sb = a.sample(wo, u), b.sample(wo, u)
    for x, y in zip(sa, sb):
        np.testing.assert_allclose(x, y, rtol=1e-4, atol=1e-6)
    np.testing.assert_array_equal(a.random(100, seed=3), b.random(100, seed=3))


def test_single_matches_double_for_albedo():
    kw = dict(alpha=0.2, fresnel="schlick", f0=0.5)
    s = clbrdf.albedo(clbrdf.Model("beckmann", **kw), [0.2, 0.7], samples=1 << 16, seed=1)
    d = clbrdf.albedo(clbrdf.Model("beckmann", precision="double", **kw), [0.2, 0.7],
                      samples=1 << 16, seed=1)
    # same random numbers to 2^-24: the estimates differ far less than their error
    assert np.all(np.abs(s.albedo - d.albedo) < 0.01 * s.stderr)


@pytest.mark.slow   # ~70 s; test_kernels.py::test_no_nan_or_inf_at_extremes covers every config in the default run
@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("name", ["ggx", "beckmann"])
def test_no_nan_or_inf_at_extremes(name, precision):
    mu = np.array([1e-6, 1e-4, 1e-2, 0.5, 1.0])
    for kw in (dict(alpha=1e-4), dict(alpha=10.0), dict(alpha_x=1e-4, alpha_y=1.0),
               dict(alpha=1e-4, fresnel="conductor", kd=0.5), dict(alpha=3.0, fresnel="dielectric")):
        for sampler in ("vndf", "ndf"):
            m = clbrdf.Model(name, precision=precision, sampler=sampler, **kw)
            for est in ("uniform", "brdf", "mis"):
                r = clbrdf.albedo(m, mu, 0.3, estimator=est, samples=1 << 12)
                assert np.all(np.isfinite(r.albedo)) and np.all(np.isfinite(r.stderr)), (kw, est)
            s = np.sqrt(1 - mu ** 2)
            wo = np.stack([s, 0 * s, mu], -1)
            wi, w, p = m.sample(np.repeat(wo, 400, 0), seed=2)
            assert np.all(np.isfinite(wi)) and np.all(np.isfinite(w)) and np.all(np.isfinite(p)), kw
            wi2 = np.stack([-s, 0 * s, mu], -1)
            for a in (wo, wi2):
                for b in (wo, wi2):
                    assert np.all(np.isfinite(m.eval(b, a))) and np.all(np.isfinite(m.pdf(a, b))), kw


def test_albedo_bit_identical_across_chunking_and_runs():
    m = clbrdf.Model("ggx", alpha=np.linspace(0.1, 0.9, 5))
    a = clbrdf.albedo(m, 0.5, samples=50_000, seed=9)
    b = clbrdf.albedo(m, 0.5, samples=50_000, seed=9)
    np.testing.assert_array_equal(a.albedo, b.albedo)
    # the same job split into launches of one block each (launch size is internal: force it)
    from clbrdf.runtime import albedo as runtime
    old = runtime.LAUNCH_SAMPLES
    runtime.LAUNCH_SAMPLES = 1
    try:
        c = clbrdf.albedo(m, 0.5, samples=50_000, seed=9)
    finally:
        runtime.LAUNCH_SAMPLES = old
    np.testing.assert_array_equal(a.albedo, c.albedo)
    np.testing.assert_array_equal(a.stderr, c.stderr)


def test_qmc_error_is_smaller_than_mc():
    m = clbrdf.Model("ggx", alpha=0.4)
    mc = clbrdf.albedo(m, 0.6, samples=1 << 18)
    qmc = clbrdf.albedo(m, 0.6, samples=1 << 18, qmc=True)
    assert qmc.stderr < 0.5 * mc.stderr
    assert abs(qmc.albedo - mc.albedo) < 4 * mc.stderr


def test_bad_input_names_parameter_and_range():
    with pytest.raises(clbrdf.ParameterError, match=r"alpha=-0.1.*\[0.0001, 10\]"):
        clbrdf.Model("ggx", alpha=-0.1)
    with pytest.raises(clbrdf.ParameterError, match="eta"):
        clbrdf.Model("ggx", fresnel="dielectric", eta=0.0)
    with pytest.raises(clbrdf.ParameterError, match="alpha=nan"):
        clbrdf.Model("ggx", alpha=float("nan"))
    with pytest.raises(clbrdf.ParameterError, match="unknown model"):
        clbrdf.Model("phong")
    with pytest.raises(clbrdf.ParameterError, match="not a unit vector"):
        clbrdf.Model("ggx").sample([[0.0, 0.5, 0.5]])
    with pytest.raises(clbrdf.ParameterError, match="below the horizon"):
        clbrdf.Model("ggx").sample([[0.6, 0.0, -0.8]])
    with pytest.raises(clbrdf.ParameterError, match="mu"):
        clbrdf.albedo(clbrdf.Model("ggx"), 0.0)


def test_albedo_takes_a_model_name():
    """clbrdf.albedo("ggx", mu=0.5) raised AttributeError; the table functions take names."""
    r = clbrdf.albedo("ggx", mu=0.5, samples=1 << 10)
    d = clbrdf.albedo(clbrdf.Model("ggx"), mu=0.5, samples=1 << 10)
    assert r.albedo == d.albedo and r.stderr == d.stderr
    a = clbrdf.albedo_avg("lambert", samples=64, estimator="cosine")
    assert np.allclose(a[0], 1.0)           # kd defaults to 1
    with pytest.raises(clbrdf.ParameterError, match="model"):
        clbrdf.albedo(3, mu=0.5)
