"""Error measures of the paper (eq. 14-15) and the mean absolute error.

All are in per cent of the range of the reference (desired or measured)
signal: ``max(reference) - min(reference)``.
"""
from __future__ import annotations

import numpy as np

from pysim.core.errors import ModelError


def error_measures(reference, actual) -> dict:
    """Max, RMS and mean absolute error as % of the reference's range.

    Parameters
    ----------
    reference : array_like
        Desired or measured displacement (µm): its range is the 100 % mark.
    actual : array_like
        Simulated or achieved displacement (µm), same length.

    Returns
    -------
    dict with ``max_error_pct`` (eq. 15, taken on |error| so that an error of
    either sign counts), ``rms_error_pct`` (eq. 14) and ``mean_error_pct``.
    """
    reference = np.asarray(reference, dtype=float)
    actual = np.asarray(actual, dtype=float)
    if reference.shape != actual.shape:
        raise ModelError(f"reference has shape {reference.shape} but actual has {actual.shape}")
    if reference.size == 0:
        raise ModelError("no samples to compare")
    span = float(np.max(reference) - np.min(reference))
    if not span > 0:
        raise ModelError("the reference is constant: its range is zero, errors in % are undefined")
    error = np.abs(reference - actual)
    return {
        "max_error_pct": float(100.0 * np.max(error) / span),
        "rms_error_pct": float(100.0 * np.sqrt(np.mean(error**2)) / span),
        "mean_error_pct": float(100.0 * np.mean(error) / span),
    }
