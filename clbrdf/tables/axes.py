"""Axes of tables and sweeps: the one parser of ``NAME=...`` axis text, spacings, sample
placement, and the mapped axes that renderers' tables use.

    NAME=START:STOP:COUNT[:SPACING][:PLACEMENT][:min=LO][:max=HI]    a grid of COUNT values
    NAME=START:STOP[:SPACING]                                a range (random points of a sweep)
    NAME=v1,v2,...                                           a list of values

SPACING is ``lin`` (default), ``log`` or ``sqrt`` (values equally spaced in sqrt(value));
PLACEMENT is ``nodes`` (default: position t = i / (COUNT - 1), both ends included) or ``centres``
(t = (i + 0.5) / COUNT, the texel centres of a texture of COUNT texels over [START, STOP]); the
value is the spacing's map of t onto [START, STOP]. ``min=LO`` evaluates the model at
max(value, LO) while the axis keeps the value (Cycles' table has a row mu = 0 computed at
mu = 1e-4), ``max=HI`` at min(value, HI) (Cycles' glass tables: z = 1 computed at 0.99).

Mapped axes (``MAPPED``) name a quantity that the model takes in another form: ``r`` is the
roughness with alpha = r^2 (Cycles, Filament, UE, OSPRay: "perceptual" roughness; also Adobe's
sqrt(alpha) axis), ``theta`` is the polar angle of wo in radians with mu = cos(theta) (MDL's
theta-linear axis), ``sqrt1m_mu`` the view axis v = sqrt(1 - mu) of the LTC tables of Heitz
et al. 2016 (ltc_code, three.js), mu = 1 - v^2; ``ior_z`` and ``inv_ior_z`` the index of refraction's axis of Cycles' glass
tables, z = F0^(1/4) = sqrt((ior - 1)/(ior + 1)), with eta = ior = (1 + z^2)/(1 - z^2)
(entering, ``ior_z``) or eta = 1/ior (exiting, ``inv_ior_z``; a wo above a surface of relative
index 1/ior is a wo below one of ior); ``inv_eta`` an index of refraction given by its
reciprocal, eta = 1 / v (the exiting tables of UE5 and MoonRay, indexed by the ior of the glass
that wo is inside); ``exponent_z`` the generalised Schlick exponent of Cycles' gen-Schlick table,
exponent = 5 (1 - z) / z (z = 1/2 is Schlick's 5), z = 1 / (exponent / 5 + 1).
"""
from __future__ import annotations

import math

import numpy as np

from ..models.spec import ParameterError, called, check_int

SPACINGS = ("lin", "log", "sqrt")
PLACEMENTS = ("nodes", "centres")
MAX_COUNT = 1_000_000

# axis name -> (the model quantity it sets, the map as a formula, the map, its inverse)
MAPPED = {
    "r": ("alpha", "alpha = r^2", lambda r: r * r, np.sqrt),
    "theta": ("mu", "mu = cos(theta)", np.cos, np.arccos),
    "sqrt1m_mu": ("mu", "mu = 1 - v^2", lambda v: 1 - v * v, lambda mu: np.sqrt(1 - mu)),
    "ior_z": ("eta", "eta = (1 + z^2) / (1 - z^2)", lambda z: (1 + z * z) / (1 - z * z),
              lambda e: np.sqrt((e - 1) / (e + 1))),
    "inv_ior_z": ("eta", "eta = (1 - z^2) / (1 + z^2)", lambda z: (1 - z * z) / (1 + z * z),
                  lambda e: np.sqrt((1 - e) / (1 + e))),
    "inv_eta": ("eta", "eta = 1 / v", lambda v: 1 / v, lambda e: 1 / e),
    "exponent_z": ("exponent", "exponent = 5 (1 - z) / z", lambda z: 5 * (1 - z) / z,
                   lambda e: 1 / (0.2 * e + 1)),
}

VIEW = ("mu",) + tuple(k for k, m in MAPPED.items() if m[0] == "mu")   # axes of wo's polar angle

FORM = ("expected NAME=START:STOP:COUNT[:lin|log|sqrt][:nodes|centres][:min=LO][:max=HI], "
        "NAME=START:STOP[:SPACING] (random points) or NAME=v1,v2,...")


def parse_axis(text: str) -> dict:
    """Axis text (module docstring) -> an axis dict: ``name`` and either ``values`` or
    ``start``, ``stop`` and optional ``count``, ``spacing``, ``placement``, ``min``."""
    name, sep, rest = text.partition("=")
    name, rest = name.strip(), rest.strip()
    if not sep or not name or not rest:
        raise ParameterError(f"{called('axis')} {text!r} is malformed: {FORM}")

    def num(s, what):
        try:
            v = float(s)
        except ValueError:
            raise ParameterError(f"{called('axis')} {text!r}: {what}={s.strip()!r} is not a number "
                                 f"({FORM})") from None
        if not math.isfinite(v):
            raise ParameterError(f"{called('axis')} {text!r}: {what}={v!r} is not finite")
        return v
    if ":" not in rest:
        return {"name": name, "values": [num(s, "value") for s in rest.split(",")]}
    fields = [s.strip() for s in rest.split(":")]
    ax = {"name": name}
    nums = []
    for f in fields:
        if f in SPACINGS:
            ax["spacing"] = f
        elif f in PLACEMENTS or f == "centers":
            ax["placement"] = "centres" if f == "centers" else f
        elif f.startswith("min="):
            ax["min"] = num(f[4:], "min")
        elif f.startswith("max="):
            ax["max"] = num(f[4:], "max")
        elif len(nums) < 3 and not ({"spacing", "placement", "min", "max"} & set(ax)):
            nums.append(f)
        else:
            raise ParameterError(f"{called('axis')} {text!r}: {f!r} is not a spacing ({', '.join(SPACINGS)}),"
                                 f" a placement ({', '.join(PLACEMENTS)}), min=LO or max=HI "
                                 f"({FORM})")
    if len(nums) not in (2, 3):
        raise ParameterError(f"{called('axis')} {text!r} is malformed: {FORM}")
    ax["start"], ax["stop"] = num(nums[0], "START"), num(nums[1], "STOP")
    if len(nums) == 3:
        try:
            ax["count"] = int(nums[2])
        except ValueError:
            raise ParameterError(f"{called('axis')} {text!r}: COUNT={nums[2]!r} is not an integer: valid "
                                 f"COUNT is in [1, {MAX_COUNT}]") from None
    return ax


def axis_from_python(name, v) -> dict:
    """Python forms: a tuple (start, stop, count[, spacing[, placement]]) or (start, stop[,
    spacing]) with random points, a string as on the command line, a list or array of values,
    or a dict."""
    if isinstance(v, dict):
        return {"name": name, **v}
    if isinstance(v, str):
        return parse_axis(f"{name}={v}")
    if isinstance(v, tuple):
        rest = list(v)
        ax = {"name": name}
        while rest and isinstance(rest[-1], str):
            w = rest.pop()
            ax["placement" if w in PLACEMENTS else "spacing"] = w
        if len(rest) not in (2, 3):
            raise ParameterError(f"{called('axis')} {name}={v!r} is malformed: give (start, stop, count[, "
                                 f"spacing[, placement]]), (start, stop[, spacing]) with random "
                                 f"points, or a list of values")
        ax["start"], ax["stop"] = float(rest[0]), float(rest[1])
        if len(rest) == 3:
            ax["count"] = rest[2]
        return ax
    return {"name": name, "values": np.asarray(v, dtype=np.float64).reshape(-1).tolist()}


def positions(count: int, placement: str) -> np.ndarray:
    """Where COUNT samples lie in [0, 1]: nodes i / (COUNT - 1) or texel centres (i + 0.5) / COUNT."""
    i = np.arange(count, dtype=np.float64)
    if placement == "centres":
        return (i + 0.5) / count
    return i / (count - 1) if count > 1 else np.zeros(1)


def grid_values(start, stop, count, spacing="lin", placement="nodes") -> np.ndarray:
    """COUNT values from START to STOP with the spacing and placement (module docstring)."""
    if placement == "nodes":     # numpy's own forms: exact end points
        if spacing == "log":
            return np.geomspace(start, stop, count)
        if spacing == "sqrt":
            return np.linspace(math.sqrt(start), math.sqrt(stop), count) ** 2
        return np.linspace(start, stop, count)
    return warp(positions(count, placement), start, stop, spacing)


def warp(u, start, stop, spacing):
    """Map u in [0, 1] onto [start, stop] with the axis spacing."""
    if spacing == "log":
        return start * (stop / start) ** u
    if spacing == "sqrt":
        return (math.sqrt(start) + (math.sqrt(stop) - math.sqrt(start)) * u) ** 2
    return start + (stop - start) * u


def unwarp(v, start, stop, spacing):
    """The inverse of ``warp``: where a value lies on its axis, in [0, 1]."""
    v = np.asarray(v, dtype=np.float64)
    if stop == start:
        return np.zeros_like(v)
    if spacing == "log":
        return np.log(v / start) / math.log(stop / start)
    if spacing == "sqrt":
        return (np.sqrt(v) - math.sqrt(start)) / (math.sqrt(stop) - math.sqrt(start))
    return (v - start) / (stop - start)


def check_form(ax: dict, random: bool = False) -> dict:
    """The axis with its spacing, placement and values checked (not yet against a model):
    ``values`` filled in for a grid; a range keeps start/stop for random points."""
    name = ax["name"]
    spacing = ax.get("spacing", "lin")
    placement = ax.get("placement", "nodes")
    is_list = "values" in ax and ax.get("start") is None
    if spacing not in SPACINGS and not (is_list and spacing == "list"):
        raise ParameterError(f"{called('axis')} {name}: spacing={spacing!r} is not valid: choose one of "
                             f"{', '.join(SPACINGS)}")
    if placement not in PLACEMENTS:
        raise ParameterError(f"{called('axis')} {name}: placement={placement!r} is not valid: choose one of "
                             f"{', '.join(PLACEMENTS)}")
    extra = {k: ax[k] for k in ("min", "max") if ax.get(k) is not None}
    for k in extra:
        if not math.isfinite(float(extra[k])):
            raise ParameterError(f"{called('axis')} {name}: {k}={extra[k]!r} is not finite")
    if is_list:
        if random:
            raise ParameterError(f"{called('axis')} {name} is a list of values: random points need a range "
                                 f"START:STOP")
        v = np.asarray(ax["values"], dtype=np.float64)
        if v.ndim != 1 or v.size == 0 or not np.all(np.isfinite(v)):
            raise ParameterError(f"{called('axis')} {name} must be a non-empty list of finite numbers")
        return {"name": name, "values": v.tolist(), "spacing": "list", **extra}
    start, stop = float(ax["start"]), float(ax["stop"])
    if spacing == "log" and (start <= 0 or stop <= 0):
        raise ParameterError(f"{called('axis')} {name}: log spacing needs START and STOP > 0, got "
                             f"{start if start <= 0 else stop!r}: valid is (0, inf)")
    if spacing == "sqrt" and (start < 0 or stop < 0):
        raise ParameterError(f"{called('axis')} {name}: sqrt spacing needs START and STOP >= 0, got "
                             f"{start if start < 0 else stop!r}")
    if random:
        if ax.get("count") is not None:
            raise ParameterError(f"{called('axis')} {name}: with random points give START:STOP[:SPACING], "
                                 f"not a COUNT ({ax['count']})")
        return {"name": name, "start": start, "stop": stop, "spacing": spacing, **extra}
    count = ax.get("count")
    if count is None:
        raise ParameterError(f"{called('axis')} {name}: a grid axis needs a COUNT (START:STOP:COUNT) or "
                             f"a list of values; or use random points ({called('random')}=N)")
    count = check_int(f"{called('axis')} {name} COUNT", count, 1, MAX_COUNT)
    out = {"name": name, "start": start, "stop": stop, "count": count, "spacing": spacing}
    if placement != "nodes":
        out["placement"] = placement
    out["values"] = grid_values(start, stop, count, spacing, placement).tolist()
    return {**out, **extra}


def midpoints(ax: dict) -> list:
    """The coordinates halfway between neighbouring samples in the lookup's index space (where
    linear interpolation is least accurate): warp((i + 1/2) / (N - 1)) for nodes, warp((i + 1) / N)
    for texel centres, (v_i + v_i+1) / 2 for a list; N - 1 values (none for N = 1)."""
    v = np.asarray(ax["values"], dtype=np.float64)
    n = len(v)
    if n < 2:
        return []
    if ax.get("spacing") == "list" or "count" not in ax:
        return ((v[1:] + v[:-1]) / 2).tolist()
    i = np.arange(n - 1, dtype=np.float64)
    u = (i + 1) / n if ax.get("placement") == "centres" else (i + 0.5) / (n - 1)
    return warp(u, ax["start"], ax["stop"], ax["spacing"]).tolist()


def evaluated(ax: dict) -> np.ndarray:
    """The values the model is evaluated at: value clamped to [min, max], through the map of a
    mapped axis."""
    v = np.asarray(ax["values"], dtype=np.float64)
    if ax.get("min") is not None:
        v = np.maximum(v, float(ax["min"]))
    if ax.get("max") is not None:
        v = np.minimum(v, float(ax["max"]))
    if ax["name"] in MAPPED:
        v = MAPPED[ax["name"]][2](v)
    return v


def describe(ax: dict) -> str:
    """One line: 'alpha = r^2, r: 0 .. 1, 32 nodes, lin, evaluated at r >= 0.01'."""
    n = ax["name"]
    if ax.get("spacing") == "list":
        v = ax["values"]
        s = f"{n}: {len(v)} values {', '.join(f'{x:g}' for x in v[:6])}{', ...' if len(v) > 6 else ''}"
    elif "count" in ax:
        s = (f"{n}: {ax['start']:g} .. {ax['stop']:g}, {ax['count']} "
             f"{ax.get('placement', 'nodes')}, {ax['spacing']}")
    else:
        s = f"{n}: {ax['start']:g} .. {ax['stop']:g}, {ax['spacing']}"
    if ax.get("min") is not None:
        s += f", evaluated at {n} >= {ax['min']:g}"
    if ax.get("max") is not None:
        s += f", evaluated at {n} <= {ax['max']:g}"
    if n in MAPPED:
        s += f" ({MAPPED[n][1]})"
    return s


def axis_text(ax: dict) -> str:
    """The axis as text (``parse_axis`` reads it back): 'alpha=0.1:1:4:log', 'mu=0.5,1'."""
    if ax.get("spacing") == "list" or ax.get("start") is None:
        return f"{ax['name']}=" + ",".join(f"{v:g}" for v in ax["values"])
    parts = [f"{ax['start']:g}", f"{ax['stop']:g}"]
    if ax.get("count") is not None:
        parts.append(str(ax["count"]))
    if ax.get("spacing", "lin") != "lin":
        parts.append(ax["spacing"])
    if ax.get("placement", "nodes") != "nodes":
        parts.append(ax["placement"])
    for k in ("min", "max"):
        if ax.get(k) is not None:
            parts.append(f"{k}={ax[k]:g}")
    return f"{ax['name']}=" + ":".join(parts)
