"""Seeded synthetic measured data with one hidden effect, for testing diagnosis.

``make_case(seed)`` draws, from that seed alone:

- a plant: an MPI model (10 one-sided play operators, eq. 13 thresholds over
  the input's range) with random weight density, a2, a1 and offset, redrawn
  until it is invertible with a slope margin of at least 10 % of its mean gain;
- an input (0 … U V, U in [60, 150]) at 1, 2, 5 or 10 kHz, 6000 … 12000
  samples, starting with a full-range preconditioning triangle, then one of
  ``triangles`` (bursts of decaying triangles of random period),
  ``multisine`` (3–6 sines, random frequencies and phases) or
  ``steps`` (steps to random levels held for random times, mixed with sine
  segments);
- one hidden effect, drawn uniformly from ``none``, ``rate_dependence``,
  ``creep``, ``delay``, ``drift``:

  ``rate_dependence``  a continuous first-order lag (τ = 2 … 30 samples) or
                       second-order stage (natural frequency fs/150 … fs/15,
                       ζ = 0.05 … 0.6) after the hysteresis, simulated with
                       scipy's ``lsim`` (not the model's own discretisation);
  ``creep``            a logarithmic creep kernel, ``γ Σ Δu_k ln(1 + (t − t_k)/τ0)``
                       over all input changes (τ0 = 1 … 100 samples), or a sum of
                       2–3 first-order lags with random time constants (10
                       samples … half the record) and weights:
                       in both cases *not* the diagnosis' own creep modes;
  ``delay``            1 … 8 samples of pure delay;
  ``drift``            a polynomial baseline of degree 1 or 2 in time plus a
                       slow random walk whose RMS is 3 % of the polynomial's
                       (a trend can be extrapolated into a held-out part, a
                       random walk cannot: it is the unpredictable remainder);
- white Gaussian sensor noise.

Magnitudes.  What makes an effect detectable is not its raw size but the part
an MPI model cannot absorb (a delay on a single-frequency sine is mostly
absorbed as a wider loop).  The generator therefore measures the *visible* part:
the effect minus its least-squares projection on the MPI regressors (operator
outputs, u, u³, a constant) over the record after the preconditioning, its RMS
taken over those samples and over the last 35 % of the record (where a
held-out part lies), whichever is smaller.  The signal-to-noise ratio
SNR = RMS(visible) / σ is drawn log-uniformly in [4, 40].  For creep and drift
the noise σ is drawn first (log-uniform 0.01 … 0.3 % of the displacement
range) and the effect scaled to the SNR; for delay and
rate dependence, whose size follows from their parameters, σ = RMS(visible)/SNR
(parameters are redrawn until σ is 0.003 … 1 % of the range).  For ``none`` σ is
log-uniform 0.01 … 0.3 % of the range.  At SNR 4 the effect is plainly visible
in a residual plot but not at a glance in the raw data.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.signal

from pysim.core.model import HysteresisModel, eq13_thresholds

EFFECTS = ("none", "rate_dependence", "creep", "delay", "drift")
WAVEFORMS = ("triangles", "multisine", "steps")
N_OPERATORS = 10
SNR_RANGE = (4.0, 40.0)
#: RMS of the drift's random-walk part relative to its polynomial part.
DRIFT_WALK_SHARE = 0.03


@dataclass
class SyntheticCase:
    """One synthetic record and its hidden truth."""

    seed: int
    effect: str
    waveform: str
    time_s: np.ndarray
    voltage_V: np.ndarray
    displacement_um: np.ndarray
    clean_um: np.ndarray          # plant + effect, no noise
    plant: HysteresisModel
    noise_um: float
    snr: float
    visible_rms_um: float
    parameters: dict = field(default_factory=dict)

    @property
    def sample_rate_hz(self) -> float:
        return 1.0 / (self.time_s[1] - self.time_s[0])


def _log_uniform(rng, lo, hi):
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


# ---------------------------------------------------------------- inputs

def _ramps(extrema, lengths):
    """Piecewise-linear signal through ``extrema`` with ramps of ``lengths`` samples."""
    knots = np.concatenate(([0], np.cumsum(lengths)))
    return np.interp(np.arange(knots[-1]), knots, extrema)


def _triangles(rng, n, lo, hi):
    pieces, total = [], 0
    span = hi - lo
    while total < n:
        period = rng.integers(40, 800)
        centre = rng.uniform(lo + 0.3 * span, hi - 0.3 * span)
        amplitude = min(centre - lo, hi - centre) * rng.uniform(0.7, 1.0)
        decay = rng.uniform(0.6, 0.9)
        extrema = [centre]
        for _ in range(rng.integers(3, 9)):
            extrema += [centre + amplitude, centre - amplitude]
            amplitude *= decay
        extrema.append(centre)
        piece = _ramps(np.array(extrema), np.full(len(extrema) - 1, period // 2))
        pieces.append(piece)
        total += piece.size
    return np.concatenate(pieces)[:n]


def _multisine(rng, n, lo, hi):
    k = np.arange(n)
    signal = np.zeros(n)
    for _ in range(rng.integers(3, 7)):
        cycles = _log_uniform(rng, 3.0, n / 30.0)
        signal += rng.uniform(0.3, 1.0) * np.sin(2 * np.pi * cycles * k / n + rng.uniform(0, 2 * np.pi))
    signal = (signal - signal.min()) / np.ptp(signal)
    return lo + (hi - lo) * (0.02 + 0.96 * signal)


def _steps(rng, n, lo, hi):
    pieces, total = [], 0
    span = hi - lo
    while total < n:
        length = int(_log_uniform(rng, 30, 800))
        level = rng.uniform(lo, hi)
        if rng.uniform() < 0.3:
            period = _log_uniform(rng, 30, 500)
            amplitude = rng.uniform(0.05, 0.4) * span
            piece = level + amplitude * np.sin(2 * np.pi * np.arange(length) / period)
        else:
            piece = np.full(length, level)
        pieces.append(np.clip(piece, lo, hi))
        total += length
    return np.concatenate(pieces)[:n]


def make_input(rng, waveform, n, lo, hi):
    """Preconditioning full-range triangle, then ``waveform``; ``n`` samples in [lo, hi]."""
    precondition = _ramps(np.array([lo, hi, lo]), [n // 40, n // 40])
    body = {"triangles": _triangles, "multisine": _multisine, "steps": _steps}[waveform](
        rng, n - precondition.size, lo, hi)
    return np.concatenate((precondition, body)), precondition.size


# ----------------------------------------------------------------- plant

def make_plant(rng, lo, hi):
    """Random invertible MPI model with eq. 13 thresholds over [lo, hi]."""
    span = hi - lo
    r = eq13_thresholds(N_OPERATORS, span, "osp")
    gain_um_per_V = _log_uniform(rng, 10.0, 100.0) / span  # 10 … 100 µm over the range
    while True:
        centre, width = rng.uniform(0.0, 1.2), rng.uniform(0.2, 2.0)
        density = np.exp(-((r / span - centre) / width) ** 2)
        hysteretic = rng.uniform(0.2, 0.7)   # share of the gain carried by the operators
        b = density / density.sum() * hysteretic * gain_um_per_V
        a2 = (1.0 - hysteretic) * gain_um_per_V
        a1 = rng.uniform(-0.4, 0.4) * gain_um_per_V / span**2
        model = HysteresisModel(a1, a2, tuple(r), tuple(b), operator="osp", input_offset_V=lo,
                                output_offset_um=rng.uniform(-50.0, 50.0), voltage_range_V=(lo, hi),
                                name="synthetic_plant")
        report = model.check_invertibility()
        if report.invertible and report.min_slope_um_per_V >= 0.1 * gain_um_per_V:
            return model


# --------------------------------------------------------------- effects

def _rate_dependence(rng, h, T):
    if rng.uniform() < 0.4:
        tau = _log_uniform(rng, 2.0, 30.0) * T
        system = scipy.signal.lti([1.0], [tau, 1.0])
        params = {"order": 1, "time_constant_s": tau}
    else:
        fn = 1.0 / (_log_uniform(rng, 15.0, 150.0) * T)
        zeta = rng.uniform(0.05, 0.6)
        w = 2 * np.pi * fn
        system = scipy.signal.lti([w * w], [1.0, 2 * zeta * w, w * w])
        params = {"order": 2, "natural_frequency_hz": fn, "damping_ratio": zeta}
    t = np.arange(h.size) * T
    _, y, _ = scipy.signal.lsim(system, h - h[0], t)
    return h[0] + y, params


def _creep_shape(rng, u, T):
    du = np.diff(u, prepend=u[0])
    k = np.arange(u.size)
    if rng.uniform() < 0.6:
        tau0 = _log_uniform(rng, 1.0, 100.0) * T
        kernel = np.log1p(k * T / tau0)
        params = {"kernel": "log", "tau0_s": tau0}
    else:
        taus = np.sort([_log_uniform(rng, 10.0, u.size / 2) * T for _ in range(rng.integers(2, 4))])
        parts = rng.uniform(0.3, 1.0, taus.size)
        kernel = sum(p * (1.0 - np.exp(-k * T / tau)) for p, tau in zip(parts, taus))
        params = {"kernel": "lags", "time_constants_s": taus.tolist()}
    return scipy.signal.fftconvolve(du, kernel)[: u.size], params


def _drift_shape(rng, n, T):
    s = np.arange(n) / n
    degree = int(rng.integers(1, 3))
    poly = rng.normal() * s + (rng.normal() * s**2 if degree == 2 else 0.0)
    walk = np.cumsum(rng.normal(size=n))
    walk = scipy.signal.sosfiltfilt(scipy.signal.butter(2, 20.0 / n, output="sos"), walk)
    walk -= np.polyval(np.polyfit(s, walk, 1), s)
    walk *= DRIFT_WALK_SHARE * np.std(poly) / np.std(walk)
    return poly + walk, {"degree": degree}


def _visible_rms(effect_um, columns, start):
    """RMS of the part of ``effect_um`` (after ``start``) that the MPI regressors
    cannot absorb: the smaller of its RMS over all those samples and over the
    last 35 % of the record (where a held-out part would lie)."""
    A, e = columns[start:], effect_um[start:]
    coefficients, *_ = np.linalg.lstsq(A, e, rcond=None)
    visible = e - A @ coefficients
    tail = visible[-int(0.35 * effect_um.size):]
    return float(min(np.sqrt(np.mean(visible**2)), np.sqrt(np.mean(tail**2))))


# ------------------------------------------------------------------ case

def make_case(seed: int, effect: str = None) -> SyntheticCase:
    """The synthetic record of ``seed`` (effect drawn from the seed unless given)."""
    rng = np.random.default_rng([seed, 5])
    effect = EFFECTS[rng.integers(len(EFFECTS))] if effect is None else effect
    if effect not in EFFECTS:
        raise ValueError(f"effect must be one of {EFFECTS}, got {effect!r}")
    waveform = WAVEFORMS[rng.integers(len(WAVEFORMS))]
    fs = float(rng.choice([1000.0, 2000.0, 5000.0, 10000.0]))
    T = 1.0 / fs
    n = int(rng.integers(6000, 12001))
    lo, hi = 0.0, float(rng.uniform(60.0, 150.0))
    v, start = make_input(rng, waveform, n, lo, hi)
    plant = make_plant(rng, lo, hi)
    h, operators = plant.simulate(v, return_operators=True)
    u = v - lo
    columns = np.column_stack([operators[:, 1:], u, u**3, np.ones(n)])
    span = float(np.ptp(h[start:]))
    snr = _log_uniform(rng, *SNR_RANGE)
    params = {}

    if effect == "none":
        clean, visible_rms = h, 0.0
        sigma = _log_uniform(rng, 1e-4, 3e-3) * span
        snr = 0.0
    elif effect in ("creep", "drift"):
        if effect == "creep":
            shape, params = _creep_shape(rng, u, T)
        else:
            shape, params = _drift_shape(rng, n, T)
        sigma = _log_uniform(rng, 1e-4, 3e-3) * span
        unit_visible = _visible_rms(shape, columns, start)
        scale = snr * sigma / unit_visible
        clean = h + scale * shape
        visible_rms = snr * sigma
        params["scale"] = scale
    else:
        for _ in range(100):
            if effect == "delay":
                d = int(rng.integers(1, 9))
                clean = np.concatenate((np.full(d, h[0]), h[:-d]))
                params = {"delay_samples": d}
            else:
                clean, params = _rate_dependence(rng, h, T)
            visible_rms = _visible_rms(clean - h, columns, start)
            sigma = visible_rms / snr
            if 3e-5 * span <= sigma <= 1e-2 * span:
                break
            snr = _log_uniform(rng, *SNR_RANGE)
        else:
            raise RuntimeError(f"seed {seed}: no {effect} of a plausible size for this input")
    noise = rng.normal(scale=sigma, size=n)
    return SyntheticCase(
        seed=seed, effect=effect, waveform=waveform, time_s=np.arange(n) * T, voltage_V=v,
        displacement_um=clean + noise, clean_um=clean, plant=plant, noise_um=sigma, snr=snr,
        visible_rms_um=visible_rms, parameters=params)
