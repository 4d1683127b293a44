"""``clbrdf check``: the property battery on the device, for one configuration.

``check(model, ...)`` runs, for a model configuration as a user would pass it:

- finite: eval, pdf, and sampled directions, weights and densities over a grid of directions
  from grazing (mu = MU_MIN of the precision) to normal, mirror pairs included, are finite;
- non-negative: the same values are >= 0;
- weight: a sample's weight equals f cos(theta_i) / pdf computed by eval and pdf at the sampled
  direction (relative error at most 1e-3 single / 1e-8 double in all but 0.1 % of samples);
- chi-square: the sampled directions follow the pdf (Pearson's test over equal-mass bins whose
  expected counts are integrals of the pdf refined until two quadrature orders agree, at several
  outgoing directions; Sidak-corrected to a family-wise significance of 1e-3);
- pdf integral: the pdf integrates to the fraction of samples above the horizon (at most 1);
- albedo vs quadrature: the brdf and mis estimates of E agree (Sidak-corrected z-test) with a
  deterministic quadrature of eval over the hemisphere, which does not use the sampler;
- stderr honest: z-scores of 64 independent small estimates have variance near 1;
- energy: max E over the direction grid with its confidence bounds; fails when the lower bound
  exceeds 1 (the configuration gains energy).

Each check gives a statistic, a threshold, a verdict and the worst point. ``CheckReport.passed``
is True when every check passes.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..api.albedo import EPS, albedo, rounding_floor, unseen
from ..api.model import Model
from ..models import get_spec, presets
from ..models.spec import MU_MIN, ParameterError
from . import stats as S

ALPHA = 1e-3              # family-wise significance of the statistical checks
WEIGHT_RTOL = {"single": 1e-3, "double": 1e-8}
WEIGHT_BAD_FRACTION = 1e-3


def floor_of(m, e):
    return rounding_floor(m.precision, e)


def resolution(e, samples):
    """What n samples cannot see where the weights are of the order of E (core.unseen with
    W = |E|), for comparisons that start from a reference rather than from an AlbedoResult."""
    return unseen(np.abs(e), samples, ALPHA)


@dataclass
class Check:
    name: str
    passed: bool
    statistic: float
    threshold: str
    worst: str = ""
    details: dict = field(default_factory=dict)

    def to_json(self):
        return {"name": self.name, "passed": bool(self.passed), "statistic": _num(self.statistic),
                "threshold": self.threshold, "worst": self.worst}


@dataclass
class CheckReport:
    model: str
    params: dict
    precision: str
    checks: list
    seconds: float

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def to_json(self):
        return {"model": self.model, "params": {k: v for k, v in self.params.items() if k != "model"},
                "precision": self.precision,
                "passed": self.passed, "seconds": self.seconds,
                "checks": [c.to_json() for c in self.checks]}

    def table(self) -> str:
        rows = [("check", "statistic", "threshold", "verdict", "worst point")]
        for c in self.checks:
            rows.append((c.name, f"{c.statistic:.4g}", c.threshold, "pass" if c.passed else "FAIL",
                         c.worst))
        w = [max(len(r[i]) for r in rows) for i in range(4)]
        lines = ["  ".join(r[i].ljust(w[i]) for i in range(4)) + "  " + r[4] for r in rows]
        verdict = "all checks pass" if self.passed else \
            f"{sum(not c.passed for c in self.checks)} of {len(self.checks)} checks FAIL"
        return "\n".join(lines + [f"{self.model}: {verdict} ({self.seconds:.1f} s)"])


def _num(x):
    x = float(x)
    return x if math.isfinite(x) else str(x)


def _dir(mu, phi):
    s = np.sqrt(np.maximum(0.0, 1 - mu * mu))
    return np.stack([s * np.cos(phi), s * np.sin(phi), mu], -1)


def _mus(precision):
    lo = MU_MIN[precision]
    return np.array([lo, 1e-4 if lo < 1e-4 else 2 * lo, 1e-2, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0])


def _phis(m):
    return np.array([0.0, 0.4, 1.3, 2.2, 3.5]) if m.anisotropic else np.array([0.0])


def _where(wo=None, wi=None, ch=None):
    parts = []
    if wo is not None:
        parts.append(f"wo=({wo[0]:.4g}, {wo[1]:.4g}, {wo[2]:.4g})")
    if wi is not None:
        parts.append(f"wi=({wi[0]:.4g}, {wi[1]:.4g}, {wi[2]:.4g})")
    if ch is not None:
        parts.append(f"channel {ch}")
    return " ".join(parts)


MIRROR_Z = np.array([1.0, 1.0, -1.0])


def _sides(m):
    """The sides of the surface a sampled wi can lie on: +1 above, and -1 below for a model that
    transmits (spec.transmits)."""
    return (1, -1) if m.spec.transmits else (1,)


def _both(m, d):
    """Directions d (above), and their mirror images below for a model that transmits."""
    return np.concatenate([d, d * MIRROR_Z]) if m.spec.transmits else d


def _pairs(m):
    """Direction pairs (wi, wo): every grid direction against every other, plus mirror pairs
    (and straight-through pairs for a model that transmits)."""
    mus, phis = _mus(m.precision), _phis(m)
    M, P = np.meshgrid(mus, np.concatenate([phis, phis + np.pi]), indexing="ij")
    d = _both(m, _dir(M.ravel(), P.ravel()))
    wi = np.repeat(d, len(d), 0)
    wo = np.tile(d, (len(d), 1))
    mirror = d * np.array([-1.0, -1.0, 1.0])
    extra_wi, extra_wo = [mirror], [d]
    if m.spec.transmits:
        extra_wi.append(-d)
        extra_wo.append(d)
    return np.concatenate([wi] + extra_wi), np.concatenate([wo] + extra_wo)


def probe_values(m, seed):
    """eval and pdf over the pairs, samples at every grid direction: arrays and their points."""
    wi, wo = _pairs(m)
    f = np.asarray(m.eval(wo, wi), float)
    p = np.asarray(m.pdf(wo, wi), float)
    mus, phis = _mus(m.precision), _phis(m)
    M, P = np.meshgrid(mus, phis, indexing="ij")
    wos = _both(m, _dir(M.ravel(), P.ravel()))
    n = 4096
    wo_s = np.repeat(wos, n, 0)
    swi, sw, sp = m.sample(wo_s, seed=seed)
    return dict(wi=wi, wo=wo, f=f, p=p, wo_s=wo_s, swi=np.asarray(swi, float),
                sw=np.asarray(sw, float), sp=np.asarray(sp, float))


def _rowwise(a):
    return a.reshape(len(a), -1)


def check_finite(m, v) -> Check:
    bad_total, worst = 0, ""
    # a model's declared delta (spec.deltas: a dielectric at eta = 1) samples with pdf +inf
    sp = np.where(np.isposinf(v["sp"]) & np.any(m.spec.deltas(m.config, m.params)), 1.0, v["sp"])
    for name, arr, wi, wo in (("eval", v["f"], v["wi"], v["wo"]), ("pdf", v["p"], v["wi"], v["wo"]),
                              ("sample weight", v["sw"], v["swi"], v["wo_s"]),
                              ("sample pdf", sp, v["swi"], v["wo_s"]),
                              ("sample direction", v["swi"], v["swi"], v["wo_s"])):
        bad = ~np.all(np.isfinite(_rowwise(arr)), axis=1)
        if bad.any() and not worst:
            i = int(np.argmax(bad))
            worst = f"{name} {_rowwise(arr)[i].tolist()} at {_where(wo[i], wi[i])}"
        bad_total += int(bad.sum())
    return Check("finite", bad_total == 0, bad_total, "0 non-finite values", worst)


def check_nonnegative(m, v) -> Check:
    lo, worst = 0.0, ""
    for name, arr, wi, wo in (("eval", v["f"], v["wi"], v["wo"]), ("pdf", v["p"], v["wi"], v["wo"]),
                              ("sample weight", v["sw"], v["swi"], v["wo_s"]),
                              ("sample pdf", v["sp"], v["swi"], v["wo_s"])):
        a = np.nan_to_num(_rowwise(arr), nan=0.0).min(axis=1)
        i = int(np.argmin(a))
        if a[i] < lo:
            lo, worst = float(a[i]), f"{name} = {a[i]:.3g} at {_where(wo[i], wi[i])}"
    return Check("non-negative", lo >= 0, lo, "min >= 0", worst)


def check_weight(m, v, perturbations: int = 4) -> Check:
    """Each sample's weight against f cos(theta_i) / pdf at the sampled direction, both from the
    double twin of the configuration. The kernel computes a weight from the half vector it drew
    and returns wi rounded to its precision, so where f or pdf is ill-conditioned (near-mirror
    lobes at grazing angles) the weight is judged against the range of f cos / pdf over wi and
    wo moved by their rounding (a few random perturbations of one unit roundoff, renormalised,
    and of each component by one ulp, not), widened by its own width and by the relative
    tolerance; samples where that value moves by more than itself within one rounding are not
    judged, and counted."""
    # samples above the horizon (either side for a model that transmits); a delta (an infinite
    # pdf: a dielectric at eta = 1) has no f or pdf to compare with
    z = v["swi"][:, 2]
    up = ((z != 0) if m.spec.transmits else (z > 0)) & (v["sp"] > 0) & np.isfinite(v["sp"])
    wi, wo = v["swi"][up], v["wo_s"][up]
    if not len(wi):
        if m.spec.transmits and np.all(np.isinf(v["sp"][v["sp"] > 0])):
            return Check("weight = f cos / pdf", True, 0.0, "a delta only: nothing to compare")
        return Check("weight = f cos / pdf", False, 1.0, "samples above the horizon", "none")
    w = _rowwise(v["sw"][up])
    ref = _double_twin(m)

    def ratio(a, b):
        f = _rowwise(np.asarray(ref.eval(b, a), float))
        pe = np.asarray(ref.pdf(b, a), float)
        return f * np.abs(a[:, 2:3]) / np.where(pe > 0, pe, np.inf)[:, None]
    want = ratio(wi, wo)
    lo, hi = want.copy(), want.copy()
    rng = np.random.default_rng(12345)
    dt = np.float32 if m.precision == "single" else np.float64

    def ulp_steps(w):
        """each component moved by -1, 0 or +1 ulp of the kernel's precision, not renormalised:
        a renormalised perturbation keeps x = -sqrt(1 - y^2 - z^2) of a grazing near-mirror wi,
        where the ulp of x carries wo.h (exppow alpha 1e-4, mu 1e-12 in double: one ulp of wi.x
        moves f cos / pdf by 0.7 %)"""
        k = rng.integers(-1, 2, w.shape)
        x = w.astype(dt)
        return np.where(k > 0, np.nextafter(x, dt(2)), np.where(k < 0, np.nextafter(x, dt(-2)), x)
                        ).astype(float)

    def renormalised(w):
        p = w + EPS[m.precision] * rng.standard_normal(w.shape)
        return p / np.linalg.norm(p, axis=1, keepdims=True)
    for _ in range(perturbations):
        for move in (renormalised, ulp_steps):
            pi_, po = move(wi), move(wo)
            ok = (pi_[:, 2] * wi[:, 2] > 0) & (po[:, 2] * wo[:, 2] > 0)     # on their sides
            r = np.where(ok[:, None], ratio(np.where(ok[:, None], pi_, wi),
                                            np.where(ok[:, None], po, wo)), want)
            lo, hi = np.minimum(lo, r), np.maximum(hi, r)
    tol = WEIGHT_RTOL[m.precision]
    # the range widened by its own width (the perturbations sample it), and samples whose
    # f cos / pdf moves by more than itself within one rounding left out: there no representable
    # wi reproduces the drawn half vector (float32, wo.z = 1e-6, wi.x = -1: the ulp of x is 200
    # times the 1 + wi.x that sets wo.h; a weight 12.7 times f cos / pdf at the rounded wi)
    width = hi - lo
    scale = np.maximum(np.abs(want), 1e-30)
    dist = np.maximum(lo - width - w, w - hi - width)          # <= 0 inside the range
    rel = np.maximum(dist, 0) / scale
    rel = np.where((w == 0) & (want == 0), 0.0, rel)
    judged = (width / scale < 1).all(axis=1)
    rel = np.where(judged, rel.max(axis=1), 0.0)
    frac = float(np.mean(~(rel <= tol)))
    i = int(np.argmax(np.nan_to_num(rel, nan=np.inf)))
    left = int(np.count_nonzero(~judged))
    return Check("weight = f cos / pdf", frac <= WEIGHT_BAD_FRACTION, frac,
                 f"fraction with rel. error > {tol:g} <= {WEIGHT_BAD_FRACTION:g}",
                 f"rel. error {rel[i]:.3g} (weight {w[i].tolist()} vs {want[i].tolist()}) at "
                 f"{_where(wo[i], wi[i])}" + (f"; {left} of {len(rel)} samples ill-conditioned "
                                              "(not judged)" if left else ""))


def _double_twin(m):
    """The same configuration (and class) in double precision where the device has fp64: f and
    pdf at a sampled direction are then computed accurately, and the check measures the sample
    weight, not the conditioning of a single-precision eval (h = normalize(wi + wo))."""
    if m.precision == "double" or not m.device.info.has_fp64:
        return m
    return type(m)(m.name, precision="double", device=m.device,
                   channels=m.channels, **m.options, **m.params)


def _lobe_scale(wo, wi):
    """Stretch (ax, ay) of the half-vector map of wo from pilot samples wi (not the tested
    ones): median |slope| of h = normalize(wi + wo) along x and y, within [1e-4, 1]."""
    wi = wi[wi[:, 2] > 0]
    if len(wi) < 16:
        return 1.0, 1.0
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    sx = np.median(np.abs(h[:, 0] / h[:, 2]))
    sy = np.median(np.abs(h[:, 1] / h[:, 2]))
    return float(np.clip(2 * sx, 1e-4, 1.0)), float(np.clip(2 * sy, 1e-4, 1.0))


def _side_map(m, wo, side, seed):
    """The chi-square's map of one side of the surface, seen mirrored into the upper hemisphere
    (side -1: wi below, z negated): the half-vector map of wo (mirrored with the side) where wo
    reflects onto that side; elsewhere (the refracted lobe of a model that transmits) of the
    direction whose mirror image is the pilot samples' mean direction."""
    pilot, _, _ = m.sample(np.broadcast_to(wo, (4096, 3)), seed=seed + 7919)
    pilot = np.asarray(pilot, float) * np.array([1.0, 1.0, side])
    wo_map = wo * np.array([1.0, 1.0, side])
    if wo_map[2] <= 0:
        c = pilot[pilot[:, 2] > 0].sum(0)
        c = c / np.linalg.norm(c) if np.linalg.norm(c) > 0 else np.array([0.0, 0.0, 1.0])
        wo_map = np.array([-c[0], -c[1], max(c[2], 1e-6)])
        wo_map /= np.linalg.norm(wo_map)
    return S.HalfVectorMap(wo_map, *_lobe_scale(wo_map, pilot))


def chi2_at(m, wo, n, seed, max_levels=3, side=1):
    """Chi-square of n samples at wo against the pdf on one side of the surface (the upper
    hemisphere, or the lower one mirrored: side -1), panels refined (x2 each way, up to
    ``max_levels`` times) until the two quadrature orders agree to 0.1 sd in every bin. The
    samples on the other side fall in the chi-square's below-the-horizon bin."""
    hmap = _side_map(m, wo, side, seed)
    flip = np.array([1.0, 1.0, side])
    wi, _, pdf_s = m.sample(np.broadcast_to(wo, (n, 3)), seed=seed)
    wi = np.asarray(wi, float) * flip
    if m.spec.transmits:        # a rejected sample (pdf 0) may point to either side, and a
        # delta's (pdf inf) has no density: neither side's
        wi[~((np.asarray(pdf_s) > 0) & np.isfinite(pdf_s)), 2] = -1.0

    def pdf(w):
        return np.asarray(m.pdf(np.broadcast_to(wo, w.shape), w * flip), float)
    ns, nt = 64, 128
    for level in range(max_levels + 1):
        r = S.map_chi2(hmap, pdf, wi, ns=ns, nt=nt, max_qerr=None)
        if r.qerr < 0.1 or level == max_levels:
            return r, (ns, nt), hmap
        ns, nt = 2 * ns, 2 * nt


def check_chi2(m, samples, seed, out_dir=None):
    from scipy import stats as sps      # scipy.stats: 0.9 s to import, on use only
    cases = [(wo, side) for wo in _chi2_directions(m) for side in _sides(m)]
    k = len(cases)
    level = S.sidak(ALPHA, k)
    results = []
    for j, (wo, side) in enumerate(cases):
        try:
            # up to 1024 x 2048 panels: Ward alpha_y = 1e-3 at a grazing off-axis wo needs them
            r, panels, hmap = chi2_at(m, wo, samples, seed + j, max_levels=4, side=side)
        except ValueError as e:          # the pdf is not finite or negative somewhere
            bad = Check("chi-square", False, float("nan"), "a finite, non-negative pdf",
                        f"{e} at {_where(wo)}")
            return bad, Check("pdf integral", False, float("nan"), "a finite, non-negative pdf",
                              bad.worst)
        results.append((r, wo, panels, hmap))
    pmin = min(r.p for r, *_ in results)
    r, wo, panels, hmap = min(results, key=lambda x: x[0].p)
    conv = max(x[0].qerr for x in results)
    passed = pmin >= level and conv < 0.1
    worst = f"p = {pmin:.3g} at {_where(wo)} ({r.dof} dof, stat {r.stat:.4g}, panels {panels})"
    if conv >= 0.1:
        worst += f"; expected counts not converged ({conv:.3g} sd)"
    chk = Check("chi-square", passed, pmin, f"p >= {level:.3g} (Sidak, {k} "
                f"{'directions' if len(_sides(m)) == 1 else 'directions and sides'}, "
                f"family {ALPHA:g})", worst)
    if not passed and out_dir is not None:
        chk.details["files"] = _chi2_plots(r, panels, wo, out_dir, m)
    # the binomial sd of the fraction above, and the quadrature's own error (two orders)
    ints = [(x[0].total, x[0].above, x[1], x[0].total_err) for x in results]
    z = [abs(t - a) / math.sqrt(max(a * (1 - a), 1 / samples) / samples + e * e)
         for t, a, _, e in ints]
    i = int(np.argmax(z))
    over = max(t - e for t, _, _, e in ints)
    zlim = float(sps.norm.isf(level / 2))
    pdf_chk = Check("pdf integral", z[i] < zlim + 1 and over <= 1 + 1e-3, z[i],
                    f"|int pdf - fraction above| < {zlim + 1:.2f} sd and int pdf <= 1.001",
                    f"int pdf = {ints[i][0]:.6g}, fraction above {ints[i][1]:.6g} at "
                    f"{_where(ints[i][2])}")
    return chk, pdf_chk


def _chi2_plots(r, panels, wo, out_dir, m):
    """Observed and expected counts per bin (PNG) and the worst bins (CSV)."""
    from pathlib import Path

    from matplotlib.figure import Figure
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ns, nt = panels
    obs_map = r.obs[:-1][r.binmap] / np.maximum(np.bincount(r.binmap.ravel())[r.binmap], 1)
    exp_map = r.exp[:-1][r.binmap] / np.maximum(np.bincount(r.binmap.ravel())[r.binmap], 1)
    fig = Figure(figsize=(12, 4), layout="constrained")
    for i, (title, a) in enumerate((("observed", obs_map), ("expected", exp_map),
                                    ("(obs - exp) / sqrt(exp)",
                                     (obs_map - exp_map) / np.sqrt(np.maximum(exp_map, 1e-12))))):
        ax = fig.add_subplot(1, 3, i + 1)
        im = ax.imshow(a, origin="lower", aspect="auto", extent=(0, 1, 0, 1))
        ax.set_title(title)
        ax.set_xlabel("t (azimuth of h / 2 pi)")
        ax.set_ylabel("s (graded slope radius)")
        fig.colorbar(im, ax=ax)
    fig.suptitle(f"{m.name} chi-square at wo = {np.round(wo, 4).tolist()}")
    png = out / f"chi2_{m.name}.png"
    fig.savefig(png)
    z = (r.obs - r.exp) / np.sqrt(np.maximum(r.exp, 1e-12))
    order = np.argsort(-np.abs(z))[:20]
    csv = out / f"chi2_{m.name}_worst_bins.csv"
    with open(csv, "w") as f:
        f.write("bin,observed,expected,z\n")
        for b in order:
            name = "below-horizon" if b == len(r.obs) - 1 else str(b)
            f.write(f"{name},{int(r.obs[b])},{r.exp[b]:.6g},{z[b]:.4g}\n")
    return [str(png), str(csv)]


def quadrature_albedo(m, wo, hmap, panels, side=1):
    """E(wo) per channel by integrating eval(wo, wi) cos(theta_i) over the panels of hmap
    (Gauss-Legendre of order 4 per panel on 2 ns x 2 nt panels): a deterministic value that does
    not use the sampler; its error is taken as the change from ns x nt panels plus the change
    from order 3 to 4 there. eval is the double twin's (a single-precision eval is off at
    near-mirror grazing pairs: ggx alpha = 1e-4 at mu = 1e-4 gave 0.9043 for 0.8921)."""
    ns, nt = panels
    out = []
    ref = _double_twin(m)
    for c in range(m.channels):
        def f(w, c=c):
            v = np.asarray(ref.eval(np.broadcast_to(wo, w.shape), w * np.array([1, 1, side])),
                           float)
            return (v if m.channels == 1 else v[..., c]) * w[..., 2]
        hi = S.panel_integrals(hmap, f, 2 * ns, 2 * nt, 4).sum()
        lo = S.panel_integrals(hmap, f, ns, nt, 4).sum()
        lo3 = S.panel_integrals(hmap, f, ns, nt, 3).sum()
        out.append((hi, abs(hi - lo) + abs(lo - lo3)))
    return np.array(out)


def _delta_albedo(m, wo, seed, n=1 << 16):
    """(E, err) per channel of the model's declared delta lobe (spec.deltas), which eval does not
    hold: the mean of the weights of the samples with an infinite pdf, and its standard error;
    0 without deltas."""
    if not np.any(m.spec.deltas(m.config, m.params)):
        return np.zeros((m.channels, 2))
    _, w, p = m.sample(np.broadcast_to(wo, (n, 3)), seed=seed)
    w = _rowwise(np.asarray(w, float)) * np.isinf(np.asarray(p))[:, None]
    return np.stack([w.mean(0), w.std(0) / math.sqrt(n)], -1)


def check_albedo(m, samples, seed):
    """brdf and mis estimates against the sampler-free quadrature of eval (quadrature_albedo)."""
    from scipy import stats as sps      # scipy.stats: 0.9 s to import, on use only
    wos = _chi2_directions(m) + [_dir(np.array(MU_MIN[m.precision] * 100), np.array(0.0))]
    zs, worst_z, worst = 0, 0.0, ""
    for j, wo in enumerate(wos):
        try:
            q = 0
            for side in _sides(m):           # a model that transmits: both sides' integrals
                _, panels, hmap = chi2_at(m, wo, 1 << 12, seed + 100 + j, max_levels=3, side=side)
                q = q + quadrature_albedo(m, wo, hmap, panels, side)
            q = q + _delta_albedo(m, wo, seed + 200 + j)
        except ValueError as e:
            return Check("albedo vs quadrature", False, float("nan"), "a finite pdf and eval",
                         f"{e} at {_where(wo)}")
        if not np.all(np.isfinite(q)):
            return Check("albedo vs quadrature", False, float("nan"), "a finite eval",
                         f"the quadrature of eval is not finite at {_where(wo)}")
        mu, phi = float(wo[2]), math.atan2(wo[1], wo[0])
        for k, est in enumerate(("brdf", "mis")):
            r = albedo(m, mu, phi, estimator=est, samples=samples, seed=seed + 2 * j + k)
            e, se = np.atleast_1d(r.albedo), np.atleast_1d(r.sampling_stderr)
            se_all = np.atleast_1d(r.stderr)
            # the side of the unseen-event allowance the difference is on: an estimate above
            # the quadrature may have missed zeros (at most ln(1000) E / N), one below it
            # large weights (r.unseen)
            side = np.where(e > q[:, 0], resolution(e, r.samples), np.atleast_1d(r.unseen))
            z = np.abs(e - q[:, 0]) / np.sqrt(se ** 2 + q[:, 1] ** 2 + floor_of(m, e) ** 2
                                              + side ** 2)
            zs += z.size
            if z.max() > worst_z:
                c = int(np.argmax(z))
                worst_z = float(z.max())
                worst = (f"{est} {e[c]:.7g} +- {se_all[c]:.2g} vs quadrature {q[c, 0]:.7g} at "
                         f"{_where(wo)}" + (f" channel {c}" if m.channels > 1 else ""))
    lim = float(sps.norm.isf(S.sidak(ALPHA, zs) / 2))
    return Check("albedo vs quadrature", worst_z < lim, worst_z,
                 f"|z| < {lim:.2f} (Sidak over {zs})", worst)


def _chi2_directions(m):
    wos = [_dir(np.array(mu), np.array(phi)) for mu in (0.05, 0.5, 1.0) for phi in _phis(m)[:2]]
    wos = [w for i, w in enumerate(wos) if not (w[2] == 1.0 and i % 2)]
    return list(_both(m, np.array(wos)))


def check_stderr(m, seed, samples, runs=64):
    """z-scores of independent estimates against their mean: var(z) ~ 1 when the stderr is
    honest. Accepts var(z) in a chi-square interval (runs - 1 dof) widened by 25 % for the
    estimated stderr (heavy-tailed weights fail here, rightly). The spread may exceed the stderr
    by rounding (``floor_of``) and by what the sample count cannot resolve (``resolution``): the
    upper side judges z with both, the lower side (a stderr larger than the spread) with the
    stderr alone."""
    from scipy import stats as sps      # scipy.stats: 0.9 s to import, on use only
    worst_v, worst = 1.0, ""
    for mu in (0.1, 0.8):
        MU = np.full(runs, mu)
        # independent runs: 64 points with equal parameters draw independent streams
        r = albedo(m, MU, samples=samples, seed=seed)
        e = _rowwise(r.albedo.reshape(runs, -1))
        s = _rowwise(r.sampling_stderr.reshape(runs, -1))
        for c in range(e.shape[1]):
            if np.all(s[:, c] < floor_of(m, e[:, c])):
                continue            # no statistical error to judge: the estimator is exact
            d2 = (e[:, c] - e[:, c].mean()) ** 2
            with np.errstate(divide="ignore", invalid="ignore"):
                v_lo = float(np.nansum(d2 / s[:, c] ** 2) / (runs - 1))
            s2 = s[:, c] ** 2 + floor_of(m, e[:, c]) ** 2 + resolution(e[:, c], samples) ** 2
            v_hi = float(np.sum(d2 / s2) / (runs - 1))
            v = v_lo if v_lo < 1 else max(v_hi, 1.0)
            if abs(math.log(v)) > abs(math.log(worst_v)):
                worst_v, worst = v, (f"mu={mu}" + (f" channel {c}" if e.shape[1] > 1 else "")
                                     + f": E in [{e[:, c].min():.8g}, {e[:, c].max():.8g}], "
                                       f"median stderr {np.median(s[:, c]):.2g}")
    lo = sps.chi2.ppf(ALPHA / 4, runs - 1) / (runs - 1) / 1.25
    hi = sps.chi2.isf(ALPHA / 4, runs - 1) / (runs - 1) * 1.25
    return Check("stderr honest", lo <= worst_v <= hi, worst_v, f"var(z) in [{lo:.2f}, {hi:.2f}]",
                 worst)


def check_energy(m, samples, seed):
    from scipy import stats as sps      # scipy.stats: 0.9 s to import, on use only
    mus, phis = _mus(m.precision), _phis(m)
    if m.spec.transmits:                  # wo on both sides
        mus = np.concatenate([mus, -mus])
    MU, PHI = np.meshgrid(mus, phis, indexing="ij")
    r = albedo(m, MU, PHI, estimator="mis", samples=samples, seed=seed)
    e, s = r.albedo, np.sqrt(r.sampling_stderr ** 2 + floor_of(m, r.albedo) ** 2)
    k = e.size
    z = float(sps.norm.isf(S.sidak(ALPHA, k)))
    # weights are >= 0: events the samples missed can lower E by at most their share of it
    # (ln(1000) E / N) and raise it by at most their share of W (r.unseen); the lower bound
    # needs the first, the upper the second
    lo_all = e - z * s - resolution(e, r.samples)
    # the most E may be (1; a BSDF in radiance form: more where it refracts into a rarer medium)
    bound = m.spec.energy_bound(m.config, m.params, MU)
    bound = bound[..., None] if e.ndim > bound.ndim else bound
    i = np.unravel_index(int(np.argmax(lo_all - bound)), e.shape)
    lower, upper = lo_all[i], e[i] + z * s[i] + r.unseen[i]
    ch = i[2] if len(i) > 2 else None
    text = "1" if np.all(bound == 1) else "the model's bound"
    return Check("energy", lower <= bound[i], float(e[i]), f"lower confidence bound of max E <= {text}",
                 f"E = {e[i]:.6g} [{lower:.6g}, {upper:.6g}] at mu={MU[i[:2]]:.3g} "
                 f"phi={PHI[i[:2]]:.3g}" + (f" channel {ch}" if ch is not None else ""))


def check(model, *, samples: int = 1 << 16, seed: int = 0, precision: str = "single",
          device=None, out=None, **params) -> CheckReport:
    """Run the battery on one configuration (a model name with parameters, options and
    ``preset``, or a ``Model``). ``samples``: samples per direction for the chi-square and the
    albedo checks. ``out``: a directory for the chi-square plots when that check fails."""
    t0 = time.perf_counter()
    m = model if isinstance(model, Model) else Model(model, precision=precision, device=device,
                                                     **params)
    v = probe_values(m, seed)
    checks = [check_finite(m, v), check_nonnegative(m, v), check_weight(m, v)]
    checks += list(check_chi2(m, samples, seed, out))
    checks += [check_albedo(m, samples, seed), check_stderr(m, seed, samples),
               check_energy(m, samples, seed)]
    return CheckReport(m.name, m.describe(), m.precision, checks, time.perf_counter() - t0)


def edge(p, side: str) -> float:
    """The value of parameter ``p`` at the ``lo`` or ``hi`` edge of its range: ``lo`` itself, or
    where ``lo`` is excluded the next value in, 1e-6 of the way (or 1e-6 of lo, if lo > 0)."""
    if side == "hi":
        return float(p.hi)
    if not p.lo_open:
        return float(p.lo)
    return float(p.lo + (abs(p.lo) * 1e-6 if p.lo else 1e-6 * min(1.0, p.hi - p.lo)))


def configurations(name: str) -> list[tuple[str, dict]]:
    """(id, keywords) of the configurations that the conformance battery runs for model
    ``name``, drawn from its description: the defaults, RGB, each option value, each optional
    parameter added, up to three presets, and each parameter at the lo and hi edges of its range, alone or with the option value that makes it used (ids ``alpha=lo``; double
    precision is a keyword of its own)."""
    spec = get_spec(name)
    base, _ = spec.configure()
    opts = dict(base.options)
    out = [("defaults", {}), ("rgb", {"channels": 3})]
    for o in spec.options:
        out += [(f"{o.name}={c}", {o.name: c}) for c in o.choices if c != opts.get(o.name)]
    out += [(f"+{p.name}", {p.name: p.default}) for p in spec.params
            if p.name not in base.param_names and not p.computed]
    for mat in presets.materials(name)[::37][:3]:
        out.append((f"preset={mat}", {"preset": mat}))

    def valid(kw):
        try:
            kw2 = dict(kw)
            if "preset" in kw2:
                p = presets.get(name, kw2.pop("preset"))
                kw2 = {**p.options, **p.params, "channels": 3}
            spec.configure(**kw2)
            return True
        except ParameterError:
            return False                # e.g. layer-2 parameters of schlick without material=double
    out = [(cid, kw) for cid, kw in out if valid(kw)]
    for p in spec.params:
        if p.computed:
            continue
        for side in ("lo", "hi"):
            kw = {p.name: edge(p, side)}
            if p.name in base.param_names and kw[p.name] == p.default:
                continue                # the defaults again
            alts = [kw] + [{**kw, o.name: c} for o in spec.options for c in o.choices]
            ok = next((a for a in alts if valid(a)), None)
            if ok is not None:
                out.append((f"{p.name}={side}", ok))
    return out
