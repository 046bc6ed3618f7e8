"""The fourth record generator (``fourth_generator_records.py``) and what its records taught the diagnosis.

The generator is checked against definitions: its segment-wise operator equals
the paper's sample recursion, its plants increase along every branch, each
effect's size on the first record is the one it drew.  The end-to-end
tests (about two minutes) diagnose records of the kinds that were wrong before
and assert the properties the issue asks for, each against the generator's
truth: the cause named, and the model delivered predicting the third record,
which the diagnosis never sees, better than the plain fit.
"""
import functools
import json

import numpy as np
import pytest

import fourth_generator_records as fg
from independent_records import osp_recursion

from pysim.diagnosis import diagnose


@functools.lru_cache(maxsize=None)
def _actuator(seed):
    return fg.make_actuator(seed)


def _third_record_rms_pct(model, actuator):
    """RMS error (% of range) of ``model`` run from rest on the third record's voltage, against its
    noise-free displacement after the first 0.2 s."""
    v3, clean = actuator["v3"], actuator["yclean3"]
    settle = int(round(0.2 * actuator["fs"]))
    miss = np.asarray(model.simulate(v3), dtype=float)[settle:] - clean[settle:]
    return float(np.sqrt(np.mean(miss**2)) / np.ptp(clean) * 100)


def test_operators_equal_the_sample_recursion():
    rng = np.random.default_rng(1)
    u = np.abs(np.cumsum(rng.standard_normal(3000)))
    u[500:520] = u[500]                                  # a hold
    r = np.sort(rng.uniform(0, 5, 12))
    np.testing.assert_allclose(fg.play(u, r), osp_recursion(u, r), rtol=0, atol=1e-12)
    np.testing.assert_allclose(fg.play(u, r), fg.play_loop(u, r), rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", range(8))
def test_plants_increase_along_every_branch(seed):
    plant = fg.make_plant(np.random.default_rng(seed))
    top = plant["umax"]
    levels = [0.0, top, 0.0, 0.7 * top, 0.1 * top, top, 0.5 * top, 0.0]
    u = np.concatenate([np.zeros(1)] + [np.linspace(a, z, 801)[1:] for a, z in zip(levels[:-1], levels[1:])])
    slope = np.diff(fg.hyst(plant, u)) / np.diff(u)
    assert slope.min() > 0.1 * plant["gain"]


@pytest.mark.parametrize("seed", [65, 67, 72])
def test_records_hold_what_the_truth_says(seed):
    actuator = _actuator(seed)
    truth = json.loads(actuator["truth_json"])
    sigma = actuator["sigma_um"]
    # the first record's effect has the size drawn for it, where the bisection could reach it
    size = float(np.sqrt(np.mean((actuator["yclean1"] - actuator["yplain1"]) ** 2)) / sigma)
    assert size == pytest.approx(actuator["size1_sigma"], rel=1e-9)
    assert actuator["truth"] == truth["effect"]["name"]
    # the third record starts from rest, at the bottom of the range
    assert actuator["start3"] == "rest" and actuator["v3"][0] == pytest.approx(truth["plant"]["vmin"])


def test_a_staircase_does_not_choose_operators_finer_than_its_steps():
    """Seed 72 given alone: a slew limit of 1 σ on a staircase from a history.  Twenty operators fit the
    staircase's levels as well as ten, with weights that only each step's ramp decides; every extension
    fitted on them predicted a multisine about 12 times worse than the plain fit.  On the ten operators
    the slew limit leads the named set and its model predicts the multisine better than the plain fit."""
    actuator = _actuator(72)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert "slew_limit" in d.causes
    assert _third_record_rms_pct(d.extended.model, actuator) < _third_record_rms_pct(d.baseline.model, actuator)


def test_a_second_record_that_does_not_excite_the_effect_cannot_overrule_it():
    """Seed 67: a 4 V/ms slew limit on a staircase, 3.2 σ² removed out of sample; the second record,
    band-limited noise, never slews that fast, so the slew limit's model equals its hysteresis part there.
    Before, the second record named nothing and the plain fit handed over predicted the third record
    (a multisine that slews) 31 times worse than the slew limit's model."""
    actuator = _actuator(67)
    fs = actuator["fs"]
    d = diagnose(actuator["v1"], actuator["y1"], fs, validate=(actuator["v2"], actuator["y2"], fs))
    assert d.cause == "slew_limit"
    assert "does not excite slew_limit" in d.why
    plain, delivered = (_third_record_rms_pct(m, actuator) for m in (d.baseline.model, d.extended.model))
    assert delivered < 0.2 * plain


def test_stages_a_quiet_first_record_cannot_shape_are_told_apart_on_the_second():
    """Seed 65: a 3 ms low-pass before the hysteresis; the first record, one slow triangle, shows 0.2 σ
    of it, the second, a staircase, 7.4 σ.  Each stage's shape was fitted to the first record's noise,
    and the lag's happened to carry to the staircase; fitted on the staircase itself, the low-pass wins."""
    actuator = _actuator(65)
    fs = actuator["fs"]
    d = diagnose(actuator["v1"], actuator["y1"], fs, validate=(actuator["v2"], actuator["y2"], fs))
    assert d.causes[0] == "rate_dependent_hysteresis"
    assert _third_record_rms_pct(d.extended.model, actuator) < _third_record_rms_pct(d.baseline.model, actuator)


def test_a_slew_limit_on_a_staircase_alone_keeps_the_records_ties_and_predicts_better():
    """Seed 58 given alone: a slew limit of 2.7 σ on a staircase from rest.  Fitted with the operators the
    record's own fit ties freed again by the stage's ramps, its model predicted the third record (sines the
    limit never reaches) 1.37 times worse than the plain fit; with the record's ties it predicts it better."""
    actuator = _actuator(58)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert d.cause == "slew_limit" and d.extended.cause == "slew_limit"
    assert _third_record_rms_pct(d.extended.model, actuator) < _third_record_rms_pct(d.baseline.model, actuator)


def test_a_staircase_whose_fast_part_barely_overlaps_its_slow_part_is_diagnosed_not_refused():
    """Seed 93's first record, a staircase after a history: its split of other character (trained on the
    slowest blocks, scored on the fastest inside their range) scores a single sample.  That split is left
    out rather than refusing the record with an error about a constant reference."""
    actuator = _actuator(93)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert d.cause in ("none", "creep") and not any(ev.character for ev in (d.baseline, d.richer))


def test_an_input_stage_that_moves_one_sample_frees_no_operator_the_record_ties():
    """Seed 112: a slew limit of 0.9 σ on steps and sines, named by its steps; the limit found moves one
    sample of the record.  That sample had let three operators the record's own fit ties take weights of
    -0.19, +0.41 and -0.20 µm/V, and the model delivered predicted the third record 33 times worse than the
    plain fit.  With the record's ties kept, nothing delivered predicts the third record worse than the
    plain fit by more than 5 %."""
    actuator = _actuator(112)
    fs = actuator["fs"]
    d = diagnose(actuator["v1"], actuator["y1"], fs, validate=(actuator["v2"], actuator["y2"], fs))
    assert "slew_limit" in d.causes
    plain, delivered = (_third_record_rms_pct(m, actuator) for m in (d.baseline.model, d.extended.model))
    assert delivered <= 1.05 * plain
    weights = np.asarray(d.candidates["slew_limit"].fit.model.hysteresis.weights_um_per_V)
    assert np.max(np.abs(weights)) < 0.1


def test_a_slew_limit_named_on_a_staircase_alone_is_delivered_when_it_predicts_better():
    """Seed 39, given alone: a slew limit on a staircase of holds, named right.  Behind its stage the
    record decides the hysteresis part far less than the plain fit's (a cycle prediction spread of about
    2 σ against 0.2 σ), but the slew limit's own error on a new input is far larger than that: its model
    predicts the third record, a multisine that slews, better than the plain fit, and it is delivered
    (a rule that withheld such models on the spread alone handed over the plain fit here)."""
    actuator = _actuator(39)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert d.cause == "slew_limit", d.why
    assert d.extended.model is not d.baseline.model
    plain, delivered = (_third_record_rms_pct(m, actuator) for m in (d.baseline.model, d.extended.model))
    assert delivered < 0.7 * plain


def test_a_second_record_the_effect_cannot_touch_does_not_leave_it_unexplained():
    """Seed 95: a slew limit of 2.5 σ on a staircase after a history, a slow triangle from rest as the
    second record (which never slews that fast).  The first record's hysteresis part misses the
    second's paths, and the general model on both records decides: the slew limit takes both records to
    their noise, the second from 0.96 σ² to a hair above, as no effect can lower a record already at
    its noise.  The verdict had been `unexplained`; now the slew limit is named, and its model predicts
    the third record better than the plain fit."""
    actuator = _actuator(95)
    fs = actuator["fs"]
    d = diagnose(actuator["v1"], actuator["y1"], fs, validate=(actuator["v2"], actuator["y2"], fs))
    assert "slew_limit" in d.causes and d.validation["verdict_by"] == "general model on both records", d.why
    plain, delivered = (_third_record_rms_pct(m, actuator) for m in (d.baseline.model, d.extended.model))
    assert delivered < 0.7 * plain


def test_a_state_that_fits_the_record_but_predicts_its_blocks_worse_is_not_kept():
    """Seed 112 given alone: a slew limit of 0.9 σ that moves one sample, early in the record.
    Re-estimated behind the limit, the starting state put two operators at the ends of their bounds
    and fitted the whole record 2 % better, but the weights turned negative, the held-out blocks were
    predicted worse (0.44 % against 0.427 % of range with the state held) and the model predicted the
    third record 14 times worse than the plain fit.  Behind a stage that moves so few samples the state
    is now kept only where it also predicts the held-out blocks better: the slew limit's model stays
    within 1.5 times the plain fit there."""
    actuator = _actuator(112)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert "slew_limit" in d.causes, d.why
    slew = d.candidates["slew_limit"]
    assert slew.rms_pct <= d.baseline.rms_pct, d.why
    plain, candidate = (_third_record_rms_pct(m, actuator) for m in (d.baseline.model, slew.model))
    assert candidate < 1.5 * plain
    assert np.min(slew.fit.model.hysteresis.weights_um_per_V) > -0.01


def test_a_drift_is_held_after_the_record_it_was_fitted_on():
    """Seed 120: a drift that is a slow sine (4 s period, 8 σ), records of 1.9 s (band-limited noise after
    a history, then a multisine from rest); the third record, decaying triangles, lasts 4.1 s.  The drift
    is named and fitted on both records as a parabola in time.  Run on past the first record, the parabola
    grew to several times the drift's amplitude, and the model predicted the third record 3 times worse
    than the plain fit; held at its value at the record's end, it predicts it better."""
    actuator = _actuator(120)
    fs = actuator["fs"]
    d = diagnose(actuator["v1"], actuator["y1"], fs, validate=(actuator["v2"], actuator["y2"], fs))
    assert d.cause == "drift", d.why
    assert d.extended.model.stages.drift_span_s == pytest.approx((actuator["v1"].size - 1) / fs)
    assert actuator["v3"].size > 1.5 * actuator["v1"].size
    plain, delivered = (_third_record_rms_pct(m, actuator) for m in (d.baseline.model, d.extended.model))
    assert delivered < 0.8 * plain


def test_what_a_staircase_leaves_in_the_levels_of_its_held_out_holds_names_nothing():
    """Seed 224 given alone: no effect, a staircase after a history.  Held out block by block, the plain
    fit leaves 3.0 σ² in the median block, and an input low-pass and a slew limit removed 0.9 and 0.7 σ²
    of it; they were named.  All of that lies in the levels of the held-out holds, which every
    rate-independent fit extrapolates from the other blocks: with each hold's level taken out of every
    model's residual, the plain fit leaves the noise and no candidate less, so nothing is named.  Seed
    232, a true slew limit (2.2 σ) on a staircase after a history, draws its ramps after the steps,
    which no level takes out: it is still named."""
    actuator = _actuator(224)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert d.cause == "none", d.why
    assert "levels of held-out holds" in d.why
    removed = [ev.removed_beside_hold_levels_sigma2 for ev in d.candidates.values()]
    assert max(removed) < 0.03
    reported = d.as_json()["evidence"]["candidates"]
    assert [reported[c]["mse_removed_beside_hold_levels_over_noise"] for c in d.candidates] == removed
    actuator = _actuator(232)
    d = diagnose(actuator["v1"], actuator["y1"], actuator["fs"])
    assert d.cause == "slew_limit", d.why
    assert d.candidates["slew_limit"].removed_beside_hold_levels_sigma2 > 1.0


def test_a_staircase_fitted_in_turn_after_a_second_record_names_nothing_from_its_hold_levels():
    """Seed 229: no effect; band-limited noise after a history, then a staircase after a history as the
    second record.  The staircase reaches further, the roles swap and it is fitted in turn: its held-out
    holds' levels gave creep, drift, a slew limit and an input low-pass the same advantage, and all four
    were named.  With the levels taken out none keeps any, and nothing is named."""
    actuator = _actuator(229)
    fs = actuator["fs"]
    d = diagnose(actuator["v1"], actuator["y1"], fs, validate=(actuator["v2"], actuator["y2"], fs))
    assert d.cause == "none" and d.causes == (), d.why
