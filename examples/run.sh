#!/usr/bin/env bash
# Build and run every example this machine can run, each result beside the Python package's.
#
#   bash examples/run.sh        (after bash run.sh: uses .venv, or CLBRDF_PYTHON: any Python
#                                    with clbrdf installed; the headers are its `clbrdf --include`)
#
# c99_albedo (gcc), opencl_albedo (gcc and the OpenCL ICD loader: Debian ocl-icd-opencl-dev),
# cuda_albedo (nvcc; run only where a CUDA device answers); c99_albedo and cuda_albedo also
# sample rough glass (ggx_dielectric, from both sides) against `clbrdf albedo ggx_dielectric`;
# energy_compensation (gcc and a
# generated Cycles-layout header); ltc_quad (gcc and a generated Charlie LTC table: a quad light
# shaded with ltc_polygon, against the same lookup and clbrdf.ref.ltc in Python). The albedo examples draw the same samples as
# `clbrdf albedo ggx --estimator brdf --width 1` (clbrdf_random2): they must agree with it to
# TOL relative (summation order; the estimate's own standard error is 3.6e-4 relative), and the
# header's lookup with clbrdf.Table.lookup to the 6 decimals the example prints. Exit 1 on any disagreement; an example this
# machine cannot build or run is reported as skipped.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PY=${CLBRDF_PYTHON:-$ROOT/.venv/bin/python}
ALPHA=0.3 MU=0.5 N=1048576 SEED=7 TOL=1e-5
OUT=$(mktemp -d)
cd "$OUT"           # Python runs outside the checkout: the installed clbrdf, not ./clbrdf
INC=$("$PY" -m clbrdf --include)     # the C headers of the installed package
trap 'rm -rf "$OUT"' EXIT
WARN=(-Wall -Wextra -Werror)
fail=0

python_albedo() {    # [mu eta]: rough glass (ggx_dielectric) at that mu and eta
    if [ $# -gt 0 ]; then
        set -- ggx_dielectric -p eta=$2 --mu=$1
    else
        set -- ggx --mu=$MU
    fi
    "$PY" -m clbrdf albedo "$1" -p alpha=$ALPHA "${@:2}" --estimator brdf --samples $N \
        --seed $SEED --width 1 --json | "$PY" -c 'import json, sys; print(json.load(sys.stdin)["albedo"][0])'
}

compare() {     # name, value, reference, tolerance (relative)
    if "$PY" -c "import sys; a, b, t = map(float, sys.argv[1:]); sys.exit(abs(a - b) > t * abs(b))" "$2" "$3" "$4"; then
        printf '%-22s %.9f   python %.9f   agree (%s)\n' "$1" "$2" "$3" "$4"
    else
        printf '%-22s %.9f   python %.9f   DISAGREE (tolerance %s)\n' "$1" "$2" "$3" "$4"
        fail=1
    fi
}

ref=$(python_albedo)
ETA=1.5
glass_out=$(python_albedo $MU $ETA) glass_in=$(python_albedo -$MU $ETA)
echo "GGX alpha $ALPHA, mu $MU, $N samples, seed $SEED (python: clbrdf albedo, brdf, Philox, width 1);"
echo "glass (ggx_dielectric) eta $ETA from outside (mu $MU) and inside (mu -$MU)"

if command -v gcc >/dev/null; then
    gcc -std=c99 "${WARN[@]}" -pedantic -O2 -I "$INC" "$ROOT"/examples/c99_albedo.c -lm -o "$OUT/c99_albedo"
    compare c99_albedo "$("$OUT/c99_albedo" $ALPHA $MU $N $SEED | cut -d' ' -f1)" "$ref" $TOL
    compare "c99_albedo glass" "$("$OUT/c99_albedo" $ALPHA $MU $N $SEED $ETA | cut -d' ' -f1)" \
        "$glass_out" $TOL
    compare "c99_albedo glass in" "$("$OUT/c99_albedo" $ALPHA -$MU $N $SEED $ETA | cut -d' ' -f1)" \
        "$glass_in" $TOL
else
    echo "c99_albedo             skipped: no gcc"
fi

if command -v gcc >/dev/null && [ -f /usr/include/CL/cl.h ]; then
    gcc -std=c99 -Wall -Wextra -Werror -O2 "$ROOT"/examples/opencl_albedo.c -lOpenCL -lm -o "$OUT/opencl_albedo"
    line=$("$OUT/opencl_albedo" "$INC" $ALPHA $MU $N $SEED)
    compare "opencl_albedo" "${line%% *}" "$ref" $TOL
    echo "                       (device: ${line#* })"
else
    echo "opencl_albedo          skipped: needs gcc and CL/cl.h (apt-get install ocl-icd-opencl-dev)"
fi

if command -v nvcc >/dev/null; then
    nvcc -std=c++17 -O2 -I "$INC" "$ROOT"/examples/cuda_albedo.cu -o "$OUT/cuda_albedo"
    if line=$("$OUT/cuda_albedo" $ALPHA $MU $N $SEED 2>/dev/null); then
        compare "cuda_albedo" "${line%% *}" "$ref" $TOL
        echo "                       (device: ${line#* })"
        line=$("$OUT/cuda_albedo" $ALPHA $MU $N $SEED $ETA)
        compare "cuda_albedo glass" "${line%% *}" "$glass_out" $TOL
        line=$("$OUT/cuda_albedo" $ALPHA -$MU $N $SEED $ETA)
        compare "cuda_albedo glass in" "${line%% *}" "$glass_in" $TOL
    else
        echo "cuda_albedo            built; not run: no CUDA device"
    fi
else
    echo "cuda_albedo            skipped: no nvcc"
fi

if command -v gcc >/dev/null; then
    "$PY" -m clbrdf table --layout cycles --only table_ggx_E --only table_ggx_Eavg \
        --samples 16384 --out "$OUT/ggx_E.h" \
        --out "$OUT/ggx_E.npz" >/dev/null
    gcc -std=c99 -Wall -Wextra -Werror -I "$OUT" "$ROOT"/examples/energy_compensation.c -lm \
        -o "$OUT/energy_compensation"
    line=$("$OUT/energy_compensation")
    e=$(echo "$line" | sed 's/.*: E \([0-9.]*\),.*/\1/')
    want=$("$PY" -c "
import clbrdf
print(clbrdf.Table.load('$OUT/ggx_E.npz', 'table_ggx_E').lookup(0.5, 0.75))")
    compare "energy_compensation" "$e" "$want" 1.5e-6     # it prints 6 decimals
    echo "                       ($line)"
fi
if command -v gcc >/dev/null; then
    "$PY" -m clbrdf ltc charlie --axis sqrt1m_mu=0:1:8:max=0.999602 --axis alpha=0.05:1:8 \
        --samples 256 --report-samples 4096 --out "$OUT/charlie_ltc.h" --out "$OUT/charlie_ltc.npz" >/dev/null
    gcc -std=c99 -Wall -Wextra -Werror -I "$INC" -I "$OUT" "$ROOT"/examples/ltc_quad.c -lm \
        -o "$OUT/ltc_quad"
    line=$("$OUT/ltc_quad" 0.6 0.4)
    want=$("$PY" -c "
import numpy as np, clbrdf
from clbrdf.ref.ltc import ltc_polygon
t = clbrdf.Table.load('$OUT/charlie_ltc.npz', 'ltc')
v = np.sqrt(1 - 0.6)
r = t.lookup(v, 0.4)
m = np.asarray(r[:9], float).reshape(3, 3)
q = np.array([[0.5, -0.5, 0.5], [1.5, -0.5, 0.5], [1.5, 0.5, 1.0], [0.5, 0.5, 1.0]])
print(r[9] * ltc_polygon(m, q))")
    compare "ltc_quad" "${line%% *}" "$want" 2e-6
    echo "                       ($line)"
fi
exit $fail
