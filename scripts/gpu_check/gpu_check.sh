#!/usr/bin/env bash
# clbrdf on an NVIDIA GPU: one command, run from the bundle that
# scripts/gpu_check/make_bundle.py made on a CPU machine (docs/kernels.md, "On a GPU"):
#
#   bash gpu_check.sh [OUT]          (OUT: the report's folder, default ./gpu_check_out)
#
# 1. capi: builds capi_check.cu over the C API for every case and precision of the bundle
#    (cases/*: every model, clbrdf.studies.capi.cases()) and runs eval, pdf and sample on the
#    cases' 400 inputs and the albedo of 2^16 samples at 3 mu, against the values the Python
#    package computed on the CPU (expected.txt, albedo.txt); examples/cuda_albedo.cu against
#    `clbrdf albedo` (examples/expected.json);
# 2. opencl: where NVIDIA's OpenCL driver is present, installs clbrdf and pyopencl from wheels/
#    and runs the package itself on the GPU: the conformance battery's fast subset, `clbrdf
#    check` on three models (the same verdicts as on the CPU: check/), benchmarks/bench_albedo.py;
# 3. bench: GGX albedo samples per second through the C API in CUDA (bench_cuda.cu: one thread
#    per sample stream; block size and occupancy from the CUDA occupancy API) and Cycles'
#    table_ggx_E end to end: the same samples as the table `clbrdf table` made on the CPU
#    (cycles/), and its distance to the quadrature's;
# 4. report.py writes OUT/report.md and OUT/report.json; exit 1 if any check failed.
# It stops at once (exit 2), saying what, where a tool it needs is missing. Each step has its
# own time limit, cut to what is left of one deadline (CLBRDF_GPU_CHECK_SECONDS, default 460 s
# after the start, leaving the report its seconds within 8 minutes); a step cut short fails
# (timeout's exit 124) and the report says which. Not yet timed on a GPU.
#
# Environment: PYTHON (default python3), NVCC (default nvcc), CUDA_ARCH (default native),
# JOBS (parallel builds, default nproc); for the CPU test of this script
# (tests/runtime/test_gpu_check.py): CLBRDF_GPU_CHECK_BACKEND=cpu builds the same programs with CXX
# (default g++) and runs them on the host, CLBRDF_GPU_CHECK_OPENCL=any runs step 2 on any
# OpenCL device (else: auto, NVIDIA's only; skip), CLBRDF_GPU_CHECK_NO_INSTALL=1 uses PYTHON's
# own clbrdf instead of the wheels, CLBRDF_GPU_CHECK_QUICK=1 makes step 2 and 3 small (the
# battery's GGX cases, bench_albedo.py --quick).
set -uo pipefail
B=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
OUT=$(mkdir -p "${1:-gpu_check_out}" && cd "${1:-gpu_check_out}" && pwd)
PY=${PYTHON:-python3}
BACKEND=${CLBRDF_GPU_CHECK_BACKEND:-cuda}
OPENCL=${CLBRDF_GPU_CHECK_OPENCL:-auto}
JOBS=${JOBS:-$(nproc 2>/dev/null || echo 4)}
STEPS="$OUT/steps.jsonl"
: > "$STEPS"
T0=$(date +%s)
DEADLINE=$(( T0 + ${CLBRDF_GPU_CHECK_SECONDS:-460} ))
lim() {    # a step's time limit: $1 seconds, or what is left before the deadline
    local left=$(( DEADLINE - $(date +%s) ))
    [ "$left" -lt 1 ] && left=1
    [ "$left" -gt "$1" ] && left=$1
    echo "$left"
}

say() { echo "gpu_check: $*"; }
missing() { echo "gpu_check: MISSING: $*" >&2; exit 2; }
step() {   # name status seconds detail: one line of steps.jsonl (report.py reads it)
    "$PY" -c 'import json, sys; print(json.dumps(dict(zip(["step", "status", "seconds", "detail"], sys.argv[1:]))))' \
        "$@" >> "$STEPS"
}

# ---- 0. what is needed, before any work ----
command -v "$PY" >/dev/null || missing "python ($PY): set PYTHON"
[ -f "$B/manifest.json" ] && [ -d "$B/cases" ] || missing "the bundle: run gpu_check.sh from the folder make_bundle.py wrote"
if [ "$BACKEND" = cuda ]; then
    NVCC=${NVCC:-nvcc}
    command -v "$NVCC" >/dev/null || missing "nvcc (the CUDA toolkit): put it on PATH or set NVCC"
    command -v nvidia-smi >/dev/null || missing "nvidia-smi (the NVIDIA driver)"
    nvidia-smi -L > "$OUT/gpus.txt" 2>&1 || missing "a GPU: nvidia-smi -L failed: $(cat "$OUT/gpus.txt")"
    grep -q GPU "$OUT/gpus.txt" || missing "a GPU: nvidia-smi -L lists none"
    say "$(head -1 "$OUT/gpus.txt"); $("$NVCC" --version | tail -1)"
    ARCH=${CUDA_ARCH:-native}
    build() {   # out src includes... : flags from $FLAGS
        local out=$1 src=$2; shift 2
        "$NVCC" -std=c++17 -O2 -arch="$ARCH" $FLAGS "$@" -x cu "$src" -o "$out"
    }
else
    CXX=${CXX:-g++}
    command -v "$CXX" >/dev/null || missing "$CXX (the CPU backend's compiler)"
    build() {
        local out=$1 src=$2; shift 2
        "$CXX" -std=c++17 -O2 -Wall -Wextra -Werror $FLAGS "$@" -x c++ "$src" -lm -o "$out"
    }
    say "CPU backend ($CXX): the programs run on the host"
fi
export FLAGS=""

# clbrdf for the comparisons (clbrdf.studies.capi.ulps) and step 2: from the bundle's wheels
if [ "${CLBRDF_GPU_CHECK_NO_INSTALL:-0}" = 1 ]; then
    "$PY" -c 'import clbrdf' 2>/dev/null || missing "clbrdf for $PY (CLBRDF_GPU_CHECK_NO_INSTALL=1)"
else
    ls "$B"/wheels/clbrdf-*.whl >/dev/null 2>&1 || missing "wheels/ in the bundle (make_bundle.py without --no-wheels)"
    "$PY" -m pip --version >/dev/null 2>&1 || missing "pip for $PY"
    if ! "$PY" -m pip install -q --no-index --find-links "$B/wheels" --target "$OUT/site" \
            clbrdf pytest pytest-xdist > "$OUT/pip.log" 2>&1; then
        missing "wheels for $("$PY" -V) (the bundle has: $(ls "$B"/wheels | grep -o 'cp3[0-9]*' | sort -u | tr '\n' ' ')): $(tail -2 "$OUT/pip.log")"
    fi
    export PYTHONPATH="$OUT/site${PYTHONPATH:+:$PYTHONPATH}"
    export PATH="$OUT/site/bin:$PATH"
fi
"$PY" -c 'import numpy, clbrdf.studies.capi' 2>"$OUT/import.log" || missing "an importable clbrdf and numpy: $(tail -1 "$OUT/import.log")"

# ---- 1. the C API over every model, and the CUDA example ----
t=$(date +%s)
mkdir -p "$OUT/cases"
build_case() {   # one case folder: build, rows, albedo
    local c=$1 d="$B/cases/$1" o="$OUT/cases/$1"
    mkdir -p "$o"
    if ! FLAGS="$(cat "$d/defines")" build "$o/capi_check" "$B/capi_check.cu" -I "$B/include" -I "$d" \
            > "$o/build.log" 2>&1; then
        echo "build failed" > "$o/status"; return
    fi
    "$o/capi_check" "$B/include/data" < "$d/rows.txt" > "$o/out.txt" 2> "$o/run.log" \
        || { echo "run failed" > "$o/status"; return; }
    read -r n seed mus < <("$PY" -c 'import json, sys; a = json.load(open(sys.argv[1]))["albedo"]; print(a["samples"], a["seed"], *a["mu"])' "$d/case.json")
    "$o/capi_check" "$B/include/data" albedo $n $seed $mus > "$o/albedo.txt" 2>> "$o/run.log" \
        || { echo "albedo run failed" > "$o/status"; return; }
    echo ran > "$o/status"
}
export -f build_case build
export B OUT PY NVCC ARCH CXX 2>/dev/null
ls "$B/cases" | timeout $(lim 420) xargs -P "$JOBS" -I{} bash -c 'build_case {}'
step capi done $(( $(date +%s) - t )) "$(ls "$B/cases" | wc -l) case builds"
say "capi: $(grep -l ran "$OUT"/cases/*/status | wc -l) of $(ls "$B/cases" | wc -l) case builds ran ($(( $(date +%s) - t )) s)"

t=$(date +%s)
if [ "$BACKEND" = cuda ]; then
    mkdir -p "$OUT/examples"
    if build "$OUT/examples/cuda_albedo" "$B/examples/cuda_albedo.cu" -I "$B/include" > "$OUT/examples/build.log" 2>&1; then
        read -r a mu n seed eta < <("$PY" -c 'import json, sys; e = json.load(open(sys.argv[1])); print(e["alpha"], e["mu"], e["n"], e["seed"], e["eta"])' "$B/examples/expected.json")
        { "$OUT/examples/cuda_albedo" $a $mu $n $seed; "$OUT/examples/cuda_albedo" $a $mu $n $seed $eta
          "$OUT/examples/cuda_albedo" $a -$mu $n $seed $eta; } > "$OUT/examples/out.txt" 2>&1
        step examples ran $(( $(date +%s) - t )) "cuda_albedo: ggx, glass, glass from inside"
    else
        step examples "build failed" $(( $(date +%s) - t )) "$(tail -3 "$OUT/examples/build.log")"
    fi
else
    step examples skipped 0 "the CPU backend does not run CUDA host code"
fi

# ---- 3. CUDA speed and the Cycles table (before step 2: it needs no Python) ----
t=$(date +%s)
mkdir -p "$OUT/bench"
if FLAGS="$(cat "$B/cycles/defines")" build "$OUT/bench/bench_cuda" "$B/bench_cuda.cu" -I "$B/include" \
        > "$OUT/bench/build.log" 2>&1; then
    [ "$BACKEND" = cuda ] && RATE="0.5 30 7" || RATE="0.5 16 3"
    CYC=$("$PY" -c 'import json, sys; print(json.load(open(sys.argv[1]))["samples"])' "$B/cycles/cycles.json")
    # the host does about 10 M samples/s: the Cycles table only for a small bundle there
    if [ "$BACKEND" = cuda ] || [ "$CYC" -le 65536 ]; then CYCLES=1; else CYCLES=0; fi
    if timeout $(lim 120) "$OUT/bench/bench_cuda" rate $RATE > "$OUT/bench/rate.json" 2> "$OUT/bench/run.log" \
        && { [ $CYCLES = 0 ] || timeout $(lim 120) "$OUT/bench/bench_cuda" cycles "$B/cycles/cells.txt" $CYC \
                 "$OUT/bench/cycles.txt" > "$OUT/bench/cycles.json" 2>> "$OUT/bench/run.log"; }; then
        [ $CYCLES = 1 ] && what="cycles $CYC samples per cell" \
            || what="cycles table left out: $CYC samples per cell on the host (make_bundle.py --cycles-samples 65536 for a CPU test)"
        step bench ran $(( $(date +%s) - t )) "rate $RATE; $what"
    else
        step bench "run failed" $(( $(date +%s) - t )) "$(tail -3 "$OUT/bench/run.log") (time limit 120 s a run)"
    fi
    # the arithmetic per sample (report.py counts it in the PTX): wherever nvcc is
    if command -v "${NVCC:-nvcc}" >/dev/null; then
        "${NVCC:-nvcc}" -std=c++17 -O2 -arch="${ARCH:-sm_90}" $(cat "$B/cycles/defines") -I "$B/include" -ptx \
            -x cu "$B/bench_cuda.cu" -o "$OUT/bench/bench.ptx" > "$OUT/bench/ptx.log" 2>&1 || true
    fi
else
    step bench "build failed" $(( $(date +%s) - t )) "$(tail -3 "$OUT/bench/build.log")"
fi

# ---- 2. the package itself on the GPU through OpenCL ----
t=$(date +%s)
mkdir -p "$OUT/opencl"
SEL=$("$PY" - "$OPENCL" <<'EOF' 2> "$OUT/opencl/devices.log"
import sys
want = sys.argv[1]
if want != "skip":
    from clbrdf.runtime.device import compiler_error, list_devices
    for d in list_devices():
        sel = f"{d.platform_index}:{d.device_index}"
        if (want == "any" or "nvidia" in (d.platform + d.name).lower()) and compiler_error(
                (d.platform_index, d.device_index)) is None:
            print(sel)
            break
EOF
)
if [ -z "$SEL" ]; then
    why="no NVIDIA OpenCL device (CLBRDF_GPU_CHECK_OPENCL=$OPENCL); /etc/OpenCL/vendors: $(ls /etc/OpenCL/vendors 2>/dev/null | tr '\n' ' ')"
    step opencl skipped $(( $(date +%s) - t )) "$why $(tail -1 "$OUT/opencl/devices.log")"
    say "opencl: skipped: $why"
else
    export CLBRDF_DEVICE=$SEL
    say "opencl: device $SEL"
    "$PY" -m clbrdf devices > "$OUT/opencl/devices.txt" 2>&1
    QUICK=${CLBRDF_GPU_CHECK_QUICK:-0}
    [ "$QUICK" = 1 ] && K=(-k "ggx and not dielectric") || K=()
    (cd "$B" && timeout $(lim 300) "$PY" -m pytest -q -p no:cacheprovider -o addopts="" -m "not slow" "${K[@]}" \
        -W ignore::clbrdf.api.useless.UselessEstimatorWarning --rootdir "$B" \
        --junitxml "$OUT/opencl/conformance.xml" tests/models/test_conformance.py) \
        > "$OUT/opencl/conformance.txt" 2>&1
    echo $? > "$OUT/opencl/conformance.rc"
    for m in $(ls "$B/check" | sed 's/\.json$//'); do
        timeout $(lim 120) "$PY" -m clbrdf check $m --device "$SEL" --json > "$OUT/opencl/check-$m.json" 2> "$OUT/opencl/check-$m.log"
        echo $? > "$OUT/opencl/check-$m.rc"
    done
    [ "$QUICK" = 1 ] && BA=(--quick) || BA=(--rounds 3 --log2-numpy 15 --log2-numpy-small-chunk 14)
    (cd "$B" && timeout $(lim 240) "$PY" benchmarks/bench_albedo.py --device "$SEL" --no-mitsuba "${BA[@]}") \
        > "$OUT/opencl/bench_albedo.txt" 2>&1
    echo $? > "$OUT/opencl/bench_albedo.rc"
    step opencl ran $(( $(date +%s) - t )) "device $SEL"
fi

# ---- 4. the report ----
step total done $(( $(date +%s) - T0 )) "backend $BACKEND"
"$PY" "$B/report.py" "$B" "$OUT"
