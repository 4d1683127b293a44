"""Ward 1992 anisotropic Gaussian BRDF with Walter 2005's sampler; not in the four papers: the
example model of docs/adding-a-model.md. Kernel: kernels/ward.h; reference: clbrdf.ref.ward.

    f = kd / pi + ks exp(-tan^2 theta_h (cos^2 phi_h / alpha_x^2 + sin^2 phi_h / alpha_y^2))
                  / (4 pi alpha_x alpha_y sqrt(cos_i cos_o))

``kd`` is compiled only when given. Ward's normalisation is approximate: the model gains energy
at grazing angles (docs/models.md).
"""
import numpy as np

from .spec import Facts, ModelSpec, Param, Resolved

PARAMS = (
    Param("alpha_x", "slope deviation along the tangent x", 1e-3, 1.0, 0.2),
    Param("alpha_y", "slope deviation along the bitangent y", 1e-3, 1.0, 0.2),
    Param("ks", "specular reflectance", 0.0, 1.0, 1.0, spectral=True),
    Param("kd", "diffuse albedo", 0.0, 1.0, 0.0, spectral=True),
)


def configure(opts: dict, given: set):
    kd = "kd" in given
    return Resolved((("WARD_DIFFUSE", str(int(kd))),),
                    ("alpha_x", "alpha_y", "ks") + (("kd",) if kd else ()))


SPECS = (ModelSpec(
    page="models.md#ward-ward",
    name="ward",
    ref="ward",
    title="Ward 1992 anisotropic Gaussian (Walter 2005 sampler)",
    reference="Ward 1992 eq 5b; Walter 2005, Notes on the Ward BRDF, eq 6-9",
    header="ward.h",
    prefix="ward",
    params=PARAMS,
    configure_fn=configure,
    anisotropic_fn=lambda d, v: bool(np.any(np.asarray(v["alpha_x"]) != np.asarray(v["alpha_y"]))),
    facts=Facts(
        sweeps=((("alpha_x", "alpha_y"), (1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0)),),
        capi=(("ward", {"alpha_x": 0.1, "alpha_y": 0.3, "kd": 0.2}),),
        sharp={"alpha_x": 0.01, "alpha_y": 0.01}, roughest={"alpha_x": 1e-3, "alpha_y": 1e-3}),
),)
