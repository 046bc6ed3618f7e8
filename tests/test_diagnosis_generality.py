"""Diagnosis beyond the hidden-effect benchmark: a second record, ambiguity and
the excitation that resolves it, causes outside the catalogue, input stages,
the decision rule, the folds, and the shipped micromanipulator record.

Records are made here from an MPI plant and effects written out in the test
(shifts, input stages, disturbances), so every truth is independent of the
fitted models.
"""
import math
import re
import subprocess
import sys

import numpy as np
import pytest

from pysim.diagnosis.candidates import EFFECTS, MAX_CREEP_SHARE, CandidateFitter
from pysim.diagnosis.diagnose import diagnose
from pysim.diagnosis.folds import make_folds, step_windows
from pysim.diagnosis.rules import decide, removal_holds
from pysim.diagnosis.excitation import separating_excitation
from pysim.core.input_stage import InputStageModel, input_lowpass, slew_limit
from pysim.diagnosis.validation import score_on_record
from pysim.core.spec import load_spec
from pysim.identification.data import MeasuredData, load_measured, save_measured, shipped_dataset
from pysim.testing.synthetic import make_case

FS = 2000.0
T = 1.0 / FS


@pytest.fixture(scope="module")
def plant():
    return make_case(3, "none").plant


def multisine(plant, n, seed):
    r = np.random.default_rng(seed)
    k = np.arange(n)
    s = sum(r.uniform(0.3, 1.0) * np.sin(2 * np.pi * r.uniform(2, n / 200) * k / n + r.uniform(0, 6))
            for _ in range(4))
    return plant.voltage_range_V[1] * (0.02 + 0.96 * (s - s.min()) / np.ptp(s))


def steps(plant, n, seed):
    r = np.random.default_rng(seed)
    out = []
    while sum(map(len, out)) < n:
        out.append(np.full(int(r.integers(100, 600)), r.uniform(0, plant.voltage_range_V[1])))
    return np.concatenate(out)[:n]


def delayed(plant, v, d):
    h = plant.simulate(v)
    return np.concatenate((np.full(d, h[0]), h[:-d]))


def noisy(y, seed, fraction=0.002):
    return y + np.random.default_rng(seed).normal(0, fraction * np.ptp(y), y.size)


# ------------------------------------------------------------ second record

def _validated(pair):
    """The diagnosis of an independent pair's first record validated on its second."""
    train, other = pair.train, pair.validation
    return diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz,
                    validate=(other.voltage_V, other.displacement_um, other.sample_rate_hz))


def test_second_record_names_the_cause_and_recovers_the_sensor_shift(plant):
    v1, v2 = multisine(plant, 10000, 1), steps(plant, 8000, 2)
    y1 = noisy(delayed(plant, v1, 4), 1)
    y2 = noisy(1.03 * delayed(plant, v2, 4) + 0.9, 2)      # sensor gain +3 %, zero +0.9 µm
    d = diagnose(v1, y1, FS, validate=(v2, y2, FS))
    assert d.cause == "delay" and d.validation["cause"] == "delay"
    table = d.validation["table"]
    assert set(table) == {"baseline", "richer", *d.candidates}
    row = table["delay"]
    assert row["gain"] == pytest.approx(1.03, abs=0.005) and row["offset_um"] == pytest.approx(0.9, abs=0.1)
    assert row["timing_samples"] == 0
    assert row["rms_pct"] < 0.5 * table["baseline"]["rms_pct"]
    # the JSON carries the table, without the predictions
    j = d.as_json()
    assert j["evidence"]["validation"]["table"]["delay"]["rms_pct"] == pytest.approx(row["rms_pct"])
    assert "prediction_um" not in j["evidence"]["candidates"]["delay"]["validation"]


def test_a_second_record_does_not_let_a_timing_shift_hide_a_lag(plant):
    """Truth: no effect.  A one-sample delay added to a model must cost it on the second record
    (the timing is the logger's, the same for every model, so it is not re-fitted per model)."""
    from pysim.core.extended import ExtendedModel, StageSpec
    from pysim.diagnosis.candidates import CandidateFit

    v = multisine(plant, 8000, 5)
    y = noisy(plant.simulate(v), 6)
    plain = ExtendedModel(plant, StageSpec(sample_period_s=1.0 / FS))
    lagging = ExtendedModel(plant, StageSpec(sample_period_s=1.0 / FS, delay_samples=1.0))
    scores = {name: score_on_record(CandidateFit(name, model, None, {}), v, y, 1.0 / FS, plant.voltage_range_V)
              for name, model in (("plain", plain), ("lagging", lagging))}
    assert scores["plain"]["timing_samples"] == scores["lagging"]["timing_samples"] == 0
    assert scores["lagging"]["mse_um2"] > 2.0 * scores["plain"]["mse_um2"]


def test_creep_left_by_the_history_before_the_second_record_is_scored_as_its_transient(plant, monkeypatch):
    """Truth: a plant that creeps (a 2 s mode among others).  The second record is the tail of a
    longer run that held the top of the range first, so its creep modes start far from rest; a
    model with those modes is scored at the record's noise only when their free decay is fitted."""
    from pysim.core.extended import ExtendedModel, StageSpec
    from pysim.diagnosis import validation
    from pysim.diagnosis.candidates import CandidateFit

    creeping = ExtendedModel(plant, StageSpec(sample_period_s=T, creep_time_constants_s=(0.01, 0.3, 2.0),
                                              creep_weights_um_per_V=(0.004, 0.004, 0.008)))
    v_record = multisine(plant, 8000, 31)
    v_run = np.concatenate((np.full(4000, plant.voltage_range_V[1]), v_record))
    y = noisy(creeping.simulate(v_run)[4000:], 32)
    sigma2 = (0.002 * np.ptp(y)) ** 2

    def mse():
        return score_on_record(CandidateFit("creep", creeping, None, {}), v_record, y, T,
                               plant.voltage_range_V)["mse_um2"]

    assert mse() < 1.3 * sigma2
    monkeypatch.setattr(validation, "MIN_HISTORY_MODE_SAMPLES", np.inf)
    assert mse() > 5.0 * sigma2


def test_the_operator_state_after_an_unknown_history_is_found_through_the_creep(plant, monkeypatch):
    """Truth: a plant whose displacement creeps (0.05 s and 0.3 s modes).  Before the second record
    the input rose to 93 % of the range and fell to 41 %, levels off any grid; the record holds
    there, then plays a multisine.  The model that made the record must be scored at its noise.
    Two parts are needed, each checked by switching it off: states left by short histories as
    starts, and the search through the stages (the exact steps of a static model put a state's
    effect at the wrong samples when the creep spreads it over the hold)."""
    from pysim.core.extended import ExtendedModel, StageSpec
    from pysim.diagnosis import validation
    from pysim.diagnosis.candidates import CandidateFit

    top = plant.voltage_range_V[1]
    creeping = ExtendedModel(plant, StageSpec(sample_period_s=T, displacement_creep_time_constants_s=(0.05, 0.3),
                                              displacement_creep_shares=(0.02, 0.01)))
    sine = multisine(plant, 8000, 41)
    v_record = np.r_[np.full(1000, 0.41 * top), np.clip(0.41 * top + 0.9 * (sine - sine[0]), 0.0, top)]
    history = np.r_[np.linspace(0.0, 0.93 * top, 1200), np.linspace(0.93 * top, 0.41 * top, 500)]
    before = history.size - 1
    y = noisy(creeping.simulate(np.r_[history[:-1], v_record])[before:], 42)
    sigma2 = (0.002 * np.ptp(y)) ** 2

    def mse(stage_rounds, history_starts):
        monkeypatch.setattr(validation, "STAGE_STATE_ROUNDS", stage_rounds)
        monkeypatch.setattr(validation, "HISTORY_STARTS", history_starts)
        return score_on_record(CandidateFit("creep", creeping, None, {}), v_record, y, T,
                               plant.voltage_range_V)["mse_um2"] / sigma2

    rounds, starts = validation.STAGE_STATE_ROUNDS, validation.HISTORY_STARTS
    both, neither = mse(rounds, starts), mse(0, 0)
    assert both < 1.25
    assert neither > 5.0
    assert mse(rounds, 0) < 0.7 * neither          # the search alone helps
    assert mse(0, starts) < 0.2 * neither          # so do the starts alone


def lagged(plant, v, tau_s):
    """The plant's output through an exact (zero-order-hold) first-order lag, at rest at the start."""
    import scipy.signal
    h = plant.simulate(v)
    a = np.exp(-T / tau_s)
    y, _ = scipy.signal.lfilter([1 - a], [1, -a], h, zi=[a * h[0]])
    return y


def test_a_second_record_too_quiet_to_decide_leaves_the_first_records_verdict(plant):
    """Truth: a 1 ms lag on both records.  The second record comes through a logger ten times as
    noisy, on which everything a model could still explain is below the noise: it cannot confirm
    any effect, and the lag does not make it worse, so the first record's cross-validated verdict
    stands (and the report says why)."""
    v1, v2 = multisine(plant, 10000, 11), multisine(plant, 8000, 14)
    y1, y2 = noisy(lagged(plant, v1, 1e-3), 12), noisy(lagged(plant, v2, 1e-3), 13, fraction=0.02)
    d = diagnose(v1, y1, FS, validate=(v2, y2, FS))
    assert "rate_dependence" in d.cross_validation_causes, d.why     # a small lag: maybe a named set
    assert d.causes == d.cross_validation_causes and d.validation["verdict_by"] == "cross-validation", d.why
    assert d.validation["confirms"] is False and "cannot confirm" in d.why


def test_a_quiet_second_record_that_the_cause_makes_worse_overrules_it(plant):
    """The first record shows a 10 ms lag; the second, of 'the same actuator' through a noisier
    logger, shows none: the lag fitted on the first record raises the second record's error, so
    it is not named even though that record is too quiet to confirm anything."""
    v1, v2 = multisine(plant, 10000, 11), multisine(plant, 8000, 14)
    y1, y2 = noisy(lagged(plant, v1, 1e-2), 12), noisy(plant.simulate(v2), 13, fraction=0.02)
    d = diagnose(v1, y1, FS, validate=(v2, y2, FS))
    assert "rate_dependence" in d.cross_validation_causes, d.why
    assert d.cause == "none" and d.causes == (), d.why
    # neither multisine holds a step: creep the hysteresis fit absorbs is not ruled out, and said so
    assert "creep that the hysteresis fit absorbs on a moving input is not ruled out" in d.why
    assert d.validation["verdict_by"] == "second record", d.why
    # the text gives the second record's figures, and they agree with naming nothing there (it
    # used to quote the first record's 165 σ² removed "(needs 0.25)" beside the verdict none)
    found = re.search(r"the best there, (\w+), removes (-?[\d.e+-]+) σ² \(needs ([\d.]+)\) and "
                      r"(-?[\d.]+) % of the RMS error \(needs ([\d.]+)\)", d.why)
    assert found, d.why
    removed, needed, gain, gain_needed = map(float, found.group(2, 3, 4, 5))
    assert removed < needed or gain < gain_needed, d.why
    assert "rate_dependence removed" in d.why and "does not confirm" in d.why


@pytest.mark.parametrize("noise_seeds", [(381, 382), (1, 2)])
def test_a_cause_is_not_dropped_by_a_second_record_that_measures_the_hysteresis_transfer(noise_seeds):
    """Truth: a 2-sample delay on a plant of 12 operators (another generator's).  A staircase of 34
    holds shows it plainly; the second record, slow ramps, barely excites it, and how the first
    record's hysteresis part carries to it decides that record's errors: the delay's model predicts
    it worse than the baseline, but the first record's baseline and richer models, equally good
    there, already predict it ¼-½ σ² apart.  A rise within that spread is no evidence against the
    delay (with the first noise; with the second, the spread is so wide that the delay is tested as an
    effect on the second record's own rate-independent fit), so it stays named (it used to be
    dropped, and the holds named other causes)."""
    import third_generator_records as tg

    rng = np.random.default_rng(380)
    plant = tg.make_plant(rng)
    n = 16000
    levels = np.concatenate([np.linspace(0, 1, 12), np.linspace(1, 0, 12)[1:], np.linspace(0, 0.7, 8)[1:],
                             np.linspace(0.7, 0.2, 6)[1:]])
    v1 = plant.max_voltage_V * np.repeat(levels, n // levels.size + 1)[:n]
    corners = rng.uniform(0, 1, 14)
    corners[0] = 0.0
    v2 = plant.max_voltage_V * np.interp(np.arange(n), np.linspace(0, n - 1, corners.size), corners)

    def measured(v, seed):
        h = plant.hysteresis_um(v)
        y = np.r_[np.zeros(2), h[:-2]]                     # at rest (0 µm) before the record
        return y + np.random.default_rng(seed).normal(0, 0.002 * np.ptp(y), n)

    first_noise, second_noise = noise_seeds
    d = diagnose(v1, measured(v1, first_noise), FS, validate=(v2, measured(v2, second_noise), FS))
    assert d.cross_validation_causes == ("delay",), d.why
    assert d.causes == ("delay",), d.why
    assert re.search(r"the first record's two rate-independent models predict (it|that record) [\d.]+ ?σ² apart"
                     r"|beyond the [\d.]+ σ² by which the first record's two rate-independent models predict it apart",
                     d.why), d.why
    table = d.validation["table"]
    # the premise: the second record cannot tell the delay's effect from the hysteresis transfer
    assert table["delay"]["rms_pct"] > table["baseline"]["rms_pct"], d.why
    assert abs(table["richer"]["rms_pct"] / table["baseline"]["rms_pct"] - 1.0) > 0.05, table


def test_creep_of_the_displacement_is_named_and_predicts_a_new_input(plant):
    """Truth: the displacement creeps by a share of itself (y = h + Σ w_j lag_j[h], each lag an
    exact exponential of the hysteresis output), the classic log-like creep of a stack.  It is
    named creep, and the extended model (whichever creep structure predicted the second record
    better) predicts a third input it never saw better than the plain fit; so does the
    displacement-driven structure on its own."""
    import scipy.signal

    def creeping(v):
        h = plant.simulate(v)
        y = h.copy()
        for tau, weight in ((0.01, 0.04), (0.1, 0.05), (1.0, 0.06)):
            a = np.exp(-T / tau)
            y += weight * scipy.signal.lfilter([1 - a], [1, -a], h, zi=[a * h[0]])[0]
        return y

    v1, v2, v3 = steps(plant, 12000, 21), multisine(plant, 10000, 22), steps(plant, 10000, 23)
    d = diagnose(v1, noisy(creeping(v1), 24), FS, validate=(v2, noisy(creeping(v2), 25), FS))
    assert d.cause == "creep", d.why
    truth = creeping(v3)

    def rms(model):
        return float(np.sqrt(np.mean((model.simulate(v3)[500:] - truth[500:]) ** 2)))

    assert rms(d.extended.model) < 0.7 * rms(d.baseline.model)
    # the displacement-driven structure itself: admissible shares, and it too predicts the third input
    fitter = CandidateFitter(v1, noisy(creeping(v1), 24), T)
    family, result = fitter.with_estimated_state(fitter.displacement_creep(fitter.base()))
    shares = np.asarray(family.parameters["shares"])
    assert np.all(shares >= 0) and shares.sum() <= MAX_CREEP_SHARE + 1e-12
    assert rms(fitter.finish(family, result).model) < 0.7 * rms(d.baseline.model)


def test_a_slew_limit_that_a_quiet_first_record_hides_is_named_by_a_decisive_second_one():
    """Truth (the independent generator's pair 63): an amplifier slew limit of 0.15 V/ms.  The
    first record, a decaying triangle from an unknown history, is fitted to its noise by the
    rate-independent models; the second, a multisine, is dominated by the limit, and the slew
    limit fitted on the first record removes most of its residual: the second record decides."""
    import independent_records

    pair = independent_records.make_pair(63)
    assert pair.truth.effect == "slew_limit"
    d = _validated(pair)
    assert d.cross_validation_cause == "none", d.why
    assert d.cause == "slew_limit" and d.validation["verdict_by"] == "second record", d.why
    assert "first record shows nothing beyond its noise" in d.why
    table = d.validation["table"]
    assert table["slew_limit"]["rms_pct"] < 0.5 * min(table["baseline"]["rms_pct"], table["richer"]["rms_pct"])


def test_a_second_record_that_only_the_first_records_hysteresis_fails_is_not_decisive():
    """Truth (the independent generator's pair 65): a 0.1 ms lag, below the noise.  The first
    record (steps and sines from an unknown history) identifies the hysteresis only partly, and its
    models leave over 100 σ² on the second record, a multisine; a delay removes most of that by
    accident.  The second record fitted on its own by a rate-independent model reaches its noise,
    so that residual is the hysteresis part failing on a new input, not an effect: nothing is named
    (with one BLAS thread the delay was named before this rule)."""
    import independent_records

    from pysim.diagnosis.second_record import _rate_independent_excess

    pair = independent_records.make_pair(65)
    train, other = pair.train, pair.validation
    d = _validated(pair)
    noise2 = d.validation["noise_um"]
    baseline_mse = np.mean((other.displacement_um - d.baseline.validation["prediction_um"])[1:-1] ** 2)
    assert baseline_mse > 100 * noise2**2                      # the trap: a large residual on record 2
    fitter = CandidateFitter(train.voltage_V, train.displacement_um, 1 / train.sample_rate_hz)
    assert _rate_independent_excess(fitter, other.voltage_V, other.displacement_um) < 1.0
    assert d.cause == "none" and d.causes == (), d.why
    # the slew-limit pair, whose second record no rate-independent model absorbs, stays decisive
    slew = independent_records.make_pair(63).validation
    assert _rate_independent_excess(fitter, slew.voltage_V, slew.displacement_um) > 100.0


def _excitation_benchmark():
    """``benchmarks/bench_diagnosis_excitations.py`` as a module (its records and helpers)."""
    import sys
    from pathlib import Path

    benchmarks = str(Path(__file__).resolve().parents[1] / "benchmarks")
    if benchmarks not in sys.path:
        sys.path.insert(0, benchmarks)
    import bench_diagnosis_excitations

    return bench_diagnosis_excitations


def _excitation_third_record_errors(bench, rec, d) -> dict:
    """RMS error (% of range) of the plain fit and of the model delivered on an excitation benchmark
    record's third record (never given to the diagnosis), as the benchmark scores it."""
    return {label: bench._rms_pct(model, rec["test"])
            for label, model in (("plain", d.baseline.model), ("delivered", d.extended.model))}


def test_a_second_record_that_only_measures_the_hysteresis_transfer_does_not_narrow_the_set():
    """Truth (the excitation benchmark's seed 21, records no generator of the tests plays): a plain
    MPI plant with a two-sample delay, 0.85 σ above the noise, seen through band-limited noise; the
    second record is slow random ramps.  Cross-validation names a set of look-alikes that holds the
    delay.  The first record's models miss the ramps by about 100 σ², which the ramps' own
    rate-independent fit does not leave: that table measures how the hysteresis part transfers, and
    creep's model happened to transfer best, so the second record's set, the same first cause
    without the delay, had replaced the cross-validated one.  Now the cross-validated set stands,
    and the model delivered still predicts a third input (a multisine) better than the plain fit."""
    bench = _excitation_benchmark()

    rec = bench.make_records(21)
    assert (rec["kind"], rec["effect"]) == ("band_noise", "delay")
    first, second = rec["train"], rec["validation"]
    d = diagnose(first["voltage_V"], first["displacement_um"], bench.SAMPLE_RATE_HZ,
                 validate=(second["voltage_V"], second["displacement_um"], bench.SAMPLE_RATE_HZ))
    assert "delay" in d.cross_validation_causes
    assert "delay" in d.causes and d.validation["verdict_by"] == "cross-validation", d.why
    assert "does not replace the cross-validated one" in d.why
    noise2 = d.validation["noise_um"]
    miss = second["displacement_um"] - d.baseline.validation["prediction_um"]
    assert np.mean(miss[1:-1] ** 2) > 30 * noise2**2          # the trap: the transfer error
    error = _excitation_third_record_errors(bench, rec, d)
    assert error["delivered"] < 0.9 * error["plain"], error


def test_the_search_error_sum_ignores_columns_the_rows_never_move():
    """A second implementation: least squares on the columns that move.  An operator above the
    search rows' input leaves a column of rounding (1e-130) or of numbers whose squares underflow
    (1e-170, its norm 0 in floating point); the normal equations of the scaled columns gave 364 for
    a true 53.9 here (NaN on third-generator seed 2's resonance search, where a grid search then took
    the NaN for its minimum)."""
    from pysim.diagnosis.candidates import _lsq_sse

    rng = np.random.default_rng(0)
    n = 4000
    u = 75 + 75 * np.sin(np.linspace(0, 20, n))
    t = np.arange(n)
    moving = np.column_stack([u**3, u, np.maximum(u - 30, 0), np.ones(n)])
    A = np.column_stack([moving[:, :3], 1e-130 * np.exp(-t / 500), 1e-170 * np.exp(-t / 700), moving[:, 3]])
    y = 0.001 * u**2 + rng.normal(0, 0.01, n)
    theta = np.linalg.lstsq(moving, y, rcond=None)[0]
    assert _lsq_sse(A, y) == pytest.approx(float(np.sum((y - moving @ theta) ** 2)), rel=1e-9)
    assert _lsq_sse(np.zeros((n, 2)), y) == pytest.approx(float(y @ y))
    # the same columns with the voltage in mV: the cubic column is 10⁹ times larger, the offset column
    # is not, and it still moves the fit (measured against the largest column it was dropped)
    in_mV = np.column_stack([(1e3 * u) ** 3, 1e3 * u, np.maximum(1e3 * u - 3e4, 0), np.ones(n)])
    assert _lsq_sse(in_mV, y) == pytest.approx(float(np.sum((y - moving @ theta) ** 2)), rel=1e-6)


def test_the_diagnosis_does_not_depend_on_the_units():
    """Truth (the independent generator's pair 1): a 28.6 Hz resonance (ζ 0.49) after the
    hysteresis.  The same records with the voltage in mV and the displacement in nm behind a sensor
    zero of 250 µm must name the same causes and predict as well in % of the range: every threshold
    of the method is relative.  Before, the searches' error sums measured a column against the
    largest one, the cubic column (mV³), so the offset column was dropped: the resonance, the input
    low-pass and the slew limit fitted 8-10 times worse than in V and a delay was named alone."""
    import independent_records

    pair = independent_records.make_pair(1)
    assert pair.truth.effect == "rate_dependence"
    train, other = pair.train, pair.validation

    def in_units(record, volts, microns, zero_um):
        return (volts * record.voltage_V, microns * (record.displacement_um + zero_um), record.sample_rate_hz)

    in_V = diagnose(*in_units(train, 1.0, 1.0, 0.0), validate=in_units(other, 1.0, 1.0, 0.0))
    in_mV_nm = diagnose(*in_units(train, 1e3, 1e3, 250.0), validate=in_units(other, 1e3, 1e3, 250.0))
    assert in_V.cause == "rate_dependence", in_V.why
    assert (in_mV_nm.cause, in_mV_nm.causes) == (in_V.cause, in_V.causes), in_mV_nm.why
    for name in ("baseline", "richer", *in_V.candidates):
        ours = in_V.candidates.get(name) or getattr(in_V, name)
        theirs = in_mV_nm.candidates.get(name) or getattr(in_mV_nm, name)
        assert theirs.rms_pct == pytest.approx(ours.rms_pct, rel=0.02), name


def test_minor_loops_without_an_effect_name_nothing():
    """Truth: a plain MPI plant of the third generator (``make_plant(default_rng(1003))``, at rest at
    0 V), no effect, 0.2 % noise; the input: loops of 0.4 of the range at 2 Hz whose centre wanders
    at 0.3 Hz and that reach neither end; the second record random ramps.  In the held-out blocks the
    rate-independent models extrapolate where operators sit in states the other blocks never showed
    (median block 2.35 σ² for ten operators, 1.03 for the true thresholds), and creep's model, which
    extrapolates less, removed 0.30 σ² -- enough to be named.  Where every operator stays in the states
    training showed, it removes nothing (-0.008 σ²), so nothing is named, and the why says so."""
    import third_generator_records as plants

    bench = _excitation_benchmark()

    rng = np.random.default_rng(1003)
    plant = plants.make_plant(rng)
    n = 16000
    t = np.arange(n) / bench.SAMPLE_RATE_HZ

    def record(share_of_range):
        v = share_of_range * plant.max_voltage_V
        y = plant.hysteresis_um(v)
        return v, y + rng.normal(scale=bench.NOISE_SHARE * np.ptp(y), size=n), bench.SAMPLE_RATE_HZ

    # in this order: the ramps are drawn after the first record's noise
    first = record(0.5 + 0.2 * np.sin(2 * np.pi * 2.0 * t) + 0.1 * np.sin(2 * np.pi * 0.3 * t))
    second = record(bench.excitation("random_ramps", rng, n))
    d = diagnose(*first, validate=second)
    assert d.cause == "none" and d.causes == (), d.why
    assert "creep removes" in d.why and "extrapolate operator states" in d.why


def test_an_effect_that_only_the_second_records_input_excites_is_named_when_it_takes_its_turn():
    """Truth (the independent generator's pair 2): creep, 5 % of the displacement over modes of
    18 ms to 0.8 s.  Its first record, a sine from rest, shows the creep 0.8 σ above the noise: named
    by the near-noise rule.  With three times the noise (a noisier sensor, the same actuator) that sine
    shows nothing beyond its noise (its rate-independent fit absorbs the creep); the second record, a
    multisine, shows it plainly when it is the record fitted and cross-validated.  Before the second
    record took its turn, nothing was named.  The extended model must predict a third record, which
    the diagnosis never saw, better than the plain fit."""
    import independent_records

    pair = independent_records.make_pair(2)
    assert pair.truth.effect == "creep"
    train, other, third = pair.train, pair.validation, pair.test
    sine_alone = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert sine_alone.cause == "creep", sine_alone.why
    assert "significant near the noise" in sine_alone.reasons["creep"]
    noisier = train.displacement_um + np.random.default_rng(5).normal(
        0.0, pair.truth.noise_sigma_um * math.sqrt(3.0**2 - 1.0), train.displacement_um.size)
    alone = diagnose(train.voltage_V, noisier, train.sample_rate_hz)
    assert alone.cause == "none", alone.why                  # the first record shows nothing
    d = diagnose(train.voltage_V, noisier, train.sample_rate_hz,
                 validate=(other.voltage_V, other.displacement_um, other.sample_rate_hz),
                 source="sine.csv", validate_source="multisine.csv")
    assert d.cause == "creep" and d.causes == ("creep",), d.why
    assert d.records_swapped and d.source == "multisine.csv" and d.validation["source"] == "sine.csv"
    assert "sine.csv shows no effect beyond its noise" in d.swap_reason
    assert d.as_json()["evidence"]["swap_reason"] == d.swap_reason and d.why.startswith("the records' roles")
    from pysim.cli.commands.diagnose import format_text
    assert "records swapped: sine.csv shows no effect" in format_text(d, None, None)
    table = d.validation["table"]                             # not contradicted on the first record
    assert table["creep"]["rms_pct"] <= min(table["baseline"]["rms_pct"], table["richer"]["rms_pct"])
    part = slice(third.settle_samples, None)
    rms = {label: float(np.sqrt(np.mean((getattr(d, label).model.simulate(third.voltage_V)[part]
                                         - third.clean_um[part]) ** 2)))
           for label in ("baseline", "extended")}
    assert rms["extended"] < 0.9 * rms["baseline"], rms


def resonant(plant, v, natural_frequency_hz, damping_ratio):
    """The plant's output through an exact (zero-order-hold) second-order low-pass of unit static
    gain, at rest at the start (scipy's discretisation, not the package's stages)."""
    import scipy.signal
    w = 2 * np.pi * natural_frequency_hz
    b, a, _ = scipy.signal.cont2discrete(([w**2], [1, 2 * damping_ratio * w, w**2]), T, method="zoh")
    b = np.ravel(b)
    h = plant.simulate(v)
    return scipy.signal.lfilter(b, a, h, zi=scipy.signal.lfilter_zi(b, a) * h[0])[0]


def test_a_lag_seen_on_one_sine_is_fitted_as_a_lag_not_a_resonance():
    """One frequency fixes a stage's phase there and nothing else: a lag and a resonance fit it
    alike, and only held-out blocks may choose the resonance.  Truth (the independent generator's
    pair 137): a 50 ms first-order lag after an MPI plant of many operators off the eq. 13 grid, a
    sine from an unknown history, 1.1 σ of it that no rate-independent model absorbs.  The lag
    candidate must be first order near 50 ms, and predict the pair's other record, a chirp, better
    than the plain fit (an in-sample BIC chose a 2.2 Hz resonance that predicts it worse)."""
    import independent_records

    pair = independent_records.make_pair(137)
    truth = pair.truth.effect_parameters
    assert pair.truth.effect == "rate_dependence" and truth["order"] == 1
    train, chirp = pair.train, pair.validation
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    lag = d.candidates["rate_dependence"]
    assert lag.fit.parameters["order"] == 1, lag.fit.parameters
    assert lag.fit.parameters["time_constant_s"] == pytest.approx(truth["time_constant_s"], rel=0.2)
    part = slice(chirp.settle_samples, None)
    rms = {label: float(np.sqrt(np.mean((model.simulate(chirp.voltage_V)[part] - chirp.clean_um[part]) ** 2)))
           for label, model in (("plain", d.baseline.fit.model), ("lag", lag.fit.model))}
    assert rms["lag"] < 0.5 * rms["plain"], rms


def test_a_lag_tied_with_a_lowpass_before_the_hysteresis_is_told_apart_by_the_second_records_own_fit():
    """Pair 137 again, with its chirp as the second record.  On the sine a lag after the hysteresis,
    a low-pass before it and a delay tie; the lag fitted there (46 ms) predicts the chirp worse than
    the low-pass (48 ms) does, so scoring the first record's models on the chirp named the low-pass.
    Fitted on the chirp itself, the lag's structure is the one that reaches the noise: the second
    record rules the others out and the lag is named alone."""
    import independent_records

    d = _validated(independent_records.make_pair(137))
    assert {"rate_dependence", "rate_dependent_hysteresis"} <= set(d.cross_validation_causes)
    assert d.causes == ("rate_dependence",), d.why
    assert "ruled out there" in d.why and "rate_dependent_hysteresis" in d.validation["note"]


def steps_and_sines(plant, n, seed):
    """Holds after random steps, each hold carrying a small sine (a rig's staircase test)."""
    v = steps(plant, n, seed)
    k = np.arange(n)
    top = plant.voltage_range_V[1]
    return np.clip(v + 0.04 * top * np.sin(2 * np.pi * 35.0 * k / FS), 0.0, top)


@pytest.mark.parametrize("truth", ["rate_dependence", "rate_dependent_hysteresis"])
def test_look_alike_dynamics_are_ranked_by_how_their_structures_fit_both_records(plant, truth):
    """A 1.5 ms lag after the hysteresis, or the same low-pass before it (written out here), on steps
    and sines, validated on a multisine.  Whatever the diagnosis names, the rule that tells the
    look-alikes apart on both records in sample must never displace the true structure by the
    other one, and must displace the other one by the true structure when the verdict names it."""
    from pysim.diagnosis.second_record import structure_on_both

    tau = 1.5e-3
    v1, v2 = steps_and_sines(plant, 14000, 21), multisine(plant, 9000, 22)

    def measured(v, seed):
        if truth == "rate_dependence":
            return noisy(lagged(plant, v, tau), seed)
        return noisy(plant.simulate(input_lowpass(v, tau, T)), seed)

    y1, y2 = measured(v1, 23), measured(v2, 24)
    d = diagnose(v1, y1, FS, validate=(v2, y2, FS))
    assert d.cause == truth, d.why
    other = "rate_dependent_hysteresis" if truth == "rate_dependence" else "rate_dependence"
    assert d.candidates[truth].significant and d.candidates[other].significant, d.why
    fitter = CandidateFitter(d.voltage_V, d.displacement_um, T)
    reference = min(d.baseline.validation["mse_um2"], d.richer.validation["mse_um2"])
    found = structure_on_both(fitter, d.candidates, (other,), d.displacement_um, v2, y2, d.noise_um, reference)
    assert found is not None and found[0] == truth, found
    errors = found[1]
    assert errors[truth][0] < errors[other][0] and errors[truth][1] < errors[other][1], errors
    assert structure_on_both(fitter, d.candidates, (truth,), d.displacement_um, v2, y2, d.noise_um,
                             reference) is None


def test_a_resonance_near_the_sample_rate_is_told_from_a_delay_by_its_excitation():
    """Independent pair 89: a second-order stage at a third of the sample rate (1.67 kHz at 5 kHz,
    ζ 0.8, simulated finely by the independent generator) after a plant of 26 operators off the eq. 13
    grid.  Below fs/20 it is a 0.75-sample delay: the records (steps, a sine) tie it with a delay and
    a low-pass before the hysteresis.  The excitation written for the set has to reach where the
    stage shows its shape, and the resonance search has to reach its corner (it runs up to the sample
    rate): played on the same
    actuator (another noise draw), the record it gives names the stage."""
    import independent_records

    pair = independent_records.make_pair(89)
    assert pair.truth.effect == "rate_dependence" and pair.truth.effect_parameters["order"] == 2
    d = _validated(pair)
    assert "rate_dependence" in d.causes and len(d.causes) > 1 and d.excitation is not None, d.why
    played = independent_records.respond(pair, d.excitation, noise_seed=89)
    again = diagnose(played.voltage_V, played.displacement_um, played.sample_rate_hz)
    assert again.cause == "rate_dependence", again.why
    assert again.candidates["rate_dependence"].fit.parameters["order"] == 2


def test_a_resonance_that_only_ties_a_fraction_of_a_sample_delay_does_not_displace_it():
    """Independent pair 115: a 0.21-sample delay at 2 kHz.  A resonance near the sample rate
    (ζ 0.64) fits both records as well as the delay does, within the tie margin; named first, it
    predicted a third record of the actuator worse than the plain fit (its gain near Nyquist rings
    on steps).  Among ties the one with fewer parameters is named unless the other's advantage holds
    on both records, and the extended model must predict the third record better than the plain fit."""
    import independent_records

    pair = independent_records.make_pair(115)
    assert pair.truth.effect == "delay"
    d = _validated(pair)
    assert d.cause == "delay", d.why
    rms = {label: _third_record_rms(pair, model)
           for label, model in (("plain", d.baseline.fit.model), ("extended", d.extended.fit.model))}
    assert rms["extended"] < rms["plain"], rms


def slew_limited(plant, v, rate_V_per_ms):
    """The plant behind an amplifier that follows the command at most at ``rate_V_per_ms``."""
    step = rate_V_per_ms * 1e3 * T
    x = np.empty(len(v))
    x[0] = v[0]
    for k in range(1, len(v)):
        x[k] = x[k - 1] + min(max(v[k] - x[k - 1], -step), step)
    return plant.simulate(x)


@pytest.mark.parametrize("truth", ["resonance", "slew_limit", "none"])
def test_dynamics_that_only_upward_steps_show_are_searched_on_them(plant, truth):
    """Truth: a 15 Hz, ζ 0.3 resonance after the hysteresis, a 2 V/ms amplifier slew limit before
    it, or neither.  The first record is a slow sine, which hides both (the resonance's small lag
    is absorbed in the loop's width, the limit is never reached); the second, upward steps, rings
    or ramps after each step but cannot identify the hysteresis.  The effect's shape is searched
    on the steps with the first record's hysteresis: it is named with its parameters, and it
    predicts a third input (steps up and down) better than the plain fit.  Without an effect the
    same pair names nothing.  (Before the search, the resonance was missed, and a lag searched
    alone on the steps named the slew limit a resonance.)"""
    top = plant.voltage_range_V[1]
    k = np.arange(18000)
    v1 = top * (0.5 - 0.48 * np.cos(2 * np.pi * k / 6000))
    v2 = np.repeat(np.linspace(0.0, top, 7), 900)
    v3 = steps(plant, 8000, 31)
    respond = {"resonance": lambda v: resonant(plant, v, 15.0, 0.3),
               "slew_limit": lambda v: slew_limited(plant, v, 2.0),
               "none": plant.simulate}[truth]

    d = diagnose(v1, noisy(respond(v1), 41), FS, validate=(v2, noisy(respond(v2), 42), FS))
    if truth == "none":
        assert d.cause == "none" and d.causes == (), d.why
        # the second record holds each step 0.45 s: creep would have shown there
        assert "not ruled out" not in d.why
        return
    assert d.cross_validation_cause == "none", d.why             # the sine alone shows nothing
    cause = "rate_dependence" if truth == "resonance" else "slew_limit"
    assert d.cause == cause and d.causes == (cause,) and not d.records_swapped, d.why
    p = d.extended.fit.parameters
    if truth == "resonance":
        assert p["order"] == 2 and abs(p["natural_frequency_hz"] / 15.0 - 1) < 0.03, p
        assert abs(p["damping_ratio"] - 0.3) < 0.03, p
    else:
        assert abs(p["rate_V_per_ms"] / 2.0 - 1) < 0.03, p
    assert d.candidates[cause].validation["shape_fitted_on"] == "second record"
    assert "searched on the second record" in d.validation["note"]
    clean = respond(v3)
    rms = {label: float(np.sqrt(np.mean((getattr(d, label).model.simulate(v3) - clean)[100:] ** 2)))
           for label in ("baseline", "extended")}
    assert rms["extended"] < 0.3 * rms["baseline"], rms


def slow_with_two_steps(plant, n):
    """A slow sine (a period of 3000 samples) with two large steps into holds of 300 samples, the
    second to the level where the sine resumes."""
    top = plant.voltage_range_V[1]
    k = np.arange(n)
    v = top * (0.5 - 0.45 * np.cos(2 * np.pi * k / 3000))
    first = 7500 - 600                                        # the sine peaks at 7500
    v[first:first + 300] = 0.02 * top
    v[first + 300:first + 600] = 0.95 * top
    return v


def test_step_windows_are_steps_into_holds_not_fast_inputs():
    k = np.arange(4000)
    fast = 50.0 + 50.0 * np.sin(2 * np.pi * k / 20)         # moves up to 16 % of its span per sample
    assert step_windows(fast, 40) == []
    staircase = np.repeat([0.0, 100.0, 30.0, 30.5, 90.0], 800)
    # 30 → 30.5 V is below STEP_SHARE of the span; each window starts STEP_RISE_SAMPLES before its step
    assert step_windows(staircase, 40) == [(797, 840), (1597, 1640), (3197, 3240)]
    ramp_in = staircase.copy()
    ramp_in[800:803] = [25.0, 50.0, 75.0]                     # a rise over three samples is a step too
    assert step_windows(ramp_in, 40)[0] == (800, 843)
    into_sine = np.concatenate((np.zeros(500), 100.0 + 20.0 * np.sin(np.arange(500) / 3.0)))
    assert step_windows(into_sine, 40) == []                  # no hold after it: the blocks weigh it


def test_an_effect_that_only_two_large_steps_show_is_named_by_the_responses_to_them():
    """Truth (the independent generator's pair 239): a 96 V/ms amplifier slew limit.  The first
    record, steps and sines from an unknown history at 2 kHz, reaches the limit only in its two
    full-range steps, whose responses ramp over a few samples; the median over the
    cross-validation blocks does not weigh so few samples, and nothing was named.  Predicted with
    each step left out of the fit, the slew limit removes nearly all of what the rate-independent
    model leaves there: it is named with a rate within 25 % of the truth (74.5 V/ms: a ramp of
    three samples tells the rate only roughly), and the second record
    (band-limited noise that never reaches the limit) does not contradict it."""
    import independent_records

    pair = independent_records.make_pair(239)
    truth = pair.truth.effect_parameters["slew_rate_V_per_ms"]
    assert pair.truth.effect == "slew_limit"
    train = pair.train
    alone = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert alone.cause == "slew_limit" and "steps into holds" in alone.why, alone.why
    assert not alone.candidates["slew_limit"].significant, alone.why    # the blocks alone show nothing
    evidence = alone.as_json()["evidence"]["steps"]
    assert evidence["windows"] >= 2 and evidence["removed_share"]["slew_limit"] >= 0.75, evidence
    assert "on the responses to" in alone.reasons["slew_limit"], alone.reasons
    from pysim.cli.commands.diagnose import format_text
    from pysim.diagnosis.report import summary_markdown
    assert "step(s) into holds it removes" in format_text(alone, None, None)
    assert "step(s) into holds, each left out of its fit, it removes" in summary_markdown(alone)
    assert abs(alone.extended.fit.parameters["rate_V_per_ms"] / truth - 1) < 0.25, alone.extended.fit.parameters
    d = _validated(pair)
    assert d.cause == "slew_limit" and d.causes == ("slew_limit",), d.why


def test_a_stage_that_takes_the_steps_is_named_though_one_window_gains_a_little_error():
    """Truth (the independent generator's pair 911): a 34 V/ms amplifier slew limit on steps and
    sines after an unknown history at 1 kHz; the limit bites only in the samples after two steps.
    Predicted with each step left out of its fit, the slew limit (found within 1 %) removes nearly
    all of the 242 σ² the rate-independent model leaves in the five windows, and leaves 0.46 σ²
    more in one of them.  Requiring every window to stay within the noise margin named nothing;
    what it adds there is 0.04 % of what it removes, and it is named, alone or with the second
    record, and predicts the third record (a sine) no worse than the plain fit."""
    import independent_records

    pair = independent_records.make_pair(911)
    truth = pair.truth.effect_parameters["slew_rate_V_per_ms"]
    assert pair.truth.effect == "slew_limit"
    train = pair.train
    alone = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert alone.causes == ("slew_limit",) and "steps into holds" in alone.why, alone.why
    evidence = alone.as_json()["evidence"]["steps"]
    assert evidence["windows"] == 5 and evidence["removed_share"]["slew_limit"] >= 0.9, evidence
    assert abs(alone.extended.fit.parameters["rate_V_per_ms"] / truth - 1) < 0.05, alone.extended.fit.parameters
    assert _third_record_rms(pair, alone.extended.model) <= _third_record_rms(pair, alone.baseline.model)
    assert _validated(pair).causes == ("slew_limit",)


def test_an_advantage_only_where_the_fits_extrapolate_names_nothing():
    """Truth (the independent generator's pair 968): no effect; a plant of 30 operators, fitted
    with ten, on steps and sines after an unknown history.  In the median block creep removed
    0.84 σ² and a lag 0.53 σ²; where every operator stays in states its training showed, three of
    the five blocks are at the noise for every model, and the median there gave the lag 0.003 σ²
    (0.6 % of its removal), which had kept creep named.  Nothing is named, alone or with the
    second record, and nothing is refused."""
    import independent_records

    pair = independent_records.make_pair(968)
    assert pair.truth.effect == "none"
    train = pair.train
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert d.cause == "none" and d.causes == (), d.why
    assert d.extended.model is d.baseline.model or _third_record_rms(pair, d.extended.model) <= _third_record_rms(
        pair, d.baseline.model)
    # nor by the second record (band-limited noise), which the first record's fits predict from states that
    # record never showed either: creep removed 0.31 of the 0.45 σ² the baseline leaves there
    validated = _validated(pair)
    assert validated.cause == "none" and validated.causes == (), validated.why


def test_a_stage_that_takes_one_step_and_spoils_another_is_not_named_by_the_steps():
    """Truth (the independent generator's pair 607): a 75 V/ms amplifier slew limit, two steps into
    holds.  Left out of the fit, a resonance takes 98 % of the full-range step's 1697 σ² and leaves
    the other step 40 σ² worse, ten times what the rate-independent model leaves there: a wrong
    shape, however small beside what it takes.  It is not named from the steps (the slew limit,
    which left out of the fit predicts the full-range step poorly, is not either)."""
    import independent_records

    pair = independent_records.make_pair(607)
    assert pair.truth.effect == "slew_limit"
    train = pair.train
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert "rate_dependence" not in d.causes, d.why
    steps = d.as_json()["evidence"].get("steps")
    assert not steps or "rate_dependence" not in steps["removed_share"], steps


def test_a_stage_that_fits_a_lone_step_where_the_out_of_sample_winner_cannot_leads_the_set():
    """Truth (the independent generator's pair 751): a 75 V/ms amplifier slew limit.  The record,
    holds and sines from rest at 5 kHz, has one 147 V step into a hold.  Left out of the fit, that
    step hides the branch of the hysteresis its ramp runs along, so the slew limit (found at the
    right rate) predicts the window worse than a resonance, which only blends the levels before and
    after the step; fitted on the whole record the slew limit explains the window to the noise and
    the resonance does not.  The slew limit leads the named set, the resonance stays in it, the
    set's excitation holds steps, and the model delivered predicts the third record (band-limited
    noise, where the limit bites) better than the plain fit.  (Before, the resonance alone was
    named, and it predicted the third record 1.3 times worse than the plain fit.)"""
    import independent_records

    pair = independent_records.make_pair(751)
    assert pair.truth.effect == "slew_limit"
    train, test = pair.train, pair.test
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert d.causes[0] == "slew_limit" and "rate_dependence" in d.causes, d.why
    steps_evidence = d.as_json()["evidence"]["steps"]
    fitted = steps_evidence["in_sample_sigma2"]
    assert fitted["slew_limit"] < 1.25 < fitted["rate_dependence"], steps_evidence
    assert steps_evidence["out_of_sample_best"] == "rate_dependence", steps_evidence
    assert "one fits the steps and the other predicts them" in d.why, d.why
    rate = d.extended.fit.parameters["rate_V_per_ms"]
    assert abs(rate / pair.truth.effect_parameters["slew_rate_V_per_ms"] - 1) < 0.05, rate
    assert d.excitation is not None and "slew limit turns a step into a ramp" in d.why
    part = slice(test.settle_samples, None)
    rms = {label: float(np.sqrt(np.mean((getattr(d, label).model.simulate(test.voltage_V) - test.clean_um)[part] ** 2)))
           for label in ("baseline", "extended")}
    assert rms["extended"] < 0.5 * rms["baseline"], rms


def test_an_extension_whose_hysteresis_part_misses_a_new_input_is_not_delivered_behind_a_shape_correction():
    """Truth (the independent generator's pair 503): a 40 V/ms slew limit, shown by two full-range
    steps of a first record of steps and sines after an unknown history; the second record is a
    sine.  The slew limit is named by the responses to the steps.  On the second record the input's
    path predicts most of what every model leaves, and after that correction -- itself a
    rate-independent fit of the sine -- the two models differ only in the first samples, so the
    comparison saw no difference; compared as fitted, the slew limit's model is not better there,
    and the plain fit is delivered.  The judge is a third record, a decaying triangle given to
    neither: the model delivered predicts it no worse than the plain fit.  The slew limit moves only
    the samples of the two steps, so its fit keeps the operator ties of the record's own fit
    (2026-12-05): its model, which had predicted the triangle 2.2 times worse than the plain fit with
    weights those few samples decided, now predicts it within 1 % of it."""
    import independent_records

    pair = independent_records.make_pair(503)
    assert pair.truth.effect == "slew_limit"
    d = _validated(pair)
    assert d.cause == "slew_limit", d.why
    assert d.validation.get("shape"), d.validation      # the correction that hid the difference
    assert d.validation["delivered"] == "baseline" and d.validation["withheld"] == "slew_limit", d.validation
    withheld = d.validation["withheld_sigma2"]
    assert withheld["slew_limit"] > withheld["baseline"], withheld
    plain = _third_record_rms(pair, d.baseline.model)
    assert _third_record_rms(pair, d.extended.model) <= plain * (1 + 1e-9)
    assert _third_record_rms(pair, d.candidates["slew_limit"].fit.model) < 1.01 * plain


def test_a_resonance_near_nyquist_is_found_at_its_own_frequency_on_steps():
    """Truth (the independent generator's pair 161): a 333 Hz resonance, ζ 0.46, at 1 kHz.  The
    first record (steps and sines from an unknown history) shows it only in its responses to five
    steps.  Discretised exactly for an input linear between samples, the second-order stage fitted
    there lies at the truth's frequency and damping (the bilinear transform maps a 333 Hz stage to
    257 Hz: its fit on the same record gave 518 Hz, ζ 0.69, and left 7 % more error) and predicts
    the steps better than its look-alikes.  The second record, band-limited noise
    below the resonance, cannot tell it from a delay: the named set holds it."""
    import independent_records

    pair = independent_records.make_pair(161)
    truth = pair.truth.effect_parameters
    assert pair.truth.effect == "rate_dependence" and truth["order"] == 2
    train = pair.train
    alone = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert alone.cause == "rate_dependence" and alone.causes == ("rate_dependence",), alone.why
    found = alone.candidates["rate_dependence"].fit.parameters
    assert found["order"] == 2, found
    assert found["natural_frequency_hz"] == pytest.approx(truth["natural_frequency_hz"], rel=0.1), found
    assert found["damping_ratio"] == pytest.approx(truth["damping_ratio"], abs=0.1), found
    d = _validated(pair)
    assert "rate_dependence" in d.causes, d.why


def test_a_candidate_whose_fit_moves_operators_in_lockstep_is_kept():
    """Truth (the independent generator's pair 78): a 50 ms input low-pass on a multisine at
    5 kHz.  In one cross-validation block the low-passed input never falls by the width of the
    two operators at 52.5 and 75 V after both were dragged: each follows the running maximum, a
    shifted copy of the other, and the column pivoting names the offset as the dependent column.
    The wider operator is tied to its neighbour (as when the pivoting names an operator) instead
    of the candidate being lost; its low-pass is found at the truth's time constant."""
    import independent_records

    pair = independent_records.make_pair(78)
    assert pair.truth.effect == "rate_dependent_hysteresis"
    train = pair.train
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert "rate_dependent_hysteresis" in d.candidates, sorted(d.candidates)
    found = d.candidates["rate_dependent_hysteresis"].fit.parameters["input_time_constant_s"]
    assert found == pytest.approx(pair.truth.effect_parameters["time_constant_s"], rel=0.1)


def test_a_record_with_large_steps_and_no_effect_names_nothing(plant):
    """Truth: no effect.  A slow sine with two large steps into holds: the responses to the steps
    are predicted as well by the rate-independent model as anything else, and nothing is named."""
    v1 = slow_with_two_steps(plant, 12000)
    d = diagnose(v1, noisy(plant.simulate(v1), 43), FS)
    assert d.cause == "none" and d.causes == (), d.why


def test_a_cause_the_steps_name_is_tested_on_the_second_records_own_hysteresis():
    """Truth (the independent generator's pair 263): a 75 V/ms slew limit that two full-range steps
    of the first record (steps and sines from an unknown history) show.  On those steps a lag
    predicts best; the second record, band-limited noise that never reaches the limit, is
    predicted far worse by every model fitted on the first record (its hysteresis part fails on
    the new input).  Put on the second record's own rate-independent fit, the lag raises its error
    by more than the noise margin -- the slew limit does not: the lag is not named."""
    import independent_records

    from pysim.diagnosis.second_record import _raised_on_own_hysteresis

    pair = independent_records.make_pair(263)
    assert pair.truth.effect == "slew_limit"
    train, other = pair.train, pair.validation
    d = _validated(pair)
    assert d.cross_validation_cause == "rate_dependence", d.why
    assert d.cause in ("none", "slew_limit"), d.why
    fitter = CandidateFitter(train.voltage_V, train.displacement_um, 1 / train.sample_rate_hz)
    raised = _raised_on_own_hysteresis(fitter, d.candidates, ("rate_dependence", "slew_limit"),
                                       other.voltage_V, other.displacement_um)
    assert raised["rate_dependence"] >= 0.25 and raised["slew_limit"] < 0.25, raised


def test_a_cause_the_first_records_models_cannot_carry_to_the_second_is_confirmed_by_its_own_fit(monkeypatch):
    """Truth (the independent generator's pair 154): creep of the input (three modes, 8 ms to 2.7 s,
    a quarter of the response) on a chirp from an unknown history, validated on band-limited
    noise.  Scored from the operator state that the exact steps of a static model find (the
    second record's scoring without the history starts and the search through the stages), the
    chirp's models leave the noise record far above its noise whatever effect they carry, so the
    second record alone would say `unexplained`; its own rate-independent fit leaves an effect's
    worth too, and diagnosed on its own it names creep: creep is named, and it predicts the third
    record (steps and sines) better than the plain fit.  With the state found through the creep,
    creep's model is significant on the second record itself, and it was named by that record until
    rate-dependent hysteresis gained thresholds that grow with the rate: that structure, kept for
    predicting both records best (the noise record at 0.72 % RMS against creep's 0.75 %), leaves the
    first record's models' verdict there open, and the second record diagnosed on its own decides."""
    import independent_records
    from pysim.diagnosis import validation

    pair = independent_records.make_pair(154)
    assert pair.truth.effect == "creep"
    test = pair.test

    def third_record_better(d):
        rms = {}
        for label, ev in (("plain", d.baseline), ("creep", d.extended)):
            scored = score_on_record(ev.fit, test.voltage_V, test.displacement_um, 1 / test.sample_rate_hz,
                                     (float(d.voltage_V.min()), float(d.voltage_V.max())),
                                     train_voltage_V=d.voltage_V)
            rms[label] = scored["rms_pct"]
        assert rms["creep"] < 0.7 * rms["plain"], rms

    d = _validated(pair)
    assert d.cause == "creep" and d.validation["verdict_by"] in ("second record", "second record alone"), d.why
    third_record_better(d)
    monkeypatch.setattr(validation, "HISTORY_STARTS", 0)
    monkeypatch.setattr(validation, "STAGE_STATE_ROUNDS", 0)
    d = _validated(pair)
    assert d.cause == "creep" and d.validation["verdict_by"] == "second record alone", d.why
    assert "diagnosed on its own" in d.why
    third_record_better(d)


@pytest.mark.parametrize("generator, seed", [("independent", 153), ("outside", 77)])
def test_the_model_delivered_for_a_set_is_the_member_that_predicts_the_second_record_best(generator, seed):
    """Truth: a lag after the hysteresis (the independent generator's pair 153, a 1.7 ms lag on an MPI
    actuator, steps and sines from an unknown history, then a decaying triangle; the outside-class
    pair 77, a lag behind a Bouc-Wen actuator, a sine sweep, then band-limited noise).  The records
    cannot tell the lag from its look-alikes, so a set is named, but the members' models carry the
    first record's hysteresis part to a new input very differently.  The delivered model is the
    member that predicts the second record best (77: the delay's, 140 σ² against the lag's 145), or
    the one whose structure, refitted on both records, predicts the held-out blocks of each better
    still; where the second record only measures the hysteresis transfer (153), the set's first
    member, refitted on both records.  Either way the delivered model predicts the third record
    (never given) better than the plain fit, which the set's first member once did not on 153
    (1.04x the plain fit's RMS).

    Which member comes first, and whether the second record is decisive, can differ between
    floating-point kernels (201, a resonance, was named a set on the machine this test was first
    written on, the lag alone on the pinned kernels of tests/pin_kernels.sh): the assertions follow
    the path the verdict took, and every path must deliver a member that predicts the new input."""
    if generator == "independent":
        import independent_records

        pair = independent_records.make_pair(seed)
        assert pair.truth.effect == "rate_dependence"
        d = _validated(pair)
    else:
        pair, d = _diagnose_outside_pair(seed, "bouc_wen", "lag")
    assert len(d.causes) > 1 and "rate_dependence" in d.causes, d.why
    assert d.extended.cause == d.cause, d.why
    noise2 = d.validation["noise_um"]
    on_second = {c: d.candidates[c].validation["mse_um2"] / noise2**2 for c in d.causes}
    if d.validation.get("delivered") is not None:
        # the second record weighed the set: its best member is delivered and comes first
        assert d.validation["delivered"] == d.cause, d.why
        assert d.cause in d.validation["delivered_sigma2"] and "is the model delivered" in d.why
    if d.validation.get("delivered_by") == "both records":
        # the member the second record chose gave way to one whose structure, refitted on both
        # records, predicts the held-out blocks of each record better
        both = d.validation["delivered_both_sigma2"]
        others = [errors for cause, errors in both.items() if cause != d.cause]
        assert others and all(both[d.cause][i] < min(e[i] for e in others) for i in (0, 1)), both
        assert "refitted on both records" in d.why, d.why
    elif d.validation.get("delivered") is not None:
        assert on_second[d.cause] == min(on_second.values()), on_second
    else:
        # the second record did not weigh the set (it measures the hysteresis transfer, not the effect):
        # the cross-validated first member is delivered, refitted on both records
        assert d.cause == d.cross_validation_cause and d.fitted_on_both_records, d.why
        assert "measures how the first record's hysteresis part transfers" in d.why, d.why
    rms = {label: _third_record_rms(pair, ev.model) for label, ev in (("plain", d.baseline), ("delivered", d.extended))}
    assert rms["delivered"] < 0.7 * rms["plain"], rms


def test_a_start_the_baseline_could_not_know_is_not_put_to_the_general_model_as_an_effect():
    """Truth (the independent generator's pair 168, first record alone): an MPI actuator without an
    effect, driven by band-limited noise after an unknown history.  The baseline misses the record's
    held-out samples by about 1.1 σ² (its start), the richer rate-independent model (more operators,
    a free starting state) takes them to the noise.  Nothing is named, and the general model on the
    record's halves is not asked: alone it fits this loop shape worse than either MPI model, and its
    creep, which takes up that shape error, was once named here, with a model that predicted the third
    record (never given) 36 times worse than the plain fit (RMS error against the noise-free
    displacement)."""
    import independent_records

    pair = independent_records.make_pair(168)
    assert pair.truth.effect == "none"
    train = pair.train
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    noise2 = d.noise_um**2
    assert d.baseline.mse_um2 / noise2 - 1.0 >= 1.0 > d.richer.mse_um2 / noise2 - 1.0
    assert d.cause == "none" and set(d.causes) <= {"none"} and d.general_model is None, d.why
    assert d.extended.model is d.baseline.model


def test_a_second_operator_set_that_predicts_the_faster_part_worse_is_not_taken():
    """Truth (the independent generator's pair 153, first record alone): a 1.7 ms lag after an MPI
    hysteresis of 16 operators off the eq. 13 grid; the first record is eight steps from an unknown
    history, the pair's other two records (a decaying triangle and a multisine, both from rest) are
    never given.  Every fast stage is also fitted on twice the operators; there the lag wins the
    record's held-out blocks by a few hundredths of σ², which steps held between the same levels
    allow, but predicts the record's faster part worse.  Taken for that win, it led the named set and
    its model, delivered, predicted the triangle 2.4 times worse than the plain fit (RMS error against
    the noise-free displacement).  The operator set is now kept only where it also predicts the part
    of other character no worse: the lag and the model delivered predict both unseen records better
    than the plain fit."""
    import independent_records

    pair = independent_records.make_pair(153)
    assert pair.truth.effect == "rate_dependence"
    train = pair.train
    d = diagnose(train.voltage_V, train.displacement_um, train.sample_rate_hz)
    assert "rate_dependence" in d.causes, d.why

    plain = {name: _record_rms(getattr(pair, name), d.baseline.model) for name in ("validation", "test")}
    lag = _record_rms(pair.validation, d.candidates["rate_dependence"].model)
    assert lag < plain["validation"], (lag, plain)
    delivered = {name: _record_rms(getattr(pair, name), d.extended.model) for name in ("validation", "test")}
    assert all(delivered[name] < plain[name] for name in plain), (delivered, plain)


def test_an_extension_that_predicts_the_second_record_worse_than_the_plain_fit_is_not_delivered():
    """Truth (the independent generator's pair 239): a 96 V/ms slew limit before the hysteresis,
    fitted on steps and sines from an unknown history that move the operators only up to 45 V of
    150 V, validated on band-limited noise that never reaches the slew limit.  The steps name the
    slew limit, but its model's hysteresis part, fitted together with it, extrapolates the unexcited
    range differently from the plain fit's and predicts the second record far worse.  The cause
    stays named; the model delivered is the plain fit.  The third record (a decaying triangle; never given)
    shows that this was right: the slew model predicts it worse than the plain fit (2.07x its RMS
    error before this rule, when the slew model was delivered), the model delivered does not."""
    import json

    import independent_records

    from pysim.cli.commands.diagnose import _spec_header, format_text
    from pysim.diagnosis.report import summary_markdown

    pair = independent_records.make_pair(239)
    assert pair.truth.effect == "slew_limit"
    d = _validated(pair)
    assert d.cause == "slew_limit" and d.withheld == "slew_limit", d.why
    assert d.extended.model is d.baseline.model and d.validation["delivered"] == "baseline"
    errors = d.validation["withheld_sigma2"]
    assert errors["slew_limit"] > errors["baseline"] + 1.0, errors
    assert "the model delivered is the plain fit" in d.why
    rms = {label: _third_record_rms(pair, model)
           for label, model in (("plain", d.baseline.model), ("slew model", d.candidates["slew_limit"].model),
                                ("delivered", d.extended.model))}
    assert rms["slew model"] > 1.2 * rms["plain"] and rms["delivered"] <= rms["plain"], rms
    # every output says what is delivered, and the JSON keeps its format
    assert "the model delivered is the plain fit" in summary_markdown(d)
    assert "(model delivered: the plain fit)" in format_text(d, None, None)
    assert _spec_header(d).startswith("Plain MPI model (slew_limit named")
    report = json.loads(json.dumps(d.as_json()))
    assert report["extended"]["cause"] == "baseline" and report["evidence"]["validation"]["withheld"] == "slew_limit"


def test_a_first_record_that_misses_part_of_the_range_hands_the_fit_to_the_second():
    """Truth (the independent generator's pair 9, forced to a 1.3 ms lag after the hysteresis, at
    10 kHz): the first record is played on that actuator after an unknown history (up to the top,
    down to the middle) and only moves between 15 % and 99 % of the range (steps into holds, then
    sines); the second record, the pair's own, covers all of it.  Fitted on the first, every model
    extrapolates over 16 % of the range, and the second record's scoring leaves that part out,
    so nothing tested it: the lag's model predicted the third record (never given, full range)
    at 4x the noise σ.  The record that covers both is fitted now, and the lag is named there; its
    model predicts the third record inside the noise.  A spike put in the first record's first
    hold is repaired and reported, though the diagnosis handed over is the one fitted on the second
    record (it had been left out of the report on this path alone)."""
    import independent_records

    from pysim.diagnosis.folds import range_beyond_first

    pair = independent_records.make_pair(9, effect="rate_dependence")
    fs = pair.train.sample_rate_hz
    lo, hi = pair.truth.plant["voltage_range_V"]
    span = hi - lo

    def held(levels, seconds):
        return np.concatenate([np.full(int(seconds * fs), level) for level in levels])

    history = np.concatenate([np.linspace(lo, hi, int(0.5 * fs)), np.linspace(hi, lo + 0.5 * span, int(0.3 * fs))])
    bottom, top = lo + 0.15 * span, lo + 0.99 * span
    t = np.arange(int(2.0 * fs)) / fs
    sines = np.concatenate([(top + bottom) / 2 + (top - bottom) / 2 * np.sin(2 * np.pi * f * t)
                            for f in (1.0, 5.0, 20.0)])
    played = independent_records.respond(
        pair, np.concatenate([history, held([lo + 0.5 * span, top, bottom, lo + 0.7 * span, lo + 0.35 * span], 0.6),
                              sines]), noise_seed=5)
    v1, y1 = played.voltage_V[history.size:], played.displacement_um[history.size:].copy()
    # a spike in the first record's first hold: repaired, and reported though the second record is fitted
    spike_at = 3000
    y1[spike_at] += 0.05 * np.ptp(y1)
    other = pair.validation
    assert range_beyond_first(v1, other.voltage_V) > 0.15
    d = diagnose(v1, y1, fs, validate=(other.voltage_V, other.displacement_um, fs))
    assert d.records_swapped and "would extrapolate over 16 % of that range" in d.swap_reason, d.why
    assert [(a["kind"], a["record"], a["sample"], a["repaired"]) for a in d.artefacts] == [
        ("spike", "first", spike_at, True)], d.why
    assert "rate_dependence" in d.causes, d.why
    assert _third_record_rms(pair, d.extended.model) < pair.truth.noise_sigma_um, d.why


def test_an_effect_the_second_records_own_fit_cannot_take_is_left_out_there(plant, monkeypatch):
    """A candidate whose structure the second record cannot identify (the independent generator's
    pair 207: an input low-pass of 0.21 s fitted on a multisine made the second record's regressors
    -- a sine's -- linearly dependent) is left out of the comparison on the second record's own
    fit, which goes on with the others; it used to fail there.  `with_estimated_state` raises the
    reason.  Identification fails here on purpose for every family with an input stage."""
    from types import SimpleNamespace

    from pysim.diagnosis.second_record import _raised_on_own_hysteresis
    from pysim.identification.identify import IdentificationError

    v1 = multisine(plant, 8000, 41)
    fitter = CandidateFitter(v1, noisy(plant.simulate(v1), 42), T)
    base = fitter.base()
    families = {"rate_dependent_hysteresis": fitter._with(base, "rate_dependent_hysteresis",
                                                         parameters={"input_time_constant_s": 0.2},
                                                         input_stage=("lowpass", 0.2)),
                "delay": fitter.delay(base)}
    candidates = {c: SimpleNamespace(fit=SimpleNamespace(family=f)) for c, f in families.items()}
    v2 = multisine(plant, 6000, 43)
    y2 = noisy(plant.simulate(v2), 44)
    fit = CandidateFitter.fit

    def failing(self, family, rows=None):
        if family.input_stage is not None:
            raise IdentificationError("the regressors are linearly dependent")
        return fit(self, family, rows)

    monkeypatch.setattr(CandidateFitter, "fit", failing)
    second = CandidateFitter(v2, y2, T)
    with pytest.raises(IdentificationError):
        second.with_estimated_state(second.adopt(second.base("richer"), families["rate_dependent_hysteresis"]))
    raised = _raised_on_own_hysteresis(fitter, candidates, ("rate_dependent_hysteresis", "delay"), v2, y2)
    assert set(raised) == {"delay"}, raised


def bouc_wen_um(v, d=0.8, alpha=0.45, beta=0.035, gamma=0.02, substeps=20):
    """A Bouc-Wen actuator (rate-independent, outside the PI class): y = d v − h with
    dh = (α d − β sign(dv) h − γ |h|) dv, integrated in ``substeps`` per sample."""
    h, out, previous = 0.0, np.empty(len(v)), v[0]
    for k, x in enumerate(v):
        dv = (x - previous) / substeps
        for _ in range(substeps):
            h += (alpha * d - beta * np.sign(dv) * h - gamma * abs(h)) * dv
        previous, out[k] = x, d * x - h
    return out


def test_a_plant_outside_the_model_class_without_an_effect_names_nothing():
    """Truth: a Bouc-Wen actuator, no effect.  The MPI model misses part of its shape on a
    multisine, and a drift fitted with it there gained 0.49 σ² on the other record, a sine, while
    it raised the multisine's own cross-validated error by 0.35 σ²: it was named (in the second
    record's turn).  A cause that raises the error of the record it was fitted on is contradicted
    there: nothing is named, in either order of the records."""
    rng = np.random.default_rng(1)
    k = np.arange(16000)
    r = np.random.default_rng(rng.integers(1_000_000))
    s = sum(r.uniform(0.3, 1) * np.sin(2 * np.pi * r.uniform(2, k.size / 300) * k / k.size + r.uniform(0, 6))
            for _ in range(4))
    v2 = 150 * (0.01 + 0.98 * (s - s.min()) / np.ptp(s))
    v1 = 75 - 73 * np.cos(2 * np.pi * np.arange(12000) / 3000)
    y1, y2 = bouc_wen_um(v1), bouc_wen_um(v2)
    noise = 0.002 * np.ptp(y1)
    y1, y2 = y1 + rng.normal(0, noise, y1.size), y2 + rng.normal(0, noise, y2.size)
    for first, second in (((v1, y1), (v2, y2)), ((v2, y2), (v1, y1))):
        d = diagnose(*first, FS, validate=(*second, FS))
        assert d.cause == "none" and d.causes == (), d.why


def test_a_preisach_plant_without_an_effect_names_nothing_and_reports_its_shape():
    """Truth: a Preisach actuator (relays with a 2-D weight: minor loops that are not congruent),
    no effect.  No MPI model draws its loops: the rate-independent models leave many noise
    variances on a sine sweep and on triangles, which were called "unexplained" -- an effect
    outside the catalogue.  The input's path predicts that residual out of block (a shape error,
    not an effect): nothing is named, and the shape evidence is reported for both records."""
    import independent_records

    t = np.arange(6000) / 1000.0
    sweep = 50 + 45 * np.sin(2 * np.pi * (1.0 * t + 2.0 * t**2))
    triangles = np.interp(t, np.linspace(0, 6, 13), [5, 95, 20, 80, 35, 65, 5, 95, 20, 80, 35, 65, 5])
    rng = np.random.default_rng(1)

    def measured(v):
        x = (v - 0.0) / 100.0
        return 6.0 * (independent_records.preisach_relays(v, 0.0, 100.0) + 1) / 2 + 4.0 * x + rng.normal(0, 0.01,
                                                                                                       v.size)

    d = diagnose(sweep, measured(sweep), 1000.0, validate=(triangles, measured(triangles), 1000.0))
    assert d.cause == "none" and d.causes == (), d.why
    assert set(d.shape) == {"first", "second"}
    assert all(found["removed_sigma2"] >= 3 for found in d.shape.values())
    assert "outside the model class" in d.why and "path-only correction" in d.why
    assert d.as_json()["evidence"]["shape"]["second"]["removed_sigma2"] == d.shape["second"]["removed_sigma2"]


def test_an_mpi_record_gets_no_shape_correction():
    """An MPI plant (the independent generator's) is inside the class: no path correction, whatever
    its effect."""
    import independent_records

    for seed in (0, 1):      # none; a lag after the hysteresis
        d = _validated(independent_records.make_pair(seed))
        assert d.shape == {}, (seed, d.shape)


def _logged_at(pair, rate_hz, noise_seed=7):
    """The second record's voltage played on the true actuator and logged at ``rate_hz`` (the
    generator's ADC samples the continuous response; between samples the voltage is linear)."""
    import independent_records

    fs = pair.train.sample_rate_hz
    t_s = np.arange(pair.validation.voltage_V.size) / fs
    t2_s = np.arange(int(t_s[-1] * rate_hz + 1e-9) + 1) / rate_hz
    return independent_records.respond(pair, np.interp(t2_s, t_s, pair.validation.voltage_V),
                                       noise_seed=noise_seed, sample_rate_hz=rate_hz)


def test_a_second_record_at_a_multiple_of_the_rate_is_used_at_every_mth_sample():
    import independent_records

    pair = independent_records.make_pair(6)         # a low-pass before the hysteresis, 2 kHz
    fs, first = pair.train.sample_rate_hz, pair.train
    found = {}
    for factor in (1, 2):
        other = _logged_at(pair, factor * fs)
        found[factor] = diagnose(first.voltage_V, first.displacement_um, fs, source="first.csv",
                                 validate=(other.voltage_V, other.displacement_um, factor * fs),
                                 validate_source="other.csv")
    assert found[1].cause == found[2].cause == pair.truth.effect_parameters["name"] == "rate_dependent_hysteresis"
    assert found[1].validation["resampled"] == ""
    assert found[2].validation["resampled"] == ("other.csv was sampled at 4000 Hz and is used at 2000 Hz, the rate "
                                                "of first.csv: every 2nd sample")
    assert found[2].validation["resampled"] in found[2].validation["note"]


@pytest.mark.parametrize("factor, first_every, second_every", [(0.5, 2, 1), (1.5, 2, 3)])
def test_a_slower_second_record_puts_both_on_the_highest_common_rate(factor, first_every, second_every):
    """A second record logged slower than the first, or at a rate neither a multiple nor a fraction of
    it, is not refused: both are used at the highest rate on whose grid both records' samples fall
    (every m-th sample of each), and the verdict there is the one of the same records cut down to that
    rate by hand before they are given (a second way to the same samples)."""
    import independent_records

    pair = independent_records.make_pair(6)         # a low-pass before the hysteresis, 2 kHz
    fs, first = pair.train.sample_rate_hz, pair.train
    other = _logged_at(pair, factor * fs)
    time_s = 3.0 + np.arange(first.voltage_V.size) / fs     # a logger's clock, not starting at zero
    d = diagnose(first.voltage_V, first.displacement_um, fs, time_s=time_s, source="first.csv",
                 validate=(other.voltage_V, other.displacement_um, factor * fs), validate_source="other.csv")
    common = fs / first_every
    by_hand = diagnose(first.voltage_V[::first_every], first.displacement_um[::first_every], common,
                       validate=(other.voltage_V[::second_every], other.displacement_um[::second_every], common))
    assert d.cause == by_hand.cause == pair.truth.effect_parameters["name"], d.why
    assert d.extended.rms_pct == pytest.approx(by_hand.extended.rms_pct, rel=1e-9)
    assert d.extended.model.sample_period_s == pytest.approx(1.0 / common)
    assert d.time_s.size == by_hand.time_s.size and d.time_s[1] - d.time_s[0] == pytest.approx(first_every / fs)
    assert d.time_s[0] >= 3.0
    said = d.validation["resampled"]
    assert said.startswith(f"first.csv was sampled at {fs:g} Hz and is used at {common:g} Hz"), said
    assert (f"other.csv was sampled at {factor * fs:g} Hz" in said) == (second_every > 1), said


def test_a_second_record_at_a_rate_without_a_common_grid_is_refused():
    """Rates whose samples meet on no grid down to a tenth of the first record's rate would need
    samples invented: one message naming the second record and both rates, no fit."""
    import independent_records

    pair = independent_records.make_pair(6)
    fs, first = pair.train.sample_rate_hz, pair.train
    v2, y2 = pair.validation.voltage_V, pair.validation.displacement_um
    rate = 0.61725 * fs                            # no m <= 10 brings the two grids together
    with pytest.raises(ValueError) as refused:
        diagnose(first.voltage_V, first.displacement_um, fs, source="first.csv", validate=(v2, y2, rate),
                 validate_source="other.csv")
    message = str(refused.value)
    assert message.startswith(f"other.csv: records at {fs:g} Hz and {rate:g} Hz have no common rate"), message
    assert "\n" not in message


def test_a_record_without_noise_is_weighed_against_the_lowest_noise_measured_not_its_own_misfit():
    """A simulated record of a plain MPI actuator (independent generator: thresholds off the eq. 13
    grid), without noise: the fit's misfit is the model class's, and weighed against a noise
    estimate of 10⁻⁶ of the range it was named a delay (74 % of the error removed).  It is weighed
    against 0.1 % of the range instead, said so, and nothing is named; the same record with a
    sensor's noise is weighed against that noise."""
    import json

    import independent_records

    from pysim.diagnosis.residuals import VALIDATED_NOISE_FRACTION, is_noise_free

    rng = np.random.default_rng(5)
    plant = independent_records.make_plant(rng, (0.0, 100.0))
    k = np.arange(6000)
    v = 50 + 45 * np.sin(2 * np.pi * k / 1500) * (0.6 + 0.4 * np.cos(2 * np.pi * k / 4100))
    y = plant.hysteresis_um(v) + plant.sensor_offset_um
    d = diagnose(v, y, FS)
    assert d.cause == "none" and d.causes == () and d.noise_free, d.why
    assert d.noise_um == pytest.approx(VALIDATED_NOISE_FRACTION * np.ptp(y), rel=1e-12)
    assert "shows no measurable noise" in d.why
    assert json.loads(json.dumps(d.as_json()))["evidence"]["noise_free"] is True
    sigma = 2e-6 * np.ptp(y)            # a capacitive sensor's noise: measured, not floored
    noisy = y + np.random.default_rng(6).normal(0.0, sigma, y.size)
    assert not is_noise_free(noisy - y, noisy)
    d = diagnose(v, noisy, FS)
    assert not d.noise_free and d.noise_um < 2 * sigma and "no measurable noise" not in d.why


# ------------------------------------------------------------ ambiguity

@pytest.mark.parametrize("truth", ["delay", "rate_dependence"])
def test_the_separating_excitation_tells_a_delay_from_a_lag(plant, truth):
    v, plan = separating_excitation(["delay", "rate_dependence"], plant.voltage_range_V, FS, 16000)
    lo, hi = plant.voltage_range_V
    assert v.size == 16000 and v.min() >= lo and v.max() <= hi
    assert [p["samples"] for p in plan] and sum(p["samples"] for p in plan) == v.size
    if truth == "delay":
        y = delayed(plant, v, 3)
    else:
        h = plant.simulate(v)
        y = input_lowpass(h, 4 * T, T)          # a first-order lag after the hysteresis (same discretisation)
    d = diagnose(v, noisy(y, 5, 0.001), FS)
    assert d.cause == truth, d.why


def test_a_single_sine_record_names_the_delay_or_a_set_whose_excitation_resolves_it(plant):
    k = np.arange(10000)
    v = plant.voltage_range_V[1] * (0.5 - 0.48 * np.cos(2 * np.pi * k / 400))
    d = diagnose(v, noisy(delayed(plant, v, 3), 6, 0.001), FS)
    assert "delay" in d.causes, d.why
    if len(d.causes) > 1:
        assert d.excitation is not None and d.excitation.min() >= 0 and d.excitation.max() <= v.max()
        again = diagnose(d.excitation, noisy(delayed(plant, d.excitation, 3), 7, 0.001), FS)
        assert again.cause == "delay", again.why
    else:
        assert d.cause == "delay" and d.excitation is None


def test_excitation_parts_hold_what_they_promise():
    v, plan = separating_excitation(["creep", "drift", "delay"], (-10.0, 90.0), 1000.0, 12000)
    parts = {p["purpose"].split(":")[0]: v[p["start_sample"]:p["start_sample"] + p["samples"]] for p in plan}
    first, last = plan[0], plan[-1]
    # a slow full-range cycle at both ends
    for p in (first, last):
        piece = v[p["start_sample"]:p["start_sample"] + p["samples"]]
        assert piece.max() == pytest.approx(90.0) and piece.min() == pytest.approx(-10.0)
    # holds: runs of at least 500 identical samples
    steps_part = parts["steps held long"]
    runs = np.diff(np.flatnonzero(np.diff(np.r_[np.nan, steps_part, np.nan]) != 0))
    assert runs.max() >= 500
    # several frequencies: the sine part's spectrum has peaks an octave or more apart
    sines = parts["sines at several frequencies and two amplitudes"]
    spectrum = np.abs(np.fft.rfft(sines - sines.mean()))
    freqs = np.fft.rfftfreq(sines.size, 1e-3)
    top = freqs[np.argsort(spectrum)[-200:]]
    assert top.max() / max(top.min(), 1e-9) > 8
    # ... up to a fifth of the sample rate, where a stage with its corner above fs/20 shows its shape; the
    # fast ones small (a third of the large ones' amplitude), so an amplifier's slew limit does not bite
    fast = np.abs(np.fft.rfft(sines - sines.mean()))[freqs > 150.0]
    assert freqs[freqs > 150.0][np.argmax(fast)] == pytest.approx(200.0, rel=0.02)
    near = (freqs > 48.0) & (freqs < 52.0)                                 # the fastest large burst, fs/20
    assert fast.max() < 0.5 * spectrum[near].max()


@pytest.mark.parametrize("sample_rate_hz", [100.0, 2000.0, 25000.0])
@pytest.mark.parametrize("causes", [["creep"], ["creep", "delay", "rate_dependence"], ["drift"]])
def test_an_excitation_of_the_default_length_holds_every_step_long_enough_for_creep(causes, sample_rate_hz):
    """A diagnosis that names nothing on a record without holds points to `pysim excite`: the
    excitation it writes must hold each step CREEP_HOLD_S or more, at any sample rate, even when a
    fitted creep is fast (which shortens the holds).  Counted as runs of identical samples."""
    from pysim.diagnosis.excitation import samples_for_holds
    from pysim.diagnosis.folds import CREEP_HOLD_S, holds_after_a_step

    n = max(6000, samples_for_holds(causes, sample_rate_hz))
    fast = {"creep": {"time_constants_s": [2.0 / sample_rate_hz]}}
    for candidates in (None, fast):
        v, plan = separating_excitation(causes, (0.0, 150.0), sample_rate_hz, n, candidates=candidates)
        part = next(p for p in plan if p["purpose"].startswith("steps held long"))
        steps_part = v[part["start_sample"]:part["start_sample"] + part["samples"]]
        edges = np.flatnonzero(np.diff(steps_part) != 0)
        runs = np.diff(np.r_[-1, edges, steps_part.size - 1])
        assert runs.size == 6 and runs.min() >= math.ceil(CREEP_HOLD_S * sample_rate_hz), runs
        assert holds_after_a_step(v, sample_rate_hz)


def test_excitation_refuses_a_bad_range():
    with pytest.raises(ValueError, match="low < high"):
        separating_excitation(["delay"], (5.0, 5.0), 1000.0)


# ------------------------------------------------------------ outside the catalogue

def test_a_disturbance_outside_the_catalogue_is_unexplained(plant):
    v = multisine(plant, 10000, 3)
    y = plant.simulate(v)
    sigma = 0.002 * np.ptp(y)
    y = y + 20 * sigma * np.sin(2 * np.pi * 37.3 * np.arange(v.size) * T)
    d = diagnose(v, noisy(y, 8), FS)
    assert d.cause == "unexplained" and d.causes == ("unexplained",), d.why
    assert "outside the catalogue" in d.why


def test_holds_and_the_motion_in_them_are_measured_as_defined():
    """hold_runs: every hold after a step, from the first sample at the new level to the last within
    1 % of the span; none on a ramp, a constant or too short a record.  motion_within_holds: the
    spread about each hold's mean in σ² above the noise -- for white noise plus a settling of known
    shape, the settling's own spread (computed here from its definition), within the noise of the
    estimate; no measure without a positive σ."""
    from pysim.diagnosis.folds import hold_runs
    from pysim.diagnosis.residuals import motion_within_holds

    levels = np.array([0.0, 80.0, 20.0, 100.0, 50.0, 10.0])
    v = np.repeat(levels, 400)
    runs = hold_runs(v, 10)
    assert runs == [(400 * k, 400 * (k + 1)) for k in range(1, 6)]
    assert hold_runs(np.linspace(0, 100, 2000), 10) == [] and hold_runs(np.full(100, 3.0)) == []
    assert hold_runs([0.0, 1.0]) == []
    rng = np.random.default_rng(3)
    sigma = 0.01
    settling = 3 * sigma * np.exp(-np.arange(400) / 40.0)
    expected = np.sum((settling - settling.mean()) ** 2) / 399 / sigma**2
    residual = rng.normal(0.0, sigma, v.size) + np.tile(settling, 6)
    excess, dof = motion_within_holds(residual, runs, sigma)
    assert dof == 5 * 399
    assert excess == pytest.approx(expected, abs=4 * math.sqrt(2 / dof))
    still, _ = motion_within_holds(rng.normal(0.0, sigma, v.size), runs, sigma)
    assert abs(still) < 4 * math.sqrt(2 / dof)
    assert math.isnan(motion_within_holds(residual, runs, 0.0)[0])


@pytest.mark.parametrize("disturbance_sigma", [0.0, 4.0])
def test_holds_that_show_no_motion_tell_a_shape_outside_the_class_from_an_effect(disturbance_sigma):
    """Truth: a Bouc-Wen actuator (rate independent, outside the MPI class; outside-class seed 97),
    no effect; a staircase first, band-limited noise second.  The first record's MPI model misses the
    second by far more than its noise; without the holds the verdict is `unexplained` or a cause
    whose model absorbs part of the shape error (creep on the pinned kernels of tests/pin_kernels.sh,
    `unexplained` where the tests were first written: the searches settle differently).  In the
    staircase's holds a rate-independent output stands still, and so does the residual: nothing is
    named.  The same records with a disturbance outside the catalogue (a 37.3 Hz sine of 4 σ, which
    moves in the holds too) stay `unexplained`: the rule answers what the holds show, not which
    plant class it is."""
    import outside_class_records

    pair = outside_class_records.make_outside_pair(97)
    assert pair.plant == "bouc_wen" and pair.effect == "none" and pair.train.input_kind == "staircase"
    fs = pair.train.sample_rate_hz

    def measured(record):
        t = np.arange(record.voltage_V.size) / fs
        return record.displacement_um + disturbance_sigma * pair.noise_um * np.sin(2 * np.pi * 37.3 * t)

    d = diagnose(pair.train.voltage_V, measured(pair.train), fs,
                 validate=(pair.validation.voltage_V, measured(pair.validation), fs))
    if disturbance_sigma == 0.0:
        assert d.cause == "none" and d.causes == () and d.extended.model is d.baseline.model, d.why
        assert "does not move within" in d.why and "holds of the record fitted" in d.why
        before = d.why.split("Without the holds the verdict would be ", 1)
        assert len(before) == 2, d.why
        # the holds overruled a verdict that named something: an `unexplained` or a catalogue cause
        assert before[1].startswith("unexplained") or before[1].split(" ", 1)[0].rstrip(",") in EFFECTS, d.why
    else:
        assert d.cause == "unexplained", d.why
        assert "does not move within" not in d.why


@pytest.mark.parametrize("creep_sigma", [0.0, 40.0])
def test_a_cause_whose_model_moves_in_holds_where_the_actuator_stands_still_is_ruled_out(creep_sigma):
    """Truth: a Bouc-Wen actuator (rate independent, outside the MPI class; outside-class seed 25),
    no effect; band-limited noise first, a staircase second.  The creep model absorbs part of the
    shape error on the first record and was named; on the staircase its prediction settles after
    every step while the actuator's output stands still, so the holds rule it out and nothing is
    named.  The same records with real creep (a slow mode of the input, 0.3 s, defined here, of
    ``creep_sigma`` noise σ per volt-span) move in the holds too: the rule does not fire, and creep
    is named."""
    import outside_class_records
    from scipy import signal

    pair = outside_class_records.make_outside_pair(25)
    assert pair.plant == "bouc_wen" and pair.effect == "none" and pair.validation.input_kind == "staircase"
    fs = pair.train.sample_rate_hz

    def measured(record):
        v = record.voltage_V
        share = (v - v.min()) / np.ptp(v)
        pole = math.exp(-1.0 / (0.3 * fs))                   # a 0.3 s mode, at rest at the first sample
        slow = signal.lfilter([1 - pole], [1, -pole], share, zi=[share[0] * pole])[0]
        return record.displacement_um + creep_sigma * pair.noise_um * slow

    d = diagnose(pair.train.voltage_V, measured(pair.train), fs,
                 validate=(pair.validation.voltage_V, measured(pair.validation), fs))
    if creep_sigma == 0.0:
        assert d.cause == "none" and d.causes == () and d.extended.model is d.baseline.model, d.why
        assert "model moves within the holds of the second record" in d.why, d.why
        assert "Without the holds the verdict would be" in d.why
    else:
        assert "creep" in d.causes, d.why
        assert "moves within the holds" not in d.why and "does not move within" not in d.why


def test_holds_that_move_add_the_cause_whose_model_follows_them_and_keep_the_delivered_model():
    """Truth: a Bouc-Wen actuator (outside the MPI class; outside-class seed 101) behind a lag; a
    staircase first, random triangles second.  Over the whole record the shape error mixes with the
    lag, and an input low-pass (rate-dependent hysteresis) lowered the out-of-sample error the most,
    so it alone was named.  Inside the staircase's holds the hysteresis part of every model stands
    still and what moves is the lag alone: the lag's model follows it to the noise, the input
    low-pass's does not, so the lag joins the verdict.  The input low-pass's model stays delivered:
    it predicts the second record better, and the third record (a sine sweep, never given) far
    better than the plain fit; the lag's model, fitted on the staircase, does not carry the
    hysteresis to the triangles (naming the lag alone delivered the plain fit)."""
    pair, d = _diagnose_outside_pair(101, "bouc_wen", "lag")
    assert pair.train.input_kind == "staircase"
    assert "rate_dependence" in d.causes and len(d.causes) > 1, d.why
    assert "the holds add rate_dependence to the causes named" in d.why, d.why
    motions = d.validation["holds_motion_sigma2"]
    assert motions["rate_dependence"] < 0.25 < motions["rate_dependent_hysteresis"] < motions["plain"], motions
    assert d.extended.cause == d.cause and d.extended.model is not d.baseline.model, d.why
    assert d.excitation is not None                      # the set gets the excitation that separates it

    def third_record_rms(model):
        test = pair.test
        settle = int(0.1 * pair.train.sample_rate_hz)
        return float(np.sqrt(np.mean((model.simulate(test.voltage_V) - test.clean_um)[settle:] ** 2)))

    assert third_record_rms(d.extended.model) < 0.5 * third_record_rms(d.baseline.model)


@pytest.mark.parametrize("seed", [96, 9])
def test_a_second_record_that_alone_shows_no_effect_is_no_effect_where_the_first_records_models_fail(seed):
    """Truth: actuators outside the MPI class, no effect.  Seed 96: a Preisach actuator (minor
    loops that are not congruent), a sine sweep first, band-limited noise second; seed 9: a
    Bouc-Wen actuator (loops that overshoot after a reversal), a sine sweep, then triangles.  The
    first record shows no effect out of sample; its MPI model does not carry to the second record's
    paths and leaves it far above its noise, which no candidate explains (`unexplained` before).
    Diagnosed on its own, 96's second record shows no effect either; 9's takes the overshoot on its
    constant-rate triangles for creep or a lag, which, fitted there, the sine sweep does not confirm.
    Either way the gap is the hysteresis part, and nothing is named.

    On the pinned kernels of tests/pin_kernels.sh the first record of 9 is fitted to within 0.31 σ²
    of its noise, so the second record's `unexplained` is set aside before the second record is
    diagnosed alone (the first record's candidates were fitted to noise): nothing is named by that
    rule instead, and the assertions follow the path taken."""
    from pysim.diagnosis.rules import NOISE_FRACTION

    _, d = _diagnose_outside_pair(seed, {96: "preisach", 9: "bouc_wen"}[seed], "none")
    assert d.cause == "none" and d.causes == () and d.extended.model is d.baseline.model, d.why
    assert d.cross_validation_cause == "none"
    if seed == 96 or d.validation["verdict_by"] == "each record alone":
        assert d.validation["verdict_by"] == "each record alone", d.why
        assert ("names nothing either" if seed == 96 else "nothing is confirmed") in d.why, d.why
        assert "Without the second record on its own the verdict would be unexplained" in d.why, d.why
    else:
        quiet = re.search(r"the first record leaves only ([0-9.]+) σ² above its noise", d.why)
        assert quiet and float(quiet.group(1)) < 2 * NOISE_FRACTION, d.why
        assert "so the second record's unexplained is not evidence of an effect" in d.why, d.why
    # the gap it describes is real: the first record's plain fit misses the second record by far more
    # than its noise
    assert d.validation["table"]["baseline"]["rms_pct"] > 1.0


@pytest.mark.parametrize("cause", ["slew_limit", "rate_dependent_hysteresis"])
def test_input_stages_are_recognised(plant, cause):
    if cause == "slew_limit":
        v = steps(plant, 10000, 4)
        x = slew_limit(v, 20e3, T)                 # 20 V/ms
    else:
        v = multisine(plant, 10000, 5)
        x = input_lowpass(v, 3 * T, T)
    d = diagnose(v, noisy(plant.simulate(x), 9), FS)
    assert cause in d.causes or (d.cause == "unexplained" and d.candidates[cause].significant), d.why
    fit = d.candidates[cause].fit
    assert isinstance(fit.model, InputStageModel)
    np.testing.assert_allclose(fit.model.simulate(d.voltage_V, fit.state), fit.prediction_um, atol=1e-9)


def test_an_input_lowpass_on_a_fast_record_predicts_a_slow_one_to_its_noise(plant):
    # a fast first record: a 50 ms low-pass leaves the operators part of the
    # range, and the plain fit's operator state absorbs part of the lag; the
    # second record, slow steps, takes the operators further
    tau = 0.05
    v1 = multisine(plant, 12000, 11)
    x1 = input_lowpass(v1, tau, T)
    assert np.ptp(x1) < 0.85 * np.ptp(v1)
    v2 = steps(plant, 8000, 12)
    y1, y2 = noisy(plant.simulate(x1), 13), noisy(plant.simulate(input_lowpass(v2, tau, T)), 14)
    d = diagnose(v1, y1, FS, validate=(v2, y2, FS))
    assert d.cause == "rate_dependent_hysteresis", d.why
    candidate = d.candidates["rate_dependent_hysteresis"]
    assert candidate.fit.parameters["input_time_constant_s"] == pytest.approx(tau, rel=0.05)
    # both records are predicted to their noise (σ: 0.2 % of each record's range)
    assert candidate.mse_um2 < 1.5 * (0.002 * np.ptp(y1)) ** 2
    assert candidate.validation["mse_um2"] < 2.0 * (0.002 * np.ptp(y2)) ** 2


def test_slew_limit_is_an_exact_rate_bound():
    v = np.r_[np.zeros(5), np.full(20, 10.0), np.zeros(20)]
    x = slew_limit(v, 2000.0, 1e-3)               # 2 V per sample
    assert np.max(np.abs(np.diff(x))) <= 2.0 + 1e-12
    np.testing.assert_allclose(x[5:10], [2, 4, 6, 8, 10])
    assert x[24] == 10.0 and x[30] == 0.0


def test_a_slew_limit_far_below_the_fastest_step_is_found_on_steps(plant):
    """Truth: full-span steps (each made in one sample, 100 V/ms and more at 2 kHz) into holds,
    behind an amplifier that follows at 1 V/ms: every step is a ramp of about 100 samples.  The
    slew rate is searched from the rate that crosses the span once in the record up to the fastest
    move, so it is found within 3 %; searched down to a 40th of the fastest move only (2.5 V/ms
    here), it was not, and the model left the ramps in the residual."""
    top = plant.voltage_range_V[1]
    levels = np.array([0.05, 0.9, 0.2, 0.7, 0.1, 0.95, 0.4, 0.6]) * top
    v = np.repeat(levels, 1200)
    rate_V_per_ms = 1.0
    y = noisy(slew_limited(plant, v, rate_V_per_ms), 7)
    assert np.max(np.abs(np.diff(v))) / T / 1e3 > 40 * rate_V_per_ms    # outside the old search range
    fitter = CandidateFitter(v, y, T)
    family = fitter.family("slew_limit", fitter.base())
    assert family.parameters["rate_V_per_ms"] == pytest.approx(rate_V_per_ms, rel=0.03), family.parameters
    fit = fitter.finish(family, fitter.fit(family))
    noise_um = 0.002 * np.ptp(y)
    assert np.mean((y - fit.prediction_um) ** 2) < 1.5 * noise_um**2


def test_the_spec_written_for_an_input_stage_holds_the_stage_and_predicts_a_new_input(plant, tmp_path):
    """``pysim diagnose --out`` for a slew limit: the spec's MODEL is the stage and then the plant, so
    run from the file on another staircase (other levels, never diagnosed) it follows the true actuator
    to within a few noise σ once the input has been near both ends of the range, where the part after
    the stage alone misses the ramps by far more."""
    top = plant.voltage_range_V[1]
    v = np.repeat(np.array([0.05, 0.9, 0.2, 0.7, 0.1, 0.95, 0.4, 0.6]) * top, 1200)
    y = noisy(slew_limited(plant, v, 1.0), 7)
    record = save_measured(MeasuredData(np.arange(v.size) * T, v, y, "synthetic"), tmp_path / "slewed.csv")
    spec = tmp_path / "slewed_ext.py"
    run = subprocess.run([sys.executable, "-m", "pysim.cli.main", "diagnose", str(record), "--out", str(spec)],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "cause slew_limit" in run.stdout, run.stdout
    model = load_spec(spec)
    assert isinstance(model, InputStageModel) and model.kind == "slew_limit"
    assert model.parameter / 1e3 == pytest.approx(1.0, rel=0.05)
    new_input = np.repeat(np.array([0.5, 0.15, 0.85, 0.3, 0.93, 0.07, 0.6]) * top, 1000)   # inside its range
    truth = slew_limited(plant, new_input, 1.0)
    # scored once the input has been near both ends of the record's range: before that, what "from rest"
    # leaves in the operators differs between a model fitted on 0.05-0.95 of the range and the actuator
    wiped = slice(5000, None)
    noise_um = 0.002 * np.ptp(y)
    assert np.sqrt(np.mean((model.simulate(new_input) - truth)[wiped] ** 2)) < 3 * noise_um
    assert np.sqrt(np.mean((model.plant.simulate(new_input) - truth)[wiped] ** 2)) > 30 * noise_um


@pytest.mark.parametrize("tau_s", [5e-3, 0.3e-3])
def test_input_lowpass_follows_a_ramped_step_as_the_closed_form(tau_s):
    """The input 0, 1, 1, ... is, linear between samples, a ramp over the first period and then
    held: y(T) = 1 − (τ/T)(1 − exp(−T/τ)), after it y_k = 1 − (1 − y(T)) exp(−(k − 1) T/τ) --
    monotone and with unit gain also for a low-pass shorter than a sample."""
    T = 1e-3
    x = input_lowpass(np.r_[0.0, np.ones(400)], tau_s, T)
    k = np.arange(1, 401)
    expected = np.r_[0.0, 1.0 - (tau_s / T) * -np.expm1(-T / tau_s) * np.exp(-(k - 1) * T / tau_s)]
    np.testing.assert_allclose(x, expected, atol=1e-12)
    assert np.all(np.diff(x) >= 0.0) and x[-1] == pytest.approx(1.0, abs=1e-12)


# ------------------------------------------------------------ decision and folds

def test_decide_follows_its_rules():
    s = 1.0
    # nothing beats the rate-independent models: none
    assert decide({"delay": 1.1, "creep": 1.05}, 1.2, 1.2, s, {})["cause"] == "none"
    # a candidate that beats the baseline but not the richer model is not named
    assert decide({"delay": 5.0}, 9.0, 5.1, 2.0, {})["cause"] == "none"
    # two candidates within the margin: a set, the simpler first
    d = decide({"delay": 2.0, "rate_dependence": 2.1, "creep": 6.0}, 30.0, 30.0, s,
               {"delay": 1, "rate_dependence": 2, "creep": 3})
    assert d["causes"] == ("delay", "rate_dependence")
    # the best removes less than half of the excess over the noise: unexplained
    d = decide({"creep": 20.0}, 30.0, 30.0, s, {"creep": 1})
    assert d["cause"] == "unexplained" and d["explained_share"] == pytest.approx(10 / 29)
    # from 1.5 σ² up to 3 σ² above the noise (a quiet sensor's class misfit), less than half of it: nothing
    d = decide({"drift": 2.5, "creep": 2.55}, 3.0, 3.0, s, {"drift": 1, "creep": 3})
    assert d["cause"] == "none" and d["not_most_of_misfit"] == ("drift", "creep") and not any(d["significant"].values())
    assert d["explained_share"] == pytest.approx(0.25) and "25 % of the 2 σ²" in d["text"]
    assert decide({"drift": 2.1}, 2.4, 2.4, s, {"drift": 1})["cause"] == "drift"     # 21 % of 1.4 σ²
    assert decide({"drift": 1.9}, 3.0, 3.0, s, {"drift": 1})["cause"] == "drift"     # 55 % of 2 σ²
    # the residual far above the noise and nothing significant: unexplained too
    assert decide({"creep": 30.0}, 30.0, 30.0, s, {})["cause"] == "unexplained"
    # among ties the simpler one is named first, unless the better one's advantage holds across the record
    tied = ({"delay": 2.1, "rate_dependence": 2.0}, 30.0, 30.0, s, {"delay": 1, "rate_dependence": 2})
    assert decide(*tied)["causes"] == ("delay", "rate_dependence")
    assert decide(*tied, outranks=lambda a, b: False)["causes"] == ("delay", "rate_dependence")
    asked = []
    d = decide(*tied, outranks=lambda a, b: asked.append((a, b)) or True)
    assert d["causes"] == ("rate_dependence", "delay") and asked == [("rate_dependence", "delay")]


def test_an_effect_near_the_noise_is_named_only_when_its_removal_holds_across_the_record():
    s = 1.0
    # 0.12 σ² above the noise, all of it removed, consistently: named
    assert decide({"creep": 1.0}, 1.12, 1.12, s, {}, consistent={"creep": True})["cause"] == "creep"
    # the same removal carried by a few stretches of the record: not named
    assert decide({"creep": 1.0}, 1.12, 1.12, s, {}, consistent={"creep": False})["cause"] == "none"
    # without the consistency evidence the noise margin alone decides
    assert decide({"creep": 1.0}, 1.12, 1.12, s, {})["cause"] == "none"
    # below the near-noise floor, or less than half of what is above the noise: not named
    assert decide({"creep": 1.0}, 1.05, 1.05, s, {}, consistent={"creep": True})["cause"] == "none"
    assert decide({"creep": 1.4}, 1.6, 1.6, s, {}, consistent={"creep": True})["cause"] == "none"
    # two consistent candidates near the noise: the tie margin is half of what the best removes
    d = decide({"delay": 1.0, "creep": 1.03, "drift": 1.1}, 1.2, 1.2, s, {"delay": 1, "creep": 3, "drift": 2},
               consistent={"delay": True, "creep": True, "drift": True})
    assert d["causes"] == ("delay", "creep")


def test_a_look_alike_within_the_margin_joins_the_set_even_if_its_own_removal_did_not_hold():
    # the errors of excitations seed 203 (a 1.5 σ delay on minor loops), in σ²: creep's removal held
    # across the record, the delay's (0.10 σ² against 0.12) did not; once creep shows an effect, the
    # delay explains it as well
    s = 1.0
    mse = {"creep": 1.048, "delay": 1.070, "rate_dependence": 1.069, "drift": 1.176, "slew_limit": 1.167}
    complexity = {"creep": 2, "delay": 1, "rate_dependence": 2, "drift": 1, "slew_limit": 1}
    consistent = {"creep": True, "delay": False, "rate_dependence": False, "drift": False, "slew_limit": False}
    d = decide(mse, 1.167, 1.167, s, complexity, consistent=consistent)
    # drift predicts worse than the rate-independent models and the slew limit no better: neither joins
    assert set(d["causes"]) == {"creep", "delay", "rate_dependence"}
    # the look-alikes join the set, not the significant ones: Occam's razor names the simplest
    assert d["significant"] == {**consistent}
    assert d["cause"] == "delay" and d["best"] == "creep"
    # unless the best one's advantage holds
    assert decide(mse, 1.167, 1.167, s, complexity, consistent=consistent,
                  outranks=lambda a, b: True)["cause"] == "creep"
    # a candidate beyond the margin (half of the 0.12 σ² creep removes) stays out
    far = decide({**mse, "delay": 1.12}, 1.167, 1.167, s, complexity, consistent=consistent)
    assert "delay" not in far["causes"]
    # and so does one within it that removes too little to be significant at all (independent seed 905:
    # a slew limit removed 0.21 σ² beside a lag's 0.36, under both ¼ σ² and half the 0.44 σ² excess)
    lag = decide({"rate_dependence": 1.083, "rate_dependent_hysteresis": 1.141, "slew_limit": 1.231}, 1.443, 1.443,
                 s, {"rate_dependence": 1, "rate_dependent_hysteresis": 1, "slew_limit": 1},
                 consistent={"rate_dependence": False, "rate_dependent_hysteresis": False, "slew_limit": False})
    assert lag["causes"] == ("rate_dependence", "rate_dependent_hysteresis")
    # where the operators stay in states the training blocks showed, the effect is asked to remain, not
    # each look-alike: one that removes nothing there joins while creep removes something
    seen = {"creep": 0.13, "delay": -0.01, "rate_dependence": 0.12, "drift": 0.0, "slew_limit": 0.0}
    assert set(decide(mse, 1.167, 1.167, s, complexity, consistent=consistent,
                      removed_where_states_seen=seen)["causes"]) == {"creep", "delay", "rate_dependence"}
    # and where creep's advantage vanishes there, nothing is named
    assert decide(mse, 1.167, 1.167, s, complexity, consistent=consistent,
                  removed_where_states_seen={**seen, "creep": 0.0})["cause"] == "none"
    # with nothing significant, nothing joins anything
    assert decide(mse, 1.167, 1.167, s, complexity, consistent={c: False for c in mse})["cause"] == "none"


@pytest.mark.parametrize("seed", [4, 5])
def test_coloured_noise_without_an_effect_names_nothing(plant, seed):
    """Sensor noise that is not white (an AR(1) part, correlation 0.5 per sample, twice the white
    part) has a larger variance than the sample-to-sample differences show, so the noise σ is
    underestimated: no candidate may be named near that noise for it."""
    v = multisine(plant, 10000, seed)
    y = plant.simulate(v)
    rng = np.random.default_rng(seed)
    e = rng.normal(0.0, 1.0, y.size)
    coloured = np.empty_like(e)
    coloured[0] = e[0]
    for k in range(1, e.size):
        coloured[k] = 0.5 * coloured[k - 1] + math.sqrt(1 - 0.25) * e[k]
    span = float(np.ptp(y))
    d = diagnose(v, y + 0.002 * span * coloured + 0.001 * span * rng.normal(0.0, 1.0, y.size), FS)
    assert d.cause == "none", d.why


def _pink_noise(n, sigma, rng):
    """Noise whose power falls as 1/f from the record's lowest frequency up (a sensor's slow
    wander at every time scale), of standard deviation ``sigma``: written here from its spectrum."""
    f = np.fft.rfftfreq(n)
    spectrum = rng.normal(size=f.size) + 1j * rng.normal(size=f.size)
    spectrum[0] = 0.0
    spectrum[1:] /= np.sqrt(f[1:])
    x = np.fft.irfft(spectrum, n)
    return sigma * x / x.std()


def test_slow_sensor_wander_is_not_named_a_delay_by_a_fit_that_raises_its_own_noise():
    """An independent record without an effect (band-limited noise input) whose sensor noise is
    1/f, not white: most of it is a slow wander no model of the catalogue follows.  The general
    model on the record's halves had named a delay that removed 97 % of the error above the noise,
    because the delay's blur of the fast input raised the σ estimated from its own residual 3.4
    times; weighed against one noise for all the fits, the delay fits worse than the model alone
    and no cause is named with confidence (the wander is left as unexplained or as nothing)."""
    import independent_records

    pair = independent_records.make_pair(1010, "none")
    record = pair.train
    y = record.clean_um + _pink_noise(record.clean_um.size, pair.truth.noise_sigma_um, np.random.default_rng(1015))
    d = diagnose(record.voltage_V, y, record.sample_rate_hz)
    assert d.cause in ("none", "unexplained"), d.why


def test_noise_correlated_over_samples_is_weighed_at_its_whole_variance_and_names_nothing(plant):
    """All of the sensor noise correlated from sample to sample (AR(1), φ = 0.8, as a sensor's own
    low-pass filter gives): the first differences show only sqrt(1 - φ) of its σ, and the plain fit
    was left 'unexplained' at four noise variances.  The noise is now measured where its differences
    level off, at its whole σ, and nothing is named."""
    v = multisine(plant, 10000, 1)
    y = plant.simulate(v)
    rng = np.random.default_rng(1)
    e = rng.normal(0.0, 1.0, y.size)
    coloured = np.empty_like(e)
    coloured[0] = e[0]
    for k in range(1, e.size):
        coloured[k] = 0.8 * coloured[k - 1] + math.sqrt(1 - 0.64) * e[k]
    sigma = 0.003 * float(np.ptp(y))
    d = diagnose(v, y + sigma * coloured, FS)
    assert d.cause == "none" and d.causes == (), d.why
    assert d.noise_um == pytest.approx(sigma * np.std(coloured), rel=0.1)


def test_removal_holds_when_it_is_spread_over_the_record_not_when_one_stretch_carries_it():
    rng = np.random.default_rng(3)
    n = 20000
    noise = rng.normal(0.0, 1.0, n)
    effect = 0.3 * np.sin(np.arange(n) / 40.0)          # 0.045 σ² spread over the whole record
    y = effect + noise
    assert removal_holds(y, np.zeros(n), effect)
    # a candidate that predicts the noise itself in one twentieth of the record removes about as much
    # on average (0.05 σ²), but from one stretch only
    lucky = np.zeros(n)
    lucky[:n // 20] = y[:n // 20]
    assert float(np.mean(y**2 - (y - lucky) ** 2)) > 0.04
    assert not removal_holds(y, np.zeros(n), lucky)
    # NaN (not scored) samples are left out; too few scored samples prove nothing
    half = np.where(np.arange(n) < n // 2, effect, np.nan)
    assert removal_holds(y, np.zeros(n), half)
    assert not removal_holds(y[:100], np.zeros(100), effect[:100])


def test_folds_score_only_inside_the_training_range():
    v = np.r_[np.linspace(0, 10, 1000), np.linspace(10, 20, 1000), np.linspace(20, 0, 1000)]
    folds = make_folds(v, 3, settle=10)
    for train, scored in folds:
        assert np.intersect1d(train, scored).size == 0
        assert scored.size == 0 or (v[scored].min() >= v[train].min() and v[scored].max() <= v[train].max())
        assert train.min() >= 10 and (scored.size == 0 or scored.min() >= 10)


def _play_operator_output_V(voltage_V, threshold_V, start_V=0.0):
    """The one-sided play operator written out (a second implementation, not the package's): the
    output follows the input when it falls below it and trails it by ``threshold_V`` when it rises."""
    out = np.empty(len(voltage_V))
    w = start_V
    for k, v in enumerate(voltage_V):
        w = max(v - threshold_V, min(v, w))
        out[k] = w
    return out


def test_folds_leave_out_samples_where_an_operator_leaves_the_states_training_showed():
    # the first half peaks at 6 V, the second at 9 V; coming down from 9 V, the operator of threshold
    # 3 V stays at 6 V until the input meets it, then follows it down to 3 V: from 6 V down to 3 V the
    # input is inside the first half's range, the operator above the 0-3 V the first half gave it
    # steps of 1/32 V, exact in binary: no step counts as larger than another
    v = np.r_[np.linspace(0, 6, 193), np.linspace(6, 0, 193)[1:], np.linspace(0, 9, 289)[1:],
              np.linspace(9, 0, 289)[1:]]
    w = _play_operator_output_V(v, 3.0)
    by_input = make_folds(v, 2)
    by_state = make_folds(v, 2, operator_outputs_V=w[:, None])
    for (train, scored_by_input), (same_train, scored) in zip(by_input, by_state):
        np.testing.assert_array_equal(train, same_train)
        margin = 1e-3 * np.ptp(v[train])
        inside = (w[scored_by_input] >= w[train].min() - margin) & (w[scored_by_input] <= w[train].max() + margin)
        np.testing.assert_array_equal(scored, scored_by_input[inside])
    # the second half held out: the input is scored from 6 V down, the operator only once it is back
    # at 3 V -- the 96 samples of the way down from 6 V to above 3 V go, and only they
    second_by_input, second = by_input[1][1], by_state[1][1]
    dropped = np.setdiff1d(second_by_input, second)
    assert dropped.size == 96
    assert np.all(np.diff(v[dropped]) < 0) and v[dropped].max() == 6.0 and v[dropped].min() > 3.0
    # the first half held out: every state it shows, the second half showed too
    np.testing.assert_array_equal(by_input[0][1], by_state[0][1])


def test_the_median_score_where_states_were_seen_leaves_out_blocks_that_score_a_handful_of_samples():
    from pysim.diagnosis.scoring import MIN_SCORED_PER_BLOCK, blocked_score, well_scored

    n = 1000
    y = np.zeros(4 * n)
    prediction = np.r_[np.full(n, 1.0), np.full(n, 2.0), np.full(n, 3.0), np.full(n, 10.0)]
    rows = np.arange(4 * n)
    blocks = np.array_split(rows, 4)
    few = blocks[3][:MIN_SCORED_PER_BLOCK - 1]
    folds = [(np.setdiff1d(rows, b), s) for b, s in zip(blocks, blocks[:3] + [few])]
    assert blocked_score(y, prediction, folds) == ([1.0, 4.0, 9.0, 100.0], pytest.approx(6.5))
    kept = well_scored(folds)
    assert [s.size for _, s in kept] == [n, n, n]
    assert blocked_score(y, prediction, kept)[1] == pytest.approx(4.0)   # the median of 1, 4 and 9
    enough = blocks[3][:MIN_SCORED_PER_BLOCK]
    assert len(well_scored(folds[:3] + [(folds[3][0], enough)])) == 4
    # fewer than two blocks of that many samples prove nothing: no score where states were seen
    assert well_scored([(t, s[:10]) for t, s in folds]) is None
    assert well_scored(folds[:1] + [(t, s[:10]) for t, s in folds[1:]]) is None


def test_a_cause_whose_advantage_vanishes_where_the_operator_states_were_seen_is_not_named():
    # creep removes 0.3 σ² against the rate-independent models (1.5 → 1.2 σ², 10.6 % of the RMS):
    # significant by the ¼ σ² and 5 % rules alone
    args = ({"creep": 1.2, "delay": 1.49}, 1.6, 1.5, 1.0, {"creep": 3, "delay": 1})
    assert decide(*args)["cause"] == "creep"
    # where the operators stay in states training showed, it removes nothing: nothing is named
    vetoed = decide(*args, removed_where_states_seen={"creep": -0.01, "delay": 0.01})
    assert vetoed["cause"] == "none" and vetoed["causes"] == () and not vetoed["significant"]["creep"]
    assert vetoed["not_where_states_seen"] == ("creep",)
    # a small share of its removal there keeps it (the rule asks that the advantage not vanish, not
    # that it repeat): 0.05 of the 0.3 σ² it removes
    kept = decide(*args, removed_where_states_seen={"creep": 0.05, "delay": 0.0})
    assert kept["cause"] == "creep" and kept["not_where_states_seen"] == ()
    # but not a trace that the median block's noise makes (independent seed 968: 0.6 % of the removal)
    trace = decide(*args, removed_where_states_seen={"creep": 0.002, "delay": 0.0})
    assert trace["cause"] == "none" and trace["not_where_states_seen"] == ("creep",)
    # it asks whether there is an effect, not which: a look-alike that removes nothing there stays in
    # the set while another member removes something
    tied = ({"creep": 1.2, "delay": 1.21}, 1.6, 1.5, 1.0, {"creep": 3, "delay": 1})
    assert set(decide(*tied)["causes"]) == {"creep", "delay"}
    both = decide(*tied, removed_where_states_seen={"creep": 0.2, "delay": -0.1})
    assert set(both["causes"]) == {"creep", "delay"} and both["not_where_states_seen"] == ()
    assert decide(*tied, removed_where_states_seen={"creep": 0.0, "delay": -0.1})["cause"] == "none"
    # a large excess that no cause then explains is still reported as unexplained
    big = decide({"creep": 3.0}, 6.0, 6.0, 1.0, {"creep": 3}, removed_where_states_seen={"creep": 0.0})
    assert big["cause"] == "unexplained" and big["not_where_states_seen"] == ("creep",)


# ------------------------------------------------------------ the micromanipulator record

@pytest.fixture(scope="module")
def backlash():
    data = load_measured(shipped_dataset("discrete_backlash"))
    return data, diagnose(data.voltage_V, data.displacement_um, data.sample_rate_hz, source="discrete_backlash")


def test_discrete_backlash_extension_is_admissible_and_keeps_the_static_gain(backlash):
    data, d = backlash
    fit = d.extended.fit
    j = d.as_json()
    measured = j["evidence"]["measured_gain_um_per_V"]
    assert j["extended"]["static_gain_um_per_V"] == pytest.approx(measured, rel=0.1)
    if fit.cause == "creep":
        assert min(fit.parameters["weights_um_per_V"]) >= 0
    stages = getattr(fit.model, "stages", None)
    if stages is not None:
        assert stages.delay_samples >= 0 and stages.static_gain() == pytest.approx(1.0, abs=1e-12)
    assert np.isfinite(fit.result.condition_number)


def test_discrete_backlash_extension_predicts_the_other_branch_at_least_as_well(backlash):
    """Trained on the falling branches only, the extended model predicts the rising ones (a part of
    the loop of another shape) at least as well as the plain fit trained the same way."""
    data, d = backlash
    from pysim.diagnosis.candidates import CandidateFitter

    v, y = d.voltage_V, d.displacement_um
    fitter = CandidateFitter(v, y, d.sample_period_s)
    rising = np.flatnonzero(np.gradient(v) > 0)
    falling = np.flatnonzero(np.gradient(v) < 0)
    rising = rising[rising > 200]
    extended_family = d.extended.fit.family
    baseline_family = d.baseline.fit.family
    if extended_family.cause in ("baseline", "richer"):
        pytest.fail(f"no extension to judge: {d.why}")
    err = {}
    for label, family in (("baseline", baseline_family), ("extended", extended_family)):
        prediction = fitter.fit(family, falling).prediction_um
        err[label] = float(np.sqrt(np.mean((y[rising] - prediction[rising]) ** 2)))
    assert err["extended"] <= err["baseline"] * 1.0001, err


def test_a_record_that_only_rises_is_not_refused_and_says_why(plant):
    """Upward steps only: no operator's hysteresis can be identified. identify refuses with the
    reason; without require_excitation it fits the record's own curve (every operator reported as
    not identifiable), so the six levels are met to the noise; diagnose names nothing and says why
    (with a second record that can identify the hysteresis, the roles swap: nothing to name there
    either)."""
    from pysim.identification.identify import IdentificationError, identify

    v = np.repeat(np.linspace(0.0, plant.voltage_range_V[1], 6), 700)
    clean = plant.simulate(v)
    y = noisy(clean, 10)
    with pytest.raises(IdentificationError, match="only rises"):
        identify(v, y)
    fit = identify(v, y, require_excitation=False)
    assert "only rises" in fit.unidentified_reason
    assert len(fit.not_identifiable_operators) == fit.model.n_operators - 1
    noise = 0.002 * np.ptp(clean)
    assert np.sqrt(np.mean((fit.prediction_um - clean) ** 2)) < 0.2 * noise
    w = multisine(plant, 5000, 11)
    d = diagnose(v, y, FS, validate=(w, noisy(plant.simulate(w), 12), FS))
    assert d.cause == "none" and d.causes == ()
    assert "cannot identify the hysteresis" in d.why


@pytest.mark.parametrize("input_kind, creeping, expected", [
    ("ramp", False, "none"), ("staircase", False, "none"), ("staircase", True, "creep")])
def test_a_one_way_record_names_only_what_its_holds_show(plant, input_kind, creeping, expected):
    """A record whose input only rises cannot identify the hysteresis, but its curve is a function
    of the input: the rate-independent reference must take it whole, or the curve's shape is blamed
    on an effect.  Truths: no effect on a ramp and on a staircase of seven holds (before, with
    a1 u³ + a2 u + offset as the reference, named creep, 32 σ² removed, and an input low-pass); a
    creep of 5 % of the displacement with a 0.2 s time constant, written out here, on the staircase,
    where it moves the displacement while the input holds (before: named nothing)."""
    import scipy.signal

    top = plant.voltage_range_V[1]
    v = np.linspace(0.0, top, 6000) if input_kind == "ramp" else np.repeat(np.linspace(0.0, top, 7), 1000)
    h = plant.simulate(v)
    if creeping:
        pole = math.exp(-T / 0.2)
        h = h + 0.05 * scipy.signal.lfilter([1 - pole], [1, -pole], h - h[0])
    d = diagnose(v, noisy(h, 31), FS)
    assert d.cause == expected, d.why
    assert "cannot identify the hysteresis" in d.why


def test_a_first_record_that_cannot_identify_the_hysteresis_swaps_roles_with_the_second(plant):
    """Truth: a 4-sample delay.  The first record is upward steps (no loop, so every model fitted on
    it would be judged on the second record for the hysteresis it never saw); the second, a
    multisine, identifies it.  The models are fitted on the second record and scored on the
    first, whose steps show the delay plainly: it is named, and the report says the roles swapped."""
    top = plant.voltage_range_V[1]
    v1 = np.repeat(np.linspace(0.0, top, 6), 700)
    v2 = multisine(plant, 8000, 21)
    y1, y2 = noisy(delayed(plant, v1, 4), 22), noisy(delayed(plant, v2, 4), 23)
    d = diagnose(v1, y1, FS, validate=(v2, y2, FS), source="steps.csv", validate_source="multisine.csv")
    assert d.records_swapped and d.as_json()["evidence"]["records_swapped"] is True
    assert d.source == "multisine.csv" and np.array_equal(d.voltage_V, v2)
    assert d.cause == "delay", d.why
    assert "roles are swapped" in d.why and "steps.csv cannot identify the hysteresis" in d.why
    assert d.validation["source"] == "steps.csv" and "roles are swapped" in d.validation["note"]
    from pysim.cli.commands.diagnose import format_text
    assert "records swapped: steps.csv cannot identify" in format_text(d, None, None)
    table = d.validation["table"]
    assert table["delay"]["rms_pct"] < 0.5 * table["baseline"]["rms_pct"]
    # a rich first record keeps its role
    assert not diagnose(v2, y2, FS, validate=(v1, y1, FS)).records_swapped


def test_a_hold_a_hair_below_the_fitted_range_is_scored_on_the_second_record():
    """A second record whose top hold stops 1e-6 of the span short of (or beyond) the first
    record's top is not an extrapolation: its samples are scored (leaving them out left only the
    rest level of a step record, where every model looks alike)."""
    from pysim.core.extended import ExtendedModel, StageSpec
    from pysim.core.model import HysteresisModel
    from pysim.diagnosis.candidates import CandidateFit

    h = HysteresisModel(0.0, 0.5, (0.0, 20.0), (0.0, 0.2), voltage_range_V=(0.0, 100.0))
    fit = CandidateFit("baseline", ExtendedModel(h, StageSpec(sample_period_s=1e-3)), None, {})
    v = np.concatenate((np.zeros(300), np.full(300, 100.0 - 1e-4), np.full(300, 100.0 + 1e-4)))
    s = score_on_record(fit, v, h.simulate(v), 1e-3, (0.0, 100.0))
    assert s["scored_samples"] == v.size - 2          # all but the two edge samples
    far = np.concatenate((np.zeros(300), np.full(300, 100.5)))
    assert score_on_record(fit, far, h.simulate(far), 1e-3, (0.0, 100.0))["scored_samples"] == 299


def _diagnose_outside_pair(seed: int, plant: str, effect: str):
    """``(pair, diagnosis)``: the outside-class pair of ``seed`` (checked to be of ``plant`` with
    ``effect``), its first record diagnosed and validated on its second."""
    import outside_class_records

    pair = outside_class_records.make_outside_pair(seed)
    assert pair.plant == plant and pair.effect == effect
    fs = pair.train.sample_rate_hz
    return pair, diagnose(pair.train.voltage_V, pair.train.displacement_um, fs,
                          validate=(pair.validation.voltage_V, pair.validation.displacement_um, fs))


def _record_rms(record, model) -> float:
    """RMS error (µm) of a model's prediction of a generated record against its noise-free
    displacement, after the record's settling window (the whole record when it has none, as the
    outside-class records)."""
    error = (model.simulate(record.voltage_V) - record.clean_um)[getattr(record, "settle_samples", 0):]
    return float(np.sqrt(np.mean(error**2)))


def _third_record_rms(pair, model) -> float:
    """:func:`_record_rms` on the pair's third record (never given to the diagnosis)."""
    return _record_rms(pair.test, model)


def test_the_model_delivered_is_refitted_on_both_records():
    """Truth (the independent generator's pair 258): creep of the hysteresis output (five modes,
    6 ms to 1.8 s), first record one sine from rest, second a decaying triangle.  One frequency
    pins a creep mode's weight only through a phase shift: fitted on the sine alone, creep's fastest
    mode takes 0.30 µm/V where the decaying triangle shows none.  Refitted on both records (modes
    and operator weights shared), the model predicts the third record (steps and sines; never
    given) far better than the fit on the sine alone, and both better than the plain fit.  (The
    model delivered is on ten operators: on the sine, creep's columns leave twenty undecided.)"""
    import independent_records

    pair = independent_records.make_pair(258)
    assert pair.truth.effect == "creep" and pair.train.input_kind == "sine"
    d = _validated(pair)
    assert d.cause == "creep" and d.fitted_on_both_records, d.why
    assert "refitted on both records" in d.why
    alone = d.candidates["creep"]
    assert d.extended.fit.parameters["time_constants_s"] == alone.fit.parameters["time_constants_s"]
    assert min(d.extended.fit.parameters["weights_um_per_V"]) > -1e-12          # still admissible (to rounding)
    # the first record itself is fitted about as well (its held-out blocks cost at most 0.08 σ² more)
    assert d.validation["delivered_first_rms_pct"] < 1.05 * alone.train_rms_pct
    rms = {label: _third_record_rms(pair, model) for label, model in
           (("plain", d.baseline.model), ("first record alone", alone.model), ("both records", d.extended.model))}
    assert rms["both records"] < 0.2 * rms["first record alone"] < 0.2 * rms["plain"], rms


def test_creep_outside_the_mpi_class_is_delivered_with_the_general_models_modes():
    """Truth (outside-class seed 51): a Bouc-Wen actuator with creep of its output, 4.8 % at 28 ms
    and 3.5 % at 0.57 s; first record random triangles, second band-limited noise.  Fitted with
    the MPI weights on the first record, creep's modes also bend the loops the MPI model misses
    (fast modes with large shares), and that model predicts the third record (a sine sweep,
    never given) several times worse than the plain fit.  The general model, which holds the
    Bouc-Wen loops, finds modes near the truth on both records; with them the model delivered
    predicts the third record better than the plain fit."""
    pair, d = _diagnose_outside_pair(51, "bouc_wen", "creep")
    assert d.cause == "creep", d.why
    assert d.validation["delivered_creep_modes"] == "general model on both records"
    assert "modes delivered are the general model's" in d.why
    parameters = d.extended.fit.parameters
    assert parameters["driven_by"] == "displacement"
    shares, taus = np.asarray(parameters["shares"]), np.asarray(parameters["time_constants_s"])
    truth = pair.effect_parameters
    # admissible, and near the truth: the total share within a third of it, every mode with more
    # than 1 % of the displacement at 10 ms or slower
    assert np.all(shares >= 0) and abs(shares.sum() - sum(truth["shares"])) < sum(truth["shares"]) / 3, parameters
    assert np.all(taus[shares > 0.01] >= 0.01), parameters
    rms = {label: _third_record_rms(pair, model) for label, model in
           (("plain", d.baseline.model), ("first record alone", d.candidates["creep"].model),
            ("delivered", d.extended.model))}
    assert rms["delivered"] < 0.8 * rms["plain"] < 0.8 * rms["first record alone"], rms


def test_creep_that_the_general_model_gives_no_weight_gives_way_to_none():
    """Truth (outside-class seed 73): a Bouc-Wen actuator without an effect; first record random
    triangles, second a sine sweep.  The MPI models' creep takes 16 % of the 1.7 σ² their richer
    rate-independent fit leaves above the noise, and since a best candidate must remove half of a
    misfit of 1.5-3 σ² it is not named on the first record.  Before that rule creep was named, its
    model carried to the second record, and the general model with creep, fitted on both records,
    turned it down by putting no weight on any creep mode (every creep record of the outside-class
    seeds 0-146 gets 2-13 % there): that premise is asserted here too.  Nothing is named, and the
    plain fit is delivered."""
    from pysim.diagnosis.diagnose import NO_CREEP_WEIGHT
    from pysim.diagnosis.preisach import GeneralModelParts

    pair, d = _diagnose_outside_pair(73, "bouc_wen", "none")
    assert d.cause == "none" and not d.causes, d.why
    assert "the best candidate, creep, removes only" in d.why and "half is asked" in d.why, d.why
    assert d.extended.fit is d.baseline.fit
    T = 1 / pair.train.sample_rate_hz
    both = GeneralModelParts(pair.train.voltage_V, pair.train.displacement_um, T,
                             pair.validation.voltage_V, pair.validation.displacement_um, T)
    assert max(both.fit("creep").creep["weights"]) <= NO_CREEP_WEIGHT


def test_a_refit_on_both_records_that_the_first_records_blocks_reject_is_not_delivered():
    """Truth (the independent generator's pair 1): a 28.6 Hz resonance (ζ = 0.49), first record one
    sine, second steps and sines.  The sine finds the resonance at 26.5 Hz; with that shape fixed,
    the second record's steps bend the shared operator weights to alternating signs, and the first
    record's held-out blocks are predicted 1.5 σ² worse.  So the fit on the first record alone is
    delivered: it predicts the third record (a decaying triangle; never given) at 0.03 of the
    plain fit's RMS error, where the joint fit would reach only 0.28."""
    import independent_records

    pair = independent_records.make_pair(1)
    assert pair.truth.effect == "rate_dependence"
    d = _validated(pair)
    assert d.cause == "rate_dependence" and not d.fitted_on_both_records, d.why
    assert d.extended.model is d.candidates["rate_dependence"].model
    assert _third_record_rms(pair, d.extended.model) < 0.1 * _third_record_rms(pair, d.baseline.model)


def test_the_member_of_a_set_delivered_is_the_one_that_fitted_on_both_records_predicts_both_best():
    """Truth (the third generator's seed 12): creep of the hysteresis output (0.14-0.3 s), 3.2 σ on
    the first record (decaying triangles after an unknown history), where a drift draws the same
    decaying envelope: the set {creep, drift} is named.  The second record (a multisine from rest)
    does not show the creep, and drift's model fitted on the first record predicts it a little
    better; fitted on both records, creep's structure predicts the held-out blocks of both better,
    so creep's refitted model is delivered.  It predicts the third record (holds then sines, never
    given) far better than the plain fit, which drift's model did not."""
    import third_generator_records

    records = third_generator_records.make_third_records(12)
    assert records.truth == "creep"
    first, second, third = records.records
    fs = records.sample_rate_hz
    d = diagnose(first.voltage_V, first.displacement_um, fs, validate=(second.voltage_V, second.displacement_um, fs))
    assert set(d.causes) == {"creep", "drift"}, d.why
    assert d.cause == "creep" and d.fitted_on_both_records, d.why
    chosen = d.validation["delivered_both_sigma2"]
    assert all(chosen["drift"][j] - chosen["creep"][j] >= 0.08 for j in (0, 1))
    settled = slice(int(0.1 * fs), None)

    def third_rms(model):
        return float(np.sqrt(np.mean((np.asarray(model.simulate(third.voltage_V))[settled]
                                      - third.clean_um[settled]) ** 2)))

    assert third_rms(d.extended.model) < 0.5 * third_rms(d.baseline.model)
    assert third_rms(d.candidates["drift"].model) > third_rms(d.baseline.model)


@pytest.mark.parametrize("seed", [24, 4])
def test_a_general_rate_independent_model_on_both_records_tells_a_loop_shape_from_an_effect(seed):
    """Truth: Preisach actuators (minor loops that are not congruent), seed 24 without an effect,
    seed 4 with a 2 ms lag; triangles first, band-limited noise second.  The MPI models leave both
    `unexplained` (neither record alone, nor the swap, decides).  A discrete Preisach model fitted
    on both records together reaches the noise of each without an effect on seed 24 (nothing is
    named), and only with the lag on seed 4."""
    _, d = _diagnose_outside_pair(seed, "preisach", {24: "none", 4: "lag"}[seed])
    assert d.validation["verdict_by"] == "general model on both records", d.why
    assert "by the two records together" in d.why, d.why
    assert "Without the general model the verdict would be unexplained" in d.why, d.why
    left = d.validation["general_model_left_sigma2"]
    if seed == 24:
        assert d.cause == "none" and d.causes == () and d.extended.model is d.baseline.model, d.why
        assert left["none"] < 0.25
    else:
        assert d.causes == ("rate_dependence",), d.why
        assert left["rate_dependence"] == min(left.values()) and left["rate_dependence"] < 0.05 * left["none"], left


def test_a_named_cause_whose_model_misses_the_second_record_is_judged_by_the_general_model():
    """Truth: outside-class seed 60, a Preisach actuator with a 2 ms lag.  The MPI models name an
    input low-pass first (alone, or with creep as a look-alike: the same code gave the one in an
    earlier CI run and the other in a later fresh install), whose model, fitted on the first
    record, leaves the second far above its noise: the general model on both records, which holds
    a lag and an input low-pass alike, leaves 0.03 σ² with the lag and 21 σ² with the input
    low-pass, so the lag is named, and the third record (never given) is predicted better than by
    the plain fit."""
    pair, d = _diagnose_outside_pair(60, "preisach", "lag")
    assert d.causes == ("rate_dependence",) and d.validation["verdict_by"] == "general model on both records", d.why
    assert re.search(r"rate_dependent_hysteresis(, creep)? (was|were) named, but rate_dependent_hysteresis's model, "
                     r"fitted on the first record, leaves the second [0-9.]+ σ² above its noise", d.why), d.why
    assert "Without the general model the verdict would be rate_dependent_hysteresis" in d.why, d.why
    left = d.validation["general_model_left_sigma2"]
    assert left["rate_dependence"] < 0.25 and left["rate_dependent_hysteresis"] > 10 * left["rate_dependence"], left
    assert _third_record_rms(pair, d.extended.model) < _third_record_rms(pair, d.baseline.model)


def test_a_none_the_plain_fit_cannot_carry_to_the_second_record_is_put_to_the_general_model():
    """Truth: outside-class seed 34, a Preisach actuator with creep.  The MPI models name nothing (no
    candidate beats their loop-shape error on the second record), yet their plain fit of the first
    record leaves the second more than its noise above it: the general model on both records, which
    holds the Preisach hysteresis, is asked, and only creep brings both records to their noise.
    Creep is named, and the third record (never given) is predicted better than by the plain fit."""
    pair, d = _diagnose_outside_pair(34, "preisach", "creep")
    assert d.causes == ("creep",) and d.validation["verdict_by"] == "general model on both records", d.why
    assert "nothing was named, but the plain fit of the first record leaves the second" in d.why, d.why
    assert "Without the general model nothing would be named: no candidate lowers" in d.why, d.why
    left = d.validation["general_model_left_sigma2"]
    assert left["creep"] == min(left.values()) and left["creep"] < 0.25 * left["none"], left
    fit = d.extended.fit
    assert fit.cause == "creep", d.why
    # admissible: modes of one sign, none cancelling another
    weights = np.asarray(fit.parameters["shares" if fit.parameters["driven_by"] == "displacement"
                                       else "weights_um_per_V"])
    tiny = 1e-9 * np.max(np.abs(weights))
    assert np.all(weights >= -tiny) or np.all(weights <= tiny), fit.parameters
    assert _third_record_rms(pair, d.extended.model) < _third_record_rms(pair, d.baseline.model)


def test_a_verdict_of_the_mpi_models_gives_way_when_one_rate_independent_actuator_fits_both_records():
    """Truth: outside-class seed 49, a Bouc-Wen actuator without an effect (minor loops that
    neither close nor wipe out), band-limited noise first, triangles second.  The record does not
    determine the richer operator set (its cycle prediction spread is above 0.5 σ and above the
    plain fit's), so the candidates are fitted on the plain set, and the best of them removes only a
    third of what the plain fit leaves out of sample: the MPI models alone would say `unexplained`
    (on the richer set they had named a lag, whose model left the second record far above its
    noise).  The general model on both records, whose Bouc-Wen operators hold this hysteresis, fits
    each record to its noise without any effect: nothing is named, and the plain fit is delivered."""
    from pysim.identification.determinacy import DETERMINED_SPREAD

    _, d = _diagnose_outside_pair(49, "bouc_wen", "none")
    assert d.cause == "none" and d.causes == (), d.why
    assert d.validation["verdict_by"] == "general model on both records", d.why
    plain_spread, richer_spread = d.rate_independent_spreads
    assert richer_spread > max(DETERMINED_SPREAD, plain_spread), d.rate_independent_spreads
    assert "Without the general model the verdict would be unexplained" in d.why, d.why
    assert "one rate-independent actuator explains both" in d.why, d.why
    assert d.extended.model is d.baseline.model
    assert d.validation["general_model_left_sigma2"]["none"] < 0.25


def test_a_bouc_wen_actuator_without_an_effect_left_unexplained_by_the_mpi_models_names_nothing():
    """Truth: outside-class seed 137, a Bouc-Wen actuator without an effect, triangles first, a sine
    sweep second.  The MPI models leave the first record unexplained (8.3 σ² out of sample, no
    candidate significant); the general model with its Bouc-Wen operators fits both records to
    their noise: nothing is named, and the plain fit is delivered."""
    _, d = _diagnose_outside_pair(137, "bouc_wen", "none")
    assert d.cause == "none" and d.causes == (), d.why
    assert d.validation["verdict_by"] == "general model on both records", d.why
    assert "Without the general model the verdict would be unexplained" in d.why, d.why
    assert d.extended.model is d.baseline.model


def test_without_a_second_record_an_unexplained_verdict_delivers_the_plain_fit():
    """Truth (outside-class pair 40): a Preisach actuator (2-D weight, no effect) on triangles,
    given alone.  The MPI models leave its loop shape far above the noise and no cause explains
    most of it: `unexplained`.  The best candidate's model is fitted to that shape, and it predicted
    the third record (a sine sweep, never given) 10.6 times worse than the plain fit; nothing on one
    record tests that, so the plain fit is delivered, and it predicts the third record no worse."""
    import outside_class_records
    from pysim.diagnosis.report import summary_markdown

    pair = outside_class_records.make_outside_pair(40)
    assert pair.plant == "preisach" and pair.effect == "none"
    d = diagnose(pair.train.voltage_V, pair.train.displacement_um, pair.train.sample_rate_hz)
    assert d.cause in ("unexplained", "none"), d.why      # a named effect would be a false alarm
    assert d.extended.cause == "baseline" and d.gain_pct == 0.0
    assert f"Model delivered: the plain fit (no cause is named: `{d.cause}`)" in summary_markdown(d)
    assert _third_record_rms(pair, d.extended.model) <= _third_record_rms(pair, d.baseline.model)
    if d.cause == "unexplained":
        assert "the model delivered is the plain fit" in d.why.lower(), d.why
        # what it would have delivered: worse on the input it never saw
        best = min(d.candidates.values(), key=lambda ev: ev.mse_um2)
        assert _third_record_rms(pair, best.model) > 2 * _third_record_rms(pair, d.baseline.model)


def _diagnose_outside_record_alone(seed: int, plant: str, effect: str):
    """``(pair, diagnosis)``: the outside-class pair of ``seed`` (checked to be of ``plant`` with
    ``effect``), its first record diagnosed alone."""
    import outside_class_records

    pair = outside_class_records.make_outside_pair(seed)
    assert pair.plant == plant and pair.effect == effect
    return pair, diagnose(pair.train.voltage_V, pair.train.displacement_um, pair.train.sample_rate_hz)


@pytest.mark.parametrize("seed, plant", [(8, "preisach"), (73, "bouc_wen")])
def test_without_a_second_record_an_actuator_outside_the_mpi_class_without_an_effect_names_nothing(seed, plant):
    """Truth (outside-class pairs 8 and 73): a Preisach and a Bouc-Wen actuator without an effect, on
    triangles, given alone.  The MPI models leave their loop shape far above the noise and no cause
    explains most of it (they were left `unexplained`, counted a false alarm).  One rate-independent
    actuator of any Preisach or Bouc-Wen shape explains both halves of the record to their noise:
    nothing is named, the verdict says how and what it does not rule out, and the plain fit is
    delivered."""
    from pysim.diagnosis.preisach import NOISE_FRACTION

    _, d = _diagnose_outside_record_alone(seed, plant, "none")
    assert d.cause == "none" and d.causes == (), d.why
    assert "by the general model on the record's two halves" in d.why, d.why
    assert "Without the general model the verdict would be unexplained" in d.why, d.why
    assert "not ruled out" in d.why, d.why
    general = d.as_json()["evidence"]["general_model"]
    assert general["fitted_on"] == "the record's two halves" and general["cause"] == "none"
    assert general["left_sigma2"]["none"] <= NOISE_FRACTION
    assert d.extended.model is d.baseline.model


def test_without_a_second_record_the_general_model_sees_the_input_of_a_left_out_start():
    """Truth (outside-class pair 184): a Preisach actuator without an effect, on band-limited noise,
    given alone.  Its first 13 samples are left out as a start transient that no rate-independent
    state explains, and the MPI models leave the rest `unexplained`.  The record starts at the top
    of its range, where every operator is fixed.  With those samples cut off, the general model's
    thresholds reached 99.5 V of the 150 V range and missed the large loops: the halves stood at
    1.18 and 1.33 of their noise, and the record was left `unexplained` (a false alarm).  The
    left-out start is not scored, but its input still moves the operators: the model alone fits
    both halves to their noise, and nothing is named."""
    from pysim.diagnosis.preisach import NOISE_FRACTION

    pair, d = _diagnose_outside_record_alone(184, "preisach", "none")
    evidence = d.as_json()["evidence"]
    assert evidence["start_excluded_samples"] > 0
    assert pair.train.voltage_V[0] == pair.train.voltage_V.max()
    assert d.cause == "none" and d.causes == (), d.why
    assert "Without the general model the verdict would be unexplained" in d.why, d.why
    general = evidence["general_model"]
    assert general["cause"] == "none" and general["left_sigma2"]["none"] <= NOISE_FRACTION
    assert d.extended.model is d.baseline.model


def test_without_a_second_record_a_named_cause_whose_model_misses_the_record_gives_way_to_the_general_model():
    """Truth (outside-class pair 25): a Bouc-Wen actuator without an effect, on band-limited noise,
    given alone.  The MPI models named creep (a false alarm whose model predicted the third record
    worse than the plain fit), and creep's own model leaves the record several σ² above its noise.
    The general model alone, with one sensor, fits both halves of the record to their noise: nothing
    is named, and the plain fit is delivered."""
    from pysim.diagnosis.rules import NEAR_NOISE_FRACTION, UNEXPLAINED_LEVEL

    pair, d = _diagnose_outside_record_alone(25, "bouc_wen", "none")
    assert d.cause == "none" and d.causes == (), d.why
    assert "Without the general model the verdict would be creep" in d.why, d.why
    left = re.search(r"creep's model leaves the record ([0-9.]+) σ² above its noise", d.why)
    assert left and float(left.group(1)) >= UNEXPLAINED_LEVEL, d.why
    general = d.as_json()["evidence"]["general_model"]
    assert general["cause"] == "none" and general["left_sigma2"]["none"] <= NEAR_NOISE_FRACTION
    assert d.extended.model is d.baseline.model
    assert _third_record_rms(pair, d.extended.model) <= _third_record_rms(pair, d.candidates["creep"].model)


def test_without_a_second_record_a_named_cause_gives_way_to_the_effect_the_general_model_needs():
    """Truth (outside-class pair 85): a Bouc-Wen actuator with a lag, on band-limited noise, given
    alone.  The MPI models named creep, whose own model leaves the record far above its noise.  On
    the general model fitted on the record's halves, the lag alone brings each half to its noise, and
    the named set holds no lag: the lag is named (a delay with it, which that input cannot tell
    apart) and its model delivered, which predicts a third input the diagnosis never saw better than
    the plain fit and than creep's model.  (Pair 29, a lag on a sine sweep, went this way on the
    machine the test was first written on; on the pinned kernels of tests/pin_kernels.sh the MPI
    models name its lag directly.)"""
    from pysim.diagnosis.preisach import NOISE_FRACTION
    from pysim.diagnosis.rules import UNEXPLAINED_LEVEL

    pair, d = _diagnose_outside_record_alone(85, "bouc_wen", "lag")
    assert d.cause == "rate_dependence" and "creep" not in d.causes, d.why
    assert "Without the general model the verdict would be creep" in d.why, d.why
    left = re.search(r"creep's model leaves the record ([0-9.]+) σ² above its noise", d.why)
    assert left and float(left.group(1)) >= UNEXPLAINED_LEVEL, d.why
    general = d.as_json()["evidence"]["general_model"]
    assert general["cause"] == "rate_dependence" and general["left_sigma2"]["rate_dependence"] <= NOISE_FRACTION
    assert d.extended.cause == "rate_dependence"
    delivered = _third_record_rms(pair, d.extended.model)
    assert delivered < _third_record_rms(pair, d.baseline.model)
    assert delivered < _third_record_rms(pair, d.candidates["creep"].model)


def test_without_a_second_record_an_effect_the_general_model_needs_is_named_and_the_plain_fit_delivered():
    """Truth (outside-class pair 28): a Preisach actuator with a lag, on a sine sweep, given alone.
    The MPI models leave the record unexplained (their loop shape and the lag together).  On the
    general model fitted on the record's two halves, the lag is what brings both halves to their
    noise (a sweep's rates differ): it is named.  Its MPI model, fitted with the MPI weights, would
    carry their shape error too, so the plain fit is delivered."""
    from pysim.diagnosis.preisach import NOISE_FRACTION
    from pysim.diagnosis.report import summary_markdown

    _, d = _diagnose_outside_record_alone(28, "preisach", "lag")
    assert "rate_dependence" in d.causes, d.why
    general = d.as_json()["evidence"]["general_model"]
    assert general["cause"] in d.causes and general["left_sigma2"]["rate_dependence"] <= NOISE_FRACTION
    assert general["left_sigma2"]["none"] > 10.0           # far from explained without the lag
    assert d.extended.model is d.baseline.model
    assert "the model delivered is the plain fit" in d.why, d.why
    assert "is named by the general model on the record's two halves" in summary_markdown(d)


def test_without_a_second_record_a_none_whose_plain_fit_misses_the_record_is_put_to_the_general_model():
    """Truth (outside-class pair 42): a Preisach actuator with creep of its output, on a sine sweep,
    given alone.  The MPI models name nothing: their loop shape takes up the creep as far as the
    record shows it, yet the plain fit misses held-out samples by more than the noise.  On the general
    model fitted on the record and scored on its two halves, creep brings each half to its noise and
    the model alone does not: creep is named.  The model delivered takes its modes from that general
    model, and predicts a third input the diagnosis never saw better than the plain fit and than the
    creep fitted with the MPI weights."""
    from pysim.diagnosis.preisach import NOISE_FRACTION
    from pysim.diagnosis.diagnose import PLAIN_MISS_LEVEL

    pair, d = _diagnose_outside_record_alone(42, "preisach", "creep")
    assert d.cause == "creep", d.why
    assert "Without the general model nothing would be named" in d.why, d.why
    left = re.search(r"the plain fit leaves the record's held-out samples ([0-9.]+) σ² above its noise", d.why)
    assert left and float(left.group(1)) >= PLAIN_MISS_LEVEL, d.why
    general = d.as_json()["evidence"]["general_model"]
    assert general["cause"] == "creep" and general["left_sigma2"]["creep"] <= NOISE_FRACTION
    assert general["left_sigma2"]["none"] > 1.0
    assert "Creep's modes delivered are the general model's" in d.why, d.why
    delivered = _third_record_rms(pair, d.extended.model)
    assert delivered < _third_record_rms(pair, d.baseline.model)
    assert delivered < _third_record_rms(pair, d.candidates["creep"].model)


def test_without_a_second_record_a_creep_the_general_model_gives_no_weight_gives_way_to_it():
    """Truth (outside-class pair 89): a Bouc-Wen actuator without an effect, on a sine sweep, given
    alone.  The general model with creep, fitted on the record's halves, gives no weight to any
    creep mode, and alone it fits both halves to their noise: nothing is named and the plain fit is
    delivered, whatever the MPI models said first.

    On the machine this test was first written on, the MPI models named creep (its own model leaves
    the record under 3 σ², so that rule does not ask), which predicted a third input worse than the
    plain fit; the rule on the creep weight turned it into `none`.  On the pinned kernels of
    tests/pin_kernels.sh the MPI models name nothing on this record, and the general model is asked
    because the plain fit misses held-out samples by more than 1 σ²; no outside-class record of seeds
    0-191 given alone reaches the creep-weight rule there.  The assertions follow the path taken."""
    from pysim.diagnosis.diagnose import NO_CREEP_WEIGHT, PLAIN_MISS_LEVEL
    from pysim.diagnosis.preisach import NOISE_FRACTION, creep_on_halves

    pair, d = _diagnose_outside_record_alone(89, "bouc_wen", "none")
    train = pair.train
    assert max(creep_on_halves(train.voltage_V, train.displacement_um,
                               1 / train.sample_rate_hz).creep["weights"]) <= NO_CREEP_WEIGHT
    assert d.cause == "none" and d.causes == (), d.why
    assert d.extended.model is d.baseline.model
    general = d.as_json()["evidence"]["general_model"]
    assert general["left_sigma2"]["none"] <= NOISE_FRACTION, general
    if "Without the general model the verdict would be creep" in d.why:
        assert general["cause"] == "none", general
        assert "puts no weight on any creep mode" in d.why, d.why
        assert _third_record_rms(pair, d.extended.model) < _third_record_rms(pair, d.candidates["creep"].model)
    else:
        # nothing was named; the plain fit's miss asked the general model, and nothing stands
        assert general["cause"] in (None, "none"), general
        left = re.search(r"the plain fit leaves the record's held-out samples ([0-9.]+) σ² above its noise", d.why)
        assert left and float(left.group(1)) >= PLAIN_MISS_LEVEL, d.why
        assert "one rate-independent actuator explains both" in d.why, d.why


def test_without_a_second_record_an_effect_whose_model_misses_the_record_is_put_to_the_general_model():
    """Truth (outside-class pair 10): a Preisach actuator with creep, on triangles, given alone.  The
    MPI models name an effect other than creep (a slew limit tied with an input low-pass, or
    rate-dependent hysteresis, depending on which operator set the fast stages are fitted on),
    whose own model leaves the record over a hundred σ² above its noise.  On one record's halves
    the general model judges that effect too (where it can hold it): creep brings each half to its
    noise, a slew limit takes nothing, and creep is named.  Its model predicts a third input better
    than the effect first named (0.62x rate-dependent hysteresis's RMS, 0.25x the slew limit's; about
    even with the plain fit, 1.02x: there the Preisach loop shape, which no MPI model holds, dominates)."""
    from pysim.diagnosis.preisach import NOISE_FRACTION
    from pysim.diagnosis.rules import UNEXPLAINED_LEVEL

    pair, d = _diagnose_outside_record_alone(10, "preisach", "creep")
    named = re.search(r"(\w+) was named, but \1's model leaves the record ([0-9.]+) σ² above its noise", d.why)
    assert named, d.why
    first_named = named.group(1)
    assert first_named != "creep" and float(named.group(2)) >= UNEXPLAINED_LEVEL, d.why
    assert d.cause == "creep" and first_named not in d.causes and "slew_limit" not in d.causes, d.why
    general = d.as_json()["evidence"]["general_model"]
    assert general["cause"] == "creep" and general["left_sigma2"]["creep"] <= NOISE_FRACTION
    assert general["left_sigma2"]["slew_limit"] >= 0.9 * general["left_sigma2"]["none"]
    # the general model holds no rate-dependent hysteresis (its entry is then empty); what it holds
    # of the effect first named takes nothing
    left_by_first = general["left_sigma2"].get(first_named)
    assert left_by_first is None or left_by_first >= 0.9 * general["left_sigma2"]["none"], general
    assert d.extended.cause == "creep"
    assert _third_record_rms(pair, d.extended.model) < 0.7 * _third_record_rms(pair, d.candidates[first_named].model)


def test_without_a_second_record_a_creep_model_that_misses_the_record_takes_the_general_models_modes():
    """Truth (outside-class pair 75): a Bouc-Wen actuator with creep, on band-limited noise, given
    alone.  Creep is named, but its model, fitted with the MPI weights, leaves the record's held-out
    samples over 1 σ² above its noise: its modes take up the loop shape the MPI model misses, and
    it predicted a third input several times worse than the plain fit.  The model delivered takes
    its modes from the general model on the record's halves and predicts that input better than the
    plain fit."""
    from pysim.diagnosis.diagnose import PLAIN_MISS_LEVEL

    pair, d = _diagnose_outside_record_alone(75, "bouc_wen", "creep")
    assert d.cause == "creep", d.why
    assert d.candidates["creep"].mse_um2 / d.noise_um**2 - 1.0 >= PLAIN_MISS_LEVEL
    # put to the general model for that too: alone it fits the halves (it takes up creep as a loop
    # shape), which does not turn a creep into `none`
    assert "the general model alone takes up creep as a loop shape too" in d.why, d.why
    assert "Creep's modes delivered are the general model's, fitted on the record and scored on its two halves" in d.why
    delivered = _third_record_rms(pair, d.extended.model)
    assert delivered < _third_record_rms(pair, d.baseline.model)
    assert delivered < 0.5 * _third_record_rms(pair, d.candidates["creep"].model)


def test_without_a_second_record_a_creep_that_stands_by_what_the_general_model_alone_leaves_takes_its_modes():
    """Truth (outside-class pair 35): a Bouc-Wen actuator with creep of its output, on band-limited
    noise, given alone.  Creep is named; its own model, fitted with the MPI weights, leaves the
    record more than 3 σ² above its noise.  The general model alone fits the record's halves within
    their noise, so no effect was fitted there, and the name stands by the little it leaves above
    the noise.  Creep's own modes took up the loop shape the MPI model misses (a third input, a
    staircase the diagnosis never saw, predicted 1.8 times worse than by the plain fit); the model
    delivered takes its modes from the general model with creep on the halves, and predicts that
    input better than the plain fit."""
    from pysim.diagnosis.rules import UNEXPLAINED_LEVEL

    pair, d = _diagnose_outside_record_alone(35, "bouc_wen", "creep")
    assert d.cause == "creep", d.why
    assert d.candidates["creep"].mse_um2 / d.noise_um**2 - 1.0 >= UNEXPLAINED_LEVEL
    assert "that would leave nothing for creep: the name stands" in d.why, d.why
    assert "Creep's modes delivered are the general model's, fitted on the record and scored on its two halves" in d.why
    parameters = d.extended.fit.parameters
    assert parameters["driven_by"] == "displacement" and min(parameters["shares"]) >= 0.0
    delivered = _third_record_rms(pair, d.extended.model)
    assert delivered < _third_record_rms(pair, d.baseline.model)
    assert delivered < 0.5 * _third_record_rms(pair, d.candidates["creep"].model)


def test_without_a_second_record_a_creep_model_that_misses_the_record_gives_way_to_the_effect_it_hid(monkeypatch):
    """Truth (outside-class pair 142): a Preisach actuator with a delay, on a sine sweep, given
    alone.  The MPI models name creep, whose own model leaves the record 4.6 σ² above its noise.  A
    named creep that misses the record by 1 σ² or more but less than ``UNEXPLAINED_LEVEL`` is put to
    the general model on the record's halves, where only another effect may replace it (the model
    alone takes up creep as a loop shape on one record): here the delay brings each half to its
    noise, creep does not, and the named set held no delay, so the delay is named (with its
    look-alikes) and its model predicts a third input the diagnosis never saw better than the plain
    fit and than creep's model.

    The band's upper edge is raised to 5 σ² so that this record falls into it: the record that
    reached the band where the test was first written (outside-class pair 87, a Bouc-Wen delay, creep
    2.6 σ²) is named {lag, delay} by the MPI models directly on the pinned kernels of
    tests/pin_kernels.sh, and no outside-class record of seeds 0-191 given alone falls into the band
    with another effect on the halves there."""
    import importlib

    from pysim.diagnosis.diagnose import PLAIN_MISS_LEVEL

    # the module, not the function the package exports under the same name
    diagnosis_module = importlib.import_module("pysim.diagnosis.diagnose")
    from pysim.diagnosis.preisach import NOISE_FRACTION

    monkeypatch.setattr(diagnosis_module, "UNEXPLAINED_LEVEL", 5.0)
    pair, d = _diagnose_outside_record_alone(142, "preisach", "delay")
    assert "delay" in d.causes and "creep" not in d.causes, d.why
    assert "Without the general model the verdict would be creep" in d.why, d.why
    left = d.candidates["creep"].mse_um2 / d.noise_um**2 - 1.0
    assert PLAIN_MISS_LEVEL <= left < diagnosis_module.UNEXPLAINED_LEVEL
    general = d.as_json()["evidence"]["general_model"]
    assert general["left_sigma2"]["delay"] <= NOISE_FRACTION < general["left_sigma2"]["creep"]
    assert d.extended.cause in d.causes
    delivered = _third_record_rms(pair, d.extended.model)
    assert delivered < _third_record_rms(pair, d.baseline.model)
    assert delivered < _third_record_rms(pair, d.candidates["creep"].model)


def test_a_history_floor_makes_the_model_delivered_run_from_rest_and_predict_a_new_input():
    """Outside-class seed 271 (a Bouc-Wen actuator with a 0-150 V amplifier and a delay; its first record
    starts at 92 V and reaches 0 V at sample 2506).  Without a floor the top operator's start state had
    been fitted at -13.3 V, which only a history below 0 V leaves, and the delay's model, simulated from
    rest on a third input the diagnosis never saw, missed the actuator's noise-free response worse than
    the plain fit did (1.86 times its RMS error).  Since a start state whose columns the delay makes
    dependent drops out of the fit through the stage instead of failing it, the fit without a floor
    predicts the third input better too.  Told that the amplifier's lowest output is 0 V, the same cause
    is named, every start state is one a history above 0 V leaves, and the model delivered predicts the
    third input several times better than the plain fit."""
    import outside_class_records

    pair = outside_class_records.make_outside_pair(271)
    first, second, third = pair.train, pair.validation, pair.test
    settle = int(0.1 * third.sample_rate_hz)

    def third_rms(model):
        return float(np.sqrt(np.mean((model.simulate(third.voltage_V)[settle:] - third.clean_um[settle:]) ** 2)))

    ratio = {}
    for floor in (None, 0.0):
        d = diagnose(first.voltage_V, first.displacement_um, first.sample_rate_hz,
                     validate=(second.voltage_V, second.displacement_um, second.sample_rate_hz), history_floor_V=floor)
        assert d.cause == "delay", d.why
        ratio[floor] = third_rms(d.extended.model) / third_rms(d.baseline.model)
        if floor is not None:
            assert np.all(np.asarray(d.extended.fit.state.operators) >= -1e-12)
    assert ratio[None] < 0.5 and ratio[0.0] < 0.5, ratio


def test_a_history_floor_above_a_records_lowest_voltage_is_refused_naming_the_record(plant):
    from pysim.diagnosis.errors import DiagnosisError

    v = multisine(plant, 3000, 1)
    y = noisy(plant.simulate(v), 1)
    lowest = int(np.argmin(v))
    assert v[lowest] < 5.0
    with pytest.raises(DiagnosisError, match=r"^a\.csv: the history floor, 5 V, is above the record's lowest "
                                             rf"voltage, {re.escape(f'{v[lowest]:g}')} V at sample {lowest}:"):
        diagnose(v, y, 1000.0, source="a.csv", history_floor_V=5.0)
    with pytest.raises(DiagnosisError, match=r"^second record: the history floor, -5 V, is above"):
        diagnose(v, y, 1000.0, validate=(v - 10.0, y, 1000.0), history_floor_V=-5.0)
    with pytest.raises(DiagnosisError, match="finite"):
        diagnose(v, y, 1000.0, history_floor_V=float("inf"))


def test_a_delay_longer_than_ten_samples_is_within_the_general_models_reach():
    """Truth (the independent generator's pair 795): a 20-sample (10 ms) delay after an MPI plant
    of 27 operators; the first record, one sine from rest, hides it below the noise, the second (a
    chirp) shows it at about 75 times the noise.  Delay is named by the second record, and the
    general model on both records then judged it: its delay search stopped at ten samples, so the
    delay left 104 σ² there and a rate-dependent hysteresis, which took it up, was named instead
    (its model predicts the third record at 0.30 times the plain fit's RMS error, the delay's at
    0.03).  The general model now searches as far as the first record's own delay search."""
    import independent_records

    from pysim.diagnosis.candidates import longest_delay_samples
    from pysim.diagnosis.preisach import GeneralModelParts

    pair = independent_records.make_pair(795)
    assert pair.truth.effect == "delay" and round(pair.truth.effect_parameters["delay_samples"]) == 20
    first, second = pair.train, pair.validation
    parts = GeneralModelParts(first.voltage_V, first.displacement_um, 1 / first.sample_rate_hz,
                              second.voltage_V, second.displacement_um, 1 / second.sample_rate_hz)
    grid = parts._delay_grid_s()
    shortest = min(first.voltage_V.size, second.voltage_V.size)
    assert grid[-1] == pytest.approx(longest_delay_samples(shortest) / first.sample_rate_hz)
    assert np.all(grid[1:] / grid[:-1] <= 2.0 + 1e-12)
    d = _validated(pair)
    assert d.cause == "delay" and d.causes == ("delay",), d.why
    assert d.extended.fit.parameters["delay_samples"] == pytest.approx(20.0, abs=1.0)
    assert _third_record_rms(pair, d.extended.model) < 0.1 * _third_record_rms(pair, d.baseline.model)


def test_an_extension_whose_columns_leave_the_richer_weights_undecided_is_delivered_on_the_baselines_operators():
    """Truth (the excitation benchmark's seed 132): creep of 4 % at 0.4 s after an MPI plant, seen
    through a square wave whose edges are the only samples between its two bands of levels.  The
    record decides the richer plain fit (20 operators) well enough for it to be the base, but with
    creep's modes fitted beside its operators the weights between the bands are left to the edges'
    few samples: -0.91 and +0.65 µm/V side by side, a spread of about 10³ σ in the prediction of a
    full-range cycle (:meth:`CandidateFitter.prediction_spread`).  That model predicted a third
    input (a multisine over the whole range) 2.6 times worse than the plain fit.  Creep is still
    named by the candidates as cross-validated on twenty operators, but its model delivered is
    fitted on the baseline's ten, where the record decides it, and predicts the third input no worse
    than the plain fit."""
    bench = _excitation_benchmark()

    rec = bench.make_records(132)
    assert (rec["kind"], rec["effect"]) == ("square", "creep")
    first = rec["train"]
    fitter = CandidateFitter(first["voltage_V"], first["displacement_um"], 1 / bench.SAMPLE_RATE_HZ)
    assert fitter.richer_determined                   # the trap: the plain richer fit is decided
    d = diagnose(first["voltage_V"], first["displacement_um"], bench.SAMPLE_RATE_HZ)
    assert d.cause == "creep", d.why
    # the richer plain fit was the base and creep was named on it; the model delivered is on the baseline's operators
    assert d.richer.mse_um2 < d.baseline.mse_um2 and "the best rate-independent model, the richer" in d.why
    named = d.candidates["creep"]
    assert named.fit.family.n_operators == d.richer.fit.family.n_operators
    assert d.extended.fit.family.n_operators == d.baseline.fit.family.n_operators < d.richer.fit.family.n_operators
    assert fitter.prediction_spread(named.fit) > 100.0 > 2.0 > fitter.prediction_spread(d.extended.fit)
    assert "creep's model delivered is fitted on the plain fit's 10 operators" in d.why, d.why
    error = _excitation_third_record_errors(bench, rec, d)
    assert error["delivered"] <= error["plain"], error


def test_creep_that_moves_the_holds_of_a_staircase_is_named_by_them():
    """Truth (the excitation benchmark's seed 160, first record alone): creep of 4 % at 0.4 s after
    an MPI plant, seen through a staircase of 35 levels held 0.23 s each, 9 σ on the record.  The fits
    absorb most of it between the holds: out of sample creep removes 0.17 σ² of the 0.25 the blocks
    ask, and nothing was named.  In the holds, where a rate-independent actuator stands still
    whatever its loop shape, the plain fit's residual moves by about 0.16 σ² over some 15 000 degrees
    of freedom, many standard errors from none; creep's model takes up all of that motion and the
    other candidates almost none.  Creep is named by the holds, and its model predicts a third input
    (a multisine from rest) better than the plain fit."""
    bench = _excitation_benchmark()

    rec = bench.make_records(160)
    assert (rec["kind"], rec["effect"]) == ("staircase", "creep")
    first = rec["train"]
    d = diagnose(first["voltage_V"], first["displacement_um"], bench.SAMPLE_RATE_HZ)
    assert d.cross_validation_cause == "none"                 # the blocks alone name nothing
    assert d.causes == ("creep",), d.why
    assert "named by the holds of the input" in d.why
    moving = d.as_json()["evidence"]["moving_holds"]
    assert moving["t"] > 3.0 and moving["motion_sigma2"]["plain"] > 0.08
    assert abs(moving["motion_sigma2"]["creep"]) < 0.25 * moving["motion_sigma2"]["plain"]
    error = _excitation_third_record_errors(bench, rec, d)
    assert error["delivered"] < 0.7 * error["plain"], error


def test_a_richer_set_the_record_does_not_decide_is_no_base_even_beside_an_undecided_baseline():
    """Truth (the excitation benchmark's seed 201, first record alone): a two-sample delay after an
    MPI plant, 0.74 σ on band-limited noise over the full range.  Neither plain fit is decided by the
    record: ten operators predict a full-range cycle to several σ, twenty to less but still above
    DETERMINED_SPREAD.  Twenty had been the base because they were the less loose of the two, and the
    delay's model on them predicted a multisine 2.6 times worse than the plain fit; where the record
    decides neither set, the simpler one is the base."""
    from pysim.identification.determinacy import DETERMINED_SPREAD

    bench = _excitation_benchmark()
    rec = bench.make_records(201)
    assert (rec["kind"], rec["effect"]) == ("band_noise", "delay")
    first = rec["train"]
    d = diagnose(first["voltage_V"], first["displacement_um"], bench.SAMPLE_RATE_HZ)
    plain_spread, richer_spread = d.rate_independent_spreads
    assert plain_spread > richer_spread > DETERMINED_SPREAD, d.rate_independent_spreads
    assert d.richer_determined is False
    assert "delay" in d.causes, d.why
    assert all(ev.fit.family.n_operators == d.baseline.fit.family.n_operators for ev in d.candidates.values())
    error = _excitation_third_record_errors(bench, rec, d)
    assert error["delivered"] < 1.2 * error["plain"], error
    # and the user is told that no model of this record predicts another input well
    assert "The record does not decide how a rate-independent model predicts a new input" in d.why, d.why
    assert error["plain"] > 5 * 100 * bench.NOISE_SHARE               # as the sentence says: loosely


def test_a_delay_near_the_noise_stays_in_the_set_its_look_alike_named():
    """Truth (the excitation benchmark's seed 203, first record alone): a delay of two samples after a
    perturbed MPI plant, 1.5 σ on minor loops about mid-range.  Out of sample creep (two modes of a few
    milliseconds: a lag) removes 0.12 σ² and its removal holds across the record; the delay removes
    0.10 σ², within the tie margin, but its own removal does not hold, and creep alone was named.  The
    delay explains the record as well as creep does, so the set holds it."""
    bench = _excitation_benchmark()

    rec = bench.make_records(203)
    assert (rec["kind"], rec["effect"]) == ("minor_loops", "delay")
    first = rec["train"]
    d = diagnose(first["voltage_V"], first["displacement_um"], bench.SAMPLE_RATE_HZ)
    assert "delay" in d.causes and "creep" in d.causes, d.why
    # the delay's removal alone did not hold across the record: it joined as creep's look-alike
    assert not d.candidates["delay"].significant and d.candidates["creep"].significant
    assert "explain it as well" in d.why
    # minor loops decide both operator sets (a cycle predicted to well under 1 σ): no warning that the
    # record's models predict other inputs loosely
    assert max(d.rate_independent_spreads) < 1.0
    assert "does not decide how a rate-independent model predicts" not in d.why


def test_a_creep_whose_own_model_explains_both_records_keeps_its_own_modes():
    """Truth (the excitation benchmark's seed 105): creep of 4 % at 0.4 s after a perturbed MPI
    plant, first record a sine sweep down from the top of the range, second record another
    excitation.  Creep's own model (modes fitted with the MPI weights) leaves the first record's
    held-out blocks 0.7 σ² and the second record 1.3 σ² above the noise: it explains both.  The
    general model's modes had replaced its own (2.8 % at 0.31 s, and a spurious 3.1 % at 2.7 s that
    trades with the sensor offset), and that model predicted a third input from rest 3.3 times worse
    than the plain fit.  With its own modes the model delivered predicts it better than the plain fit."""
    bench = _excitation_benchmark()

    rec = bench.make_records(105)
    assert (rec["kind"], rec["effect"]) == ("sweep_down", "creep")
    first, second = rec["train"], rec["validation"]
    d = diagnose(first["voltage_V"], first["displacement_um"], bench.SAMPLE_RATE_HZ,
                 validate=(second["voltage_V"], second["displacement_um"], bench.SAMPLE_RATE_HZ))
    assert d.cause == "creep", d.why
    assert "delivered_creep_modes" not in d.validation and "general model's" not in d.why
    own = d.candidates["creep"]
    assert own.mse_um2 / d.noise_um**2 - 1.0 < 1.0
    assert own.validation["mse_um2"] / d.validation["noise_um"] ** 2 - 1.0 < 3.0
    error = _excitation_third_record_errors(bench, rec, d)
    assert error["delivered"] < error["plain"], error


def test_an_advantage_that_lives_in_the_hold_levels_of_a_staircase_is_not_named():
    # the numbers of the fourth generator's seed 224 (no effect, a staircase after a history), in σ²:
    # the plain fit leaves 3.03 in the median block, an input low-pass 2.14 and a slew limit 2.35; the
    # input low-pass removes 44 % of the 2.03 σ² above the noise, which names nothing since a best
    # candidate must remove half of a misfit of 1.5-3 σ²
    own = decide({"rate_dependent_hysteresis": 2.14, "slew_limit": 2.35}, 3.03, 25.0, 1.0,
                 {"rate_dependent_hysteresis": 1, "slew_limit": 1})
    assert own["cause"] == "none" and own["not_most_of_misfit"] == ("rate_dependent_hysteresis", "slew_limit")
    # with removals above half of it (1.08 and 1.03 σ²), the hold levels' rule is what turns them down:
    # with each hold's level taken out of every model's residual neither removes anything
    args = ({"rate_dependent_hysteresis": 1.95, "slew_limit": 2.0}, 3.03, 25.0, 1.0,
            {"rate_dependent_hysteresis": 1, "slew_limit": 1})
    assert set(decide(*args)["causes"]) == {"rate_dependent_hysteresis", "slew_limit"}
    levels = {"rate_dependent_hysteresis": -0.04, "slew_limit": 0.0}
    vetoed = decide(*args, removed_beside_hold_levels=levels)
    assert vetoed["cause"] == "none" and vetoed["not_beside_hold_levels"] == ("rate_dependent_hysteresis",
                                                                              "slew_limit")
    assert vetoed["not_where_states_seen"] == ()
    # a true slew limit on a staircase (seed 232) keeps most of its removal after the step: named
    kept = decide({"slew_limit": 2.19}, 4.18, 13.0, 1.0, {"slew_limit": 1},
                  removed_beside_hold_levels={"slew_limit": 2.55})
    assert kept["cause"] == "slew_limit" and kept["not_beside_hold_levels"] == ()
    # one test passed by a significant cause is enough for the others to stay: it asks whether there
    # is an effect, whichever of the two tests turned a look-alike down
    mixed = decide(*args, removed_where_states_seen={"rate_dependent_hysteresis": 0.5, "slew_limit": 0.0},
                   removed_beside_hold_levels={"rate_dependent_hysteresis": 0.5, "slew_limit": 0.0})
    assert mixed["cause"] == "rate_dependent_hysteresis" and mixed["not_beside_hold_levels"] == ()
    # each test by its own: one cause lost where the states were seen, the other beside the levels
    split = decide(*args, removed_where_states_seen={"rate_dependent_hysteresis": 0.0, "slew_limit": 0.5},
                   removed_beside_hold_levels={"rate_dependent_hysteresis": 0.5, "slew_limit": 0.0})
    assert split["cause"] == "none"
    assert split["not_where_states_seen"] == ("rate_dependent_hysteresis",)
    assert split["not_beside_hold_levels"] == ("slew_limit",)


def test_a_stage_that_leaves_the_samples_it_moves_as_they_were_is_not_named():
    # independent pair 2017 with its noise at 0.03 % of the range, in σ²: a slew limit that moves one
    # sample removed 13.9 of the 15.8 the plain fit leaves in the median block, and left the plain fit's
    # 6.8 there as it was; turned down by itself, whatever the look-alikes do
    args = ({"slew_limit": 1.82, "rate_dependent_hysteresis": 24.9}, 15.75, 16.5, 1.0,
            {"slew_limit": 1, "rate_dependent_hysteresis": 1})
    assert decide(*args)["cause"] == "slew_limit"
    turned = decide(*args, unexplained_where_moved=("slew_limit",))
    assert turned["cause"] != "slew_limit" and turned["not_where_moved"] == ("slew_limit",)
    assert not turned["significant"]["slew_limit"]
    # a look-alike that removes enough by itself is still named, and the turned-down stage joins no set
    args = ({"slew_limit": 1.82, "rate_dependent_hysteresis": 2.0}, 15.75, 16.5, 1.0,
            {"slew_limit": 1, "rate_dependent_hysteresis": 1})
    assert set(decide(*args)["causes"]) == {"slew_limit", "rate_dependent_hysteresis"}
    kept = decide(*args, unexplained_where_moved=("slew_limit",))
    assert kept["causes"] == ("rate_dependent_hysteresis",) and kept["not_where_moved"] == ("slew_limit",)
    # a cause too small to matter is not reported as turned down
    small = decide({"slew_limit": 15.7}, 15.75, 16.5, 1.0, {"slew_limit": 1}, unexplained_where_moved=("slew_limit",))
    assert small["cause"] != "slew_limit" and small["not_where_moved"] == ()


def _quiet_pair(seed: int, effect: str, noise_share: float):
    """An independent-generator pair with its noise replaced by white noise of ``noise_share`` of the
    first record's range (a sensor far quieter than the generator draws)."""
    import independent_records

    pair = independent_records.make_pair(seed, effect)
    rng = np.random.default_rng(seed)
    train = pair.train
    quiet = train.clean_um + rng.normal(0.0, noise_share * np.ptp(train.clean_um), train.clean_um.size)
    return pair, quiet


def test_a_quiet_record_without_an_effect_is_not_given_a_slew_limit_by_one_sample():
    """Truth (the independent generator's pair 2017 drawn without an effect, its noise at 0.03 % of
    the range):
    steps and sines after an unknown history at 10 kHz.  The record decides the weights only loosely,
    and a 479 V/ms slew limit that moves one sample of a 497 V/ms step by 1.8 V refitted them to predict
    the held-out blocks 13.9 σ² better, leaving the plain fit's miss at that sample as it was.  Not
    named; a true slew limit on steps and sines (pair 2007 drawn with one) removes nearly all of the plain fit's miss
    where it moves the input and is still named."""
    pair, quiet = _quiet_pair(2017, "none", 3e-4)
    assert pair.truth.effect == "none"
    train = pair.train
    d = diagnose(train.voltage_V, quiet, train.sample_rate_hz)
    assert "slew_limit" not in d.causes and d.cause in ("none", "unexplained"), d.why
    without, with_stage, samples = d.candidates["slew_limit"].explained_where_moved
    assert samples <= 10 and with_stage > 0.5 * without, d.candidates["slew_limit"].explained_where_moved
    assert "where slew_limit's stage moves the input" in d.why, d.why
    reported = d.as_json()["evidence"]["candidates"]["slew_limit"]["miss_where_stage_moves_over_noise"]
    assert reported == {"without_stage": without, "with_stage": with_stage, "samples": samples}

    import independent_records

    true_pair = independent_records.make_pair(2007, "slew_limit")
    assert true_pair.truth.effect == "slew_limit" and true_pair.train.input_kind == "steps_sines"
    t = true_pair.train
    named = diagnose(t.voltage_V, t.displacement_um, t.sample_rate_hz)
    assert named.cause == "slew_limit", named.why
    without, with_stage, _ = named.candidates["slew_limit"].explained_where_moved
    assert with_stage < 0.1 * without


def test_a_cause_must_remove_more_than_the_noise_of_the_measured_voltage():
    """decide: a candidate that removes 0.2 σ² near the noise is significant on a clean voltage and
    not when the voltage's own noise adds 0.23 σ² to every model's error."""
    mse, complexity = {"rate_dependent_hysteresis": 1.1}, {"rate_dependent_hysteresis": 1}
    consistent = {"rate_dependent_hysteresis": True}
    clean = decide(mse, 1.3, 1.3, 1.0, complexity, consistent)
    noisy = decide(mse, 1.3, 1.3, 1.0, complexity, consistent, input_noise_um2=0.23)
    assert clean["cause"] == "rate_dependent_hysteresis" and noisy["cause"] == "none"


def test_a_noisy_voltage_channel_is_no_input_low_pass():
    """Independent seed 1002 (no effect, a decaying sine at 10 kHz) with the voltage measured with white
    noise of 0.2 % of its range (an amplifier's monitor): an input low-pass filters that noise out of the
    prediction and had been named with its look-alikes; the voltage's noise is read to 10 %, the why
    says what it adds, and nothing is named.  The clean voltage names nothing either."""
    import independent_records

    pair = independent_records.make_pair(1002, "none")
    record = pair.train
    v, y, fs = record.voltage_V, record.displacement_um, record.sample_rate_hz
    sigma_V = 0.002 * float(np.ptp(v))
    noisy = v + np.random.default_rng(1002).normal(0.0, sigma_V, v.size)
    d = diagnose(noisy, y, fs)
    assert d.cause == "none", d.why
    assert d.voltage_noise_V == pytest.approx(sigma_V, rel=0.1)
    assert "The voltage holds white noise" in d.why
    assert d.as_json()["evidence"]["voltage_noise_V"] == pytest.approx(sigma_V, rel=0.1)
    clean = diagnose(v, y, fs)
    assert clean.cause == "none" and clean.voltage_noise_V < 1e-4 * float(np.ptp(v))


def test_a_cause_that_a_static_output_curvature_explains_as_well_is_not_named():
    """decide: a lag that removes 0.46 σ² near the noise is named against the rate-independent models
    alone, not when the same models with a curved output remove 0.54 σ² (a sensor that bows); it is
    named again when the curvature removes only 0.1 σ², and one cause beyond the curvature keeps the
    verdict for all (the test asks whether there is an effect, as where the states were seen)."""
    mse, complexity, consistent = {"rate_dependence": 1.12}, {"rate_dependence": 1}, {"rate_dependence": True}
    plain = decide(mse, 1.58, 1.58, 1.0, complexity, consistent)
    assert plain["cause"] == "rate_dependence"
    bowed = decide(mse, 1.58, 1.58, 1.0, complexity, consistent,
                   removed_beyond_output_curvature={"rate_dependence": -0.08})
    assert bowed["cause"] == "none" and bowed["not_beyond_output_curvature"] == ("rate_dependence",)
    curved_a_little = decide(mse, 1.58, 1.58, 1.0, complexity, consistent,
                             removed_beyond_output_curvature={"rate_dependence": 0.36})
    assert curved_a_little["cause"] == "rate_dependence"
    two = {"rate_dependence": 1.12, "delay": 1.3}
    kept = decide(two, 1.58, 1.58, 1.0, {"rate_dependence": 1, "delay": 1}, {c: True for c in two},
                  removed_beyond_output_curvature={"rate_dependence": 0.36, "delay": -0.2})
    assert kept["cause"] == "rate_dependence" and kept["not_beyond_output_curvature"] == ()


def _bowed(displacement_um, bow_fraction):
    """The displacement read by a sensor whose reading bows by ``bow_fraction / 4`` of the range at mid
    range (zero at both ends): a quadratic static nonlinearity after the actuator."""
    y = np.asarray(displacement_um, dtype=float)
    z = (y - y.min()) / np.ptp(y)
    return y + bow_fraction * np.ptp(y) * (z * z - z)


def test_a_sensor_that_bows_is_no_lag_on_one_sine():
    """Independent seeds 1007 and 1011 (one sine each, no effect) read by a sensor that bows by 2.5 % of
    the range: the loop's two branches bend alike, which no MPI model draws and a lag or a slew limit
    partly imitates (named, with look-alikes, before the curvature reference); nothing is named, the
    why says what the curvature explains, and the JSON reports each candidate's removal beyond it."""
    import independent_records

    for seed in (1007, 1011):
        record = independent_records.make_pair(seed, "none").train
        assert record.input_kind == "sine"
        d = diagnose(record.voltage_V, _bowed(record.displacement_um, 0.1), record.sample_rate_hz)
        assert d.cause == "none", (seed, d.why)
        assert "static curvature of its output" in d.why, d.why
        reported = d.as_json()["evidence"]["candidates"]["rate_dependence"]
        assert reported["mse_removed_beyond_output_curvature_over_noise"] < 0.0

    # a true lag on the same sine (4.5 σ that no rate-independent model absorbs), read by the same
    # sensor, is still named: a curvature bends both branches alike and cannot widen the loop
    lagged = independent_records.make_pair(1007, "rate_dependence").train
    d = diagnose(lagged.voltage_V, _bowed(lagged.displacement_um, 0.1), lagged.sample_rate_hz)
    assert "rate_dependence" in d.causes, d.why


def _rate_thresholds_pair(seed, form, growth_at_fast_rate):
    """The independent generator's records of ``seed`` (its inputs) through a PI plant of its own kind
    whose thresholds grow with the input's rate, written here: ``r_i (1 + g |v̇|)`` (``form``
    "proportional") or ``r_i + g' |v̇|`` for every operator, the one at 0 V included ("additive", the
    rate-dependent PI models of the literature); the rate a central difference, the growth at the
    first record's 95th-percentile rate ``growth_at_fast_rate`` (of the thresholds, or of the top
    threshold / 10), the same physical growth on the second record.  Returns the first record's
    voltage, displacement (0.2 % noise) and rate, the second record, its noise-free displacement, and g."""
    import independent_records

    pair = independent_records.make_pair(seed, "none")
    first, second = pair.train, pair.validation
    v, rate_hz = first.voltage_V, first.sample_rate_hz
    plant = independent_records.make_plant(np.random.default_rng(seed + 77),
                                           voltage_range_V=(float(v.min()), float(v.max())))
    r0 = np.asarray(plant.thresholds_V, dtype=float)
    fast = float(np.quantile(np.abs(np.gradient(v) * rate_hz), 0.95))
    growth = growth_at_fast_rate / fast * (1.0 if form == "proportional" else float(r0.max()) / 10.0)

    def respond(voltage_V):
        u = voltage_V - plant.voltage_range_V[0]
        rate = np.abs(np.gradient(u) * rate_hz)
        w, out = np.zeros(r0.size), np.empty((u.size, r0.size))
        for k, uk in enumerate(u):
            r = r0 * (1.0 + growth * rate[k]) if form == "proportional" else r0 + growth * rate[k]
            w = np.maximum(uk - r, np.minimum(uk, w))
            out[k] = w
        return plant.a1_um_per_V3 * u**3 + plant.a2_um_per_V * u + out @ plant.weights_um_per_V

    h = respond(v)
    y = h + np.random.default_rng(seed).normal(0.0, 0.002 * np.ptp(h), h.size)
    return v, y, rate_hz, second, respond(second.voltage_V), growth


@pytest.mark.parametrize("seed, form", [(1009, "proportional"), (1005, "proportional"), (1007, "additive")])
def test_thresholds_that_grow_with_the_rate_are_named_and_predict_another_input(seed, form):
    """Records whose loops widen with frequency because the thresholds grow with the input's rate (a
    multisine, a chirp, a sine): before that structure was in the catalogue a multisine and the chirp
    were `unexplained` at 5-16 σ.  Named rate-dependent hysteresis with that structure, and its model,
    fitted on the first record alone, predicts the second record (another input, noise-free truth)
    at most half as badly as the plain fit; the proportional growth is found within a factor of two
    (the truth's rate a central difference, the model's a backward one)."""
    v, y, rate_hz, second, truth2, growth = _rate_thresholds_pair(seed, form, 0.5)
    d = diagnose(v, y, rate_hz)
    assert d.cause == "rate_dependent_hysteresis", d.why
    parameters = d.extended.fit.parameters
    assert "threshold_growth_s_per_V" in parameters, parameters
    if form == "proportional":
        assert 0.5 < parameters["threshold_growth_s_per_V"] / growth < 2.0, (parameters, growth)
    part = slice(second.settle_samples, None)
    errors = {which: float(np.sqrt(np.mean((getattr(d, which).model.simulate(second.voltage_V)[part]
                                             - truth2[part]) ** 2))) for which in ("baseline", "extended")}
    assert errors["extended"] < 0.5 * errors["baseline"], errors
    assert d.reasons["rate_dependent_hysteresis"].startswith("thresholds that grow with the input rate")


# ------------------------------------------------------------ two effects at once

def test_a_record_with_two_effects_says_more_is_in_it_than_the_cause_named(plant):
    """One cause is named at a time.  A record of a delay of 8 samples and a sensor drift of 30 % of
    the range over the record, both written here: whichever cause is named, its model cannot take
    the other effect, and the diagnosis says that more is in the record than it explains (what its
    model leaves on the held-out blocks is many noise variances).  The same record without the drift
    has one effect, and nothing is said."""
    v = multisine(plant, 12000, 5)
    h = delayed(plant, v, 8)
    t = np.arange(v.size) / FS
    two = diagnose(v, noisy(h + 0.3 * np.ptp(h) * t / t[-1], 7), FS)
    assert two.cause in ("delay", "drift", "rate_dependence", "rate_dependent_hysteresis"), two.why
    left = two.left_over
    assert left["more_than_one_cause"] and left["held_out_sigma2"] >= 3.0, left
    assert left["plain_sigma2"] > left["held_out_sigma2"]
    assert "more is in the record than" in two.why
    assert two.as_json()["evidence"]["left_over_over_noise"] == left

    one = diagnose(v, noisy(h, 7), FS)
    assert one.cause in ("delay", "rate_dependence", "rate_dependent_hysteresis"), one.why
    assert not one.left_over["more_than_one_cause"] and one.left_over["held_out_sigma2"] < 1.0, one.left_over
    assert "more is in the record than" not in one.why
