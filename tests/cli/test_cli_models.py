"""`clbrdf albedo` and `clbrdf table` work for every registered model, with its defaults and with a
preset where it has presets: exit 0, finite albedos in [0, 1.5], one per channel, and a table
file whose E agrees with the Python API's bit for bit. In the test process (tests/cliutil.py;
tests/cli/test_cli.py runs the command line as a subprocess)."""
import json

import numpy as np
import pytest

import clbrdf
from clbrdf.models import presets
from cliutil import run_inprocess as run_cli


CASES = [(name, None) for name in clbrdf.MODELS] + \
        [(name, presets.materials(name)[0]) for name in sorted(presets.sources())]


@pytest.mark.parametrize("name,preset", [c if c[1] is None else pytest.param(*c, marks=pytest.mark.slow)
                                         for c in CASES],
                         ids=[f"{n}-{p or 'defaults'}" for n, p in CASES])
def test_albedo_and_table_for_every_model(name, preset, tmp_path):
    extra = ["--preset", preset] if preset else []
    r = run_cli("albedo", name, *extra, "--mu", "0.05,0.5,1", "--samples", "8192", "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    E = np.asarray(out["albedo"], float)
    channels = 3 if preset else 1
    assert E.shape == ((3, 3) if channels == 3 else (3,))
    assert np.all(np.isfinite(E)) and np.all(E >= 0) and np.all(E < 1.5), E
    assert np.all(np.isfinite(out["stderr"]))
    m = clbrdf.Model(name, preset=preset)
    # the command line's estimator when none is given: brdf with Sobol points (cli.RECOMMENDED)
    assert out["estimator"] == "brdf" and out["qmc"] is True
    np.testing.assert_array_equal(E, clbrdf.albedo(m, [0.05, 0.5, 1.0], samples=8192,
                                                   qmc=True).albedo)

    f = tmp_path / "t.npz"
    r = run_cli("table", name, *extra, "--axis", "mu=0.25:1:4", "--samples", "2048", "--out", str(f))
    assert r.returncode == 0, r.stderr
    t = clbrdf.Table.load(f)
    assert t["E"].shape == ((4, 3) if channels == 3 else (4,))
    assert np.all(np.isfinite(t["E"])) and np.all(np.isfinite(t["E_avg"]))
    meta = t.computed
    assert meta["model"] == name
    assert (meta.get("preset", {}).get("material") == preset) if preset else "preset" not in meta
