"""Stages *before* the hysteresis: the voltage the actuator's operators see is
not the voltage commanded.

``lowpass``
    A first-order low-pass on the input, ``1/(τ s + 1)`` (exact for an input
    linear between samples, unit static gain): the operators see a lagged
    voltage, so loops widen with frequency -- unlike a lag after the
    hysteresis, which delays the whole output, including its rate-independent
    part.  The diagnosis names it ``rate_dependent_hysteresis``.
``slew_limit``
    An amplifier whose output follows the command at most at ``rate_V_per_s``:
    ``x_k = x_{k−1} + clip(v_k − x_{k−1}, −R T, R T)``.  Slow inputs pass
    unchanged; fast, large steps are turned into ramps.

Both start at rest at the first sample.  :class:`InputStageModel` composes
such a stage with a plant model (a :class:`pysim.core.extended.ExtendedModel`
or :class:`pysim.core.model.HysteresisModel`).  It runs on the host (the slew
limit's recursion in the C kernel, ``fmu_src/input_stages.c``): the plant
FMU has no input stage, so ``build-fmu`` refuses a spec that holds one unless
told to build the part after the stage.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

from pysim.core import kernel as _kernel
from pysim.core.errors import ModelError
from pysim.core.extended import first_order_section

__all__ = ["INPUT_STAGE_KINDS", "InputStageModel", "apply_input_stage", "input_lowpass", "slew_limit"]

INPUT_STAGE_KINDS = ("lowpass", "slew_limit")


def input_lowpass(voltage_V, time_constant_s: float, sample_period_s: float) -> np.ndarray:
    """First-order low-pass of the input, at rest at the first sample
    (:func:`~pysim.core.extended.first_order_section`).

    Examples
    --------
    >>> x = input_lowpass(np.r_[0.0, np.ones(2000)], 0.01, 1e-4)
    >>> round(float(x[-1]), 6), bool(np.all(np.diff(x) >= 0))
    (1.0, True)
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    if not time_constant_s > 0:
        return v.copy()
    b0, b1, _, a1, _ = first_order_section(time_constant_s, sample_period_s)
    zi = scipy.signal.lfilter_zi([b0, b1], [1.0, a1]) * (v[0] if v.size else 0.0)
    out, _ = scipy.signal.lfilter([b0, b1], [1.0, a1], v, zi=zi)
    return out


def slew_limit(voltage_V, rate_V_per_s: float, sample_period_s: float) -> np.ndarray:
    """The command followed at most at ``rate_V_per_s``, from rest at the first sample.

    Examples
    --------
    >>> slew_limit([0.0, 10.0, 10.0, 10.0, 0.0], 4000.0, 1e-3).tolist()
    [0.0, 4.0, 8.0, 10.0, 6.0]
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    if not (math.isfinite(rate_V_per_s) and rate_V_per_s > 0):
        return v.copy()
    step = rate_V_per_s * sample_period_s
    if v.size == 0:
        return v.copy()
    dv = np.abs(np.diff(v))
    if dv.size and float(dv.max()) <= step:
        return v.copy()
    # the recursion runs in C (fmu_src/input_stages.c): a loop over 10⁵ samples took about 10 ms in Python
    # against under 1 ms there, and the diagnosis runs it a hundred times on a long record
    v = _kernel.contiguous(v)
    followed = np.empty_like(v)
    _kernel.library().istage_slew_limit(v.size, _kernel.as_pointer(v), step, _kernel.as_pointer(followed))
    return followed


def apply_input_stage(kind: str, parameter: float, voltage_V, sample_period_s: float) -> np.ndarray:
    """Run the input stage ``kind`` (:data:`INPUT_STAGE_KINDS`) with its parameter
    (time constant in s, or rate in V/s)."""
    if kind == "lowpass":
        return input_lowpass(voltage_V, parameter, sample_period_s)
    if kind == "slew_limit":
        return slew_limit(voltage_V, parameter, sample_period_s)
    raise ModelError(f"unknown input stage {kind!r}; known: {INPUT_STAGE_KINDS}")


@dataclass(frozen=True)
class InputStageModel:
    """A plant model preceded by an input stage.

    Parameters
    ----------
    plant : ExtendedModel or HysteresisModel
        What follows the stage.
    kind : {"lowpass", "slew_limit"}
    parameter : float
        Time constant (s) of the low-pass, or rate (V/s) of the slew limit.
    sample_period_s : float

    Examples
    --------
    >>> from pysim.core.model import HysteresisModel
    >>> h = HysteresisModel(0.0, 1.0, (0.0,), (0.0,), voltage_range_V=(0.0, 10.0))
    >>> InputStageModel(h, "slew_limit", 1000.0, 1e-3).simulate([0.0, 5.0, 5.0]).tolist()
    [0.0, 1.0, 2.0]
    >>> InputStageModel(h, "lowpass", -1.0, 1e-3)
    Traceback (most recent call last):
    ...
    pysim.core.errors.ModelError: an input stage needs a parameter > 0 and a sample period > 0 s
    """

    plant: object
    kind: str
    parameter: float
    sample_period_s: float

    def __post_init__(self):
        if self.kind not in INPUT_STAGE_KINDS:
            raise ModelError(f"unknown input stage {self.kind!r}; known: {INPUT_STAGE_KINDS}")
        if not (math.isfinite(self.parameter) and self.parameter > 0 and self.sample_period_s > 0):
            raise ModelError("an input stage needs a parameter > 0 and a sample period > 0 s")

    @property
    def hysteresis(self):
        return getattr(self.plant, "hysteresis", self.plant)

    @property
    def stages(self):
        return getattr(self.plant, "stages", None)

    @property
    def name(self) -> str:
        return self.plant.name

    @property
    def description(self) -> str:
        return self.plant.description

    @property
    def voltage_range_V(self) -> tuple:
        return self.plant.voltage_range_V

    def stage_summary(self) -> str:
        """The stage in words, with its parameter in the units a user reads.

        Examples
        --------
        >>> from pysim.core.model import HysteresisModel
        >>> h = HysteresisModel(0.0, 1.0, (0.0,), (0.0,), voltage_range_V=(0.0, 10.0))
        >>> InputStageModel(h, "slew_limit", 4.2e5, 1e-4).stage_summary()
        'slew limit 420 V/ms'
        >>> InputStageModel(h, "lowpass", 1.9e-4, 1e-4).stage_summary()
        'input low-pass, time constant 0.19 ms'
        """
        if self.kind == "slew_limit":
            return f"slew limit {self.parameter / 1e3:.4g} V/ms"
        return f"input low-pass, time constant {self.parameter * 1e3:.4g} ms"

    def stage_input(self, voltage_V) -> np.ndarray:
        """The voltage the actuator sees after the input stage."""
        return apply_input_stage(self.kind, self.parameter, voltage_V, self.sample_period_s)

    def simulate(self, voltage_V, state=None, **options):
        """Displacement (µm) for a voltage record (V): the input stage (from rest
        at the first sample), then the plant (``state`` and options as the plant's)."""
        return self.plant.simulate(self.stage_input(voltage_V), state, **options)
