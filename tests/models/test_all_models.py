"""Properties every registered model must have, whatever its family: the same values, densities
and samples at every vector width (the kernels are one source compiled with W lanes), finite
outputs, and sample weights equal to f cos / pdf. Each model's own test file checks it against
its paper's formula; this file catches a model that only works at the widths its author tried.
"""
import numpy as np
import pytest

import clbrdf
from clbrdf.models import presets


def model_kwargs(name):
    """A preset where the model has one (RGB, fitted values), else its defaults plus every
    per-channel parameter given three different values when the model has any."""
    if presets.sources().get(name):
        return {"preset": presets.materials(name)[0]}
    spec = clbrdf.MODELS[name]
    spectral = [p for p in spec.params if p.spectral]
    if not spectral:
        return {}
    kw = {"channels": 3}
    for p in spectral:
        d = p.default
        kw[p.name] = [d, d * 0.5 + (0.5 * p.lo if np.isfinite(p.lo) else 0), d]
    try:
        clbrdf.MODELS[name].configure(**kw)
    except clbrdf.ParameterError:       # parameters that need an option: keep the defaults
        return {}
    return kw


def directions(n=61, seed=5):
    """n unit vectors; the last three are the normal, cos 0.05 and cos 1e-3. With seeds 5 and 6,
    pair 58 is (n, n) (h = n, a 0 in lane 2 of its 8-lane vector), which exposed PoCL's double8
    pow bug (see pow_pos in common.h) through its neighbour, pair 57."""
    rng = np.random.default_rng(seed)
    z = np.concatenate([rng.uniform(0.02, 1, n - 3), [1.0, 0.05, 1e-3]])
    phi = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)


def outputs(name, precision, width):
    m = clbrdf.Model(name, precision=precision, width=width, **model_kwargs(name))
    wo = directions()
    wi = directions(seed=6)
    f = m.eval(wo, wi)
    p = m.pdf(wo, wi)
    ws, w, ps = m.sample(wo, seed=3)
    return m, wo, f, p, ws, w, ps


# "default": the precision's default width on a CPU (16 single, 8 double), whose builds the other
# tests share; each other (model, precision, width) is a kernel build of its own: slow tier
DEFAULT_WIDTH = {"single": 16, "double": 8}
WIDTHS = ["default"] + [pytest.param(w, marks=pytest.mark.slow) for w in (2, 4, 8, 16)]


@pytest.mark.parametrize("width", WIDTHS)
@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("name", list(clbrdf.MODELS))
def test_every_width_agrees_with_width_1(name, precision, width):
    width = DEFAULT_WIDTH[precision] if width == "default" else width
    a = outputs(name, precision, 1)[2:]
    b = outputs(name, precision, width)[2:]
    # vector and scalar math builtins may round differently: a few ulps, relative to the scale
    # of each output; sampled directions whose pdf is large can move by more
    rtol = 2e-5 if precision == "single" else 1e-12
    for x, y, what in zip(a, b, ("eval", "pdf", "sample wi", "sample weight", "sample pdf")):
        x, y = np.asarray(x, float), np.asarray(y, float)
        assert np.all(np.isfinite(y)), what
        scale = np.maximum(np.abs(x), 1e-30)
        bad = np.abs(x - y) > rtol * scale + rtol * 1e-3 * np.max(np.abs(x))
        allowed = 0.0 if what in ("eval", "pdf") else 0.02
        assert np.mean(bad) <= allowed, (what, np.mean(bad), np.max(np.abs(x - y) / scale))


# double precision in the slow tier: clbrdf check's weight check runs both at the defaults
@pytest.mark.parametrize("precision", ["single", pytest.param("double", marks=pytest.mark.slow)])
@pytest.mark.parametrize("name", list(clbrdf.MODELS))
def test_sample_weight_is_f_cos_over_pdf(name, precision):
    m, wo, f, p, wi, w, ps = outputs(name, precision, None)
    ok = ps > 0
    assert np.all(np.isfinite(w)) and np.all(np.isfinite(ps)) and np.all(ps >= 0)
    fs = m.eval(wo[ok], wi[ok])
    pe = m.pdf(wo[ok], wi[ok])
    cos = np.abs(wi[ok, 2]).reshape((-1,) + (1,) * (fs.ndim - 1))   # |cos|: a BSDF
    rtol = 1e-3 if precision == "single" else 1e-8
    np.testing.assert_allclose(pe, ps[ok], rtol=rtol, atol=0)
    wt = w[ok]
    np.testing.assert_allclose(wt, fs * cos / pe.reshape(cos.shape), rtol=rtol,
                               atol=rtol * 1e-3 * np.max(np.abs(wt)))
