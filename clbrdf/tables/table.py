"""Albedo tables as a renderer stores them, with their lookup, and their files.

``Table``: one table (``clbrdf.layouts.compute_table``): axes in memory order (slowest first),
one or more quantities (interleaved channels, last), the stored (encoded) values, per-cell
standard errors and metadata. ``Table.lookup`` interpolates as the consumer does: multilinear in
the continuous index of each axis, clamped to the table (nodes: index = u (N - 1); texel centres:
index = u N - 1/2, the GPU's bilinear filter with clamp-to-edge), u the position of the
coordinate on its axis (clbrdf.axes.unwarp; a list of values: piecewise linear in the value).

Files (``save_tables``, ``load_tables``; written together: a kill leaves the old files or the
new ones):
- ``.npz``: per table NAME the stored array, ``NAME.stderr``, ``NAME.axis.AXIS`` and the
  metadata (JSON) of every table;
- ``.h``: a C header that compiles as C99, C++17, CUDA and OpenCL C (``clbrdf.export``);
- ``.exr``: one part per table, one channel per quantity and ``QUANTITY.stderr`` (float32; the
  leading axes stacked as rows), the metadata as a string attribute ``clbrdf``.
"""
from __future__ import annotations

import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..models.spec import ParameterError
from .axes import unwarp
from .cheader import c_header
from .outputs import _tmp_prefix, remove_stale, write_together
from .plain import check_output

FORMAT = "clbrdf-tables/1"
SUFFIXES = (".npz", ".h", ".exr")
ENCODINGS = ("float32", "float16", "unorm16")


def encode(values: np.ndarray, encoding: str) -> np.ndarray:
    """The consumer's stored form of values in [0, 1] (float16 and unorm16 round to nearest)."""
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
    axes: list                      # axis dicts (clbrdf.axes) with "values", memory order
    quantity: list                  # channel names: ["E"], ["A", "B"], an RGB model's ["E.R", "E.G", "E.B"]
    raw: np.ndarray                 # stored values: shape of the axes (+ channels if > 1)
    stderr: np.ndarray              # standard error of each value before encoding
    encoding: str = "float32"
    meta: dict = field(default_factory=dict)

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

    def lookup(self, *coords, **named) -> np.ndarray:
        """Interpolated values at coordinates given in axis order or by axis name (they
        broadcast); the channels (several quantities) on a last axis."""
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

    def to_json(self) -> dict:
        """Metadata: axes (without values), quantity, encoding, and how it was computed."""
        return {"name": self.name, "quantity": self.quantity, "encoding": self.encoding,
                "shape": list(self.shape),
                "axes": [{k: v for k, v in a.items() if k != "values"} for a in self.axes],
                "stderr_max": float(np.max(self.stderr)) if self.stderr.size else 0.0,
                **{k: v for k, v in self.meta.items() if k not in ("name", "quantity",
                                                                    "encoding")}}

    @staticmethod
    def load(path, name: str | None = None) -> "Table":
        """The table ``name`` of a file written by ``save_tables`` (the only one if not given)."""
        tables = load_tables(path)
        if name is None:
            if len(tables) != 1:
                raise ParameterError(f"{str(path)!r} holds tables {', '.join(tables)}: give name=")
            return next(iter(tables.values()))
        if name not in tables:
            raise ParameterError(f"{str(path)!r} has no table {name!r}: it holds "
                                 f"{', '.join(tables)}")
        return tables[name]


# ---------------------------------------------------------------------------------------------
# files

def _npz_bytes(tables: dict) -> bytes:
    arrays = {}
    meta = {"format": FORMAT, "tables": {}}
    for name, t in tables.items():
        arrays[name] = t.raw
        arrays[f"{name}.stderr"] = np.asarray(t.stderr, dtype=np.float64)
        for a in t.axes:
            arrays[f"{name}.axis.{a['name']}"] = np.asarray(a["values"], dtype=np.float64)
        meta["tables"][name] = t.to_json()
    buf = io.BytesIO()
    np.savez_compressed(buf, metadata=np.asarray(json.dumps(meta)), **arrays)
    return buf.getvalue()


def _load_npz(path) -> dict:
    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["metadata"]))
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise ParameterError(f"{str(path)!r} is not a clbrdf layout table file (format "
                                 f"{FORMAT}); plain tables load with numpy.load")
        out = {}
        for name, m in meta["tables"].items():
            axes = [dict(a, values=z[f"{name}.axis.{a['name']}"].tolist()) for a in m["axes"]]
            out[name] = Table(name=name, axes=axes, quantity=m["quantity"], raw=z[name],
                              stderr=z[f"{name}.stderr"], encoding=m["encoding"],
                              meta={k: v for k, v in m.items()
                                    if k not in ("axes", "shape", "stderr_max")})
        return out


def _openexr():
    try:
        import OpenEXR
    except ImportError:
        raise ParameterError(".exr files need the OpenEXR package: pip install 'clbrdf[exr]'") \
            from None
    return OpenEXR


def _exr_bytes(tables: dict, path: Path) -> bytes:
    OpenEXR = _openexr()
    parts = []
    # a multi-part file shares one display window: the largest table's; each part's data
    # window is its own size
    dims = [(int(np.prod(t.shape[:-1])) if len(t.shape) > 1 else 1, t.shape[-1])
            for t in tables.values()]
    display = (np.array([0, 0], np.int32), np.array([max(w for _, w in dims) - 1,
                                                     max(h for h, _ in dims) - 1], np.int32))
    for name, t in tables.items():
        vals = np.asarray(t.values, dtype=np.float32)
        errs = np.asarray(t.stderr, dtype=np.float32)
        nc = len(t.quantity)
        if nc == 1:
            vals, errs = vals[..., None], errs[..., None]
        shape = t.shape
        rows = int(np.prod(shape[:-1])) if len(shape) > 1 else 1
        chans = {}
        for c, q in enumerate(t.quantity):
            chans[q] = np.ascontiguousarray(vals[..., c].reshape(rows, shape[-1]))
            chans[f"{q}.stderr"] = np.ascontiguousarray(errs[..., c].reshape(rows, shape[-1]))
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "displayWindow": display,
                  "dataWindow": (np.array([0, 0], np.int32),
                                 np.array([shape[-1] - 1, rows - 1], np.int32)),
                  "clbrdf": json.dumps({"format": FORMAT, "table": t.to_json(),
                                        "axes_values": {a["name"]: a["values"] for a in t.axes}})}
        parts.append(OpenEXR.Part(header, chans, name))
    # OpenEXR writes to a path: a temporary name beside the target (.NAME.PID.*.tmp, which a
    # later write removes if this process was killed: tables.remove_stale), read back as bytes
    remove_stale(path)
    tmp = path.with_name(_tmp_prefix(path) + "exr-staging.tmp")
    try:
        OpenEXR.File(parts).write(str(tmp))
        return tmp.read_bytes()
    finally:
        tmp.unlink(missing_ok=True)


def _load_exr(path) -> dict:
    OpenEXR = _openexr()
    out = {}
    with OpenEXR.File(str(path), separate_channels=True) as f:
        for part in f.parts:
            m = json.loads(part.header["clbrdf"])
            tm = m["table"]
            axes = [dict(a, values=m["axes_values"][a["name"]]) for a in tm["axes"]]
            shape = tuple(tm["shape"])
            vals = [np.asarray(part.channels[q].pixels, np.float64).reshape(shape)
                    for q in tm["quantity"]]
            errs = [np.asarray(part.channels[f"{q}.stderr"].pixels, np.float64).reshape(shape)
                    for q in tm["quantity"]]
            v = np.stack(vals, -1) if len(vals) > 1 else vals[0]
            s = np.stack(errs, -1) if len(errs) > 1 else errs[0]
            raw = encode(v, tm["encoding"]) if tm["encoding"] != "float32" else v.astype(np.float32)
            out[tm["name"]] = Table(name=tm["name"], axes=axes, quantity=tm["quantity"], raw=raw,
                                   stderr=s, encoding=tm["encoding"],
                                   meta={k: x for k, x in tm.items()
                                         if k not in ("axes", "shape", "stderr_max")})
    return out


def check_out(out) -> Path:
    """Before any work: a known suffix, an existing directory that takes new files."""
    out = Path(out)
    if out.suffix.lower() not in SUFFIXES:
        raise ParameterError(f"--out {str(out)!r}: unknown suffix {out.suffix!r}: these tables "
                             f"are written as {', '.join(SUFFIXES)}")
    if out.is_dir():
        raise ParameterError(f"--out {str(out)!r} is a directory; give a file name")
    try:   # check_output knows the plain tables' suffixes: probe the directory as .npz
        check_output(out.with_suffix(".npz"))
    except ValueError as e:
        raise ParameterError(f"--out {str(out)!r}: {e}") from None
    if out.exists() and not os.access(out, os.W_OK):
        raise ParameterError(f"--out {str(out)!r} is not writable")
    if out.suffix.lower() == ".exr":
        _openexr()              # before any work
    return out


def save_tables(tables: dict, out, *, prefix: str = "clbrdf") -> list:
    """Write {name: Table} to ``out`` (.npz, .h or .exr, module docstring); returns the paths."""
    out = check_out(out)
    suffix = out.suffix.lower()
    if suffix == ".npz":
        data = _npz_bytes(tables)
    elif suffix == ".h":
        data = c_header(tables, prefix=prefix, guard=out.name)
    else:
        data = _exr_bytes(tables, out)
    write_together({out: data})
    return [out]


def load_tables(path) -> dict:
    """{name: Table} from a .npz or .exr written by ``save_tables``."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".npz", ".exr"):
        raise ParameterError(f"{str(path)!r}: tables load from .npz or .exr (a .h is for C)")
    if not path.is_file():
        raise ParameterError(f"{str(path)!r} does not exist or is not a file")
    try:
        return _load_npz(path) if suffix == ".npz" else _load_exr(path)
    except ParameterError:
        raise
    except Exception as e:      # empty, truncated or foreign files: zipfile, OpenEXR, JSON, keys
        raise ParameterError(f"{str(path)!r} is not a readable clbrdf table file "
                             f"({type(e).__name__}: {e})") from None
