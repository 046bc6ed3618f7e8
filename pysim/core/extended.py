"""Extended model: the MPI hysteresis model followed by output stages.

The MPI model is rate independent and has no memory between reversals.  The
extended model adds, after the hysteresis output ``h`` (µm), what measured
actuators show beyond that (see :mod:`pysim.diagnosis.diagnose`)::

    y = D[G[h]] + Σ_j w_j C_j[u] + Σ_j p_j t^j

- ``G``: linear dynamics with unit static gain, a first-order lag
  ``1/(τ s + 1)`` and/or a second-order resonance
  ``ω²/(s² + 2 ζ ω s + ω²)`` (``lag_time_constant_s``, ``resonance_hz``,
  ``damping_ratio``);
  and/or creep of the displacement itself, ``1 − Σ_j s_j + Σ_j s_j/(τ_j s + 1)``
  (``displacement_creep_time_constants_s``, ``displacement_creep_shares``: after
  a step the output jumps to ``1 − Σ s_j`` of its new value and creeps the rest
  of the way, the classic ``y(t) = y_0 (1 + γ log t)`` creep of a piezo stack,
  proportional to the displacement reached);
- ``D``: a pure delay of ``delay_samples`` sample periods (a fraction is
  linear interpolation between two samples);
- ``C_j``: creep modes, first-order lags ``1/(τ_j s + 1)`` of the shifted
  input ``u = v - input_offset_V`` (V) with weights ``w_j`` in µm/V
  (``creep_time_constants_s``, ``creep_weights_um_per_V``);
- drift: a polynomial in the time ``t`` (s) since the start of the run,
  ``drift_coefficients`` = ``(p_1, p_2, ...)`` in µm/s^j; from
  ``t = drift_span_s`` on (when > 0) it holds the value it has there.  A
  polynomial fitted to a record says nothing about the time after it, and run
  on past it a trend grows without bound (a slow wander identified on a 1.9 s
  record as a parabola predicted a 4.1 s record 3 times worse than the plain
  MPI fit).

Every stage is discrete at ``sample_period_s``: the model is a sampled-data
model of the record it was identified from, and an FMU built from it must step
at that period.  The lag and the resonance are discretised exactly for an input
that is linear between samples (first-order hold: :func:`first_order_section`,
:func:`second_order_section`): a measured actuator's lag may be shorter than a
sample, where the bilinear transform's pole turns negative and its response
rings, and a resonance near the Nyquist frequency keeps its physical frequency.
Creep modes (time constants of several samples and more, where the two agree)
use the bilinear transform, whose form the displacement-creep factoring needs.
The coefficients are computed once, here, and handed to the C recursions
(``fmu_src/output_stages.c``), the same code the plant FMU compiles.

The model starts at rest: the stages are initialised as if the first sample's
input had been held since forever.
"""
from __future__ import annotations

import ctypes
import math
from dataclasses import dataclass, field, fields, replace

import numpy as np
import scipy.optimize
import scipy.signal

from pysim.core import kernel as _kernel
from pysim.core.errors import ModelError
from pysim.core.model import HysteresisModel

_DOUBLE_P = ctypes.POINTER(ctypes.c_double)
_bound = None

#: Largest delay line the C stages accept (samples).
MAX_DELAY_SAMPLES = 10_000_000


class OutputStagesStruct(ctypes.Structure):
    """Mirror of ``OutputStages`` in output_stages.h."""

    _fields_ = [
        ("n_sections", ctypes.c_int),
        ("sections", _DOUBLE_P),
        ("delay_whole", ctypes.c_int),
        ("delay_fraction", ctypes.c_double),
        ("n_creep", ctypes.c_int),
        ("creep_alpha", _DOUBLE_P),
        ("creep_beta", _DOUBLE_P),
        ("creep_weights", _DOUBLE_P),
        ("n_drift", ctypes.c_int),
        ("drift", _DOUBLE_P),
        ("drift_span", ctypes.c_double),
    ]


def _library():
    global _bound
    if _bound is None:
        lib = _kernel.library()
        p, size_t, double = _DOUBLE_P, ctypes.c_size_t, ctypes.c_double
        stages_p = ctypes.POINTER(OutputStagesStruct)
        lib.ostage_check.argtypes = [stages_p]
        lib.ostage_check.restype = ctypes.c_int
        lib.ostage_message.argtypes = [ctypes.c_int]
        lib.ostage_message.restype = ctypes.c_char_p
        lib.ostage_state_size.argtypes = [stages_p]
        lib.ostage_state_size.restype = size_t
        lib.ostage_init.argtypes = [stages_p, double, double, p]
        lib.ostage_init.restype = None
        lib.ostage_output.argtypes = [stages_p, p, double, double, double, p]
        lib.ostage_output.restype = double
        lib.ostage_run.argtypes = [stages_p, size_t, p, p, p, p, p]
        lib.ostage_run.restype = None
        _bound = lib
    return _bound


# ------------------------------------------------------------ discretisation

def first_order_section(time_constant_s: float, sample_period_s: float) -> np.ndarray:
    """Section ``(b0, b1, b2, a1, a2)`` of ``1/(τ s + 1)``, exact for an input that is
    linear between samples (first-order hold).

    With ``h = T/τ`` and ``α = exp(−h)``: ``(b0 + b1 z⁻¹) / (1 − α z⁻¹)`` where
    ``b1 = (1 − α)/h − α`` and ``b0 = 1 − α − b1``, so the static gain is 1.  The
    pole ``α`` lies in ``(0, 1)`` for every τ > 0: the step response rises
    monotonically, also for a lag shorter than a sample (where the bilinear
    transform's pole turns negative and the response rings), and a lag that
    tends to zero tends to no stage at all.

    Examples
    --------
    >>> b0, b1, b2, a1, a2 = first_order_section(0.25e-3, 1e-3)
    >>> [round(float(c), 4) for c in (b0, b1, -a1, (b0 + b1) / (1 + a1))]
    [0.7546, 0.2271, 0.0183, 1.0]
    """
    h = float(sample_period_s) / float(time_constant_s)
    gain = -math.expm1(-h)                  # 1 − α, accurate for slow lags
    alpha = 1.0 - gain
    b1 = gain / h - alpha
    return np.array([gain - b1, b1, 0.0, -alpha, 0.0])


def second_order_section(natural_frequency_hz: float, damping_ratio: float,
                         sample_period_s: float) -> np.ndarray:
    """Section ``(b0, b1, b2, a1, a2)`` of ``ω²/(s² + 2ζω s + ω²)`` (ω = 2π f), exact for
    an input that is linear between samples (first-order hold).

    The poles are ``exp(s_i T)`` of the continuous poles, so the natural
    frequency and damping are the physical ones up to the Nyquist frequency (the
    bilinear transform warps a resonance near it); the numerator is scaled so
    the static gain is 1 to rounding.

    Examples
    --------
    >>> b0, b1, b2, a1, a2 = second_order_section(300.0, 0.3, 1e-3)
    >>> gain = (b0 + b1 + b2) / (1 + a1 + a2)           # static gain
    >>> pole_radius = math.sqrt(a2)                     # exp(-ζωT) of the continuous poles
    >>> round(float(gain), 12), round(pole_radius / math.exp(-0.3 * 2 * math.pi * 300 * 1e-3), 12)
    (1.0, 1.0)
    """
    w = 2.0 * math.pi * float(natural_frequency_hz)
    zeta = float(damping_ratio)
    num, den, _ = scipy.signal.cont2discrete(([w * w], [1.0, 2.0 * zeta * w, w * w]), float(sample_period_s),
                                             method="foh")
    b = np.ravel(num)[-3:]
    a = np.ravel(den)
    b = b * (np.sum(a) / np.sum(b))
    return np.array([b[0], b[1], b[2], a[1], a[2]])


def tustin_creep_mode(time_constant_s: float, sample_period_s: float):
    """``(alpha, beta)`` of a creep mode ``c_k = α c_{k−1} + β (u_k + u_{k−1})``
    (the bilinear transform of ``1/(τ s + 1)``)."""
    tk = 2.0 * time_constant_s / sample_period_s
    return (tk - 1.0) / (tk + 1.0), 1.0 / (tk + 1.0)


def tustin_displacement_creep(time_constants_s, shares, sample_period_s: float) -> list:
    """First-order sections ``(b0, b1, 0, a1, 0)`` of displacement creep
    ``G(s) = 1 − Σ s_j + Σ s_j / (τ_j s + 1)`` under the bilinear transform.

    The parallel form is factored exactly into a cascade (the stage recursion
    runs cascaded sections only): with the modes' poles ``α_j`` sorted
    ascending, ``G(z) = K Π (z − ζ_j)/(z − α_j)`` where the zeros interlace
    the poles -- ``ζ_1`` in ``(−1, α_1)`` and ``ζ_j`` in ``(α_{j−1}, α_j)`` --
    because every share is positive, so each zero is found by bracketing
    (well conditioned even when the poles crowd near ``z = 1``).  Each section
    pairs a pole with the zero below it and has unit static gain, so ``G``
    has unit static gain exactly.

    Parameters
    ----------
    time_constants_s : sequence of float
        τ_j > 0, s.
    shares : sequence of float
        s_j >= 0, with ``Σ s_j < 1`` (the instantaneous part ``1 − Σ s_j`` is positive).
    sample_period_s : float

    Examples
    --------
    >>> sections = tustin_displacement_creep((0.01, 0.1), (0.05, 0.05), 1e-3)
    >>> len(sections), [round((b0 + b1) / (1 + a1), 12) for b0, b1, _, a1, _ in sections]
    (2, [1.0, 1.0])
    """
    T = float(sample_period_s)
    modes = {}
    for tau, share in zip(time_constants_s, shares):
        if share > 0:
            alpha, beta = tustin_creep_mode(float(tau), T)
            modes[alpha] = (modes.get(alpha, (0.0, beta))[0] + float(share), beta)   # equal τ: one mode
    if not modes:
        return []
    alphas = np.array(sorted(modes))
    weights = np.array([modes[a][0] * modes[a][1] for a in alphas])     # s_j β_j
    direct = 1.0 - float(sum(m[0] for m in modes.values()))

    def g(z):
        return direct + float(np.sum(weights * (z + 1.0) / (z - alphas)))

    sections = []
    for j, alpha in enumerate(alphas):
        # g falls from g(-1) = 1 - Σ s_j > 0 (or +inf just above the pole below) to -inf just below α_j
        a = -1.0 if j == 0 else float(np.nextafter(alphas[j - 1], alpha))
        b = float(np.nextafter(alpha, a))
        if g(a) > 0.0 > g(b):
            zero = scipy.optimize.brentq(g, a, b, xtol=1e-300, rtol=4 * np.finfo(float).eps, maxiter=500)
        else:
            zero = float(alpha)         # a share too small to move the zero off its pole: no section effect
        k = (1.0 - alpha) / (1.0 - zero)
        sections.append([float(k), float(-k * zero), 0.0, -float(alpha), 0.0])
    return sections


# ---------------------------------------------------------- running stages

class OutputStages:
    """Discrete output stages with their coefficient arrays (kept alive for C).

    Parameters
    ----------
    sections : array_like (n, 5)
        Second-order sections ``b0 b1 b2 a1 a2``.
    delay_samples : float
        Delay in samples (whole part and interpolated fraction), >= 0.
    creep_alpha, creep_beta, creep_weights : array_like
        Creep modes (see :func:`tustin_creep_mode`), weights in µm/V.
    drift : array_like
        ``p_1 .. p_n`` in µm/s^j.
    drift_span_s : float
        From this time on (s, > 0) the drift holds its value; 0: it runs on.
    """

    def __init__(self, sections=(), delay_samples: float = 0.0, creep_alpha=(), creep_beta=(),
                 creep_weights=(), drift=(), drift_span_s: float = 0.0):
        self.sections = _kernel.contiguous(np.reshape(sections, (-1, 5)))
        self.delay_samples = float(delay_samples)
        whole = math.floor(delay_samples)
        self.delay_whole = int(whole)
        self.delay_fraction = float(delay_samples - whole)
        self.creep_alpha = _kernel.contiguous(creep_alpha).ravel()
        self.creep_beta = _kernel.contiguous(creep_beta).ravel()
        self.creep_weights = _kernel.contiguous(creep_weights).ravel()
        self.drift = _kernel.contiguous(drift).ravel()
        self.drift_span_s = float(drift_span_s)
        if not (self.creep_alpha.size == self.creep_beta.size == self.creep_weights.size):
            raise ModelError("creep_alpha, creep_beta and creep_weights must have the same length")
        if not 0 <= self.delay_whole <= MAX_DELAY_SAMPLES:
            raise ModelError(f"delay must lie in [0, {MAX_DELAY_SAMPLES}] samples, got {delay_samples}")
        self._struct = OutputStagesStruct(
            self.sections.shape[0], _kernel.as_pointer(self.sections), self.delay_whole,
            self.delay_fraction, self.creep_alpha.size, _kernel.as_pointer(self.creep_alpha),
            _kernel.as_pointer(self.creep_beta), _kernel.as_pointer(self.creep_weights),
            self.drift.size, _kernel.as_pointer(self.drift), self.drift_span_s)
        status = _library().ostage_check(ctypes.byref(self._struct))
        if status != 0:
            raise ModelError("invalid output stages: " + _library().ostage_message(status).decode())

    @property
    def state_size(self) -> int:
        """Doubles of state (layout in output_stages.h)."""
        return int(_library().ostage_state_size(ctypes.byref(self._struct)))

    def rest_state(self, h0_um: float, u0_V: float) -> np.ndarray:
        """State with ``h0_um`` and ``u0_V`` held since forever."""
        state = np.zeros(self.state_size)
        _library().ostage_init(ctypes.byref(self._struct), float(h0_um), float(u0_V),
                               _kernel.as_pointer(state))
        return state

    def run(self, h_um, u_V=None, time_s=None, state=None):
        """Stage outputs for a record; ``state`` (carried in place) defaults to rest
        at the first sample.  Returns ``(y_um, state)``."""
        h = _kernel.contiguous(h_um).ravel()
        u = None if u_V is None else _kernel.contiguous(u_V).ravel()
        t = None if time_s is None else _kernel.contiguous(time_s).ravel()
        if self.creep_weights.size and (u is None or u.size != h.size):
            raise ModelError("creep stages need the input u for every sample")
        if self.drift.size and (t is None or t.size != h.size):
            raise ModelError("drift needs the time of every sample")
        if state is None:
            state = self.rest_state(h[0] if h.size else 0.0, u[0] if u is not None and u.size else 0.0)
        elif state.shape != (self.state_size,):
            raise ModelError(f"stage state must have {self.state_size} entries, got shape {state.shape}")
        y = np.empty_like(h)
        _library().ostage_run(ctypes.byref(self._struct), h.size, _kernel.as_pointer(h),
                              _kernel.as_pointer(u), _kernel.as_pointer(t), _kernel.as_pointer(state),
                              _kernel.as_pointer(y))
        return y, state

    def linear_part(self) -> "OutputStages":
        """The sections and the delay alone: the part a change of the hysteresis
        output passes through (the creep driven by the input and the drift do
        not depend on it).

        Examples
        --------
        >>> stages = OutputStages([first_order_section(0.01, 1e-3)], delay_samples=1.5,
        ...                       creep_alpha=[0.9], creep_beta=[0.05], creep_weights=[0.2])
        >>> part = stages.linear_part()
        >>> part.sections.shape, part.delay_samples, part.creep_weights.size
        ((1, 5), 1.5, 0)
        """
        return OutputStages(self.sections, self.delay_samples)

    def apply_to_columns(self, columns) -> np.ndarray:
        """Run every column of an (N, p) array through the stages on its own, each
        starting at rest at its first value.  For linear stages without creep or
        drift this is the design-matrix transform of :func:`pysim.identification.identify.identify`.

        Returns a column-major (Fortran-ordered) array; column-major input is
        processed without copies.
        """
        if self.creep_weights.size or self.drift.size:
            raise ModelError("only linear dynamics and delay act on design-matrix columns")
        columns = np.asfortranarray(columns, dtype=np.float64)
        out = np.empty_like(columns, order="F")
        lib, stages = _library(), ctypes.byref(self._struct)
        n, state_size = columns.shape[0], self.state_size
        for j in range(columns.shape[1]):
            column, target = columns[:, j], out[:, j]
            state = self.rest_state(column[0] if n else 0.0, 0.0) if state_size else np.zeros(0)
            lib.ostage_run(stages, n, _kernel.as_pointer(column), None, None, _kernel.as_pointer(state),
                           _kernel.as_pointer(target))
        return out


# ------------------------------------------------------------ the model

@dataclass
class ExtendedState:
    """State of an :class:`ExtendedModel` between two calls of ``simulate``.

    Attributes
    ----------
    operators : ndarray
        Operator outputs of the hysteresis part.
    stages : ndarray
        Output-stage state (layout in output_stages.h).
    samples : int
        Samples simulated so far (the drift's time is ``samples * sample_period_s``).
    """

    operators: np.ndarray
    stages: np.ndarray
    samples: int = 0


def _mode_problems(label: str, time_constants_s: tuple, values: tuple, values_label: str) -> list:
    """What is wrong with a set of modes: one value per time constant, each τ finite and > 0."""
    problems = []
    if len(time_constants_s) != len(values):
        problems.append(f"{len(time_constants_s)} {label} time constants but {len(values)} {values_label}")
    if not all(math.isfinite(x) and x > 0 for x in time_constants_s):
        problems.append(f"{label} time constants must be finite and > 0 s")
    return problems


@dataclass(frozen=True)
class StageSpec:
    """The output stages of an :class:`ExtendedModel` (see the module notes).

    Parameters
    ----------
    sample_period_s : float
        Sample period, s, of every discrete stage (and of the FMU's step).
        Needed (> 0) as soon as any stage is present.
    lag_time_constant_s : float
        τ of a first-order lag after the hysteresis, s (0: none).
    resonance_hz : float
        Natural frequency of a second-order stage after the hysteresis, Hz (0: none).
    damping_ratio : float
        ζ of that stage (> 0).
    delay_samples : float
        Pure delay in sample periods, >= 0 (a fraction interpolates linearly).
    creep_time_constants_s : tuple of float
        Creep mode time constants, s.
    creep_weights_um_per_V : tuple of float
        Creep mode weights, µm/V.
    displacement_creep_time_constants_s : tuple of float
        Time constants, s, of creep of the displacement itself (modes after the
        hysteresis, driven by its output rather than by the input).
    displacement_creep_shares : tuple of float
        Share (>= 0, summing to less than 1) of a settled displacement that each
        of those modes contributes: after a step the output jumps to
        ``1 − Σ shares`` of its new value and creeps the rest.
    drift_coefficients : tuple of float
        ``p_1, p_2, ...``: drift ``Σ p_j t^j`` in µm, t in s since the start.
    drift_span_s : float
        From this time on (s) the drift holds the value it has there: the span
        of the record it was identified on (0: the polynomial runs on).

    Examples
    --------
    >>> stages = StageSpec(sample_period_s=1e-3, lag_time_constant_s=0.01)
    >>> stages.present, round(stages.static_gain(), 12)
    (True, 1.0)
    """

    sample_period_s: float = 0.0
    lag_time_constant_s: float = 0.0
    resonance_hz: float = 0.0
    damping_ratio: float = 1.0
    delay_samples: float = 0.0
    creep_time_constants_s: tuple = ()
    creep_weights_um_per_V: tuple = ()
    drift_coefficients: tuple = ()
    displacement_creep_time_constants_s: tuple = ()
    displacement_creep_shares: tuple = ()
    drift_span_s: float = 0.0
    _runner: OutputStages = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        problems = []
        scalars = {"sample_period_s": self.sample_period_s, "lag_time_constant_s": self.lag_time_constant_s,
                   "resonance_hz": self.resonance_hz, "damping_ratio": self.damping_ratio,
                   "delay_samples": self.delay_samples, "drift_span_s": self.drift_span_s}
        for key, value in scalars.items():
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                problems.append(f"{key} must be a finite number >= 0, got {value!r}")
        taus = tuple(float(x) for x in self.creep_time_constants_s)
        weights = tuple(float(x) for x in self.creep_weights_um_per_V)
        drift = tuple(float(x) for x in self.drift_coefficients)
        problems += _mode_problems("creep", taus, weights, "creep weights")
        if not all(math.isfinite(x) for x in weights + drift):
            problems.append("creep weights and drift coefficients must be finite")
        d_taus = tuple(float(x) for x in self.displacement_creep_time_constants_s)
        shares = tuple(float(x) for x in self.displacement_creep_shares)
        problems += _mode_problems("displacement creep", d_taus, shares, "shares")
        if not (all(math.isfinite(x) and x >= 0 for x in shares) and sum(shares) < 1.0):
            problems.append(f"displacement creep shares must be >= 0 and sum to less than 1, got {shares}")
        if not problems:
            uses_period = (self.lag_time_constant_s > 0 or self.resonance_hz > 0 or self.delay_samples > 0
                           or taus or drift or d_taus)
            if uses_period and not self.sample_period_s > 0:
                problems.append("sample_period_s must be > 0 when a stage is present")
            if self.resonance_hz > 0 and not self.damping_ratio > 0:
                problems.append("damping_ratio must be > 0 for a resonance")
            if self.delay_samples > MAX_DELAY_SAMPLES:
                problems.append(f"delay_samples must be <= {MAX_DELAY_SAMPLES}")
        if problems:
            raise ModelError("invalid output stages: " + "; ".join(problems))
        for key in scalars:
            object.__setattr__(self, key, float(getattr(self, key)))
        object.__setattr__(self, "creep_time_constants_s", taus)
        object.__setattr__(self, "creep_weights_um_per_V", weights)
        object.__setattr__(self, "drift_coefficients", drift)
        object.__setattr__(self, "displacement_creep_time_constants_s", d_taus)
        object.__setattr__(self, "displacement_creep_shares", shares)
        p = self.coefficients()
        object.__setattr__(self, "_runner", OutputStages(p["sections"], self.delay_samples, p["creep_alpha"],
                                                         p["creep_beta"], weights, drift, self.drift_span_s))

    def coefficients(self) -> dict:
        """The discrete coefficients the C stages (and the plant FMU) use.

        Returns
        -------
        dict with ``sections`` (list of ``[b0, b1, b2, a1, a2]``), ``delay_whole``
        (int), ``delay_fraction``, ``creep_alpha``, ``creep_beta``,
        ``creep_weights``, ``drift`` (lists of float), ``drift_span_s`` and ``sample_period_s``.
        """
        T = self.sample_period_s
        sections = []
        if self.lag_time_constant_s > 0:
            sections.append(first_order_section(self.lag_time_constant_s, T).tolist())
        if self.resonance_hz > 0:
            sections.append(second_order_section(self.resonance_hz, self.damping_ratio, T).tolist())
        sections += tustin_displacement_creep(self.displacement_creep_time_constants_s,
                                              self.displacement_creep_shares, T)
        creep = [tustin_creep_mode(tau, T) for tau in self.creep_time_constants_s]
        whole = math.floor(self.delay_samples)
        return {
            "sections": sections,
            "delay_whole": int(whole),
            "delay_fraction": float(self.delay_samples - whole),
            "creep_alpha": [a for a, _ in creep],
            "creep_beta": [b for _, b in creep],
            "creep_weights": list(self.creep_weights_um_per_V),
            "drift": list(self.drift_coefficients),
            "drift_span_s": self.drift_span_s,
            "sample_period_s": T,
        }

    @property
    def runner(self) -> OutputStages:
        """The stages ready to run in C."""
        return self._runner

    @property
    def state_size(self) -> int:
        """Doubles of stage state (layout in output_stages.h)."""
        return self._runner.state_size

    @property
    def present(self) -> bool:
        """Whether any stage is present (else the plant is its hysteresis alone)."""
        return self._runner.state_size > 0 or bool(self.drift_coefficients)

    @property
    def delay_s(self) -> float:
        return self.delay_samples * self.sample_period_s

    def static_gain(self) -> float:
        """Static gain of the dynamics G (1 by construction of the sections)."""
        gain = 1.0
        for b0, b1, b2, a1, a2 in self.coefficients()["sections"]:
            gain *= (b0 + b1 + b2) / (1.0 + a1 + a2)
        return gain


@dataclass(frozen=True)
class ExtendedModel:
    """A plant made of parts: the MPI hysteresis model, then output stages.

    It has the interface of every model of the package --
    ``simulate(voltage_V, state=None, *, return_state=False)``, ``initial_state()``,
    ``name``, ``voltage_range_V`` -- with a state of its own
    (:class:`ExtendedState`).  Its parts stay visible: ``hysteresis`` is the
    rate-independent part, the only one an inverse compensator can invert
    (``InverseCompensator(plant.hysteresis)``; passing the composed plant is
    refused, so what is inverted is always explicit), ``stages`` the rest.

    Parameters
    ----------
    hysteresis : HysteresisModel
        The MPI/CPI model; it names the plant (``name``, ``description``).
    stages : StageSpec
        The output stages after it.

    Examples
    --------
    >>> import numpy as np
    >>> from pysim.core import HysteresisModel, eq13_thresholds
    >>> h = HysteresisModel(0.0, 0.5, tuple(eq13_thresholds(3, 150.0)), (0.0, 0.1, 0.1))
    >>> plant = ExtendedModel(h, StageSpec(sample_period_s=1e-3, lag_time_constant_s=5e-3))
    >>> y, state = plant.simulate(np.full(200, 100.0), return_state=True)
    >>> bool(abs(y[-1] - h.simulate([100.0])[0]) < 1e-9), state.samples
    (True, 200)
    """

    hysteresis: HysteresisModel
    stages: StageSpec = field(default_factory=StageSpec)

    def __post_init__(self):
        if not isinstance(self.hysteresis, HysteresisModel):
            raise ModelError(f"hysteresis must be a HysteresisModel, got {type(self.hysteresis).__name__}")
        if not isinstance(self.stages, StageSpec):
            raise ModelError(f"stages must be a StageSpec, got {type(self.stages).__name__}")

    # ------------------------------------------------ the model interface
    @property
    def name(self) -> str:
        return self.hysteresis.name

    @property
    def description(self) -> str:
        return self.hysteresis.description

    @property
    def voltage_range_V(self) -> tuple:
        return self.hysteresis.voltage_range_V

    @property
    def n_operators(self) -> int:
        return self.hysteresis.n_operators

    @property
    def sample_period_s(self) -> float:
        return self.stages.sample_period_s

    def with_parameters(self, **changes) -> "ExtendedModel":
        """A copy with fields of either part replaced: stage fields
        (``creep_weights_um_per_V``, ...) go to ``stages``, the others
        (``name``, ``a2``, ...) to ``hysteresis``."""
        stage_fields = {f.name for f in fields(StageSpec) if f.init}
        staged = {key: value for key, value in changes.items() if key in stage_fields}
        rest = {key: value for key, value in changes.items() if key not in stage_fields}
        return ExtendedModel(self.hysteresis.with_parameters(**rest) if rest else self.hysteresis,
                             replace(self.stages, **staged) if staged else self.stages)

    def major_loop_gain(self) -> float:
        """Static gain, µm/V: the hysteresis part's major-loop gain through the
        dynamics plus the creep modes' static contribution."""
        return self.hysteresis.major_loop_gain() * self.stages.static_gain() + sum(
            self.stages.creep_weights_um_per_V)

    def initial_state(self, voltage_V: float = None) -> ExtendedState:
        """Demagnetised operators, stages at rest at ``voltage_V`` (default: the
        bottom of the voltage range)."""
        h = self.hysteresis
        v0 = h.voltage_range_V[0] if voltage_V is None else float(voltage_V)
        operators = h.initial_state()
        h0 = h.simulate([v0], operators.copy())[0]
        return ExtendedState(operators, self.stages.runner.rest_state(h0, v0 - h.input_offset_V), 0)

    rest_state = initial_state

    # ------------------------------------------------------------ forward
    def simulate(self, voltage_V, state=None, *, return_state=False, return_operators=False,
                 threshold_scale=None):
        """Displacement (µm) for a voltage record (V) sampled at ``sample_period_s``.

        Parameters
        ----------
        voltage_V : array_like
            Input samples, one per sample period.
        state : ExtendedState, optional
            State after a previous call (default: demagnetised operators and
            output stages at rest at the first sample).
        return_state, return_operators, threshold_scale
            As in :meth:`pysim.core.model.HysteresisModel.simulate`; the state is an
            :class:`ExtendedState`.
        """
        v = _kernel.contiguous(voltage_V).ravel()
        if state is not None and not isinstance(state, ExtendedState):
            raise ModelError(f"the state of an extended model is an ExtendedState, got {type(state).__name__}")
        hysteresis, runner = self.hysteresis, self.stages.runner
        operators = hysteresis.initial_state() if state is None else state.operators
        h, operators, ops = hysteresis.simulate(v, operators, return_state=True, return_operators=True,
                                                threshold_scale=threshold_scale)
        u = v - hysteresis.input_offset_V
        samples = 0 if state is None else int(state.samples)
        if state is None:
            stage_state = runner.rest_state(h[0] if h.size else 0.0, u[0] if u.size else 0.0)
        else:
            stage_state = np.array(state.stages, dtype=float)
        time = (samples + np.arange(v.size, dtype=float)) * self.stages.sample_period_s
        y, stage_state = runner.run(h, u, time, stage_state)
        out = [y]
        if return_state:
            out.append(ExtendedState(operators, stage_state, samples + v.size))
        if return_operators:
            out.append(ops)
        return out[0] if len(out) == 1 else tuple(out)


def plant_parts(model):
    """``(hysteresis, stages)`` of any plant model: a :class:`HysteresisModel`
    is its own hysteresis with no stages (``stages`` None, as for an extended
    model whose stages are all absent)."""
    if isinstance(model, ExtendedModel):
        return model.hysteresis, (model.stages if model.stages.present else None)
    if isinstance(model, HysteresisModel):
        return model, None
    raise ModelError(f"not a plant model: {type(model).__name__}")
