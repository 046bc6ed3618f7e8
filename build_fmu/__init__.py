"""FMI 2.0 co-simulation FMUs of a hysteresis model spec.

``build_fmus(spec_or_model, out_dir, platforms=...) -> {"plant": Path, "inverse": Path}``
builds the plant FMU (``voltage`` V -> ``displacement`` um) and the inverse
compensator FMU (``displacement_ref`` um -> ``voltage`` V) from the hand-written
C sources in ``fmu_src/``; ``build-fmu`` is its command line.  For an extended
spec (:class:`pysim.extended.ExtendedModel`) the plant carries the output
stages and steps at the spec's sample period only, and the inverse
compensates the hysteresis part alone.
"""
from build_fmu.build import DEFAULT_PLATFORMS, BuildError, build_fmus
from build_fmu.compile import PLATFORMS, ToolchainError

__all__ = ["build_fmus", "BuildError", "ToolchainError", "DEFAULT_PLATFORMS", "PLATFORMS"]
