"""Where a record is cut to fit and to score.

The diagnosis judges every model out of sample, so it needs the parts of a
record to fit on and the parts to score on: contiguous blocks for the blocked
cross-validation (:func:`make_folds`; a held-out sample is scored only where
its input stays inside the range, and moves by no larger a step, than the
training blocks showed), a split of different character (:func:`character_split`:
fitted on the slowest blocks, scored on the fastest), the responses to steps
into holds (:func:`step_windows`) and the samples at the start that output
stages, starting at rest, may not yet follow (:func:`settle_samples`).
Nothing here fits a model: these are index sets of the voltage alone.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.ndimage

from pysim.diagnosis.errors import DiagnosisError
from pysim.diagnosis.validation import RANGE_TOLERANCE_FRACTION, inside_range

__all__ = ["N_FOLDS", "STEP_SHARE", "STEP_RISE_SAMPLES", "HOLD_SHARE", "SETTLE_MIN_SAMPLES",
           "SETTLE_FRACTION", "DEFAULT_TRAIN_FRACTION", "WIDER_RANGE_SHARE", "Split", "input_period",
           "split_record", "range_beyond_first", "make_folds", "character_split", "step_windows",
           "CREEP_HOLD_S", "holds_after_a_step", "hold_runs"]


#: Contiguous blocks of the blocked cross-validation (each held out once).
N_FOLDS = 5
#: A step into a hold (:func:`step_windows`): the input moves this share of its span or more within
#: STEP_RISE_SAMPLES samples, then stays within HOLD_SHARE of its span while the response settles.
STEP_SHARE = 0.05
STEP_RISE_SAMPLES = 3
HOLD_SHARE = 0.01
#: A hold after a step this long (s) shows creep plainly: its slow modes keep moving while the
#: input rests, which no rate-independent model can follow.  A record without one can hide creep
#: that the hysteresis fit absorbs on a moving input.
CREEP_HOLD_S = 0.25
#: Samples at the start left out of fitting and scoring the extensions: their output
#: stages start at rest, the actuator may not have been (the larger of the two).
SETTLE_MIN_SAMPLES = 20
SETTLE_FRACTION = 0.01
DEFAULT_TRAIN_FRACTION = 0.65
#: A second record whose input covers the first's range and reaches beyond it by more than this
#: share of the range both span together is the one the models are fitted on (when it names an effect).
WIDER_RANGE_SHARE = 0.10
_PERIODIC_CORRELATION = 0.9


@dataclass
class Split:
    """Where the report shades a held-out part (the last cross-validation block).

    Attributes
    ----------
    warmup : int
        Samples left out at the start (0: the initial state is estimated).
    split : int
        First sample of the last block.
    n_samples : int
    period_samples : float or None
        Input period when the input is periodic.
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
    """Training / held-out split of one record, for a single hold-out.

    With ``warmup="auto"`` nothing is left out at the start (the identification
    estimates the initial operator state), so no record is refused for
    reaching its extremes late.  The first ``train_fraction`` trains; for a
    periodic input the split moves to the nearest whole number of periods.

    Examples
    --------
    >>> v = 50 + 50 * np.sin(2 * np.pi * np.arange(20000) / 400.0)
    >>> s = split_record(v, 0.65)
    >>> s.warmup, round(s.period_samples), round(s.split / s.period_samples, 2)
    (0, 400, 32.0)
    """
    v = np.asarray(voltage_V, dtype=float)
    n = v.size
    if not 0.2 <= train_fraction <= 0.9:
        raise DiagnosisError(f"train fraction must lie in [0.2, 0.9], got {train_fraction}")
    w = 0 if warmup == "auto" else int(warmup)
    usable = n - w
    if usable < 2 * min_samples:
        raise DiagnosisError(f"only {usable} samples after a warm-up of {w}; need {2 * min_samples}")
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


# -------------------------------------------------------------- folds

#: The most of the two records' joint span that only the first may reach for the second to count as
#: the wider record, and the most as a share of what only the second reaches.
FIRST_ONLY_SHARE, FIRST_ONLY_RATIO = 0.1, 0.2


def range_beyond_first(voltage1_V, voltage2_V) -> float:
    """Share of the input range that two records span together which only the second reaches,
    when the second covers the first's (:func:`~pysim.diagnosis.validation.inside_range`: to 0.1 %
    of its span) or nearly: what only the first reaches is at most ``FIRST_ONLY_SHARE`` of the
    joint span and ``FIRST_ONLY_RATIO`` of what only the second reaches; 0 otherwise.

    Models fitted on the first record extrapolate there: its operators never moved that far, and
    scoring on the second record leaves those samples out, so nothing would test them.  A first
    record that goes a little past the second's top, as an outside generator's seed 3 (61-100 V
    against 0-93 V), is still the narrower one by far.

    Examples
    --------
    >>> range_beyond_first([20.0, 80.0, 150.0], [0.0, 149.9, 60.0])
    0.13333333333333333
    >>> round(range_beyond_first([61.3, 100.0], [0.0, 93.1]), 3)
    0.613
    >>> range_beyond_first([0.0, 150.0], [10.0, 140.0]), range_beyond_first([20.0, 150.0], [0.0, 120.0])
    (0.0, 0.0)
    """
    a, b = np.asarray(voltage1_V, dtype=float), np.asarray(voltage2_V, dtype=float)
    low, high = min(a.min(), b.min()), max(a.max(), b.max())
    span = high - low
    if not span > 0:
        return 0.0
    only_second = (max(0.0, a.min() - b.min()) + max(0.0, b.max() - a.max())) / span
    if not inside_range([a.min(), a.max()], b.min(), b.max()).all():
        only_first = (max(0.0, b.min() - a.min()) + max(0.0, a.max() - b.max())) / span
        if only_first > min(FIRST_ONLY_SHARE, FIRST_ONLY_RATIO * only_second):
            return 0.0
    return float(only_second)


def make_folds(voltage_V, n_folds: int = N_FOLDS, min_block: int = 200, settle: int = 0,
               operator_outputs_V=None) -> list:
    """Contiguous blocks and, for each, the samples scored when it is held out.

    Returns
    -------
    list of (train_rows, scored_rows) index arrays: the training rows are the
    other blocks; the scored rows are the block's samples whose input lies
    inside the range of the training rows and changes from the previous sample
    by no more than the input ever does there (a step the training part never
    showed is an extrapolation too, and so are the ``settle`` samples after
    it).  The first ``settle`` samples are
    in neither (where the stages of an extended model still depend on the
    unknown state before the record).

    ``operator_outputs_V`` ((N, m), optional): the outputs of a rate-independent
    model's operators over the record.  Where given, a sample is scored only
    where every operator's output also lies inside its range over the training
    rows (to ``RANGE_TOLERANCE_FRACTION`` of the input's span there).  An input
    inside the training range can still leave an operator where training never
    did -- minor loops remember a peak the other blocks did not reach, and an
    operator keeps that state after the input has come back -- and there
    every rate-independent model extrapolates.

    Examples
    --------
    >>> folds = make_folds(np.r_[np.linspace(0, 10, 500), np.linspace(10, 0, 500)], 2)
    >>> [(t.size, s.size) for t, s in folds]
    [(500, 500), (500, 500)]

    The second half of this record peaks at 9 V, the first at 6 V.  Coming
    back down from 9 V, an operator of threshold 3 V stays above 3 V, where
    the first half never took it, until the input falls to 3 V: from 6 V
    down to 3 V the input is inside the training range, the operator is not.

    >>> from pysim.identification.identify import regressors
    >>> v = np.r_[np.linspace(0, 6, 201), np.linspace(6, 0, 201)[1:], np.linspace(0, 9, 301)[1:],
    ...           np.linspace(9, 0, 301)[1:]]
    >>> A, _ = regressors(v, [3.0], "osp", 0.0, cubic=False)
    >>> [s.size for _, s in make_folds(v, 2)], [s.size for _, s in make_folds(v, 2, operator_outputs_V=A[:, 1:2])]
    ([501, 285], [501, 189])
    """
    v = np.asarray(voltage_V, dtype=float)
    step = np.abs(np.diff(v, prepend=v[:1]))
    k = int(max(2, min(n_folds, v.size // min_block)))
    blocks = np.array_split(np.arange(v.size), k)
    folds = []
    for j, block in enumerate(blocks):
        train = np.concatenate([b for i, b in enumerate(blocks) if i != j])
        train = train[train >= settle]
        lo, hi = v[train].min(), v[train].max()
        fastest = step[train].max()
        ok = inside_range(v[block], lo, hi) & (block >= settle)
        if operator_outputs_V is not None:
            margin = RANGE_TOLERANCE_FRACTION * (hi - lo)
            seen = operator_outputs_V[train]
            held = operator_outputs_V[block]
            ok &= np.all((held >= seen.min(axis=0) - margin) & (held <= seen.max(axis=0) + margin), axis=1)
        for k in np.flatnonzero(step[block] > fastest):
            ok[k:k + max(settle, 1)] = False        # a step never seen, and the response settling after it
        folds.append((train, block[ok]))
    return folds


def character_split(voltage_V, sample_period_s: float, n_blocks: int = N_FOLDS):
    """A split of different character: train on the blocks where the input moves
    slowest, score on the fastest (within the training range).

    Returns ``(train_rows, scored_rows, description)`` or None when the record is too short.
    """
    v = np.asarray(voltage_V, dtype=float)
    if v.size < 4 * 200:
        return None
    blocks = np.array_split(np.arange(v.size), max(4, min(n_blocks, v.size // 200)))
    rate = [float(np.sqrt(np.mean(np.diff(v[b]) ** 2))) / sample_period_s for b in blocks]
    order = np.argsort(rate)
    n_train = int(math.ceil(len(blocks) / 2))
    train = np.sort(np.concatenate([blocks[i] for i in order[:n_train]]))
    test = np.sort(np.concatenate([blocks[i] for i in order[n_train:]]))
    lo, hi = v[train].min(), v[train].max()
    scored = test[inside_range(v[test], lo, hi)]
    slow, fast = np.mean([rate[i] for i in order[:n_train]]), np.mean([rate[i] for i in order[n_train:]])
    return train, scored, (f"trained on the {n_train} blocks with the slowest input (RMS rate {slow:.4g} V/s), "
                           f"scored on the others ({fast:.4g} V/s)")


def settle_samples(n_samples: int) -> int:
    """Samples at the start of a record (and after an unseen step) left to settle."""
    return int(max(SETTLE_MIN_SAMPLES, SETTLE_FRACTION * n_samples))


def _stepped(v, span: float) -> np.ndarray:
    """Per sample: the input has moved at least ``STEP_SHARE`` of ``span`` within the last
    ``STEP_RISE_SAMPLES`` samples (the start of the record taken as held before it)."""
    before = v[np.maximum(np.arange(v.size) - STEP_RISE_SAMPLES, 0)]
    return np.abs(v - before) >= STEP_SHARE * span


def step_windows(voltage_V, window: int) -> list:
    """The responses to steps into holds: ``(first, stop)`` sample ranges.

    A step is a move of at least ``STEP_SHARE`` of the input's span within
    ``STEP_RISE_SAMPLES`` samples, into a hold: the input then stays within
    ``HOLD_SHARE`` of its span for ``window`` samples.  The range runs from
    the start of the rise to the end of the hold's first ``window`` samples,
    where a fast stage (a delay, a lag, a slew limit) shows in a few samples
    that the median over cross-validation blocks never weighs.

    Examples
    --------
    >>> v = np.repeat([0.0, 10.0, 2.0, 2.05], [300, 300, 300, 300])
    >>> step_windows(v, 50)
    [(297, 350), (597, 650)]
    """
    v = np.asarray(voltage_V, dtype=float)
    span = float(np.ptp(v)) if v.size else 0.0
    if not span > 0 or v.size < 2 * window or window < 1:
        return []
    # spread of the input over the next `window` samples, for every start
    ahead_max = scipy.ndimage.maximum_filter1d(v, window, origin=-(window // 2))
    ahead_min = scipy.ndimage.minimum_filter1d(v, window, origin=-(window // 2))
    holds = (ahead_max - ahead_min) <= HOLD_SHARE * span
    holds[v.size - window + 1:] = False
    starts = np.flatnonzero(holds & _stepped(v, span))
    windows, stop = [], 0
    for k in starts:
        first = max(int(k) - STEP_RISE_SAMPLES, 0)
        if first >= stop:
            stop = int(k) + window
            windows.append((first, stop))
    return windows


def holds_after_a_step(voltage_V, sample_rate_hz: float, hold_s: float = CREEP_HOLD_S) -> bool:
    """Whether a step of the input goes into a hold of at least ``hold_s`` seconds.

    A step and a hold are those of :func:`hold_runs` (a move of ``STEP_SHARE``
    of the span or more, then a rest within ``HOLD_SHARE`` of the first sample
    at the new level), the holds the diagnosis measures motion in.

    Examples
    --------
    >>> v = np.repeat([0.0, 10.0, 2.0], [1000, 1000, 100])
    >>> holds_after_a_step(v, 1000.0, 0.25), holds_after_a_step(v, 1000.0, 2.0)
    (True, False)
    """
    return bool(hold_runs(voltage_V, max(int(math.ceil(float(hold_s) * float(sample_rate_hz))), 1)))


def hold_runs(voltage_V, min_samples: int = 10) -> list:
    """Every hold after a step, whole: ``(first, stop)`` sample ranges.

    A step is a move of at least ``STEP_SHARE`` of the input's span within
    ``STEP_RISE_SAMPLES`` samples; its hold starts at the first sample at the
    new level and lasts while the input stays within ``HOLD_SHARE`` of its
    span of that sample.  With the input linear between samples, a
    rate-independent actuator's output is constant from ``first`` on, so
    whatever the displacement does inside a hold is an effect of time.
    Holds shorter than ``min_samples`` are left out.

    Examples
    --------
    >>> v = np.repeat([0.0, 10.0, 2.0, 2.05, 7.0], [30, 40, 20, 20, 5])
    >>> hold_runs(v, 10)
    [(30, 70), (70, 110)]
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    span = float(np.ptp(v)) if v.size else 0.0
    if not span > 0 or v.size <= STEP_RISE_SAMPLES:
        return []
    moved = _stepped(v, span)
    # the first sample at the new level: the input does not move on by more than HOLD_SHARE next
    arrived = np.zeros(v.size, dtype=bool)
    arrived[:-1] = moved[:-1] & (np.abs(v[1:] - v[:-1]) <= HOLD_SHARE * span)
    runs, stop = [], 0
    for first in np.flatnonzero(arrived).tolist():
        if first < stop:
            continue
        away = np.flatnonzero(np.abs(v[first:] - v[first]) > HOLD_SHARE * span)
        stop = first + (int(away[0]) if away.size else v.size - first)
        if stop - first >= min_samples:
            runs.append((first, stop))
    return runs


def record_folds(voltage_V):
    """The blocked cross-validation folds of a record (its start left to settle) and the mask of
    the samples they score."""
    v = np.asarray(voltage_V, dtype=float)
    folds = make_folds(v, settle=settle_samples(v.size))
    mask = np.zeros(v.size, dtype=bool)
    for _, scored in folds:
        mask[scored] = True
    return folds, mask


def step_folds(windows, settle: int, n_samples: int) -> list:
    """The step ``windows`` as cross-validation folds: at most ``N_FOLDS`` groups (round robin), each
    scored on its windows and trained on every other sample after ``settle``."""
    folds = []
    for j in range(min(N_FOLDS, len(windows))):
        keep = np.ones(n_samples, dtype=bool)
        keep[:settle] = False
        group = windows[j::N_FOLDS]
        for first, stop in group:
            keep[first:stop] = False
        folds.append((np.flatnonzero(keep), np.concatenate([np.arange(a, b) for a, b in group])))
    return folds


def contiguous_blocks(n_samples: int, n_blocks: int = N_FOLDS) -> list:
    """Each block predicted from all the others (for a second record's path correction)."""
    blocks = np.array_split(np.arange(n_samples), n_blocks)
    return [(np.concatenate([b for j, b in enumerate(blocks) if j != i]), block) for i, block in enumerate(blocks)]
