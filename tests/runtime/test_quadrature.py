"""estimator='quadrature': deterministic adaptive Gauss-Legendre panels in the sampler's own unit
square (kernels/integrators.cl, quadrature_panels; clbrdf/runtime/quadrature.py, run_quadrature), against
the float64 reference's independent quadrature (clbrdf.ref).

Claim (docs/guide.md, docs/accuracy/quadrature.md): within tol (1e-6 single, 1e-7 double by default)
of the reference, with an error estimate at most tol, for every model at its defaults and at
roughness 1e-3, mu from 1e-3 to 1, except the cases the models' descriptions list (``LIMITS``, strict xfails: each must
still fail). Models that tabulate Smith's Lambda or G1 differ from the reference by the tables'
documented accuracy (docs/models.md: |dG1| <= 2e-4 GTR, 1e-4 SGD, 1e-5 exp-power), which adds
3 |dG1| E to the bound (G changes by at most |dG1 / G1| per direction, twice in G).
The default run takes a few cases; ``-m slow`` every model, case, precision and mu.
"""
import warnings

import numpy as np
import pytest

import clbrdf
from clbrdf.runtime import quadrature as runtime
from clbrdf.api.albedo import QUAD_TOL
from clbrdf.models import MODELS, get_spec
from known import known
from clbrdf.ref import reference

MUS = (1e-3, 0.02, 0.05, 0.2, 0.5, 0.8, 1.0)
ROUGH = {n: s.facts.roughest for n, s in MODELS.items() if s.facts.roughest}
CASES = [(n, "defaults", {}) for n in MODELS] + [(n, "rough", kw) for n, kw in ROUGH.items()]
# where the quadrature is off by more than the bound, or 2^24 evaluations do not bring its
# estimate to tol (a RuntimeWarning says so): each model's description (tests/known.py)
LIMITS = known("quadrature")

_REF: dict = {}


def _reference(name, kw, mu):
    key = (name, repr(sorted(kw.items())), mu)
    if key not in _REF:
        _REF[key] = float(np.ravel(reference(name, **kw).albedo(mu, 0.0, 1e-11)[0])[0])
    return _REF[key]


def _bound(name, precision, e_ref):
    return QUAD_TOL[precision] + 3 * get_spec(name).facts.lambda_g1_error * abs(e_ref)


FAST = {("ggx", "defaults", "single"), ("ggx", "defaults", "double"), ("ggx", "rough", "double"),
        ("beckmann", "defaults", "single"), ("ward", "defaults", "double"),
        ("lambert", "defaults", "double"), ("low_smooth", "defaults", "double"),
        ("schlick", "defaults", "single")}
FAST_MUS = (0.02, 0.5, 1.0)


def _params():
    for name, case, kw in CASES:
        for prec in ("single", "double"):
            for mu in MUS:
                marks = [] if (name, case, prec) in FAST and mu in FAST_MUS else [pytest.mark.slow]
                if (name, case, prec, mu) in LIMITS:
                    marks.append(pytest.mark.xfail(strict=True,
                                                   reason=LIMITS[name, case, prec, mu]))
                yield pytest.param(name, kw, prec, mu, marks=marks, id=f"{name}-{case}-{prec}-{mu:g}")


@pytest.mark.parametrize("name, kw, precision, mu", list(_params()))
def test_quadrature_matches_reference(name, kw, precision, mu, model_cache):
    """|E - E_ref| <= tol (+ the tables' bound) and the error estimate <= tol."""
    m = model_cache(name, precision=precision, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)       # not converging is a failure
        r = clbrdf.albedo(m, mu, estimator="quadrature")
    e_ref = _reference(name, kw, mu)
    e, err = float(np.ravel(r.albedo)[0]), float(np.ravel(r.stderr)[0])
    assert err <= QUAD_TOL[precision]
    assert abs(e - e_ref) <= _bound(name, precision, e_ref), (e, e_ref, e - e_ref, err)


def test_quadrature_rgb_and_mixture_lobes(model_cache):
    """An RGB preset (low_microfacet alum-bronze: a cosine lobe and a microfacet lobe, per-channel
    parameters) and a three-lobe sampler (low_smooth with a diffuse term and two lobes): every
    channel within tol of the reference, double precision."""
    for name, kw in (("low_microfacet", {"preset": "alum-bronze"}),
                     ("low_smooth", {"kd": 0.3, "a2": 0.5, "b2": 3.0})):
        m = model_cache(name, precision="double", **kw)
        ref = reference(m)
        for mu in (0.3, 0.9):
            r = clbrdf.albedo(m, mu, estimator="quadrature")
            e_ref = np.ravel(ref.albedo(mu, 0.0, 1e-11)[0])
            np.testing.assert_allclose(np.ravel(r.albedo), e_ref, rtol=0, atol=1e-7)
            assert np.all(np.asarray(r.stderr) <= 1e-7)


def test_quadrature_is_deterministic_and_split_independent(monkeypatch, model_cache):
    """Bit-identical on repeat and when the points are refined one at a time instead of together
    (each panel is integrated alone; a point's sum runs in a fixed panel order)."""
    m = model_cache("ggx", precision="double", alpha=np.array([0.05, 0.3, 0.9])[:, None], kd=0.2)
    mu = np.array([0.1, 0.6, 1.0])
    a = clbrdf.albedo(m, mu, estimator="quadrature", tol=1e-6)
    b = clbrdf.albedo(m, mu, estimator="quadrature", tol=1e-6)
    monkeypatch.setattr(runtime, "QUAD_GROUP", 1)
    c = clbrdf.albedo(m, mu, estimator="quadrature", tol=1e-6)
    for r in (b, c):
        np.testing.assert_array_equal(r.albedo, a.albedo)
        np.testing.assert_array_equal(r.stderr, a.stderr)
        np.testing.assert_array_equal(r.evaluations, a.evaluations)
    assert a.albedo.shape == (3, 3) and a.samples == a.evaluations.max()


def test_quadrature_tighter_tol_costs_more_and_gets_closer(model_cache):
    """The error estimate follows tol down, the evaluations go up, and the error follows."""
    m = model_cache("beckmann", precision="double", alpha=0.2)
    e_ref = _reference("beckmann", {"alpha": 0.2}, 0.4)
    prev = None
    for tol in (1e-4, 1e-6, 1e-8):
        r = clbrdf.albedo(m, 0.4, estimator="quadrature", tol=tol)
        assert r.stderr <= tol and abs(r.albedo - e_ref) <= tol
        if prev is not None:
            assert r.samples > prev
        prev = r.samples


def test_quadrature_warns_when_it_stops_short(model_cache):
    """A point that max_evals cannot bring to tol is reported: a RuntimeWarning naming the
    count, and its error estimate above tol in the result."""
    m = model_cache("ashikhmin_shirley", precision="double")
    with pytest.warns(RuntimeWarning, match=r"1 of 2 points stopped at max_evals=262144"):
        r = clbrdf.albedo(m, [0.02, 1.0], estimator="quadrature", tol=1e-9, max_evals=1 << 18)
    assert r.stderr[0] > 1e-9


@pytest.mark.parametrize("kw, match", [
    ({"qmc": True}, "qmc=True is not valid"), ({"tol": 0.0}, "tol=0.0 is out of range"),
    ({"tol": 1.5}, "tol=1.5 is out of range"), ({"max_evals": 10}, "max_evals=10 is out of range")])
def test_quadrature_bad_arguments(kw, match, model_cache):
    m = model_cache("ggx")
    with pytest.raises(clbrdf.ParameterError, match=match):
        clbrdf.albedo(m, 0.5, estimator="quadrature", **kw)


def test_tol_is_refused_for_monte_carlo(model_cache):
    with pytest.raises(clbrdf.ParameterError, match="tol and max_evals are for estimator="):
        clbrdf.albedo(model_cache("ggx"), 0.5, estimator="brdf", tol=1e-6)


def test_quadrature_host_memory_does_not_grow_with_points(model_cache):
    """Points are refined QUAD_GROUP at a time: the peak of host allocations (tracemalloc, which
    sees NumPy's) for 8 x QUAD_GROUP points that all run to max_evals is within 1.5x of that for
    QUAD_GROUP points (plus the per-point results, 1 kB each at most)."""
    import tracemalloc
    peaks = []
    for k in (runtime.QUAD_GROUP, 8 * runtime.QUAD_GROUP):
        m = model_cache("ashikhmin_shirley", nu=np.linspace(80, 120, k))
        tracemalloc.start()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            r = clbrdf.albedo(m, 0.02, estimator="quadrature", tol=1e-12, max_evals=1 << 20)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        assert np.all(r.evaluations >= (1 << 20) - 4 * 405)   # every point ran to the cap
    assert peaks[1] <= 1.5 * peaks[0] + 1024 * 8 * runtime.QUAD_GROUP, peaks
