"""Statistics of a model's residual (measured − simulated displacement).

Each function looks at the residual from one angle that separates the causes
a rate-independent model misses (see :mod:`pysim.diagnosis.diagnose`):

- against the input rate dv/dt: a delay or a lag makes the residual follow the
  rate (``−delay × slope``);
- against the time since the last input change (a reversal or a step): creep
  keeps moving for seconds after a change, dynamics ring and settle within a
  few time constants, a delay only lasts a few samples;
- lagged cross-correlation with the input and with dv/dt: where the residual
  is linked to the input and with what lag; drift is not linked at all;
- the spectrum: drift lives below the input's frequencies, ringing shows a
  peak above them, noise is flat.

All functions take plain arrays (µm, V, s) and return plain numbers or arrays.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.signal

_MAD_TO_SIGMA = 1.482602218505602  # 1 / Φ⁻¹(3/4): MAD of a normal sample → σ


def noise_sigma(residual_um, quantum_um: float = 0.0) -> float:
    """Standard deviation (µm) of the white part of a residual.

    The first difference of a smooth error is small while that of white noise
    has variance 2σ²; the median absolute deviation of the differences ignores
    the few large differences at steps.  A quantised sensor can give a median
    of zero: the estimate is then at least ``quantum_um / sqrt(12)``.
    """
    return max(_difference_sigma(residual_um, 1), quantum_um / np.sqrt(12.0))


def input_noise_sigma(voltage_V) -> float:
    """Standard deviation (V) of the white noise of a measured voltage (an amplifier's monitor output):
    the median absolute deviation of its third differences, which a command's smooth parts, its steps
    and its turns leave near zero (0.015 % of the range at most on the generators' noise-free
    commands, band-limited noise the highest).

    Examples
    --------
    >>> k = np.arange(20000)
    >>> v = 75.0 + 70.0 * np.sin(2 * np.pi * k / 2000)
    >>> round(float(input_noise_sigma(v)), 4)
    0.0
    >>> round(float(input_noise_sigma(v + np.random.default_rng(0).normal(0.0, 0.3, k.size))), 2)
    0.3
    """
    return float(_difference_sigma(voltage_V, 3))


def _difference_sigma(residual_um, order: int) -> float:
    """σ of white noise from the median absolute deviation of the ``order``-th differences (their
    variance is C(2 order, order) σ²: 2 for first differences, 20 for third); 0 when too short."""
    d = np.diff(np.asarray(residual_um, dtype=float), n=order)
    if d.size == 0:
        return 0.0
    return _mad_sigma(d, {1: 2.0, 3: 20.0}[order])


def _mad_sigma(differences, variance_factor: float) -> float:
    """σ of white noise whose ``differences`` have the variance ``variance_factor`` σ², from their
    median absolute deviation (robust to the few large differences at steps)."""
    mad = float(np.median(np.abs(differences - np.median(differences))))
    return _MAD_TO_SIGMA * mad / np.sqrt(variance_factor)


#: Differences two samples apart that spread this much more (in variance) than differences one sample
#: apart may show noise correlated from sample to sample (an AR(1) coefficient φ of 0.25 or more, as
#: a sensor's own low-pass filter gives), whose variance the first differences underestimate by
#: 1 - φ; white noise spreads the same at every lag (to within a few per cent on a thousand samples).
CORRELATED_NOISE_RISE = 1.25

#: How far each doubling of the lag may rise from what AR(1) noise of the fitted φ gives: from lag
#: ``k`` to ``2k`` the differences' variance rises by ``1 + φ^k``; every measured rise must lie within
#: this (absolute) of it (the spread of the estimates on a few thousand samples is about 0.05-0.1).
#: A misfit's differences rise otherwise (a smooth one's by nearly 4 at every doubling).
AR1_RISE_TOLERANCE = 0.15

#: Lags ``k`` with ``φ^k`` below this have reached the level ``2 σ²``.
AR1_LEVELLED = 0.05

#: The longest lag (samples) searched for the level of correlated noise, and at most this fraction
#: of the residual's length; φ above 0.95 (a correlation time over 20 samples) is not taken for
#: noise.
MAX_NOISE_LAG = 128
MAX_NOISE_LAG_FRACTION = 0.05
MAX_NOISE_CORRELATION = 0.95


def _lag_sigma(residual, lag: int) -> float:
    """σ of noise from the median absolute deviation of differences ``lag`` samples apart (the
    full variance of stationary noise once ``lag`` outlasts its correlation)."""
    return _mad_sigma(residual[lag:] - residual[:-lag], 2.0)


def level_noise_sigma(residual_um, first_difference_sigma: float | None = None) -> float:
    """Standard deviation (µm) of a residual's noise, white or AR(1)-correlated.

    White noise gives the first differences' σ (:func:`noise_sigma`), which is
    returned unchanged.  Noise correlated from sample to sample (a sensor's
    low-pass filter; an AR(1) coefficient φ) shows only ``sqrt(1 - φ)`` of its
    σ in the first differences, so every model would leave it as a misfit of
    several noise variances.  Its differences ``k`` samples apart have the
    variance ``2 σ² (1 - φ^k)``: from lag ``k`` to ``2k`` it rises by
    ``1 + φ^k``, less at every doubling, to the level ``2 σ²``.  When the
    second lag rises by :data:`CORRELATED_NOISE_RISE` or more (φ ≥ 0.25) and
    every doubling follows ``1 + φ^k`` of one φ within
    :data:`AR1_RISE_TOLERANCE` up to the first that has levelled off
    (``φ^k`` below :data:`AR1_LEVELLED`), that level is the noise's σ; a slow
    misfit's rise at longer lags does not count.
    A misfit's differences rise otherwise (a smooth one's by nearly 4 at every
    doubling): the first differences' σ is kept.  Of several models of one
    record, :func:`models_noise_sigma` decides which estimate holds.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> white = rng.normal(0.0, 0.05, 20000)
    >>> bool(level_noise_sigma(white) == noise_sigma(white))
    True
    >>> ar = np.zeros(20000)
    >>> for k in range(1, ar.size):
    ...     ar[k] = 0.8 * ar[k - 1] + 0.6 * white[k]
    >>> round(float(np.std(ar)), 3), round(float(noise_sigma(ar)), 3), round(level_noise_sigma(ar), 3)
    (0.049, 0.022, 0.049)
    >>> t = np.arange(20000)
    >>> smooth_misfit = white + 0.2 * np.sin(2 * np.pi * t / 40)
    >>> bool(level_noise_sigma(smooth_misfit) == noise_sigma(smooth_misfit))
    True
    """
    return _noise_level(residual_um, first_difference_sigma)[1]


def _noise_level(residual_um, first_difference_sigma: float | None = None) -> tuple:
    """``(kind, σ µm)`` of :func:`level_noise_sigma`: ``kind`` is ``"white"`` (the second lag does
    not rise: the first differences' σ), ``"correlated"`` (AR(1) noise: its level) or ``"misfit"``
    (the differences rise, but not as AR(1) noise's: the first differences' σ)."""
    r = np.asarray(residual_um, dtype=float)
    first = _difference_sigma(r, 1) if first_difference_sigma is None else first_difference_sigma
    longest = min(MAX_NOISE_LAG, int(MAX_NOISE_LAG_FRACTION * r.size))
    if first <= 0.0 or longest < 4:
        return "white", first
    # the second lag decides for most residuals (white noise): the longer lags only where it rises
    second = _lag_sigma(r, 2) ** 2 / max(first**2, 1e-300) - 1.0
    if second < CORRELATED_NOISE_RISE - 1.0:
        return "white", first
    if second > MAX_NOISE_CORRELATION:
        return "misfit", first
    lags = 2 ** np.arange(int(np.log2(longest)) + 1)                     # 1, 2, 4, ...
    variance = np.array([first**2] + [_lag_sigma(r, int(k)) ** 2 for k in lags[1:]])
    rise = variance[1:] / np.maximum(variance[:-1], 1e-300) - 1.0         # lag k -> 2k: φ^k for AR(1)
    grid = np.linspace(CORRELATED_NOISE_RISE - 1.0 - AR1_RISE_TOLERANCE, MAX_NOISE_CORRELATION, 200)
    # the doublings up to the first that has levelled off: beyond the noise's correlation a slow
    # misfit may rise again (the model class's, or an effect's), which says nothing of the noise
    for n_rises in range(2, rise.size + 1):
        # the φ that fits these doublings' rises best, on a grid fine against the estimates' spread
        predicted = grid[:, None] ** lags[None, :n_rises]
        best = int(np.argmin(np.sum((rise[None, :n_rises] - predicted) ** 2, axis=1)))
        phi = grid[best]
        if np.max(np.abs(rise[:n_rises] - predicted[best])) > AR1_RISE_TOLERANCE:
            return "misfit", first
        if phi ** lags[n_rises - 1] < AR1_LEVELLED:
            decay = phi ** lags[:n_rises + 1]                             # φ^k at every lag so far
            levelled = decay < AR1_LEVELLED
            return "correlated", float(np.sqrt(np.median(variance[:n_rises + 1][levelled] / (1.0 - decay[levelled]))))
    return "misfit", first                  # not levelled off within the record


#: Below this fraction of its range a record's noise is not a sensor's (24-bit converters resolve
#: 6e-8 of theirs): the record is a simulation or was smoothed, and has no measurable noise.
NOISE_FREE_FRACTION = 1e-7

#: The lowest noise, as a fraction of the displacement's range, the diagnosis was measured at (the
#: generators of the tests and benchmarks: 0.1-0.5 %); a record without measurable noise is weighed
#: against it.
VALIDATED_NOISE_FRACTION = 1e-3


def record_noise_sigma(residual_um, displacement_um) -> float:
    """Standard deviation (µm) of the noise against which a residual of the record
    ``displacement_um`` is weighed: :func:`level_noise_sigma` (white noise, or noise correlated
    from sample to sample at its whole variance), at least the record's resolution
    (:func:`quantum`).

    A record without measurable noise (:func:`is_noise_free`, as a simulation
    gives) would make every deterministic misfit, however small, thousands of
    noise variances, and the misfit of the model class would be named as an
    effect.  Such a record is weighed against :data:`VALIDATED_NOISE_FRACTION`
    of its range instead, the lowest noise the diagnosis was measured at.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 2001)
    >>> y = 10.0 * np.sin(2 * np.pi * t)
    >>> record_noise_sigma(1e-4 * np.cos(6 * np.pi * t) ** 3, y)      # 20 µm range, no noise
    0.02
    >>> noisy = np.random.default_rng(0).normal(0.0, 0.05, t.size)
    >>> round(record_noise_sigma(noisy, y + noisy), 2)
    0.05
    """
    return models_noise_sigma([residual_um], displacement_um)[0]


def models_noise_sigma(residuals_um, displacement_um) -> tuple:
    """``(σ µm, noise_free)`` against which several models' residuals of one record are weighed: the
    smallest of their :func:`record_noise_sigma` estimates, or the floor for all of them when any
    residual shows no measurable noise (no model fits white noise away, so one such residual means
    the record has none, whatever the others' misfits look like).  The noise is white when any
    residual's differences do not rise with the lag; otherwise, when one rises as AR(1) noise does
    (:func:`level_noise_sigma`), it is the least level of those.

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 2001)
    >>> y = 10.0 * np.sin(2 * np.pi * t)
    >>> models_noise_sigma([1e-4 * np.cos(6 * np.pi * t) ** 3, 1e-3 * np.sign(np.sin(40 * t))], y)
    (0.02, True)
    """
    scale = _RecordScale(displacement_um)
    first = [_difference_sigma(r, 1) for r in residuals_um]       # each residual's, computed once
    if any(scale.noise_free(r, sigma) for r, sigma in zip(residuals_um, first)):
        return VALIDATED_NOISE_FRACTION * scale.span, True
    levels = [_noise_level(r, sigma) for r, sigma in zip(residuals_um, first)]
    # the noise is in every residual and no model fits it away: one residual whose differences do not
    # rise shows white noise (the others' rise is misfit); where none is white, a residual that rises as
    # AR(1) noise does shows correlated noise, at the least of such levels (a misfit that happens to
    # rise that way in one model's residual raises only that one's)
    correlated = [sigma for kind, sigma in levels if kind == "correlated"]
    white = any(kind == "white" for kind, _ in levels)
    chosen = correlated if correlated and not white else first
    return float(min(max(sigma, scale.step / np.sqrt(12.0)) for sigma in chosen)), False


def is_noise_free(residual_um, displacement_um) -> bool:
    """Whether a residual of the record ``displacement_um`` shows no measurable noise: its white
    part, and the record's resolution, below :data:`NOISE_FREE_FRACTION` of the record's range.

    The white part is also estimated from third differences, which a smooth misfit hardly moves
    (a sine's by (2π/period)³) while white noise gives the same σ as from first differences: a
    noise-free record's misfit can be rough enough in its first differences to look like noise.
    """
    return _RecordScale(displacement_um).noise_free(residual_um, _difference_sigma(residual_um, 1))


class _RecordScale:
    """What a record's displacement sets for weighing its residuals: its range (µm), its least step
    between samples (:func:`quantum`) and its resolution -- that step when the values lie on its
    grid (a quantised sensor), else 0 (a smooth record's least increment is no resolution)."""

    def __init__(self, displacement_um):
        y = np.asarray(displacement_um, dtype=float)
        self.span = float(np.ptp(y)) if y.size else 0.0
        self.step = quantum(y)
        grid = (y - y[0]) / self.step if self.step > 0 else np.zeros(0)
        on_grid = grid.size and np.mean(np.abs(grid - np.round(grid)) < 1e-3) > 0.99
        self.resolution = self.step if on_grid else 0.0

    def noise_free(self, residual_um, first_difference_sigma: float) -> bool:
        limit = NOISE_FREE_FRACTION * self.span
        if self.resolution / np.sqrt(12.0) >= limit:
            return False
        white = first_difference_sigma
        if np.size(residual_um) > 3:
            white = min(white, _difference_sigma(residual_um, 3))
        return white < limit


def quantum(values) -> float:
    """Smallest non-zero step between samples (the sensor's resolution, if any)."""
    d = np.abs(np.diff(np.asarray(values, dtype=float)))
    d = d[d > 0]
    return float(d.min()) if d.size else 0.0


def input_changes(voltage_V, tolerance_V: float):
    """Samples where the input changes direction or jumps, and the direction after.

    A reversal is placed at the extreme sample once the input has moved back
    from it by more than ``tolerance_V`` (so noise on a hold is no reversal); a
    jump is a one-sample step larger than ten times ``tolerance_V`` and than ten
    times the median step (a step, not a fast ramp).

    Returns
    -------
    index : ndarray of int
        Sample of each change, ascending.
    direction : ndarray of float
        +1 if the input rises after the change, −1 if it falls.
    """
    v = np.asarray(voltage_V, dtype=float)
    events = {}
    dv = np.diff(v)
    jump = 10.0 * max(tolerance_V, float(np.median(np.abs(dv))) if dv.size else 0.0)
    for k in np.flatnonzero(np.abs(dv) > jump):
        events[int(k) + 1] = float(np.sign(dv[k]))
    top = bottom = 0          # running maximum / minimum since the last reversal
    direction = 0             # +1 rising, -1 falling, 0 not yet known
    for k in range(1, v.size):
        x = v[k]
        # the last sample at an extreme: after a hold the change is where the input leaves it
        if direction >= 0 and x >= v[top]:
            top = k
        if direction <= 0 and x <= v[bottom]:
            bottom = k
        if direction >= 0 and x < v[top] - tolerance_V:
            if direction > 0:
                events.setdefault(top, -1.0)
            direction, bottom = -1, k
        elif direction <= 0 and x > v[bottom] + tolerance_V:
            if direction < 0:
                events.setdefault(bottom, 1.0)
            direction, top = 1, k
    index = np.array(sorted(events), dtype=int)
    return index, np.array([events[k] for k in index])


def time_since_change(voltage_V, sample_period_s: float, tolerance_V: float):
    """Time (s) since the last input change and its direction, for every sample.

    Samples before the first change get NaN and direction 0.
    """
    index, direction = input_changes(voltage_V, tolerance_V)
    n = len(voltage_V)
    last = np.full(n, -1)
    sign = np.zeros(n)
    if index.size:
        slot = np.searchsorted(index, np.arange(n), side="right") - 1
        valid = slot >= 0
        last[valid] = index[slot[valid]]
        sign[valid] = direction[slot[valid]]
    elapsed = np.where(last >= 0, (np.arange(n) - last) * sample_period_s, np.nan)
    return elapsed, sign


def binned_mean(x, values, edges):
    """Mean of ``values`` in each bin of ``x`` (NaN for an empty bin) and the counts."""
    x = np.asarray(x, dtype=float)
    values = np.asarray(values, dtype=float)
    ok = np.isfinite(x) & np.isfinite(values)
    slot = np.digitize(x[ok], edges) - 1
    inside = (slot >= 0) & (slot < len(edges) - 1)
    counts = np.bincount(slot[inside], minlength=len(edges) - 1)
    sums = np.bincount(slot[inside], weights=values[ok][inside], minlength=len(edges) - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(counts > 0, sums / np.maximum(counts, 1), np.nan), counts


def correlation(a, b) -> float:
    """Pearson correlation (0 when either is constant)."""
    a = np.asarray(a, dtype=float) - np.mean(a)
    b = np.asarray(b, dtype=float) - np.mean(b)
    denominator = np.sqrt(np.dot(a, a) * np.dot(b, b))
    return float(np.dot(a, b) / denominator) if denominator > 0 else 0.0


def cross_correlation(residual, signal, max_lag: int):
    """Normalised cross-correlation ρ(k) of ``residual[n]`` with ``signal[n − k]``
    for k = −max_lag … max_lag (positive k: the residual follows the signal).

    Returns ``(lags, rho)``.
    """
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    s = np.asarray(signal, dtype=float) - np.mean(signal)
    n = r.size
    max_lag = int(min(max_lag, n - 1))
    full = scipy.signal.correlate(r, s, mode="full", method="fft")
    centre = n - 1
    lags = np.arange(-max_lag, max_lag + 1)
    denominator = np.sqrt(np.dot(r, r) * np.dot(s, s))
    rho = full[centre + lags] / denominator if denominator > 0 else np.zeros(lags.size)
    return lags, rho


def spectrum(residual, sample_rate_hz: float, segments: int = 4):
    """Welch power spectral density (µm²/Hz) of a residual: ``(frequency_hz, psd)``.

    About ``segments`` Hann-windowed segments with half overlap: a coarse
    frequency grid (sample rate × segments / length) but a steadier estimate.
    """
    r = np.asarray(residual, dtype=float)
    nperseg = int(max(min(r.size, 16), 2 * r.size // (segments + 1)))
    return scipy.signal.welch(r - np.mean(r), fs=sample_rate_hz, nperseg=nperseg)


def dominant_frequency(signal, sample_rate_hz: float) -> float:
    """Frequency (Hz) of the largest peak of the Hann-windowed periodogram of
    ``signal`` (its mean removed), refined by parabolic interpolation."""
    x = np.asarray(signal, dtype=float)
    if x.size < 8:
        return 0.0
    power = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(x.size))) ** 2
    k = 1 + int(np.argmax(power[1:]))
    shift = 0.0
    if 1 < k < power.size - 1:
        a, b, c = np.log(power[k - 1:k + 2] + 1e-300)
        shift = 0.5 * (a - c) / (a - 2 * b + c) if a - 2 * b + c != 0 else 0.0
    return float((k + shift) * sample_rate_hz / x.size)


def motion_within_holds(residual_um, runs, noise_um: float) -> tuple:
    """How much the residual moves inside holds of the input, beyond its noise (σ²).

    Inside a hold (:func:`pysim.diagnosis.folds.hold_runs`) a rate-independent
    actuator's output, and a rate-independent model's prediction, stay
    constant: the residual's spread about its mean in each hold is noise,
    whatever shape error the model makes.  Creep, a lag, a delay or a slew
    limit keep it moving after the step, and a disturbance at any time.

    Parameters
    ----------
    residual_um : array_like
    runs : list of (first, stop)
    noise_um : float
        The noise σ of the record.

    Returns
    -------
    (excess_sigma2, degrees_of_freedom)
        The mean square about each hold's mean, per degree of freedom, over
        σ², minus one (NaN without a positive σ or a degree of freedom: no
        measure); and the degrees of freedom (samples less one per hold).

    Examples
    --------
    >>> r = np.random.default_rng(0).normal(0.0, 1.0, 2000)
    >>> excess, dof = motion_within_holds(r, [(0, 1000), (1000, 2000)], 1.0)
    >>> abs(excess) < 0.15, dof
    (True, 1998)
    >>> settling = 3.0 * np.exp(-np.arange(1000) / 50.0)           # 3 σ after each step, τ = 50 samples
    >>> excess, _ = motion_within_holds(r + np.tile(settling, 2), [(0, 1000), (1000, 2000)], 1.0)
    >>> round(excess, 1)
    0.2
    """
    r = np.asarray(residual_um, dtype=float)
    spread, dof = 0.0, 0
    for first, stop in runs:
        piece = r[first:stop]
        if piece.size > 1:
            spread += float(np.sum((piece - piece.mean()) ** 2))
            dof += piece.size - 1
    if dof == 0 or not noise_um > 0:
        return math.nan, dof
    return spread / dof / noise_um**2 - 1.0, dof


def residual_statistics(residual_um, voltage_V, sample_rate_hz: float, noise_um: float) -> dict:
    """The statistics of :mod:`pysim.diagnosis.diagnose`'s evidence, for one stretch of record.

    Parameters
    ----------
    residual_um : array_like
        Measured minus simulated displacement, µm.
    voltage_V : array_like
        Input over the same samples, V.
    sample_rate_hz : float
    noise_um : float
        Noise level (σ, µm) the residual is compared with.

    Returns
    -------
    dict of plain numbers:

    ``rms_um``, ``rms_over_noise``
        Size of the residual, absolutely and in units of the noise.
    ``rate_correlation``
        Correlation of the residual with dv/dt (a delay or lag gives ≈ −1).
    ``input_xcorr_peak``, ``input_xcorr_lag_s``; ``rate_xcorr_peak``, ``rate_xcorr_lag_s``
        Largest |ρ| of the lagged cross-correlations and its lag.
    ``creep_log_correlation``
        Correlation of the direction-signed residual with ln(time since the
        last change) on samples more than 10 samples after a change (creep
        makes it grow with log time).
    ``settling_fraction``
        Share of the residual's mean square within 20 samples after a change
        (dynamics and delays concentrate there).
    ``low_frequency_fraction``
        Share of the residual power below a fifth of the input's dominant
        frequency (drift lives there).
    ``peak_frequency_hz``, ``peak_over_median``
        Largest spectral peak above twice the input's dominant frequency, away
        from its harmonics, and its height over the median of the spectrum
        there (ringing).
    """
    r = np.asarray(residual_um, dtype=float)
    v = np.asarray(voltage_V, dtype=float)
    T = 1.0 / sample_rate_hz
    rate = np.gradient(v, T)
    tolerance = 0.005 * float(np.ptp(v)) if np.ptp(v) > 0 else 0.0
    max_lag = int(min(r.size // 4, max(10, round(0.05 * r.size))))
    lags, rho_v = cross_correlation(r, v, max_lag)
    _, rho_rate = cross_correlation(r, rate, max_lag)
    elapsed, sign = time_since_change(v, T, tolerance)
    late = np.isfinite(elapsed) & (elapsed > 10 * T)
    signed = r * sign
    creep_corr = correlation(signed[late], np.log(elapsed[late])) if np.count_nonzero(late) > 10 else 0.0
    early = np.isfinite(elapsed) & (elapsed <= 20 * T)
    total = float(np.sum(r**2))
    f, p = spectrum(r, sample_rate_hz)
    f_input = dominant_frequency(v, sample_rate_hz)
    low = f <= max(f_input / 5.0, f[1] if f.size > 1 else 0.0)
    # ringing shows between the input's harmonics (a loop-shape error sits on them)
    df = f[1] - f[0] if f.size > 1 else 0.0
    harmonic = np.zeros(f.size, dtype=bool)
    if f_input > 0:
        order = np.round(f / f_input)
        harmonic = (order >= 1) & (np.abs(f - order * f_input) <= max(1.5 * df, 0.05 * f_input))
    high = (f > 2.0 * f_input) & ~harmonic
    peak_f, peak_ratio = 0.0, 0.0
    if np.count_nonzero(high) > 3:
        i = int(np.argmax(np.where(high, p, -np.inf)))
        peak_f, peak_ratio = float(f[i]), float(p[i] / max(np.median(p[high]), 1e-300))
    i_v, i_rate = int(np.argmax(np.abs(rho_v))), int(np.argmax(np.abs(rho_rate)))
    rms = float(np.sqrt(np.mean(r**2))) if r.size else 0.0
    return {
        "rms_um": rms,
        "rms_over_noise": rms / noise_um if noise_um > 0 else float("inf"),
        "rate_correlation": correlation(r, rate),
        "input_xcorr_peak": float(rho_v[i_v]), "input_xcorr_lag_s": float(lags[i_v] * T),
        "rate_xcorr_peak": float(rho_rate[i_rate]), "rate_xcorr_lag_s": float(lags[i_rate] * T),
        "creep_log_correlation": creep_corr,
        "settling_fraction": float(np.sum(r[early] ** 2) / total) if total > 0 else 0.0,
        "low_frequency_fraction": float(np.sum(p[low]) / np.sum(p)) if np.sum(p) > 0 else 0.0,
        "input_frequency_hz": f_input,
        "peak_frequency_hz": peak_f, "peak_over_median": peak_ratio,
    }
