"""Cheaper Fresnel terms fitted to a conductor's exact one, and how far each is from it.

A conductor of complex index n + i k (``fresnel=conductor``; the metal presets, clbrdf/data/
published_fits/metals_rgb.md) has three cheaper stand-ins, each per channel:

- ``schlick``: F0 = F(1), the exact normal reflectance (Schlick 1994 eq 11);
- ``gen_schlick``: F0 = F(1), F90 = 1 and one exponent for every channel (the parameter is not
  spectral), the least-squares fit of the exact curves weighted by 2 c dc (the weight of F_avg);
- ``f82``: F0 = F(1) and the tint F(1/7) / F_Schlick(1/7) (Hoffman 2023, section 4: the F82
  model matches the exact F at normal incidence and at cos = 1/7, 81.8 degrees, as Cycles'
  conductor setup and OpenPBR do), clipped to the parameter's [0, 1].

``fit_conductor`` gives the parameters; ``fresnel_errors`` the largest |F_fit - F| over c in
[0, 1] and the error of F_avg = 2 int F c dc (both by a 2000-node Gauss-Legendre rule per
channel, float64, from ``clbrdf.ref.microfacet.fresnel``, independent of the kernels).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.optimize import minimize_scalar

from ..ref.microfacet import fresnel
from ..models import get_spec

FITS = ("schlick", "gen_schlick", "f82")
C82 = 1 / 7
@lru_cache(maxsize=1)
def gauss_rule() -> tuple:
    """(nodes, weights) of 2000-point Gauss-Legendre on [0, 1]: computed on first use (about
    1 CPU-second, an eigenproblem), never at import."""
    x, w = np.polynomial.legendre.leggauss(2000)
    return (x + 1) / 2, w / 2


def conductor_curve(eta, k, c):
    """The exact F of the conductor n + i k (per channel, columns) at the cosines c."""
    return fresnel("conductor", c[:, None], eta=np.asarray(eta, float)[None, :],
                   k=np.asarray(k, float)[None, :])


def fitted_curve(kind, p, c):
    """F of a fitted term (per channel, columns) at the cosines c."""
    f0 = np.asarray(p["f0"], float)[None, :]
    if kind == "schlick":
        return fresnel("schlick", c[:, None], f0=f0)
    if kind == "gen_schlick":
        return fresnel("gen_schlick", c[:, None], f0=f0, f90=np.asarray(p["f90"], float)[None, :],
                       exponent=float(p["exponent"]))
    return fresnel("f82", c[:, None], f0=f0, f82=np.asarray(p["f82"], float)[None, :])


def fit_conductor(eta, k, kind: str) -> dict:
    """Parameters of the ``kind`` term (``FITS``) for the conductor n + i k (per channel)."""
    if kind not in FITS:
        raise ValueError(f"kind={kind!r}: choose one of {', '.join(FITS)}")
    eta, k = np.atleast_1d(np.asarray(eta, float)), np.atleast_1d(np.asarray(k, float))
    f0 = conductor_curve(eta, k, np.array([1.0]))[0]
    if kind == "schlick":
        return {"f0": f0.tolist()}
    if kind == "f82":
        schlick82 = f0 + (1 - f0) * (1 - C82) ** 5
        tint = np.clip(conductor_curve(eta, k, np.array([C82]))[0] / schlick82, 0, 1)
        return {"f0": f0.tolist(), "f82": tint.tolist()}
    nodes, weights = gauss_rule()
    exact = conductor_curve(eta, k, nodes)
    ones = np.ones_like(f0)

    def loss(n):
        d = fitted_curve("gen_schlick", {"f0": f0, "f90": ones, "exponent": n}, nodes) - exact
        return float(np.sum(weights[:, None] * 2 * nodes[:, None] * d * d))
    rng = get_spec("ggx").param("exponent")
    n = minimize_scalar(loss, bounds=(0.5, 500.0), method="bounded",
                        options={"xatol": 1e-6}).x
    n = float(np.clip(n, rng.lo, rng.hi))
    return {"f0": f0.tolist(), "f90": ones.tolist(), "exponent": n}


def fresnel_errors(eta, k, kind: str, params: dict | None = None) -> dict:
    """max |F_fit - F| over c (and where), and F_avg of both, per channel."""
    eta, k = np.atleast_1d(np.asarray(eta, float)), np.atleast_1d(np.asarray(k, float))
    p = fit_conductor(eta, k, kind) if params is None else params
    nodes, weights = gauss_rule()
    exact, fit = conductor_curve(eta, k, nodes), fitted_curve(kind, p, nodes)
    d = np.abs(fit - exact)
    i = np.argmax(d, axis=0)
    favg = lambda f: np.sum(weights[:, None] * 2 * nodes[:, None] * f, axis=0)   # noqa: E731
    return {"params": p, "max_abs": d.max(axis=0).tolist(), "at_cos": nodes[i].tolist(),
            "F_avg": favg(exact).tolist(), "F_avg_fit": favg(fit).tolist()}
