"""Double-precision NumPy reference of Schlick 1994 (docs/models/schlick.md), its sampling density,
and a deterministic albedo integrator. Written from the paper, independently of kernels/schlick.h.

Notation (paper section 2): h = normalize(wi + wo), t = n.h, u = wo.h, v = n.wo, v' = n.wi,
w = cos(phi), phi the azimuth of h measured from the scratch direction (cos psi, sin psi, 0).

    S(u)  = c                                  (eq 10, spectral="constant")
          = c + (1 - c)(1 - u)^5               (eq 11, spectral="fresnel")
    Z(t)  = r / (1 + r t^2 - t^2)^2            (eq 14)
    A(w)  = sqrt(p / (p^2 - p^2 w^2 + w^2))    (eq 14; A = 1 when p = 1)
    G(v)  = v / (r - r v + v)                  (eq 16)
    D     = Z A / (4 pi v v')                                   (eq 12)
          = G(v) G(v') Z A / (4 pi v v')                        (eq 15)
          = r A / pi + (1 - r) Z A / (4 pi v v')                (eq 17)
          = (1 - G(v) G(v')) A / pi + G(v) G(v') Z A / (4 pi v v')   (eq 18)
    SINGLE: R = S(u) D;  DOUBLE: R = S(u) D + (1 - S(u)) S2(u) D2   (eq 9)

Parameters: c, r, p, psi (layer 1) and c2, r2, p2, psi2 (layer 2 of DOUBLE). At h = n the
azimuth is undefined: w = 1 there (phi = atan2(0, 0) = 0), so A = sqrt(p).

Sampler (ours; the paper has none), see docs/models/schlick.md: per layer, the half vector has
density p_h(h) = t Z(t) A(phi) / (pi <A>) on the hemisphere (t from 2 t Z(t) dt, phi from
A(phi) dphi / (2 pi <A>), <A> = (2/pi) sqrt(p) K(1 - p^2) the azimuthal mean of A), and
wi = reflect(wo, h): pdf(wi) = p_h / (4 wo.h). Eq 17/18 mix in the cosine lobe with probability
P_d = r (eq 17) or 1 - G(v) 2/(2 + r) (eq 18; 2/(2 + r) = G(2/3), the cosine-weighted mean of
v' is 2/3). DOUBLE chooses layer 1 with probability sum_c S_c(v) / (sum_c S_c(v)
+ sum_c (1 - S_c(v)) S2_c(v)) (1/2 when both sums are 0).
"""
import numpy as np
from scipy import special

from .quadrature import half_cos, hemisphere_integral

INV_PI = 1 / np.pi
MATERIALS = ("single", "double")
SPECTRALS = ("constant", "fresnel")
DIRECTIONALS = ("eq18", "eq17", "eq15", "eq12")
DEFAULTS = {"c": 1.0, "r": 0.5, "p": 1.0, "psi": 0.0, "c2": 1.0, "r2": 1.0, "p2": 1.0, "psi2": 0.0}


def configure(material="single", spectral="constant", directional="eq18", **kw):
    for name, v, ch in (("material", material, MATERIALS), ("spectral", spectral, SPECTRALS),
                        ("directional", directional, DIRECTIONALS)):
        if v not in ch:
            raise ValueError(f"{name}={v!r} is not one of {ch}")
    names = ("c", "r", "p", "psi") + (("c2", "r2", "p2", "psi2") if material == "double" else ())
    extra = set(kw) - set(names)
    if extra:
        raise TypeError(f"parameters {sorted(extra)} not used with material={material}")
    cfg = {"material": material, "spectral": spectral, "directional": directional}
    for n in names:
        cfg[n] = np.asarray(kw.get(n, DEFAULTS[n]), float)
    return cfg


def _layers(cfg):
    out = [(cfg["c"], cfg["r"], cfg["p"], cfg["psi"])]
    if cfg["material"] == "double":
        out.append((cfg["c2"], cfg["r2"], cfg["p2"], cfg["psi2"]))
    return out


# ---------------------------------------------------------------------------------------------
# factors

def S(spectral, c, u):
    return c if spectral == "constant" else c + (1 - c) * (1 - u) ** 5   # eq 10, eq 11


def Z(r, h):
    """eq 14, with 1 - t^2 = hx^2 + hy^2 (h unit)."""
    t2 = h[..., 2] ** 2
    return r / ((h[..., 0] ** 2 + h[..., 1] ** 2) + r * t2) ** 2


def azimuth(h, psi):
    """phi of h from the scratch direction (cos psi, sin psi, 0)."""
    return np.arctan2(h[..., 1], h[..., 0]) - psi


def A(p, phi):
    w = np.cos(phi)                                   # eq 14
    return np.sqrt(p / (p * p - p * p * w * w + w * w))


def A_mean(p):
    """(1/2pi) int_0^2pi A dphi = (2/pi) sqrt(p) K(m = 1 - p^2)."""
    p = np.asarray(p, float)
    return 2 / np.pi * np.sqrt(p) * special.ellipkm1(p * p)


def Gs(r, v):
    return v / (r - r * v + v)                        # eq 16


def directional(eq, r, p, psi, wo, wi, h):
    """D(t, v, v', w) of eq 12/15/17/18 (both directions above the horizon)."""
    v, vp = wo[..., 2], wi[..., 2]
    za = Z(r, h) * A(p, azimuth(h, psi)) / (4 * np.pi * v * vp)
    a_pi = A(p, azimuth(h, psi)) / np.pi
    if eq == "eq12":
        return za
    if eq == "eq15":
        return Gs(r, v) * Gs(r, vp) * za
    if eq == "eq17":
        return r * a_pi + (1 - r) * za
    gg = Gs(r, v) * Gs(r, vp)
    return (1 - gg) * a_pi + gg * za


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def eval(wo, wi, channels=1, **params):
    """BRDF R (1/sr); 0 unless wi.z > 0 and wo.z > 0. channels=3: c, c2 have a trailing axis of
    3 (or are scalars) and the result has one too."""
    cfg = configure(**params)
    wi, wo = np.asarray(wi, float), np.asarray(wo, float)
    valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = _unit(wi + wo)
        u = half_cos(wo, wi)
        layers = _layers(cfg)
        ds = [directional(cfg["directional"], r, p, psi, wo, wi, h) for (_, r, p, psi) in layers]
        if channels == 3:
            u, ds = u[..., None], [d[..., None] for d in ds]
            valid = valid[..., None]
        s1 = S(cfg["spectral"], layers[0][0], u)
        f = s1 * ds[0]
        if len(layers) == 2:
            f = f + (1 - s1) * S(cfg["spectral"], layers[1][0], u) * ds[1]
    return np.where(valid, f, 0.0)


# ---------------------------------------------------------------------------------------------
# sampling density

def diffuse_prob(eq, r, v):
    if eq in ("eq12", "eq15"):
        return np.zeros_like(v)
    if eq == "eq17":
        return r + 0 * v
    return 1 - Gs(r, v) * 2 / (2 + r)


def layer_prob(cfg, v, channels=1):
    """Probability of layer 1 (1 for SINGLE)."""
    if cfg["material"] == "single":
        return np.ones_like(v)
    vv = v[..., None] if channels == 3 else v
    s1 = S(cfg["spectral"], cfg["c"], vv)
    s2 = (1 - s1) * S(cfg["spectral"], cfg["c2"], vv)
    if channels == 3:
        s1, s2 = np.sum(s1 * np.ones(3), -1), np.sum(s2 * np.ones(3), -1)
    tot = s1 + s2
    return np.where(tot > 0, s1 / np.where(tot > 0, tot, 1), 0.5)


def lobe_pdf_h(r, p, psi, h):
    """Half-vector density t Z A / (pi <A>) (solid angle of h)."""
    return h[..., 2] * Z(r, h) * A(p, azimuth(h, psi)) / (np.pi * A_mean(p))


def pdf(wo, wi, channels=1, **params):
    """Solid-angle density of wi under the sampler (module docstring); 0 below the horizon."""
    cfg = configure(**params)
    wo, wi = np.asarray(wo, float), np.asarray(wi, float)
    valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
    v = wo[..., 2] * np.ones(np.broadcast_shapes(wo.shape, wi.shape)[:-1])
    with np.errstate(divide="ignore", invalid="ignore"):
        h = _unit(wi + wo)
        woh = half_cos(wo, wi)
        cosine = wi[..., 2] * INV_PI
        P1 = layer_prob(cfg, v, channels)
        out = 0
        for k, (_, r, p, psi) in enumerate(_layers(cfg)):
            pd = diffuse_prob(cfg["directional"], r, v)
            lobe = pd * cosine + (1 - pd) * lobe_pdf_h(r, p, psi, h) / (4 * woh)
            out = out + (P1 if k == 0 else 1 - P1) * lobe
    return np.where(valid, out, 0.0)


# ---------------------------------------------------------------------------------------------
# Quadrature map of the half vector, graded to a Schlick lobe of roughness r_map, isotropy p
#
# Azimuth: 4 quadrants around the peaks of A at phi = pi/2, 3pi/2 (w = 0); in each the distance
# chi from the peak is p sinh(tau L), L = asinh(pi/(2p)), tau in [0, 1]: dchi/dtau = L
# sqrt(p^2 + chi^2), which follows A ~ 1/sqrt(p^2 cos^2 chi + sin^2 chi). Polar: x = 1 - F(t),
# F(t) = r t^2 / (1 - (1 - r) t^2) the CDF of 2 t Z(t) (so tan^2 theta_h = r x / (1 - x),
# dw_h = dx dphi / (2 t Z)), run in y = sqrt(1 - x) from 1 to y_min(phi), where wi reaches the
# horizon (tan theta_max = tan((pi/2 + delta)/2), tan delta = tan theta_o cos(phi_h - phi_o)).
# points() returns wi and |dw_i / ds dt| (density 1), so any integrand is integrated exactly.

class HalfVectorMap:
    def __init__(self, wo, r_map, p, psi=0.0):
        self.wo = np.asarray(wo, float)
        self.r, self.p, self.psi = float(r_map), float(p), float(psi)
        self.L = np.arcsinh(np.pi / (2 * self.p))
        self.so = np.hypot(self.wo[0], self.wo[1])
        self.co = self.wo[2]
        self.phio = np.arctan2(self.wo[1], self.wo[0])

    def _phi(self, t):
        q = np.minimum(np.floor(4 * t), 3)
        tau = 4 * t - q
        chi = self.p * np.sinh(tau * self.L)
        sign = np.where(q % 2 == 0, -1.0, 1.0)
        phi_rel = np.where(q < 2, np.pi / 2, 3 * np.pi / 2) + sign * chi
        dphi = 4 * self.p * self.L * np.cosh(tau * self.L)
        return phi_rel + self.psi, dphi

    def _ymin(self, phi):
        delta = np.arctan2(self.so * np.cos(phi - self.phio), self.co)
        tan2max = np.tan((np.pi / 2 + delta) / 2) ** 2
        return np.sqrt(self.r / (tan2max + self.r))

    def points(self, s, t):
        phi, dphi = self._phi(t)
        ymin = self._ymin(phi)
        one_y = s * (1 - ymin)
        y = 1 - one_y
        x = one_y * (1 + y)
        tan2 = self.r * x / (y * y)
        cos_t = 1 / np.sqrt(1 + tan2)
        sin_t = np.sqrt(tan2) * cos_t
        h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)
        woh = h @ self.wo
        wi = 2 * woh[..., None] * h - self.wo
        # 1 / (2 t Z): Z = (1 + tan2)^2 y^4 / r on this map
        dwh = self.r / (2 * cos_t * (1 + tan2) ** 2 * y ** 4)
        jac = 4 * woh * dwh * 2 * y * (1 - ymin) * dphi
        return wi, jac

    def coords(self, wi):
        """(s, t) of directions wi above the horizon (inverse of points)."""
        h = _unit(np.asarray(wi, float) + self.wo)
        phi_rel = np.mod(np.arctan2(h[..., 1], h[..., 0]) - self.psi, 2 * np.pi)
        q = np.minimum(np.floor(phi_rel / (np.pi / 2)), 3)
        centre = np.where(q < 2, np.pi / 2, 3 * np.pi / 2)
        chi = np.abs(phi_rel - centre)
        t = (q + np.arcsinh(chi / self.p) / self.L) / 4
        tan2 = (h[..., 0] ** 2 + h[..., 1] ** 2) / h[..., 2] ** 2
        y = np.sqrt(self.r / (tan2 + self.r))
        ymin = self._ymin(np.arctan2(h[..., 1], h[..., 0]))
        s = (1 - y) / (1 - ymin)
        return np.clip(s, 0, 1 - 1e-12), np.clip(t, 0, 1 - 1e-12)


def _map(wo, r_map, p, psi):
    m = HalfVectorMap(wo, r_map, p, psi)
    return m.points, (lambda wi: np.ones(wi.shape[:-1]))


def direction(mu, phi=0.0):
    s = np.sqrt(1 - mu * mu)
    return np.array([s * np.cos(phi), s * np.sin(phi), mu], float)


def albedo(mu, phi=0.0, tol=1e-8, **params):
    """E(wo) = int R(wi, wo) cos_i dw_i, wo = direction(mu, phi), for one channel (scalar c, c2);
    returns (E, err). Each term (per layer: the Z A term on a map graded to (r, p), the A/pi
    term of eq 17/18 on a map with r_map = 1 and the layer's p) is integrated separately."""
    cfg = configure(**params)
    wo = direction(float(mu), float(phi))
    v = wo[2]
    eq, sp = cfg["directional"], cfg["spectral"]
    layers = _layers(cfg)
    terms = []
    for k, (c, r, p, psi) in enumerate(layers):
        r, p, psi = float(r), float(p), float(psi)

        def weight(u, k=k):
            s1 = S(sp, layers[0][0], u)
            return s1 if k == 0 else (1 - s1) * S(sp, layers[1][0], u)

        def spec(wi, r=r, p=p, psi=psi, weight=weight):
            h = _unit(wi + wo)
            vp = wi[..., 2]
            g = Gs(r, v) * Gs(r, vp)
            coef = {"eq12": 1.0, "eq15": g, "eq17": 1 - r, "eq18": g}[eq]
            return (weight(h @ wo) * coef * Z(r, h) * A(p, azimuth(h, psi)) / (4 * np.pi * v))
        terms.append((spec, _map(wo, r, p, psi)))
        if eq in ("eq17", "eq18"):
            def diff(wi, r=r, p=p, psi=psi, weight=weight):
                h = _unit(wi + wo)
                vp = wi[..., 2]
                coef = r if eq == "eq17" else 1 - Gs(r, v) * Gs(r, vp)
                return weight(h @ wo) * coef * A(p, azimuth(h, psi)) * INV_PI * vp
            terms.append((diff, _map(wo, 1.0, p, psi)))
    value = err = 0.0
    for g, m in terms:
        with np.errstate(divide="ignore", invalid="ignore"):
            a, e = hemisphere_integral(g, [m], tol / len(terms))
        value, err = value + a, err + e
    return value, err


def mixture_integral(g, wo, tol=1e-8, **params):
    """Integral of g(wi) over the upper hemisphere for integrands shaped like this configuration's
    sampling density (g: a function of an (..., 3) array of wi, e.g. a kernel pdf). A partition
    of unity over the lobes: map k (one per layer, graded to (r, p, psi), and one with
    r_map = p = 1) carries the weight q_k / sum_j q_j, q_k the reference lobe density (the
    uniform 1/(2 pi) for the last). Returns (value, err)."""
    cfg = configure(**params)
    wo = np.asarray(wo, float)
    dens = []
    for (_, r, p, psi) in _layers(cfg):
        def q(wi, r=r, p=p, psi=psi):
            h = _unit(wi + wo)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(wi[..., 2] > 0, lobe_pdf_h(r, p, psi, h) / (4 * (h @ wo)), 0.0)
        dens.append((HalfVectorMap(wo, float(r), float(p), float(psi)), q))
    dens.append((HalfVectorMap(wo, 1.0, 1.0), lambda wi: np.full(wi.shape[:-1], 0.5 / np.pi)))
    maps = []
    for m, q in dens:
        def points(s, t, m=m, q=q):
            wi, jac = m.points(s, t)
            return wi, jac * q(wi)
        maps.append((points, q))
    return hemisphere_integral(g, maps, tol)


# ---------------------------------------------------------------------------------------------
# VERIFY numbers for docs/models/schlick.md: python -m clbrdf.ref.schlick

TABLE_R = (0.01, 0.1, 0.3, 0.6, 1.0)
TABLE_P = (0.01, 0.1, 0.5, 1.0)
TABLE_MU = (1.0, 0.5, 0.1, 0.01)


def eq13_numbers(ps=(1e-4, 0.01, 0.1, 0.3, 0.5, 0.9, 1.0), rs=(1e-4, 0.01, 0.1, 0.5, 1.0)):
    """Eq 13 by adaptive quadrature (scipy.integrate.quad): int_0^1 2 t Z dt per r; per p the
    printed int_0^1 sqrt(1 - w^2) A dw, the meant int_0^1 A / sqrt(1 - w^2) dw (= int_0^pi/2 A
    dphi) and its closed form (pi/2) <A> = sqrt(p) K(1 - p^2)."""
    from scipy import integrate
    z = {r: integrate.quad(lambda t: 2 * t * r / (1 + r * t * t - t * t) ** 2, 0, 1,
                           points=[1 - np.sqrt(r)], limit=200)[0] for r in rs}
    a = {}
    for p in ps:
        Aw = lambda w: np.sqrt(p / (p * p - p * p * w * w + w * w))   # noqa: E731
        printed = integrate.quad(lambda w: np.sqrt(1 - w * w) * Aw(w), 0, 1, points=[p], limit=200)[0]
        meant = integrate.quad(lambda ph: Aw(np.cos(ph)), 0, np.pi / 2, points=[np.pi / 2 - p],
                               limit=200)[0]
        a[p] = (printed, meant, np.pi / 2 * float(A_mean(p)))
    return z, a


def albedo_avg(tol=1e-8, nodes=20, n_phi=8, **params):
    """E_avg = (1/pi) int E(wo) cos_o dw_o = (2/pi) int_0^pi/2 dphi int_0^1 2 E(mu, phi) mu dmu
    (one channel): Gauss-Legendre with ``nodes`` in x = sqrt(mu) (integrand 4 E x^3, smooth
    also where E ~ 1/mu) and, unless every layer is isotropic, ``n_phi`` in phi over [0, pi/2]
    (the model is symmetric in phi -> -phi and phi -> pi - phi only when psi = psi2 = 0; give
    psi = 0). The rule's error is not estimated: compare two node counts."""
    cfg = configure(**params)
    x, w = np.polynomial.legendre.leggauss(nodes)
    x, w = (x + 1) / 2, w / 2
    iso = all(float(p) == 1 for (_, _, p, _) in _layers(cfg))
    if iso:
        phis, wphi = np.zeros(1), np.ones(1)
    else:
        phis, wphi = np.polynomial.legendre.leggauss(n_phi)
        phis, wphi = (phis + 1) * np.pi / 4, wphi / 2
    return sum(wq * wk * 4 * xk ** 3 * albedo(xk * xk, ph, tol, **params)[0]
               for xk, wk in zip(x, w) for ph, wq in zip(phis, wphi))


def energy_table(tol=1e-7, phis=(0.0, np.pi / 2), eqs=DIRECTIONALS):
    """E(mu, phi) for SINGLE, S = 1 (c = 1, constant), psi = 0, over TABLE_R x TABLE_P x TABLE_MU.
    Returns {(eq, r, p, mu, phi): (E, err)}."""
    out = {}
    for eq in eqs:
        for r in TABLE_R:
            for p in TABLE_P:
                for mu in TABLE_MU:
                    for phi in (phis if p < 1 else phis[:1]):
                        out[(eq, r, p, mu, phi)] = albedo(mu, phi, tol, directional=eq, r=r, p=p)
    return out


def _main():
    z, a = eq13_numbers()
    print("int_0^1 2 t Z(t) dt:", {r: f"{v:.12f}" for r, v in z.items()})
    print("p | printed int sqrt(1-w^2) A dw | meant int A/sqrt(1-w^2) dw | (pi/2)<A> | <A>")
    for p, (pr, me, cf) in a.items():
        print(f"{p:g} | {pr:.6f} | {me:.6f} | {cf:.6f} | {cf / (np.pi / 2):.6f}")
    from scipy import optimize
    res = optimize.minimize_scalar(lambda lp: -eq13_numbers(ps=(np.exp(lp),), rs=())[1][np.exp(lp)][0],
                                   bounds=(np.log(1e-6), 0), method="bounded")
    print(f"max over p of the printed integral: {-res.fun:.6f} at p = {np.exp(res.x):.4f} "
          f"(pi/2 = {np.pi / 2:.6f})")
    t = energy_table()
    for eq in DIRECTIONALS:
        print(f"\n{eq}: E(mu) at phi_o = 0 [phi_o = pi/2] (scratch along x); mu = {TABLE_MU}")
        print("| r | p | " + " | ".join(f"mu={m:g}" for m in TABLE_MU) + " |")
        print("|---|---|" + "---|" * len(TABLE_MU))
        for r in TABLE_R:
            for p in TABLE_P:
                cells = []
                for mu in TABLE_MU:
                    e0 = t[(eq, r, p, mu, 0.0)][0]
                    cell = f"{e0:.4f}"
                    if p < 1:
                        cell += f" [{t[(eq, r, p, mu, np.pi / 2)][0]:.4f}]"
                    cells.append(cell)
                print(f"| {r:g} | {p:g} | " + " | ".join(cells) + " |")
    print("\nE_avg (p = 1): " + " | ".join(f"r={r:g}" for r in TABLE_R))
    for eq in DIRECTIONALS:
        print(f"| {eq} | " + " | ".join(f"{albedo_avg(1e-8, directional=eq, r=r):.6f}"
                                         for r in TABLE_R) + " |")
    errs = max(e for _, e in t.values())
    print(f"\nlargest quadrature error estimate: {errs:.2g}")


if __name__ == "__main__":
    _main()


# ---------------------------------------------------------------------------------------------
# The registered reference (clbrdf.ref.Reference)

from . import Reference


class SchlickReference(Reference):
    """eval and pdf of this module with the options; per-channel c, c2 as trailing axes."""
    def _kw(self, v):
        return {**{k: np.asarray(x, float) for k, x in v.items()}, **self.options}

    def eval(self, wo, wi):
        return eval(np.asarray(wo, float), np.asarray(wi, float), channels=self.channels,
                    **self._kw(self.params))

    def pdf(self, wo, wi):
        return pdf(np.asarray(wo, float), np.asarray(wi, float), channels=self.channels,
                   **self._kw(self.params))

    def albedo1(self, mu, phi, tol, v, c):
        kw = {k: float(x) for k, x in v.items()}
        return albedo(mu, phi, tol, **kw, **self.options)


REFERENCES = {"schlick": SchlickReference}
