"""The parts of a nanopositioning rig around the actuator, as discrete-time
equations at the controller's sample period ``T`` (s).

Each part is a small frozen dataclass with its parameters in physical units and
a ``step`` function that is *the* definition of its discrete behaviour: the
co-simulation (:mod:`pysim.cosim.rig`) runs these equations, and the FMUs of the
parts compute the same operations in C in the same order, so a chain of FMUs
and the Python simulation give the same samples.

Signal flow of one sample ``k`` of a rig (see :mod:`pysim.cosim.rig`)::

    reference r_k (µm) ─► controller ─► DAC ─► amplifier ─► actuator ─► stage ─► sensor + ADC ─► m_k (µm)
                              ▲                                                                  │
                              └──────────────── one sample of computation delay ◄────────────────┘

- :class:`Converter`: a ``bits``-bit converter over ``[low, high]``: rounds to
  the nearest code and holds it for the sample (sample and hold); values
  outside the range saturate at the end codes.
- :class:`Amplifier`: voltage gain (the paper's rig: 15 V/V, 0-10 V command to
  0-150 V), a first-order small-signal bandwidth, a slew-rate limit
  ``I_max / C`` (the current limit into the stack's capacitance), and the
  output range.  Its output is its state: no direct feed-through, which also
  keeps a closed loop free of algebraic loops.
- :class:`SensorNoise`: white noise of a given RMS from a 64-bit xorshift
  generator with a fixed seed (the same numbers in Python and in C).
- :class:`PIController`: a discrete PI(D) controller with conditional
  integration (anti-windup) and output limits; its output is applied one
  sample after the measurement it uses, as on a real-time DSP.

Examples
--------
>>> amp = Amplifier(gain_V_per_V=15.0, bandwidth_hz=10e3, current_limit_A=0.5, capacitance_F=3.6e-6)
>>> round(amp.slew_rate_V_per_s / 1e3, 1)      # V/ms
138.9
>>> state = amp.initial_state(0.0)
>>> state = amp.step(state, 10.0, 1e-4)         # a full-scale command step: slew limited
>>> round(state, 6)
13.888889
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pysim.core.errors import ModelError

__all__ = ["Converter", "Amplifier", "SensorNoise", "PIController", "XorShiftNormal"]


def _finite(name: str, value, positive: bool = False, non_negative: bool = False) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(value) or (positive and value <= 0) or (non_negative and value < 0):
        need = "> 0" if positive else ">= 0" if non_negative else "finite"
        raise ModelError(f"{name} must be finite and {need}, got {value!r}")
    return value


@dataclass(frozen=True)
class Converter:
    """A ``bits``-bit converter (DAC or ADC) over ``[low, high]``.

    Parameters
    ----------
    bits : int
        Resolution, 1-32 (0: an ideal converter that only saturates).
    low, high : float
        Range in the converted quantity's unit (V for a DAC, µm for a sensor's ADC).

    Examples
    --------
    >>> dac = Converter(16, 0.0, 10.0)
    >>> dac.lsb
    0.00015259021896696422
    >>> dac.convert(5.00001) == round(5.00001 / dac.lsb) * dac.lsb
    True
    """

    bits: int = 16
    low: float = 0.0
    high: float = 10.0

    def __post_init__(self):
        if not isinstance(self.bits, int) or not 0 <= self.bits <= 32:
            raise ModelError(f"converter bits must be a whole number 0-32, got {self.bits!r}")
        low, high = _finite("converter low", self.low), _finite("converter high", self.high)
        if not low < high:
            raise ModelError(f"converter range must have low < high, got [{low}, {high}]")
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)

    @property
    def lsb(self) -> float:
        """One code step (0 for an ideal converter)."""
        return 0.0 if self.bits == 0 else (self.high - self.low) / (2 ** self.bits - 1)

    def convert(self, value: float) -> float:
        """Saturate into the range, then round to the nearest code (ties to even)."""
        x = min(max(float(value), self.low), self.high)
        if self.bits == 0:
            return x
        lsb = self.lsb
        return self.low + round((x - self.low) / lsb) * lsb


@dataclass(frozen=True)
class Amplifier:
    """A piezo amplifier: gain, small-signal bandwidth, slew limit, output range.

    Parameters
    ----------
    gain_V_per_V : float
        Voltage gain (15 V/V on the paper's rig).
    bandwidth_hz : float
        -3 dB frequency of the first-order small-signal response, Hz (inf: none).
    current_limit_A : float
        Peak output current, A (inf: no slew limit).
    capacitance_F : float
        Capacitance of the driven stack, F (a PSt 150/7/100 stack: a few µF).
    output_low_V, output_high_V : float
        Output range, V.

    Notes
    -----
    One sample of length ``T``, command ``c`` (V at the amplifier's input)::

        target = gain * c
        a' = a + (1 - exp(-2π f_bw T)) (target - a)     # exact step of the first-order lag
        a' = a + clip(a' - a, -S T, +S T)               # S = I_max / C, the slew limit
        a' = clip(a', output_low, output_high)

    and the output during the sample is ``a`` (the state before the update).
    """

    gain_V_per_V: float = 15.0
    bandwidth_hz: float = math.inf
    current_limit_A: float = math.inf
    capacitance_F: float = 3.6e-6
    output_low_V: float = 0.0
    output_high_V: float = 150.0

    def __post_init__(self):
        for name in ("gain_V_per_V", "capacitance_F"):
            object.__setattr__(self, name, _finite(name, getattr(self, name), positive=True))
        for name in ("bandwidth_hz", "current_limit_A"):
            value = float(getattr(self, name))
            if not (value > 0):
                raise ModelError(f"{name} must be > 0 (inf: no limit), got {value!r}")
            object.__setattr__(self, name, value)
        low = _finite("output_low_V", self.output_low_V)
        high = _finite("output_high_V", self.output_high_V)
        if not low < high:
            raise ModelError(f"amplifier output range must have low < high, got [{low}, {high}]")
        object.__setattr__(self, "output_low_V", low)
        object.__setattr__(self, "output_high_V", high)

    @property
    def slew_rate_V_per_s(self) -> float:
        """``I_max / C``, V/s (inf without a current limit)."""
        return self.current_limit_A / self.capacitance_F

    def coefficients(self, step_s: float) -> tuple:
        """``(alpha, max_change_V)`` of one step of ``step_s`` seconds."""
        step_s = _finite("step_s", step_s, positive=True)
        alpha = 1.0 if math.isinf(self.bandwidth_hz) else -math.expm1(-2.0 * math.pi * self.bandwidth_hz * step_s)
        return alpha, self.slew_rate_V_per_s * step_s

    def initial_state(self, output_V: float) -> float:
        """The output held since forever (clipped into the range)."""
        return min(max(float(output_V), self.output_low_V), self.output_high_V)

    def step(self, state_V: float, command_V: float, step_s: float) -> float:
        """The state after one sample with ``command_V`` held (see Notes)."""
        alpha, max_change = self.coefficients(step_s)
        return self._step(state_V, command_V, alpha, max_change)

    def _step(self, a: float, command: float, alpha: float, max_change: float) -> float:
        change = alpha * (self.gain_V_per_V * command - a)
        change = min(max(change, -max_change), max_change)
        return min(max(a + change, self.output_low_V), self.output_high_V)

    def run(self, command_V, step_s: float, state_V: float | None = None):
        """Outputs (V) for a command record, and the final state."""
        alpha, max_change = self.coefficients(step_s)
        commands = np.asarray(command_V, dtype=float).ravel().tolist()
        a = self.initial_state(self.gain_V_per_V * commands[0] if commands else 0.0) if state_V is None \
            else float(state_V)
        out = []
        for c in commands:
            out.append(a)
            a = self._step(a, c, alpha, max_change)
        return np.array(out), a


class XorShiftNormal:
    """Reproducible standard-normal numbers: xorshift64* and the Box-Muller
    transform, the same integer operations as the C sensor of the FMUs.

    Examples
    --------
    >>> g = XorShiftNormal(1)
    >>> values = [g.next() for _ in range(20000)]
    >>> abs(float(np.mean(values))) < 0.03 and abs(float(np.std(values)) - 1) < 0.03
    True
    """

    _MASK = (1 << 64) - 1

    def __init__(self, seed: int):
        self.state = (int(seed) & self._MASK) or 0x9E3779B97F4A7C15
        self._spare = None

    def _uniform(self) -> float:
        x = self.state
        x ^= (x >> 12)
        x ^= (x << 25) & self._MASK
        x ^= (x >> 27)
        self.state = x
        # 53 random bits -> (0, 1]
        return (((x * 0x2545F4914F6CDD1D) & self._MASK) >> 11) * (1.0 / 9007199254740992.0) + (
            1.0 / 9007199254740992.0)

    def next(self) -> float:
        if self._spare is not None:
            value, self._spare = self._spare, None
            return value
        u1, u2 = self._uniform(), self._uniform()
        radius = math.sqrt(-2.0 * math.log(u1))
        angle = 2.0 * math.pi * u2
        self._spare = radius * math.sin(angle)
        return radius * math.cos(angle)


@dataclass(frozen=True)
class SensorNoise:
    """White measurement noise of ``rms_um`` µm RMS, seeded (``seed``)."""

    rms_um: float = 0.0
    seed: int = 2014

    def __post_init__(self):
        object.__setattr__(self, "rms_um", _finite("noise rms_um", self.rms_um, non_negative=True))
        if not isinstance(self.seed, int) or abs(self.seed) > 2 ** 53:
            raise ModelError(f"noise seed must be a whole number of at most 2^53 in size, got {self.seed!r}")

    def generator(self) -> XorShiftNormal:
        return XorShiftNormal(self.seed)


@dataclass(frozen=True)
class PIController:
    """Discrete PI controller with anti-windup, acting in volts at the actuator.

    Parameters
    ----------
    kp_V_per_um : float
        Proportional gain, V per µm of error.
    ki_V_per_um_s : float
        Integral gain, V per µm·s of error (0: P only).
    output_low_V, output_high_V : float
        Limits of feedforward + feedback (the actuator's voltage range).

    Notes
    -----
    With the error ``e_k = r_k - m_k`` of sample ``k`` and the feedforward
    voltage ``f_k``, the controller computes during sample ``k`` the voltage it
    applies at sample ``k + 1`` (one sample of computation delay)::

        u   = f_k + kp e_k + i_k
        out = clip(u, low, high)
        i_{k+1} = i_k + ki T e_k   unless out was clipped and e_k pushes further out

    (conditional integration: the integrator stops while the output is saturated
    in the direction the error drives it, so it does not wind up).
    """

    kp_V_per_um: float = 0.0
    ki_V_per_um_s: float = 0.0
    output_low_V: float = 0.0
    output_high_V: float = 150.0

    def __post_init__(self):
        object.__setattr__(self, "kp_V_per_um", _finite("kp_V_per_um", self.kp_V_per_um, non_negative=True))
        object.__setattr__(self, "ki_V_per_um_s", _finite("ki_V_per_um_s", self.ki_V_per_um_s,
                                                          non_negative=True))
        low = _finite("output_low_V", self.output_low_V)
        high = _finite("output_high_V", self.output_high_V)
        if not low < high:
            raise ModelError(f"controller output range must have low < high, got [{low}, {high}]")
        object.__setattr__(self, "output_low_V", low)
        object.__setattr__(self, "output_high_V", high)

    @property
    def active(self) -> bool:
        """Whether there is any feedback."""
        return self.kp_V_per_um > 0 or self.ki_V_per_um_s > 0

    def step(self, integrator_V: float, error_um: float, feedforward_V: float, step_s: float) -> tuple:
        """``(output_V, next_integrator_V)`` for one sample (see Notes)."""
        u = feedforward_V + self.kp_V_per_um * error_um + integrator_V
        out = min(max(u, self.output_low_V), self.output_high_V)
        winding = (u > self.output_high_V and error_um > 0) or (u < self.output_low_V and error_um < 0)
        if not winding:
            integrator_V = integrator_V + self.ki_V_per_um_s * step_s * error_um
        return out, integrator_V
