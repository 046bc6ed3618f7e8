"""Plant FMUs of extended models (MPI + output stages): the FMU reproduces
``ExtendedModel.simulate`` bit for bit for every stage kind, its stages match
independent implementations (scipy filters, shifts, polynomials), FMU states
carry the stages and the step count, steps other than the sample period are
refused, the model description passes the validators, and
``pysim diagnose --out SPEC`` then ``build-fmu SPEC`` works end to end."""
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
from conftest import continuous_response
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu

from pysim.core.extended import ExtendedModel, StageSpec
from pysim.core.model import HysteresisModel, InverseCompensator
from pysim.core.spec import load_spec
from pysim.fmu import build_fmus
from pysim.fmu.variables import variables
from pysim.testing.fmus import ALL_PLATFORMS, DEFAULT_MODEL, ERROR, OK, WARNING, RawFMU, built_fmus, extracted

T = 2e-4                                   # s: 5 kHz, as on a typical rig
# offsets on: the stages see u = voltage - input_offset and h with the output offset
BASE = DEFAULT_MODEL.with_parameters(input_offset_V=-3.0, output_offset_um=1.5, name="shifted")
LO, HI = BASE.voltage_range_V

STAGES = {
    "lag": dict(lag_time_constant_s=2e-3),
    "second_order": dict(resonance_hz=120.0, damping_ratio=0.05),
    "delay": dict(delay_samples=3.4),
    "creep": dict(creep_time_constants_s=(0.01, 0.1), creep_weights_um_per_V=(0.02, 0.04)),
    "drift": dict(drift_coefficients=(0.5, -0.2), drift_span_s=0.5),     # held over the last 0.3 s
    "displacement_creep": dict(displacement_creep_time_constants_s=(0.002, 0.02, 0.2),
                               displacement_creep_shares=(0.04, 0.05, 0.06)),
    "combination": dict(lag_time_constant_s=1e-3, resonance_hz=300.0, damping_ratio=0.2, delay_samples=2.0,
                        creep_time_constants_s=(0.05,), creep_weights_um_per_V=(0.03,),
                        drift_coefficients=(0.1, 0.05, -0.01)),
}


def extended(kind: str, base: HysteresisModel = BASE) -> ExtendedModel:
    return ExtendedModel(base.with_parameters(name=f"ext_{kind}"), StageSpec(sample_period_s=T, **STAGES[kind]))


def fmus(kind: str) -> dict:
    """Plant and inverse FMUs of the extended model ``kind`` (the combination
    for every platform: the stages must build for all of them)."""
    return built_fmus(extended(kind), ALL_PLATFORMS if kind == "combination" else ("linux64",))


def record(seed: int, n: int = 4000) -> np.ndarray:
    """Voltage samples (V): ramps of random speed to random levels, each held
    for a random time (holds show ringing, creep and delay)."""
    rng = np.random.default_rng(seed)
    pieces, level = [], LO
    while sum(p.size for p in pieces) < n:
        target = rng.uniform(LO, HI)
        pieces.append(np.linspace(level, target, rng.integers(2, 200))[1:])
        pieces.append(np.full(rng.integers(1, 300), target))
        level = target
    return np.concatenate(pieces)[:n]


def cosimulate(fmu_path, voltage, reals=None) -> np.ndarray:
    """fmpy FMU2Slave loop at the sample period: set voltage, get
    displacement, doStep."""
    folder = str(extracted(fmu_path))
    md = read_model_description(folder)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="extended")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    for name, value in (reals or {}).items():
        slave.setReal([vr[name]], [value])
    slave.exitInitializationMode()
    out = np.empty(len(voltage))
    for k, v in enumerate(voltage):
        slave.setReal([vr["voltage"]], [float(v)])
        out[k] = slave.getReal([vr["displacement"]])[0]
        slave.doStep(k * T, T)
    slave.terminate()
    slave.freeInstance()
    return out


# ------------------------------------------------ the FMU is the Python model

@pytest.mark.parametrize("kind", sorted(STAGES))
def test_plant_fmu_reproduces_the_extended_model(kind):
    model = extended(kind)
    v = record(seed=len(kind))
    y = cosimulate(fmus(kind)["plant"], v)
    expected = model.simulate(v)
    assert np.max(np.abs(y - expected)) <= 1e-9 * np.ptp(expected)
    assert np.array_equal(y, expected)                  # the same C code, the same bits
    # and the stages do act: the output is not the hysteresis alone
    assert np.max(np.abs(y - BASE.simulate(v))) > 1e-3 * np.ptp(expected)


def _bilinear_rest(b, a, x):
    """scipy's filter of x, at rest at x[0] (an independent implementation)."""
    y, _ = scipy.signal.lfilter(b, a, x, zi=scipy.signal.lfilter_zi(b, a) * x[0])
    return y


@pytest.mark.parametrize("kind", ["lag", "second_order", "delay", "creep", "drift", "displacement_creep"])
def test_plant_fmu_stages_match_independent_implementations(kind):
    """FMU output against the hysteresis output passed through each stage as
    written from its definition (a lag and a resonance: scipy's simulation of
    the continuous stage with the input linear between samples; creep modes:
    scipy's bilinear transform; delay: a shift with linear interpolation;
    drift: the polynomial in t = k T, held from its span on)."""
    v = record(seed=7)
    y = cosimulate(fmus(kind)["plant"], v)
    h = BASE.simulate(v)
    t = np.arange(v.size) * T
    p = STAGES[kind]
    if kind == "lag":
        expected = continuous_response([1.0], [p["lag_time_constant_s"], 1.0], h, T)
    elif kind == "second_order":
        w, zeta = 2 * np.pi * p["resonance_hz"], p["damping_ratio"]
        expected = continuous_response([w * w], [1.0, 2 * zeta * w, w * w], h, T)
    elif kind == "delay":
        m, f = int(p["delay_samples"]), p["delay_samples"] % 1.0
        padded = np.concatenate((np.full(m + 1, h[0]), h))      # h[0] held since forever
        k = np.arange(h.size) + m + 1
        expected = (1 - f) * padded[k - m] + f * padded[k - m - 1]
    elif kind == "creep":
        u = v - BASE.input_offset_V
        expected = h.copy()
        for tau, weight in zip(p["creep_time_constants_s"], p["creep_weights_um_per_V"]):
            expected += weight * _bilinear_rest(*scipy.signal.bilinear([1.0], [tau, 1.0], fs=1 / T), u)
    elif kind == "displacement_creep":
        # the parallel form 1 - Σ s_j + Σ s_j/(τ_j s + 1) that the FMU runs as a factored cascade
        shares = p["displacement_creep_shares"]
        expected = (1.0 - sum(shares)) * h
        for tau, share in zip(p["displacement_creep_time_constants_s"], shares):
            expected += share * _bilinear_rest(*scipy.signal.bilinear([1.0], [tau, 1.0], fs=1 / T), h)
    else:
        held = np.minimum(t, p["drift_span_s"])
        expected = h + sum(c * held ** (j + 1) for j, c in enumerate(p["drift_coefficients"]))
    assert np.max(np.abs(y - expected)) <= 1e-9 * np.ptp(h)


def test_the_drift_span_is_a_visible_constant():
    """A drift held from its span on shows the span (s) among the read-only constants."""
    md = RawFMU(fmus("drift")["plant"]).description
    span = [v for v in md.modelVariables if v.name == "drift_span"]
    assert len(span) == 1 and span[0].causality == "local" and span[0].variability == "constant"
    assert float(span[0].start) == STAGES["drift"]["drift_span_s"] and span[0].unit == "s"


def test_fmpy_simulate_fmu_drives_the_fixed_step_plant():
    """fmpy's own driver with output_interval = T: its step sizes carry the
    rounding of n T arithmetic and are accepted.  It samples the outputs
    after each step, before the next input is set: where the input holds over
    two samples, that is the model's output at that sample."""
    model = extended("combination")
    n = 3000
    v = np.repeat(record(seed=11, n=n // 2), 2)            # every value held for two samples
    signal = np.array(list(zip(np.arange(n) * T, v)), dtype=[("time", np.float64), ("voltage", np.float64)])
    result = simulate_fmu(str(fmus("combination")["plant"]), stop_time=(n - 1) * T, output_interval=T,
                          input=signal, output=["displacement"])
    assert result.size == n
    expected = model.simulate(v)
    assert np.array_equal(result["time"], np.arange(n) * T)
    assert np.array_equal(result["displacement"][1::2], expected[1::2])
    assert result["displacement"][0] == expected[0]


# --------------------------------------------------------------- parameters

def test_creep_weights_and_drift_are_parameters():
    """Changing them in initialisation mode gives the model with the changed values."""
    model = extended("combination")
    changed = {"creep_weight[1]": -0.05, "drift[2]": 0.3}
    v = record(seed=5, n=2000)
    y = cosimulate(fmus("combination")["plant"], v, reals=changed)
    other = model.with_parameters(creep_weights_um_per_V=(-0.05,), drift_coefficients=(0.1, 0.3, -0.01))
    assert np.array_equal(y, other.simulate(v))


def test_stage_constants_are_visible_and_read_only():
    model = extended("combination")
    fmu = RawFMU(fmus("combination")["plant"])
    md = fmu.description
    constants = {v.name: v for v in md.modelVariables if v.causality == "local"}
    expected = {"sample_period": T, "lag_time_constant": 1e-3, "resonance_frequency": 300.0,
                "damping_ratio": 0.2, "delay": 2.0 * T, "creep_time_constant[1]": 0.05}
    assert {name: float(v.start) for name, v in constants.items()} == expected
    assert all(v.variability == "constant" for v in constants.values())
    units = {name: v.unit for name, v in constants.items()}
    assert units == {"sample_period": "s", "lag_time_constant": "s", "resonance_frequency": "Hz",
                     "damping_ratio": None, "delay": "s", "creep_time_constant[1]": "s"}
    drift_units = {v.name: v.unit for v in md.modelVariables if v.name.startswith("drift[")}
    assert drift_units == {"drift[1]": "um/s", "drift[2]": "um/s2", "drift[3]": "um/s3"}
    c = fmu.instantiate()
    assert fmu.set_real(c, {"sample_period": 1e-3}) == ERROR        # where a parameter could be set
    assert "sample_period is a constant of this FMU" in fmu.errors()[-1][3]
    assert fmu.set_real(c, {"creep_weight[1]": 0.03}) == OK
    assert fmu.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == OK
    assert fmu.fmi2EnterInitializationMode(c) == OK
    assert fmu.get_real(c, list(expected)) == (OK, list(expected.values()))
    fmu.fmi2FreeInstance(c)
    # the generated configuration holds the discrete coefficients exactly
    with zipfile.ZipFile(fmus("combination")["plant"]) as archive:
        config = archive.read("sources/model_config.h").decode()

    def numbers(macro):
        body = re.search(rf"#define {macro} \{{(.*?)\}}", config, re.S).group(1)
        return [float(x) for x in body.replace("\\", " ").split(",")]

    stages = model.stages.coefficients()
    assert numbers("MODEL_SECTIONS") == [x for s in stages["sections"] for x in s]
    assert numbers("MODEL_CREEP_ALPHA") == stages["creep_alpha"]
    assert numbers("MODEL_CREEP_BETA") == stages["creep_beta"]
    assert f"#define MODEL_STAGE_STATE_SIZE {model.stages.state_size}\n" in config
    assert f"#define MODEL_SAMPLE_PERIOD {T!r}\n" in config


# --------------------------------------------------------------- FMU state

def test_state_round_trips_continue_bit_identically():
    """Stages and the step count (the drift's time) are part of the FMU state."""
    model = extended("combination")
    fmu = RawFMU(fmus("combination")["plant"])
    v = record(seed=3, n=3000)
    half = 1234
    a = fmu.initialised("a")
    first, t = fmu.run(a, v[:half], "voltage", "displacement", h=T)
    status, saved = fmu.get_state(a)
    assert status == OK
    blob = fmu.serialize(a, saved)
    second, _ = fmu.run(a, v[half:], "voltage", "displacement", t0=t, h=T)
    assert np.array_equal(np.concatenate([first, second]), model.simulate(v))
    # get/set on the same instance
    assert fmu.fmi2SetFMUstate(a, saved) == OK
    replay, _ = fmu.run(a, v[half:], "voltage", "displacement", t0=t, h=T)
    assert np.array_equal(replay, second)
    # serialised, into an instance that never ran
    b = fmu.instantiate("b")
    status, restored = fmu.deserialize(b, blob)
    assert status == OK and fmu.fmi2SetFMUstate(b, restored) == OK
    moved, _ = fmu.run(b, v[half:], "voltage", "displacement", t0=t, h=T)
    assert np.array_equal(moved, second)
    # and the Python model carried over the same split agrees
    _, state = model.simulate(v[:half], return_state=True)
    assert np.array_equal(model.simulate(v[half:], state), second)
    for c, s in ((a, saved), (b, restored)):
        fmu.free_state(c, s)
        fmu.fmi2FreeInstance(c)


def test_state_before_the_first_step_starts_the_stages_at_rest_again():
    model = extended("combination")
    fmu = RawFMU(fmus("combination")["plant"])
    v = record(seed=9, n=500)
    c = fmu.initialised()
    _, fresh = fmu.get_state(c)
    first, _ = fmu.run(c, v, "voltage", "displacement", h=T)
    assert fmu.fmi2SetFMUstate(c, fresh) == OK
    again, _ = fmu.run(c, v[::-1], "voltage", "displacement", h=T)
    assert np.array_equal(first, model.simulate(v))
    assert np.array_equal(again, model.simulate(v[::-1]))
    fmu.fmi2FreeInstance(c)


def test_reading_after_the_step_gives_the_next_sample_for_the_held_input():
    """Outputs change over a step: read after fmi2DoStep, the displacement is
    the model's next sample with the input held."""
    model = extended("combination")
    fmu = RawFMU(fmus("combination")["plant"])
    v = record(seed=2, n=300)
    c = fmu.initialised()
    after, _ = fmu.run(c, v, "voltage", "displacement", h=T, get_first=False)
    expected = [model.simulate(np.append(v[:k + 1], v[k]))[-1] for k in range(v.size)]
    assert np.array_equal(after, expected)
    fmu.fmi2FreeInstance(c)


# --------------------------------------------------------------- step size

def test_other_step_sizes_are_refused_and_change_nothing():
    model = extended("lag")
    fmu = RawFMU(fmus("lag")["plant"])
    v = record(seed=4, n=400)
    c = fmu.initialised()
    y, t = fmu.run(c, v[:200], "voltage", "displacement", h=T)
    for bad in (2 * T, T / 2, T * (1 + 1e-6)):
        assert fmu.set_real(c, {"voltage": float(v[200])}) == OK
        assert fmu.do_step(c, t, bad) == ERROR
        message = fmu.errors()[-1][3]
        assert "fmi2DoStep" in message and "sample period" in message and repr(T) in message
    rest, t_end = fmu.run(c, v[200:], "voltage", "displacement", t0=t, h=T)
    assert np.array_equal(np.concatenate([y, rest]), model.simulate(v))
    # a step that differs from T by the rounding of the importer's time arithmetic is one sample
    assert fmu.do_step(c, t_end, T * (1 + 1e-10)) in (OK, WARNING)
    fmu.fmi2FreeInstance(c)


def test_model_description_declares_the_fixed_step():
    for kind in ("lag", "combination"):
        md = read_model_description(str(fmus(kind)["plant"]))
        assert not md.coSimulation.canHandleVariableCommunicationStepSize
        assert float(md.defaultExperiment.stepSize) == T
        assert "output stages" in md.description
    # the inverse and plain plants keep variable steps
    assert read_model_description(str(fmus("lag")["inverse"])).coSimulation.canHandleVariableCommunicationStepSize
    assert read_model_description(str(built_fmus()["plant"])).coSimulation.canHandleVariableCommunicationStepSize


# --------------------------------------------------------------- validators

def test_extended_plant_passes_fmpy_validate_fmutool_and_the_schema():
    from test_fmu_validation import fmutool_check, xmllint

    path = fmus("combination")["plant"]
    assert validate_fmu(str(path)) == []
    report = fmutool_check(path)
    assert "compliant with FMI-2.0" in report and "No semantic error" in report and "ERROR" not in report
    result = xmllint(extracted(path) / "modelDescription.xml")
    assert result.returncode == 0, result.stderr


# --------------------------------------------------------------- inverse

def test_inverse_fmu_of_an_extended_spec_compensates_the_hysteresis_part():
    model = extended("creep")
    fmu = RawFMU(fmus("creep")["inverse"])
    assert "output stages are not inverted" in fmu.description.description
    assert [v.name for v in fmu.description.modelVariables] == [v.name for v in variables(BASE, "inverse")]
    reference = model.hysteresis.simulate(record(seed=6, n=1500))
    c = fmu.initialised()
    voltage, _ = fmu.run(c, reference, "displacement_ref", "voltage")
    assert np.max(np.abs(voltage - InverseCompensator(model.hysteresis)(reference))) <= 1e-12 * (HI - LO)
    assert np.max(np.abs(model.hysteresis.simulate(voltage) - reference)) <= 1e-9 * np.ptp(reference)
    fmu.fmi2FreeInstance(c)


def test_extended_spec_without_stages_builds_like_its_hysteresis_part(tmp_path):
    plain = ExtendedModel(BASE, StageSpec(sample_period_s=T))
    messages = []
    paths = build_fmus(plain, tmp_path, ("linux64",), progress=messages.append)
    assert any("without output stages" in m for m in messages)
    md = read_model_description(str(paths["plant"]))
    assert md.coSimulation.canHandleVariableCommunicationStepSize
    assert [v.name for v in md.modelVariables] == [v.name for v in variables(BASE, "plant")]


# --------------------------------------------------------------- end to end

def test_diagnose_then_build_fmu_end_to_end(tmp_path):
    from pysim.identification.data import MeasuredData, save_measured
    from pysim.testing.synthetic import make_case

    case = make_case(3, effect="creep")
    data = save_measured(MeasuredData(case.time_s, case.voltage_V, case.displacement_um, "synthetic"),
                         tmp_path / "rig.csv")
    spec = tmp_path / "rig_extended.py"
    run = subprocess.run([sys.executable, "-m", "pysim.cli.main", "diagnose", str(data), "--out", str(spec)],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    model = load_spec(spec)
    assert isinstance(model, ExtendedModel) and model.stages.present
    out = tmp_path / "fmus"
    run = subprocess.run([sys.executable, "-m", "build_fmu.cli", str(spec), "-o", str(out), "--platforms",
                          "linux64"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "output stages" in run.stdout and "not inverted" in run.stdout
    assert sorted(p.name for p in out.iterdir()) == ["rig_extended_inverse.fmu", "rig_extended_plant.fmu"]
    # the record's own voltages, one step per sample
    v = np.clip(case.voltage_V, *model.voltage_range_V)
    folder = str(extracted(out / "rig_extended_plant.fmu"))
    md = read_model_description(folder)
    assert float(md.defaultExperiment.stepSize) == model.sample_period_s
    slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier)
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    y = np.empty(v.size)
    for k, x in enumerate(v):
        slave.setReal([0], [float(x)])
        y[k] = slave.getReal([1])[0]
        slave.doStep(k * model.sample_period_s, model.sample_period_s)
    slave.freeInstance()
    assert np.array_equal(y, model.simulate(v))


# --------------------------------------------------------------- C sources

@pytest.mark.parametrize("compiler", ["gcc", "clang"])
def test_extended_plant_sources_compile_without_warnings(tmp_path, compiler):
    from test_fmu_native import WARNINGS, _compile

    from pysim.fmu.compile import fmi_include_dir

    src = extracted(fmus("combination")["plant"]) / "sources"
    include = ["-I", str(src), "-I", str(fmi_include_dir())]
    _compile([compiler] + WARNINGS + include + ["-c", str(src / "all.c"), "-o", "all.o"], tmp_path)
    for name in ("fmi2_layer.c", "model.c", "output_stages.c"):        # each also on its own
        _compile([compiler] + WARNINGS + include + ["-c", str(src / name), "-o", name + ".o"], tmp_path)
    assert Path(tmp_path / "model.c.o").is_file()
