"""A hysteresis shape outside the model class, told from an effect by what it
depends on.

A rate-independent residual is a function of the input's path memory (the
present input and the turning points not yet wiped out); a lag, a delay,
creep or a drift also of the input's timing.  :func:`path_corrected` predicts
every model's cross-validated residual from the samples of the other blocks
with the nearest memory (:func:`pysim.diagnosis.path_memory.path_predicted`)
and, when that takes more than any effect does, compares every model after
the same correction, on the first record (:func:`correct_for_shape`) and on
a second one (:func:`correct_validation_for_shape`).
"""
from __future__ import annotations

import math

import numpy as np

from pysim.diagnosis.folds import contiguous_blocks
from pysim.diagnosis.path_memory import path_predicted
from pysim.diagnosis.rules import NOISE_FRACTION, UNEXPLAINED_LEVEL
from pysim.diagnosis.scoring import blocked_score

__all__ = ["path_corrected", "correct_for_shape", "correct_like_the_others", "correct_validation_for_shape"]


def path_corrected(predictions: dict, y, memory, blocks, score, noise_um: float, reference) -> tuple | None:
    """Every model's prediction plus what the input's path alone predicts of its residual -- when the
    record's hysteresis shape lies outside the model class.

    A rate-independent residual is a function of the input's path memory
    (:mod:`pysim.diagnosis.path_memory`); a residual that depends on the
    input's timing is not.  Each model's residual is predicted out of block
    from the samples with the nearest memory, and the prediction is added to
    the model's.  The correction counts (the shape is outside the class) when
    it removes ``UNEXPLAINED_LEVEL`` σ² or more of the better rate-independent
    model's error and leaves that model below every other model's
    uncorrected error by the noise margin (``NOISE_FRACTION`` σ²): the path
    explains more than any effect.  Then every model is compared after it --
    a shape error is neither named as an effect nor called unexplained, and
    an effect is named by what it removes beyond the shape.

    Parameters
    ----------
    predictions : dict
        Model → out-of-sample prediction (µm; NaN where not scored).
    y : ndarray
        Measured displacement, µm.
    memory : ndarray
        :func:`pysim.diagnosis.path_memory.path_memory` of the record's input.
    blocks : list of (train_rows, predicted_rows)
    score : callable
        ``score(model, prediction)`` → the mean-square error (µm²) of that
        model's prediction, as the record scores that model.
    noise_um : float
    reference : iterable
        The keys of the rate-independent models.

    Returns
    -------
    ``(corrected, evidence)`` -- model → corrected prediction, and a dict
    with ``removed_sigma2`` (the shape error removed from the better
    rate-independent model), ``left_sigma2`` (its error after) and
    ``shape_rms_pct`` (the shape error's RMS, % of the range of ``y``) -- or
    None when the correction does not count.

    Examples
    --------
    A loop the model misses (a Preisach-like shape) on a repeated triangle:

    >>> from pysim.diagnosis.path_memory import path_memory
    >>> v = np.tile(np.r_[np.linspace(0, 10, 100), np.linspace(10, 0, 100)], 10)
    >>> y = v + np.where(np.diff(v, prepend=0) >= 0, -0.5, 0.5)
    >>> y = y + np.random.default_rng(0).normal(0, 0.05, v.size)
    >>> blocks = [(np.setdiff1d(np.arange(v.size), b), b) for b in np.array_split(np.arange(v.size), 5)]
    >>> score = lambda model, p: float(np.mean((y - p) ** 2))
    >>> corrected, evidence = path_corrected({"baseline": v, "lag": v}, y, path_memory(v), blocks, score,
    ...                                      0.05, ["baseline"])
    >>> evidence["removed_sigma2"] > 90, evidence["left_sigma2"] < 3
    (True, True)
    """
    y = np.asarray(y, dtype=float)
    s2 = noise_um**2
    if not s2 > 0:
        return None
    keys = list(predictions)
    # every model's residual at once: the nearest paths are found once per block
    shapes = path_predicted(np.column_stack([y - predictions[k] for k in keys]), memory, blocks)
    corrected = {k: _plus_shape(predictions[k], shapes[:, i]) for i, k in enumerate(keys)}
    before = {k: score(k, p) for k, p in predictions.items()}
    after = {k: score(k, p) for k, p in corrected.items()}
    reference = list(reference)
    ref_before, ref_after = min(before[k] for k in reference), min(after[k] for k in reference)
    others = [before[k] for k in predictions if k not in reference]
    if ref_before - ref_after < UNEXPLAINED_LEVEL * s2 or (others and ref_after > min(others) - NOISE_FRACTION * s2):
        return None
    span = float(np.ptp(y[np.isfinite(y)]))
    return corrected, {"removed_sigma2": float((ref_before - ref_after) / s2), "left_sigma2": float(ref_after / s2),
                       "shape_rms_pct": 100.0 * math.sqrt(max(ref_before - ref_after, 0.0)) / span if span > 0
                       else float("nan")}


def correct_for_shape(evaluations, folds, y, mask, memory, noise_um) -> dict:
    """Apply :func:`path_corrected` to the cross-validated predictions of ``evaluations`` (the first two
    are the rate-independent models); the evidence, or {} when the shape is inside the class."""
    found = path_corrected({i: ev.cv_prediction_um for i, ev in enumerate(evaluations)}, y, memory, folds,
                           lambda _, p: blocked_score(y, p, folds)[1], noise_um, (0, 1))
    if found is None:
        return {}
    corrected, evidence = found
    span = float(np.ptp(y[mask]))
    for i, ev in enumerate(evaluations):
        _rescored(ev, corrected[i], folds, y, span)
    return evidence


def correct_like_the_others(evaluation, folds, y, mask, memory) -> None:
    """Correct one more model's cross-validated prediction as :func:`correct_for_shape` corrected
    the others (after it found that the correction counts): its residual's part that the input's
    path alone predicts is added, and it is scored again."""
    shape = path_predicted((y - evaluation.cv_prediction_um)[:, None], memory, folds)[:, 0]
    _rescored(evaluation, _plus_shape(evaluation.cv_prediction_um, shape), folds, y, float(np.ptp(y[mask])))


def _plus_shape(prediction_um, shape_um):
    """The prediction plus the path-predicted shape error, where the path predicts one."""
    return np.where(np.isfinite(shape_um), prediction_um + shape_um, prediction_um)


def _rescored(evaluation, prediction_um, folds, y, span_um: float) -> None:
    evaluation.cv_prediction_um = prediction_um
    evaluation.per_block_mse_um2, score = blocked_score(y, prediction_um, folds)
    evaluation.rms_um = math.sqrt(score)
    evaluation.rms_pct = 100.0 * evaluation.rms_um / span_um


def correct_validation_for_shape(evaluations, v2, y2, noise2_um, memory2) -> dict:
    """The same on the second record, for the scores of :func:`score_on_record` (the first two
    evaluations are the rate-independent models; ``memory2``: the second record's path memory).
    Every model is scored on the samples :func:`score_on_record` scored it on (for an input stage,
    where the stage's output stays inside the range it showed on the first record)."""
    rows = [ev.validation["scored_rows"] for ev in evaluations]

    def score(i, prediction):
        return float(np.mean((y2[rows[i]] - prediction[rows[i]]) ** 2))

    found = path_corrected({i: ev.validation["prediction_um"] for i, ev in enumerate(evaluations)}, y2,
                           memory2, contiguous_blocks(v2.size), score, noise2_um, (0, 1))
    if found is None:
        return {}
    corrected, evidence = found
    for i, ev in enumerate(evaluations):
        mse = score(i, corrected[i])
        span = float(np.ptp(y2[rows[i]]))
        # the prediction as fitted is kept: whether a model carries its hysteresis part to a new input
        # is what the correction hides (it is itself a rate-independent fit of that record)
        ev.validation = dict(ev.validation, prediction_um=corrected[i], mse_um2=mse,
                             rms_pct=100.0 * math.sqrt(mse) / span, shape_corrected=True,
                             as_fitted_prediction_um=ev.validation["prediction_um"])
    return evidence
