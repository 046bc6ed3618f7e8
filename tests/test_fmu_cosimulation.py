"""Co-simulation of the plant and inverse FMUs with fmpy against the Python
model (``HysteresisModel.simulate`` and ``InverseCompensator``), on the
paper's example input and on random piecewise-monotone signals, with the FMU
binaries as built and as rebuilt by fmpy from the FMUs' own sources."""
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from pysim.core.model import InverseCompensator
from pysim.testing.fmus import (
    DEFAULT_MODEL,
    ERROR,
    OK,
    WARNING,
    RawFMU,
    built_fmus,
    extracted,
    paper_signal,
    piecewise_monotone,
    voltage_signal,
)

MODEL = DEFAULT_MODEL
LO, HI = MODEL.voltage_range_V


def open_slave(folder, name="fmpy"):
    folder = str(Path(folder).resolve())
    md = read_model_description(folder)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName=name)
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    return slave, {v.name: v.valueReference for v in md.modelVariables}


def cosimulate(folder, inputs, steps=None, reals=None, booleans=None, get_first=True):
    """fmpy FMU2Slave loop: set input, get output, doStep (variable steps)."""
    slave, vr = open_slave(folder)
    for name, value in (reals or {}).items():
        slave.setReal([vr[name]], [value])
    for name, value in (booleans or {}).items():
        slave.setBoolean([vr[name]], [value])
    slave.exitInitializationMode()
    steps = np.full(len(inputs), 1e-3) if steps is None else steps
    out = np.empty(len(inputs))
    t = 0.0
    for k, (x, h) in enumerate(zip(inputs, steps)):
        slave.setReal([0], [float(x)])
        if get_first:
            out[k] = slave.getReal([1])[0]
        slave.doStep(t, float(h))
        if not get_first:
            out[k] = slave.getReal([1])[0]
        t += float(h)
    slave.terminate()
    slave.freeInstance()
    return out


def relative_error(a, b):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b))


@pytest.fixture(scope="module")
def fmus():
    paths = built_fmus()
    return {kind: extracted(path) for kind, path in paths.items()}


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory):
    """The FMUs with their linux64 binaries compiled again by fmpy (CMake and
    the system compiler) from nothing but the FMU's sources/ folder."""
    from fmpy.build import build_platform_binary

    out = {}
    for kind, path in built_fmus().items():
        folder = tmp_path_factory.mktemp(f"rebuilt-{kind}")
        shutil.copytree(extracted(path), folder, dirs_exist_ok=True)
        shutil.rmtree(folder / "binaries")
        build_platform_binary(str(folder.resolve()), build_dir=str(tmp_path_factory.mktemp(f"cmake-{kind}")))
        assert (folder / "binaries" / "linux64" / f"{MODEL.name}_{kind}.so").is_file()
        out[kind] = folder
    return out


def _signals(seed):
    rng = np.random.default_rng(seed)
    return voltage_signal(MODEL, piecewise_monotone(rng)), rng.uniform(1e-4, 1e-2, 2000)


@pytest.mark.parametrize("which", ["built", "rebuilt"])
def test_plant_reproduces_the_python_model_on_the_paper_input(fmus, rebuilt, which):
    folder = (fmus if which == "built" else rebuilt)["plant"]
    v = voltage_signal(MODEL, paper_signal())
    y = cosimulate(folder, v)
    assert relative_error(y, MODEL.simulate(v)) <= 1e-12


@pytest.mark.parametrize("which", ["built", "rebuilt"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_plant_reproduces_the_python_model_on_random_signals_with_variable_steps(fmus, rebuilt, which, seed):
    folder = (fmus if which == "built" else rebuilt)["plant"]
    v, _ = _signals(seed)
    steps = np.random.default_rng(seed + 100).uniform(1e-4, 1e-2, v.size)
    y = cosimulate(folder, v, steps)
    assert relative_error(y, MODEL.simulate(v)) <= 1e-12


@pytest.mark.parametrize("which", ["built", "rebuilt"])
@pytest.mark.parametrize("seed", [4, 5])
def test_inverse_then_plant_returns_the_reference(fmus, rebuilt, which, seed):
    folders = fmus if which == "built" else rebuilt
    # a reference the actuator can follow: the model's response to some voltage
    reference = MODEL.simulate(_signals(seed)[0])
    voltage = cosimulate(folders["inverse"], reference)
    displacement = cosimulate(folders["plant"], voltage)
    span = np.ptp(reference)
    assert np.max(np.abs(displacement - reference)) <= 1e-9 * span
    # the same voltages as the Python compensator, solved by the same kernel
    expected = InverseCompensator(MODEL, "exact")(reference)
    assert np.max(np.abs(voltage - expected)) <= 1e-12 * (HI - LO)


def test_inverse_on_the_paper_input(fmus):
    reference = MODEL.simulate(voltage_signal(MODEL, paper_signal()))
    voltage = cosimulate(fmus["inverse"], reference)
    assert np.max(np.abs(cosimulate(fmus["plant"], voltage) - reference)) <= 1e-9 * np.ptp(reference)


def test_previous_sample_loop_is_the_papers_fig7_compensator(fmus):
    """use_previous_sample switches to the Fig. 7 loop with the analytic
    inverse computed in C: same voltages as the Python compensator (numpy's
    analytic inverse), and the loop's tracking error is exactly what closing
    it with the previous sample predicts: P[P^-1[w]] = w, so the plant gives
    y_ref + a1 (u_k^3 - u_{k-1}^3), starting from u_{-1} = 0."""
    reference = MODEL.simulate(voltage_signal(MODEL, paper_signal(4001, 4.0)))
    voltage = cosimulate(fmus["inverse"], reference, booleans={"use_previous_sample": True})
    expected = InverseCompensator(MODEL, "previous_sample")(reference)
    assert np.max(np.abs(voltage - expected)) <= 1e-12 * (HI - LO)
    u = voltage - MODEL.input_offset_V
    u_previous = np.concatenate([[0.0], u[:-1]])
    predicted = MODEL.a1 * (u ** 3 - u_previous ** 3)
    error = MODEL.simulate(voltage) - reference
    assert np.max(np.abs(error)) > 1e-3 * np.ptp(reference)        # not exact, unlike the default
    assert np.max(np.abs(error - predicted)) <= 1e-9 * np.ptp(reference)


def test_parameters_change_without_rebuild(fmus):
    """Every model parameter is an FMI parameter: values set in initialisation
    mode give the model with those values."""
    rng = np.random.default_rng(7)
    n = MODEL.n_operators
    thresholds = np.sort(rng.uniform(0.0, 120.0, n))
    weights = rng.uniform(0.01, 0.08, n)
    other = MODEL.with_parameters(a1=-1e-6, a2=0.25, thresholds_V=tuple(thresholds),
                                  weights_um_per_V=tuple(weights), input_offset_V=10.0,
                                  output_offset_um=-3.5, voltage_range_V=(5.0, 140.0))
    reals = {"a1": other.a1, "a2": other.a2, "input_offset": other.input_offset_V,
             "output_offset": other.output_offset_um, "voltage_min": 5.0, "voltage_max": 140.0}
    reals.update({f"r[{i + 1}]": r for i, r in enumerate(thresholds)})
    reals.update({f"b[{i + 1}]": b for i, b in enumerate(weights)})
    v = voltage_signal(other, piecewise_monotone(rng))
    assert relative_error(cosimulate(fmus["plant"], v, reals=reals), other.simulate(v)) <= 1e-12
    reference = other.simulate(v)
    voltage = cosimulate(fmus["inverse"], reference, reals=reals)
    assert np.max(np.abs(other.simulate(voltage) - reference)) <= 1e-9 * np.ptp(reference)


def test_output_for_a_held_input_does_not_change_over_a_step(fmus):
    v, steps = _signals(8)
    for kind, signal in (("plant", v), ("inverse", MODEL.simulate(v))):
        before = cosimulate(fmus[kind], signal, get_first=True)
        after = cosimulate(fmus[kind], signal, get_first=False)
        assert np.array_equal(before, after)


def test_memory_is_committed_by_do_step_only(fmus):
    """Several inputs set within one step: each output uses the committed
    operator state; only the input held at fmi2DoStep enters the memory."""
    fmu = RawFMU(built_fmus()["plant"])
    c = fmu.initialised()
    first, second = 120.0, 40.0
    fmu.set_real(c, {"voltage": first})
    _, (y_first,) = fmu.get_real(c, ["displacement"])
    fmu.set_real(c, {"voltage": second})
    _, (y_second,) = fmu.get_real(c, ["displacement"])
    assert y_first == MODEL.simulate([first])[0]
    assert y_second == MODEL.simulate([second])[0]        # not simulate([120, 40])[1]
    assert y_second != MODEL.simulate([first, second])[1]
    assert fmu.do_step(c, 0.0, 1e-3) == OK
    fmu.set_real(c, {"voltage": first})
    _, (y_third,) = fmu.get_real(c, ["displacement"])
    assert y_third == MODEL.simulate([second, first])[1]
    fmu.fmi2FreeInstance(c)


def test_simulate_fmu_records_the_output_of_the_input_held_over_each_step(fmus):
    """fmpy's own driver: inputs applied at the communication points, outputs
    recorded after each step."""
    v = voltage_signal(MODEL, piecewise_monotone(np.random.default_rng(9)))[:300]
    t = np.arange(v.size, dtype=float)
    signal = np.array(list(zip(t, v)), dtype=[("time", np.float64), ("voltage", np.float64)])
    result = simulate_fmu(str(built_fmus()["plant"]), start_time=0.0, stop_time=t[-1], output_interval=1.0,
                          input=signal, output=["displacement"])
    expected = MODEL.simulate(v)
    assert result["displacement"][0] == expected[0]
    assert relative_error(result["displacement"][1:], expected[:-1]) <= 1e-12


def test_voltage_outside_the_range_is_clamped_with_a_warning():
    fmu = RawFMU(built_fmus()["plant"])
    c = fmu.initialised()
    assert fmu.set_real(c, {"voltage": HI + 25.0}) == WARNING
    status, (voltage, displacement) = fmu.get_real(c, ["voltage", "displacement"])
    assert status == OK and voltage == HI
    assert displacement == MODEL.simulate([HI])[0]
    assert any("clamped" in m[3] and m[1] == WARNING for m in fmu.messages)
    assert fmu.set_real(c, {"voltage": LO - 1e9}) == WARNING
    assert fmu.get_real(c, ["voltage"])[1] == [LO]
    fmu.fmi2FreeInstance(c)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), float("-inf")])
def test_non_finite_input_is_refused_and_not_accepted(bad):
    for kind, name in (("plant", "voltage"), ("inverse", "displacement_ref")):
        fmu = RawFMU(built_fmus()[kind])
        c = fmu.initialised()
        assert fmu.set_real(c, {name: 50.0}) == OK
        assert fmu.set_real(c, {name: bad}) == ERROR
        assert fmu.get_real(c, [name]) == (OK, [50.0])
        assert any("not a finite number" in m[3] for m in fmu.errors())
        # the instance goes on as if the call had not happened
        assert fmu.do_step(c, 0.0, 1e-3) == OK
        fmu.fmi2FreeInstance(c)


def test_step_size_and_time_are_checked():
    fmu = RawFMU(built_fmus()["plant"])
    c = fmu.initialised()
    v = voltage_signal(MODEL, np.linspace(0, 1, 50))
    y, t = fmu.run(c, v[:25], "voltage", "displacement")
    for bad_t, bad_h in ((t, 0.0), (t, -1e-3), (t, float("nan")), (t, float("inf")), (t + 1e-3, 1e-3),
                         (t - 0.5, 1e-3), (float("nan"), 1e-3)):
        assert fmu.do_step(c, bad_t, bad_h) == ERROR
    assert len(fmu.errors()) == 7
    # a time within rounding of the FMU's is accepted
    rest, _ = fmu.run(c, v[25:], "voltage", "displacement", t0=t * (1 + 1e-15))
    assert np.array_equal(np.concatenate([y, rest]), MODEL.simulate(v))
    fmu.fmi2FreeInstance(c)


def test_many_instances_are_independent():
    fmu = RawFMU(built_fmus()["plant"])
    rng = np.random.default_rng(10)
    signals = [voltage_signal(MODEL, rng.uniform(0, 1, 40)) for _ in range(200)]
    instances = [fmu.initialised(f"i{k}") for k in range(len(signals))]
    outputs = np.empty((len(signals), 40))
    t = 0.0
    for k in range(40):          # interleaved: one sample of every instance, then the next
        for i, c in enumerate(instances):
            fmu.set_real(c, {"voltage": signals[i][k]})
            outputs[i, k] = fmu.get_real(c, ["displacement"])[1][0]
            assert fmu.do_step(c, t, 1e-3) == OK
        t += 1e-3
    for i, c in enumerate(instances):
        assert np.array_equal(outputs[i], MODEL.simulate(signals[i]))
        fmu.fmi2FreeInstance(c)


def test_invalid_parameters_are_refused_at_initialisation():
    fmu = RawFMU(built_fmus()["plant"])
    c = fmu.instantiate()
    fmu.fmi2EnterInitializationMode(c)
    assert fmu.set_real(c, {"r[3]": 200.0}) == OK          # above r[4]: not ascending
    assert fmu.fmi2ExitInitializationMode(c) == ERROR
    assert any("r[4]" in m[3] and "ascending" in m[3] for m in fmu.errors())
    assert fmu.do_step(c, 0.0, 1e-3) == ERROR               # Error state
    assert fmu.fmi2Reset(c) == OK                            # back to the start values
    fmu.fmi2EnterInitializationMode(c)
    assert fmu.fmi2ExitInitializationMode(c) == OK
    fmu.fmi2FreeInstance(c)


def test_inverse_refuses_parameters_that_make_it_impossible():
    """The paper's a1 = -1 (normalised): right after a reversal near the top
    only the r = 0 operator follows the input and the slope 2.42 + b_1 - 3 v^2
    is negative at the top of the range."""
    fmu = RawFMU(built_fmus()["inverse"])
    scale_v, scale_y = 150.0, 20.0                # the default spec's normalisation
    c = fmu.instantiate()
    fmu.fmi2EnterInitializationMode(c)
    assert fmu.set_real(c, {"a1": -1.0 * scale_y / scale_v ** 3}) == OK
    assert fmu.fmi2ExitInitializationMode(c) == ERROR
    message = next(m[3] for m in fmu.errors() if "not invertible" in m[3])
    b1 = 5.0 * np.exp(-0.505) / 10                  # p(0)/n, normalised
    slope = (2.42 + b1 - 3.0) * scale_y / scale_v   # um/V at v = 150 V
    assert "with 1 operator(s) following the input" in message and "at 150 V" in message
    assert float(message.split("slope falls to ")[1].split(" ")[0]) == pytest.approx(slope, rel=1e-5)
    fmu.fmi2FreeInstance(c)


def test_parameters_are_fixed_after_initialisation():
    fmu = RawFMU(built_fmus()["inverse"])
    c = fmu.initialised()
    assert fmu.set_real(c, {"a2": 1.0}) == ERROR
    assert fmu.set_boolean(c, {"use_previous_sample": True}) == ERROR
    assert fmu.set_real(c, {"voltage": 1.0}) == ERROR          # an output
    assert fmu.get_real(c, ["a2"]) == (OK, [MODEL.a2])
    fmu.fmi2FreeInstance(c)


def test_logging_follows_the_debug_logging_switch():
    fmu = RawFMU(built_fmus()["plant"])
    c = fmu.instantiate(logging_on=False)
    fmu.fmi2EnterInitializationMode(c)
    fmu.fmi2ExitInitializationMode(c)
    assert fmu.messages == []                                  # no events logged
    assert fmu.set_real(c, {"voltage": HI + 1.0}) == WARNING
    assert fmu.messages == []                                  # warnings off too
    assert fmu.set_real(c, {"voltage": float("nan")}) == ERROR
    assert len(fmu.errors()) == 1                              # errors always reach the logger
    import ctypes

    categories = (ctypes.c_char_p * 1)(b"logStatusWarning")
    assert fmu.fmi2SetDebugLogging(c, 1, 1, categories) == OK
    assert fmu.set_real(c, {"voltage": HI + 1.0}) == WARNING
    assert fmu.messages[-1][2] == "logStatusWarning"
    bad = (ctypes.c_char_p * 1)(b"logNoSuchThing")
    assert fmu.fmi2SetDebugLogging(c, 1, 1, bad) == ERROR
    fmu.fmi2FreeInstance(c)


def test_wrong_guid_and_model_exchange_are_refused():
    fmu = RawFMU(built_fmus()["plant"])
    assert not fmu.instantiate(guid="{00000000-0000-0000-0000-000000000000}")
    assert not fmu.instantiate(kind=0)
    assert len(fmu.errors()) == 2


def test_fmpy_reports_errors_as_exceptions(fmus):
    slave, vr = open_slave(fmus["plant"])
    slave.exitInitializationMode()
    with pytest.raises(FMICallException):
        slave.doStep(0.0, -1.0)
    slave.freeInstance()
    assert os.path.isdir(fmus["plant"])
