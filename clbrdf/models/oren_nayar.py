"""Rough diffuse reflection: EON, the energy-preserving Oren-Nayar of Portsmouth, Kutz & Hill
2025 (OpenPBR's diffuse lobe), its single-scattering part FON (Fujii's Oren-Nayar) and the
qualitative Oren-Nayar QON (MaterialX's form, sigma = r radians). Kernel:
kernels/oren_nayar.h; reference: clbrdf.ref.oren_nayar.

    FON: f = rho / pi A_F (1 + r s / t)        EON: f = FON + rho_ms / pi (1 - E_F(mu_o))
                                                        (1 - E_F(mu_i)) / (1 - Ebar_F)

``albedo=exact`` uses FON's closed-form directional albedo E_F in EON's multiple-scattering
lobe (then EON at rho = 1 reflects exactly 1 at every angle), ``albedo=approx`` the paper's
quartic fit of it. ``sampler=cltc`` is the paper's clipped-LTC sampler mixed with the uniform
hemisphere; ``cosine`` the cosine hemisphere.
"""
from .spec import Facts, ModelSpec, Option, Param, Resolved

PARAMS = (
    Param("rho", "diffuse albedo", 0.0, 1.0, 0.8, spectral=True),
    Param("r", "roughness (qon: sigma in radians)", 0.0, 1.0, 0.5),
)
FORMS = ("eon", "fon", "qon")
ALBEDOS = ("exact", "approx")
SAMPLERS = ("cltc", "cosine")
OPTIONS = (Option("form", "eon: energy-preserving (Portsmouth et al. 2025); fon: its "
                  "single-scattering part (Fujii); qon: the qualitative Oren-Nayar", FORMS, "eon"),
           Option("albedo", "FON's albedo in EON's multiple-scattering lobe: closed form, or "
                  "the paper's quartic fit", ALBEDOS, "exact"),
           Option("sampler", "cltc: the paper's clipped LTC mixed with the uniform hemisphere; "
                  "cosine", SAMPLERS, "cltc"))


def configure(opts: dict, given: set):
    o = {op.name: op.check(opts.get(op.name, op.default)) for op in OPTIONS}
    defines = (("ON_FORM", str(FORMS.index(o["form"]))),
               ("ON_ALBEDO", str(ALBEDOS.index(o["albedo"]))),
               ("ON_SAMPLER", str(SAMPLERS.index(o["sampler"]))))
    return Resolved(defines, ("rho", "r"), o)


SPECS = (ModelSpec(
    page="models/oren_nayar.md",
    name="oren_nayar",
    ref="oren_nayar",
    title="Oren-Nayar diffuse: EON (energy-preserving), FON, QON",
    reference="Portsmouth, Kutz & Hill 2025, EON: A Practical Energy-Preserving Rough Diffuse "
              "BRDF, JCGT 14(1), eq 4-13 and Listings 1-3; Fujii 2020; Oren & Nayar 1994",
    header="oren_nayar.h",
    prefix="oren_nayar",
    params=PARAMS,
    options=OPTIONS,
    configure_fn=configure,
    facts=Facts(
        sweeps=((("r",), (0.0, 0.01, 0.1, 0.3, 0.6, 1.0)),),
        capi=(("oren_nayar", {"r": 0.7, "rho": 0.6}),
              ("oren_nayar-qon", {"r": 0.5, "form": "qon"}),
              ("oren_nayar-approx-rgb", {"r": 0.3, "rho": [0.2, 0.5, 0.9], "channels": 3,
                                         "albedo": "approx", "sampler": "cosine"})),
        sharp={}),
),)


def openpbr(row: dict):
    """OpenPBR Surface's diffuse lobe at its defaults (published_fits/openpbr.md)."""
    return ({"form": "eon"}, {"rho": [row[f"color_{c}"] for c in "rgb"], "r": row["roughness"]})


PRESETS = {"openpbr_diffuse.csv": openpbr}

