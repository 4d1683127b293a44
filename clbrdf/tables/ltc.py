"""``clbrdf.fit_ltc``: linearly transformed cosines (Heitz, Dupuy, Hill & Neubelt 2016) fitted to
a model's lobe f(wo, wi) cos(theta_i) / E(wo) in every cell of a table, all cells at once.

Per cell (a view angle and parameter values):
- the magnitude E = int f cos dwi and the Schlick split's B term int f cos (1 - wo.h)^5 dwi
  (what the engines store beside the matrix) by the deterministic quadrature in double
  precision, to 2e-7 (``magnitudes``); one pass of BRDF samples (Philox, ``report_samples`` per
  cell) gives the lobe's mean direction and its second moments;
- the start: the frame of the mean direction (Heitz's X, Y, Z: y kept out for an isotropic
  model) and the scales a, b whose transformed cosine has the lobe's second moments in that
  frame (along the moments' principal axes, turned by psi about Z, for an anisotropic model or
  a phi axis) (``_scale_of_moment``), or the best of a few variants of it (``best_start``), so that
  no cell waits for a neighbour and the fit runs in parallel;
- Nelder-Mead over (log a, log b, c, t) with M = [X Y Z] Ry(t) [[a, 0, c], [0, b, 0], [0, 0, 1]]
  (ltc_code's parametrisation, whose frame stays at the mean direction, and the turn t of the
  frame about Y: all four free entries; without t the fit was up to 1.4x worse in L3 than
  ltc_code's shipped GGX table at r > 0.8, whose frame came from its own noisy mean); for an
  anisotropic lobe also (d, psi): M = [X Y Z] Ry(t) Rz(psi) [[a, 0, c], [0, b, d], [0, 0, 1]];
  in lockstep for all cells: each step is one or two kernel
  launches of one candidate per active cell, each the L3 error between lobe and LTC estimated
  with the same ``samples`` quasi-random numbers per cell (common random numbers: a
  deterministic loss that the simplex can converge on);
- the reported errors: L3 = int |t - D|^3 dw (the fit's own metric, t the normalised lobe) and
  the relative L1 error int |t - D| dw (in [0, 2]: twice the mass the LTC puts in the wrong
  place), each with its standard error, from ``report_samples`` independent Philox samples.
The matrix is stored as ltc_code and the engines store it: M^-1 divided by its middle element.

``form="zeltner"``: the two-parameter LTC of Zeltner, Burley & Chiang 2022 (their sheen table,
Cycles' ``table_sheen_ltc``): M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]] in the frame of the
normal with X toward wo, Nelder-Mead over (log a, b) from the best of 15 starts.
"""
from __future__ import annotations

import time

import numpy as np

from ..api.model import Model
from ..models import get_spec
from ..models.choices import MAGNITUDE_TOL
from ..models.spec import ParameterError, Setting, check_int, given
from ..runtime.launch import derive_seed, environment
from ..api.albedo import QUAD_TOL
from ..runtime.ltc import LTCRunner
from ..runtime.quadrature import quadrature_runner
from ..version import __version__
from . import axes as ax_mod
from .compute import table_axes
from .table import Table

ENTRIES = tuple(f"minv{r}{c}" for r in range(3) for c in range(3))
QUANTITIES = ENTRIES + ("E", "B", "L3", "L1")


def _moment_of_scale(a):
    """E[x^2] of the cosine lobe through diag(a, a, 1), normalised: with u = sin^2 theta
    uniform, x^2 = a^2 u cos^2 phi / (a^2 u + 1 - u), so E = a^2 (k - log1p(k)) / (2 k^2),
    k = a^2 - 1 (a series near k = 0)."""
    a2 = a * a
    k = a2 - 1
    small = np.abs(k) < 1e-3
    ks = np.where(small, 1.0, k)
    exact = a2 * (ks - np.log1p(ks)) / (2 * ks * ks)
    series = a2 * (0.5 - k / 3 + k * k / 4) / 2
    return np.where(small, series, exact)


def _scale_of_moment(s):
    """The a with _moment_of_scale(a) = s (bisection in log a; s in (0, 1/2))."""
    s = np.clip(s, 1e-14, 0.5 - 1e-9)
    lo, hi = np.full(s.shape, -16.0), np.full(s.shape, 8.0)
    for _ in range(80):
        mid = (lo + hi) / 2
        big = _moment_of_scale(np.exp(mid)) > s
        hi = np.where(big, mid, hi)
        lo = np.where(big, lo, mid)
    return np.exp((lo + hi) / 2)


def _frames(mean, isotropic: bool, ref=None):
    """(n, 3, 3) rotations [X Y Z] (columns) with Z the lobe's mean direction and X in the plane
    of Z and the reference direction ``ref`` (n, 3) (default x: wo's plane at phi = 0), so that
    a lobe seen at another azimuth gets the same frame, turned."""
    z = np.array(mean, float)
    if isotropic:
        z[:, 1] = 0
    nz = np.linalg.norm(z, axis=1)
    z = np.where(nz[:, None] > 0, z / np.where(nz > 0, nz, 1)[:, None], [0.0, 0.0, 1.0])
    if ref is None:
        ref = np.broadcast_to([1.0, 0.0, 0.0], z.shape)
    y = np.cross(z, ref)
    x = np.cross(y, z)
    nx = np.linalg.norm(x, axis=1)
    x = np.where(nx[:, None] > 1e-12, x / np.where(nx > 0, nx, 1)[:, None], [1.0, 0.0, 0.0])
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=2)


def _matrices(frames, x):
    """M = R Ry(t) S(a, b, c) and M^-1 for parameters x = (log a, log b, c, t) (n, 4): the
    frame R turned by t about its Y axis; the four free entries of an isotropic LTC (M^-1 in the
    x-z plane, normalised by its middle element). With x (n, 6) = (..., d, psi), anisotropic:
    M = R Ry(t) Rz(psi) S(a, b, c, d), S = [[a, 0, c], [0, b, d], [0, 0, 1]]: the lobe's
    principal axes turned by psi about its mean direction, and a shear along each."""
    n = len(x)
    ct, st = np.cos(x[:, 3]), np.sin(x[:, 3])
    ry = np.zeros((n, 3, 3))
    ry[:, 0, 0], ry[:, 0, 2], ry[:, 1, 1], ry[:, 2, 0], ry[:, 2, 2] = ct, st, 1, -st, ct
    frames = frames @ ry
    s = np.zeros((n, 3, 3))
    s[:, 0, 0] = np.exp(x[:, 0])
    s[:, 1, 1] = np.exp(x[:, 1])
    s[:, 0, 2] = x[:, 2]
    s[:, 2, 2] = 1
    if x.shape[1] == 6:
        s[:, 1, 2] = x[:, 4]
        cp, sp = np.cos(x[:, 5]), np.sin(x[:, 5])
        rz = np.zeros((n, 3, 3))
        rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = cp, -sp, sp, cp, 1
        frames = frames @ rz
    m = frames @ s
    return m, np.linalg.inv(m)


def _zeltner_matrices(frames, x):
    """M and M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]] R^T for x = (log a, b) (n, 2), R the
    normal's frame with X toward wo (Zeltner et al. 2022: Cycles' transformA, transformB)."""
    n = len(x)
    s = np.zeros((n, 3, 3))
    s[:, 0, 0] = s[:, 1, 1] = np.exp(x[:, 0])
    s[:, 0, 2] = x[:, 1]
    s[:, 2, 2] = 1
    minv = s @ np.swapaxes(frames, 1, 2)
    return np.linalg.inv(minv), minv


FORMS = {"general": _matrices, "zeltner": _zeltner_matrices}


def _general_of(frames, m):
    """The isotropic parameters x = (log a, log b, c, t) (n, 4) with _matrices(frames, x) = m
    up to scale, for m (n, 3, 3) whose R^T m keeps y apart (a Zeltner LTC): the x-z block of
    R^T m = Ry(t) [[a, c], [0, 1]] k is a QR decomposition."""
    A = np.swapaxes(frames, 1, 2) @ m
    c0, c1 = A[:, [0, 2], 0], A[:, [0, 2], 2]          # the block's columns (x, z)
    u00 = np.linalg.norm(c0, axis=1)
    q = c0 / u00[:, None]                              # (cos t, -sin t)
    u01 = np.sum(q * c1, axis=1)
    u11 = q[:, 0] * c1[:, 1] - q[:, 1] * c1[:, 0]
    t = np.arctan2(-q[:, 1], q[:, 0])
    return np.stack([np.log(np.abs(u00 / u11)), np.log(np.abs(A[:, 1, 1] / u11)), u01 / u11,
                     t], axis=1)


class _Fit:
    """The cells' runner and the loss of candidate parameters (cells, x)."""

    def __init__(self, runner, frames, E, scale, samples, seed, matrices=_matrices):
        self.runner, self.frames, self.E, self.scale = runner, frames, E, scale
        self.samples, self.seed, self.evaluations = samples, seed, 0
        self.matrices = matrices

    def __call__(self, cells, x):
        if len(cells) == 0:
            return np.zeros(0)
        m, minv = self.matrices(self.frames[cells], x)
        r = self.runner.loss(cells, m, minv, self.E[cells], self.scale[cells], self.samples,
                             self.seed)
        self.evaluations += len(cells)
        return r[:, 0] / self.samples


def nelder_mead(f, x0, steps, *, max_iter=600, xtol=1e-4, ftol=1e-6):
    """Nelder-Mead (reflection 1, expansion 2, contraction 1/2, shrink 1/2; Lagarias et al.
    1998) on n problems at once: f(cells, x) evaluates the candidates x (k, d) of the problems
    ``cells``; x0 (n, d) and per-coordinate initial steps (n, d). A problem stops when its
    simplex is within xtol in every coordinate and its values within ftol (relative) of the best.
    Returns (x (n, d), f (n,), iterations (n,))."""
    n, d = x0.shape
    simplex = np.repeat(x0[:, None], d + 1, axis=1)
    for j in range(d):
        simplex[:, j + 1, j] += steps[:, j]
    cells = np.arange(n)
    fv = f(np.repeat(cells, d + 1), simplex.reshape(-1, d)).reshape(n, d + 1)
    its = np.zeros(n, int)
    active = np.ones(n, bool)
    for _ in range(max_iter):
        order = np.argsort(fv, axis=1, kind="stable")
        simplex = np.take_along_axis(simplex, order[..., None], axis=1)
        fv = np.take_along_axis(fv, order, axis=1)
        spread_x = np.max(np.abs(simplex[:, 1:] - simplex[:, :1]), axis=(1, 2))
        spread_f = fv[:, -1] - fv[:, 0]
        active &= ~((spread_x <= xtol) & (spread_f <= ftol * np.abs(fv[:, 0])))
        a = np.flatnonzero(active)
        if a.size == 0:
            break
        its[a] += 1
        s, v = simplex[a], fv[a]
        c = s[:, :-1].mean(axis=1)
        worst = s[:, -1]
        xr = 2 * c - worst
        fr = f(a, xr)
        expand = fr < v[:, 0]
        accept_r = (fr >= v[:, 0]) & (fr < v[:, -2])
        contract = fr >= v[:, -2]
        outside = contract & (fr < v[:, -1])
        x2 = np.where(expand[:, None], c + 2 * (xr - c),
                      np.where(outside[:, None], c + 0.5 * (xr - c), c + 0.5 * (worst - c)))
        need = expand | contract
        f2 = np.full(a.size, np.inf)
        f2[need] = f(a[need], x2[need])
        new_x, new_f = worst.copy(), v[:, -1].copy()
        take_r = accept_r | (expand & ~(f2 < fr))
        new_x[take_r], new_f[take_r] = xr[take_r], fr[take_r]
        take_e = expand & (f2 < fr)
        new_x[take_e], new_f[take_e] = x2[take_e], f2[take_e]
        take_c = (outside & (f2 <= fr)) | (contract & ~outside & (f2 < v[:, -1]))
        new_x[take_c], new_f[take_c] = x2[take_c], f2[take_c]
        shrink = contract & ~take_c
        s[:, -1], v[:, -1] = new_x, new_f
        if shrink.any():
            k = np.flatnonzero(shrink)
            s[k, 1:] = s[k, :1] + 0.5 * (s[k, 1:] - s[k, :1])
            v[k, 1:] = f(np.repeat(a[k], d), s[k, 1:].reshape(-1, d)).reshape(k.size, d)
        simplex[a], fv[a] = s, v
    best = np.argmin(fv, axis=1)
    return simplex[np.arange(n), best], fv[np.arange(n), best], its


def _canonical(minv):
    """The one M^-1 of each LTC fit for interpolation: D_o is symmetric about z, so Rz(b) M^-1
    is the same LTC for every b, and fits of neighbouring cells can land b apart (the
    anisotropic form's psi and psi + pi/2 with a and b swapped); turned so that the upper-left
    2 x 2 block is symmetric with a positive trace (its polar form: b = atan2(m01 - m10,
    m00 + m11), the b nearest to the identity), which an isotropic fit already is."""
    minv = np.array(minv, float)
    b = np.arctan2(minv[:, 0, 1] - minv[:, 1, 0], minv[:, 0, 0] + minv[:, 1, 1])
    c, s = np.cos(b)[:, None], np.sin(b)[:, None]
    r0, r1 = minv[:, 0].copy(), minv[:, 1].copy()
    minv[:, 0], minv[:, 1] = c * r0 - s * r1, s * r0 + c * r1
    return minv


B_RELATIVE = 1e-2           # and of B, relative to B's first value, down to B_FLOOR
B_FLOOR = 1e-11             # (or 1e-4 of a larger target)


def check_magnitude_tol(tol) -> float:
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 1e-9 <= tol <= 1e-2:
        raise ParameterError(f"{given('magnitude_tol', tol)} is out of range: valid is [1e-9, "
                             f"1e-2] (the quadrature's error target of E and B)", "magnitude_tol")
    return float(tol)


def magnitudes(m, wo, config: dict, tol: float = MAGNITUDE_TOL):
    """(E, E_err, B, B_err, how) of model m (built from ``config``: one channel, one cell per row
    of wo): the magnitude E = int f cos dwi and the Schlick split's B = int f cos (1 - wo.h)^5
    dwi by the deterministic quadrature (clbrdf/runtime/quadrature.py) in double precision where
    the device has it, to MAGNITUDE_TOL (the estimate can be 3x short of the truth: at 5e-7, E
    was 1.4e-6 off at GGX alpha 0.016, mu 0.42); err is the quadrature's error estimate. It
    costs more than the Monte Carlo pass it replaces (double precision, 2 cores: 50 s for the
    threejs layout's 4096 GGX cells, 80 s for Cycles' 1024 Charlie cells). B's integrand
    grows as (1 - wo.h)^5 up to the horizon, where it drops to 0: a small B (a smooth lobe near
    normal incidence) met MAGNITUDE_TOL before any panel was cut, its estimate fooled by the drop
    (GGX alpha 0.016 at mu 1: 1.84e-7 +- 3e-9, the truth 2.236e-7). B is therefore integrated
    again to B_RELATIVE of its first value (where the first is above that target): then
    |B - truth| <= 2.2 err on a 16 x 16 grid of
    the threejs layout's cells, against the float64 reference (tests/tables/test_ltc.py). A cell that
    stops above its target (at the evaluation cap) raises: a magnitude is never stored less
    accurate than it says."""
    double = m.device.info.has_fp64
    q = Model(m.name, precision="double", device=m.device, **config) \
        if double and m.precision != "double" else m
    tol = tol if q.precision == "double" else max(tol, QUAD_TOL["single"])
    rows, shape = [wo[:, 0], wo[:, 1], wo[:, 2]], (len(wo),)
    run_quadrature = quadrature_runner()
    E, E_err, _, t_e = run_quadrature(q, shape, rows, tol=tol)
    B, B_err, _, t_0 = run_quadrature(q, shape, rows, tol=tol, integrand="schlick")
    floor = max(B_FLOOR if q.precision == "double" else 1e-9, tol * 1e-4)
    tol_b = np.clip(B_RELATIVE * B[:, 0], floor, tol)
    # again only where the first pass is above the new target: elsewhere it met that target
    # already (a second pass refines along another path to another value within it): GGX 16 x 16
    # cells 3.6 -> 3.0 s, Charlie 12 x 12 10.1 -> 8.0 s
    again, t_b = np.flatnonzero(B_err[:, 0] > tol_b), 0.0
    if again.size:
        n = len(wo)
        sub = Model(m.name, precision=q.precision, device=m.device, width=q.width,
                    **{k: np.asarray(v)[again] if np.ndim(v) and np.shape(v)[0] == n else v
                       for k, v in config.items()})
        B[again], B_err[again], _, t_b = run_quadrature(
            sub, (again.size,), [r[again] for r in rows], tol=tol_b[again], integrand="schlick")
    for what, err, target in (("E", E_err[:, 0], tol), ("B", B_err[:, 0], tol_b)):
        if np.any(err > target):
            i = int(np.argmax(err - target))
            raise RuntimeError(f"fit_ltc: the quadrature of {what} stopped at error "
                               f"{err[i]:.2g} > {np.broadcast_to(target, err.shape)[i]:g} at "
                               f"mu={wo[i, 2]:.6g}")
    how = {"magnitudes": "quadrature", "magnitude_tol": tol, "magnitude_precision": q.precision,
           "magnitude_seconds": round(t_e + t_0 + t_b, 3)}
    return E[:, 0], E_err[:, 0], B[:, 0], B_err[:, 0], how


class _Grid:
    """The validated cells of a fit, before any device work: the axes, the flattened grid (mu,
    phi and the parameters per cell) and the model over every cell."""

    def __init__(self, name, axes, fixed, precision, device, width, form="general"):
        spec = get_spec(name)
        if spec.transmits:
            raise ParameterError(f"fit_ltc: {name} transmits; an LTC approximates a reflection "
                                 f"lobe over the upper hemisphere: choose a reflection model")
        if fixed.get("channels", 1) != 1:
            raise ParameterError("fit_ltc fits one channel: leave channels at 1")
        self.name, self.fixed = name, fixed
        self.axl = table_axes(spec, axes, fixed, precision)
        names = self.names = [a["name"] for a in self.axl]
        evals = {a["name"]: ax_mod.evaluated(a) for a in self.axl}
        target = {k: ax_mod.MAPPED[k][0] if k in ax_mod.MAPPED else k for k in names}
        grids = dict(zip(names, np.meshgrid(*[evals[k] for k in names], indexing="ij")))
        self.shape = grids[names[0]].shape
        view = next(k for k in names if k in ax_mod.VIEW)
        self.mu = grids[view].reshape(-1)
        self.n = self.mu.size
        self.phi = grids["phi"].reshape(-1) if "phi" in grids else np.zeros(self.n)
        self.params = {target[k]: grids[k].reshape(-1) for k in names if k not in (view, "phi")}
        m = self.model = Model(name, precision=precision, device=device, width=width, **fixed,
                               **self.params)
        self.isotropic = not (m.anisotropic or "phi" in names)
        if form == "zeltner" and not self.isotropic:
            raise ParameterError('form="zeltner" is the isotropic two-parameter LTC: fit an '
                                 'isotropic model without a phi axis, or use form="general"')

    def check_not_empty(self, empty):
        if np.all(empty):
            at = ", ".join(f"{k}={v[0]:g}" for k, v in self.params.items())
            raise ParameterError(f"fit_ltc: the lobe is empty (E = 0) in every cell (mu="
                                 f"{self.mu[0]:g}{', ' + at if at else ''}, ...)")


class _Cells:
    """Cells [i0, i1) of a fit's grid (``_Grid``): the model over them, wo per cell, and the
    lobe's moments (E, B, the frame and the moment-matched start) from ``N`` Philox samples per
    cell. The random numbers are keyed by a cell's index in the whole grid, so that a part of
    the cells gives what the whole gives in those cells."""

    def __init__(self, grid, i0, i1, N, seed, magnitude_tol=MAGNITUDE_TOL):
        self.grid, self.i0 = grid, i0
        mu, phi = grid.mu[i0:i1], grid.phi[i0:i1]
        self.params = {k: v[i0:i1] for k, v in grid.params.items()}
        g = grid.model
        m = self.model = g if (i0, i1) == (0, grid.n) else Model(
            grid.name, precision=g.precision, device=g.device, width=g.width, **grid.fixed,
            **self.params)
        iso = self.isotropic = grid.isotropic
        n = self.n = mu.size
        st = np.sqrt((1 - mu) * (1 + mu))
        self.wo = np.stack([st * np.cos(phi), st * np.sin(phi), mu], axis=1)
        self.indep = LTCRunner(m, self.wo, "philox", cell0=i0)
        self.N, self.seed = N, seed
        first = self.indep.moments(min(N, 1 << 12), derive_seed(seed, 0))
        self.azimuth = np.stack([np.cos(phi), np.sin(phi), np.zeros(n)], axis=1)
        self.frames = _frames(first[:, 3:6], isotropic=iso, ref=self.azimuth)
        mom = self.indep.moments(N, derive_seed(seed, 1), self.frames)
        # the magnitudes E and B by the deterministic quadrature (``magnitudes``); the samples'
        # moments give the frame and the start
        self.E, self.E_se, self.B, self.B_se, self.how = magnitudes(
            m, self.wo, {**grid.fixed, **self.params}, magnitude_tol)
        # an empty cell: no sample of the lobe contributed (Charlie at alpha 1e-3 and mu >= 0.5,
        # where E < 1e-150); it is fitted as the cosine's (finite throughout) and then stored as
        # M^-1 = I, its E and B and errors 0 (``table``)
        empty = self.empty = mom[:, 0] <= 0
        E = np.where(empty, 0.0, self.E)
        if n == grid.n:
            grid.check_not_empty(empty)         # before the fit (a part: fit_ltc checks after)
        self.E_fit = np.where(empty, 1.0, E)
        mom = mom.copy()        # the cosine's: mean z, E[x^2] = E[y^2] = 1/4, E[z^2] = 1/2
        mom[empty, 0] = 1
        mom[np.ix_(empty, np.arange(3, 12))] = [0, 0, 1, 0.25, 0.25, 0.5, 0, 0, 0]
        # the frame of the accurate mean (in the first frame), and the moments turned into it
        mean_local = mom[:, 3:6] / mom[:, 0:1]
        rot = _frames(mean_local, isotropic=iso)           # local frame -> refined frame
        # (in the first frame, x is already wo's azimuth plane)
        self.frames = self.frames @ rot
        S = np.zeros((n, 3, 3))
        for (i, j), col in zip([(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)], range(6, 12)):
            S[:, i, j] = S[:, j, i] = mom[:, col] / mom[:, 0]
        local = np.einsum("nki,nkl,nlj->nij", rot, S, rot)     # rot^T S rot
        sxx, syy, sxy = local[:, 0, 0], local[:, 1, 1], local[:, 0, 1]
        psi = np.zeros(n) if iso else 0.5 * np.arctan2(2 * sxy, sxx - syy)   # principal axes
        c2, s2 = np.cos(psi) ** 2, np.sin(psi) ** 2
        a = _scale_of_moment(c2 * sxx + s2 * syy + np.sin(2 * psi) * sxy)
        b = _scale_of_moment(s2 * sxx + c2 * syy - np.sin(2 * psi) * sxy)
        zero = np.zeros(n)
        self.x0 = np.stack([np.log(a), np.log(b), zero, zero] + ([] if iso else [zero, psi]), 1)
        steps = [np.full(n, 0.1), np.full(n, 0.1), np.minimum(0.1 * a, 0.1),
                 np.minimum(0.1 * a, 0.05)]
        self.steps = np.stack(steps + ([] if iso else [np.minimum(0.1 * b, 0.1),
                                                        np.full(n, 0.1)]), axis=1)
        self.scale = np.pi * a * b                   # about 1 / max D of the start

    def best_start(self, loss, extra=()):
        """The best of a few starts per cell, all evaluated in one launch: the moment-matched
        one; the same with a = b (their geometric mean) and that x 1/2 and x 2; each also with
        the frame turned back to the normal. A ring-shaped lobe (Charlie sheen at normal
        incidence, alpha 0.05) has second moments that no single cosine matches: from the
        moment start alone Nelder-Mead stalled at L1 1.1 beside neighbours at 0.2. ``extra``:
        further starts (n, d) each (fit_ltc: the Zeltner fit's)."""
        x0, n = self.x0, self.n
        z = self.frames[:, :, 2]
        back = np.arctan2(self.frames[:, 2, 0], z[:, 2])         # Ry(back) R^T-turns Z to z
        iso = (x0[:, 0] + x0[:, 1]) / 2
        rest = [] if self.isotropic else [np.zeros(n), x0[:, 5]]      # d, psi
        starts = []
        for t in (np.zeros(n), back):
            starts.append(np.stack([x0[:, 0], x0[:, 1], x0[:, 2], t] + rest, axis=1))
            for k in (0.0, -np.log(2), np.log(2)):
                starts.append(np.stack([iso + k, iso + k, np.zeros(n), t] + rest, axis=1))
        return self._best(loss, starts + list(extra))

    def _best(self, loss, starts):
        n = self.n
        cand = np.concatenate(starts)
        f = loss(np.tile(np.arange(n), len(starts)), cand).reshape(len(starts), n)
        best = np.argmin(f, axis=0)
        return cand.reshape(len(starts), n, -1)[best, np.arange(n)]

    def zeltner(self):
        """The normal's frames (X toward wo) and steps of form="zeltner"; its start: the best of
        15 in one launch: a = 1 / (the moment-matched scale's geometric mean) x 1/4 .. 4, and
        b = 0, or the shift -a tan(theta) that moves the cosine's axis to the lobe's mean
        direction (at theta from the normal), or half of it."""
        n = self.n
        frames = _frames(np.tile([0.0, 0.0, 1.0], (n, 1)), isotropic=True, ref=self.azimuth)
        z = np.einsum("nji,nj->ni", frames, self.frames[:, :, 2])    # mean direction, locally
        tan = z[:, 0] / np.maximum(z[:, 2], 1e-3)
        a0 = np.exp(-(self.x0[:, 0] + self.x0[:, 1]) / 2)
        starts = [np.stack([np.log(a0 * k), -a0 * k * tan * h], axis=1)
                  for k in (0.25, 0.5, 1.0, 2.0, 4.0) for h in (0.0, 0.5, 1.0)]
        steps = np.stack([np.full(n, 0.1), np.maximum(0.1 * a0, 0.05)], axis=1)
        return frames, steps, starts

    def errors(self, minv, seed_word: int = 3):
        """(L3, L3_se, L1, L1_se) of the LTCs minv (n, 3, 3) from N independent samples."""
        minv = np.asarray(minv, float)
        N, k3 = self.N, 1 / self.scale ** 3
        rep = self.indep.loss(np.arange(self.n), np.linalg.inv(minv), minv, self.E_fit,
                              self.scale, N, derive_seed(self.seed, seed_word))
        L3 = rep[:, 0] / N * k3
        L3_se = np.sqrt(np.maximum(rep[:, 1] / N - (rep[:, 0] / N) ** 2, 0) / (N - 1)) * k3
        L1 = rep[:, 2] / N
        L1_se = np.sqrt(np.maximum(rep[:, 3] / N - L1 * L1, 0) / (N - 1))
        return tuple(np.where(self.empty, 0.0, e) for e in (L3, L3_se, L1, L1_se))

    def result(self, minv, errors) -> dict:
        """The cells' arrays of the table: M^-1 (n, 3, 3) (the identity in an empty cell), the
        magnitudes and the errors, each with its standard error (0 in an empty cell)."""
        minv = np.where(self.empty[:, None, None], np.eye(3), minv)
        out = {"minv": minv, "empty": self.empty}
        for k, v in zip(("E", "E_se", "B", "B_se", "L3", "L3_se", "L1", "L1_se"),
                        (self.E, self.E_se, self.B, self.B_se) + tuple(errors)):
            out[k] = np.where(self.empty, 0.0, v)
        return out


def _fit_part(grid, spec: dict, i0: int, i1: int) -> dict:
    """Cells [i0, i1) of the fit ``spec`` (fit_ltc's checked arguments) over ``grid``: their
    arrays (``_Cells.result``), iterations per cell and the counts and seconds of the fit."""
    samples, seed, max_iter, restarts, form = (spec[k] for k in (
        "samples", "seed", "max_iter", "restarts", "form"))
    t0 = time.perf_counter()
    c = _Cells(grid, i0, i1, spec["report_samples"], seed, spec["magnitude_tol"])
    t1 = time.perf_counter()
    runner = LTCRunner(c.model, c.wo, "sobol", cell0=i0)

    def run(loss, x0, steps):
        x, fx, its = nelder_mead(loss, x0, steps, max_iter=max_iter)
        for _ in range(restarts):   # a collapsed simplex can stall off the minimum (Lagarias et
            # al. 1998): start a fresh one at the best point
            x2, f2, its2 = nelder_mead(loss, x, steps, max_iter=max_iter)
            better = f2 < fx
            x[better], fx[better] = x2[better], f2[better]
            its += its2
        return x, fx, its

    evaluations, its = 0, 0
    if form == "zeltner" or c.isotropic:
        zframes, zsteps, zstarts = c.zeltner()
        zloss = _Fit(runner, zframes, c.E_fit, c.scale, samples, derive_seed(seed, 2),
                     _zeltner_matrices)
        xz, _, its = run(zloss, c._best(zloss, zstarts), zsteps)
        evaluations = zloss.evaluations
    if form == "zeltner":
        _, minv = _zeltner_matrices(zframes, xz)
    else:
        loss = _Fit(runner, c.frames, c.E_fit, c.scale, samples, derive_seed(seed, 2))
        x, fx, its_g = run(loss, c.best_start(loss), c.steps)
        its = its + its_g
        if c.isotropic:
            # the Zeltner LTCs are general ones: where one beats the general fit (the same
            # samples), that fit is stuck (Charlie alpha 1e-3, mu 0.05: at 11x the Zeltner
            # fit's loss); go on from it there. (As one more start for every cell it made 47
            # GGX cells worse than ltc_code's table: a lower start can end higher.)
            xs = _general_of(c.frames, _zeltner_matrices(zframes, xz)[0])
            stuck = np.flatnonzero(loss(np.arange(c.n), xs) < fx)
            if stuck.size:
                x2, f2, its2 = run(lambda k, y: loss(stuck[k], y), xs[stuck], c.steps[stuck])
                better = f2 < fx[stuck]
                x[stuck[better]] = x2[better]
                its[stuck] += its2
        evaluations += loss.evaluations
        _, minv = _matrices(c.frames, x)
    t2 = time.perf_counter()
    out = c.result(minv, c.errors(minv))
    t3 = time.perf_counter()
    return {**out, "its": np.broadcast_to(its, (c.n,)), "evaluations": int(evaluations),
            "how": c.how, "seconds_moments": t1 - t0, "seconds_fit": t2 - t1,
            "seconds_report": t3 - t2, "device": c.model.device.info.name}


def fit_ltc_part(spec: dict, i0: int, i1: int, device=None) -> dict:
    """Cells [i0, i1) of the fit ``spec`` on ``device`` (a cluster worker's part of fit_ltc:
    clbrdf/studies/cluster.py); the model at ``spec["width"]``, the width of the whole fit."""
    grid = _Grid(spec["name"], spec["axes"], spec["fixed"], spec["precision"], device,
                 spec["width"], spec["form"])
    return _fit_part(grid, spec, i0, i1)


def _local_parts(grid, spec):
    return [_fit_part(grid, spec, 0, grid.n)]


# where fit_ltc's cells are fitted: ``ltc_parts_runner()(grid, spec)`` returns the parts' results
# in order of their cells; here, unless a ``with using_ltc_parts(run):`` block installed another
# (a cluster's)
_PARTS = Setting("clbrdf_ltc_parts_runner")
using_ltc_parts = _PARTS.using


def _table(grid, spec: dict, parts: list, meta: dict) -> Table:
    """The fit's Table from its parts' arrays (normalised as the engines store M^-1)."""
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]
           if isinstance(parts[0][k], np.ndarray)}
    n, minv = grid.n, cat["minv"]
    # any positive scale of M^-1 is the same LTC: isotropic, the engines' M^-1[1][1] (= 1 / b
    # > 0); anisotropic, |det M^-1|^(1/3), since there M^-1[1][1] passes through 0 and
    # changes sign (and a negative scale sends the lobe below the horizon), after the
    # rotation that makes M^-1 unique (``_canonical``)
    if grid.isotropic:
        minv_n = minv / minv[:, 1:2, 1:2]
    else:
        minv_n = _canonical(minv)
        minv_n /= np.cbrt(np.abs(np.linalg.det(minv_n)))[:, None, None]
    vals = np.concatenate([minv_n.reshape(n, 9),
                           np.stack([cat[k] for k in ("E", "B", "L3", "L1")], 1)], 1)
    errs = np.concatenate([np.zeros((n, 9)), np.stack([cat[k] for k in (
        "E_se", "B_se", "L3_se", "L1_se")], 1)], 1)
    m = grid.model
    how = {**parts[0]["how"], "magnitude_seconds": round(sum(
        p["how"]["magnitude_seconds"] for p in parts), 3)}
    computed = {"quantity": "ltc", "model": m.name,
                **{k: v for k, v in m.describe().items() if k != "model" and k not in grid.params},
                "axes": grid.names, "report_samples": spec["report_samples"],
                "seed": spec["seed"], **how, "precision": m.precision, **meta,
                "normalised_by": "M^-1[1][1]" if grid.isotropic else "|det M^-1|^(1/3)",
                "empty_cells": int(cat["empty"].sum()), "device": m.device.info.name,
                "width": m.width, "clbrdf": __version__, "environment": environment()}
    q = len(QUANTITIES)
    return Table(name="ltc", axes=grid.axl, quantity=list(QUANTITIES),
                 raw=vals.reshape(grid.shape + (q,)).astype(np.float32),
                 stderr=errs.reshape(grid.shape + (q,)), encoding="float32",
                 meta={"computed": computed})


def fit_ltc(name: str, axes: dict, *, samples: int = 1024, report_samples: int = 1 << 16,
            seed: int = 0, precision: str = "single", device=None, width: int | None = None,
            max_iter: int = 600, restarts: int = 1, form: str = "general",
            magnitude_tol: float = MAGNITUDE_TOL, command: str | None = None, **fixed):
    """A table of LTC fits over the grid of ``axes`` (as ``clbrdf.albedo_table`` takes them: a
    view axis ``mu``, ``theta`` or ``sqrt1m_mu``, ``phi`` (wo's azimuth), ``r`` or ``alpha``
    and any numeric parameter, alpha_x and alpha_y of an anisotropic model included), with
    fixed parameters and options in ``fixed``. Returns a ``clbrdf.Table``
    named "ltc" whose quantities are the normalised M^-1 entries ``minv00`` .. ``minv22``
    (row-major, M^-1 / M^-1[1][1], or M^-1 / |det M^-1|^(1/3) for an anisotropic model or a
    phi axis), the magnitude ``E``, the Schlick split's ``B`` term (with
    F0: E(F0) = F0 (E - B) + B), the fit's ``L3`` error and the relative ``L1`` error, each with
    its ``_stderr`` (module docstring). ``samples``: quasi-random samples per loss evaluation
    (a multiple of 16); ``report_samples``: Philox samples of the lobe's moments and the reported
    errors (E and B are the quadrature's, to ``magnitude_tol``: ``magnitudes``);
    ``max_iter``: Nelder-Mead iterations per cell and run, at most; ``restarts``: further runs
    from the best point; ``form``: "general" (the 4 or 6 free entries) or "zeltner" (the
    two-parameter LTC of Zeltner et al. 2022, module docstring). Inside ``on_cluster`` (or
    ``--cluster``) parts of the cells are fitted on the workers, with the local result."""
    if form not in FORMS:
        raise ParameterError(f"form={form!r} is not valid: choose one of {', '.join(FORMS)}")
    samples = check_int("samples", samples, 16, 1 << 24, "[16, 2^24]")
    if samples % 16:
        raise ParameterError(f"samples={samples} is not valid: give a multiple of 16")
    report_samples = check_int("report_samples", report_samples, 16, 1 << 28, "[16, 2^28]")
    max_iter = check_int("max_iter", max_iter, 1, 100000)
    restarts = check_int("restarts", restarts, 0, 100)
    magnitude_tol = check_magnitude_tol(magnitude_tol)
    t0 = time.perf_counter()
    grid = _Grid(name, axes, fixed, precision, device, width, form)
    spec = dict(name=name, axes=axes, fixed=fixed, precision=precision, width=grid.model.width,
                form=form, samples=samples, report_samples=report_samples, seed=seed,
                max_iter=max_iter, restarts=restarts, magnitude_tol=magnitude_tol)
    parts = (_PARTS.get() or _local_parts)(grid, spec)
    grid.check_not_empty(np.concatenate([p["empty"] for p in parts]))
    its = np.concatenate([p["its"] for p in parts])
    secs = {k: round(sum(p[k] for p in parts), 3)
            for k in ("seconds_moments", "seconds_fit", "seconds_report")}
    meta = {"fit": ("Nelder-Mead on (log a, b), M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]] in the "
                    "normal's frame, X toward wo (Zeltner et al. 2022)" if form == "zeltner" else
                    "Nelder-Mead on (log a, log b, c, t), M = [X Y Z] Ry(t) [[a, 0, c], "
                    "[0, b, 0], [0, 0, 1]], from the best of the moment starts and the Zeltner "
                    "form's fit" if grid.isotropic else
                    "Nelder-Mead on (log a, log b, c, t, d, psi), M = [X Y Z] Ry(t) Rz(psi) "
                    "[[a, 0, c], [0, b, d], [0, 0, 1]]") + " (clbrdf/tables/ltc.py)",
            "loss": "L3 = int |f cos / E - D|^3 dw, MIS of the lobe's and the LTC's samples",
            "form": form, "samples": samples, "max_iter": max_iter, "restarts": restarts,
            "iterations_max": int(its.max()), "iterations_mean": round(float(its.mean()), 2),
            "loss_evaluations": sum(p["evaluations"] for p in parts), "parts": len(parts),
            "seconds": round(time.perf_counter() - t0, 3), **secs,
            **({"command": command} if command else {})}
    return _table(grid, spec, parts, meta)


def ltc_errors(name: str, axes: dict, minv, *, report_samples: int = 1 << 16, seed: int = 0,
               precision: str = "single", device=None, width: int | None = None,
               magnitude_tol: float = MAGNITUDE_TOL, **fixed):
    """The errors of given LTCs (``minv`` (..., 3, 3) over the grid of ``axes``, e.g. a shipped
    table's) under fit_ltc's metrics, with the same samples fit_ltc reports with: a Table as
    fit_ltc's, with these matrices."""
    grid = _Grid(name, axes, fixed, precision, device, width)
    c = _Cells(grid, 0, grid.n, report_samples, seed, check_magnitude_tol(magnitude_tol))
    minv = np.asarray(minv, float).reshape(c.n, 3, 3)
    spec = {"report_samples": report_samples, "seed": seed}
    return _table(grid, spec, [{**c.result(minv, c.errors(minv)), "how": c.how}],
                  {"fit": "given matrices"})


def ltc_matrix(table, *index) -> np.ndarray:
    """The normalised M^-1 (3, 3) of one cell of a fit_ltc table (or (..., 3, 3) for all)."""
    v = np.stack([table[k] for k in ENTRIES], axis=-1)
    v = v[index] if index else v
    return v.reshape(v.shape[:-1] + (3, 3))


__all__ = ["fit_ltc", "fit_ltc_part", "ltc_errors", "ltc_matrix", "nelder_mead", "using_ltc_parts"]
