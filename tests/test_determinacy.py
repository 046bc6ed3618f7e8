"""How well a record determines a model's prediction of a new input: the spread of the prediction
of a full-range cycle, against a Monte-Carlo of refits and against what fits on a staircase predict."""
import numpy as np
import pytest

from pysim.core.model import HysteresisModel
from pysim.identification.determinacy import DETERMINED_SPREAD, cycle_prediction_spread, decided_weights, probe_cycle
from pysim.identification.identify import identify

TRUTH = HysteresisModel(a1=-2e-6, a2=0.25, thresholds_V=(0.0, 30.0, 60.0, 90.0, 120.0),
                        weights_um_per_V=(0.0, 0.06, 0.05, 0.04, 0.03), voltage_range_V=(0.0, 150.0))


def decaying_cycles(n=3000):
    t = np.linspace(0.0, 1.0, n)
    return 75.0 - 75.0 * np.cos(2 * np.pi * 5 * t) * np.where(t < 0.2, 1.0, np.exp(-1.5 * (t - 0.2)))


def staircase(step_V=13.0, hold=600):
    up = np.arange(0.0, 150.0, step_V)
    levels = np.concatenate([up, up[::-1]])
    return np.repeat(levels, hold)


def test_probe_cycle_spans_the_range_with_minor_loops():
    v = probe_cycle(-20.0, 120.0, 1000)
    assert v.min() == pytest.approx(-20.0) and v.max() == pytest.approx(120.0)
    second_half = v[500:]
    reversals = np.count_nonzero(np.diff(np.sign(np.diff(second_half))) != 0)
    assert reversals >= 3                                # nested reversals inside the range
    assert np.ptp(second_half[-100:]) < 0.5 * np.ptp(v)  # the last loops are minor ones


def test_spread_matches_a_monte_carlo_of_refits():
    """The spread is the standard deviation of the probe prediction over noise realisations (σ units):
    refitting the same record with fresh noise 300 times gives the same number to Monte-Carlo accuracy."""
    v = decaying_cycles()
    clean = TRUTH.simulate(v)
    sigma = 0.05
    rng = np.random.default_rng(3)
    # a demagnetised start (warmup=0): the fit is then linear in its parameters, as the spread assumes
    fits = [identify(v, clean + rng.normal(0.0, sigma, v.size), n_operators=5, warmup=0) for _ in range(300)]
    assert not any(f.constraints_active for f in fits)
    probe = probe_cycle(float(v.min()), float(v.max()))
    predictions = np.array([f.model.simulate(probe) for f in fits])
    monte_carlo = float(np.sqrt(np.mean(np.var(predictions, axis=0)))) / sigma
    assert cycle_prediction_spread(fits[0], v) == pytest.approx(monte_carlo, rel=0.12)


def test_a_staircase_does_not_determine_operators_finer_than_its_steps():
    """20 operators 7.5 V apart on 13 V steps: only the few samples of each step's ramp tell them apart.
    The spread exceeds the limit, and refits with fresh noise predict a new input differently by more
    than the noise; 5 operators on the same record stay below the limit and agree."""
    v = staircase()
    ramped = np.convolve(np.concatenate([[v[0]] * 2, v]), np.ones(3) / 3, mode="valid")   # 3-sample ramps
    clean, sigma = TRUTH.simulate(ramped), 0.03
    rng = np.random.default_rng(7)
    new_input = decaying_cycles()
    spread, disagreement = {}, {}
    for n in (20, 5):
        fits = [identify(ramped, clean + rng.normal(0.0, sigma, v.size), n_operators=n) for _ in range(12)]
        spread[n] = cycle_prediction_spread(fits[0], ramped)
        predictions = np.array([f.model.simulate(new_input) for f in fits])
        disagreement[n] = float(np.sqrt(np.mean(np.var(predictions, axis=0)))) / sigma
    assert spread[20] > DETERMINED_SPREAD > spread[5]
    assert disagreement[20] > 1.0 > disagreement[5]


def test_well_excited_record_determines_twice_the_operators():
    v = decaying_cycles(6000)
    y = TRUTH.simulate(v) + np.random.default_rng(1).normal(0.0, 0.05, v.size)
    assert cycle_prediction_spread(identify(v, y, n_operators=20), v) < DETERMINED_SPREAD


@pytest.mark.parametrize("step_V", [25.0, 37.5])
def test_a_staircase_decides_no_more_weights_with_finer_thresholds(step_V):
    """Between instantaneous steps of ``step_V``, every operator output moves by whole steps: two
    thresholds between the same multiples of the step give the same column.  At most one weight per
    step of the span is decided, however many operators are fitted; twice the operators decide no
    more.  A decaying cycle, which visits every level, decides more with twice the operators."""
    v = staircase(step_V=step_V)
    y = TRUTH.simulate(v) + np.random.default_rng(2).normal(0.0, 0.03, v.size)
    decided = {n: decided_weights(identify(v, y, n_operators=n)) for n in (10, 20)}
    steps_spanned = int(round(np.ptp(v) / step_V))
    assert 0 < decided[20] == decided[10] < steps_spanned
    cycles = decaying_cycles(6000)
    y = TRUTH.simulate(cycles) + np.random.default_rng(1).normal(0.0, 0.05, cycles.size)
    assert decided_weights(identify(cycles, y, n_operators=20)) > decided_weights(identify(cycles, y, n_operators=10))
