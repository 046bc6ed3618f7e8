"""The search of the diagnosis over stages before the hysteresis (the stages
themselves, and the model they make with a plant, are the core's:
:mod:`pysim.core.input_stage`): which slew rates to try on given records.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["MOVED_EXPLAINED_SHARE", "SLEW_SEARCH_SPAN", "explained_where_moved", "moved_by_stage",
           "slew_rate_grid"]

#: The slew rates searched first span this ratio below the fastest move of the records.
SLEW_SEARCH_SPAN = 40.0
#: Share of the rate-independent fit's squared miss on the samples an input stage moves (and the
#: :data:`MOVED_SETTLE_SAMPLES` after each) that the stage's own fit must remove there.
MOVED_EXPLAINED_SHARE = 0.5
#: Samples after each moved one that still count as moved (the operators settle with the input).
MOVED_SETTLE_SAMPLES = 2


def slew_rate_grid(records, points: int) -> np.ndarray:
    """Slew rates (V/s) to search for the records ``[(voltage_V, sample_period_s), ...]``, ascending.

    ``points`` rates, evenly spaced in log, from a ``SLEW_SEARCH_SPAN``-th of the fastest move of
    the records (V/s) up to it; below them, at the same spacing, more rates down to the slowest
    limit a record can show, the rate that crosses its input's span once in the whole record (a
    slower limit never lets the stage follow it).  Steps move far faster than a large stack's
    amplifier may follow: independent seed 759's second record moves 500 V/ms behind a 1.5 V/ms
    limit, which the first rates alone do not reach.  Empty when no record's input moves.

    Examples
    --------
    >>> steps = np.repeat([0.0, 100.0, 0.0], 1000)             # 100 V in one 1 ms sample
    >>> grid = slew_rate_grid([(steps, 1e-3)], 3)
    >>> (grid / 1e3).round(4).tolist()                          # V/ms
    [0.0333, 0.1406, 0.5928, 2.5, 15.8114, 100.0]
    """
    records = [(np.asarray(v, dtype=float).ravel(), float(T)) for v, T in records]
    fastest = max((float(np.max(np.abs(np.diff(v)))) / T for v, T in records if v.size > 1), default=0.0)
    if not fastest > 0:
        return np.zeros(0)
    top = np.geomspace(fastest / SLEW_SEARCH_SPAN, fastest, points)
    slowest = min(float(np.ptp(v)) / (v.size * T) for v, T in records)
    if not 0 < slowest < top[0]:
        return top
    spacing = math.log(top[1] / top[0]) if points > 1 else math.log(SLEW_SEARCH_SPAN)
    below = math.ceil(math.log(top[0] / slowest) / spacing)
    return np.r_[np.geomspace(slowest, top[0], below + 1)[:-1], top]


def moved_by_stage(voltage_V, operator_input_V) -> np.ndarray:
    """Boolean mask of the samples where a stage moves what the operators see: ``operator_input_V``
    differs from ``voltage_V`` by more than rounding (10⁻⁹ of the voltage's span).

    Examples
    --------
    >>> moved_by_stage([0.0, 10.0, 10.0], [0.0, 5.0, 10.0]).tolist()
    [False, True, False]
    """
    v = np.asarray(voltage_V, dtype=float)
    return np.abs(np.asarray(operator_input_V, dtype=float) - v) > 1e-9 * max(float(np.ptp(v)), 1e-300)


def explained_where_moved(voltage_V, operator_input_V, displacement_um, without_stage_um, with_stage_um,
                          settle: int = MOVED_SETTLE_SAMPLES) -> tuple:
    """``(miss_without_um2, miss_with_um2, samples)``: the squared misses (summed, µm²) of a fit
    without the stage and of the fit with it on the samples where the stage moves what the operators
    see (``operator_input_V`` differs from ``voltage_V``) and the ``settle`` samples after each.

    A stage that moves only a few samples shows itself there: a true slew limit turns the
    rate-independent fit's large miss on a step's first samples into the noise, while a stage that
    leaves that miss as it was has not explained the samples it changed, and any gain it brings
    elsewhere comes from the weights those samples lever, not from an effect.

    Examples
    --------
    >>> v = np.array([0.0, 0.0, 10.0, 10.0, 10.0, 10.0])
    >>> x = np.array([0.0, 0.0, 5.0, 10.0, 10.0, 10.0])       # a ramp behind a slew limit
    >>> y = x.copy()                                            # an actuator that follows it
    >>> explained_where_moved(v, x, y, v, x)                    # samples 2, 3 and 4
    (25.0, 0.0, 3)
    """
    v = np.asarray(voltage_V, dtype=float)
    moved = np.flatnonzero(moved_by_stage(v, operator_input_V))
    if moved.size == 0:
        return 0.0, 0.0, 0
    rows = np.unique(np.minimum(moved[:, None] + np.arange(settle + 1), v.size - 1))
    y = np.asarray(displacement_um, dtype=float)[rows]
    without = float(np.sum((y - np.asarray(without_stage_um, dtype=float)[rows]) ** 2))
    with_stage = float(np.sum((y - np.asarray(with_stage_um, dtype=float)[rows]) ** 2))
    return without, with_stage, int(rows.size)
