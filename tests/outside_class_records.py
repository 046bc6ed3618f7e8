"""Records of actuators whose hysteresis lies outside the MPI class, to judge the diagnosis.

A second independent generator, beside :mod:`independent_records` (whose
plants are MPI models): the hysteresis here is a Preisach model with a 2-D
weight (minor loops that are not congruent; its relays switch along short
ramps, so the output is continuous) or an asymmetric Bouc-Wen model, with a
reversible part.  Nothing of the package is used.

At most one effect per record: ``none``, ``creep`` (two slow first-order
modes of the output), ``lag`` (a first-order stage after the hysteresis),
``delay`` (an exact delay of a fraction of a sample to a few samples).  The
plant runs on a grid ``OVERSAMPLING`` times finer than the samples; the
input is linear between samples.  A pair of records of one actuator is made
per seed with two different inputs (sine sweep, band-limited noise,
staircase of holds, random triangles), and a third record with another
input for prediction; the first may start after an unknown history.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from independent_records import preisach_relays

__all__ = ["PLANTS", "EFFECTS", "INPUTS", "OVERSAMPLING", "OutsideRecord", "OutsidePair", "bouc_wen",
           "make_outside_pair"]

PLANTS = ("preisach", "bouc_wen")
EFFECTS = ("none", "creep", "lag", "delay")
INPUTS = ("sine_sweep", "band_noise", "staircase", "triangles")
OVERSAMPLING = 8
#: The catalogue's name for each effect.
CATALOGUE_NAME = {"none": "none", "creep": "creep", "lag": "rate_dependence", "delay": "delay"}


def bouc_wen(v, lo, hi, beta: float = 2.5, gamma: float = 0.5, exponent: float = 1.0, linear: float = 1.3,
             cubic: float = 0.1) -> np.ndarray:
    """An asymmetric Bouc-Wen hysteresis of the input scaled to [0, 4] (rate independent:
    integrated in steps of the input, not of time); starts at rest (internal state 0).  Its
    internal state saturates near ``1 / (beta ± gamma)``: with the defaults the loop is about a
    tenth of the output's range wide, as a piezo actuator's."""
    s = (np.asarray(v, dtype=float) - lo) / (hi - lo) * 4.0
    h, out, previous = 0.0, np.empty(s.size), float(s[0]) if s.size else 0.0
    for k, x in enumerate(s.tolist()):
        move = x - previous
        pieces = max(1, int(abs(move) / 0.01))
        d = move / pieces
        for _ in range(pieces):
            h += d - beta * abs(d) * abs(h) ** (exponent - 1.0) * h - gamma * d * abs(h) ** exponent
        out[k] = linear * x - h + cubic * (x - 2.0) ** 3 / 8.0
        previous = x
    return out / 4.0


@dataclass
class OutsideRecord:
    voltage_V: np.ndarray
    displacement_um: np.ndarray
    clean_um: np.ndarray
    sample_rate_hz: float
    input_kind: str


@dataclass
class OutsidePair:
    train: OutsideRecord
    validation: OutsideRecord
    test: OutsideRecord
    plant: str
    effect: str
    effect_parameters: dict
    noise_um: float

    @property
    def catalogue_name(self) -> str:
        return CATALOGUE_NAME[self.effect]


def _signal(rng, kind, n, fs, lo, hi):
    t = np.arange(n) / fs
    duration = n / fs
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    if kind == "sine_sweep":
        f0, f1 = rng.uniform(0.5, 3.0), rng.uniform(20.0, min(150.0, fs / 20))
        phase = 2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * duration))
        x = mid + half * (0.6 + 0.4 * np.cos(2 * np.pi * t / duration * rng.uniform(0.5, 1.5)) ** 2) * np.sin(phase)
    elif kind == "band_noise":
        b, a = scipy.signal.butter(2, rng.uniform(5.0, min(80.0, fs / 25)) / (fs / 2))
        x = scipy.signal.filtfilt(b, a, rng.standard_normal(n))
        x = lo + (x - x.min()) / np.ptp(x) * (hi - lo)
    elif kind == "staircase":
        x, k = np.empty(n), 0
        while k < n:
            hold = int(rng.uniform(0.05, 0.3) * fs)
            x[k:k + hold] = rng.uniform(lo, hi)
            k += hold
    elif kind == "triangles":
        corners = np.r_[lo, hi, rng.uniform(lo, hi, 28)]
        x = np.interp(np.arange(n), np.linspace(0, n - 1, corners.size), corners)
    else:
        raise ValueError(f"unknown input {kind!r}")
    return np.clip(x, lo, hi)


def _effect(rng, name, fs):
    if name == "creep":
        return {"time_constants_s": [rng.uniform(0.01, 0.05), rng.uniform(0.2, 1.0)],
                "shares": [rng.uniform(0.02, 0.06), rng.uniform(0.02, 0.06)]}
    if name == "lag":
        return {"time_constant_s": rng.uniform(0.5, 3.0) / fs}
    if name == "delay":
        return {"delay_samples": rng.uniform(0.5, 3.0)}
    return {}


def _apply(name, params, y_fine, dt_s):
    if name == "creep":
        out = y_fine.copy()
        for tau, share in zip(params["time_constants_s"], params["shares"]):
            b, a = [dt_s / (tau + dt_s)], [1.0, -tau / (tau + dt_s)]
            out += share * scipy.signal.lfilter(b, a, y_fine, zi=scipy.signal.lfilter_zi(b, a) * y_fine[0])[0]
        return out
    if name == "lag":
        b, a = scipy.signal.bilinear([1.0], [params["time_constant_s"], 1.0], 1.0 / dt_s)
        return scipy.signal.lfilter(b, a, y_fine, zi=scipy.signal.lfilter_zi(b, a) * y_fine[0])[0]
    return y_fine


def make_outside_pair(seed: int) -> OutsidePair:
    """Three records of one actuator outside the MPI class (plant and effect cycle with the seed)."""
    rng = np.random.default_rng(7_000_000 + seed)
    plant = PLANTS[seed % len(PLANTS)]
    effect = EFFECTS[(seed // len(PLANTS)) % len(EFFECTS)]
    lo, hi = ((0.0, 150.0), (-20.0, 100.0), (0.0, 100.0))[rng.integers(3)]
    fs = (1000.0, 2000.0, 5000.0)[rng.integers(3)]
    span_um = rng.uniform(8.0, 40.0)
    if plant == "preisach":
        up, down, reversible = rng.uniform(0.55, 0.8), rng.uniform(0.2, 0.45), rng.uniform(0.2, 0.6)

        def hysteresis(u):
            s = (u - lo) / (hi - lo)
            return span_um * ((1 - reversible) * (preisach_relays(u, lo, hi, 40, up, down, 1.0 / 40) + 1) / 2
                              + reversible * s)
    else:
        beta, gamma = rng.uniform(1.5, 4.0), rng.uniform(-0.5, 0.5)
        beta_gamma = (beta, gamma * beta)

        def hysteresis(u):
            return span_um * bouc_wen(u, lo, hi, *beta_gamma) / 1.3

    params = _effect(rng, effect, fs)
    noise_um = rng.uniform(0.001, 0.003) * span_um
    n = int(rng.uniform(4.0, 8.0) * fs)
    kinds = rng.permutation(len(INPUTS))
    history = rng.random() < 0.6
    records = []
    for i in range(3):
        kind = INPUTS[kinds[i]]
        v = _signal(rng, kind, n, fs, lo, hi)
        before = [np.linspace(lo, v[0], max(2, int(0.05 * fs)))]
        if i == 0 and history:
            turns = np.r_[lo, rng.uniform(lo, hi, 4), v[0]]
            before = [np.linspace(turns[j], turns[j + 1], max(2, int(0.03 * fs))) for j in range(turns.size - 1)]
            before.append(np.full(int(0.05 * fs), v[0]))
        full = np.concatenate(before + [v])
        fine = np.interp(np.arange(full.size * OVERSAMPLING) / OVERSAMPLING, np.arange(full.size), full)
        y_fine = _apply(effect, params, hysteresis(fine), 1.0 / (fs * OVERSAMPLING))
        shift = params.get("delay_samples", 0.0) * OVERSAMPLING
        sampled = np.interp(np.arange(full.size) * OVERSAMPLING - shift, np.arange(y_fine.size), y_fine)
        clean = sampled[full.size - v.size:]
        records.append(OutsideRecord(v, clean + rng.normal(0.0, noise_um, v.size), clean, fs, kind))
    return OutsidePair(*records, plant=plant, effect=effect, effect_parameters=params, noise_um=noise_um)
