"""Double-precision NumPy references of the models, written from the papers independently of the
kernels, one module per model family, all behind one interface.

``reference(model, **kwargs)`` takes what ``clbrdf.Model`` takes (a name with options, parameters,
``channels``, ``preset``; or a ``Model``) and returns a ``Reference``:

    eval(wo, wi)                    f in 1/sr, shape (...) or (..., 3) for an RGB model
    pdf(wo, wi)                     density (1/sr) of wi under the model's sampler, given wo
    albedo(mu, phi=0.0, tol=1e-8)   (E, err) for wo = direction(mu, phi) by the deterministic
                                    quadrature of ``clbrdf.ref.quadrature``; E per channel
    reciprocal                      whether the paper claims f(wo, wi) = f(wi, wo)

A model's description names its reference module (``ModelSpec.ref``: ``"microfacet"`` is
``clbrdf/ref/microfacet.py``), which defines ``REFERENCES = {model name: Reference subclass}``.
A subclass implements one channel (``eval1``, ``albedo1``) and the sampler's density (``pdf``);
``channel(c)`` gives the parameter values of channel c. Directions are float64 arrays (..., 3).
"""
from __future__ import annotations

import importlib
import importlib.util

import numpy as np

from ..models import get_spec, presets


class Reference:
    reciprocal = True

    def __init__(self, spec, config, params: dict):
        self.spec, self.config, self.name = spec, config, spec.name
        self.options = dict(config.options)
        self.defines = dict(config.defines)
        self.channels = config.channels
        self.params = {k: np.asarray(v, float) for k, v in params.items()}

    def __repr__(self):
        return f"<Reference {self.name} {self.options} channels={self.channels}>"

    def channel(self, c: int | None) -> dict:
        """Parameter values of channel c (None: a one-channel model): a per-channel parameter's
        c-th value, the others as they are."""
        if c is None or self.channels == 1:
            return dict(self.params)
        return {k: (v[..., c] if k in self.config.spectral else v) for k, v in self.params.items()}

    def channel_values(self) -> list[dict]:
        return [self.channel(c) for c in range(self.channels)] if self.channels > 1 else [self.channel(None)]

    # ---- what a family implements
    def eval1(self, wo, wi, v: dict, c: int | None):
        raise NotImplementedError

    def pdf(self, wo, wi):
        raise NotImplementedError

    def albedo1(self, mu: float, phi: float, tol: float, v: dict, c: int | None):
        raise NotImplementedError

    # ---- the interface
    def eval(self, wo, wi):
        wo, wi = np.asarray(wo, float), np.asarray(wi, float)
        if self.channels == 1:
            return self.eval1(wo, wi, self.channel(None), None)
        return np.stack([self.eval1(wo, wi, self.channel(c), c) for c in range(self.channels)], -1)

    def albedo(self, mu, phi=0.0, tol=1e-8):
        if self.channels == 1:
            return self.albedo1(float(mu), float(phi), tol, self.channel(None), None)
        parts = [self.albedo1(float(mu), float(phi), tol, self.channel(c), c) for c in range(self.channels)]
        return np.array([p[0] for p in parts]), np.array([p[1] for p in parts])


def reference(model, **kwargs) -> Reference:
    """The float64 reference of a configuration: ``reference("ggx", alpha=0.2)``,
    ``reference("sgd_bagher", preset="gold-paint")`` or ``reference(clbrdf.Model(...))``."""
    if not isinstance(model, str):                # a clbrdf.Model
        if kwargs:
            raise TypeError("reference(model): give keywords with a model name, not with a Model")
        spec, config, params = model.spec, model.config, model.params
    else:
        spec = get_spec(model)
        preset, channels = kwargs.pop("preset", None), kwargs.pop("channels", None)
        kwargs, channels = presets.applied(spec.name, preset, kwargs, channels)
        config, params = spec.configure(channels=channels, **kwargs)
    # a reference of this package, or a module elsewhere (a model registered from outside)
    own = importlib.util.find_spec(f"{__name__}.{spec.ref}") is not None
    module = importlib.import_module(f"{__name__}.{spec.ref}" if own else spec.ref)
    return module.REFERENCES[spec.name](spec, config, params)
