"""``Table``: every table the tool makes, in one type.

A table is one or more quantities (``quantity``: channel labels, interleaved last) over axes in
memory order (slowest first), as stored (``raw``, in its ``encoding``), with the standard error
of every value, the samples per cell where refinement made them differ, metadata (``meta``:
what it is and how it was computed) and, for a table of directional albedo E, its average
E_avg over the parameter axes (``average``, a Table). ``albedo_table`` and ``make_layout``
return them; ``save_tables`` and ``load_tables`` (clbrdf.tables.files) write and read them.

``Table.lookup`` interpolates as the consumer does: multilinear in the continuous index of each
axis, clamped to the table (nodes: index = u (N - 1); texel centres: index = u N - 1/2, the
GPU's bilinear filter with clamp-to-edge), u the position of the coordinate on its axis
(clbrdf.tables.axes.unwarp; a list of values: piecewise linear in the value). A coordinate
outside an axis' range warns (``TableRangeWarning``) unless ``outside="clamp"`` (quiet, as a
renderer) or ``"raise"``.

``t["E"]``, ``t["E_stderr"]``, ``t["alpha"]``, ``t["E_avg"]``: the named arrays (``keys()``);
``t.to_xarray()``: an ``xarray.Dataset`` (``pip install 'clbrdf[xarray]'``).
"""
from __future__ import annotations

import csv
import glob
import io
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..models.spec import ParameterError
from .axes import MAPPED, VIEW, grid_values, parse_axis, unwarp

OUTSIDE = ("warn", "clamp", "raise")     # Table.lookup outside the table's range


class TableRangeWarning(UserWarning):
    """A table was read outside its axes' range (Table.lookup): the value at the edge is used."""


FORMAT = "clbrdf-tables/2"
FORMATS_READ = ("clbrdf-tables/1", FORMAT)  # 1: the layout tables of clbrdf 0.1.0
ENCODINGS = ("float32", "float16", "unorm16", "float64")
DIRECTION_AXES = VIEW + ("phi",)
CHANNELS = ("R", "G", "B")


def encode(values: np.ndarray, encoding: str) -> np.ndarray:
    """The consumer's stored form of values in [0, 1] (float16 and unorm16 round to nearest)."""
    if encoding == "float64":
        return np.asarray(values, dtype=np.float64)
    if encoding == "float32":
        return values.astype(np.float32)
    if encoding == "float16":
        return values.astype(np.float16)
    if encoding == "unorm16":
        return np.round(np.clip(values, 0, 1) * 65535).astype(np.uint16)
    raise ParameterError(f"encoding={encoding!r} is not valid: choose one of {', '.join(ENCODINGS)}")


def decode(raw: np.ndarray, encoding: str) -> np.ndarray:
    """What the consumer reads from the stored form, as float64."""
    if encoding == "unorm16":
        return raw.astype(np.float64) / 65535
    return raw.astype(np.float64)


@dataclass
class Table:
    name: str
    axes: list                      # axis dicts (clbrdf.tables.axes) with "values", memory order
    quantity: list                  # channel labels: ["E"], ["A", "B", "E"], ["E.R", "E.G", "E.B"]
    raw: np.ndarray                 # stored values: shape of the axes (+ channels if > 1)
    stderr: np.ndarray              # standard error of each value before encoding
    encoding: str = "float32"
    meta: dict = field(default_factory=dict)
    samples: np.ndarray | None = None   # samples per cell (axes shape) where refinement ran
    average: "Table | None" = None      # E_avg over the parameter axes, for a table of E

    @property
    def values(self) -> np.ndarray:
        """What the consumer reads (decoded, float64)."""
        return decode(self.raw, self.encoding)

    @property
    def shape(self) -> tuple:
        return tuple(len(a["values"]) for a in self.axes)

    @property
    def axis_names(self) -> list:
        return [a["name"] for a in self.axes]

    @property
    def computed(self) -> dict:
        """How the values were computed (model, parameters, estimator, samples, device, ...)."""
        return self.meta.get("computed", {})

    # ---- named arrays ----
    def groups(self) -> dict:
        """{name: channel indices}: an RGB quantity's labels Q.R, Q.G, Q.B form one group Q."""
        out: dict = {}
        for i, q in enumerate(self.quantity):
            g = q.rsplit(".", 1)[0] if q.rsplit(".", 1)[-1] in CHANNELS and "." in q else q
            out.setdefault(g, []).append(i)
        return out

    def _channels(self, a, idx):
        if len(self.quantity) == 1:
            return a
        return a[..., idx[0]] if len(idx) == 1 else a[..., idx]

    def keys(self) -> list:
        own = self.axis_names + [k for g in self.groups() for k in (g, g + "_stderr")]
        if self.samples is not None:
            own += [g + "_samples" for g in self.groups()]
        return own + ([k for k in self.average.keys() if k not in own] if self.average else [])

    def __getitem__(self, key: str) -> np.ndarray:
        if key in self.axis_names:
            return np.asarray(self.axes[self.axis_names.index(key)]["values"], dtype=np.float64)
        groups = self.groups()
        for suffix, arr in (("", None), ("_stderr", self.stderr)):
            g = key[:len(key) - len(suffix)] if suffix and key.endswith(suffix) else key
            if (suffix == "" or key.endswith(suffix)) and g in groups:
                return self._channels(self.values if arr is None else np.asarray(arr), groups[g])
        if key.endswith("_samples") and key[:-8] in groups and self.samples is not None:
            return np.asarray(self.samples)         # per cell, the same for every channel
        if self.average is not None and key in self.average.keys():
            return self.average[key]
        raise KeyError(f"table {self.name} has no {key!r}: it has {', '.join(self.keys())}")

    def __contains__(self, key) -> bool:
        return key in self.keys()

    # ---- lookup ----
    def axis_range(self, axis: int) -> tuple:
        """(lo, hi): the coordinates axis ``axis`` covers (its start and stop; a list of values:
        their least and greatest). Between a texel-centred axis' ends and its outer centres the
        lookup clamps to the edge texel as a GPU does: that is inside the table."""
        a = self.axes[axis]
        if a.get("spacing") == "list" or "count" not in a:
            v = np.asarray(a["values"], dtype=np.float64)
            return float(v.min()), float(v.max())
        return float(min(a["start"], a["stop"])), float(max(a["start"], a["stop"]))

    def outside(self, axis: int, x) -> np.ndarray:
        """Where coordinate x lies outside the axis' range (``axis_range``; a relative 1e-12
        of slack for rounding)."""
        lo, hi = self.axis_range(axis)
        slack = 1e-12 * max(abs(lo), abs(hi), 1.0)
        x = np.asarray(x, dtype=np.float64)
        return (x < lo - slack) | (x > hi + slack)

    def index(self, axis: int, x) -> np.ndarray:
        """The continuous, clamped index of coordinate x on axis ``axis``."""
        a = self.axes[axis]
        n = len(a["values"])
        x = np.asarray(x, dtype=np.float64)
        if np.isnan(x).any():
            raise ParameterError(f"table {self.name}: coordinate {a['name']} is NaN; valid is "
                                 f"any number (clamped to the axis, as the C lookup does)")
        if a.get("spacing") == "list" or "count" not in a:
            v = np.asarray(a["values"], dtype=np.float64)
            if n == 1:
                return np.zeros_like(x)
            if v[0] > v[-1]:
                return np.interp(-x, -v, np.arange(n, dtype=np.float64))
            return np.interp(x, v, np.arange(n, dtype=np.float64))
        # clamp the coordinate, not only the index: a sqrt or log axis has no index below 0
        x = np.clip(x, min(a["start"], a["stop"]), max(a["start"], a["stop"]))
        u = unwarp(x, a["start"], a["stop"], a["spacing"])
        i = u * n - 0.5 if a.get("placement") == "centres" else u * (n - 1)
        return np.clip(i, 0, n - 1)

    def lookup(self, *coords, outside: str = "warn", **named) -> np.ndarray:
        """Interpolated values at coordinates given in axis order or by axis name (they
        broadcast); the channels (several quantities) on a last axis.

        A coordinate outside its axis' range (``axis_range``) is clamped to it, as a renderer's
        lookup (and the C header's) does; ``outside`` says what else happens: "warn" (default)
        a ``TableRangeWarning`` naming the table, axis, value and range; "clamp" nothing (the
        renderer's behaviour); "raise" a ParameterError, before any value is computed."""
        if outside not in OUTSIDE:
            raise ParameterError(f"outside={outside!r} is not valid: choose one of "
                                 f"{', '.join(OUTSIDE)}")
        names = self.axis_names
        if coords and named:
            raise ParameterError("give the coordinates in axis order or by name, not both")
        if named:
            missing = [n for n in names if n not in named]
            extra = [n for n in named if n not in names]
            if missing or extra:
                raise ParameterError(f"table {self.name} has axes {', '.join(names)}; "
                                     f"got {', '.join(named)}")
            coords = [named[n] for n in names]
        if len(coords) != len(names):
            raise ParameterError(f"table {self.name} has {len(names)} axes ({', '.join(names)}), "
                                 f"got {len(coords)} coordinates")
        if outside != "clamp":
            self._check_range(coords, outside)
        idx = np.broadcast_arrays(*[self.index(d, c) for d, c in enumerate(coords)])
        data = self.values
        nc = len(self.quantity)
        if nc == 1:
            data = data[..., None]
        out = np.zeros(idx[0].shape + (nc,))
        lo = [np.minimum(np.floor(i).astype(np.int64), n - 1) for i, n in zip(idx, self.shape)]
        fr = [i - l for i, l in zip(idx, lo)]
        for corner in range(1 << len(names)):
            w = np.ones(idx[0].shape)
            sel = []
            for d, n in enumerate(self.shape):
                up = (corner >> d) & 1
                sel.append(np.minimum(lo[d] + up, n - 1))
                w = w * (fr[d] if up else 1 - fr[d])
            out += w[..., None] * data[tuple(sel)]
        return out[..., 0] if nc == 1 else out

    def _check_range(self, coords, outside: str) -> None:
        for d, c in enumerate(coords):
            c = np.asarray(c, dtype=np.float64)
            out = self.outside(d, c)
            if not out.any():
                continue
            lo, hi = self.axis_range(d)
            far = c[out]
            worst = float(far[np.argmax(np.maximum(lo - far, far - hi))])
            name = self.axes[d]["name"]
            msg = (f"table {self.name}: {name}={worst:g} is outside the table's {name} range "
                   f"[{lo:g}, {hi:g}]" + (f" ({int(out.sum())} of {out.size} coordinates)"
                                          if out.size > 1 else ""))
            if outside == "raise":
                raise ParameterError(msg)
            warnings.warn(msg + f": the value at {name}={min(max(worst, lo), hi):g} is used "
                          f"(clamped, as a renderer's lookup does; lookup(outside='clamp') "
                          f"clamps quietly, 'raise' refuses)", TableRangeWarning, stacklevel=3)

    # ---- description ----
    def to_json(self) -> dict:
        """Metadata: axes (without values), quantity, encoding, and how it was computed."""
        return {"name": self.name, "quantity": self.quantity, "encoding": self.encoding,
                "shape": list(self.shape),
                "axes": [{k: v for k, v in a.items() if k != "values"} for a in self.axes],
                "stderr_max": float(np.max(self.stderr)) if np.size(self.stderr) else 0.0,
                **{k: v for k, v in self.meta.items() if k not in ("name", "quantity",
                                                                    "encoding")}}

    def __repr__(self):
        avg = f", average {self.average.name}" if self.average is not None else ""
        return (f"Table({self.name!r}, {', '.join(self.quantity)} over "
                f"{' x '.join(f'{n} ({len(a)})' for n, a in zip(self.axis_names, (a['values'] for a in self.axes)))}"
                f", {self.encoding}{avg})")

    def to_xarray(self):
        """An ``xarray.Dataset``: each quantity and its ``_stderr`` (and ``_samples``) as
        variables over named dimensions (``channel`` for an RGB quantity), the axes as
        coordinates with their spacing, placement and mapping as attributes, the average's
        variables over its own axes, and the metadata as JSON in ``attrs["clbrdf"]``."""
        try:
            import xarray as xr
        except ImportError:
            raise ImportError("Table.to_xarray needs xarray: pip install 'clbrdf[xarray]'") \
                from None
        data, coords = {}, {}
        for t in [self] + ([self.average] if self.average is not None else []):
            dims = t.axis_names
            for a in t.axes:
                attrs = {k: (json.dumps(v) if isinstance(v, (list, dict)) or v is None else v)
                         for k, v in a.items() if k not in ("values", "name")}
                if a["name"] in MAPPED:
                    attrs["mapping"] = MAPPED[a["name"]][1]
                coords[a["name"]] = (a["name"], np.asarray(a["values"], np.float64), attrs)
            for g, idx in t.groups().items():
                multi = len(idx) > 1
                d = dims + (["channel"] if multi else [])
                if multi:
                    coords["channel"] = ("channel", [t.quantity[i].rsplit(".", 1)[1] for i in idx])
                data[g] = (d, t[g])
                data[g + "_stderr"] = (d, t[g + "_stderr"])
                if t.samples is not None:
                    data[g + "_samples"] = (dims, np.asarray(t.samples))
        return xr.Dataset(data, coords=coords,
                          attrs={"clbrdf": json.dumps(self.to_json(), default=str),
                                 "name": self.name, "encoding": self.encoding})

    @staticmethod
    def load(path, name: str | None = None) -> "Table":
        """The table ``name`` of a file the tool wrote (``load_tables``; the only one if not
        given: a table's average comes with it)."""
        tables = load_tables(path)
        if name is None:
            if len(tables) != 1:
                raise ParameterError(f"{str(path)!r} holds tables {', '.join(tables)}: give name=")
            return next(iter(tables.values()))
        if name not in tables:
            raise ParameterError(f"{str(path)!r} has no table {name!r}: it holds "
                                 f"{', '.join(tables)}")
        return tables[name]


def from_albedo(arrays: dict, meta: dict) -> Table:
    """The Table of ``albedo_table``'s arrays (E, E_stderr, one array per axis, E_samples; A,
    B with ``split``; E_avg, E_avg_stderr, E_avg_samples ...) and its metadata: the table "E"
    (quantities E; A, B, E when split; E.R, E.G, E.B for an RGB model) with its average
    "E_avg". Also reads the plain .npz tables of clbrdf 0.1.0."""
    names = [a for a in meta["axes"] if a != "channel"]
    rgb = "channel" in meta["axes"]
    specs = {a["name"]: a for a in meta.get("axis_specs", [])}

    def axis(n):
        base = specs.get(n, {"name": n, "spacing": meta.get("spacing", {}).get(n, "list")})
        return dict(base, values=np.asarray(arrays[n], np.float64).tolist())
    qs = ["A", "B", "E"] if "split" in meta else ["E"]

    def table(name, axes, suffix):
        if len(qs) > 1:
            labels = [q + suffix for q in qs]
            raw = np.stack([np.asarray(arrays[q + suffix], np.float64) for q in qs], -1)
            err = np.stack([np.asarray(arrays[q + suffix + "_stderr"], np.float64) for q in qs], -1)
        else:
            labels = [f"E{suffix}.{c}" for c in CHANNELS] if rgb else ["E" + suffix]
            raw = np.asarray(arrays["E" + suffix], np.float64)
            err = np.asarray(arrays["E" + suffix + "_stderr"], np.float64)
        s = arrays.get("E" + suffix + "_samples")
        return Table(name=name, axes=axes, quantity=labels, raw=raw, stderr=err,
                     encoding="float64", samples=None if s is None else np.asarray(s))
    t = table("E", [axis(n) for n in names], "")
    t.meta = {"computed": meta}
    if "E_avg" in arrays or "A_avg" in arrays:
        t.average = table("E_avg", [axis(n) for n in names if n not in DIRECTION_AXES], "_avg")
        t.average.meta = {"average_of": "E", "how": meta.get("E_avg", "")}
    return t


# ---------------------------------------------------------------------------------------------
# reading the files the tool writes (clbrdf.tables.files writes them)

def _tables_from_json(meta: dict, array) -> dict:
    """{name: Table} from a file's metadata and ``array(key)``; averages attached to their table."""
    out = {}
    for name, m in meta["tables"].items():
        axes = [dict(a, values=np.asarray(array(f"{name}.axis.{a['name']}"), np.float64).tolist())
                for a in m["axes"]]
        t = Table(name=name, axes=axes, quantity=m["quantity"], raw=array(name),
                  stderr=array(f"{name}.stderr"), encoding=m["encoding"],
                  samples=array(f"{name}.samples") if m.get("samples") else None,
                  meta={k: v for k, v in m.items() if k not in (
                      "axes", "shape", "stderr_max", "samples", "average")})
        _check_shapes(t, m)
        out[name] = t
    for name, t in list(out.items()):
        of = t.meta.get("average_of")
        if of in out:
            out[of].average = out.pop(name)
    return out


def _check_shapes(t: Table, m: dict) -> None:
    """Every stored array against the table's metadata, before any use: a file whose arrays
    disagree with it is refused naming the table and the array."""
    want = tuple(m.get("shape", t.shape))
    if tuple(t.shape) != want:
        raise ParameterError(f"table {t.name}: its axes have {t.shape} values, its metadata says "
                             f"{want}")
    full = want + ((len(t.quantity),) if len(t.quantity) > 1 else ())
    for what, a in (("values", t.raw), ("stderr", t.stderr)):
        if np.shape(a) != full:
            raise ParameterError(f"table {t.name}: its {what} array has shape {np.shape(a)}, its "
                                 f"axes and quantities ({', '.join(t.quantity)}) need {full}")
    if t.samples is not None and np.shape(t.samples) != want:
        raise ParameterError(f"table {t.name}: its samples array has shape {np.shape(t.samples)}, "
                             f"its axes need {want}")
    if t.encoding not in ENCODINGS:
        raise ParameterError(f"table {t.name}: encoding {t.encoding!r} is not one of "
                             f"{', '.join(ENCODINGS)}")


def from_ltc_layout(meta: dict, arrays: dict, axes_values: dict | None = None) -> dict:
    """{name: Table} of an LTC layout's file as clbrdf wrote it before its tables had one
    format (.npz: a "meta" entry; .exr: parts with a "clbrdf_ltc" header): each texture as a
    table of its channels, and the fit's E, B, L3, L1 with their standard errors as "ltc"."""
    comp = meta.get("computed", {})
    names = comp.get("axes") or [t.partition("=")[0] for t in meta["axes"]]
    if axes_values is None:             # .exr: the layout's axis texts give the values
        axes_values = {}
        for text in meta["axes"]:
            a = parse_axis(text)
            axes_values[a["name"]] = grid_values(a["start"], a["stop"], a["count"],
                                                 a.get("spacing", "lin"),
                                                 a.get("placement", "nodes"))
    axes = [{"name": n, "spacing": "list", "values": np.asarray(axes_values[n], float).tolist()}
            for n in names]
    out = {}
    for k, chans in meta["textures"].items():
        raw = np.asarray(arrays[k], np.float32)
        out[k] = Table(name=k, axes=[dict(a) for a in axes], quantity=list(chans), raw=raw,
                       stderr=np.zeros(raw.shape), encoding="float32",
                       meta={"texture": {"layout": meta["layout"],
                                         "planar": bool(meta.get("planar")), "of": "ltc"}})
    q = ["E", "B", "L3", "L1"]
    out["ltc"] = Table(name="ltc", axes=axes, quantity=q,
                       raw=np.stack([np.asarray(arrays[x], np.float32) for x in q], -1),
                       stderr=np.stack([np.asarray(arrays[x + "_stderr"], float) for x in q], -1),
                       encoding="float32", meta={"computed": comp, "layout": meta["layout"]})
    for t in out.values():
        _check_shapes(t, {})
    return out


def _load_npz(path) -> dict:
    with open(path, "rb") as f:
        if f.read(4) != b"PK\x03\x04":   # an .npz is a zip archive; NumPy would try a pickle
            raise ParameterError(f"{str(path)!r} is not a clbrdf table file: not a zip archive "
                                 f"(an .npz is one)")
    with np.load(path, allow_pickle=False) as z:
        if "metadata" not in z.files and "meta" in z.files:     # an LTC layout before 0.2
            meta = json.loads(str(z["meta"]))
            arrays = {k: z[k] for k in z.files if k != "meta"}
            return from_ltc_layout(meta, arrays, {n: arrays[n] for n in meta["computed"]["axes"]})
        meta = json.loads(str(z["metadata"]))
        if isinstance(meta, dict) and meta.get("format") in FORMATS_READ:
            return _tables_from_json(meta, lambda k: z[k])
        if isinstance(meta, dict) and "axes" in meta and "E" in z.files:   # 0.1.0 plain table
            return {"E": from_albedo({k: z[k] for k in z.files if k != "metadata"}, meta)}
        raise ParameterError(f"{str(path)!r} is not a clbrdf table file (its metadata has no "
                             f"format {FORMAT})")


def openexr():
    try:
        import OpenEXR
    except ImportError:
        raise ParameterError(".exr files need the OpenEXR package: pip install 'clbrdf[exr]'") \
            from None
    return OpenEXR


def _load_exr(path) -> dict:
    OpenEXR = openexr()
    meta, arrays = {"format": FORMAT, "tables": {}}, {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        if f.parts and "clbrdf_ltc" in f.parts[0].header:      # an LTC layout before 0.2
            old = json.loads(f.parts[0].header["clbrdf_ltc"])
            arrays = {}
            for part in f.parts:
                ch = part.channels
                if part.name() == "errors":
                    arrays.update({c.replace(".stderr", "_stderr"): np.asarray(ch[c].pixels)
                                   for c in ch})
                else:
                    arrays[part.name()] = np.stack([np.asarray(ch[c].pixels) for c in "RGBA"
                                                    if c in ch], -1)
            return from_ltc_layout(old, arrays)
        for part in f.parts:
            m = json.loads(part.header["clbrdf"])
            tm = m["table"]
            name, shape = tm["name"], tuple(tm["shape"])
            vals = [np.asarray(part.channels[q].pixels, np.float64).reshape(shape)
                    for q in tm["quantity"]]
            errs = [np.asarray(part.channels[f"{q}.stderr"].pixels, np.float64).reshape(shape)
                    for q in tm["quantity"]]
            v = np.stack(vals, -1) if len(vals) > 1 else vals[0]
            arrays[name] = encode(v, tm["encoding"]) if tm["encoding"] not in (
                "float32", "float64") else v.astype(np.float32)
            arrays[f"{name}.stderr"] = np.stack(errs, -1) if len(errs) > 1 else errs[0]
            for a, vs in m["axes_values"].items():
                arrays[f"{name}.axis.{a}"] = vs
            if "samples" in part.channels:
                arrays[f"{name}.samples"] = np.asarray(part.channels["samples"].pixels,
                                                       np.float64).reshape(shape)
            meta["tables"][name] = tm
    return _tables_from_json(meta, arrays.__getitem__)


def _load_csv(path) -> dict:
    """A .csv the tool wrote: its first line ``# clbrdf-tables/2 {table json}``, then a header
    and one row per cell (axes, then each channel and its stderr, then samples)."""
    text = Path(path).read_text()
    first, _, rest = text.partition("\n")
    if not first.startswith(f"# {FORMAT} "):
        raise ParameterError(f"{str(path)!r} is not a clbrdf table file (its first line is not "
                             f"'# {FORMAT} ...')")
    m = json.loads(first[len(FORMAT) + 3:])
    rows = list(csv.reader(io.StringIO(rest)))
    header, rows = rows[0], np.asarray(rows[1:], dtype=np.float64)
    col = {h: rows[:, i] for i, h in enumerate(header)}
    shape = tuple(m["shape"])
    name = m["name"]

    def grid(key):
        return col[key].reshape(shape)
    arrays = {name: np.stack([grid(q) for q in m["quantity"]], -1) if len(m["quantity"]) > 1
              else grid(m["quantity"][0])}
    arrays[name] = encode(arrays[name], m["encoding"]) if m["encoding"] != "float32" else \
        arrays[name].astype(np.float32)
    arrays[f"{name}.stderr"] = np.stack([grid(q + "_stderr") for q in m["quantity"]], -1) \
        if len(m["quantity"]) > 1 else grid(m["quantity"][0] + "_stderr")
    for d, a in enumerate(m["axes"]):
        vals = rows[:, header.index(a["name"])].reshape(shape)
        arrays[f"{name}.axis.{a['name']}"] = np.moveaxis(vals, d, 0).reshape(shape[d], -1)[:, 0]
    if m.get("samples"):
        arrays[f"{name}.samples"] = grid("samples")
    return _tables_from_json({"tables": {name: m}}, arrays.__getitem__)


def load_tables(path) -> dict:
    """{name: Table} from a file the tool wrote: .npz (this version's and 0.1.0's both formats),
    .exr or .csv (a table's averages come back as its ``average``; a .h is for C)."""
    path = Path(path)
    suffix = path.suffix.lower()
    readers = {".npz": _load_npz, ".exr": _load_exr, ".csv": _load_csv}
    if suffix not in readers:
        raise ParameterError(f"path={str(path)!r}: tables load from {', '.join(readers)} "
                             f"(a .h is for C)")
    if suffix == ".csv" and not path.exists():     # several tables: OUT_STEM.NAME.csv each
        parts = sorted(q for q in path.parent.glob(f"{glob.escape(path.stem)}.*.csv")
                       if not q.name.endswith(".avg.csv"))
        if parts:
            tables = [t for q in parts for t in load_tables(q).values()]
            tables.sort(key=lambda t: t.meta.get("position", 0))
            for t in tables:
                t.meta.pop("position", None)
            return {t.name: t for t in tables}
    if not path.is_file():
        raise ParameterError(f"path={str(path)!r} does not exist or is not a file")
    try:
        tables = readers[suffix](path)
    except ParameterError as e:
        if str(path) in str(e):
            raise
        raise ParameterError(f"{str(path)!r}: {e}") from None
    except Exception as e:      # empty, truncated or foreign files: zipfile, OpenEXR, JSON, keys
        raise ParameterError(f"{str(path)!r} is not a readable clbrdf table file "
                             f"({type(e).__name__}: {e})") from None
    if suffix == ".csv":        # a table's average is a file of its own beside it
        avg = path.with_name(path.name[:-4] + ".avg.csv")
        if avg.is_file() and not path.name.endswith(".avg.csv"):
            for t in tables.values():
                t.average = next(iter(load_tables(avg).values()))
    return tables
