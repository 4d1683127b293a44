"""Schlick 1994, the customizable reflectance model. Kernel: kernels/schlick.h.

SINGLE R = S(u) D, DOUBLE R = S(u) D + (1 - S(u)) S2(u) D2 (eq 9); S = c (eq 10) or
c + (1 - c)(1 - u)^5 (eq 11); D one of eq 12, 15, 17, 18 with Z and A of eq 14, G of eq 16.
Options: ``material`` (single | double), ``spectral`` (constant = eq 10 | fresnel = eq 11),
``directional`` (eq18 | eq17 | eq15 | eq12). Parameters per layer: c (per channel), r, p, psi;
layer 2 of DOUBLE: c2, r2, p2, psi2. The azimuthal factor A and the scratch angle are compiled
only when p or psi (p2 or psi2) is given; otherwise the layer is isotropic (p = 1, A = 1).
The sampler is ours (the paper has none): see kernels/schlick.h and docs/models/schlick.md.
"""
from math import pi

from .spec import Facts, ModelSpec, Option, Param, ParameterError, Resolved

R_MIN = 1e-7          # r -> 0 is a mirror (a Dirac), which a BRDF kernel cannot represent
P_MIN = 1e-6          # p -> 0 makes A a Dirac in the azimuth

PARAMS = (
    Param("c", "reflection factor C at normal incidence (layer 1)", 0.0, 1.0, 1.0, spectral=True),
    Param("r", "roughness (layer 1): 0 mirror .. 1 Lambertian", R_MIN, 1.0, 0.5),
    Param("p", "isotropy (layer 1): 0 fully anisotropic .. 1 isotropic", P_MIN, 1.0, 1.0),
    Param("psi", "angle of the scratch direction (cos psi, sin psi, 0) in the tangent plane, "
          "radians (layer 1)", -2 * pi, 2 * pi, 0.0),
    Param("c2", "reflection factor C' at normal incidence (layer 2 of DOUBLE)", 0.0, 1.0, 1.0,
          spectral=True),
    Param("r2", "roughness (layer 2 of DOUBLE)", R_MIN, 1.0, 1.0),
    Param("p2", "isotropy (layer 2 of DOUBLE)", P_MIN, 1.0, 1.0),
    Param("psi2", "angle of the scratch direction (layer 2 of DOUBLE), radians", -2 * pi, 2 * pi, 0.0),
)

OPTIONS = (
    Option("material", "SINGLE (homogeneous) or DOUBLE (a layer over another), eq 9",
           ("single", "double"), "single"),
    Option("spectral", "spectral factor S(u): constant C (eq 10) or Fresnel-like (eq 11)",
           ("constant", "fresnel"), "constant"),
    Option("directional", "directional factor D: eq 18 (shadowing with reemission), eq 17 "
           "(Lambertian interpolation), eq 15 (shadowing), eq 12 (plain)",
           ("eq18", "eq17", "eq15", "eq12"), "eq18"),
)


def configure(opts: dict, given: set):
    material = opts.get("material", "single")
    spectral = opts.get("spectral", "constant")
    directional = opts.get("directional", "eq18")
    double = material == "double"
    layer2 = {"c2", "r2", "p2", "psi2"} & given
    if layer2 and not double:
        raise ParameterError(f"parameter {sorted(layer2)[0]} belongs to layer 2: it needs "
                             f"material=double")
    aniso1 = bool({"p", "psi"} & given)
    aniso2 = double and bool({"p2", "psi2"} & given)
    used = ("c", "r") + (("p", "psi") if aniso1 else ())
    if double:
        used += ("c2", "r2") + (("p2", "psi2") if aniso2 else ())
    defines = (("SCH_DOUBLE", str(int(double))), ("SCH_FRESNEL", str(int(spectral == "fresnel"))),
               ("SCH_EQ", directional[2:]), ("SCH_ANISO1", str(int(aniso1))),
               ("SCH_ANISO2", str(int(aniso2))))
    return Resolved(defines, used, {"material": material, "spectral": spectral,
                                    "directional": directional})


SPEC = ModelSpec(
    page="models/schlick.md",
    name="schlick",
    ref="schlick",
    title="Schlick 1994 customizable reflectance (SINGLE / DOUBLE, eq 12/15/17/18)",
    reference="Schlick 1994 eq 9 (materials), 10-11 (S), 12/15/17/18 (D), 14 (Z, A), 16 (G); "
              "sampler: ours, the paper has none (kernels/schlick.h)",
    header="schlick.h",
    prefix="schlick",
    params=PARAMS,
    options=OPTIONS,
    configure_fn=configure,
    anisotropic_fn=lambda d, v: d["SCH_ANISO1"] == "1" or d["SCH_ANISO2"] == "1",
    facts=Facts(
        sweeps=((("r",), (1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.1, 0.5, 1.0)),),
        capi=(("schlick", {}), ("schlick-aniso", {"p": 0.2, "psi": 0.5})),
        sharp={"r": 1e-3},
        ladder={"material": "double", "spectral": "fresnel", "c": 0.6, "r": 0.2, "r2": 0.8}),
)

SPECS = (SPEC,)
