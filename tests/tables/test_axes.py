"""The one axis parser of tables and sweeps (clbrdf/tables/axes.py): forms, spacings, placements, min=,
mapped axes, midpoints, and the errors that name what is wrong."""
import numpy as np
import pytest

from clbrdf import ParameterError
from clbrdf.tables.axes import check_form, describe, evaluated, grid_values, midpoints, parse_axis, positions, unwarp, warp


def test_forms():
    assert parse_axis("mu=0.1,0.5,1") == {"name": "mu", "values": [0.1, 0.5, 1.0]}
    assert parse_axis("alpha=0.01:1:log") == {"name": "alpha", "start": 0.01, "stop": 1.0,
                                              "spacing": "log"}
    ax = parse_axis("r=0:1:32:sqrt:centres:min=0.01")
    assert ax == {"name": "r", "start": 0.0, "stop": 1.0, "count": 32, "spacing": "sqrt",
                  "placement": "centres", "min": 0.01}
    assert parse_axis("mu = 0:1:4:centers")["placement"] == "centres"


def test_placements_and_spacings():
    assert np.allclose(positions(4, "nodes"), [0, 1 / 3, 2 / 3, 1])
    assert np.allclose(positions(4, "centres"), [0.125, 0.375, 0.625, 0.875])
    assert np.allclose(grid_values(0, 1, 16, "lin", "centres"), (np.arange(16) + 0.5) / 16)
    assert np.allclose(grid_values(1e-3, 1, 4, "log"), [1e-3, 1e-2, 1e-1, 1])
    assert np.allclose(grid_values(0, 1, 3, "sqrt"), [0, 0.25, 1])
    for sp in ("lin", "log", "sqrt"):
        u = np.linspace(0, 1, 7)
        assert np.allclose(unwarp(warp(u, 0.01, 2.0, sp), 0.01, 2.0, sp), u)
    assert np.allclose(grid_values(0.01, 2, 5, "sqrt", "centres"),
                       warp((np.arange(5) + 0.5) / 5, 0.01, 2, "sqrt"))


def test_min_and_mapped_axes():
    ax = check_form(parse_axis("r=0:1:3:min=0.01"))
    assert ax["values"] == [0.0, 0.5, 1.0]                  # the axis keeps its values
    assert np.allclose(evaluated(ax), [1e-4, 0.25, 1.0])    # alpha = max(r, 0.01)^2
    th = check_form(parse_axis("theta=0:1.5:4"))
    assert np.allclose(evaluated(th), np.cos([0, 0.5, 1.0, 1.5]))
    assert "alpha = r^2" in describe(ax) and "evaluated at r >= 0.01" in describe(ax)


def test_midpoints_sit_halfway_in_index_space():
    ax = check_form(parse_axis("mu=0:1:5"))
    assert np.allclose(midpoints(ax), [0.125, 0.375, 0.625, 0.875])
    ax = check_form(parse_axis("mu=0:1:4:centres"))
    assert np.allclose(midpoints(ax), [0.25, 0.5, 0.75])      # between texel centres
    ax = check_form(parse_axis("eta=1,1.5,3"))
    assert np.allclose(midpoints(ax), [1.25, 2.25])
    assert midpoints(check_form(parse_axis("mu=0.5"))) == []


@pytest.mark.parametrize("text, match", [
    ("mu", "is malformed"),
    ("mu=0:1:x", "COUNT='x' is not an integer"),
    ("mu=a:1:4", "START='a' is not a number"),
    ("mu=0:1:4:cubic", "'cubic' is not a spacing"),
    ("mu=0:1:4:min=nan", "min=nan is not finite"),
    ("mu=0:1", "a grid axis needs a COUNT"),
    ("alpha=0:1:4:log", "log spacing needs START and STOP > 0"),
    ("alpha=-1:1:4:sqrt", "sqrt spacing needs START and STOP >= 0"),
    ("mu=0:1:0", "COUNT"),
])
def test_errors_name_the_problem(text, match):
    with pytest.raises(ParameterError, match=match):
        check_form(parse_axis(text))


def test_view_axis_sqrt1m_mu_is_mu_in_another_form(tmp_path):
    """sqrt1m_mu (ltc_code's and three.js's view axis, mu = 1 - v^2) through the whole table
    path: the same cells as a mu axis at 1 - v^2, bit for bit (the same points and seeds), and a
    chart and files written from it."""
    import clbrdf
    v = check_form(parse_axis("sqrt1m_mu=0:0.9:4"))
    assert np.allclose(evaluated(v), 1 - np.linspace(0, 0.9, 4) ** 2)
    a = clbrdf.albedo_table("ggx", {"sqrt1m_mu": "0:0.9:4", "alpha": [0.2, 0.6]}, samples=1024)
    b = clbrdf.albedo_table("ggx", {"mu": list(1 - np.linspace(0, 0.9, 4) ** 2),
                                    "alpha": [0.2, 0.6]}, samples=1024)
    assert np.array_equal(a["E"], b["E"]) and np.array_equal(a["E_avg"], b["E_avg"])
    assert np.array_equal(a["sqrt1m_mu"], np.linspace(0, 0.9, 4))
    written = clbrdf.save_tables(a, [tmp_path / "v.npz", tmp_path / "v.h"])
    assert (tmp_path / "v.png").exists() and len(written) == 3
    back = clbrdf.Table.load(tmp_path / "v.npz")
    assert np.allclose(back.lookup(sqrt1m_mu=0.3, alpha=0.2), a.lookup(sqrt1m_mu=0.3, alpha=0.2))
