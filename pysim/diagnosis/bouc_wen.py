"""A bank of Bouc-Wen operators: rate-independent hysteresis without the Preisach class's memory.

A Bouc-Wen actuator's hysteretic part ``h`` moves with the input's increments,
not with time (first exponent, the form used for piezo actuators)::

    dh = dx - β |dx| h - γ dx |h|,      x = (v - v_min) / (v_max - v_min)

Its loops neither wipe out older turning points nor close their minor loops,
so a Preisach model (and the MPI model) misses them on an input it was not
fitted on: without this bank the general model left two Bouc-Wen records of one
actuator 2-6 σ² above their noise, and a lag or creep took part of that shape
error (outside-class seeds 57, 89).  The equation is linear in ``h`` on each
side of ``h = 0``, so every monotone run of the input is solved exactly (an
exponential approach to ``±1/(β ± γ)``, crossing zero once at most): the bank
needs no time step, and its outputs depend on the input's path alone.

An operator's weight enters the model linearly; its shape is fixed on a grid:
every pair of rates ``β + γ`` (where ``h`` has the sign of the motion, after
the first part of a branch) and ``β - γ`` from ``RATES``, so any Bouc-Wen
actuator of the first exponent whose rates lie in that band is approached by
a mixture of them.  The state before the record is unknown; its effect fades
at least as ``exp(-min(RATES) T)`` with ``T`` the input's travel, so only
samples after enough travel are used (``forgotten_from``): a free column for
that fading would also take the free decay of creep after a history.
"""
from __future__ import annotations

import numpy as np

__all__ = ["RATES", "N_OPERATORS", "bouc_wen_bank", "forgotten_from"]

#: Rates ``β ± γ`` of the bank, per unit of the normalised input: a branch saturates after about
#: 3/rate of the range (from a sixteenth of it to half of it).  Slower ones would remember the path
#: over most of the range, and on an input that moves at an even pace a memory of the path is a
#: memory of time: rates from 3 took creep for hysteresis (outside-class seeds 27 and 50, creep that
#: the general model alone then fitted to the noise), and the Preisach part holds slow curvature.
RATES = np.geomspace(6.0, 48.0, 5)
#: Operators of the bank: every pair of rates.
N_OPERATORS = RATES.size ** 2


def _rates():
    """(``β + γ``, ``β - γ``) of every operator."""
    return np.repeat(RATES, RATES.size), np.tile(RATES, RATES.size)


def _normalised(voltage_V, range_V) -> np.ndarray:
    return (np.asarray(voltage_V, dtype=float) - range_V[0]) / (range_V[1] - range_V[0])


def _rising(g0, travel, rate_pos, rate_neg):
    """The state after ``travel`` (>= 0, one column per sample of a run, rows) of rising input from
    ``g0`` (per operator): ``dg/dx = 1 - k g`` with ``k = rate_neg`` below zero, ``rate_pos`` above."""
    below = g0 < 0.0
    # travel at which a state below zero reaches it (log1p: exact for small states)
    to_zero = np.where(below, np.log1p(-rate_neg * np.minimum(g0, 0.0)) / rate_neg, 0.0)
    still_below = below & (travel < to_zero)
    g_below = 1.0 / rate_neg + (g0 - 1.0 / rate_neg) * np.exp(-rate_neg * travel)
    start = np.where(below, 0.0, g0)
    rest = np.maximum(travel - to_zero, 0.0)
    g_above = 1.0 / rate_pos + (start - 1.0 / rate_pos) * np.exp(-rate_pos * rest)
    return np.where(still_below, g_below, g_above)


def bouc_wen_bank(voltage_V, range_V) -> np.ndarray:
    """The outputs of every operator of the bank, started at ``h = 0``.

    Parameters
    ----------
    voltage_V : array_like
        The input, V.
    range_V : tuple of float
        ``(v_min, v_max)`` that normalise it.

    Returns
    -------
    ndarray, shape (N, N_OPERATORS)

    Examples
    --------
    A rising input drives every operator towards ``1/(β + γ)``, a falling one towards
    ``-1/(β + γ)`` (the same rate: a fall of ``h`` is a rise of ``-h``); the loop is the same at
    any speed:

    >>> v = np.r_[np.linspace(0, 100, 400), np.linspace(100, 0, 400)]
    >>> h = bouc_wen_bank(v, (0.0, 100.0))
    >>> fastest = RATES[-1]
    >>> bool(np.isclose(h[399, -1], 1 / fastest)), bool(np.isclose(h[-1, -1], -1 / fastest))
    (True, True)
    >>> slow = bouc_wen_bank(np.interp(np.arange(7991) / 10, np.arange(800), v), (0.0, 100.0))
    >>> bool(np.allclose(slow[::10], h))
    True
    """
    x = _normalised(voltage_V, range_V)
    rate_pos, rate_neg = _rates()
    out = np.zeros((x.size, rate_pos.size))
    if x.size < 2:
        return out
    step = np.diff(x)
    direction = np.sign(step)
    moving = np.flatnonzero(direction)
    if moving.size == 0:
        return out
    # a run: consecutive steps of one direction (holds between them belong to it)
    turns = moving[1:][direction[moving[1:]] != direction[moving[:-1]]]
    starts = np.r_[moving[0], turns]
    ends = np.r_[turns, step.size]
    h = np.zeros(rate_pos.size)
    for first, last in zip(starts.tolist(), ends.tolist()):
        sign = direction[first]
        travel = np.cumsum(np.abs(step[first:last]))[:, None]
        # a fall of h is a rise of -h with the same rates
        run = sign * _rising(sign * h, travel, rate_pos, rate_neg)
        out[first + 1:last + 1] = run
        h = run[-1]
    return out


def forgotten_from(voltage_V, range_V) -> int:
    """The first sample from which the bank's state before the record has faded to ``exp(-6)`` of
    what it was, or less (the input has travelled ``6 / min(RATES)`` of its range); the record's
    length when it never gets there.  Before it, the bank's outputs depend on that unknown state.

    Examples
    --------
    Up and down, one percent of the range per sample: the slowest rate, 6, has forgotten after one
    range of travel.

    >>> v = np.r_[np.arange(0, 100), np.arange(100, -1, -1)]
    >>> forgotten_from(v, (0.0, 100.0))
    100
    """
    travel = np.r_[0.0, np.cumsum(np.abs(np.diff(_normalised(voltage_V, range_V))))]
    return int(np.searchsorted(travel, 6.0 / RATES.min() - 1e-12))
