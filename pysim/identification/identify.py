"""Identification of MPI/CPI models from measured voltage and displacement.

With the thresholds fixed (eq. 13, over the range of the samples fitted) and
the operator state at the start of the record fixed, the model output is
linear in the parameters ``θ = (a1, a2, b_1 … b_n, offset)``::

    y_k = a1 u_k³ + a2 u_k + Σ_i b_i F_{r_i}[u; s_i]_k + offset

so the least-squares fit is a linear least-squares problem.  Keeping the
identified model invertible adds linear inequality constraints (the slope along
every branch stays above a margin; see :mod:`pysim.core.invertibility`), which makes
it a least-squares problem with linear inequality constraints (LSI).  It is
solved exactly with the Lawson-Hanson reduction LSI → least-distance
programming → non-negative least squares (``scipy.optimize.nnls``): a finite
active-set method that ends at the global optimum, unlike the particle swarm
of the paper.

**The unknown initial state.**  A record does not start from the demagnetised
state: the actuator had a history.  Every operator's state before the first
sample is a number ``s_i`` in its admissible band (``u_0 − r_i ≤ s_i ≤ u_0``
for one-sided play, ``u_0 − r_i ≤ s_i ≤ u_0 + r_i`` for classical play).  An
operator's output is a composition of clamps of that number, so at every sample
it is ``clamp(s_i, L_ik, U_ik)``, where ``L`` and ``U`` are the outputs started
from the lowest and the highest admissible state (they meet once the input has
wiped the initial state out).  By default (``warmup="auto"``) the states are
estimated with the weights, by alternating exact steps: the LSI fit of the
weights for fixed states, then for each operator the exact minimiser of the
piecewise-quadratic error over its state for fixed weights (a sweep over the
sorted breakpoints ``L_ik``, ``U_ik``).  Every step lowers the error, and the
best of three starts (demagnetised, lowest and highest states) is kept.  So
every sample is fitted: no warm-up has to be left out, whatever the input.

**Operators the record does not excite.**  An operator moves only when the
input travels more than its threshold in one direction.  Its *travel* over the
fitted samples (where its state is fixed by the input) measures how much the
record says about its weight.  An operator whose travel is below half a
threshold spacing cannot be told apart from the offset: its weight is tied to
its nearest lower excited operator (equal weight density, ``b_i / Δr_i``), the
merge is reported (``not_identifiable_operators``), and the model keeps the
smooth density instead of an arbitrary value.

An operator with ``r = 0`` equals its input (``F_0[u] = u``), so its weight
cannot be told apart from ``a2``: its column is left out and ``b = 0`` is
reported for it, the sum living in ``a2``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numpy.linalg import LinAlgError
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import minimize_scalar, nnls

from pysim.core.invertibility import branch_cases, square_range
from pysim.core.metrics import error_measures
from pysim.core.model import HysteresisModel, eq13_thresholds
from pysim.identification.errors import IdentificationError

#: An operator whose travel over the fitted samples is below this fraction of
#: the threshold spacing is not identifiable (its weight is tied to a neighbour).
MIN_TRAVEL_FRACTION = 0.5
#: Alternating steps of the initial-state estimation (per start).
STATE_ITERATIONS = 12
#: Rounds of state steps through a column transform (see ``identify``).
TRANSFORM_STATE_ROUNDS = 3
#: Pivoted-QR tolerance below which an operator's column counts as a combination of the others
#: (its weight is then tied to its neighbour's density).
RANK_TOLERANCE = 1e-7
#: Pivot of the scaled triangular factor, as a share of the largest, at or below which the least-squares
#: solve refuses the columns as linearly dependent.
DEPENDENCE_TOLERANCE = 1e-10
_BIG = 1e12


#: A residual beyond this many times the RMS of the rest in the first 2 % of a record marks a start
#: transient (a logger or amplifier settling that no operator state explains).
START_OUTLIER = 8.0


@dataclass
class IdentificationResult:
    """Outcome of :func:`identify`.

    Attributes
    ----------
    model : HysteresisModel
        The identified model (physical units).
    warmup_samples : int
        Samples at the start left out of the fit (0 with ``warmup="auto"``:
        the initial state is estimated instead).
    fit_slice : slice
        Samples the fit used.
    prediction_um : ndarray
        Model output over the whole record, from ``initial_state``.
    errors : dict
        ``max_error_pct``, ``rms_error_pct``, ``mean_error_pct`` on the fit samples.
    constraints_active : bool
        Whether the invertibility constraints (or sign constraints on extra
        regressors) changed the unconstrained optimum.
    extra_coefficients : dict
        Coefficients of the extra regressors passed to :func:`identify`.
    objective : float
        Sum of squared errors on the fit samples, µm².
    initial_state : ndarray
        Operator state before the first sample (V of the shifted input):
        estimated with ``warmup="auto"``, demagnetised with a numeric warm-up.
        ``model.simulate(voltage_V, initial_state)`` reproduces ``prediction_um``.
    initial_state_estimated : bool
    not_identifiable_operators : tuple of int
        0-based indices of operators the fitted samples do not excite; their
        weight is tied to ``merged_into[i]`` (equal weight density).
    merged_into : dict
        Operator index → index of the operator whose density it shares.
    operator_travel_V : ndarray
        Travel of every operator over the fitted samples where its state is
        fixed by the input, V.
    condition_number : float
        2-norm condition number of the column-scaled design matrix on the
        fitted samples (large: weakly determined parameters).
    record_predictions_um : tuple of ndarray
        From :func:`identify_jointly`: every record's prediction over all its
        samples, with that record's own offset and extras (empty otherwise).
    """

    model: HysteresisModel
    warmup_samples: int
    fit_slice: slice
    prediction_um: np.ndarray
    errors: dict
    constraints_active: bool
    extra_coefficients: dict = field(default_factory=dict)
    objective: float = float("nan")
    initial_state: np.ndarray = None
    initial_state_estimated: bool = False
    not_identifiable_operators: tuple = ()
    merged_into: dict = field(default_factory=dict)
    operator_travel_V: np.ndarray = None
    condition_number: float = float("nan")
    record_predictions_um: tuple = ()
    unidentified_reason: str = ""

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

    def identifiability(self) -> dict:
        """What the record says about the model (plain numbers, for JSON).

        Returns
        -------
        dict with ``initial_state_V`` (the operator state before the first
        sample), ``initial_state_estimated``, ``not_identifiable_operators``
        (1-based operator numbers, as in the printed table), their thresholds,
        ``operator_travel_V`` and ``condition_number``.
        """
        r = self.model.thresholds_V
        return {
            "initial_state_V": [float(x) for x in self.initial_state],
            "initial_state_estimated": bool(self.initial_state_estimated),
            "not_identifiable_operators": [i + 1 for i in self.not_identifiable_operators],
            "not_identifiable_thresholds_V": [float(r[i]) for i in self.not_identifiable_operators],
            "operator_travel_V": [float(x) for x in self.operator_travel_V],
            "condition_number": float(self.condition_number),
            "unidentified_reason": self.unidentified_reason,
        }


def auto_warmup(voltage_V, widest_band_V: float = None) -> int:
    """First sample by which the input has been at both ends of its range.

    An operator whose band (``r`` for one-sided, ``2 r`` for classical play) is
    narrower than ``span - 2 tol`` has forgotten everything before the input
    came within ``tol`` of both ends.  With the widest band given, ``tol`` is
    chosen just inside that limit, so from the returned sample on the model's
    output no longer depends on the history before the record; without it the
    ends must be reached to 0.5 % of the span.

    Examples
    --------
    >>> auto_warmup([5.0, 0.0, 3.0, 10.0, 4.0])
    3
    """
    v = np.asarray(voltage_V, dtype=float)
    lo, hi = float(v.min()), float(v.max())
    span = hi - lo
    tol = 0.005 * span if widest_band_V is None else 0.45 * max(span - widest_band_V, 0.0)
    first_low = int(np.argmax(v <= lo + tol))
    first_high = int(np.argmax(v >= hi - tol))
    return max(first_low, first_high)


def operator_bounds(voltage_V, thresholds_V, operator: str, input_offset_V: float, history_floor_V=None,
                    threshold_scale=None):
    """Operator outputs started from the lowest and the highest admissible state.

    Parameters
    ----------
    history_floor_V : float, optional
        The lowest input (V) a history before the record may have visited (the
        amplifier's lowest output).  The lowest admissible state is then the one
        that a history which starts demagnetised and stays above it can leave:
        ``min(0, floor - offset)`` for a one-sided operator, ``min(0, floor -
        offset + r)`` for a play operator.  Without it the band is unbounded below.
    threshold_scale : array_like, optional
        A factor on every threshold at each sample (thresholds that change with
        time; :meth:`pysim.core.model.HysteresisModel.simulate`).  An operator's
        update is a clip whatever its threshold, so the bounds hold as they do
        for fixed thresholds.

    Returns
    -------
    low, high : ndarray (N, n)
        For any admissible initial state ``s``, operator ``i`` outputs
        ``clip(s_i, low[:, i], high[:, i])`` at every sample; ``low[0]`` and
        ``high[0]`` are the admissible band of the state itself.

    Examples
    --------
    >>> low, high = operator_bounds([5.0, 10.0, 0.0], [0.0, 4.0], "osp", 0.0)
    >>> low[:, 1].tolist(), high[:, 1].tolist()
    ([1.0, 6.0, 0.0], [5.0, 6.0, 0.0])

    A history above 0 V cannot leave the 4 V operator below 0 V before the first sample:

    >>> low, _ = operator_bounds([5.0, 10.0, 0.0], [0.0, 4.0], "osp", 0.0, history_floor_V=0.0)
    >>> low[:, 1].tolist()
    [1.0, 6.0, 0.0]
    >>> free, _ = operator_bounds([3.0, 10.0], [0.0, 4.0], "osp", 0.0)
    >>> floored, _ = operator_bounds([3.0, 10.0], [0.0, 4.0], "osp", 0.0, history_floor_V=0.0)
    >>> float(free[0, 1]), float(floored[0, 1])
    (-1.0, 0.0)
    """
    r = np.asarray(thresholds_V, dtype=float)
    probe = HysteresisModel(0.0, 0.0, tuple(r), tuple(np.zeros_like(r)), operator=operator,
                            input_offset_V=input_offset_V, name="probe")
    if history_floor_V is None:
        lowest = np.full(r.size, -_BIG)
    else:
        # a history from the demagnetised state (0) that never goes below u_floor: a one-sided operator's
        # state never falls below min(0, u_floor), a play operator's never below min(0, u_floor + r)
        u_floor = float(history_floor_V) - float(input_offset_V)
        lowest = np.minimum(0.0, u_floor + (r if operator == "play" else np.zeros_like(r)))
    _, low = probe.simulate(voltage_V, lowest, return_operators=True, threshold_scale=threshold_scale)
    _, high = probe.simulate(voltage_V, np.full(r.size, _BIG), return_operators=True, threshold_scale=threshold_scale)
    return low, high


def regressors(voltage_V, thresholds_V, operator: str, input_offset_V: float, cubic: bool,
               initial_state=None, rows=None, threshold_scale=None):
    """Design matrix of the linear-in-parameters model.

    Parameters
    ----------
    initial_state : array_like, optional
        Operator state before the first sample (default: demagnetised).
    rows : slice or array of int, optional
        Only these rows of the matrix (the operators still run over the whole record: a search that
        scores a part of it need not copy the rest).
    threshold_scale : array_like, optional
        A factor on every threshold at each sample (:func:`operator_bounds`).

    Returns
    -------
    columns : ndarray (N, p)
        ``[u³ (if cubic), u, F_{r_i}[u] for r_i > 0 ..., 1]``.
    operator_columns : list of int
        Index of each operator's column, or -1 for r = 0 operators (merged into a2).

    Examples
    --------
    >>> A, columns = regressors([0.0, 2.0, 1.0], [0.0, 0.5], "osp", 0.0, cubic=False)
    >>> A.tolist(), columns
    ([[0.0, 0.0, 1.0], [2.0, 1.5, 1.0], [1.0, 1.0, 1.0]], [-1, 1])
    """
    r = np.asarray(thresholds_V, dtype=float)
    # only the operator outputs are used: zero weights; simulate ignores the voltage range
    probe = HysteresisModel(0.0, 0.0, tuple(r), tuple(np.zeros_like(r)), operator=operator,
                            input_offset_V=input_offset_V, name="probe")
    _, operators = probe.simulate(voltage_V, initial_state, return_operators=True, threshold_scale=threshold_scale)
    u = np.asarray(voltage_V, dtype=float) - input_offset_V
    if rows is not None:
        operators, u = operators[rows], u[rows]
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
                        operator_columns, margin: float, operator_factors=None):
    """Rows G, h with G θ >= h  <=>  slope >= margin on every branch case.

    ``operator_factors[i]`` is operator i's weight in units of its column's
    coefficient (1 unless merged with others into one column).
    """
    a2_col = 1 if cubic else 0
    factors = np.ones(len(operator_columns)) if operator_factors is None else operator_factors
    rows, rhs = [], []
    for case in branch_cases(template):
        base = np.zeros(n_columns)
        base[a2_col] = 1.0
        for i in case.active:
            if operator_columns[i] >= 0:
                base[operator_columns[i]] += factors[i]
        t_values = square_range(case.u_from, case.u_to) if cubic else (0.0,)
        for t in set(t_values):
            row = base.copy()
            if cubic:
                row[0] = 3.0 * t
            rows.append(row)
            rhs.append(margin)
    return np.array(rows), np.array(rhs)


def _operator_template(r, operator: str, input_offset_V: float, voltage_range_V) -> HysteresisModel:
    """A model with the fitted operators' thresholds ``r`` (V), kind, input offset and range and zero
    weights: what the invertibility constraints are written on."""
    return HysteresisModel(0.0, 1.0, tuple(r), tuple(np.zeros_like(r)), operator=operator,
                           input_offset_V=input_offset_V, voltage_range_V=tuple(voltage_range_V), name="template")


def _constraint_rows(template: HysteresisModel, cubic: bool, n_params: int, operator_columns, operator_factors,
                     margin, nonnegative_columns=(), lagging_columns=()):
    """Rows G, h with G θ >= h: the ``template``'s operators (:func:`_operator_template`) weighted
    into an invertible model over its voltage range with slope >= ``margin`` (none when ``margin`` is
    None), the same with the coefficients in ``lagging_columns`` taken off the slope, and the
    coefficients in ``nonnegative_columns`` >= 0."""
    if margin is not None:
        G, h = _invertibility_rows(template, n_params, cubic, operator_columns, margin, operator_factors)
        if len(lagging_columns):
            after_step = G.copy()
            after_step[:, list(lagging_columns)] -= 1.0
            G, h = np.vstack([G, after_step]), np.concatenate([h, h])
    else:
        G, h = np.zeros((0, n_params)), np.zeros(0)
    nonneg = list(nonnegative_columns)
    if nonneg:
        sign_rows = np.zeros((len(nonneg), n_params))
        sign_rows[np.arange(len(nonneg)), nonneg] = 1.0
        G, h = np.vstack([G, sign_rows]) if G.size else sign_rows, np.concatenate([h, np.zeros(len(nonneg))])
    return G, h


def _operator_weights(theta, anchor, factor, column_of) -> np.ndarray:
    """Every operator's weight from the fitted coefficients: ``factor[i] × θ[column of anchor[i]]``
    (0 for an operator tied to nothing)."""
    return np.array([factor[i] * theta[column_of[anchor[i]]] if anchor[i] >= 0 else 0.0
                     for i in range(len(anchor))])


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
        # (the Gram matrix's check already refused a non-finite A: not scanned again row by row)
        Q1 = solve_triangular(R1, A.T, trans="T", lower=False, check_finite=False).T
        R2 = cholesky(Q1.T @ Q1, lower=False)
        c = solve_triangular(R2, Q1.T @ y, trans="T", lower=False)
        return R2 @ R1, c
    except LinAlgError:
        Q, R = np.linalg.qr(A)
        return R, Q.T @ y


def column_norms(A) -> np.ndarray:
    """The Euclidean norm of every column of ``A`` (2-D), exactly as ``np.linalg.norm(A, axis=0)``
    computes it, without the copy that function makes of a tall matrix first.

    Examples
    --------
    >>> column_norms(np.array([[3.0, 0.0], [4.0, 2.0]])).tolist()
    [5.0, 2.0]
    """
    return np.sqrt(np.add.reduce(A * A, axis=0))


def _scaled_factor(A, y):
    """``(R, c, scale)``: :func:`_triangular_factor` of ``A`` with its columns scaled to unit norm
    (a zero column left as it is), and the scale."""
    scale = column_norms(A)
    scale[scale == 0] = 1.0
    R, c = _triangular_factor(A / scale, y)
    return R, c, scale


def _dependent_column(R):
    """The column whose pivot in ``R`` falls to ``DEPENDENCE_TOLERANCE`` of the largest (a
    combination of the others), or None."""
    diagonal = np.abs(np.diag(R))
    which = int(np.argmin(diagonal))
    return which if diagonal[which] <= DEPENDENCE_TOLERANCE * np.max(diagonal) else None


def _columns_singular(A) -> bool:
    """Whether :func:`solve_lsi` would find the columns of ``A`` linearly dependent (its test)."""
    return _dependent_column(_scaled_factor(A, np.zeros(A.shape[0]))[0]) is not None


def solve_lsi(A, y, G, h, names=None):
    """min ||A θ − y||  subject to  G θ >= h  (Lawson-Hanson, exact).

    Returns (θ, constraints_active, condition_number).  Raises
    IdentificationError if the columns are linearly dependent (naming them when
    ``names`` are given) or the constraints cannot all hold.

    Examples
    --------
    >>> A = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> theta, active, _ = solve_lsi(A, np.array([1.0, -1.0, 0.0]), np.array([[0.0, 1.0]]), np.array([0.0]))
    >>> np.round(theta, 6).tolist(), active
    ([0.5, 0.0], True)
    """
    R, c, scale = _scaled_factor(A, y)
    which = _dependent_column(R)
    if which is not None:
        what = f" ({names[which]} is a combination of the others)" if names is not None else ""
        raise IdentificationError(
            "the regressors are linearly dependent" + what + ": the input does not excite every operator "
            "(too few distinct input levels or thresholds beyond the input range)")
    singular = np.linalg.svd(R, compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else float("inf")
    theta_s = solve_triangular(R, c, lower=False)
    Gs = G / scale
    if G.size == 0 or np.all(Gs @ theta_s >= h - 1e-12 * np.maximum(1.0, np.abs(h))):
        return theta_s / scale, False, condition
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
    return theta_s / scale, True, condition


def best_clamped_state(target, low, high, s_low: float, s_high: float) -> float:
    """The ``s`` in ``[s_low, s_high]`` minimising ``Σ (target − clip(s, low, high))²`` exactly.

    The error is a quadratic in ``s`` between neighbouring breakpoints (the
    sorted ``low`` and ``high`` values); every piece's minimiser is found from
    cumulative sums, so the cost is that of a sort.

    Examples
    --------
    >>> best_clamped_state(np.array([0.3, 0.5]), np.zeros(2), np.ones(2), 0.0, 1.0)
    0.4
    """
    t, L, U = (np.asarray(x, dtype=float) for x in (target, low, high))
    if t.size == 0:
        return float(s_low)
    knots = np.unique(np.concatenate((L, U, [s_low, s_high])))
    knots = knots[(knots >= s_low) & (knots <= s_high)]
    if knots.size < 2:
        return float(s_low)
    a, b = knots[:-1], knots[1:]
    mid = 0.5 * (a + b)
    # rows with L > s contribute (t - L)², rows with U < s contribute (t - U)², the rest (t - s)²
    order_l = np.argsort(L)
    Ls, tl = L[order_l], t[order_l]
    el = (tl - Ls) ** 2

    def suffix(x):
        return np.concatenate((np.cumsum(x[::-1])[::-1], [0.0]))

    def prefix(x):
        return np.concatenate(([0.0], np.cumsum(x)))

    above = np.searchsorted(Ls, mid, side="right")           # first index with L > mid
    e_above, t_above, t2_above = suffix(el)[above], suffix(tl)[above], suffix(tl**2)[above]
    n_above = t.size - above
    order_u = np.argsort(U)
    Us, tu = U[order_u], t[order_u]
    below = np.searchsorted(Us, mid, side="left")            # rows with U < mid
    e_below, t_below, t2_below = prefix((tu - Us) ** 2)[below], prefix(tu)[below], prefix(tu**2)[below]
    m = t.size - n_above - below
    S = t.sum() - t_above - t_below
    Q = (t**2).sum() - t2_above - t2_below
    with np.errstate(invalid="ignore", divide="ignore"):
        s_star = np.where(m > 0, S / np.maximum(m, 1), a)
    s_star = np.clip(s_star, a, b)
    value = e_above + e_below + m * s_star**2 - 2.0 * S * s_star + Q
    return float(s_star[int(np.argmin(value))])


def refine_state_through_stage(state, residual_um, low, high, weights_um_per_V, transform, window,
                                gain: float = 1.0) -> np.ndarray:
    """Each operator's state before the first sample, for fixed weights, through
    a linear output stage.

    The stage spreads a state's effect over later samples, so the exact steps
    of a static model do not apply; a bounded scalar search per operator does
    (the error is piecewise quadratic in the state).  The error is taken over
    ``window``, which a caller ends at the last sample that still remembers the
    state: a lightly damped stage would otherwise let the state ring on and fit
    a disturbance late in the record.

    Parameters
    ----------
    state : ndarray
        The current state, one value per operator (V).
    residual_um : ndarray
        The error over ``window`` of the model with ``state`` (µm).
    low, high : ndarray
        ``(N, n)`` bounds of each operator's output (:func:`operator_bounds`).
    weights_um_per_V : ndarray
    transform : callable
        ``transform(columns)``: the stage applied to each ``(m, k)`` column on
        its own, from rest at its first value (as
        :meth:`pysim.core.extended.OutputStages.apply_to_columns`).
    window : ndarray
        Increasing sample indices the error is taken on.
    gain : float
        A factor on the model's output (the sensor gain of another record).

    Returns
    -------
    ndarray
        The refined state; an operator's state changes only where that lowers
        the error.

    Examples
    --------
    A one-sample delay: the static exact step would fit the state to the wrong
    samples; through the stage the state that made the record is found.

    >>> import numpy as np
    >>> from pysim.core.extended import OutputStages
    >>> v = np.r_[np.full(5, 1.0), np.linspace(1.0, 3.0, 5)]
    >>> low, high = operator_bounds(v, [1.0], "osp", 0.0)
    >>> delay = OutputStages(delay_samples=1.0).apply_to_columns
    >>> y = delay(np.clip(0.5, low, high))[:, 0]
    >>> start = np.array([0.0])
    >>> e = y - delay(np.clip(start, low, high))[:, 0]
    >>> refine_state_through_stage(start, e, low, high, np.array([1.0]), delay, np.arange(10)).round(3)
    array([0.5])
    """
    state = np.array(state, dtype=float)
    window = np.asarray(window)
    if window.size == 0:
        return state
    stop = int(window[-1]) + 1
    residual = np.array(residual_um, dtype=float)
    for i in range(state.size):
        if weights_um_per_V[i] == 0.0 or not high[0, i] > low[0, i]:     # no weight, or a state fixed from the start
            continue
        current = np.minimum(np.maximum(state[i], low[:stop, i]), high[:stop, i])

        def effect(s, i=i, current=current):
            change = np.minimum(np.maximum(s, low[:stop, i]), high[:stop, i]) - current
            return gain * weights_um_per_V[i] * np.asarray(transform(change[:, None]), dtype=float)[:, 0][window]

        def cost(s, effect=effect):
            e = residual - effect(s)
            return float(e @ e)

        found = minimize_scalar(cost, bounds=(low[0, i], high[0, i]), method="bounded",
                                options={"xatol": 1e-4 * (high[0, i] - low[0, i])})
        if found.fun < float(residual @ residual):
            residual = residual - effect(found.x)
            state[i] = found.x
    return state


def short_history_states(levels_V, thresholds_V, operator: str = "osp") -> list:
    """Operator states left by short histories: the input came from far below
    or above, turned at a level ``e2`` (and at ``e3``, back towards where it came
    from), then went to the record's first sample.  Starts for the estimate of
    an unknown initial state; clip them to the admissible band
    (:func:`operator_bounds`) before use.

    Parameters
    ----------
    levels_V : array_like
        The turning levels tried, relative to the model's input offset (V).
    thresholds_V : array_like
    operator : str

    Returns
    -------
    list of ndarray

    Examples
    --------
    Up from far below to 10 V: each operator lags the input by its threshold.

    >>> short_history_states([10.0], [0.0, 4.0])[0].tolist()
    [10.0, 6.0]
    >>> len(short_history_states([0.0, 5.0, 10.0], [0.0, 4.0]))     # 2 x 3 single turns, 2 x 3 double
    12
    """
    r = np.asarray(thresholds_V, dtype=float)
    probe = HysteresisModel(0.0, 0.0, tuple(r), tuple(np.zeros_like(r)), operator=operator,
                            input_offset_V=0.0, name="probe")
    found = []
    for origin in (-_BIG, _BIG):
        for e2 in levels_V:
            found.append(probe.simulate([e2], np.full(r.size, origin), return_state=True)[1])
            for e3 in levels_V:
                if (e3 - e2) * origin > 0:       # e3 turns back towards the origin's side
                    found.append(probe.simulate([e2, e3], np.full(r.size, origin), return_state=True)[1])
    return found


def first_reversal(voltage_V) -> int:
    """Index of the first sample after which the input moves against its first direction
    (the length of the record if it never does)."""
    dv = np.diff(np.asarray(voltage_V, dtype=float))
    moves = np.flatnonzero(dv != 0)
    if moves.size == 0:
        return len(voltage_V)
    first = np.sign(dv[moves[0]])
    against = moves[np.sign(dv[moves]) == -first]
    return int(against[0]) if against.size else len(voltage_V)


def operator_travel(low, high, rows: slice, voltage_V=None) -> np.ndarray:
    """Travel of every operator (V) over ``rows`` where its state no longer
    depends on the initial state (``low == high``), counted from the input's
    first reversal in ``rows`` (on the first monotone run an operator only
    follows the input, which the linear term already does)."""
    lo, hi = low[rows], high[rows]
    # |lo − hi| ≤ atol: np.isclose with rtol = 0 on finite values, without its temporaries
    gap = lo - hi
    np.abs(gap, out=gap)
    fixed = gap <= 1e-9 * max(1.0, float(hi.max(initial=0.0)), -float(hi.min(initial=0.0)))
    steps = np.diff(lo, axis=0)
    np.abs(steps, out=steps)
    steps *= fixed[1:] & fixed[:-1]
    if not isinstance(rows, slice):
        steps[np.diff(np.asarray(rows)) != 1] = 0.0        # no travel across a gap between blocks
    if voltage_V is not None:
        steps[: first_reversal(np.asarray(voltage_V)[rows])] = 0.0
    return steps.sum(axis=0)


def _merge_plan(thresholds, travel, span):
    """Which operators are fitted on their own and which share a neighbour's
    weight density.  Returns (anchor, factor): operator i's weight is
    ``factor[i] × θ[anchor[i]]`` (anchor -1: no weight, r = 0 or nothing to tie to)."""
    r = np.asarray(thresholds, dtype=float)
    n = r.size
    spacing = np.diff(np.concatenate(([0.0], r)))
    typical = span / max(n, 1) if n else span
    spacing = np.where(spacing > 0, spacing, typical)
    anchor = np.full(n, -1)
    factor = np.ones(n)
    last = -1
    for i in range(n):
        if r[i] == 0.0:
            continue
        if travel[i] >= MIN_TRAVEL_FRACTION * spacing[i]:
            anchor[i], last = i, i
        elif last >= 0:
            anchor[i], factor[i] = last, spacing[i] / spacing[last]
    return anchor, factor


def _with_ties(thresholds, anchor, factor, tied) -> tuple:
    """``(anchor, factor)`` of a merge plan with the operators of ``tied`` (operator → the operator
    whose weight density it shares) tied as well, each to its partner's own anchor."""
    r = np.asarray(thresholds, dtype=float)
    spacing = np.diff(np.concatenate(([0.0], r)))
    anchor, factor = anchor.copy(), factor.copy()
    for i, partner in sorted((int(i), int(p)) for i, p in tied.items()):
        if not (0 <= i < r.size and 0 <= partner < r.size) or anchor[i] != i or anchor[partner] < 0:
            continue
        target = anchor[partner]
        ratio = factor[partner] * (spacing[i] / spacing[partner] if spacing[partner] > 0 else 1.0)
        for k in range(r.size):                # i, and every operator tied to i, follow the partner
            if anchor[k] == i:
                anchor[k], factor[k] = target, factor[k] * ratio
    return anchor, factor


def require_rising(voltage_V, displacement_um, where: str = "") -> None:
    """Raise :class:`IdentificationError` when the displacement clearly falls as the voltage rises
    (correlation below -0.5: a sensor that counts the other way).

    Every model here rises with the voltage: it would fit the mirror image of such a record's loops
    and leave the difference to be blamed on an effect.  ``where`` completes the message ("over
    samples 0..999").

    Examples
    --------
    >>> v = np.linspace(0.0, 100.0, 50)
    >>> require_rising(v, 0.1 * v)
    >>> require_rising(v, -0.1 * v)
    Traceback (most recent call last):
    ...
    pysim.identification.errors.IdentificationError: the displacement falls as the voltage rises (correlation -1.00, slope -0.1 µm/V): the models rise with the voltage; give the displacement with its sign flipped (−displacement, or --flip-displacement on the command line)
    """
    v, y = np.asarray(voltage_V, dtype=float), np.asarray(displacement_um, dtype=float)
    v_dev, y_dev = v - v.mean(), y - y.mean()
    scale = math.sqrt(float(v_dev @ v_dev) * float(y_dev @ y_dev))
    correlation = float(v_dev @ y_dev) / scale if scale > 0 else 0.0
    if correlation < -0.5:
        slope = float(v_dev @ y_dev) / float(v_dev @ v_dev)
        where = f" {where}" if where else ""
        raise IdentificationError(
            f"the displacement falls as the voltage rises{where} (correlation {correlation:.2f}, slope "
            f"{slope:.3g} µm/V): the models rise with the voltage; give the displacement with its sign "
            "flipped (−displacement, or --flip-displacement on the command line)")


def _reversal_check(v, rows, where):
    """One message when the input in ``rows`` never changes direction."""
    x = v[rows]
    dv = np.diff(x)
    tol = 1e-9 * max(1.0, float(np.max(np.abs(x))))
    if not (np.any(dv > tol) and np.any(dv < -tol)):
        sense = "rises" if np.any(dv > tol) else "falls"
        raise IdentificationError(
            f"the input only {sense} over samples {where}: hysteresis needs the input to rise and fall "
            "(record at least one full cycle across the range)")


def _why_unidentified(v, rows, thresholds, travel, span, where, merge=True):
    """Why fitting ``rows`` identifies no operator's hysteresis (None when it identifies one), with
    the merge plan ``(anchor, factor)`` for those rows from the operators' ``travel`` over them (see
    :func:`_merge_plan`; without ``merge`` every operator keeps its own weight)."""
    try:
        _reversal_check(v, rows, where)
        reason = None
    except IdentificationError as exc:
        reason = str(exc)
    r = np.asarray(thresholds, dtype=float)
    if merge:
        anchor, factor = _merge_plan(r, travel, span)
    else:
        anchor, factor = np.where(r > 0, np.arange(r.size), -1), np.ones(r.size)
    if reason is None and np.any(r > 0) and not np.any(anchor >= 0):
        reason = (f"no operator is excited over samples {where}: the input never travels more than the "
                  f"smallest threshold ({float(np.min(r[r > 0])):.4g} V) in one direction after a "
                  "reversal; record at least one rise and fall over most of the range")
    return reason, anchor, factor


def identify(voltage_V, displacement_um, *, n_operators: int = 10, model: str = "mpi",
             operator: str = "osp", thresholds_V=None, warmup="auto", fit_slice: slice = None,
             min_slope_fraction: float = 0.01, extra_regressors: dict = None, extra_nonnegative=(),
             column_transform=None, initial_state=None, start_state=None, merge_unexcited: bool = True,
             fit_rows=None, lagging_extras=(),
             input_offset_V: float = None, require_excitation: bool = True, history_floor_V: float = None,
             tied_operators: dict = None, threshold_scale=None, name: str = None,
             description: str = "") -> IdentificationResult:
    """Fit an MPI or CPI model to a measured record.

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record (same length).
    n_operators : int
        Number of operators n (thresholds from eq. 13 over the range of the
        fitted samples unless given).
    model : {"mpi", "cpi"}
        CPI forces a1 = 0.
    operator : {"osp", "play"}
        Operator kind.  The input is shifted to the bottom of the fitted
        samples' range (``input_offset_V``) for both kinds.
    thresholds_V : array_like, optional
        Thresholds r_i (V, of the shifted input) instead of eq. 13.
    warmup : "auto" or int
        ``"auto"``: every sample is fitted and the operator state before the
        first sample is estimated with the weights (see the module notes).
        An int: that many samples at the start are left out and the model
        starts demagnetised.
    fit_slice : slice, optional
        Fit only on these samples (e.g. a training part).
    min_slope_fraction : float
        Invertibility margin: the slope along every branch stays above this
        fraction of the record's mean gain (displacement span / voltage span).
        Use a negative value to fit without the constraints.
    extra_regressors : dict of name -> array, optional
        Further columns that enter linearly (e.g. creep modes); their fitted
        coefficients come back in ``extra_coefficients``.
    extra_nonnegative : iterable of str
        Names of extra regressors whose coefficient is constrained to be >= 0.
    lagging_extras : iterable of str
        Names of extra regressors that are how far a unit-gain lag of the input trails it
        (``C[u] − u``: creep modes).  The hysteresis curve is then the settled one, and the
        response right after a voltage step is its slope less these coefficients; that slope is
        held to the same invertibility margin, so a step moves the actuator its way at once and
        creep only adds to it (on a single sine, a fast mode over a falling curve could otherwise
        draw a phase shift).
    column_transform : callable, optional
        Linear map applied to every column of the hysteresis model's design
        matrix (an (N, p) array in, the same shape out), for models whose output
        passes through a linear stage (dynamics, delay); ``prediction_um`` is
        then that model's output.  The invertibility constraints still apply
        to the hysteresis parameters.  With ``warmup="auto"`` the initial state
        is estimated by the fit without the transform, then refined through
        it (a bounded search per operator, weights fixed).
    initial_state : array_like, optional
        A fixed operator state before the first sample (V of the shifted
        input) instead of estimating one.
    start_state : array_like, optional
        With ``warmup="auto"``: a state estimated before (for a related
        model) to start the estimation from, with the demagnetised one,
        instead of screening many starts; with ``column_transform`` it is
        refined through the transform only.
    merge_unexcited : bool
        Tie the weight of operators the fitted samples do not excite to their
        lower neighbour's density (default) instead of fitting it freely.
    fit_rows : array_like of int, optional
        Fit only these samples (e.g. every block of a record but one) instead
        of ``fit_slice``; the model still runs over the whole record.
    input_offset_V : float, optional
        Input shift (default: the bottom of the fitted samples' range).
    require_excitation : bool
        Refuse a record that cannot identify any operator (default).  With
        False such a record is fitted as the curve it shows (the operators'
        columns with their estimated states, dependent ones tied; on an
        input that only rises they are ramps) and every operator is
        reported as not identifiable (``unidentified_reason``): the weights
        describe this record's curve, not the loops of another input.  When
        only the rows fitted identify nothing (``fit_rows`` of a record that
        does), the model is to predict rows they do not excite, and it is
        ``a1 u³ + a2 u + offset``.
    tied_operators : dict of int to int, optional
        Operators (0-based) whose weight density is tied to another operator's from the start, as
        a fit of the same record found them (``merged_into`` of its result): an input stage that
        moves a sample or two of the record must not free a weight the record does not determine.
    history_floor_V : float, optional
        The lowest voltage the actuator was driven to before the record (V), e.g. 0 for a
        unipolar amplifier.  The estimated start state is then one that a history from the
        demagnetised state above this voltage leaves (:func:`operator_bounds`).  Without it
        (default) the state is bounded only by the first sample, and a state below the
        demagnetised level that the record never wipes stays in the fit: the model
        simulated from rest (``simulate``, the FMUs) then misses its own fit by a constant
        until the input's top.  With it, once the record has visited this voltage the model
        from rest is its fit.  Must not be above the record's lowest voltage.
    threshold_scale : array_like, optional
        A factor on every threshold at each sample (thresholds that grow with the input's rate,
        :mod:`pysim.core.input_stage`); the returned model holds the thresholds as fitted and
        reproduces ``prediction_um`` when simulated with the same factors.
    name, description : str
        Stored in the model.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    IdentificationError
        With one message naming what the record lacks (a constant or
        one-directional input, too few samples, no excited operator).

    Examples
    --------
    >>> import numpy as np
    >>> from pysim.core.model import HysteresisModel, eq13_thresholds
    >>> r = eq13_thresholds(4, 100.0)
    >>> truth = HysteresisModel(0.0, 0.4, tuple(r), (0.0, 0.05, 0.05, 0.05), voltage_range_V=(0.0, 100.0))
    >>> v = 50 + 50 * np.sin(np.linspace(0, 6 * np.pi, 3000))
    >>> y = truth.simulate(v, [40.0, 30.0, 20.0, 10.0])     # an unknown history
    >>> fit = identify(v, y, model="cpi", n_operators=4)
    >>> bool(fit.errors["max_error_pct"] < 1e-6), fit.warmup_samples
    (True, 0)
    """
    v, y, rows, first, stop, start = _checked_rows(voltage_V, displacement_um, model, warmup, fit_slice, fit_rows)
    lo, hi = float(v[rows].min()), float(v[rows].max())
    if not hi > lo:
        raise IdentificationError(f"the voltage is constant over samples {first}..{stop - 1}: nothing to identify")
    require_rising(v[rows], y[rows], f"over samples {first}..{stop - 1}")
    # u = v - lo for both kinds: the cubic a1 u^3 about the bottom of the range
    # is what makes loops asymmetric (about the centre it would be odd-symmetric)
    input_offset = lo if input_offset_V is None else float(input_offset_V)
    n_rows = (stop - first) if fit_rows is None else rows.size
    r = (eq13_thresholds(n_operators, hi - lo, operator) if thresholds_V is None
         else np.asarray(thresholds_V, dtype=float))
    cubic = model == "mpi"
    extras = _checked_extras(extra_regressors, extra_nonnegative, v.size, lagging_extras)
    n_params_hint = (2 if cubic else 1) + int(np.count_nonzero(r)) + 1 + len(extras)
    if n_rows < n_params_hint + 1:
        raise IdentificationError(
            f"{n_rows} samples to fit (after a warm-up of {start}) but the model has {n_params_hint} "
            f"parameters: need at least {n_params_hint + 1}")
    u = v - input_offset
    history_floor = checked_history_floor(history_floor_V, v)
    low, high = operator_bounds(v, r, operator, input_offset, history_floor, threshold_scale)
    demagnetised = np.clip(np.zeros(r.size), low[0], high[0])
    estimate = warmup == "auto" and initial_state is None
    if initial_state is not None:
        state0 = np.clip(np.asarray(initial_state, dtype=float).ravel(), low[0], high[0])
        if state0.size != r.size:
            raise IdentificationError(f"initial_state has {state0.size} entries, not {r.size}")
    else:
        state0 = demagnetised
    travel, unexcited_message, anchor, factor, static_curve = _excitation_of_rows(
        v, rows, (first, stop), r, (low, high), hi - lo, merge_unexcited, require_excitation)
    if tied_operators:
        anchor, factor = _with_ties(r, anchor, factor, tied_operators)
    columns = _Columns(r, cubic, anchor, factor, extras)

    # Only the window's rows are fitted; the state matters only where an
    # operator has not yet forgotten it (low < high): the "transient" rows.
    low_w, high_w, y_w, u_w = low[rows], high[rows], y[rows], u[rows]
    columns.tie_dependent(state0, low_w, high_w, u_w, static_curve,
                          through=None if column_transform is None else (column_transform, low, high, u, rows))
    cubic, n_hyst = columns.cubic, columns.n_hyst

    if unexcited_message is None and np.any(r > 0) and not any(r[i] > 0 for i in columns.own):
        unexcited_message = (f"the fitted samples take only {np.unique(u_w).size} distinct input levels: no "
                             "operator can be told apart from a straight line; record a rise and a fall through "
                             "many levels")
        if require_excitation:
            raise IdentificationError(unexcited_message)
    effective_columns = [columns.column_of.get(int(anchor[i]), -1) if anchor[i] >= 0 else -1
                         for i in range(r.size)]
    n_params = n_hyst + len(extras)
    mean_gain = float(np.ptp(y[rows])) / (hi - lo)
    G, h = _constraint_rows(_operator_template(r, operator, input_offset, (lo, hi)), cubic, n_params,
                            effective_columns, factor,
                            min_slope_fraction * mean_gain if min_slope_fraction >= 0 else None,
                            [n_hyst + j for j, key in enumerate(extras) if key in set(extra_nonnegative)],
                            [n_hyst + j for j, key in enumerate(extras) if key in set(lagging_extras)])
    extra_matrix = np.column_stack(list(extras.values())) if extras else np.zeros((v.size, 0))
    window = _WindowFit(columns, low_w, high_w, y_w, u_w, extra_matrix[rows], G, h, (low[0], high[0]))

    warm = None if start_state is None else np.clip(np.asarray(start_state, dtype=float).ravel(), low[0], high[0])
    if warm is not None and warm.size != r.size:
        raise IdentificationError(f"start_state has {warm.size} entries, not {r.size}")
    # without a start to refine, the estimation screens the extreme states and short histories over the
    # fitted range (where some fitted row still remembers the state)
    screened = ([demagnetised, low[0].copy(), high[0].copy()] + [
                    np.clip(s, low[0], high[0])
                    for s in short_history_states(np.linspace(lo, hi, 9) - input_offset, r, operator)]
                if estimate and warm is None and window.transient_rows.size else None)
    record = _RecordArrays(low, high, u, y, rows, extra_matrix, G, h)
    state0, A, theta, active, condition, sse = _state_and_parameters(
        window, columns, record, column_transform, state0, demagnetised, warm if estimate else None, screened)

    a1 = float(theta[0]) if cubic else 0.0
    a2 = float(theta[columns.n_lin - 1])
    weights = columns.weights_of(theta)
    offset = float(theta[n_hyst - 1])
    identified = HysteresisModel(
        a1=a1, a2=a2, thresholds_V=tuple(r), weights_um_per_V=tuple(weights), operator=operator,
        input_offset_V=input_offset, output_offset_um=offset, voltage_range_V=(lo, hi),
        name=name or f"identified_{model}", description=description)
    extra_coefficients = {key: float(theta[n_hyst + j]) for j, key in enumerate(extras)}
    prediction = A @ theta
    not_identifiable = columns.not_identifiable
    merged = {int(i): int(anchor[i]) for i in not_identifiable if anchor[i] >= 0}
    if static_curve:
        not_identifiable = tuple(int(i) for i in range(r.size) if r[i] > 0)
    return IdentificationResult(
        model=identified, warmup_samples=start, prediction_um=prediction,
        fit_slice=rows if isinstance(rows, slice) else slice(first, stop),
        errors=error_measures(y[rows], prediction[rows]), constraints_active=active,
        extra_coefficients=extra_coefficients, objective=sse, initial_state=np.asarray(state0, dtype=float),
        initial_state_estimated=bool(estimate), not_identifiable_operators=not_identifiable,
        merged_into=merged, operator_travel_V=travel, condition_number=condition,
        unidentified_reason=unexcited_message or "")


def history_floor_for_input(history_floor_V, operators_input_V):
    """The history floor (V) for operators that see ``operators_input_V`` instead of the voltage (an
    input stage's output, which may dip below the voltage's lowest value): the lower of the two;
    None without a floor.

    Examples
    --------
    >>> history_floor_for_input(0.0, [0.5, 80.0]), history_floor_for_input(0.0, [-0.2, 80.0])
    (0.0, -0.2)
    """
    if history_floor_V is None:
        return None
    return min(float(history_floor_V), float(np.min(operators_input_V)))


def checked_history_floor(history_floor_V, voltage_V, where: str = ""):
    """``history_floor_V`` as a float (or None); a floor above the record's lowest voltage (``where``
    names the record in the message) or one that is not finite raises :class:`IdentificationError`.

    Examples
    --------
    >>> checked_history_floor(0, [3.0, 150.0, 20.0])
    0.0
    """
    if history_floor_V is None:
        return None
    floor = float(history_floor_V)
    if not math.isfinite(floor):
        raise IdentificationError(f"history_floor_V must be a finite voltage, got {history_floor_V!r}")
    lowest = int(np.argmin(voltage_V))
    if voltage_V[lowest] < floor:
        raise IdentificationError(
            f"the history floor, {floor:g} V, is above the record's lowest voltage{where}, {voltage_V[lowest]:g} V at "
            f"sample {lowest}: the amplifier goes lower than that floor")
    return floor


def _excitation_of_rows(v, rows, first_stop: tuple, r, bounds: tuple, span_V: float, merge: bool,
                        require_excitation: bool) -> tuple:
    """``(travel, unexcited_message, anchor, factor, static_curve)``: how far each operator travels
    over the fitted ``rows`` (from sample ``first`` to before ``stop``, ``first_stop``), why none is
    identifiable (None when one is), each operator's anchor and factor (:func:`_why_unidentified`),
    and whether the whole record identifies no operator (it is then fitted as the curve it shows).
    ``bounds`` are the operators' ``(low, high)`` of :func:`operator_bounds`.  Raises
    :class:`IdentificationError` when no operator is identifiable and ``require_excitation``."""
    (first, stop), (low, high) = first_stop, bounds
    travel = operator_travel(low, high, rows, v)
    unexcited_message, anchor, factor = _why_unidentified(v, rows, r, travel, span_V, f"{first}..{stop - 1}",
                                                          merge=merge)
    if unexcited_message is not None and require_excitation:
        raise IdentificationError(unexcited_message)
    whole = isinstance(rows, slice) and first == 0 and stop == v.size
    static_curve = unexcited_message is not None and (
        whole or _why_unidentified(v, slice(0, v.size), r, operator_travel(low, high, slice(0, v.size), v),
                                   span_V, "")[0] is not None)
    if static_curve:
        # the whole record identifies no operator's hysteresis: all are reported as such, but each keeps
        # its column (dependent ones are tied below), so the fit is the record's own curve, as a
        # rate-independent reference must be: on an input that only rises the operators are ramps whose
        # knots the estimated states place.  a1 u³ + a2 u + offset alone left the loading curve's shape,
        # which a diagnosis then blamed on creep (a time function is an input function on a ramp)
        anchor = np.where(r > 0, np.arange(r.size), -1)
        factor = np.ones(r.size)
    elif unexcited_message is not None:
        # only the fitted rows identify nothing (a training part of a record that does): the model is
        # to predict rows these do not excite, so no operator gets a weight here (a1 u³ + a2 u + offset)
        anchor = np.full(r.size, -1)
    return travel, unexcited_message, anchor, factor, static_curve


@dataclass(frozen=True)
class _RecordArrays:
    """The whole record as a fit sees it: every sample's operator bounds ``low``, ``high`` (samples ×
    operators, V of the shifted input), the shifted input ``u`` (V), the displacement ``y`` (µm), the
    ``rows`` fitted (a slice or sorted indices), the extra regressors' columns ``extra_matrix``
    (samples × k) and the constraints ``G θ >= h``."""
    low: np.ndarray
    high: np.ndarray
    u: np.ndarray
    y: np.ndarray
    rows: object
    extra_matrix: np.ndarray
    G: np.ndarray
    h: np.ndarray


def _state_and_parameters(window, columns, record: _RecordArrays, column_transform, state0, demagnetised, warm,
                          screened) -> tuple:
    """``(state0, A, theta, active, condition, sse)``: the operator state before the first sample and
    the parameters fitted with it, through ``column_transform`` when given; ``A`` is the whole record's
    design matrix.  The state is estimated with the weights from ``warm`` (a state estimated before)
    and ``demagnetised`` (the demagnetised state within the first sample's bounds), or from the
    ``screened`` starts when there is no ``warm``; with neither it is ``state0``."""
    estimate = warm is not None or screened is not None
    transient = bool(window.transient_rows.size)
    if estimate and transient and warm is not None and column_transform is not None:
        state0 = warm         # the estimate is refined through the transform below
    elif estimate and transient:
        starts = [warm, demagnetised] if warm is not None else screened
        state0, theta, active, condition, sse = window.estimated_state(starts, demagnetised,
                                                                       from_settled=warm is None)
    else:
        _, theta, active, condition, sse = window.solve(state0)
    if column_transform is None:
        A = columns.design(state0, record.low, record.high, record.u, record.extra_matrix)
    else:
        state0, A, theta, active, condition, sse = _fit_through_transform(
            columns, column_transform, record, [state0, demagnetised] if estimate else [state0],
            refine=bool(estimate and transient))
    return state0, A, theta, active, condition, sse


def _checked_rows(voltage_V, displacement_um, model, warmup, fit_slice, fit_rows) -> tuple:
    """``(v, y, rows, first, stop, warmup_samples)``: the record checked, and the samples to fit
    (a slice, or sorted indices for ``fit_rows``) with the first and one past the last of them."""
    if model not in ("mpi", "cpi"):
        raise IdentificationError(f"model must be 'mpi' or 'cpi', got {model!r}")
    if not (warmup == "auto" or (isinstance(warmup, (int, np.integer)) and warmup >= 0)):
        raise IdentificationError(f"warmup must be 'auto' or a whole number of samples >= 0, got {warmup!r}")
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    if v.shape != y.shape:
        raise IdentificationError(f"{v.size} voltage samples but {y.size} displacement samples")
    if v.size == 0:
        raise IdentificationError("the record is empty")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(y))):
        raise IdentificationError("the record holds NaN or infinite values")
    window = fit_slice or slice(0, v.size)
    first, stop, _ = window.indices(v.size)
    start = 0 if warmup == "auto" else int(warmup)
    first = max(first, start)
    if stop - first < 2:
        raise IdentificationError(f"{max(stop - first, 0)} samples to fit (after a warm-up of {start})")
    rows = slice(first, stop)
    if fit_rows is not None:
        rows = np.asarray(fit_rows, dtype=int).ravel()
        if rows.size > 1 and not np.all(rows[1:] > rows[:-1]):     # the folds pass sorted rows: no sort
            rows = np.unique(rows)
        if rows.size < 2 or rows[0] < 0 or rows[-1] >= v.size:
            raise IdentificationError(f"fit_rows must hold at least 2 sample indices in 0..{v.size - 1}")
        first, stop = int(rows[0]), int(rows[-1]) + 1
    return v, y, rows, first, stop, start


def _checked_extras(extra_regressors, extra_nonnegative, n_samples: int, lagging_extras=()) -> dict:
    """The extra regressors as float columns of the record's length, checked with the names of the
    non-negative and the lagging ones."""
    extras = dict(extra_regressors or {})
    for key, column in extras.items():
        column = np.asarray(column, dtype=float).ravel()
        if column.shape != (n_samples,):
            raise IdentificationError(f"extra regressor {key!r} has {column.size} samples, not {n_samples}")
        extras[key] = column
    for what, named in (("extra_nonnegative", extra_nonnegative), ("lagging_extras", lagging_extras)):
        unknown = set(named) - set(extras)
        if unknown:
            raise IdentificationError(f"{what} names no extra regressor: {sorted(unknown)}")
    return extras


class _Columns:
    """The hysteresis part's columns of the design matrix: ``[u³] u``, one column per operator with a
    weight of its own, the offset (the extras follow them).  An operator tied to a lower neighbour
    (``anchor[i]``, with the ratio ``factor[i]`` of their weights) adds its output to that column;
    one tied to nothing (anchor -1) has no weight.  Ties change while dependent operators are found
    (:meth:`tie_dependent`), and the layout with them."""

    def __init__(self, thresholds, cubic: bool, anchor, factor, extras: dict):
        self.r, self.cubic, self.anchor, self.factor = thresholds, cubic, anchor, factor
        self.extra_names = list(extras)
        # (state, columns through a stage) of tie_dependent's last probe, for the fit to reuse
        self.transformed_at = None
        self._lay_out()

    def _lay_out(self):
        r, anchor = self.r, self.anchor
        self.n_lin = 2 if self.cubic else 1
        self.own = [i for i in range(r.size) if anchor[i] == i]
        self.not_identifiable = tuple(int(i) for i in range(r.size) if r[i] > 0 and anchor[i] != i)
        self.column_of = {i: self.n_lin + j for j, i in enumerate(self.own)}
        self.n_hyst = self.n_lin + len(self.own) + 1
        self.names = ((["a1 u³"] if self.cubic else []) + ["a2 u"]
                      + [f"operator {i + 1} (r = {r[i]:.4g} V)" for i in self.own]
                      + ["offset"] + [f"extra {k!r}" for k in self.extra_names])

    def design(self, state, lo_b, hi_b, uu, extra=None) -> np.ndarray:
        """The hysteresis columns for the rows whose operator bounds are ``lo_b``, ``hi_b`` (rows ×
        operators) and shifted input ``uu``, from the operator ``state`` before them; the columns of
        ``extra`` (rows × k), when given, follow them."""
        n_lin, n_hyst, own = self.n_lin, self.n_hyst, self.own
        n_extra = 0 if extra is None else extra.shape[1]
        A = np.empty((uu.size, n_hyst + n_extra))
        if self.cubic:
            A[:, 0] = uu**3
        A[:, n_lin - 1] = uu

        def outputs(which):
            # the operators' outputs from ``state``: clamped between their bounds on every row
            return np.minimum(np.maximum(state[which], lo_b[:, which]), hi_b[:, which])

        if own:                                  # their columns are consecutive, in order
            block = A[:, n_lin:n_lin + len(own)]
            first, end = own[0], own[-1] + 1
            if end - first == len(own):
                # operators first..end-1 (the usual case): clamped in place, without temporaries (the
                # design is rebuilt for every state tried, on every fitted row)
                np.maximum(state[first:end], lo_b[:, first:end], out=block)
                np.minimum(block, hi_b[:, first:end], out=block)
            else:
                block[...] = outputs(own)
        for i in self.not_identifiable:
            if self.anchor[i] >= 0:
                A[:, self.column_of[self.anchor[i]]] += self.factor[i] * outputs(i)
        A[:, n_hyst - 1] = 1.0
        if n_extra:
            A[:, n_hyst:] = extra
        return A

    def weights_of(self, theta) -> np.ndarray:
        """Every operator's weight (µm/V) from the fitted coefficients."""
        return _operator_weights(theta, self.anchor, self.factor, self.column_of)

    def tie_dependent(self, state, low_w, high_w, u_w, static_curve: bool, through=None) -> None:
        """Tie operators whose columns the fitted rows make linearly dependent on the others (few
        distinct input levels, as in steps) to their lower neighbour, the widest first, until the
        columns are independent; drop u³ when the rows show only two input levels.

        ``through``: ``(column_transform, low, high, u, rows)`` when the columns are fitted after a
        stage.  A stage that loses samples can make columns dependent that are not before it: a delay
        of d samples drops the record's last d samples from every column (a record whose input leaves
        its levels only on its last sample then loses the one sample that tells two operators apart).
        When the columns through the stage could not be solved, the ties are made on them; otherwise
        the ties stand as the columns before the stage give them (a stable stage keeps what they
        tell apart)."""
        self._tie_while_dependent(lambda: self.design(state, low_w, high_w, u_w), static_curve)
        if through is None:
            return
        transform, low, high, u, rows = through

        def probe_through_stage():
            full = np.asarray(transform(self.design(state, low, high, u)), dtype=float)
            # the fit through the stage starts from this state: kept for it (see transformed_design)
            self.transformed_at = (np.array(state, dtype=float), full)
            return full[rows]

        if not _columns_singular(probe_through_stage()):
            return
        self._tie_while_dependent(probe_through_stage, static_curve)

    def _tie_while_dependent(self, probe, static_curve: bool) -> None:
        """The ties of :meth:`tie_dependent` for the columns ``probe()`` gives with the current layout."""
        r, anchor, factor = self.r, self.anchor, self.factor
        spacing = np.diff(np.concatenate(([0.0], r)))
        for _ in range(r.size + 1):
            own, n_hyst, column_of = self.own, self.n_hyst, self.column_of
            probe_matrix = probe()
            norms = column_norms(probe_matrix)
            norms[norms == 0] = 1.0
            # only R and the pivots: forming Q would cost more than the whole fit (mode "raw" gives R as
            # its square top; mode "r" copies the whole tall matrix to zero all below it)
            _, R_probe, pivots = scipy.linalg.qr(probe_matrix / norms, mode="raw", pivoting=True)
            diagonal = np.abs(np.diag(R_probe))
            rank = int(np.count_nonzero(diagonal > RANK_TOLERANCE * diagonal[0]))
            dependent_ops = [i for i in own if column_of[i] in set(pivots[rank:].tolist())]
            if rank < n_hyst and not dependent_ops and static_curve and own:
                # the pivoting named another column (the offset, against an operator the input never
                # reaches): the widest operator goes first
                dependent_ops = [max(own, key=lambda j: r[j])]
            if rank < n_hyst and not dependent_ops and own:
                # the pivoting named the offset or u, but operators are in the dependence (two operators
                # whose states follow the input in lockstep over these rows, each a shifted copy of it):
                # they are read off the null vector, and the widest of them goes first
                _, _, vt = np.linalg.svd(R_probe[:n_hyst])
                null = np.zeros(n_hyst)
                null[pivots] = vt[-1]
                dependent_ops = [i for i in own if abs(null[column_of[i]]) > 1e-6 * float(np.max(np.abs(null)))]
            if rank < n_hyst and not dependent_ops and self.cubic:
                # u³ is a combination of u and the offset: the samples take two input levels (steps
                # between two voltages), which show no loop curvature; the model is fitted without it
                self.cubic = False
                self._lay_out()
                continue
            if rank == n_hyst or not dependent_ops:
                break
            i = max(dependent_ops, key=lambda j: r[j])
            lower = [j for j in own if j < i]
            anchor[i] = lower[-1] if lower else -1
            factor[i] = spacing[i] / spacing[anchor[i]] if lower and spacing[anchor[i]] > 0 else 1.0
            for k in range(r.size):
                if k != i and anchor[k] == i:        # operators tied to i follow it
                    anchor[k], factor[k] = anchor[i], factor[k] * factor[i]
            self._lay_out()
        if rank < n_hyst:
            self.transformed_at = None      # probed with a layout since changed

    def transformed_design(self, state, low, high, u, transform) -> np.ndarray:
        """The hysteresis columns of the whole record for operator ``state``, through ``transform``
        (the last probe of :meth:`tie_dependent` when it was of this state and layout)."""
        kept = self.transformed_at
        if kept is not None and np.array_equal(kept[0], state):
            return kept[1]
        return np.asarray(transform(self.design(state, low, high, u)), dtype=float)


class _WindowFit:
    """The constrained least-squares fit of the fitted rows for any operator state before them, and
    the estimation of that state.

    The state matters only where an operator has not yet forgotten it (low < high): the
    "transient" rows.  Rows outside them do not depend on the state: the first matrix built is
    kept, and for every further state only its transient rows are rewritten (a fit without state
    estimation builds one matrix).
    """

    def __init__(self, columns: _Columns, low_w, high_w, y_w, u_w, extra_w, G, h, state_bounds):
        self.columns = columns
        self.low_w, self.high_w, self.y_w, self.u_w, self.extra_w = low_w, high_w, y_w, u_w, extra_w
        self.G, self.h = G, h
        self.state_low, self.state_high = state_bounds          # the admissible states before the first row
        remembers = np.ascontiguousarray((high_w - low_w > 0).T)      # operator × row, one row per operator
        self.transient_rows = np.flatnonzero(np.any(remembers, axis=0))
        self.moving = [np.flatnonzero(row) for row in remembers]
        self._base = None

    def design(self, state) -> np.ndarray:
        """The fitted rows' design matrix (hysteresis columns, then extras) for ``state``."""
        design = self.columns.design
        if self._base is None:
            self._base = design(state, self.low_w, self.high_w, self.u_w, self.extra_w)
            return self._base
        A = self._base.copy()
        if self.transient_rows.size:
            k = self.transient_rows
            A[k, :self.columns.n_hyst] = design(state, self.low_w[k], self.high_w[k], self.u_w[k])
        return A

    def solve(self, state) -> tuple:
        """``(A, θ, active constraints, condition number, squared error)`` for ``state``."""
        A = self.design(state)
        theta, active, condition = solve_lsi(A, self.y_w, self.G, self.h, self.columns.names)
        e = self.y_w - A @ theta
        return A, theta, active, condition, float(e @ e)

    def refine_state(self, state, A, theta):
        """Exact coordinate steps over every operator's state, weights fixed."""
        state = state.copy()
        residual = self.y_w - A @ theta
        b = self.columns.weights_of(theta)
        for i in range(state.size):
            k = self.moving[i]
            if b[i] == 0.0 or k.size == 0:
                continue
            L, U = self.low_w[k, i], self.high_w[k, i]
            current = np.minimum(np.maximum(state[i], L), U)
            target = residual[k] / b[i] + current
            new = best_clamped_state(target, L, U, self.state_low[i], self.state_high[i])
            residual[k] -= b[i] * (np.minimum(np.maximum(new, L), U) - current)
            state[i] = new
        return state

    def polish_state(self, state, theta):
        """All states at once for fixed weights (trust region on the
        piecewise-linear residual of the transient rows)."""
        b = self.columns.weights_of(theta)
        k = self.transient_rows
        if k.size == 0 or not np.any(b):
            return state
        lt, ht = self.low_w[k], self.high_w[k]
        zero = np.zeros(state.size)
        rest = self.y_w[k] - self.columns.design(zero, lt, ht, self.u_w[k], self.extra_w[k]) @ theta
        rest = rest + (np.minimum(np.maximum(zero, lt), ht) @ b)

        def residual(s):
            return np.minimum(np.maximum(s, lt), ht) @ b - rest

        def jacobian(s):
            return ((lt < s) & (s < ht)) * b

        lower, upper = self.state_low, self.state_high
        s = np.clip(state, lower, upper)
        f = residual(s)
        cost = float(f @ f)
        damping = 1e-6
        for _ in range(40):
            J = jacobian(s)
            gradient = J.T @ f
            free = ~(((s <= lower) & (gradient > 0)) | ((s >= upper) & (gradient < 0))) & np.any(J != 0, axis=0)
            if not np.any(free):
                break
            H = J[:, free].T @ J[:, free]
            H = H + damping * (np.trace(H) / max(H.shape[0], 1) + 1e-300) * np.eye(H.shape[0])
            try:
                direction = -np.linalg.solve(H, gradient[free])
            except LinAlgError:
                break
            improved = False
            for scale in (1.0, 0.5, 0.25, 0.1, 0.03):
                trial = s.copy()
                trial[free] = np.clip(s[free] + scale * direction, lower[free], upper[free])
                f_trial = residual(trial)
                c_trial = float(f_trial @ f_trial)
                if c_trial < cost:
                    s, f, improved = trial, f_trial, True
                    relative = (cost - c_trial) / max(cost, 1e-300)
                    cost = c_trial
                    break
            if not improved or relative < 1e-8:
                break
        return s

    def screen(self, states) -> np.ndarray:
        """Unconstrained least-squares error of each state (Gram matrices:
        only the transient rows change from one state to the next)."""
        design, transient_rows = self.columns.design, self.transient_rows
        low_w, high_w, u_w, y_w, extra_w = self.low_w, self.high_w, self.u_w, self.y_w, self.extra_w
        fixed = np.setdiff1d(np.arange(u_w.size), transient_rows)
        A0 = design(states[0], low_w[fixed], high_w[fixed], u_w[fixed], extra_w[fixed])
        gram0, moment0, yy0 = A0.T @ A0, A0.T @ y_w[fixed], float(y_w[fixed] @ y_w[fixed])
        lt, ht, ut, et, yt = (low_w[transient_rows], high_w[transient_rows], u_w[transient_rows],
                              extra_w[transient_rows], y_w[transient_rows])
        yy = yy0 + float(yt @ yt)
        scores = []
        for s in states:
            At = design(s, lt, ht, ut, et)
            gram, moment = gram0 + At.T @ At, moment0 + At.T @ yt
            scale = np.sqrt(np.maximum(np.diag(gram), 1e-300))
            try:
                theta = np.linalg.solve(gram / np.outer(scale, scale), moment / scale)
                scores.append(yy - float(theta @ (moment / scale)))
            except LinAlgError:
                scores.append(np.inf)
        return np.array(scores)

    def estimated_state(self, candidates, demagnetised, from_settled: bool) -> tuple:
        """``(state, θ, active constraints, condition number, squared error)`` of the best fit from
        the best-screened ``candidates`` (and, with ``from_settled``, the state that fits the
        transient best for the weights of the rows whose state the input has fixed), each
        improved by alternating state steps and fits."""
        scores = self.screen(candidates)
        order = [int(j) for j in np.argsort(scores)[:3]]
        starts = [(candidates[j], None) for j in dict.fromkeys(order[:2] + [0])]
        settled = np.setdiff1d(np.arange(self.u_w.size), self.transient_rows)
        n_params = self.columns.n_hyst + self.extra_w.shape[1]
        if from_settled and settled.size >= max(3 * n_params, self.u_w.size // 10):
            # weights from the samples whose state the input has fixed, then
            # the states that fit the transient best for those weights
            A_s = self.columns.design(demagnetised, self.low_w[settled], self.high_w[settled], self.u_w[settled],
                                      self.extra_w[settled])
            try:
                theta_s = solve_lsi(A_s, self.y_w[settled], self.G, self.h, self.columns.names)[0]
                state = demagnetised.copy()
                for _ in range(3):
                    state = self.refine_state(state, self.design(state), theta_s)
                state = self.polish_state(state, theta_s)
                starts.insert(0, (state, theta_s))
            except IdentificationError:
                pass
        best = None
        failure = None
        for state, _ in starts:
            # a start (or a step) that leaves an operator constant makes its column
            # collinear with the offset: that start or step is dropped
            try:
                A, theta, active, condition, sse = self.solve(state)
            except IdentificationError as exc:
                failure = exc
                continue
            for _ in range(STATE_ITERATIONS):
                candidate = self.polish_state(self.refine_state(state, A, theta), theta)
                try:
                    A2, theta2, active2, condition2, sse2 = self.solve(candidate)
                except IdentificationError:
                    break
                if sse2 < sse * (1.0 - 1e-4):
                    state, A, theta, active, condition, sse = candidate, A2, theta2, active2, condition2, sse2
                else:
                    break
            if best is None or sse < best[-1]:
                best = (state, A, theta, active, condition, sse)
        if best is None:
            raise failure
        state, _, theta, active, condition, sse = best
        return state, theta, active, condition, sse


def _fit_through_transform(columns: _Columns, column_transform, record: _RecordArrays, states, refine: bool) -> tuple:
    """``(state, A, θ, active constraints, condition number, squared error)`` of the fit of ``record``
    whose hysteresis columns pass through ``column_transform``: the best of ``states``, and with
    ``refine`` its state refined through the stage for fixed weights, a few rounds."""
    names = columns.names
    low, high, u, y, rows, extra_matrix, G, h = (record.low, record.high, record.u, record.y, record.rows,
                                                 record.extra_matrix, record.G, record.h)

    def transformed(state):
        A_t = np.column_stack([columns.transformed_design(state, low, high, u, column_transform), extra_matrix])
        theta_t, active_t, condition_t = solve_lsi(A_t[rows], y[rows], G, h, names)
        e = y[rows] - A_t[rows] @ theta_t
        return state, A_t, theta_t, active_t, condition_t, float(e @ e)

    # the fitted samples up to the last that still remembers the state (the stage is causal: the
    # refinement needs no sample after them)
    remembers = np.flatnonzero(np.any(high > low, axis=1))
    remembered = np.arange(u.size)[rows]
    remembered = remembered[remembered <= (remembers[-1] if remembers.size else -1)]
    # the state estimated without the stage competes with the demagnetised one, and the better
    # one is refined through the stage; a state whose columns the stage makes dependent drops out
    fits, failure = [], None
    for state in states:
        try:
            fits.append(transformed(state))
        except IdentificationError as exc:
            failure = exc
    if not fits:
        raise failure
    best = min(fits, key=lambda fit: fit[-1])
    if refine:
        for _ in range(TRANSFORM_STATE_ROUNDS):
            try:
                # each operator's state for fixed weights, through the stage
                # (see :func:`refine_state_through_stage`)
                state = refine_state_through_stage(best[0], (y - best[1] @ best[2])[remembered], low, high,
                                                   columns.weights_of(best[2]), column_transform, remembered)
                candidate = transformed(state)
            except IdentificationError:
                break
            if not candidate[-1] < best[-1] * (1.0 - 1e-4):
                break
            best = candidate
    return best


def identify_jointly(records, *, thresholds_V, input_offset_V: float, initial_states, voltage_range_V,
                     model: str = "mpi", operator: str = "osp", column_transform=None, shared_extras=None,
                     own_extras=None, extra_nonnegative=(), fit_rows=None, min_slope_fraction: float = 0.01,
                     lagging_extras=(), history_floor_V: float = None, threshold_scales=None,
                     name: str = None, description: str = "") -> IdentificationResult:
    """Fit one model's linear parameters on several records of the same actuator.

    The hysteresis parameters (``a1``, ``a2``, the weights; thresholds and
    input offset given) and the coefficients of ``shared_extras`` are common
    to all records; each record has its own operator state before its first
    sample (given, e.g. estimated by :func:`identify` on the first record and
    by :func:`pysim.diagnosis.validation.score_on_record` on the others), its
    own sensor offset and the coefficients of its ``own_extras`` (a drift, a
    history's decaying transient).  Operators are tied as in :func:`identify`
    by their travel over all records together, so an operator that only a
    later record moves is fitted on its own; the fit is exact under the same
    invertibility constraints over ``voltage_range_V``.

    Parameters
    ----------
    records : sequence of (voltage_V, displacement_um)
        The records (µm for the displacement: a sensor gain that differs
        between records is corrected by the caller).
    thresholds_V, input_offset_V
        The model's thresholds and input shift.
    initial_states : sequence of array_like
        Operator state before each record's first sample.
    voltage_range_V : (float, float)
        Range over which the model must stay invertible (and that it reports).
    column_transform : callable, optional
        Applied to each record's hysteresis columns separately (a linear stage
        after the hysteresis, at rest at the record's first sample).
    shared_extras : sequence of dict, optional
        Per record, name → column; the same names on every record, one
        coefficient each for all records.
    own_extras : sequence of dict, optional
        Per record, name → column; names unique over the records, one
        coefficient each, fitted on its record only.
    extra_nonnegative : iterable of str
        Names of shared extras whose coefficients must be >= 0.
    lagging_extras : iterable of str
        Shared extras that trail the input, taken off the slope right after a step as in
        :func:`identify`.
    fit_rows : sequence of index arrays, optional
        Per record, the samples fitted (default: all).
    history_floor_V : float, optional
        The lowest voltage the actuator was driven to before any record (V): each given
        state is clipped to what a history above it leaves, as in :func:`identify`.
    threshold_scales : sequence of array_like or None, optional
        Per record, a factor on every threshold at each sample (as in :func:`identify`).

    Returns
    -------
    IdentificationResult
        For the first record: the model, its prediction and errors over that
        record (from its initial state), the shared extras' coefficients and
        the first record's own ones in ``extra_coefficients``; ``objective``
        is the error sum over all records.

    Raises
    ------
    IdentificationError
        When the records together cannot determine the parameters (dependent
        columns) or the constraints cannot hold.

    Examples
    --------
    >>> from pysim.core.model import HysteresisModel
    >>> r = (0.0, 25.0, 50.0, 75.0)
    >>> truth = HysteresisModel(0.0, 0.4, r, (0.0, 0.05, 0.05, 0.05), voltage_range_V=(0.0, 100.0))
    >>> low_sine = 30 + 25 * np.sin(np.linspace(0, 6 * np.pi, 1500))       # moves two operators
    >>> full_sine = 50 + 50 * np.sin(np.linspace(0, 6 * np.pi, 1500))      # moves all of them
    >>> states = ([40.0, 20.0, 0.0, 0.0], [50.0, 25.0, 0.0, 0.0])
    >>> records = [(v, truth.simulate(v, list(s)) + offset) for v, s, offset in
    ...            zip((low_sine, full_sine), states, (1.0, -0.5))]
    >>> fit = identify_jointly(records, thresholds_V=r, input_offset_V=0.0, initial_states=states,
    ...                        voltage_range_V=(0.0, 100.0))
    >>> np.round(fit.model.weights_um_per_V, 6).tolist(), round(fit.model.output_offset_um, 6)
    ([0.0, 0.05, 0.05, 0.05], 1.0)
    """
    if model not in ("mpi", "cpi"):
        raise IdentificationError(f"model must be 'mpi' or 'cpi', got {model!r}")
    records, shared, own, rows, shared_names, own_names = _joint_records(records, initial_states, shared_extras,
                                                                         own_extras, fit_rows)
    r = np.asarray(thresholds_V, dtype=float)
    cubic = model == "mpi"
    n_lin = 2 if cubic else 1
    lo, hi = (float(x) for x in voltage_range_V)

    travel = np.zeros(r.size)
    raw = []
    scales = [None] * len(records) if threshold_scales is None else list(threshold_scales)
    for index, ((v, _), state, k, scale) in enumerate(zip(records, initial_states, rows, scales)):
        history_floor = checked_history_floor(history_floor_V, v, f" of record {index}")
        low, high = operator_bounds(v, r, operator, input_offset_V, history_floor, scale)
        travel += operator_travel(low, high, k, v) if k.size > 1 else 0.0
        A, columns = regressors(v, r, operator, input_offset_V, cubic,
                                initial_state=np.clip(np.asarray(state, dtype=float), low[0], high[0]),
                                threshold_scale=scale)
        raw.append((A, columns))
    anchor, factor = _merge_plan(r, travel, hi - lo)
    groups = [i for i in range(r.size) if anchor[i] == i]
    column_of = {i: n_lin + j for j, i in enumerate(groups)}
    n_hyst = n_lin + len(groups) + 1

    n_shared, n_own = len(shared_names), len(own_names)
    layout = _JointLayout(n_lin, n_hyst, anchor, factor, column_of, column_transform, shared_names, own_names)
    blocks = [layout.block(index, A, columns, shared[index], own[index]) for index, (A, columns) in enumerate(raw)]
    targets = [y for _, y in records]
    n_params = n_hyst + n_shared + n_own
    names = ((["a1 u³"] if cubic else []) + ["a2 u"] + [f"operator {i + 1} (r = {r[i]:.4g} V)" for i in groups]
             + ["offset"] + [f"extra {key!r}" for key in shared_names] + own_names)
    effective_columns = [column_of.get(int(anchor[i]), -1) if anchor[i] >= 0 else -1 for i in range(r.size)]
    first_y = targets[0][rows[0]]
    mean_gain = float(np.ptp(first_y)) / (hi - lo) if hi > lo else 0.0
    G, h = _constraint_rows(_operator_template(r, operator, input_offset_V, (lo, hi)), cubic, n_params,
                            effective_columns, factor,
                            min_slope_fraction * mean_gain if min_slope_fraction >= 0 else None,
                            [n_hyst + j for j, key in enumerate(shared_names) if key in set(extra_nonnegative)],
                            [n_hyst + j for j, key in enumerate(shared_names) if key in set(lagging_extras)])
    A_all = np.vstack([block[k] for block, k in zip(blocks, rows)])
    y_all = np.concatenate([y[k] for y, k in zip(targets, rows)])
    theta, active, condition = solve_lsi(A_all, y_all, G, h, names)
    residual = y_all - A_all @ theta

    weights = _operator_weights(theta, anchor, factor, column_of)
    identified = HysteresisModel(
        a1=float(theta[0]) if cubic else 0.0, a2=float(theta[n_lin - 1]), thresholds_V=tuple(r),
        weights_um_per_V=tuple(weights), operator=operator, input_offset_V=input_offset_V,
        output_offset_um=float(theta[n_hyst - 1]), voltage_range_V=(lo, hi),
        name=name or f"identified_{model}", description=description)
    coefficients = {key: float(theta[n_hyst + j]) for j, key in enumerate(shared_names)}
    coefficients.update({key: float(theta[n_hyst + n_shared + own_names.index(key)]) for key in own[0]})
    # the first record's prediction: its hysteresis, the shared extras and its own ones (it has no own offset)
    keep = np.array(list(range(n_hyst + n_shared)) + [n_hyst + n_shared + own_names.index(key) for key in own[0]])
    prediction = blocks[0][:, keep] @ theta[keep]
    not_identifiable = tuple(int(i) for i in range(r.size) if r[i] > 0 and anchor[i] != i)
    return IdentificationResult(
        model=identified, warmup_samples=0, prediction_um=prediction,
        fit_slice=slice(int(rows[0][0]), int(rows[0][-1]) + 1),
        errors=error_measures(first_y, prediction[rows[0]]), constraints_active=active,
        extra_coefficients=coefficients, objective=float(residual @ residual),
        initial_state=np.asarray(initial_states[0], dtype=float), initial_state_estimated=False,
        not_identifiable_operators=not_identifiable,
        merged_into={int(i): int(anchor[i]) for i in not_identifiable if anchor[i] >= 0},
        operator_travel_V=travel, condition_number=condition,
        record_predictions_um=(prediction,) + tuple(block @ theta for block in blocks[1:]))


def _joint_records(records, initial_states, shared_extras, own_extras, fit_rows) -> tuple:
    """``(records, shared, own, rows, shared_names, own_names)`` of :func:`identify_jointly`, checked:
    the records as float arrays, each record's shared and own extras and fitted rows, the shared
    extras' names and the own coefficients' names (each later record's sensor offset first)."""
    records = [(np.asarray(v, dtype=float).ravel(), np.asarray(y, dtype=float).ravel()) for v, y in records]
    n_records = len(records)
    if n_records == 0 or len(initial_states) != n_records:
        raise IdentificationError(f"{n_records} records but {len(initial_states)} initial states")
    shared = list(shared_extras) if shared_extras is not None else [{} for _ in records]
    own = list(own_extras) if own_extras is not None else [{} for _ in records]
    rows = ([np.arange(v.size) for v, _ in records] if fit_rows is None
            else [np.unique(np.asarray(k, dtype=int).ravel()) for k in fit_rows])
    if not (len(shared) == len(own) == len(rows) == n_records):
        raise IdentificationError("shared_extras, own_extras and fit_rows need one entry per record")
    shared_names = list(shared[0])
    if any(list(extras) != shared_names for extras in shared):
        raise IdentificationError("shared_extras must name the same columns, in the same order, on every record")
    own_names = [f"record {k + 1} offset" for k in range(1, n_records)] + [key for extras in own for key in extras]
    if len(set(own_names)) != len(own_names) or set(own_names) & set(shared_names):
        raise IdentificationError("own_extras' names must be unique over the records and the shared extras")
    return records, shared, own, rows, shared_names, own_names


@dataclass(frozen=True)
class _JointLayout:
    """The columns of :func:`identify_jointly`'s design matrix: ``n_lin`` linear ones, the operators'
    (each operator's output added to the column of its ``anchor``, times its ``factor``;
    ``column_of`` an anchor's column), the offset (``n_hyst`` hysteresis columns in all, passed
    through ``column_transform`` when given), the shared extras (``shared_names``), then every
    record's own coefficients (``own_names``)."""
    n_lin: int
    n_hyst: int
    anchor: np.ndarray
    factor: np.ndarray
    column_of: dict
    column_transform: object
    shared_names: list
    own_names: list

    def block(self, index: int, A, columns, shared: dict, own: dict) -> np.ndarray:
        """Record ``index``'s rows of the joint design matrix, from its regressors ``A`` (their
        operator ``columns``) and its ``shared`` and ``own`` extras (name -> column): the own
        coefficients are zero but for its own sensor offset and extras."""
        n_lin, n_hyst, anchor, factor, column_of = (self.n_lin, self.n_hyst, self.anchor, self.factor,
                                                    self.column_of)
        column_transform, shared_names, own_names = self.column_transform, self.shared_names, self.own_names
        n_samples = A.shape[0]
        H = np.zeros((n_samples, n_hyst))
        H[:, :n_lin] = A[:, :n_lin]
        for i in range(len(anchor)):
            if anchor[i] >= 0 and columns[i] >= 0:
                H[:, column_of[anchor[i]]] += factor[i] * A[:, columns[i]]
        H[:, n_hyst - 1] = 1.0
        if column_transform is not None:
            H = np.asarray(column_transform(H), dtype=float)
        S = (np.column_stack([np.asarray(shared[key], dtype=float).ravel() for key in shared_names])
             if shared_names else np.zeros((n_samples, 0)))
        O = np.zeros((n_samples, len(own_names)))
        if index > 0:
            O[:, index - 1] = 1.0            # the record's own sensor offset
        for key, column in own.items():
            O[:, own_names.index(key)] = np.asarray(column, dtype=float).ravel()
        return np.column_stack([H, S, O])


def start_transient(voltage_V, displacement_um, **settings) -> int:
    """Samples at the start that no rate-independent state explains (a sensor or
    amplifier settling when the logger started), to leave out of a fit.

    The baseline is fitted on every sample with its initial state estimated;
    within the first 2 % of the record, the samples up to the last one whose
    residual exceeds ``START_OUTLIER`` times the RMS of the residual over the
    rest of the record are a start transient (0 when there is none): creep,
    lag or drift spread over the whole record, a settling logger does not.

    Examples
    --------
    >>> k = np.arange(3000)
    >>> v = 50 + 40 * np.sin(2 * np.pi * k / 500)
    >>> y = 0.5 * v + np.where(k < 10, -10.0, 0.0) + np.random.default_rng(0).normal(0, 0.01, k.size)
    >>> 10 <= start_transient(v, y, n_operators=4) <= 30
    True
    """
    v = np.asarray(voltage_V, dtype=float)
    y = np.asarray(displacement_um, dtype=float)
    return settling_samples(y - identify(v, y, require_excitation=False, **settings).prediction_um)


def settling_samples(residual_um) -> int:
    """The rule of :func:`start_transient` on the residual of a fit of every
    sample (for a caller that has that fit already).

    Examples
    --------
    >>> settling_samples(np.concatenate(([30.0, 12.0], 0.01 * np.sin(np.arange(998)))))
    2
    """
    residual = np.asarray(residual_um, dtype=float)
    n_head = max(residual.size // 50, 1)
    rest = residual[n_head:]
    scale = float(np.sqrt(np.mean((rest - np.mean(rest)) ** 2))) if rest.size else 0.0
    # the fit that includes the transient bends its initial state towards it, so a few samples after
    # the transient may be counted too: leaving out too many costs little, too few biases the fit
    large = np.flatnonzero(np.abs(residual[:n_head] - np.mean(rest)) > START_OUTLIER * max(scale, 1e-300))
    return int(large[-1] + 1) if large.size else 0
