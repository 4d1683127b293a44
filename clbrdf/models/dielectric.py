"""Rough dielectric interfaces: microfacet reflection and refraction over the whole sphere (Walter
et al. 2007) with a GGX or Beckmann distribution. Kernel: kernels/dielectric.h; reference:
clbrdf.ref.dielectric; docs/models/dielectric.md.

``eta`` is the index of refraction of the side below the surface (z < 0) relative to the side
above: a wo below the surface sees 1/eta. E = E_R + E_T; ``lobes`` keeps one of the terms (the
reflection or the transmission albedo), ``transport`` picks importance (energy: what renderers'
glass tables integrate) or radiance (Walter's BTDF, with the 1/eta^2 of radiance crossing the
interface). eta = 1 is no interface: all light passes straight through (a delta of weight 1);
``eta_one="limit"`` makes it the limit eta -> 1 of the microfacet model instead (OpenPBR's tables).
"""
import numpy as np

from .microfacet import ROUGH, SWEPT, roughness
from .spec import Facts, ModelSpec, Option, Param, Resolved

ETA = (0.01, 100.0)

PARAMS = (
    Param("alpha", "roughness (isotropic)", *ROUGH, 0.5),
    Param("alpha_x", "roughness along the tangent x (anisotropic)", *ROUGH, 0.5),
    Param("alpha_y", "roughness along the bitangent y (anisotropic)", *ROUGH, 0.5),
    Param("eta", "index of refraction below the surface relative to above (1/eta seen from below)",
          *ETA, 1.5),
)

OPTIONS = (
    Option("masking", "masking-shadowing term G of both branches: height-correlated 1 / (1 + "
           "Lo + Li) (as Cycles, pbrt-v4), separable G1 G1 (Walter 2007, Mitsuba 3), or beta: "
           "height-correlated exactly, B(1 + Lo, 1 + Lt) for refraction (the random walk's)",
           ("correlated", "separable", "beta"), "correlated"),
    Option("sampler", "the normals the sampler draws: visible normals or normals", ("vndf", "ndf"),
           "vndf"),
    Option("lobes", "the terms f has: reflection and transmission, or one of them",
           ("both", "reflection", "transmission"), "both"),
    Option("transport", "the refracted term's convention: importance (energy) or radiance "
           "(times 1/eta^2)", ("importance", "radiance"), "importance"),
    Option("eta_one", "eta = 1: no interface (the light passes, weight 1) or the limit eta -> 1 "
           "of the microfacet model (weight G / G1)", ("no_interface", "limit"), "no_interface"),
)


def configure(dist: str):
    def fn(opts: dict, given: set):
        rough = roughness(given)
        o = {"masking": opts.get("masking", "correlated"), "sampler": opts.get("sampler", "vndf"),
             "lobes": opts.get("lobes", "both"), "transport": opts.get("transport", "importance"),
             "eta_one": opts.get("eta_one", "no_interface")}
        lobes = {"both": "DI_BOTH", "reflection": "DI_REFLECTION",
                 "transmission": "DI_TRANSMISSION"}[o["lobes"]]
        defines = (("MF_DIST", dist), ("MF_ANISO", str(int(len(rough) == 2))),
                   ("MF_MASKING", f"MASKING_{o['masking'].upper()}"),
                   ("MF_SAMPLER", f"SAMPLER_{o['sampler'].upper()}"),
                   ("DI_LOBES", lobes), ("DI_TRANSPORT", f"DI_{o['transport'].upper()}"),
                   ("DI_ETA1", "DI_ETA1_LIMIT" if o["eta_one"] == "limit" else "DI_ETA1_NONE"))
        return Resolved(defines, rough + ("eta",), o)
    return fn


def critical_mu(defines: dict, values: dict, channels: int):
    """E(mu) has a kink at the critical angle of a smooth interface, mu = sqrt(1 - eta^2) for
    eta < 1 (where total internal reflection starts); NaN where there is none."""
    eta = np.asarray(values["eta"], dtype=np.float64)
    mu = np.where(eta < 1, np.sqrt(np.clip(1 - eta * eta, 0, 1)), np.nan)
    return mu[..., None]


def energy_bound(defines: dict, values: dict, mu):
    """Energy conservation, E_R + E_T (n_i / n_o)^2 <= 1 in radiance form: E <= max(1, (n_o /
    n_i)^2), n_o and n_i the indices of wo's and of the refracted direction's sides."""
    mu = np.asarray(mu, float)
    if defines["DI_TRANSPORT"] != "DI_RADIANCE":
        return np.ones(mu.shape)
    eta = np.asarray(values["eta"], float)
    rel = np.where(mu > 0, eta, 1 / eta)            # n_i / n_o
    return np.maximum(1.0, 1 / rel ** 2)


def spec(dist: str, title: str, reference: str, facts: Facts) -> ModelSpec:
    return ModelSpec(
        name=f"{dist}_dielectric", title=title, reference=reference, header="dielectric.h",
        page="models/dielectric.md",
        prefix="dielectric", params=PARAMS, options=OPTIONS, configure_fn=configure(dist),
        notes="alpha_x and alpha_y (instead of alpha) make it anisotropic; eta = 1 is no "
              "interface (all light passes straight through)",
        anisotropic_fn=lambda d, v: d.get("MF_ANISO") == "1", mu_kinks_fn=critical_mu,
        ref="dielectric", transmits=True, facts=facts, energy_bound_fn=energy_bound,
        deltas_fn=lambda d, v: (np.asarray(v["eta"]) == 1) & (d["DI_LOBES"] != "DI_REFLECTION"),
        deltas_text="eta = 1 (no interface: the light passes straight through)")


GGX = spec("ggx", "Rough dielectric (reflection and refraction), GGX distribution",
           "Walter et al. 2007 eqs 13-21 (BSDF), eq 33 (D); Heitz 2018 / Dupuy & Benyoub 2023 (VNDF)",
           Facts(sweeps=((("alpha",), SWEPT),),
                 capi=(("ggx-dielectric", {"alpha": 0.3, "eta": 1.5}),
                       ("ggx-dielectric-inside", {"alpha": 0.2, "eta": 0.7, "masking": "separable"})),
                 sharp={"alpha": 0.01}, roughest={"alpha": 1e-3},
                 ladder={"alpha": 0.3, "eta": 1.5}))
BECKMANN = spec("beckmann", "Rough dielectric (reflection and refraction), Beckmann distribution",
                "Walter et al. 2007 eqs 13-21 (BSDF), eq 25 (D), eq 27 (Lambda); Heitz & d'Eon 2014 (VNDF)",
                Facts(sweeps=((("alpha",), SWEPT),),
                      capi=(("beckmann-dielectric", {"alpha": 0.25, "eta": 1.33}),),
                      sharp={"alpha": 0.01}, roughest={"alpha": 1e-3}))

SPECS = (GGX, BECKMANN)
