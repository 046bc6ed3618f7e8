"""The general rate-independent model on two records (pysim.diagnosis.preisach), judged on a
Preisach actuator of relays (tests/independent_records.py: a second implementation, no play
operators) and on effects applied on a grid finer than the samples."""
import numpy as np
import pytest
import scipy.signal

from independent_records import preisach_relays
from pysim.diagnosis.preisach import (NOISE_FRACTION, effects_on_both_records, fit_both_records,
                                      general_thresholds, preisach_columns, verdict_on_both_records)

RATE_HZ = 2000.0
FINE = 8
LO, HI = 0.0, 120.0
SPAN_UM = 20.0
NOISE_UM = 0.002 * SPAN_UM


def _triangles(rng, n):
    turns = np.r_[LO, np.sort(rng.uniform(LO, HI, 9))[::-1] * np.tile([1.0, 0.3], 5)[:9] + LO]
    turns = np.r_[HI, LO, turns, HI, LO + 0.5 * (HI - LO)]
    return np.interp(np.linspace(0, turns.size - 1, n), np.arange(turns.size), turns)


def _multisine(rng, n):
    t = np.arange(n) / RATE_HZ
    s = sum(np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi)) / f for f in (0.7, 1.9, 4.3, 9.1))
    s = (s - s.min()) / np.ptp(s)
    return LO + (HI - LO) * (0.02 + 0.96 * s)


def _actuator(v, lag_s=0.0, history=None):
    """Relays (continuous switching) plus a reversible part, run on a grid FINE times finer than the
    samples; an optional lag after it; ``history`` turning points played before the record."""
    before = [] if history is None else [np.linspace(a, b, 40) for a, b in zip(history[:-1], history[1:])]
    full = np.concatenate(before + [np.linspace(LO if history is None else history[-1], v[0], 40), v])
    fine = np.interp(np.arange(full.size * FINE) / FINE, np.arange(full.size), full)
    h = SPAN_UM * (0.6 * (preisach_relays(fine, LO, HI, 30, 0.7, 0.35, 1.0 / 30) + 1) / 2 + 0.4 * (fine - LO) / (HI - LO))
    if lag_s:
        a = np.exp(-1.0 / (lag_s * RATE_HZ * FINE))
        h = scipy.signal.lfilter([1 - a], [1, -a], h, zi=[a * h[0]])[0]
    return h[::FINE][full.size - v.size:]


@pytest.fixture(scope="module")
def inputs():
    rng = np.random.default_rng(11)
    return _triangles(rng, 8000), _multisine(rng, 8000)


def _noisy(y, seed):
    return y + np.random.default_rng(seed).normal(0.0, NOISE_UM, y.size)


def test_a_preisach_actuator_without_effect_is_fitted_to_its_noise_on_two_inputs_and_nothing_is_named(inputs):
    v1, v2 = inputs
    fits = effects_on_both_records(v1, _noisy(_actuator(v1), 1), 1 / RATE_HZ, v2, _noisy(_actuator(v2), 2),
                                   1 / RATE_HZ)
    assert max(fits["none"].mse_sigma2) < 1.0 + NOISE_FRACTION
    assert fits["none"].noise_um == pytest.approx((NOISE_UM, NOISE_UM), rel=0.1)
    assert verdict_on_both_records(fits)["cause"] == "none"


def test_a_lag_after_a_preisach_hysteresis_is_named_with_its_time_constant(inputs):
    v1, v2 = inputs
    lag_s = 5e-3
    fits = effects_on_both_records(v1, _noisy(_actuator(v1, lag_s), 3), 1 / RATE_HZ,
                                   v2, _noisy(_actuator(v2, lag_s), 4), 1 / RATE_HZ)
    said = verdict_on_both_records(fits)
    assert "rate_dependence" in said["causes"]
    assert fits["none"].excess_sigma2 > 1.0
    assert fits["rate_dependence"].parameter == pytest.approx(lag_s, rel=0.25)
    assert max(fits["rate_dependence"].mse_sigma2) < 1.0 + NOISE_FRACTION


def test_an_unknown_history_is_left_out_not_guessed(inputs):
    v2, v1 = inputs             # the multisine first: it starts inside the range, where the history shows
    history = [LO, 0.9 * HI, 0.2 * HI, 0.7 * HI, 0.4 * HI]
    y1 = _noisy(_actuator(v1, history=history), 5)
    assert not np.allclose(y1[:50], _noisy(_actuator(v1), 5)[:50], atol=10 * NOISE_UM)   # the history shows
    fit = fit_both_records(v1, y1, 1 / RATE_HZ, v2, _noisy(_actuator(v2), 6), 1 / RATE_HZ)
    _, first = preisach_columns(v1, general_thresholds([v1, v2]), (LO, HI))
    assert 0 < first <= 0.4 * v1.size
    assert fit.samples[0] == v1.size - first
    assert max(fit.mse_sigma2) < 1.0 + NOISE_FRACTION


def test_the_second_records_sensor_gain_and_offset_are_refitted(inputs):
    v1, v2 = inputs
    fit = fit_both_records(v1, _noisy(_actuator(v1), 7), 1 / RATE_HZ,
                           v2, 1.036 * _noisy(_actuator(v2), 8) - 0.9, 1 / RATE_HZ)
    assert fit.second_gain == pytest.approx(1.036, abs=0.003)
    assert fit.second_offset_um == pytest.approx(-0.9, abs=0.05)
    assert max(fit.mse_sigma2) < 1.0 + NOISE_FRACTION
