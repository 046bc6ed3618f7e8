"""The rig parts (pysim.core.rig) against their defining physics."""
import math

import numpy as np
import pytest

from pysim.core.errors import ModelError
from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise, XorShiftNormal


def test_converter_codes_range_and_rounding():
    dac = Converter(16, 0.0, 10.0)
    assert dac.lsb == pytest.approx(10.0 / 65535, rel=1e-15)
    codes = np.arange(0, 65536, 997)
    for code in codes:                                  # every code is reproduced exactly
        value = code * dac.lsb
        assert dac.convert(value) == pytest.approx(value, abs=1e-12)
    assert dac.convert(-3.0) == 0.0 and dac.convert(12.0) == pytest.approx(10.0)
    # the error of a converted value is at most half a step
    x = np.random.default_rng(1).uniform(0, 10, 2000)
    assert np.max(np.abs([dac.convert(v) - v for v in x])) <= dac.lsb / 2 + 1e-15
    # ties to even, as Python's round and C's nearbyint
    assert Converter(2, 0.0, 3.0).convert(0.5) == 0.0 and Converter(2, 0.0, 3.0).convert(1.5) == 2.0
    assert Converter(0, -1.0, 1.0).convert(0.123456789) == 0.123456789      # ideal: no steps
    with pytest.raises(ModelError, match="low < high"):
        Converter(16, 1.0, 1.0)
    with pytest.raises(ModelError, match="bits"):
        Converter(40, 0.0, 1.0)


def test_amplifier_small_signal_is_a_first_order_lag():
    """A small step (no slew limit reached) follows 1 - exp(-2π f t) exactly at the samples."""
    amp = Amplifier(gain_V_per_V=15.0, bandwidth_hz=1000.0, current_limit_A=10.0, capacitance_F=3.6e-6)
    T = 1e-5
    out, _ = amp.run(np.full(400, 0.1), T, state_V=0.0)
    t = np.arange(400) * T
    assert np.allclose(out, 1.5 * (1.0 - np.exp(-2 * math.pi * 1000.0 * t)), rtol=0, atol=1e-12)


def test_amplifier_slew_limit_is_current_over_capacitance():
    amp = Amplifier(gain_V_per_V=15.0, bandwidth_hz=math.inf, current_limit_A=0.3, capacitance_F=3.6e-6)
    T = 1e-5
    out, _ = amp.run(np.full(200, 10.0), T, state_V=0.0)
    rate = np.diff(out[:100]) / T
    assert amp.slew_rate_V_per_s == pytest.approx(0.3 / 3.6e-6)
    assert np.allclose(rate, amp.slew_rate_V_per_s, rtol=1e-9)        # ramps at I/C until it arrives
    assert out[-1] == pytest.approx(150.0)                                # then holds the output
    assert np.max(out) <= 150.0 and np.min(Amplifier().run(np.full(5, -1.0), T, 0.0)[0]) >= 0.0


def test_pi_controller_integrates_and_does_not_wind_up():
    pi = PIController(kp_V_per_um=0.1, ki_V_per_um_s=1000.0, output_low_V=0.0, output_high_V=150.0)
    T = 1e-4
    out, i = pi.step(0.0, 2.0, 10.0, T)
    assert out == pytest.approx(10.0 + 0.2) and i == pytest.approx(0.2)
    # saturated high with the error still pushing up: the integrator holds
    i = 200.0
    out, i_next = pi.step(i, 5.0, 0.0, T)
    assert out == 150.0 and i_next == i
    # saturated high but the error now pulls down: it integrates at once
    out, i_next = pi.step(i, -5.0, 0.0, T)
    assert i_next < i
    assert not PIController().active and PIController(0.0, 1.0).active


def test_xorshift_normal_is_reproducible_and_standard():
    a, b = XorShiftNormal(2014), XorShiftNormal(2014)
    x = np.array([a.next() for _ in range(50000)])
    assert np.array_equal(x[:100], [b.next() for _ in range(100)])
    assert abs(x.mean()) < 0.02 and abs(x.std() - 1.0) < 0.02
    assert abs(np.mean(x ** 3)) < 0.05 and abs(np.mean(x ** 4) - 3.0) < 0.1        # normal, not uniform
    assert abs(np.corrcoef(x[:-1], x[1:])[0, 1]) < 0.02                             # white
    assert SensorNoise(0.01, seed=3).generator().next() == XorShiftNormal(3).next()
