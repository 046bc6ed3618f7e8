"""The outcome of a diagnosis (:class:`Diagnosis`) and its JSON report."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pysim.diagnosis.folds import Split
from pysim.diagnosis.scoring import Evaluation

__all__ = ["Diagnosis"]

#: Per-sample arrays of a model's second-record scores, left out of the JSON.
_VALIDATION_ARRAYS = ("prediction_um", "scored_rows", "as_fitted_prediction_um")


@dataclass
class Diagnosis:
    """Outcome of :func:`pysim.diagnosis.diagnose.diagnose` (see :meth:`as_json` for the report format).

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
        Spikes, jumps, flat runs and mains hum of the displacement that no model of the
        actuator explains (:func:`pysim.diagnosis.artefacts.record_artefacts`),
        each with ``record`` ("first" or "second", as given) and ``repaired``
        (spikes, jumps and hums are, before the diagnosis, unless
        ``repair_artefacts=False``; ``displacement_um`` is then the repaired
        record).  Samples count from the record's first.
    noise_free : bool
        The record fitted shows no measurable noise (a simulation:
        :func:`pysim.diagnosis.residuals.is_noise_free`); ``noise_um`` is then
        0.1 % of its range, the lowest noise the diagnosis was measured at.
    voltage_noise_V : float
        σ of the white noise of the voltage as measured
        (:func:`pysim.diagnosis.residuals.input_noise_sigma`); a cause must
        remove more error than it adds to every model (:func:`decide`).
    moving_holds : dict or None
        When the holds of the input moved where nothing else was named and a
        cause's model took up that motion
        (:func:`pysim.diagnosis.holds.named_by_moving_holds`): the records,
        ``holds``, ``dof``, ``t`` (the plain fit's motion in standard errors)
        and ``motion_sigma2`` (cause and ``"plain"`` -> the motion left, σ²).
        None otherwise.
    general_model : dict or None
        Without a second record, when the MPI models left the record
        ``unexplained``: what the general rate-independent model fitted on the
        record's two halves said (``fitted_on``, ``cause``: ``"none"``, a cause
        or None when the verdict stands, ``causes`` and ``left_sigma2``: what
        it leaves above the noise alone and with each effect, σ²).  None
        otherwise (with a second record this is in ``validation``).
    baseline, extended, richer : Evaluation
    candidates : dict
        Cause → Evaluation.
    rate_independent_spreads : tuple or None
        ``(baseline, richer)``: how far the record determines each
        rate-independent model's prediction of a full-range cycle, in noise σ
        (:func:`pysim.identification.determinacy.cycle_prediction_spread`);
        the extensions are fitted on the richer operator set only where it is
        determined.  None without a richer model.
    richer_determined : bool or None
        Whether the record decides the richer model
        (:attr:`pysim.diagnosis.candidates.CandidateFitter.richer_determined`: its spread, and
        more weights of its own than the baseline's).
    left_over : dict or None
        What the named cause's model leaves above the noise, σ²
        (:func:`pysim.diagnosis.diagnose.left_over`: ``held_out_sigma2``,
        ``plain_sigma2``, ``second_record_sigma2``, ``more_than_one_cause``);
        None when no cause is named.
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
    voltage_noise_V: float = 0.0
    general_model: dict = None
    moving_holds: dict = None
    rate_independent_spreads: tuple = None
    richer_determined: bool = None
    left_over: dict = None

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
                "mse_removed_beside_hold_levels_over_noise": _plain(ev.removed_beside_hold_levels_sigma2),
                "mse_removed_beyond_output_curvature_over_noise": _plain(ev.removed_beyond_output_curvature_sigma2),
                "miss_where_stage_moves_over_noise": _moved_miss(ev.explained_where_moved),
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
                "voltage_noise_V": self.voltage_noise_V,
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
                    **({} if self.rate_independent_spreads is None else {
                        "cycle_prediction_spread_sigma": dict(zip(("baseline", "richer"),
                                                                  self.rate_independent_spreads)),
                        "richer_determined": self.richer_determined}),
                },
                "measured_gain_um_per_V": measured_gain,
                "cross_validation_cause": self.cross_validation_cause,
                "cross_validation_causes": list(self.cross_validation_causes),
                "steps": self.steps,
                "shape": self.shape,
                "record_artefacts": self.artefacts,
                "validation": self.validation,
                "general_model": self.general_model,
                "moving_holds": self.moving_holds,
                "left_over_over_noise": self.left_over,
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


def _moved_miss(explained):
    """``{"without_stage", "with_stage", "samples"}`` of an input stage that moves few samples (the
    squared misses there in σ², summed), None for any other model."""
    if explained is None:
        return None
    without, with_stage, samples = explained
    return {"without_stage": without, "with_stage": with_stage, "samples": samples}


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
