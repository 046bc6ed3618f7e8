"""Excitations that separate causes a record cannot tell apart.

On a single sine, a delay, a lag after the hysteresis, a low-pass before it
and creep all look like a phase shift; a slow drift looks like a loop that
does not close.  :func:`separating_excitation` writes a voltage record, within
the actuator's range, made of the parts that pull them apart:

- a **slow full-range cycle** at the start and the same at the end: the
  hysteresis is identified on it, and a drift shows as the gap between the two;
- **sines at several frequencies** (from a few hundred samples per period to
  about twenty) at a large and a small amplitude, and at the small amplitude
  on up to five samples per period: a delay's phase grows in proportion to
  the frequency while a lag's saturates and its amplitude drops (a stage
  whose corner lies above a twentieth of the sample rate looks like a
  fraction of a sample's delay below it, and shows its own shape only near
  its corner; small, so that an amplifier's slew limit does not bite);
  a low-pass before the hysteresis changes the loop's *shape* with frequency
  and amplitude, a lag after it only scales and shifts it; a slew limit only
  bites on the large, fast ones;
- **steps held long** (to several levels, up and down): creep keeps moving for
  decades of time during a hold, dynamics and delays settle within a few time
  constants, a slew limit turns the step into a ramp.

Only the parts that concern the causes in question are included (the two
slow cycles always are); every part starts and ends where the previous one
left the input, so the record has no jumps except the steps.
"""
from __future__ import annotations

import math

import numpy as np

from pysim.diagnosis.errors import DiagnosisError
from pysim.diagnosis.folds import CREEP_HOLD_S
from pysim.identification.data import checked_sample_rate

__all__ = ["separating_excitation", "samples_for_holds"]

_FREQUENCY_CAUSES = {"delay", "rate_dependence", "rate_dependent_hysteresis", "slew_limit"}
#: Levels of the steps part, as shares of the range (each held a sixth of the part).
_STEP_LEVELS = (0.85, 0.25, 0.95, 0.1, 0.6, 0.05)


def _ramp(a, b, n):
    return np.linspace(a, b, max(int(n), 2))


def separating_excitation(causes, voltage_range_V, sample_rate_hz: float, n_samples: int = 20000,
                          candidates: dict = None):
    """Voltage record (V) that separates ``causes``, and its plan.

    Parameters
    ----------
    causes : iterable of str
        The causes to separate (names of the diagnosis catalogue).
    voltage_range_V : (float, float)
        The actuator's range: the record stays inside it.
    sample_rate_hz : float
        Sample rate the record is played at.
    n_samples : int
        Length of the record (at least 2000).
    candidates : dict, optional
        Cause → fitted parameters; creep time constants set the hold length.

    Returns
    -------
    voltage_V : ndarray
    plan : list of dict
        ``{"purpose", "start_sample", "samples"}`` for every part.

    Examples
    --------
    >>> v, plan = separating_excitation(["delay", "rate_dependence"], (0.0, 100.0), 1000.0, 8000)
    >>> v.size, bool(v.min() >= 0.0 and v.max() <= 100.0), [p["purpose"].split(":")[0] for p in plan]
    (8000, True, ['slow full-range cycle', 'sines at several frequencies and two amplitudes', 'slow full-range cycle'])
    """
    causes = set(causes)
    lo, hi = (float(x) for x in voltage_range_V)
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise DiagnosisError(f"voltage range must be finite with low < high, got {voltage_range_V}")
    sample_rate_hz = checked_sample_rate(sample_rate_hz, "sample rate", DiagnosisError)
    n_samples = int(n_samples)
    if n_samples < 2000:
        raise DiagnosisError(f"an excitation needs at least 2000 samples, got {n_samples}")
    span, mid = hi - lo, 0.5 * (lo + hi)
    parts = _parts(causes)
    weights = np.array([w for _, w, _ in parts])
    lengths = np.floor(weights / weights.sum() * n_samples).astype(int)
    lengths[-1] += n_samples - lengths.sum()
    pieces, plan, start, level = [], [], 0, lo
    taus = (candidates or {}).get("creep", {}).get("time_constants_s", [])
    for (purpose, _, kind), n in zip(parts, lengths):
        if kind == "cycle":
            a = int(n * 0.45)
            piece = np.concatenate((_ramp(level, lo, n - 2 * a), _ramp(lo, hi, a), _ramp(hi, lo, a)))[:n]
        elif kind == "sines":
            piece = _sines(n, sample_rate_hz, lo, span, mid, level)
        else:
            piece = _steps(n, sample_rate_hz, lo, span, level, taus)
        piece = np.clip(piece[:n], lo, hi)
        if piece.size < n:
            piece = np.concatenate((piece, np.full(n - piece.size, piece[-1])))
        pieces.append(piece)
        plan.append({"purpose": purpose, "start_sample": int(start), "samples": int(n)})
        start += n
        level = float(piece[-1])
    return np.concatenate(pieces), plan


def _parts(causes: set) -> list:
    """``(purpose, weight, kind)`` of every part the causes call for, in playing order."""
    parts = [("slow full-range cycle: identifies the hysteresis; compared with the last one it shows drift",
              1.0, "cycle")]
    if causes & _FREQUENCY_CAUSES:
        parts.append(("sines at several frequencies and two amplitudes: a delay's phase grows with frequency, a "
                      "lag's saturates; a low-pass before the hysteresis reshapes the loops; a slew limit bites "
                      "only on large fast ones", 2.0, "sines"))
    if "creep" in causes or "slew_limit" in causes or "drift" in causes or len(causes & _FREQUENCY_CAUSES) < 2:
        parts.append(("steps held long: creep keeps moving during a hold, dynamics and delays settle, a slew "
                      "limit turns a step into a ramp", 2.0, "steps"))
    parts.append(("slow full-range cycle: the same as the first; a gap between them is drift", 1.0, "cycle"))
    return parts


def samples_for_holds(causes, sample_rate_hz: float, hold_s: float = CREEP_HOLD_S) -> int:
    """The shortest excitation for ``causes`` whose steps are each held ``hold_s`` seconds or more.

    A creep that the hysteresis fit absorbs on a moving input shows only in
    a hold long enough for its slow modes to move (``CREEP_HOLD_S``); at a
    high sample rate the default length of an excitation is too short for
    that.  The result is at least 2000 (the shortest excitation), and 2000
    when ``causes`` call for no steps.

    Examples
    --------
    >>> samples_for_holds(["creep"], 2000.0), samples_for_holds(["creep"], 100.0)
    (6012, 2000)
    """
    sample_rate_hz = checked_sample_rate(sample_rate_hz, "sample rate", DiagnosisError)
    parts = _parts(set(causes))
    share = sum(w for _, w, kind in parts if kind == "steps") / sum(w for _, w, _ in parts)
    if share == 0:
        return 2000
    hold = math.ceil(float(hold_s) * sample_rate_hz)
    # the steps part is floor(share * n) samples long and holds each of its levels a sixth of it
    return max(2000, math.ceil((len(_STEP_LEVELS) * hold + len(_STEP_LEVELS)) / share))


def _sines(n, fs, lo, span, mid, level):
    """Bursts of sines: large ones at five frequencies (fs/400 … fs/20), then small ones at seven
    (fs/400 … fs/5)."""
    large, small = 0.45 * span, 0.15 * span
    bursts = ([(f, large) for f in np.geomspace(fs / 400.0, fs / 20.0, 5)]
              + [(f, small) for f in np.geomspace(fs / 400.0, fs / 5.0, 7)])
    each = max(n // len(bursts), 20)
    out = []
    for f, a in bursts:
        k = np.arange(each)
        lead = min(each // 5, 50)
        burst = mid + a * np.sin(2 * np.pi * f * k / fs)
        # fade in and out so the input starts and ends at the centre without a jump
        envelope = np.clip(np.minimum(k, each - 1 - k) / max(lead, 1), 0.0, 1.0)
        burst = mid + (burst - mid) * envelope
        out.append(burst)
    piece = np.concatenate(out)
    ease = _ramp(level, mid, min(50, n // 10))
    return np.concatenate((ease, piece))[:n]


def _steps(n, fs, lo, span, level, taus):
    """Steps to alternating high and low levels, each held long."""
    levels = lo + span * np.array(_STEP_LEVELS)
    hold = n // len(levels)
    if len(taus):
        # short enough for more steps when the fitted creep is fast, never shorter than creep needs to show
        hold = int(min(hold, max(3 * max(taus) * fs, hold // 2, math.ceil(CREEP_HOLD_S * fs))))
    out = [np.full(hold, x) for x in levels]
    piece = np.concatenate(out)
    return np.concatenate((piece, np.full(max(n - piece.size, 0), levels[-1])))
