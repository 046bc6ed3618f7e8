"""Model discrepancy: where a rate-independent MPI model misses on measured data,
which cause explains it, and how much an extended model gains.

Procedure (``diagnose``):

1. **Split** (:func:`split_record`).  The samples before the input has visited
   both ends of its range depend on the actuator's unknown history and are left
   out (warm-up, :func:`pysim.identification.identify.auto_warmup`).  Of the rest, the first
   ``train_fraction`` (65 %) trains, the remainder is held out.  When the input
   is periodic (autocorrelation peak above 0.9), the split is moved to the
   nearest whole number of periods after the warm-up, so both parts hold whole
   cycles.  Every model is simulated over the *whole* record, so the held-out
   prediction continues the state reached at the end of the training part.
2. **Baseline**: the MPI model fitted on the training part
   (:func:`pysim.identification.identify.identify`).  Its residual is analysed
   (:mod:`pysim.diagnosis.residuals`): against time, input rate, time since the last
   input change, lagged cross-correlation with the input and its rate, and its
   spectrum.  The noise level σ is estimated from the sample-to-sample
   differences of the residuals (the smallest estimate over the baseline and
   the candidates: unexplained fast structure can only inflate it).
3. **Candidates**: every effect of the catalog (rate_dependence, creep, delay,
   drift; :mod:`pysim.diagnosis.candidates`) is fitted on the training part and scored by
   its held-out RMS error.  A candidate is *significant* when it lowers the
   held-out mean-square error by at least ``NOISE_FRACTION`` × σ² and the RMS
   error by at least ``MIN_GAIN_PCT`` %.  Without noise-level structure nothing
   can be significant, so a model that only fits noise never is.
4. **Cause**: the significant candidate with the lowest held-out RMS error, or
   ``none`` when no candidate is significant.  Occam's razor: a candidate with
   fewer effect parameters whose held-out mean-square error is within
   ``NOISE_FRACTION`` × σ² of the best one's is preferred.  Each candidate's
   evidence (its held-out error, its parameters, the residual statistics that
   point to it) is reported with the reason the winner wins.
5. **Gain**: held-out max and RMS error (% of the held-out measured range) of
   the baseline and of the extended model, ``gain_pct = 100 (1 − rms_after /
   rms_before)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pysim.core.metrics import error_measures
from pysim.diagnosis.candidates import EFFECTS, CandidateFit, CandidateFitter
from pysim.diagnosis.errors import DiagnosisError
from pysim.diagnosis.residuals import noise_sigma, quantum, residual_statistics
from pysim.identification.identify import IdentificationError, auto_warmup

CAUSES = EFFECTS + ("none",)
#: A candidate must remove at least this many noise variances of held-out mean-square error.
NOISE_FRACTION = 0.25
#: ... and cut the held-out RMS error by at least this much (%).
MIN_GAIN_PCT = 5.0
DEFAULT_TRAIN_FRACTION = 0.65
_PERIODIC_CORRELATION = 0.9


@dataclass
class Split:
    """Training and held-out parts of one record.

    Attributes
    ----------
    warmup : int
        Samples left out at the start.
    split : int
        First held-out sample; training is ``warmup … split − 1``.
    n_samples : int
    period_samples : float or None
        Input period when the input is periodic (the split then falls on a
        whole number of periods after the warm-up).
    """

    warmup: int
    split: int
    n_samples: int
    period_samples: float | None = None

    @property
    def train(self) -> slice:
        return slice(self.warmup, self.split)

    @property
    def heldout(self) -> slice:
        return slice(self.split, self.n_samples)

    def as_dict(self, sample_period_s: float) -> dict:
        return {"warmup_samples": self.warmup, "first_heldout_sample": self.split,
                "n_samples": self.n_samples, "train_samples": self.split - self.warmup,
                "heldout_samples": self.n_samples - self.split,
                "period_s": None if self.period_samples is None else self.period_samples * sample_period_s}


def input_period(voltage_V) -> float | None:
    """Period (samples) of a periodic input, or None.

    The first peak of the autocorrelation after its first zero crossing that
    exceeds 0.9 (and is within 2 % of the highest such peak) counts, when at
    least three periods fit in the record.
    """
    x = np.asarray(voltage_V, dtype=float)
    x = x - x.mean()
    n = x.size
    if n < 16 or not np.any(x):
        return None
    spectrum = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(np.abs(spectrum) ** 2)[:n]
    acf = acf / acf[0] / (1.0 - np.arange(n) / n)   # unbiased: long lags see fewer samples
    below = np.flatnonzero(acf[: n // 3] < 0)
    if below.size == 0:
        return None
    start = int(below[0])
    stop = n // 3
    if stop <= start + 1:
        return None
    window = acf[start:stop]
    peaks = np.flatnonzero((window[1:-1] >= window[:-2]) & (window[1:-1] >= window[2:])
                           & (window[1:-1] >= _PERIODIC_CORRELATION)) + 1
    if peaks.size == 0:
        return None
    # the first strong peak: later ones are multiples of the period
    k = start + int(peaks[np.argmax(window[peaks] >= 0.98 * window[peaks].max())])
    # parabolic interpolation of the peak
    a, b, c = acf[k - 1], acf[k], acf[k + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else 0.0
    return float(k + shift)


def split_record(voltage_V, train_fraction: float = DEFAULT_TRAIN_FRACTION, warmup="auto",
                 min_samples: int = 100) -> Split:
    """Training / held-out split of one record (see the module notes)."""
    v = np.asarray(voltage_V, dtype=float)
    n = v.size
    if not 0.2 <= train_fraction <= 0.9:
        raise DiagnosisError(f"train fraction must lie in [0.2, 0.9], got {train_fraction}")
    w = auto_warmup(v) if warmup == "auto" else int(warmup)
    usable = n - w
    if usable < 2 * min_samples:
        raise IdentificationError(
            f"only {usable} samples after a warm-up of {w} (the input reaches both ends of its range "
            f"late); need {2 * min_samples}: give a shorter warm-up")
    if usable < 0.3 * n and warmup == "auto":
        raise IdentificationError(
            f"the input reaches both ends of its range only at sample {w} of {n}; less than 30 % of the "
            f"record is left to train and validate on: give the warm-up explicitly")
    target = w + train_fraction * usable
    period = input_period(v[w:])
    split = int(round(target))
    if period is not None:
        cycles = round((target - w) / period)
        snapped = int(round(w + cycles * period))
        if cycles >= 1 and w + min_samples <= snapped <= n - min_samples:
            split = snapped
        else:
            period = None
    split = min(max(split, w + min_samples), n - min_samples)
    return Split(w, split, n, period)


@dataclass
class Evaluation:
    """A fitted model scored on the held-out part.

    Attributes
    ----------
    fit : CandidateFit
    rms_pct, max_pct : float
        Held-out RMS and max error, % of the held-out measured range.
    rms_um : float
        Held-out RMS error, µm.
    train_rms_pct : float
        RMS error on the training part, % of its measured range.
    gain_pct : float
        ``100 (1 − rms / rms_baseline)``.
    excess_over_noise : float
        Held-out mean-square error removed, in units of σ² (negative: added).
    significant : bool
    """

    fit: CandidateFit
    rms_pct: float
    max_pct: float
    rms_um: float
    train_rms_pct: float
    gain_pct: float = 0.0
    excess_over_noise: float = 0.0
    significant: bool = False

    @property
    def cause(self) -> str:
        return self.fit.cause

    @property
    def model(self):
        return self.fit.model

    @property
    def prediction_um(self) -> np.ndarray:
        return self.fit.prediction_um


@dataclass
class Diagnosis:
    """Outcome of :func:`diagnose` (see :meth:`as_json` for the report format)."""

    cause: str
    split: Split
    sample_period_s: float
    noise_um: float
    baseline: Evaluation
    candidates: dict
    extended: Evaluation
    statistics: dict
    reasons: dict
    why: str
    time_s: np.ndarray = field(repr=False, default=None)
    voltage_V: np.ndarray = field(repr=False, default=None)
    displacement_um: np.ndarray = field(repr=False, default=None)
    source: str = ""

    @property
    def gain_pct(self) -> float:
        return self.extended.gain_pct

    @property
    def heldout_span_um(self) -> float:
        return float(np.ptp(self.displacement_um[self.split.heldout]))

    def as_json(self) -> dict:
        """``{"cause", "evidence", "baseline", "extended", "gain_pct"}`` (plain types)."""
        candidates = {}
        for cause, ev in self.candidates.items():
            candidates[cause] = {
                "heldout_rms_pct": ev.rms_pct, "heldout_max_pct": ev.max_pct, "gain_pct": ev.gain_pct,
                "mse_removed_over_noise": ev.excess_over_noise, "significant": ev.significant,
                "train_rms_pct": ev.train_rms_pct, "parameters": _plain(ev.fit.parameters),
                "reason": self.reasons[cause],
            }
        span = self.heldout_span_um
        return _plain({
            "source": self.source,
            "cause": self.cause,
            "evidence": {
                "why": self.why,
                "noise_um": self.noise_um,
                "noise_pct": 100.0 * self.noise_um / span if span > 0 else float("nan"),
                "split": self.split.as_dict(self.sample_period_s),
                "sample_rate_hz": 1.0 / self.sample_period_s,
                "candidates": candidates,
                "residual_statistics": _plain(self.statistics),
            },
            "baseline": {"rms_pct": self.baseline.rms_pct, "max_pct": self.baseline.max_pct},
            "extended": {"rms_pct": self.extended.rms_pct, "max_pct": self.extended.max_pct,
                         "cause": self.extended.cause, "parameters": _plain(self.extended.fit.parameters)},
            "gain_pct": self.gain_pct,
        })


def _plain(value):
    """Plain JSON types (floats, lists, dicts); NaN and infinities become None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _evaluate(fit: CandidateFit, y, split: Split) -> Evaluation:
    held, train = split.heldout, split.train
    errors = error_measures(y[held], fit.prediction_um[held])
    residual = y[held] - fit.prediction_um[held]
    return Evaluation(fit, errors["rms_error_pct"], errors["max_error_pct"],
                      float(np.sqrt(np.mean(residual**2))),
                      error_measures(y[train], fit.prediction_um[train])["rms_error_pct"])


def _reasons(candidates: dict, stats: dict, noise_um: float, sample_period_s: float) -> dict:
    """One sentence of evidence per candidate: its fit, and the statistic that points to it."""
    text = {}
    for cause, ev in candidates.items():
        p = ev.fit.parameters
        if cause == "rate_dependence":
            shape = (f"second-order stage, f_n = {p['natural_frequency_hz']:.4g} Hz, ζ = {p['damping_ratio']:.3g}"
                     if p["order"] == 2 else f"first-order lag, τ = {p['time_constant_s'] * 1e3:.4g} ms")
            hint = f"residual-rate correlation {stats['rate_correlation']:+.2f}; " + (
                f"largest residual spectral peak between the input's harmonics {stats['peak_frequency_hz']:.4g} Hz "
                f"at {stats['peak_over_median']:.1f}× the median" if stats["peak_over_median"] > 0
                else "no spectral peak between the input's harmonics can be resolved")
        elif cause == "delay":
            shape = f"delay {p['delay_samples']:.3g} samples ({p['delay_s'] * 1e3:.4g} ms)"
            hint = (f"residual-rate correlation {stats['rate_correlation']:+.2f}; "
                    f"{100 * stats['settling_fraction']:.0f} % of the residual power within 20 samples "
                    f"of an input change")
        elif cause == "creep":
            taus = p["time_constants_s"]
            shape = f"{len(taus)} creep modes, τ = {taus[0]:.3g} … {taus[-1]:.3g} s"
            hint = (f"direction-signed residual vs ln(time since change): correlation "
                    f"{stats['creep_log_correlation']:+.2f}")
        else:
            shape = f"polynomial of degree {p['degree']} in time"
            hint = (f"{100 * stats['low_frequency_fraction']:.0f} % of the residual power below a fifth of the "
                    f"input frequency; peak |cross-correlation| with the input {abs(stats['input_xcorr_peak']):.2f}")
        verdict = "significant" if ev.significant else "not significant"
        text[cause] = (f"{shape}: held-out RMS {ev.rms_pct:.3g} % (gain {ev.gain_pct:+.1f} %, removes "
                       f"{ev.excess_over_noise:.2f} σ² of mean-square error: {verdict}); {hint}")
    return text


def diagnose(voltage_V, displacement_um, sample_rate_hz: float, *, time_s=None, n_operators: int = 10,
             model: str = "mpi", operator: str = "osp", train_fraction: float = DEFAULT_TRAIN_FRACTION,
             warmup="auto", name: str = "extended_mpi", source: str = "") -> Diagnosis:
    """Diagnose what a rate-independent MPI model misses on a measured record.

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record, uniformly sampled.
    sample_rate_hz : float
        Sample rate, Hz (the extended model's stages run at this rate).
    time_s : array_like, optional
        Sample times, s (for plots; default ``k / sample_rate_hz``).
    n_operators, model, operator
        MPI model settings, as in :func:`pysim.identification.identify.identify`.
    train_fraction : float
        Share of the samples after the warm-up used for training.
    warmup : "auto" or int
        Samples left out at the start.
    name : str
        Name of the extended model (a C identifier).
    source : str
        Where the data came from (for the report).

    Returns
    -------
    Diagnosis

    Raises
    ------
    DiagnosisError
        When the record cannot be diagnosed (too short, constant, late warm-up).
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    where = f"{source}: " if source else ""
    if v.shape != y.shape:
        raise DiagnosisError(f"{where}{v.size} voltage samples but {y.size} displacement samples")
    if not (sample_rate_hz > 0 and math.isfinite(sample_rate_hz)):
        raise DiagnosisError(f"{where}sample rate must be a positive number of Hz, got {sample_rate_hz}")
    T = 1.0 / float(sample_rate_hz)
    try:
        split = split_record(v, train_fraction, warmup)
        description = f"MPI model with output stages identified from {source or 'a record'} by pysim diagnose"
        fitter = CandidateFitter(v, y, T, split.warmup, split.split, n_operators=n_operators, model=model,
                                 operator=operator, name=name, description=description)
        baseline = _evaluate(fitter.baseline(), y, split)
        candidates = {cause: _evaluate(fitter.fit(cause, split.period_samples), y, split) for cause in EFFECTS}
    except IdentificationError as exc:
        raise DiagnosisError(f"{where}{exc}") from exc

    # Structure the model misses also shows in the differences (ringing, steps),
    # so it can only inflate the estimate: the smallest over all fitted models
    # is the closest to the sensor noise.
    residual = y - baseline.prediction_um
    step = quantum(y)
    noise = min(noise_sigma((y - ev.prediction_um)[split.warmup:], step)
                for ev in [baseline, *candidates.values()])
    for ev in candidates.values():
        ev.gain_pct = 100.0 * (1.0 - ev.rms_um / baseline.rms_um) if baseline.rms_um > 0 else 0.0
        removed = baseline.rms_um**2 - ev.rms_um**2
        ev.excess_over_noise = removed / noise**2 if noise > 0 else (math.inf if removed > 0 else 0.0)
        ev.significant = bool(ev.excess_over_noise >= NOISE_FRACTION and ev.gain_pct >= MIN_GAIN_PCT)

    held = split.heldout
    stats = residual_statistics(residual[held], v[held], sample_rate_hz, noise)
    significant = [ev for ev in candidates.values() if ev.significant]
    ranked = sorted(candidates.values(), key=lambda ev: ev.rms_um)
    if significant:
        best = min(significant, key=lambda ev: ev.rms_um)
        # Occam's razor: as good within the noise margin and simpler
        close = [ev for ev in significant
                 if ev.rms_um**2 - best.rms_um**2 <= NOISE_FRACTION * noise**2]
        winner = min(close, key=lambda ev: (ev.fit.complexity, ev.rms_um))
        cause, extended = winner.cause, winner
        runner = next((ev for ev in ranked if ev is not winner), None)
        why = (f"{cause} lowers the held-out RMS error the most: {baseline.rms_pct:.3g} % → "
               f"{winner.rms_pct:.3g} % of range ({winner.gain_pct:.1f} % less, {winner.excess_over_noise:.3g} σ² "
               f"of mean-square error removed, σ = {noise:.3g} µm)")
        ties = [ev for ev in close if ev is not winner]
        if winner is not best:
            why += (f"; {best.cause} reaches {best.rms_pct:.3g} %, but within the noise margin "
                    f"({NOISE_FRACTION} σ²) with more parameters, so the simpler {cause} is named")
        elif runner is not None:
            why += (f"; next best {runner.cause} reaches {runner.rms_pct:.3g} % "
                    f"({runner.gain_pct:.1f} % less)")
        if ties:
            why += (f". Caution: {', '.join(ev.cause for ev in ties)} "
                    f"{'fits' if len(ties) == 1 else 'fit'} as well within the noise margin, so this "
                    f"record cannot tell them apart (a single-frequency input, for one, shows a lag, a "
                    f"delay and creep alike as a phase shift): record with steps or several frequencies "
                    f"to separate them")
    else:
        cause, extended = "none", baseline
        best = ranked[0]
        why = (f"no candidate lowers the held-out error significantly: the best, {best.cause}, removes "
               f"{best.excess_over_noise:.3g} σ² of mean-square error (needs {NOISE_FRACTION}) and "
               f"{best.gain_pct:.1f} % of the RMS error (needs {MIN_GAIN_PCT}); the baseline residual is "
               f"{stats['rms_over_noise']:.2f}× the noise level σ = {noise:.3g} µm")
    if extended is baseline:
        extended = Evaluation(baseline.fit, baseline.rms_pct, baseline.max_pct, baseline.rms_um,
                              baseline.train_rms_pct)
    extended_residual = y - extended.prediction_um
    statistics = {"baseline": stats,
                  "extended": residual_statistics(extended_residual[held], v[held], sample_rate_hz, noise)}
    time = np.arange(v.size) * T if time_s is None else np.asarray(time_s, dtype=float)
    return Diagnosis(cause=cause, split=split, sample_period_s=T, noise_um=noise, baseline=baseline,
                     candidates=candidates, extended=extended, statistics=statistics,
                     reasons=_reasons(candidates, stats, noise, T), why=why, time_s=time, voltage_V=v,
                     displacement_um=y, source=source)
