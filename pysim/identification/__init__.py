"""Identification from measured records: the one data loader and the
constrained least-squares fit of MPI/CPI models.  Built on :mod:`pysim.core`.
"""
from pysim.identification.data import MeasuredData, load_measured, save_measured, shipped_dataset
from pysim.identification.errors import DataError, IdentificationError
from pysim.identification.identify import IdentificationResult, identify, settling_samples, start_transient

__all__ = ["identify", "start_transient", "settling_samples", "IdentificationResult", "MeasuredData", "load_measured", "save_measured",
           "shipped_dataset", "IdentificationError", "DataError"]
