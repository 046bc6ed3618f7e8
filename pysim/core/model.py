"""The (modified) Prandtl-Ishlinskii hysteresis model and its inverses.

A :class:`HysteresisModel` is the model *spec*: everything the FMU builder needs
and everything the Python simulation needs.  The model is (Gu, Zhu, Su 2014,
eq. 7, with an input shift and an output offset)::

    u = v - input_offset_V
    y = a1 u^3 + a2 u + sum_i b_i F_{r_i}[u] + output_offset_um

with one-sided play operators (``operator="osp"``, eq. 3-4) or classical play
operators (``operator="play"``, eq. 1-2).  CPI is the case ``a1 = 0``.

Units: voltage in V, displacement in µm, thresholds in V, ``a1`` in µm/V³,
``a2`` and the weights in µm/V.

The sample-by-sample recursion runs in the C kernel shared with the FMUs
(``fmu_src/hysteresis.c``); this module prepares arrays and carries state.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass, field, replace

import numpy as np

from pysim.core import kernel as _kernel
from pysim.core.errors import ModelError, NotInvertibleError

OPERATOR_KINDS = {"osp": 0, "play": 1}


@dataclass(frozen=True)
class HysteresisModel:
    """MPI/CPI hysteresis model of a piezo actuator (the model spec).

    Parameters
    ----------
    a1 : float
        Cubic coefficient of the input function, µm/V³ (0 gives the CPI model).
    a2 : float
        Linear coefficient of the input function, µm/V.
    thresholds_V : sequence of float
        Operator thresholds r_i ≥ 0, V (ascending).
    weights_um_per_V : sequence of float
        Operator weights b_i, µm/V.
    operator : {"osp", "play"}
        One-sided play (paper) or classical play operators.
    input_offset_V : float
        Voltage subtracted from the input before the model (u = v − offset).
    output_offset_um : float
        Displacement added to the output (sensor offset).
    voltage_range_V : (float, float)
        Range of voltages the model is valid for (and the inverse may command).
    name : str
        Identifier (used as the FMU model name).
    description : str
        Free text: where the numbers come from.
    """

    a1: float
    a2: float
    thresholds_V: tuple
    weights_um_per_V: tuple
    operator: str = "osp"
    input_offset_V: float = 0.0
    output_offset_um: float = 0.0
    voltage_range_V: tuple = (0.0, 150.0)
    name: str = "mpi"
    description: str = ""
    _arrays: dict = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        r = np.asarray(self.thresholds_V, dtype=float).ravel()
        b = np.asarray(self.weights_um_per_V, dtype=float).ravel()
        problems = []
        if self.operator not in OPERATOR_KINDS:
            problems.append(f"operator must be one of {sorted(OPERATOR_KINDS)}, got {self.operator!r}")
        if r.shape != b.shape:
            problems.append(f"{r.size} thresholds but {b.size} weights")
        values = {"a1": self.a1, "a2": self.a2, "input_offset_V": self.input_offset_V,
                  "output_offset_um": self.output_offset_um}
        for key, value in values.items():
            if not np.isfinite(value):
                problems.append(f"{key} is not finite ({value})")
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(b))):
            problems.append("thresholds and weights must be finite")
        if np.any(r < 0):
            problems.append(f"thresholds must be >= 0 V, got {r[r < 0][0]}")
        if r.size > 1 and np.any(np.diff(r) < 0):
            problems.append("thresholds must be in ascending order")
        lo, hi = (float(x) for x in self.voltage_range_V)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            problems.append(f"voltage_range_V must be finite with low < high, got {self.voltage_range_V}")
        if not self.name.isidentifier():
            problems.append(f"name must be a C identifier, got {self.name!r}")
        if problems:
            raise ModelError("invalid hysteresis model: " + "; ".join(problems))
        object.__setattr__(self, "thresholds_V", tuple(float(x) for x in r))
        object.__setattr__(self, "weights_um_per_V", tuple(float(x) for x in b))
        object.__setattr__(self, "voltage_range_V", (lo, hi))
        object.__setattr__(self, "a1", float(self.a1))
        object.__setattr__(self, "a2", float(self.a2))
        object.__setattr__(self, "input_offset_V", float(self.input_offset_V))
        object.__setattr__(self, "output_offset_um", float(self.output_offset_um))
        object.__setattr__(self, "_arrays", {"r": _kernel.contiguous(r), "b": _kernel.contiguous(b)})

    # ------------------------------------------------------------------ basics
    @property
    def n_operators(self) -> int:
        return len(self.thresholds_V)

    @property
    def kind(self) -> str:
        """``"mpi"`` or ``"cpi"`` (a1 == 0)."""
        return "cpi" if self.a1 == 0.0 else "mpi"

    @property
    def thresholds(self) -> np.ndarray:
        return self._arrays["r"].copy()

    @property
    def weights(self) -> np.ndarray:
        return self._arrays["b"].copy()

    def with_parameters(self, **changes) -> "HysteresisModel":
        """A copy with some fields replaced."""
        return replace(self, **changes)

    def initial_state(self) -> np.ndarray:
        """Demagnetised operator state (all zero), as in the paper."""
        return np.zeros(self.n_operators)

    def _c_model(self) -> _kernel.HystModel:
        return _kernel.HystModel(
            OPERATOR_KINDS[self.operator], self.n_operators, self.a1, self.a2,
            self.input_offset_V, self.output_offset_um,
            _kernel.as_pointer(self._arrays["r"]), _kernel.as_pointer(self._arrays["b"]))

    def _state(self, state) -> np.ndarray:
        if state is None:
            return self.initial_state()
        state = np.array(state, dtype=np.float64)
        if state.shape != (self.n_operators,):
            raise ModelError(f"operator state must have {self.n_operators} entries, got shape {state.shape}")
        return state

    # ----------------------------------------------------------------- forward
    def simulate(self, voltage_V, state=None, *, return_state=False, return_operators=False,
                 threshold_scale=None):
        """Displacement (µm) for a voltage record (V).

        Parameters
        ----------
        voltage_V : array_like
            Input samples.  The model is rate independent: only the order of the
            samples matters.
        state : array_like, optional
            Operator state before the first sample (default: all zero).
        return_state : bool
            Also return the operator state after the last sample; feeding it to
            the next call continues the record exactly.
        return_operators : bool
            Also return the operator outputs, shape (len(voltage), n_operators).
        threshold_scale : array_like, optional
            One factor (>= 0) per sample that multiplies every threshold at that sample
            (thresholds that change with time: :mod:`pysim.core.input_stage`'s
            ``rate_thresholds``).  Default: the thresholds as they are.

        Returns
        -------
        displacement_um : ndarray, and the extras asked for, in that order.

        Examples
        --------
        >>> h = HysteresisModel(0.0, 0.0, (0.0, 1.0), (0.0, 1.0), voltage_range_V=(0.0, 10.0))
        >>> h.simulate([0.0, 4.0, 8.0]).tolist(), h.simulate([0.0, 4.0, 8.0], threshold_scale=[1, 2, 3]).tolist()
        ([0.0, 3.0, 7.0], [0.0, 2.0, 5.0])
        """
        v = _kernel.contiguous(voltage_V).ravel()
        w = self._state(state)
        y = np.empty_like(v)
        ops = np.empty((v.size, self.n_operators)) if return_operators else None
        model = self._c_model()
        scale = None if threshold_scale is None else _kernel.contiguous(threshold_scale).ravel()
        if scale is not None and (scale.shape != v.shape or not np.all(scale >= 0.0)):
            raise ModelError(f"threshold_scale needs one factor >= 0 per sample ({v.size}), "
                             f"got {scale.size} (smallest {float(scale.min()) if scale.size else 'none'})")
        # (no scale: NULL, the thresholds as they are -- the same loop and bits as hyst_simulate)
        _kernel.library().hyst_simulate_scaled(ctypes.byref(model), v.size, _kernel.as_pointer(v),
                                               _kernel.as_pointer(scale), _kernel.as_pointer(w),
                                               _kernel.as_pointer(y), _kernel.as_pointer(ops))
        out = [y]
        if return_state:
            out.append(w)
        if return_operators:
            out.append(ops)
        return out[0] if len(out) == 1 else tuple(out)

    def major_loop_gain(self) -> float:
        """Nominal gain, µm/V: displacement span over voltage span of the first
        loading curve across the voltage range (used for uncompensated drive)."""
        lo, hi = self.voltage_range_V
        y = self.simulate(np.linspace(lo, hi, 2))
        return float((y[-1] - y[0]) / (hi - lo))

    def check_invertibility(self, voltage_range_V=None):
        """See :func:`pysim.core.invertibility.check_invertibility`."""
        from pysim.core.invertibility import check_invertibility

        return check_invertibility(self, voltage_range_V)


def eq13_thresholds(n_operators: int, input_span_V: float, operator: str = "osp") -> np.ndarray:
    """Thresholds of eq. 13, ``r_i = (i-1)/n * span`` (V).

    For classical play operators the band is ``2 r`` wide, so the span is halved
    to cover the same input excursions.
    """
    if n_operators < 1:
        raise ModelError(f"need at least one operator, got {n_operators}")
    span = float(input_span_V) / (2.0 if operator == "play" else 1.0)
    return np.arange(n_operators) / n_operators * span


def analytic_inverse(model: HysteresisModel) -> HysteresisModel:
    """The paper's analytic inverse (eq. 11-12) of the linear-plus-operators part.

    For a CPI model (a1 = 0) the returned model maps displacement (µm) to voltage
    (V) exactly when both start from the demagnetised state at the bottom of the
    range.  For MPI it is the ``P^-1`` block of Fig. 7, fed with
    ``y_d - a1 u^3 - output_offset``.

    Returns
    -------
    HysteresisModel with a1 = 0, a2 = 1/a2, thresholds r̂_j (µm), weights b̂_j.
    """
    r, b, a2 = model.thresholds, model.weights, model.a2
    cumulative = a2 + np.concatenate(([0.0], np.cumsum(b)))  # a2 + sum_{i<j} b_i, j = 1..n+1
    if np.any(cumulative <= 0):
        raise NotInvertibleError("a2 + sum of weights must stay positive for the analytic inverse")
    r_hat = np.array([a2 * r[j] + np.sum(b[:j] * (r[j] - r[:j])) for j in range(len(r))])
    b_hat = -b / (cumulative[:-1] * cumulative[1:])
    lo, hi = model.voltage_range_V
    return HysteresisModel(
        a1=0.0, a2=1.0 / a2, thresholds_V=tuple(r_hat), weights_um_per_V=tuple(b_hat),
        operator=model.operator, input_offset_V=model.output_offset_um,
        output_offset_um=model.input_offset_V, voltage_range_V=(-1e300, 1e300),
        name=f"{model.name}_inverse", description="analytic inverse (eq. 11-12)")


class InverseCompensator:
    """Feed-forward compensator: desired displacement (µm) → voltage (V).

    Parameters
    ----------
    model : HysteresisModel
        The plant model to invert; refused (:class:`NotInvertibleError`) unless
        strictly increasing along every branch over its voltage range.
    method : {"exact", "previous_sample"}
        ``"exact"`` solves ``a1 u³ + P[u] = y_d`` at every sample to machine
        precision; ``"previous_sample"`` is the paper's Fig. 7 loop with the
        cubic term taken from the previous output sample (OSP/play models).

    Notes
    -----
    Targets that the voltage range cannot reach saturate at the range ends;
    :attr:`saturated_samples` counts them.
    """

    def __init__(self, model: HysteresisModel, method: str = "exact"):
        if not isinstance(model, HysteresisModel):
            parts = " (its hysteresis part is .hysteresis)" if hasattr(model, "hysteresis") else ""
            raise ModelError(f"an inverse compensator inverts a HysteresisModel, got {type(model).__name__}"
                             f"{parts}: the output stages of an extended plant (dynamics, delay, creep, "
                             "drift) have no rate-independent inverse, so say explicitly what to invert, "
                             "e.g. InverseCompensator(plant.hysteresis)")
        if method not in ("exact", "previous_sample"):
            raise ModelError(f"method must be 'exact' or 'previous_sample', got {method!r}")
        report = model.check_invertibility()
        if not report.invertible:
            raise NotInvertibleError(report.message)
        self.model = model
        self.method = method
        # The C loop removes the offsets itself, so its P^-1 block works on
        # unshifted w -> u.
        self._pinv = (analytic_inverse(model).with_parameters(input_offset_V=0.0, output_offset_um=0.0)
                      if method == "previous_sample" else None)
        self.saturated_samples = 0
        self.reset()

    def reset(self, state=None):
        """Start again from an operator state (default: demagnetised)."""
        self.state = self.model._state(state)
        if self._pinv is not None:
            # The inverse operators see w = y - offset - a1 u^3; demagnetised
            # forward state at u = 0 corresponds to demagnetised inverse state.
            self._inverse_state = np.zeros(self.model.n_operators)
            self._u_prev = ctypes.c_double(0.0)
        self.saturated_samples = 0

    def __call__(self, displacement_um) -> np.ndarray:
        y = _kernel.contiguous(displacement_um).ravel()
        v = np.empty_like(y)
        lo, hi = self.model.voltage_range_V
        lib = _kernel.library()
        if self.method == "exact":
            model = self.model._c_model()
            self.saturated_samples += lib.hyst_invert_run(
                ctypes.byref(model), y.size, _kernel.as_pointer(y), _kernel.as_pointer(self.state),
                lo, hi, _kernel.as_pointer(v))
        else:
            pinv = self._pinv._c_model()
            lib.hyst_invert_previous_sample_run(
                ctypes.byref(pinv), self.model.a1, self.model.input_offset_V,
                self.model.output_offset_um, y.size, _kernel.as_pointer(y),
                _kernel.as_pointer(self._inverse_state), ctypes.byref(self._u_prev), lo, hi,
                _kernel.as_pointer(v))
            # keep the forward operator state in step with the commanded voltage
            _, self.state = self.model.simulate(v, self.state, return_state=True)
        return v


def invert(model: HysteresisModel, displacement_um, method: str = "exact") -> np.ndarray:
    """Voltage (V) that makes ``model`` follow ``displacement_um`` from the
    demagnetised state (see :class:`InverseCompensator`)."""
    return InverseCompensator(model, method)(displacement_um)
