"""Tests of clbrdf.ref.microfacet against independent results: closed forms, the integral
definitions of docs/models/microfacet.md evaluated with scipy.integrate, and brute-force quadrature
over the hemisphere in other coordinates than the integrator's maps."""
import functools
import warnings

import numpy as np
import pytest
from scipy import integrate, optimize

from clbrdf.ref import microfacet as R
from clbrdf.ref.quadrature import spherical

DISTS = ("beckmann", "ggx")
ROUGH = [(1e-3, 1e-3), (0.05, 0.05), (0.3, 0.3), (1.0, 1.0), (0.01, 1.0), (0.3, 0.06)]


def quad(f, a, b, **kw):
    kw.setdefault("epsabs", 1e-12)
    kw.setdefault("epsrel", 1e-11)
    kw.setdefault("limit", 400)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        return integrate.quad(f, a, b, **kw)[0]


def P22(dist, x, a):
    """Slope function of docs/models/microfacet.md, x = tan^2 theta_h; integral_0^inf P22 = 1/pi."""
    if dist == "beckmann":
        return np.exp(-x / a ** 2) / (np.pi * a ** 2)
    return a ** 2 / (np.pi * (a ** 2 + x) ** 2)


def slope_normal(tx, ty):
    n = np.array([-tx, -ty, 1.0])
    return n / np.linalg.norm(n)


def theta_max_numeric(wo, phi_h):
    """Largest theta_h with reflect(wo, h).z >= 0 at azimuth phi_h, by root finding."""
    def wz(th):
        return R.reflect(wo, spherical(th, phi_h))[2]
    return optimize.brentq(wz, 0, np.pi / 2, xtol=1e-15) if wz(np.pi / 2) < 0 else np.pi / 2


# ---------------------------------------------------------------------------------------------
# Distributions and masking

@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("ax,ay", ROUGH)
def test_D_normalised(dist, ax, ay):
    # integral D(h) (h.n) dw_h = integral D cos^4 d^2t over slopes t; slopes (ax r cos, ay r sin)
    def inner(psi):
        def g(r):
            h = slope_normal(ax * r * np.cos(psi), ay * r * np.sin(psi))
            return R.D(dist, h, ax, ay) * h[2] ** 4 * ax * ay * r
        return quad(g, 0, 1) + quad(g, 1, np.inf)
    assert quad(inner, 0, 2 * np.pi) == pytest.approx(1, abs=1e-8)


@pytest.mark.parametrize("dist", DISTS)
def test_D_matches_P22(dist):
    rng = np.random.default_rng(0)
    th = rng.uniform(0, 1.5, 50)
    for a in (1e-3, 0.2, 1.0):
        h = spherical(th, rng.uniform(0, 2 * np.pi, 50))
        want = P22(dist, np.tan(th) ** 2, a) / np.cos(th) ** 4
        np.testing.assert_allclose(R.D(dist, h, a, a), want, rtol=1e-12, atol=1e-300)
    assert R.D(dist, np.array([0.6, 0, -0.8]), 0.3, 0.3) == 0


def lambda_integral(dist, theta, phi, ax, ay):
    """Smith Lambda from its definition: P2 the slope density projected on the azimuth of w,
    Lambda = integral_{1/tan}^inf (r tan - 1) P2(r) dr. The anisotropic slope density is
    P22_1(tx^2/ax^2 + ty^2/ay^2) / (ax ay), P22_1 the a = 1 slope function."""
    c, s = np.cos(phi), np.sin(phi)

    def P2(r):
        def p(q):
            tx, ty = r * c - q * s, r * s + q * c
            return P22(dist, (tx / ax) ** 2 + (ty / ay) ** 2, 1.0) / (ax * ay)
        scale = 10 * max(ax, ay)
        # p(q) is not even in q when ax != ay
        return sum(quad(p, lo, hi, epsabs=0) for lo, hi in
                   ((-np.inf, -scale), (-scale, 0), (0, scale), (scale, np.inf)))
    tan = np.tan(theta)
    lo = 1 / tan
    return quad(lambda r: (r * tan - 1) * P2(r), lo, lo + 10 * max(ax, ay)) + \
        quad(lambda r: (r * tan - 1) * P2(r), lo + 10 * max(ax, ay), np.inf)


@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("theta", [0.3, 1.0, 1.45, 1.56])
@pytest.mark.parametrize("ax,ay,phi", [(0.05, 0.05, 0.0), (0.5, 0.5, 0.0), (1.0, 1.0, 0.0),
                                       (0.1, 0.7, 0.4), (0.7, 0.1, 1.2)])
def test_Lambda_matches_integral_definition(dist, theta, ax, ay, phi):
    w = spherical(theta, phi)
    want = lambda_integral(dist, theta, phi, ax, ay)
    assert R.Lambda(dist, w, ax, ay) == pytest.approx(want, rel=1e-7, abs=1e-12)


def test_Lambda_limits():
    for dist in DISTS:
        assert R.Lambda(dist, np.array([0.0, 0, 1]), 0.5, 0.5) == 0
        assert R.G1(dist, np.array([0.0, 0, 1]), 0.5, 0.5) == 1
        assert R.G1(dist, np.array([1.0, 0, 0]), 0.5, 0.5) == 0
        assert R.G1(dist, np.array([0.6, 0, -0.8]), 0.5, 0.5) == 0


@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("ax,ay", [(0.01, 0.01), (0.3, 0.3), (1.0, 1.0), (0.05, 0.6)])
@pytest.mark.parametrize("theta_o,phi_o", [(0.0, 0.0), (0.8, 0.3), (1.45, 2.0)])
def test_visible_normals_normalised(dist, ax, ay, theta_o, phi_o):
    # integral G1(wo) max(0, wo.h) D(h) dw_h = cos_o. Slopes (ax r cos psi, ay r sin psi),
    # dw_h = cos^3 d^2t; wo.h > 0 <=> r < r_max = wz / k, k = ax wx cos psi + ay wy sin psi, where
    # k > 0. Fixed Gauss-Legendre in psi (split where k changes sign) and in r = tan(beta).
    wo = spherical(theta_o, phi_o)
    psi0 = np.arctan2(-ax * wo[0], ay * wo[1])
    edges = psi0 + np.pi / 2 * np.arange(5)
    total = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        psi, wpsi = gl(lo, hi, 64)
        for p, wp in zip(psi, wpsi):
            k = ax * wo[0] * np.cos(p) + ay * wo[1] * np.sin(p)
            b_max = np.arctan2(wo[2], k) if k > 0 else np.pi / 2
            for b0, b1 in zip(np.linspace(0, b_max, 5)[:-1], np.linspace(0, b_max, 5)[1:]):
                beta, wb = gl(b0, b1, 48)
                r = np.tan(beta)
                t = np.stack([ax * r * np.cos(p), ay * r * np.sin(p), -np.ones_like(r)], -1)
                h = -t / np.linalg.norm(t, axis=-1, keepdims=True)
                g = np.maximum(0, h @ wo) * R.D(dist, h, ax, ay) * h[:, 2] ** 3 * ax * ay * r
                total += wp * np.sum(g / np.cos(beta) ** 2 * wb)
    assert R.G1(dist, wo, ax, ay) * total == pytest.approx(wo[2], abs=1e-9)


# ---------------------------------------------------------------------------------------------
# Fresnel

def conductor_textbook(c, eta, k):
    """Unpolarised conductor reflectance from a^2, b^2 (e.g. Cook-Torrance / Glassner form)."""
    s2 = 1 - c * c
    t = eta * eta - k * k - s2
    ab2 = np.sqrt(t * t + 4 * eta * eta * k * k)
    a = np.sqrt((ab2 + t) / 2)
    rs = (ab2 - 2 * a * c + c * c) / (ab2 + 2 * a * c + c * c)
    st = s2 / c                                    # sin theta tan theta
    rp = rs * (ab2 - 2 * a * st + st * st) / (ab2 + 2 * a * st + st * st)
    return (rs + rp) / 2


def test_fresnel():
    c = np.linspace(0.01, 1, 100)
    for eta in (1.33, 1.5, 2.4):
        assert R.fresnel("dielectric", 1.0, eta=eta) == pytest.approx(((eta - 1) / (eta + 1)) ** 2, rel=1e-14)
    for eta in (0.65, 0.9, 1.5, 3.0):       # eta < 1: total internal reflection below critical c
        np.testing.assert_allclose(R.fresnel("conductor", c, eta=eta, k=0.0),
                                   R.fresnel("dielectric", c, eta=eta), rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(R.fresnel("dielectric", np.array([0.1, 0.5]), eta=0.7), 1.0)
    for eta, k in ((0.2, 3.0), (1.1, 2.5), (2.8, 0.4)):
        np.testing.assert_allclose(R.fresnel("conductor", c, eta=eta, k=k),
                                   conductor_textbook(c, eta, k), rtol=1e-12)
    assert R.fresnel("schlick", 1.0, f0=0.04) == pytest.approx(0.04)
    assert R.fresnel("schlick", 0.0, f0=0.04) == pytest.approx(1.0)
    assert R.fresnel("dielectric", 0.0, eta=1.5) == pytest.approx(1.0)
    np.testing.assert_array_equal(R.fresnel("one", c), 1.0)


# ---------------------------------------------------------------------------------------------
# BRDF value

def random_upper(rng, n):
    w = rng.normal(size=(n, 3))
    w[:, 2] = np.abs(w[:, 2])
    return w / np.linalg.norm(w, axis=-1, keepdims=True)


FRESNEL_OPTS = [dict(fresnel="one"), dict(fresnel="schlick", f0=0.1),
                dict(fresnel="dielectric", eta=1.5), dict(fresnel="dielectric", eta=0.7),
                dict(fresnel="conductor", eta=0.2, k=3.0)]


@pytest.mark.parametrize("dist", DISTS)
@pytest.mark.parametrize("masking", [m for m in R.MASKINGS if m != "unshadowed"])
@pytest.mark.parametrize("fr", FRESNEL_OPTS, ids=lambda d: "-".join(map(str, d.values())))
def test_reciprocity(dist, masking, fr):
    rng = np.random.default_rng(1)
    wi, wo = random_upper(rng, 200), random_upper(rng, 200)
    for rough in (dict(alpha=0.2), dict(alpha_x=0.05, alpha_y=0.8)):
        f1 = R.eval(dist, wo, wi, masking=masking, kd=0.2, **rough, **fr)
        f2 = R.eval(dist, wi, wo, masking=masking, kd=0.2, **rough, **fr)
        assert np.all(f1 > 0)
        np.testing.assert_allclose(f1, f2, rtol=1e-12)


def test_eval_basics():
    rng = np.random.default_rng(2)
    wi, wo = random_upper(rng, 10), random_upper(rng, 10)
    np.testing.assert_allclose(R.eval("lambert", wo, wi, kd=0.7), 0.7 / np.pi)
    below = wi * [1, 1, -1]
    for model in R.MODELS:
        assert np.all(R.eval(model, wo, below) == 0) and np.all(R.eval(model, below, wi) == 0)
    # broadcasting: one wo against many wi, parameters per direction
    f = R.eval("ggx", wo[0], wi, alpha=np.linspace(0.1, 1, 10))
    assert f.shape == (10,)
    assert f[3] == R.eval("ggx", wo[0], wi[3], alpha=0.4)
    # the Fresnel option follows the parameters given, unused parameters are errors
    assert R.eval("ggx", wo[0], wi[0], f0=0.1) == R.eval("ggx", wo[0], wi[0], fresnel="schlick", f0=0.1)
    with pytest.raises(TypeError):
        R.eval("ggx", wo, wi, fresnel="one", f0=0.1)
    with pytest.raises(TypeError):
        R.eval("ggx", wo, wi, alpha=0.1, alpha_x=0.2)


# ---------------------------------------------------------------------------------------------
# Sampling densities

@functools.lru_cache
def leggauss(n):
    return np.polynomial.legendre.leggauss(n)


def gl(a, b, n):
    x, w = leggauss(n)
    return (a + b) / 2 + (b - a) / 2 * x, (b - a) / 2 * w


def hemisphere_gl(g, n=800):
    """integral over the upper hemisphere of g(w) dw (g vectorised), by a fixed n x n
    Gauss-Legendre product rule in (theta, phi): for smooth integrands only."""
    th, wt = gl(0, np.pi / 2, n)
    ph, wp = gl(0, 2 * np.pi, n)
    w = spherical(th[:, None], ph[None, :])
    return np.sum(g(w) * (np.sin(th) * wt)[:, None] * wp[None, :])


def halfvector_gl(g, wo, n=128):
    """integral of g(h) dw_h over the half vectors whose reflection of wo is above the horizon,
    by a fixed product rule in (phi_h, theta_h), theta_h up to the horizon found by root finding;
    the azimuth split where theta_max varies fastest (phi_h - phi_o = +-pi/2)."""
    phi_o = np.arctan2(wo[1], wo[0])
    total = 0.0
    for k in range(4):
        ph, wp = gl(phi_o + (k - 0.5) * np.pi / 2, phi_o + (k + 0.5) * np.pi / 2, n)
        for phi, w_phi in zip(ph, wp):
            th, wt = gl(0, theta_max_numeric(wo, phi), n)
            total += w_phi * np.sum(g(spherical(th, phi)) * np.sin(th) * wt)
    return total


PDF_CASES = [("ggx", 0.8, 0.0, dict(alpha=0.3)), ("beckmann", 0.3, 0.7, dict(alpha=0.4)),
             ("ggx", 0.2, 2.0, dict(alpha_x=0.2, alpha_y=0.5, fresnel="schlick", f0=0.3, kd=0.4))]


@pytest.mark.parametrize("model,mu,phi,p", PDF_CASES)
def test_pdf_integrals(model, mu, phi, p):
    wo = R.direction(mu, phi)
    cfg = R.configure(model, **p)
    ax, ay = cfg["ax"], cfg["ay"]
    tot = {s: hemisphere_gl(lambda w, s=s: R.pdf(model, wo, w, s, **p)) for s in R.SAMPLERS}
    assert tot["uniform"] == pytest.approx(1, abs=1e-10)
    assert tot["cosine"] == pytest.approx(1, abs=1e-10)
    # fractions that stay above the horizon, computed over half vectors
    frac_ndf = halfvector_gl(lambda h: R.D(model, h, ax, ay) * h[..., 2], wo)
    frac_vndf = halfvector_gl(lambda h: R.G1(model, wo, ax, ay) * np.maximum(0, h @ wo)
                              * R.D(model, h, ax, ay) / wo[2], wo)
    assert 0.5 < frac_ndf < 1 and 0.5 < frac_vndf < 1
    assert tot["ndf"] == pytest.approx(frac_ndf, abs=1e-9)
    assert tot["vndf"] == pytest.approx(frac_vndf, abs=1e-9)
    kd = p.get("kd", 0.0)
    p_d = kd / (kd + R.fresnel(cfg["fresnel"], mu, f0=cfg.get("f0")))
    assert tot["brdf"] == pytest.approx(p_d + (1 - p_d) * frac_vndf, abs=1e-9)
    assert tot["mis"] == pytest.approx(0.5 + 0.5 * tot["brdf"], abs=1e-9)


def test_pdf_basics():
    rng = np.random.default_rng(3)
    wi, wo = random_upper(rng, 50), random_upper(rng, 50)
    for s in R.SAMPLERS:
        assert np.all(R.pdf("ggx", wo, wi * [1, 1, -1], s, alpha=0.3) == 0)
    np.testing.assert_allclose(R.pdf("lambert", wo, wi, "brdf"), wi[:, 2] / np.pi)
    # lobe_sampler=ndf without kd is the ndf density; with kd the mixture
    np.testing.assert_array_equal(R.pdf("ggx", wo, wi, "brdf", alpha=0.3, lobe_sampler="ndf"),
                                  R.pdf("ggx", wo, wi, "ndf", alpha=0.3))
    mix = R.pdf("beckmann", wo, wi, "brdf", alpha=0.3, kd=0.5, lobe_sampler="ndf")
    np.testing.assert_allclose(mix, wi[:, 2] / np.pi / 3 + 2 / 3 * R.pdf("beckmann", wo, wi, "ndf", alpha=0.3))


def test_theta_max_formula():
    # theta_max = (pi/2 + delta)/2, tan delta = tan theta_o cos(phi_h - phi_o)
    for mu, phi_o in ((0.999, 0.2), (0.5, 1.0), (1e-3, 4.0)):
        wo = R.direction(mu, phi_o)
        for phi in np.linspace(0, 2 * np.pi, 13):
            delta = np.arctan2(np.sqrt(1 - mu * mu) * np.cos(phi - phi_o), mu)
            assert (np.pi / 2 + delta) / 2 == pytest.approx(theta_max_numeric(wo, phi), abs=1e-12)


# ---------------------------------------------------------------------------------------------
# Albedo

def albedo_brute(model, mu, phi=0.0, **p):
    """E by nested adaptive scipy quad over (phi_i, theta_i), split at the specular azimuth."""
    wo = R.direction(mu, phi)

    def inner(ph):
        return quad(lambda th: R.eval(model, wo, spherical(th, ph), **p) * np.cos(th) * np.sin(th),
                    0, np.pi / 2, epsabs=1e-11)
    return sum(quad(inner, phi + k * np.pi / 2, phi + (k + 1) * np.pi / 2, epsabs=1e-11)
               for k in range(4))


def test_albedo_lambert_exact():
    for mu in (1e-3, 0.3, 1.0):
        E, err = R.albedo("lambert", mu, kd=0.8)
        assert E == pytest.approx(0.8, rel=1e-14) and err < 1e-14


_SLOW = pytest.mark.slow        # each brute-force case takes 1.5 s
@pytest.mark.parametrize("model,mu,phi,p", [
    ("ggx", 0.5, 0.0, dict(alpha=0.3)),
    pytest.param("beckmann", 0.2, 0.5, dict(alpha=0.6, masking="separable", fresnel="conductor",
                                            eta=0.2, k=3.0), marks=_SLOW),
    ("ggx", 0.9, 1.0, dict(alpha_x=0.3, alpha_y=0.6, fresnel="dielectric", eta=1.5, kd=0.3)),
    pytest.param("ggx", 0.1, 0.3, dict(alpha=0.6, masking="none", fresnel="schlick", f0=0.1),
                 marks=_SLOW),
    pytest.param("beckmann", 0.7, 1.1, dict(alpha=0.3, masking="vcavity", fresnel="schlick",
                                            f0=0.5), marks=_SLOW),
    ("ggx", 0.5, 0.0, dict(alpha=1.0)),            # the furnace value, GGX correlated
])
def test_albedo_against_brute_force(model, mu, phi, p):
    E, err = R.albedo(model, mu, phi, **p)
    assert err < 1e-8
    assert E == pytest.approx(albedo_brute(model, mu, phi, **p), abs=3e-8)


def test_albedo_narrow_lobe_at_grazing():
    # GGX alpha 0.01 at mu 0.05: quadrature over half vectors in (phi_h, log tan theta_h),
    # theta_h up to the horizon found by root finding
    model, mu, a = "ggx", 0.05, 0.01
    wo = R.direction(mu)
    cfg = R.configure(model, alpha=a)

    def inner(phi):
        tm = theta_max_numeric(wo, phi)

        def g(lt):                   # lt = log tan theta_h
            th = np.arctan(np.exp(lt))
            h = spherical(th, phi)
            wi = R.reflect(wo, h)
            jac = np.sin(th) * np.cos(th) ** 2 * np.exp(lt)   # d theta / d lt times sin theta
            return R.eval_specular(cfg, wo, wi) * max(wi[2], 0) * 4 * (wo @ h) * jac
        lo, hi = np.log(a) - 25, np.log(np.tan(tm))
        return quad(g, lo, hi, points=[np.log(a)] if lo < np.log(a) < hi else None, epsabs=1e-12)
    brk = [0, np.pi / 2 - 0.1, np.pi / 2, np.pi / 2 + 0.1, np.pi]
    want = 2 * sum(quad(inner, lo, hi, epsabs=1e-11) for lo, hi in zip(brk[:-1], brk[1:]))
    E, err = R.albedo(model, mu, alpha=a)
    assert err < 1e-8
    assert E == pytest.approx(want, abs=2e-8)


def test_albedo_no_masking_no_fresnel():
    # G = 1, F = 1 at normal incidence: the weight of ndf sampling, wo.h / (cos_o h.z), is 1,
    # so E is the fraction of normals with theta_h < pi/4: 1/(1 + a^2) (GGX), 1 - exp(-1/a^2).
    for a in (0.1, 0.5, 1.0):
        assert R.albedo("ggx", 1.0, alpha=a, masking="none")[0] == pytest.approx(1 / (1 + a * a), abs=1e-9)
        assert R.albedo("beckmann", 1.0, alpha=a, masking="none")[0] == pytest.approx(1 - np.exp(-1 / a ** 2), abs=1e-9)
    # elsewhere the weight is unbounded and E > 1: "E <= 1" does not hold without masking
    assert R.albedo("ggx", 0.1, alpha=0.3, masking="none")[0] > 2


@pytest.mark.parametrize("model", DISTS)
@pytest.mark.parametrize("masking", ["correlated", pytest.param("separable", marks=pytest.mark.slow),
                                     pytest.param("vcavity", marks=pytest.mark.slow)])
def test_albedo_at_most_one_with_masking(model, masking):
    for a in (0.05, 0.5, 1.0):
        for mu in (0.02, 0.3, 1.0):
            E, err = R.albedo(model, mu, alpha=a, masking=masking, tol=1e-7)
            assert E <= 1 + err


def test_albedo_near_mirror_normal_incidence():
    a = 1e-3
    # Beckmann: nothing beyond the horizon (exp(-1/a^2)), masking exp(-1/(a tan)^2): E = 1
    E, err = R.albedo("beckmann", 1.0, alpha=a)
    assert abs(E - 1) < 1e-12
    # GGX: the heavy tail puts 1 - 1/(1 + a^2) = a^2/(1 + a^2) beyond the horizon, so 1 - E is
    # about 1.0e-6 and E is NOT 1 within 1e-6. Independent 1-D quadrature over theta_h (wo = n,
    # wi at 2 theta_h, G = 1/(1 + Lambda(wi)) with the closed-form Lambda of docs/models/microfacet.md):
    def g(th):
        t2 = np.tan(2 * th) ** 2
        lam = (-1 + np.sqrt(1 + a * a * t2)) / 2
        return P22("ggx", np.tan(th) ** 2, a) / np.cos(th) ** 3 / (1 + lam) * 2 * np.pi * np.sin(th)
    want = sum(quad(g, lo, hi, epsabs=1e-14) for lo, hi in
               ((0, a), (a, 30 * a), (30 * a, 0.5), (0.5, np.pi / 4)))
    E, err = R.albedo("ggx", 1.0, alpha=a)
    assert E == pytest.approx(want, abs=1e-10)
    horizon = a * a / (1 + a * a)           # GGX mass beyond theta_h = pi/4
    assert horizon < 1 - E < 1.01 * horizon and 1 - E > 1e-6


def test_balance_strategy_agrees():
    for model, mu in (("ggx", 0.3), ("beckmann", 0.8)):
        p = dict(alpha=0.3, kd=0.2, fresnel="schlick", f0=0.2)
        E1, e1 = R.albedo(model, mu, **p)
        E2, e2 = R.albedo(model, mu, strategy="balance", **p)
        assert abs(E1 - E2) <= e1 + e2


def test_error_estimate():
    for model, mu, p in (("ggx", 0.02, dict(alpha_x=0.001, alpha_y=0.1)),
                         ("beckmann", 0.6, dict(alpha=0.02, kd=0.5)),
                         ("ggx", 0.001, dict(alpha=0.001))):
        E, err = R.albedo(model, mu, tol=1e-6, **p)
        E2, err2 = R.albedo(model, mu, tol=1e-10, **p)
        assert err <= 1e-6 and abs(E - E2) <= err + err2


def test_albedo_avg():
    E_avg, err = R.albedo_avg("lambert", kd=0.8)
    assert E_avg == pytest.approx(0.8, rel=1e-12)
    # against a fixed 16-point Gauss-Legendre rule in x = sqrt(mu) of E(mu)
    p = dict(alpha=1.0)
    E_avg, err = R.albedo_avg("ggx", tol=1e-6, **p)
    x, w = gl(0, 1, 16)
    want = sum(wk * 4 * xk ** 3 * R.albedo("ggx", xk * xk, **p)[0] for xk, wk in zip(x, w))
    assert err < 1e-6
    assert E_avg == pytest.approx(want, abs=2e-6)
