"""Where the C sources, the compilers and the compile cache are: one home for
the package, its FMU builder, the tests and the benchmarks.

- :data:`SOURCE_DIR`: the hand-written C sources (``fmu_src/`` in the
  repository, installed as the package data ``pysim.core.csrc``).
- :func:`zig_cc`: zig's C compiler from the PyPI package ``ziglang``, the
  cross-compiler of every FMU binary.
- :func:`host_compiler`: a compiler for this machine (``$CC``, ``cc``, ``gcc``,
  ``clang``, else zig), for the host kernel.
- :func:`cache_dir`: compiled artefacts (``$PIEZO_MPI_CACHE`` or
  ``~/.cache/piezo-mpi``).

Examples
--------
>>> from pysim.core.toolchain import SOURCE_DIR, zig_cc
>>> (SOURCE_DIR / "hysteresis.c").is_file()
True
>>> zig_cc()[-2:]
['ziglang', 'cc']
"""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pysim.core.csrc as _csrc

__all__ = ["SOURCE_DIR", "cache_dir", "host_compiler", "zig_cc", "zig_command"]

SOURCE_DIR = Path(_csrc.__file__).resolve().parent


def zig_command() -> list[str]:
    """The command that runs zig (``python -m ziglang``)."""
    return [sys.executable, "-m", "ziglang"]


def zig_cc() -> list[str]:
    """The command that runs zig's C compiler."""
    return zig_command() + ["cc"]


def host_compiler() -> list[str]:
    """Command that compiles C for this machine: ``$CC``, ``cc``/``gcc``/``clang``, else zig."""
    if os.environ.get("CC"):
        return [os.environ["CC"]]
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return [path]
    return zig_cc()


def cache_dir() -> Path:
    """Folder for compiled artefacts (``$PIEZO_MPI_CACHE`` or ``~/.cache/piezo-mpi``)."""
    root = os.environ.get("PIEZO_MPI_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "piezo-mpi"
