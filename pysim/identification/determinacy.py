"""How well a record determines an identified model's prediction of an input it never showed.

A least-squares fit can reach the noise on its record and still leave
combinations of the weights that only a few samples decide: a staircase of
13 V steps visits the same levels going up and going down, and operators
7 V apart then differ only in the two or three samples of each step's ramp.
Every held-out block of such a record shows the same levels, so
cross-validation cannot see it; on a new input the weights those samples
fixed (−0.68, +0.64, −0.32 µm/V side by side) predict a full cycle wrong by
percent of the range while the fit with half the operators predicts it to
0.15 %.

:func:`cycle_prediction_spread` measures that directly: the standard
deviation of the model's prediction of a full-range cycle with minor loops,
propagated from the fitted samples' information, in units of the noise σ of
the record (the ordinary least-squares covariance ``σ² (AᵀA)⁻¹``; the
invertibility constraints are left aside).  Well-excited records give a few
hundredths to a few tenths; a value above 1 means the record does not decide
that prediction to its own noise.
"""
from __future__ import annotations

import numpy as np

from pysim.identification.identify import IdentificationResult

__all__ = ["probe_cycle", "cycle_prediction_spread", "decided_weights", "finer_fit_determined", "DETERMINED_SPREAD"]

#: The spread (in noise σ) up to which a record counts as determining a model's prediction of a cycle.
DETERMINED_SPREAD = 0.5


def probe_cycle(low_V: float, high_V: float, n_samples: int = 2000) -> np.ndarray:
    """A voltage cycle over ``[low_V, high_V]`` (V), piecewise linear: two full-range triangles from
    the bottom, then reversals about the middle of decaying amplitude (nested minor loops).

    Examples
    --------
    >>> v = probe_cycle(0.0, 150.0, 400)
    >>> float(v.min()), float(v.max())
    (0.0, 150.0)
    """
    middle, half = 0.5 * (low_V + high_V), 0.5 * float(high_V - low_V)
    amplitudes = np.linspace(0.9, 0.1, 9)
    minor = middle + half * amplitudes * np.resize([1.0, -1.0], amplitudes.size)
    knots = np.concatenate([[low_V, high_V, low_V, high_V, low_V], minor])
    per_segment = max(int(n_samples) // (knots.size - 1), 4)
    segments = [np.linspace(a, b, per_segment, endpoint=False) for a, b in zip(knots[:-1], knots[1:])]
    return np.concatenate(segments + [knots[-1:]])


def _weight_owners(result: IdentificationResult) -> list:
    """Indices of the operators above threshold 0 that carry a weight of their own in ``result``:
    neither tied to another (``merged_into``) nor left out as not identifiable."""
    merged = set(int(i) for i in result.merged_into)
    dropped = set(int(i) for i in result.not_identifiable_operators)
    r = np.asarray(result.model.thresholds_V, dtype=float)
    return [i for i in range(r.size) if r[i] > 0 and i not in merged and i not in dropped]


def decided_weights(result: IdentificationResult) -> int:
    """How many operator weights the record decides on its own in ``result``: the operators above
    threshold 0 neither tied to another nor left out as not identifiable.

    A fit with more operators is richer than another only if this number is larger: on a staircase
    of a few levels, thresholds finer than the steps differ only in how the ties divide a weight.

    Examples
    --------
    A staircase of 50 V steps decides two weights, with three operators or with twelve:

    >>> import numpy as np
    >>> from pysim.core.model import HysteresisModel
    >>> from pysim.identification import identify
    >>> plant = HysteresisModel(a1=0.0, a2=0.3, thresholds_V=(0, 50, 100), weights_um_per_V=(0, 0.1, 0.05))
    >>> steps = np.repeat([0.0, 50.0, 100.0, 150.0, 100.0, 50.0, 0.0, 100.0, 50.0, 150.0, 0.0], 300)
    >>> measured = plant.simulate(steps) + np.random.default_rng(0).normal(0, 0.05, steps.size)
    >>> [decided_weights(identify(steps, measured, n_operators=n)) for n in (3, 12)]
    [2, 2]
    """
    return len(_weight_owners(result))


def _columns(result: IdentificationResult, voltage_V, state, threshold_scale=None) -> np.ndarray:
    """The fit's hysteresis columns over ``voltage_V`` from ``state``: ``[u³] u``, one column per
    operator with a weight of its own (tied operators added to their anchor's at their ratio of
    threshold spacing, as the fit ties them), the offset."""
    model = result.model
    v = np.asarray(voltage_V, dtype=float).ravel()
    _, operators = model.simulate(v, state, return_operators=True, threshold_scale=threshold_scale)
    u = v - model.input_offset_V
    r = np.asarray(model.thresholds_V, dtype=float)
    spacing = np.diff(np.concatenate(([0.0], r)))
    merged = {int(i): int(a) for i, a in result.merged_into.items()}
    columns = [u**3] if model.a1 != 0.0 else []
    columns.append(u)
    for i in _weight_owners(result):
        column = operators[:, i].copy()
        for j, anchor in merged.items():
            if anchor == i:
                column += operators[:, j] * (spacing[j] / spacing[i] if spacing[i] > 0 else 1.0)
        columns.append(column)
    columns.append(np.ones_like(u))
    return np.column_stack(columns)


def cycle_prediction_spread(result: IdentificationResult, voltage_V, column_transform=None, extra_columns=None,
                            threshold_scale=None) -> float:
    """RMS over :func:`probe_cycle` (spanning the fitted samples' input range) of the standard
    deviation of ``result``'s prediction, in units of the record's noise σ, from the information
    of the samples it was fitted on (``voltage_V``: what the fit's operators saw over the record).

    ``column_transform`` and ``extra_columns`` describe a fit with output stages or regressors of
    its own (an extension fitted by the diagnosis): ``column_transform(columns)`` runs the
    hysteresis columns through its stages (the probe's as well), and ``extra_columns`` ((N, m),
    over the record) are fitted beside them; the probe gives those no part.  ``threshold_scale``:
    the factor on every threshold at each sample of the record, for a fit whose thresholds change
    with time (the probe, a slow cycle, sees them as they are).  A regressor that can
    stand in for a combination of operators shows here as a spread the plain fit does not have.

    Returns ``inf`` when the fitted columns are linearly dependent.

    Examples
    --------
    >>> import numpy as np
    >>> from pysim.core.model import HysteresisModel
    >>> from pysim.identification import identify
    >>> truth = HysteresisModel(a1=0.0, a2=0.3, thresholds_V=(0, 50, 100), weights_um_per_V=(0, 0.1, 0.05))
    >>> v = 75 + 75 * np.sin(np.linspace(0, 6 * np.pi, 3000))
    >>> fit = identify(v, truth.simulate(v) + np.random.default_rng(0).normal(0, 0.05, v.size), n_operators=3)
    >>> cycle_prediction_spread(fit, v) < 0.2
    True

    A regressor that follows the top operator's path closely leaves the weights to the few
    samples where the two differ:

    >>> top = fit.model.simulate(v, fit.initial_state, return_operators=True)[1][:, 2]
    >>> look_alike = top + np.random.default_rng(1).normal(0, 1e-3, v.size)
    >>> cycle_prediction_spread(fit, v, extra_columns=look_alike[:, None]) > 100
    True
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    rows = result.fit_slice if result.fit_slice is not None else slice(0, v.size)
    fitted = _columns(result, v, result.initial_state, threshold_scale)
    fitted_v = v[rows]
    # the probe starts from rest at the bottom of the range the fit saw
    probe = _columns(result, probe_cycle(float(fitted_v.min()), float(fitted_v.max())), None)
    if column_transform is not None:
        fitted, probe = column_transform(fitted), column_transform(probe)
    if extra_columns is not None:
        extra = np.asarray(extra_columns, dtype=float).reshape(v.size, -1)
        fitted = np.column_stack([fitted, extra])
        probe = np.column_stack([probe, np.zeros((probe.shape[0], extra.shape[1]))])
    fitted = fitted[rows]
    norms = np.linalg.norm(fitted, axis=0)
    norms[norms == 0.0] = 1.0
    try:
        _, R = np.linalg.qr(fitted / norms)
        spread = np.linalg.solve(R.T, (probe / norms).T)            # R⁻ᵀ pᵀ for every probe sample
    except np.linalg.LinAlgError:
        return float("inf")
    value = float(np.sqrt(np.mean(np.sum(spread**2, axis=0))))
    return value if np.isfinite(value) else float("inf")


def finer_fit_determined(coarse_spread: float, fine_spread: float) -> bool:
    """Whether a record determines a fit with more operators as well as it must to be preferred: its
    cycle prediction spread (σ) is at most ``DETERMINED_SPREAD``, or at most the coarser fit's.

    Examples
    --------
    >>> finer_fit_determined(0.04, 9.9), finer_fit_determined(0.04, 0.3), finer_fit_determined(1.6, 0.75)
    (False, True, True)
    """
    return fine_spread <= max(DETERMINED_SPREAD, coarse_spread)
