"""Diagnosis: what an identified model gets wrong on a record, which effect
causes it, the extended model and its gain.  Built on :mod:`pysim.core` and
:mod:`pysim.identification`.
"""
from pysim.diagnosis.diagnose import Diagnosis, diagnose
from pysim.diagnosis.errors import DiagnosisError
from pysim.diagnosis.rules import CAUSES

__all__ = ["diagnose", "Diagnosis", "CAUSES", "DiagnosisError"]
