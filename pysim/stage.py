"""Linear stage dynamics behind the actuator: discretise and apply with carried state.

The stage is any single-input single-output python-control system (continuous
or discrete, transfer function or state space).  In the co-simulation it sees
the plant FMU's displacement once per communication step, so a continuous
stage is discretised for that step:

``"tustin"`` (default)
    Bilinear transform.  The plant is static (rate independent), so its output
    between communication points follows the smooth input; it is not a held
    staircase.  Tustin is second-order accurate for such signals and, with
    ``prewarp_hz`` set to an excitation frequency f, maps s = j2πf exactly onto
    z = exp(j2πf h): the sampled steady-state response to a sine at f is then
    exactly |G(j2πf)| and ∠G(j2πf).  The stepped-sine sweep uses this.
``"zoh"``
    Zero-order hold: exact when the actuator is driven by a DAC that holds its
    value over the step.  Against a sine it adds the hold's sinc loss, a half
    step of delay, and the staircase's ripple at the step rate (which a lightly
    damped resonance near that rate folds back onto the fundamental).
``"foh"``
    First-order hold (linear interpolation between samples).

A discrete stage is taken as is; its sampling time must equal the step.
The discrete system runs as cascaded second-order sections (scipy's
``sosfilt``), whose state is carried across blocks, so a record can be filtered
in one call or in pieces with identical results.
"""
from __future__ import annotations

import importlib
import importlib.util
import math
from pathlib import Path

import control
import numpy as np
import scipy.signal

from pysim.errors import UserError

METHODS = ("tustin", "zoh", "foh")


def as_siso(system):
    """Check that ``system`` is a SISO python-control LTI system and return it."""
    if not isinstance(system, (control.TransferFunction, control.StateSpace)):
        raise TypeError(f"stage must be a python-control TransferFunction or StateSpace, "
                        f"got {type(system).__name__}")
    if system.ninputs != 1 or system.noutputs != 1:
        raise ValueError(f"stage must have one input and one output, "
                         f"got {system.ninputs} inputs and {system.noutputs} outputs")
    return system


def discretise(system, step_s: float, method: str = "tustin", prewarp_hz: float | None = None):
    """Discrete-time version of ``system`` for a communication step.

    Parameters
    ----------
    system : control.TransferFunction or control.StateSpace
        SISO stage, continuous (dt = 0) or discrete.
    step_s : float
        Communication step, s.
    method : {"tustin", "zoh", "foh"}
        Discretisation of a continuous system (see the module notes).
    prewarp_hz : float, optional
        Tustin only: frequency (Hz) at which the discrete frequency response
        equals the continuous one exactly.

    Returns
    -------
    Discrete python-control system with ``dt == step_s``.
    """
    as_siso(system)
    if not (step_s > 0 and math.isfinite(step_s)):
        raise ValueError(f"step must be a positive number of seconds, got {step_s}")
    if method not in METHODS:
        raise ValueError(f"discretisation method must be one of {METHODS}, got {method!r}")
    if system.dt is True:
        raise ValueError("stage is discrete with an unspecified sampling time (dt=True); give it dt = step")
    if system.dt:
        if not math.isclose(system.dt, step_s, rel_tol=1e-9):
            raise ValueError(f"discrete stage has dt = {system.dt} s but the communication step is {step_s} s")
        return system
    if prewarp_hz is not None and method != "tustin":
        raise ValueError("prewarp_hz applies to the tustin method only")
    if prewarp_hz is not None and not (0 < prewarp_hz < 0.5 / step_s):
        raise ValueError(f"prewarp frequency {prewarp_hz} Hz must lie between 0 and the Nyquist "
                         f"frequency {0.5 / step_s} Hz")
    prewarp = None if prewarp_hz is None else 2.0 * math.pi * prewarp_hz
    # through state space: a transfer function would gain a cancelling
    # pole-zero pair for a static gain under Tustin
    return control.sample_system(control.ss(system), step_s, method=method, prewarp_frequency=prewarp)


def slowest_time_constant_s(system) -> float:
    """Time constant (s) of the slowest-decaying pole: the stage's transients
    fall by e^-1 in this time.  ``inf`` for a pole on the stability boundary."""
    as_siso(system)
    poles = np.asarray(system.poles(), dtype=complex)
    if poles.size == 0:
        return 0.0
    if system.dt:
        radius = np.max(np.abs(poles))
        if radius >= 1.0:
            return math.inf
        dt = 1.0 if system.dt is True else float(system.dt)
        return -dt / math.log(radius) if radius > 0 else 0.0
    slowest = np.max(poles.real)
    return math.inf if slowest >= 0 else -1.0 / slowest


def _sections(system):
    """Second-order sections and pure delay (samples) of a discrete SISO system.

    Poles and zeros come from the state-space form (eigenvalues), which stays
    accurate for poles crowded near z = 1 at fine steps, where the roots of
    transfer-function coefficients would not.  scipy's digital zpk form pads
    missing zeros at the origin, which would drop the delay of a strictly
    proper system (ZOH gives one), so the delay is kept apart and applied as a
    short delay line.
    """
    ss = control.ss(system)
    A = np.asarray(ss.A, dtype=float)
    poles = np.linalg.eigvals(A) if A.size else np.zeros(0)
    zeros = np.asarray(ss.zeros(), dtype=complex) if A.size else np.zeros(0)
    zeros = zeros[np.isfinite(zeros)]
    delay = poles.size - zeros.size
    if delay < 0:
        raise ValueError("the discrete stage is improper (more zeros than poles): it is not causal")
    # gain of k prod(z - z_i) / prod(z - p_j), matched at a point away from both
    candidates = np.array([2.0, -2.0, 2.0j, 1.5 + 1.5j, 3.0])
    distance = [min(np.min(np.abs(c - poles), initial=np.inf), np.min(np.abs(c - zeros), initial=np.inf))
                for c in candidates]
    z0 = candidates[int(np.argmax(distance))]
    value = complex(np.asarray(ss(z0)).squeeze())
    gain = (value * np.prod(z0 - poles) / np.prod(z0 - zeros)).real
    if gain == 0.0:
        return np.array([[0.0, 0.0, 0.0, 1.0, 0.0, 0.0]]), 0
    if poles.size == 0:
        return np.array([[gain, 0.0, 0.0, 1.0, 0.0, 0.0]]), 0
    return scipy.signal.zpk2sos(zeros, poles, gain), delay


class DiscreteStage:
    """A discrete SISO LTI system with its state, applied sample by sample or
    in blocks.

    Parameters
    ----------
    system : control.TransferFunction or control.StateSpace
        The stage (continuous systems are discretised with ``method``).
    step_s : float
        Sampling time, s.
    method, prewarp_hz
        See :func:`discretise`.
    """

    def __init__(self, system, step_s: float, method: str = "tustin", prewarp_hz: float | None = None):
        self.continuous = None if system.dt else system
        self.system = discretise(system, step_s, method, prewarp_hz)
        self.step_s = float(step_s)
        self.sos, self.delay = _sections(self.system)
        self.reset()

    def reset(self, initial_input: float | None = None):
        """Rest (zero state), or at equilibrium with a constant input
        ``initial_input`` (µm) held since forever."""
        if initial_input is None:
            self._zi = np.zeros((self.sos.shape[0], 2))
            self._line = np.zeros(self.delay)
            return
        if np.any(np.abs(np.asarray(self.system.poles()) - 1.0) < 1e-12):
            raise ValueError("the stage has a pole at z = 1 (no finite static gain): it has no "
                             "equilibrium for a constant input")
        self._zi = scipy.signal.sosfilt_zi(self.sos) * float(initial_input)
        self._line = np.full(self.delay, float(self.dc_gain() * initial_input))

    def dc_gain(self) -> float:
        """Static gain of the discrete system."""
        return float(np.real(self.system(1.0)))

    def apply(self, signal) -> np.ndarray:
        """Filter a block of samples, continuing from the carried state."""
        u = np.asarray(signal, dtype=float).ravel()
        y, self._zi = scipy.signal.sosfilt(self.sos, u, zi=self._zi)
        if self.delay:
            # y[n] = s[n - delay]; the line holds the last `delay` filter outputs
            joined = np.concatenate((self._line, y))
            y, self._line = joined[:u.size], joined[u.size:]
        return y

    def step(self, value: float) -> float:
        """One sample (convenience; use :meth:`apply` for records)."""
        return float(self.apply([value])[0])

    def frequency_response(self, frequency_hz) -> np.ndarray:
        """Complex response of the discrete system at ``frequency_hz``."""
        f = np.asarray(frequency_hz, dtype=float)
        return np.asarray(self.system(np.exp(2j * math.pi * f * self.step_s)), dtype=complex)


def load_stage(source):
    """The ``STAGE`` of a stage module.

    Parameters
    ----------
    source : str, Path or LTI system
        Path to a ``.py`` file, a module name (``models.flexure_stage``), a bare
        name looked up in ``models/`` (``flexure_stage``), or a system (checked
        and returned).
    """
    if isinstance(source, (control.TransferFunction, control.StateSpace)):
        return as_siso(source)
    text = str(source)
    path = Path(text)
    try:
        if text.endswith(".py") or path.exists():
            if not path.is_file():
                raise UserError(f"{text}: stage file does not exist")
            spec = importlib.util.spec_from_file_location(f"_piezo_stage_{abs(hash(str(path.resolve())))}", path)
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(text if "." in text else f"models.{text}")
    except UserError:
        raise
    except ImportError as exc:
        raise UserError(f"{text}: no stage file or module of that name ({exc})") from exc
    except Exception as exc:  # the module's own error, reported with its name
        raise UserError(f"{text}: {type(exc).__name__}: {exc}") from exc
    stage = getattr(module, "STAGE", None)
    if not isinstance(stage, (control.TransferFunction, control.StateSpace)):
        raise UserError(f"{text}: defines no STAGE of type control.TransferFunction or control.StateSpace")
    try:
        return as_siso(stage)
    except (TypeError, ValueError) as exc:
        raise UserError(f"{text}: {exc}") from exc
