"""RGB models (channels=3): each channel is the one-channel model with that channel's parameters.

The one-channel kernels are tested against the float64 reference elsewhere; here the property is
that the channel loop of the kernels, the parameter rows and the host's channel axis put every
channel's parameters and results in the right place, at every width and precision.
"""
import json
import subprocess
import sys

import numpy as np
import pytest

import clbrdf
from clbrdf.models.spec import ParameterError

F0 = [0.04, 0.5, 0.95]
ETA, K = [1.2, 0.3, 2.5], [0.1, 2.0, 3.5]
KS, KD = [1.0, 0.25, 3.0], [0.05, 0.4, 0.8]


def dirs(n=257, seed=3):
    rng = np.random.default_rng(seed)
    z = rng.uniform(0.01, 1, (2, n))
    phi = rng.uniform(0, 2 * np.pi, (2, n))
    s = np.sqrt(1 - z * z)
    w = np.stack([s * np.cos(phi), s * np.sin(phi), z], -1)
    return w[0], w[1]


CASES = [
    ("lambert", {"kd": KD}),
    ("ggx", {"alpha": 0.3, "f0": F0}),
    ("ggx", {"alpha_x": 0.2, "alpha_y": 0.6, "eta": ETA, "k": K, "ks": KS, "kd": KD}),
    ("beckmann", {"alpha": 0.4, "eta": ETA, "kd": KD, "masking": "vcavity", "sampler": "ndf"}),
]


def channel(kw, c):
    return {k: (v[c] if isinstance(v, list) else v) for k, v in kw.items()}


@pytest.mark.parametrize("width", [1, 16])
@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("name,kw", CASES, ids=lambda x: x if isinstance(x, str) else "-".join(x))
def test_eval_is_per_channel(name, kw, precision, width):
    wi, wo = dirs()
    m3 = clbrdf.Model(name, channels=3, precision=precision, width=width, **kw)
    f3 = m3.eval(wo, wi)
    assert f3.shape == (len(wi), 3)
    for c in range(3):
        f1 = clbrdf.Model(name, precision=precision, width=width, **channel(kw, c)).eval(wo, wi)
        np.testing.assert_array_equal(f3[:, c], f1)


@pytest.mark.parametrize("name,kw", CASES[:2], ids=["lambert", "ggx-schlick"])
def test_sample_and_albedo_per_channel_without_mixture(name, kw):
    """Without a Lambertian term in a microfacet model the sampled direction does not depend on
    the channel parameters: weights and albedos are the one-channel ones, bit for bit."""
    wi, wo = dirs(1000)
    m3 = clbrdf.Model(name, channels=3, **kw)
    wi3, w3, p3 = m3.sample(wo, seed=4)
    assert w3.shape == (len(wo), 3)
    r3 = clbrdf.albedo(m3, [0.2, 0.7, 1.0], samples=4096, seed=2)
    assert r3.albedo.shape == (3, 3) and r3.stderr.shape == (3, 3)
    for c in range(3):
        m1 = clbrdf.Model(name, **channel(kw, c))
        wi1, w1, p1 = m1.sample(wo, seed=4)
        np.testing.assert_array_equal(wi3, wi1)
        np.testing.assert_array_equal(p3, p1)
        np.testing.assert_array_equal(w3[:, c], w1)
        r1 = clbrdf.albedo(m1, [0.2, 0.7, 1.0], samples=4096, seed=2)
        np.testing.assert_array_equal(r3.albedo[:, c], r1.albedo)
        np.testing.assert_array_equal(r3.stderr[:, c], r1.stderr)


@pytest.mark.parametrize("estimator", ["brdf", "mis", "cosine"])
def test_mixture_weights_and_albedo(estimator):
    """With kd the lobe choice uses the channel sums; the weight is still f cos / pdf per channel,
    and each channel's albedo agrees with the one-channel model's within 4 combined stderr."""
    name, kw = CASES[2]
    wi, wo = dirs(2000)
    m3 = clbrdf.Model(name, channels=3, precision="double", **kw)
    wis, w, p = m3.sample(wo, seed=9)
    ok = p > 0
    f = m3.eval(wo[ok], wis[ok])
    np.testing.assert_allclose(w[ok], f * wis[ok, 2:3] / p[ok, None], rtol=1e-9)
    np.testing.assert_allclose(m3.pdf(wo[ok], wis[ok]), p[ok], rtol=1e-9)
    mu = [0.15, 0.6, 1.0]
    r3 = clbrdf.albedo(m3, mu, samples=1 << 16, seed=1, estimator=estimator)
    for c in range(3):
        r1 = clbrdf.albedo(clbrdf.Model(name, precision="double", **channel(kw, c)), mu,
                           samples=1 << 16, seed=11, estimator=estimator)
        z = (r3.albedo[:, c] - r1.albedo) / np.hypot(r3.stderr[:, c], r1.stderr)
        assert np.all(np.abs(z) < 4), z


def test_albedo_table_has_channel_axis():
    t = clbrdf.albedo_table("ggx", {"mu": [0.3, 1.0], "alpha": [0.2, 0.5]}, samples=2048,
                            channels=3, f0=F0)
    assert t["E"].shape == (2, 2, 3) and t["E_avg"].shape == (2, 3)
    assert t.computed["axes"] == ["mu", "alpha", "channel"]
    assert t.quantity == ["E.R", "E.G", "E.B"]
    # f0 = 0.95 reflects more than 0.04 at every point
    assert np.all(t["E"][..., 2] > t["E"][..., 0])


def test_bad_channel_input():
    with pytest.raises(ParameterError, match="per channel"):
        clbrdf.Model("ggx", channels=3, f0=[0.1, 0.2])
    with pytest.raises(ParameterError, match="channels=2"):
        clbrdf.Model("ggx", channels=2)
    with pytest.raises(ParameterError, match="f0=1.5"):
        clbrdf.Model("ggx", channels=3, f0=[0.1, 1.5, 0.2])


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "clbrdf.cli", *args], capture_output=True, text=True)


def test_cli_rgb():
    r = run_cli("eval", "ggx", "-p", "alpha=0.3", "-p", "kd=0.1,0.2,0.3", "--wi", "0,0,1",
                "--wo", "0.6,0,0.8", "--json")
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)["value"]
    one = [float(clbrdf.Model("ggx", alpha=0.3, kd=k).eval([0.6, 0, 0.8], [0, 0, 1]))
           for k in (0.1, 0.2, 0.3)]
    np.testing.assert_array_equal(v, one)
    r = run_cli("eval", "ggx", "-p", "alpha=0.3,0.2,0.1", "--wi", "0,0,1", "--wo", "0,0,1")
    assert r.returncode == 2 and "alpha" in r.stderr and "not per channel" in r.stderr
    r = run_cli("eval", "ggx", "-p", "kd=0.1,0.2", "--wi", "0,0,1", "--wo", "0,0,1")
    assert r.returncode == 2 and "three" in r.stderr
