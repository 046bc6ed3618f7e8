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

``rate_thresholds``
    Not a stage of the voltage but of the operators: every threshold grows
    with the input's rate, ``r_i(t) = r_i (1 + γ |v̇(t)|)`` (γ in s/V, the rate
    the backward difference ``(v_k − v_{k−1}) / T``, 0 at the first sample).
    Loops widen with frequency while a slow input sees the rate-independent
    thresholds -- the rate-dependent Prandtl-Ishlinskii models of the
    literature.  The operators see the voltage itself.

All start at rest at the first sample.  :class:`InputStageModel` composes
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

__all__ = ["INPUT_STAGE_KINDS", "InputStageModel", "apply_input_stage", "input_lowpass", "rate_threshold_scale",
           "slew_limit", "stage_threshold_scale"]

INPUT_STAGE_KINDS = ("lowpass", "slew_limit", "rate_thresholds")


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


def rate_threshold_scale(voltage_V, growth_s_per_V: float, sample_period_s: float) -> np.ndarray:
    """Factor ``1 + γ |v̇|`` on every threshold at each sample (``γ = growth_s_per_V``; the rate a
    backward difference, 0 at the first sample).

    Examples
    --------
    >>> rate_threshold_scale([0.0, 1.0, 1.0, 0.0], 0.5e-3, 1e-3).tolist()
    [1.0, 1.5, 1.0, 1.5]
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    rate = np.abs(np.diff(v, prepend=v[:1])) / sample_period_s
    return 1.0 + max(float(growth_s_per_V), 0.0) * rate


def apply_input_stage(kind: str, parameter: float, voltage_V, sample_period_s: float) -> np.ndarray:
    """The voltage the operators see behind the input stage ``kind`` (:data:`INPUT_STAGE_KINDS`) with
    its parameter (time constant in s, rate in V/s, or threshold growth in s/V: the voltage itself)."""
    if kind == "lowpass":
        return input_lowpass(voltage_V, parameter, sample_period_s)
    if kind == "slew_limit":
        return slew_limit(voltage_V, parameter, sample_period_s)
    if kind == "rate_thresholds":
        return np.array(voltage_V, dtype=float).ravel()
    raise ModelError(f"unknown input stage {kind!r}; known: {INPUT_STAGE_KINDS}")


def stage_threshold_scale(kind: str, parameter: float, voltage_V, sample_period_s: float):
    """The factor on the operators' thresholds at each sample behind the input stage ``kind``
    (:func:`rate_threshold_scale`), or None where the stage leaves them as they are."""
    if kind == "rate_thresholds":
        return rate_threshold_scale(voltage_V, parameter, sample_period_s)
    if kind not in INPUT_STAGE_KINDS:
        raise ModelError(f"unknown input stage {kind!r}; known: {INPUT_STAGE_KINDS}")
    return None


@dataclass(frozen=True)
class InputStageModel:
    """A plant model preceded by an input stage.

    Parameters
    ----------
    plant : ExtendedModel or HysteresisModel
        What follows the stage.
    kind : {"lowpass", "slew_limit", "rate_thresholds"}
    parameter : float
        Time constant (s) of the low-pass, rate (V/s) of the slew limit, or growth γ (s/V) of
        the thresholds with the input's rate.
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
        >>> InputStageModel(h, "rate_thresholds", 2e-5, 1e-4).stage_summary()
        'thresholds that grow with the input rate, +2 % per V/ms'
        """
        if self.kind == "slew_limit":
            return f"slew limit {self.parameter / 1e3:.4g} V/ms"
        if self.kind == "rate_thresholds":
            return f"thresholds that grow with the input rate, +{self.parameter * 1e5:.4g} % per V/ms"
        return f"input low-pass, time constant {self.parameter * 1e3:.4g} ms"

    def stage_input(self, voltage_V) -> np.ndarray:
        """The voltage the actuator sees after the input stage."""
        return apply_input_stage(self.kind, self.parameter, voltage_V, self.sample_period_s)

    def threshold_scale(self, voltage_V):
        """The factor on every threshold at each sample of ``voltage_V``, or None
        (:func:`stage_threshold_scale`)."""
        return stage_threshold_scale(self.kind, self.parameter, voltage_V, self.sample_period_s)

    def simulate(self, voltage_V, state=None, **options):
        """Displacement (µm) for a voltage record (V): the input stage (from rest
        at the first sample), then the plant (``state`` and options as the plant's).

        Examples
        --------
        >>> from pysim.core.model import HysteresisModel
        >>> h = HysteresisModel(0.0, 0.0, (0.0, 1.0), (0.0, 1.0), voltage_range_V=(0.0, 10.0))
        >>> InputStageModel(h, "rate_thresholds", 0.25e-3, 1e-3).simulate([0.0, 4.0, 8.0]).tolist()
        [0.0, 2.0, 6.0]
        """
        scale = self.threshold_scale(voltage_V)
        if scale is not None:
            options = dict(options, threshold_scale=scale)
        return self.plant.simulate(self.stage_input(voltage_V), state, **options)
