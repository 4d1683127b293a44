"""The white furnace of energy compensation with a layout's tables (``clbrdf furnace``): the
single-scattering albedo estimated directly, divided by (Turquin) or completed with
(Kulla-Conty) the tables' E and E_avg; both are 1 for a perfect table.
"""
from __future__ import annotations

import numpy as np

from ..api.albedo import albedo, fresnel_avg
from ..api.model import Model
from ..models.spec import ParameterError
from ..tables.axes import MAPPED
from ..tables.files import flat


def _channel(t, label: str, coords: dict, outside: str):
    """Quantity ``label`` of table t at coords, from its channel ``label`` or ``1-label``; None
    if t has neither."""
    q = list(t.quantity)
    for name, sign in ((label, 1), ("1-" + label, -1)):
        if name in q:
            v = np.asarray(t.lookup(**coords, outside=outside))
            v = v if len(q) == 1 else v[..., q.index(name)]
            return v if sign > 0 else 1 - v
    return None


def _reads(t, label: str) -> bool:
    """Whether ``_read(t, label, ...)`` finds the quantity."""
    q = set(t.quantity)
    return bool({label, "1-" + label} & q) or (label == "E" and {"A", "B"} <= q)


def _read(t, label: str, outside: str = "raise", **coords):
    """Quantity ``label`` (E or E_avg) of table t: its channel, or A + B for E (the split
    tables of three.js and MaterialX). ``outside``: as Table.lookup; the furnace's points are
    inside the tables ("raise"), the Kulla-Conty integral over mu reads them as a renderer does
    ("clamp": below a table's first mu, its edge)."""
    v = _channel(t, label, coords, outside)
    return v if v is not None else (_channel(t, "A", coords, outside)
                                    + _channel(t, "B", coords, outside))


def _find(tables: dict, directional: bool):
    """(table, read(r=..., [mu=...], [outside=...]), roughness axis) of E over (mu, r) -- or
    over (mu, alpha), alpha = r^2 -- or of E_avg over r (alpha): a channel E or 1 - E, or
    A + B; r axes first. (None, None, None) if there is none."""
    label = "E" if directional else "E_avg"
    for roughness in ("r", "alpha"):
        for t in tables.values():
            if set(t.axis_names) == ({"mu", roughness} if directional else {roughness}) and \
                    _reads(t, label):
                def read(r, t=t, roughness=roughness, **coords):
                    return _read(t, label, **{roughness: r if roughness == "r" else
                                              np.square(r)}, **coords)
                return t, read, roughness
    return None, None, None


DEFAULT_R = (0.1, 0.25, 0.5, 0.75, 1.0)
DEFAULT_MU = (0.05, 0.2, 0.5, 1.0)


def _inside(t, axis: str, values, to_axis, given: bool, what: str):
    """(the values inside table t's axis ``axis``, {what: the values left out}); a value the
    caller gave outside the table is a ParameterError (the furnace reads no table outside its
    range), a default one is left out and reported."""
    values = np.asarray(values, float).ravel()
    d = t.axis_names.index(axis)
    out = t.outside(d, to_axis(values))
    if out.any() and given:
        lo, hi = t.axis_range(d)
        raise ParameterError(f"{what}={values[out][0]:g} is outside table {t.name}: its {axis} "
                             f"axis covers [{lo:g}, {hi:g}]; the furnace reads no table outside "
                             f"its range")
    if out.all():
        lo, hi = t.axis_range(d)
        raise ParameterError(f"table {t.name}'s {axis} axis [{lo:g}, {hi:g}] holds none of the "
                             f"furnace's {what} values {', '.join(f'{v:g}' for v in values)}: "
                             f"give {what}=")
    return values[~out], ({what: values[out].tolist()} if out.any() else {})


def _r_to(roughness):
    return (lambda r: r) if roughness == "r" else np.square


def white_furnace(tables: dict, *, r=None, mu=None,
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
    and E_avg's consistency with E. Returns arrays over (r, mu) and the stderr of E_ss, and
    ``left_out``: the default points (r ``DEFAULT_R``, mu ``DEFAULT_MU``) outside the tables'
    axes, which are not evaluated (a point given outside them is a ParameterError)."""
    tables = flat(tables)          # a table's average (E_avg) as a table of its own
    t, read, rough = _find(tables, True)
    if t is None:
        raise ParameterError("white_furnace needs a table with E (a channel E or 1-E, or A and "
                             "B) over the axes mu and r (or alpha)")
    ta, read_avg, rough_avg = _find(tables, False)
    given = r is not None
    r, left = _inside(t, rough, DEFAULT_R if r is None else r, _r_to(rough), given, "r")
    if ta is not None:
        r, more = _inside(ta, rough_avg, r, _r_to(rough_avg), given, "r")
        left = {"r": left.get("r", []) + more.get("r", [])} if more else left
    mu, more = _inside(t, "mu", DEFAULT_MU if mu is None else mu, lambda m: m, mu is not None,
                       "mu")
    left.update(more)
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
           "turquin": d.albedo / e_tab, "left_out": left}
    if ta is not None:
        x, w = np.polynomial.legendre.leggauss(64)
        x, w = (x + 1) / 2, w / 2
        integral = np.stack([np.sum(w * (1 - read(mu=x, r=np.full_like(x, rv),
                                                  outside="clamp")) * x) * 2
                             for rv in np.asarray(r, float)])[:, None]
        e_avg = read_avg(r=R)
        with np.errstate(divide="ignore", invalid="ignore"):
            norm = np.where(1 - e_avg > 0, integral / (1 - e_avg), 1.0)
        out["E_avg_table"] = e_avg
        out["kulla_conty"] = d.albedo + (1 - e_tab) * norm
    return out


# ---------------------------------------------------------------------------------------------
# Glass: a rough dielectric's tables from both sides (docs/models/dielectric.md)

# the axes that give a dielectric's index: eta itself and those mapped onto it (ior_z, ...)
INDEX_AXES = ("eta",) + tuple(k for k, v in MAPPED.items() if v[0] == "eta")


def _eta_of(axis: dict):
    """(values of the axis -> eta, eta -> values) of a table's index-of-refraction axis."""
    name = axis["name"]
    if name == "eta":
        return (lambda v: v), (lambda e: e)
    _, _, fwd, inv = MAPPED[name]
    return fwd, inv


def _glass_readers(tables: dict, directional: bool):
    """read(eta, r, [mu]) of E (or E_avg) of a dielectric from the tables whose axes are an
    index axis (``INDEX_AXES``), r (and mu): each eta from the table whose range holds it
    (Cycles: ior_z for eta >= 1, inv_ior_z for eta < 1). None if there is none."""
    label = "E" if directional else "E_avg"
    found = []
    for t in tables.values():
        names = set(t.axis_names)
        idx = [a for a in t.axes if a["name"] in INDEX_AXES]
        lobes = t.meta.get("computed", {}).get("options", {}).get("lobes", "both")
        if len(idx) != 1 or names != {idx[0]["name"], "r"} | ({"mu"} if directional else set()) \
                or not _reads(t, label) or lobes != "both":     # E_R alone: not the glass's E
            continue
        fwd, inv = _eta_of(idx[0])
        ev = fwd(np.clip(np.asarray(idx[0]["values"], float), idx[0].get("min", -np.inf),
                         idx[0].get("max", np.inf)))
        found.append((t, idx[0]["name"], inv, float(np.min(ev)), float(np.max(ev))))
    if not found:
        return None

    def read(eta, r, **coords):
        eta = float(eta)
        for t, name, inv, lo, hi in found:
            if lo - 1e-12 <= eta <= hi + 1e-12:
                return _read(t, label, **{name: float(inv(eta)), "r": r}, **coords)
        raise ParameterError(f"no glass table holds eta={eta:g} (tables cover "
                             f"{', '.join(f'[{lo:.4g}, {hi:.4g}]' for *_, lo, hi in found)})")
    return read


def has_glass(tables: dict) -> bool:
    """Whether the tables hold a dielectric's E and E_avg over an index axis (glass_furnace)."""
    t = flat(tables)
    return _glass_readers(t, True) is not None and _glass_readers(t, False) is not None


def kulla_conty_split(F_avg, F_avg_inv, E_avg_out, E_avg_in, eta):
    """x of Kulla & Conty 2017's energy split of a dielectric's multiple-scattering lobes (as
    MoonRay's TransmissionCookTorranceEnergyCompensation::computeFactor): with eta > 1 the
    relative index from outside, t = eta^2 (1 - E_avg(1/eta)) / (1 - E_avg(eta)) (1 -
    F_avg(1/eta)) / (1 - F_avg(eta)), x = t / (1 + t). From outside the compensating lobes take
    the shares 1 - (1 - F_avg) x (reflection) and (1 - F_avg) x (transmission) of the energy
    1 - E lost, from inside 1 - (1 - F_avg_inv)(1 - x) and (1 - F_avg_inv)(1 - x): the energy
    transmitted by them from outside is eta^2 times that from inside, as for a smooth
    interface (1 - F_avg(eta) = eta^2 (1 - F_avg(1/eta)))."""
    t = eta ** 2 * (1 - E_avg_in) / (1 - E_avg_out) * (1 - F_avg_inv) / (1 - F_avg)
    return t / (1 + t)


def glass_furnace(tables: dict, *, ior=(1.2, 1.5, 2.0), r=(0.25, 0.5, 1.0), mu=(0.1, 0.5, 1.0),
                  samples: int = 1 << 20, seed: int = 7, qmc: bool = True, **kw) -> dict:
    """The white furnace of a rough dielectric's energy compensation with its tables from both
    sides (E over (index, mu, r) and E_avg over (index, r): Cycles' four glass tables, or any
    with an index axis of ``INDEX_AXES``: eta, ior_z, inv_ior_z, inv_eta): E_ss = E_R + E_T of ``ggx_dielectric`` (the tables'
    model and options) estimated directly at eta = ior (entering) and 1/ior (exiting), and
    after Turquin's scaling, E_ss / E_tab, and Kulla-Conty's lobes, E_ss + (1 - E_tab(mu)) (a_R
    J(eta) + a_T J(1/eta)), J(e) = 2 int (1 - E_tab(e, x)) x dx / (1 - E_avg_tab(e)), the shares
    a_R, a_T from ``kulla_conty_split`` with the kernel's own F_avg. Both are 1 for perfect
    tables. Arrays over (side, ior, r, mu), side 0 entering and 1 exiting; also x, J over
    (side, ior, r) (1 where E_avg is consistent with E), and the ratio of the
    multiple-scattering transmission out -> in over in -> out (eta^2)."""
    tables = flat(tables)
    read, read_avg = _glass_readers(tables, True), _glass_readers(tables, False)
    if read is None or read_avg is None:
        raise ParameterError("glass_furnace needs a dielectric's E over (an index axis: eta, ior_z, "
                             "inv_ior_z or inv_eta; "
                             "mu; r) and E_avg over (that axis; r), from both sides")
    t0 = next(t for t in tables.values() if {"mu", "r"} <= set(t.axis_names)
              and set(t.axis_names) & set(INDEX_AXES))
    comp = t0.meta.get("computed", {})
    model = comp.get("model", "ggx_dielectric")
    fixed = dict(comp.get("options", {}))
    dev = {k: kw.pop(k) for k in ("device", "width", "precision") if k in kw}
    iors, rs, mus = (np.asarray(v, float) for v in (ior, r, mu))
    x_gl, w_gl = np.polynomial.legendre.leggauss(64)
    x_gl, w_gl = (x_gl + 1) / 2, w_gl / 2
    shape = (2, len(iors), len(rs), len(mus))
    out = {k: np.zeros(shape) for k in ("E_ss", "E_ss_stderr", "E_table", "turquin",
                                        "kulla_conty")}
    out.update(ior=iors, r=rs, mu=mus, x=np.zeros((len(iors), len(rs))),
               ms_transmission_ratio=np.zeros((len(iors), len(rs))),
               J=np.zeros((2, len(iors), len(rs))))
    for i, n in enumerate(iors):
        fa, fa_inv = (float(fresnel_avg("ggx", fresnel="dielectric", eta=e, **{
            k: v for k, v in dev.items() if k == "device"})) for e in (n, 1 / n))
        for j, rv in enumerate(rs):
            J, ea = {}, {}
            for e in (n, 1 / n):
                ea[e] = float(read_avg(e, rv))
                e_x = read(e, np.full_like(x_gl, rv), mu=x_gl, outside="clamp")
                integral = float(np.sum(w_gl * (1 - e_x) * x_gl) * 2)
                J[e] = integral / (1 - ea[e]) if 1 - ea[e] > 0 else 1.0
            x = kulla_conty_split(fa, fa_inv, ea[n], ea[1 / n], n)
            out["x"][i, j] = x
            out["J"][:, i, j] = J[n], J[1 / n]
            t_out, t_in = (1 - fa) * x, (1 - fa_inv) * (1 - x)
            out["ms_transmission_ratio"][i, j] = (t_out * (1 - ea[n])) / (t_in * (1 - ea[1 / n]))
            for side, (e, a_t) in enumerate(((n, t_out), (1 / n, t_in))):
                m = Model(model, alpha=rv ** 2, eta=e, **fixed, **dev)
                d = albedo(m, mus, samples=samples, seed=seed, qmc=qmc, **kw)
                e_tab = np.asarray(read(e, np.full_like(mus, rv), mu=mus), float)
                out["E_ss"][side, i, j] = d.albedo
                out["E_ss_stderr"][side, i, j] = d.stderr
                out["E_table"][side, i, j] = e_tab
                out["turquin"][side, i, j] = d.albedo / e_tab
                out["kulla_conty"][side, i, j] = d.albedo + (1 - e_tab) * (
                    (1 - a_t) * J[e] + a_t * J[1 / e])
    return out
