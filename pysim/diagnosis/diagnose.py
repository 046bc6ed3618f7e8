"""Model discrepancy: where a rate-independent MPI model misses on measured data,
which cause explains it, and how much an extended model gains -- judged so that
an extrapolation error is never taken for an effect.

Procedure (``diagnose``):

1. **Baseline**: the MPI model fitted on *every* sample, the operator state at
   the start of the record estimated with the weights
   (:func:`pysim.identification.identify.identify`): no warm-up is left out and
   no record is refused for reaching its extremes late.  A **richer
   rate-independent model** (2n operators, its own initial state) is fitted
   beside it.
2. **Candidates**: every cause of the catalogue (:mod:`pysim.diagnosis.candidates`:
   rate_dependence, creep, delay, drift, rate_dependent_hysteresis,
   slew_limit) is built on the better of the two rate-independent models (a
   stage whose parameters all shape the response -- a delay, a lag or
   resonance, an input low-pass, a slew limit -- also on the other one, and
   keeps the better out of sample: :func:`candidates_on_either_base`); its
   shape parameters are searched on the whole record, its linear parameters
   refitted on every training part.  Every extension is physically admissible
   (non-negative creep modes, stable unit-gain dynamics, delay ≥ 0, a smooth
   drift) and the conditioning of every fit is reported.
3. **Blocked cross-validation**: the record is cut into ``N_FOLDS`` contiguous
   blocks; each block in turn is held out, every model is refitted on the other
   blocks (the input is known everywhere, so the held-out block's prediction
   continues the state the input leaves) and scored on the held-out samples
   whose input stays inside the range (and the largest sample-to-sample step)
   the training blocks covered -- a model is never judged on an extrapolation.  The score is the median over the
   blocks of the held-out mean-square error, so one block the others cannot
   predict does not decide alone.
4. **Cause**: a candidate is *significant* when its cross-validated
   mean-square error is lower than that of the baseline *and* of the richer
   rate-independent model by at least ``NOISE_FRACTION`` σ² and its RMS error
   by ``MIN_GAIN_PCT`` %; near the noise, when it removes at least
   ``NEAR_NOISE_FRACTION`` σ² and half of what the better rate-independent model
   leaves above the noise, and that removal holds across the record (a
   batch-means test, :func:`removal_holds`: on many samples an effect well under
   the noise is measurable, and one lucky stretch is not an effect).  The best significant candidate is named; candidates
   whose error is within ``TIE_FRACTION`` of what the best leaves above the noise (or within
   the noise margin, or near the noise half of what the best removes) are named with it as a set (``causes``) and an excitation
   that separates them is written (:mod:`pysim.diagnosis.excitation`).  When
   the best candidate removes less than ``UNEXPLAINED_SHARE`` of the residual
   above the noise, or no candidate is significant while the residual stays
   far above the noise, the verdict is ``unexplained``, with the evidence; the
   model delivered is then the best candidate's only where a second record
   tests it (the withholding below), the plain fit otherwise.
   **Steps**: when nothing is named, the responses to steps into holds
   (:func:`step_windows`) are predicted with each group of them left out of
   the fit; a fast stage (a delay, a lag, a slew limit) may show only in the
   few samples after large steps, which the median over the blocks never
   weighs.  Where the better rate-independent model leaves at least
   ``UNEXPLAINED_LEVEL`` σ² there, a candidate of ``DYNAMICS`` that removes
   ``DECISIVE_SHARE`` of it, worsens no step and not the blocked score is
   named (ties as above); a second record tests it on its own
   rate-independent fit (:func:`_raised_on_own_hysteresis`).
5. **Second record** (``validate=``): every model fitted on the first record is
   scored on a second record of the same actuator (its initial operator state,
   the free decay of its slow stage modes and the sensor offset and gain
   re-fitted and reported); the cause is then
   named by that record -- with two exceptions that follow from what a record
   can show.  A second record on which the better rate-independent model is
   already within ``2 NOISE_FRACTION`` σ² of its noise cannot confirm any
   effect, so the first record's verdict stands unless its cause makes the
   second record worse; a first record that close to its noise floor has
   fitted every candidate's effect to noise, so the second record cannot
   name one either, unless it is decisive (a large residual, most of it
   removed by one cause that does not worsen the first record).  And a candidate that the first record names and the
   second finds significant too is named even when it leaves most of the
   second record's residual (the rest is reported), rather than
   ``unexplained``.  When the first record's models leave the second record
   unexplained while its own rate-independent fit leaves ``UNEXPLAINED_LEVEL``
   σ² too, the second record is diagnosed on its own, and the cross-validated
   cause stands if it names it (:func:`_second_record_alone`).  Look-alike
   dynamics (``DYNAMICS``) are finally told apart by how each structure fits
   both records in sample (:func:`structure_on_both`).  A second record whose input covers the
   first's range and reaches beyond it by more than ``WIDER_RANGE_SHARE`` of the range both span
   (:func:`range_beyond_first`) is the one fitted, the first scored, when it names an effect: fitted
   on the narrower record every model would extrapolate where nothing scores it.  Without a second record, a split of
   different character (train on the slowest blocks, score on the fastest) is
   reported beside the cross-validation.  When the first record shows no effect
   and only its models' prediction of the second record is left unexplained,
   the second record is diagnosed on its own: when it names nothing either,
   the gap is the first record's hysteresis part on an input it never showed,
   and nothing is named (:func:`_second_record_shows_none`); when it names a
   cause, the records' roles are swapped (fitted on the second, scored on the
   first), and the cause is named only when that confirms it, nothing when it
   confirms nothing.
   **General model** (:mod:`pysim.diagnosis.preisach`): a discrete Preisach
   model, alone and with each effect it holds, fitted on both records
   together, judges four verdicts the MPI models cannot settle: an
   ``unexplained`` one; a named lag, delay, creep or input low-pass whose own
   model leaves the second record ``UNEXPLAINED_LEVEL`` σ² above its noise;
   a named creep to whose modes the general model with creep gives no weight
   (``NO_CREEP_WEIGHT``); and a ``none`` whose plain fit leaves the second
   record ``PLAIN_MISS_LEVEL`` σ² above its noise (after the second record has
   had its turn).  A decisive effect there is named; a named cause gives way
   to ``none`` only when the general model alone fits each record to its noise
   and leaves under ``NEAR_NOISE_FRACTION`` σ² over both (nothing is left for
   the cause to explain), and a ``none`` is never replaced by anything less.
   A creep delivered takes its modes from the general model on both records
   when that model's creep is admissible and driven by the displacement
   (:func:`pysim.diagnosis.second_record.creep_modes_of_both_records`): fitted
   with the MPI weights on one record, the modes also take up the MPI
   model's loop-shape error.
   **Holds** of the input (:mod:`pysim.diagnosis.holds`) also weigh the
   verdict: a rate-independent actuator stands still in them, so they turn an
   ``unexplained`` verdict into ``none``, rule out a named cause whose model
   moves where the record stands still, and add to the verdict a cause whose
   model follows the motion where the record moves.
6. **Gain**: cross-validated max and RMS error (% of the measured range of
   the scored samples) of the baseline and of the extended model,
   ``gain_pct = 100 (1 − rms_after / rms_before)``.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from pysim.diagnosis.artefacts import (REPAIRABLE, artefacts_sentence, find_artefacts,
                                      repaired_displacement)
from pysim.diagnosis.candidates import EFFECTS, CandidateFitter
from pysim.diagnosis.errors import DiagnosisError
from pysim.diagnosis.excitation import separating_excitation
from pysim.diagnosis.folds import (CREEP_HOLD_S, DEFAULT_TRAIN_FRACTION, Split, WIDER_RANGE_SHARE,
                                   holds_after_a_step, record_folds, settle_samples, character_split,
                                   make_folds, range_beyond_first, split_record)
from pysim.diagnosis.holds import (contradicted_by_holds, contradicted_sentence, preferred_by_holds, still_holds,
                                   still_sentence, voting_holds)
from pysim.diagnosis.path_memory import path_memory
from pysim.diagnosis.preisach import creep_on_both_records, effects_on_both_records, verdict_on_both_records
from pysim.diagnosis.residuals import (NOISE_FREE_FRACTION, VALIDATED_NOISE_FRACTION, models_noise_sigma,
                                      record_noise_sigma, residual_statistics)
from pysim.diagnosis.rules import (MIN_GAIN_PCT, NEAR_NOISE_FRACTION, NOISE_FRACTION, TIE_FRACTION,
                                   UNEXPLAINED_LEVEL, rms_gain_pct, shape_not_unexplained, advantage_holds,
                                   decide, removal_holds)
from pysim.diagnosis.scoring import (Evaluation, blocked_score, candidates_on_either_base,
                                     rate_independent_models, cv_runner, well_scored)
from pysim.diagnosis.second_record import (RolesStand, best_fitted_on_both_records, best_predictor_of_set,
                                           creep_modes_of_both_records,
                                           both_records_sentence, delivering_verdict, dynamics_where_they_show,
                                           fit_on_both_records, predicts_second_record_better,
                                           second_record_fitter, structure_on_both,
                                           told_apart_by_second_record, validate_on_second_record)
from pysim.diagnosis.shape import correct_for_shape, correct_like_the_others
from pysim.diagnosis.steps import shown_by_steps
from pysim.diagnosis.validation import score_on_record
from pysim.identification.data import (checked_sample_rate, common_sample_rate, resample_record,
                                       resampling_stride)
from pysim.identification.errors import DataError
from pysim.identification.identify import (IdentificationError, identify, require_rising, settling_samples,
                                            start_transient)

__all__ = ["diagnose", "Diagnosis"]

#: Per-sample arrays of a model's second-record scores, left out of the JSON.
_VALIDATION_ARRAYS = ("prediction_um", "scored_rows", "as_fitted_prediction_um")


@dataclass
class Diagnosis:
    """Outcome of :func:`diagnose` (see :meth:`as_json` for the report format).

    Attributes
    ----------
    cause : str
        ``"none"``, one of the catalogue's causes, or ``"unexplained"``.
    causes : tuple of str
        The named set: ``(cause,)`` when unambiguous, several when the record
        cannot tell them apart, ``()`` for none.
    excitation : ndarray or None
        Voltage (V, one sample per sample period) that separates an ambiguous set.
    records_swapped : bool
        True when the models were fitted on the second record given and
        scored on the first (``voltage_V``, ``displacement_um`` and
        ``source`` are then the second record's): the first could not
        identify the hysteresis, or it showed no effect and the second,
        fitted in its turn, names one.
    swap_reason : str
        Why the roles swapped ("" when they did not).
    steps : dict or None
        When the responses to steps into holds named the cross-validated
        cause (:func:`step_windows`): the number of windows and samples, the
        mean-square error the rate-independent model leaves there above the
        noise (σ²) and the share each qualifying candidate removes.
    shape : dict
        Record ("first", "second") → the hysteresis shape error found there
        (:func:`path_corrected`): what the input's path alone predicts of the
        best rate-independent model's residual, in σ² and % of range; every
        model on that record was compared after the same correction.  Empty
        when the MPI class draws the record's loops.
    artefacts : list of dict
        Spikes, jumps and flat runs of the displacement that no model of the
        actuator explains (:func:`pysim.diagnosis.artefacts.record_artefacts`),
        each with ``record`` ("first" or "second", as given) and ``repaired``
        (spikes and jumps are, before the diagnosis, unless
        ``repair_artefacts=False``; ``displacement_um`` is then the repaired
        record).  Samples count from the record's first.
    noise_free : bool
        The record fitted shows no measurable noise (a simulation:
        :func:`pysim.diagnosis.residuals.is_noise_free`); ``noise_um`` is then
        0.1 % of its range, the lowest noise the diagnosis was measured at.
    baseline, extended, richer : Evaluation
    candidates : dict
        Cause → Evaluation.
    """

    cause: str
    split: Split
    sample_period_s: float
    noise_um: float
    baseline: Evaluation
    candidates: dict
    extended: Evaluation
    statistics: dict
    reasons: dict
    why: str
    time_s: np.ndarray = field(repr=False, default=None)
    voltage_V: np.ndarray = field(repr=False, default=None)
    displacement_um: np.ndarray = field(repr=False, default=None)
    source: str = ""
    causes: tuple = ()
    excitation: np.ndarray = field(repr=False, default=None)
    richer: Evaluation = None
    folds: list = field(default_factory=list)
    scored_samples: int = 0
    cross_validation_cause: str = ""
    cross_validation_causes: tuple = ()
    validation: dict = None
    excitation_plan: list = field(default_factory=list)
    start_excluded_samples: int = 0
    records_swapped: bool = False
    swap_reason: str = ""
    steps: dict = None
    shape: dict = field(default_factory=dict)
    artefacts: list = field(default_factory=list)
    noise_free: bool = False

    @property
    def gain_pct(self) -> float:
        return self.extended.gain_pct

    @property
    def withheld(self) -> str:
        """The named cause whose model is not delivered because it predicts the second record
        worse than the plain fit (``extended`` is then the baseline); "" otherwise."""
        return (self.validation or {}).get("withheld", "")

    @property
    def fitted_on_both_records(self) -> bool:
        """True when the delivered model's linear parameters were fitted on the first record and
        the second together (its shape parameters on the first); its cross-validated scores are
        those of the fit on the first record alone."""
        return (self.validation or {}).get("delivered_fit") == "both records"

    @property
    def heldout_span_um(self) -> float:
        return float(np.ptp(self.displacement_um[self.split.heldout]))

    def table(self) -> list:
        """Rows ``(model, cv_rms_pct, cv_max_pct, gain_pct, validation_rms_pct)`` of every model."""
        rows = []
        for ev in [self.baseline, self.richer, *self.candidates.values()]:
            if ev is None:
                continue
            val = ev.validation["rms_pct"] if ev.validation else None
            rows.append((ev.cause, ev.rms_pct, ev.max_pct, ev.gain_pct, val))
        return rows

    def as_json(self) -> dict:
        """``{"cause", "causes", "evidence", "baseline", "extended", "gain_pct", ...}`` (plain types)."""
        candidates = {}
        for cause, ev in self.candidates.items():
            candidates[cause] = {
                "heldout_rms_pct": ev.rms_pct, "heldout_max_pct": ev.max_pct, "gain_pct": ev.gain_pct,
                "mse_removed_over_noise": ev.excess_over_noise, "significant": ev.significant,
                "mse_removed_where_states_seen_over_noise": _plain(ev.removed_where_states_seen_sigma2),
                "train_rms_pct": ev.train_rms_pct, "parameters": _plain(ev.fit.parameters),
                "reason": self.reasons.get(cause, ""), "gain_vs_rate_independent_pct": ev.gain_vs_richer_pct,
                "condition_number": ev.fit.result.condition_number if ev.fit.result else None,
                "static_gain_um_per_V": _static_gain(ev.fit.model),
                "character_split_rms_pct": ev.character.get("rms_pct"),
                "validation": None if ev.validation is None else _plain(
                    {k: x for k, x in ev.validation.items() if k not in _VALIDATION_ARRAYS}),
            }
        span = float(np.ptp(self.displacement_um))
        ident = self.baseline.fit.result
        measured_gain = float(np.ptp(self.displacement_um)) / float(np.ptp(self.voltage_V))
        return _plain({
            "source": self.source,
            "cause": self.cause,
            "causes": list(self.causes),
            "evidence": {
                "why": self.why,
                "noise_um": self.noise_um,
                "noise_pct": 100.0 * self.noise_um / span if span > 0 else float("nan"),
                "noise_free": self.noise_free,
                "split": self.split.as_dict(self.sample_period_s),
                "scoring": {"method": "blocked cross-validation", "folds": self.folds,
                            "scored_samples": self.scored_samples,
                            "rule": "each block held out in turn; scored where the input stays inside the "
                                    "range of the training blocks; the score is the median over the blocks "
                                    "of the held-out mean-square error"},
                "sample_rate_hz": 1.0 / self.sample_period_s,
                "start_excluded_samples": self.start_excluded_samples,
                "records_swapped": self.records_swapped,
                "swap_reason": self.swap_reason,
                "candidates": candidates,
                "rate_independent": {
                    "baseline": {"rms_pct": self.baseline.rms_pct, "max_pct": self.baseline.max_pct,
                                 "n_operators": self.baseline.fit.model.n_operators,
                                 **(ident.identifiability() if ident else {})},
                    "richer": None if self.richer is None else {
                        "rms_pct": self.richer.rms_pct, "max_pct": self.richer.max_pct,
                        "n_operators": self.richer.fit.model.n_operators,
                        "condition_number": self.richer.fit.result.condition_number},
                },
                "measured_gain_um_per_V": measured_gain,
                "cross_validation_cause": self.cross_validation_cause,
                "cross_validation_causes": list(self.cross_validation_causes),
                "steps": self.steps,
                "shape": self.shape,
                "record_artefacts": self.artefacts,
                "validation": self.validation,
                "residual_statistics": _plain(self.statistics),
            },
            "baseline": {"rms_pct": self.baseline.rms_pct, "max_pct": self.baseline.max_pct},
            "extended": {"rms_pct": self.extended.rms_pct, "max_pct": self.extended.max_pct,
                         "cause": self.extended.cause, "parameters": _plain(self.extended.fit.parameters),
                         "static_gain_um_per_V": _static_gain(self.extended.fit.model),
                         "condition_number": (self.extended.fit.result.condition_number
                                              if self.extended.fit.result else None)},
            "gain_pct": self.gain_pct,
            "excitation": None if self.excitation is None else {
                "samples": int(self.excitation.size), "plan": self.excitation_plan,
                "voltage_range_V": [float(self.excitation.min()), float(self.excitation.max())]},
        })


def _static_gain(model) -> float:
    """Major-loop gain (µm/V) of a fitted model through its stages."""
    plant = getattr(model, "plant", model)
    try:
        return float(plant.major_loop_gain())
    except Exception:   # a model without the method: no number rather than a wrong one
        return float("nan")


def _plain(value):
    """Plain JSON types (floats, lists, dicts); NaN and infinities become None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


#: Why the records' roles swap when the first record shows no effect (or one only in its steps).
_NO_EFFECT_SHOWN = ("{first} shows no effect beyond its noise, and {second} may show one that the input of {first} "
                    "does not excite")
_STEPS_ALONE = ("{first} shows an effect only in its responses to steps, and {second} may show one that the input "
                "of {first} does not excite")

#: σ² above its noise that the plain fit of the first record leaves on the second before a ``none``
#: verdict is put to the general model on both records: an error as large as the noise itself.
PLAIN_MISS_LEVEL = 1.0

def _left_on_second_record(evaluation, validation) -> float:
    """What a model fitted on the first record leaves on the second above its noise (σ²); 0 when
    there is no second record or no score there."""
    if validation is None or evaluation.validation is None:
        return 0.0
    return evaluation.validation["mse_um2"] / validation["noise_um"] ** 2 - 1.0


#: Weight (a share of the displacement, or µm/V of the input's lag) at or below which the general model
#: on both records puts no weight on a creep mode: the non-negative fit's bound.
NO_CREEP_WEIGHT = 1e-9

#: Named causes the general model on both records also holds (a first-order lag only), and so may judge.
GENERAL_MODEL_JUDGES = ("rate_dependence", "delay", "creep", "rate_dependent_hysteresis")


def _general_model_can_judge(evaluation) -> bool:
    """Whether the general model on both records (:mod:`pysim.diagnosis.preisach`) holds the
    structure of a named cause: a lag (not a second-order stage), a delay, creep, an input low-pass.
    A slew limit, a resonance or a drift it holds poorly or not at all, and it would replace them by
    their look-alikes (independent pair 503: a slew limit that the general model takes for a lag)."""
    if evaluation.cause == "rate_dependence":
        return evaluation.fit.parameters.get("order") == 1
    return evaluation.cause in GENERAL_MODEL_JUDGES


def _reasons(candidates: dict, stats: dict, steps: dict | None = None) -> dict:
    """One sentence of evidence per candidate: its fit, and the statistic that points to it (and,
    when the responses to steps named the cause, what each candidate removes there)."""
    text = {}
    for cause, ev in candidates.items():
        p = ev.fit.parameters
        if cause == "rate_dependence":
            shape = (f"second-order stage, f_n = {p['natural_frequency_hz']:.4g} Hz, ζ = {p['damping_ratio']:.3g}"
                     if p["order"] == 2 else f"first-order lag, τ = {p['time_constant_s'] * 1e3:.4g} ms")
            hint = f"residual-rate correlation {stats['rate_correlation']:+.2f}"
        elif cause == "delay":
            shape = f"delay {p['delay_samples']:.3g} samples ({p['delay_s'] * 1e3:.4g} ms)"
            hint = (f"residual-rate correlation {stats['rate_correlation']:+.2f}; "
                    f"{100 * stats['settling_fraction']:.0f} % of the residual power within 20 samples "
                    f"of an input change")
        elif cause == "creep" and p.get("driven_by") == "displacement":
            taus, shares = p["time_constants_s"], p["shares"]
            shape = (f"creep of the displacement, {len(taus)} mode(s) "
                     f"({', '.join(f'{t:.3g} s' for t in taus)}), {100 * sum(shares):.3g} % of a settled "
                     f"displacement reached by creeping")
            hint = (f"direction-signed residual vs ln(time since change): correlation "
                    f"{stats['creep_log_correlation']:+.2f}")
        elif cause == "creep":
            taus, weights = p["time_constants_s"], p.get("weights_um_per_V", [])
            used = [f"{t:.3g} s" for t, w in zip(taus, weights) if w != 0]
            shape = (f"{len(used)} non-negative creep mode(s) of the input, of {len(taus)} "
                     f"({', '.join(used) or 'none'}), Σw = {sum(weights):.4g} µm/V")
            hint = (f"direction-signed residual vs ln(time since change): correlation "
                    f"{stats['creep_log_correlation']:+.2f}")
        elif cause == "drift":
            shape = f"polynomial of degree {p['degree']} in time"
            hint = (f"{100 * stats['low_frequency_fraction']:.0f} % of the residual power below a fifth of the "
                    f"input frequency")
        elif cause == "rate_dependent_hysteresis":
            shape = f"input low-pass before the hysteresis, τ = {p['input_time_constant_s'] * 1e3:.4g} ms"
            hint = f"residual-rate correlation {stats['rate_correlation']:+.2f}"
        else:
            shape = f"amplifier slew limit {p['rate_V_per_ms']:.4g} V/ms"
            hint = f"residual-rate correlation {stats['rate_correlation']:+.2f}"
        verdict = "significant" if ev.significant else "not significant"
        if ev.significant and ev.excess_over_noise < NOISE_FRACTION:
            verdict = "significant near the noise: at least half of the excess, and it holds across the record"
        cond = ev.fit.result.condition_number if ev.fit.result is not None else float("nan")
        if steps and cause in steps["removed_share"]:
            verdict += (f" in the blocks; on the responses to {steps['windows']} step(s) into holds it removes "
                        f"{100 * steps['removed_share'][cause]:.0f} % of {steps['excess_sigma2']:.3g} σ²")
        text[cause] = (f"{shape}: cross-validated RMS {ev.rms_pct:.3g} % (gain {ev.gain_pct:+.1f} % against the "
                       f"baseline, {ev.gain_vs_richer_pct:+.1f} % against the best rate-independent model, removes "
                       f"{ev.excess_over_noise:.2f} σ²: {verdict}); condition number {cond:.3g}; {hint}")
    return text


def _note_resampling(validation: dict, resampled: str) -> None:
    """Say in the second record's table how that record was put on the first one's sample period."""
    if validation is not None:
        validation["resampled"] = resampled
        if resampled:
            validation["note"] += f"; {resampled}"


def _check_record(v, y, sample_rate_hz, what: str):
    if v.shape != y.shape:
        raise DiagnosisError(f"{what}{v.size} voltage samples but {y.size} displacement samples")
    checked_sample_rate(sample_rate_hz, f"{what}sample rate", DiagnosisError)
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise DiagnosisError(f"{what}the record holds NaN or infinite values")
    if v.size < 400:
        raise DiagnosisError(f"{what}{v.size} samples; the diagnosis needs at least 400 "
                             "(five blocks of cross-validation)")
    try:
        require_rising(v, y)
    except IdentificationError as exc:
        raise DiagnosisError(f"{what}{exc}") from None


def diagnose(voltage_V, displacement_um, sample_rate_hz: float, *, time_s=None, n_operators: int = 10,
             model: str = "mpi", operator: str = "osp", train_fraction: float = DEFAULT_TRAIN_FRACTION,
             warmup="auto", validate=None, name: str = "extended_mpi", source: str = "",
             validate_source: str = "", repair_artefacts: bool = True, _swap_reason: str = "") -> Diagnosis:
    """Diagnose what a rate-independent MPI model misses on a measured record.

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record, uniformly sampled.
    sample_rate_hz : float
        Sample rate, Hz (the extended model's stages run at this rate).
    time_s : array_like, optional
        Sample times, s (for plots; default ``k / sample_rate_hz``).
    n_operators, model, operator
        MPI model settings, as in :func:`pysim.identification.identify.identify`.
    train_fraction : float
        Where the report's plots shade the held-out part (a periodic input's
        split falls on whole periods); the scores are cross-validated.
    warmup : "auto" or int
        Kept for compatibility: ``"auto"`` (no warm-up, the initial operator
        state is estimated).  A number leaves that many samples out of the
        plots' training part only.
    validate : (voltage_V, displacement_um, sample_rate_hz), optional
        A second record of the same actuator with another input: every model
        is scored on it and the cause is named by it.  When the first record
        cannot identify the hysteresis (a step, an input that only rises) and
        the second can, the roles swap: the models are fitted on the second
        record and scored on the first (``Diagnosis.records_swapped``).  When
        the first record shows no effect, the second takes its turn the same
        way: an effect that only its input excites (creep under slow holds, a
        lag a single sine hides) is named by it and confirmed on the first.
        A second record that cannot identify the hysteresis still shows the
        shape of a lag, resonance, delay, input low-pass or slew limit (the
        response to each step): those shapes are searched there, with the
        first record's hysteresis.  A second record sampled a whole number of
        times faster is used at every m-th sample
        (:func:`pysim.identification.data.resample_record`); one sampled
        slower, or at a rate neither a multiple nor a fraction of the first's,
        puts both records on the highest rate their samples share
        (:func:`pysim.identification.data.common_sample_rate`: every m-th
        sample of each, the first's at most every 10th), and the models run
        at that rate.  The report says so; rates that differ by a logger's
        rounding count as one.
    name : str
        Name of the extended model (a C identifier).
    source, validate_source : str
        Where the data came from (for the report).
    repair_artefacts : bool
        Repair the spikes and jumps found in either record before the
        diagnosis (:mod:`pysim.diagnosis.artefacts`); with False they are
        only reported.  Flat runs are always only reported.

    Returns
    -------
    Diagnosis

    Raises
    ------
    DiagnosisError
        When a record cannot be diagnosed (too short, constant, one-directional,
        a second record at a rate that is not the first's or a whole multiple
        of it), with one message naming it.

    Examples
    --------
    >>> import numpy as np
    >>> from pysim.core.model import HysteresisModel, eq13_thresholds
    >>> r = eq13_thresholds(10, 100.0)
    >>> plant = HysteresisModel(0.0, 0.3, tuple(r), (0.0,) + (0.03,) * 9, voltage_range_V=(0.0, 100.0))
    >>> k = np.arange(6000)
    >>> v = 50 + 45 * np.sin(2 * np.pi * k / 1500) * np.cos(2 * np.pi * k / 4100)
    >>> y = plant.simulate(v) + np.random.default_rng(1).normal(0, 0.02, k.size)
    >>> d = diagnose(v, y, 1000.0)
    >>> d.cause, d.causes, d.excitation is None
    ('none', (), True)
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    given = (v, y, sample_rate_hz)
    where = f"{source}: " if source else ""
    _check_record(v, y, sample_rate_hz, where)
    resampled = ""
    first_every, first_rate_hz = 1, float(sample_rate_hz)
    if validate is not None:
        try:
            v2, y2, rate2 = validate
        except (TypeError, ValueError) as exc:
            raise DiagnosisError("validate must be (voltage_V, displacement_um, sample_rate_hz)") from exc
        v2, y2 = np.asarray(v2, dtype=float).ravel(), np.asarray(y2, dtype=float).ravel()
        where2 = f"{validate_source}: " if validate_source else "second record: "
        _check_record(v2, y2, rate2, where2)
        # the extended models run at one sample period: the first record's (the one a spec is written
        # for), or, for a slower second record, the highest rate both records' samples fall on
        try:
            common_rate_hz = common_sample_rate(sample_rate_hz, v.size, rate2, v2.size)
            v2, y2, how = resample_record(v2, y2, float(rate2), common_rate_hz)
        except DataError as exc:
            raise DiagnosisError(f"{where2}{exc}") from exc
        notes = []
        if common_rate_hz != first_rate_hz:
            first_every = resampling_stride(first_rate_hz, common_rate_hz)
            if time_s is not None:
                time_s = np.ravel(time_s)[::first_every] if np.size(time_s) == v.size else None
            v, y, first_how = resample_record(v, y, first_rate_hz, common_rate_hz)
            sample_rate_hz = common_rate_hz
            given = (v, y, sample_rate_hz)
            _check_record(v, y, sample_rate_hz, where)
            notes.append(f"{source or 'the first record'} was sampled at {first_rate_hz:g} Hz and is used at "
                         f"{common_rate_hz:g} Hz, the highest rate on which both records' samples fall: "
                         f"{first_how} (a stage faster than a sample there is not resolved)")
        if how != "as recorded":
            notes.append(f"{validate_source or 'the second record'} was sampled at {float(rate2):g} Hz and is "
                         f"used at {common_rate_hz:g} Hz" + ("" if notes else
                                                            f", the rate of {source or 'the first record'}")
                         + f": {how}")
            _check_record(v2, y2, sample_rate_hz, where2)
        resampled = "; ".join(notes)
        second_every = resampling_stride(rate2, sample_rate_hz)
        second_rate_hz = float(rate2)
        rate2 = sample_rate_hz
    # the plain fit of every sample, made once: the artefacts are found on its residual, the start
    # transient is read from it, and while neither changes the record the candidates start from it
    # (None: the record cannot be fitted, which the start transient's own fit then says)
    fit_options = {"n_operators": n_operators, "model": model, "operator": operator}
    try:
        whole_fit = identify(v, y, require_excitation=False, **fit_options)
    except IdentificationError:
        whole_fit = None
    # spikes, jumps and flat runs no model of the actuator explains, found on each record's plain fit
    # first (a jump looks like drift or creep to every candidate); the records' roles are the user's
    artefacts = []
    if not _swap_reason:
        first_found = [] if whole_fit is None else find_artefacts(v, y, sample_rate_hz, fit=whole_fit,
                                                                  **fit_options)
        second_found = [] if validate is None else find_artefacts(v2, y2, sample_rate_hz, **fit_options)
        if repair_artefacts and first_found:
            y = repaired_displacement(y, first_found)        # flat runs are left as they are
            given = (v, y, sample_rate_hz)
            whole_fit = None
        if repair_artefacts and second_found:
            y2 = repaired_displacement(y2, second_found)
        first_times = np.ravel(time_s) if time_s is not None and np.size(time_s) == v.size else None
        # each record's said in its own samples and time (either may be used at every m-th sample)
        artefacts = [dict(a, record="first", repaired=bool(repair_artefacts and a["kind"] in REPAIRABLE),
                          sample=a["sample"] * first_every, samples=a["samples"] * first_every,
                          time_s=(a["sample"] * first_every / first_rate_hz if first_times is None
                                  else float(first_times[a["sample"]])))
                     for a in first_found]
        artefacts += [dict(a, record="second", repaired=bool(repair_artefacts and a["kind"] in REPAIRABLE),
                           sample=a["sample"] * second_every, samples=a["samples"] * second_every,
                           time_s=a["sample"] * second_every / second_rate_hz)
                      for a in second_found]

    def reported(result):
        """The result with the artefacts found here, and their sentence in ``why``."""
        if not artefacts:
            return result
        sentence = artefacts_sentence(artefacts, source or "the first record", validate_source or "the second record")
        return replace(result, artefacts=artefacts, why=f"{result.why}. {sentence}")

    T = 1.0 / float(sample_rate_hz)
    time = np.arange(v.size) * T if time_s is None else np.asarray(time_s, dtype=float).ravel()
    try:
        start = (start_transient(v, y, **fit_options) if whole_fit is None
                 else settling_samples(y - whole_fit.prediction_um))
    except IdentificationError as exc:
        raise DiagnosisError(f"{where}{exc}") from exc
    if start:
        v, y, time = v[start:], y[start:], time[start:]
        whole_fit = None
    split = split_record(v, train_fraction, 0 if warmup == "auto" else int(warmup))
    description = f"MPI model with output stages identified from {source or 'a record'} by pysim diagnose"
    try:
        fitter = CandidateFitter(v, y, T, n_operators=n_operators, model=model, operator=operator, name=name,
                                 description=description, baseline_result=whole_fit)
    except IdentificationError as exc:
        raise DiagnosisError(f"{where}{exc}") from exc
    fitter.period_samples = split.period_samples
    folds, mask = record_folds(v)
    if np.count_nonzero(mask) < 100:
        raise DiagnosisError(f"{where}the input of every block leaves the range of the others: no sample can be "
                             "scored out of sample; record the range more than once")
    character = character_split(v, T)

    # what the input cannot show is known from the rate-independent fit the fitter starts from (the
    # baseline family is fitted on the same input and thresholds): decided before any cross-validation
    unidentified = fitter.baseline_result.unidentified_reason
    if unidentified and _swap_reason:
        raise RolesStand()

    def in_turn(reason):
        """The same diagnosis with the records' roles swapped, or None when the given order stands."""
        try:
            turned = diagnose(v2, y2, rate2, n_operators=n_operators, model=model, operator=operator,
                              train_fraction=train_fraction, validate=given, name=name,
                              source=validate_source or "second record", validate_source=source or "first record",
                              _swap_reason=reason)
        except (RolesStand, DiagnosisError):
            return None
        _note_resampling(turned.validation, resampled)
        return turned

    if unidentified and validate is not None:
        # every model fitted here would be scored on the second record for the hysteresis this record
        # cannot show, not for its effect: when the second record identifies it, the roles swap
        swapped = in_turn(f"{source or 'first record'} cannot identify the hysteresis ({unidentified})")
        if swapped is not None:
            return reported(swapped)

    turn_tried = False
    beyond = range_beyond_first(given[0], v2) if validate is not None and not _swap_reason else 0.0
    if beyond > WIDER_RANGE_SHARE:
        # fitted here, every model would extrapolate over part of the range the second record shows
        # (a record that starts after an unknown history may never return to the bottom), and the
        # scoring there leaves that part out: the record that covers both is fitted, when it names an
        # effect (otherwise this record may show one that the wider record's input does not excite)
        first, second = source or "the first record", validate_source or "the second record"
        turn_tried = True
        swapped = in_turn(f"{first} reaches only {given[0].min():.4g} to {given[0].max():.4g} V of the "
                          f"{v2.min():.4g} to {v2.max():.4g} V that {second} covers (models fitted on {first} "
                          f"would extrapolate over {100 * beyond:.0f} % of that range)")
        if swapped is not None and swapped.cause in EFFECTS:
            return swapped

    run = cv_runner(fitter, folds, character, y, mask)

    try:
        baseline, richer = rate_independent_models(fitter, run, folds, character, y, mask)
    except IdentificationError as exc:
        raise DiagnosisError(f"{where}{exc}") from exc
    rate_independent = richer if richer.mse_um2 < baseline.mse_um2 else baseline
    train_range = (float(v.min()), float(v.max()))

    def scored_on_both_records(option):
        # two structures of one cause: the second record is held-out data too (the score is kept:
        # the second record's table scores each model once)
        if option.validation is None:
            option.validation = score_on_record(option.fit, v2, y2, T, train_range, train_voltage_V=v)
        return option.mse_um2 * option.validation["mse_um2"]

    candidates = candidates_on_either_base(fitter, run, baseline, richer, EFFECTS,
                                           None if validate is None else scored_on_both_records)

    shaped_on_second = []
    if validate is not None:
        try:
            second_unidentified = identify(v2, y2, n_operators=n_operators, model=model, operator=operator,
                                           require_excitation=False).unidentified_reason
        except IdentificationError:
            second_unidentified = ""
        if second_unidentified:
            shaped_on_second = dynamics_where_they_show(fitter, run, rate_independent, candidates, v, v2, y2,
                                                        record_noise_sigma(y - baseline.prediction_um, y))

    noise, noise_free = models_noise_sigma([y - ev.prediction_um for ev in [baseline, richer, *candidates.values()]],
                                           y)
    # a hysteresis shape outside the model class: every model is compared after the same correction
    shape = {}
    first_memory = path_memory(v)
    first_shape = correct_for_shape([baseline, richer, *candidates.values()], folds, y, mask, first_memory,
                                     noise)
    if first_shape:
        shape["first"] = first_shape
    ref_mse = min(baseline.mse_um2, richer.mse_um2)

    def gains(ev):
        ev.gain_pct = 100.0 * (1.0 - ev.rms_um / baseline.rms_um) if baseline.rms_um > 0 else 0.0
        ev.gain_vs_richer_pct = 100.0 * (1.0 - ev.rms_um / math.sqrt(ref_mse)) if ref_mse > 0 else 0.0
        ev.excess_over_noise = (ref_mse - ev.mse_um2) / noise**2 if noise > 0 else 0.0

    for ev in [richer, *candidates.values()]:
        gains(ev)
    complexity = {c: ev.fit.complexity for c, ev in candidates.items()}
    consistent = {c: removal_holds(y, rate_independent.cv_prediction_um, ev.cv_prediction_um)
                  for c, ev in candidates.items()}

    def outranks(a, b):
        return advantage_holds(y, candidates[b].cv_prediction_um, candidates[a].cv_prediction_um)

    # the same blocks scored only where every operator of the richer model also stays inside the
    # states its training blocks showed: a cause must remove error there as well.  Minor loops that
    # peak where no other block does leave operators in such states, every rate-independent model
    # extrapolates there, and a slow candidate that draws the same trend could be named for it
    # (only where two blocks or more score MIN_SCORED_PER_BLOCK such samples: fewer prove nothing)
    seen_folds = well_scored(make_folds(v, settle=settle_samples(v.size),
                                        operator_outputs_V=fitter.operator_outputs_V()))
    removed_seen = None
    if seen_folds is not None:

        def where_seen(ev):
            return blocked_score(y, ev.cv_prediction_um, seen_folds)[1]

        reference_seen = min(where_seen(baseline), where_seen(richer))
        removed_seen = {c: reference_seen - where_seen(ev) for c, ev in candidates.items()}
        for c, ev in candidates.items():
            ev.removed_where_states_seen_sigma2 = removed_seen[c] / noise**2 if noise > 0 else 0.0
    verdict = shape_not_unexplained(decide({c: ev.mse_um2 for c, ev in candidates.items()}, baseline.mse_um2,
                                           richer.mse_um2, noise, complexity, consistent, outranks,
                                           removed_seen), first_shape)
    for c, ev in candidates.items():
        ev.significant = verdict["significant"][c]
    if unidentified and verdict["cause"] in ("unexplained", "drift"):
        # without identified operators the loop shape is left in the residual: calling it "outside the
        # catalogue" would name the missing excitation as an effect, and on an input that barely
        # reverses a slow trend in time is a trend in the input level, i.e. the shape again
        verdict = {**verdict, "cause": "none", "causes": (), "best": None, "explained_share": 0.0, "text": ""}
    if verdict["cause"] == "none" and not unidentified:
        by_steps = shown_by_steps(fitter, baseline, richer, candidates, y, noise, complexity)
        if by_steps is not None:
            verdict = by_steps
            for c, ev in by_steps.pop("structures").items():
                if ev is not candidates[c]:
                    # the structure the steps named (a resonance the blocks tied with a lag)
                    ev.structures, ev.significant = candidates[c].structures, candidates[c].significant
                    gains(ev)
                    candidates[c] = ev
    cv_verdict = verdict

    validation = None
    if validate is not None:
        # the second record's own fitter: identified at most once, only when a rule fits that record itself
        second_fitter = functools.cache(lambda: second_record_fitter(fitter, v2, y2))
        validation, v_verdict = validate_on_second_record(fitter, baseline, richer, candidates, v, v2, y2,
                                                          complexity, cv_verdict, noise, outranks, second_fitter)
        validation["source"] = validate_source
        _note_resampling(validation, resampled)
        if validation.get("shape"):
            shape["second"] = validation["shape"]
        if shaped_on_second:
            validation["note"] += (f"; the shape of {' and '.join(shaped_on_second)} was searched on the second "
                                   "record, which shows it but cannot identify the hysteresis (the hysteresis "
                                   "part is the first record's)")
        if unidentified:
            # the first record cannot identify the hysteresis: the second record would measure that,
            # not an effect, so it does not name the cause
            validation["note"] += ("; not used to name the cause: the first record cannot identify the "
                                   f"hysteresis ({unidentified})")
        else:
            verdict = v_verdict
            # a tied set (on the second record, or on the first when the second names one of it) may be
            # told apart by the second record's own fit of each cause's structure
            tied = (verdict["causes"] if len(verdict["causes"]) > 1 else
                    cv_verdict["causes"] if len(cv_verdict["causes"]) > 1 and verdict["cause"] in cv_verdict["causes"]
                    else ())
            told = told_apart_by_second_record(fitter, tied, v2, y2, second_fitter) if tied else None
            if told is not None:
                kept, on_second = told
                if verdict["cause"] in kept:
                    kept = [verdict["cause"]] + [c for c in kept if c != verdict["cause"]]
                out = [c for c in tied if c not in kept]
                remark = (f"; {', '.join(tied)} tie as the models fitted on the first record; fitted on the "
                          "second record itself, "
                          + ", ".join(f"{c} leaves {on_second[c]:.3g} σ²" for c in tied if c in on_second)
                          + f", and {' and '.join(out)} {'is' if len(out) == 1 else 'are'} ruled out there "
                          f"({'its error is' if len(out) == 1 else 'their errors are'} higher than the best one's "
                          "by more than the noise margin, or by more than the noise can make)")
                verdict = dict(verdict, cause=kept[0], causes=tuple(kept), best=kept[0], told_apart=True)
                validation.update(cause=kept[0], causes=list(kept), verdict_by="second record",
                                  remark=validation["remark"] + remark, note=validation["note"] + remark)
            # look-alike dynamics are told apart by how each structure fits both records in sample
            structure = structure_on_both(fitter, candidates, verdict["causes"], y, v2, y2, noise,
                                          min(baseline.validation["mse_um2"], richer.validation["mse_um2"]),
                                          second_fitter)
            if structure is not None:
                winner, errors = structure
                named = ", ".join(verdict["causes"])
                remark = (f"; in sample, with the same free parameters (on the second record the first record's "
                          f"shape on that record's own rate-independent fit), {winner} leaves "
                          f"{errors[winner][0]:.3g} σ² and {errors[winner][1]:.3g} σ² on the two records, "
                          + ", ".join(f"{c} {errors[c][0]:.3g} σ² and {errors[c][1]:.3g} σ²"
                                      for c in verdict["causes"] if c != winner)
                          + f": it fits both records better than {named}, by more than the noise can make on at "
                          "least one, so it is named")
                verdict = dict(verdict, cause=winner, causes=(winner,), best=winner, structure=True)
                validation.update(cause=winner, causes=[winner], verdict_by="both records",
                                  structures={c: {"first_sigma2": e1, "second_sigma2": e2}
                                              for c, (e1, e2) in errors.items()},
                                  remark=validation["remark"] + remark, note=validation["note"] + remark)

    def delivered_by_second_record(verdict):
        """(verdict, remark): the member of the set whose model predicts the second record best
        first, when one does so beyond the noise; else the verdict as it is and ''."""
        delivered = best_predictor_of_set(candidates, tuple(verdict["causes"]), y2, validation["noise_um"])
        if delivered is None:
            return verdict, ""
        member, errors = delivered
        first = verdict["causes"][0]
        remark = (f"; of the set, {member}'s model predicts the second record best ({errors[member]:.3g} σ² against "
                  f"{errors[first]:.3g} σ² for {first}'s, by more than the noise can make), so it is the model "
                  "delivered until the excitation tells the set apart")
        return delivering_verdict(verdict, validation, member, remark, delivered_sigma2=errors), remark

    named_verdict, delivery_remark = verdict, ""   # the why tells how the causes were named; the delivery is a remark
    if validation is not None and len(verdict["causes"]) > 1:
        verdict, delivery_remark = delivered_by_second_record(verdict)
    joint_first = {}     # cause -> its fit on both records' median held-out block of the first record (µm²)
    if validation is not None and len(verdict["causes"]) > 1 and not unidentified and not shape:
        found = best_fitted_on_both_records(fitter, candidates, tuple(verdict["causes"]), v2, y2, T, folds,
                                            noise, validation["noise_um"], joint_first)
        if found is not None:
            sentence = ("; but" if delivery_remark else ";") + both_records_sentence(*found, verdict["causes"][0])
            delivery_remark += sentence
            verdict = delivering_verdict(verdict, validation, found[0], sentence, delivered_by="both records",
                                         delivered_both_sigma2={c: list(e) for c, e in found[1].items()})
    still_in_holds, held_sentence = "", ""
    if verdict["cause"] == "unexplained" or verdict["cause"] in EFFECTS:
        # what no candidate explains may be a hysteresis shape outside the model class or an effect
        # outside the catalogue, and a named cause may be a shape error that its dynamics absorb;
        # holds of the input tell them apart, as a rate-independent actuator's output does not move
        # in them (outside-class seeds 97 and 113: Bouc-Wen actuators without an effect, a staircase
        # first, `unexplained` on band-limited noise; seeds 1 and 25: the same with the staircase
        # second, rate-dependent hysteresis and creep named, whose models move in its holds)
        voters = voting_holds(
            [(source or "the record fitted", v, y, baseline.prediction_um, noise)]
            + ([] if validation is None or baseline.validation is None else
               [(validate_source or "the second record", v2, y2, baseline.validation["prediction_um"],
                 validation["noise_um"])]))
        held = still_holds(voters)

        def prediction(c, index):
            ev = candidates[c]
            if index == 0:
                return ev.prediction_um
            return None if ev.validation is None else ev.validation["prediction_um"]

        # (nothing is contradicted where no record holds still: `held` is then empty)
        contradicted = (contradicted_by_holds(held, verdict["causes"], prediction)
                        if verdict["cause"] in EFFECTS else {})
        if contradicted:
            delivered_ruled_out = verdict["cause"] in contradicted
            held_sentence = contradicted_sentence(contradicted)
            kept = tuple(c for c in verdict["causes"] if c not in contradicted)
            if kept:
                verdict = dict(verdict, cause=kept[0], causes=kept, best=kept[0])
                out = f"{', '.join(contradicted)} {'is' if len(contradicted) == 1 else 'are'} ruled out"
                held_sentence = f"{out}: {held_sentence}"
                if validation is not None:
                    validation.update(cause=kept[0], causes=list(kept))
                    if len(kept) > 1 and delivered_ruled_out:
                        # the member delivered is ruled out: the rest are weighed by the second record
                        # as any set is, not taken in their order
                        verdict, delivery_remark = delivered_by_second_record(verdict)
            else:
                still_in_holds = f"{held_sentence}; and {still_sentence(held)}"
        elif held and verdict["cause"] == "unexplained":
            still_in_holds = still_sentence(held)
        elif voters and not held and verdict["cause"] in EFFECTS and verdict["cause"] != "drift":
            # the holds move: there every model's hysteresis part is constant, so the motion is the
            # effect alone, free of the shape error (outside-class seeds 29 and 101: Bouc-Wen actuators
            # behind lags, named creep and an input low-pass, whose models leave 52 and 1.3 σ² of the
            # holds' motion, the lag's 3.4 and 0.02).  The causes the holds prefer join the verdict
            # first; the named ones stay, because the holds do not see how a model carries the
            # hysteresis to a new input (independent pair 153: creep, delivered for predicting the
            # second record at 6 σ² against the lag's 357, leaves the most motion in the holds)
            named = verdict["cause"]
            preferred = preferred_by_holds(voters, named, [c for c in candidates if c not in ("drift", named)],
                                           prediction)
            if preferred is not None:
                winners, motions = preferred
                kept = verdict["causes"]
                # the member the second record chose to deliver stays first; the others follow the holds
                lead = kept[:1] if delivery_remark else ()
                causes_now = tuple(dict.fromkeys(lead + tuple(winners) + tuple(kept)))
                held_sentence = (
                    f"in the holds of {' and '.join(h.name for h in voters if h.excess_sigma2 >= NOISE_FRACTION)}, "
                    "where every model's hysteresis part stands still and the motion is the effect alone, "
                    + ", ".join(f"{c}'s model leaves {motions[c]:.3g} σ²" for c in winners)
                    + f", {named}'s {motions[named]:.3g} σ² and the plain fit's {motions['plain']:.3g} σ²: "
                    f"the holds add {' and '.join(winners)} to the causes named")
                verdict = dict(verdict, cause=causes_now[0], causes=causes_now, best=causes_now[0])
                if validation is not None:
                    validation.update(cause=causes_now[0], causes=list(causes_now), verdict_by="holds",
                                      holds_motion_sigma2={c: float(m) for c, m in motions.items()})
                    if not delivery_remark:
                        # no member was chosen yet: the one of the new set whose model predicts the
                        # second record best, as for any set
                        verdict, delivery_remark = delivered_by_second_record(verdict)
        if still_in_holds:
            verdict = {**verdict, "cause": "none", "causes": (), "best": None, "explained_share": 0.0, "text": ""}
        if validation is not None and (still_in_holds or held_sentence):
            validation["note"] += f"; {still_in_holds or held_sentence}"
    each_alone = ""
    if (verdict["cause"] == "unexplained" and cv_verdict["cause"] == "none" and validation is not None
            and not unidentified and not _swap_reason):
        # the first record shows no effect out of sample, and only its models' prediction of the second
        # record is left unexplained: that is an effect of the catalogue's or outside it, or the first
        # record's hysteresis part on an input it never showed (a hysteresis outside the MPI class:
        # minor loops that are not congruent, loops that overshoot after a reversal).  The second
        # record diagnosed on its own tells them apart: an effect shows there too (outside-class
        # seed 96: a Preisach actuator, no effect; each record alone names nothing, the first
        # record's models leave the second at 90.6 σ²)
        each_alone, alone = _second_record_shows_none(v2, y2, rate2, validate_source, n_operators=n_operators,
                                                      model=model, operator=operator, train_fraction=train_fraction,
                                                      repair_artefacts=repair_artefacts)
        if not each_alone and alone is not None and alone.cause in EFFECTS:
            # the second record alone names a cause the first record does not show: fitted on the second
            # record and scored on the first, a real effect is confirmed there; a shape error of the
            # second record's taken for an effect (a Bouc-Wen overshoot after reversals read as a lag
            # or creep) is not
            first, second = source or "the first record", validate_source or "the second record"
            turned = in_turn(f"{first} shows no effect out of sample, its models leave {second} unexplained, and "
                             f"{second} on its own names {', '.join(alone.causes)}")
            if turned is not None and turned.cause in EFFECTS and set(turned.causes) & set(alone.causes):
                return reported(turned)
            if turned is not None and turned.cause == "none":
                each_alone = (f"{second}, diagnosed on its own, names {', '.join(alone.causes)}, but fitted there and "
                              f"scored on {first} nothing is confirmed")
        if each_alone:
            first = source or "the record fitted"
            each_alone = (
                f"nothing is named: {first} shows no effect out of sample, and {each_alone}; what the first "
                f"record's models leave on {validate_source or 'the second record'} is therefore their hysteresis "
                "part on an input the first record never showed (a hysteresis outside the MPI class, such as minor "
                "loops that are not congruent or loops that overshoot after a reversal), not an effect: the plain "
                "fit is delivered, and a hysteresis that predicts both records needs a record whose input moves "
                "through both records' paths")
            verdict = {**verdict, "cause": "none", "causes": (), "best": None, "explained_share": 0.0, "text": ""}
            validation.update(cause="none", causes=[], verdict_by="each record alone",
                              note=f"{validation['note']}; {each_alone}")
    general = ""
    named_before, named_set = verdict["cause"], tuple(verdict["causes"])
    # what the named cause's own model, fitted on the first record, leaves on the second (σ²)
    named_left = _left_on_second_record(candidates[named_before], validation) if named_before in EFFECTS else 0.0
    plain_left = _left_on_second_record(baseline, validation)
    none_asked = (named_before == "none" and validation is not None and not unidentified and not _swap_reason
                  and plain_left >= PLAIN_MISS_LEVEL and not still_in_holds)
    if none_asked and not turn_tried and not each_alone:
        # the MPI models' own way first: an effect the first record's input does not excite shows
        # when the second record is the one fitted (independent pair 2: creep a sine hides and a
        # multisine shows; the MPI model fitted there is the one delivered)
        turn_tried = True
        turned = in_turn(_NO_EFFECT_SHOWN.format(first=source or "the first record",
                                                 second=validate_source or "the second record"))
        if turned is not None and turned.cause in EFFECTS:
            return reported(turned)
    # named creep: the general model with creep on both records, fitted once (it gives the model
    # delivered its modes, below); when it puts no weight on any mode, the richest model sees no creep
    # in either record, and the name is put to it (outside-class seed 73: a Bouc-Wen actuator without
    # an effect, named creep by the MPI models, whose model carries to the second record; every
    # creep record of seeds 0-146 gets modes of 2-13 % there, and so does every in-class one tried)
    general_creep = (creep_on_both_records(v, y, T, v2, y2, T)
                     if validation is not None and not unidentified and named_before == "creep" else None)
    creep_unseen = general_creep is not None and max(general_creep.creep["weights"]) <= NO_CREEP_WEIGHT
    if (validation is not None and not unidentified
            and (named_before == "unexplained" or none_asked or creep_unseen
                 or (named_left >= UNEXPLAINED_LEVEL and _general_model_can_judge(candidates[named_before])))):
        # the MPI models leave the records unexplained, or the named cause's model leaves the second
        # record far above its noise: an effect outside what they can show, or their loop shape (a
        # Preisach actuator's minor loops are not congruent, and no MPI model carries from one input
        # to another) that an effect stood in for.  A model that holds every Preisach hysteresis,
        # fitted on both records together, tells them apart: a rate-independent actuator fits both to
        # the noise, a rate effect does not, and the effect that brings it there is the cause
        # (outside-class seeds 8, 24, 32, 40: Preisach actuators without an effect, both records
        # fitted within 0.07 σ² of their noise; seed 4: a 2 ms lag, 12.7 σ² left, 0.02 σ² with the
        # lag; seed 60: a 2 ms lag named an input low-pass, whose model left the second record far
        # above its noise: on the general model the lag leaves 0.03 σ², the input low-pass 21).  A
        # named cause is put to it only when the general model holds that cause too (not a resonance,
        # a slew limit or a drift), and it is replaced by a decisive other effect, or by `none` when
        # the general model alone fits each record within the noise margin and leaves under
        # NEAR_NOISE_FRACTION σ² over both: the richest rate-independent model leaves nothing for the
        # cause to explain, and the cause's own model does not carry to the second record
        # (outside-class seeds 49 and 121: Bouc-Wen actuators without an effect named a lag and creep,
        # whose models leave the second record 142 and 99 σ² above its noise; the general model
        # alone 0.02 σ² or less; seed 27, Bouc-Wen creep named right, where it leaves 0.16 σ², keeps
        # its name).  A `none` is put to it when the plain MPI fit misses the second record by as
        # much as its noise (the holds did not show the actuator standing still): an effect the MPI
        # models could not tell from their loop shape (outside-class seeds 18, 34, 50, 74, 114, 146:
        # Preisach creep named `none`, the plain fit leaving the second record 4.5-144 σ² above its
        # noise; on the general model creep takes 0.56-7.1 σ² to the noise).  It is replaced only by
        # a decisive effect; an MPI actuator without one fits the second record within 1 σ² and is
        # never asked
        said = verdict_on_both_records(effects_on_both_records(v, y, T, v2, y2, T, stop_at_noise=True))
        # what stands of a verdict the MPI models named: nothing decisive, or a set that holds the name
        # already, changes nothing; `none` only replaces a cause where the model alone leaves nothing
        keeps_name = said["cause"] is None or bool(set(named_set) & set(said["causes"]))
        none_too_weak = said["cause"] == "none" and (named_before == "none"
                                                     or said["left_sigma2"]["none"] > NEAR_NOISE_FRACTION)
        if named_before != "unexplained" and (keeps_name or none_too_weak):
            said = dict(said, cause=None)
        if said["cause"] is not None:
            general = said["sentence"]
            if named_before == "none":
                general = (f"nothing was named, but the plain fit of the first record leaves the second "
                           f"{plain_left:.3g} σ² above its noise, and {general}")
            elif creep_unseen:
                general = (f"{', '.join(named_set)} {'was' if len(named_set) == 1 else 'were'} named, but "
                           "the general model with creep, fitted on both records, puts no weight on any creep "
                           f"mode, and {general}")
            elif named_before != "unexplained":
                general = (f"{', '.join(named_set)} {'was' if len(named_set) == 1 else 'were'} named, but "
                           f"{named_before}'s model, fitted on the first record, leaves the second "
                           f"{named_left:.3g} σ² above its noise, and {general}")
            named_now = said["cause"]
            verdict = {**verdict, "cause": named_now, "causes": said["causes"],
                       "best": None if named_now == "none" else named_now, "explained_share": 0.0, "text": ""}
            validation.update(cause=named_now, causes=list(said["causes"]), verdict_by="general model on both records",
                              general_model_left_sigma2=said["left_sigma2"],
                              note=f"{validation['note']}; {general}")
            if validation.get("delivered") not in (None, *said["causes"]):
                # a member delivered from the set named before that this verdict does not hold
                validation.pop("delivered")
                validation.pop("delivered_sigma2", None)
            if named_now != "none" and len(said["causes"]) > 1:
                verdict, delivery_remark = delivered_by_second_record(verdict)
        elif named_before == "unexplained":
            validation.update(general_model_left_sigma2=said["left_sigma2"],
                              note=f"{validation['note']}; {said['sentence']}")
        elif named_before == "none":
            validation.update(general_model_left_sigma2=said["left_sigma2"],
                              note=f"{validation['note']}; the plain fit of the first record leaves the second "
                                   f"{plain_left:.3g} σ² above its noise, and {said['sentence']}: nothing is named")
        else:
            # the judgement is reported where it keeps the name too
            asked_because = ("the general model with creep, fitted on both records, puts no weight on any creep "
                             "mode" if creep_unseen else
                             f"{named_before}'s model, fitted on the first record, leaves the second "
                             f"{named_left:.3g} σ² above its noise")
            validation.update(general_model_left_sigma2=said["left_sigma2"],
                              note=f"{validation['note']}; {asked_because}, and {said['sentence']}: the name stands")
    cause, causes = verdict["cause"], verdict["causes"]
    held = split.heldout
    residual = y - baseline.prediction_um
    stats = residual_statistics(residual[held], v[held], sample_rate_hz, noise)
    plain = Evaluation(baseline.fit, baseline.rms_pct, baseline.max_pct, baseline.rms_um, baseline.train_rms_pct,
                       cv_prediction_um=baseline.cv_prediction_um, character=baseline.character,
                       validation=baseline.validation)
    extended = (candidates[cause] if cause in EFFECTS else
                candidates[verdict["best"]] if cause == "unexplained" and verdict["best"] is not None else plain)
    unexplained_sentence = ""
    if cause == "unexplained" and extended is not plain and validation is None:
        # no cause is named and no record it was not fitted on tests the best candidate: its model is
        # fitted to what the catalogue does not explain (on actuators outside the MPI class, mostly the
        # loop shape), and alone it predicted a third record worse than the plain fit on 15 of the 20
        # such records measured (outside-class seeds 0-95, first record alone: up to 10.6x; better on 5,
        # by at most 26 %)
        unexplained_sentence = (
            f"the model delivered is the plain fit: the best candidate, {extended.cause}, is fitted to what no "
            "cause of the catalogue explains, and without a second record nothing tests how it predicts a new "
            "input (give one: `--validate`, or `validate=` in Python)")
        extended = plain
    modes_sentence = ""
    if validation is not None and extended is not plain and extended.cause == "creep" and not unidentified:
        # creep's modes from the general model on both records, where they cannot take up the MPI
        # model's loop-shape error (creep_modes_of_both_records)
        found = creep_modes_of_both_records(fitter, run, extended, v2, y2, general_creep)
        if found is not None:
            extended, modes_sentence = found
            if "first" in shape:
                correct_like_the_others(extended, folds, y, mask, first_memory)
            gains(extended)
            validation.update(delivered_creep_modes="general model on both records",
                              note=f"{validation['note']}; {modes_sentence}")
    withheld_sentence = ""
    # an extension fitted with its own hysteresis part may carry that part to a new input worse than
    # the plain fit does (operators the first record barely moves, a range it never reaches): one that
    # predicts the second record worse is not a better model of the actuator, so it is not delivered
    # (the cause it names still stands)
    misleads = (predicts_second_record_better(extended, baseline, y2, validation["noise_um"], as_fitted=True)
                if validation is not None and extended is not plain else None)
    if misleads is not None:
        withheld_sentence = (
            f"{extended.cause}'s model, fitted on the first record, predicts the second record worse than the "
            f"plain fit ({misleads[0]:.3g} σ² against {misleads[1]:.3g} σ², by more than the noise can make): its "
            "hysteresis part, fitted together with the effect, does not carry to a new input, so the model "
            f"delivered is the plain fit; fit {extended.cause} again on a record that moves the whole range")
        validation.update(delivered="baseline", withheld=extended.cause,
                          withheld_sigma2={extended.cause: misleads[0], "baseline": misleads[1]},
                          note=f"{validation['note']}; {withheld_sentence}")
        extended = plain
    both_sentence = ""
    if validation is not None and extended is not plain and not unidentified and not shape:
        # the cause is named; what it predicts of a new input improves with all the data there is:
        # the delivered model's hysteresis and effect parameters are refitted on both records, when
        # that predicts the first record's held-out blocks no worse (not after a shape correction:
        # its scores are of corrected predictions)
        joint = fit_on_both_records(fitter, extended, v2, y2, T, folds, noise,
                                    None if modes_sentence else joint_first.get(extended.cause))
        if joint is not None:
            fit, first_rms_pct, second_rms_pct = joint
            both_sentence = (
                f"the model delivered is {extended.cause}'s refitted on both records (its shape parameters kept; "
                "hysteresis and effect parameters shared, each record with its own initial state and sensor "
                f"offset): RMS {first_rms_pct:.3g} % of range on the first record (fitted on it alone: "
                f"{extended.train_rms_pct:.3g} %), {second_rms_pct:.3g} % on the second")
            validation.update(delivered_fit="both records", delivered_first_rms_pct=first_rms_pct,
                              delivered_second_rms_pct=second_rms_pct,
                              note=f"{validation['note']}; {both_sentence}")
            extended = replace(extended, fit=fit, train_rms_pct=first_rms_pct)
    why = _why(named_verdict, cv_verdict, baseline, richer, candidates, noise,
               None if unidentified else validation)
    if still_in_holds:
        why = f"nothing is named: {still_in_holds}. Without the holds the verdict would be {why}"
    elif general:
        # before `each_alone`: the general model judged the `none` that the records alone gave
        named_how = ("nothing is named" if cause == "none" else
                     f"{', '.join(causes)} {'is' if len(causes) == 1 else 'are'} named")
        before = (f"nothing would be named: {each_alone.removeprefix('nothing is named: ') or why}"
                  if named_before == "none" else f"the verdict would be {why}")
        why = f"{named_how} by the two records together: {general}. Without the general model {before}"
    elif each_alone:
        why = f"{each_alone}. Without the second record on its own the verdict would be {why}"
    elif held_sentence:
        why += f". {held_sentence[0].upper()}{held_sentence[1:]}"
    if unidentified:
        why += f". The record cannot identify the hysteresis: {unidentified}{delivery_remark}"
    if modes_sentence:
        why += f". {modes_sentence[0].upper()}{modes_sentence[1:]}"
    if withheld_sentence:
        why += f". {withheld_sentence}"
    if unexplained_sentence:
        why += f". {unexplained_sentence[0].upper()}{unexplained_sentence[1:]}"
    if both_sentence:
        why += f". {both_sentence[0].upper()}{both_sentence[1:]}"
    for which, found in shape.items():
        where_found = "the record fitted" if which == "first" else "the second record"
        why += (f". On {where_found} the input's path alone predicts {found['removed_sigma2']:.3g} σ² of what "
                f"the rate-independent models leave ({found['shape_rms_pct']:.2g} % of range RMS; "
                f"{found['left_sigma2']:.3g} σ² left): a rate-independent error -- "
                + ("a hysteresis shape outside the model class" if which == "first" else
                   "a hysteresis shape outside the model class, or the first record's hysteresis part on an input "
                   "it never showed")
                + " -- so every model there is compared after the same path-only correction"
                + (f"; the {found['left_sigma2'] - 1.0:.3g} σ² still above the noise is most likely the rest of "
                   "that shape (the nearest paths of other blocks cannot teach all of it), not an effect outside "
                   "the catalogue" if cause == "none" and found["left_sigma2"] - 1.0 >= UNEXPLAINED_LEVEL else ""))
    if noise_free:
        why += (f". The record fitted shows no measurable noise (below {NOISE_FREE_FRACTION:g} of its range, as a "
                f"simulation gives): every error is weighed against {100 * VALIDATED_NOISE_FRACTION:g} % of the "
                "range instead, the lowest noise the diagnosis was measured at, so a smaller effect is not seen; "
                "add the sensor's noise to a simulated record to weigh it against that")
    if cause == "none" and not any(holds_after_a_step(x, sample_rate_hz) for x in
                                   ((v,) if validate is None else (v, v2))):
        # a moving input lets the hysteresis fit absorb slow creep (third generator's seed 197: creep of
        # 0.05 s and 0.71 s, 6 σ on the record, 0.02 σ² left out of sample); a hold after a step does not
        why += (f". No step of the input goes into a hold of {CREEP_HOLD_S:g} s or more, where creep keeps moving "
                "while the input rests: creep that the hysteresis fit absorbs on a moving input is not ruled out; "
                "`pysim excite RECORD --causes creep --out steps.csv` writes steps held long to play and diagnose")
    if _swap_reason:
        swap = (f"the records' roles are swapped: {_swap_reason}, so every model is fitted on {source} and "
                f"scored on {validate_source}")
        why = f"{swap}. {why}"
        validation["note"] += f"; {swap}"
    excitation, plan = None, []
    if len(causes) > 1:
        lo, hi = float(v.min()), float(v.max())
        excitation, plan = separating_excitation(causes, (lo, hi), sample_rate_hz, max(v.size, 6000),
                                                 candidates={c: candidates[c].fit.parameters for c in causes})
        why += (f". The record cannot tell {', '.join(causes)} apart (their errors differ by less than "
                f"{100 * TIE_FRACTION:.0f} % of what the best leaves above the noise, or than the noise margin): play the excitation written by `pysim excite` "
                f"({'; '.join(p['purpose'] for p in plan)}) and diagnose that record")
    statistics = {"baseline": stats,
                  "extended": residual_statistics((y - extended.prediction_um)[held], v[held], sample_rate_hz,
                                                  noise)}
    # only the steps named the cause when the second record neither named nor confirmed it
    steps_alone = bool(cv_verdict.get("steps") and validation is not None
                       and validation["verdict_by"] == "cross-validation")
    if ((cause == "none" or steps_alone) and validate is not None and not unidentified and not _swap_reason
            and not turn_tried and not still_in_holds and not each_alone and not general):
        # an effect that the first record's input does not excite (creep that a single sine hides in
        # the loop's shape and a multisine shows) is found only when the second record is the one
        # fitted and cross-validated; its verdict must then hold on the first record, by the same rules.
        # So too when only the first record's steps name a cause: the steps' look-alikes (a lag, an
        # input low-pass, a delay) may be told apart by the second record fitted in its turn
        first, second = source or "the first record", validate_source or "the second record"
        turned = in_turn((_STEPS_ALONE if steps_alone else _NO_EFFECT_SHOWN).format(first=first, second=second))
        if turned is not None and turned.cause in EFFECTS:
            return reported(turned)
    return reported(Diagnosis(cause=cause, split=split, sample_period_s=T, noise_um=noise, baseline=baseline,
                              candidates=candidates, extended=extended, statistics=statistics,
                              reasons=_reasons(candidates, stats, cv_verdict.get("steps")), why=why, time_s=time,
                              voltage_V=v,
                              displacement_um=y, source=source, causes=tuple(causes), excitation=excitation,
                              richer=richer, folds=[{"train_samples": int(t.size), "scored_samples": int(s.size)}
                                                    for t, s in folds],
                              scored_samples=int(np.count_nonzero(mask)), cross_validation_cause=cv_verdict["cause"],
                              cross_validation_causes=tuple(cv_verdict["causes"]), validation=validation,
                              excitation_plan=plan, start_excluded_samples=start,
                              records_swapped=bool(_swap_reason), swap_reason=_swap_reason,
                              steps=cv_verdict.get("steps"), shape=shape, noise_free=noise_free))


def _second_record_shows_none(v2, y2, sample_rate_hz, validate_source, **options) -> tuple:
    """(sentence, diagnosis): the sentence that the second record, diagnosed on its own, shows no
    effect ('' when it names a cause, is left unexplained or cannot be diagnosed alone), and that
    diagnosis (None when there is none)."""
    name = validate_source or "the second record"
    try:
        alone = diagnose(v2, y2, sample_rate_hz, source=name, **options)
    except DiagnosisError:
        return "", None
    if alone.cause != "none" or alone.noise_free:
        return "", alone
    return (f"{name}, diagnosed on its own (its own rate-independent fit, every cause fitted and cross-validated "
            f"there), names nothing either (its own plain fit leaves {alone.baseline.rms_pct:.3g} % of range RMS "
            "out of sample)"), alone


def _why(verdict, cv_verdict, baseline, richer, candidates, noise, validation) -> str:
    if verdict.get("structure") and validation is not None:
        # named by how the structures fit both records (structure_on_both); the remark says by how much
        cause, table = verdict["cause"], validation["table"]
        return (f"{cause} lowers the error significantly on the record fitted (cross-validated "
                f"{baseline.rms_pct:.3g} % → {candidates[cause].rms_pct:.3g} % of range) and the second record's "
                f"({table['baseline']['rms_pct']:.3g} % → {table[cause]['rms_pct']:.3g} %), and of the look-alike "
                f"dynamics its structure fits both records best" + validation["remark"])
    if validation is not None and validation.get("verdict_by") != "second record":
        # the second record could not decide: the cross-validated verdict, and why it stands
        return _why(verdict, cv_verdict, baseline, richer, candidates, noise, None) + validation["remark"]
    by = "on the second record" if validation is not None else "out of sample (blocked cross-validation)"
    ref = "richer" if richer.mse_um2 < baseline.mse_um2 else "baseline"
    cause = verdict["cause"]
    if cause in EFFECTS:
        ev = candidates[cause]
        if validation is not None:
            row = validation["table"][cause]
            text = (f"{cause} lowers the error on the second record significantly"
                    + ("" if not ev.significant or verdict.get("told_apart") else
                       " and, of the candidates that do so on both records, the most on both together"
                       if verdict.get("best") in (None, cause) else
                       " and, of the candidates that do so on both records and tie, the one with the fewest "
                       "parameters") + ": second record RMS "
                    f"{validation['table']['baseline']['rms_pct']:.3g} % → {row['rms_pct']:.3g} % of range (richer "
                    f"rate-independent model {validation['table']['richer']['rms_pct']:.3g} %), cross-validated "
                    f"{baseline.rms_pct:.3g} % → {ev.rms_pct:.3g} %")
        elif verdict.get("steps"):
            steps = verdict["steps"]
            text = (f"{cause} predicts the responses to {steps['windows']} step{'s' if steps['windows'] > 1 else ''} "
                    f"into holds best, each left out of its fit: of the {steps['excess_sigma2']:.3g} σ² that the "
                    f"best rate-independent model leaves above the noise in the {steps['samples']} samples after "
                    f"them, it removes {100 * steps['removed_share'][cause]:.0f} % (the median over the "
                    f"cross-validation blocks, {baseline.rms_pct:.3g} % → {ev.rms_pct:.3g} % of range, does not "
                    f"weigh so few samples; σ = {noise:.3g} µm)")
        else:
            text = (f"{cause} lowers the cross-validated RMS error the most: {baseline.rms_pct:.3g} % → "
                    f"{ev.rms_pct:.3g} % of range ({ev.gain_pct:.1f} % less; {ev.gain_vs_richer_pct:.1f} % less "
                    f"than the best rate-independent model, the {ref}; {ev.excess_over_noise:.3g} σ² removed, "
                    f"σ = {noise:.3g} µm)")
        others = [c for c in verdict["causes"] if c != cause]
        if others:
            text += f"; {', '.join(others)} explain it as well"
        return text + ("" if validation is None else validation["remark"])
    lost = verdict.get("not_where_states_seen") or (cv_verdict or {}).get("not_where_states_seen") or ()
    lost_text = ""
    if lost:
        lost_text = "; ".join(
            f"{c} lowers the cross-validated error by {candidates[c].excess_over_noise:.3g} σ² against the "
            f"better rate-independent model, but where every operator stays in states its training blocks "
            f"showed it removes {candidates[c].removed_where_states_seen_sigma2:.3g} σ²" for c in lost)
        lost_text += (": the advantage lies where the rate-independent models extrapolate operator states no "
                      "other block showed (minor loops that peak in one block), not in an effect")
    if cause == "unexplained":
        return f"unexplained {by}: {verdict['text']}" + (f" ({lost_text})" if lost else "")
    best = min(candidates.values(), key=lambda ev: ev.mse_um2) if candidates else None
    if best is None:
        return "no candidate could be fitted"
    if lost:
        return lost_text + f", so nothing is named; σ = {noise:.3g} µm"
    if validation is not None and baseline.validation is not None and richer.validation is not None:
        # named by the second record: its own figures (the first record's would contradict the verdict)
        scored = [ev for ev in candidates.values() if ev.validation is not None]
        if scored:
            best2 = min(scored, key=lambda ev: ev.validation["mse_um2"])
            ref2 = min(baseline.validation["mse_um2"], richer.validation["mse_um2"])
            noise2 = validation["noise_um"]
            gain2 = rms_gain_pct(best2.validation["mse_um2"], ref2)
            first = ""
            if cv_verdict is not None and cv_verdict.get("cause") in EFFECTS:
                named = candidates[cv_verdict["cause"]]
                first = (f"; on the record fitted, {named.cause} removed {named.excess_over_noise:.3g} σ² out of "
                         "sample, which the second record does not confirm")
            return (f"no candidate lowers the error on the second record significantly against both the "
                    f"baseline and the richer rate-independent model: the best there, {best2.cause}, removes "
                    f"{(ref2 - best2.validation['mse_um2']) / noise2**2:.3g} σ² (needs {NOISE_FRACTION}) and "
                    f"{gain2:.1f} % of the RMS error (needs {MIN_GAIN_PCT}){first}; σ = {noise2:.3g} µm "
                    "there" + validation["remark"])
    return (f"no candidate lowers the error {by} significantly against both the baseline and the richer "
            f"rate-independent model: the best, {best.cause}, removes {best.excess_over_noise:.3g} σ² "
            f"(needs {NOISE_FRACTION}) and {best.gain_vs_richer_pct:.1f} % of the RMS error (needs "
            f"{MIN_GAIN_PCT}), or near the noise {NEAR_NOISE_FRACTION} σ², half of the excess over the noise "
            f"and a removal that holds across the record; σ = {noise:.3g} µm")
