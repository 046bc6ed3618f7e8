"""pytest plugin (``-p asan_fmus``) used by tests/test_memory.py: the FMU tests
run against FMUs whose linux64 binary is a sanitized build.

``PIEZO_SANITIZED_FMUS`` holds ``plant=PATH<pathsep>inverse=PATH``; the
plugin makes ``fmu_testing.built_fmus()`` return those FMUs for the default
spec (every other model is built as usual).  It must be loaded before the
test modules import ``built_fmus``, which ``-p`` does."""
from __future__ import annotations

import os
from pathlib import Path


def _swapped() -> dict:
    text = os.environ.get("PIEZO_SANITIZED_FMUS", "")
    return {kind: Path(path) for kind, path in (item.split("=", 1) for item in text.split(os.pathsep) if item)}


def _allocate_through_the_sanitizer():
    """fmpy hands the FMU the C library's calloc and free resolved in libc
    itself, past the sanitizer's interceptors, so the FMU's heap blocks would
    go unchecked: give it the process-wide symbols (the preloaded runtime's)
    before fmpy.fmi2 builds its default callbacks from them."""
    import ctypes

    import fmpy

    process = ctypes.CDLL(None)
    for name in ("calloc", "realloc", "free"):
        function, original = getattr(process, name), getattr(fmpy, name)
        function.argtypes, function.restype = original.argtypes, original.restype
        setattr(fmpy, name, function)


def pytest_configure(config):
    swapped = _swapped()
    if not swapped:
        return
    _allocate_through_the_sanitizer()
    import fmu_testing

    original = fmu_testing.built_fmus

    def built_fmus(model=fmu_testing.DEFAULT_MODEL, platforms=fmu_testing.ALL_PLATFORMS):
        if model == fmu_testing.DEFAULT_MODEL and "linux64" in platforms:
            return dict(swapped)
        return original(model, platforms)

    fmu_testing.built_fmus = built_fmus


def pytest_report_header(config):
    swapped = _swapped()
    return f"sanitized FMUs: {', '.join(swapped)}" if swapped else None
