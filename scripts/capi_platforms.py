#!/usr/bin/env python3
"""Record how the C API's results agree across builds and platforms (docs/kernels.md, the
section between the markers): for every case of clbrdf.studies.capi.cases(), the C99 build (gcc) against
the Python package (width 1), and the C API compiled as OpenCL C on every OpenCL device present
against the C99 build; the largest difference over every output, in units of the precision's
eps (clbrdf.studies.capi.ulps says how it is counted).

    python scripts/capi_platforms.py [--out docs/kernels.md] [--n 400]
"""
import argparse
import datetime as _dt
import platform
import subprocess
from pathlib import Path

BEGIN, END = "<!-- capi_platforms:begin -->", "<!-- capi_platforms:end -->"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="docs/kernels.md")
    ap.add_argument("--n", type=int, default=400)
    a = ap.parse_args()
    from clbrdf.studies import capi
    from clbrdf.runtime.device import compiler_error, get_device, list_devices
    devs = [f"{i.platform_index}:{i.device_index}" for i in list_devices()
            if compiler_error((i.platform_index, i.device_index)) is None]
    names = {d: get_device(d).info for d in devs}
    gcc = subprocess.run(["gcc", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
    head = ["| case | precision | C99 vs Python | " + " | ".join(
        f"OpenCL {d} vs C99" for d in devs) + " |",
            "|---|---|---:|" + "---:|" * len(devs)]
    rows = []
    for name, _, _ in capi.cases():
        for precision in ("single", "double"):
            m = capi.model(name, precision)
            wo, wi, u = capi.inputs(a.n, m=m)
            c = capi.run_c(name, precision, wo, wi, u)
            py = capi.run_python(name, precision, wo, wi, u)
            cells = [max(capi.ulps(c, py, m.channels, precision).values())]
            for d in devs:
                if precision == "double" and not names[d].has_fp64:
                    cells.append(None)
                    continue
                o = capi.run_opencl(name, precision, wo, wi, u, device=d)
                cells.append(max(capi.ulps(o, c, m.channels, precision).values()))
            rows.append(f"| {name} | {precision} | " + " | ".join(
                "-" if x is None else f"{x:.1f}" for x in cells) + " |")
            print(rows[-1], flush=True)
    text = [BEGIN, "", f"Measured {_dt.date.today()} by `python scripts/capi_platforms.py` on "
            f"{platform.machine()} with {gcc}; {a.n} inputs per case (uniform, grazing to "
            f"mu 1e-4 and mirror pairs; the model's own Philox numbers for sampling). Largest "
            f"difference over f, pdf, the sampled wi, its weight and pdf, in units of eps of the "
            f"precision (`clbrdf.studies.capi.ulps`). OpenCL devices:", ""]
    text += [f"- `{d}`: {names[d].name} [{names[d].platform}]" for d in devs]
    text += ["", *head, *rows, "", END]
    out = Path(a.out)
    old = out.read_text() if out.exists() else ""
    if BEGIN in old:
        new = old[:old.index(BEGIN)] + "\n".join(text) + old[old.index(END) + len(END):]
    else:
        new = old.rstrip() + "\n\n" + "\n".join(text) + "\n"
    out.write_text(new)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
