"""Loads the C hysteresis kernel (``fmu_src/hysteresis.c``, with the output
stages of extended models, ``fmu_src/output_stages.c``, the slew limit of an
input stage, ``fmu_src/input_stages.c``, and the mathematics of the MPI
parameters, ``fmu_src/mpi_parameters.c``) for the host.

The play-operator recursion, the forward model and the exact inverse exist once,
in C; the FMUs compile that file and so does this module, so the Python model and
the FMUs compute with the same code.  The library is compiled on first use into a
cache folder (``$PIEZO_MPI_CACHE`` or ``~/.cache/piezo-mpi``), keyed by a hash of
the source and the compiler, with the system C compiler if there is one and zig
(PyPI ``ziglang``) otherwise.
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np

from pysim.core.toolchain import SOURCE_DIR, cache_dir, host_compiler

_SOURCES = ("hysteresis.c", "hysteresis.h", "output_stages.c", "output_stages.h", "mpi_parameters.c",
            "mpi_parameters.h", "input_stages.c", "input_stages.h")
_C_FILES = tuple(name for name in _SOURCES if name.endswith(".c"))
_lock = threading.Lock()
_library = None

_DOUBLE_P = ctypes.POINTER(ctypes.c_double)


class HystModel(ctypes.Structure):
    """Mirror of ``HystModel`` in hysteresis.h."""

    _fields_ = [
        ("operator_kind", ctypes.c_int),
        ("n_operators", ctypes.c_int),
        ("a1", ctypes.c_double),
        ("a2", ctypes.c_double),
        ("input_offset", ctypes.c_double),
        ("output_offset", ctypes.c_double),
        ("thresholds", _DOUBLE_P),
        ("weights", _DOUBLE_P),
    ]


class MpiInvertibility(ctypes.Structure):
    """Mirror of ``MpiInvertibility`` in mpi_parameters.h."""

    _fields_ = [
        ("invertible", ctypes.c_int),
        ("descending", ctypes.c_int),
        ("n_active", ctypes.c_int),
        ("min_slope", ctypes.c_double),
        ("worst_voltage", ctypes.c_double),
    ]


def _library_name() -> str:
    if sys.platform == "win32":
        return "hysteresis.dll"
    if sys.platform == "darwin":
        return "libhysteresis.dylib"
    return "libhysteresis.so"


def _build(target: Path, compiler: list[str]) -> None:
    export = "__declspec(dllexport)" if sys.platform == "win32" else '__attribute__((visibility("default")))'
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        out = Path(tmp) / target.name
        cmd = compiler + [
            "-shared", "-fPIC", "-O2", "-std=c99", "-ffp-contract=off", "-fvisibility=hidden",
            f"-DHYST_API={export}", *(str(SOURCE_DIR / name) for name in _C_FILES), "-o", str(out),
        ]
        result = subprocess.run(cmd, capture_output=True, text=True)
        if result.returncode != 0:
            raise RuntimeError(
                "could not compile the hysteresis kernel with "
                f"{' '.join(compiler)}:\n{result.stderr.strip()}"
            )
        os.replace(out, target)  # atomic: a concurrent user sees all or nothing


def library() -> ctypes.CDLL:
    """The loaded kernel library (compiled on first use)."""
    global _library
    with _lock:
        if _library is not None:
            return _library
        compiler = host_compiler()
        digest = hashlib.sha256()
        for name in _SOURCES:
            digest.update((SOURCE_DIR / name).read_bytes())
        digest.update(" ".join(compiler).encode())
        target = cache_dir() / digest.hexdigest()[:16] / _library_name()
        if not target.exists():
            _build(target, compiler)
        lib = ctypes.CDLL(str(target))
        size_t, double, p = ctypes.c_size_t, ctypes.c_double, _DOUBLE_P
        model_p = ctypes.POINTER(HystModel)
        lib.hyst_simulate.argtypes = [model_p, size_t, p, p, p, p]
        lib.hyst_simulate.restype = None
        lib.hyst_simulate_scaled.argtypes = [model_p, size_t, p, p, p, p, p]
        lib.hyst_simulate_scaled.restype = None
        lib.hyst_invert_run.argtypes = [model_p, size_t, p, p, double, double, p]
        lib.hyst_invert_run.restype = size_t
        lib.hyst_invert_previous_sample_run.argtypes = [
            model_p, double, double, double, size_t, p, p, p, double, double, p]
        lib.hyst_invert_previous_sample_run.restype = None
        lib.mpi_invertibility.argtypes = [model_p, double, double, p, ctypes.POINTER(MpiInvertibility)]
        lib.mpi_invertibility.restype = None
        lib.mpi_inverse_parameters.argtypes = [model_p, model_p, p, p, p]
        lib.mpi_inverse_parameters.restype = ctypes.c_int
        char_pp = ctypes.POINTER(ctypes.c_char_p)
        size_p = ctypes.POINTER(size_t)
        lib.mpi_host_layout.argtypes = [size_t, char_pp, char_pp, size_p, size_p]
        lib.mpi_host_layout.restype = ctypes.c_int
        lib.mpi_host_max_delay.argtypes = []
        lib.mpi_host_max_delay.restype = ctypes.c_long
        lib.istage_slew_limit.argtypes = [size_t, p, double, p]
        lib.istage_slew_limit.restype = None
        _library = lib
        return lib


def as_pointer(array: np.ndarray):
    """ctypes double pointer to a C-contiguous float64 array (or NULL for None)."""
    if array is None:
        return None
    return array.ctypes.data_as(_DOUBLE_P)


def contiguous(values) -> np.ndarray:
    """A C-contiguous float64 copy-if-needed of ``values``."""
    return np.ascontiguousarray(values, dtype=np.float64)
