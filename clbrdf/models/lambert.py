"""Lambertian reflection: f = kd / pi. Kernel: kernels/lambert.h."""
from .spec import ModelSpec, Param

SPEC = ModelSpec(
    name="lambert",
    ref="microfacet",
    title="Lambertian",
    reference="Lambert 1760; f = kd / pi",
    header="lambert.h",
    prefix="lambert",
    params=(Param("kd", "diffuse albedo", 0.0, 1.0, 1.0, spectral=True),),
)

SPECS = (SPEC,)
