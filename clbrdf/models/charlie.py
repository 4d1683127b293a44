"""Charlie sheen (Estevez & Kulla 2017), the sheen lobe of glTF KHR_materials_sheen and
Enterprise PBR, for their sheen albedo tables. Kernel: kernels/charlie.h; reference:
clbrdf.ref.charlie.

    f = ks D G / (4 cos_i cos_o),  D = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi)

with G from Estevez and Kulla's fitted Lambda (``visibility=charlie``) or Neubelt and
Pettineo's visibility 1 / (4 (cos_i + cos_o - cos_i cos_o)) in place of G / (4 cos_i cos_o)
(``visibility=ashikhmin``, Filament's cloth). glTF's alpha is sheenRoughness^2.
"""
from .spec import Facts, ModelSpec, Option, Param, ParameterError, Resolved

PARAMS = (
    Param("alpha", "roughness (glTF: sheenRoughness^2)", 1e-3, 1.0, 0.25),
    Param("ks", "sheen colour: scale of the lobe", 0.0, 1e6, 1.0, spectral=True),
)
VISIBILITY = ("charlie", "ashikhmin")


def configure(opts: dict, given: set):
    v = opts.get("visibility", "charlie")
    if v not in VISIBILITY:
        raise ParameterError(f"option visibility={v!r} is not valid: choose one of "
                             f"{', '.join(VISIBILITY)}")
    return Resolved((("CHARLIE_V", str(VISIBILITY.index(v))),), ("alpha", "ks"), {"visibility": v})


SPECS = (ModelSpec(
    page="models.md#charlie-sheen-charlie",
    name="charlie",
    ref="charlie",
    title="Charlie sheen (Estevez & Kulla 2017)",
    reference="Estevez & Kulla 2017, Production Friendly Microfacet Sheen BRDF, eq 2 and the "
              "Lambda fit of their Table 1; Neubelt & Pettineo 2013 (ashikhmin visibility)",
    header="charlie.h",
    prefix="charlie",
    params=PARAMS,
    options=(Option("visibility", "masking: Estevez-Kulla's fitted Lambda, or Ashikhmin's "
                    "visibility (Neubelt)", VISIBILITY, "charlie"),),
    configure_fn=configure,
    facts=Facts(
        sweeps=((("alpha",), (1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0)),),
        capi=(("charlie", {"alpha": 0.4}),
              ("charlie-ashikhmin", {"alpha": 0.2, "visibility": "ashikhmin"}))),
),)
