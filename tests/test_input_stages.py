"""Tests of the input stages: the slew limit's recursion in C (pysim.core.input_stage, against the
independent generator's own loop) and pysim.diagnosis.input_stages, what a stage shows where it moves
the input."""
import numpy as np
import pytest

from independent_records import rate_limit

from pysim.core.input_stage import slew_limit
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
