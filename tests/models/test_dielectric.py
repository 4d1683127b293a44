"""The rough dielectric's own claims (docs/models/dielectric.md): the smooth limit, eta = 1 as no
interface, the two sides, the transport conventions, and its bad input. The shared battery
(tests/models/test_conformance.py, tests/studies/test_check.py) covers eval, pdf, sampling and albedo against the
float64 reference."""
import warnings

import numpy as np
import pytest

import clbrdf
from clbrdf.ref.microfacet import fresnel
from cliutil import run_inprocess


def _Ee(mu, **kw):
    """E and the quadrature's error estimate (double precision; tol 1e-8, which a one-branch
    integrand with its kink at the critical angle may stop short of: then the estimate says so)."""
    m = clbrdf.Model("ggx_dielectric", precision="double", **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        r = clbrdf.albedo(m, mu, estimator="quadrature", tol=1e-8)
    return float(r.albedo), float(r.stderr)


def _E(mu, **kw):
    return _Ee(mu, **kw)[0]


@pytest.mark.parametrize("eta", [1.5, 0.7])
def test_smooth_limit_reflects_F_and_transmits_1_minus_F(eta):
    """At alpha = 1e-4 E_R = F(mu) and E_T = 1 - F(mu) (importance) within 1e-5, on both sides
    of the critical angle of eta = 0.7 (mu_c = 0.714), and E_T = (1 - F) / eta^2 in radiance."""
    for mu in (0.3, 0.75, 0.95):
        F = float(fresnel("dielectric", mu, eta=eta))
        r = _E(mu, alpha=1e-4, eta=eta, lobes="reflection")
        t = _E(mu, alpha=1e-4, eta=eta, lobes="transmission")
        t_rad = _E(mu, alpha=1e-4, eta=eta, lobes="transmission", transport="radiance")
        assert abs(r - F) < 1e-5 and abs(t - (1 - F)) < 1e-5, (mu, r, t, F)
        assert abs(t_rad - (1 - F) / eta ** 2) < 1e-5, (mu, t_rad)


def test_both_lobes_are_the_sum_of_each():
    for mu in (0.05, 0.5, -0.4):
        e, de = _Ee(mu, alpha=0.4, eta=1.33)
        r, dr = _Ee(mu, alpha=0.4, eta=1.33, lobes="reflection")
        t, dt = _Ee(mu, alpha=0.4, eta=1.33, lobes="transmission")
        assert abs(e - r - t) < de + dr + dt + 1e-9 and de + dr + dt < 2e-6, (mu, e, r, t)


def test_from_below_is_the_mirror_image_with_the_inverse_index():
    """E(-mu, eta) = E(mu, 1/eta), and eval of mirrored directions likewise, in both
    transports."""
    (a, da), (b, db) = _Ee(-0.6, alpha=0.3, eta=1.5), _Ee(0.6, alpha=0.3, eta=1 / 1.5)
    assert abs(a - b) < da + db + 1e-9
    rng = np.random.default_rng(4)
    w = rng.normal(size=(2, 256, 3))
    wo, wi = w / np.linalg.norm(w, axis=-1, keepdims=True)
    z = np.array([1.0, 1.0, -1.0])
    for transport in ("importance", "radiance"):
        a = clbrdf.Model("ggx_dielectric", precision="double", eta=1.5, transport=transport)
        b = clbrdf.Model("ggx_dielectric", precision="double", eta=1 / 1.5, transport=transport)
        np.testing.assert_allclose(a.eval(wo, wi), b.eval(wo * z, wi * z), rtol=1e-12)


def test_eta_one_is_no_interface():
    """The light passes straight through: the sampler returns wi = -wo with weight 1 and an
    infinite pdf, eval and pdf are 0, E = 1 by brdf, mis and the quadrature, from both sides;
    the uniform and cosine estimators are refused, as they cannot see a delta."""
    for precision in ("single", "double"):
        m = clbrdf.Model("ggx_dielectric", precision=precision, alpha=0.5, eta=1.0)
        wo = np.array([[0.6, 0.0, 0.8], [0.0, 0.6, -0.8], [1e-3, 0.0, np.sqrt(1 - 1e-6)]])
        wi, w, p = m.sample(wo, u=np.full((3, 4), 0.3))
        np.testing.assert_allclose(wi, -wo, atol=1e-6)
        assert np.all(w == 1) and np.all(np.isinf(p))
        assert np.all(m.eval(wo, -wo) == 0) and np.all(m.pdf(wo, -wo) == 0)
        for est in ("brdf", "mis", "quadrature"):
            r = clbrdf.albedo(m, [0.05, 0.5, 1.0, -0.3], estimator=est)
            np.testing.assert_allclose(r.albedo, 1.0, rtol=0, atol=1e-6)
        for est in ("uniform", "cosine"):
            with pytest.raises(clbrdf.ParameterError, match=f"estimator='{est}' cannot see the "
                                                            "delta lobe of eta = 1"):
                clbrdf.albedo(m, 0.5, estimator=est)
    # reflection only has no delta: every estimator gives 0
    m = clbrdf.Model("ggx_dielectric", eta=1.0, lobes="reflection")
    assert float(clbrdf.albedo(m, 0.5, estimator="uniform").albedo) == 0


def test_bad_input_is_refused_or_defined():
    """eta <= 0, NaN, beyond 100: an error naming eta and its range; a direction in the surface
    plane: f, pdf and the sample's weight 0, no NaN; mu = 0 is refused, mu < 0 is wo below for a
    model that transmits and refused for a reflection model; a reflection model's sampler
    refuses a wo below."""
    for eta in (0.0, -1.0, float("nan"), 1000.0, 0.001):
        with pytest.raises(clbrdf.ParameterError, match=r"eta=.* valid eta is in \[0.01, 100\]"):
            clbrdf.Model("ggx_dielectric", eta=eta)
    m = clbrdf.Model("ggx_dielectric")
    plane = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    other = np.array([[0.0, 0.0, -1.0], [0.3, 0.0, 0.9539392]])
    assert np.all(m.eval(plane, other) == 0) and np.all(m.eval(other, plane) == 0)
    assert np.all(m.pdf(plane, other) == 0)
    wi, w, p = m.sample(plane, u=np.full((2, 4), 0.4))
    assert np.all(np.isfinite(wi)) and np.all(w == 0) and np.all(p == 0)
    with pytest.raises(clbrdf.ParameterError, match=r"mu=0.0 is out of range.*\[-1, -1e-06\] or"):
        clbrdf.albedo(m, 0.0)
    with pytest.raises(clbrdf.ParameterError, match="mu=-0.5 is out of range"):
        clbrdf.albedo("ggx", -0.5)
    with pytest.raises(clbrdf.ParameterError, match="below the horizon"):
        clbrdf.Model("ggx").sample(np.array([0.0, 0.6, -0.8]))


def test_cli_takes_directions_below_for_a_bsdf():
    r = run_inprocess("albedo", "ggx_dielectric", "--mu=-0.5,0.5", "-p", "eta=1.33",
                      "--estimator", "quadrature", "--precision", "double", "--json")
    assert r.returncode == 0, r.stderr
    r = run_inprocess("eval", "ggx_dielectric", "--wo", "0,0,1", "--wi", "0.1,0,-0.99498744")
    assert r.returncode == 0 and float(r.stdout) > 0, r.stderr
    r = run_inprocess("albedo", "ggx_dielectric", "--mu", "0.5", "-p", "eta=1",
                      "--estimator", "uniform")
    assert r.returncode != 0 and "--estimator=uniform cannot see the delta" in r.stderr
    r = run_inprocess("eval", "ggx", "--wo", "0,0,1", "--wi", "0.1,0,-0.99498744")
    assert r.returncode != 0 and "below the horizon" in r.stderr


@pytest.mark.parametrize("name, kw", [("ggx_dielectric", {"alpha": 0.4, "eta": 1.33}),
                                      ("ggx", {"alpha": 0.3, "kd": 0.2})])
def test_three_number_estimates_use_rand_philox_triple(name, kw):
    """A sampler of three numbers (a branch or a lobe picked by u2) draws them four samples per
    three Philox calls (integrators.cl, RNG_TRIPLES); rand_philox_triple (rng.h) gives the same
    numbers one sample at a time: the mean of Model.sample's weights at them is clbrdf.albedo's
    brdf estimate, in double precision, to rounding (also for counts that are not a multiple of
    the four samples a lane takes)."""
    from clbrdf.runtime.build import run_functions
    from clbrdf.runtime.launch import seed_words
    lo, hi = seed_words(5)
    src = ("__kernel void f(global const real_t *S, global real_t *A, global real_t *B, "
           "global real_t *C) { size_t i = get_global_id(0);"
           f" rand4 u = rand_philox_triple((uint)S[i], 0, 0, {int(lo)}u, {int(hi)}u);"
           " A[i] = u.u0; B[i] = u.u1; C[i] = u.u2; }")
    m = clbrdf.Model(name, precision="double", **kw)
    for n in (1000, 4096):
        u0, u1, u2 = run_functions(("common.h", "rng.h"), src, "f", [np.arange(n, dtype=float)],
                                   outputs=3)
        u = np.stack([u0, u1, u2, np.full(n, 0.5)], -1)
        wo = np.broadcast_to([0.6, 0.0, 0.8], (n, 3))
        _, w, _ = m.sample(wo, u=u)
        r = clbrdf.albedo(m, 0.8, samples=n, seed=5)
        assert abs(float(np.mean(w)) - float(r.albedo)) < 1e-12, (n, np.mean(w), r.albedo)
