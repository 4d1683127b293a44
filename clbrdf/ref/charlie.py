"""float64 reference of the Charlie sheen (clbrdf/models/charlie.py), from Estevez & Kulla 2017
(D, eq 2; the Lambda fit of Table 1) and Neubelt & Pettineo 2013 (the Ashikhmin visibility),
written without the kernel. Quadrature over the cosine map and the half-vector map of D cos
theta_h (inverse CDF s = u^(alpha / (2 alpha + 1)) of s = sin theta_h, reflected)."""
import numpy as np

from . import Reference
from .quadrature import (
    cosine_map,
    direction,
    dot,
    hemisphere_integral,
    normalize,
    reflect,
)

FIT = np.array([[21.5473, 3.82987, 0.19823, -1.97760, -4.32054],    # at (1 - alpha)^2 = 0
                [25.3245, 3.32435, 0.16801, -1.27393, -4.85967]])   # at (1 - alpha)^2 = 1


def D(h, alpha):
    sin2 = np.clip(h[..., 0] ** 2 + h[..., 1] ** 2, 0, 1)
    return (2 + 1 / alpha) * sin2 ** (0.5 / alpha) / (2 * np.pi)


def Lambda(mu, alpha):
    t = (1 - alpha) ** 2
    a, b, c, d, e = FIT[0] + (FIT[1] - FIT[0]) * t

    def L(x):
        return a / (1 + b * x ** c) + d * x + e
    mu = np.asarray(mu, float)
    return np.where(mu < 0.5, np.exp(L(np.minimum(mu, 0.5))), np.exp(2 * L(0.5) - L(1 - np.maximum(mu, 0.5))))


def charlie_map(wo, alpha):
    """Half vectors with density D cos theta_h, reflected: p(wi) = D h_z / (4 wo.h)."""
    k = alpha / (2 * alpha + 1)

    def points(s, t):
        with np.errstate(divide="ignore"):
            sn = np.where(s > 0, np.exp(k * np.log(np.maximum(s, 1e-300))), 0.0)
        hz = np.sqrt(np.maximum(1 - sn * sn, 0))
        phi = 2 * np.pi * t
        h = np.stack([sn * np.cos(phi), sn * np.sin(phi), hz], -1)
        return reflect(wo, h), np.ones_like(s)

    def density(wi):
        h = normalize(wi + wo)
        with np.errstate(divide="ignore", invalid="ignore"):
            p = D(h, alpha) * h[..., 2] / (4 * dot(wo, h))
        return np.where(wi[..., 2] > 0, p, 0.0)
    return points, density


class CharlieReference(Reference):
    def eval1(self, wo, wi, v, c):
        alpha = float(v["alpha"])
        ci, co = wi[..., 2], wo[..., 2]
        ok = (ci > 0) & (co > 0)
        h = normalize(wi + wo)
        with np.errstate(invalid="ignore", divide="ignore"):
            if self.options.get("visibility", "charlie") == "ashikhmin":
                vis = 1 / (4 * (ci + co - ci * co))
            else:
                vis = 1 / (4 * ci * co * (1 + Lambda(ci, alpha) + Lambda(co, alpha)))
            f = v["ks"] * D(h, alpha) * vis
        return np.where(ok, f, 0.0)

    def pdf(self, wo, wi):
        wo, wi = np.asarray(wo, float), np.asarray(wi, float)
        return charlie_map(wo, float(self.params["alpha"]))[1](wi) * (wo[..., 2] > 0)

    def albedo1(self, mu, phi, tol, v, c):
        wo = direction(mu, phi)
        maps = [cosine_map(), charlie_map(wo, float(v["alpha"]))]
        return hemisphere_integral(lambda wi: self.eval1(wo, wi, v, c) * wi[..., 2], maps, tol)


REFERENCES = {"charlie": CharlieReference}
