"""Stepped-sine measurement: the projection, the crossing, and sweeps through real FMUs
(hysteresis switched off: the stage's own frequency response must come out)."""
import math

import control
import numpy as np
import pytest
from pysim.specs.default_mpi import MODEL
from pysim.specs.flexure_stage import STAGE

from pysim.cosim.bandwidth import (
    crossing_frequency,
    default_frequencies,
    fundamental,
    measure_bandwidth,
    settling_periods,
    stepped_sine,
    summary,
)
from pysim.cosim.harness import CoSimulation, NominalDrive

pytest_plugins = ["fmu_fixtures"]  # the FMUs, built once


def test_fundamental_is_exact_for_a_sine_with_offset_and_harmonics(rng):
    n, periods = 64, 3
    phase = 2 * math.pi * np.arange(n * periods) / n
    for _ in range(20):
        amplitude, theta = rng.uniform(0.1, 50), rng.uniform(-math.pi, math.pi)
        y = 37.5 + amplitude * np.sin(phase + theta)
        for k in range(2, n - 1):  # every harmonic that does not fold onto the fundamental
            y += rng.uniform(-5, 5) * np.sin(k * phase + rng.uniform(0, 2 * math.pi))
        c = fundamental(y, n)
        assert abs(c) == pytest.approx(amplitude, abs=1e-12 * 50)
        assert math.remainder(np.angle(c) - theta, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)


def test_fundamental_refuses_partial_periods():
    with pytest.raises(ValueError, match="whole number of periods"):
        fundamental(np.zeros(100), 64)
    with pytest.raises(ValueError, match="at least 3"):
        fundamental(np.zeros(4), 2)


def test_crossing_is_exact_where_the_magnitude_is_linear_in_log_frequency():
    # -20 dB/decade above 100 Hz: -3 dB at 100 * 10^(3/20) Hz, between grid points
    f = np.geomspace(10, 10000, 31)
    magnitude = np.where(f <= 100, 1.0, 100 / f)
    assert crossing_frequency(f, magnitude) == pytest.approx(100 * 10 ** (3 / 20), rel=1e-12)
    assert math.isnan(crossing_frequency(f, np.ones_like(f)))            # never crossed
    assert math.isnan(crossing_frequency(f, np.full_like(f, 0.5)))       # starts below


def test_settling_periods_cover_the_transient():
    tau = 1 / (0.1 * 2 * math.pi * 600)
    for f in (10.0, 300.0, 2000.0):
        p = settling_periods(f, tau, 1e-6)
        assert (p - 1) / f >= tau * math.log(1e6) > (p - 2) / f
    with pytest.raises(ValueError, match="never settles"):
        settling_periods(10.0, math.inf, 1e-6)
    assert len(default_frequencies()) >= 30


@pytest.fixture(scope="module")
def linear_results(linear_fmus, linear_model):
    plant, inverse = linear_fmus
    f = default_frequencies(10.0, 2000.0, 36)
    with CoSimulation(plant, inverse, stage=STAGE) as sim:
        drive = NominalDrive.from_model(linear_model)
        return measure_bandwidth(sim, drive, amplitudes_um=(20.0,), offset_um=37.5, frequencies_hz=f)


def test_linear_plant_sweep_measures_the_stage_frequency_response(linear_results):
    for result in linear_results:
        f = result.frequencies_hz
        g = np.abs(STAGE(2j * np.pi * f))
        np.testing.assert_allclose(result.gain, g, rtol=5e-3)                  # the requirement
        np.testing.assert_allclose(result.normalised, g / g[0], rtol=5e-3)
        np.testing.assert_allclose(result.gain, g, rtol=1e-5)                  # what the method gives
        np.testing.assert_allclose(np.angle(result.response), np.angle(STAGE(2j * np.pi * f)), atol=1e-5)


def test_linear_plant_bandwidth_matches_control_bandwidth(linear_results):
    expected = control.bandwidth(STAGE) / (2 * math.pi)
    for result in linear_results:
        assert result.bandwidth_hz() == pytest.approx(expected, rel=0.01)
    out = summary(linear_results, STAGE)
    assert out["stage_bandwidth_hz"] == pytest.approx(expected, rel=1e-12)
    assert set(out["bandwidth_hz"]) == {"uncompensated", "compensated"}


def test_rate_independent_hysteresis_leaves_the_normalised_response_to_the_stage(default_fmus):
    """Both paths, with hysteresis: normalised, the response is the stage's (the
    fundamental of a rate-independent plant does not depend on frequency)."""
    plant, inverse = default_fmus
    f = default_frequencies(10.0, 2000.0, 30)
    g = np.abs(STAGE(2j * np.pi * f))
    with CoSimulation(plant, inverse, stage=STAGE) as sim:
        drive = NominalDrive.from_model(MODEL)
        results = measure_bandwidth(sim, drive, amplitudes_um=(7.5, 30.0), offset_um=37.5, frequencies_hz=f)
    for r in results:
        np.testing.assert_allclose(r.normalised, g / g[0], rtol=1e-4)
        # the actuator's fundamental is the same at every frequency
        np.testing.assert_allclose(r.actuator_gain, r.actuator_gain[0], rtol=1e-12)
        if r.path == "compensated":
            np.testing.assert_allclose(r.actuator_gain, 1.0, rtol=1e-9)   # exact inverse
        else:
            assert r.actuator_gain[0] < 0.95                              # hysteresis flattens small loops
    with pytest.raises(ValueError, match="inverse FMU"):
        with CoSimulation(plant, stage=STAGE) as sim:
            stepped_sine(sim, f, 10.0, 37.5, "compensated")
