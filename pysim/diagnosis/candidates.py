"""The candidate extensions of the MPI model, each fitted on the training part.

Every candidate keeps the MPI hysteresis and adds one effect of the catalog of
:mod:`pysim.diagnosis.diagnose`; every one is cheap because the model stays linear in
the hysteresis parameters once the effect's own shape parameters are fixed:

``rate_dependence``
    ``y = G[h]`` with G a first-order lag or a second-order stage (unit static
    gain).  G is linear, so ``G[Φθ] = G[Φ]θ``: for given (τ) or (f, ζ) the fit
    is a least-squares problem on filtered regressors.  The shape parameters
    are searched on a grid and refined (Brent / Nelder-Mead) with unconstrained
    least squares; the final fit is the exact constrained one of
    :func:`pysim.identification.identify.identify`.  First or second order is chosen by BIC.
``delay``
    ``y = D[h]``: every whole delay up to ``max_delay`` is scored at once from
    one QR factorisation (shifting the output instead of the regressors), then
    a fractional delay is refined around the best one.
``creep``
    ``y = h + Σ w_j C_j[u]``: first-order lags of the input with fixed time
    constants spread two per decade from three samples to half the training
    part; the weights enter linearly (extra regressors).  A logarithmic creep
    law is a superposition of such modes.
``drift``
    ``y = h + p_1 t + p_2 t²``: a polynomial in time, extra regressors; the
    degree (1 or 2) is the one that extrapolates best within the training part.

The prediction of every candidate comes from simulating the resulting
:class:`pysim.core.extended.ExtendedModel` over the whole record, so the held-out
part continues the state of the training part.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from pysim.core.extended import (
    ExtendedModel,
    OutputStages,
    StageSpec,
    tustin_creep_mode,
    tustin_first_order,
    tustin_second_order,
)
from pysim.core.model import HysteresisModel
from pysim.diagnosis.errors import DiagnosisError
from pysim.identification.identify import IdentificationError, identify, regressors

EFFECTS = ("rate_dependence", "creep", "delay", "drift")
#: Training samples (the last before the split) on which shape parameters are searched.
SEARCH_SAMPLES = 30000
#: Samples before the search window from which the stages are run.
SEARCH_PAD = 5000


@dataclass
class CandidateFit:
    """One fitted model.

    Attributes
    ----------
    cause : str
        ``"baseline"`` or one of :data:`EFFECTS`.
    model : ExtendedModel
        The fitted model (a plain MPI model with no stages for the baseline).
    prediction_um : ndarray
        Its simulation over the whole record.
    parameters : dict
        The effect's parameters (units in the names).
    """

    cause: str
    model: ExtendedModel
    prediction_um: np.ndarray
    parameters: dict

    @property
    def complexity(self) -> int:
        """Number of fitted effect parameters besides the hysteresis (Occam's razor)."""
        p = self.parameters
        if self.cause == "rate_dependence":
            return int(p["order"])
        if self.cause == "delay":
            return 1
        if self.cause == "creep":
            return len(p["time_constants_s"])
        if self.cause == "drift":
            return int(p["degree"])
        return 0


def _bic(sse: float, n: int, k: int) -> float:
    return n * math.log(max(sse, 1e-300) / n) + k * math.log(n)


class CandidateFitter:
    """Fits the baseline MPI model and every candidate on one training part.

    Parameters
    ----------
    voltage_V, displacement_um : ndarray
        The whole record.
    sample_period_s : float
    warmup, split : int
        Training samples are ``warmup … split − 1``; the rest is held out.
    n_operators, model, operator
        As in :func:`pysim.identification.identify.identify`.
    name : str
        Name of the fitted models.
    """

    def __init__(self, voltage_V, displacement_um, sample_period_s: float, warmup: int, split: int, *,
                 n_operators: int = 10, model: str = "mpi", operator: str = "osp",
                 name: str = "extended_mpi", description: str = ""):
        self.v = np.asarray(voltage_V, dtype=float)
        self.y = np.asarray(displacement_um, dtype=float)
        self.T = float(sample_period_s)
        self.warmup, self.split = int(warmup), int(split)
        self.settings = {"n_operators": n_operators, "model": model, "operator": operator}
        self.name, self.description = name, description
        self.baseline_result = identify(self.v, self.y, warmup=self.warmup, fit_slice=slice(0, self.split),
                                        **self.settings)
        m = self.baseline_result.model
        self.design, _ = regressors(self.v, m.thresholds_V, operator, m.input_offset_V, model == "mpi")
        self.u = self.v - m.input_offset_V
        self.n_train = self.split - self.warmup
        # Shape parameters are searched on at most SEARCH_SAMPLES training
        # samples (the last ones): enough to pin a few parameters down, and it
        # bounds the search cost for long records.  The stages run from
        # SEARCH_PAD samples earlier so that their start-up has died out.
        rows = min(self.n_train, SEARCH_SAMPLES)
        self._search_rows = slice(self.split - rows, self.split)
        self._search_from = max(0, self.split - rows - SEARCH_PAD)
        self._search_design = np.asfortranarray(self.design[self._search_from:self.split])

    # ----------------------------------------------------------- helpers
    @staticmethod
    def _lsq_sse(A, y) -> float:
        """Sum of squared errors of the unconstrained least-squares fit of y by A.

        Solved through the normal equations of the norm-scaled columns: a
        p × p system, far cheaper than a factorisation of the tall matrix in a
        search loop; the error sum is quadratic in the parameters near the
        optimum, so their small rounding error hardly moves it.  The final fits
        are the exact ones of :func:`pysim.identification.identify.identify`.
        """
        scale = np.sqrt(np.einsum("ij,ij->j", A, A))
        scale[scale == 0] = 1.0
        As = A / scale
        gram, rhs = As.T @ As, As.T @ y
        try:
            theta = np.linalg.solve(gram, rhs)
        except np.linalg.LinAlgError:
            theta = np.linalg.lstsq(gram, rhs, rcond=None)[0]
        residual = y - As @ theta
        return float(residual @ residual)

    def _search_sse(self, stages: OutputStages) -> float:
        """Training error of the unconstrained fit with ``stages`` after the
        hysteresis, on the search window."""
        columns = stages.apply_to_columns(self._search_design)
        offset = self._search_from
        rows = slice(self._search_rows.start - offset, self._search_rows.stop - offset)
        return self._lsq_sse(columns[rows], self.y[self._search_rows])

    def _model(self, hysteresis: HysteresisModel, **stages) -> ExtendedModel:
        hysteresis = hysteresis.with_parameters(name=self.name, description=self.description)
        return ExtendedModel(hysteresis, StageSpec(sample_period_s=self.T, **stages))

    def _finish(self, cause, result, parameters, **stages) -> CandidateFit:
        model = self._model(result.model, **stages)
        return CandidateFit(cause, model, model.simulate(self.v), parameters)

    def _fit(self, warmup=None, **options):
        return identify(self.v, self.y, warmup=self.warmup if warmup is None else warmup,
                        fit_slice=slice(0, self.split), **self.settings, **options)

    # ---------------------------------------------------------- baseline
    def baseline(self) -> CandidateFit:
        return self._finish("baseline", self.baseline_result, {})

    # --------------------------------------------------- rate dependence
    def _sections_sse(self, sections) -> float:
        return self._search_sse(OutputStages(sections))

    def rate_dependence(self) -> CandidateFit:
        T = self.T
        rows = self._search_rows.stop - self._search_rows.start
        fs = 1.0 / T
        # first order: τ from one sample to 1/20 of the search window (log grid, then Brent)
        log_tau = np.linspace(0.0, math.log(max(2.0, rows / 20.0)), 16)

        def first(x):
            return self._sections_sse([tustin_first_order(math.exp(x) * T, T)])

        scores = [first(x) for x in log_tau]
        i = int(np.argmin(scores))
        bounds = (log_tau[max(i - 1, 0)], log_tau[min(i + 1, log_tau.size - 1)])
        refined = scipy.optimize.minimize_scalar(first, bounds=bounds, method="bounded",
                                                 options={"xatol": 2e-3})
        x1, sse1 = (refined.x, refined.fun) if refined.fun < scores[i] else (log_tau[i], scores[i])

        # second order: natural frequency from 20 cycles per window to fs/3 (log grid, then Nelder-Mead)
        log_f = np.linspace(math.log(max(fs / 3000.0, 20.0 * fs / rows)), math.log(fs / 3.0), 12)
        log_z = np.log([0.05, 0.15, 0.35, 0.7, 1.2])
        z_range = (math.log(0.005), math.log(5.0))

        def clip(x):
            return (math.exp(min(max(x[0], log_f[0] - 1.0), log_f[-1])),
                    math.exp(min(max(x[1], z_range[0]), z_range[1])))

        def second(x):
            return self._sections_sse([tustin_second_order(*clip(x), T)])

        sse2, a, b = min((second((a, b)), a, b) for a in log_f for b in log_z)
        refined = scipy.optimize.minimize(second, x0=[a, b], method="Nelder-Mead",
                                          options={"xatol": 2e-3, "fatol": 1e-9 * sse2, "maxfev": 60,
                                                   "initial_simplex": [[a, b], [a + 0.3, b], [a, b + 0.4]]})
        if refined.fun < sse2:
            sse2, (a, b) = refined.fun, refined.x
        f2, z2 = clip((a, b))

        if _bic(sse2, rows, 2) < _bic(sse1, rows, 1):
            stages = {"resonance_hz": f2, "damping_ratio": z2}
            parameters = {"order": 2, "natural_frequency_hz": f2, "damping_ratio": z2}
            sections = [tustin_second_order(f2, z2, T)]
        else:
            tau = math.exp(x1) * T
            stages = {"lag_time_constant_s": tau}
            parameters = {"order": 1, "time_constant_s": tau}
            sections = [tustin_first_order(tau, T)]
        result = self._fit(column_transform=OutputStages(sections).apply_to_columns)
        return self._finish("rate_dependence", result, parameters, **stages)

    # ------------------------------------------------------------- delay
    def max_delay(self, period_samples: float = None) -> int:
        """Longest delay searched (samples): 1/20 of the training part, at most
        500, and for a periodic input at most a quarter period (a whole period
        of delay would only replay the previous cycle)."""
        limit = min(500, max(5, self.n_train // 20))
        if period_samples:
            limit = min(limit, max(1, int(period_samples / 4)))
        return int(limit)

    def delay(self, period_samples: float = None) -> CandidateFit:
        dmax = self.max_delay(period_samples)
        first = max(self.warmup, self._search_rows.start)
        stop = self.split - dmax
        if stop - first < self.design.shape[1] + 1:
            raise IdentificationError("the training part is too short for the delay search")
        # y[j + d] = (A θ)[j] for the same rows j: one QR for every d
        Q, _ = np.linalg.qr(self.design[first:stop])
        sse = []
        for d in range(dmax + 1):
            target = self.y[first + d:stop + d]
            sse.append(float(target @ target - np.sum((Q.T @ target) ** 2)))
        d_best = int(np.argmin(sse))

        def fractional(x):
            return self._search_sse(OutputStages(delay_samples=x))

        refined = scipy.optimize.minimize_scalar(fractional, bounds=(max(0.0, d_best - 1.0), d_best + 1.0),
                                                 method="bounded", options={"xatol": 1e-3})
        delay = float(refined.x) if refined.fun < fractional(float(d_best)) else float(d_best)
        result = self._fit(warmup=self.warmup + math.ceil(delay),
                           column_transform=OutputStages(delay_samples=delay).apply_to_columns)
        return self._finish("delay", result, {"delay_samples": delay, "delay_s": delay * self.T},
                            delay_samples=delay)

    # ------------------------------------------------------------- creep
    def creep_time_constants_s(self) -> np.ndarray:
        ratio = max(10.0, self.n_train / 6.0)
        count = int(math.ceil(2.0 * math.log10(ratio))) + 1
        return 3.0 * self.T * np.geomspace(1.0, ratio, count)

    def creep(self) -> CandidateFit:
        taus = self.creep_time_constants_s()
        columns = {}
        for j, tau in enumerate(taus):
            alpha, beta = tustin_creep_mode(tau, self.T)
            mode = OutputStages(creep_alpha=[alpha], creep_beta=[beta], creep_weights=[1.0])
            columns[f"creep_{j}"], _ = mode.run(np.zeros_like(self.u), self.u)
        result = self._fit(extra_regressors=columns)
        weights = tuple(result.extra_coefficients[f"creep_{j}"] for j in range(taus.size))
        parameters = {"time_constants_s": taus.tolist(), "weights_um_per_V": list(weights)}
        return self._finish("creep", result, parameters, creep_time_constants_s=tuple(taus.tolist()),
                            creep_weights_um_per_V=weights)

    # ------------------------------------------------------------- drift
    def drift(self) -> CandidateFit:
        time = np.arange(self.v.size) * self.T
        scale = self.split * self.T          # keeps the columns of order one
        # A drift model is judged by how it extrapolates: fitted on the first
        # 70 % of the training part, each degree predicts the last 30 %; the
        # quadratic must do clearly better (RMS below 0.8 of the line's), as it
        # extrapolates a random wander in the baseline more wildly.
        inner = self.warmup + int(0.7 * self.n_train)
        best = None
        for degree in (1, 2):
            columns = {f"t{j}": (time / scale) ** j for j in range(1, degree + 1)}
            probe = identify(self.v, self.y, warmup=self.warmup, fit_slice=slice(0, inner),
                             extra_regressors=columns, **self.settings)
            error = self.y[inner:self.split] - probe.prediction_um[inner:self.split]
            score = float(np.sqrt(np.mean(error**2))) * (1.0 if degree == 1 else 1.0 / 0.8)
            if best is None or score < best[0]:
                best = (score, degree, columns)
        _, degree, columns = best
        result = self._fit(extra_regressors=columns)
        coefficients = tuple(result.extra_coefficients[f"t{j}"] / scale**j for j in range(1, degree + 1))
        parameters = {"degree": degree, "coefficients_um_per_s_power": list(coefficients)}
        return self._finish("drift", result, parameters, drift_coefficients=coefficients)

    def fit(self, cause: str, period_samples: float = None) -> CandidateFit:
        """Fit one effect of :data:`EFFECTS` (``period_samples``: the input's
        period, if periodic, which bounds the delay search)."""
        if cause not in EFFECTS:
            raise DiagnosisError(f"unknown effect {cause!r}; the catalog is {EFFECTS}")
        if cause == "delay":
            return self.delay(period_samples)
        return getattr(self, cause)()
