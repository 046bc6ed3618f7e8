"""FMUs for tests and benchmarks: the FMUs of a spec built once per process
(one build path for every test, so a swap to sanitized binaries reaches them
all), raw ctypes access to an FMU binary (every status visible, no
exceptions), and the input signals the FMU tests use.

``PIEZO_SANITIZED_FMUS`` (``plant=PATH<pathsep>inverse=PATH``) makes
:func:`built_fmus` return those FMUs for the default spec: the memory tests
run the FMU tests against a sanitized build that way.

Examples
--------
>>> from pysim.testing.fmus import built_fmus, RawFMU     # doctest: +SKIP
>>> plant = RawFMU(built_fmus()["plant"])                 # doctest: +SKIP
>>> c = plant.initialised()                               # doctest: +SKIP
>>> plant.set_real(c, {"voltage": 75.0}), plant.get_real(c, ["displacement"])[0]  # doctest: +SKIP
(0, 0)
"""
from __future__ import annotations

import atexit
import ctypes
import os
import shutil
import struct
import tempfile
from functools import lru_cache
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import (
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)

from pysim.core.model import HysteresisModel
from pysim.fmu import DEFAULT_PLATFORMS, build_fmus
from pysim.specs.default_mpi import MODEL as DEFAULT_MODEL

__all__ = ["DEFAULT_MODEL", "LINEAR_MODEL", "ALL_PLATFORMS", "built_fmus", "extracted", "temporary_folder", "RawFMU",
           "voltage_signal", "paper_signal", "piecewise_monotone", "to_hex_lines", "from_hex"]

ALL_PLATFORMS = DEFAULT_PLATFORMS
OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
SANITIZED_ENV = "PIEZO_SANITIZED_FMUS"

# "Hysteresis switched off": one operator of zero weight, a1 = 0, so the plant
# is the straight line 0.5 µm/V through the origin, as an FMU like any other.
LINEAR_MODEL = HysteresisModel(a1=0.0, a2=0.5, thresholds_V=(0.0,), weights_um_per_V=(0.0,),
                               voltage_range_V=(0.0, 150.0), name="linear_plant",
                               description="hysteresis switched off (test plant)")


def temporary_folder(prefix: str) -> Path:
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    atexit.register(shutil.rmtree, folder, True)
    return folder


def sanitized_fmus() -> dict:
    """``{kind: Path}`` from ``$PIEZO_SANITIZED_FMUS`` (empty when not set)."""
    text = os.environ.get(SANITIZED_ENV, "")
    return {kind: Path(path) for kind, path in (item.split("=", 1) for item in text.split(os.pathsep) if item)}


def built_fmus(model=DEFAULT_MODEL, platforms=ALL_PLATFORMS) -> dict:
    """``{"plant": Path, "inverse": Path}`` for ``model``, built once per process
    (the sanitized FMUs of ``$PIEZO_SANITIZED_FMUS`` for the default spec)."""
    platforms = tuple(platforms)
    swapped = sanitized_fmus()
    if swapped and model == DEFAULT_MODEL and "linux64" in platforms:
        return dict(swapped)
    return dict(_build_once(model, platforms))


@lru_cache(maxsize=None)
def _build_once(model, platforms) -> dict:
    return build_fmus(model, temporary_folder("fmu-tests-"), platforms)


@lru_cache(maxsize=None)
def extracted(fmu_path) -> Path:
    """The FMU unpacked into a temporary folder (once per process)."""
    return Path(extract(str(fmu_path), str(temporary_folder("fmu-unzipped-"))))


def voltage_signal(model, normalised):
    """Map a signal on [0, 1] onto the model's voltage range (V)."""
    lo, hi = model.voltage_range_V
    return lo + (hi - lo) * np.asarray(normalised, dtype=float)


def paper_signal(n_samples=20001, t_end=20.0):
    """v(t) = 0.5 + 0.5 sin(3t)/(1+t), the input of the paper's simulation example."""
    t = np.linspace(0.0, t_end, n_samples)
    return 0.5 + 0.5 * np.sin(3.0 * t) / (1.0 + t)


def piecewise_monotone(rng, n_segments=30):
    """Random extrema on [0, 1] (both ends included) joined by ramps of random length."""
    extrema = rng.uniform(0.0, 1.0, n_segments)
    extrema[:3] = (0.0, 1.0, 0.0)
    pieces = [a + (b - a) * np.sort(rng.uniform(0.0, 1.0, rng.integers(2, 80)))
              for a, b in zip(extrema[:-1], extrema[1:])]
    return np.concatenate(pieces + [extrema[-1:]])


def to_hex_lines(values) -> str:
    """Bit patterns of doubles, one 16-digit hex number per line."""
    return "".join(format(struct.unpack("<Q", struct.pack("<d", float(x)))[0], "016x") + "\n" for x in values)


def from_hex(line: str) -> float:
    return struct.unpack("<d", struct.pack("<Q", int(line, 16)))[0]


class RawFMU:
    """An FMU binary called through ctypes, returning raw statuses.

    Parameters
    ----------
    fmu_path : path
        The .fmu file (unpacked once per process).
    library : path, optional
        The binary to load (default: the FMU's linux64 library).
    """

    _SIGNATURES = {
        "fmi2Instantiate": (ctypes.c_void_p, [ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p,
                                              ctypes.c_void_p, ctypes.c_int, ctypes.c_int]),
        "fmi2FreeInstance": (None, [ctypes.c_void_p]),
        "fmi2SetupExperiment": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_double,
                                               ctypes.c_int, ctypes.c_double]),
        "fmi2EnterInitializationMode": (ctypes.c_int, [ctypes.c_void_p]),
        "fmi2ExitInitializationMode": (ctypes.c_int, [ctypes.c_void_p]),
        "fmi2Terminate": (ctypes.c_int, [ctypes.c_void_p]),
        "fmi2Reset": (ctypes.c_int, [ctypes.c_void_p]),
        "fmi2SetDebugLogging": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_int, ctypes.c_size_t, ctypes.c_void_p]),
        "fmi2GetReal": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]),
        "fmi2SetReal": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]),
        "fmi2GetBoolean": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]),
        "fmi2SetBoolean": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]),
        "fmi2GetInteger": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p]),
        "fmi2DoStep": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_double, ctypes.c_double, ctypes.c_int]),
        "fmi2GetFMUstate": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p]),
        "fmi2SetFMUstate": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p]),
        "fmi2FreeFMUstate": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p]),
        "fmi2SerializedFMUstateSize": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]),
        "fmi2SerializeFMUstate": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                                 ctypes.c_size_t]),
        "fmi2DeSerializeFMUstate": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t,
                                                   ctypes.c_void_p]),
        "fmi2GetDirectionalDerivative": (ctypes.c_int, [ctypes.c_void_p] + [ctypes.c_void_p, ctypes.c_size_t] * 2
                                         + [ctypes.c_void_p, ctypes.c_void_p]),
        "fmi2CancelStep": (ctypes.c_int, [ctypes.c_void_p]),
        "fmi2GetRealStatus": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]),
        "fmi2GetStatus": (ctypes.c_int, [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]),
    }

    def __init__(self, fmu_path, library=None):
        self.folder = extracted(Path(fmu_path))
        self.description = read_model_description(str(self.folder))
        self.identifier = self.description.coSimulation.modelIdentifier
        self.guid = self.description.guid
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        path = Path(library) if library else self.folder / "binaries" / "linux64" / f"{self.identifier}.so"
        self.lib = ctypes.CDLL(str(path))
        for name, (restype, argtypes) in self._SIGNATURES.items():
            function = getattr(self.lib, name)
            function.restype, function.argtypes = restype, argtypes
        self.messages = []                  # (instance, status, category, message)
        self._logger = fmi2CallbackLoggerTYPE(self._log)
        self._callbacks = fmi2CallbackFunctions()
        self._callbacks.logger = self._logger
        from fmpy import calloc, free

        self._callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self._callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)

    def _log(self, env, instance, status, category, message):
        self.messages.append((instance.decode(), status, category.decode(), message.decode()))

    def __getattr__(self, name):
        return getattr(self.lib, name)

    # -------------------------------------------------------------- calls
    def instantiate(self, name="test", guid=None, logging_on=True, kind=1):
        return self.lib.fmi2Instantiate(name.encode(), kind, (guid or self.guid).encode(), b"",
                                        ctypes.addressof(self._callbacks), 0, int(logging_on))

    def initialised(self, name="test", reals=None, booleans=None, start_time=0.0):
        """An instance in StepComplete, with parameters set in initialisation mode."""
        c = self.instantiate(name)
        assert c
        assert self.lib.fmi2SetupExperiment(c, 0, 0.0, start_time, 0, 0.0) == OK
        assert self.lib.fmi2EnterInitializationMode(c) == OK
        if reals:
            assert self.set_real(c, reals) <= WARNING
        if booleans:
            assert self.set_boolean(c, booleans) == OK
        status = self.lib.fmi2ExitInitializationMode(c)
        assert status <= WARNING, self.messages
        return c

    def _refs(self, names):
        return (ctypes.c_uint * len(names))(*[self.vr[n] if isinstance(n, str) else n for n in names])

    def set_real(self, c, values: dict) -> int:
        names = list(values)
        array = (ctypes.c_double * len(names))(*[values[n] for n in names])
        return self.lib.fmi2SetReal(c, self._refs(names), len(names), array)

    def get_real(self, c, names):
        array = (ctypes.c_double * len(names))()
        status = self.lib.fmi2GetReal(c, self._refs(names), len(names), array)
        return status, list(array)

    def set_boolean(self, c, values: dict) -> int:
        names = list(values)
        array = (ctypes.c_int * len(names))(*[int(values[n]) for n in names])
        return self.lib.fmi2SetBoolean(c, self._refs(names), len(names), array)

    def do_step(self, c, t, h) -> int:
        return self.lib.fmi2DoStep(c, t, h, 1)

    def run(self, c, inputs, input_name, output_name, t0=0.0, h=1e-3, get_first=True):
        """Set, get and step over inputs; returns the outputs and the end time."""
        out = np.empty(len(inputs))
        t = t0
        for k, x in enumerate(inputs):
            assert self.set_real(c, {input_name: float(x)}) <= WARNING
            if get_first:
                status, (out[k],) = self.get_real(c, [output_name])
                assert status <= WARNING
            assert self.do_step(c, t, h) <= WARNING
            if not get_first:
                status, (out[k],) = self.get_real(c, [output_name])
                assert status <= WARNING
            t += h
        return out, t

    def get_state(self, c):
        state = ctypes.c_void_p()
        status = self.lib.fmi2GetFMUstate(c, ctypes.byref(state))
        return status, state

    def serialize(self, c, state) -> bytes:
        size = ctypes.c_size_t()
        assert self.lib.fmi2SerializedFMUstateSize(c, state, ctypes.byref(size)) == OK
        buffer = (ctypes.c_char * size.value)()
        assert self.lib.fmi2SerializeFMUstate(c, state, buffer, size.value) == OK
        return bytes(buffer)

    def deserialize(self, c, blob: bytes):
        state = ctypes.c_void_p()
        buffer = ctypes.create_string_buffer(blob, max(len(blob), 1))
        status = self.lib.fmi2DeSerializeFMUstate(c, buffer, len(blob), ctypes.byref(state))
        return status, state

    def free_state(self, c, state) -> int:
        return self.lib.fmi2FreeFMUstate(c, ctypes.byref(state))

    def errors(self):
        return [m for m in self.messages if m[1] >= ERROR]
