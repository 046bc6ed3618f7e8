"""The FMI layer's contract for calls an importer gets wrong: each is refused
with the status the FMI 2.0 standard asks for, explained through the logger,
and leaves the instance as it was."""
import ctypes

import numpy as np
import pytest

from pysim.testing.fmus import DEFAULT_MODEL, DISCARD, ERROR, OK, RawFMU, built_fmus, voltage_signal

MODEL = DEFAULT_MODEL
DOUBLE1 = (ctypes.c_double * 1)(1.0)
VR1 = (ctypes.c_uint * 1)(0)


@pytest.fixture(params=["plant", "inverse"])
def fmu(request):
    return RawFMU(built_fmus()[request.param])


def _misuse_in_step_complete(f, c):
    out = (ctypes.c_double * 1)()
    unknown = (ctypes.c_uint * 1)(10_000)
    return {
        "SetReal NULL vr": f.fmi2SetReal(c, None, 1, DOUBLE1),
        "SetReal NULL values": f.fmi2SetReal(c, VR1, 1, None),
        "GetReal NULL values": f.fmi2GetReal(c, VR1, 1, None),
        "GetReal unknown vr": f.fmi2GetReal(c, unknown, 1, out),
        "SetReal unknown vr": f.fmi2SetReal(c, unknown, 1, DOUBLE1),
        "GetBoolean unknown vr": f.fmi2GetBoolean(c, unknown, 1, (ctypes.c_int * 1)()),
        "GetInteger any vr": f.fmi2GetInteger(c, VR1, 1, (ctypes.c_int * 1)()),
        "EnterInitializationMode again": f.fmi2EnterInitializationMode(c),
        "ExitInitializationMode again": f.fmi2ExitInitializationMode(c),
        "SetupExperiment late": f.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
        "CancelStep without a pending step": f.fmi2CancelStep(c),
        "GetDirectionalDerivative": f.fmi2GetDirectionalDerivative(c, VR1, 1, VR1, 1, DOUBLE1, out),
        "DoStep zero step": f.do_step(c, 0.0, 0.0),
    }


def test_misuse_is_refused_explained_and_harmless(fmu):
    name_in = next(v.name for v in fmu.description.modelVariables if v.causality == "input")
    name_out = next(v.name for v in fmu.description.modelVariables if v.causality == "output")
    x = voltage_signal(MODEL, np.linspace(0.1, 0.9, 40))
    x = x if name_in == "voltage" else MODEL.simulate(x)
    c = fmu.initialised()
    first, t = fmu.run(c, x[:20], name_in, name_out)
    before = len(fmu.errors())
    statuses = _misuse_in_step_complete(fmu, c)
    assert all(status == ERROR for status in statuses.values()), statuses
    assert len(fmu.errors()) - before == len(statuses)            # one explanation each
    rest, _ = fmu.run(c, x[20:], name_in, name_out, t0=t)           # nothing changed
    reference = fmu.initialised("reference")
    whole, _ = fmu.run(reference, x, name_in, name_out)
    assert np.array_equal(np.concatenate([first, rest]), whole)
    fmu.fmi2FreeInstance(c)
    fmu.fmi2FreeInstance(reference)


def test_calls_before_initialisation_and_after_termination(fmu):
    c = fmu.instantiate()
    assert fmu.do_step(c, 0.0, 1e-3) == ERROR                       # doStep before initialisation
    assert fmu.get_real(c, ["a1"])[0] == ERROR                     # getReal in Instantiated
    assert fmu.fmi2Terminate(c) == ERROR
    assert any("not allowed in state Instantiated" in m[3] for m in fmu.errors())
    assert fmu.fmi2SetupExperiment(c, 0, 0.0, 1.0, 1, 0.5) == ERROR      # stop before start
    assert fmu.fmi2EnterInitializationMode(c) == OK
    assert fmu.fmi2ExitInitializationMode(c) == OK
    assert fmu.fmi2Terminate(c) == OK
    assert fmu.do_step(c, 0.0, 1e-3) == ERROR
    assert fmu.get_real(c, ["a2"]) == (OK, [MODEL.a2])             # values stay readable
    assert fmu.fmi2Reset(c) == OK
    assert fmu.fmi2EnterInitializationMode(c) == OK
    fmu.fmi2FreeInstance(c)


def test_calls_without_an_instance_do_not_crash(fmu):
    assert fmu.fmi2DoStep(None, 0.0, 1e-3, 1) == ERROR
    assert fmu.fmi2SetReal(None, VR1, 1, DOUBLE1) == ERROR
    assert fmu.fmi2GetReal(None, VR1, 1, (ctypes.c_double * 1)()) == ERROR
    assert fmu.fmi2GetFMUstate(None, ctypes.byref(ctypes.c_void_p())) == ERROR
    assert fmu.fmi2Reset(None) == ERROR
    fmu.fmi2FreeInstance(None)
    assert not fmu.lib.fmi2Instantiate(b"x", 1, fmu.guid.encode(), b"", None, 0, 0)   # no callbacks
    assert not fmu.instantiate(name="")


def test_status_queries(fmu):
    c = fmu.initialised()
    value = ctypes.c_double()
    assert fmu.do_step(c, 0.0, 0.25) == OK
    assert fmu.fmi2GetRealStatus(c, 2, ctypes.byref(value)) == OK and value.value == 0.25   # last time
    status = ctypes.c_int()
    assert fmu.fmi2GetStatus(c, 0, ctypes.byref(status)) == DISCARD    # nothing asynchronous to report
    fmu.fmi2FreeInstance(c)
