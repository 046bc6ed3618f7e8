"""C sources of the FMUs and of the host hysteresis kernel.

Installed as the package data ``pysim.core.csrc``; :mod:`pysim.core.toolchain`
names the folder (``SOURCE_DIR``).
"""
