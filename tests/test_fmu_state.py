"""FMU state: get/set and serialize/deserialize round trips continue the
simulation bit for bit; truncated, corrupted or foreign serialized states are
refused with fmi2Error and change nothing."""
import ctypes

import numpy as np
import pytest

from pysim.testing.fmus import (
    DEFAULT_MODEL,
    ERROR,
    OK,
    RawFMU,
    built_fmus,
    paper_signal,
    piecewise_monotone,
    voltage_signal,
)

MODEL = DEFAULT_MODEL
PORTS = {"plant": ("voltage", "displacement"), "inverse": ("displacement_ref", "voltage")}


def signal(kind, seed=3):
    v = voltage_signal(MODEL, piecewise_monotone(np.random.default_rng(seed)))
    return v if kind == "plant" else MODEL.simulate(v)


@pytest.fixture(params=["plant", "inverse"])
def kind(request):
    return request.param


@pytest.fixture
def fmu(kind):
    return RawFMU(built_fmus()[kind])


def test_get_and_set_state_continue_bit_identically(fmu, kind):
    x = signal(kind)
    half = x.size // 2
    c = fmu.initialised()
    first, t = fmu.run(c, x[:half], *PORTS[kind])
    status, saved = fmu.get_state(c)
    assert status == OK
    second, _ = fmu.run(c, x[half:], *PORTS[kind], t0=t)
    assert fmu.fmi2SetFMUstate(c, saved) == OK
    replay, _ = fmu.run(c, x[half:], *PORTS[kind], t0=t)
    assert np.array_equal(replay, second)
    # and the whole run equals one uninterrupted run of a fresh instance
    other = fmu.initialised("other")
    whole, _ = fmu.run(other, x, *PORTS[kind])
    assert np.array_equal(np.concatenate([first, second]), whole)
    assert fmu.free_state(c, saved) == OK and not saved.value
    fmu.fmi2FreeInstance(c)
    fmu.fmi2FreeInstance(other)


def test_serialized_state_continues_in_another_instance(fmu, kind):
    x = signal(kind, seed=4)
    half = x.size // 3
    a = fmu.initialised("a")
    _, t = fmu.run(a, x[:half], *PORTS[kind])
    _, state = fmu.get_state(a)
    blob = fmu.serialize(a, state)
    rest_a, _ = fmu.run(a, x[half:], *PORTS[kind], t0=t)

    b = fmu.instantiate("b")                          # never initialised itself
    status, restored = fmu.deserialize(b, blob)
    assert status == OK
    assert fmu.fmi2SetFMUstate(b, restored) == OK     # now in StepComplete at time t
    rest_b, _ = fmu.run(b, x[half:], *PORTS[kind], t0=t)
    assert np.array_equal(rest_a, rest_b)
    assert fmu.serialize(b, restored) == blob          # serialising again gives the same bytes
    for c, s in ((a, state), (b, restored)):
        fmu.free_state(c, s)
        fmu.fmi2FreeInstance(c)


def test_state_keeps_parameters_and_method():
    """A snapshot carries the parameters and the inverse's method switch."""
    fmu = RawFMU(built_fmus()["inverse"])
    reference = MODEL.simulate(voltage_signal(MODEL, paper_signal(2001, 2.0)))
    a = fmu.initialised("a", reals={"a2": MODEL.a2 * 1.1}, booleans={"use_previous_sample": True})
    _, t = fmu.run(a, reference[:1000], "displacement_ref", "voltage")
    _, state = fmu.get_state(a)
    blob = fmu.serialize(a, state)
    rest_a, _ = fmu.run(a, reference[1000:], "displacement_ref", "voltage", t0=t)
    b = fmu.initialised("b")                           # default parameters, exact method
    _, restored = fmu.deserialize(b, blob)
    assert fmu.fmi2SetFMUstate(b, restored) == OK
    assert fmu.get_real(b, ["a2"])[1] == [MODEL.a2 * 1.1]
    rest_b, _ = fmu.run(b, reference[1000:], "displacement_ref", "voltage", t0=t)
    assert np.array_equal(rest_a, rest_b)


def _reference_blob(fmu, kind):
    c = fmu.initialised("source")
    _, t = fmu.run(c, signal(kind)[:200], *PORTS[kind])
    _, state = fmu.get_state(c)
    return fmu.serialize(c, state), t


def _still_works(fmu, c, kind, t):
    """After a refused call the instance continues as if it had not happened."""
    x = signal(kind, seed=5)[:50]
    y, _ = fmu.run(c, x, *PORTS[kind], t0=t)
    return y


def test_every_corrupted_byte_is_refused(fmu, kind):
    blob, t = _reference_blob(fmu, kind)
    c = fmu.initialised("target")
    _, t_c = fmu.run(c, signal(kind)[:200], *PORTS[kind])
    assert t_c == t
    _, mine = fmu.get_state(c)
    expected = _still_works(fmu, c, kind, t)
    assert fmu.fmi2SetFMUstate(c, mine) == OK
    errors_before = len(fmu.errors())
    for i in range(len(blob)):
        for bit in (0x01, 0x80):
            bad = bytearray(blob)
            bad[i] ^= bit
            status, state = fmu.deserialize(c, bytes(bad))
            assert status == ERROR, (i, bit)
            assert not state.value
    assert len(fmu.errors()) - errors_before == 2 * len(blob)       # each one explained
    assert np.array_equal(_still_works(fmu, c, kind, t), expected)
    fmu.fmi2FreeInstance(c)


def test_truncated_extended_and_foreign_states_are_refused(fmu, kind):
    blob, t = _reference_blob(fmu, kind)
    other = RawFMU(built_fmus()["inverse" if kind == "plant" else "plant"])
    foreign, _ = _reference_blob(other, "inverse" if kind == "plant" else "plant")
    c = fmu.initialised("target")
    for bad in (b"", blob[:1], blob[:40], blob[:-1], blob[:-8], blob + b"\0", foreign):
        status, state = fmu.deserialize(c, bad)
        assert status == ERROR and not state.value
    messages = [m[3] for m in fmu.errors()]
    assert len(messages) == 7 and all("this FMU writes" in m for m in messages)


def test_state_of_another_model_of_the_same_size_is_refused():
    """Same layout, other spec (other GUID): the header's model hash tells."""
    fmu = RawFMU(built_fmus()["plant"])
    twin_model = MODEL.with_parameters(a2=MODEL.a2 * 1.01, name="twin")
    twin = RawFMU(built_fmus(twin_model, ("linux64",))["plant"])
    foreign, _ = _reference_blob(twin, "plant")
    blob, _ = _reference_blob(fmu, "plant")
    assert len(foreign) == len(blob)
    c = fmu.initialised()
    status, state = fmu.deserialize(c, foreign)
    assert status == ERROR and not state.value
    assert "written by a different model" in fmu.errors()[-1][3]
    # a NULL buffer and a NULL result pointer are refused, not dereferenced
    assert fmu.fmi2DeSerializeFMUstate(c, None, len(blob), ctypes.byref(ctypes.c_void_p())) == ERROR
    assert fmu.fmi2DeSerializeFMUstate(c, blob, len(blob), None) == ERROR
    fmu.fmi2FreeInstance(c)


def test_state_functions_refuse_bad_pointers(fmu):
    c = fmu.initialised()
    assert fmu.fmi2SetFMUstate(c, None) == ERROR
    garbage = ctypes.create_string_buffer(64)              # not a state of this FMU
    assert fmu.fmi2SetFMUstate(c, garbage) == ERROR
    assert fmu.fmi2GetFMUstate(c, None) == ERROR
    assert fmu.fmi2GetFMUstate(None, ctypes.byref(ctypes.c_void_p())) == ERROR   # no instance
    null_state = ctypes.c_void_p()
    assert fmu.free_state(c, null_state) == OK               # freeing NULL is allowed
    fmu.fmi2FreeInstance(c)
