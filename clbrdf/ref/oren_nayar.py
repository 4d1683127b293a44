"""float64 reference of the Oren-Nayar family (clbrdf/models/oren_nayar.py): EON and FON from
Portsmouth, Kutz & Hill 2025 (eq 4-13 and their Listings 1-3), QON from Oren & Nayar 1994 in
MaterialX's form, written without the kernel (1 - E in the paper's form; the kernel's
r-cancelled one). The sampler's density by NumPy's matrix inverse of the CLTC's M. Albedo:
quadrature over the cosine map; ``eon_albedo`` and ``fon_albedo`` are the paper's closed forms,
which tests compare with it."""
import numpy as np

from . import Reference
from .quadrature import cosine_map, direction, hemisphere_integral

C1 = 0.5 - 2 / (3 * np.pi)
C2 = 2 / 3 - 28 / (15 * np.pi)
QUARTIC = (0.0571085289, 0.491881867, -0.332181442, 0.0714429953)   # Listing 1, E_FON_approx


def fon_albedo(mu, r, approx=False):
    """E_F(mu): the closed form (eq 6-7) or the paper's quartic fit."""
    mu = np.asarray(mu, float)
    af = 1 / (1 + C1 * r)
    if approx:
        m = 1 - mu
        return (1 + r * sum(c * m ** (k + 1) for k, c in enumerate(QUARTIC))) * af
    si = np.sqrt(1 - mu * mu)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = si * (np.arccos(mu) - si * mu) + 2 / 3 * ((si / mu) * (1 - si ** 3) - si)
    g = np.where(mu > 0, g, np.pi / 2 - 2 / 3)
    return af * (1 + r * g / np.pi)


def fon_average(r):
    """Ebar_F = 2 int E_F mu dmu (eq 10)."""
    return (1 + C2 * r) / (1 + C1 * r)


def rho_ms(rho, r):
    e = fon_average(r)
    return rho * rho * e / (1 - rho * (1 - e))                       # eq 12


def eon_albedo(mu, rho, r, approx=False):
    """E(mu) of EON: rho E_F + rho_ms (1 - E_F) (the paper's E_EON)."""
    e = fon_albedo(mu, r, approx)
    return rho * e + rho_ms(rho, r) * (1 - e)


def cltc_terms(mu, r):
    """The CLTC's (a, b, c, d) (Listing 3)."""
    a = 1 + r * (0.303392 + (-0.518982 + 0.111709 * mu) * mu + (-0.276266 + 0.335918 * mu) * r)
    b = r * (-1.16407 + 1.15859 * mu + (0.150815 - 0.150105 * mu) * r) / (mu ** 3 - 1.43545)
    c = 1 + (0.20013 + (-0.506373 + 0.261777 * mu) * mu) * r
    d = (0.540852 + (-1.01625 + 0.475392 * mu) * mu) * r / (-1.0743 + mu * (0.0725628 + mu))
    return a, b, c, d


def uniform_prob(mu, r):
    return r ** 0.1 * (0.162925 + mu * (-0.372058 + (0.538233 - 0.290822 * mu) * mu))


class OrenNayarReference(Reference):
    def eval1(self, wo, wi, v, c):
        rho, r = float(v["rho"]), float(v["r"])
        ci, co = wi[..., 2], wo[..., 2]
        ok = (ci > 0) & (co > 0)
        s = np.sum(wi * wo, axis=-1) - ci * co
        t = np.maximum(ci, co)
        form = self.options["form"]
        with np.errstate(invalid="ignore", divide="ignore"):
            if form == "qon":
                s2 = r * r
                A = 1 - 0.5 * s2 / (s2 + 0.33)
                B = 0.45 * s2 / (s2 + 0.09)
                f = rho / np.pi * (A + B * np.maximum(s, 0) / t)
            else:
                f = rho / np.pi * (1 + r * np.where(s > 0, s / t, s)) / (1 + C1 * r)
                if form == "eon" and r > 0:
                    approx = self.options["albedo"] == "approx"
                    eo = np.maximum(1 - fon_albedo(co, r, approx), 0)
                    ei = np.maximum(1 - fon_albedo(ci, r, approx), 0)
                    f = f + rho_ms(rho, r) / np.pi * eo * ei / (1 - fon_average(r))
        return np.where(ok, f, 0.0)

    def pdf(self, wo, wi):
        wo, wi = np.asarray(wo, float), np.asarray(wi, float)
        ok = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        if self.options["sampler"] == "cosine":
            return np.where(ok, wi[..., 2] / np.pi, 0.0)
        r = float(self.params["r"])
        mu = wo[..., 2]
        a, b, c, d = cltc_terms(mu, r)
        M = np.zeros(np.shape(mu) + (3, 3))
        M[..., 0, 0], M[..., 0, 2], M[..., 1, 1] = a, b, c
        M[..., 2, 0], M[..., 2, 2] = d, 1.0
        # wo's azimuth frame: x toward wo's tangential part
        l = np.hypot(wo[..., 0], wo[..., 1])
        cx = np.where(l > 0, wo[..., 0] / np.where(l > 0, l, 1), 1.0)
        sx = np.where(l > 0, wo[..., 1] / np.where(l > 0, l, 1), 0.0)
        local = np.stack([cx * wi[..., 0] + sx * wi[..., 1], cx * wi[..., 1] - sx * wi[..., 0],
                          wi[..., 2]], -1)
        Minv = np.linalg.inv(M)
        w = np.einsum("...ij,...j->...i", Minv, local)
        n = np.linalg.norm(w, axis=-1)
        clip = 0.5 * (1 + 1 / np.sqrt(d * d + 1))       # the clipped disk's share of pi
        cltc = np.maximum(w[..., 2] / n, 0) / (np.pi * clip) * np.abs(np.linalg.det(Minv)) / n ** 3
        pu = uniform_prob(mu, r)
        return np.where(ok, pu / (2 * np.pi) + (1 - pu) * cltc, 0.0)

    def albedo1(self, mu, phi, tol, v, c):
        wo = direction(mu, phi)
        return hemisphere_integral(lambda wi: self.eval1(wo, wi, v, c) * wi[..., 2],
                                   [cosine_map()], tol)


REFERENCES = {"oren_nayar": OrenNayarReference}
