"""The model registry: name -> ModelSpec."""
from ..spec import ModelSpec, ParameterError
from . import lambert, microfacet

MODELS: dict[str, ModelSpec] = {s.name: s for s in (lambert.SPEC, microfacet.GGX, microfacet.BECKMANN)}


def get_spec(name: str) -> ModelSpec:
    try:
        return MODELS[name]
    except KeyError:
        raise ParameterError(f"unknown model {name!r}; models: {', '.join(MODELS)}") from None
