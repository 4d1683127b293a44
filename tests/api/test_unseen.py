"""Honest error bars where rare events hide (issue 25, section 1).

A small fraction of GGX visible normals reflect wo below the horizon (weight 0); at low
roughness a run often draws none of them and its sample spread is near 0, while the cosine and
uniform estimators rarely or never draw a sharp lobe at all. The reported error must still cover
the true error: |E - E_ref| <= 4 reported sigma in >= 99.9 % of cells and never beyond 10, over
alpha 1e-4 .. 0.1 and mu 1e-3 .. 1, for every Monte Carlo estimator with both generators, in
``albedo``, tables, layouts and sweeps. E_ref is the float64 reference (clbrdf.ref, an adaptive
quadrature written independently of the kernels).
"""
import functools
import json
import warnings

import numpy as np
import pytest

import clbrdf
from clbrdf.ref import reference

ALPHAS = (1e-4, 3e-4, 1e-3, 0.00416, 0.01, 0.0301, 0.1)
MUS = (1e-3, 0.01, 0.1, 0.3, 0.6, 0.925, 1.0)


@functools.lru_cache(maxsize=None)
def e_ref(alpha, mu):
    return float(reference("ggx", alpha=alpha).albedo(mu)[0])


def ref_grid(alphas, mus):
    return np.array([[e_ref(a, m) for m in mus] for a in alphas])


def z_scores(e, s, ref):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(e == ref, 0.0, np.abs(e - ref) / s)


def assert_covered(z, what):
    z = np.asarray(z).ravel()
    bad4 = int((z > 4).sum())
    assert bad4 <= 0.001 * z.size and z.max() <= 10, \
        f"{what}: {bad4} of {z.size} cells beyond 4 sigma, largest z {z.max():.3g}"


def grid_albedo(estimator, qmc, samples, seed, precision="single"):
    m = clbrdf.Model("ggx", alpha=np.array(ALPHAS)[:, None], precision=precision)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return clbrdf.albedo(m, np.array(MUS)[None, :], estimator=estimator, qmc=qmc,
                             samples=samples, seed=seed)


@pytest.mark.parametrize("qmc", [False, True], ids=["philox", "sobol"])
@pytest.mark.parametrize("estimator", ["brdf", "mis", "cosine", "uniform"])
def test_reported_error_covers_the_true_error(estimator, qmc):
    """Every estimator, both generators, three sample counts and seeds: 147 cells each."""
    ref = ref_grid(ALPHAS, MUS)
    zs = []
    for samples, seed in ((1 << 10, 1), (1 << 14, 2), (1 << 16, 3)):
        r = grid_albedo(estimator, qmc, samples, seed)
        zs.append(z_scores(r.albedo, r.stderr, ref))
        # the parts: the reported error is the sampling error and the allowance in quadrature
        assert np.all(r.stderr >= r.sampling_stderr)
        assert np.all(r.stderr >= r.unseen)
    assert_covered(np.array(zs), f"{estimator} qmc={qmc}")


def test_the_sampling_error_alone_was_not_honest():
    """The failure the allowance fixes: the spread alone puts cells tens of thousands of sigma
    off (GGX alpha 1e-4, mu 0.1: E = 1 - 2.4e-7 +- 6e-12 for 1 - 5.1e-7)."""
    ref = ref_grid(ALPHAS, MUS)
    r = grid_albedo("brdf", True, 1 << 16, 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.abs(r.albedo - ref) / r.sampling_stderr
    assert np.nanmax(z[np.isfinite(z)]) > 100
    assert z_scores(r.albedo, r.stderr, ref).max() < 4


def test_exact_estimators_have_no_allowance():
    """Lambert with cosine or brdf sampling: every weight is kd, nothing can be unseen."""
    m = clbrdf.Model("lambert", kd=0.7, precision="double")
    for est in ("cosine", "brdf", "mis"):
        r = clbrdf.albedo(m, [0.1, 0.5, 1.0], estimator=est, samples=1 << 10)
        assert np.all(r.weight_scale == 0), est
        np.testing.assert_allclose(r.albedo, 0.7, rtol=1e-14)
        assert np.all(r.stderr < 1e-14)
    r = clbrdf.albedo(m, [0.5], estimator="uniform", samples=1 << 10)
    assert np.all(r.weight_scale > 0)          # 2 kd cos varies: an allowance of 2 kd ln(1000)/N


def test_allowance_shrinks_as_one_over_n():
    """GGX alpha 0.00416 at mu 1 draws no zero (its zeros have probability 1.7e-5) in 2^12
    Sobol points, nor at alpha 1e-3 (1e-6) in 2^16: the low side's scale E."""
    a = clbrdf.albedo(clbrdf.Model("ggx", alpha=0.00416), 1.0, samples=1 << 12, qmc=True)
    b = clbrdf.albedo(clbrdf.Model("ggx", alpha=0.001), 1.0, samples=1 << 16, qmc=True)
    assert a.weight_scale > 0.99 and b.weight_scale > 0.99
    np.testing.assert_allclose(a.unseen * a.samples / a.weight_scale,
                               b.unseen * b.samples / b.weight_scale)
    np.testing.assert_allclose(b.unseen, np.log(1000) * b.weight_scale / b.samples)


def test_albedo_avg_covers_the_true_average():
    """E_avg of near-mirror GGX: the nodes may all miss the same rare events; their allowances
    add up (not in quadrature)."""
    alphas = np.array([0.00416])
    ref = []
    x, w = np.polynomial.legendre.leggauss(32)
    mu = (x + 1) / 2
    for a in alphas:
        ref.append(sum(wi * m * e_ref(float(a), float(m)) for wi, m in zip(w, mu)))
    m = clbrdf.Model("ggx", alpha=alphas)
    for qmc in (False, True):
        avg, s = clbrdf.albedo_avg(m, samples=1 << 12, qmc=qmc, seed=5)
        assert_covered(z_scores(avg, s, np.array(ref)), f"E_avg qmc={qmc}")


@pytest.mark.slow
@pytest.mark.parametrize("estimator,qmc", [("brdf", True), ("brdf", False), ("mis", True),
                                           ("mis", False), ("cosine", True), ("uniform", False)])
def test_table_cells_cover_the_true_error_slow(estimator, qmc):
    """A plain table over the acceptance grid (alpha 1e-4 .. 0.1 log, mu 1e-3 .. 1 log), 16 x 16
    cells at 2^12 samples: the cells' errors against the float64 reference."""
    alphas = np.geomspace(1e-4, 0.1, 16)
    mus = np.geomspace(1e-3, 1, 16)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = clbrdf.albedo_table("ggx", {"alpha": alphas, "mu": mus}, samples=1 << 12,
                                estimator=estimator, qmc=qmc, average=False)
    ref = ref_grid(tuple(alphas), tuple(mus))
    assert_covered(z_scores(t["E"], t["E_stderr"], ref), f"table {estimator} qmc={qmc}")


def test_target_stderr_refines_cells_that_drew_no_rare_event():
    """GGX alpha 1e-4, mu 0.1: the spread alone says 6e-12 at 2^16; the target cannot be met
    without the samples to see events of probability ~1e-7, so the cell is refined to the cap
    and the warning says so, where it used to stop at once."""
    with pytest.warns(clbrdf.TargetStderrWarning):
        t = clbrdf.albedo_table("ggx", {"alpha": [1e-4], "mu": [0.1]}, samples=1 << 12,
                                qmc=True, target_stderr=1e-6, max_samples=1 << 16,
                                average=False)
    assert t["E_samples"].max() == 1 << 16
    assert t["E_stderr"].max() > 1e-6


def test_sweep_verdicts_near_mirror_ggx_with_kd(tmp_path):
    """`sweep ggx -p kd=1e-5 --axis alpha=.002,.004,.008,.016` called all 4 points gains, 3
    wrongly (the true max over the 32 directions of E + kd is below 1 for alpha >= 0.004); and
    the worst case of the issue, alpha 0.0301 with kd = 1e-4 (E(mu 0.925) = 0.99907 reported as
    1.0000426 +- 8.4e-6). Two of those roughnesses here; the issue's whole grid is the slow
    test below."""
    alphas = [0.008, 0.0301]
    for qmc in (False, True):
        s = clbrdf.sweep("ggx", tmp_path / f"s{qmc}.zarr", axes={"alpha": alphas},
                         kd=1e-4, qmc=qmc, samples=4096)
        mus = np.asarray(s.root["directions/mu"][:])
        verdict = np.asarray(s.root["verdict"][:])
        for a, v in zip(alphas, verdict):
            true_max = max(e_ref(a, float(m)) for m in mus) + 1e-4
            want = 2 if true_max > 1 else 1
            assert v in (0, want), (a, qmc, v, true_max)
        # reported errors cover the truth at every direction
        E = np.asarray(s.root["E"][:], np.float64)
        S = np.asarray(s.root["E_stderr"][:], np.float64)
        ref = np.array([[e_ref(a, float(m)) + 1e-4 for m in mus] for a in alphas])
        assert_covered(z_scores(E, S, ref), f"sweep qmc={qmc}")


@pytest.mark.slow
@pytest.mark.parametrize("qmc", [False, True], ids=["philox", "sobol"])
def test_sweep_false_verdicts_on_the_issue_grid_slow(tmp_path, qmc):
    """`clbrdf sweep ggx --axis alpha=0.002:0.05:20:log --axis kd=0:0.002:21` called 15 of 420
    points (11 with --qmc) gains that conserve, where the stated error rate (1e-3 per point)
    allows about 0.4. Against the float64 reference at every direction of the sweep: no wrong
    verdict (the truth: max over the 32 directions of E_ggx + kd above 1 or not)."""
    s = clbrdf.sweep("ggx", tmp_path / "s.zarr", axes={"alpha": (0.002, 0.05, 20, "log"),
                                                         "kd": (0, 0.002, 21)}, qmc=qmc)
    mus = np.asarray(s.root["directions/mu"][:])
    alpha = np.asarray(s.root["params/alpha"][:])
    kd = np.asarray(s.root["params/kd"][:])
    verdict = np.asarray(s.root["verdict"][:])
    emax = {a: max(e_ref(float(a), float(m)) for m in mus) for a in np.unique(alpha)}
    want = np.array([2 if emax[a] + k > 1 else 1 for a, k in zip(alpha, kd)])
    wrong = (verdict != 0) & (verdict != want)
    assert not wrong.any(), list(zip(alpha[wrong], kd[wrong], verdict[wrong]))
    assert (verdict != 0).mean() > 0.8          # and the rule still decides most points


@pytest.mark.parametrize("layout, table, rows", [
    ("ospray", "MicrofacetAlbedoTable_dir", 3),
    pytest.param("ue5", "ggx_spec_energy", 2, marks=pytest.mark.slow)])
def test_layout_cells_cover_the_true_error(layout, table, rows):
    """`clbrdf table --layout ospray`: 86 cells of its first three roughness rows were more than
    5 sigma off (alpha 0.00416, mu 1: 1.0000000 +- 4.3e-10 for 0.9999826); ue5's
    E(1/64, 1/64) 54 sigma. The layout's first rows at its published sample count and the
    default estimator (brdf, Sobol points), against the float64 reference, every cell (channel E
    of ue5's table; the table's roughness axis is r, alpha = r^2, evaluated at min= where
    given)."""
    from clbrdf.tables.axes import check_form, evaluated, parse_axis
    from clbrdf.tables.layouts import get_layout, layout_table
    lay = get_layout(layout)
    tab = json.loads(json.dumps([t for t in lay["tables"] if t["name"] == table][0]))
    axis = lambda p: check_form(parse_axis([a for a in tab["axes"] if a.startswith(p)][0]))
    alphas = evaluated(axis("r="))[:rows]              # alpha = max(r, min)^2 of the first rows
    mus = evaluated(axis("mu="))
    tab["axes"] = [("r=" + ",".join(repr(float(np.sqrt(v))) for v in alphas))
                   if a.startswith("r=") else a for a in tab["axes"]]
    t = layout_table(lay, tab, samples=lay["samples"], estimator="brdf", qmc=True,
                     check_interpolation=False)
    names = t.axis_names
    q = t.quantity.index("E")
    vals = t.values if len(t.quantity) == 1 else t.values[..., q]
    errs = t.stderr if len(t.quantity) == 1 else t.stderr[..., q]
    ref = ref_grid(tuple(float(v) for v in alphas), tuple(float(m) for m in mus))
    if names[0] == "mu":
        ref = ref.T
    assert_covered(z_scores(vals, errs, ref), f"{layout} {table}")


@pytest.mark.parametrize("name,alpha,mu", [("ggx", 0.5, 0.5), ("ggx", 0.05, 0.05),
                                           ("beckmann", 0.02, 0.05)])
def test_sobol_error_bars_match_the_error(name, alpha, mu):
    """With W from the probes alone, Sobol points' bars were 3 to 16 times the error (rms z
    0.15, 0.38, 0.06 over 24 seeds): the allowance dwarfed their spread. W now reads what the
    samples drew (weight_scale's ``seen``): over 64 seeds at 2^16 samples the rms z is in
    [0.67, 1.5] and no |z| exceeds 4 (the float64 reference)."""
    ref = float(reference(name, alpha=alpha).albedo(mu)[0])
    m = clbrdf.Model(name, alpha=alpha)
    z = []
    for seed in range(64):
        r = clbrdf.albedo(m, mu, samples=1 << 16, seed=100 + seed, qmc=True)
        z.append((float(r.albedo) - ref) / float(r.stderr))
    z = np.array(z)
    assert 0.67 <= np.sqrt(np.mean(z ** 2)) <= 1.5, np.sqrt(np.mean(z ** 2))
    assert np.abs(z).max() <= 4


def test_target_stderr_with_sobol_points_spends_what_the_target_needs(monkeypatch):
    """A 4 x 4 GGX table refined to 1e-5 with Sobol points: with the allowance that reads the
    samples it takes at most half the samples it took with W from the probes alone, and its
    cells are still within 4 reported errors of the float64 reference."""
    import clbrdf.runtime.albedo as ra
    axes = {"mu": np.array([0.1, 0.4, 0.7, 1.0]), "alpha": np.array([0.1, 0.3, 0.6, 1.0])}
    kw = dict(samples=1 << 12, qmc=True, average=False, target_stderr=1e-5,
              max_samples=1 << 22)
    new = clbrdf.albedo_table("ggx", axes, **kw)
    real = ra.run_albedo
    monkeypatch.setattr(ra, "run_albedo", lambda *a, **k: real(*a, **k)[:4] + (None,))
    old = clbrdf.albedo_table("ggx", axes, **kw)
    assert new["E_samples"].sum() * 2 <= old["E_samples"].sum(), (new["E_samples"],
                                                                  old["E_samples"])
    ref = ref_grid(tuple(axes["alpha"]), tuple(axes["mu"])).T
    assert np.all(new["E_stderr"] <= 1e-5)
    assert_covered(z_scores(new["E"], new["E_stderr"], ref), "refined table")
