"""Ashikhmin & Shirley 2000, "An anisotropic Phong BRDF model" (JGT 5(2)). Kernel:
kernels/ashikhmin_shirley.h; reference: clbrdf.ref.ashikhmin_shirley.

    f = ks rho_s + rho_d + kd / pi
    rho_s = sqrt((nu+1)(nv+1)) / (8 pi) (n.h)^(nu cos^2 phi_h + nv sin^2 phi_h) F(k.h)
            / ((k.h) max(n.wi, n.wo))                                             (eq 16)
    rho_d = 28 rd / (23 pi) (1 - rs)(1 - (1 - n.wi/2)^5)(1 - (1 - n.wo/2)^5)      (eq 14)

``F`` is Schlick's (eq 11) with F0 = ``rs`` (``fresnel=schlick``, the paper's), or the exact
dielectric Fresnel factor of index ``eta`` (``fresnel=dielectric``: Löw et al.'s fits). The
paper's model is nu, nv, rs and rd; ``ks`` (a scale of rho_s) and ``kd`` (a Lambertian term) are
compiled only when given and exist for the published fits. ``rd`` needs the Schlick form, whose
rs is the (1 - Rs) of eq 14. ``rs``, ``rd``, ``eta``, ``ks`` and ``kd`` are per channel.

Sampling: the paper's half-vector sampler (eq 19-20, 18) for rho_s and the cosine density for
the diffuse terms, mixed with probability p_d = w_d / (w_d + w_s) for the cosine lobe:
w_d = sum over channels of rd (1 - rs)(1 - (1 - n.wo/2)^5) + kd, the diffuse terms' exact albedo,
and w_s = sum over channels of ks F(n.wo), the albedo of a mirror with the same Fresnel factor
(what rho_s tends to as nu, nv grow). The pdf is the mixture density.

Presets: Löw et al. 2012's Ashikhmin-Shirley fits to MERL (E1 and E2 metrics, via
bsdfbenchmark/bbm ``fits/``): ``Aggregate(Lambertian(albedo), LowAshikhminShirley(albedo,
sharpness, fresnelReflectance))``. bbm (bsdfmodel/low.h, ashikhminshirley.h, scaledmodel.h,
fresnel_cook.h) evaluates LowAshikhminShirley as albedo * (n+1)/(8 pi) (n.h)^n F_cook(eta, wi.h)
/ ((wi.h) max(n.wi, n.wo)), isotropic with n = sharpness and eta = fresnelReflectance (an index,
Cook-Torrance's Fresnel formula), and Lambertian as albedo / pi: exactly this model with
nu = nv = sharpness, fresnel = dielectric, eta = fresnelReflectance, ks = LowAshikhminShirley
albedo, kd = Lambertian albedo, and no rd.
"""
import numpy as np

from .spec import Facts, ModelSpec, Option, Param, ParameterError, Resolved

PARAMS = (
    Param("nu", "Phong exponent along the tangent u (x)", 0.0, 1e7, 100.0),
    Param("nv", "Phong exponent along the bitangent v (y)", 0.0, 1e7, 100.0),
    Param("rs", "specular reflectance at normal incidence (Schlick F0, eq 11)", 0.0, 1.0, 0.05,
          spectral=True),
    Param("rd", "diffuse albedo of the non-Lambertian diffuse term (eq 14)", 0.0, 1.0, 0.0,
          spectral=True),
    Param("eta", "index of refraction of the dielectric Fresnel factor (fresnel=dielectric)",
          0.0, 100.0, 1.5, lo_open=True, spectral=True),
    Param("ks", "scale of the specular term (Löw et al.'s fits)", 0.0, 1e6, 1.0, spectral=True),
    Param("kd", "albedo of an added Lambertian term", 0.0, 1.0, 0.0, spectral=True),
)

OPTIONS = (
    Option("fresnel", "Fresnel factor: Schlick with F0 = rs (the paper's) or exact dielectric "
           "with index eta", ("schlick", "dielectric"), "schlick"),
)


def configure(opts: dict, given: set):
    fresnel = opts.get("fresnel", "dielectric" if "eta" in given else "schlick")
    if fresnel == "dielectric":
        if "rs" in given:
            raise ParameterError("parameter rs is not used by ashikhmin_shirley with "
                                 "fresnel=dielectric (its Fresnel factor has index eta)")
        if "rd" in given:
            raise ParameterError("parameter rd (the diffuse term of eq 14, scaled by 1 - rs) needs "
                                 "fresnel=schlick; use kd for a Lambertian term")
    rd, ks, kd = "rd" in given, "ks" in given, "kd" in given
    used = (("nu", "nv") + (("eta",) if fresnel == "dielectric" else ("rs",))
            + (("ks",) if ks else ()) + (("rd",) if rd else ()) + (("kd",) if kd else ()))
    defines = (("AS_FRESNEL", str(int(fresnel == "dielectric"))), ("AS_KS", str(int(ks))),
               ("AS_RD", str(int(rd))), ("AS_KD", str(int(kd))))
    return Resolved(defines, used, {"fresnel": fresnel})


SPEC = ModelSpec(
    page="models/ashikhmin_shirley.md",
    name="ashikhmin_shirley",
    ref="ashikhmin_shirley",
    title="Ashikhmin-Shirley 2000 anisotropic Phong (specular eq 16, diffuse eq 14)",
    reference="Ashikhmin & Shirley 2000 eq 16 (specular), eq 11 (Schlick F), eq 14 (diffuse), "
              "eq 5, 18-20 (sampler)",
    header="ashikhmin_shirley.h",
    prefix="ashikhmin_shirley",
    params=PARAMS,
    options=OPTIONS,
    configure_fn=configure,
    anisotropic_fn=lambda d, v: bool(np.any(np.asarray(v["nu"]) != np.asarray(v["nv"]))),
    facts=Facts(
        sweeps=((("nu", "nv"), (0.0, 1.0, 10.0, 1e2, 1e3, 1e4, 1e5)),),
        capi=(("ashikhmin_shirley", {"nu": 20.0, "nv": 200.0, "rs": 0.3, "rd": 0.4}),
              # a published fit (RGB, every parameter from the preset)
              ("ashikhmin_shirley-preset", {"preset": "alum-bronze:E1"})),
        sharp={"nu": 1e4, "nv": 1e4},
        ladder={"nu": 100.0, "nv": 100.0, "fresnel": "dielectric", "eta": 1.5, "kd": 0.2}),
)

SPECS = (SPEC,)


def low_ashikhmin_shirley(fit: dict):
    """A Löw et al. 2012 fit line -> (options, params); see the module docstring."""
    a = fit["LowAshikhminShirley"]
    return ({"fresnel": "dielectric"},
            {"nu": a["sharpness"], "nv": a["sharpness"], "eta": a["fresnelReflectance"],
             "ks": a["albedo"], "kd": fit["Lambertian"]["albedo"]})


PRESETS = {"low_ashikhminshirley_E2.fit": low_ashikhmin_shirley,
           "low_ashikhminshirley_E1.fit": low_ashikhmin_shirley}
