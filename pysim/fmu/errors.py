"""Errors of the FMU builder."""
from pysim.core.errors import PiezoMPIError

__all__ = ["BuildError", "ToolchainError"]


class BuildError(PiezoMPIError, ValueError):
    """A spec or an option the builder cannot use (the command line exits with code 2)."""


class ToolchainError(BuildError, RuntimeError):
    """The compiler or the FMI headers are missing, or compiling failed (exit code 1)."""
