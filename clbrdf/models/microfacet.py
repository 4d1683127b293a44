"""Microfacet reflection with a Beckmann or GGX distribution. Kernel: kernels/microfacet.h.

f = ks F(wi.h) D(h) G(wi, wo, h) / (4 cos_i cos_o) + kd / pi  (Walter et al. 2007 eq 20;
docs/models/microfacet.md). Only the terms a configuration uses are compiled: the Fresnel term follows
the ``fresnel`` option (or, when it is not given, the Fresnel parameters given: f0 or f90 ->
schlick, eta -> dielectric, eta and k -> conductor; f90 gives Schlick's F a grazing value other
than 1, as Filament, UE and three.js do to split E into the scale and bias of F0), the Lambertian term is compiled when kd is given, the
scale ks when ks is given, and alpha_x/alpha_y select the anisotropic form. f0, eta, k, ks and kd
are per channel in an RGB model (channels=3).

Other distributions plug in with ``spec(name, ..., header="dist_<name>.h", shape=Param(...))``:
the header provides <name>_D, <name>_Lambda, <name>_sample_ndf (and <name>_sample_vndf) on a
``Microfacet`` whose ``shape`` field holds the extra parameter.
"""
from .spec import Facts, ModelSpec, Option, Param, ParameterError, Resolved

ROUGH = (1e-4, 10.0)
# the roughnesses of the stability map (clbrdf.studies.stability), from near-mirror to matte
SWEPT = (1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0)
# single precision at f0 = 0: Schlick's (1 - c)^5 carries the float32 rounding of c = wi.h, off by
# 5 eps / (1 - c) relative (6.5e-5 at 1 - c = 2.4e-3, F = 8e-14); the stable form
# 1 - c = |wo - wi|^2 / (4 (1 + c)) needs wo and wi at each Fresnel call

PARAMS = (
    Param("alpha", "roughness (isotropic)", *ROUGH, 0.5),
    Param("alpha_x", "roughness along the tangent x (anisotropic)", *ROUGH, 0.5),
    Param("alpha_y", "roughness along the bitangent y (anisotropic)", *ROUGH, 0.5),
    Param("f0", "Schlick Fresnel reflectance at normal incidence", 0.0, 1.0, 0.04, spectral=True),
    Param("f90", "Schlick Fresnel reflectance at grazing incidence (generalised Schlick)", 0.0,
          1.0, 1.0, spectral=True),
    Param("exponent", "exponent of the generalised Schlick term (1 - c)^exponent (Cycles)", 0.0,
          1e5, 5.0, lo_open=True),
    Param("f82", "F82-tint: reflectance at cos 1/7 as a fraction of Schlick's (Hoffman 2023)",
          0.0, 1.0, 1.0, spectral=True),
    Param("eta", "relative index of refraction (dielectric) or its real part (conductor)",
          0.0, 100.0, 1.5, lo_open=True, spectral=True),
    Param("k", "extinction coefficient (conductor)", 0.0, 100.0, 3.0, spectral=True),
    Param("ks", "scale of the specular term", 0.0, 1e6, 1.0, spectral=True),
    Param("kd", "albedo of the added Lambertian term", 0.0, 1.0, 0.0, spectral=True),
)

OPTIONS = (
    Option("masking", "masking-shadowing term G",
           ("correlated", "separable", "vcavity", "none", "unshadowed"), "correlated"),
    Option("fresnel", "Fresnel term F", ("one", "schlick", "gen_schlick", "f82", "remapped",
                                          "dielectric", "conductor"), "one"),
    Option("sampler", "importance sampler of the specular lobe: visible normals or normals",
           ("vndf", "ndf"), "vndf"),
)

FRESNEL_PARAMS = {"one": (), "schlick": ("f0",), "gen_schlick": ("f0", "f90", "exponent"),
                  "f82": ("f0", "f82"), "remapped": ("f0", "f90", "eta"), "dielectric": ("eta",),
                  "conductor": ("eta", "k")}
# every parameter of a Fresnel term (fresnel_avg, the tables' Fresnel axes)
FRESNEL_NAMES = ("f0", "f90", "exponent", "f82", "eta", "k")


def roughness(given: set) -> tuple:
    """The roughness parameters the kernel reads: alpha, or alpha_x and alpha_y (anisotropic)
    where either is given."""
    if {"alpha_x", "alpha_y"} & given:
        if "alpha" in given:
            raise ParameterError("give either alpha (isotropic) or alpha_x and alpha_y "
                                 "(anisotropic), not both")
        return ("alpha_x", "alpha_y")
    return ("alpha",)


def configure(dist: str, shape: str | None = None, header: str | None = None,
              samplers=("vndf", "ndf")):
    def fn(opts: dict, given: set):
        rough = roughness(given)
        fresnel = opts.get("fresnel")
        if fresnel is None:
            fresnel = ("conductor" if {"eta", "k"} <= given else "dielectric" if "eta" in given
                       else "gen_schlick" if "exponent" in given else "f82" if "f82" in given
                       else "schlick" if {"f0", "f90"} & given else "one")
        masking = opts.get("masking", "correlated")
        sampler = opts.get("sampler", samplers[0])
        if sampler not in samplers:
            raise ParameterError(f"option sampler={sampler!r} is not available for {dist}: "
                                 f"choose one of {', '.join(samplers)}")
        diffuse = "kd" in given
        ks = "ks" in given
        f90 = fresnel == "schlick" and "f90" in given
        defines = (
            ("MF_DIST", dist),
            ("MF_ANISO", str(int(len(rough) == 2))),
            ("MF_MASKING", f"MASKING_{masking.upper()}"),
            ("MF_FRESNEL", f"FRESNEL_{fresnel.upper()}"),
            ("MF_DIFFUSE", str(int(diffuse))),
            ("MF_SAMPLER", f"SAMPLER_{sampler.upper()}"),
            ("MF_KS", str(int(ks))),
            ("MF_F90", str(int(f90))),
        ) + ((("MF_SHAPE", shape),) if shape else ())
        used = (rough + ((shape,) if shape else ()) + FRESNEL_PARAMS[fresnel]
                + (("f90",) if f90 else ())
                + (("ks",) if ks else ()) + (("kd",) if diffuse else ()))
        return Resolved(defines, used, {"masking": masking, "fresnel": fresnel,
                                        "sampler": sampler}, (header,) if header else ())
    return fn


def critical_mu(defines: dict, values: dict, channels: int):
    """Where F(c) has a kink (or, for a conductor with small k, a bend as sharp as k): the
    Fresnel's inner square root sqrt(eta^2 - k^2 - sin^2) (kernels/fresnel.h) changes from
    imaginary to real at sin^2 = eta^2 - k^2, i.e. mu = sqrt(1 - eta^2 + k^2) where
    0 < eta^2 - k^2 < 1 (a dielectric: k = 0, total reflection beyond the critical angle), and
    so does E of a smooth surface (one per channel); NaN elsewhere. Derived from the Fresnel's
    parameters, not its name: a conductor with eta < 1 and k ~ 0 has the dielectric's kink."""
    import numpy as np
    fres = defines.get("MF_FRESNEL")
    if fres not in ("FRESNEL_DIELECTRIC", "FRESNEL_REMAPPED", "FRESNEL_CONDUCTOR"):
        return None
    eta = np.asarray(values["eta"], dtype=np.float64)
    k = np.asarray(values["k"], dtype=np.float64) if fres == "FRESNEL_CONDUCTOR" else 0.0
    d = eta * eta - k * k
    mu = np.where((d > 0) & (d < 1), np.sqrt(np.clip(1 - d, 0, 1)), np.nan)
    return mu if channels > 1 else mu[..., None]


def spec(name: str, title: str, reference: str, *, header: str | None = None,
         shape: Param | None = None, samplers=("vndf", "ndf"), aniso: bool = True,
         ref: str = "microfacet", facts: Facts = Facts(),
         page: str = "models/microfacet.md") -> ModelSpec:
    """A microfacet model with distribution ``name`` (see the module docstring)."""
    params = PARAMS + ((shape,) if shape else ())
    if not aniso:
        params = tuple(p for p in params if p.name not in ("alpha_x", "alpha_y"))
    options = tuple(Option(o.name, o.meaning, samplers, samplers[0]) if o.name == "sampler" else o
                    for o in OPTIONS)
    notes = ("fresnel defaults to the Fresnel parameters given: f0 -> schlick, eta -> dielectric, "
             "eta and k -> conductor, none -> one; f90 (with schlick) makes it F0 + (F90 - F0)(1 - c)^5; ks scales the specular term; kd adds a "
             "Lambertian term" + ("; alpha_x and alpha_y (instead of alpha) make it anisotropic"
                                  if aniso else ""))
    return ModelSpec(name=name, title=title, reference=reference, header="microfacet.h",
                     prefix="microfacet", params=params, options=options,
                     configure_fn=configure(name, shape.name if shape else None, header, samplers),
                     notes=notes, anisotropic_fn=lambda d, v: d.get("MF_ANISO") == "1",
                     mu_kinks_fn=critical_mu, ref=ref, facts=facts, page=page)


GGX = spec("ggx", "Microfacet, GGX (Trowbridge-Reitz) distribution",
           "Walter et al. 2007 eq 33 (D), Smith Lambda; Heitz 2018 / Dupuy & Benyoub 2023 (VNDF)",
           facts=Facts(
               sweeps=((("alpha",), SWEPT),),
               capi=(("ggx", {"alpha": 0.3}),
                     ("ggx-schlick-rgb", {"alpha": 0.15, "f0": [0.9, 0.6, 0.3], "channels": 3}),
                     ("ggx-aniso-conductor", {"alpha_x": 0.05, "alpha_y": 0.4, "eta": 0.2, "k": 3.0}),
                     ("ggx-dielectric-diffuse", {"alpha": 0.5, "eta": 1.5, "kd": 0.3}),
                     ("ggx-separable-ndf", {"alpha": 0.2, "masking": "separable", "sampler": "ndf"})),
               sharp={"alpha": 0.01}, roughest={"alpha": 1e-3},
               ladder={"alpha": 0.3, "fresnel": "dielectric", "eta": 1.5, "kd": 0.2}))
BECKMANN = spec("beckmann", "Microfacet, Beckmann distribution",
                "Walter et al. 2007 eq 25 (D), eq 27 (Lambda); Heitz & d'Eon 2014 (VNDF)",
                facts=Facts(
                    sweeps=((("alpha",), SWEPT),),
                    capi=(("beckmann", {"alpha": 0.25}),
                          ("beckmann-vcavity", {"alpha": 0.6, "masking": "vcavity", "f0": 0.5})),
                    sharp={"alpha": 0.01}, roughest={"alpha": 1e-3},
                    ladder={"alpha": 0.3, "fresnel": "conductor", "eta": 0.2, "k": 3.0}))

SPECS = (GGX, BECKMANN)


def low_cook_torrance(fit: dict):
    """Löw et al. 2012's Cook-Torrance fits (bbm ``LowCookTorrance``: bsdfmodel/cooktorrance.h):
    f = albedo F(eta) D_ct G_vgroove / (pi cos_i cos_o) with the unnormalised Beckmann
    D_ct = exp(-tan^2 / m^2) / (m^2 cos^4) = pi D, so f = 4 albedo F D G / (4 cos_i cos_o):
    ks = 4 albedo; plus the Lambertian albedo / pi."""
    ct = fit["LowCookTorrance"]
    return ({"fresnel": "dielectric", "masking": "vcavity"},
            {"alpha": ct["roughness"], "eta": ct["eta"], "ks": [4 * a for a in ct["albedo"]],
             "kd": fit["Lambertian"]["albedo"]})


def metal(row: dict):
    """A conductor of published optical constants (metals_rgb.csv: n + i k at R, G, B)."""
    return ({"fresnel": "conductor"},
            {"eta": [row[f"eta_{c}"] for c in "rgb"], "k": [row[f"k_{c}"] for c in "rgb"]})


def openpbr_specular(row: dict):
    """OpenPBR Surface's specular lobes at their defaults (published_fits/openpbr.md): the
    dielectric (eta = specular_ior) or the metal (F82-tint, F0 = base_color, tint =
    specular_color), alpha = specular_roughness^2."""
    alpha = row["roughness"] ** 2
    if row["lobe"] == "dielectric":
        return ({"fresnel": "dielectric"}, {"alpha": alpha, "eta": [row["ior"]] * 3})
    if row["lobe"] == "metal":
        return ({"fresnel": "f82"}, {"alpha": alpha, "f0": [row[f"color_{c}"] for c in "rgb"],
                                     "f82": [row[f"specular_color_{c}"] for c in "rgb"]})
    raise ParameterError(f"preset {row['name']!r}: lobe {row['lobe']!r} is not a specular one")


PRESETS = {"low_cooktorrance_E2.fit": ("beckmann", low_cook_torrance),
           "low_cooktorrance_E1.fit": ("beckmann", low_cook_torrance),
           "metals_rgb.csv": [("ggx", metal), ("beckmann", metal)],
           "openpbr_specular.csv": ("ggx", openpbr_specular)}
