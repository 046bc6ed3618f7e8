"""Errors of the identification layer."""
from pysim.core.errors import PiezoMPIError

__all__ = ["IdentificationError", "DataError"]


class IdentificationError(PiezoMPIError, ValueError):
    """A record that cannot support a fit, or fit options that are invalid."""


class DataError(IdentificationError):
    """A measured-data file or record that cannot be used (names file, line and column)."""
