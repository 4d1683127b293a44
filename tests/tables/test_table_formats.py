"""Files written by clbrdf 0.1.0 load with ``Table.load`` / ``load_tables``: its plain .npz
tables (``clbrdf.tables.save_table`` of ``albedo_table``'s dict: one channel, RGB, the Fresnel
split with refinement) and its layout tables (format ``clbrdf-tables/1``). The files in
tests/data/v0.1.0/ were written by the 0.1.0 code (commit 2cc0bae, scripts/write_v010_tables.py
run with that tree first on sys.path); each is compared with its own arrays read by numpy."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import clbrdf

DATA = Path(__file__).parents[1] / "data" / "v0.1.0"


def raw(name):
    with np.load(DATA / name) as z:
        return {k: z[k] for k in z.files}


@pytest.mark.parametrize("name", ["plain.npz", "plain_rgb.npz", "split_refined.npz"])
def test_plain_tables_of_010_load(name):
    z = raw(name)
    meta = json.loads(str(z["metadata"]))
    t = clbrdf.Table.load(DATA / name)
    assert t.computed == meta
    axes = [a for a in meta["axes"] if a != "channel"]
    assert t.axis_names == axes
    for a in axes:
        np.testing.assert_array_equal(t[a], z[a])
    for k in ("E", "E_stderr", "E_avg", "E_avg_stderr", "A", "B", "A_avg", "B_avg_stderr",
              "E_samples", "E_avg_samples"):
        if k in z:
            np.testing.assert_array_equal(t[k], z[k], err_msg=k)
    # the lookup at the table's own nodes gives the stored values
    grid = np.meshgrid(*[z[a] for a in axes], indexing="ij")
    want = np.stack([z[q] for q in ("A", "B", "E")], -1) if "A" in z else z["E"]
    np.testing.assert_allclose(t.lookup(*grid), want, rtol=1e-12)


def test_layout_tables_of_010_load():
    z = raw("layout_ue5.npz")
    meta = json.loads(str(z["metadata"]))
    assert meta["format"] == "clbrdf-tables/1"
    tables = clbrdf.load_tables(DATA / "layout_ue5.npz")
    assert list(tables) == list(meta["tables"])
    for name, t in tables.items():
        np.testing.assert_array_equal(t.raw, z[name])
        np.testing.assert_array_equal(t.stderr, z[f"{name}.stderr"])
        assert t.quantity == meta["tables"][name]["quantity"]
        assert t.encoding == meta["tables"][name]["encoding"]
        for a in t.axes:
            np.testing.assert_array_equal(a["values"], z[f"{name}.axis.{a['name']}"])
