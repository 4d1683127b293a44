"""Double-precision reference of the rough dielectric (Walter et al. 2007), written from the paper
in its own notation, independently of kernels/dielectric.h.

Walter's directions: i the light's (our wi), o the viewer's (our wo), both pointing away from the
surface, with the indices eta_i, eta_o of the media they lie in (1 above, eta below). Then

    reflection (i, o on one side):  h_r = sign(i.n) normalize(i + o)                      (eq 13)
        f_r = F(i.h_r) D(h_r) G(i, o, h_r) / (4 |i.n| |o.n|)                              (eq 20)
    refraction (opposite sides):    h_t = -normalize(eta_i i + eta_o o)                   (eq 16)
        f_t = |i.h| |o.h| / (|i.n| |o.n|) eta_o^2 (1 - F(i.h)) D(h) G(i, o, h)
              / (eta_i (i.h) + eta_o (o.h))^2                                           (eq 21)

eq 21 is the radiance form; the importance (energy) form is f_t (eta_i / eta_o)^2. F(i.h) is the
Fresnel reflectance seen from i's side (the relative index eta_t / eta_i across the facet), D and
the Smith Lambda those of clbrdf.ref.microfacet, with a direction below the surface masked as
its mirror image. The sidedness factors chi+((v.h) / (v.n)) of eq 23 decide which (i, o, h) are
possible. Where the kernel flips its frame, this reference keeps the world frame; it computes
a refracted pair's Fresnel reflectance (the kernel: its transmittance, by another formula) from
the rarer medium's side.

The albedo (not by the kernel's visible-normal sampler): E_R integrates f |cos_i| over the
half-vector map of clbrdf.ref.microfacet (eta >= 1; eta < 1: as E_T, with F G(wo, wr) for
wr the reflected direction); E_T = int (1 - F) G(wo, wt) t (wo.h) / |wo.n| D dh over
the normals h facing wo, drawn by inverting the distribution's CDF, wt the refracted direction,
t = 1 for importance and (eta_o / eta_i)^2 for radiance.
"""
import numpy as np
from scipy import special

from . import Reference
from .microfacet import D as D_, Lambda as Lambda_, fresnel
from .microfacet import halfvector_map, rough
from .quadrature import (
    gauss01,
    adaptive_gl1,
    adaptive_gl2,
    direction,
    dot,
    hemisphere_integral,
    normalize,
)


def beta_ge1(a, b):
    """The Beta function B(a, b) for a, b >= 1 as Gamma(p) / poch(q, p) (p = min, q = max):
    within 3e-11 of a 40-digit log B up to 1e7 (tests/runtime/test_special.py's); scipy.special.betaln
    cancels for a large argument (9e-8 off in log)."""
    p, q = np.minimum(a, b), np.maximum(a, b)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        out = np.exp(special.gammaln(p) - np.log(special.poch(q, p)))
    return np.where(np.isinf(q), 0.0, out)


def _up(w):
    """w mirrored into the upper hemisphere (D and Lambda of the surface seen from below)."""
    w = np.asarray(w, float)
    return np.concatenate([w[..., :2], np.abs(w[..., 2:3])], -1)


class DielectricReference(Reference):
    reciprocal = False          # generalised: (studies) f(wo, wi) / n^2 of one side

    def __init__(self, spec, config, params):
        super().__init__(spec, config, params)
        self.dist = spec.name.split("_")[0]

    def rough(self):
        return rough(self.params)

    def D(self, h):
        return D_(self.dist, _up(h), *self.rough())

    def Lambda(self, w):
        return Lambda_(self.dist, _up(w), *self.rough())

    def G(self, wi, wo):
        li, lo = self.Lambda(wi), self.Lambda(wo)
        if self.options["masking"] == "separable":
            return 1 / ((1 + li) * (1 + lo))
        if self.options["masking"] == "beta":       # Heitz 2014: exact for uniform heights
            across = np.asarray(wi)[..., 2] * np.asarray(wo)[..., 2] < 0
            return np.where(across, beta_ge1(1 + li, 1 + lo), 1 / (1 + li + lo))
        return 1 / (1 + li + lo)

    def indices(self, w, eta):
        """The index of the medium direction w lies in: 1 above, eta below."""
        return np.where(w[..., 2] > 0, 1.0, eta)

    def keeps(self):
        lobes = self.options["lobes"]
        return lobes != "transmission", lobes != "reflection"

    def eval1(self, wo, wi, v, c):
        f, _ = self._eval_pdf(wo, wi, float(v["eta"]))
        return f

    def pdf(self, wo, wi):
        return self._eval_pdf(np.asarray(wo, float), np.asarray(wi, float),
                              float(self.params["eta"]))[1]

    def _eval_pdf(self, wo, wi, eta):
        wo, wi = np.broadcast_arrays(np.asarray(wo, float), np.asarray(wi, float))
        i, o = wi, wo
        ni, no = i[..., 2], o[..., 2]
        eta_i, eta_o = self.indices(i, eta), self.indices(o, eta)
        refl = ni * no > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            hr = np.sign(ni)[..., None] * normalize(i + o)
            ht = -normalize(eta_i[..., None] * i + eta_o[..., None] * o)
            h = np.where(refl[..., None], hr, ht)
            # the microfacet normal m = h or -h with m.n > 0 (the chi+(m.n) of D), and the
            # sidedness of eq 23: i.m and i.n alike, o.m and o.n alike
            h = h * np.where(h[..., 2] < 0, -1.0, 1.0)[..., None]
            ih, oh = dot(i, h), dot(o, h)
            ok = (ih * ni > 0) & (oh * no > 0) & (ni != 0) & (no != 0) & (h[..., 2] > 0)
            ok &= refl | (eta != 1)
            # F from the light's side: the index across the facet relative to eta_i
            # F of a refracted pair from the rarer medium's side, where the relative index
            # exceeds 1: F(c) seen from the denser side has an infinite slope at the critical
            # angle, so that a direction's rounding (|w| = 1 +- 1e-16) moved F by 4e-9
            across = np.where(refl, np.where(ni > 0, eta, 1 / eta), eta_o / eta_i)
            seen = np.where(refl | (across >= 1), np.abs(ih), np.abs(oh))
            across = np.where(refl | (across >= 1), across, 1 / across)
            F = np.where(across == 1, 0.0,      # exactly: eta^2 + c^2 - 1 rounds at eta = 1
                         fresnel("dielectric", np.clip(seen, 0, 1), eta=across))
            Dh, G = self.D(h), self.G(i, o)
            keep_r, keep_t = self.keeps()
            fr = keep_r * F * Dh * G / (4 * np.abs(ni * no))
            denom = (eta_i * ih + eta_o * oh) ** 2
            ft = (keep_t * np.abs(ih * oh) / np.abs(ni * no) * eta_o ** 2 * (1 - F) * Dh * G
                  / denom)
            if self.options["transport"] == "importance":
                ft = ft * (eta_i / eta_o) ** 2
            f = np.where(ok, np.where(refl, fr, ft), 0.0)
            # the sampler: normals of wo (visible or not), then reflection with probability
            # F (both lobes), 1 (reflection only) or 0 (transmission only)
            pr = {"both": F, "reflection": 1.0, "transmission": 0.0}[self.options["lobes"]]
            oh_abs = np.abs(oh)
            if self.options["sampler"] == "vndf":
                ph = Dh * oh_abs / np.abs(no) / (1 + self.Lambda(o))
            else:
                ph = Dh * np.abs(h[..., 2])
            jr = 1 / (4 * oh_abs)                             # eq 14
            jt = eta_i ** 2 * np.abs(ih) / denom              # eq 17, for the light's direction
            p = np.where(refl, pr * ph * jr, (1 - pr) * ph * jt)
            p = np.where(ok, p, 0.0)
        return np.nan_to_num(f), np.nan_to_num(p)

    # ---- albedo by quadrature over the microfacet normals
    def _normals(self, s, t, wo):
        """h from (s, t) in [0,1]^2 by the distribution's inverse CDF (as halfvector_map of
        clbrdf.ref.microfacet, without the reflection), and the Jacobian: int g(h) dh =
        int g(h(s, t)) / (D(h) h.z) jac ds dt. Isotropic: t runs over the azimuths of the normals
        wo sees (h.wo > 0) only, so that the integrand's kink where wo.h crosses 0 is an edge of
        the square (at mu = 1e-4 a rule across that curve was 4.5e-7 off, 900 times its error
        estimate, against 2^27 QMC samples and the kernel's quadrature)."""
        ax, ay = self.rough()
        iso = ax == ay
        if iso:
            mu, phi_o = wo[2], np.arctan2(wo[1], wo[0])
        x = 2 * np.pi * t
        phi = np.arctan2(ay * np.sin(x), ax * np.cos(x))
        a2 = 1 / ((np.cos(phi) / ax) ** 2 + (np.sin(phi) / ay) ** 2)
        if self.dist == "ggx":
            r = 1 - s                                  # u = 1 - r^2: smooth towards grazing h
            with np.errstate(divide="ignore"):
                tan2 = a2 * (1 - r) * (1 + r) / (r * r)
            jac = 2 * r
        else:
            with np.errstate(divide="ignore"):
                tan2 = -a2 * np.log1p(-s)
            jac = np.ones_like(s)
        cos_t = 1 / np.sqrt(1 + tan2)
        sin_t = np.sqrt(np.maximum(0.0, 1 - cos_t * cos_t))
        if iso:     # h.wo > 0: cos(phi - phi_o) > -cot(theta_h) cot(theta_o)
            with np.errstate(divide="ignore", invalid="ignore"):
                c0 = -cos_t * mu / (sin_t * np.sqrt(max(0.0, 1 - mu * mu)))
            half = np.arccos(np.clip(np.nan_to_num(c0, nan=-1.0), -1, 1))
            phi = phi_o + half * (2 * t - 1)
            jac = jac * half / np.pi
        h = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], -1)
        return h, jac

    def albedo1(self, mu, phi, tol, v, c):
        eta = float(v["eta"])
        if mu < 0:             # from below: the mirror image sees 1/eta
            mu, eta = -mu, 1 / eta
        wo = direction(mu, phi)
        keep_r, keep_t = self.keeps()
        if eta == 1:           # the delta straight through: weight 1, or G(wo, -wo) / G1(wo)
            if self.options.get("eta_one") == "limit":
                g = self.G(-wo, wo) * (1 + self.Lambda(wo))
                return float(keep_t * g), 0.0
            return float(keep_t), 0.0

        # reflection, eta >= 1: f over the half-vector map of clbrdf.ref.microfacet, which keeps
        # wi above the horizon (the kink where G drops to 0 is the edge of its square; over the
        # normals below it was 3.3e-7 off at mu = 1e-3, 4000 times the rule's error estimate).
        # eta < 1: over the normals with the refraction (that map does not resolve the kink of F
        # at the critical angle: 4.4e-8 off at mu = 0.5, eta = 1/1.5, 12 times its estimate)
        e_r, err_r = 0.0, 0.0
        hv_r = keep_r and eta >= 1
        if hv_r:
            hv = halfvector_map(self.dist, wo, *self.rough())
            e_r, err_r = hemisphere_integral(
                lambda wi: self._eval_pdf(np.broadcast_to(wo, wi.shape), wi, eta)[0] * wi[..., 2],
                [hv], tol / 2)

        def func(s, t):
            h, jac = self._normals(s, t, wo)
            with np.errstate(divide="ignore", invalid="ignore"):
                oh = dot(wo, h)
                F = fresnel("dielectric", np.clip(oh, 0, 1), eta=eta)
                # Snell: wt = -wo/eta + (oh/eta - cos_t) h, cos_t = sqrt(1 - (1 - oh^2)/eta^2)
                ct2 = 1 - (1 - oh * oh) / eta ** 2
                ct = np.sqrt(np.maximum(ct2, 0))
                wt = -wo / eta + (oh / eta - ct)[..., None] * h
                base = oh / mu / h[..., 2] * jac            # (wo.h) / cos_o D dh / (D h.z)
                gt = np.where((wt[..., 2] < 0) & (ct2 > 0), self.G(wt, wo), 0.0)
                tt = 1.0 if self.options["transport"] == "importance" else 1 / eta ** 2
                g = base * keep_t * (1 - F) * gt * tt
                if keep_r and not hv_r:
                    wr = 2 * oh[..., None] * h - wo
                    g = g + base * F * np.where(wr[..., 2] > 0, self.G(wr, wo), 0.0)
            return np.where((oh > 0) & np.isfinite(g), g, 0.0)
        if not (keep_t or (keep_r and not hv_r)):
            return e_r, err_r
        e_t, err_t = adaptive_gl2(func, tol / 2 if hv_r else tol)
        return e_r + e_t, err_r + err_t

    def albedo_avg(self, tol=1e-6, n_phi=8):
        """E_avg = 2 int_0^1 E(mu) mu dmu (and the azimuth average where anisotropic)."""
        def over_mu(phi):
            return adaptive_gl1(lambda x: 4 * self.albedo(x * x, phi, tol / 10)[0] * x ** 3
                                if x else 0.0, 0.0, 1.0, tol / 2)
        ax, ay = self.rough()
        if ax == ay:
            return over_mu(0.0)
        xs, ws = gauss01(n_phi)
        parts = [over_mu(np.pi / 2 * xk) for xk in xs]
        return sum(w * p[0] for w, p in zip(ws, parts)), sum(w * p[1] for w, p in zip(ws, parts))


REFERENCES = {"ggx_dielectric": DielectricReference, "beckmann_dielectric": DielectricReference}
