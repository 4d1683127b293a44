#!/usr/bin/env python3
"""The GPU check's report (scripts/gpu_check/gpu_check.sh runs it last): reads the bundle B
and the run's folder OUT, compares every output with the CPU's values and writes OUT/report.md
and OUT/report.json. Exit 0 when every check that ran passed, 1 otherwise.

    python report.py BUNDLE OUT

Agreement per case and precision: the largest difference over f, pdf, the sampled wi, its
weight and pdf in units of the precision's eps (clbrdf.studies.capi.ulps, the measure of
tests/runtime/test_capi.py and docs/kernels.md), within the case's bound (case.json); the albedo's mean
weight within the same number of eps of its mean |weight|; the CUDA example within examples/
expected.json's relative tolerance (the same samples); the Cycles table within cycles.json's
relative tolerance of the CPU's table from the same samples (its distance to the quadrature, the
table's own error, is reported beside it).
"""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np

# FP32, SFU (MUFU) and INT32 lanes per SM per clock by compute capability major, Volta to
# Blackwell (the CUDA C++ Programming Guide's table of arithmetic instruction throughput)
LANES = {7: (64, 16, 64), 8: (128, 16, 64), 9: (128, 16, 64), 10: (128, 16, 64)}
# what one PTX instruction costs in machine instructions (fp32, mufu, int), where it is not one
# of its class: IEEE sqrt, reciprocal and division are a MUFU estimate and Newton steps; a 64-bit
# integer operation is two 32-bit ones (a 64-bit multiply three)
PTX_COST = {"sqrt.rn.f32": (7, 1, 0), "rcp.rn.f32": (4, 1, 0), "div.rn.f32": (8, 1, 0),
            "mul.lo.s64": (0, 0, 3), "mul.lo.u64": (0, 0, 3), "mul.wide.u32": (0, 0, 2),
            "mul.wide.s32": (0, 0, 2)}
FP32_OPS = ("add", "sub", "mul", "fma", "min", "max", "neg", "abs", "setp", "selp", "cvt")
INT_OPS = ("add", "sub", "mul", "mad", "xor", "and", "or", "not", "shl", "shr", "setp", "selp",
           "min", "max", "cvt")
SFU_OPS = ("ex2", "lg2", "sin", "cos", "rsqrt", "rcp", "sqrt", "tanh")


def load_rows(p: Path) -> np.ndarray:
    return np.loadtxt(p, ndmin=2)


def capi_results(B: Path, OUT: Path) -> list:
    from clbrdf.studies.capi import ulps
    rows = []
    for d in sorted((B / "cases").iterdir()):
        meta = json.loads((d / "case.json").read_text())
        o = OUT / "cases" / d.name
        status = (o / "status").read_text().strip() if (o / "status").exists() else "not run"
        r = {"case": meta["case"], "precision": meta["precision"], "bound": meta["ulps"],
             "status": status}
        if status == "ran":
            got, want = load_rows(o / "out.txt"), load_rows(d / "expected.txt")
            if got.shape != want.shape:
                r.update(status="wrong shape", detail=f"{got.shape} for {want.shape}")
            else:
                u = ulps(got, want, meta["channels"], meta["precision"])
                worst = max(u, key=u.get)
                r.update(ulps=u[worst], worst=worst)
                a, e = load_rows(o / "albedo.txt"), load_rows(d / "albedo.txt")
                eps = float(np.finfo(np.float32 if meta["precision"] == "single" else np.float64).eps)
                scale = np.asarray(meta["albedo"]["mean_abs_weight"])[:, None]
                r["albedo_ulps"] = float(np.max(np.abs(a - e) / (eps * scale)))
                r["albedo"] = a[:, 0].tolist()
                ok = r["ulps"] <= meta["ulps"] and r["albedo_ulps"] <= meta["ulps"]
                r["status"] = "agree" if ok else "DISAGREE"
        else:
            log = o / ("build.log" if "build" in status else "run.log")
            r["detail"] = log.read_text()[-1500:] if log.exists() else ""
        rows.append(r)
    return rows


def examples_result(B: Path, OUT: Path):
    p = OUT / "examples" / "out.txt"
    if not p.exists():
        return None
    e = json.loads((B / "examples" / "expected.json").read_text())
    lines = p.read_text().splitlines()
    out = []
    for name, line in zip(("ggx", "glass", "glass_in"), lines):
        val, _, dev = line.partition(" ")
        try:
            v = float(val)
        except ValueError:
            out.append({"name": name, "status": "run failed", "detail": line})
            continue
        want = e["expected"][name]
        ok = abs(v - want) <= e["tol"] * abs(want)
        out.append({"name": name, "value": v, "expected": want, "device": dev,
                    "status": "agree" if ok else "DISAGREE"})
    if len(out) < 3:
        out.append({"name": "missing lines", "status": "run failed", "detail": p.read_text()[-500:]})
    return out


def ptx_counts(p: Path) -> dict | None:
    """Machine instructions by class (fp32, mufu, int) in the bench kernel's PTX (sums_kernel),
    static: its loop body is one sample, so these are per-sample counts plus the kernel's few
    set-up instructions; PTX_COST for the instructions that expand. Moves, loads, stores and
    branches are not counted."""
    if not p.exists():
        return None
    out, cur = {"fp32": 0, "mufu": 0, "int": 0}, False
    for line in p.read_text().splitlines():
        if ".entry" in line:
            cur = "sums_kernel" in line
            continue
        if not cur:
            continue
        m = re.match(r"\s+(?:@!?%p\d+\s+)?([a-z][a-z0-9]*(?:\.[a-z0-9]+)*)", line)
        if not m:
            continue
        op = m.group(1)
        base, typ = op.split(".")[0], op.rsplit(".", 1)[-1]
        if op in PTX_COST:
            for k, c in zip(("fp32", "mufu", "int"), PTX_COST[op]):
                out[k] += c
        elif base in SFU_OPS and ".approx" in op:
            out["mufu"] += 1
        elif typ == "f32" and base in FP32_OPS:
            out["fp32"] += 1
        elif re.fullmatch(r"[usb](32|64)", typ) and base in INT_OPS:
            out["int"] += 2 if typ.endswith("64") else 1
    return out if any(out.values()) else None


def bench_result(B: Path, OUT: Path) -> dict | None:
    d = OUT / "bench"
    if not (d / "rate.json").exists() or not (d / "rate.json").read_text().strip():
        return None
    r = {"rate": json.loads((d / "rate.json").read_text())}
    if (d / "cycles.json").exists() and (d / "cycles.txt").exists():
        meta = json.loads((B / "cycles" / "cycles.json").read_text())
        r["cycles"] = json.loads((d / "cycles.json").read_text())
        got = load_rows(d / "cycles.txt")
        want = np.loadtxt(B / "cycles" / "expected.txt")
        quad = np.loadtxt(B / "cycles" / "quadrature.txt")
        rel = float(np.max(np.abs(got[:, 0] - want) / np.abs(want)))
        r["cycles"].update(max_rel_diff=rel, tol=meta["tol"],
                           max_abs_quadrature=float(np.max(np.abs(got[:, 0] - quad))),
                           status="agree" if got.shape[0] == want.size and rel <= meta["tol"]
                           else "DISAGREE")
    r["ptx"] = ptx_counts(d / "bench.ptx")
    return r


def verdicts(p: Path) -> dict:
    try:
        return {c["name"]: c["passed"] for c in json.loads(p.read_text())["checks"]}
    except (ValueError, KeyError, OSError):
        return {}


def opencl_result(B: Path, OUT: Path) -> dict | None:
    d = OUT / "opencl"
    if not (d / "conformance.rc").exists():
        return None

    def rc(name):
        return int((d / f"{name}.rc").read_text().strip() or 1)
    tail = (d / "conformance.txt").read_text().strip().splitlines()
    checks = {}
    for f in sorted((B / "check").glob("*.json")):
        want, got = verdicts(f), verdicts(d / f"check-{f.stem}.json")
        checks[f.stem] = {"rc": rc(f"check-{f.stem}"), "cpu": want, "gpu": got,
                          "status": "same verdicts" if got and got == want else "DIFFERENT"}
    return {"conformance": {"rc": rc("conformance"), "summary": tail[-1] if tail else ""},
            "check": checks, "bench_albedo": {"rc": rc("bench_albedo")},
            "devices": (d / "devices.txt").read_text() if (d / "devices.txt").exists() else ""}


def main(argv):
    B, OUT = Path(argv[1]), Path(argv[2])
    steps = [json.loads(x) for x in (OUT / "steps.jsonl").read_text().splitlines() if x.strip()]
    manifest = json.loads((B / "manifest.json").read_text())
    capi = capi_results(B, OUT)
    ex = examples_result(B, OUT)
    bench = bench_result(B, OUT)
    ocl = opencl_result(B, OUT)
    gpus = (OUT / "gpus.txt").read_text().strip() if (OUT / "gpus.txt").exists() else "(CPU backend)"
    fails = [f"capi {r['case']} {r['precision']}: {r['status']}" for r in capi if r["status"] != "agree"]
    fails += [f"example {e['name']}: {e['status']}" for e in (ex or []) if e["status"] != "agree"]
    if bench and bench.get("cycles", {}).get("status") == "DISAGREE":
        fails.append("cycles table: DISAGREE")
    fails += [f"step {s['step']}: {s['status']}" for s in steps if "failed" in s["status"]]
    if ocl:
        if ocl["conformance"]["rc"]:
            fails.append(f"conformance battery (OpenCL): rc {ocl['conformance']['rc']}")
        fails += [f"clbrdf check {m}: {c['status']} (GPU {c['gpu']}, CPU {c['cpu']})"
                  for m, c in ocl["check"].items() if c["status"] != "same verdicts"]
        if ocl["bench_albedo"]["rc"]:
            fails.append(f"bench_albedo.py: rc {ocl['bench_albedo']['rc']}")

    L = ["# clbrdf GPU check", "", f"- GPU: {gpus}",
         f"- bundle: made {manifest['made']} at commit {manifest['commit']} on {manifest['device']}",
         f"- steps: " + "; ".join(f"{s['step']} {s['status']} ({s['seconds']} s)" for s in steps), "",
         "## 1. The C API against the Python package on the CPU", "",
         "Largest difference over f, pdf, sampled wi, weight and pdf (units of eps, "
         "clbrdf.studies.capi.ulps) on 400 inputs; the albedo (2^16 samples at mu 0.2, 0.6, 1) "
         "in eps of the mean |weight|.", "",
         "| case | precision | bound | eval/pdf/sample (eps) | worst column | albedo (eps) | status |",
         "|---|---|---:|---:|---|---:|---|"]
    for r in capi:
        L.append(f"| {r['case']} | {r['precision']} | {r['bound']} | "
                 f"{r.get('ulps', float('nan')):.1f} | {r.get('worst', '-')} | "
                 f"{r.get('albedo_ulps', float('nan')):.1f} | {r['status']} |")
    for r in capi:
        if r.get("detail"):
            L += ["", f"{r['case']} {r['precision']} ({r['status']}):", "```", r["detail"], "```"]
    if ex:
        L += ["", "CUDA example (examples/cuda_albedo.cu, the same samples as `clbrdf albedo`):", ""]
        L += [f"- {e['name']}: {e.get('value')} for {e.get('expected')}: {e['status']}" for e in ex]
    if bench:
        rt = bench["rate"]
        L += ["", "## 3. Speed in CUDA through the C API", "",
              f"GGX alpha {rt['alpha']}, 64 mu, {rt['samples']:.3g} samples a launch, one thread per "
              f"stream of {rt['stream']} samples: **{rt['samples_per_s'] / 1e9:.2f} G samples/s** "
              f"(median; fastest launch {rt['samples'] / rt['seconds_min'] / 1e9:.2f}); block "
              f"{rt['block']}, occupancy {rt['occupancy']:.2f}. E at mu {rt['mu'][0]}: {rt['E'][0]:.6f} "
              f"+- {rt['stderr'][0]:.1g}; at mu {rt['mu'][1]}: {rt['E'][1]:.6f} +- {rt['stderr'][1]:.1g}."]
        if bench.get("ptx"):
            s = bench["ptx"]
            L += ["", f"Arithmetic counted per sample (the kernel's PTX, static; its loop body is "
                  f"one sample: report.py's ptx_counts): {s['fp32']} FP32, {s['mufu']} MUFU "
                  f"(special functions), {s['int']} INT32 instructions (Philox4x32-10 is most of "
                  f"the integer work). The physical limit is the chip's rate of the busiest class "
                  f"over its count: {physical_note(s, rt)}"]
        if "cycles" in bench:
            c = bench["cycles"]
            L += ["", f"Cycles table_ggx_E ({c['cells']} cells x {c['samples_per_cell']} samples): "
                  f"{c['seconds_end_to_end']:.3f} s end to end, kernel {c['seconds_kernel']:.3f} s; "
                  f"against the CPU's table from the same samples: max relative difference "
                  f"{c['max_rel_diff']:.2g} (tolerance {c['tol']:g}): {c['status']}; its distance "
                  f"to the quadrature (the table's own error): max {c['max_abs_quadrature']:.2g}."]
    L += ["", "## 2. The package through OpenCL", ""]
    if ocl:
        L += [f"- conformance battery, fast subset: {ocl['conformance']['summary']} "
              f"(rc {ocl['conformance']['rc']})"]
        L += [f"- clbrdf check {m}: {c['status']} as on the CPU (failing: "
              f"{', '.join(k for k, v in c['gpu'].items() if not v) or 'none'})"
              for m, c in ocl["check"].items()]
        L += [f"- benchmarks/bench_albedo.py: rc {ocl['bench_albedo']['rc']} "
              f"(its table: opencl/bench_albedo.txt)", "", "```", ocl["devices"].strip(), "```"]
    else:
        L += ["- " + next((f"{s['status']}: {s['detail']}" for s in steps if s["step"] == "opencl"),
                          "not run")]
    L += ["", "## Verdict", ""]
    L += [f"- FAILED: {f}" for f in fails] or ["- every check that ran passed"]
    (OUT / "report.md").write_text("\n".join(L) + "\n")
    (OUT / "report.json").write_text(json.dumps({"gpus": gpus, "manifest": manifest, "steps": steps,
                                                 "capi": capi, "examples": ex, "bench": bench,
                                                 "opencl": ocl, "failures": fails}, indent=1))
    print("\n".join(L))
    print(f"gpu_check: wrote {OUT / 'report.md'}; {len(fails)} failures")
    return 1 if fails else 0


def physical_note(s: dict, rt: dict) -> str:
    """Where the device's properties are known (rate.json: sm, clock_khz, cc), samples/s at the
    busiest class's peak; else the counts alone."""
    if not all(k in rt for k in ("sm", "clock_khz", "cc")):
        return "the device's SM count and clock were not reported."
    fp, mu, it = LANES.get(int(rt["cc"]), LANES[9])
    hz = rt["clock_khz"] * 1e3 * rt["sm"]
    limits = {"FP32": fp * hz / max(s["fp32"], 1), "MUFU": mu * hz / max(s["mufu"], 1),
              "INT32": it * hz / max(s["int"], 1)}
    k = min(limits, key=limits.get)
    return (f"{rt['sm']} SMs at {rt['clock_khz'] / 1e6:.2f} GHz: FP32 {fp * hz / 1e12:.1f} T instr/s "
            f"-> {limits['FP32'] / 1e9:.0f} G samples/s, MUFU -> {limits['MUFU'] / 1e9:.0f}, INT32 -> "
            f"{limits['INT32'] / 1e9:.0f}; the limit is {k}'s {limits[k] / 1e9:.0f} G samples/s, "
            f"measured {rt['samples_per_s'] / limits[k]:.0%} of it.")


if __name__ == "__main__":
    sys.exit(main(sys.argv))
