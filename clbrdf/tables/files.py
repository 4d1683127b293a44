"""Writing tables (``save_tables``): ``.npz`` (every table, versioned: ``clbrdf-tables/2``),
``.csv`` (long format, one row per cell; a table's average in ``NAME.avg.csv``), ``.h`` (a C
header that compiles as C99, C++17, CUDA and OpenCL C: clbrdf.tables.cheader) and ``.exr`` (one
part per table, one channel per quantity and ``QUANTITY.stderr``, float32, the leading axes
stacked as rows) and, for an LTC layout's textures, ``.js`` (three.js) and a ``.h`` of the
texture arrays (clbrdf.tables.textures), with a PNG chart beside the first output. All files of one call are written
together: a kill at any moment leaves the old files or the new ones (clbrdf.tables.outputs).
``load_tables`` (clbrdf.tables.table) reads back what is written here.
"""
from __future__ import annotations

import io
import json
import os
from pathlib import Path

import numpy as np

from ..models.spec import ParameterError, given
from .chart import figure_png
from .cheader import c_header
from .outputs import probe_directory, remove_stale, tmp_prefix, write_together
from .table import FORMAT, Table, openexr
from .textures import c_text as textures_c_text, js_text, texture_tables

SUFFIXES = (".npz", ".csv", ".h", ".exr")      # any tables; .js: an LTC layout's textures


def check_out(out, suffixes=SUFFIXES, what: str = "tables") -> Path:
    """Before any work: a known suffix (one of ``suffixes``, what ``what`` is written as), a
    directory that exists and takes new files, a path that is not a directory and is writable;
    .exr needs OpenEXR. Raises ParameterError naming ``out``."""
    out = Path(out)
    if out.suffix.lower() not in suffixes:
        raise ParameterError(f"{given('out', str(out))}: unknown output suffix "
                             f"{out.suffix!r}: {what} are written as {', '.join(suffixes)}", "out")
    companions = [chart_path(out)] + ([out.with_suffix(".avg.csv")]
                                      if out.suffix.lower() == ".csv" else [])
    for p in [out] + companions:
        if p.is_dir():
            raise ParameterError(f"{given('out', str(out))}: {str(p)!r} is a directory; "
                                 f"give a file name", "out")
        if p.exists() and not os.access(p, os.W_OK):
            raise ParameterError(f"{given('out', str(out))}: {str(p)!r} is not writable",
                                 "out")
    try:
        probe_directory(out)
    except ValueError as e:
        raise ParameterError(f"{given('out', str(out))}: {e}", "out") from None
    if out.suffix.lower() == ".exr":
        openexr()               # before any work
    return out


class Checked(tuple):
    """Output paths that ``check_outputs`` has checked: ``save_tables`` writes them without
    checking again."""


def check_outputs(outs, suffixes=SUFFIXES, what: str = "tables") -> Checked:
    """``check_out`` of each path (one, or a list), before any work."""
    outs = [outs] if isinstance(outs, (str, os.PathLike)) else list(outs)
    if not outs:
        raise ParameterError("out=[] is not valid: give at least one path", "out")
    return Checked(check_out(o, suffixes, what) for o in outs)


def as_tables(tables) -> dict:
    """{name: Table} from a Table or a dict of them."""
    if isinstance(tables, Table):
        return {tables.name: tables}
    if isinstance(tables, dict) and tables and all(isinstance(t, Table) for t in tables.values()):
        return dict(tables)
    raise ParameterError(f"tables={type(tables).__name__} is not valid: give a clbrdf.Table or "
                         f"a dict of them")


def flat(tables: dict, scalars: bool = True) -> dict:
    """The tables with each average as a table of its own (``average_of`` in its metadata);
    ``scalars=False`` leaves out averages without axes (a C lookup or an image needs one)."""
    out = {}
    for name, t in tables.items():
        out[name] = t
        if t.average is not None and (scalars or t.average.axes):
            a = t.average
            out[a.name] = Table(a.name, a.axes, a.quantity, a.raw, a.stderr, a.encoding,
                                {**a.meta, "average_of": name}, a.samples)
    return out


def _json(t: Table) -> dict:
    return {**t.to_json(), "samples": t.samples is not None,
            **({"average": t.average.name} if t.average is not None else {})}


def npz_bytes(tables: dict) -> bytes:
    arrays = {}
    meta = {"format": FORMAT, "tables": {}}
    for name, t in flat(tables).items():
        arrays[name] = t.raw
        arrays[f"{name}.stderr"] = np.asarray(t.stderr, dtype=np.float64)
        for a in t.axes:
            arrays[f"{name}.axis.{a['name']}"] = np.asarray(a["values"], dtype=np.float64)
        if t.samples is not None:
            arrays[f"{name}.samples"] = np.asarray(t.samples)
        meta["tables"][name] = _json(t)
    buf = io.BytesIO()
    np.savez_compressed(buf, metadata=np.asarray(json.dumps(meta)), **arrays)
    return buf.getvalue()


def _fmt(x) -> str:
    return repr(float(x))


def csv_text(t: Table, position: int | None = None) -> str:
    """First line ``# clbrdf-tables/2 {metadata}``, a header, one row per cell: the axes, each
    channel, each channel's stderr, the samples."""
    vals = t.values.reshape(t.shape + (-1,))
    errs = np.asarray(t.stderr, np.float64).reshape(t.shape + (-1,))
    head = {**_json(t), **({} if position is None else {"position": position})}
    lines = [f"# {FORMAT} " + json.dumps(head, default=str),
             ",".join(t.axis_names + t.quantity + [q + "_stderr" for q in t.quantity]
                      + (["samples"] if t.samples is not None else []))]
    axv = [np.asarray(a["values"], np.float64) for a in t.axes]
    for idx in np.ndindex(t.shape):
        row = [_fmt(v[i]) for v, i in zip(axv, idx)] + [_fmt(x) for x in vals[idx]] + \
            [_fmt(x) for x in errs[idx]] + ([str(int(t.samples[idx]))] if t.samples is not None
                                            else [])
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def csv_files(tables: dict, out: Path) -> dict:
    """{path: text}: one table in ``out`` (its average in OUT.avg.csv); several in
    OUT_STEM.NAME.csv, which ``load_tables(out)`` reads back in their order."""
    files = {}
    for i, (name, t) in enumerate(tables.items()):
        path = out if len(tables) == 1 else out.with_name(f"{out.stem}.{name}.csv")
        files[path] = csv_text(t, None if len(tables) == 1 else i)      # the order, to read back
        if t.average is not None:
            files[path.with_suffix(".avg.csv")] = csv_text(flat({name: t})[t.average.name])
    return files


def exr_bytes(tables: dict, path: Path) -> bytes:
    OpenEXR = openexr()
    tables = flat(tables, scalars=False)
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
        if t.samples is not None:
            chans["samples"] = np.ascontiguousarray(
                np.asarray(t.samples, np.float32).reshape(rows, shape[-1]))
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "displayWindow": display,
                  "dataWindow": (np.array([0, 0], np.int32),
                                 np.array([shape[-1] - 1, rows - 1], np.int32)),
                  "clbrdf": json.dumps({"format": FORMAT, "table": _json(t),
                                        "axes_values": {a["name"]: a["values"] for a in t.axes}},
                                       default=str)}
        parts.append(OpenEXR.Part(header, chans, name))
    return exr_parts_bytes(parts, path)


def exr_parts_bytes(parts: list, path: Path) -> bytes:
    """The bytes of a multi-part EXR file of OpenEXR.Part ``parts``, to be written at ``path``."""
    OpenEXR = openexr()
    # OpenEXR writes to a path: a temporary name beside the target (.NAME.PID.*.tmp, which a
    # later write removes if this process was killed: outputs.remove_stale), read back as bytes
    remove_stale(path)
    tmp = path.with_name(tmp_prefix(path) + "exr-staging.tmp")
    try:
        OpenEXR.File(parts).write(str(tmp))
        return tmp.read_bytes()
    finally:
        tmp.unlink(missing_ok=True)


def chart_path(out: Path) -> Path:
    return out.with_suffix(".png")


def header_text(tables: dict, out: Path, prefix: str) -> str:
    """.h: an LTC layout's texture arrays in the engine's memory order (clbrdf.tables.textures),
    else every table with its lookup functions (clbrdf.tables.cheader)."""
    if texture_tables(tables):
        return textures_c_text(tables)
    return c_header(flat(tables, scalars=False), prefix=prefix, guard=out.name)


# one writer per suffix: (tables, out path, prefix) -> {path: bytes or text}
WRITERS = {
    ".npz": lambda tables, out, prefix: {out: npz_bytes(tables)},
    ".csv": lambda tables, out, prefix: csv_files(tables, out),
    ".h": lambda tables, out, prefix: {out: header_text(tables, out, prefix)},
    ".exr": lambda tables, out, prefix: {out: exr_bytes(tables, out)},
    ".js": lambda tables, out, prefix: {out: js_text(tables)},
}


def files_for(tables: dict, out: Path, *, prefix: str = "clbrdf", chart: bool = True) -> dict:
    """{path: bytes or text} of everything ``save_tables`` writes for one output (checked)."""
    files = WRITERS[out.suffix.lower()](tables, out, prefix)
    if chart:           # the tables' charts; an LTC layout's: its fit's error map
        charted = {k: t for k, t in tables.items() if k not in texture_tables(tables)}
        files[chart_path(out)] = figure_png(charted)
    return files


def save_tables(tables, out, *, prefix: str = "clbrdf", chart: bool = True,
                suffixes=None) -> list:
    """Write a Table (or {name: Table}) to ``out``, a path or a list of them (.npz, .csv, .h,
    .exr; an LTC layout's tables also .js, as its ``suffixes`` allow; module docstring), with a
    PNG chart beside the first (``chart=False``: none). Every path is checked before anything
    is computed or written (``Checked`` paths, from ``check_outputs`` before the work, are not
    checked again), and all files are committed together. Returns the paths written."""
    tables = as_tables(tables)
    if suffixes is None:
        suffixes = SUFFIXES + ((".js",) if texture_tables(tables) else ())
    outs = out if isinstance(out, Checked) else check_outputs(out, suffixes)
    files = {}
    for i, o in enumerate(outs):
        files.update(files_for(tables, o, prefix=prefix, chart=chart and i == 0))
    write_together(files)
    return list(files)
