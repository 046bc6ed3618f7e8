"""A general rate-independent model fitted on two records together: the arbiter
between a loop shape outside the MPI class and an effect.

When the MPI model fitted on one record leaves a second record unexplained,
the gap may be an effect, or the MPI model's loop shape on an input the first
record never showed (a Preisach actuator's minor loops are not congruent, so no
MPI model carries from one input to another).  One record cannot tell them
apart; two records of different inputs can, fitted *together* by a model that
holds every rate-independent hysteresis of the Preisach class: a
rate-independent actuator is fitted to the noise on both at once, a rate
effect is not (a lag widens the fast record's loops and not the slow one's).

The model is the discrete Preisach model written with play operators: every
Preisach operator is ``∫ ψ(r, F_r[v]) dr`` with ``F_r`` the play operator of
threshold ``r``; here ``N_THRESHOLDS`` one-sided play operators (the first is
the input itself), each through its own output function (``N_LEVELS + 2``
cubic B-splines over the range its output can take).  Every
weight enters linearly, so it is fitted by least squares (a small ridge
holds the weights of output levels a record never reaches at zero) on both
records at once, the second record with its own sensor offset and gain.
Beside it, a bank of Bouc-Wen operators (:mod:`pysim.diagnosis.bouc_wen`),
each with its weight: a Bouc-Wen actuator's minor loops neither close nor
wipe out older turning points, which no Preisach model holds.
Only samples where every play operator's output is fixed by the input and
the bank's state before the record has faded are used:
the state the actuator was in when a record began is never guessed
(:func:`pysim.identification.identify.operator_bounds`); the thresholds
reach as far as every record determines within its first
``1 - KNOWN_SHARE``.

Without a second record, the same model is fitted on the one record and
scored on its two halves (:func:`effects_on_halves`, :func:`fit_on_halves`):
one sensor for both (a jump of the sensor's zero is not an offset of a second
record), and every path run over the whole record.

An effect of the catalogue is then tried on the same model, fitted on both
records together with its shape parameter searched, each as the catalogue
runs it (one implementation of each stage):

- after the hysteresis, on every column (:class:`pysim.core.extended.OutputStages`):
  ``rate_dependence`` (a first-order lag ``1/(τ s + 1)``) and ``delay`` (``d >= 0``);
- ``creep`` as the catalogue admits it: non-negative weights on slow first-order
  modes' lag behind what drives them (:func:`pysim.diagnosis.candidates.mode_lags`,
  :func:`~pysim.diagnosis.candidates.creep_time_constants_s`), driven by the input
  or by the displacement, each record with its modes' free decay from its first
  sample (a history before it leaves them away from rest);
- before the hysteresis (:func:`pysim.core.input_stage.apply_input_stage`):
  ``rate_dependent_hysteresis`` (an input low-pass) and ``slew_limit``; the
  operators' paths are run again on the stage's output.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg
import scipy.optimize

from pysim.core.extended import OutputStages, first_order_section
from pysim.core.input_stage import apply_input_stage
from pysim.diagnosis.bouc_wen import N_OPERATORS, bouc_wen_bank, forgotten_from
from pysim.diagnosis.candidates import creep_time_constants_s, gain_sign, longest_delay_samples, mode_lags
from pysim.diagnosis.input_stages import slew_rate_grid
from pysim.diagnosis.residuals import record_noise_sigma
from pysim.diagnosis.rules import DECISIVE_SHARE, NOISE_FRACTION, TIE_FRACTION, UNEXPLAINED_LEVEL
from pysim.identification.identify import operator_bounds

__all__ = ["N_THRESHOLDS", "N_LEVELS", "HYSTERESIS_COLUMNS", "KNOWN_SHARE", "JointFit", "preisach_columns",
           "GeneralModelParts",
           "fit_both_records", "creep_on_both_records", "effects_on_both_records", "effects_on_halves",
           "fit_on_halves", "creep_on_halves", "verdict_on_both_records"]

#: Play operators of the general model (the first is the input itself).
N_THRESHOLDS = 16
#: Knots of each operator's output function (cubic B-splines).
N_LEVELS = 12
#: Columns of the model alone, before an effect's (the Preisach model's splines, then the Bouc-Wen bank).
HYSTERESIS_COLUMNS = N_THRESHOLDS * (N_LEVELS + 2) + N_OPERATORS
#: Share of every record, at its end, whose samples the thresholds must leave usable.
KNOWN_SHARE = 0.6
#: Ridge on the normalised normal equations: weights of output levels a record never reaches stay at 0.
RIDGE = 1e-7
#: The second record's sensor gain against the first's is searched within these bounds.
GAIN_BOUNDS = (0.5, 2.0)
#: Usable samples of each record on which an effect's shape parameter is searched.
SEARCH_ROWS = 8000
_PROBE_THRESHOLDS = 48


@dataclass
class JointFit:
    """The general rate-independent model (with an effect, or none) fitted on both records.

    Attributes
    ----------
    effect : str
        ``"none"`` or the catalogue's cause tried.
    parameter : float
        The effect's shape parameter (τ in s for ``rate_dependence``, the delay in s for
        ``delay``, the trend's degree for ``drift``); NaN otherwise.
    mse_sigma2 : tuple of float
        Each record's mean-square error over its usable samples, in the noise variance of ``noise_um``.
    noise_um : tuple of float
        Each record's noise σ, µm: from first differences of this fit's residual, or, for the fits
        of :meth:`GeneralModelParts.effects`, the one all of them are weighed against
        (:meth:`weighed_against`).
    samples : tuple of int
        Each record's usable samples (every operator fixed by the input).
    second_gain, second_offset_um : float
        The second record's sensor gain and offset against the first's (1 and 0 for one record's
        halves, which share its sensor).
    weights : ndarray
        The fitted weights (the hysteresis columns first, then the effect's).
    creep : dict or None
        For ``creep``: ``driven_by`` (``"input"`` or ``"displacement"``),
        ``time_constants_s`` and ``weights`` of its modes (µm/V of the input's
        lag, in the direction of the actuator's gain, or shares of the
        displacement, the instantaneous part ``1 - Σ shares``).
    """
    effect: str
    parameter: float
    mse_sigma2: tuple
    noise_um: tuple
    samples: tuple
    second_gain: float = 1.0
    second_offset_um: float = 0.0
    weights: np.ndarray = field(default=None, repr=False)
    creep: dict = None

    @property
    def excess_sigma2(self) -> float:
        """Mean-square error above the noise over both records, in noise variances (samples pooled)."""
        n = np.asarray(self.samples, dtype=float)
        if not np.all(np.isfinite(self.mse_sigma2)):
            return math.inf
        return float(np.sum(n * (np.asarray(self.mse_sigma2) - 1.0)) / np.sum(n))

    def weighed_against(self, noise_um) -> "JointFit":
        """The same fit with each record's error in the noise variance ``noise_um`` (µm, one per
        record) instead of the σ estimated from its own residual.

        Fits compared with each other are weighed against one noise per record: a stage that
        blurs a fast input adds a misfit at every sample, which its own σ (from the residual's
        differences) takes for noise, so the fit would look closer to its noise the worse it
        follows the record (an independent record with 1/f sensor noise: a fractional delay
        raised its own σ 3.4 times and was named at 0.11 σ² above the noise, against 3.5 σ² for
        the model alone).

        Examples
        --------
        >>> fit = JointFit("delay", 1e-4, (1.0, 2.0), (0.2, 0.1), (100, 100))
        >>> fit.weighed_against((0.1, 0.1)).mse_sigma2
        (4.0, 2.0)
        """
        mse = tuple(float(m) * (s / reference) ** 2 if math.isfinite(m) else float(m)
                    for m, s, reference in zip(self.mse_sigma2, self.noise_um, noise_um))
        return replace(self, mse_sigma2=mse, noise_um=tuple(float(s) for s in noise_um))


def _first_fixed_sample(low, high) -> np.ndarray:
    """For each operator, the first sample from which its output no longer depends on the state
    before the record (the record's length when it never gets there), from its outputs started at
    the lowest and the highest admissible state (:func:`operator_bounds`)."""
    fixed = np.isclose(low, high, rtol=0.0, atol=1e-9 * (1.0 + np.abs(low)))
    first = np.argmax(fixed, axis=0)
    return np.where(fixed.any(axis=0), first, low.shape[0])


def general_thresholds(records_V, known_share: float = KNOWN_SHARE) -> np.ndarray:
    """``N_THRESHOLDS`` thresholds (V) from 0 to the largest every record fixes within its first
    ``1 - known_share`` of samples.  A record whose input fixes no threshold that early (it wanders
    within a volt or two before it sweeps) counts them from the sample where it fixes its first.

    Examples
    --------
    >>> v = np.r_[np.linspace(0, 100, 200), np.linspace(100, 0, 200), np.linspace(0, 100, 200)]
    >>> r = general_thresholds([v])
    >>> r.size, float(r[0]), bool(0 < r[-1] <= 100)
    (16, 0.0, True)
    """
    span = max(float(np.ptp(v)) for v in records_V)
    probe = np.linspace(0.0, span, _PROBE_THRESHOLDS + 1)[1:]
    reach = span
    for v in records_V:
        first = _first_fixed_sample(*operator_bounds(v, probe, "osp", 0.0))
        fixed_early = probe[first <= (1.0 - known_share) * len(v)]
        if not fixed_early.size and first.min() < len(v):
            start = int(first.min())
            fixed_early = probe[first <= start + (1.0 - known_share) * (len(v) - start)]
        reach = min(reach, float(fixed_early.max()) if fixed_early.size else 0.0)
    if reach <= 0.0:
        reach = probe[0]
    return np.linspace(0.0, reach, N_THRESHOLDS)


def _cubic_splines(x, lo: float, hi: float) -> np.ndarray:
    """``(N, N_LEVELS + 2)`` uniform cubic B-splines over ``[lo, hi]``: they sum to one there and
    reproduce every cubic polynomial, so a smooth output function is approached far closer than
    by hat functions (error of order ``h⁴``), and a play operator's linear weight exactly."""
    h = (hi - lo) / (N_LEVELS - 1)
    centres = lo + h * np.arange(-1, N_LEVELS + 1)
    t = np.abs(x[:, None] - centres) / h
    return np.where(t < 1.0, (4.0 - 6.0 * t**2 + 3.0 * t**3) / 6.0,
                    np.where(t < 2.0, (2.0 - t) ** 3 / 6.0, 0.0))


def preisach_columns(voltage_V, thresholds_V, range_V) -> tuple:
    """``(A, first_usable)``: the general model's design matrix on one record (``N_THRESHOLDS``
    operators × ``N_LEVELS + 2`` cubic B-splines of each one's output) and the first sample from which
    every operator's output is fixed by the input (rows before it depend on the unknown state).

    Examples
    --------
    >>> v = np.r_[np.linspace(0, 10, 50), np.linspace(10, 0, 50)]
    >>> A, first = preisach_columns(v, [0.0, 2.0], (0.0, 10.0))
    >>> A.shape, np.allclose(A[:, :N_LEVELS + 2].sum(axis=1), 1.0), int(first)
    ((100, 28), True, 10)
    """
    low, first = _operator_paths(voltage_V, thresholds_V)
    return _spline_design(low, thresholds_V, range_V), first


def _operator_paths(voltage_V, thresholds_V) -> tuple:
    """Each operator's output started at its lowest admissible state, and the first sample from
    which every one of them is fixed by the input."""
    low, high = operator_bounds(np.asarray(voltage_V, dtype=float), np.asarray(thresholds_V, dtype=float),
                                "osp", 0.0)
    return low, int(_first_fixed_sample(low, high).max())


def _spline_design(operator_outputs, thresholds_V, range_V) -> np.ndarray:
    """The cubic B-splines of every operator's output over the range it can take."""
    lo, hi = range_V
    return np.hstack([_cubic_splines(operator_outputs[:, i], lo - threshold, hi)
                      for i, threshold in enumerate(np.asarray(thresholds_V, dtype=float))])


def _solve(gram, rhs, nonnegative=()):
    """Ridge least squares from the normal equations (normalised to a unit diagonal); the weights
    indexed by ``nonnegative`` are kept >= 0 (bounded least squares on the Cholesky factor)."""
    scale = np.sqrt(np.maximum(np.diag(gram), 1e-300))
    normalised = gram / np.outer(scale, scale) + RIDGE * np.eye(gram.shape[0])
    b = rhs / scale
    if len(nonnegative) == 0:
        return np.linalg.solve(normalised, b) / scale
    # ½ xᵀNx − xᵀb = ½ |Lᵀx − L⁻¹b|² + const with N = L Lᵀ; the scale is positive, so the bounds hold
    factor = np.linalg.cholesky(normalised)
    target = scipy.linalg.solve_triangular(factor, b, lower=True)
    lower = np.full(b.size, -np.inf)
    lower[list(nonnegative)] = 0.0
    x = scipy.optimize.lsq_linear(factor.T, target, bounds=(lower, np.inf), method="bvls").x
    return x / scale


def _fit(designs, displacements_um, effect, parameter, nonnegative=(), shared_sensor: bool = False) -> JointFit:
    """Fit the weights on both records (each design and displacement on the rows used), the second
    with its own sensor gain and offset, or, with ``shared_sensor`` (two parts of one record), one
    offset for both (``nonnegative``: columns whose weights stay >= 0)."""
    A1, A2 = (np.ascontiguousarray(A) for A in designs)
    y1, y2 = displacements_um
    # the normal equations' parts, computed once: for a fixed gain g of the second record,
    # [A1 1 0; g A2 0 1] [w; c1; c2] = [y1; y2] is linear in the weights and both offsets
    G1, G2 = A1.T @ A1, A2.T @ A2
    s1, s2 = A1.sum(axis=0), A2.sum(axis=0)
    b1, b2 = A1.T @ y1, A2.T @ y2
    n1, n2 = float(y1.size), float(y2.size)
    m = G1.shape[0]

    if shared_sensor:
        # one sensor: [A1 1; A2 1] [w; c] = [y1; y2], one offset and no gain to search
        gram = np.zeros((m + 1, m + 1))
        gram[:m, :m] = G1 + G2
        gram[:m, m] = gram[m, :m] = s1 + s2
        gram[m, m] = n1 + n2
        weights = _solve(gram, np.r_[b1 + b2, y1.sum() + y2.sum()], nonnegative)
        gain, offsets = 1.0, (weights[-1], weights[-1])
        weights = weights[:-1]
    else:
        yy = float(y1 @ y1 + y2 @ y2)

        def normal_equations(gain):
            gram = np.zeros((m + 2, m + 2))
            gram[:m, :m] = G1 + gain**2 * G2
            gram[:m, m], gram[:m, m + 1] = s1, gain * s2
            gram[m, :m], gram[m + 1, :m] = s1, gain * s2
            gram[m, m], gram[m + 1, m + 1] = n1, n2
            return gram, np.r_[b1 + gain * b2, y1.sum(), y2.sum()]

        def squared_error(gain):
            # from the normal equations alone: |y - B w|² = y'y - 2 w'B'y + w'B'B w
            gram, rhs = normal_equations(gain)
            w = _solve(gram, rhs, nonnegative)
            return yy - 2.0 * w @ rhs + w @ gram @ w

        # the gain profiled out: the weights follow it exactly (alternating the two converges slowly,
        # as the weights of both records compromise at every pass)
        gain = float(scipy.optimize.minimize_scalar(squared_error, bounds=GAIN_BOUNDS, method="bounded",
                                                    options={"xatol": 1e-5}).x)
        weights = _solve(*normal_equations(gain), nonnegative)
        offsets, weights = (weights[-2], weights[-1]), weights[:-2]
    e1 = y1 - A1 @ weights - offsets[0]
    e2 = y2 - gain * (A2 @ weights) - offsets[1]
    noise = (record_noise_sigma(e1, y1), record_noise_sigma(e2, y2))
    mse = tuple(float(np.mean(e**2) / s**2) for e, s in zip((e1, e2), noise))
    # y2 = g (A2 w + c1) + (c2 - g c1): the second record's offset against the first's, scaled
    return JointFit(effect, parameter, mse, noise, (y1.size, y2.size), gain, float(offsets[1] - gain * offsets[0]),
                    weights)


#: Effects tried before the hysteresis on the general model, with the catalogue's input stage that runs each.
INPUT_EFFECTS = {"rate_dependent_hysteresis": "lowpass", "slew_limit": "slew_limit"}


class GeneralModelParts:
    """Two records prepared once for the general model (thresholds, operator outputs, usable rows),
    or one record's two halves (:meth:`halves`): the parts the model is scored on, each a record's
    rows.  The model alone and with creep are kept once fitted: asking for creep and then for every
    effect fits creep once.  Parameters as :func:`fit_both_records` (each record's voltage, V,
    displacement, µm, and sample period, s).

    Examples
    --------
    One record's halves, fitted with creep and then with every effect: the creep fit is made once.

    >>> rng = np.random.default_rng(4)
    >>> t = np.arange(6000) / 1000.0
    >>> v = np.repeat(rng.uniform(5, 95, 12), 500)
    >>> y = 0.2 * operator_bounds(v, [0.0, 10.0, 25.0], "osp", 0.0)[0].sum(axis=1) + rng.normal(0, 0.05, t.size)
    >>> parts = GeneralModelParts.halves(v, y, 1e-3)
    >>> parts.fit("creep").weights is parts.effects()["creep"].weights
    True
    """

    def __init__(self, v1, y1, period1_s, v2, y2, period2_s):
        self._prepare(((v1, y1, period1_s), (v2, y2, period2_s)), KNOWN_SHARE, halves=False)

    @classmethod
    def halves(cls, voltage_V, displacement_um, period_s, scored_from: int = 0):
        """One record, scored on its first and second half: one sensor (one offset, no second gain),
        and the operators' and the Bouc-Wen bank's paths run over the whole record, so the second half
        starts where the first left them (as the actuator did) and only the record's start is unknown.
        The samples before ``scored_from`` (a start whose displacement is not to be fitted: a sensor
        settling) are not scored, but their input moves the operators as every other sample's does."""
        both = cls.__new__(cls)
        # the thresholds leave each half KNOWN_SHARE of its samples, the first half too
        both._prepare(((voltage_V, displacement_um, period_s),), 1.0 - (1.0 - KNOWN_SHARE) / 2.0, halves=True,
                      scored_from=int(scored_from))
        return both

    def _prepare(self, records, known_share, halves, scored_from=0):
        self.v = tuple(np.asarray(v, dtype=float) for v, _, _ in records)
        self.y = tuple(np.asarray(y, dtype=float) for _, y, _ in records)
        self.T = tuple(float(T) for _, _, T in records)
        self.shared_sensor = halves
        self.thresholds_V = general_thresholds(self.v, known_share)
        self.range_V = (min(float(v.min()) for v in self.v), max(float(v.max()) for v in self.v))
        built = [preisach_columns(v, self.thresholds_V, self.range_V) for v in self.v]
        self.A = tuple(self._with_bouc_wen(a, v) for (a, _), v in zip(built, self.v))
        # rows where every play operator is fixed by the input and the Bouc-Wen bank has forgotten
        # its state before the record, as far as that leaves known_share of the record
        usable = [np.arange(max(first, min(forgotten_from(v, self.range_V), int((1.0 - known_share) * v.size)),
                                scored_from), v.size)
                  for (_, first), v in zip(built, self.v)]
        if halves:
            half = scored_from + (self.v[0].size - scored_from) // 2
            if min(np.count_nonzero(usable[0] < half), np.count_nonzero(usable[0] >= half)) < self.A[0].shape[1]:
                # the input fixes the operators too late for the record's first half to score a model of
                # this many columns (independent seeds 38 and 1003: steps that turn back only after the
                # middle, not a sample of the first half usable): the halves of the usable samples instead
                half = int(usable[0][usable[0].size // 2]) if usable[0].size else half
            self.record_of = (0, 0)
            self.usable = (usable[0][usable[0] < half], usable[0][usable[0] >= half])
            part_samples = (half - scored_from, self.v[0].size - half)
        else:
            self.record_of = (0, 1)
            self.usable = tuple(usable)
            part_samples = tuple(v.size for v in self.v)
        self.part_s = tuple(n * self.T[r] for n, r in zip(part_samples, self.record_of))
        # creep may only trail the input in the direction of the actuator's gain (the catalogue's
        # admissible creep: non-negative weights on the modes' lag behind the input)
        self.gain_sign = gain_sign(self.v[0], self.y[0])
        self.creep_time_constants_s = creep_time_constants_s(min(part_samples), max(self.T))
        self._plain = {}            # the model alone, on the search rows and on all (creep starts from it)
        self._crept = {}            # the model with creep, likewise

    @property
    def scorable(self) -> bool:
        """Whether every part holds at least as many usable samples as the model alone has columns:
        a part with fewer is fitted by the others' weights and scores nothing of its own (a record
        whose input never fixes the operators' states leaves none)."""
        return min(rows.size for rows in self.usable) >= self.A[0].shape[1]

    def _with_bouc_wen(self, preisach_design, voltage_V, rows=slice(None)) -> np.ndarray:
        """The Preisach columns (on ``rows``) with the Bouc-Wen bank's outputs beside them."""
        return np.hstack([preisach_design, bouc_wen_bank(voltage_V, self.range_V)[rows]])

    def _rows(self, search):
        # the shape parameter's search weighs every part on at most SEARCH_ROWS usable samples
        # (every k-th: the whole part's character); the fit found is made on all of them
        return ([rows[::max(1, rows.size // SEARCH_ROWS)] for rows in self.usable] if search else self.usable)

    def _on_rows(self, designs, rows, effect, parameter, nonnegative=()) -> JointFit:
        """Fit on each part's rows of its record's design (``designs``: one per record)."""
        return _fit([designs[r][k] for r, k in zip(self.record_of, rows)],
                    [self.y[r][k] for r, k in zip(self.record_of, rows)], effect, parameter, nonnegative,
                    self.shared_sensor)

    def fit(self, effect="none", parameter=float("nan"), search=False) -> JointFit:
        if effect == "none":
            if search not in self._plain:
                self._plain[search] = self._on_rows(self.A, self._rows(search), "none", float("nan"))
            return self._plain[search]
        rows = self._rows(search)
        if effect == "rate_dependence":
            designs = [OutputStages([first_order_section(parameter, T)]).apply_to_columns(A)
                       for A, T in zip(self.A, self.T)]
        elif effect == "delay":
            designs = [OutputStages(delay_samples=max(parameter / T, 0.0)).apply_to_columns(A)
                       for A, T in zip(self.A, self.T)]
        elif effect == "creep":
            if search not in self._crept:
                self._crept[search] = self._creep(rows)
            return self._crept[search]
        elif effect == "drift":
            return self._drift(rows)
        elif effect in INPUT_EFFECTS:
            # the operators see the stage's output: their paths (and the rows they fix) change
            staged = [apply_input_stage(INPUT_EFFECTS[effect], parameter, v, T) for v, T in zip(self.v, self.T)]
            paths = [_operator_paths(x, self.thresholds_V) for x in staged]
            kept = [used[used >= paths[r][1]] for r, used in zip(self.record_of, rows)]
            if min(k.size / u.size for k, u in zip(kept, rows)) < KNOWN_SHARE:
                # a stage so slow that the operators' paths stay unknown on most of a part: not a fit
                return JointFit(effect, parameter, (math.inf, math.inf), (math.nan, math.nan),
                                tuple(k.size for k in kept))
            designs = [self._with_bouc_wen(_spline_design(paths[r][0][k], self.thresholds_V, self.range_V),
                                           staged[r], k) for r, k in zip(self.record_of, kept)]
            return _fit(designs, [self.y[r][k] for r, k in zip(self.record_of, kept)], effect, parameter,
                        shared_sensor=self.shared_sensor)
        else:
            raise ValueError(f"the general model holds no effect {effect!r}")
        return self._on_rows(designs, rows, effect, parameter)

    def _creep(self, rows, rounds: int = 3) -> JointFit:
        """Creep as the catalogue admits it: non-negative weights on slow modes' lag behind what
        drives them, driven by the input (in the direction of the actuator's gain) or by the
        displacement (the hysteresis output of the fit before, refined for a few rounds); the
        better of the two."""
        m = self.A[0].shape[1]
        nonnegative = tuple(range(m, m + self.creep_time_constants_s.size))

        taus = self.creep_time_constants_s
        # each record may begin with its modes away from rest (a history before it): each mode's
        # free decay from the record's first sample, a column of that record alone, free in sign
        decays = [np.exp(-np.arange(v.size)[:, None] * T / taus) for v, T in zip(self.v, self.T)]
        starts = [np.hstack([decay if r == k else np.zeros_like(decay) for k in range(len(self.v))])
                  for r, decay in enumerate(decays)]

        def with_modes(drives, driven_by):
            designs = [np.hstack([A, mode_lags(x, taus, T), start])
                       for A, x, T, start in zip(self.A, drives, self.T, starts)]
            fit = self._on_rows(designs, rows, "creep", float("nan"), nonnegative)
            return replace(fit, creep={"driven_by": driven_by, "time_constants_s": tuple(taus.tolist()),
                                       # the bounded solve may leave -1e-18 where a bound holds
                                       "weights": tuple(np.maximum(fit.weights[m:m + taus.size], 0.0).tolist())})

        best = with_modes([self.gain_sign * v for v in self.v], "input")
        fit = self.fit("none", search=rows is not self.usable)
        for _ in range(rounds):
            fit = with_modes([A @ fit.weights[:m] for A in self.A], "displacement")
            if fit.excess_sigma2 < best.excess_sigma2:
                best = fit
        return best

    def _drift(self, rows) -> JointFit:
        """A smooth trend in time, as the catalogue admits drift: a polynomial of degree 1, or 2 when
        that leaves at most four fifths of what the line leaves above the noise.  Two records were
        taken at other times, so each has its own trend from its first sample (columns of that record
        alone); a record's two halves share one trend over the whole record."""
        def with_trend(degree):
            designs = []
            for r, (A, v) in enumerate(zip(self.A, self.v)):
                time_share = np.arange(v.size) / max(v.size - 1, 1)
                own = np.column_stack([time_share**k for k in range(1, degree + 1)])
                blocks = [own if k == r else np.zeros_like(own) for k in range(len(self.v))]
                designs.append(np.hstack([A] + blocks))
            return self._on_rows(designs, rows, "drift", float(degree))

        line, curve = with_trend(1), with_trend(2)
        return curve if curve.excess_sigma2 <= 0.8 * line.excess_sigma2 else line

    def searched(self, effect, grid) -> JointFit:
        """The effect with its shape parameter searched on the ascending log-spaced ``grid``, then refined."""
        grid = np.asarray(grid, dtype=float)
        # every trial weighed against the model alone's noise on the same rows (see weighed_against)
        noise = self.fit(search=True).noise_um

        def score(parameter):
            # (a stage that leaves the operators' paths unknown scores as a very poor fit, not inf)
            return min(self.fit(effect, parameter, search=True).weighed_against(noise).excess_sigma2, 1e12)

        scores = [score(p) for p in grid]
        k = int(np.argmin(scores))
        lo, hi = math.log(grid[max(k - 1, 0)]), math.log(grid[min(k + 1, grid.size - 1)])
        found = scipy.optimize.minimize_scalar(lambda x: score(math.exp(x)), bounds=(lo, hi), method="bounded",
                                               options={"xatol": 0.05})
        return self.fit(effect, math.exp(found.x) if found.fun < scores[k] else grid[k])

    def _delay_grid_s(self) -> np.ndarray:
        """Delays (s) tried: from a tenth of a sample to the longest the first record's own delay
        search reaches (:func:`pysim.diagnosis.candidates.longest_delay_samples` of the shortest
        part), at most a factor of two apart.  A shorter reach (ten samples, as before) left an
        independent seed's delay of 20 samples to a rate-dependent hysteresis, which named it."""
        period = max(self.T)
        longest = longest_delay_samples(int(min(self.part_s) / period)) * period
        lowest = 0.1 * min(self.T)
        count = max(8, int(math.ceil(math.log2(longest / lowest))) + 1)
        return np.geomspace(lowest, longest, count)

    def effects(self, stop_at_noise: bool = False) -> dict:
        """The model alone (``"none"``) and with each effect it holds, as
        :func:`effects_on_both_records` (``stop_at_noise`` likewise)."""
        alone = self.fit()
        if stop_at_noise and _within_noise(alone):
            return {"none": alone}
        period = max(self.T)
        shortest = min(self.part_s)
        time_constants_s = np.geomspace(0.05 * min(self.T), min(300.0 * period, shortest / 20), 8)
        rates = slew_rate_grid(list(zip(self.v, self.T)), 8)
        fits = {"none": alone,
                "rate_dependence": self.searched("rate_dependence", time_constants_s),
                "delay": self.searched("delay", self._delay_grid_s()),
                "creep": self.fit("creep"),
                "drift": self.fit("drift"),
                "rate_dependent_hysteresis": self.searched("rate_dependent_hysteresis", time_constants_s)}
        if rates.size:
            fits["slew_limit"] = self.searched("slew_limit", rates)
        # one noise per record for all of them: the least any fit's residual shows, as for the MPI
        # models (pysim.diagnosis.residuals.models_noise_sigma)
        least = tuple(min(f.noise_um[r] for f in fits.values()) for r in range(len(alone.noise_um)))
        return {c: f.weighed_against(least) for c, f in fits.items()}


def fit_both_records(v1, y1, period1_s, v2, y2, period2_s) -> JointFit:
    """The general rate-independent model fitted on both records together.

    Parameters
    ----------
    v1, y1, v2, y2 : array_like
        Voltage (V) and displacement (µm) of the two records.
    period1_s, period2_s : float
        Their sample periods, s.

    Returns
    -------
    JointFit

    Examples
    --------
    A rate-independent actuator outside the MPI class (a smooth density of play
    operators, each through a quadratic output) is fitted to its noise on two
    inputs at once:

    >>> rng = np.random.default_rng(1)
    >>> t = np.arange(4000) / 1000.0
    >>> v1 = 50 + 50 * np.sin(2 * np.pi * 1.0 * t) * np.exp(-t / 4)
    >>> v2 = 50 + 45 * np.sin(2 * np.pi * 3.0 * t) * np.sin(2 * np.pi * 0.4 * t)
    >>> def actuator(v):
    ...     r = np.arange(0.0, 40.0, 0.5)
    ...     low, _ = operator_bounds(v, r, "osp", 0.0)
    ...     return (np.exp(-r / 20) * (0.01 * low + 1e-4 * low**2)).sum(axis=1)
    >>> fit = fit_both_records(v1, actuator(v1) + rng.normal(0, 0.1, t.size), 1e-3,
    ...                        v2, actuator(v2) + rng.normal(0, 0.1, t.size), 1e-3)
    >>> bool(max(fit.mse_sigma2) < 1.0 + NOISE_FRACTION)
    True
    """
    return GeneralModelParts(v1, y1, period1_s, v2, y2, period2_s).fit()


def creep_on_both_records(v1, y1, period1_s, v2, y2, period2_s) -> JointFit:
    """The general rate-independent model with creep, fitted on both records together.

    Creep's modes are estimated here on a hysteresis of any rate-independent
    shape, so an MPI model's shape error cannot pass for creep in them, as it
    can in a creep fitted with the MPI weights on one record (fast modes that
    bend the loops the MPI model misses, and then bend every new input's
    loops the wrong way).  ``fit.creep`` holds the modes found.

    Parameters
    ----------
    v1, y1, period1_s, v2, y2, period2_s
        Each record's voltage (V), displacement (µm) and sample period (s).

    Returns
    -------
    JointFit

    Examples
    --------
    Creep of 4 % with 30 ms and 4 % with 0.6 s after a hysteresis, on two inputs:

    >>> import scipy.signal
    >>> rng = np.random.default_rng(4)
    >>> t = np.arange(6000) / 1000.0
    >>> v1 = 50 + 50 * np.sin(2 * np.pi * 0.5 * t) * np.exp(-t / 8)
    >>> v2 = np.repeat(rng.uniform(0, 100, 20), 300)
    >>> def actuator(v):
    ...     r = np.arange(0.0, 40.0, 0.5)
    ...     h = (np.exp(-r / 20) * (0.01 * operator_bounds(v, r, "osp", 0.0)[0])).sum(axis=1)
    ...     out = 0.92 * h
    ...     for tau in (0.03, 0.6):
    ...         b, a = scipy.signal.bilinear([1.0], [tau, 1.0], 1000.0)
    ...         out += 0.04 * scipy.signal.lfilter(b, a, h, zi=scipy.signal.lfilter_zi(b, a) * h[0])[0]
    ...     return out
    >>> fit = creep_on_both_records(v1, actuator(v1) + rng.normal(0, 0.02, t.size), 1e-3,
    ...                             v2, actuator(v2) + rng.normal(0, 0.02, t.size), 1e-3)
    >>> fit.creep["driven_by"], round(sum(fit.creep["weights"]), 2)
    ('displacement', 0.08)
    """
    return GeneralModelParts(v1, y1, period1_s, v2, y2, period2_s).fit("creep")


def _within_noise(fit: JointFit) -> bool:
    """The fit leaves each record within ``NOISE_FRACTION`` σ² of its noise: no effect can be named."""
    return max(fit.mse_sigma2) <= 1.0 + NOISE_FRACTION


def effects_on_both_records(v1, y1, period1_s, v2, y2, period2_s, *, stop_at_noise: bool = False) -> dict:
    """The general rate-independent model alone (``"none"``) and with each effect it holds
    (``rate_dependence``, ``delay``, ``creep``, ``rate_dependent_hysteresis`` and, when an input
    moves, ``slew_limit``), each fitted on both records together.

    Parameters
    ----------
    v1, y1, period1_s, v2, y2, period2_s
        Each record's voltage (V), displacement (µm) and sample period (s).
    stop_at_noise : bool
        Return the model alone when it fits each record within ``NOISE_FRACTION`` σ² of its noise:
        :func:`verdict_on_both_records` then says ``"none"`` whatever the effects would fit, so
        they are not fitted (each costs as much as the model alone, several times over).

    Returns
    -------
    dict of str to JointFit

    Examples
    --------
    A lag of 2 ms after the same hysteresis is what only the lag brings to the noise:

    >>> import scipy.signal
    >>> rng = np.random.default_rng(2)
    >>> t = np.arange(4000) / 1000.0
    >>> v1 = 50 + 50 * np.sin(2 * np.pi * 1.0 * t)
    >>> v2 = 50 + 45 * np.sin(2 * np.pi * 15.0 * t) * np.sin(2 * np.pi * 0.4 * t)
    >>> def hysteresis(v):
    ...     r = np.arange(0.0, 40.0, 0.5)
    ...     low, _ = operator_bounds(v, r, "osp", 0.0)
    ...     return (np.exp(-r / 20) * (0.01 * low + 1e-4 * low**2)).sum(axis=1)
    >>> def actuator(v):
    ...     lag = ([[-500.0]], [[500.0]], [[1.0]], [[0.0]])        # 1/(τ s + 1), τ = 2 ms
    ...     h = hysteresis(v)
    ...     return scipy.signal.lsim(lag, h, t, X0=[h[0]])[1]
    >>> fits = effects_on_both_records(v1, actuator(v1) + rng.normal(0, 0.02, t.size), 1e-3,
    ...                                v2, actuator(v2) + rng.normal(0, 0.02, t.size), 1e-3)
    >>> min(fits, key=lambda c: fits[c].excess_sigma2), abs(fits["rate_dependence"].parameter - 2e-3) < 3e-4
    ('rate_dependence', True)
    >>> bool(fits["none"].excess_sigma2 > 10 * fits["rate_dependence"].excess_sigma2)
    True

    Without the lag, and with more noise than the 16 thresholds miss of this hysteresis's 80, the
    model alone fits both records to their noise, and no effect is fitted:

    >>> sorted(effects_on_both_records(v1, hysteresis(v1) + rng.normal(0, 0.1, t.size), 1e-3,
    ...                                v2, hysteresis(v2) + rng.normal(0, 0.1, t.size), 1e-3,
    ...                                stop_at_noise=True))
    ['none']
    """
    return GeneralModelParts(v1, y1, period1_s, v2, y2, period2_s).effects(stop_at_noise)


def effects_on_halves(voltage_V, displacement_um, period_s, *, stop_at_noise: bool = False) -> dict:
    """:func:`effects_on_both_records` on one record, scored on its first and second half as on two
    records.

    Without a second record, the general model can still say whether one rate-independent actuator
    explains the record: fitted on the whole record and scored on each half, a hysteresis outside
    the MPI class is fitted to the noise on each.  The record has one sensor (one offset, no gain
    of the second half against the first: a jump of the sensor is not explained away), and every
    path runs over the whole record (the second half starts where the first left the actuator);
    only samples whose operator outputs the input fixes are used.

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record.
    period_s : float
        Its sample period, s.
    stop_at_noise : bool
        As for :func:`effects_on_both_records`.

    Returns
    -------
    dict of str to JointFit

    Examples
    --------
    A rate-independent actuator outside the MPI class (a smooth density of play operators, each
    through a quadratic output), on one multisine record:

    >>> rng = np.random.default_rng(5)
    >>> t = np.arange(8000) / 1000.0
    >>> v = 50 + 30 * np.sin(2 * np.pi * 0.7 * t) + 18 * np.sin(2 * np.pi * 2.3 * t)
    >>> r = np.arange(0.0, 40.0, 0.5)
    >>> low, _ = operator_bounds(v, r, "osp", 0.0)
    >>> y = (np.exp(-r / 20) * (0.01 * low + 1e-4 * low**2)).sum(axis=1) + rng.normal(0, 0.1, t.size)
    >>> fits = effects_on_halves(v, y, 1e-3, stop_at_noise=True)
    >>> verdict_on_both_records(fits, "the record's two halves")["cause"]
    'none'

    The same record with the sensor's zero moved by 0.5 µm (5 σ) in its second half is not:

    >>> y[t.size // 2:] += 0.5
    >>> fits = effects_on_halves(v, y, 1e-3, stop_at_noise=True)
    >>> verdict_on_both_records(fits, "the record's two halves")["cause"] == "none"
    False
    """
    return GeneralModelParts.halves(voltage_V, displacement_um, period_s).effects(stop_at_noise)


def fit_on_halves(voltage_V, displacement_um, period_s) -> JointFit:
    """The general rate-independent model alone, fitted on one record and scored on its two halves
    (as :func:`effects_on_halves`).

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record: voltage (V) and displacement (µm).
    period_s : float
        Its sample period, s.

    Returns
    -------
    JointFit

    Examples
    --------
    >>> rng = np.random.default_rng(3)
    >>> t = np.arange(6000) / 1000.0
    >>> v = 50 + 45 * np.sin(2 * np.pi * 1.3 * t) * np.cos(2 * np.pi * 0.21 * t)
    >>> y = 0.2 * operator_bounds(v, [0.0, 10.0, 25.0], "osp", 0.0)[0].sum(axis=1)
    >>> fit = fit_on_halves(v, y + rng.normal(0, 0.05, t.size), 1e-3)
    >>> bool(max(fit.mse_sigma2) < 1.0 + NOISE_FRACTION), fit.samples[0] < fit.samples[1]
    (True, True)
    """
    return GeneralModelParts.halves(voltage_V, displacement_um, period_s).fit()


def creep_on_halves(voltage_V, displacement_um, period_s) -> JointFit:
    """The general rate-independent model with creep, fitted on one record and scored on its two
    halves (as :func:`effects_on_halves`): :func:`creep_on_both_records` without a second record.

    Where a hysteresis of any rate-independent shape is held, creep's modes take only what that
    shape cannot: a named creep to which they give no weight at all was the MPI model's loop
    shape.  Parameters as :func:`fit_on_halves`; returns a :class:`JointFit` whose ``creep`` holds
    the modes found (time constants, s, and non-negative weights).

    Examples
    --------
    Creep of 6 % with 0.2 s on a hysteresis, and the same hysteresis without it:

    >>> import scipy.signal
    >>> rng = np.random.default_rng(5)
    >>> t = np.arange(8000) / 1000.0
    >>> v = np.repeat(rng.uniform(5, 95, 16), 500)
    >>> h = 0.2 * operator_bounds(v, [0.0, 10.0, 25.0], "osp", 0.0)[0].sum(axis=1)
    >>> b, a = scipy.signal.bilinear([1.0], [0.2, 1.0], 1000.0)
    >>> crept = 0.94 * h + 0.06 * scipy.signal.lfilter(b, a, h, zi=scipy.signal.lfilter_zi(b, a) * h[0])[0]
    >>> noise = rng.normal(0, 0.02, t.size)
    >>> round(sum(creep_on_halves(v, crept + noise, 1e-3).creep["weights"]), 2)
    0.06
    >>> max(creep_on_halves(v, h + noise, 1e-3).creep["weights"]) < 1e-3
    True
    """
    return GeneralModelParts.halves(voltage_V, displacement_um, period_s).fit("creep")


def verdict_on_both_records(fits: dict, records: str = "both records") -> dict:
    """What the general model says of two records that the MPI diagnosis leaves unexplained, or
    whose named cause's MPI model misses the second record.

    - ``"none"`` when the general rate-independent model alone fits *each* record
      within ``NOISE_FRACTION`` σ² of its noise: the gap was the MPI model's loop shape;
    - a cause when its effect on the general model removes ``DECISIVE_SHARE`` or more of what
      the model alone leaves above the noise over both records (and at least 1 σ², or
      ``NOISE_FRACTION`` σ² when it brings each record within ``NOISE_FRACTION`` of its noise),
      lowering each record's error, or keeping within its noise a record the model alone fits
      there (an input stage, which runs every operator's path again, only when it leaves no
      record more than ``UNEXPLAINED_LEVEL`` σ² above its noise); causes within
      ``TIE_FRACTION`` of what the best leaves above the noise, or within ``NOISE_FRACTION`` σ² of
      it, are named with it;
    - ``None`` otherwise (the verdict stays ``unexplained``).

    Parameters
    ----------
    fits : dict of str to JointFit
        :func:`effects_on_both_records`'s (or :func:`effects_on_halves`') result.
    records : str
        What the fits were made on, as the sentence names it.

    Returns
    -------
    dict
        ``cause`` (``"none"``, a cause or None), ``causes`` (tuple), ``left_sigma2`` (what each
        fit leaves above the noise over both records, σ²) and ``sentence`` (the evidence).

    Examples
    --------
    >>> def fit(effect, *mse):
    ...     return JointFit(effect, float("nan"), mse, (0.1, 0.1), (1000, 1000))
    >>> fits = {"none": fit("none", 9.0, 17.0), "rate_dependence": fit("rate_dependence", 1.1, 1.5),
    ...         "delay": fit("delay", 1.2, 1.7), "creep": fit("creep", 5.0, 9.0)}
    >>> verdict_on_both_records(fits)["causes"]
    ('rate_dependence', 'delay')
    >>> verdict_on_both_records({c: fit(c, 1.05, 1.1) for c in fits})["cause"]
    'none'
    >>> print(verdict_on_both_records({**fits, "none": fit("none", 2.0, 2.2)})["cause"])
    None

    Near the noise, an effect that brings each record to it is named with less removed:

    >>> near = {**fits, "none": fit("none", 1.9, 1.2), "creep": fit("creep", 1.0, 1.02)}
    >>> verdict_on_both_records(near)["causes"]
    ('creep',)

    A stage the records cannot fit is said so, not scored as an infinite error:

    >>> slow = fit("rate_dependent_hysteresis", float("inf"), float("inf"))
    >>> sentence = verdict_on_both_records({**fits, "none": fit("none", 2.0, 2.2),
    ...                                     "rate_dependent_hysteresis": slow})["sentence"]
    >>> print(sentence.split(", with ")[-1].split(")")[0])
    rate_dependent_hysteresis no fit: so slow a stage leaves the operators' paths unknown
    """
    base = fits["none"]
    left = {c: f.excess_sigma2 for c, f in fits.items()}
    described = (f"a general rate-independent model (a discrete Preisach model of {N_THRESHOLDS} play operators, "
                 f"each through its own output function, and {N_OPERATORS} Bouc-Wen operators) fitted on {records} "
                 "together leaves "
                 + " and ".join(f"{m:.3g} σ²" for m in base.mse_sigma2) + " of their noise")
    if _within_noise(base):
        return {"cause": "none", "causes": (), "left_sigma2": left,
                "sentence": f"{described}: one rate-independent actuator explains both, so what the MPI models "
                            "leave is their loop shape (outside the MPI class), not an effect"}
    # an input stage runs every operator's path again, so on records whose loop shape the model
    # misses it can stand in for that shape: it counts only when it explains each record as an
    # effect named anywhere in the diagnosis does, within UNEXPLAINED_LEVEL σ² of its noise
    # (outside-class 62: thresholds that reach 78 V of 120 V, where the true 1.5-sample delay leaves
    # 11.5 σ² and an input low-pass 3.9 σ², 7.2 σ² on the second record)
    effects = {c: f for c, f in fits.items()
               if c != "none" and not (c in INPUT_EFFECTS and max(f.mse_sigma2) > 1.0 + UNEXPLAINED_LEVEL)}
    evidence = ", ".join(f"with {c} " + (f"{f.excess_sigma2:.3g} σ²" if math.isfinite(f.excess_sigma2) else
                                         "no fit: so slow a stage leaves the operators' paths unknown")
                         for c, f in sorted(fits.items(), key=lambda cf: cf[1].excess_sigma2) if c != "none")
    if not effects:
        return {"cause": None, "causes": (), "left_sigma2": left,
                "sentence": f"{described} ({base.excess_sigma2:.3g} σ² above it over both; {evidence}): no effect "
                            "of the catalogue explains it"}
    best = min(effects, key=lambda c: effects[c].excess_sigma2)
    removed = base.excess_sigma2 - effects[best].excess_sigma2
    # each record's error lowered; a record the model alone already fits within its noise cannot be
    # lowered but by chance, and only has to stay there (fourth-generator seed 95: a slew limit on a
    # staircase that takes both records to the noise, the second, a slow triangle it never touches,
    # from 0.96 σ² to a hair above it, had been left `unexplained`)
    lowers_each = all(b < a or max(a, b) <= 1.0 + NOISE_FRACTION
                      for a, b in zip(base.mse_sigma2, effects[best].mse_sigma2))
    # at least 1 σ² removed over both records; an effect that brings *each* record to its noise,
    # where the model alone leaves one of them above it, is the mirror of `none` and needs only
    # the noise margin (outside-class 162 and 178: Preisach creep, 0.6-0.8 σ² over both, one record
    # 1.5-2.3 σ² above its noise; creep leaves 0.00 σ²)
    to_the_noise = max(effects[best].mse_sigma2) <= 1.0 + NOISE_FRACTION
    if removed >= max(DECISIVE_SHARE * base.excess_sigma2, NOISE_FRACTION if to_the_noise else 1.0) and lowers_each:
        # ties as everywhere in the diagnosis: within TIE_FRACTION of what the best leaves above the
        # noise, or within the noise margin
        margin = max(TIE_FRACTION * effects[best].excess_sigma2, NOISE_FRACTION)
        causes = tuple(sorted((c for c in effects if effects[c].excess_sigma2 - effects[best].excess_sigma2 <= margin),
                              key=lambda c: effects[c].excess_sigma2))
        return {"cause": best, "causes": causes, "left_sigma2": left,
                "sentence": f"{described} ({base.excess_sigma2:.3g} σ² above it over both; {evidence}): "
                            f"{' and '.join(causes)} {'removes' if len(causes) == 1 else 'remove'} "
                            + ("all" if removed >= 0.995 * base.excess_sigma2 else
                               f"{100 * removed / base.excess_sigma2:.0f} %")
                            + " of it on a hysteresis of any rate-independent shape"}
    return {"cause": None, "causes": (), "left_sigma2": left,
            "sentence": f"{described} ({base.excess_sigma2:.3g} σ² above it over both; {evidence}): no effect of "
                        f"the catalogue removes {100 * DECISIVE_SHARE:.0f} % of it"}
