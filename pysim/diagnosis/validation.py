"""Scoring a fitted model on a second record of the same actuator.

A model identified on one record meets a second one that started from another
history, through a sensor whose zero (and, a little, its gain) may have moved.
Neither is an effect of the actuator, so :func:`score_on_record` re-fits
exactly these, and nothing else, before it scores:

- the operator state before the second record's first sample (exact steps for
  each operator with the model's weights fixed; see
  :func:`pysim.identification.identify.best_clamped_state`);
- the sensor offset and gain (``y ≈ gain · model + offset``, least squares).

The timing is not re-fitted (``TIMING_SHIFTS_SAMPLES``): a shift chosen per
model can cancel the lag that a rate-dependent candidate adds, and on an
independent record it made a creep model that predicts new inputs worse than
the plain fit look better on the second record.  Different loggers' timing is
the user's to align (``timing_samples`` stays in the results, 0).

The score is taken where the second record's input stays inside the range of
the record the model was fitted on (no extrapolation).
"""
from __future__ import annotations

import numpy as np

from pysim.diagnosis.candidates import CandidateFit, initial_extended_state
from pysim.diagnosis.input_stages import InputStageModel
from pysim.diagnosis.residuals import noise_sigma, quantum
from pysim.identification.identify import best_clamped_state, operator_bounds

#: Alternations between the operator state and the offset/gain.
STATE_ROUNDS = 4
#: Timing shifts of the second record tried, samples (see the module notes: none).
TIMING_SHIFTS_SAMPLES = (0,)


def _affine(p, y):
    """Gain and offset of the least-squares fit ``y ≈ g p + c``."""
    A = np.column_stack([p, np.ones_like(p)])
    (g, c), *_ = np.linalg.lstsq(A, y, rcond=None)
    return float(g), float(c)


def _shifted(p, shift: int):
    """``p`` delayed by ``shift`` samples (edges repeated)."""
    if shift == 0:
        return p
    if shift > 0:
        return np.concatenate((np.full(shift, p[0]), p[:-shift]))
    return np.concatenate((p[-shift:], np.full(-shift, p[-1])))


def score_on_record(fit: CandidateFit, voltage_V, displacement_um, sample_period_s: float,
                    train_range_V, *, train_voltage_V=None) -> dict:
    """Score a fitted model on another record (see the module notes).

    Parameters
    ----------
    fit : CandidateFit
    voltage_V, displacement_um : array_like
        The other record.
    sample_period_s : float
    train_range_V : (float, float)
        Input range of the record the model was fitted on: only samples
        inside it are scored.
    train_voltage_V : array_like, optional
        That record's input itself.  For a model with an input stage the range
        that counts is the one its hysteresis saw -- the stage's output (a
        low-pass narrows a fast input's range, and a step on the other record
        can take it beyond) -- so it is computed from this record when given.

    Returns
    -------
    dict with ``rms_pct``, ``max_pct`` (% of the measured range of the scored
    samples), ``mse_um2``, ``offset_um``, ``gain``, ``timing_samples``,
    ``scored_samples``, ``noise_um`` (σ of the residual's white part),
    ``initial_state_V`` and ``prediction_um`` (after the re-fitted offset,
    gain and timing).

    Examples
    --------
    >>> import numpy as np
    >>> from pysim.core.extended import ExtendedModel, StageSpec
    >>> from pysim.core.model import HysteresisModel
    >>> h = HysteresisModel(0.0, 0.5, (0.0, 20.0), (0.0, 0.2), voltage_range_V=(0.0, 100.0))
    >>> plant = ExtendedModel(h, StageSpec(sample_period_s=1e-3))
    >>> v = 50 + 40 * np.sin(np.linspace(0, 20, 2000))
    >>> y = 1.02 * h.simulate(v) - 0.9
    >>> s = score_on_record(CandidateFit("baseline", plant, None, {}), v, y, 1e-3, (0.0, 100.0))
    >>> round(s["gain"], 6), round(s["offset_um"], 6), s["timing_samples"], s["rms_pct"] < 1e-9
    (1.02, -0.9, 0, True)
    """
    v = np.asarray(voltage_V, dtype=float)
    y = np.asarray(displacement_um, dtype=float)
    model = fit.model
    plant = getattr(model, "plant", model) if isinstance(model, InputStageModel) else model
    h = plant.hysteresis
    x = model.stage_input(v) if isinstance(model, InputStageModel) else v
    low, high = operator_bounds(x, h.thresholds_V, h.operator, h.input_offset_V)
    state = np.clip(np.zeros(h.n_operators), low[0], high[0])
    b = np.asarray(h.weights_um_per_V, dtype=float)

    def predict(s):
        return plant.simulate(x, initial_extended_state(plant, x[0], s))

    moving = [np.flatnonzero(high[:, i] - low[:, i] > 0) for i in range(h.n_operators)]
    if any(k.size for k in moving):
        for _ in range(STATE_ROUNDS):
            p = predict(state)
            g, c = _affine(p, y)
            e = y - g * p - c
            for i, k in enumerate(moving):
                if k.size == 0 or b[i] == 0.0 or g == 0.0:
                    continue
                L, U = low[k, i], high[k, i]
                current = np.clip(state[i], L, U)
                target = e[k] / (g * b[i]) + current
                new = best_clamped_state(target, L, U, low[0, i], high[0, i])
                e[k] -= g * b[i] * (np.clip(new, L, U) - current)
                state[i] = new
    p = predict(state)
    lo, hi = train_range_V
    level = v
    if isinstance(model, InputStageModel) and train_voltage_V is not None:
        seen = model.stage_input(np.asarray(train_voltage_V, dtype=float))
        lo, hi, level = float(seen.min()), float(seen.max()), x
    scored = np.flatnonzero((level >= lo) & (level <= hi))
    scored = scored[(scored > 0) & (scored < v.size - 1)]
    if scored.size < 10:
        scored = np.arange(1, v.size - 1)
    best = None
    for shift in TIMING_SHIFTS_SAMPLES:
        ps = _shifted(p, shift)
        g, c = _affine(ps[scored], y[scored])
        e = y[scored] - (g * ps[scored] + c)
        mse = float(np.mean(e**2))
        if best is None or mse < best[0] * (1 - 1e-9):
            best = (mse, shift, g, c, g * ps + c)
    mse, shift, g, c, prediction = best
    span = float(np.ptp(y[scored]))
    error = np.abs(y[scored] - prediction[scored])
    return {"rms_pct": 100.0 * float(np.sqrt(mse)) / span if span > 0 else float("nan"),
            "max_pct": 100.0 * float(error.max()) / span if span > 0 else float("nan"),
            "mse_um2": mse, "offset_um": c, "gain": g, "timing_samples": shift,
            "scored_samples": int(scored.size),
            "noise_um": noise_sigma((y - prediction)[scored], quantum(y)),
            "initial_state_V": [float(s) for s in state], "prediction_um": prediction}
