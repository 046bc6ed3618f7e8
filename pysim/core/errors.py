"""Errors of the model core, and the root every layer's error derives from.

Each layer raises one error type of its own (``ModelError`` here,
``pysim.fmu.BuildError``, ``pysim.cosim.CoSimulationError``,
``pysim.identification.IdentificationError``,
``pysim.diagnosis.DiagnosisError``); all derive from :class:`PiezoMPIError`, so
the command line can turn any of them into one message and exit code 2 without
knowing the layers.  Their messages say what is wrong and where (file, line,
column, parameter, voltage) on one line.
"""

__all__ = ["PiezoMPIError", "ModelError", "NotInvertibleError", "SpecError"]


class PiezoMPIError(Exception):
    """Root of the errors of every layer of the package: bad input, stated on one line."""


class ModelError(PiezoMPIError, ValueError):
    """A model, its parameters or its state cannot be used."""


class NotInvertibleError(ModelError):
    """The model is not strictly increasing along every branch, so no inverse exists."""


class SpecError(ModelError):
    """A spec file that cannot be loaded or does not define a model."""
