"""The FMU builder: a model spec in, FMI 2.0 co-simulation FMUs out.

``build_fmus(spec_or_model, out_dir, platforms=...) -> {"plant": Path, "inverse": Path}``
generates ``modelDescription.xml`` and ``model_config.h`` per FMU, cross-compiles
the hand-written C sources (``fmu_src/`` in the repository) with zig for
linux64, win64 and darwin64, checks the binaries and writes the archives, all
or nothing.  Built on :mod:`pysim.core`; the ``build-fmu`` command is its
command line.

Examples
--------
>>> from pysim.fmu import build_fmus                       # doctest: +SKIP
>>> build_fmus("default_mpi", "fmus/", platforms=["linux64"])  # doctest: +SKIP
{'plant': PosixPath('fmus/default_mpi_plant.fmu'), 'inverse': PosixPath('fmus/default_mpi_inverse.fmu')}
"""
from pysim.fmu.build import DEFAULT_PLATFORMS, build_fmus, check_model
from pysim.fmu.compile import PLATFORMS
from pysim.fmu.errors import BuildError, ToolchainError

__all__ = ["build_fmus", "check_model", "BuildError", "ToolchainError", "DEFAULT_PLATFORMS", "PLATFORMS"]
