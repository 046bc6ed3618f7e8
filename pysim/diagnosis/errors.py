"""The error of the diagnosis layer."""
from pysim.core.errors import PiezoMPIError

__all__ = ["DiagnosisError"]


class DiagnosisError(PiezoMPIError, ValueError):
    """A record or option the diagnosis cannot use."""
