"""clbrdf/studies/compensation.py and `clbrdf compensation`: each method's formula against the
white furnace (F = 1: every method and the walk give E = 1), the lobe energy against the walk's
own orders, the glass split's conservation, and the command's output files and input checks."""
import csv

import numpy as np
import pytest

from clbrdf.studies import compensation as C
from cliutil import run_inprocess as run_cli


def test_every_method_is_a_white_furnace_at_f_one():
    """F0 = 1, F_avg = 1: Kulla-Conty, Turquin and Fdez-Aguera's E are 1 for any E, E_avg, A, B
    (each paper's defining property)."""
    rng = np.random.default_rng(1)
    e, e_avg = rng.uniform(0.3, 1, 50), rng.uniform(0.3, 1, 50)
    a = rng.uniform(0.2, 0.9, 50)
    b = rng.uniform(0, 1 - a)
    est = C.conductor_albedo(e, e_avg, e, 1.0, 1.0, a, a + b - a)
    for k in ("kulla_conty", "turquin", "fdez_aguera"):
        np.testing.assert_allclose(est[k], 1, rtol=1e-12)


def test_white_material_matches_the_walk_and_kulla_contys_lobe_holds_its_energy():
    """Schlick F0 = 1 (F = 1): the walk's E = 1 exactly, so every compensated E is within the
    quadrature's tolerance of it; single's error is -(1 - E). Kulla-Conty's lobe then carries
    1 - E(mu_o) = the walk's order >= 2 energy (its first order is E), so its L1 includes no
    energy error: it is at least the noise floor and below 2."""
    rows, lobes = C.conductor_cells({"fresnel": "schlick", "f0": [1.0, 1.0, 1.0]}, (0.3, 1.0),
                                    (0.4, 1.0), (0.5,), walks=1 << 16, lobe_walks=1 << 17)
    for r in rows:
        assert r["E_walk"] == 1 and r["walks_cut"] == 0
        for k in ("kulla_conty", "turquin", "fdez_aguera"):
            assert abs(r[f"{k}_error"]) < 1e-6, (k, r)
        assert r["single_error"] < 0
    for r in lobes:
        assert r["noise_L1"] <= r["kulla_conty_L1"] < 2


def test_glass_split_conserves_energy():
    rows = C.glass_cells((1.5,), (0.5,), (0.3, 0.9), walks=1 << 16)
    for r in rows:
        assert r["R_walk"] + r["T_walk"] == pytest.approx(1, abs=1e-12)
        for k in ("scaled_beta", "scaled_correlated"):
            assert r[f"{k}_R"] + r[f"{k}_T"] == pytest.approx(1, abs=1e-12)
            assert r[f"{k}_R_error"] == pytest.approx(-r[f"{k}_T_error"], abs=1e-12)
        # the walk's reflection is the single-scattering one plus what scatters back
        assert r["R_walk"] >= r["single_beta_R"] - 4 * r["walk_stderr"]


def test_command_writes_the_map(tmp_path):
    out = tmp_path / "comp"
    r = run_cli("compensation", "--preset", "copper", "--alphas", "0.3", "--mus", "0.5,1",
                "--lobe-mus", "0.5", "--glass-eta", "1.5", "--walks", "4096", "--lobe-walks",
                "4096", "--out", str(out), "-q")
    assert r.returncode == 0, r.stderr
    for f in ("README.md", "residuals.csv", "lobes.csv", "glass.csv", "residuals.png",
              "glass.png"):
        assert (out / f).stat().st_size > 0
    rows = list(csv.DictReader(open(out / "residuals.csv")))
    assert len(rows) == 2 * 3 and {r["material"] for r in rows} == {"copper"}
    assert "kulla_conty" in (out / "README.md").read_text()


@pytest.mark.parametrize("args, what", [(("--alphas", "5"), "alpha=5.0 is out of range"),
                                        (("--f0", "0.9,0.5"), "--f0 '0.9,0.5'"),
                                        (("--mus", "0"), "mu=0.0 is out of range"),
                                        (("--walks", "10"), "walks")])
def test_command_refuses_bad_input(tmp_path, args, what):
    r = run_cli("compensation", *args, "--out", str(tmp_path / "x"))
    assert r.returncode != 0 and what in r.stderr, r.stderr
    assert not (tmp_path / "x").exists()


@pytest.mark.slow      # table sizes: ~250 device quadratures
def test_recommend_at_f_one_picks_the_table_the_tolerance_allows():
    """F = 1, alpha 0.5: Turquin's, Fdez-Aguera's and Kulla-Conty's E are 1 like the walk's, so
    the cheapest compensating method (Turquin) is chosen with the smallest table whose furnace
    error is within tolerance; the tables' errors shrink with N (64 x 64 within 1e-3 over mu
    0.02..1, docs/compensation/table_size.md)."""
    r = C.recommend("ggx", 0.01, alpha=0.5, walks=1 << 16)
    for k in ("turquin", "fdez_aguera", "kulla_conty"):
        assert r.methods[k]["error"] < 1e-6
    assert r.methods["single"]["error"] > 0.01
    errs = [r.sizes[n]["turquin"] for n in C.SIZES]
    assert errs == sorted(errs, reverse=True) and errs[-1] < 1e-3
    assert r.method == "turquin"
    assert r.table_size == min(n for n in C.SIZES if r.sizes[n]["turquin"] <= 0.01)


@pytest.mark.slow      # table sizes: ~250 device quadratures
def test_recommend_glass_and_bad_input():
    r = C.recommend("ggx_dielectric", 0.05, alpha=0.3, eta=1.5, walks=1 << 16)
    assert set(r.methods) == set(C.GLASS_METHODS) and r.table_size is None
    assert r.methods["single_beta"]["error"] > r.methods["scaled_correlated"]["error"]
    with pytest.raises(C.ParameterError, match="tolerance"):
        C.recommend("ggx", 0.0, alpha=0.5)
    with pytest.raises(C.ParameterError, match="beckmann"):
        C.recommend("beckmann", 0.01)


@pytest.mark.slow      # table sizes: ~250 device quadratures
def test_simplest_command_answers_which_compensation():
    r = run_cli("simplest", "ggx", "--metric", "compensation", "-t", "0.05", "-p",
                "alpha=0.6", "--preset", "copper")
    assert r.returncode == 0, r.stderr
    assert "method: " in r.stdout and "table: " in r.stdout and "kulla_conty" in r.stdout
