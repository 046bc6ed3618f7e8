"""The model core: MPI/CPI hysteresis models, output stages, invertibility,
stages before the hysteresis, inverse compensators, the C kernel binding, spec files and the paper's error
measures.  Imports nothing else of the package.

Examples
--------
>>> import numpy as np
>>> from pysim.core import HysteresisModel, InverseCompensator, eq13_thresholds
>>> r = eq13_thresholds(4, 100.0)
>>> model = HysteresisModel(-1e-6, 0.4, tuple(r), (0.0, 0.05, 0.05, 0.05), voltage_range_V=(0.0, 100.0))
>>> v = np.array([0.0, 60.0, 30.0, 90.0])
>>> bool(np.allclose(InverseCompensator(model)(model.simulate(v)), v))
True
"""
from pysim.core.errors import ModelError, NotInvertibleError, PiezoMPIError, SpecError
from pysim.core.extended import ExtendedModel, ExtendedState, OutputStages, StageSpec
from pysim.core.input_stage import InputStageModel
from pysim.core.metrics import error_measures
from pysim.core.model import HysteresisModel, InverseCompensator, analytic_inverse, eq13_thresholds, invert
from pysim.core.spec import load_spec, write_spec

__all__ = ["HysteresisModel", "ExtendedModel", "ExtendedState", "OutputStages", "StageSpec", "InputStageModel",
           "InverseCompensator",
           "analytic_inverse", "invert", "eq13_thresholds", "error_measures", "load_spec", "write_spec",
           "PiezoMPIError", "ModelError", "NotInvertibleError", "SpecError"]
