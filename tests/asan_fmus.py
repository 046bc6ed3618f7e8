"""pytest plugin (``-p asan_fmus``) used by tests/test_memory.py: the FMU tests
run against FMUs whose linux64 binary is a sanitized build.

``PIEZO_SANITIZED_FMUS`` holds ``plant=PATH<pathsep>inverse=PATH``;
:func:`pysim.testing.fmus.built_fmus`, the one build path of the tests, then
returns those FMUs for the default spec (every other model is built as
usual).  This plugin routes fmpy's allocations through the sanitizer; it must
be loaded before fmpy builds its callbacks, which ``-p`` does."""
from __future__ import annotations

from pysim.testing.fmus import sanitized_fmus


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
    if sanitized_fmus():
        _allocate_through_the_sanitizer()


def pytest_report_header(config):
    swapped = sanitized_fmus()
    return f"sanitized FMUs: {', '.join(swapped)}" if swapped else None
