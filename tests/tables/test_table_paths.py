"""Tables and averages, for every kind of axis: each cell of ``albedo_table`` equals a direct
``albedo`` call at that cell's scalar values (independent streams: within 5 combined standard
errors; 5 sigma over the few hundred cells here has a false-alarm rate below 1e-4), and E_avg
integrates over the azimuth where E depends on it."""
import itertools
import json

import numpy as np
import pytest

import clbrdf
from clbrdf import albedo_table

N = 1 << 13
CASES = {
    # name: (model, axes, fixed)
    "mu-alpha": ("ggx", {"mu": [0.2, 0.9], "alpha": [0.1, 0.6]}, {}),
    # a per-channel axis whose length is 3 (the grid's last dimension was read as R, G, B)
    "rgb-kd-axis-of-3": ("ggx", {"mu": [0.3, 0.8], "kd": [0.1, 0.5, 0.9]},
                         {"channels": 3, "f0": [0.9, 0.5, 0.1]}),
    "rgb-axis-first": ("ggx", {"kd": [0.2, 0.7], "mu": [0.25, 0.5, 1.0]},
                       {"channels": 3, "f0": [0.9, 0.5, 0.1], "alpha": 0.3}),
    "preset-axis": ("beckmann", {"mu": [0.3, 0.9], "alpha": [0.05, 0.4, 0.7]},
                    {"preset": "alum-bronze"}),
    "preset-spectral-axis": ("beckmann", {"mu": [0.4, 0.9], "kd": [0.0, 0.3, 0.6]},
                             {"preset": "alum-bronze"}),
    "anisotropic-phi": ("ggx", {"mu": [0.3, 0.9], "phi": [0.0, 0.7, 2.0],
                                "alpha_x": [0.05, 0.5]}, {"alpha_y": 0.8}),
    "schlick-scratch": ("schlick", {"psi": [0.0, 0.5], "mu": [0.3, 0.8], "phi": [0.0, 1.0]},
                        {"p": 0.1, "r": 0.3}),
    # axis text: texel centres, r (alpha = r^2), theta (mu = cos theta), min=, sqrt spacing
    "r-theta-centres": ("ggx", {"theta": "0:1.5:3:centres", "r": "0:1:3:centres"}, {}),
    "nodes-with-min": ("ggx", {"mu": "0:1:3:min=0.05", "r": "0:1:3:min=0.1"}, {}),
    "sqrt-spacing": ("beckmann", {"mu": "0.1:1:3:sqrt", "alpha": "0.05,0.3"}, {}),
    # the Fresnel split: A, B and E = A + B as three quantities
    "split-r": ("ggx", {"r": "0.2:0.9:2", "mu": "0:1:3:centres"}, {"split": True}),
}
MODEL_OF = {"r": ("alpha", lambda v: v * v), "theta": ("mu", np.cos)}
SPLIT_AS = {"A": {"f0": 1.0, "f90": 0.0}, "B": {"f0": 0.0, "f90": 1.0}, "E": {"f0": 1.0, "f90": 1.0}}


def axis_values(spec):
    """(axis values, model values) of an axis as the README states them, written out here
    independently of clbrdf.tables.axes: t = i / (N - 1) at nodes, (i + 0.5) / N at texel centres;
    lin: START + t (STOP - START); sqrt: (sqrt START + t (sqrt STOP - sqrt START))^2; min=LO
    evaluates at max(value, LO); r and theta map to alpha = r^2 and mu = cos theta."""
    if not isinstance(spec, str):
        return list(spec), list(spec)
    fields = spec.split(":")
    if len(fields) == 1:
        v = [float(x) for x in spec.split(",")]
        return v, v
    a, b, n = float(fields[0]), float(fields[1]), int(fields[2])
    flags = fields[3:]
    i = np.arange(n)
    t = (i + 0.5) / n if "centres" in flags else i / (n - 1)
    v = ((np.sqrt(a) + t * (np.sqrt(b) - np.sqrt(a))) ** 2 if "sqrt" in flags
         else a + t * (b - a))
    lo = [float(f[4:]) for f in flags if f.startswith("min=")]
    return v.tolist(), (np.maximum(v, lo[0]) if lo else v).tolist()


def cell_params(axes, names, idx):
    """The model's keywords at one cell (mu and phi apart)."""
    out = {}
    for k, i in zip(names, idx):
        name, f = MODEL_OF.get(k, (k, lambda v: v))
        out[name] = float(f(np.float64(axis_values(axes[k])[1][i])))
    return out


@pytest.mark.parametrize("case", list(CASES))
def test_table_cells_equal_direct_albedo(case):
    name, axes, fixed = CASES[case]
    t = albedo_table(name, axes, samples=N, seed=3, **fixed)
    names = list(axes)
    shape = tuple(len(axis_values(v)[0]) for v in axes.values())
    for k in names:
        assert np.allclose(t[k], axis_values(axes[k])[0], rtol=1e-12, atol=1e-15), k
    rgb = fixed.get("channels") == 3 or "preset" in fixed
    split = fixed.get("split", False)
    model_fixed = {k: v for k, v in fixed.items() if k != "split"}
    quantities = SPLIT_AS if split else {"E": {}}
    for q in quantities:
        assert t[q].shape == shape + ((3,) if rgb else ())
    for idx in itertools.product(*[range(n) for n in shape]):
        cell = cell_params(axes, names, idx)
        mu, phi = cell.pop("mu"), cell.pop("phi", 0.0)
        for q, fres in quantities.items():
            fres = dict(fres, fresnel="schlick") if fres else {}
            r = clbrdf.albedo(clbrdf.Model(name, **model_fixed, **fres, **cell), mu, phi,
                              samples=N, seed=11)
            e, s = t[q][idx], t[q + "_stderr"][idx]
            z = np.abs(e - r.albedo) / np.sqrt(s ** 2 + r.stderr ** 2 + 1e-300)
            assert np.all(z < 5), (case, q, idx, e, r.albedo, z)
    # E_avg over the parameter axes
    pnames = [k for k in names if k not in ("mu", "theta", "phi")]
    pshape = tuple(len(axis_values(axes[k])[0]) for k in pnames)
    for q, fres in quantities.items():
        assert t[q + "_avg"].shape == pshape + ((3,) if rgb else ())
        for idx in itertools.product(*[range(n) for n in pshape]):
            cell = cell_params(axes, pnames, idx)
            fres = dict(fres, fresnel="schlick") if fres else {}
            a, s = clbrdf.albedo_avg(clbrdf.Model(name, **model_fixed, **fres, **cell),
                                     samples=N, seed=5)
            z = np.abs(t[q + "_avg"][idx] - a) / np.sqrt(t[q + "_avg_stderr"][idx] ** 2 + s ** 2)
            assert np.all(z < 5), (case, q, idx, t[q + "_avg"][idx], a)


@pytest.mark.parametrize("model, kw", [
    ("ggx", {"alpha_x": 0.05, "alpha_y": 0.8}),
    ("ashikhmin_shirley", {"nu": 10.0, "nv": 1000.0}),
    ("schlick", {"p": 0.05, "psi": 0.4, "r": 0.2}),
])
def test_e_avg_averages_over_azimuth(model, kw):
    """E_avg of an azimuth-dependent model is the mean over azimuths: the default rule
    (16 azimuths) agrees with 64 azimuths within 4 stderr, and phi = 0 alone (the old code path)
    is measurably different."""
    m = clbrdf.Model(model, **kw)
    assert m.anisotropic
    a16, s16 = clbrdf.albedo_avg(m, samples=1 << 14)
    a64, s64 = clbrdf.albedo_avg(m, samples=1 << 14, phi_nodes=64, seed=1)
    a1, s1 = clbrdf.albedo_avg(m, samples=1 << 14, phi_nodes=1, seed=2)
    assert abs(a16 - a64) < 4 * np.hypot(s16, s64), (a16, a64)
    assert abs(a1 - a64) > 8 * np.hypot(s1, s64), (a1, a64)


def test_isotropic_models_use_one_azimuth():
    for name, kw in [("ggx", {}), ("ashikhmin_shirley", {"nu": 50.0, "nv": 50.0}), ("schlick", {}),
                     ("low_smooth", {}), ("holzschuch_pacanowski", {})]:
        assert not clbrdf.Model(name, **kw).anisotropic, name


@pytest.mark.parametrize("axes, match", [
    ({}, "axes={} is not valid"),
    ({"alpha": [0.1]}, "a table needs one axis of the outgoing direction: mu"),
    ({"mu": []}, r"axis mu must be a non-empty 1-D list of numbers, got shape \(0,\)"),
    ({"mu": [[0.1, 0.2]]}, r"axis mu must be a non-empty 1-D list .*shape \(1, 2\)"),
    ({"mu": 0.5}, r"axis mu must be a non-empty 1-D list .*shape \(\)"),
    ({"mu": ["a"]}, "values must be numbers"),
    ({"mu": [0.5], "masking": [1.0]}, "axis 'masking' of model ggx is an option"),
    ({"mu": [0.5], "beta": [1.0]}, "axis 'beta' of model ggx is not a parameter"),
    ({"mu": [0.5, float("nan")]}, "axis mu contains NaN"),
    ({"mu": [0.0, 0.5]}, r"mu=0.0 is out of range"),
])
def test_table_rejects_bad_axes(axes, match):
    with pytest.raises(clbrdf.ParameterError, match=match):
        albedo_table("ggx", axes, samples=64)


def test_table_axis_and_fixed_value_conflict():
    with pytest.raises(clbrdf.ParameterError, match="alpha is given both as an axis"):
        albedo_table("ggx", {"mu": [0.5], "alpha": [0.1]}, alpha=0.2, samples=64)


def test_python_table_metadata_is_complete():
    """One writer of metadata: the Python table records what its bits depend on."""
    t = albedo_table("ggx", {"mu": [0.5], "alpha": [0.1, 0.2]}, samples=64,
                     spacing={"alpha": "log"}, width=4)
    meta = t.computed
    assert meta["spacing"] == {"mu": "list", "alpha": "log"}
    assert meta["width"] == 4
    for k in ("device", "platform", "driver", "version", "environment", "precision", "seed"):
        assert k in meta, k


@pytest.mark.parametrize("case", ["rgb-axis-first", "anisotropic-phi", "schlick-scratch", "r-theta-centres",
                                  "preset-spectral-axis"])
def test_chart_and_files_of_every_axis_kind(case, tmp_path):
    """The chart has one row per channel of an RGB table and says at which value of further
    axes it is drawn; .npz, .csv and .avg.csv are written for every kind of axis (phi included:
    E_avg has no phi axis)."""
    from clbrdf.cli.tables import _table_summary
    from clbrdf.tables import chart, files
    name, axes, fixed = CASES[case]
    t = albedo_table(name, axes, samples=256, **fixed)
    fig = chart.figure(t)
    rgb = "channel" in t.computed["axes"]
    rows = 3 if rgb else 1
    titles = [ax.get_title() for ax in fig.axes]
    if rgb:
        for c in "RGB":
            assert any(ti.startswith(f"channel {c}") for ti in titles), titles
    assert sum(1 for ax in fig.axes if ax.get_label() != "<colorbar>") >= 2 * rows
    sliced = [a for a in list(axes)[2:] if a != "mu"] if list(axes)[0] != "mu" else list(axes)[2:]
    sup = fig._suptitle.get_text()
    for a in sliced:
        assert f"{a}=" in sup, (a, sup)
    # .h and .exr (each a C header or an image of every table) for two kinds; .npz and .csv all
    suffixes = (".npz", ".csv") + ((".h", ".exr") if case in ("rgb-axis-first", "r-theta-centres")
                                   else ())
    for suffix in suffixes:
        written = files.save_tables(t, tmp_path / f"t{suffix}")
        assert all(p.exists() for p in written)
        if suffix != ".h":          # every file the tool writes loads back to the same table
            back = clbrdf.Table.load(tmp_path / f"t{suffix}")
            for k in t.keys():
                np.testing.assert_allclose(back[k], t[k], rtol=1e-7 if suffix != ".exr" else 1e-6, atol=0 if suffix != ".exr" else 1e-7,
                                           err_msg=f"{suffix} {k}")
    avg = (tmp_path / "t.avg.csv").read_text().splitlines()
    assert "phi" not in avg[1].split(",")
    print(_table_summary(t, 0.0, written))


def test_table_as_an_xarray_dataset():
    """Table.to_xarray: named dimensions, each axis a coordinate with its spacing and mapping,
    E and E_stderr over (mu, r, channel), E_avg over r alone, the same numbers."""
    xr = pytest.importorskip("xarray")
    t = albedo_table("ggx", {"mu": "0.2:1:3", "r": "0.2:1:2:sqrt"}, samples=256, channels=3,
                     f0=[0.9, 0.5, 0.1])
    ds = t.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert ds["E"].dims == ("mu", "r", "channel") and ds["E_avg"].dims == ("r", "channel")
    assert list(ds["channel"].values) == ["R", "G", "B"]
    assert ds["r"].attrs["mapping"] == "alpha = r^2" and ds["r"].attrs["spacing"] == "sqrt"
    np.testing.assert_array_equal(ds["E"].values, t["E"])
    np.testing.assert_array_equal(ds["E_stderr"].values, t["E_stderr"])
    np.testing.assert_array_equal(ds["E_avg"].sel(channel="G").values, t["E_avg"][..., 1])
    assert json.loads(ds.attrs["clbrdf"])["computed"]["model"] == "ggx"


def test_white_furnace_reads_a_plain_table_and_its_average():
    """clbrdf.albedo_table's Table (E over mu and r, its E_avg attached) serves both
    compensations of the white furnace, as a layout's tables do."""
    from clbrdf.studies.furnace import white_furnace
    t = albedo_table("ggx", {"mu": "0.02:1:16", "r": "0.1:1:10"}, samples=1 << 12, qmc=True)
    out = white_furnace({"E": t}, r=(0.5, 1.0), mu=(0.5, 1.0), samples=1 << 14)
    assert "kulla_conty" in out
    # the table's E and E_avg against the estimates of E_ss: within a few 1e-2 after
    # compensation (a 16 x 10 table of 2^12 samples)
    assert np.all(np.abs(out["turquin"] - 1) < 0.03), out["turquin"]
    assert np.all(np.abs(out["kulla_conty"] - 1) < 0.03), out["kulla_conty"]
