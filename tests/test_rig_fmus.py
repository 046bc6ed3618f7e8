"""The FMUs of the rig parts (amplifier, controller, sensor, LTI system) against
the Python reference equations of pysim.core.rig and the unit table of
pysim.cosim.rig: bit for bit on linux64 for the rig parts, <= 1e-12 relative
for the LTI system at steps other than its nominal one; fmpy validate; bad
parameters refused at initialisation."""
import math
import shutil
from pathlib import Path

import control
import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.validation import validate_fmu
from pysim.specs.flexure_stage import STAGE

from pysim.core.errors import ModelError
from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise, XorShiftNormal
from pysim.cosim.stage import discretise
from pysim.fmu.errors import BuildError
from pysim.fmu.rig_parts import amplifier_part, build_part_fmus, controller_part, lti_part, sensor_part, zoh_matrices

T = 5e-5
AMPLIFIER = Amplifier(gain_V_per_V=15.0, bandwidth_hz=10e3, current_limit_A=0.3, capacitance_F=3.6e-6,
                      output_low_V=0.0, output_high_V=150.0)
CONTROLLER = PIController(kp_V_per_um=0.05, ki_V_per_um_s=600.0, output_low_V=0.0, output_high_V=150.0)
DAC = Converter(16, 0.0, 10.0)
ADC = Converter(16, -10.0, 110.0)
NOISE = SensorNoise(rms_um=0.01, seed=2014)
# a third-order system with a zero and feed-through: exercises every matrix of the recursion
LTI_3 = control.tf([0.5, 300.0, 4e5], [1e-3, 2.0, 2e3, 4e5])
LTI_DISCRETE = control.tf([0.2, 0.1], [1.0, -1.2, 0.5], T)


def _parts():
    return {
        "amplifier": amplifier_part(AMPLIFIER, T),
        "amplifier_ideal": amplifier_part(Amplifier(gain_V_per_V=15.0), T, name="amplifier_ideal"),
        "controller": controller_part(CONTROLLER, DAC, 15.0, T),
        "sensor": sensor_part(ADC, NOISE, T),
        "stage": lti_part(STAGE, T, name="stage"),
        "lti3": lti_part(LTI_3, T, name="lti3", input_unit=None, output_unit=None),
        "lti_discrete": lti_part(LTI_DISCRETE, T, name="lti_discrete"),
        "gain": lti_part(control.tf([2.0], [1.0]), T, name="gain"),
    }


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    from fmpy import platform

    out = tmp_path_factory.mktemp("rig_fmus")
    return build_part_fmus(_parts().values(), out, platforms=(platform,))


class Driver:
    """One FMU instance driven through fmpy's FMI 2.0 calls."""

    def __init__(self, path, parameters=None, booleans=None, start_time=0.0):
        self.md = read_model_description(str(path))
        self.owned = not Path(path).is_dir()             # an extracted FMU is used as it is
        self.dir = extract(str(path)) if self.owned else str(path)
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="test")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=start_time)
        if parameters:
            self.fmu.setReal([self.vr[k] for k in parameters], list(map(float, parameters.values())))
        if booleans:
            self.fmu.setBoolean([self.vr[k] for k in booleans], list(booleans.values()))
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()
        self.time = start_time

    def run(self, inputs: dict, output: str, steps=None):
        """Outputs after each step with ``inputs`` (``{name: array}``) held; ``steps``: step sizes."""
        names = list(inputs)
        n = len(inputs[names[0]])
        steps = np.full(n, T) if steps is None else steps
        vrs, out_vr = [self.vr[k] for k in names], [self.vr[output]]
        out = np.empty(n)
        for k in range(n):
            self.fmu.setReal(vrs, [float(inputs[name][k]) for name in names])
            self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=float(steps[k]))
            self.time += float(steps[k])
            out[k] = self.fmu.getReal(out_vr)[0]
        return out

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()
        if self.owned:
            shutil.rmtree(self.dir, ignore_errors=True)


def _drive(path, inputs, output, steps=None, **kwargs):
    d = Driver(path, **kwargs)
    try:
        return d.run(inputs, output, steps)
    finally:
        d.close()


def _same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape
    bad = np.flatnonzero(a != b)
    assert bad.size == 0, f"{bad.size} samples differ, first at {bad[0]}: {a[bad[0]]!r} != {b[bad[0]]!r}"


# ------------------------------------------------------------------ amplifier
def _amplifier_reference(amp, commands, steps):
    a = amp.initial_state(0.0)
    out = []
    for c, h in zip(commands, steps):
        alpha, max_change = amp.coefficients(float(h))
        a = amp._step(a, float(c), alpha, max_change)
        out.append(a)
    return np.array(out)


def _commands(rng, n):
    """Steps (slew limited), small moves (bandwidth), out of range (saturation)."""
    levels = rng.choice([-1.0, 0.0, 0.3, 2.0, 5.0, 9.9, 10.0, 12.0], size=n // 50 + 1)
    c = np.repeat(levels, 50)[:n]
    return c + 0.05 * rng.standard_normal(n)


def test_amplifier_equals_python_bit_for_bit(fmus):
    rng = np.random.default_rng(1)
    c = _commands(rng, 4000)
    steps = np.full(c.size, T)
    y = _drive(fmus["amplifier"], {"command": c}, "voltage")
    ref = _amplifier_reference(AMPLIFIER, c, steps)
    _same_bits(y, ref)
    assert np.any(y == 150.0) and np.any(y == 0.0)                  # saturation reached
    assert np.any(np.abs(np.diff(ref)) == AMPLIFIER.slew_rate_V_per_s * T)   # slew limited


def test_amplifier_variable_steps_and_ideal(fmus):
    rng = np.random.default_rng(2)
    c = _commands(rng, 1500)
    steps = T * rng.choice([0.5, 1.0, 2.0, 0.37, 3.1], size=c.size)
    y = _drive(fmus["amplifier"], {"command": c}, "voltage", steps)
    ref = _amplifier_reference(AMPLIFIER, c, steps)
    np.testing.assert_allclose(y, ref, rtol=1e-12, atol=1e-12 * 150.0)
    ideal = Amplifier(gain_V_per_V=15.0)
    _same_bits(_drive(fmus["amplifier_ideal"], {"command": c}, "voltage"),
               _amplifier_reference(ideal, c, np.full(c.size, T)))


# ----------------------------------------------------------------- controller
def _controller_reference(pi, dac, gain, r, m, ff, steps, feedback=True, scale=1.0, offset=0.0):
    integrator = 0.0
    out = []
    for rk, mk, fk, h in zip(r, m, ff, steps):
        f = scale * float(fk) + offset
        if feedback:
            u, integrator = pi.step(integrator, float(rk) - float(mk), f, float(h))
        else:
            u = min(max(f, pi.output_low_V), pi.output_high_V)
        out.append(dac.convert(u / gain))
    return np.array(out)


def _controller_inputs(rng, n):
    r = 40.0 + 30.0 * np.sin(np.arange(n) * 0.01)
    m = r + np.repeat(rng.normal(0.0, 3.0, n // 100 + 1), 100)[:n]      # long one-sided errors: windup
    m[n // 3: n // 3 + 300] -= 500.0                                   # drives the output to its limits
    m[2 * n // 3: 2 * n // 3 + 300] += 500.0
    ff = np.clip(2.0 * r + rng.normal(0.0, 5.0, n), -20.0, 170.0)      # feedforward beyond the range
    ff[2 * n // 3: 2 * n // 3 + 300] = -20.0
    return r, m, ff


@pytest.mark.parametrize("feedback", [True, False])
def test_controller_equals_python_bit_for_bit(fmus, feedback):
    rng = np.random.default_rng(3)
    r, m, ff = _controller_inputs(rng, 3000)
    scale, offset = (1.0, 0.0) if feedback else (1.0 / 0.49, 0.3)
    y = _drive(fmus["controller"], {"reference": r, "measurement": m, "feedforward": ff}, "command",
               parameters={"ff_scale": scale, "ff_offset": offset}, booleans={"feedback": feedback})
    ref = _controller_reference(CONTROLLER, DAC, 15.0, r, m, ff, np.full(r.size, T), feedback, scale, offset)
    _same_bits(y, ref)
    assert np.any(y == 10.0) and np.any(y == 0.0)                      # saturated both ways
    assert np.all(np.abs(y / DAC.lsb - np.round(y / DAC.lsb)) < 1e-6)  # on DAC codes


def test_controller_anti_windup_and_variable_steps(fmus):
    rng = np.random.default_rng(4)
    r, m, ff = _controller_inputs(rng, 2000)
    ff = np.zeros_like(ff)
    steps = T * rng.choice([1.0, 0.5, 2.5], size=r.size)
    y = _drive(fmus["controller"], {"reference": r, "measurement": m, "feedforward": ff}, "command", steps)
    ref = _controller_reference(CONTROLLER, DAC, 15.0, r, m, ff, steps)
    _same_bits(y, ref)          # ki h e: the same h (differences of exact binary times) in both


def test_controller_feedforward_only_path(fmus):
    """ff_scale 0, offset 0 with feedback: the feedback path of RigSimulation (f = 0)."""
    rng = np.random.default_rng(5)
    r, m, ff = _controller_inputs(rng, 1000)
    y = _drive(fmus["controller"], {"reference": r, "measurement": m, "feedforward": ff}, "command",
               parameters={"ff_scale": 0.0})
    _same_bits(y, _controller_reference(CONTROLLER, DAC, 15.0, r, m, np.zeros_like(ff), np.full(r.size, T)))


# --------------------------------------------------------------------- sensor
def _sensor_reference(adc, noise, s):
    gen = noise.generator()
    return np.array([adc.convert(x + noise.rms_um * gen.next()) if noise.rms_um else adc.convert(x)
                     for x in s.tolist()])


def test_sensor_equals_python_bit_for_bit(fmus):
    rng = np.random.default_rng(6)
    s = np.concatenate([rng.uniform(-20.0, 120.0, 3000), np.full(50, 50.0), rng.uniform(0, 100, 1001)])
    y = _drive(fmus["sensor"], {"displacement": s}, "measurement")
    _same_bits(y, _sensor_reference(ADC, NOISE, s))
    assert y.min() == -10.0 and y.max() == 110.0
    quiet = _drive(fmus["sensor"], {"displacement": s}, "measurement", parameters={"noise_rms": 0.0})
    _same_bits(quiet, _sensor_reference(ADC, SensorNoise(0.0), s))


@pytest.mark.parametrize("seed", [0, 1, -7, 2 ** 40 + 3])
def test_sensor_seeds_and_ideal_adc(fmus, seed):
    s = np.linspace(-5.0, 105.0, 501)
    y = _drive(fmus["sensor"], {"displacement": s}, "measurement",
               parameters={"seed": seed, "adc_bits": 0, "noise_rms": 0.5})
    _same_bits(y, _sensor_reference(Converter(0, -10.0, 110.0), SensorNoise(0.5, seed), s))


def test_xorshift_reference_sequence():
    """The generator the sensor reproduces: first numbers of seed 2014 (pinned)."""
    g = XorShiftNormal(2014)
    first = [g.next() for _ in range(3)]
    assert all(math.isfinite(x) for x in first) and first[0] != first[1]


# ------------------------------------------------------------------------ LTI
def _lti_reference(system, u, steps):
    """z' = Ad z + Bd u, y = D u + C z' per step, Ad and Bd from
    pysim.cosim.stage.discretise(system, h, "zoh") (the harness's recursion)."""
    cache = {}
    z = None
    out = []
    for uk, h in zip(u.tolist(), steps.tolist()):
        if h not in cache:
            d = control.ss(discretise(system, h, "zoh"))     # a discrete system comes back as it is
            cache[h] = (np.asarray(d.A, float).tolist(), np.asarray(d.B, float).ravel().tolist(),
                        np.asarray(d.C, float).ravel().tolist(), float(np.asarray(d.D, float).ravel()[0]))
        A, B, C, D = cache[h]
        rows = range(len(B))
        z = [0.0] * len(B) if z is None else z
        z = [sum(A[i][j] * z[j] for j in rows) + B[i] * uk for i in rows]
        y = D * uk
        for i in rows:
            y += C[i] * z[i]
        out.append(y)
    return np.array(out)


def _lti_input(rng, n):
    return np.repeat(rng.uniform(-1.0, 80.0, n // 40 + 1), 40)[:n] + rng.normal(0.0, 1.0, n)


@pytest.mark.parametrize("name, system", [("stage", STAGE), ("lti3", LTI_3), ("gain", control.tf([2.0], [1.0]))])
def test_lti_nominal_step_bit_for_bit_and_forced_response(fmus, name, system):
    rng = np.random.default_rng(7)
    u = _lti_input(rng, 3000)
    y = _drive(fmus[name], {"u": u}, "y")
    _same_bits(y, _lti_reference(system, u, np.full(u.size, T)))
    # python-control's forced response of the ZOH system: y_k = C x_k + D u_k, x_{k+1} = A x_k + B u_k;
    # the FMU's output after step k is C x_{k+1} + D u_k
    d = discretise(system, T, "zoh") if control.ss(system).nstates else control.ss(control.tf(system), dt=T)
    response = control.forced_response(control.ss(d), T=np.arange(u.size + 1) * T, U=np.append(u, 0.0))
    x_next = np.atleast_2d(response.states)[:, 1:]
    expected = (np.asarray(d.C, float) @ x_next).ravel() + float(np.asarray(d.D).ravel()[0]) * u
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(y - expected)) <= 1e-12 * scale


@pytest.mark.parametrize("name, system", [("stage", STAGE), ("lti3", LTI_3)])
def test_lti_changed_step_sizes(fmus, name, system):
    """Any step: the FMU computes the ZOH discretisation in C (Pade 13, scaling
    and squaring) and equals scipy's to <= 1e-12 relative."""
    rng = np.random.default_rng(8)
    u = _lti_input(rng, 2400)
    for steps in (np.full(u.size, 2.0 ** -14),                                   # one other step
                  T * rng.choice([0.25, 0.5, 1.0, 1.5, 4.0, 0.1], size=u.size),   # varying
                  np.full(u.size, 1e-3)):                                        # coarse: many squarings
        y = _drive(fmus[name], {"u": u}, "y", steps)
        ref = _lti_reference(system, u, steps)
        assert np.max(np.abs(y - ref)) <= 1e-12 * np.max(np.abs(ref)), name


def test_lti_discrete_steps_at_its_sampling_time(fmus):
    rng = np.random.default_rng(9)
    u = _lti_input(rng, 500)
    y = _drive(fmus["lti_discrete"], {"u": u}, "y")
    _same_bits(y, _lti_reference(LTI_DISCRETE, u, np.full(u.size, T)))
    d = Driver(fmus["lti_discrete"])
    try:
        with pytest.raises(Exception):
            d.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=2 * T)
    finally:
        d.close()


def test_zoh_matrices_equal_the_harness_discretisation():
    for system in (STAGE, LTI_3):
        for h in (T, 1e-3, 3.3e-6):
            Ad, Bd, C, D = zoh_matrices(system, h)
            d = discretise(system, h, "zoh")
            for a, b in ((Ad, d.A), (Bd, d.B), (C, d.C), (D, d.D)):
                assert np.array_equal(np.asarray(a, float), np.asarray(b, float))


# ----------------------------------------------------- validation, bad input
@pytest.mark.parametrize("name", list(_parts()))
def test_fmpy_validate(fmus, name):
    assert validate_fmu(str(fmus[name])) == []


@pytest.mark.parametrize("name, parameters, word", [
    ("amplifier", {"gain": 0.0}, "gain"),
    ("amplifier", {"output_low": 200.0}, "output_low"),
    ("amplifier", {"bandwidth": -1.0}, "bandwidth"),
    ("controller", {"dac_bits": 16.5}, "dac_bits"),
    ("controller", {"ki": -1.0}, "ki"),
    ("controller", {"amplifier_gain": 0.0}, "amplifier_gain"),
    ("sensor", {"adc_bits": 33.0}, "adc_bits"),
    ("sensor", {"seed": 0.5}, "seed"),
    ("sensor", {"noise_rms": -0.1}, "noise_rms"),
    ("stage", {"A[1,1]": 1e300}, "A[1,1]"),
])
def test_bad_parameters_refused_at_initialisation(fmus, name, parameters, word):
    from pysim.testing.fmus import RawFMU

    fmu = RawFMU(fmus[name])
    c = fmu.instantiate()
    assert c
    assert fmu.fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0) == 0
    assert fmu.fmi2EnterInitializationMode(c) == 0
    assert fmu.set_real(c, parameters) == 0
    assert fmu.fmi2ExitInitializationMode(c) == 3
    assert any(word in m[3] and "invalid parameters" in m[3] for m in fmu.errors()), fmu.messages
    fmu.fmi2FreeInstance(c)


def test_builder_refuses_what_it_cannot_build():
    with pytest.raises(BuildError, match="one input and one output"):
        lti_part(control.ss(np.eye(2) * -1.0, np.eye(2), np.eye(2), np.zeros((2, 2))), T)
    with pytest.raises(BuildError, match="dt"):
        lti_part(control.tf([1.0], [1.0, -0.5], 2 * T), T)
    with pytest.raises(BuildError, match="identifier"):
        amplifier_part(AMPLIFIER, T, name="my amplifier")
    with pytest.raises(ModelError, match="seed"):          # refused by the part itself, before any build
        sensor_part(ADC, SensorNoise(0.01, 2 ** 60), T)


# ------------------------------------------ FMU state, other checkers, sources
@pytest.mark.parametrize("name, inputs", [
    ("amplifier", {"command": "c"}), ("controller", {"reference": "r", "measurement": "m", "feedforward": "f"}),
    ("sensor", {"displacement": "s"}), ("stage", {"u": "s"})])
def test_state_round_trip_continues_bit_for_bit(fmus, name, inputs):
    """Get/set and serialize/deserialize in the middle of a run (a pending
    step, the noise generator's spare value) continue exactly."""
    rng = np.random.default_rng(10)
    n = 401
    signals = {"c": _commands(rng, n), "r": 40.0 + rng.normal(0, 1, n), "m": 40.0 + rng.normal(0, 5, n),
               "f": rng.uniform(0, 150, n), "s": rng.uniform(0, 100, n)}
    data = {port: signals[key] for port, key in inputs.items()}
    output = {"amplifier": "voltage", "controller": "command", "sensor": "measurement", "stage": "y"}[name]
    d = Driver(fmus[name])
    try:
        first = d.run({k: v[:201] for k, v in data.items()}, output)
        state = d.fmu.getFMUstate()
        blob = d.fmu.serializeFMUstate(state)
        time = d.time
        rest = d.run({k: v[201:] for k, v in data.items()}, output)
        for restore in ("state", "blob"):
            d.fmu.setFMUstate(state if restore == "state" else d.fmu.deSerializeFMUstate(blob))
            d.time = time
            _same_bits(d.run({k: v[201:] for k, v in data.items()}, output), rest)
        d.fmu.freeFMUstate(state)
    finally:
        d.close()
    whole = _drive(fmus[name], data, output)
    _same_bits(np.concatenate([first, rest]), whole)


def test_fmutool_and_schema_checks(fmus):
    import subprocess
    import sys

    import fmpy

    program = shutil.which("fmutool") or str(Path(sys.executable).parent / "fmutool")
    schema = Path(fmpy.__file__).resolve().parent / "schema" / "fmi2" / "fmi2ModelDescription.xsd"
    for name in ("amplifier", "controller", "sensor", "stage", "lti_discrete", "gain"):
        result = subprocess.run([program, "-input", str(fmus[name]), "-check"], capture_output=True, text=True,
                                timeout=120)
        text = result.stdout + result.stderr
        assert "seems to be compliant with FMI-2.0" in text and "No semantic error" in text, text
        folder = extract(str(fmus[name]))
        try:
            lint = subprocess.run(["xmllint", "--noout", "--schema", str(schema),
                                   str(Path(folder) / "modelDescription.xml")], capture_output=True, text=True)
            assert lint.returncode == 0, lint.stderr
        finally:
            shutil.rmtree(folder, ignore_errors=True)


def test_binaries_rebuilt_from_the_sources_give_the_same_numbers(fmus, tmp_path):
    """An importer compiles sources/all.c (fmpy: CMake and the system compiler)."""
    from fmpy.build import build_platform_binary

    rng = np.random.default_rng(12)
    s = rng.uniform(-20.0, 120.0, 500)
    for name, port, output in (("sensor", "displacement", "measurement"), ("stage", "u", "y")):
        folder = tmp_path / name
        shutil.copytree(extract(str(fmus[name])), folder)
        shutil.rmtree(folder / "binaries")
        (tmp_path / f"cmake-{name}").mkdir()
        build_platform_binary(str(folder.resolve()), build_dir=str(tmp_path / f"cmake-{name}"))
        _same_bits(_drive(folder, {port: s}, output), _drive(fmus[name], {port: s}, output))


@pytest.mark.parametrize("name", ["amplifier", "controller", "sensor", "stage"])
def test_misuse_is_refused_with_fmi2error(fmus, name):
    from pysim.testing.fmus import RawFMU

    fmu = RawFMU(fmus[name])
    md = read_model_description(str(fmus[name]))
    first_input = next(v.name for v in md.modelVariables if v.causality == "input")
    output = next(v.name for v in md.modelVariables if v.causality == "output")
    parameter = next(v.name for v in md.modelVariables if v.causality == "parameter" and v.type == "Real")
    c = fmu.instantiate()
    assert fmu.do_step(c, 0.0, T) == 3                                  # before initialisation
    fmu.fmi2FreeInstance(c)
    c = fmu.initialised()
    assert fmu.set_real(c, {output: 1.0}) == 3                          # an output
    assert fmu.set_real(c, {parameter: 1.0}) == 3                       # a parameter after initialisation
    assert fmu.set_real(c, {first_input: float("nan")}) == 3            # not a number
    assert fmu.do_step(c, 0.0, 0.0) == 3 and fmu.do_step(c, 0.0, -T) == 3
    assert fmu.do_step(c, 1.0, T) == 3                                  # not the FMU's time
    assert fmu.set_real(c, {first_input: 1.0}) == 0 and fmu.do_step(c, 0.0, T) == 0
    assert len(fmu.errors()) >= 6
    fmu.fmi2FreeInstance(c)


@pytest.fixture(scope="module")
def windows_fmus(tmp_path_factory):
    parts = _parts()
    out = tmp_path_factory.mktemp("rig_fmus_win")
    return build_part_fmus([parts[k] for k in ("amplifier", "sensor", "stage")], out,
                           platforms=("linux64", "win64"))


@pytest.mark.parametrize("name", ["amplifier", "sensor", "stage"])
def test_windows_dll_under_wine_gives_the_linux_numbers_bit_for_bit(windows_fmus, tmp_path, name):
    """The C driver of the plant and inverse FMUs (tests/c/fmu_driver.c, vr 0
    in, vr 1 out, varying steps, state replays) on the Linux binary natively and
    on the Windows DLL under wine.  Its check that reading the output before and
    after a step agree does not apply: these outputs move over a step."""
    import subprocess

    import robustness

    from pysim.core.toolchain import zig_cc
    from pysim.fmu.compile import FLAGS, fmi_include_dir
    from pysim.testing.fmus import to_hex_lines

    driver = Path(__file__).resolve().parent / "c" / "fmu_driver.c"
    include = ["-I", str(fmi_include_dir())]
    warnings = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
    subprocess.run(["gcc"] + warnings + include + [str(driver), "-o", str(tmp_path / "drv"), "-ldl"], check=True)
    flags = [f for f in FLAGS if f != "-shared"] + ["-Wpedantic"]
    subprocess.run(zig_cc() + ["-target", "x86_64-windows-gnu"] + flags + include
                   + [str(driver), "-o", str(tmp_path / "drv.exe")], check=True, cwd=tmp_path)
    folder = Path(extract(str(windows_fmus[name])))
    guid = read_model_description(str(folder)).guid
    x = np.random.default_rng(13).uniform(-1.0, 11.0, 800) * (10.0 if name != "amplifier" else 1.0)
    (tmp_path / "in.txt").write_text(to_hex_lines(x))
    native = subprocess.run([str(tmp_path / "drv"), str(folder / "binaries" / "linux64" / f"{name}.so"), guid,
                             "in.txt"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    shutil.copy(folder / "binaries" / "win64" / f"{name}.dll", tmp_path)
    program, env = robustness.wine()
    emulated = subprocess.run([program, "drv.exe", f"{name}.dll", guid, "in.txt"], cwd=tmp_path, env=env,
                              capture_output=True, text=True, timeout=600)
    shutil.rmtree(folder, ignore_errors=True)
    lines = [native.stdout.splitlines(), emulated.stdout.replace("\r\n", "\n").splitlines()]
    values = [[x for x in out if not x.startswith("#")] for out in lines]
    checks = [[x for x in out if x.startswith("#")] for out in lines]
    assert len(values[0]) == x.size and values[0] == values[1]
    for found in checks:
        assert "# replay from deserialized state identical" in found
        assert "# replay from saved state identical" in found


@pytest.mark.parametrize("name", ["amplifier", "controller", "sensor", "stage", "lti_discrete", "gain"])
def test_sources_compile_without_warnings(tmp_path, name):
    """-Wall -Wextra -Wpedantic -Werror with gcc, clang and zig for every target."""
    import subprocess

    from pysim.core.toolchain import zig_cc
    from pysim.fmu.compile import PLATFORMS, fmi_include_dir
    from pysim.fmu.rig_parts import part_sources

    for path, data in part_sources(_parts()[name], "0").items():
        if path.startswith("sources/"):
            (tmp_path / path[len("sources/"):]).write_bytes(data)
    compilers = [["gcc"], ["clang"]] + [zig_cc() + ["-target", target] for p in PLATFORMS.values()
                                        for target in p.targets]
    for compiler in compilers:
        if not shutil.which(compiler[0]):
            continue
        result = subprocess.run(compiler + ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
                                            "-ffp-contract=off", "-I", str(tmp_path), "-I", str(fmi_include_dir()),
                                            "-c", str(tmp_path / "all.c"), "-o", str(tmp_path / "all.o")],
                                capture_output=True, text=True, cwd=tmp_path)
        assert result.returncode == 0 and not result.stderr.strip(), (compiler, result.stderr)
