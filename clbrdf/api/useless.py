"""Where an estimator is useless: the stability map that ships with the package
(``clbrdf/data/stability.csv``, made by ``clbrdf stability``: clbrdf.studies.stability), read
by ``albedo`` to warn when it is asked for an estimator in a cell the map marks useless or biased.
"""
from __future__ import annotations

import csv
import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..models import get_spec
from ..models.choices import MC_ESTIMATORS

Z_BIAS = 4.0
USELESS = 1e-2          # relative efficiency below which an estimator is marked useless
FLAGS = ("nonfinite", "biased", "precision_loss", "useless")


def sweep_label(names) -> str:
    return "=".join(names) if names else "defaults"


def samplers(name: str) -> tuple:
    """The model's sampler choices, or ("-",) when it has one."""
    spec = get_spec(name)
    opt = next((o for o in spec.options if o.name == "sampler"), None)
    return tuple(opt.choices) if opt is not None and len(opt.choices) > 1 else ("-",)


def read_csv(path) -> list[dict]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("value", "mu", "E", "stderr", "E_ref", "ref_err", "z", "efficiency", "seconds"):
            r[k] = float(r[k])
        for k in FLAGS:
            r[k] = int(r[k])
    return rows


MAP = Path(__file__).resolve().parents[1] / "data" / "stability.csv"


_BEST = {}     # (model, precision, sweep, value, mu) -> the map's row of the best estimator


@lru_cache(maxsize=1)
def _shipped() -> dict:
    """{(model, estimator, sampler, precision): [(names, values, mus, efficiency grid)]}"""
    if not MAP.exists():
        return {}
    out = {}
    rows = read_csv(MAP)
    for r in rows:
        if r["efficiency"] == 1.0:
            _BEST[(r["model"], r["precision"], r["sweep"], r["value"], r["mu"])] = r
    for r in rows:
        out.setdefault((r["model"], r["estimator"], r["sampler"], r["precision"], r["sweep"]),
                       {})[(r["value"], r["mu"])] = (r["efficiency"], r["biased"] or
                                                     r["nonfinite"], r["z"])
    grids = {}
    for (model, est, smp, prec, sweep), cells in out.items():
        values = np.array(sorted({v for v, _ in cells}))
        mus = np.array(sorted({m for _, m in cells}))
        g = np.full((len(values), len(mus), 3), np.nan)    # efficiency, biased, z
        for (v, m), e in cells.items():
            g[np.searchsorted(values, v), np.searchsorted(mus, m)] = e
        names = () if sweep == "defaults" else tuple(sweep.split("="))
        grids.setdefault((model, est, smp, prec), []).append((names, values, mus, g))
    return grids


def _nearest(grid_values, x, log):
    """Index of the nearest grid value (in log where all are positive)."""
    gv = np.asarray(grid_values, float)
    if log and gv.min() > 0:
        d = np.abs(np.log(gv)[None, :] - np.log(np.maximum(x, gv.min() * 1e-3))[:, None])
    else:
        d = np.abs(gv[None, :] - x[:, None])
    return np.argmin(d, axis=1)


def useless_cells(m, mu, estimator: str):
    """Where the shipped map marks ``estimator`` useless or biased for model ``m`` at the
    nearest swept value of each swept parameter (the other parameters as given) and the nearest
    mu: (fraction of points, worst cell's efficiency, its z, an example), or None."""
    if estimator not in MC_ESTIMATORS:
        return None
    smp = m.options.get("sampler", "-") if estimator in ("brdf", "mis") else "-"
    if smp != "-" and samplers(m.name) == ("-",):
        smp = "-"
    grids = _shipped().get((m.name, estimator, smp, m.precision))
    if not grids:
        return None
    mu = np.asarray(mu, float)
    worst, example, bad_any = None, None, None
    for names, values, mus, g in grids:
        if names and not all(n in m.params for n in names):
            continue
        x = np.asarray(m.params[names[0]], float) if names else np.zeros(())
        if names and m.channels > 1 and names[0] in m.config.spectral:
            x = x[..., 0]
        xb, mb = (a.ravel() for a in np.broadcast_arrays(x, mu))
        cell = g[_nearest(values, xb, True), _nearest(mus, mb, True)]
        eff = np.nan_to_num(cell[:, 0], nan=1.0)
        bad = (eff < USELESS) | (np.nan_to_num(cell[:, 1]) > 0)
        bad_any = bad if bad_any is None or bad_any.shape != bad.shape else bad_any | bad
        if bad.any():
            k = int(np.argmax(np.where(bad, -eff + cell[:, 1], -np.inf)))
            if worst is None or eff[k] < worst[0]:
                best = _BEST.get((m.name, m.precision, sweep_label(names),
                                  float(values[_nearest(values, xb[k:k + 1], True)[0]]),
                                  float(mus[_nearest(mus, mb[k:k + 1], True)[0]])))
                worst = (float(eff[k]), float(cell[k, 2]), best)
                example = (f"{sweep_label(names)}={xb[k]:.3g}, " if names else "") + \
                    f"mu={mb[k]:.3g}"
    if example is None:
        return None
    return float(np.mean(bad_any)), worst[0], worst[1], worst[2], example


def warn_if_useless(m, mu, estimator: str, stacklevel: int = 3):
    hit = useless_cells(m, mu, estimator)
    if hit is None:
        return
    frac, eff, z, best, example = hit
    why = (f"efficiency {eff:.1g} of the best estimator there" if eff < USELESS else
           "no estimator is efficient there")
    if z > Z_BIAS:
        why += f", and the map's estimate was {z:.3g} standard errors from the reference"
    if best is not None and not best["biased"]:
        use = f"Use {best['estimator']!r}" + (f" with sampler={best['sampler']!r}"
                                               if best["sampler"] != "-" else "")
    else:
        use = ("Every Monte Carlo estimator was biased there at the map's 2^16 samples: use "
               "estimator='quadrature' and check its error estimate")
    warnings.warn(f"estimator={estimator!r} is marked useless by the stability map for "
                  f"{m.name} at {frac:.0%} of these points (e.g. {example}: {why}; the map "
                  f"ships in clbrdf/data/stability.csv and `clbrdf stability` remakes it); its "
                  f"estimates are unreliable there and their reported error, which allows for "
                  f"what the samples cannot see, may be far larger than E. {use}.",
                  UselessEstimatorWarning, stacklevel=stacklevel)


class UselessEstimatorWarning(UserWarning):
    """An albedo estimator asked for where the stability map marks it useless."""
