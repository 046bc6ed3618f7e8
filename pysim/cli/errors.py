"""The error of the command line: options that do not fit together.

Errors of the layers below (:class:`pysim.core.errors.PiezoMPIError` and its
subclasses) and this one are reported by :func:`pysim.cli.main.main` as one line
on stderr with exit code 2.
"""
from pysim.core.errors import PiezoMPIError

__all__ = ["UserError"]


class UserError(PiezoMPIError, ValueError):
    """Bad command-line input: an option, a combination of options."""
