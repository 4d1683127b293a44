"""Reading an ES module written for three.js (``clbrdf ltc --layout threejs``) the way three.js
does: Node imports it with a stub ``three`` package whose DataTexture keeps its data, and
RectAreaLightTexturesLib.init() hands over the textures."""
import json
import subprocess

import numpy as np

STUB = ("export class DataTexture { constructor(d, w, h) { this.data = d; this.w = w; "
        "this.h = h; } }\nexport const DataUtils = { toHalfFloat: (x) => 0 };\n"
        + "".join(f"export const {k} = '{k}';\n" for k in
                  ("ClampToEdgeWrapping", "FloatType", "HalfFloatType", "LinearFilter",
                   "NearestFilter", "RGBAFormat", "UVMapping")))


def node_textures(js, names, tmp) -> dict:
    """{name: (rows, cols, channels) float32} of LTC_FLOAT_1, 2, ... of the module ``js`` (in
    directory ``tmp``), named by ``names`` in order."""
    stub = tmp / "node_modules" / "three"
    stub.mkdir(parents=True, exist_ok=True)
    (stub / "package.json").write_text('{"name": "three", "type": "module", "main": "index.js"}')
    (stub / "index.js").write_text(STUB)
    (tmp / "package.json").write_text('{"type": "module"}')
    (tmp / "read_js.js").write_text(
        f"import {{ RectAreaLightTexturesLib as L }} from './{js.name}';\nconst t = L.init();\n"
        "console.log(JSON.stringify([" + ", ".join(
            f"[t.LTC_FLOAT_{i}.h, t.LTC_FLOAT_{i}.w, Array.from(t.LTC_FLOAT_{i}.data)]"
            for i in range(1, len(names) + 1)) + "]));\n")
    out = json.loads(subprocess.run(["node", "read_js.js"], cwd=tmp, capture_output=True,
                                    text=True, check=True).stdout)
    return {n: np.float32(d).reshape(h, w, -1) for n, (h, w, d) in zip(names, out)}
