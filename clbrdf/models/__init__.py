"""The model registry: name -> ModelSpec.

Every module in this package that defines ``SPECS`` (a tuple of ``ModelSpec``) contributes its
models, in module order: lambert and microfacet first, then the others by name. ``register``
adds a model described outside the package (its kernel header an absolute path, its reference
a module of its own: docs/adding-a-model.md).
"""
import importlib
import pkgutil

from .spec import Facts, ModelSpec, ParameterError  # noqa: F401  (Facts: for model modules)

_FIRST = ("lambert", "microfacet")


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


def register(spec: ModelSpec) -> ModelSpec:
    """Add a model to the registry (``clbrdf.MODELS``): every API, table, study and command then
    takes it by name. Its ``header`` is a kernel header's absolute path (or a header of
    clbrdf.kernels), its ``ref`` the module that holds its float64 reference
    (``REFERENCES = {name: Reference subclass}``)."""
    if not isinstance(spec, ModelSpec):
        raise ParameterError(f"spec={spec!r} is not valid: give a clbrdf.models.spec.ModelSpec")
    if spec.name in MODELS:
        raise ParameterError(f"model {spec.name!r} is registered already")
    MODELS[spec.name] = spec
    return spec
