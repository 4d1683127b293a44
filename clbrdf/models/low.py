"""Löw, Kronander, Ynnerman & Unger 2012, "BRDF models for accurate and efficient rendering of
glossy surfaces" (ACM TOG 31(1)): the smooth-surface model and the microfacet ABC model.
Kernels: kernels/low_smooth.h, kernels/low_microfacet.h (kernels/low_abc.h shared).

Parameter names are the paper's eq 11 names in lower case: ``a``, ``b``, ``c`` are A, B, C of the
condensed ABC function S(f) = A / (1 + B f^2)^C (not the a, b, c of the original ABC model, eq 7,
with A = a^2, B = b^2, C = (c + 1)/2). ``a`` and ``kd`` are per channel; ``b``, ``c``, ``eta`` are
shared by the channels, as in the paper's fits.

- ``low_smooth`` (eq 12-14): f = kd/pi + F(theta_d; eta) S(|Lp + Vp|),
  cos theta_d = sqrt(1 - |Lp - Vp|^2/4). Option ``lobes=two`` (or giving any of a2, b2, c2) adds
  the lobe without Fresnel factor of the two-lobe variant (eq 34):
  f = kd/pi + S2(|Dp|) + F S(|Dp|), S2 with parameters ``a2`` (per channel), ``b2``, ``c2``.
  ``a, b, c`` always belong to the lobe with the Fresnel factor (S of eq 12 = S2 of eq 34, whose
  Fresnel-free S1 is our a2, b2, c2).
- ``low_microfacet`` (eq 15): f = kd/pi + S(sqrt(1 - n.h)) F(wi.h; eta) G / (pi cos_i cos_o),
  V-cavity G; the pi in the denominator is the one of the published fits.

The Lambertian term is compiled only when ``kd`` is given.

Presets: the published MERL fits (E2 metric) of Löw et al. 2012, supplemental material, as
collected by bsdfbenchmark/bbm (``fits/``, BSD-3-Clause) and jdupuy/dj_brdf (public domain):
``Aggregate(Lambertian(albedo), LowSmooth(A, B, C, eta))`` and
``Aggregate(Lambertian(albedo), LowMicrofacetFit(A, B, C, eta))``; bbm evaluates Lambertian as
albedo/pi, LowSmooth as A (1 + B |Ip + Op|^2)^-C F_cook(eta, sqrt(1 - |Ip - Op|^2/4)) and
LowMicrofacetFit as A D G F_cook(eta, wi.h) / (pi cos_i cos_o) with D = (1 + B (1 - h.z))^-C and
V-groove G, which are exactly these models with kd = albedo, a = A, b = B, c = C, eta = eta.
"""
from .spec import Facts, ModelSpec, Option, Param, Resolved

PARAMS_ABC = (
    Param("a", "A of the ABC function S = A / (1 + B f^2)^C (eq 11): scale of the lobe",
          0.0, 1e8, 1.0, spectral=True),
    Param("b", "B of eq 11: sharpness of the lobe (about 1e8 for a near mirror; below 1e-6 the "
          "lobe is flat to 1e-6)", 1e-6, 1e9, 100.0),
    Param("c", "C of eq 11: fall-off of the wide-angle tail", 0.0, 50.0, 1.0, lo_open=True),
    Param("eta", "Fresnel parameter of the dielectric Fresnel factor (a fitting value)",
          0.0, 1000.0, 1.5, lo_open=True),
    Param("kd", "albedo of the Lambertian term kd/pi", 0.0, 1.0, 0.0, spectral=True),
)
PARAMS_TWO = (
    Param("a2", "two-lobe variant (eq 34): A of the lobe without Fresnel factor",
          0.0, 1e8, 1.0, spectral=True),
    Param("b2", "two-lobe variant: B of the lobe without Fresnel factor", 1e-6, 1e9, 10.0),
    Param("c2", "two-lobe variant: C of the lobe without Fresnel factor", 0.0, 50.0, 1.0,
          lo_open=True),
)
TWO = ("a2", "b2", "c2")


def _configure_smooth(opts: dict, given: set):
    lobes = opts.get("lobes", "two" if set(TWO) & given else "one")
    diffuse = "kd" in given
    used = ("a", "b", "c", "eta") + (("kd",) if diffuse else ()) + (TWO if lobes == "two" else ())
    defines = (("LOW_DIFFUSE", str(int(diffuse))), ("LOW_TWO_LOBES", str(int(lobes == "two"))))
    return Resolved(defines, used, {"lobes": lobes})


def _configure_microfacet(opts: dict, given: set):
    diffuse = "kd" in given
    used = ("a", "b", "c", "eta") + (("kd",) if diffuse else ())
    return Resolved((("LOW_DIFFUSE", str(int(diffuse))),), used)


# the stability map's b (from a near-constant lobe to a spike) and c (around 1)
SWEPT_B = (1e-6, 1e-2, 1.0, 1e2, 1e4, 1e6, 1e8)
SWEPT_C = (0.1, 0.5, 0.9, 1 - 1e-4, 1 - 1e-7, 1.0, 1 + 1e-7, 1 + 1e-4, 2.0, 10.0)

LOW_SMOOTH = ModelSpec(
    page="models/low.md",
    name="low_smooth",
    ref="low",
    title="Löw et al. 2012 smooth-surface model (projected deviation vector, ABC lobe)",
    reference="Löw et al. 2012 eq 11-14 (model), eq 34 (two lobes), eq 17-22 (sampler)",
    header="low_smooth.h",
    prefix="low_smooth",
    params=PARAMS_ABC + PARAMS_TWO,
    options=(Option("lobes", "one ABC lobe with Fresnel (eq 12) or two lobes (eq 34)",
                    ("one", "two"), "one"),),
    configure_fn=_configure_smooth,
    facts=Facts(sweeps=((("b",), SWEPT_B), (("c",), SWEPT_C)),
                capi=(("low_smooth", {}),), sharp={"b": 1e4},
                ladder={"lobes": "two", "kd": 0.1}),
)

LOW_MICROFACET = ModelSpec(
    page="models/low.md",
    name="low_microfacet",
    ref="low",
    title="Löw et al. 2012 microfacet ABC model (V-cavity G, dielectric Fresnel)",
    reference="Löw et al. 2012 eq 11, 15 (model), eq 23-28 (sampler)",
    header="low_microfacet.h",
    prefix="low_microfacet",
    params=PARAMS_ABC,
    configure_fn=_configure_microfacet,
    facts=Facts(sweeps=((("b",), SWEPT_B), (("c",), SWEPT_C)),
                capi=(("low_microfacet", {}),), sharp={"b": 1e4}),
)

SPECS = (LOW_SMOOTH, LOW_MICROFACET)


# ---- presets: published MERL fits (see the module docstring and data/published_fits/SOURCES.md)

def _fit_params(fit: dict, model_key: str):
    m = fit[model_key]
    return {}, {"kd": list(fit["Lambertian"]["albedo"]), "a": list(m["A"]), "b": float(m["B"]),
                "c": float(m["C"]), "eta": float(m["eta"])}


def smooth_fit(fit: dict):
    """A line of low_lowsmooth_E2.fit -> (options, params) of ``low_smooth``."""
    return _fit_params(fit, "LowSmooth")


def microfacet_fit(fit: dict):
    """A line of low_lowmicrofacet_E2.fit -> (options, params) of ``low_microfacet``."""
    return _fit_params(fit, "LowMicrofacetFit")


def microfacet_csv(row: dict):
    """A row of abc_low2012_fits.csv (dj_brdf; columns kD_*, A_*, B, C, ior) -> (options,
    params) of ``low_microfacet``."""
    return {}, {"kd": [float(row[f"kD_{ch}"]) for ch in "rgb"],
                "a": [float(row[f"A_{ch}"]) for ch in "rgb"],
                "b": float(row["B"]), "c": float(row["C"]), "eta": float(row["ior"])}


# (model, to_params): this module defines two models. The .fit file is low_microfacet's default
# source; ``MATERIAL:abc_low2012_fits`` picks the dj_brdf table (the same numbers, see the tests).
PRESETS = {
    "low_lowsmooth_E2.fit": ("low_smooth", smooth_fit),
    "low_lowmicrofacet_E2.fit": ("low_microfacet", microfacet_fit),
    "abc_low2012_fits.csv": ("low_microfacet", microfacet_csv),
}
