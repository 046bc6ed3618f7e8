"""What a record shows that no model of the actuator explains: sensor and logger artefacts.

Every cause of the diagnosis catalogue acts on the actuator, and the
actuator's displacement is continuous: it neither leaps between two samples
while the voltage is steady nor freezes while the voltage moves.  Three
things a rig's record can nevertheless hold, found here from the record and
the plain fit's residual (measured − simulated displacement):

``spike``
    A single sample far off both of its neighbours, which agree with each
    other (a glitch of the sensor, the ADC or the logger).
``jump``
    A step of the residual between two samples that stays, while the input
    is steady (no input step in the 20 samples before and 5 after, so a
    delayed or lagging response to an input step is never one; a step is a
    large change of the input at which its slope changes by as much, so the
    samples of fast sines are not steps): the sensor's
    zero, its mount or the stage moved.  Either the step itself stands out
    with the samples around it quiet, or, away from the input's corners too,
    straight lines through the 50 samples on either side, each fitting them
    to the noise, differ at the step by as much (their average over 50
    samples sees a smaller jump through the noise of single steps).
    There are few: an actuator that steps where its relays switch steps
    back on the way down, and does so every cycle (more than
    :data:`MAX_JUMPS` are taken as the actuator's).
``flat``
    The displacement repeats exactly the same value for many samples while
    the fitted model moves by half the limit below or more, and misses the
    reading by as much (``clipped`` at the record's maximum or minimum: the
    sensor or its amplifier saturates; ``stuck`` elsewhere: a frozen
    reading).  A quantised sensor repeats its value during a hold, where the
    model does not move.
``hum``
    A sinusoid at a mains frequency (50 or 60 Hz or a low harmonic of
    either, searched ±1 % around it) through the whole record, which the
    input does not drive: pickup of the sensor, its cable or the amplifier.
    It must stand out of the residual's spectrum beside it (a line, not the
    dense spectrum a multisine's misfit fills), keep its amplitude and phase
    over parts of the record of a few periods each (a misfit that follows the input changes with
    it: a chirp passing 50 Hz), lie on no low multiple of a line that holds
    much of the input (a steady 10 Hz sine's loops have a fifth harmonic at
    50 Hz) and carry at least half a noise σ RMS (a weaker line adds the
    same error to every model and changes no verdict).  At 3 noise σ RMS, a
    50 Hz hum left the best rate-independent model 6-11 σ² out of sample on
    seven of twenty records without an effect, which were then called
    ``unexplained``.

Each must stand :data:`ARTEFACT_SIGMAS` noise σ out of what the noise makes,
so white noise alone shows one with a probability below 10⁻¹⁵ per sample.
They bias every fit, and a jump looks like drift or creep to the catalogue,
so the diagnosis looks for them first (:func:`find_artefacts`, on the plain
fit of each record) and repairs the two that can be repaired without
guessing (:func:`repaired_displacement`): a spike becomes the mean of its
neighbours, the displacement after a jump is shifted back by the jump, and a
hum's sinusoid is subtracted.
A flat run hides what the sensor did not see; it is reported, not filled.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.fft
import scipy.optimize

from pysim.diagnosis.residuals import record_noise_sigma
from pysim.identification.errors import IdentificationError
from pysim.identification.identify import identify

__all__ = ["ARTEFACT_SIGMAS", "FLAT_RUN_SAMPLES", "MAX_JUMPS", "MAINS_HZ", "REPAIRABLE", "KIND_PLURALS",
           "record_artefacts", "find_artefacts", "mains_hums", "repaired_displacement", "artefacts_sentence",
           "artefact_label"]

#: An artefact stands this many noise σ out of what the noise makes.
ARTEFACT_SIGMAS = 10.0
#: A run of identical displacement samples this long (or longer) while the model moves is flat.
FLAT_RUN_SAMPLES = 20
#: Samples after (and before) an input step where the model's own errors gather (delays, lags,
#: ringing): no jump or spike is looked for there.
_AFTER_INPUT_STEP, _BEFORE_INPUT_STEP = 20, 5
#: A jump's neighbours: the residual's other steps within this many samples are small.
_QUIET = 5
#: A jump between two local lines: each is fitted on this many samples on its side ...
_LINE_SAMPLES = 50
#: ... and leaves at most this many noise σ RMS (white noise leaves 1 ± 0.1: more is a shape of the
#: residual's own, which bends the lines: where the actuator moves fast, an effect's error changes
#: within a few samples, and 20-sample lines took such places on chirps and band noise for jumps);
#: the samples tried are those whose one-sample step stands this many of its noise σ (σ√2) out
#: (at 4, one of 594 generated records without an artefact showed a jump, and with lines of 20
#: samples six of 491: a step of 5.7-6.0 σ of the residual's own between lines its curvature set
#: apart, at turns of the input and where a chirp or band noise moves the actuator fast)
_LINE_RMS_SIGMAS, _CANDIDATE_SIGMAS = 1.5, 5.0
#: More jumps than this in one record are the actuator's own steps (see :func:`_actuators_own`).
MAX_JUMPS = 3
#: A jump's size is measured on up to this many samples on either side ...
_SIZE_WINDOW = 200
#: ... and again on the fit of the record repaired by it, this many times.
_SIZE_REFITS = 3
#: The kinds :func:`repaired_displacement` repairs.
REPAIRABLE = ("spike", "jump", "hum")
#: Mains frequencies (Hz); a hum is looked for at each and at its harmonics up to the third.
MAINS_HZ, _MAINS_HARMONICS = (50.0, 60.0), 3
#: A hum's frequency is searched this far around its nominal one (share of it): the grid's
#: frequency varies by a few tenths of a percent, a logger's clock by less.
_MAINS_TOLERANCE = 0.01
#: The residual's spectral floor beside a line is read this far around it (share of its frequency),
#: leaving out twice the search band.
_FLOOR_BAND = 0.2
#: A line stands this many times the floor out of it: the largest of the few thousand periodogram
#: values a search reads, of white noise (exponential, mean the floor), exceeds 40 with a probability
#: below 10⁻¹³; a misfit is no white noise (a staircase's repeated steps left 41 at 50 Hz), and a
#: hum of half a noise σ RMS stands n / 8 out over n samples.
_LINE_OVER_FLOOR = 100.0
#: A hum is reported and repaired from this RMS on (noise σ).
_HUM_MIN_RMS_SIGMAS = 0.5
#: The one sinusoid of the whole record removes in its parts of this many periods (four at least)
#: at least this share of what a sinusoid fitted in each part removes there (a stationary line:
#: about 1; a line in one quarter of the record only: 0.25; the misfit of the responses to a
#: staircase's steps, a line of their rate's harmonics, gathers after each step; a multisine's
#: intermodulation beats with its lines' spacing).
_HUM_PERIODS_PER_PART, _HUM_COHERENCE = 4, 0.7
#: The input holds a line of its own at a frequency where its periodogram stands this many times its
#: floor out (a digital command's floor beside a line is its leakage, or nothing).
_INPUT_LINE_OVER_FLOOR = 10.0
#: An input line holding this share of the input's variance or more ...
_DOMINANT_INPUT_SHARE = 0.05
#: ... (half of it or more) makes its first harmonics up to this order no hum (a steady input's loops
#: repeat them).
_INPUT_HARMONICS = 20
#: A search needs this many periods of the line in the record (5 in each of four parts at least).
_HUM_MIN_PERIODS = 20
#: Found spikes and jumps listed one by one at most; more are counted.
_LISTED = 5


def record_artefacts(voltage_V, displacement_um, residual_um, noise_um: float, sample_rate_hz: float) -> list:
    """Spikes, jumps and flat runs in a record (see the module's description).

    Parameters
    ----------
    voltage_V, displacement_um : array_like
        The record.
    residual_um : array_like
        Measured minus simulated displacement of a model fitted to it (µm).
    noise_um : float
        Noise σ of the residual (µm).
    sample_rate_hz : float

    Returns
    -------
    list of dict
        One per artefact, in order of the sample: ``kind`` (``"spike"``,
        ``"jump"``, ``"clipped"``, ``"stuck"`` or ``"hum"``), ``sample``
        (0-based first sample), ``time_s``, ``samples`` (how many), ``size_um``
        (the spike's or jump's size, the largest residual of a flat run, or a
        hum's amplitude) and ``size_over_noise``.  A hum (sample 0, every
        sample) also gives ``frequency_hz``, ``rms_um`` and the sinusoid
        ``cos_um cos(2π c k) + sin_um sin(2π c k)`` at sample ``k`` with
        ``c = cycles_per_sample``.

    Examples
    --------
    >>> k = np.arange(4000)
    >>> v = 50.0 + 40.0 * np.sin(2 * np.pi * k / 1000)
    >>> rng = np.random.default_rng(0)
    >>> y = 0.2 * v + rng.normal(0.0, 0.01, k.size)
    >>> y[2500:] += 0.5                                     # the sensor's zero moves
    >>> y[700] += 0.4                                       # a glitch
    >>> [(a["kind"], a["sample"]) for a in record_artefacts(v, y, y - 0.2 * v, 0.01, 1000.0)]
    [('spike', 700), ('jump', 2499)]
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    r = np.asarray(residual_um, dtype=float).ravel()
    n = v.size
    if not (noise_um > 0 and math.isfinite(noise_um)) or n < 4 * _AFTER_INPUT_STEP or y.size != n or r.size != n:
        return []
    limit = ARTEFACT_SIGMAS * noise_um
    hums = _hums(v, r, noise_um, sample_rate_hz)
    # the other tests read the residual without the hum: a line of a few σ bends the local lines a jump
    # is told by
    r = r - _hum_sum(hums, n)
    near_step = _near_input_steps(v)
    flat = _flat_runs(v, y, r, limit)
    # a frozen reading that comes back steps to the true displacement: that step is the run's end
    ends = {b for a in flat for b in (a["sample"] - 1, a["sample"] + a["samples"] - 1)}
    jumps = [a for a in _jumps(r, limit, near_step, near_step | _near_input_corners(v))
             if not ends & {a["sample"] - 1, a["sample"], a["sample"] + 1}]
    found = hums + _spikes(r, limit, near_step) + _actuators_own(jumps) + flat
    return sorted(_placed(found, noise_um, sample_rate_hz), key=lambda a: a["sample"])


def _placed(found, noise_um: float, sample_rate_hz: float) -> list:
    """``found`` with each artefact's ``time_s`` and ``size_over_noise`` set."""
    for a in found:
        a["time_s"] = a["sample"] / sample_rate_hz
        a["size_over_noise"] = abs(a["size_um"]) / noise_um
    return found


def find_artefacts(voltage_V, displacement_um, sample_rate_hz: float, *, fit=None, **fit_options) -> list:
    """:func:`record_artefacts` of a record against its plain rate-independent fit.

    The fit (:func:`pysim.identification.identify.identify` with
    ``fit_options``, every sample, the initial state estimated) and its
    residual's noise are the record's own; a record that cannot be fitted
    at all has no artefacts to report here (the diagnosis says why it cannot).
    ``fit``: that fit of this very record, when the caller has made it already
    (the diagnosis uses it again); jumps are still measured on refits of the
    repaired record, with ``fit_options``.

    Examples
    --------
    >>> k = np.arange(4000)
    >>> v = 50.0 + 40.0 * np.sin(2 * np.pi * k / 1000)
    >>> y = 0.2 * v + np.random.default_rng(0).normal(0.0, 0.01, k.size)
    >>> y[3000] -= 0.3
    >>> [(a["kind"], a["sample"]) for a in find_artefacts(v, y, 1000.0)]
    [('spike', 3000)]
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    y = np.asarray(displacement_um, dtype=float).ravel()
    if fit is None:
        try:
            fit = identify(v, y, require_excitation=False, **fit_options)
        except IdentificationError:
            return []
    residual = y - fit.prediction_um
    noise = record_noise_sigma(residual, y)
    found = record_artefacts(v, y, residual, noise, sample_rate_hz)
    jumps = [a for a in found if a["kind"] == "jump"]
    if not jumps:
        return found
    near_step = _near_input_steps(v)
    # the smallest jump the lines' test finds: ARTEFACT_SIGMAS standard errors of the difference of
    # two full lines' levels at the step
    smallest = ARTEFACT_SIGMAS * noise * math.sqrt(2.0 * _edge_level_variance(_LINE_SAMPLES))
    while jumps:
        steps = np.array([a["sample"] for a in jumps], dtype=int)
        for _ in range(_SIZE_REFITS):
            # the fit that saw a jump took part of it into its weights and offset: measured again on
            # the fit of the repaired record, what is left of each is added to it
            repaired = repaired_displacement(y, found)
            try:
                residual = repaired - identify(v, repaired, require_excitation=False, **fit_options).prediction_um
            except IdentificationError:
                break
            for a in jumps:
                a["size_um"] += _jump_size(residual, a["sample"], steps, near_step, noise)
        # a large jump bends the fit that saw it, and the bend can pass for a smaller jump elsewhere
        # (independent seed 3, band noise: a 25 σ jump, and a bend measured at 3.5 σ once it was
        # repaired): what no longer stands out on the repaired record's fit is dropped, and the rest
        # measured again without it
        kept = [a for a in found if a["kind"] != "jump" or abs(a["size_um"]) >= smallest]
        if len(kept) == len(found):
            break
        found = kept
        jumps = [a for a in found if a["kind"] == "jump"]
    return found


def repaired_displacement(displacement_um, artefacts) -> np.ndarray:
    """The displacement with its spikes, jumps and hums (:data:`REPAIRABLE`) repaired.

    A spike's sample becomes the mean of its two neighbours; every sample
    after a jump is shifted back by the jump's size; a hum's sinusoid is
    subtracted.  Flat runs are kept.

    Examples
    --------
    >>> y = np.array([0.0, 0.1, 5.0, 0.3, 0.4, 9.5, 9.6])
    >>> found = [{"kind": "spike", "sample": 2, "size_um": 4.8}, {"kind": "jump", "sample": 4, "size_um": 9.0}]
    >>> repaired_displacement(y, found).round(3).tolist()
    [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    """
    y = np.array(displacement_um, dtype=float).ravel()
    for a in artefacts:
        k = int(a["sample"])
        if a["kind"] == "spike" and 0 < k < y.size - 1:
            y[k] = 0.5 * (y[k - 1] + y[k + 1])
        elif a["kind"] == "jump":
            y[k + 1:] -= a["size_um"]
    return y - _hum_sum([a for a in artefacts if a["kind"] == "hum"], y.size)


def _hum_sum(hums, n_samples: int) -> np.ndarray:
    """The sum of the sinusoids of ``hums`` over ``n_samples`` samples (zero without any)."""
    total = np.zeros(n_samples)
    for a in hums:
        total += _wave(n_samples, a["cycles_per_sample"], a["cos_um"], a["sin_um"])
    return total


def _wave(n_samples: int, cycles_per_sample: float, cos_coefficient: float, sin_coefficient: float) -> np.ndarray:
    """``cos_coefficient cos(2π c k) + sin_coefficient sin(2π c k)`` at samples ``k = 0 … n - 1``."""
    phase = 2.0 * np.pi * cycles_per_sample * np.arange(n_samples)
    return cos_coefficient * np.cos(phase) + sin_coefficient * np.sin(phase)


def _sinusoid(x, cycles_per_sample: float) -> tuple:
    """Least-squares ``(cos, sin)`` coefficients of ``x`` at ``cycles_per_sample`` beside a level and a
    slope, and the sum of squares the sinusoid removes."""
    k = np.arange(x.size, dtype=float)
    phase = 2.0 * np.pi * cycles_per_sample * k
    basis = np.column_stack((np.cos(phase), np.sin(phase), np.ones(x.size), k / max(x.size - 1, 1) - 0.5))
    coefficients, *_ = np.linalg.lstsq(basis, x, rcond=None)
    trend, *_ = np.linalg.lstsq(basis[:, 2:], x, rcond=None)
    removed = float(np.sum((x - basis[:, 2:] @ trend) ** 2) - np.sum((x - basis @ coefficients) ** 2))
    return float(coefficients[0]), float(coefficients[1]), removed


def _periodogram(x, n_fft: int) -> np.ndarray:
    """|DFT|² / n of ``x`` without its mean, zero-padded to ``n_fft`` points (bins fs / n_fft apart)."""
    x = np.asarray(x, dtype=float)
    return np.abs(np.fft.rfft(x - x.mean(), n_fft)) ** 2 / x.size


def _dominant_input_lines(v, n_fft: int) -> list:
    """``(cycles per sample, share of the variance)`` of each of the input's lines that holds at least
    :data:`_DOMINANT_INPUT_SHARE` of its variance: the largest peak of the periodogram, refined to
    where one sinusoid removes the most, taken out, and again (a chirp or band noise has none)."""
    x = np.asarray(v, dtype=float) - float(np.mean(v))
    total = float(np.sum(x**2))
    lines = []
    while total > 0 and len(lines) < 1.0 / _DOMINANT_INPUT_SHARE:
        power = _periodogram(x, n_fft)
        peak = int(np.argmax(power[1:])) + 1
        cycles = _best_frequency(x, (peak - 1) / n_fft, (peak + 1) / n_fft)
        cos_v, sin_v, removed = _sinusoid(x, cycles)
        if removed < _DOMINANT_INPUT_SHARE * total:
            break
        lines.append((cycles, removed / total))
        x = x - _wave(x.size, cycles, cos_v, sin_v)
    return lines


def _driven_by_input_lines(cycles: float, lines, n_samples: int) -> bool:
    """Whether ``cycles`` (per sample) is where the actuator's misfit of the input's dominant ``lines``
    (:func:`_dominant_input_lines`) repeats: a sum or difference of up to three of them (a multisine's
    intermodulation: 26.3 + 44.3 + 49.5 Hz put a line at 120.1 Hz), or a harmonic up to
    :data:`_INPUT_HARMONICS` of a line that holds most of the input (a steady sine's or triangle's
    loops); within a quarter of a DFT bin, and a fiftieth of one more per order for the lines' own
    errors (each line found leaks a little into the next one's estimate).  Both lines' frequencies are
    fitted to far less than a bin (a line of half a noise σ RMS over 5000 samples: about a fiftieth);
    two lines a quarter of a bin apart or less blend into one, which is then taken for the
    actuator's."""
    if not lines:
        return False
    frequencies = np.array([c for c, _ in lines])
    most = np.array([c for c, share in lines if share >= 0.5])
    orders = np.arange(1, _INPUT_HARMONICS + 1)[:, None]
    if most.size and np.any(np.abs(cycles - orders * most) <= (0.25 + 0.02 * orders) / n_samples):
        return True
    signed = np.concatenate(([0.0], frequencies, -frequencies))
    combined = signed[:, None, None] + signed[None, :, None] + signed[None, None, :]
    return bool(np.any(np.abs(np.abs(combined) - cycles) <= 0.31 / n_samples))


def _best_frequency(x, low: float, high: float) -> float:
    """The frequency (cycles per sample) between ``low`` and ``high`` where one sinusoid removes the
    most of ``x``."""
    refined = scipy.optimize.minimize_scalar(lambda c: -_sinusoid(x, c)[2], bounds=(max(low, 0.0), high),
                                             method="bounded", options={"xatol": 1e-3 / x.size})
    return float(refined.x)


def mains_hums(voltage_V, residual_um, noise_um: float, sample_rate_hz: float) -> list:
    """The hums (see the module's description) of a residual of any model of a record.

    :func:`record_artefacts` looks for them on the plain fit's residual; where the actuator's own
    effect fills the spectrum around 50 Hz there (a delay on steps and sines), a hum stands out only
    of the residual of a model that holds the effect, which the diagnosis then searches.

    Examples
    --------
    >>> k = np.arange(20000)
    >>> v = 75.0 + 70.0 * np.sin(2 * np.pi * 7.3 * k / 5000.0)
    >>> r = 0.03 * np.sin(2 * np.pi * 50.2 * k / 5000.0) + np.random.default_rng(1).normal(0.0, 0.01, k.size)
    >>> [(a["kind"], round(a["frequency_hz"], 2), round(a["rms_um"], 3)) for a in mains_hums(v, r, 0.01, 5000.0)]
    [('hum', 50.2, 0.021)]
    """
    v = np.asarray(voltage_V, dtype=float).ravel()
    r = np.asarray(residual_um, dtype=float).ravel()
    if not (noise_um > 0 and math.isfinite(noise_um)) or r.size != v.size or not np.all(np.isfinite(r)):
        return []
    return _placed(_hums(v, r, noise_um, sample_rate_hz), noise_um, sample_rate_hz)


def _floor(power, nominal_hz: float, bin_hz: float) -> float:
    """The mean of a periodogram's noise beside the mains frequency ``nominal_hz`` (the median of its
    values within :data:`_FLOOR_BAND` of it, outside twice the search band, over ln 2: the median of an
    exponential distribution)."""
    beside = np.r_[power[int(nominal_hz * (1 - _FLOOR_BAND) / bin_hz):
                         int(nominal_hz * (1 - 2 * _MAINS_TOLERANCE) / bin_hz)],
                   power[int(nominal_hz * (1 + 2 * _MAINS_TOLERANCE) / bin_hz) + 1:
                         int(nominal_hz * (1 + _FLOOR_BAND) / bin_hz) + 1]]
    return float(np.median(beside)) / math.log(2.0)


def _hums(v, r, noise_um: float, sample_rate_hz: float) -> list:
    """Mains lines of the residual ``r`` that no line of the input ``v`` drives (see the module)."""
    n = r.size
    duration = n / sample_rate_hz
    nominal = sorted({k * f for f in MAINS_HZ for k in range(1, _MAINS_HARMONICS + 1)
                      if k * f * (1 + _FLOOR_BAND) < 0.5 * sample_rate_hz and k * f * duration >= _HUM_MIN_PERIODS})
    if not nominal:
        return []
    n_fft = scipy.fft.next_fast_len(4 * n)
    power = _periodogram(r, n_fft)
    bin_hz = sample_rate_hz / n_fft
    padding = int(math.ceil(n_fft / n))                 # bins of the padded DFT per bin of the record's
    input_lines = input_power = None
    found = []
    for f0 in nominal:
        lo = int(math.floor(f0 * (1 - _MAINS_TOLERANCE) / bin_hz))
        hi = int(math.ceil(f0 * (1 + _MAINS_TOLERANCE) / bin_hz))
        peak = lo + int(np.argmax(power[lo:hi + 1]))
        if not power[peak] > _LINE_OVER_FLOOR * _floor(power, f0, bin_hz):
            continue
        # the frequency where one sinusoid removes the most, between the bins beside the peak
        cycles = _best_frequency(r, (peak - 1) / n_fft, (peak + 1) / n_fft)
        cos_um, sin_um, removed = _sinusoid(r, cycles)
        rms = math.sqrt(0.5 * (cos_um**2 + sin_um**2))
        if rms < _HUM_MIN_RMS_SIGMAS * noise_um:
            continue
        # the same line over the whole record: each part's own sinusoid removes little more there
        line = _wave(n, cycles, cos_um, sin_um)
        own = global_ = 0.0
        for part in np.array_split(np.arange(n), max(4, int(cycles * n / _HUM_PERIODS_PER_PART))):
            own += _sinusoid(r[part], cycles)[2]
            global_ += float(np.sum(r[part] ** 2) - np.sum((r[part] - line[part]) ** 2))
        if not global_ >= _HUM_COHERENCE * own:
            continue
        # the input's own line there drives the actuator there (a multisine's component, a square wave's
        # harmonic): the residual's line is then the actuator's misfit of it
        if input_power is None:
            input_power = _periodogram(v, n_fft)
        near = int(round(cycles * n_fft))
        input_line = np.max(input_power[max(near - padding, 0):near + padding + 1])
        if input_line > _INPUT_LINE_OVER_FLOOR * _floor(input_power, f0, bin_hz):
            continue
        if input_lines is None:
            input_lines = _dominant_input_lines(v, n_fft)
        if _driven_by_input_lines(cycles, input_lines, n):
            continue
        found.append({"kind": "hum", "sample": 0, "samples": n, "size_um": math.hypot(cos_um, sin_um),
                      "rms_um": rms, "frequency_hz": cycles * sample_rate_hz, "cycles_per_sample": cycles,
                      "cos_um": cos_um, "sin_um": sin_um})
    return found


def _near_input_steps(v) -> np.ndarray:
    """Samples within reach of an input step: a one-sample change of the input five times its median
    change (and more than 0.1 % of its range) at which the input's slope changes by as much, from
    ``_BEFORE_INPUT_STEP`` before to ``_AFTER_INPUT_STEP`` after."""
    change = np.diff(v)
    dv = np.abs(change)
    large = max(5.0 * float(np.median(dv)), 1e-3 * float(np.ptp(v)))
    step = dv > large
    # a fast stretch of the input changes that much at every sample and is no step: the sines after a
    # staircase whose holds set the median, a chirp's fast end (taken for steps, they hid 10-48 % of
    # steps-and-sines records from the search).  What a step does to a model's error (a fractional
    # delay's one-sample pulse) follows the change of the slope, so a large one marks it
    if change.size > 1:
        bend = np.abs(np.diff(change))
        into, out_of = np.concatenate(([np.inf], bend)), np.concatenate((bend, [np.inf]))
        step &= np.maximum(into, out_of) > large
    # dv[k] is the change from sample k to k + 1: reach from k back and from k + 1 on
    return _within_reach(v.size, np.flatnonzero(step), _BEFORE_INPUT_STEP, _AFTER_INPUT_STEP + 1)


def _near_input_corners(v) -> np.ndarray:
    """Samples within reach of a corner of the input: its slope changes within one sample by five
    times its median change and by more than 0.01 % of its range (a triangle's turn), from
    ``_BEFORE_INPUT_STEP`` before to ``_AFTER_INPUT_STEP`` after.  A lag's or a delay's error
    follows the input's slope, so it flips there between two samples."""
    bend = np.abs(np.diff(v, 2))           # bend[k]: the slope's change at sample k + 1
    corner = bend > max(5.0 * float(np.median(bend)), 1e-4 * float(np.ptp(v))) if bend.size else bend
    return _within_reach(v.size, np.flatnonzero(corner) + 1, _BEFORE_INPUT_STEP, _AFTER_INPUT_STEP)


def _within_reach(n_samples: int, samples, before: int, after: int) -> np.ndarray:
    """Of ``n_samples``, those from ``before`` before to ``after`` after any of ``samples``."""
    edges = np.zeros(n_samples + 1, dtype=np.int64)
    samples = np.asarray(samples, dtype=np.int64)
    np.add.at(edges, np.clip(samples - before, 0, n_samples), 1)
    np.add.at(edges, np.clip(samples + after + 1, 0, n_samples), -1)
    return np.cumsum(edges[:n_samples]) > 0


def _edge_level_variance(n_samples: int) -> float:
    """The variance (per unit noise variance) of the level that a straight line through
    ``n_samples`` consecutive samples gives half a sample beyond its last one."""
    n = float(n_samples)
    return 1.0 / n + (n / 2.0) ** 2 / (n * (n * n - 1.0) / 12.0)


def _edge_line(r, rows, at: float) -> tuple:
    """A straight line through ``r[rows]``: its level at ``at``, that level's variance per unit
    noise variance, and the RMS of what the line leaves."""
    x = rows - at
    (slope, level), unscaled = np.polyfit(x, r[rows], 1, cov="unscaled")
    return float(level), float(unscaled[1, 1]), float(np.sqrt(np.mean((r[rows] - level - slope * x) ** 2)))


def _spikes(r, limit, near_step) -> list:
    # off both neighbours by the limit (white noise: σ√1.5), the neighbours within a quarter of it
    off = r[1:-1] - 0.5 * (r[:-2] + r[2:])
    agree = np.abs(r[2:] - r[:-2]) < 0.25 * np.abs(off)
    big = np.abs(off) > limit * math.sqrt(1.5)
    candidates = np.flatnonzero(big & agree) + 1
    out = []
    for k in candidates:
        if near_step[k] or k < 4 or k + 4 > r.size:
            continue
        # alone: a lone sample's neighbours are off by half of it (its own shadow), the next ones by
        # noise; ringing or a cluster of glitches is off by as much on every sample
        size = abs(off[k - 1])
        if (max(abs(off[k - 2]), abs(off[k])) > 0.6 * size
                or np.max(np.abs(np.r_[off[k - 4:k - 2], off[k + 1:k + 3]])) > 0.25 * size):
            continue
        out.append({"kind": "spike", "sample": int(k), "samples": 1, "size_um": float(off[k - 1])})
    return out


def _jumps(r, limit, near_step, near_turn) -> list:
    """Steps of the residual between samples k and k + 1 that stay, by either of two tests.

    *Alone*: the step exceeds ``limit`` (of its noise σ√2), the five steps on either side stay under
    a fifth of it, and the means of the five samples on either side differ by as much.  *Between
    lines* (away from input steps and corners, ``near_turn``): straight lines through the
    ``_LINE_SAMPLES`` samples on either side, both fitting (``_LINE_RMS_SIGMAS``), differ at
    k + ½ by ``ARTEFACT_SIGMAS`` standard errors of that difference, and the one-sample step is
    the largest within five samples and at least half of it.  The first needs about 14 σ (the
    noise of ten neighbouring steps breaks its quiet), the second about 9 σ where the residual is quiet.
    """
    noise = limit / ARTEFACT_SIGMAS
    d = np.diff(r)                          # d[k]: from sample k to k + 1
    big = np.flatnonzero(np.abs(d) > limit * math.sqrt(2.0))
    out = []
    for k in np.flatnonzero(np.abs(d) > _CANDIDATE_SIGMAS * noise * math.sqrt(2.0)):
        if k < _QUIET or k + 1 + _QUIET > r.size or near_step[k] or near_step[k + 1]:
            continue
        if _alone(r, d, k, limit) or _between_lines(r, d, k, noise, near_turn):
            out.append({"kind": "jump", "sample": int(k), "samples": 2,
                        "size_um": _jump_size(r, k, big, near_step, noise)})
    return out


def _alone(r, d, k, limit) -> bool:
    """The step from sample k to k + 1 stands ``limit`` out with quiet neighbours (see :func:`_jumps`)."""
    if abs(d[k]) <= limit * math.sqrt(2.0):
        return False
    around = np.r_[d[k - _QUIET:k], d[k + 1:k + 1 + _QUIET]]
    if np.max(np.abs(around)) > 0.2 * abs(d[k]):
        return False                         # not alone: a spike's way back, or a fast motion
    shift = float(np.mean(r[k + 1:k + 1 + _QUIET]) - np.mean(r[k + 1 - _QUIET:k + 1]))
    return not (abs(shift) < 0.7 * abs(d[k]) or abs(shift) < limit)


def _between_lines(r, d, k, noise, near_turn) -> bool:
    """The residual's levels before and after k + ½ differ as a jump's do (see :func:`_jumps`)."""
    if k + 1 < _LINE_SAMPLES or k + 1 + _LINE_SAMPLES > r.size or near_turn[k] or near_turn[k + 1]:
        return False
    if abs(d[k]) < np.max(np.abs(d[k - _QUIET:k + _QUIET + 1])):
        return False                         # another step close by is larger
    sides = []
    for rows in (np.arange(k + 1 - _LINE_SAMPLES, k + 1), np.arange(k + 1, k + 1 + _LINE_SAMPLES)):
        rows = rows[~near_turn[rows]]
        if rows.size < _LINE_SAMPLES // 2:
            return False
        sides.append(_edge_line(r, rows, k + 0.5))
    (before, var_before, rms_before), (after, var_after, rms_after) = sides
    offset = after - before
    return (abs(offset) >= ARTEFACT_SIGMAS * noise * math.sqrt(var_before + var_after)
            and max(rms_before, rms_after) <= _LINE_RMS_SIGMAS * noise and abs(d[k]) >= 0.5 * abs(offset))


def _actuators_own(jumps) -> list:
    """The jumps, unless there are so many that they are the actuator's rather than the sensor's.

    A sensor's zero or mount moves now and then.  An actuator whose hysteresis is made of a few relays
    (a Preisach actuator with coarse switching, a stick-slip stage) steps at the voltages where they
    switch, every time the input passes them, and steps back on the way down: many steps.  More than
    :data:`MAX_JUMPS` in a record are taken as the actuator's, and none is reported.  (A test that
    each jump stays for the whole stretch after it also threw out sensor jumps that the plain fit
    had partly taken into its weights.)
    """
    return [] if len(jumps) > MAX_JUMPS else jumps


def _jump_size(r, k, big, near_step, noise_um) -> float:
    """The jump between samples k and k + 1.

    From a straight line through the residual on either side (up to ``_SIZE_WINDOW`` samples, not
    past another large step, not near an input step), both taken to k + ½: a repair that leaves a
    step of a fraction of σ over half a record would still be seen as drift.  Where the residual
    around has a shape of its own (a slew limit's or a misfit's), the lines miss the step: when they
    differ from the step of the five samples' means on either side by more than three of that
    step's standard errors, or a side has fewer than 20 samples, that step is the size.
    """
    local = float(np.mean(r[k + 1:k + 1 + _QUIET]) - np.mean(r[max(k + 1 - _QUIET, 0):k + 1]))
    before, after = big[big < k], big[big > k]
    lo = max(k + 1 - _SIZE_WINDOW, int(before[-1]) + 1 if before.size else 0)
    hi = min(k + 1 + _SIZE_WINDOW, int(after[0]) + 1 if after.size else r.size)
    ends = []
    for rows in (np.arange(lo, k + 1), np.arange(k + 1, hi)):
        rows = rows[~near_step[rows]]
        if rows.size < 20:
            return local
        ends.append(_edge_line(r, rows, k + 0.5)[0])
    lines = float(ends[1] - ends[0])
    return local if abs(lines - local) > 3.0 * noise_um * math.sqrt(2.0 / _QUIET) else lines


def _flat_runs(v, y, r, limit) -> list:
    same = np.r_[False, y[1:] == y[:-1]]    # sample k repeats sample k - 1
    edges = np.flatnonzero(np.diff(np.r_[0, same.astype(np.int8), 0]))
    top, bottom = float(np.max(y)), float(np.min(y))
    out = []
    for start, stop in zip(edges[::2] - 1, edges[1::2]):     # samples start .. stop - 1 are equal
        if stop - start < FLAT_RUN_SAMPLES:
            continue
        # the model moves by half the limit or more where the reading does not, and misses it by as much
        model_moved = float(np.ptp(y[start:stop] - r[start:stop]))
        worst = float(r[start:stop][np.argmax(np.abs(r[start:stop]))])
        if model_moved < 0.5 * limit or abs(worst) < 0.5 * limit:
            continue
        moved = float(np.ptp(v[start:stop]))
        kind = "clipped" if y[start] in (top, bottom) else "stuck"
        out.append({"kind": kind, "sample": int(start), "samples": int(stop - start), "size_um": worst,
                    "level_um": float(y[start]), "input_moved_V": moved, "model_moved_um": model_moved,
                    "at": "maximum" if y[start] == top else "minimum" if y[start] == bottom else ""})
    return out


def artefacts_sentence(artefacts, first_name: str = "the record", second_name: str = "the second record") -> str:
    """One sentence that states the artefacts found, record by record (``""`` when there are none).

    Artefacts with ``record`` "second" are said of ``second_name``, the others of ``first_name``.

    Examples
    --------
    >>> jump = {"kind": "jump", "sample": 9, "time_s": 0.009, "size_um": 0.5}
    >>> text = artefacts_sentence([jump], "run.csv")
    >>> text.startswith("run.csv holds what no model of the actuator explains: 1 jump of the displacement")
    True
    >>> "(+0.5 µm between samples 9 and 10, t = 0.009 s)" in text
    True
    """
    sentences = []
    for record, name in (("first", first_name), ("second", second_name)):
        mine = [a for a in artefacts if a.get("record", "first") == record]
        if mine:
            sentences.append(f"{name} holds what no model of the actuator explains: " + "; ".join(_phrases(mine)))
    if not sentences:
        return ""
    repaired = [a for a in artefacts if a.get("repaired")]
    kept = [a for a in artefacts if not a.get("repaired")]
    tail = []
    if repaired:
        how = {"spike": "a spike replaced by the mean of its neighbours",
               "jump": "the displacement after a jump shifted back by it",
               "hum": "a hum's sinusoid subtracted"}
        counts = {k: sum(a["kind"] == k for a in repaired) for k in REPAIRABLE}
        kinds = [k for k in REPAIRABLE if counts[k]]
        names = _and(k if counts[k] == 1 else KIND_PLURALS[k] for k in kinds)
        tail.append(f"the {names} {'was' if len(repaired) == 1 else 'were'} repaired before the diagnosis "
                    f"({'; '.join(how[k] for k in kinds)})")
    if kept:
        tail.append("every fit is biased by what was kept -- cut or repair those samples and diagnose again")
    tail = "; ".join(tail)
    return "; and ".join(sentences) + ". " + tail[0].upper() + tail[1:]


#: Each kind's name in the plural, as the sentences and the report write it.
KIND_PLURALS = {"spike": "spikes", "jump": "jumps", "hum": "hums", "clipped": "clipped runs", "stuck": "frozen runs"}


def _and(words) -> str:
    words = list(words)
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def artefact_label(a: dict) -> str:
    """A few words that say where an artefact is, for a list.

    Examples
    --------
    >>> artefact_label({"kind": "jump", "sample": 9, "size_um": 0.5})
    'jump at sample 9'
    >>> artefact_label({"kind": "hum", "sample": 0, "frequency_hz": 50.02, "rms_um": 0.0412})
    'hum at 50.02 Hz (0.0412 µm RMS)'
    """
    if a["kind"] == "hum":
        return f"hum at {a['frequency_hz']:.4g} Hz ({a['rms_um']:.3g} µm RMS)"
    return f"{a['kind']} at sample {a['sample']}"


def _phrases(artefacts) -> list:
    by_kind = {}
    for a in artefacts:
        by_kind.setdefault(a["kind"], []).append(a)
    parts = []
    if "spike" in by_kind:
        s = by_kind["spike"]
        listed = ", ".join(str(a["sample"]) for a in s[:_LISTED]) + (", …" if len(s) > _LISTED else "")
        parts.append(f"{len(s)} spike{'s' if len(s) > 1 else ''} (single samples up to "
                     f"{max(abs(a['size_um']) for a in s):.3g} µm off both neighbours while the input is smooth, at "
                     f"sample{'s' if len(s) > 1 else ''} {listed}: a glitch of the sensor or logger)")
    if "jump" in by_kind:
        s = by_kind["jump"]
        listed = "; ".join(f"{a['size_um']:+.3g} µm between samples {a['sample']} and {a['sample'] + 1}, "
                           f"t = {a['time_s']:.4g} s" for a in s[:_LISTED]) + ("; …" if len(s) > _LISTED else "")
        parts.append(f"{len(s)} jump{'s' if len(s) > 1 else ''} of the displacement while the input is steady "
                     f"({listed}): the sensor's zero, its mount or the stage moved, which no effect of the "
                     "catalogue does" + ("" if all(a.get("repaired") for a in s) else
                                         " (a drift or creep named may be this)"))
    for a in by_kind.get("hum", []):
        parts.append(f"a hum of {a['rms_um']:.3g} µm RMS at {a['frequency_hz']:.4g} Hz through the whole record, "
                     "which the input does not drive: mains pickup of the sensor, its cable or the amplifier")
    for a in by_kind.get("clipped", []):
        parts.append(f"the displacement stays at its {a['at']} ({a['level_um']:.4g} µm) for {a['samples']} samples "
                     f"from sample {a['sample']} while the input moves by {a['input_moved_V']:.3g} V and the model by "
                     f"{a['model_moved_um']:.3g} µm: the sensor or its amplifier saturates")
    for a in by_kind.get("stuck", []):
        parts.append(f"the displacement stays at exactly {a['level_um']:.4g} µm for {a['samples']} samples from "
                     f"sample {a['sample']} while the input moves by {a['input_moved_V']:.3g} V and the model by "
                     f"{a['model_moved_um']:.3g} µm: a frozen reading")
    return parts
