"""The sixth record generator (``sixth_generator_records.py``), checked against definitions.

Its operators equal the paper's sample recursion written elsewhere (a second implementation), its
plants increase along every branch, its effects are what their names say (a delay is a shift, creep
follows a step on a logarithmic curve, a drift depends on time alone), and its records keep the input
in the actuator's range.  What the diagnosis makes of its records is measured by
``benchmarks/bench_diagnosis_sixth_generator.py``, not asserted here.
"""
import numpy as np
import pytest

import sixth_generator_records as sixth
from independent_records import osp_recursion


def _plant(seed):
    return sixth.Actuator(seed).plant


@pytest.mark.parametrize("seed", [0, 3, 7])
def test_operators_equal_the_sample_recursion(seed):
    plant = _plant(seed)
    rng = np.random.default_rng(seed + 100)
    v = np.clip(np.abs(np.cumsum(rng.standard_normal(3000))) * 3.0, 0.0, sixth.FULL_SCALE_V)
    plant.rest()
    y = plant.hysteresis_um(v)
    u = v / sixth.FULL_SCALE_V
    expected = plant.a1 * u ** 3 + plant.a2 * u + osp_recursion(u, plant.r) @ plant.b
    np.testing.assert_allclose(y, expected * plant.span_um / (plant.a1 + plant.a2 + plant.b.sum()), rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_plants_increase_along_every_branch_and_span_their_range(seed):
    plant = _plant(seed)
    levels = np.array([0.0, 1.0, 0.0, 0.7, 0.1, 1.0, 0.5, 0.0]) * sixth.FULL_SCALE_V
    v = np.concatenate([np.zeros(1)] + [np.linspace(a, z, 801)[1:] for a, z in zip(levels[:-1], levels[1:])])
    plant.rest()
    y = plant.hysteresis_um(v)
    assert np.min(np.diff(y) / np.diff(v)) > 0
    # from rest, operator i reaches 1 - r_i at full scale (the OSP recursion from w = 0)
    top = plant.a1 + plant.a2 + np.sum(plant.b * (1.0 - plant.r))
    assert y[800] == pytest.approx(top * plant.span_um / (plant.a1 + plant.a2 + plant.b.sum()), rel=1e-12)


def test_a_delay_is_a_shift_and_none_changes_nothing():
    h = np.sin(np.linspace(0, 20, 500))
    shifted = sixth.apply_effect("delay", {"samples": 3}, h, 2000.0)
    np.testing.assert_array_equal(shifted[3:], h[:-3])
    np.testing.assert_array_equal(sixth.apply_effect("none", {}, h, 2000.0), h)


def test_creep_follows_a_step_on_a_logarithmic_curve():
    fs, gamma, t0 = 2000.0, 0.03, 0.05
    h = np.concatenate([np.zeros(10), np.ones(20000)])
    y = sixth.apply_effect("creep", {"gamma": gamma, "t0_s": t0}, h, fs)
    t = np.arange(20000) / fs
    np.testing.assert_allclose(y[10:], 1.0 + gamma * np.log10(1.0 + t / t0), rtol=0, atol=1e-9)
    assert np.all(np.diff(y[10:]) >= 0)


def test_drift_depends_on_time_alone():
    parameters = {"amplitude_of_span": 0.02, "time_constant_s": 5.0, "slope_of_span_per_s": 1e-4}
    t = np.arange(4000) / 2000.0
    a, b = np.sin(7 * t), np.cos(3 * t)       # same span (2) and length
    a[0], b[0] = -1.0, 1.0
    a[1], b[1] = 1.0, -1.0
    extra_a = sixth.apply_effect("drift", parameters, a, 2000.0) - a
    extra_b = sixth.apply_effect("drift", parameters, b, 2000.0) - b
    np.testing.assert_allclose(extra_a, extra_b, rtol=0, atol=1e-12)
    np.testing.assert_allclose(extra_a, 2.0 * (0.02 * (1 - np.exp(-t / 5.0)) + 1e-4 * t), rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", [1, 4, 9])
def test_records_stay_in_range_and_carry_their_effect(seed):
    actuator, records = sixth.make_actuator(seed)
    assert sorted(r["input"] for r in records) == ["multisine", "steps_sines", "triangle"]
    for r in records:
        assert r["voltage_V"].min() >= 0.0 and r["voltage_V"].max() <= sixth.FULL_SCALE_V + 1e-9
        assert r["displacement_um"].shape == r["voltage_V"].shape
        assert (r["effect_sigma"] > 0) == (actuator.effect != "none")
    triangle = next(r for r in records if r["input"] == "triangle")
    assert triangle["start"] == "rest" and triangle["voltage_V"][0] == 0.0
