"""More microfacet distributions: GTR and SGD (Holzschuch & Pacanowski 2015 Table 1), and the full
SGD BRDF of Bagher, Soler & Holzschuch 2012 with its published MERL fits as presets.

- ``gtr``: the microfacet model of ``microfacet.py`` with D = GTR (``gamma``; 2 is GGX, 1 is
  Burley's clearcoat lobe). Kernel: kernels/dist_gtr.h.
- ``sgd``: the same with D = the shifted gamma distribution (``p``). Kernel: kernels/dist_sgd.h.
  Both isotropic; Smith Lambda tabulated (kernels/dist_lambda_tables.h, with GTR gamma = 1 in
  closed form); sampler: exact inversion of the NDF's CDF (``sampler=ndf``; no visible-normal
  sampler, so ``sampler=vndf`` is rejected).
- ``sgd_bagher``: dj_brdf's ``djb::sgd`` BRDF, every parameter per channel (kernels/sgd_bagher.h);
  presets: ``sgd_bagher2012_fits.csv`` (100 MERL materials).
"""
from dataclasses import replace
from math import pi

from .microfacet import SWEPT, spec
from .spec import Facts, ModelSpec, Param, Resolved

GTR_ALPHA = (1e-3, 0.999)     # a = 1 is the degenerate D = 1/pi; the Lambda table's a range
SGD_ALPHA = (1e-5, 1.0)       # the published fits reach 1.6e-5; the Lambda table's a range


def _with_alpha(s: ModelSpec, lo: float, hi: float, default: float) -> ModelSpec:
    params = tuple(replace(p, lo=lo, hi=hi, default=default) if p.name == "alpha" else p
                   for p in s.params)
    return replace(s, params=params)


GTR = _with_alpha(spec(
    "gtr", "Microfacet, GTR (generalised Trowbridge-Reitz) distribution, isotropic",
    "Holzschuch & Pacanowski 2015 Table 1 (P22, c); Burley 2012 eq 4; Lambda tabulated "
    "(gamma = 1 closed form)",
    header="dist_gtr.h", page="models/distributions.md",
    shape=Param("gamma", "GTR exponent (2: GGX, 1: Burley's clearcoat)", 0.5, 4.0, 2.0),
    samplers=("ndf",), aniso=False, ref="distributions",
    facts=Facts(sweeps=((("alpha",), (1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 0.999)),
                        (("gamma",), (0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0))),
                capi=(("gtr", {"alpha": 0.3, "gamma": 1.5}),),
                sharp={"alpha": 0.01}, roughest={"alpha": 1e-3},
                ladder={"alpha": 0.3, "gamma": 1.8, "fresnel": "dielectric", "eta": 1.5},
                lambda_g1_error=2e-4)),
    *GTR_ALPHA, 0.5)

SGD = _with_alpha(spec(
    "sgd", "Microfacet, shifted gamma distribution (SGD), isotropic",
    "Bagher et al. 2012 eq 6; Holzschuch & Pacanowski 2015 Table 1 (with its 1/pi); "
    "Lambda tabulated",
    header="dist_sgd.h", page="models/distributions.md",
    shape=Param("p", "SGD power p (1 - p is the incomplete gamma's shape)", 0.0, 2.0, 0.5),
    samplers=("ndf",), aniso=False, ref="distributions",
    facts=Facts(sweeps=((("alpha",), (1e-5,) + SWEPT),),
                capi=(("sgd", {"alpha": 0.2, "p": 0.8}),),
                sharp={"alpha": 0.002}, roughest={"alpha": 1e-3},
                lambda_g1_error=1e-4)), *SGD_ALPHA, 0.01)


# ---- the full SGD BRDF of the published fits (dj_brdf djb::sgd)

BAGHER_PARAMS = (
    Param("rho_d", "diffuse albedo rho_d", 0.0, 1.0, 0.1, spectral=True),
    Param("rho_s", "specular scale rho_s", 0.0, 100.0, 0.5, spectral=True),
    Param("alpha", "SGD alpha (shift and scale of the slopes)", *SGD_ALPHA, 0.01, spectral=True),
    Param("p", "SGD power p", 0.0, 2.0, 0.5, spectral=True),
    Param("kap", "NDF scale kap", 0.0, 1e8, 1.0, lo_open=True, spectral=True,
          computed="1 / (alpha Gamma(1-p, alpha)), the normalised NDF"),
    Param("f0", "Fresnel fit F = f0 - f1 cos + (1 - cos)^5 (1 - f0)", 0.0, 100.0, 1.0,
          spectral=True),
    Param("f1", "Fresnel fit f1", -100.0, 100.0, 0.0, spectral=True),
    Param("lam", "shadowing fit lambda: G1 = clamp(1 + lambda (1 - exp(c max(0, theta - "
          "theta0)^k)), 0, 1)", 0.0, 1e9, 1.0, lo_open=True, spectral=True),
    Param("c", "shadowing fit c", 0.0, 1e38, 1e-7, lo_open=True, spectral=True),
    Param("k", "shadowing fit exponent k", 0.0, 1e4, 30.0, lo_open=True, spectral=True),
    Param("theta0", "shadowing fit theta0 (radians)", -pi / 2, pi / 2, 0.5, spectral=True),
)


def _bagher_configure(opts: dict, given: set):
    used = tuple(p.name for p in BAGHER_PARAMS if p.name != "kap" or "kap" in given)
    return Resolved((("SGDB_KAP", str(int("kap" in given))),), used)


SGD_BAGHER = ModelSpec(
    page="models/distributions.md",
    name="sgd_bagher",
    ref="distributions",
    title="SGD BRDF of Bagher et al. 2012 (the published fits' formula, all parameters per channel)",
    reference="Bagher, Soler & Holzschuch 2012 eq 6, 8, 10; jdupuy/dj_brdf djb::sgd",
    header="sgd_bagher.h", prefix="sgd_bagher", params=BAGHER_PARAMS,
    configure_fn=_bagher_configure,
    facts=Facts(
        sweeps=((("alpha",), (1e-5,) + SWEPT),),
        capi=(("sgd_bagher", {}),),
        sharp={"alpha": 0.002}))

SPECS = (GTR, SGD, SGD_BAGHER)

_CSV_KEYS = {"rho_d": "rhoD", "rho_s": "rhoS", "alpha": "alpha", "p": "p", "kap": "kap",
             "f0": "f0", "f1": "f1", "lam": "lambda", "c": "c", "k": "k", "theta0": "theta0"}


def bagher_csv(row: dict):
    """A row of sgd_bagher2012_fits.csv (dj_brdf's table: name, otherName, then rhoD, rhoS, alpha,
    p, f0, f1, kap, lambda, c, k, theta0, error, each _r _g _b) -> (options, params) of
    ``sgd_bagher``; the names map one to one (lambda -> lam)."""
    return {}, {k: [float(row[f"{v}_{ch}"]) for ch in "rgb"] for k, v in _CSV_KEYS.items()}


bagher_csv.model = "sgd_bagher"
PRESETS = {"sgd_bagher2012_fits.csv": ("sgd_bagher", bagher_csv)}
