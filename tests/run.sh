#!/usr/bin/env bash
# Installs what the test suite needs on a Debian/Ubuntu machine (system packages
# via apt-get, Python packages via pip) and runs it.  Used as is by CI.
set -euo pipefail
cd "$(dirname "$0")/.."

if command -v apt-get >/dev/null 2>&1; then
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    # wine: the Windows DLL tests; libxml2-utils: xmllint schema check; valgrind:
    # memcheck and callgrind; clang + libclang-rt-14-dev: libFuzzer and sanitizers;
    # cmake: fmpy's build of the FMUs' sources
    $SUDO apt-get install -y -qq --no-install-recommends \
        wine wine64 libxml2-utils valgrind clang libclang-rt-14-dev cmake gcc make >/dev/null
fi

python3 -m pip install -q --disable-pip-version-check -e ".[test,bench]"
# a pyenv-managed Python needs its shims refreshed to see new console scripts
if command -v pyenv >/dev/null 2>&1; then pyenv rehash || true; fi
python3 -m pytest -q
