"""Identification of MPI/CPI models from measured voltage and displacement.

With the thresholds fixed (eq. 13), the model output is linear in the
parameters ``θ = (a1, a2, b_1 … b_n, offset)``::

    y_k = a1 u_k³ + a2 u_k + Σ_i b_i F_{r_i}[u]_k + offset

so the least-squares fit is a linear least-squares problem.  Keeping the
identified model invertible adds linear inequality constraints (the slope along
every branch stays above a margin; see :mod:`pysim.core.invertibility`), which makes
it a least-squares problem with linear inequality constraints (LSI).  It is
solved exactly with the Lawson-Hanson reduction LSI → least-distance
programming → non-negative least squares (``scipy.optimize.nnls``): a finite
active-set method that ends at the global optimum, unlike the particle swarm
of the paper.

An operator with ``r = 0`` equals its input (``F_0[u] = u``), so its weight
cannot be told apart from ``a2``: its column is left out and ``b = 0`` is
reported for it, the sum living in ``a2``.

The first samples of a record depend on the actuator's unknown history.  Once
the input has visited both ends of its range every operator's state is fixed
by the data (wiping-out property), so by default the fit starts there
(``warmup="auto"``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.linalg import LinAlgError
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import nnls

from pysim.core.invertibility import branch_cases, square_range
from pysim.core.metrics import error_measures
from pysim.core.model import HysteresisModel, eq13_thresholds
from pysim.identification.errors import IdentificationError


@dataclass
class IdentificationResult:
    """Outcome of :func:`identify`.

    Attributes
    ----------
    model : HysteresisModel
        The identified model (physical units).
    warmup_samples : int
        Samples at the start left out of the fit.
    fit_slice : slice
        Samples the fit used (after the warm-up).
    prediction_um : ndarray
        Model output over the whole record, from the demagnetised state.
    errors : dict
        ``max_error_pct``, ``rms_error_pct``, ``mean_error_pct`` on the fit samples.
    constraints_active : bool
        Whether the invertibility constraints changed the unconstrained optimum.
    extra_coefficients : dict
        Coefficients of the extra regressors passed to :func:`identify`.
    """

    model: HysteresisModel
    warmup_samples: int
    fit_slice: slice
    prediction_um: np.ndarray
    errors: dict
    constraints_active: bool
    extra_coefficients: dict = field(default_factory=dict)
    objective: float = float("nan")

    def parameters(self) -> dict:
        """The model's parameters as plain numbers (for JSON)."""
        m = self.model
        return {
            "a1_um_per_V3": m.a1, "a2_um_per_V": m.a2,
            "thresholds_V": list(m.thresholds_V), "weights_um_per_V": list(m.weights_um_per_V),
            "operator": m.operator, "input_offset_V": m.input_offset_V,
            "output_offset_um": m.output_offset_um, "voltage_range_V": list(m.voltage_range_V),
            **{f"extra_{k}": v for k, v in self.extra_coefficients.items()},
        }


def auto_warmup(voltage_V, widest_band_V: float = None) -> int:
    """First sample by which the input has been at both ends of its range.

    An operator whose band (``r`` for one-sided, ``2 r`` for classical play) is
    narrower than ``span - 2 tol`` has forgotten everything before the input
    came within ``tol`` of both ends.  With the widest band given, ``tol`` is
    chosen just inside that limit, so from the returned sample on the model's
    output no longer depends on the history before the record; without it the
    ends must be reached to 0.5 % of the span.
    """
    v = np.asarray(voltage_V, dtype=float)
    lo, hi = float(v.min()), float(v.max())
    span = hi - lo
    tol = 0.005 * span if widest_band_V is None else 0.45 * max(span - widest_band_V, 0.0)
    first_low = int(np.argmax(v <= lo + tol))
    first_high = int(np.argmax(v >= hi - tol))
    return max(first_low, first_high)


def regressors(voltage_V, thresholds_V, operator: str, input_offset_V: float, cubic: bool):
    """Design matrix of the linear-in-parameters model.

    Returns
    -------
    columns : ndarray (N, p)
        ``[u³ (if cubic), u, F_{r_i}[u] for r_i > 0 ..., 1]``.
    operator_columns : list of int
        Index of each operator's column, or -1 for r = 0 operators (merged into a2).
    """
    r = np.asarray(thresholds_V, dtype=float)
    # only the operator outputs are used: zero weights; simulate ignores the voltage range
    probe = HysteresisModel(0.0, 0.0, tuple(r), tuple(np.zeros_like(r)), operator=operator,
                            input_offset_V=input_offset_V, name="probe")
    _, operators = probe.simulate(voltage_V, return_operators=True)
    u = np.asarray(voltage_V, dtype=float) - input_offset_V
    cols = ([u**3] if cubic else []) + [u]
    operator_columns = []
    for i, threshold in enumerate(r):
        if threshold == 0.0:
            operator_columns.append(-1)
        else:
            operator_columns.append(len(cols))
            cols.append(operators[:, i])
    cols.append(np.ones_like(u))
    return np.column_stack(cols), operator_columns


def _invertibility_rows(template: HysteresisModel, n_columns: int, cubic: bool,
                        operator_columns, margin: float):
    """Rows G, h with G θ >= h  <=>  slope >= margin on every branch case."""
    a2_col = 1 if cubic else 0
    rows, rhs = [], []
    for case in branch_cases(template):
        base = np.zeros(n_columns)
        base[a2_col] = 1.0
        for i in case.active:
            if operator_columns[i] >= 0:
                base[operator_columns[i]] = 1.0
        t_values = square_range(case.u_from, case.u_to) if cubic else (0.0,)
        for t in set(t_values):
            row = base.copy()
            if cubic:
                row[0] = 3.0 * t
            rows.append(row)
            rhs.append(margin)
    return np.array(rows), np.array(rhs)


def _triangular_factor(A, y):
    """R (p×p, upper) and c = Qᵀy with A = QR, by CholeskyQR2.

    Two Cholesky passes over the Gram matrix are as accurate as Householder QR
    for the well-scaled, moderately conditioned regressors here, and several
    times faster on long records (a Gram matrix is one BLAS call; Householder
    on a tall matrix is memory bound).  Falls back to Householder QR when the
    Gram matrix is too ill-conditioned for Cholesky.
    """
    try:
        R1 = cholesky(A.T @ A, lower=False)
        Q1 = solve_triangular(R1, A.T, trans="T", lower=False).T
        R2 = cholesky(Q1.T @ Q1, lower=False)
        c = solve_triangular(R2, Q1.T @ y, trans="T", lower=False)
        return R2 @ R1, c
    except LinAlgError:
        Q, R = np.linalg.qr(A)
        return R, Q.T @ y


def solve_lsi(A, y, G, h):
    """min ||A θ − y||  subject to  G θ >= h  (Lawson-Hanson, exact).

    Returns (θ, constraints_active).  Raises IdentificationError if the
    constraints cannot all hold.
    """
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    R, c = _triangular_factor(A / scale, y)
    diagonal = np.abs(np.diag(R))
    if np.min(diagonal) <= 1e-10 * np.max(diagonal):
        raise IdentificationError(
            "the regressors are linearly dependent: the input does not excite every operator "
            "(too few distinct input levels or thresholds beyond the input range)")
    theta_s = solve_triangular(R, c, lower=False)
    Gs = G / scale
    if G.size == 0 or np.all(Gs @ theta_s >= h - 1e-12 * np.maximum(1.0, np.abs(h))):
        return theta_s / scale, False
    # LSI -> LDP: z = R θ - c, constraint (G R^-1) z >= h - G R^-1 c
    E = solve_triangular(R, Gs.T, trans="T", lower=False).T
    f = h - E @ c
    p = E.shape[1]
    M = np.vstack([E.T, f[None, :]])
    target = np.zeros(p + 1)
    target[-1] = 1.0
    x, _ = nnls(M, target, maxiter=50 * M.shape[1])
    residual = M @ x - target
    if abs(residual[-1]) < 1e-12:
        raise IdentificationError("no invertible model satisfies the slope constraints")
    z = -residual[:p] / residual[-1]
    theta_s = solve_triangular(R, z + c, lower=False)
    return theta_s / scale, True


def identify(voltage_V, displacement_um, *, n_operators: int = 10, model: str = "mpi",
             operator: str = "osp", thresholds_V=None, warmup="auto", fit_slice: slice = None,
             min_slope_fraction: float = 0.01, extra_regressors: dict = None,
             column_transform=None, name: str = None, description: str = "") -> IdentificationResult:
    """Fit an MPI or CPI model to a measured record.

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record (same length).
    n_operators : int
        Number of operators n (thresholds from eq. 13 unless given).
    model : {"mpi", "cpi"}
        CPI forces a1 = 0.
    operator : {"osp", "play"}
        Operator kind.  The input is shifted to the bottom of the record's range
        (``input_offset_V``) for both kinds.
    thresholds_V : array_like, optional
        Thresholds r_i (V, of the shifted input) instead of eq. 13.
    warmup : "auto" or int
        Samples left out at the start (see :func:`auto_warmup`).
    fit_slice : slice, optional
        Fit only on these samples (e.g. a training part); the warm-up still applies.
    min_slope_fraction : float
        Invertibility margin: the slope along every branch stays above this
        fraction of the record's mean gain (displacement span / voltage span).
        Use a negative value to fit without the constraints.
    extra_regressors : dict of name -> array, optional
        Further columns that enter linearly (e.g. creep modes); their fitted
        coefficients come back in ``extra_coefficients``.
    column_transform : callable, optional
        Linear map applied to every column of the hysteresis model's design
        matrix (an (N, p) array in, the same shape out), for models whose output
        passes through a linear stage (dynamics, delay); ``prediction_um`` is
        then that model's output.  The invertibility constraints still apply
        to the hysteresis parameters.
    name, description : str
        Stored in the model.
    """
    if model not in ("mpi", "cpi"):
        raise IdentificationError(f"model must be 'mpi' or 'cpi', got {model!r}")
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    if v.shape != y.shape:
        raise IdentificationError(f"{v.size} voltage samples but {y.size} displacement samples")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise IdentificationError("the record holds NaN or infinite values")
    lo, hi = float(v.min()), float(v.max())
    if not hi > lo:
        raise IdentificationError("the voltage is constant: nothing to identify")
    # u = v - lo for both kinds: the cubic a1 u^3 about the bottom of the range
    # is what makes loops asymmetric (about the centre it would be odd-symmetric)
    input_offset = lo
    r = (eq13_thresholds(n_operators, hi - lo, operator) if thresholds_V is None
         else np.asarray(thresholds_V, dtype=float))
    cubic = model == "mpi"
    A, operator_columns = regressors(v, r, operator, input_offset, cubic)
    if column_transform is not None:
        A = np.asarray(column_transform(A), dtype=float)
    extras = dict(extra_regressors or {})
    for key, column in extras.items():
        column = np.asarray(column, dtype=float).ravel()
        if column.shape != v.shape:
            raise IdentificationError(f"extra regressor {key!r} has {column.size} samples, not {v.size}")
        A = np.column_stack([A, column])
    n_base = A.shape[1] - len(extras)

    widest = float(np.max(r, initial=0.0)) * (2.0 if operator == "play" else 1.0)
    start = auto_warmup(v, widest) if warmup == "auto" else int(warmup)
    window = fit_slice or slice(0, v.size)
    first, stop, _ = window.indices(v.size)
    first = max(first, start)
    n_params = A.shape[1]
    if stop - first < n_params + 1:
        raise IdentificationError(
            f"{stop - first} samples to fit (after a warm-up of {start}) but the model has {n_params} "
            f"parameters: need at least {n_params + 1}")

    template = HysteresisModel(0.0, 1.0, tuple(r), tuple(np.zeros_like(r)), operator=operator,
                               input_offset_V=input_offset, voltage_range_V=(lo, hi), name="template")
    mean_gain = float(np.ptp(y[first:stop])) / (hi - lo)
    if min_slope_fraction >= 0:
        G, h = _invertibility_rows(template, n_params, cubic, operator_columns,
                                   min_slope_fraction * mean_gain)
    else:
        G, h = np.zeros((0, n_params)), np.zeros(0)
    theta, active = solve_lsi(A[first:stop], y[first:stop], G, h)

    a1 = float(theta[0]) if cubic else 0.0
    a2 = float(theta[1 if cubic else 0])
    weights = np.array([theta[c] if c >= 0 else 0.0 for c in operator_columns])
    offset = float(theta[n_base - 1])
    identified = HysteresisModel(
        a1=a1, a2=a2, thresholds_V=tuple(r), weights_um_per_V=tuple(weights), operator=operator,
        input_offset_V=input_offset, output_offset_um=offset, voltage_range_V=(lo, hi),
        name=name or f"identified_{model}", description=description)
    extra_coefficients = {key: float(theta[n_base + j]) for j, key in enumerate(extras)}
    prediction = A @ theta
    residual = y[first:stop] - prediction[first:stop]
    result = IdentificationResult(
        model=identified, warmup_samples=start, fit_slice=slice(first, stop),
        prediction_um=prediction, errors=error_measures(y[first:stop], prediction[first:stop]),
        constraints_active=active, extra_coefficients=extra_coefficients,
        objective=float(residual @ residual))
    return result
