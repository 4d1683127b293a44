"""LTC tables in the layouts engines load (clbrdf/data/ltc_layouts.json): ``ltc_layout`` fits
them (clbrdf.fit_ltc) and ``save_ltc`` writes them as an ES module for three.js (``.js``), a C
header (``.h``, C99, C++17, CUDA, OpenCL C), ``.npz`` (textures, per-cell errors and how they
were computed) or ``.exr`` (one part per texture, channels R, G, B, A as the texture's; a part
"errors" with E, B, L3, L1 and their standard errors), as the layout's "formats" allow.
"""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from ..models.spec import ParameterError
from ..version import __version__
from .axes import parse_axis
from .catalog import ltc_layouts
from .ltc import fit_ltc
from .chart import figure_png
from .files import exr_parts_bytes
from .outputs import probe_directory, write_together
from .table import openexr

SUFFIXES = (".js", ".h", ".npz", ".exr")


def sphere_form_factor(z, s2):
    """The projected solid angle of a spherical cap of half-angle sigma (sin^2 sigma = s2)
    whose axis makes cos(omega) = z with the normal, clipped to the horizon, over pi s2 (the
    unclipped cap's): Snyder 1996's closed form, as ltc_code's table of it (a sphere light's
    form factor given the length and direction of the LTC's vector form factor)."""
    z, s2 = np.broadcast_arrays(np.asarray(z, float), np.asarray(s2, float))
    w = np.arccos(np.clip(z, -1, 1))
    s = np.arcsin(np.sqrt(np.clip(s2, 0, 1)))
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.arcsin(np.clip(np.cos(s) / np.sin(w), -1, 1))
        G = -2 * np.sin(w) * np.cos(s) * np.cos(g) + np.pi / 2 - g + np.sin(g) * np.cos(g)
        H = np.cos(w) * (np.cos(g) * np.sqrt(np.maximum(s2 - np.cos(g) ** 2, 0))
                         + s2 * np.arcsin(np.clip(np.cos(g) / np.sin(s), -1, 1)))
        full = np.pi * np.cos(w) * s2
        v = np.where(w <= np.pi / 2 - s, full,
                     np.where(w < np.pi / 2, full + G - H,
                              np.where(w < np.pi / 2 + s, G + H, 0.0)))
        out = v / (np.pi * s2)
    return np.where(s2 > 0, out, np.maximum(z, 0))


def ltc_layout(name: str, model: str | None = None, **kw):
    """The layout's fit (a fit_ltc Table over its axes) and its textures {NAME: (rows, cols, 4)
    float64}; ``model`` replaces the layout's (any isotropic reflection model), ``kw`` go to
    fit_ltc (parameters, options, samples, device, ...)."""
    lays = ltc_layouts()
    if name not in lays:
        raise ParameterError(f"layout={name!r} is not an LTC layout: choose one of "
                             f"{', '.join(sorted(lays))}")
    lay = lays[name]
    axes = {}
    for text in lay["axes"]:
        ax = parse_axis(text)
        axes[ax["name"]] = ax
    table = fit_ltc(model or lay["model"], axes, **{"form": lay.get("form", "general"), **kw})
    return table, textures(name, table)


def textures(name: str, table) -> dict:
    """The layout's textures {NAME: (rows, cols, channels) float64} of a fit_ltc table over two
    axes (rows: its first axis)."""
    lay = ltc_layouts()[name]
    shape = table.shape
    col, row = np.meshgrid(np.arange(shape[1]), np.arange(shape[0]))
    extra = {"zero": np.zeros(shape),
             "sphere": sphere_form_factor(2 * col / max(shape[1] - 1, 1) - 1,
                                          row / max(shape[0] - 1, 1)),
             # Zeltner's (a, b) of M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]], from the entries
             # normalised by the middle one (1/a)
             "a_inv": 1 / np.asarray(table["minv22"], float),
             "b_inv": np.asarray(table["minv02"], float) / np.asarray(table["minv22"], float)}
    return {k: np.stack([extra[q] if q in extra else table[q] for q in chans], axis=-1)
            for k, chans in lay["textures"].items()}


def _short(x) -> str:
    """The shortest text that reads back as the same float32 (NumPy's repr of a float32)."""
    t = str(np.float32(x))
    return t[:-2] if t.endswith(".0") else t


def _about(name, table) -> str:
    c = table.computed
    e1 = table["L1"]
    return (f"clbrdf {__version__} LTC layout {name}: model {c['model']}, "
            f"{c['samples']} quasi-random samples per loss, {c['report_samples']} per reported "
            f"error; relative L1 error of the LTC: median {np.median(e1):.3g}, max {e1.max():.3g} "
            f"(per cell in the .npz)")


def js_text(name: str, table, tex: dict) -> str:
    """An ES module with the textures as Float32Arrays, and a RectAreaLightTexturesLib with
    three.js's interface (init() -> LTC_FLOAT_1/2, LTC_HALF_1/2 DataTextures)."""
    lay = ltc_layouts()[name]
    rows, cols = next(iter(tex.values())).shape[:2]
    lines = [f"// {_about(name, table)}", f"// {lay['description']}", f"// {lay['notes']}",
             "// Use: import { RectAreaLightTexturesLib } from './this-file.js' in place of "
             "three/addons/lights/RectAreaLightTexturesLib.js (WebGL: RectAreaLightUniformsLib "
             "reads it; WebGPU: RectAreaLightNode.setLTC(RectAreaLightTexturesLib.init())).",
             "import { ClampToEdgeWrapping, DataTexture, DataUtils, FloatType, HalfFloatType, "
             "LinearFilter, NearestFilter, RGBAFormat, UVMapping } from 'three';", ""]
    for k, v in tex.items():
        flat = v.astype(np.float32).reshape(-1)
        body = ",".join(map(_short, flat))
        lines.append(f"export const {k} = new Float32Array([{body}]);")
    lines += ["",
              "function texture(data, type) {",
              f"\tconst t = new DataTexture(data, {cols}, {rows}, RGBAFormat, type, UVMapping, "
              "ClampToEdgeWrapping, ClampToEdgeWrapping, LinearFilter, NearestFilter, 1);",
              "\tt.needsUpdate = true;", "\treturn t;", "}", "",
              "function half(a) {", "\tconst h = new Uint16Array(a.length);",
              "\tfor (let i = 0; i < a.length; i++) h[i] = DataUtils.toHalfFloat(a[i]);",
              "\treturn h;", "}", "",
              "export class RectAreaLightTexturesLib {", "\tstatic init() {"]
    names = list(tex)
    for i, k in enumerate(names, 1):
        lines.append(f"\t\tthis.LTC_FLOAT_{i} = texture({k}, FloatType);")
        lines.append(f"\t\tthis.LTC_HALF_{i} = texture(half({k}), HalfFloatType);")
    lines += ["\t\treturn this;", "\t}", "}", ""]
    return "\n".join(lines)


def _flat(name: str, v) -> np.ndarray:
    """A texture's floats in the layout's memory order: interleaved channels, or planes."""
    v = v.astype(np.float32)
    return (np.moveaxis(v, -1, 0) if ltc_layouts()[name].get("planar") else v).reshape(-1)


def c_text(name: str, table, tex: dict) -> str:
    lay = ltc_layouts()[name]
    lines = [f"/* {_about(name, table)}", f" * {lay['description']}", f" * {lay['notes']} */",
             f"#ifndef CLBRDF_LTC_{name.upper()}_H", f"#define CLBRDF_LTC_{name.upper()}_H",
             "#if defined(__OPENCL_VERSION__)", "#define CLBRDF_LTC_DATA __constant",
             "#elif defined(__CUDACC__)", "#define CLBRDF_LTC_DATA static __device__ const",
             "#else", "#define CLBRDF_LTC_DATA static const", "#endif"]
    for k, v in tex.items():
        rows, cols = v.shape[:2]
        flat = _flat(name, v)
        lines.append(f"#define {k}_SIZE_U {cols}\n#define {k}_SIZE_V {rows}")
        lines.append(f"CLBRDF_LTC_DATA float {k}[{flat.size}] = {{" +
                     ",".join(_short(x) + ("f" if "." in _short(x) or "e" in _short(x) else ".f")
                              for x in flat) + "};")
    lines += ["#endif", ""]
    return "\n".join(lines)


def npz_bytes(name: str, table, tex: dict) -> bytes:
    buf = io.BytesIO()
    arrays = {k: v.astype(np.float32) for k, v in tex.items()}
    for q in ("E", "B", "L3", "L1"):
        arrays[q] = np.asarray(table[q])
        arrays[q + "_stderr"] = np.asarray(table[q + "_stderr"])
    for a in table.axis_names:
        arrays[a] = table[a]
    meta = {"layout": name, **ltc_layouts()[name], "computed": table.computed}
    np.savez_compressed(buf, **arrays, meta=np.array(json.dumps(meta, default=str)))
    return buf.getvalue()


def exr_bytes(name: str, table, tex: dict, path: Path) -> bytes:
    OpenEXR = openexr()
    meta = json.dumps({"layout": name, **ltc_layouts()[name], "computed": table.computed},
                      default=str)
    parts = []
    grids = dict(tex)
    grids["errors"] = None
    for k, v in grids.items():
        if v is None:
            q = ("E", "B", "L3", "L1")
            chans = {c: np.asarray(table[c], np.float32) for c in q}
            chans.update({c + ".stderr": np.asarray(table[c + "_stderr"], np.float32) for c in q})
        else:
            chans = {"RGBA"[c]: v[..., c].astype(np.float32) for c in range(v.shape[-1])}
        rows, cols = next(iter(chans.values())).shape
        chans = {c: np.ascontiguousarray(a) for c, a in chans.items()}
        window = (np.array([0, 0], np.int32), np.array([cols - 1, rows - 1], np.int32))
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "displayWindow": window, "dataWindow": window, "clbrdf_ltc": meta}
        parts.append(OpenEXR.Part(header, chans, k))
    return exr_parts_bytes(parts, path)


def check_ltc_out(out, layout: str) -> Path:
    """``out`` checked before any work: a suffix that ``layout`` is written as, a writable
    directory."""
    out = Path(out)
    allowed = ltc_layouts()[layout].get("formats", SUFFIXES)
    if out.suffix.lower() not in allowed:
        raise ParameterError(f"out={str(out)!r}: unknown output suffix {out.suffix!r}: layout "
                             f"{layout} is written as {', '.join(allowed)}")
    if out.suffix.lower() == ".exr":
        openexr()
    if out.is_dir():
        raise ParameterError(f"out={str(out)!r} is a directory; give a file name")
    try:
        probe_directory(out)
    except ValueError as e:
        raise ParameterError(f"out={str(out)!r}: {e}") from None
    return out


def save_ltc(name: str, table, tex: dict, outs, chart: bool = False) -> list:
    """Write the layout's files together (a kill leaves the old files or the new ones), with
    the fit's error map (FILE.png beside the first) if ``chart``."""
    writers = {".js": js_text, ".h": c_text, ".npz": npz_bytes,
               ".exr": lambda *a: exr_bytes(*a, Path(o))}
    files = {}
    for o in outs:
        files[Path(o)] = writers[Path(o).suffix.lower()](name, table, tex)
    if chart:
        files[Path(outs[0]).with_suffix(".png")] = figure_png({"ltc": table})
    write_together(files)
    return list(files)
