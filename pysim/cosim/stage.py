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

import math

import control
import numpy as np
import scipy.linalg
import scipy.signal

from pysim.core.errors import SpecError
from pysim.core.spec import load_module
from pysim.cosim.errors import CoSimulationError

METHODS = ("tustin", "zoh", "foh")


def as_siso(system):
    """Check that ``system`` is a SISO python-control LTI system and return it."""
    if not isinstance(system, (control.TransferFunction, control.StateSpace)):
        raise TypeError(f"stage must be a python-control TransferFunction or StateSpace, "
                        f"got {type(system).__name__}")
    if system.ninputs != 1 or system.noutputs != 1:
        raise CoSimulationError(f"stage must have one input and one output, "
                         f"got {system.ninputs} inputs and {system.noutputs} outputs")
    return system


def _matrices(system):
    """(A, B, C, D) of a SISO system as float arrays."""
    ss = control.ss(system)
    return tuple(np.atleast_2d(np.asarray(m, dtype=float)) for m in (ss.A, ss.B, ss.C, ss.D))


def _check_step(system, step_s, method, prewarp_hz):
    if not (isinstance(step_s, (int, float)) and step_s > 0 and math.isfinite(step_s)):
        raise CoSimulationError(f"step must be a positive number of seconds, got {step_s}")
    if method not in METHODS:
        raise CoSimulationError(f"discretisation method must be one of {METHODS}, got {method!r}")
    if system.dt is True:
        raise CoSimulationError("stage is discrete with an unspecified sampling time (dt=True); give it dt = step")
    if system.dt and not math.isclose(system.dt, step_s, rel_tol=1e-9):
        raise CoSimulationError(f"discrete stage has dt = {system.dt} s but the communication step is {step_s} s")
    if prewarp_hz is not None and not system.dt:
        if method != "tustin":
            raise CoSimulationError("prewarp_hz applies to the tustin method only")
        if not (0 < prewarp_hz < 0.5 / step_s):
            raise CoSimulationError(f"prewarp frequency {prewarp_hz} Hz must lie between 0 and the Nyquist "
                             f"frequency {0.5 / step_s} Hz")


def _discretise_matrices(matrices, step_s, method, prewarp_hz):
    A, B, C, D = matrices
    if A.size == 0:
        return matrices  # a static gain is the same at any step
    if method == "tustin":
        # Prewarping at w0 is the bilinear map with the step T' = 2 tan(w0 h / 2) / w0:
        # s = (2 / T') (z - 1) / (z + 1) sends s = j w0 to z = exp(j w0 h) exactly.
        step = step_s if prewarp_hz is None else math.tan(math.pi * prewarp_hz * step_s) / (math.pi * prewarp_hz)
        # Bilinear form with M = I - A T/2: Ad = M^-1 (I + A T/2), Bd = M^-1 B T,
        # Cd = C M^-1, Dd = D + C M^-1 B T/2 (numpy: scipy's solve costs
        # milliseconds per call here, which a sweep pays at every frequency)
        identity = np.eye(A.shape[0])
        m = identity - A * (step / 2)
        Ad = np.linalg.solve(m, identity + A * (step / 2))
        Bd = np.linalg.solve(m, B * step)
        Cd = np.linalg.solve(m.T, C.T).T
        Dd = D + Cd @ B * (step / 2)
    else:
        Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((A, B, C, D), step_s, method=method)
    return Ad, Bd, Cd, Dd


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
    Discrete python-control state-space system with ``dt == step_s`` (a
    discrete ``system`` is returned as is).
    """
    as_siso(system)
    _check_step(system, step_s, method, prewarp_hz)
    if system.dt:
        return system
    return control.ss(*_discretise_matrices(_matrices(system), step_s, method, prewarp_hz), step_s)


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


def _response(matrices, z):
    """C (z I - A)^-1 B + D at the complex point z."""
    A, B, C, D = matrices
    if A.size == 0:
        return complex(D.item())
    return complex((C @ np.linalg.solve(z * np.eye(A.shape[0]) - A, B)).item() + D.item())


def _sections(matrices):
    """Second-order sections and pure delay (samples) of a discrete SISO system.

    Poles are the eigenvalues of A and zeros the finite generalised
    eigenvalues of the system pencil [[A, B], [C, D]] - z [[I, 0], [0, 0]]:
    both stay accurate for poles crowded near z = 1 at fine steps, where
    the roots of transfer-function coefficients would not.  scipy's digital
    zpk form pads missing zeros at the origin, which would drop the delay of a
    strictly proper system (ZOH gives one), so the delay is kept apart and
    applied as a short delay line.
    """
    A, B, C, D = matrices
    if A.size == 0:
        return np.array([[float(D.item()), 0.0, 0.0, 1.0, 0.0, 0.0]]), 0
    n = A.shape[0]
    poles = np.linalg.eigvals(A)
    pencil = np.block([[A, B], [C, D]])
    mass = np.zeros((n + 1, n + 1))
    mass[:n, :n] = np.eye(n)
    zeros = scipy.linalg.eigvals(pencil, mass)
    zeros = zeros[np.isfinite(zeros)]
    delay = poles.size - zeros.size
    # gain of k prod(z - z_i) / prod(z - p_j), matched at a point away from both
    candidates = np.array([2.0, -2.0, 2.0j, 1.5 + 1.5j, 3.0])
    distance = [min(np.min(np.abs(c - poles)), np.min(np.abs(c - zeros), initial=np.inf)) for c in candidates]
    z0 = candidates[int(np.argmax(distance))]
    gain = (_response(matrices, z0) * np.prod(z0 - poles) / np.prod(z0 - zeros)).real
    if gain == 0.0:
        return np.array([[0.0, 0.0, 0.0, 1.0, 0.0, 0.0]]), 0
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

    def __init__(self, system, step_s: float, method: str = "tustin", prewarp_hz: float | None = None,
                 _matrices_cache=None):
        as_siso(system)
        _check_step(system, step_s, method, prewarp_hz)
        matrices = _matrices(system) if _matrices_cache is None else _matrices_cache
        self.matrices = matrices if system.dt else _discretise_matrices(matrices, step_s, method, prewarp_hz)
        self.step_s = float(step_s)
        self.sos, self.delay = _sections(self.matrices)
        self._system = None
        self.reset()

    @classmethod
    def factory(cls, system, method: str = "tustin"):
        """A function ``(step_s, prewarp_hz) -> DiscreteStage`` that converts
        ``system`` to state space once (for sweeps that change the step)."""
        as_siso(system)
        if method not in METHODS:
            raise CoSimulationError(f"discretisation method must be one of {METHODS}, got {method!r}")
        matrices = _matrices(system)
        return lambda step_s, prewarp_hz=None: cls(system, step_s, method, prewarp_hz, matrices)

    @property
    def system(self):
        """The discrete system as a python-control state-space object."""
        if self._system is None:
            self._system = control.ss(*self.matrices, self.step_s)
        return self._system

    def reset(self, initial_input: float | None = None):
        """Rest (zero state), or at equilibrium with a constant input
        ``initial_input`` (µm) held since forever."""
        if initial_input is None:
            self._zi = np.zeros((self.sos.shape[0], 2))
            self._line = np.zeros(self.delay)
            return
        A = self.matrices[0]
        if A.size and np.any(np.abs(np.linalg.eigvals(A) - 1.0) < 1e-12):
            raise CoSimulationError("the stage has a pole at z = 1 (no finite static gain): it has no "
                             "equilibrium for a constant input")
        self._zi = scipy.signal.sosfilt_zi(self.sos) * float(initial_input)
        self._line = np.full(self.delay, self.dc_gain() * float(initial_input))

    def dc_gain(self) -> float:
        """Static gain of the discrete system."""
        return _response(self.matrices, 1.0).real

    def apply(self, signal) -> np.ndarray:
        """Filter a block of samples, continuing from the carried state."""
        u = np.asarray(signal, dtype=float).ravel()
        if u.size == 0:
            return u.copy()
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
        f = np.atleast_1d(np.asarray(frequency_hz, dtype=float))
        out = np.array([_response(self.matrices, np.exp(2j * math.pi * x * self.step_s)) for x in f])
        return out if np.ndim(frequency_hz) else out[0]


def load_stage(source):
    """The ``STAGE`` of a stage module.

    Parameters
    ----------
    source : str, Path or LTI system
        Path to a ``.py`` file, a module name (``pysim.specs.flexure_stage``), a bare
        name of a shipped spec (``models/`` in the repository, ``pysim.specs`` installed) (``flexure_stage``), or a system (checked
        and returned).
    """
    if isinstance(source, (control.TransferFunction, control.StateSpace)):
        return as_siso(source)
    text = str(source)
    try:
        module = load_module(source, "stage")
    except SpecError as exc:
        raise CoSimulationError(str(exc)) from exc
    stage = getattr(module, "STAGE", None)
    if not isinstance(stage, (control.TransferFunction, control.StateSpace)):
        raise CoSimulationError(f"{text}: defines no STAGE of type control.TransferFunction or control.StateSpace")
    try:
        return as_siso(stage)
    except (TypeError, ValueError) as exc:
        raise CoSimulationError(f"{text}: {exc}") from exc
