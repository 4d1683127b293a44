#!/usr/bin/env bash
# Set up clbrdf in a virtual environment and run it.
#
#   bash run.sh                 the main job: a GGX albedo table (ggx_albedo.npz + ggx_albedo.png)
#   bash run.sh test [ARGS]     the test suite (pytest ARGS, e.g. -m slow for the slow tests)
#   bash run.sh cli ARGS        any clbrdf command, e.g. bash run.sh cli devices
#
# Steps: python3 with venv (apt-get install python3-venv if missing), a venv in .venv
# (CLBRDF_VENV overrides), pip install -e '.[test]' (again only when pyproject.toml changes),
# then Debian's PoCL (as root, when missing) and a probe for a working OpenCL device; for the
# tests also gcc, g++ and ocl-icd-opencl-dev (as root, when missing: the C API and examples). PyPI's PoCL
# (LLVM 14) fails on CPUs that LLVM 14 does not know ("unknown target CPU") and is slower where it
# works; without root and without a working device the apt command is printed.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"

VENV=${CLBRDF_VENV:-.venv}
PY=${PYTHON:-python3}
MODE=demo
case "${1:-}" in
    demo|test|cli) MODE=$1; shift ;;
    -*|"") ;;                           # options for the demo command
    *) echo "run.sh: unknown mode '$1': use demo (default), test or cli" >&2; exit 2 ;;
esac

say() { echo "run.sh: $*" >&2; }

apt_install() {
    if [ "$(id -u)" = 0 ]; then
        say "installing $* with apt-get"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -q
        apt-get install -y -q "$@"
    else
        say "needs Debian packages; run as root:"
        say "    sudo apt-get update && sudo apt-get install -y $*"
        say "then run this command again"
        exit 1
    fi
}

# 1. python3 with venv and ensurepip (Debian ships them in python3-venv)
if ! command -v "$PY" >/dev/null 2>&1; then
    apt_install python3 python3-venv
fi
if ! "$PY" -c 'import venv, ensurepip' >/dev/null 2>&1; then
    apt_install python3-venv
fi

# 2. the virtual environment (recreated when a previous attempt left it without pip)
if [ ! -x "$VENV/bin/python" ] || [ ! -x "$VENV/bin/pip" ]; then
    say "creating virtual environment $VENV"
    rm -rf "$VENV"
    "$PY" -m venv "$VENV"
fi

# 3. clbrdf and the test dependencies, editable
STAMP="$VENV/.clbrdf-installed"
WANT="$(cat pyproject.toml | sha256sum | cut -d' ' -f1)"
if [ ! -f "$STAMP" ] || [ "$(cat "$STAMP")" != "$WANT" ]; then
    say "pip install -e '.[test]' into $VENV"
    "$VENV/bin/python" -m pip install -q --disable-pip-version-check -e '.[test]'
    echo "$WANT" > "$STAMP"
fi

# 4. a working OpenCL device. Debian's PoCL (3.1, LLVM 15) is installed as root even where PyPI's
# (3.0-rc2, LLVM 14) works: on a Xeon it ran GGX albedo 1.2x as fast (benchmarks/RESULTS.md).
probe() { "$VENV/bin/python" -c 'import clbrdf; clbrdf.get_device()' 2>&1; }
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1 \
        && ! dpkg -s pocl-opencl-icd >/dev/null 2>&1; then
    apt_install pocl-opencl-icd
fi
if ! msg=$(probe); then
    say "no working OpenCL device yet: $(echo "$msg" | tail -n 1)"
    apt_install pocl-opencl-icd
    if ! msg=$(probe); then
        say "still no working OpenCL device:"
        echo "$msg" | tail -n 1 >&2
        exit 3
    fi
fi

# 5. for the tests: the compilers and the OpenCL headers the C API and examples are built with
# (tests/runtime/test_capi.py, examples/run.sh), installed as root where missing
if [ "$MODE" = test ] && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    need=()
    for pkg in gcc g++ ocl-icd-opencl-dev; do
        dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
    done
    if [ ${#need[@]} -gt 0 ]; then
        apt_install "${need[@]}"
    fi
fi

# 6. the job
case "$MODE" in
    demo)
        exec "$VENV/bin/clbrdf" table ggx --axis mu=0.02:1:32 --axis alpha=0.02:1:32 \
            --samples 65536 --out ggx_albedo.npz "$@" ;;
    test)
        exec "$VENV/bin/python" -m pytest "$@" ;;
    cli)
        exec "$VENV/bin/clbrdf" "$@" ;;
esac
