"""How a model describes itself: its parameters, its compile-time options, its kernel header.

A model module builds one ``ModelSpec``. ``ModelSpec.configure`` turns what a user passed into a
``Config``: the compile-time choices (``defines``), the parameters that configuration uses, and
their values, validated. The generic integrators see only ``Config``.
"""
from __future__ import annotations

import contextlib
import contextvars
from dataclasses import dataclass, field
from typing import Callable

import numpy as np


class ParameterError(ValueError):
    """A parameter or option with an invalid name or value; the message names the valid range
    and ``param`` the parameter (its Python name) where one is known."""

    def __init__(self, message: str = "", param: str | None = None):
        super().__init__(message)
        self.param = param


class Setting:
    """A value in effect for a block of code and what it calls (a ``contextvars.ContextVar``):
    ``setting.get()`` (``default`` outside any block), ``with setting.using(value):``."""

    def __init__(self, name: str, default=None):
        self._var = contextvars.ContextVar(name, default=None)
        self.default = default

    def get(self):
        value = self._var.get()
        return self.default if value is None else value

    @contextlib.contextmanager
    def using(self, value):
        token = self._var.set(value)
        try:
            yield value
        finally:
            self._var.reset(token)


# how a message names a parameter: its Python name, or the caller's (the command line's flags,
# clbrdf/cli/common.py FLAGS) inside ``spelling(names)``
_SPELLING = Setting("clbrdf_spelling", {})
spelling = _SPELLING.using


def called(name: str) -> str:
    """Parameter ``name`` as the caller calls it (``spelling``): ``max_samples``, or inside the
    command line ``--max-samples``."""
    return _SPELLING.get().get(name, name)


def given(name: str, value) -> str:
    """A parameter and its value as the caller writes them: ``out='t.npz'`` or, inside the
    command line, ``--out=t.npz``; a switch set: ``resume=True`` or ``--resume``."""
    flag = called(name)
    if flag == name:
        return f"{name}={value!r}"
    return flag if value is True else f"{flag}={value}"


def switch(name: str, on: bool) -> str:
    """'with resume=True' / 'with resume=False', or 'with --resume' / 'without --resume'."""
    flag = called(name)
    if flag == name:
        return f"with {name}={on}"
    return f"{'with' if on else 'without'} {flag}"


@dataclass(frozen=True)
class Param:
    name: str
    meaning: str
    lo: float
    hi: float
    default: float
    lo_open: bool = False          # lo itself excluded
    spectral: bool = False         # one value per colour channel when the model has channels=3
    computed: str = ""             # when not given, computed from other parameters (this text
                                   # says how; ``default`` is then not used)

    def range_text(self) -> str:
        return f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"

    def check(self, values: np.ndarray) -> None:
        v = np.asarray(values, dtype=np.float64)
        bad = ~np.isfinite(v) | (v > self.hi) | ((v <= self.lo) if self.lo_open else (v < self.lo))
        if np.any(bad):
            first = v.reshape(-1)[np.argmax(bad.reshape(-1))]
            raise ParameterError(f"parameter {self.name}={float(first)!r} is out of range: "
                                 f"valid {self.name} is in {self.range_text()} ({self.meaning})")


@dataclass(frozen=True)
class Option:
    name: str
    meaning: str
    choices: tuple[str, ...]
    default: str

    def check(self, value) -> str:
        if value not in self.choices:
            raise ParameterError(f"option {self.name}={value!r} is not valid: "
                                 f"choose one of {', '.join(self.choices)} ({self.meaning})")
        return value


@dataclass(frozen=True)
class Config:
    """One compiled configuration of a model."""
    model: str                       # model name (``ggx``)
    header: str                      # kernel header file
    prefix: str                      # C function prefix: prefix_eval, prefix_pdf, prefix_sample
    defines: tuple[tuple[str, str], ...]
    param_names: tuple[str, ...]
    options: tuple[tuple[str, str], ...]
    channels: int = 1                # 1, or 3 (RGB)
    spectral: tuple[str, ...] = ()   # parameters with one value per channel
    headers: tuple[str, ...] = ()    # extra kernel headers, included before ``header``

    def key(self):
        return (self.header, self.prefix, self.defines, self.param_names, self.channels,
                self.spectral, self.headers)

    def rows(self, name: str) -> int:
        """Rows of the parameter block that parameter ``name`` takes."""
        return self.channels if name in self.spectral else 1


@dataclass(frozen=True)
class Resolved:
    """What a model's options and given parameters resolve to: the answer of its
    ``configure_fn(options, names of the parameters given)``."""
    defines: tuple[tuple[str, str], ...]      # the kernel's #defines, (name, value)
    used: tuple[str, ...]                     # the parameters the kernel reads, in its order
    options: dict = field(default_factory=dict)   # the options in effect (describe(), errors)
    headers: tuple[str, ...] = ()             # kernel headers included before the model's


@dataclass(frozen=True)
class Facts:
    """What the studies and tests need to know of a model, stated on its description: a new
    model is its kernel header, its description, its reference and its doc page, with no edit in
    any list elsewhere (docs/adding-a-model.md)."""
    # the stability map (clbrdf.studies.stability): ((parameters set together, values), ...);
    # () sweeps nothing (the defaults only)
    sweeps: tuple = ()
    # the C API cross-checks (clbrdf.studies.capi): ((case name, keywords), ...)
    capi: tuple = ()
    # a near-mirror lobe's parameters for the accuracy chart (clbrdf.studies.accuracy): None
    # leaves the model out, {} charts its defaults only
    sharp: dict | None = None
    # the roughest lobe the deterministic quadrature is held to (tests/runtime/test_quadrature.py)
    roughest: dict | None = None
    # the full configuration the ladder charts (clbrdf.studies.ladder); None: not charted
    ladder: dict | None = None
    # max |G1 error| of a tabulated Smith Lambda over its whole range (docs/models/distributions.md)
    lambda_g1_error: float = 0.0


@dataclass
class ModelSpec:
    name: str
    title: str
    reference: str                   # paper and equations
    header: str
    prefix: str
    params: tuple[Param, ...]
    options: tuple[Option, ...] = ()
    # (options, names of the parameters given) -> Resolved; None: every parameter, no #define
    configure_fn: Callable | None = None
    aliases: dict[str, str] = field(default_factory=dict)
    notes: str = ""                  # how options follow from the parameters given, etc.
    # (defines, parameter values) -> whether E(wo) may depend on the azimuth of wo; None: never.
    # Averages over wo (E_avg) integrate over the azimuth where it does.
    anisotropic_fn: Callable | None = None
    # (defines, parameter values, channels) -> mu where E(mu) may have a kink (an array, last axis the
    # kinks, NaN for none), e.g. the critical angle of total internal reflection; averages over
    # mu (E_avg) split their Gauss-Legendre rule there. None: E is smooth in mu.
    mu_kinks_fn: Callable | None = None
    # the float64 reference: a module of clbrdf/ref/ whose REFERENCES has this model, or the
    # full name of a module elsewhere (a model registered from outside the package)
    ref: str = ""
    facts: Facts = field(default_factory=Facts)
    # the model's page of the documentation, relative to docs/ (with an #anchor for a section)
    page: str = ""
    # directions on the whole sphere (a BSDF that transmits; its header defines P_TRANSMITS 1):
    # wo may be below the surface (mu < 0) and wi on either side; False: a BRDF, which rejects
    # a wo below the horizon and is 0 for a wi below it
    transmits: bool = False
    # (defines, parameter values) -> where f has a delta lobe (a bool array; None: nowhere),
    # which only the sampler finds: the uniform and cosine estimators are refused there;
    # deltas_text says where, for the error
    deltas_fn: Callable | None = None
    deltas_text: str = ""
    # (defines, parameter values, mu) -> the most E(mu) may be without creating energy (an array
    # broadcast with mu); None: 1. A BSDF in radiance form exceeds 1 where it refracts into a
    # rarer medium (radiance grows by the squared ratio of the indices)
    energy_bound_fn: Callable | None = None

    # The hooks: what the library asks of a model, each a method. A description gives each as
    # a function (configure_fn, anisotropic_fn, ...) or overrides the method in a subclass.

    def resolve(self, opts: dict, given: set) -> Resolved:
        """The kernel's configuration for these options and names of the parameters given."""
        if self.configure_fn is None:
            return Resolved((), tuple(p.name for p in self.params))
        return self.configure_fn(opts, given)

    def anisotropic(self, cfg: "Config", values: dict) -> bool:
        return bool(self.anisotropic_fn and self.anisotropic_fn(dict(cfg.defines), values))

    def mu_kinks(self, cfg: "Config", values: dict):
        return (self.mu_kinks_fn(dict(cfg.defines), values, cfg.channels) if self.mu_kinks_fn
                else None)

    def energy_bound(self, cfg: "Config", values: dict, mu):
        return (np.asarray(self.energy_bound_fn(dict(cfg.defines), values, mu), float)
                if self.energy_bound_fn else np.ones(np.shape(mu)))

    def deltas(self, cfg: "Config", values: dict):
        return (np.asarray(self.deltas_fn(dict(cfg.defines), values), bool) if self.deltas_fn
                else np.zeros((), bool))

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        raise ParameterError(f"model {self.name} has no parameter {name!r}; "
                             f"parameters: {', '.join(p.name for p in self.params)}; "
                             f"options: {', '.join(o.name for o in self.options)}")

    def option(self, name: str) -> Option:
        for o in self.options:
            if o.name == name:
                return o
        raise KeyError(name)

    def split(self, kwargs: dict) -> tuple[dict, dict]:
        """Separate options (strings) from numeric parameters, checking names."""
        opts, params = {}, {}
        option_names = {o.name for o in self.options}
        for k, v in kwargs.items():
            if k in option_names:
                opts[k] = self.option(k).check(v)
            else:
                self.param(k)
                params[k] = v
        return opts, params

    def configure(self, channels: int = 1, **kwargs) -> tuple[Config, dict[str, np.ndarray]]:
        """Config and validated parameter arrays (not yet broadcast) for these arguments.

        With ``channels=3`` a spectral parameter's array has a trailing axis of length 3 (one
        value per channel; a scalar is used for all three)."""
        if channels not in (1, 3):
            raise ParameterError(f"channels={channels!r} is not valid: choose 1 or 3 (RGB)")
        opts, given = self.split(kwargs)
        r = self.resolve(opts, set(given))
        if not isinstance(r, Resolved):
            raise TypeError(f"model {self.name}: its configuration is a {type(r).__name__}, "
                            f"not clbrdf.models.spec.Resolved")
        defines, used, resolved, headers = r.defines, r.used, r.options, tuple(r.headers)
        unused = set(given) - set(used)
        if unused:
            name = sorted(unused)[0]
            raise ParameterError(f"parameter {name} is not used by model {self.name} with "
                                 f"{', '.join(f'{k}={v}' for k, v in resolved.items()) or 'these options'}")
        values = {}
        for name in used:
            p = self.param(name)
            v = np.asarray(given.get(name, p.default), dtype=np.float64)
            if p.spectral and channels > 1:
                if v.ndim == 0:
                    v = np.broadcast_to(v, (channels,))
                elif v.shape[-1] not in (1, channels):
                    raise ParameterError(
                        f"parameter {name} is per channel: with channels={channels} its last axis "
                        f"must have length {channels} (or 1), got shape {v.shape}")
                else:
                    v = np.broadcast_to(v, v.shape[:-1] + (channels,))
            p.check(v)
            values[name] = v
        spectral = tuple(n for n in used if self.param(n).spectral)
        cfg = Config(self.name, self.header, self.prefix, tuple(defines), tuple(used),
                     tuple(sorted(resolved.items())), channels, spectral, headers)
        return cfg, values


def finite_or_raise(name: str, a: np.ndarray) -> None:
    if not np.all(np.isfinite(a)):
        raise ParameterError(f"{name} contains NaN or Inf")


def check_directions(name: str, w: np.ndarray, tol: float = 1e-4, allow_below: bool = False) -> np.ndarray:
    """Unit vectors, shape (..., 3), in the upper hemisphere (z > 0) unless allow_below."""
    w = np.asarray(w, dtype=np.float64)
    if w.shape[-1:] != (3,):
        raise ParameterError(f"{name} must have shape (..., 3), got {w.shape}")
    finite_or_raise(name, w)
    norm = np.linalg.norm(w, axis=-1)
    bad = np.abs(norm - 1) > tol
    if np.any(bad):
        i = np.argmax(bad.reshape(-1))
        raise ParameterError(f"{name}={w.reshape(-1, 3)[i].tolist()} is not a unit vector "
                             f"(length {norm.reshape(-1)[i]:.6g}; valid: length 1 within {tol:g})")
    if not allow_below and np.any(w[..., 2] <= 0):
        i = np.argmax((w[..., 2] <= 0).reshape(-1))
        raise ParameterError(f"{name}={w.reshape(-1, 3)[i].tolist()} is below the horizon: "
                             f"valid directions have z = cos(theta) in (0, 1]")
    return w


# The smallest accepted mu = cos(theta_o) per precision. Below the single-precision bound
# 1 - mu^2 is 1 to the last bit and grazing lobes are no longer resolved; the conformance battery
# (tests/models/test_conformance.py) checks every model down to these values.
MU_MIN = {"single": 1e-6, "double": 1e-12}


def check_mu(mu, precision: str = "double", below: bool = False) -> np.ndarray:
    """mu = cos(theta_o) in [MU_MIN, 1]; with ``below`` (a model that transmits) also in
    [-1, -MU_MIN], a wo below the surface."""
    mu = np.asarray(mu, dtype=np.float64)
    lo = MU_MIN[precision]
    a = np.abs(mu) if below else mu
    bad = ~np.isfinite(mu) | (a < lo) | (a > 1)
    if np.any(bad):
        v = mu.reshape(-1)[np.argmax(bad.reshape(-1))]
        valid, where = ((f"[-1, -{lo:g}] or [{lo:g}, 1]", "wo above or below the surface")
                        if below else (f"[{lo:g}, 1]", "a direction above the horizon"))
        raise ParameterError(f"mu={float(v)!r} is out of range: valid mu = cos(theta_o) is in "
                             f"{valid} in {precision} precision ({where})")
    return mu


def check_choice(name: str, value, choices):
    """``value`` if it is one of ``choices``, else a ParameterError naming them."""
    if value not in choices:
        raise ParameterError(f"{given(name, value)} is not valid: choose one of "
                             f"{', '.join(choices)}", name)
    return value


def check_fraction(name: str, value, hi: float = 1.0, text: str = "") -> float:
    """A number in (0, hi) (a tolerance, a standard error target, a probability); True and
    non-numbers are not. ``text`` says what it is, after the range."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer,
                                                                      np.floating)) \
            or not 0 < float(value) < hi:
        raise ParameterError(f"{given(name, value)} is out of range: valid {called(name)} is in "
                             f"(0, {hi:g}){text}", name)
    return float(value)


def check_int(name: str, value, lo: int, hi: int, text: str | None = None) -> int:
    """An integer in [lo, hi]: 3 and 3.0 are accepted, 1.5, True, '3' and NaN are not."""
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))
    if not ok and isinstance(value, (float, np.floating)) and float(value).is_integer():
        value, ok = int(value), True
    rng = text or f"[{lo}, {hi}]"
    if not ok:
        raise ParameterError(f"{given(name, value)} is not valid: {called(name)} must be an "
                             f"integer in {rng}", name)
    if not lo <= int(value) <= hi:
        raise ParameterError(f"{given(name, int(value))} is out of range: valid {called(name)} is "
                             f"in {rng}", name)
    return int(value)
