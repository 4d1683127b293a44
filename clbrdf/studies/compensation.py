"""Energy compensation against its ground truth, the random walk of Heitz et al. 2016
(clbrdf.walk_albedo / walk_sample on the device): for GGX conductors (any Fresnel, RGB) the
albedo and the lobe of each compensation method, and for rough glass the reflected and
transmitted energy of albedo scaling. ``clbrdf compensation`` writes the maps
(docs/compensation/README.md is one).

Methods (each from its paper, on this engine's E(mu), E_avg, F_avg; E is GGX's single-scattering
albedo with F = 1, height-correlated masking, by the device quadrature; F0 = F(1)):
- ``kulla_conty`` (Kulla & Conty 2017): E_F + F_ms (1 - E), F_ms = F_avg^2 E_avg /
  (1 - F_avg (1 - E_avg)); its lobe F_ms (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg));
- ``turquin`` (Turquin 2019): E_F (1 + F0 (1 - E) / E); its lobe the single-scattering lobe
  scaled by F0 (1 - E) / E;
- ``fdez_aguera`` (Fdez-Aguera 2019, the split sum): F0 A + B + F_ms' (1 - A - B),
  F_ms' = (F0 A + B) F_avg' / (1 - F_avg' (1 - A - B)), F_avg' = F0 + (1 - F0) / 21 (Schlick's
  F with the exact F0), A and B the split sum's terms; its lobe Lambertian (an irradiance term);
- ``single``: no compensation (E_F).
Glass (ggx_dielectric, eta): ``scaled`` divides the single-scattering lobes by E_ss(mu) (Turquin's
albedo scaling for a dielectric, as Cycles 4 does with its glass table), with the exact (beta)
or Cycles' (correlated) transmission masking; ``single`` is uncompensated (beta).

The lobe error of a method at (alpha, mu_o): the relative L1 distance of its compensation lobe
from the walk's multiple-scattering lobe (the walks of order 2 and more), sum |M - W| / sum W
over bins of the outgoing hemisphere (uniform in mu_i and in phi relative to wo's plane,
folded about it: the lobes are symmetric), per channel; ``noise`` is the same distance between
two halves of the walks (halved), the part of any method's number that is the walk's noise.
"""
from __future__ import annotations

import io
from dataclasses import dataclass
import time
from pathlib import Path

import numpy as np

from ..api.albedo import albedo, fresnel_avg
from ..api.model import Model
from ..api.walk import walk_albedo, walk_sample
from ..models.spec import ParameterError, check_fraction, given
from ..tables.outputs import csv_text, write_together
from .settings import ALPHAS, GLASS_ETAS, LOBE_MUS, METALS, MUS

METHODS = ("kulla_conty", "turquin", "fdez_aguera", "single")
GLASS_METHODS = ("scaled_beta", "scaled_correlated", "single_beta")
MU_BINS, PHI_BINS = 8, 8          # the lobe's bins: mu_i uniform, phi in [0, pi] (folded)
TOL = 1e-7
AVG_NODES = 32


def _e(alpha, mus, precision="double", device=None, **kw):
    """E(mu) (trailing channel axis for RGB) of GGX at alpha by the device quadrature."""
    m = Model("ggx", alpha=alpha, precision=precision, device=device, **kw)
    return np.asarray(albedo(m, mus, estimator="quadrature", tol=TOL).albedo, np.float64)


def _fresnel_at(material: dict, c, device=None):
    """F(c) per channel of a material's Fresnel: the kernel's own, eval / eval with F = 1 at
    mirror pairs (h = z, wi.h = c), as fresnel_avg reads it."""
    c = np.asarray(c, float)
    s = np.sqrt(np.maximum(0, 1 - c * c))
    wo = np.stack([s, 0 * c, c], -1)
    wi = np.stack([-s, 0 * c, c], -1)
    m = Model("ggx", alpha=0.5, precision="double", device=device, channels=3, **material)
    one = Model("ggx", alpha=0.5, precision="double", device=device, fresnel="one")
    return np.asarray(m.eval(wo, wi)) / np.asarray(one.eval(wo, wi))[..., None]


def _fresnel_params(material: dict) -> dict:
    """The Fresnel parameters of a material (a preset's, or as given)."""
    if "preset" in material:
        m = Model("ggx", precision="double", **material)
        keep = {"fresnel", "f0", "f90", "exponent", "f82", "eta", "k"}
        p = {k: v for k, v in m.params.items() if k in keep}
        return {"fresnel": m.options["fresnel"], **p, "channels": 3}
    return {**material, "channels": 3}


def material_label(material: dict) -> str:
    if "preset" in material:
        return material["preset"]
    return " ".join(f"{k}={v}" if isinstance(v, str) else
                    f"{k}={','.join(f'{x:g}' for x in np.ravel(v))}" for k, v in material.items())


def conductor_albedo(e, e_avg, ef, f0, favg, a, b):
    """Each method's E (METHODS), from E (F = 1), E_avg, E_F, F0, F_avg and the split sum's A, B
    (broadcasting; channels trailing)."""
    fms = favg ** 2 * e_avg / (1 - favg * (1 - e_avg))
    ess, fss = a + b, f0 * a + b
    fa2 = f0 + (1 - f0) / 21
    fms2 = fss * fa2 / (1 - fa2 * (1 - ess))
    return {"kulla_conty": ef + fms * (1 - e), "turquin": ef * (1 + f0 * (1 - e) / e),
            "fdez_aguera": fss + fms2 * (1 - ess), "single": ef}


def _bins(wi, weight, keep):
    """(MU_BINS, PHI_BINS, channels) sums of weight over the folded bins of wi."""
    mu = np.clip(wi[:, 2], 0, 1 - 1e-12)
    phi = np.abs(np.arctan2(wi[:, 1], wi[:, 0]))
    i = np.minimum((mu * MU_BINS).astype(int), MU_BINS - 1)
    j = np.minimum((phi / np.pi * PHI_BINS).astype(int), PHI_BINS - 1)
    out = np.zeros((MU_BINS * PHI_BINS, weight.shape[1]))
    k = (i * PHI_BINS + j)[keep]
    for c in range(weight.shape[1]):
        out[:, c] = np.bincount(k, weights=weight[keep, c], minlength=MU_BINS * PHI_BINS)
    return out.reshape(MU_BINS, PHI_BINS, -1)


def _l1(m, w):
    return np.abs(m - w).sum(axis=(0, 1)) / np.maximum(w.sum(axis=(0, 1)), 1e-300)


def conductor_cells(material: dict, alphas=ALPHAS, mus=MUS, lobe_mus=LOBE_MUS, *,
                    walks: int = 1 << 20, lobe_walks: int = 1 << 20, seed: int = 0,
                    device=None, progress=None):
    """Albedo rows (per alpha, mu, channel: the walk's E and stderr, each method's E and error)
    and lobe rows (per alpha, lobe mu, channel: each method's relative L1 and the noise floor)
    of one material (ggx keyword arguments: a preset, or a Fresnel with its parameters)."""
    fres = _fresnel_params(material)
    f0 = _fresnel_at(material, np.array([1.0]), device)[0]
    favg = np.asarray(fresnel_avg("ggx", device=device, **fres), float)
    mus = np.asarray(mus, float)
    xg, wg = np.polynomial.legendre.leggauss(AVG_NODES)
    mg, wg = (xg + 1) / 2, wg / 2
    # the lobe bins' mu_i nodes: 4-point Gauss in each mu bin
    x4, w4 = np.polynomial.legendre.leggauss(4)
    edges = np.linspace(0, 1, MU_BINS + 1)
    mb = (edges[:-1, None] + (x4[None, :] + 1) / 2 / MU_BINS).ravel()
    wb = np.tile(w4 / 2 / MU_BINS, MU_BINS)
    label = material_label(material)
    rows, lobes = [], []
    t0 = time.perf_counter()
    for ia, alpha in enumerate(alphas):
        e = _e(alpha, mus, device=device)
        e_avg = float(np.sum(wg * 2 * mg * _e(alpha, mg, device=device)))
        a = _e(alpha, mus, device=device, fresnel="schlick", f0=1.0, f90=0.0)
        b = _e(alpha, mus, device=device, fresnel="schlick", f0=0.0, f90=1.0)
        ef = _e(alpha, mus, device=device, channels=3, **{k: v for k, v in fres.items()
                                                           if k != "channels"})
        m = Model("ggx", alpha=alpha, precision="single", device=device, channels=3,
                  **{k: v for k, v in fres.items() if k != "channels"})
        w = walk_albedo(m, mus, walks=walks, seed=seed + 1000 * ia)
        est = conductor_albedo(e[:, None], e_avg, ef, f0, favg, a[:, None], b[:, None])
        for i, mu in enumerate(mus):
            for c, cname in enumerate("RGB"):
                rows.append({"material": label, "channel": cname, "alpha": alpha, "mu": float(mu),
                             "E_walk": float(w.albedo[i, c]),
                             "E_walk_stderr": float(w.stderr[i, c]),
                             "walks_cut": float(w.cut[i]),
                             **{k: float(est[k][i, c]) for k in METHODS},
                             **{f"{k}_error": float(est[k][i, c] - w.albedo[i, c])
                                for k in METHODS}})
        # lobes
        e_b = _e(alpha, mb, device=device)
        ring = (wb * (1 - e_b) * mb).reshape(MU_BINS, 4).sum(axis=1)      # int (1 - E) mu
        cosw = (edges[1:] ** 2 - edges[:-1] ** 2) / 2                       # int mu dmu
        dphi = 2 * np.pi / PHI_BINS                                         # both folded halves
        fms = favg ** 2 * e_avg / (1 - favg * (1 - e_avg))
        for mu_o in lobe_mus:
            s = np.sqrt(1 - mu_o * mu_o)
            wo = np.broadcast_to([s, 0.0, mu_o], (lobe_walks, 3))
            wi, wt, order = walk_sample(m, wo, seed=seed + 7 + 1000 * ia, stream=int(mu_o * 1000))
            ok = np.isfinite(wi[:, 0])
            ms = _bins(wi, wt, ok & (order >= 2)) / lobe_walks
            ss = _bins(wi, wt, ok & (order == 1)) / lobe_walks
            half = np.arange(lobe_walks) < lobe_walks // 2
            h1 = _bins(wi, wt, ok & (order >= 2) & half) / (lobe_walks // 2)
            h2 = _bins(wi, wt, ok & (order >= 2) & ~half) / (lobe_walks - lobe_walks // 2)
            e_o = float(_e(alpha, [mu_o], device=device)[0])
            ef_o = _e(alpha, [mu_o], device=device, channels=3,
                      **{k: v for k, v in fres.items() if k != "channels"})[0]
            a_o = float(_e(alpha, [mu_o], device=device, fresnel="schlick", f0=1.0, f90=0.0)[0])
            b_o = float(_e(alpha, [mu_o], device=device, fresnel="schlick", f0=0.0, f90=1.0)[0])
            est_o = conductor_albedo(e_o, e_avg, ef_o, f0, favg, a_o, b_o)
            kc = (fms * (1 - e_o) / (np.pi * (1 - e_avg)))[None, None, :] \
                * (ring * dphi)[:, None, None]
            tq = ss * (f0 * (1 - e_o) / e_o)[None, None, :]
            fa = ((est_o["fdez_aguera"] - (f0 * a_o + b_o)) / np.pi)[None, None, :] \
                * (cosw * dphi)[:, None, None]
            l1 = {"kulla_conty": _l1(kc, ms), "turquin": _l1(tq, ms), "fdez_aguera": _l1(fa, ms)}
            noise = _l1(h1, h2) / 2
            for c, cname in enumerate("RGB"):
                lobes.append({"material": label, "channel": cname, "alpha": alpha,
                              "mu": float(mu_o), "E_ms_walk": float(ms[..., c].sum()),
                              **{f"{k}_L1": float(v[c]) for k, v in l1.items()},
                              "noise_L1": float(noise[c])})
        if progress:
            progress(f"{label} alpha {alpha}: {time.perf_counter() - t0:.0f} s")
    return rows, lobes


def glass_cells(etas=GLASS_ETAS, alphas=ALPHAS, mus=MUS, *, walks: int = 1 << 20,
                seed: int = 0, device=None, progress=None):
    """Per eta, alpha, mu: the walk's E_R and E_T (stderr), each glass method's E_R, E_T and
    their errors."""
    rows = []
    mus = np.asarray(mus, float)
    t0 = time.perf_counter()
    for ie, eta in enumerate(etas):
        for ia, alpha in enumerate(alphas):
            def ss(masking, lobes):
                g = Model("ggx_dielectric", alpha=alpha, eta=eta, masking=masking, lobes=lobes,
                          precision="double", device=device)
                return np.asarray(albedo(g, mus, estimator="quadrature", tol=TOL).albedo, float)
            r_b, t_b = ss("beta", "reflection"), ss("beta", "transmission")
            r_c, t_c = ss("correlated", "reflection"), ss("correlated", "transmission")
            g = Model("ggx_dielectric", alpha=alpha, eta=eta, masking="beta", device=device)
            w = walk_albedo(g, mus, walks=walks, seed=seed + 100 * ie + ia)
            est = {"scaled_beta": (r_b / (r_b + t_b), t_b / (r_b + t_b)),
                   "scaled_correlated": (r_c / (r_c + t_c), t_c / (r_c + t_c)),
                   "single_beta": (r_b, t_b)}
            for i, mu in enumerate(mus):
                n = w.walks
                rr, tt = float(w.reflected[i]), float(w.transmitted[i])
                rows.append({"eta": eta, "alpha": alpha, "mu": float(mu), "R_walk": rr,
                             "T_walk": tt, "walk_stderr": float(np.sqrt(rr * (1 - rr) / n)),
                             "walks_cut": float(w.cut[i]),
                             **{f"{k}_R": float(v[0][i]) for k, v in est.items()},
                             **{f"{k}_T": float(v[1][i]) for k, v in est.items()},
                             **{f"{k}_R_error": float(v[0][i] - rr) for k, v in est.items()},
                             **{f"{k}_T_error": float(v[1][i] - tt) for k, v in est.items()}})
        if progress:
            progress(f"glass eta {eta}: {time.perf_counter() - t0:.0f} s")
    return rows


def _chart(rows, lobes, glass, alphas):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    mats = list(dict.fromkeys(r["material"] for r in rows))
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.4))
    styles = ("-", "--", ":", "-.")
    for ax, m in zip(axes[:3], METHODS[:3]):
        for mat, ls in zip(mats, styles * 3):
            for cname in "RGB":
                sel = [r for r in rows if r["material"] == mat and r["channel"] == cname]
                worst = [max(abs(r[f"{m}_error"]) for r in sel if r["alpha"] == al) for al in alphas]
                ax.plot(alphas, worst, ls=ls, color=cname.lower(), lw=1,
                        label=f"{mat} {cname}" if m == METHODS[0] else None)
        ax.set_title(f"{m.replace('_', '-')}: albedo", fontsize=9)
        ax.set_xlabel("alpha", fontsize=8)
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
        ax.tick_params(labelsize=7)
    axes[0].set_ylabel("max over mu of |E_method - E_walk|", fontsize=8)
    axes[0].legend(fontsize=6, ncol=2)
    ax = axes[3]
    for m, col in zip(METHODS[:3], ("C0", "C1", "C2")):
        worst = [max((r[f"{m}_L1"] for r in lobes if r["alpha"] == al), default=np.nan)
                 for al in alphas]
        ax.plot(alphas, worst, color=col, label=m.replace("_", "-"))
    ax.plot(alphas, [max((r["noise_L1"] for r in lobes if r["alpha"] == al), default=np.nan)
                     for al in alphas], color="k", ls=":", label="walk noise")
    ax.set_title("lobe: relative L1 vs the walk's order >= 2", fontsize=9)
    ax.set_xlabel("alpha", fontsize=8)
    ax.set_yscale("log")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6)
    ax.tick_params(labelsize=7)
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, dpi=110)
    plt.close(fig)
    gpng = None
    if glass:
        fig, axes = plt.subplots(1, 2, figsize=(8, 3.2), sharey=True)
        for ax, part in zip(axes, "RT"):
            for m, col in zip(GLASS_METHODS, ("C0", "C1", "C2")):
                for eta, ls in zip(dict.fromkeys(r["eta"] for r in glass), styles):
                    worst = [max(abs(r[f"{m}_{part}_error"]) for r in glass
                                 if r["alpha"] == al and r["eta"] == eta) for al in alphas]
                    ax.plot(alphas, worst, color=col, ls=ls, lw=1,
                            label=f"{m} eta {eta}" if part == "R" else None)
            ax.set_title(f"glass: max over mu of |E_{part} - walk|", fontsize=9)
            ax.set_xlabel("alpha", fontsize=8)
            ax.set_yscale("log")
            ax.grid(alpha=0.3)
            ax.tick_params(labelsize=7)
        axes[0].legend(fontsize=5, ncol=1)
        fig.tight_layout()
        b = io.BytesIO()
        fig.savefig(b, dpi=110)
        plt.close(fig)
        gpng = b.getvalue()
    return png.getvalue(), gpng


def _worst(rows, key, where):
    sel = [r for r in rows if where(r)]
    return max(sel, key=lambda r: abs(r[key])) if sel else None


def report(rows, lobes, glass, *, command: str, seconds: float, walks: int, lobe_walks: int,
           alphas) -> str:
    mats = list(dict.fromkeys(r["material"] for r in rows))
    L = ["# Energy compensation against the random walk", "",
         f"Generated by `{command}` ({seconds:.0f} s; `clbrdf/studies/compensation.py` gives each "
         f"method's formula). The walk (kernels/heitz_ms.h, Heitz et al. 2016: {walks} walks per "
         "cell for the albedo, single precision, cut walks counted) is the multiple-scattering "
         "microfacet BSDF itself; each method is what a renderer adds to the single-scattering "
         "lobe, computed from this engine's exact E(mu), E_avg, F_avg (device quadrature, "
         "double; a table's own interpolation error is in table_size.md). Error = E_method - "
         "E_walk (negative: the method is too dark). What the repository's map shows, in "
         "words: findings.md; for one configuration at a tolerance: `clbrdf simplest ggx "
         "--metric compensation`.", ""]
    if rows:
        L += ["![albedo and lobe errors per alpha](residuals.png)", "",
              "## Albedo, GGX conductors", "",
              "| material | channel | method | worst error | at alpha, mu | E_walk there | "
              "mean abs error | worst at alpha <= 0.2 |", "|---|---|---|---:|---|---:|---:|---:|"]
        for mat in mats:
            for cname in "RGB":
                sel = [r for r in rows if r["material"] == mat and r["channel"] == cname]
                for m in METHODS:
                    w = max(sel, key=lambda r: abs(r[f"{m}_error"]))
                    lo = max((abs(r[f"{m}_error"]) for r in sel if r["alpha"] <= 0.2), default=0)
                    L.append(f"| {mat} | {cname} | {m} | {w[m + '_error']:+.4f} | "
                             f"{w['alpha']:g}, {w['mu']:g} | {w['E_walk']:.4f} +- "
                             f"{w['E_walk_stderr']:.1g} | "
                             f"{np.mean([abs(r[f'{m}_error']) for r in sel]):.4f} | {lo:.4f} |")
    if lobes:
        L += ["", "## Lobe, GGX conductors", "",
              f"Relative L1 distance of each method's compensation lobe from the walk's "
              f"multiple-scattering lobe (orders >= 2), {MU_BINS} x {PHI_BINS} bins of the "
              f"outgoing hemisphere (mu_i uniform, phi folded about wo's plane), {lobe_walks} "
              "walks per cell; worst channel. The noise column is the walks' own share of any "
              "number in its row.", "",
              "| material | alpha | mu | E_ms (walk) | " + " | ".join(METHODS[:3]) + " | noise |",
              "|---|---:|---:|---:|" + "---:|" * 4]
        keys = dict.fromkeys((r["material"], r["alpha"], r["mu"]) for r in lobes)
        for mat, al, mu in keys:
            sel = [r for r in lobes if (r["material"], r["alpha"], r["mu"]) == (mat, al, mu)]
            L.append(f"| {mat} | {al:g} | {mu:g} | {max(r['E_ms_walk'] for r in sel):.4f} | "
                     + " | ".join(f"{max(r[f'{m}_L1'] for r in sel):.3f}" for m in METHODS[:3])
                     + f" | {max(r['noise_L1'] for r in sel):.3f} |")
    if glass:
        L += ["", "## Rough glass (ggx_dielectric, importance), from above", "",
              "![glass errors per alpha](glass.png)", "",
              "The walk conserves energy (E_R + E_T = 1 less the cut walks), and so does every "
              "scaled method: what differs is the split between reflection and transmission.", "",
              "| eta | method | worst E_R error | at alpha, mu | worst E_T error | at alpha, mu | "
              "worst at alpha <= 0.2 (E_T) |", "|---:|---|---:|---|---:|---|---:|"]
        for eta in dict.fromkeys(r["eta"] for r in glass):
            for m in GLASS_METHODS:
                wr = _worst(glass, f"{m}_R_error", lambda r: r["eta"] == eta)
                wt = _worst(glass, f"{m}_T_error", lambda r: r["eta"] == eta)
                lo = max((abs(r[f"{m}_T_error"]) for r in glass
                          if r["eta"] == eta and r["alpha"] <= 0.2), default=0)
                L.append(f"| {eta:g} | {m} | {wr[m + '_R_error']:+.4f} | {wr['alpha']:g}, "
                         f"{wr['mu']:g} | {wt[m + '_T_error']:+.4f} | {wt['alpha']:g}, "
                         f"{wt['mu']:g} | {lo:.4f} |")
    return "\n".join(L) + "\n"


def compensation_map(out, materials=None, *, alphas=ALPHAS, mus=MUS, lobe_mus=LOBE_MUS,
                     glass_etas=GLASS_ETAS, walks: int = 1 << 20, lobe_walks: int = 1 << 20,
                     seed: int = 0, device=None, command: str = "clbrdf compensation",
                     progress=None):
    """Measure and write OUT/README.md, OUT/residuals.csv, OUT/lobes.csv, OUT/glass.csv and
    their charts. ``materials``: ggx keyword dictionaries (default: the metal presets gold,
    copper, aluminium); ``glass_etas`` () leaves glass out."""
    materials = [{"preset": m} for m in METALS] if materials is None else list(materials)
    for a in alphas:
        if not 1e-3 <= float(a) <= 2:
            raise ParameterError(f"alpha={a!r} is out of range: valid alpha is in [1e-3, 2]")
    for m in list(mus) + list(lobe_mus):
        if not 0.01 <= float(m) <= 1:
            raise ParameterError(f"mu={m!r} is out of range: valid mu is in [0.01, 1]")
    for mat in materials:                # each one checked before any work
        Model("ggx", channels=3, **mat)
    for e in glass_etas:
        Model("ggx_dielectric", eta=e, masking="beta")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"{given('out', str(out))} is a file; give a directory", "out")
    t0 = time.perf_counter()
    rows, lobes = [], []
    for k, mat in enumerate(materials):
        r, lb = conductor_cells(mat, alphas, mus, lobe_mus, walks=walks, lobe_walks=lobe_walks,
                                seed=seed + 100000 * k, device=device, progress=progress)
        rows += r
        lobes += lb
    glass = glass_cells(glass_etas, alphas, mus, walks=walks, seed=seed + 7777, device=device,
                        progress=progress) if glass_etas else []
    seconds = time.perf_counter() - t0
    png, gpng = _chart(rows, lobes, glass, list(alphas))
    files = {out / "README.md": report(rows, lobes, glass, command=command, seconds=seconds,
                                       walks=walks, lobe_walks=lobe_walks, alphas=alphas),
             out / "residuals.csv": csv_text(rows, list(rows[0])) if rows else "",
             out / "lobes.csv": csv_text(lobes, list(lobes[0])) if lobes else "",
             out / "residuals.png": png}
    if glass:
        files[out / "glass.csv"] = csv_text(glass, list(glass[0]))
        files[out / "glass.png"] = gpng
    out.mkdir(parents=True, exist_ok=True)
    write_together(files)
    return rows, lobes, glass


# ---- which compensation, which table: ``recommend`` (clbrdf simplest --metric compensation)

# cheapest first: what each method asks of a renderer
COSTS = {"single": "nothing",
         "turquin": "an E(mu, alpha) table (N^2 numbers) and a scale",
         "fdez_aguera": "the split sum's A, B tables (2 N^2; often there for image lighting)",
         "kulla_conty": "E(mu, alpha) (N^2) and E_avg(alpha) (N) tables, F_avg, an added lobe"}
GLASS_COSTS = {"single_beta": "nothing",
               "scaled_correlated": "an E(mu, alpha, eta) glass table, correlated masking (Cycles)",
               "scaled_beta": "an E(mu, alpha, eta) glass table, exact (beta) masking"}
REC_MUS = (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0)
REC_PHIS = (0.0, np.pi / 4, np.pi / 2)
SIZES = (8, 16, 32, 64)
SIZE_MUS = np.linspace(0.02, 1, 50)


@dataclass
class Recommendation:
    """The cheapest compensation of a configuration within ``tolerance`` (max relative error of
    E against the random walk over mu in REC_MUS, every channel; glass: max absolute error of
    E_R and of E_T, fractions of the energy, as E_R + E_T = 1), the
    smallest table within it (the compensated white furnace's error from bilinear lookup of N x N
    nodes over (mu, r = sqrt(alpha)), mu 0.02..1, within what the method's own error leaves of
    the tolerance: the two add; a method is chosen only with a table that fits), and the evidence: every method's error, lobe
    error and cost, every size's error, and for anisotropic GGX the cost of the isotropic table
    at sqrt(alpha_x alpha_y) (which the methods' errors then include)."""
    model: str
    material: str
    rough: dict
    tolerance: float
    method: str | None
    table_size: int | None
    methods: dict
    sizes: dict
    walk_stderr: float
    anisotropic: bool
    seconds: float

    def to_json(self) -> dict:
        return {k: getattr(self, k) for k in ("model", "material", "rough", "tolerance",
                                              "method", "table_size", "methods", "sizes",
                                              "walk_stderr", "anisotropic", "seconds")}

    def text(self) -> str:
        r = ", ".join(f"{k}={v:g}" for k, v in self.rough.items())
        costs = GLASS_COSTS if self.model == "ggx_dielectric" else COSTS
        what = ("absolute error of E_R and E_T" if self.model == "ggx_dielectric"
                else "relative error of E")
        lines = [f"{self.model} ({self.material}; {r}): compensation within {self.tolerance:g} "
                 f"(max {what} against the random walk over mu "
                 f"{', '.join(f'{m:g}' for m in REC_MUS)}"
                 + (", phi 0, pi/4, pi/2, the table read at sqrt(alpha_x alpha_y)"
                    if self.anisotropic else "") + "):",
                 f"  method: {self.method or 'none within tolerance (use the random walk)'}"
                 + (f", which needs {costs[self.method]}" if self.method else "")]
        if self.table_size is not None or self.sizes:
            lines.append(f"  table: {f'{self.table_size} x {self.table_size}' if self.table_size else 'none of ' + ', '.join(map(str, SIZES)) + ' within tolerance'}"
                         f" (bilinear over mu and r = sqrt(alpha))")
        lines += ["", f"{'method':18s} {'E error':>9s} {'at mu':>6s} {'lobe L1':>8s}  needs"]
        for k, v in self.methods.items():
            lobe = f"{v['lobe_L1']:8.3f}" if v.get("lobe_L1") is not None else f"{'-':>8s}"
            lines.append(f"{k:18s} {v['error']:9.2e} {v['at_mu']:6g} {lobe}  {costs[k]}")
        lines.append(f"(the walk's {'' if self.model == 'ggx_dielectric' else 'relative '}"
                     f"standard error: up to {self.walk_stderr:.1e})")
        if self.sizes:
            lines += ["", f"{'table N x N':12s} {'Turquin':>9s} {'Kulla-Conty':>12s}  "
                          "(max over mu 0.02..1 of the compensated furnace's error)"]
            for n, v in self.sizes.items():
                lines.append(f"{n:>5d} x {n:<4d} {v['turquin']:9.2e} {v['kulla_conty']:12.2e}")
        return "\n".join(lines)


def table_size_errors(alpha: float, sizes=SIZES, *, device=None) -> dict:
    """Per N: the compensated white furnace's error (F = 1) at ``alpha`` where E comes from N x N
    nodes over mu, r = sqrt(alpha) in [0, 1] (mu = 0 evaluated at 1e-4, r = 0 at 0.01, as
    docs/compensation/table_size.md), read by bilinear lookup: Turquin max |E / E_table - 1|,
    Kulla-Conty max |E - E_table|, over mu 0.02..1."""
    r = float(np.sqrt(alpha))
    if r > 1:
        raise ParameterError(f"alpha={alpha!r}: the tables span r = sqrt(alpha) in [0, 1]")
    e = _e(alpha, SIZE_MUS, device=device)
    out = {}
    for n in sizes:
        nodes = np.linspace(0, 1, n)
        j = min(int(r * (n - 1)), n - 2)
        t = r * (n - 1) - j
        mu_n = np.maximum(nodes, 1e-4)
        cols = [_e(max(nodes[k], 0.01) ** 2, mu_n, device=device) for k in (j, j + 1)]
        col = (1 - t) * cols[0] + t * cols[1]
        look = np.interp(SIZE_MUS, nodes, col)
        out[int(n)] = {"turquin": float(np.max(np.abs(e / look - 1))),
                       "kulla_conty": float(np.max(np.abs(e - look)))}
    return out


def recommend(model: str, tolerance: float, *, walks: int = 1 << 20, seed: int = 0,
              device=None, **params) -> Recommendation:
    """Which compensation, and which table size, a GGX conductor (``ggx``: alpha or alpha_x,
    alpha_y, any Fresnel or a preset) or rough glass (``ggx_dielectric``: alpha, eta) needs at
    ``tolerance``, measured against the random walk at this configuration."""
    t0 = time.perf_counter()
    check_fraction("tolerance", tolerance, text=" (relative error of E)")
    if model not in ("ggx", "ggx_dielectric"):
        raise ParameterError(f"model={model!r}: compensation is measured for ggx (conductors) "
                             "and ggx_dielectric (glass)")
    rough = {k: float(params.pop(k)) for k in ("alpha", "alpha_x", "alpha_y") if k in params}
    if not rough:
        rough = {"alpha": 0.5}
    aniso = "alpha_x" in rough or "alpha_y" in rough
    if aniso and not {"alpha_x", "alpha_y"} <= set(rough):
        raise ParameterError("give alpha_x and alpha_y both (anisotropic), or alpha")
    alpha_iso = rough.get("alpha") or float(np.sqrt(rough["alpha_x"] * rough["alpha_y"]))
    mus = np.array(REC_MUS)
    if model == "ggx_dielectric":
        eta = float(params.pop("eta", 1.5))
        if params or aniso:
            raise ParameterError(f"ggx_dielectric's compensation takes alpha and eta, not "
                                 f"{', '.join(sorted(params) or ['alpha_x, alpha_y'])}")
        rows = glass_cells((eta,), (alpha_iso,), mus, walks=walks, seed=seed, device=device)
        methods = {}
        for k in ("single_beta", "scaled_correlated", "scaled_beta"):
            # absolute: E_R + E_T = 1, so an error is a fraction of all the energy
            err = np.array([max(abs(r[f"{k}_R_error"]), abs(r[f"{k}_T_error"])) for r in rows])
            i = int(np.argmax(err))
            methods[k] = {"error": float(err.max()), "at_mu": float(mus[i]), "lobe_L1": None}
        se = max(r["walk_stderr"] for r in rows)
        material = f"eta={eta:g}"
        sizes = {}
    else:
        material = dict(params)
        Model("ggx", channels=3, **rough, **material)               # checked before any work
        fres = _fresnel_params(material)
        fkw = {k: v for k, v in fres.items() if k != "channels"}
        f0 = _fresnel_at(material, np.array([1.0]), device)[0]
        favg = np.asarray(fresnel_avg("ggx", device=device, **fres), float)
        xg, wg = np.polynomial.legendre.leggauss(AVG_NODES)
        mg, wg = (xg + 1) / 2, wg / 2
        e = _e(alpha_iso, mus, device=device)[:, None, None]
        e_avg = float(np.sum(wg * 2 * mg * _e(alpha_iso, mg, device=device)))
        a = _e(alpha_iso, mus, device=device, fresnel="schlick", f0=1.0, f90=0.0)[:, None, None]
        b = _e(alpha_iso, mus, device=device, fresnel="schlick", f0=0.0, f90=1.0)[:, None, None]
        phis = np.array(REC_PHIS if aniso else (0.0,))
        full = dict(rough) if aniso else {"alpha": alpha_iso}
        mf = Model("ggx", precision="double", device=device, channels=3, **full, **fkw)
        ef = np.asarray(albedo(mf, mus[:, None], phis[None, :], estimator="quadrature",
                               tol=TOL).albedo, float)
        m = Model("ggx", device=device, channels=3, **full, **fkw)
        w = walk_albedo(m, mus[:, None], phis[None, :], walks=walks, seed=seed)
        est = conductor_albedo(e, e_avg, ef, f0, favg, a, b)
        methods = {}
        for k in ("single", "turquin", "fdez_aguera", "kulla_conty"):
            rel = np.abs(est[k] / w.albedo - 1)
            i = np.unravel_index(int(np.argmax(rel)), rel.shape)
            methods[k] = {"error": float(rel.max()), "at_mu": float(mus[i[0]]), "lobe_L1": None}
        se = float(np.max(w.stderr / w.albedo))
        if not aniso:
            _, lobes = conductor_cells(material, (alpha_iso,), (), (0.5,), walks=walks,
                                       lobe_walks=walks, seed=seed + 1, device=device)
            for k in ("turquin", "fdez_aguera", "kulla_conty"):
                methods[k]["lobe_L1"] = max(r[f"{k}_L1"] for r in lobes)
        material = material_label(material) if material else "F = 1"
        sizes = table_size_errors(alpha_iso, device=device) if alpha_iso <= 1 else {}
    # the cheapest method whose error leaves room for a table's (the two add)
    method = size = None
    for k in methods:
        room = tolerance - methods[k]["error"]
        if room < 0:
            continue
        if k in ("single", "single_beta") or not sizes:
            method = k
            break
        key = "kulla_conty" if k == "kulla_conty" else "turquin"
        fits = [n for n, v in sizes.items() if v[key] <= room]
        if fits:
            method, size = k, fits[0]
            break
    return Recommendation(model, material if isinstance(material, str) else str(material),
                          rough, float(tolerance), method, size, methods, sizes, se, aniso,
                          time.perf_counter() - t0)
