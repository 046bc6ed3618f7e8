"""The search of the diagnosis over stages before the hysteresis (the stages
themselves, and the model they make with a plant, are the core's:
:mod:`pysim.core.input_stage`): which slew rates to try on given records.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["SLEW_SEARCH_SPAN", "slew_rate_grid"]

#: The slew rates searched first span this ratio below the fastest move of the records.
SLEW_SEARCH_SPAN = 40.0


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
