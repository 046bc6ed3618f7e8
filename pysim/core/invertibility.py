"""Is a hysteresis model strictly increasing along every branch?

Along any branch the slope of the model is ``dy/dv = 3 a1 u² + a2 + Σ_{active} b_i``,
where the operators that follow the input are those whose band is narrower than
the distance ``d`` travelled since the last reversal: ``r_i < d`` for one-sided
play, ``2 r_i < d`` for classical play.  On an ascending branch that distance can
be anything in ``(0, u − u_lo]``, on a descending one anything in ``(0, u_hi − u]``.

So for each count ``k`` of active operators (taken in order of band width) the
slope is ``S_k + 3 a1 u²`` on an interval of ``u`` that is known exactly; the
minimum of that over the interval sits at an end of the ``u²`` range.  This
module enumerates those cases and reports every (branch, k) whose slope is not
strictly positive, with the voltage interval where it fails.  The same linear
conditions are the constraints of the identification (:mod:`pysim.identification.identify`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class BranchCase:
    """Slope ``S + 3 a1 u²`` holds on ``u ∈ [u_from, u_to]`` on one branch."""

    branch: str               # "ascending" or "descending"
    n_active: int             # operators that follow the input
    active: tuple             # their indices (model order)
    u_from: float             # shifted input, V
    u_to: float


@dataclass
class Invertibility:
    """Result of :func:`check_invertibility`."""

    invertible: bool
    min_slope_um_per_V: float
    worst_voltage_V: float
    worst_branch: str
    failures: list = field(default_factory=list)   # (branch, v_from, v_to, n_active)
    message: str = ""


def branch_cases(model, voltage_range_V=None) -> list:
    """All (branch, active set, input interval) cases of the model's slope."""
    lo, hi = model.voltage_range_V if voltage_range_V is None else voltage_range_V
    u_lo, u_hi = lo - model.input_offset_V, hi - model.input_offset_V
    span = u_hi - u_lo
    width = np.asarray(model.thresholds_V, dtype=float) * (2.0 if model.operator == "play" else 1.0)
    order = np.argsort(width, kind="stable")
    sorted_width = width[order]
    cases = []
    n = len(width)
    for k in range(n + 1):
        # k narrowest operators active: needs r_(k) < d <= r_(k+1) for some d in (0, span]
        lower = sorted_width[k - 1] if k > 0 else 0.0
        upper = sorted_width[k] if k < n else np.inf
        if upper <= lower or (k > 0 and lower >= span):
            continue
        active = tuple(int(i) for i in order[:k])
        cases.append(BranchCase("ascending", k, active, u_lo + lower, u_hi))
        cases.append(BranchCase("descending", k, active, u_lo, u_hi - lower))
    return cases


def square_range(u_from: float, u_to: float) -> tuple:
    """(min, max) of u² over [u_from, u_to]."""
    ends = (u_from * u_from, u_to * u_to)
    low = 0.0 if u_from <= 0.0 <= u_to else min(ends)
    return low, max(ends)


def _failing_intervals(S: float, a1: float, u_from: float, u_to: float) -> list:
    """Sub-intervals of [u_from, u_to] where S + 3 a1 u² <= 0 (none, one or two)."""
    if a1 == 0.0:
        return [(u_from, u_to)] if S <= 0 else []
    limit = -S / (3.0 * a1)           # slope <= 0  <=>  u² >= limit (a1 < 0) or u² <= limit (a1 > 0)
    if a1 < 0:
        if limit <= 0:
            return [(u_from, u_to)]
        c = np.sqrt(limit)
        # |u| >= c: the parts of the interval below -c and above +c
        parts = []
        if u_from <= -c:
            parts.append((u_from, min(u_to, -c)))
        if u_to >= c:
            parts.append((max(u_from, c), u_to))
        return parts
    if limit < 0:
        return []
    c = np.sqrt(limit)
    start, stop = max(u_from, -c), min(u_to, c)
    return [(start, stop)] if start <= stop else []


def check_invertibility(model, voltage_range_V=None, min_slope_um_per_V: float = 0.0) -> Invertibility:
    """Check that ``model`` is strictly increasing along every branch.

    Parameters
    ----------
    model : HysteresisModel
    voltage_range_V : (float, float), optional
        Range to check (default: the model's own).
    min_slope_um_per_V : float
        Slope that counts as "increasing enough" (default 0: strictly positive).

    Returns
    -------
    Invertibility
        ``failures`` lists ``(branch, v_from, v_to, n_active)`` for every case
        whose slope drops to ``min_slope`` or below; ``message`` says in words
        the lowest voltage where the model stops being invertible.
    """
    b = np.asarray(model.weights_um_per_V, dtype=float)
    a1, a2 = model.a1, model.a2
    offset = model.input_offset_V
    worst = (np.inf, np.nan, "")
    failures = []
    for case in branch_cases(model, voltage_range_V):
        S = a2 + float(np.sum(b[list(case.active)])) - min_slope_um_per_V
        t_low, t_high = square_range(case.u_from, case.u_to)
        t_worst = t_high if a1 < 0 else t_low
        slope = S + 3.0 * a1 * t_worst + min_slope_um_per_V
        if slope < worst[0]:
            u_worst = np.sqrt(t_worst)
            if not (case.u_from <= u_worst <= case.u_to):
                u_worst = -u_worst
            worst = (slope, u_worst + offset, case.branch)
        for bad in _failing_intervals(S, a1, case.u_from, case.u_to):
            failures.append((case.branch, bad[0] + offset, bad[1] + offset, case.n_active))
    invertible = not failures
    if min_slope_um_per_V == 0.0:
        # The verdict is the C kernel's, which decides the sign of every slope
        # exactly (error-free sums and products): rounded arithmetic here can
        # err within 1e-16 of the boundary, and the FMUs decide with the C.
        exact = _exact_verdict(model, voltage_range_V)
        if exact is not None and exact.invertible != invertible:
            invertible = bool(exact.invertible)
            failures = [] if invertible else [
                ("descending" if exact.descending else "ascending", exact.worst_voltage, exact.worst_voltage,
                 int(exact.n_active))]
    if invertible:
        message = (f"invertible over {_range_text(model, voltage_range_V)}: smallest slope "
                   f"{worst[0]:.6g} µm/V ({worst[2]} branch, {worst[1]:.6g} V)")
    else:
        first = min(failures, key=lambda f: f[1])
        message = (f"not invertible over {_range_text(model, voltage_range_V)}: on the {first[0]} branch "
                   f"with {first[3]} operator(s) following the input the slope is <= "
                   f"{min_slope_um_per_V:g} µm/V from {first[1]:.6g} V to {first[2]:.6g} V "
                   f"(smallest slope {worst[0]:.6g} µm/V at {worst[1]:.6g} V)")
    return Invertibility(invertible, float(worst[0]), float(worst[1]), worst[2], failures, message)


def _exact_verdict(model, voltage_range_V):
    """``MpiInvertibility`` of the C kernel (exact sign decisions), or None
    for a model the kernel cannot take (no ``_c_model``)."""
    import ctypes

    from pysim.core import kernel

    if not hasattr(model, "_c_model"):
        return None
    lo, hi = model.voltage_range_V if voltage_range_V is None else voltage_range_V
    c_model = model._c_model()
    work = np.zeros(2 * model.n_operators + 10)
    out = kernel.MpiInvertibility()
    kernel.library().mpi_invertibility(ctypes.byref(c_model), float(lo), float(hi), kernel.as_pointer(work),
                                       ctypes.byref(out))
    return out


def _range_text(model, voltage_range_V) -> str:
    lo, hi = model.voltage_range_V if voltage_range_V is None else voltage_range_V
    return f"{lo:g} V to {hi:g} V"
