"""An engine's LTC textures as tables (``textures``: the packing step of an LTC layout,
clbrdf/data/ltc_layouts.json) and the two files only textures are written as: an ES module for
three.js (``js_text``) and a C header of the texture arrays in the engine's memory order
(``c_text``). clbrdf.tables.files calls them by suffix; the .npz, .exr and .csv of a layout are
the tables' own files, which ``load_tables`` reads back."""
from __future__ import annotations

import numpy as np

from ..version import __version__
from .catalog import ltc_layouts, ltc_textures
from .table import Table


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


def textures(name: str, fit: Table) -> dict:
    """The layout's textures {NAME: Table} of a fit_ltc table over two axes (rows: its first
    axis): each texture's channels are its quantities, float32, with the fit's standard errors
    where a channel is one of the fit's quantities (E, B) and 0 for the others (exact)."""
    lay = ltc_layouts()[name]
    shape = fit.shape
    col, row = np.meshgrid(np.arange(shape[1]), np.arange(shape[0]))
    extra = {"zero": np.zeros(shape),
             "sphere": sphere_form_factor(2 * col / max(shape[1] - 1, 1) - 1,
                                          row / max(shape[0] - 1, 1)),
             # Zeltner's (a, b) of M^-1 = [[a, 0, b], [0, a, 0], [0, 0, 1]], from the entries
             # normalised by the middle one (1/a)
             "a_inv": 1 / np.asarray(fit["minv22"], float),
             "b_inv": np.asarray(fit["minv02"], float) / np.asarray(fit["minv22"], float)}
    out = {}
    for k, chans in ltc_textures(lay).items():
        raw = np.stack([extra[q] if q in extra else fit[q] for q in chans], -1)
        err = np.stack([np.zeros(shape) if q in extra else fit[q + "_stderr"] for q in chans], -1)
        out[k] = Table(name=k, axes=[dict(a) for a in fit.axes], quantity=list(chans),
                       raw=raw.astype(np.float32), stderr=err, encoding="float32",
                       meta={"texture": {"layout": name, "planar": bool(lay.get("planar")),
                                         "of": fit.name}})
    return out


def texture_tables(tables: dict) -> dict:
    """The textures among ``tables`` (their meta names a layout)."""
    return {k: t for k, t in tables.items() if "texture" in t.meta}


def _layout_of(tables: dict):
    tex = texture_tables(tables)
    if not tex:
        raise ValueError("no LTC textures to write: .js files and texture headers are written "
                         "for an LTC layout (clbrdf ltc --layout)")
    first = next(iter(tex.values())).meta["texture"]
    return first["layout"], tex, tables.get(first["of"])


def _short(x) -> str:
    """The shortest text that reads back as the same float32 (NumPy's repr of a float32)."""
    t = str(np.float32(x))
    return t[:-2] if t.endswith(".0") else t


def _about(name, fit) -> str:
    if fit is None:
        return f"clbrdf {__version__} LTC layout {name}"
    c = fit.computed
    e1 = fit["L1"]
    return (f"clbrdf {__version__} LTC layout {name}: model {c['model']}, "
            f"{c['samples']} quasi-random samples per loss, {c['report_samples']} per reported "
            f"error; relative L1 error of the LTC: median {np.median(e1):.3g}, max {e1.max():.3g} "
            f"(per cell in the .npz)")


def _texels(t: Table) -> np.ndarray:
    """A texture's values (rows, cols, channels), float32."""
    v = np.asarray(t.values, np.float32)
    return v if v.ndim == 3 else v[..., None]


def js_text(tables: dict) -> str:
    """An ES module with the textures as Float32Arrays, and a RectAreaLightTexturesLib with
    three.js's interface (init() -> LTC_FLOAT_1/2, LTC_HALF_1/2 DataTextures)."""
    name, tex, fit = _layout_of(tables)
    lay = ltc_layouts()[name]
    rows, cols = next(iter(tex.values())).shape[:2]
    lines = [f"// {_about(name, fit)}", f"// {lay['consumer']}", f"// {lay['notes']}",
             "// Use: import { RectAreaLightTexturesLib } from './this-file.js' in place of "
             "three/addons/lights/RectAreaLightTexturesLib.js (WebGL: RectAreaLightUniformsLib "
             "reads it; WebGPU: RectAreaLightNode.setLTC(RectAreaLightTexturesLib.init())).",
             "import { ClampToEdgeWrapping, DataTexture, DataUtils, FloatType, HalfFloatType, "
             "LinearFilter, NearestFilter, RGBAFormat, UVMapping } from 'three';", ""]
    for k, t in tex.items():
        body = ",".join(map(_short, _texels(t).reshape(-1)))
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
    for i, k in enumerate(tex, 1):
        lines.append(f"\t\tthis.LTC_FLOAT_{i} = texture({k}, FloatType);")
        lines.append(f"\t\tthis.LTC_HALF_{i} = texture(half({k}), HalfFloatType);")
    lines += ["\t\treturn this;", "\t}", "}", ""]
    return "\n".join(lines)


def c_text(tables: dict) -> str:
    """A C header (C99, C++17, CUDA, OpenCL C) of the texture arrays in the layout's memory
    order: interleaved channels, or planes."""
    name, tex, fit = _layout_of(tables)
    lay = ltc_layouts()[name]
    lines = [f"/* {_about(name, fit)}", f" * {lay['consumer']}", f" * {lay['notes']} */",
             f"#ifndef CLBRDF_LTC_{name.upper()}_H", f"#define CLBRDF_LTC_{name.upper()}_H",
             "#if defined(__OPENCL_VERSION__)", "#define CLBRDF_LTC_DATA __constant",
             "#elif defined(__CUDACC__)", "#define CLBRDF_LTC_DATA static __device__ const",
             "#else", "#define CLBRDF_LTC_DATA static const", "#endif"]
    for k, t in tex.items():
        v = _texels(t)
        rows, cols = v.shape[:2]
        flat = (np.moveaxis(v, -1, 0) if t.meta["texture"]["planar"] else v).reshape(-1)
        lines.append(f"#define {k}_SIZE_U {cols}\n#define {k}_SIZE_V {rows}")
        lines.append(f"CLBRDF_LTC_DATA float {k}[{flat.size}] = {{" +
                     ",".join(_short(x) + ("f" if "." in _short(x) or "e" in _short(x) else ".f")
                              for x in flat) + "};")
    lines += ["#endif", ""]
    return "\n".join(lines)
