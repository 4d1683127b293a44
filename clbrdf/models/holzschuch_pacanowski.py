"""Holzschuch & Pacanowski 2015 (reflection + diffraction) and the exponential-power microfacet
distribution it introduces. Kernels: kernels/holzschuch_pacanowski.h, kernels/dist_exppow.h
(Smith Lambda from kernels/exppow_g1_table.h, made by scripts/exppow_g1_table.py; the sampler's
inverse incomplete gamma function in kernels/special.h).

``holzschuch_pacanowski``: f = kd/pi + G (ks D F / (4 cos_i cos_o) + kw/lambda^4 S(f_s)/E)
(eq 24-27); kd, ks, f0, kw per channel; a, sigma, p shared. Wavelengths R, G, B = 0.645, 0.526,
0.444 um; a one-channel model takes the wavelength of ``band`` (green by default).
``diffraction_norm``: ``conserving`` (E = pi a^2 lambda^2 / (1 + a^2 lambda^2), the lobe's
albedo is at most 1) or ``paper`` (E = pi (1 + 1/(a^2 lambda^2)) as printed).

``exppow``: the microfacet model (clbrdf.models.microfacet) with D = exponential power; ``alpha``
is sigma, ``p`` the kurtosis; isotropic; sampler ``ndf`` (eq 22-23).
"""
from . import microfacet
from .spec import Facts, ModelSpec, Option, Param, Resolved

WAVELENGTHS = {"red": 0.645, "green": 0.526, "blue": 0.444}

P_PARAM = Param("p", "exponential-power kurtosis: P22 ~ exp(-(tan^2 theta / sigma^2)^p)", 0.1, 5.0, 1.0)

PARAMS = (
    Param("kd", "diffuse albedo", 0.0, 1.0, 0.0, spectral=True),
    Param("ks", "reflection (Cook-Torrance) lobe scale", 0.0, 1e6, 1.0, spectral=True),
    Param("f0", "Schlick Fresnel reflectance at normal incidence of the reflection lobe",
          0.0, 1.2, 1.0, spectral=True),
    Param("kw", "diffraction lobe scale (the lobe is kw / lambda^4 S / E, lambda in um)",
          0.0, 1e6, 0.0, spectral=True),
    Param("a", "diffraction lobe width a (1/um): S = 1 / (1 + f^2 / a^2)^2", 0.0, 100.0, 1.0,
          lo_open=True),
    Param("sigma", "exponential-power width sigma", 1e-4, 10.0, 0.1),
    P_PARAM,
)

OPTIONS = (
    Option("diffraction_norm", "E_a_lambda: conserving = pi c/(1+c), paper = pi (1 + 1/c), "
           "c = a^2 lambda^2", ("conserving", "paper"), "conserving"),
    Option("band", "wavelength of a one-channel model: red 0.645, green 0.526, blue 0.444 um "
           "(an RGB model uses all three)", ("green", "red", "blue"), "green"),
)


def configure(opts: dict, given: set):
    norm = opts.get("diffraction_norm", "conserving")
    band = opts.get("band", "green")
    defines = (("HP_ENERGY", str(int(norm == "paper"))), ("HP_LAMBDA1", repr(WAVELENGTHS[band])))
    return Resolved(defines, tuple(p.name for p in PARAMS),
                    {"diffraction_norm": norm, "band": band})


# clbrdf check at p = lo in double precision: E = 1.8e-11 (mu = 0.5) and 7e-10 (mu = 1) by
# quadrature, carried by about one sample in 1e6 (y ~ Gamma(10, 1), tan theta_h = sigma y^5:
# nearly every normal is grazing): runs of 2^16 samples report 0 +- 0. In single precision the
# 8-ulp floor (5e-7) covers it.
SWEPT = microfacet.SWEPT
SHAPE_P = (0.1, 0.2, 0.5, 1.0, 2.0, 3.5, 5.0)     # the stability map's shapes p

HOLZSCHUCH_PACANOWSKI = ModelSpec(
    page="models/holzschuch_pacanowski.md",
    name="holzschuch_pacanowski",
    ref="holzschuch_pacanowski",
    title="Holzschuch & Pacanowski 2015: diffuse + diffraction + exponential-power reflection",
    reference="Holzschuch & Pacanowski 2015 eq 17-27 (BRDF), eq 22-23 (sampling), section 5.5 "
              "(lobe mixture)",
    header="holzschuch_pacanowski.h",
    prefix="holzschuch_pacanowski",
    params=PARAMS,
    options=OPTIONS,
    configure_fn=configure,
    facts=Facts(sweeps=((("sigma",), SWEPT), (("p",), SHAPE_P)),
                capi=(("holzschuch_pacanowski", {}),),
                sharp={"sigma": 0.01}, roughest={"sigma": 1e-3},
                ladder={"kd": 0.1, "kw": 1.0, "sigma": 0.1},
                lambda_g1_error=1e-5),
)

EXPPOW = microfacet.spec(
    "exppow", "Microfacet, exponential-power distribution (alpha = sigma)",
    "Holzschuch & Pacanowski 2015 eq 18-19 (D), eq 20-21 (Smith Lambda, tabulated), eq 22-23 "
    "(sampling)", page="models/holzschuch_pacanowski.md",
    header="dist_exppow.h", shape=P_PARAM, samplers=("ndf",), aniso=False,
    ref="holzschuch_pacanowski",
    facts=Facts(sweeps=((("alpha",), SWEPT), (("p",), SHAPE_P)),
                capi=(("exppow", {"alpha": 0.3, "p": 0.7, "f0": 0.2}),),
                sharp={"alpha": 0.01}, roughest={"alpha": 1e-3},
                ladder={"alpha": 0.3, "p": 0.9, "fresnel": "dielectric", "eta": 1.5},
                lambda_g1_error=1e-5))

SPECS = (HOLZSCHUCH_PACANOWSKI, EXPPOW)
