"""Scoring a fitted model on a second record of the same actuator.

A model identified on one record meets a second one that started from another
history, through a sensor whose zero (and, a little, its gain) may have moved.
Neither is an effect of the actuator, so :func:`score_on_record` re-fits
exactly these, and nothing else, before it scores:

- the operator state before the second record's first sample (exact steps for
  each operator with the model's weights fixed, see
  :func:`pysim.identification.identify.best_clamped_state`, from identify's
  starts and from the states short histories leave; then, for a model whose
  sections or delay spread a state's effect over later samples, a search per
  operator through them, :func:`pysim.identification.identify.refine_state_through_stage`);
- the sensor offset and gain (``y ≈ gain · model + offset``, least squares);
- the state of the output stages' slow modes (creep modes and a lag slower
  than ``MIN_HISTORY_MODE_SAMPLES``): a history before the second record leaves
  each mode away from rest, and what it adds is that mode's free response,
  ``a_j exp(−t/τ_j)``, fitted with the offset.  A creep that outlasts the
  first record shows on a second one as such a decaying transient; the models
  without those modes (the plain fit) have no such state to fit.

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

from pysim.core.input_stage import InputStageModel
from pysim.diagnosis.candidates import CandidateFit, initial_extended_state
from pysim.diagnosis.residuals import record_noise_sigma
from pysim.identification.identify import (best_clamped_state, history_floor_for_input, operator_bounds,
                                          refine_state_through_stage, short_history_states)

#: Alternations between the operator state and the offset/gain.
STATE_ROUNDS = 4
#: Turning levels of the short histories tried as starts (as in identify), and how many of the
#: states they leave are kept as starts (the best by their error as they are).
HISTORY_LEVELS = 9
HISTORY_STARTS = 2
#: Rounds of the search through the stages (a model whose stages spread a state's effect).
STAGE_STATE_ROUNDS = 3
#: Timing shifts of the second record tried, samples (see the module notes: none).
TIMING_SHIFTS_SAMPLES = (0,)
#: Stage modes at least this slow (samples) get their history's free response fitted.
MIN_HISTORY_MODE_SAMPLES = 20.0
#: An input this close to the fitted range (fraction of its span) is inside it: a hold at the
#: top of a second record that stops 0.03 V short of the first record's top (of 150 V) is no
#: extrapolation, and leaving it out left only the rest level of a step record to score.
RANGE_TOLERANCE_FRACTION = 1e-3


def inside_range(values_V, low_V: float, high_V: float) -> np.ndarray:
    """Mask of the values inside ``[low_V, high_V]``, widened on each side by
    ``RANGE_TOLERANCE_FRACTION`` of its span.

    Examples
    --------
    >>> inside_range([0.0, 99.99, 100.05, 100.2], 0.0, 100.0).tolist()
    [True, True, True, False]
    """
    margin = RANGE_TOLERANCE_FRACTION * (float(high_V) - float(low_V))
    values = np.asarray(values_V, dtype=float)
    return (values >= low_V - margin) & (values <= high_V + margin)


def history_modes(model, n_samples: int, sample_period_s: float) -> np.ndarray:
    """``(n_samples, m)`` free responses ``exp(−t/τ_j)`` of the model's slow
    output-stage modes (creep modes of either kind, a first-order lag), t from
    the first sample: what a history before the record adds while those modes
    settle.  No columns for a model without such modes.

    Examples
    --------
    >>> from pysim.core.extended import ExtendedModel, StageSpec
    >>> from pysim.core.model import HysteresisModel
    >>> h = HysteresisModel(0.0, 0.5, (0.0,), (0.0,), voltage_range_V=(0.0, 100.0))
    >>> spec = StageSpec(sample_period_s=1e-3, creep_time_constants_s=(0.002, 0.5),
    ...                  creep_weights_um_per_V=(0.01, 0.02))
    >>> history_modes(ExtendedModel(h, spec), 3, 1e-3).round(4).tolist()      # the 2 ms mode is too fast
    [[1.0], [0.998], [0.996]]
    """
    spec = getattr(model, "stages", None)
    taus = []
    if spec is not None:
        taus = [*spec.creep_time_constants_s, *spec.displacement_creep_time_constants_s,
                spec.lag_time_constant_s]
    t = np.arange(n_samples) * sample_period_s
    slow = [float(tau) for tau in taus if tau >= MIN_HISTORY_MODE_SAMPLES * sample_period_s]
    return np.column_stack([np.exp(-t / tau) for tau in slow]) if slow else np.zeros((n_samples, 0))


def _affine(p, y, modes, rows=slice(None)):
    """Least-squares ``y ≈ g p + c + modes @ a`` over ``rows``: the gain, the
    offset and ``c + modes @ a`` over every sample (µm)."""
    A = np.column_stack([p, np.ones_like(p), modes])
    theta, *_ = np.linalg.lstsq(A[rows], y[rows], rcond=None)
    return float(theta[0]), float(theta[1]), theta[1] + modes @ theta[2:]


def _shifted(p, shift: int):
    """``p`` delayed by ``shift`` samples (edges repeated)."""
    if shift == 0:
        return p
    if shift > 0:
        return np.concatenate((np.full(shift, p[0]), p[:-shift]))
    return np.concatenate((p[-shift:], np.full(-shift, p[-1])))


def score_on_record(fit: CandidateFit, voltage_V, displacement_um, sample_period_s: float,
                    train_range_V, *, train_voltage_V=None, history_floor_V=None) -> dict:
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
    history_floor_V : float, optional
        The lowest voltage the actuator was driven to before this record (V): its
        start state is one that a history above it leaves (see
        :func:`pysim.identification.identify.operator_bounds`); default: no floor.

    Returns
    -------
    dict with ``rms_pct``, ``max_pct`` (% of the measured range of the scored
    samples), ``mse_um2``, ``offset_um``, ``gain``, ``timing_samples``,
    ``scored_samples``, ``noise_um`` (σ of the residual's white part),
    ``initial_state_V``, ``prediction_um`` (after the re-fitted offset,
    gain and timing) and ``scored_rows`` (the indices of the scored samples;
    like the prediction, not for a report).

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
    x = model.stage_input(v) if isinstance(model, InputStageModel) else v
    scale = model.threshold_scale(v) if isinstance(model, InputStageModel) else None
    modes = history_modes(plant, v.size, sample_period_s)
    state, p = _StateSearch(plant, x, y, modes, history_floor_V, scale).best()
    lo, hi = train_range_V
    level = v
    if isinstance(model, InputStageModel) and train_voltage_V is not None:
        seen = model.stage_input(np.asarray(train_voltage_V, dtype=float))
        lo, hi, level = float(seen.min()), float(seen.max()), x
    scored = np.flatnonzero(inside_range(level, lo, hi))
    scored = scored[(scored > 0) & (scored < v.size - 1)]
    if scored.size < 10:
        scored = np.arange(1, v.size - 1)
    mse, shift, g, c, prediction = _best_timing(p, y, modes, scored)
    span = float(np.ptp(y[scored]))
    error = np.abs(y[scored] - prediction[scored])
    return {"rms_pct": 100.0 * float(np.sqrt(mse)) / span if span > 0 else float("nan"),
            "max_pct": 100.0 * float(error.max()) / span if span > 0 else float("nan"),
            "mse_um2": mse, "offset_um": c, "gain": g, "timing_samples": shift,
            "scored_samples": int(scored.size), "history_modes": int(modes.shape[1]),
            "noise_um": record_noise_sigma((y - prediction)[scored], y),
            "initial_state_V": [float(s) for s in state], "prediction_um": prediction, "scored_rows": scored}


def _best_timing(prediction_um, y, modes, scored) -> tuple:
    """``(mse, shift, gain, offset, fitted)``: the timing shift of :data:`TIMING_SHIFTS_SAMPLES` whose
    prediction, after the sensor gain, offset and history modes fitted on the ``scored`` rows, leaves
    the least mean-square error there (µm²; a later shift wins only by more than rounding)."""
    best = None
    for shift in TIMING_SHIFTS_SAMPLES:
        ps = _shifted(prediction_um, shift)
        g, c, free = _affine(ps, y, modes, scored)
        fitted = g * ps + free
        mse = float(np.mean((y[scored] - fitted[scored]) ** 2))
        if best is None or mse < best[0] * (1 - 1e-9):
            best = (mse, shift, g, c, fitted)
    return best


class _StateSearch:
    """The initial operator state of ``plant`` on another record (input ``x`` to its hysteresis,
    output ``y`` µm), with the sensor offset, gain and history ``modes`` fitted alongside;
    ``threshold_scale``: the factor on its thresholds at each sample, if they change with time.

    Each candidate is ``(state, error sum, prediction)``; :meth:`best` returns the best state and
    its prediction.
    """

    def __init__(self, plant, x, y, modes, history_floor_V=None, threshold_scale=None):
        self.plant, self.x, self.y, self.modes = plant, x, y, modes
        self.threshold_scale = threshold_scale
        h = plant.hysteresis
        self.low, self.high = operator_bounds(x, h.thresholds_V, h.operator, h.input_offset_V,
                                              history_floor_for_input(history_floor_V, x), threshold_scale)
        self.weights = np.asarray(h.weights_um_per_V, dtype=float)
        # the samples where each operator's admissible state still depends on where it started
        self.moving = [np.flatnonzero(self.high[:, i] - self.low[:, i] > 0) for i in range(h.n_operators)]

    def predict(self, state):
        return self.plant.simulate(self.x, initial_extended_state(self.plant, self.x[0], state),
                                   threshold_scale=self.threshold_scale)

    def as_is(self, state):
        """The state, its error sum (the offset, gain and modes fitted) and its prediction."""
        p = self.predict(state)
        g, _, free = _affine(p, self.y, self.modes)
        return state, float(np.sum((self.y - g * p - free) ** 2)), p

    def estimate(self, state):
        """Exact steps per operator from ``state``, alternating with the offset,
        gain and modes; the state, its error sum and its prediction."""
        low, high, b, y = self.low, self.high, self.weights, self.y
        state = state.copy()
        for _ in range(STATE_ROUNDS if any(k.size for k in self.moving) else 0):
            p = self.predict(state)
            g, _, free = _affine(p, y, self.modes)
            e = y - g * p - free
            for i, k in enumerate(self.moving):
                if k.size == 0 or b[i] == 0.0 or g == 0.0:
                    continue
                L, U = low[k, i], high[k, i]
                current = np.clip(state[i], L, U)
                target = e[k] / (g * b[i]) + current
                new = best_clamped_state(target, L, U, low[0, i], high[0, i])
                e[k] -= g * b[i] * (np.clip(new, L, U) - current)
                state[i] = new
        return self.as_is(state)

    def through_stages(self, found):
        """The exact steps above treat the model as static.  Its sections and
        delay spread a state's effect over later samples (a creep mode keeps
        moving after the operator has settled), so those steps can leave the
        state far off; a scalar search per operator through the stages,
        alternating with the offset, gain and modes, takes it from there."""
        low, high, y = self.low, self.high, self.y
        stage = self.plant.stages.runner.linear_part()
        remembers = np.flatnonzero(np.any(high > low, axis=1))
        if stage.state_size == 0 or remembers.size == 0:
            return found
        remembered = np.arange(int(remembers[-1]) + 1)
        for _ in range(STAGE_STATE_ROUNDS):
            state, sse, p = found
            g, _, free = _affine(p, y, self.modes)
            refined = self.as_is(refine_state_through_stage(state, (y - g * p - free)[remembered], low, high,
                                                            self.weights, stage.apply_to_columns, remembered,
                                                            gain=g))
            if not refined[1] < sse * (1.0 - 1e-4):
                break
            found = refined
        return found

    def best(self) -> tuple:
        """``(state, prediction)`` of the best start after the steps."""
        low, high, x, h = self.low, self.high, self.x, self.plant.hysteresis
        # starts as in identify: demagnetised, the lowest and highest admissible states (a record that
        # begins right after a fall from the top starts at the highest), and the best two of the states
        # short histories leave, over the range of either record -- each as it is and after the exact
        # steps, which treat the model as static and can lead a model with stages away from a good start
        starts = [np.clip(np.zeros(h.n_operators), low[0], high[0]), low[0].copy(), high[0].copy()]
        span = (min(float(x.min()), h.voltage_range_V[0]), max(float(x.max()), h.voltage_range_V[1]))
        histories = [self.as_is(np.clip(state, low[0], high[0])) for state in
                     short_history_states(np.linspace(*span, HISTORY_LEVELS) - h.input_offset_V, h.thresholds_V,
                                          h.operator)]
        histories = sorted(histories, key=lambda found: found[1])[:HISTORY_STARTS]
        found = [self.estimate(start) for start in starts + [start for start, _, _ in histories]] + histories
        state, _, p = self.through_stages(min(found, key=lambda found: found[1]))
        return state, p
