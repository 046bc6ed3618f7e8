"""Co-simulation: FMUs chained through fmpy with raw calls, LTI stages,
stepped-sine bandwidth and the paper's Table III tracking.  Built on
:mod:`pysim.core`, :mod:`pysim.specs` and :mod:`pysim.fmu`.
"""
from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import CoSimResult, CoSimulation, FMUUnit, NominalDrive, fmus_for_model

__all__ = ["CoSimulation", "CoSimResult", "FMUUnit", "NominalDrive", "fmus_for_model", "CoSimulationError"]
