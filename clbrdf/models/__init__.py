"""The model registry: name -> ModelSpec.

Every module in this package that defines ``SPECS`` (a tuple of ``ModelSpec``) contributes its
models, in module order: lambert and microfacet first, then the others by name.
"""
import importlib
import pkgutil

from .spec import ModelSpec, ParameterError

_FIRST = ("lambert", "microfacet")
# max |G1 error| of the tabulated Smith Lambda over every accepted parameter and direction
# (scripts/measure_lambda_tables.py, docs/models/distributions.md)
LAMBDA_TABLE_G1_ERROR = {"gtr": 2e-4, "sgd": 1e-4, "exppow": 1e-5, "holzschuch_pacanowski": 1e-5}


def _collect() -> dict[str, ModelSpec]:
    names = [m.name for m in pkgutil.iter_modules(__path__)]
    order = [n for n in _FIRST if n in names] + sorted(n for n in names if n not in _FIRST)
    models: dict[str, ModelSpec] = {}
    for n in order:
        for s in getattr(importlib.import_module(f"{__name__}.{n}"), "SPECS", ()):
            if s.name in models:
                raise RuntimeError(f"model {s.name!r} is defined twice (clbrdf.models.{n})")
            models[s.name] = s
    return models


MODELS: dict[str, ModelSpec] = _collect()


def get_spec(name: str) -> ModelSpec:
    try:
        return MODELS[name]
    except KeyError:
        raise ParameterError(f"unknown model {name!r}; models: {', '.join(MODELS)}") from None
