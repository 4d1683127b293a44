"""Lambertian reflection: f = kd / pi. Kernel: kernels/lambert.h."""
from .spec import Facts, ModelSpec, Param

SPEC = ModelSpec(
    page="models.md#lambertian-lambert",
    name="lambert",
    ref="microfacet",
    title="Lambertian",
    reference="Lambert 1760; f = kd / pi",
    header="lambert.h",
    prefix="lambert",
    params=(Param("kd", "diffuse albedo", 0.0, 1.0, 1.0, spectral=True),),
    facts=Facts(capi=(("lambert", {}), ("lambert-rgb", {"kd": [0.2, 0.5, 0.9], "channels": 3})),
                sharp={}),
)

SPECS = (SPEC,)
