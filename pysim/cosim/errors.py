"""The error of the co-simulation layer."""
from pysim.core.errors import PiezoMPIError

__all__ = ["CoSimulationError"]


class CoSimulationError(PiezoMPIError, ValueError):
    """An FMU, stage or chain that cannot be co-simulated (the message names the file or part)."""
