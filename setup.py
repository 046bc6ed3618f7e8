"""Package discovery and the mapping of two repository folders into ``pysim``.

Metadata and dependencies are in ``pyproject.toml``.  Every package below
``pysim/`` and ``build_fmu/`` is found automatically, so a new subpackage cannot
be forgotten.  ``fmu_src/`` (the C sources of the FMUs and of the host kernel)
installs as ``pysim.core.csrc`` and ``models/`` (the model specs) as
``pysim.specs``, and the two measured data sets (``data/measured/``) as
``pysim.identification.datasets``: the layers that use them own them, and
nothing is installed under generic top-level names such as ``models``.
"""
from setuptools import find_namespace_packages, setup

MAPPED = {"pysim.core.csrc": "fmu_src", "pysim.specs": "models",
          "pysim.identification.datasets": "data/measured"}
C_SOURCES = ["*.c", "*.h", "*/*.c", "*/*.h"]        # the shared sources and one folder per FMU kind
DATASETS = ["*/*.csv", "*/LICENSE", "*/SOURCE.md"]

found = find_namespace_packages(include=["pysim", "pysim.*", "build_fmu", "build_fmu.*"],
                                exclude=["*__pycache__*"])
setup(packages=sorted(set(found) | set(MAPPED)), package_dir=MAPPED,
      package_data={"pysim.core.csrc": C_SOURCES, "pysim.identification.datasets": DATASETS})
