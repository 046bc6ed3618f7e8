#!/usr/bin/env bash
# The test command of the README, run as is by CI.  It does what a user does:
#   1. installs the system packages the tests need (apt-get, where there is one);
#   2. builds a wheel of this checkout and installs it, not editable, with its
#      test and bench extras, into a fresh virtual environment;
#   3. from an empty folder, runs `pysim demo` and `build-fmu` as a user would;
#   4. runs the test suite from that empty folder against the installed package
#      (tests/conftest.py checks that pysim is not imported from this checkout),
#      one worker process per core (pytest-xdist), each test file on one worker
#      so that a file's shared fixtures are computed once, with the BLAS and numpy
#      kernels pinned (tests/pin_kernels.sh).
# PIEZO_MPI_VENV names the environment to create (default: a temporary folder);
# PIEZO_MPI_TEST_WORKERS the number of worker processes (default: one per core).
set -euo pipefail
REPO="$(cd "$(dirname "$0")/.." && pwd)"
cd "$REPO"

if command -v apt-get >/dev/null 2>&1; then
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    # wine: the Windows DLL tests; libxml2-utils: xmllint schema check; valgrind:
    # memcheck and callgrind; clang + libclang-rt-14-dev: libFuzzer and sanitizers;
    # cmake: fmpy's build of the FMUs' sources; python3-venv: the fresh environment
    $SUDO apt-get install -y -qq --no-install-recommends \
        wine wine64 libxml2-utils valgrind clang libclang-rt-14-dev cmake gcc make python3-venv >/dev/null
fi

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
VENV="${PIEZO_MPI_VENV:-$WORK/venv}"
PY=python3

echo "== wheel of $REPO"
# (setuptools leaves build/ and *.egg-info in the checkout: both are in .gitignore)
$PY -m pip wheel -q --disable-pip-version-check --no-deps -w "$WORK/dist" "$REPO"
WHEEL="$(ls "$WORK"/dist/piezo_mpi-*.whl)"
echo "   $(basename "$WHEEL")"

echo "== fresh virtual environment, wheel installed (not editable)"
$PY -m venv "$VENV"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check "${WHEEL}[test,bench]"

echo "== pysim demo and build-fmu from an empty folder"
mkdir -p "$WORK/user"
(
    cd "$WORK/user"
    "$VENV/bin/pysim" demo --out demo_out >/dev/null
    "$VENV/bin/build-fmu" default_mpi -o fmus -q
    for f in demo_out/report.md demo_out/results.json demo_out/bode.png fmus/default_mpi_plant.fmu \
             fmus/default_mpi_inverse.fmu; do
        [ -s "$f" ] || { echo "tests/run.sh: $f was not written" >&2; exit 1; }
    done
    "$VENV/bin/python" - <<'EOF'
import importlib.util, pathlib, sys
import pysim
site = pathlib.Path(pysim.__file__).resolve().parent.parent
for generic in ("models", "fmu_src"):
    assert not (site / generic).exists(), f"a top-level package {generic!r} was installed"
print(f"   pysim from {site}; demo_out/ and fmus/ written")
EOF
)

echo "== test suite against the installed package"
cd "$WORK/user"
# the same floating-point kernels on every x86-64 machine (why: in the file)
. "$REPO/tests/pin_kernels.sh"
# one BLAS thread per worker: the workers already use every core, and BLAS threads beside them
# would only wait on each other
PIEZO_MPI_TEST_INSTALLED=1 PIEZO_MPI_REPO="$REPO" OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
    "$VENV/bin/python" -m pytest -q -p no:cacheprovider -c "$REPO/pyproject.toml" --rootdir "$REPO" \
    -n "${PIEZO_MPI_TEST_WORKERS:-auto}" --dist loadfile "$REPO/tests"
