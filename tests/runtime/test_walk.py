"""The random walk in the kernels (kernels/heitz_ms.h, clbrdf.walk_albedo / walk_sample):
its single scattering against the models it extends (ggx and beckmann with correlated masking,
any Fresnel, anisotropic, RGB; ggx_dielectric and beckmann_dielectric with masking=beta, from
either side), its energy (every F = 1
walk leaves with weight 1; the length bound cuts exactly the higher orders), agreement with
the float64 reference walk (clbrdf/ref/heitz_ms.py), and its samples. Statistical bounds:
two-sided Sidak over the file's comparisons, family-wise 1e-3."""
import numpy as np
import pytest
from scipy import stats as sps

import clbrdf
from clbrdf.ref import heitz_ms as H
from clbrdf.studies.stats import sidak

SS = [("ggx", dict(alpha=0.1), 0.2, 0.0), ("ggx", dict(alpha=1.0), 0.05, 0.0),
      ("ggx", dict(alpha=0.6, fresnel="schlick", f0=0.3), 0.5, 0.0),
      ("ggx", dict(alpha_x=0.05, alpha_y=0.6), 0.4, 0.7),
      ("ggx", dict(alpha=0.4, preset="gold"), 0.3, 0.0),
      ("ggx_dielectric", dict(alpha=0.5, eta=1.5, masking="beta"), 0.3, 0.0),
      ("ggx_dielectric", dict(alpha=0.3, eta=1.33, masking="beta"), -0.6, 0.0),
      ("beckmann", dict(alpha=1.0), 0.05, 0.0),
      ("beckmann", dict(alpha_x=0.9, alpha_y=0.2, fresnel="schlick", f0=0.4), 0.5, 1.1),
      ("beckmann_dielectric", dict(alpha=0.7, eta=1.5, masking="beta"), 0.2, 0.0),
      ("beckmann_dielectric", dict(alpha=0.4, eta=1.5, masking="beta"), -0.5, 0.0)]
Z = float(sps.norm.isf(sidak(1e-3, 4 * len(SS) + 14) / 2))
WALKS = 1 << 18


def _model(name, kw, precision):
    return clbrdf.model(name, precision=precision, **kw)


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("k", range(len(SS)))
def test_single_scattering_is_the_model(k, precision):
    """The walks that leave after one hit carry the model's albedo (its deterministic
    quadrature, double precision): E_R and E_T apart for the dielectric."""
    name, kw, mu, phi = SS[k]
    m = _model(name, kw, precision)
    r = clbrdf.walk_albedo(m, mu, phi, walks=WALKS, seed=10 + k)
    assert np.all(r.cut == 0)
    one = np.atleast_1d(r.orders[..., 0, :] if m.channels > 1 else r.orders[..., 0])
    err = np.atleast_1d(r.orders_stderr[..., 0, :] if m.channels > 1 else r.orders_stderr[..., 0])
    ref = clbrdf.albedo(_model(name, kw, "double"), mu, phi, estimator="quadrature", tol=1e-6)
    e = np.atleast_1d(ref.albedo)
    assert np.all(np.abs(one - e) <= Z * err + 1e-7), (one, e, (one - e) / err)
    if name.endswith("_dielectric"):
        # the single-scattering split by side: walks leaving above vs the reflection lobe
        w = clbrdf.walk_sample(m, np.broadcast_to(_wo(mu, phi), (WALKS, 3)), seed=20 + k)
        same = np.sign(w[0][:, 2]) == np.sign(mu)
        rr = np.mean((w[2] == 1) & same)
        er = float(clbrdf.albedo(_model(name, {**kw, "lobes": "reflection"}, "double"), mu,
                                 phi, estimator="quadrature", tol=1e-6).albedo)
        assert abs(rr - er) <= Z * np.sqrt(er * (1 - er) / WALKS) + 1e-7, (rr, er)


def _wo(mu, phi):
    s = np.sqrt(1 - mu * mu)
    return np.array([s * np.cos(phi), s * np.sin(phi), mu])


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
@pytest.mark.parametrize("alpha", [0.05, 1.0, 2.0])
def test_every_walk_leaves_with_weight_one(alpha, dist):
    """F = 1: E = 1 exactly (no walk cut at max_order 64, mu 0.05, 2^18 walks); at max_order 2
    the cut walks are exactly the order-3-and-more share of the same keys. The dielectric (every
    weight 1, energy): E_R + E_T = 1 with none cut, from above and below."""
    m = clbrdf.model(dist, alpha=alpha, precision="single")
    r = clbrdf.walk_albedo(m, 0.05, walks=WALKS, seed=3)
    assert r.albedo == 1 and r.stderr == 0 and r.cut == 0 and r.mean_hits >= 1
    r2 = clbrdf.walk_albedo(m, 0.05, walks=WALKS, seed=3, max_order=2)
    assert r2.cut == pytest.approx(r.orders[2], abs=0.5 / WALKS)
    assert r2.albedo == pytest.approx(1 - r.orders[2], abs=0.5 / WALKS)
    g = clbrdf.model(f"{dist}_dielectric", alpha=alpha, eta=1.5, masking="beta",
                     precision="single")
    rg = clbrdf.walk_albedo(g, [0.05, -0.05, -0.9], walks=WALKS, seed=4)
    assert np.all(rg.cut == 0)
    assert np.all(rg.reflected + rg.transmitted == 1) and np.all(rg.albedo == 1)


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
def test_kernel_walk_agrees_with_the_reference_walk(dist):
    """Gold (RGB, preset), anisotropic, at three mu: the kernel's E by order against the float64
    NumPy walk's (independent numbers; Beckmann's visible normals below the horizon by rejection
    in the kernel, by inverting their CDF in the reference), two-sample z within the Sidak
    bound."""
    m = clbrdf.model(dist, alpha_x=0.8, alpha_y=0.3, preset="gold", precision="single")
    p = m.params
    mus = np.array([0.1, 0.5, 0.95])
    r = clbrdf.walk_albedo(m, mus, 0.4, walks=WALKS, seed=5)
    for j, mu in enumerate(mus):
        # one reference walk per channel, the same seed: the paths do not depend on F
        wt = np.stack([H.walk(_wo(mu, 0.4), WALKS // 2, dist=dist, alpha_x=0.8, alpha_y=0.3,
                              seed=50 + j, fresnel_kind="conductor", eta=float(p["eta"][c]),
                              k=float(p["k"][c]))[1] for c in range(3)], -1)
        order = H.walk(_wo(mu, 0.4), WALKS // 2, dist=dist, alpha_x=0.8, alpha_y=0.3,
                       seed=50 + j)[2]
        for cls, sel in enumerate((order == 1, order == 2, order >= 3)):
            x = wt * sel[:, None]
            e, s = x.mean(axis=0), x.std(axis=0) / np.sqrt(len(x))
            z = (r.orders[j, cls] - e) / np.hypot(s, r.orders_stderr[j, cls])
            assert np.all(np.abs(z) <= Z), (mu, cls, z)


def test_walk_samples_are_keyed_by_index():
    """walk_sample's walk first + i is the same walk in any call (bit for bit), and its orders
    have the distribution of walk_albedo's (a chi-square test of the order classes)."""
    m = clbrdf.model("ggx", alpha=0.7, fresnel="schlick", f0=0.5, precision="single")
    wo = np.broadcast_to(_wo(0.3, 0.0), (4096, 3))
    a = clbrdf.walk_sample(m, wo, seed=9)
    b = clbrdf.walk_sample(m, wo[:1000], seed=9, first=3000)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x[3000:4000], y)
    wi, w, order = clbrdf.walk_sample(m, np.broadcast_to(_wo(0.3, 0.0), (WALKS, 3)), seed=11)
    assert np.all(wi[:, 2] > 0) and np.all(order >= 1)
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1, atol=1e-5)
    r = clbrdf.walk_albedo(m, 0.3, walks=WALKS, seed=12)
    counts = np.array([np.sum(order == 1), np.sum(order == 2), np.sum(order >= 3)])
    e = np.array([np.mean(w * (order == 1)), np.mean(w * (order == 2)), np.mean(w * (order >= 3))])
    z = (e - r.orders) / np.hypot(r.orders_stderr, np.sqrt(
        [np.var(w * (order == c)) for c in (1, 2)] + [np.var(w * (order >= 3))]) / np.sqrt(WALKS))
    assert np.all(np.abs(z) <= Z), z
    assert counts.sum() == WALKS


@pytest.mark.parametrize("name, kw, what", [
    ("ggx", dict(masking="separable"), "masking='separable'"),
    ("ggx", dict(kd=0.5), "kd"),
    ("ggx_dielectric", dict(), "masking='correlated'"),
    ("ggx_dielectric", dict(masking="beta", lobes="reflection"), "lobes='reflection'"),
    ("beckmann", dict(masking="vcavity"), "masking='vcavity'"),
    ("gtr", dict(), "model='gtr'")])
def test_configurations_the_walk_does_not_extend_are_refused(name, kw, what):
    m = clbrdf.model(name, **kw)
    with pytest.raises(clbrdf.ParameterError, match=what.replace("(", r"\(")):
        clbrdf.walk_albedo(m, 0.5, walks=16)
    with pytest.raises(clbrdf.ParameterError, match="walks"):
        clbrdf.walk_albedo("ggx", 0.5, walks=1)


def _pairs():
    """(wo, wi): three pairs apart from the mirror directions, one grazing."""
    wo = np.stack([_wo(0.5, 0.3), _wo(0.2, 1.0), _wo(0.9, 2.0)])
    wi = np.stack([_wo(0.6, 3.0), _wo(0.3, 0.5), _wo(0.15, 2.0)])
    return wo, wi


EVAL = [("ggx", dict(alpha=0.5)), ("ggx", dict(alpha=0.4, preset="gold")),
        ("beckmann", dict(alpha_x=0.7, alpha_y=0.3, fresnel="schlick", f0=0.5))]
ZE = float(sps.norm.isf(sidak(1e-3, 3 * len(EVAL) * 2 + 2 * 4 + 2 * 3) / 2))


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("k", range(len(EVAL)))
def test_stochastic_evaluation_first_order_is_the_model(k, precision):
    """walk_eval's order-1 estimate against the model's f in the same precision (single: the
    Beckmann pair at mu 0.2 / 0.3 is 2e-36 in double, where single's D underflows to 0 in both),
    per pair and channel, within the Sidak bound of its own error bar."""
    name, kw = EVAL[k]
    wo, wi = _pairs()
    r = clbrdf.walk_eval(_model(name, kw, precision), wo, wi, walks=1 << 17, seed=30 + k)
    f = _model(name, kw, precision).eval(wo, wi)
    one, err = r.orders[:, 0], r.orders_stderr[:, 0]
    assert np.all(r.cut == 0) and np.all(r.f >= one)
    assert np.all(np.abs(one - f) <= ZE * err + 1e-7 * f), (one, f, (one - f) / err)


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
def test_stochastic_evaluation_agrees_with_the_reference(dist):
    """The kernel's estimate by order against clbrdf.ref.heitz_ms.evaluate's (float64 NumPy,
    independent numbers): two-sample z within the Sidak bound."""
    wo, wi = _pairs()
    kw = dict(alpha_x=0.6, alpha_y=0.6)
    r = clbrdf.walk_eval(clbrdf.model(dist, alpha=0.6, fresnel="schlick", f0=0.7), wo[:2],
                         wi[:2], walks=1 << 18, seed=40)
    for j in range(2):
        e = H.evaluate(wo[j], wi[j], 1 << 16, dist=dist, seed=41 + j, fresnel_kind="schlick",
                       f0=0.7, **kw) / wi[j, 2]
        z = (r.orders[j] - e.mean(0)) / np.hypot(r.orders_stderr[j], e.std(0) / np.sqrt(len(e)))
        assert np.all(np.abs(z) <= ZE), (j, z)


@pytest.mark.parametrize("dist", ["ggx", "beckmann"])
def test_stochastic_evaluation_integrates_to_the_sampled_energy(dist):
    """Per order, the integral of the evaluated f cos over wi (Gauss-Legendre in mu_i, 24 x 48
    points, 2^12 walks each) equals walk_albedo's energy of that order (independent walks):
    the estimator and the sampler are the same BSDF. Quadrature error at alpha 0.7 below 1e-4."""
    m = clbrdf.model(dist, alpha=0.7, fresnel="schlick", f0=0.6)
    x, w = np.polynomial.legendre.leggauss(24)
    mu, wmu = (x + 1) / 2, w / 2
    phi = (np.arange(48) + 0.5) * 2 * np.pi / 48
    M, P = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - M * M)
    wi = np.stack([s * np.cos(P), s * np.sin(P), M], -1)
    wo = np.broadcast_to(_wo(0.4, 0.0), wi.shape)
    r = clbrdf.walk_eval(m, wo, wi, walks=1 << 12, seed=50)
    q = (wmu[:, None] * M * 2 * np.pi / 48)[..., None]
    e = (r.orders * q).sum(axis=(0, 1))
    err = np.sqrt(((r.orders_stderr * q) ** 2).sum(axis=(0, 1)))
    a = clbrdf.walk_albedo(m, 0.4, walks=1 << 20, seed=51)
    z = (e - a.orders) / np.hypot(err, a.orders_stderr)
    assert np.all(np.abs(z) <= ZE), (e, a.orders, z)


def test_stochastic_evaluation_refuses_what_it_does_not_do():
    g = clbrdf.model("ggx_dielectric", masking="beta")
    with pytest.raises(clbrdf.ParameterError, match="conductors"):
        clbrdf.walk_eval(g, _wo(0.5, 0), _wo(0.5, 1))
    with pytest.raises(clbrdf.ParameterError, match="wi"):
        clbrdf.walk_eval("ggx", _wo(0.5, 0), [0.0, 0.0, -1.0])


def test_reflected_and_transmitted_are_relative_to_wo():
    """reflected meant 'left above': from inside (mu = -0.3, eta 2.4) it read 0.05, which was
    the transmission. Now E_R is the walks that leave on wo's side and E_T the others; above
    and below keep the sides. Beyond the critical angle (mu 0.3 < 0.909 inside eta 2.4) a
    smooth-ish interface reflects almost all."""
    g = clbrdf.model("ggx_dielectric", alpha=0.05, eta=2.4, masking="beta", precision="single")
    r = clbrdf.walk_albedo(g, [0.3, -0.3], walks=1 << 16, seed=5)
    assert np.array_equal(r.reflected, [r.above[0], r.below[1]])
    assert np.array_equal(r.transmitted, [r.below[0], r.above[1]])
    assert r.reflected[1] > 0.9 and r.transmitted[1] < 0.1
    m = clbrdf.model("ggx_dielectric", alpha=0.05, eta=2.4, lobes="reflection")
    e_r = clbrdf.albedo(m, mu=0.3, estimator="quadrature").albedo
    assert r.reflected[0] == pytest.approx(e_r, abs=0.01)      # single scattering dominates
