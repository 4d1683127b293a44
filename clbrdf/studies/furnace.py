"""The white furnace of energy compensation with a layout's tables (``clbrdf furnace``): the
single-scattering albedo estimated directly, divided by (Turquin) or completed with
(Kulla-Conty) the tables' E and E_avg; both are 1 for a perfect table.
"""
from __future__ import annotations

import numpy as np

from ..api.albedo import albedo
from ..api.model import Model
from ..models.spec import ParameterError
from ..tables.files import flat


def _channel(t, label: str, coords: dict):
    """Quantity ``label`` of table t at coords, from its channel ``label`` or ``1-label``; None
    if t has neither."""
    q = list(t.quantity)
    for name, sign in ((label, 1), ("1-" + label, -1)):
        if name in q:
            v = np.asarray(t.lookup(**coords))
            v = v if len(q) == 1 else v[..., q.index(name)]
            return v if sign > 0 else 1 - v
    return None


def _reads(t, label: str) -> bool:
    """Whether ``_read(t, label, ...)`` finds the quantity."""
    q = set(t.quantity)
    return bool({label, "1-" + label} & q) or (label == "E" and {"A", "B"} <= q)


def _read(t, label: str, **coords):
    """Quantity ``label`` (E or E_avg) of table t: its channel, or A + B for E (the split
    tables of three.js and MaterialX)."""
    v = _channel(t, label, coords)
    return v if v is not None else _channel(t, "A", coords) + _channel(t, "B", coords)


def _find(tables: dict, directional: bool):
    """(table, read(r=..., [mu=...])) of E over (mu, r) -- or over (mu, alpha), alpha = r^2 --
    or of E_avg over r (alpha): a channel E or 1 - E, or A + B; r axes first. (None, None) if
    there is none."""
    label = "E" if directional else "E_avg"
    for roughness in ("r", "alpha"):
        for t in tables.values():
            if set(t.axis_names) == ({"mu", roughness} if directional else {roughness}) and \
                    _reads(t, label):
                def read(r, t=t, roughness=roughness, **coords):
                    return _read(t, label, **{roughness: r if roughness == "r" else
                                              np.square(r)}, **coords)
                return t, read
    return None, None


def white_furnace(tables: dict, *, r=(0.1, 0.25, 0.5, 0.75, 1.0), mu=(0.05, 0.2, 0.5, 1.0),
                  samples: int = 1 << 20, seed: int = 7, qmc: bool = True, **kw) -> dict:
    """The white furnace of GGX energy compensation with these tables (a layout's E over
    (mu, r) and, for Kulla-Conty, E_avg over r): the single-scattering albedo E_ss(mu, r)
    estimated directly (``clbrdf.albedo``, the layout's model at alpha = r^2, Sobol points
    unless qmc=False, independent of the table's) before compensation, and after:

    - Turquin 2019 (Cycles, UE, Filament): f = f_ss / E_tab(mu_o), so E = E_ss / E_tab;
    - Kulla & Conty 2017 (OSPRay, OpenPBR): f = f_ss + (1 - E_tab(mu_o)) (1 - E_tab(mu_i)) /
      (pi (1 - E_avg_tab)), so E = E_ss + (1 - E_tab(mu_o)) 2 int (1 - E_tab(x)) x dx /
      (1 - E_avg_tab), the integral by 64 Gauss-Legendre nodes of the table's lookup.

    Both are 1 for a perfect table; what is left is the table's error (interpolation, noise)
    and E_avg's consistency with E. Returns arrays over (r, mu) and the stderr of E_ss."""
    tables = flat(tables)          # a table's average (E_avg) as a table of its own
    t, read = _find(tables, True)
    if t is None:
        raise ParameterError("white_furnace needs a table with E (a channel E or 1-E, or A and "
                             "B) over the axes mu and r (or alpha)")
    ta, read_avg = _find(tables, False)
    comp = t.meta.get("computed", {})
    fixed = {k: v for k, v in comp.get("options", {}).items()}
    if "split" in comp:     # E of a split computation (and A + B) is E with F = 1
        fixed["fresnel"] = "one"
    R, MU = np.meshgrid(np.asarray(r, float), np.asarray(mu, float), indexing="ij")
    m = Model(comp.get("model", "ggx"), alpha=R ** 2, **fixed,
                     **{k: kw.pop(k) for k in ("device", "width", "precision") if k in kw})
    d = albedo(m, MU, samples=samples, seed=seed, qmc=qmc, **kw)
    e_tab = read(mu=MU, r=R)
    out = {"r": R, "mu": MU, "E_ss": d.albedo, "E_ss_stderr": d.stderr, "E_table": e_tab,
           "turquin": d.albedo / e_tab}
    if ta is not None:
        x, w = np.polynomial.legendre.leggauss(64)
        x, w = (x + 1) / 2, w / 2
        integral = np.stack([np.sum(w * (1 - read(mu=x, r=np.full_like(x, rv))) * x) * 2
                             for rv in np.asarray(r, float)])[:, None]
        e_avg = read_avg(r=R)
        with np.errstate(divide="ignore", invalid="ignore"):
            norm = np.where(1 - e_avg > 0, integral / (1 - e_avg), 1.0)
        out["E_avg_table"] = e_avg
        out["kulla_conty"] = d.albedo + (1 - e_tab) * norm
    return out
