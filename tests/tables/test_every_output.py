"""Every file the command line writes holds the values it computed.

For every (command, suffix) pair the CLI offers, one run writes the ``.npz`` and every other
suffix together (one computation); each file is then read by a consumer that is not the tool's
own reader and compared with the ``.npz`` cell by cell, within the format's resolution:

- ``.h``: compiled with gcc (C99) into a program that calls each table's ``_lookup`` at every
  node of every channel (the header's own decoding of float, half and unorm16) and prints its
  ``_stderr`` array;
- ``.exr``: OpenEXR's channels (float32 of the values);
- ``.csv``: Python's csv module (the values in full);
- ``.js``: Node loads the ES module with a stub ``three`` and reads the DataTextures' data.

The ``.npz`` itself is read back by ``load_tables`` (an LTC layout's too: its fit and its
textures).
``test_the_check_catches_a_header_of_zeros`` shows that the comparison fails on the header writer
of the README's issue (float64 tables written as unsigned short zeros).
"""
import csv
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from clbrdf.tables import cheader
from clbrdf.tables.files import SUFFIXES as TABLE_SUFFIXES
from clbrdf.tables.catalog import ltc_layouts, ltc_textures
from clbrdf.tables.ltc_layouts import SUFFIXES as LTC_SUFFIXES
from clbrdf.tables.table import load_tables
from cliutil import run_inprocess
from threejs import node_textures

EPS32 = float(np.finfo(np.float32).eps)

# (command line without --out, suffixes): every suffix of every command, every encoding
# (float64 plain tables, float32, float16, unorm16), one and three channels, tables with an
# average, planar and interleaved LTC textures
CASES = {
    "table": (["table", "ggx", "--axis", "mu=0.02:1:8", "--axis", "alpha=0.02:1:6", "-n", "256"],
              TABLE_SUFFIXES),
    "table-rgb": (["table", "beckmann", "--preset", "alum-bronze", "--axis", "mu=0.1:1:4",
                   "--axis", "alpha=0.2:0.8:3", "-n", "256"], TABLE_SUFFIXES),
    "layout-float16": (["table", "--layout", "threejs", "-n", "64"], TABLE_SUFFIXES),
    "layout-unorm16": (["table", "--layout", "ue5", "-n", "64"], TABLE_SUFFIXES),
    "layout-float32": (["table", "--layout", "eevee", "-n", "64"], TABLE_SUFFIXES),
    "ltc": (["ltc", "ggx", "--axis", "mu=0.2:1:3", "--axis", "r=0.2:1:3", "-n", "64",
             "--report-samples", "256"], TABLE_SUFFIXES),
    "ltc-threejs": (["ltc", "--layout", "threejs", "-n", "64", "--report-samples", "256",
                     "--magnitude-tol", "1e-4"],
                    tuple(ltc_layouts()["threejs"]["formats"])),
    "ltc-cycles_sheen": (["ltc", "--layout", "cycles_sheen", "-n", "64", "--report-samples",
                          "256", "--magnitude-tol", "1e-4"], tuple(ltc_layouts()["cycles_sheen"]["formats"])),
}


@pytest.mark.smoke
def test_the_cases_cover_every_suffix_the_cli_offers():
    """A new suffix or LTC layout format needs a reader here."""
    offered = {("table", s) for s in TABLE_SUFFIXES} | {("ltc", s) for s in TABLE_SUFFIXES} | \
        {("ltc --layout", s) for lay in ltc_layouts().values() for s in lay.get("formats", LTC_SUFFIXES)}
    covered = set()
    for argv, sufs in CASES.values():
        kind = "ltc --layout" if argv[0] == "ltc" and "--layout" in argv else argv[0]
        covered |= {(kind, s) for s in sufs}
    assert offered <= covered, offered - covered
    assert set(READERS) >= {s for _, s in offered} - {".npz"}


def _run(tmp_path, case):
    argv, sufs = CASES[case]
    outs = [tmp_path / f"out{s}" for s in (".npz",) + tuple(s for s in sufs if s != ".npz")]
    r = run_inprocess(*argv, *[x for o in outs for x in ("--out", o)])
    assert r.returncode == 0, r.stderr
    return outs


# ---------------------------------------------------------------------------------------------
# plain and layout tables: the .npz's Tables against each other file

def _with_averages(tables, scalars=True):
    """The tables and their averages, each by its own name (a C lookup or an image needs axes)."""
    out = {}
    for name, t in tables.items():
        out[name] = t
        if t.average is not None and (scalars or t.average.axes):
            out[t.average.name] = t.average
    return out


def _channels(t):
    v = np.asarray(t.values, np.float64)
    return v[..., None] if len(t.quantity) == 1 else v


def _stderr(t):
    e = np.asarray(t.stderr, np.float64)
    return e[..., None] if len(t.quantity) == 1 else e


def read_header(path, tables, tmp):
    """{name: (values over the nodes with channels last, stderr as stored)} from the compiled
    header: each table's lookup at every node and every channel, and its stderr array."""
    text = path.read_text()
    lines = ["#include <stdio.h>", "#define CLBRDF_LUT_WITH_STDERR", f'#include "{path.name}"',
             "int main(void)", "{"]
    order = []
    for name, t in _with_averages(tables, scalars=False).items():
        m = re.search(rf"float (\w+_{re.escape(name)})_lookup\(", text)
        assert m, f"{path.name}: no lookup for table {name}"
        cn = m.group(1)
        nodes = np.stack(np.meshgrid(*[np.asarray(a["values"], np.float64) for a in t.axes],
                                     indexing="ij"), -1).reshape(-1, len(t.axes))
        nc = len(t.quantity)
        lines.append(f"    static const float {cn}_nodes[{nodes.size}] = {{"
                     + ", ".join(f"{x!r}f" for x in nodes.ravel().astype(np.float32).tolist())
                     + "};")
        args = ", ".join(f"{cn}_nodes[i * {len(t.axes)} + {d}]" for d in range(len(t.axes)))
        chan = ", c" if nc > 1 else ""
        lines.append(f"    for (int i = 0; i < {len(nodes)}; ++i) for (int c = 0; c < {nc}; ++c) "
                     f'printf("%.9g\\n", (double){cn}_lookup({args}{chan}));')
        size = int(np.prod(t.shape)) * nc
        lines.append(f'    for (int i = 0; i < {size}; ++i) printf("%.9g\\n", (double){cn}_stderr[i]);')
        order.append((name, t.shape + (nc,), size))
    lines += ["    return 0;", "}"]
    (tmp / "read_h.c").write_text("\n".join(lines) + "\n")
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-I", str(path.parent),
                    str(tmp / "read_h.c"), "-o", str(tmp / "read_h"), "-lm"], check=True)
    got = np.array(subprocess.run([str(tmp / "read_h")], capture_output=True, text=True,
                                  check=True).stdout.split(), np.float64)
    out, k = {}, 0
    for name, shape, size in order:
        out[name] = (got[k:k + size].reshape(shape), got[k + size:k + 2 * size].reshape(shape))
        k += 2 * size
    return out


def read_exr(path, tables, tmp):
    import OpenEXR
    out = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        parts = {p.name(): p for p in f.parts}
        for name, t in _with_averages(tables, scalars=False).items():
            ch = parts[name].channels
            v = np.stack([np.asarray(ch[q].pixels, np.float64).reshape(t.shape)
                          for q in t.quantity], -1)
            e = np.stack([np.asarray(ch[q + ".stderr"].pixels, np.float64).reshape(t.shape)
                          for q in t.quantity], -1)
            out[name] = (v, e)
    return out


def _csv_grid(path, t):
    rows = list(csv.reader(path.read_text().splitlines()[1:]))
    head, body = rows[0], np.array(rows[1:], np.float64)
    col = {h: body[:, i] for i, h in enumerate(head)}
    for d, a in enumerate(t.axes):         # rows in memory order: the axes' own values
        grid = np.meshgrid(*[np.asarray(b["values"]) for b in t.axes], indexing="ij")[d]
        assert np.array_equal(col[a["name"]], grid.ravel()), (path.name, a["name"])
    v = np.stack([col[q].reshape(t.shape) for q in t.quantity], -1)
    e = np.stack([col[q + "_stderr"].reshape(t.shape) for q in t.quantity], -1)
    return v, e


def read_csv(path, tables, tmp):
    out = {}
    many = len(tables) > 1
    for name, t in tables.items():
        p = path.with_name(f"{path.stem}.{name}.csv") if many else path
        out[name] = _csv_grid(p, t)
        if t.average is not None:
            out[t.average.name] = _csv_grid(p.with_suffix(".avg.csv"), t.average)
    return out


READERS = {".h": read_header, ".exr": read_exr, ".csv": read_csv, ".js": None}


def _compare(suffix, name, t, got_v, got_e):
    want, err = _channels(t), _stderr(t)
    assert got_v.shape == want.shape, (suffix, name, got_v.shape, want.shape)
    if suffix == ".csv":            # full precision
        bound_v, bound_e = 0.0, 0.0
    elif suffix == ".exr":          # float32 of the values
        bound_v, bound_e = EPS32 * np.abs(want), EPS32 * np.abs(err)
    else:       # .h: float32 storage and arithmetic, the node's index off by a few ulps of N
        scale = np.max(np.abs(want), axis=tuple(range(want.ndim - 1)))
        bound_v = 16 * EPS32 * np.abs(want) + 8 * max(t.shape) * EPS32 * scale
        bound_e = EPS32 * np.abs(err)
    bad = np.abs(got_v - want) > bound_v
    assert not bad.any(), (f"{suffix} table {name}: {int(bad.sum())} of {bad.size} values "
                           f"differ from the .npz, e.g. {got_v[bad][:3]} for {want[bad][:3]}")
    bad = np.abs(got_e - err) > bound_e
    assert not bad.any(), (f"{suffix} table {name}: {int(bad.sum())} stderr values differ, e.g. "
                           f"{got_e[bad][:3]} for {err[bad][:3]}")


def check_tables(outs, tmp):
    npz = outs[0]
    tables = load_tables(npz)
    checked = []
    for out in outs[1:]:
        got = READERS[out.suffix](out, tables, tmp)
        want = _with_averages(tables, scalars=out.suffix == ".csv")
        assert set(got) == set(want), (out.name, set(got), set(want))
        for name, (v, e) in got.items():
            _compare(out.suffix, name, want[name], v, e)
            checked.append((out.suffix, name))
    return checked


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
@pytest.mark.parametrize("case", [pytest.param("table", marks=pytest.mark.smoke), "table-rgb",
                                  "layout-float16", "layout-unorm16", "layout-float32", "ltc"])
def test_every_table_file_holds_the_npz_values(case, tmp_path):
    outs = _run(tmp_path, case)
    checked = check_tables(outs, tmp_path)
    assert {s for s, _ in checked} == {o.suffix for o in outs[1:]}


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
def test_the_check_catches_a_header_of_zeros(tmp_path, monkeypatch):
    """The comparison fails on the header writer of the issue: float64 tables went to the
    unsigned short branch, where int(v) made every value below 1 a 0."""
    def old_stored(t, cname):
        if t.encoding == "float32":
            return cheader._array("float", cname, t.raw, cheader._f32)
        bits = t.raw.view(np.uint16) if t.encoding == "float16" else t.raw
        return cheader._array("unsigned short", cname, bits, lambda v: f"{int(v)}u")
    monkeypatch.setattr(cheader, "_stored", old_stored)
    argv, _ = CASES["table"]
    outs = [tmp_path / "out.npz", tmp_path / "out.h"]
    r = run_inprocess(*argv, "--out", outs[0], "--out", outs[1])
    assert r.returncode == 0, r.stderr
    with pytest.raises(AssertionError, match=r"\.h table E: 48 of 48 values differ"):
        check_tables(outs, tmp_path)


# ---------------------------------------------------------------------------------------------
# LTC layouts: the textures of the .npz against the .js, .h and .exr

def _c_textures(h, tex, planar, tmp):
    lines = ["#include <stdio.h>", f'#include "{h.name}"', "int main(void)", "{"]
    for k, v in tex.items():
        lines.append(f'    for (int i = 0; i < {v.size}; ++i) printf("%.9g\\n", (double){k}[i]);')
    lines += ["    return 0;", "}"]
    (tmp / "read_ltc.c").write_text("\n".join(lines) + "\n")
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Werror", "-I", str(h.parent),
                    str(tmp / "read_ltc.c"), "-o", str(tmp / "read_ltc")], check=True)
    got = np.float32(subprocess.run([str(tmp / "read_ltc")], capture_output=True, text=True,
                                    check=True).stdout.split())
    out, k = {}, 0
    for name, v in tex.items():
        flat = got[k:k + v.size]
        k += v.size
        rows, cols, nc = v.shape
        out[name] = (np.moveaxis(flat.reshape(nc, rows, cols), 0, -1) if planar
                     else flat.reshape(rows, cols, nc))
    return out


def _exr_textures(path, tables):
    """The textures' and the fit's channels as OpenEXR reads them: one part per table, one
    channel per quantity."""
    import OpenEXR
    with OpenEXR.File(str(path), separate_channels=True) as f:
        parts = {p.name(): p for p in f.parts}
        out = {k: np.stack([np.asarray(parts[k].channels[q].pixels, np.float32)
                            for q in tables[k].quantity], -1) for k in tables if k != "ltc"}
        errs = {q: np.asarray(parts["ltc"].channels[q].pixels, np.float64)
                for q in ("E", "B", "L3", "L1")}
    return out, errs


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
# not smoke: each layout's magnitudes are 4096 or 1024 cells of the double-precision quadrature.
# threejs (37 s) in the slow tier: cycles_sheen covers `clbrdf ltc --layout` with every format
# of its layout, and the smoke test test_small_texture_files_read_back the threejs textures'
# .js, .h and .exr read back by Node, gcc and OpenEXR
@pytest.mark.parametrize("case", [pytest.param("ltc-threejs", marks=pytest.mark.slow),
                                  "ltc-cycles_sheen"])
def test_every_ltc_layout_file_holds_the_npz_textures(case, tmp_path):
    outs = _run(tmp_path, case)
    layout = CASES[case][0][CASES[case][0].index("--layout") + 1]
    lay = ltc_layouts()[layout]
    tables = load_tables(outs[0])
    textures = ltc_textures(lay)
    assert all(tables[k].raw.dtype == np.float32 and tables[k].quantity == textures[k]
               for k in textures)
    tex = {k: np.float32(tables[k].values) for k in textures}
    fit = {q: tables["ltc"][q] for q in ("E", "B", "L3", "L1")}
    for out in outs[1:]:
        if out.suffix == ".js":
            if shutil.which("node") is None:
                continue
            got = node_textures(out, list(tex), tmp_path)
        elif out.suffix == ".h":
            got = _c_textures(out, tex, bool(lay.get("planar")), tmp_path)
        else:
            got, errs = _exr_textures(out, tables)
            for q, v in fit.items():
                assert np.array_equal(errs[q], np.float32(v).astype(np.float64)), (out.name, q)
        for k, v in tex.items():
            assert np.array_equal(got[k], v), (out.name, k, np.abs(got[k] - v).max())


def test_older_ltc_layout_files_load():
    """LTC layouts as clbrdf 0.1 wrote them (before they had the tables' format: tests/data/
    legacy, written by commit 707016e's save_ltc) load with load_tables: the .npz and the .exr
    of one run give the same textures, errors and axes (the .exr's from the layout's axis
    texts), and a texture's E channel is the fit's E."""
    data = Path(__file__).parents[1] / "data" / "legacy"
    a = load_tables(data / "ltc_cycles_sheen_0.1.npz")
    b = load_tables(data / "ltc_cycles_sheen_0.1.exr")
    assert set(a) == set(b) == {"ltc", "table_sheen_ltc"}
    for k in a:
        assert a[k].quantity == b[k].quantity
        assert np.array_equal(a[k].values, b[k].values), k
        assert np.array_equal(np.float32(a[k].stderr), np.float32(b[k].stderr)), k
        for x, y in zip(a[k].axes, b[k].axes):
            assert x["name"] == y["name"] and np.allclose(x["values"], y["values"], atol=1e-15)
    assert np.array_equal(a["table_sheen_ltc"].values[..., 2], a["ltc"]["E"])
    assert a["table_sheen_ltc"].shape == (32, 32) and a["table_sheen_ltc"].meta["texture"]["planar"]
    t = load_tables(data / "ltc_threejs_0.1.npz")
    assert t["LTC_MAT_2"].shape == (3, 4) and t["LTC_MAT_2"].quantity == ["E", "B", "zero", "sphere"]
    assert np.array_equal(t["LTC_MAT_2"]["E"], t["ltc"]["E"])


@pytest.mark.smoke
@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not installed")
def test_small_texture_files_read_back(tmp_path):
    """The quick tier's .js (and texture .h, .exr): the threejs textures of a 3 x 4 GGX fit,
    written by save_tables and read back by Node, gcc and OpenEXR against the .npz (the full
    layouts are test_every_ltc_layout_file_holds_the_npz_textures's)."""
    from clbrdf import save_tables
    from clbrdf.tables.ltc import fit_ltc
    from clbrdf.tables.textures import textures
    fit = fit_ltc("ggx", {"sqrt1m_mu": "0:0.9:3", "r": "0.2:1:4"}, samples=64,
                  report_samples=256, magnitude_tol=1e-4)
    tables = {"ltc": fit, **textures("threejs", fit)}
    outs = [tmp_path / "t.npz", tmp_path / "t.js", tmp_path / "t.h"]
    try:
        import OpenEXR  # noqa: F401
        outs.append(tmp_path / "t.exr")
    except ImportError:
        pass
    save_tables(tables, outs, chart=False)
    back = load_tables(outs[0])
    tex = {k: np.float32(back[k].values) for k in ("LTC_MAT_1", "LTC_MAT_2")}
    for k in tex:
        assert np.array_equal(tex[k], np.float32(tables[k].values)), k
    got = {".h": _c_textures(outs[2], tex, False, tmp_path)}
    if shutil.which("node"):
        got[".js"] = node_textures(outs[1], list(tex), tmp_path)
    if len(outs) > 3:
        got[".exr"] = _exr_textures(outs[3], back)[0]
    for suffix, g in got.items():
        for k, v in tex.items():
            assert np.array_equal(g[k], v), (suffix, k)
