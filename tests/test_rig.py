"""The rig co-simulation (pysim.cosim.rig) against independent truths: the
python-control closed loop for a linear rig, the amplifier's slew limit, and
the order of the configurations on a rig with model mismatch."""
import math

import control
import numpy as np
import pytest
import scipy.optimize

from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise
from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import plant_fmu_for_model
from pysim.cosim.rig import (PATHS, Rig, RigSimulation, linear_loop, load_rig, rig_stepped_sine,
                             sweep_frequencies)
from pysim.specs.flexure_stage import STAGE
from pysim.testing.fmus import LINEAR_MODEL

T = 5e-5
IDEAL = dict(amplifier=Amplifier(15.0, math.inf, math.inf, 3.6e-6, -1e6, 1e6),
             dac=Converter(0, -1e6, 1e6), adc=Converter(0, -1e6, 1e6), noise=SensorNoise(0.0))
PI = PIController(kp_V_per_um=0.05, ki_V_per_um_s=600.0, output_low_V=-1e6, output_high_V=1e6)


@pytest.fixture(scope="module")
def linear_rig_sim():
    """Hysteresis and every amplifier and converter limit switched off."""
    rig = Rig(LINEAR_MODEL, STAGE, controller=PI, step_s=T, **IDEAL)
    with RigSimulation(rig, plant_fmu_for_model(LINEAR_MODEL)) as sim:
        yield sim


def test_linear_closed_loop_equals_python_control(linear_rig_sim):
    """Feedback path of a linear rig = control.feedback of its loop, sample for
    sample (the reference reaches the loop one step late; row k is t_{k+1})."""
    sim = linear_rig_sim
    k = np.arange(6000)
    reference = 20.0 + 10.0 * (k > 50) + 3.0 * np.sin(2 * math.pi * 40.0 * k * T)
    result = sim.run_path(reference, "feedback")
    closed = linear_loop(sim.rig, 0.5)
    seen = np.concatenate([[0.0], reference[:-1]])               # C_ref: one step late
    expected = control.forced_response(closed, T=np.arange(k.size) * T, U=seen).outputs
    harness = result.displacement_stage_um[:-1]                  # rows 0 .. N-2 hold S_1 .. S_{N-1}
    assert np.max(np.abs(harness - expected[1:])) <= 1e-6 * np.max(np.abs(expected))


def test_linear_closed_loop_bandwidth_equals_control_bandwidth(linear_rig_sim):
    sim = linear_rig_sim
    f, _ = sweep_frequencies(T, 5.0, 400.0, 60)
    result = rig_stepped_sine(sim, 2.0, 20.0, "feedback", f, settle_tol=1e-6)
    closed = linear_loop(sim.rig, 0.5)

    def gain(frequency_hz):
        return float(np.abs(np.asarray(control.frequency_response(closed, [2 * math.pi * frequency_hz]).complex)).ravel()[0])

    # the gain against the desired sine is |T(e^jωT)| at every frequency
    assert np.max(np.abs(result.gain - [gain(x) for x in f])) <= 1e-6
    # the -3 dB point of the discrete closed loop, bracketed on python-control's
    # frequency response (control.bandwidth evaluates a discrete system at z = jω,
    # not on the unit circle, so it cannot be used for it)
    grid = np.geomspace(1.0, 0.45 / T, 4000)
    below = np.flatnonzero(np.array([gain(x) for x in grid]) < 10 ** (-3 / 20))[0]
    expected_hz = scipy.optimize.brentq(lambda x: gain(x) - 10 ** (-3 / 20), grid[below - 1], grid[below])
    assert result.bandwidth_vs_desired_hz() == pytest.approx(expected_hz, rel=0.01)


def test_slew_limit_lowers_the_bandwidth_of_large_signals_only():
    """A current-limited amplifier: 83 V/ms cannot follow a 60 V sine above
    about 220 Hz, but follows a 4 V one up to the stage."""
    amp = Amplifier(15.0, 10e3, 0.3, 3.6e-6, 0.0, 150.0)
    rig = Rig(LINEAR_MODEL, None, amp, Converter(0, 0, 10), Converter(0, -10, 110), SensorNoise(0.0),
              PIController(), T)
    with RigSimulation(rig, plant_fmu_for_model(LINEAR_MODEL)) as sim:
        f, _ = sweep_frequencies(T, 50.0, 2000.0, 25)
        small = rig_stepped_sine(sim, 2.0, 37.5, "uncompensated", f)
        large = rig_stepped_sine(sim, 30.0, 37.5, "uncompensated", f)
    limit_hz = amp.slew_rate_V_per_s / (2 * math.pi * 60.0)        # 60 V amplitude at 0.5 µm/V
    assert np.all(small.normalised > 0.9)                           # no stage, no slew limit
    assert large.bandwidth_hz() == pytest.approx(limit_hz * 1.7, rel=0.35)
    assert large.normalised[f < 0.8 * limit_hz].min() > 0.97


def test_paths_order_on_a_mismatched_rig():
    """The plant is not the compensator's model: open loop compensation leaves
    the mismatch, feedback removes most of it."""
    from pysim.core import ExtendedModel, StageSpec
    from pysim.cosim.harness import fmus_for_model
    from pysim.specs.default_mpi import MODEL

    truth = ExtendedModel(MODEL.with_parameters(weights_um_per_V=tuple(1.1 * np.asarray(MODEL.weights_um_per_V)),
                                                a2=0.95 * MODEL.a2, name="mismatched"),
                          StageSpec(sample_period_s=T, creep_time_constants_s=(0.1,), creep_weights_um_per_V=(0.01,)))
    rig = Rig(truth, STAGE, Amplifier(15.0, 10e3, 0.3), Converter(16, 0, 10), Converter(16, -10, 110),
              SensorNoise(0.01), PIController(0.05, 600.0), T)
    _, inverse = fmus_for_model(MODEL)
    from pysim.cosim.harness import NominalDrive

    with RigSimulation(rig, plant_fmu_for_model(truth), inverse, NominalDrive.from_model(MODEL)) as sim:
        k = np.arange(40001)
        reference = 37.5 + 15.0 * np.sin(2 * math.pi * k * T)
        last = slice(20000, None)
        errors = {}
        for path in PATHS:
            r = sim.run_path(reference, path)
            errors[path] = np.sqrt(np.mean((r.displacement_stage_um[last] - r.reference_um[last]) ** 2))
    assert errors["compensated"] < errors["uncompensated"] / 3
    assert errors["compensated"] > 0.01 * 30                        # the mismatch is visible (> 1 % of range)
    assert errors["feedback+compensated"] < errors["compensated"] / 5
    assert errors["feedback+compensated"] < errors["feedback"]


def test_bad_rigs_and_paths_are_refused(linear_rig_sim):
    with pytest.raises(CoSimulationError, match="path must be one of"):
        linear_rig_sim.run_path([1.0, 2.0], "sideways")
    with pytest.raises(CoSimulationError, match="needs an inverse FMU"):
        linear_rig_sim.run_path([1.0, 2.0], "compensated")
    with pytest.raises(CoSimulationError, match="finite"):
        linear_rig_sim.run_path([1.0, math.nan], "feedback")
    with pytest.raises(CoSimulationError, match="step_s"):
        Rig(LINEAR_MODEL, step_s=0.0)
    with pytest.raises(CoSimulationError, match="no RIG"):
        load_rig("flexure_stage")
    assert load_rig("rig_default").name == "rig_default"


def test_the_default_rig_loop_is_stable_with_margin():
    """The default rig's PI gains: stable at the nominal gain with gain margin
    above 6 dB against the stage's resonance and the loop latency."""
    rig = load_rig("rig_default")
    z = control.tf([1.0, 0.0], [1.0], rig.step_s)
    pi = rig.controller
    loop = (pi.kp_V_per_um + pi.ki_V_per_um_s * rig.step_s / (z - 1)) / z ** 4 * 0.5 * control.tf(
        control.sample_system(rig.stage, rig.step_s, "zoh"))
    # evaluated on the frequency response (the polynomial route is ill-conditioned for this order)
    gain_margin, _, _, _, _, _ = control.stability_margins(loop, method="frd")
    assert 20 * math.log10(gain_margin) > 6.0
    assert np.max(np.abs(control.poles(linear_loop(rig, 0.5)))) < 1.0


def test_record_study_predicts_the_shipped_actuator():
    """The compensator of discrete_backlash against the extended plant its
    diagnosis builds, at the record's 200 Hz: feedforward with feedback beats
    either alone, and the loop the study tunes is stable."""
    from pysim.studies.record_study import record_study

    r = record_study("discrete_backlash")
    e = {path: value["rms_error_pct"] for path, value in r["tracking"].items()}
    assert e["feedback+compensated"] < min(e["compensated"], e["feedback"])
    assert r["rig"].step_s == pytest.approx(1 / 200.0)
    assert np.max(np.abs(control.poles(linear_loop(r["rig"], r["compensator"].major_loop_gain())))) < 1.0
