"""What a rate-independent residual can depend on: the input's path, not its timing.

A rate-independent hysteresis (Preisach, Bouc-Wen, any play-type model) gives
an output that is a function of the present input and the alternating
extremes that the input has not yet wiped out -- the memory of the path.  A
residual that is such a function is a *shape* error of the model (loops that
the MPI class cannot draw), whatever its size; a residual that also depends on
how fast the input moved or how long ago it moved (a lag, a delay, creep, a
drift) is not.

:func:`path_memory` gives each sample the present input and its last two
turning points (with the wiping-out rule); :func:`path_predicted` predicts a
residual out of sample from the samples of other blocks with the nearest
memory.  The diagnosis uses the pair to compare every model after the same
rate-independent correction when a record's hysteresis shape lies outside
the model class, so that the shape error is neither named as an effect nor
called unexplained.
"""
from __future__ import annotations

import numpy as np
import scipy.spatial

__all__ = ["path_memory", "path_predicted", "PATH_NEIGHBOURS", "REVERSAL_SHARE", "MAX_TRAIN_ROWS"]

#: Neighbours averaged for a prediction (the noise of their mean is 1/PATH_NEIGHBOURS of σ²).
PATH_NEIGHBOURS = 16
#: A reversal counts once the input has moved back by this share of its span (noise on a hold is no reversal).
REVERSAL_SHARE = 0.005
#: At most this many training rows per block teach (every k-th row of a longer record: its paths are dense).
MAX_TRAIN_ROWS = 30000


def path_memory(voltage_V, tolerance_V: float | None = None) -> np.ndarray:
    """The present input and the last two turning points not wiped out, per sample (V).

    A turning point is recorded when the input moves back from its running
    extreme by more than ``tolerance_V``; a branch that passes beyond the
    turning point before its last one wipes out that pair (the Preisach
    memory rule).  Before the record shows a turning point, the missing ones
    are the record's first input (an unknown history is not guessed).

    Parameters
    ----------
    voltage_V : array_like
    tolerance_V : float, optional
        Default: ``REVERSAL_SHARE`` of the input's span.

    Returns
    -------
    ndarray, shape (n, 3): input, last turning point, the one before (V).

    Examples
    --------
    >>> v = np.r_[np.linspace(0, 10, 11), np.linspace(9, 4, 6), np.linspace(5, 12, 8)]
    >>> m = path_memory(v, 0.5)
    >>> m[15].tolist(), m[-1].tolist()      # falling after the top at 10; above 10 the pair is wiped out
    ([5.0, 10.0, 0.0], [12.0, 0.0, 0.0])
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    n = v.size
    out = np.empty((n, 3))
    if n == 0:
        return out
    tol = REVERSAL_SHARE * float(np.ptp(v)) if tolerance_V is None else float(tolerance_V)
    stack = [float(v[0])]       # alternating turning points, oldest first; the start counts as one
    extreme, direction = float(v[0]), 0
    for k in range(n):
        x = float(v[k])
        if direction == 0:
            if abs(x - stack[0]) > tol:
                extreme, direction = x, (1 if x > stack[0] else -1)
        elif direction * (x - extreme) >= 0:
            extreme = x
        elif abs(x - extreme) > tol:
            # the input turned: the running extreme is a turning point
            stack.append(extreme)
            extreme, direction = x, -direction
        # a branch beyond the turning point before the last one wipes out the last pair
        while len(stack) >= 3 and direction * (extreme - stack[-2]) >= 0:
            del stack[-2:]
        out[k, 0] = x
        out[k, 1] = stack[-1]
        out[k, 2] = stack[-2] if len(stack) >= 2 else stack[-1]
    return out


def path_predicted(residual_um, memory, blocks, neighbours: int = PATH_NEIGHBOURS) -> np.ndarray:
    """Out-of-block prediction of a residual from the samples with the nearest path memory.

    Parameters
    ----------
    residual_um : array_like, shape (n,) or (n, m)
        One residual, or one per column (several models of one record: the
        neighbours are found once).  Rows with a NaN neither teach nor are
        predicted.
    memory : ndarray, shape (n, 3)
        :func:`path_memory` of the record's input.
    blocks : list of (train_rows, predicted_rows)
        Each block's rows are predicted from the training rows' residual
        (blocked cross-validation folds).
    neighbours : int

    Returns
    -------
    ndarray shaped as ``residual_um``: the mean residual of the ``neighbours``
    training samples with the nearest memory (Euclidean, V), NaN where
    nothing was predicted.

    Examples
    --------
    >>> v = np.tile(np.r_[np.linspace(0, 10, 50), np.linspace(10, 0, 50)], 6)
    >>> shape = np.where(np.diff(v, prepend=0) >= 0, 0.1, -0.1)    # a loop the model missed
    >>> half = np.arange(300)
    >>> p = path_predicted(shape, path_memory(v), [(half + 300, half), (half, half + 300)], 4)
    >>> round(float(np.mean(np.isclose(p, shape))), 2)      # all but the samples at the turning points
    0.98
    """
    r = np.asarray(residual_um, dtype=float)
    columns = r.reshape(r.shape[0], -1)
    m = np.asarray(memory, dtype=float)
    known = np.all(np.isfinite(columns), axis=1)
    out = np.full(columns.shape, np.nan)
    for train, predicted in blocks:
        train = np.asarray(train)[known[np.asarray(train)]]
        if train.size > MAX_TRAIN_ROWS:
            train = train[::-(-train.size // MAX_TRAIN_ROWS)]
        predicted = np.asarray(predicted)
        predicted = predicted[known[predicted]]
        if predicted.size == 0 or train.size < neighbours:
            continue
        _, nearest = scipy.spatial.cKDTree(m[train]).query(m[predicted], k=neighbours)
        nearest = train[nearest.reshape(predicted.size, -1)]
        out[predicted] = np.mean(columns[nearest], axis=1)
    return out.reshape(r.shape)
