"""Stages *before* the hysteresis, for the causes of the diagnosis catalogue
that act on the voltage the actuator sees rather than on its output:

``rate_dependent_hysteresis``
    A first-order low-pass on the input, ``1/(τ s + 1)`` (exact for an input
    linear between samples, unit static gain): the operators see a lagged
    voltage, so loops widen with frequency -- unlike a lag after the
    hysteresis, which delays the whole output, including its rate-independent
    part.
``slew_limit``
    An amplifier whose output follows the command at most at ``rate_V_per_s``:
    ``x_k = x_{k−1} + clip(v_k − x_{k−1}, −R T, R T)``.  Slow inputs pass
    unchanged; fast, large steps are turned into ramps.

Both start at rest at the first sample.  :class:`InputStageModel` composes
such a stage with a plant model (a :class:`pysim.core.extended.ExtendedModel`
or :class:`pysim.core.model.HysteresisModel`); it is a Python-side model (the
FMU plant has no input stages), with the ``simulate`` interface of every model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

from pysim.core.extended import first_order_section
from pysim.diagnosis.errors import DiagnosisError

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
    x = float(v[0])
    dv = np.abs(np.diff(v))
    if dv.size and float(dv.max()) <= step:
        return v.copy()
    # on Python floats (the same IEEE doubles): indexing the array sample by sample costs several times more
    followed = []
    for target in v.tolist():
        if target > x + step:
            x += step
        elif target < x - step:
            x -= step
        else:
            x = target
        followed.append(x)
    return np.array(followed, dtype=float)


#: The slew rates searched first span this ratio below the fastest move of the records.
SLEW_SEARCH_SPAN = 40.0


def slew_rate_grid(records, points: int) -> np.ndarray:
    """Slew rates (V/s) to search for the records ``[(voltage_V, sample_period_s), ...]``, ascending.

    ``points`` rates, evenly spaced in log, from a ``SLEW_SEARCH_SPAN``-th of the fastest move of
    the records (V/s) up to it; below them, at the same spacing, more rates down to the slowest
    limit a record can show, the rate that crosses its input's span once in the whole record (a
    slower limit never lets the stage follow it).  Steps move far faster than a large stack's
    amplifier may follow: independent seed 759's second record moves 500 V/ms behind a 1.5 V/ms
    limit, which the first rates alone do not reach.  Empty when no record's input moves.

    Examples
    --------
    >>> steps = np.repeat([0.0, 100.0, 0.0], 1000)             # 100 V in one 1 ms sample
    >>> grid = slew_rate_grid([(steps, 1e-3)], 3)
    >>> (grid / 1e3).round(4).tolist()                          # V/ms
    [0.0333, 0.1406, 0.5928, 2.5, 15.8114, 100.0]
    """
    records = [(np.asarray(v, dtype=float).ravel(), float(T)) for v, T in records]
    fastest = max((float(np.max(np.abs(np.diff(v)))) / T for v, T in records if v.size > 1), default=0.0)
    if not fastest > 0:
        return np.zeros(0)
    top = np.geomspace(fastest / SLEW_SEARCH_SPAN, fastest, points)
    slowest = min(float(np.ptp(v)) / (v.size * T) for v, T in records)
    if not 0 < slowest < top[0]:
        return top
    spacing = math.log(top[1] / top[0]) if points > 1 else math.log(SLEW_SEARCH_SPAN)
    below = math.ceil(math.log(top[0] / slowest) / spacing)
    return np.r_[np.geomspace(slowest, top[0], below + 1)[:-1], top]


def apply_input_stage(kind: str, parameter: float, voltage_V, sample_period_s: float) -> np.ndarray:
    """Run the input stage ``kind`` (:data:`INPUT_STAGE_KINDS`) with its parameter
    (time constant in s, or rate in V/s)."""
    if kind == "lowpass":
        return input_lowpass(voltage_V, parameter, sample_period_s)
    if kind == "slew_limit":
        return slew_limit(voltage_V, parameter, sample_period_s)
    raise DiagnosisError(f"unknown input stage {kind!r}; known: {INPUT_STAGE_KINDS}")


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
    """

    plant: object
    kind: str
    parameter: float
    sample_period_s: float

    def __post_init__(self):
        if self.kind not in INPUT_STAGE_KINDS:
            raise DiagnosisError(f"unknown input stage {self.kind!r}; known: {INPUT_STAGE_KINDS}")
        if not (math.isfinite(self.parameter) and self.parameter > 0 and self.sample_period_s > 0):
            raise DiagnosisError("an input stage needs a parameter > 0 and a sample period > 0 s")

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
    def voltage_range_V(self) -> tuple:
        return self.plant.voltage_range_V

    def stage_input(self, voltage_V) -> np.ndarray:
        """The voltage the actuator sees after the input stage."""
        return apply_input_stage(self.kind, self.parameter, voltage_V, self.sample_period_s)

    def simulate(self, voltage_V, state=None, **options):
        """Displacement (µm) for a voltage record (V): the input stage (from rest
        at the first sample), then the plant (``state`` and options as the plant's)."""
        return self.plant.simulate(self.stage_input(voltage_V), state, **options)
