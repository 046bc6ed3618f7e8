"""Tests of the input stages: the slew limit's recursion in C (pysim.core.input_stage, against the
independent generator's own loop), thresholds that grow with the input's rate (against a loop written
here, and identified back), and pysim.diagnosis.input_stages, what a stage shows where it moves the
input."""
import numpy as np
import pytest

from independent_records import rate_limit

from pysim.core.input_stage import InputStageModel, rate_threshold_scale, slew_limit
from pysim.core.model import HysteresisModel, eq13_thresholds
from pysim.identification.identify import identify
from pysim.diagnosis.input_stages import MOVED_SETTLE_SAMPLES, explained_where_moved


def _backlash_um(voltage_V, width_V=4.0, gain_um_per_V=0.5):
    """A rate-independent actuator written here: one play operator (backlash) with a gain."""
    out, w = np.empty(len(voltage_V)), float(voltage_V[0])
    for k, v in enumerate(voltage_V):
        w = min(max(w, v - width_V), v + width_V)
        out[k] = gain_um_per_V * w
    return out


def _steps(sample_period_s=1e-4):
    levels = [0.0, 90.0, 20.0, 70.0, 10.0]
    return np.repeat(levels, 200), sample_period_s


def test_a_true_slew_limit_explains_what_the_stage_moves():
    v, T = _steps()
    x = slew_limit(v, 200e3, T)                      # 200 V/ms: each step ramps over a few samples
    y = _backlash_um(x)                              # the actuator behind the limit, noise-free
    without, with_stage, samples = explained_where_moved(v, x, y, _backlash_um(v), _backlash_um(x))
    moved = np.count_nonzero(np.abs(x - v) > 0)
    assert moved <= samples <= moved * (MOVED_SETTLE_SAMPLES + 1)
    assert without > 0 and with_stage == 0.0


def test_a_stage_where_the_actuator_has_none_explains_nothing():
    v, T = _steps()
    x = slew_limit(v, 200e3, T)
    y = _backlash_um(v)                              # no limit on the rig: the raw voltage drives it
    without, with_stage, _ = explained_where_moved(v, x, y, _backlash_um(v), _backlash_um(x))
    assert without == 0.0 and with_stage > 0


def test_nothing_moved_counts_nothing():
    v, _ = _steps()
    assert explained_where_moved(v, v, _backlash_um(v), _backlash_um(v), _backlash_um(v)) == (0.0, 0.0, 0)


def test_the_samples_after_a_move_are_clipped_at_the_record_end():
    v = np.array([0.0, 0.0, 0.0, 10.0])
    x = np.array([0.0, 0.0, 0.0, 5.0])
    without, with_stage, samples = explained_where_moved(v, x, x, v, x)
    assert samples == 1 and (without, with_stage) == (25.0, 0.0)


@pytest.mark.parametrize("seed", range(4))
def test_the_slew_limit_in_c_follows_the_generators_own_loop(seed):
    """The C recursion against a second implementation (the independent generator's Python loop):
    random walks and quantised staircases, rates from a tenth of a volt to kilovolts per sample."""
    rng = np.random.default_rng(seed)
    for _ in range(25):
        n = int(rng.integers(2, 3000))
        v = np.cumsum(rng.normal(0.0, rng.uniform(0.01, 30.0), n)) + rng.uniform(-100.0, 100.0)
        if rng.random() < 0.5:
            v = np.round(v / 5.0) * 5.0
        rate_V_per_s, period_s = rng.uniform(10.0, 1e6), 1.0 / rng.choice([1e3, 2e3, 1e4])
        ours = slew_limit(v, rate_V_per_s, period_s)
        np.testing.assert_allclose(ours, rate_limit(v, period_s, rate_V_per_s), rtol=0.0, atol=1e-9)
        assert ours[0] == v[0] and np.max(np.abs(np.diff(ours))) <= rate_V_per_s * period_s * (1 + 1e-12)
    assert slew_limit([], 1.0, 1.0).size == 0 and slew_limit([3.0], 1.0, 1.0).tolist() == [3.0]


def _rate_threshold_loop_um(model, voltage_V, growth_s_per_V, period_s):
    """A one-sided play model whose thresholds are ``r_i (1 + γ |v̇|)``, written here sample by sample
    (the rate a backward difference, 0 at the first sample; the operators demagnetised)."""
    u = np.asarray(voltage_V, dtype=float) - model.input_offset_V
    r, b = np.asarray(model.thresholds_V), np.asarray(model.weights_um_per_V)
    w, out, previous = np.zeros(r.size), np.empty(u.size), u[0]
    for k, uk in enumerate(u):
        widened = r * (1.0 + growth_s_per_V * abs(uk - previous) / period_s)
        w = np.maximum(uk - widened, np.minimum(uk, w))
        out[k] = model.a1 * uk**3 + model.a2 * uk + b @ w + model.output_offset_um
        previous = uk
    return out


@pytest.mark.parametrize("seed", range(3))
def test_thresholds_that_grow_with_the_rate_follow_a_loop_written_here(seed):
    rng = np.random.default_rng(seed)
    n_operators = int(rng.integers(3, 12))
    model = HysteresisModel(a1=float(rng.uniform(0, 1e-5)), a2=float(rng.uniform(0.05, 0.2)),
                            thresholds_V=tuple(eq13_thresholds(n_operators, 100.0)),
                            weights_um_per_V=tuple(rng.uniform(0.0, 0.1, n_operators)),
                            input_offset_V=float(rng.uniform(-5, 5)), output_offset_um=float(rng.normal()),
                            voltage_range_V=(-10.0, 110.0))
    period_s = 1.0 / float(rng.choice([1e3, 1e4]))
    v = np.clip(np.cumsum(rng.normal(0.0, rng.uniform(0.5, 10.0), 4000)) + 50.0, -10.0, 110.0)
    growth = float(rng.uniform(1e-6, 1e-3))
    staged = InputStageModel(model, "rate_thresholds", growth, period_s)
    np.testing.assert_allclose(staged.simulate(v), _rate_threshold_loop_um(model, v, growth, period_s),
                               rtol=0.0, atol=1e-9)
    # a factor of one everywhere leaves every bit of the rate-independent model
    assert np.array_equal(model.simulate(v, threshold_scale=np.ones(v.size)), model.simulate(v))
    assert np.array_equal(rate_threshold_scale(v, 0.0, period_s), np.ones(v.size))


def test_thresholds_that_grow_with_the_rate_are_identified_back():
    """A record of such an actuator (noise-free, a multisine from rest) fitted with the true growth
    gives back its weights; fitted without it, the plain fit leaves an error the growth explains."""
    period_s = 1e-4
    t = np.arange(20000) * period_s
    v = 50.0 + 20.0 * np.sin(2 * np.pi * 7 * t) + 18.0 * np.sin(2 * np.pi * 31 * t + 1.0) \
        + 10.0 * np.sin(2 * np.pi * 2 * t + 0.3)
    v[0] = v[1] = 50.0
    r = eq13_thresholds(6, float(np.ptp(v)))
    truth = HysteresisModel(a1=0.0, a2=0.12, thresholds_V=tuple(r), weights_um_per_V=(0.0, 0.06, 0.05, 0.04, 0.03,
                                                                                        0.02),
                            input_offset_V=float(v.min()), voltage_range_V=(float(v.min()), float(v.max())))
    growth = 2e-5                                          # +2 % per V/ms; the record reaches about 5 V/ms
    y = _rate_threshold_loop_um(truth, v, growth, period_s)
    fit = identify(v, y, n_operators=6, model="cpi", thresholds_V=r, input_offset_V=truth.input_offset_V,
                   initial_state=np.zeros(r.size), threshold_scale=rate_threshold_scale(v, growth, period_s))
    np.testing.assert_allclose(fit.model.weights_um_per_V[1:], truth.weights_um_per_V[1:], rtol=1e-6)
    assert fit.errors["rms_error_pct"] < 1e-6
    plain = identify(v, y, n_operators=6, model="cpi", thresholds_V=r, input_offset_V=truth.input_offset_V,
                     initial_state=np.zeros(r.size))
    assert plain.errors["rms_error_pct"] > 0.1
