"""The per-step path of the output stages in C (fmu_src/output_stages.c) and
the extended plant FMU built on it.

- ``ostage_step`` with a double buffer -- the tentative buffer lagging one
  sample, its delay line brought up to date in one slot, no copy -- gives
  the bits of ``ostage_run`` (which steps in place), whatever tentative
  outputs are asked for in between; with no buffer it writes nothing;
- the plant FMU, under random sequences of every per-step call (set, get
  before and after the step, doStep, FMU states taken and restored out of
  order, reset), gives the bits of ``ExtendedModel.simulate``: the double
  buffer stays paired across restored states;
- stage coefficients are checked once, at fmi2ExitInitializationMode: a plant
  built with invalid ones is refused there with fmi2Error and a message
  naming the problem, and then does not step.
"""
import ctypes
import re
import shutil
import subprocess

import numpy as np
import pytest
from test_fmu_extended import T, extended, fmus

from pysim.core import kernel
from pysim.core.extended import OutputStages, OutputStagesStruct, first_order_section, second_order_section, \
    tustin_creep_mode
from pysim.fmu.compile import fmi_include_dir
from pysim.testing.fmus import ERROR, OK, WARNING, RawFMU, extracted

_P = ctypes.POINTER(ctypes.c_double)


def _function(name, restype, argtypes):
    """A function of the host library with its own ctypes signature (a fresh
    function object: the library's shared attributes stay untouched)."""
    function = kernel.library()[name]
    function.restype, function.argtypes = restype, argtypes
    return function


STAGES_P = ctypes.POINTER(OutputStagesStruct)
STEP = _function("ostage_step", ctypes.c_double,
                 [STAGES_P, _P, ctypes.c_double, ctypes.c_double, ctypes.c_double, _P])
REST = _function("ostage_rest", None, [STAGES_P, ctypes.c_double, ctypes.c_double, _P])


def _p(array):
    return array.ctypes.data_as(_P)


def random_stages(rng) -> OutputStages:
    sections = []
    if rng.random() < 0.6:
        sections.append(first_order_section(10 ** rng.uniform(-3.5, -1), T))
    if rng.random() < 0.6:
        sections.append(second_order_section(10 ** rng.uniform(1, 3), rng.uniform(0.02, 1.0), T))
    delay = float(rng.choice([0.0, 0.4, 1.0, 2.5, 3.0, 17.0, 40.75]))
    modes = [tustin_creep_mode(10 ** rng.uniform(-2, 0), T) for _ in range(rng.integers(0, 3))]
    return OutputStages(sections or (), delay, [m[0] for m in modes], [m[1] for m in modes],
                        rng.normal(0.0, 0.05, len(modes)), rng.normal(0.0, 0.5, rng.integers(0, 3)))


@pytest.mark.parametrize("seed", range(12))
def test_double_buffered_steps_give_the_in_place_bits(seed):
    rng = np.random.default_rng(seed)
    stages = random_stages(rng)
    s = ctypes.byref(stages._struct)
    n = 400
    h = np.cumsum(rng.normal(0.0, 1.0, n))
    u = rng.uniform(-10.0, 100.0, n)
    t = np.arange(n) * T
    reference, ref_state = stages.run(h, u, t)               # in place, checked once

    size = stages.state_size
    committed = rng.normal(0.0, 1e3, size)                    # junk: not started yet
    tentative = rng.normal(0.0, 1e3, size)
    paired = False
    y = np.empty(n)
    for k in range(n):
        for _ in range(rng.integers(0, 3)):                   # outputs for inputs never committed
            STEP(s, _p(committed if k else tentative), rng.normal(), rng.normal(), t[k], _p(tentative))
        if k == 0:                                            # as the plant: at rest, in place
            REST(s, h[0], u[0], _p(tentative))
            y[k] = STEP(s, _p(tentative), h[k], u[k], t[k], _p(tentative))
        else:
            if not paired:
                tentative[:] = committed                      # the one copy, at the second sample
                paired = True
            before = committed.copy()
            y[k] = STEP(s, _p(committed), h[k], u[k], t[k], _p(tentative))
            assert np.array_equal(committed, before)          # the committed state is only read
        committed, tentative = tentative, committed           # fmi2DoStep: swap
    assert np.array_equal(y, reference)
    assert np.array_equal(committed, ref_state)
    # no buffer: the output for a tentative input, nothing written
    before = committed.copy()
    STEP(s, _p(committed), 1.0, 2.0, 0.5, None)
    assert np.array_equal(committed, before)


def test_run_still_passes_an_invalid_spec_through():
    bad = OutputStagesStruct(0, None, 1, 1.5, 0, None, None, None, 0, None)       # fraction outside [0, 1)
    run = _function("ostage_run", None, [STAGES_P, ctypes.c_size_t, _P, _P, _P, _P, _P])
    h, y, state = np.arange(4.0), np.zeros(4), np.zeros(4)
    run(ctypes.byref(bad), 4, _p(h), None, None, _p(state), _p(y))
    assert np.array_equal(y, h)


# ------------------------------------------------------------- the plant FMU

@pytest.mark.parametrize("kind, seed", [("delay", 1), ("combination", 2), ("lag", 3)])
def test_any_sequence_of_calls_gives_the_model_bits(kind, seed):
    """Random set / get / doStep / get after doStep / FMU state taken /
    restored (from any earlier point, also the one before the first sample) /
    reset, against the Python model carried sample by sample."""
    model = extended(kind)
    lo, hi = model.voltage_range_V
    fmu = RawFMU(fmus(kind)["plant"])
    rng = np.random.default_rng(seed)
    c = fmu.initialised()
    voltage = fmu.get_real(c, ["voltage"])[1][0]
    state, t, saved = None, 0.0, []                # Python state after the committed samples
    counts = dict.fromkeys(("set", "get", "step", "save", "restore", "reset"), 0)
    for _ in range(2500):
        op = rng.choice(list(counts), p=[0.35, 0.2, 0.33, 0.05, 0.05, 0.02])
        counts[op] += 1
        if op == "set":
            voltage = float(rng.uniform(lo, hi))
            assert fmu.set_real(c, {"voltage": voltage}) == OK
        elif op == "get":
            status, (y,) = fmu.get_real(c, ["displacement"])
            assert status == OK and y == model.simulate([voltage], state)[0]
        elif op == "step":
            assert fmu.do_step(c, t, T) == OK
            _, state = model.simulate([voltage], state, return_state=True)
            t += T
        elif op == "save":
            status, snapshot = fmu.get_state(c)
            assert status == OK
            saved.append((snapshot, state, t, voltage))
        elif op == "restore" and saved:
            snapshot, state, t, voltage = saved[rng.integers(len(saved))]
            assert fmu.fmi2SetFMUstate(c, snapshot) == OK
        elif op == "reset":
            assert fmu.fmi2Reset(c) == OK
            assert fmu.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == OK
            assert fmu.fmi2EnterInitializationMode(c) == OK
            assert fmu.fmi2ExitInitializationMode(c) == OK
            voltage = fmu.get_real(c, ["voltage"])[1][0]
            state, t = None, 0.0
    assert min(counts.values()) > 10
    assert fmu.errors() == []
    for snapshot, *_ in saved:
        fmu.free_state(c, snapshot)
    fmu.fmi2FreeInstance(c)


# ------------------------------------------- invalid coefficients are refused

def _tampered_plant(tmp_path, kind, sections):
    """The plant of ``kind`` compiled natively with its MODEL_SECTIONS replaced."""
    src = tmp_path / "sources"
    shutil.copytree(extracted(fmus(kind)["plant"]) / "sources", src)
    config = src / "model_config.h"
    text, replaced = re.subn(r"#define MODEL_SECTIONS \{.*?\}", "#define MODEL_SECTIONS { " + sections + " }",
                             config.read_text(), flags=re.S)
    assert replaced == 1
    config.write_text(text)
    library = tmp_path / "tampered.so"
    compiler = shutil.which("gcc") or shutil.which("clang")
    if compiler is None:
        pytest.skip("no C compiler")
    result = subprocess.run([compiler, "-shared", "-fPIC", "-std=c99", "-O2", "-ffp-contract=off",
                             "-fvisibility=hidden", "-I", str(src), "-I", str(fmi_include_dir()), str(src / "all.c"),
                             "-o", str(library)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return RawFMU(fmus(kind)["plant"], library=library)


@pytest.mark.parametrize("sections, problem", [
    ("0.5, 0.5, 0.0, -1.0, 0.0", "pole at z = 1"),          # 1 + a1 + a2 = 0: no rest state
    ("0.5, 0.5, 0.0, 1e999, 0.0", "NaN or infinite"),
])
def test_invalid_stage_coefficients_are_refused_at_initialisation(tmp_path, sections, problem):
    fmu = _tampered_plant(tmp_path, "lag", sections)
    c = fmu.instantiate()
    assert fmu.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == OK
    assert fmu.fmi2EnterInitializationMode(c) == OK
    assert fmu.set_real(c, {"voltage": 10.0}) == OK
    assert fmu.fmi2ExitInitializationMode(c) == ERROR
    messages = [m[3] for m in fmu.errors()]
    assert any("invalid output stages" in m and problem in m for m in messages), messages
    assert any("fmi2ExitInitializationMode: invalid parameters" in m for m in messages)
    assert fmu.do_step(c, 0.0, T) == ERROR                   # the Error state: no step
    assert fmu.get_real(c, ["displacement"])[0] == ERROR     # nor an output from unchecked stages
    fmu.fmi2FreeInstance(c)
    # the untampered build initialises and steps
    good = RawFMU(fmus("lag")["plant"])
    c = good.initialised()
    assert good.set_real(c, {"voltage": 10.0}) == OK and good.do_step(c, 0.0, T) in (OK, WARNING)
    good.fmi2FreeInstance(c)
