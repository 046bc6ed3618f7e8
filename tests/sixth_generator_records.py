"""A sixth record generator, written from the diagnosis issue's description and the paper alone.

Used by ``benchmarks/bench_diagnosis_sixth_generator.py``.  Its choices differ on purpose from the
other generators where the issue leaves them open:

- plant: the paper's MPI form ``y = a1 u³ + a2 u + Σ b_i F_{r_i}[u]`` on the normalised input
  ``u = v / 150 V``, one-sided play operators written here, 10 operators on the eq. 13 grid or 14 on
  random thresholds, a Gaussian-like weight density, ``a1 ≤ 0``; scaled by 40-100 µm over
  ``a1 + a2 + Σ b_i`` (the operators' outputs reach ``1 − r_i`` at full scale from rest);
- 2 kHz (one actuator in four 5 kHz), white noise 0.2 % of that scale;
- inputs: a decaying triangle that starts from rest at 0 V, a multisine normalised to the full range
  (it touches each end once), steps held 0.15-0.8 s followed by two sines;
- start: rest, or after an unrecorded history of 0.5-2 s (the triangle always starts from rest);
- one effect per actuator (``seed % 5``), on all three records: ``none``; ``rate_dependence`` (a
  flexure resonance 60-300 Hz, ζ 0.1-0.6, or a first-order lag of 1-8 samples, after the hysteresis);
  ``creep`` (logarithmic, driven by the displacement: each change ``Δh`` at ``t_k`` adds
  ``γ Δh log10(1 + (t − t_k)/t0)``, γ 1-5 %); ``delay`` (1-6 samples); ``drift`` (thermal: a
  saturating exponential of 1-4 % of the span with a time constant of 2-20 s, plus a slope).

Each actuator gives three records with the three input kinds in random order.
"""
from __future__ import annotations

import numpy as np
import scipy.signal

FULL_SCALE_V = 150.0
EFFECTS = ("none", "rate_dependence", "creep", "delay", "drift")


def _one_sided_play(u, threshold, state):
    out = np.empty_like(u)
    w = state
    for k, x in enumerate(u):
        w = max(x - threshold, min(x, w))
        out[k] = w
    return out


class _Plant:
    def __init__(self, rng):
        self.n = int(rng.choice([10, 10, 14]))
        if self.n == 10:
            self.r = np.arange(self.n) / self.n
        else:
            self.r = np.sort(np.concatenate([[0.0], rng.uniform(0.02, 0.95, self.n - 1)]))
        density = rng.uniform(2.0, 6.0) * np.exp(-rng.uniform(0.3, 3.0) * self.r ** 2)
        self.b = density * np.diff(np.append(self.r, 1.0))
        self.a2 = rng.uniform(1.5, 3.0)
        self.a1 = -rng.uniform(0.0, 0.5)
        self.span_um = rng.uniform(40.0, 100.0)
        self.state = np.zeros(self.n)

    def rest(self):
        self.state = np.zeros(self.n)

    def hysteresis_um(self, voltage_V):
        u = np.asarray(voltage_V, dtype=float) / FULL_SCALE_V
        out = self.a1 * u ** 3 + self.a2 * u
        for i in range(self.n):
            w = _one_sided_play(u, self.r[i], self.state[i])
            self.state[i] = w[-1]
            out = out + self.b[i] * w
        return out * self.span_um / (self.a1 + self.a2 + self.b.sum())


def make_input(rng, kind: str, n: int, fs: float) -> np.ndarray:
    """Voltage (V) of ``n`` samples at ``fs`` Hz of one of the three input kinds."""
    t = np.arange(n) / fs
    if kind == "triangle":
        f = rng.uniform(0.5, 4.0)
        rising_from_zero = 1.0 - 2.0 * np.abs((t * f) % 1.0 - 0.5)
        return FULL_SCALE_V * rising_from_zero * np.exp(-t / (t[-1] * rng.uniform(0.4, 1.5)))
    if kind == "multisine":
        m = int(rng.integers(3, 9))
        freqs = rng.uniform(0.3, 25.0, m)
        x = (rng.uniform(0.3, 1.0, m)[:, None] / np.sqrt(freqs)[:, None]
             * np.sin(2 * np.pi * freqs[:, None] * t + rng.uniform(0, 2 * np.pi, m)[:, None])).sum(0)
        return FULL_SCALE_V * (x - x.min()) / np.ptp(x)
    if kind == "steps_sines":
        x = np.zeros(n)
        k, half = 0, n // 2
        while k < half:
            hold = int(fs * rng.uniform(0.15, 0.8))
            x[k:k + hold] = rng.uniform(0.05, 0.95) * FULL_SCALE_V
            k += hold
        ts = t[half:] - t[half]
        f1, f2 = rng.uniform(1, 10), rng.uniform(10, 60)
        x[half:] = FULL_SCALE_V * (0.5 + 0.3 * np.sin(2 * np.pi * f1 * ts) + 0.2 * np.sin(2 * np.pi * f2 * ts))
        return x
    raise ValueError(f"unknown input kind {kind!r}")


def _effect_parameters(rng, effect: str, fs: float) -> dict:
    if effect == "rate_dependence":
        if rng.random() < 0.5:
            return {"kind": "flexure", "natural_frequency_hz": float(rng.uniform(60, 300)),
                    "damping_ratio": float(rng.uniform(0.1, 0.6))}
        return {"kind": "lag", "time_constant_s": float(rng.uniform(1.0, 8.0) / fs)}
    if effect == "creep":
        return {"gamma": float(rng.uniform(0.01, 0.05)), "t0_s": float(rng.uniform(0.01, 0.2))}
    if effect == "delay":
        return {"samples": int(rng.integers(1, 7))}
    if effect == "drift":
        return {"amplitude_of_span": float(rng.uniform(0.01, 0.04) * rng.choice([-1.0, 1.0])),
                "time_constant_s": float(rng.uniform(2.0, 20.0)),
                "slope_of_span_per_s": float(rng.uniform(-1e-3, 1e-3))}
    return {}


def apply_effect(effect: str, parameters: dict, hysteresis_um, fs: float, drift_phase_s: float = 0.0):
    """The displacement (µm) the effect makes of the hysteresis output ``hysteresis_um``."""
    h = np.asarray(hysteresis_um, dtype=float)
    t = np.arange(h.size) / fs
    p = parameters
    if effect == "rate_dependence":
        if p["kind"] == "flexure":
            w = 2 * np.pi * p["natural_frequency_hz"]
            b, a = scipy.signal.bilinear([w * w], [1.0, 2 * p["damping_ratio"] * w, w * w], fs)
        else:
            b, a = scipy.signal.bilinear([1.0], [p["time_constant_s"], 1.0], fs)
        return scipy.signal.lfilter(b, a, h, zi=scipy.signal.lfilter_zi(b, a) * h[0])[0]
    if effect == "creep":
        kernel = np.log10(1.0 + t / p["t0_s"])
        return h + p["gamma"] * scipy.signal.fftconvolve(np.diff(h, prepend=h[0]), kernel)[:h.size]
    if effect == "delay":
        d = p["samples"]
        return np.concatenate([np.full(d, h[0]), h[:-d]])
    if effect == "drift":
        span = float(np.ptp(h)) or 1.0
        return h + span * (p["amplitude_of_span"] * (1 - np.exp(-(t + drift_phase_s) / p["time_constant_s"]))
                           + p["slope_of_span_per_s"] * t)
    return h


class Actuator:
    """One seed's plant, effect and noise; :meth:`respond` plays any voltage on it from rest."""

    def __init__(self, seed: int):
        self.rng = np.random.default_rng(seed)
        self.effect = EFFECTS[seed % len(EFFECTS)]
        self.sample_rate_hz = 2000.0 if self.rng.random() < 0.75 else 5000.0
        self.plant = _Plant(self.rng)
        self.parameters = _effect_parameters(self.rng, self.effect, self.sample_rate_hz)
        self.noise_um = 0.002 * self.plant.span_um

    def respond(self, voltage_V, start: str = "rest") -> dict:
        """A record of ``voltage_V``: voltage, noisy and clean displacement (µm), effect size (noise σ)."""
        fs = self.sample_rate_hz
        self.plant.rest()
        if start == "history":
            kind = str(self.rng.choice(["multisine", "steps_sines"]))
            self.plant.hysteresis_um(make_input(self.rng, kind, int(fs * self.rng.uniform(0.5, 2.0)), fs))
        h = self.plant.hysteresis_um(voltage_V)
        clean = apply_effect(self.effect, self.parameters, h, fs, self.rng.uniform(0.0, 5.0))
        return {"voltage_V": np.asarray(voltage_V, dtype=float), "clean_um": clean,
                "displacement_um": clean + self.rng.normal(0.0, self.noise_um, h.size),
                "start": start, "effect_sigma": float(np.std(clean - h) / self.noise_um)}


def make_actuator(seed: int) -> tuple:
    """``(actuator, records)``: three records of the seed's actuator, the input kinds in random order."""
    actuator = Actuator(seed)
    rng, fs = actuator.rng, actuator.sample_rate_hz
    records = []
    for kind in rng.permutation(["triangle", "multisine", "steps_sines"]):
        kind = str(kind)
        n = int(fs * rng.uniform(4.0, 10.0))
        start = "rest" if (kind == "triangle" or rng.random() < 0.5) else "history"
        record = actuator.respond(make_input(rng, kind, n, fs), start)
        record["input"] = kind
        records.append(record)
    return actuator, records
