"""The fifth record generator (``fifth_generator_records.py``) and what its records taught the diagnosis.

The generator is checked against definitions: its operators equal the paper's
sample recursion (a second implementation), its plants increase along every
branch, its records stay in the plant's range and the third starts from rest.
The end-to-end test diagnoses the record that hid a delay and asserts what the
issue asks for against the generator's truth: the cause named, with a second
record and without, and the model delivered predicting the third record, which
the diagnosis never sees, better than the plain fit.
"""
import functools

import numpy as np
import pytest

import fifth_generator_records as fifth
from independent_records import osp_recursion

from pysim.diagnosis import diagnose


@functools.lru_cache(maxsize=None)
def _actuator(seed):
    return fifth.make_actuator(seed)


def _rms_on(record):
    """``rms(model)``: the model's RMS error (µm) against ``record``'s noise-free displacement, run
    from rest over its voltage, after the first tenth of the record."""
    settled = slice(int(0.1 * record["clean_um"].size), None)

    def rms(model):
        error = model.simulate(record["voltage_V"])[settled] - record["clean_um"][settled]
        return float(np.sqrt(np.mean(error ** 2)))
    return rms


def test_operators_equal_the_sample_recursion():
    plant = fifth.make_plant(np.random.default_rng(3))
    rng = np.random.default_rng(4)
    v = plant["lo"] + np.clip(np.abs(np.cumsum(rng.standard_normal(2000))), 0, plant["hi"] - plant["lo"])
    y, _ = fifth.hysteresis(plant, v)
    u = v - plant["lo"]
    w = osp_recursion(u, plant["r"])
    expected = plant["a1"] * u**3 + plant["a2"] * u + w @ np.asarray(plant["b"]) + plant["offset"]
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_plants_increase_along_every_branch(seed):
    plant = fifth.make_plant(np.random.default_rng(1000 + seed))
    lo, top = plant["lo"], plant["hi"] - plant["lo"]
    levels = [0.0, top, 0.0, 0.7 * top, 0.1 * top, top, 0.5 * top, 0.0]
    u = np.concatenate([np.zeros(1)] + [np.linspace(a, z, 801)[1:] for a, z in zip(levels[:-1], levels[1:])])
    y, _ = fifth.hysteresis(plant, lo + u)
    assert np.min(np.diff(y) / np.diff(u)) > 0


@pytest.mark.parametrize("seed", [3, 18, 24, 34, 49])
def test_records_stay_in_range_and_the_third_starts_from_rest(seed):
    actuator = _actuator(seed)
    plant, records = actuator["plant"], actuator["records"]
    for record in records.values():
        assert plant["lo"] - 1e-9 <= record["voltage_V"].min() and record["voltage_V"].max() <= plant["hi"] + 1e-9
        assert record["displacement_um"].shape == record["clean_um"].shape == record["voltage_V"].shape
    assert records["C"]["start"] == "rest" and records["C"]["voltage_V"][0] == plant["lo"]
    if actuator["truth"] not in ("none", "delay"):
        assert 2.9 <= actuator["size_sigma"] <= 31.0


@pytest.mark.parametrize("second_record", [True, False])
def test_a_delay_on_a_staircase_that_ends_with_a_one_sample_step_is_named(second_record):
    """Seed 24: a 5-sample delay (4.8 σ) on a staircase up from 0 V and down to 18.75 V, whose last
    sample alone steps back to 0 V: the one sample after the peak that reaches the bottom.  The delay
    moves that sample out of every column of the fit through it, which made the top operators a copy
    of the offset: the delay family was refused and silently left out, and a resonance was named.  Its
    operators are now tied where the delayed columns show them dependent."""
    actuator = _actuator(24)
    assert actuator["truth"] == "delay" and actuator["effect_parameters"]["samples"] == 5
    records, fs = actuator["records"], actuator["sample_rate_hz"]
    first, second, third = records["A"], records["B"], records["C"]
    v = first["voltage_V"]
    after_peak = v[int(np.argmax(v)):]
    assert np.count_nonzero(after_peak == v.min()) == 1 and v[-1] == v.min() < v[-2]
    d = diagnose(first["voltage_V"], first["displacement_um"], fs,
                 validate=(second["voltage_V"], second["displacement_um"], fs) if second_record else None)
    assert d.causes == ("delay",), d.why
    assert d.extended.fit.parameters["delay_samples"] == pytest.approx(5.0, abs=0.1)
    third_rms = _rms_on(third)
    assert third_rms(d.extended.model) < 0.5 * third_rms(d.baseline.model)


def test_a_first_record_a_little_past_the_second_but_far_narrower_hands_it_the_fit():
    """Seed 3: a 5-sample delay; the first record (band-limited noise after a history) spans 61-100 V,
    the second (triangles from rest) 0-93 V.  The first reaches 7 % of the joint span that the second
    does not, and misses 61 %.  The fit had stayed on the first record, because the second did not
    cover all of it: the delay was named with a lag, and its model, extrapolating below 61 V, predicted
    the third record (a chirp over 0-92 V) 1.45 times worse than the plain fit.  The second record is
    now the one fitted, the delay is named alone, and its model predicts the third record far better."""
    actuator = _actuator(3)
    assert actuator["truth"] == "delay"
    records, fs = actuator["records"], actuator["sample_rate_hz"]
    first, second, third = records["A"], records["B"], records["C"]
    assert first["voltage_V"].max() > second["voltage_V"].max() and first["voltage_V"].min() > 60.0
    d = diagnose(first["voltage_V"], first["displacement_um"], fs,
                 validate=(second["voltage_V"], second["displacement_um"], fs))
    assert d.records_swapped, d.why
    assert d.causes == ("delay",), d.why
    third_rms = _rms_on(third)
    assert third_rms(d.extended.model) < 0.1 * third_rms(d.baseline.model)


def test_twenty_operators_that_decide_no_more_weights_than_ten_are_no_base_for_the_extensions():
    """Seed 18, first record alone: a drift under a staircase of five levels 16.7 V apart.  Between
    its levels, thresholds finer than the steps are tied: ten operators and twenty decide the same
    number of weights, and twenty only divide them otherwise between levels the staircase never
    shows.  Twenty had won the cross-validation on the staircase's own levels, and every model on
    them predicted the third record (a chirp down to -20 V) 8.0 times worse than the plain fit.  Now
    the richer set counts as undecided, every extension is fitted on the plain fit's ten operators,
    and the model delivered predicts the third record about as well as the plain fit (1.04 times;
    the drift, which the staircase's own slow pattern hides, is still not named)."""
    actuator = _actuator(18)
    assert actuator["truth"] == "drift"
    records, fs = actuator["records"], actuator["sample_rate_hz"]
    first, third = records["A"], records["C"]
    assert np.unique(first["voltage_V"]).size == 5
    d = diagnose(first["voltage_V"], first["displacement_um"], fs)
    assert d.richer_determined is False
    assert d.as_json()["evidence"]["rate_independent"]["richer_determined"] is False
    assert all(c.fit.family.n_operators == d.baseline.fit.model.n_operators for c in d.candidates.values())
    third_rms = _rms_on(third)
    assert third_rms(d.extended.model) < 1.1 * third_rms(d.baseline.model), d.why
