"""``build-fmu``: the command line of the FMU builder :mod:`pysim.fmu`.

``build_fmus`` is re-exported here for scripts written against earlier
versions; new code imports it from :mod:`pysim.fmu`.
"""
from pysim.fmu import DEFAULT_PLATFORMS, PLATFORMS, BuildError, ToolchainError, build_fmus

__all__ = ["build_fmus", "BuildError", "ToolchainError", "DEFAULT_PLATFORMS", "PLATFORMS"]
