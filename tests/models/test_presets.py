"""Material presets: the shipped fit files parse completely, every preset builds and evaluates,
and the Cook-Torrance presets equal the fitters' formula written out independently.

Each model's own test file checks its presets against an independent formula of the fitters'
model (tests/test_<model>.py); the Cook-Torrance fits (model ``beckmann``) are checked here.
"""
import json
import subprocess
import sys

import numpy as np
import pytest

import clbrdf
from clbrdf.models import presets
from clbrdf.models.spec import ParameterError

FILES = ["low_lowsmooth_E2.fit", "low_lowmicrofacet_E2.fit", "low_cooktorrance_E1.fit",
         "low_cooktorrance_E2.fit", "low_ashikhminshirley_E1.fit", "low_ashikhminshirley_E2.fit",
         "abc_low2012_fits.csv", "sgd_bagher2012_fits.csv"]


@pytest.mark.parametrize("source", FILES)
def test_fit_files_parse_completely(source):
    """100 MERL materials per file, each with its Lambertian and model terms (or CSV columns)."""
    fits = presets.load(source)
    assert len(fits) == 100
    text = (presets.data_dir() / source).read_text().splitlines()
    if source.endswith(".fit"):
        lines = [ln for ln in text if ln.strip() and not ln.lstrip().startswith("#")]
        assert len(lines) == 100
        for d in fits.values():
            assert len(d["Lambertian"]["albedo"]) == 3
            assert len(d) == 3                   # name, Lambertian, the model
    else:
        assert all(isinstance(v, float) for d in fits.values() for k, v in d.items()
                   if k not in ("name", "otherName"))


def test_shipped_data_matches_shared_copy():
    """The package carries the same bytes as the project's shared data (when it is present)."""
    from pathlib import Path
    shared = Path(__file__).resolve().parents[3] / "shared" / "data" / "published_fits"
    if not shared.is_dir():
        pytest.skip("no shared/ beside the repository")
    for f in FILES + ["SOURCES.md"]:
        assert (presets.data_dir() / f).read_bytes() == (shared / f).read_bytes(), f


MATERIALS = ["alum-bronze", "chrome", "blue-rubber", "white-paint", "gold-metallic-paint"]


@pytest.mark.parametrize("model", sorted(presets.sources()))
def test_every_preset_builds_and_is_finite(model):
    wi = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [-0.3, 0.4, np.sqrt(0.75)], [0.999, 0.0, 0.0447]])
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo = wi[[1, 2, 3, 0]]
    for name in presets.materials(model):
        m = clbrdf.Model(model, preset=name)
        assert m.channels == 3
        f = m.eval(wo, wi)
        assert f.shape == (4, 3) and np.all(np.isfinite(f)) and np.all(f >= 0), (name, f)
    for name in [n for n in MATERIALS if n in presets.materials(model)] or \
            presets.materials(model)[:5]:
        m = clbrdf.Model(model, preset=name)
        r = clbrdf.albedo(m, [0.1, 0.6, 1.0], samples=4096)
        assert np.all(np.isfinite(r.albedo)) and np.all(r.albedo >= 0), (name, r.albedo)


def cook_torrance_bbm(fit, wi, wo):
    """bbm LowCookTorrance (bsdfmodel/cooktorrance.h): albedo * F_cook(eta) * D * G_vgroove /
    (pi cos_i cos_o) with the unnormalised Beckmann D = exp(-tan^2/m^2) / (m^2 cos^4 theta_h),
    plus Lambertian albedo / pi; written from Cook & Torrance 1982."""
    ct, kd = fit["LowCookTorrance"], np.asarray(fit["Lambertian"]["albedo"])
    m, eta, ks = ct["roughness"], ct["eta"], np.asarray(ct["albedo"])
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    ci, co, ch, c = wi[..., 2], wo[..., 2], h[..., 2], np.sum(wi * h, -1)
    tan2 = (1 - ch * ch) / (ch * ch)
    D = np.exp(-tan2 / m ** 2) / (m ** 2 * ch ** 4)
    G = np.minimum(1, np.minimum(2 * ch * co / c, 2 * ch * ci / c))
    g = np.sqrt(eta ** 2 + c ** 2 - 1)
    F = 0.5 * ((g - c) / (g + c)) ** 2 * (1 + ((c * (g + c) - 1) / (c * (g - c) + 1)) ** 2)
    spec = F * D * G / (np.pi * ci * co)
    return spec[..., None] * ks + kd / np.pi


@pytest.mark.parametrize("source", ["E1", "E2"])
def test_cook_torrance_presets_match_bbm_formula(source):
    rng = np.random.default_rng(7)
    z = rng.uniform(0.05, 1, (2, 64))
    phi = rng.uniform(0, 2 * np.pi, (2, 64))
    w = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], -1)
    wi, wo = w[0], w[1]
    # near-specular pairs too, where the narrow lobes are large
    wi = np.concatenate([wi, wo * [-1, -1, 1] + [0.002, 0, 0]])
    wo = np.concatenate([wo, wo])
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    fits = presets.load(f"low_cooktorrance_{source}.fit")
    for name in ["alum-bronze", "chrome", "blue-rubber", "nickel", "pvc"]:
        m = clbrdf.Model("beckmann", preset=f"{name}:{source}", precision="double")
        np.testing.assert_allclose(m.eval(wo, wi), cook_torrance_bbm(fits[name], wi, wo),
                                   rtol=1e-9, atol=1e-12)


def test_preset_errors_and_overrides():
    with pytest.raises(ParameterError, match="alum-bronz.*similar: alum-bronze"):
        clbrdf.Model("beckmann", preset="alum-bronz")
    with pytest.raises(ParameterError, match="no presets"):
        clbrdf.Model("ward", preset="alum-bronze")
    with pytest.raises(ParameterError, match="source 'E3'"):
        clbrdf.Model("beckmann", preset="alum-bronze:E3")
    m = clbrdf.Model("beckmann", preset="alum-bronze", alpha=0.3)
    assert float(m.params["alpha"]) == 0.3
    assert m.describe()["preset"].startswith("alum-bronze")


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "clbrdf.cli", *args], capture_output=True, text=True)


def test_cli_presets():
    r = run_cli("models", "--presets", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert len(d["beckmann"]["materials"]) == 100
    r = run_cli("eval", "beckmann", "--preset", "chrome:E1", "--wi", "0,0.6,0.8", "--wo", "0,-0.6,0.8",
                "--json")
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)["value"]
    want = clbrdf.Model("beckmann", preset="chrome:E1").eval([0, -0.6, 0.8], [0, 0.6, 0.8])
    np.testing.assert_array_equal(v, want)
    r = run_cli("albedo", "beckmann", "--preset", "nope", "--mu", "1")
    assert r.returncode == 2 and "nope" in r.stderr
