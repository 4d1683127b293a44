"""C header of layout tables: one source that compiles as C99, C++17, CUDA and OpenCL C.

Per table NAME (prefix P): the stored values as a flat ``P_NAME[]`` array in memory order
(float, or unsigned short for float16 and unorm16 encodings), one ``P_NAME_AXIS[]`` array per
axis, ``P_NAME_stderr[]`` when CLBRDF_LUT_WITH_STDERR is defined, and

    float P_NAME_lookup(float x0, float x1, ...[, int channel])

with the interpolation of ``clbrdf.Table.lookup`` (multilinear in the clamped continuous
index: nodes u (N - 1), texel centres u N - 1/2). Axes, mapping, quantity, encoding and how the
values were computed are in the comment above each table.
"""
from __future__ import annotations

import math
import re

import numpy as np

from ..version import __version__
from .axes import describe

PORTABILITY = """\
#ifndef CLBRDF_LUT_PORTABLE
#define CLBRDF_LUT_PORTABLE
#if defined(__OPENCL_VERSION__)          /* OpenCL C: tables in the constant address space */
#define CLBRDF_LUT_DATA __constant
#define CLBRDF_LUT_FN static inline
#define CLBRDF_LUT_SQRT sqrt
#define CLBRDF_LUT_LOG log
#define CLBRDF_LUT_LDEXP ldexp
#elif defined(__CUDACC__)               /* CUDA: device globals, device functions */
#define CLBRDF_LUT_DATA static __device__ const
#define CLBRDF_LUT_FN static __device__ inline
#define CLBRDF_LUT_SQRT sqrtf
#define CLBRDF_LUT_LOG logf
#define CLBRDF_LUT_LDEXP ldexpf
#else                                   /* C99, C++ */
#include <math.h>
#define CLBRDF_LUT_DATA static const
#define CLBRDF_LUT_FN static inline
#define CLBRDF_LUT_SQRT sqrtf
#define CLBRDF_LUT_LOG logf
#define CLBRDF_LUT_LDEXP ldexpf
#endif
/* IEEE half (non-negative, finite) to float, by arithmetic: no type punning in any language */
CLBRDF_LUT_FN float clbrdf_lut_half(unsigned short h)
{
    int e = (h >> 10) & 31, m = h & 1023;
    float v = e ? CLBRDF_LUT_LDEXP((float)(m + 1024), e - 25) : CLBRDF_LUT_LDEXP((float)m, -24);
    return (h & 0x8000) ? -v : v;
}
#endif
"""


def _c_ident(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_]", "_", s)


def _f32(v) -> str:
    s = str(np.float32(v))
    if s in ("inf", "-inf", "nan"):
        raise ValueError(f"value {s} cannot be written as a C literal")
    if "." not in s and "e" not in s:
        s += ".0"
    return s + "f"


def _array(ctype: str, name: str, values, fmt) -> str:
    vals = [fmt(v) for v in np.asarray(values).ravel()]
    per = 8 if ctype == "float" else 12
    lines = [", ".join(vals[i:i + per]) for i in range(0, len(vals), per)]
    return (f"CLBRDF_LUT_DATA {ctype} {name}[{len(vals)}] = {{\n    "
            + ",\n    ".join(lines) + "\n};\n")


C_STORAGE = {"float32": "float", "float64": "float (rounded from float64)",
             "float16": "unsigned short (IEEE half bits)",
             "unorm16": "unsigned short (unorm16: value x 65535)"}


def _stored(t, cname: str) -> str:
    """The table's values as the C array the lookup reads: float for float32 and float64 tables
    (float64 rounds to float), the 16-bit patterns for float16 and unorm16."""
    if t.encoding in ("float32", "float64"):
        return _array("float", cname, np.asarray(t.raw, np.float64), _f32)
    if t.encoding == "float16":
        return _array("unsigned short", cname, np.asarray(t.raw, np.float16).view(np.uint16),
                      lambda v: f"{int(v)}u")
    if t.encoding == "unorm16":
        return _array("unsigned short", cname, np.asarray(t.raw, np.uint16),
                      lambda v: f"{int(v)}u")
    raise ValueError(f"table {t.name}: encoding {t.encoding!r} has no C storage: one of "
                     f"{', '.join(C_STORAGE)}")


def _index_expr(a: dict, var: str, axis_array: str) -> list:
    """C statements that set float xi_<var> to the clamped continuous index of coordinate var."""
    n = len(a["values"])
    out = f"x_{var}"
    if n == 1:
        return [f"float {out} = 0.0f;"]
    if a.get("spacing") == "list" or "count" not in a:
        v = np.asarray(a["values"], dtype=np.float64)
        sign = "" if v[-1] >= v[0] else "-"
        return [f"float {out};",
                "{",
                "    int lut_k = 0;",
                f"    while (lut_k < {n - 2} && {sign}{var} > {sign}{axis_array}[lut_k + 1]) lut_k++;",
                f"    float lut_d = {sign}{axis_array}[lut_k + 1] - {sign}{axis_array}[lut_k];",
                f"    float lut_t = lut_d > 0.0f ? ({sign}{var} - {sign}{axis_array}[lut_k]) / lut_d : 1.0f;",
                f"    {out} = (float)lut_k + (lut_t < 0.0f ? 0.0f : (lut_t > 1.0f ? 1.0f : lut_t));",
                "}"]
    start, stop, sp = a["start"], a["stop"], a["spacing"]
    cells = n if a.get("placement") == "centres" else n - 1
    shift = " - 0.5f" if a.get("placement") == "centres" else ""
    if sp == "log":
        k = cells / math.log(stop / start)
        u = f"({var} > 0.0f ? CLBRDF_LUT_LOG({var} / {_f32(start)}) * {_f32(k)} : -1.0f)"
    elif sp == "sqrt":
        k = cells / (math.sqrt(stop) - math.sqrt(start))
        u = (f"(({var} > 0.0f ? CLBRDF_LUT_SQRT({var}) : 0.0f) - {_f32(math.sqrt(start))}) * "
             f"{_f32(k)}")
    else:
        k = cells / (stop - start)
        u = f"({var} - {_f32(start)}) * {_f32(k)}"
    return [f"float {out} = {u}{shift};",
            f"{out} = {out} > 0.0f ? ({out} < {_f32(n - 1)} ? {out} : {_f32(n - 1)}) : 0.0f;"]


def _comment(t, cname: str, args: list) -> str:
    m = t.meta
    comp = m.get("computed", {})
    q = ", ".join(t.quantity)
    lines = [f"{cname}[{' x '.join(str(s) for s in t.shape)}"
             f"{' x ' + str(len(t.quantity)) if len(t.quantity) > 1 else ''}]: {q}"
             f"{' (interleaved channels, last)' if len(t.quantity) > 1 else ''}, stored as "
             f"{C_STORAGE.get(t.encoding, t.encoding)}" + (f", clamped to [{m['range'][0]:g}, {m['range'][1]:g}]"
                                if m.get("range") else "")]
    for d, a in enumerate(t.axes):
        lines.append(f"  axis {d} ({'slowest' if d == 0 else 'fastest' if d == len(t.axes) - 1 else 'next'}): "
                     + describe(a))
    if comp:
        fixed = ", ".join(f"{k}={v}" for k, v in comp.get("fixed", {}).items())
        if comp.get("quantity") == "ltc":       # clbrdf.fit_ltc: its own description
            lines.append(f"  {comp.get('model')}: LTC fit, {comp.get('fit')}; {comp.get('samples')} "
                         f"samples per loss, {comp.get('report_samples')} per reported error, "
                         f"seed {comp.get('seed')}, {comp.get('precision')} precision")
        else:
            lines.append(f"  {comp.get('model')} ({fixed}); {comp.get('estimator')}"
                         f"{' + qmc' if comp.get('qmc') else ''}, {comp.get('samples')} samples "
                         f"per cell, seed {comp.get('seed')}, {comp.get('precision')} precision")
        for k in ("E", "E_avg", "split"):
            if k in comp:
                lines.append(f"  {k}: {comp[k]}")
    if t.stderr.size:
        lines.append(f"  largest standard error {float(np.max(t.stderr)):.2g} (per cell: "
                     f"{cname}_stderr with CLBRDF_LUT_WITH_STDERR)")
    for label, c in m.get("clamped", {}).items():
        lines.append(f"  {c['cells']} cells of {label} clamped to the range, by up to "
                     f"{c['max_excess']:.3g} (their stderr includes it)")
    if m.get("clamped_cells") and not m.get("clamped"):      # files of older versions
        lines.append(f"  {m['clamped_cells']} cells clamped to the range")
    sig = ", ".join(f"float {a}" for a in args) + (", int channel" if len(t.quantity) > 1 else "")
    lines.append(f"  float {cname}_lookup({sig})")
    return "/* " + "\n * ".join(lines) + " */\n"


def _lookup(t, cname: str, args: list) -> str:
    nc = len(t.quantity)
    shape = t.shape
    strides = [int(np.prod(shape[d + 1:])) * nc for d in range(len(shape))]
    sig = ", ".join(f"float {a}" for a in args) + (", int channel" if nc > 1 else "")
    body = []
    for d, (a, var) in enumerate(zip(t.axes, args)):
        body += _index_expr(a, var, f"{cname}_{_c_ident(a['name'])}")
        n = shape[d]
        if n > 1:
            body += [f"int i_{var} = (int)x_{var};",
                     f"if (i_{var} > {n - 2}) i_{var} = {n - 2};",
                     f"float f_{var} = x_{var} - (float)i_{var};"]
        else:
            body += [f"int i_{var} = 0;", f"float f_{var} = 0.0f;"]
    if t.encoding == "float16":
        fetch = lambda e: f"clbrdf_lut_half({cname}[{e}])"      # noqa: E731
    elif t.encoding == "unorm16":
        fetch = lambda e: f"(float){cname}[{e}] * (1.0f / 65535.0f)"   # noqa: E731
    else:
        fetch = lambda e: f"{cname}[{e}]"       # noqa: E731
    base = " + ".join(f"i_{v} * {s}" for v, s in zip(args, strides)) + (" + channel" if nc > 1 else "")
    body.append(f"int lut_b = {base};")
    body.append("float lut_v = 0.0f;")
    live = [d for d in range(len(shape)) if shape[d] > 1]
    for corner in range(1 << len(live)):
        w, off = [], 0
        for j, d in enumerate(live):
            up = (corner >> j) & 1
            w.append(f"f_{args[d]}" if up else f"(1.0f - f_{args[d]})")
            off += strides[d] * up
        body.append(f"lut_v += {' * '.join(w) if w else '1.0f'} * {fetch(f'lut_b + {off}')};")
    body.append("return lut_v;")
    return (f"CLBRDF_LUT_FN float {cname}_lookup({sig})\n{{\n    " + "\n    ".join(body)
            + "\n}\n")


def c_header(tables: dict, *, prefix: str = "clbrdf", guard: str = "tables.h") -> str:
    """The header text for {name: Table} (module docstring)."""
    first = next(iter(tables.values()))
    m = first.meta
    g = _c_ident(f"CLBRDF_{prefix}_{guard}").upper()
    kind = "LTC" if m.get("computed", {}).get("quantity") == "ltc" else "Albedo"
    head = [f"/* {kind} tables generated by clbrdf {__version__}"]
    if m.get("layout"):
        head.append(f" * layout {m['layout']}: {m.get('consumer', '')}")
        head.append(f" * layout source: {m.get('source', '')}")
    comp = m.get("computed", {})
    if comp.get("command"):
        head.append(f" * command: {comp['command']}")
    if comp:
        head.append(f" * device: {comp.get('device')} ({comp.get('platform')}), width "
                    f"{comp.get('width')}")
    if m.get("notes"):
        words, line = m["notes"].split(), " * notes:"
        for w in words:
            if len(line) + len(w) > 96:
                head.append(line)
                line = " *  "
            line += " " + w
        head.append(line)
    head.append(" * Compiles as C99, C++17, CUDA and OpenCL C. Do not edit: regenerate. */")
    parts = ["\n".join(head) + "\n", f"#ifndef {g}\n#define {g}\n\n", PORTABILITY, "\n"]
    for name, t in tables.items():
        cname = _c_ident(f"{prefix}_{name}")
        args = [_c_ident(a["name"]) for a in t.axes]
        parts.append(_comment(t, cname, args))
        for a in t.axes:
            parts.append(_array("float", f"{cname}_{_c_ident(a['name'])}", a["values"], _f32))
        parts.append(_stored(t, cname))
        parts.append("#ifdef CLBRDF_LUT_WITH_STDERR\n")
        parts.append(_array("float", f"{cname}_stderr", t.stderr, _f32))
        parts.append("#endif\n")
        parts.append(_lookup(t, cname, args) + "\n")
    parts.append(f"#endif /* {g} */\n")
    return "".join(parts)

