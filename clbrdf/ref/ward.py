"""float64 reference of the Ward model (clbrdf/models/ward.py), from Ward 1992 eq 5b and Walter
2005 eq 6-9, written without the kernel. Quadrature: the specular term over the half-vector map
of a Beckmann distribution with the same alpha_x, alpha_y (its density D h_z / (4 wo.h) is the
sampler's, Walter eq 9), the Lambertian term exactly (kd)."""
import numpy as np

from . import Reference
from .microfacet import halfvector_map
from .quadrature import INV_PI, direction, half_cos, hemisphere_integral


def _parts(wo, wi, ax, ay):
    """(exp(-tan^2 theta_h (cos^2 phi_h / ax^2 + sin^2 phi_h / ay^2)), h) for h = wi + wo."""
    h = wi + wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", over="ignore"):
        e = np.exp(-((h[..., 0] / ax) ** 2 + (h[..., 1] / ay) ** 2) / h[..., 2] ** 2)
    return e, h


class WardReference(Reference):
    def eval1(self, wo, wi, v, c):
        ax, ay = float(v["alpha_x"]), float(v["alpha_y"])
        ci, co = wi[..., 2], wo[..., 2]
        ok = (ci > 0) & (co > 0)
        e, _ = _parts(wo, wi, ax, ay)
        with np.errstate(invalid="ignore", divide="ignore"):
            f = v["ks"] * e / (4 * np.pi * ax * ay * np.sqrt(ci * co)) + v.get("kd", 0.0) * INV_PI
        return np.where(ok, f, 0.0)

    def pdf(self, wo, wi):
        ax, ay = float(self.params["alpha_x"]), float(self.params["alpha_y"])
        e, h = _parts(wo, wi, ax, ay)
        with np.errstate(invalid="ignore", divide="ignore"):
            lobe = e / (np.pi * ax * ay * h[..., 2] ** 3) / (4 * half_cos(wo, wi))
        if "kd" in self.params:                   # channel sums, as the kernel's mixture
            kd = sum(float(v["kd"]) for v in self.channel_values())
            ks = sum(float(v["ks"]) for v in self.channel_values())
            pd = kd / (kd + ks) if kd + ks > 0 else 0.0
            lobe = pd * wi[..., 2] * INV_PI + (1 - pd) * lobe
        return np.where((wi[..., 2] > 0) & (wo[..., 2] > 0), lobe, 0.0)

    def albedo1(self, mu, phi, tol, v, c):
        wo = direction(mu, phi)
        hv = halfvector_map("beckmann", wo, float(v["alpha_x"]), float(v["alpha_y"]))
        kd = float(v.get("kd", 0.0))
        spec = dict(v, kd=0.0)
        e, err = hemisphere_integral(lambda wi: self.eval1(wo, wi, spec, c) * wi[..., 2], [hv], tol)
        return e + kd, err


REFERENCES = {"ward": WardReference}
