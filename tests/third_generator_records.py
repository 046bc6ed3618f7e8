"""A third generator of measured-like piezo records, to find the blind spots of the other two.

Written from the issue's description alone, without reading
:mod:`independent_records` or :mod:`outside_class_records`: what those two
generators assume without saying so, this one need not assume, and a
diagnosis tuned to their records may meet records here that neither makes.

The plant is the modified Prandtl-Ishlinskii (MPI) model of Gu, Zhu, Su
(IEEE TIE 2014, eq. 3-4, 7, 13), on the sample grid (no finer simulation
grid)::

    w_k = max(v_k - r, min(v_k, w_{k-1})),  w_{-1} = 0 (rest)     one-sided play operators
    h   = a1 v^3 + a2 v + sum_i b_i F_{r_i}[v]                     hysteresis (µm), v in V
    r_i = (i - 1) / n * V_max                                      eq. 13 thresholds

with three kinds of threshold set (:func:`make_plant`): the paper's ten on
the eq. 13 grid, 12-20 on that grid, or ten moved off it by up to a third of
a grid step; a Gaussian or a decaying exponential weight density, all
weights positive; the loop width 8-20 % of the output range; 0-150 V with
a stroke of 25-90 µm or 0-100 V with 20-73 µm.

One hidden effect per seed, cycling with ``seed % 5`` through :data:`EFFECTS`:

===================  =========================================================
truth                what the plant does after the hysteresis
===================  =========================================================
``none``             nothing
``rate_dependence``  a first-order lag of 0.5-5 ms (even ``seed // 5``) or a
                     second-order resonance of 50-500 Hz, damping 0.3-0.8 (odd)
``creep``            2-3 slow first-order modes (0.05-3 s) of the hysteresis
                     output added to it, 2-8 % of it in all
``delay``            a delay of 0.5-5 samples (linear interpolation between
                     the samples)
``drift``            a trend ``± A s^p`` of the record's relative time s in
                     [0, 1], p = 1 or 2, A 0.5-3 % of the output range, zero
                     at the first sample
===================  =========================================================

The effect's strength is set by bisection so that its RMS on the first
record (noise-free, with minus without the effect) is a random multiple of
the noise σ, log-uniform in 1-20; where that multiple lies outside what the
strength's bounds (:data:`STRENGTH_BOUNDS`) can reach, the nearest bound is
kept.

Each seed gives three records of one actuator, 8-12 s each at 2 or 5 kHz,
with three different inputs (:data:`INPUT_KINDS`) in random order: decaying
triangles from 0 V, a multisine of 4-8 tones between 0.15 and 15 Hz, and
holds at random levels followed by sines.  The first two records start from
rest (at 0 V; a multisine may step from there to its first voltage) or, at
random, after an unknown history of 1-4 s of ramps between random levels
that ends at the record's first voltage (a triangle record starts at 0 V,
where such a history leaves the operators at rest again); the third always
starts from rest.  White noise of σ = 0.2 % of each record's
noise-free output range is added.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal

from independent_records import osp_operators

__all__ = ["EFFECTS", "INPUT_KINDS", "SEED_OFFSET", "NOISE_SHARE", "STRENGTH_BOUNDS", "ThirdPlant",
           "ThirdRecord", "ThirdRecordSet", "make_plant", "make_input", "make_history", "apply_effect",
           "drift_um", "with_strength", "simulate_record", "make_third_records", "describe_effect"]

#: Truths in the order the seeds cycle through them (the diagnosis catalogue's names).
EFFECTS = ("none", "rate_dependence", "creep", "delay", "drift")
INPUT_KINDS = ("decaying_triangles", "multisine", "holds_then_sines")
#: A seed's random stream is ``numpy.random.default_rng(SEED_OFFSET + seed)``.
SEED_OFFSET = 1000
#: Noise σ over the record's noise-free output range.
NOISE_SHARE = 0.002
#: Per effect kind: (weakest, strongest) value of the parameter that sets its size.
STRENGTH_BOUNDS = {"lag": (0.5e-3, 5e-3), "resonance": (500.0, 50.0), "creep": (0.02, 0.08),
                   "delay": (0.5, 5.0), "drift": (0.005, 0.03)}
#: The name of that parameter in the effect's dictionary.
_STRENGTH_KEY = {"lag": "time_constant_s", "resonance": "natural_frequency_hz", "creep": "total_fraction",
                 "delay": "delay_samples", "drift": "fraction_of_range"}
_BISECTION_STEPS = 22


# ------------------------------------------------------------------ plant

@dataclass(frozen=True)
class ThirdPlant:
    """The MPI plant of a seed (voltages from 0 V, operators at rest at 0 V).

    Attributes
    ----------
    max_voltage_V : float
        Top of the voltage range (the bottom is 0 V).
    variant : str
        ``"eq13"`` (ten thresholds on the eq. 13 grid), ``"many"`` (12-20 on
        that grid) or ``"perturbed"`` (ten, moved off the grid).
    thresholds_V : ndarray
        Operator thresholds, ascending.
    a1_um_per_V3, a2_um_per_V : float
        Cubic and linear coefficients.
    weights_um_per_V : ndarray
        Operator weights (all positive).
    stroke_um : float
        Output range of a full 0 V to max and back cycle from rest.
    loop_width_share : float
        Width of that major loop over its output range, as aimed at.
    """

    max_voltage_V: float
    variant: str
    thresholds_V: np.ndarray
    a1_um_per_V3: float
    a2_um_per_V: float
    weights_um_per_V: np.ndarray
    stroke_um: float
    loop_width_share: float

    @property
    def n_operators(self) -> int:
        return int(self.thresholds_V.size)

    def hysteresis_um(self, voltage_V) -> np.ndarray:
        """``a1 v³ + a2 v + Σ b_i F_{r_i}[v]`` (µm), the operators starting at rest."""
        v = np.asarray(voltage_V, dtype=float)
        return _mpi_um(v, self.thresholds_V, self.a1_um_per_V3, self.a2_um_per_V, self.weights_um_per_V)


def _mpi_um(v, thresholds, a1, a2, weights):
    # the block-wise operators give the same bits as the paper's sample recursion
    # (tests/test_independent_records.py) and are many times faster
    operators, _ = osp_operators(v, thresholds)
    return a1 * v ** 3 + a2 * v + operators @ weights


def make_plant(rng: np.random.Generator) -> ThirdPlant:
    """A random MPI plant, strictly increasing on every branch.

    Built in normalised units (u = v / V_max in [0, 1]), where the loop width
    is set by scaling the weights of the operators with r > 0, then scaled to
    volts and to a stroke of 25-90 µm (times ``sqrt(V_max / 150 V)``).

    Parameters
    ----------
    rng : numpy.random.Generator

    Returns
    -------
    ThirdPlant
    """
    max_voltage = 150.0 if rng.random() < 0.7 else 100.0
    variant = str(rng.choice(["eq13", "eq13", "eq13", "many", "perturbed"]))
    n = 10 if variant != "many" else int(rng.integers(12, 21))
    r = np.arange(n) / n                                  # eq. 13 in normalised units
    if variant == "perturbed":
        jitter = rng.uniform(-0.35, 0.35, n) / n
        jitter[0] = abs(jitter[0]) * 0.5                  # the first threshold near, but off, zero
        r = np.sort(np.clip(r + jitter, 0.0, 0.97))
    if rng.random() < 0.5:                                # a Gaussian bump, as in the paper's example
        centre, sharpness = rng.uniform(0.0, 1.0), rng.uniform(0.3, 3.0)
        density = np.exp(-sharpness * (r - centre) ** 2)
    else:                                                 # or a decaying exponential
        density = np.exp(-r * rng.uniform(0.5, 4.0))
    spacing = np.diff(np.r_[r, 1.0])
    b = density * spacing * rng.uniform(0.7, 1.3, n)
    b = np.maximum(b, 1e-4)
    a2 = rng.uniform(0.5, 2.5)
    a1 = rng.uniform(-0.35, 0.25) * a2                    # asymmetry
    width_share = rng.uniform(0.08, 0.20)
    # a full cycle 0 -> 1 -> 0, 401 points a branch; the width is set by the operators after the first
    # (on the grid the first has r = 0 and only adds to the slope)
    u = np.r_[np.linspace(0, 1, 401), np.linspace(1, 0, 401)[1:]]
    for _ in range(6):
        y = _mpi_um(u, r, a1, a2, b)
        up, down = y[:401], y[400:][::-1]
        width = np.max(down - up) / (y.max() - y.min())
        b[1:] *= width_share / max(width, 1e-6) if width > 0 else 1.0
    # the slope just after a reversal at the top is 3 a1 + a2 + b0 (3 a1 + a2 until a perturbed
    # first threshold r0 > 0 is travelled): keep it clearly positive
    if 3 * a1 + a2 + b[0] <= 0.2 * (a2 + b[0]):
        a1 = -0.25 * (a2 + b[0]) / 3
    y = _mpi_um(u, r, a1, a2, b)
    stroke = rng.uniform(25.0, 90.0) * (max_voltage / 150.0) ** 0.5
    scale = stroke / (y.max() - y.min())
    # F_{r V_max}[v] = V_max F_r[u]
    return ThirdPlant(max_voltage, variant, r * max_voltage, scale * a1 / max_voltage ** 3,
                      scale * a2 / max_voltage, scale * b / max_voltage, stroke, width_share)


# ------------------------------------------------------------------ inputs

def _ramps(points_V, durations_s, sample_rate_hz):
    """Straight lines through ``points_V``, the i-th taking ``durations_s[i]``."""
    out = [np.array([points_V[0]])]
    for start, end, duration in zip(points_V[:-1], points_V[1:], durations_s):
        m = max(int(round(duration * sample_rate_hz)), 1)
        out.append(start + (end - start) * np.arange(1, m + 1) / m)
    return np.concatenate(out)


def make_input(kind: str, rng: np.random.Generator, sample_rate_hz: float, duration_s: float,
               max_voltage_V: float, from_rest: bool = True) -> np.ndarray:
    """A record's voltage (V), within [0, ``max_voltage_V``].

    Parameters
    ----------
    kind : str
        ``"decaying_triangles"``: triangles from 0 V whose peaks decay towards
        15-50 % of the range, 1-8 Hz, the rate changing linearly over the
        record (a chirp by up to a factor 2 either way), 30 % of the valleys
        above 0 V.  ``"multisine"``: 4-8 tones, 0.15-15 Hz, amplitudes
        falling with frequency, scaled to the full range; from rest it starts
        at the lowest point of the sum's first record length, which is 0 V
        unless the record holds a lower point later (then the record starts
        up to about 13 % of the range above 0 V: a step from rest).
        ``"holds_then_sines"``: 3-5 holds at random levels (the first at 0 V
        from rest, else at 0-50 % of the range), then 2-3 sines of 0.5-10 Hz
        around random levels.
    rng : numpy.random.Generator
    sample_rate_hz, duration_s : float
    max_voltage_V : float
    from_rest : bool
        Whether the record starts from rest (see ``kind``; a triangle record
        always starts at 0 V).

    Returns
    -------
    ndarray, ``round(duration_s * sample_rate_hz)`` samples
    """
    n = int(round(duration_s * sample_rate_hz))
    if kind == "decaying_triangles":
        f_start = np.exp(rng.uniform(np.log(1.0), np.log(8.0)))
        f_end = f_start * np.exp(rng.uniform(-0.7, 0.7))
        points, durations, t = [0.0], [], 0.0
        floor = rng.uniform(0.15, 0.5)
        decay_s = rng.uniform(0.25, 0.8) * duration_s
        while t < duration_s:
            f = f_start + (f_end - f_start) * t / duration_s
            peak = max_voltage_V * (floor + (1 - floor) * np.exp(-t / decay_s))
            valley = 0.0 if rng.random() < 0.7 else rng.uniform(0.0, 0.4) * peak
            half = 0.5 / f
            points += [peak, valley]
            # the rise takes a share of half a period in proportion to its height, the fall half a period
            durations += [half * (peak - points[-3]) / max(peak, 1e-9) + 0.3 * half, half]
            t += durations[-1] + durations[-2]
        v = _ramps(np.array(points), durations, sample_rate_hz)
    elif kind == "multisine":
        tones = int(rng.integers(4, 9))
        f = np.exp(rng.uniform(np.log(0.15), np.log(15.0), tones))
        amplitude = f ** -0.6 * rng.uniform(0.5, 1.0, tones)
        phase = rng.uniform(0, 2 * np.pi, tones)
        t = np.arange(2 * n) / sample_rate_hz
        x = (amplitude[None, :] * np.sin(2 * np.pi * t[:, None] * f[None, :] + phase[None, :])).sum(1)
        start = int(np.argmin(x[:n])) if from_rest else int(rng.integers(0, n))
        x = x[start:start + n]
        v = (x - x.min()) / (x.max() - x.min()) * max_voltage_V
    elif kind == "holds_then_sines":
        holds = int(rng.integers(3, 6))
        levels = [0.0] + list(rng.uniform(0.1, 0.95, holds) * max_voltage_V)
        hold_s = [rng.uniform(0.3, 0.5)] + list(rng.uniform(0.3, 1.0, holds))
        if not from_rest:
            levels[0] = rng.uniform(0.0, 0.5) * max_voltage_V
        v = np.concatenate([np.full(int(h * sample_rate_hz), level) for level, h in zip(levels, hold_s)])
        left = n - len(v)
        t = np.arange(left) / sample_rate_hz
        sines = int(rng.integers(2, 4))
        bounds = np.linspace(0, left, sines + 1).astype(int)
        parts = []
        for j in range(sines):
            tt = t[: bounds[j + 1] - bounds[j]]
            f = np.exp(rng.uniform(np.log(0.5), np.log(10.0)))
            amplitude = rng.uniform(0.2, 0.5) * max_voltage_V
            centre = rng.uniform(amplitude, max_voltage_V - amplitude)
            parts.append(centre + amplitude * np.sin(2 * np.pi * f * tt))
        v = np.concatenate([v] + parts)
    else:
        raise ValueError(f"unknown input kind {kind!r}")
    v = np.clip(v[:n], 0.0, max_voltage_V)
    if len(v) < n:
        v = np.r_[v, np.full(n - len(v), v[-1])]
    return v


def make_history(rng: np.random.Generator, sample_rate_hz: float, max_voltage_V: float,
                 first_voltage_V: float) -> np.ndarray:
    """An unknown history before a record: 1-4 s of ramps from 0 V through 3-7
    random levels to the record's first voltage (V; the last sample is that
    voltage up to rounding, and stands for the record's first sample).

    Parameters
    ----------
    rng : numpy.random.Generator
    sample_rate_hz, max_voltage_V, first_voltage_V : float

    Returns
    -------
    ndarray
    """
    total_s = rng.uniform(1.0, 4.0)
    turns = int(rng.integers(3, 8))
    points = np.r_[0.0, rng.uniform(0, max_voltage_V, turns), first_voltage_V]
    durations = rng.uniform(0.1, 1.0, len(points) - 1)
    durations *= total_s / durations.sum()
    return _ramps(points, durations, sample_rate_hz)


# ------------------------------------------------------------------ effects

def _lti(numerator, denominator, x, sample_rate_hz):
    # A continuous transfer function, discretised with a first-order hold, from zero state.  Not
    # independent_records.first_order_lowpass: that one goes through a state-space form and starts
    # at x[0], which gives other bits, and these records are kept exactly as first generated.
    b, a, _ = scipy.signal.cont2discrete((numerator, denominator), 1.0 / sample_rate_hz, method="foh")
    return scipy.signal.lfilter(np.ravel(b), a, x)


def apply_effect(hysteresis_um, effect: dict, sample_rate_hz: float) -> np.ndarray:
    """The dynamic part of ``effect`` applied to a hysteresis output that starts at rest.

    Parameters
    ----------
    hysteresis_um : ndarray
        Noise-free hysteresis output from rest (the history included), µm.
    effect : dict
        The effect's parameters (``effect["kind"]``: none, lag, resonance,
        creep, delay or drift).
    sample_rate_hz : float

    Returns
    -------
    ndarray
        The output with the effect (for none and drift the input itself: a drift
        is added to the record alone, by :func:`drift_um`).
    """
    y = hysteresis_um
    kind = effect["kind"]
    if kind == "lag":
        return _lti([1.0], [effect["time_constant_s"], 1.0], y, sample_rate_hz)
    if kind == "resonance":
        wn = 2 * np.pi * effect["natural_frequency_hz"]
        return _lti([wn ** 2], [1.0, 2 * effect["damping_ratio"] * wn, wn ** 2], y, sample_rate_hz)
    if kind == "creep":
        out = y.copy()
        for fraction, tau in zip(effect["fractions"], effect["time_constants_s"]):
            out = out + _lti([fraction], [tau, 1.0], y, sample_rate_hz)
        return out
    if kind == "delay":
        t = np.arange(len(y), dtype=float)
        return np.interp(t - effect["delay_samples"], t, y, left=y[0])
    return y


def drift_um(n_samples: int, effect: dict, output_range_um: float) -> np.ndarray:
    """The drift of a record: ``sign · fraction · range · s^power``, s from 0 at
    the first sample to 1 at the last; zeros for any other effect.

    Parameters
    ----------
    n_samples : int
    effect : dict
    output_range_um : float
        The record's noise-free hysteresis output range.

    Returns
    -------
    ndarray, µm
    """
    if effect["kind"] != "drift":
        return np.zeros(n_samples)
    s = np.arange(n_samples) / max(n_samples - 1, 1)
    return effect["sign"] * effect["fraction_of_range"] * output_range_um * s ** effect["power"]


def with_strength(effect: dict, strength: float) -> dict:
    """A copy of ``effect`` with the parameter that sets its size (see
    :data:`STRENGTH_BOUNDS`) set to ``strength``."""
    out = dict(effect)
    kind = out["kind"]
    if kind == "creep":
        out["fractions"] = list(np.array(out["shares"]) * strength)
    if kind in _STRENGTH_KEY:
        out[_STRENGTH_KEY[kind]] = strength
    return out


# ------------------------------------------------------------------ records

@dataclass
class ThirdRecord:
    """One record.

    Attributes
    ----------
    voltage_V : ndarray
    displacement_um : ndarray
        ``clean_um`` plus white noise.
    clean_um : ndarray
        Noise-free output with the effect.
    hysteresis_only_um : ndarray
        Noise-free output of the MPI plant alone (the same history).
    noise_um : float
        Noise σ: :data:`NOISE_SHARE` of the range of ``clean_um``.
    input_kind : str
        One of :data:`INPUT_KINDS`.
    from_rest : bool
        False: the record follows ``history_V``.
    history_V : ndarray or None
        The voltage before the record, from rest at 0 V; its last sample is
        the record's first.
    effect_to_noise : float
        RMS of ``clean_um - hysteresis_only_um`` over ``noise_um``.
    """

    voltage_V: np.ndarray
    displacement_um: np.ndarray
    clean_um: np.ndarray
    hysteresis_only_um: np.ndarray
    noise_um: float
    input_kind: str
    from_rest: bool
    history_V: np.ndarray | None
    effect_to_noise: float


@dataclass
class ThirdRecordSet:
    """The three records of one seed's actuator and its truth.

    Attributes
    ----------
    seed : int
    truth : str
        One of :data:`EFFECTS`.
    effect_parameters : dict
        ``kind`` (none, lag, resonance, creep, delay, drift) and its parameters,
        units in the names.
    plant : ThirdPlant
    sample_rate_hz : float
    records : tuple of ThirdRecord
        Three records with three different input kinds; the third from rest.
    target_to_noise : float
        The effect's RMS on the first record in noise σ, as aimed at.
    """

    seed: int
    truth: str
    effect_parameters: dict
    plant: ThirdPlant
    sample_rate_hz: float
    records: tuple
    target_to_noise: float

    @property
    def train(self) -> ThirdRecord:
        return self.records[0]

    @property
    def validation(self) -> ThirdRecord:
        return self.records[1]

    @property
    def test(self) -> ThirdRecord:
        return self.records[2]


def _with_history(voltage_V, history_V):
    """The whole voltage from rest and the number of samples before the record."""
    if history_V is not None and len(history_V):
        return np.r_[history_V[:-1], voltage_V], len(history_V) - 1
    return voltage_V, 0


def _outputs(full_hysteresis_um, n_before, n_samples, effect, sample_rate_hz):
    """Hysteresis-only and clean output (µm) of the record part of a whole timeline."""
    full_clean = apply_effect(full_hysteresis_um, effect, sample_rate_hz)
    hysteresis, clean = full_hysteresis_um[n_before:], full_clean[n_before:]
    return hysteresis, clean + drift_um(n_samples, effect, hysteresis.max() - hysteresis.min())


def simulate_record(plant: ThirdPlant, effect: dict, voltage_V, sample_rate_hz: float, history_V=None):
    """Noise-free output of a record.

    Parameters
    ----------
    plant : ThirdPlant
    effect : dict
    voltage_V : ndarray
    sample_rate_hz : float
    history_V : ndarray, optional
        The voltage before the record (see :func:`make_history`); default: the
        record starts from rest.

    Returns
    -------
    hysteresis_only_um, clean_um : ndarray
    """
    full, n_before = _with_history(voltage_V, history_V)
    return _outputs(plant.hysteresis_um(full), n_before, len(voltage_V), effect, sample_rate_hz)


def _effect_template(rng, truth, seed):
    """The effect's parameters, its strength still to be set."""
    if truth == "none":
        return {"kind": "none"}
    if truth == "rate_dependence":
        if (seed // len(EFFECTS)) % 2 == 0:
            return {"kind": "lag", "time_constant_s": 1e-3}
        return {"kind": "resonance", "natural_frequency_hz": 200.0,
                "damping_ratio": float(rng.uniform(0.3, 0.8))}
    if truth == "creep":
        modes = int(rng.integers(2, 4))
        taus = np.sort(np.exp(rng.uniform(np.log(0.05), np.log(3.0), modes)))
        shares = rng.dirichlet(np.ones(modes))
        return {"kind": "creep", "time_constants_s": list(taus), "shares": list(shares),
                "fractions": list(shares * 0.05), "total_fraction": 0.05}
    if truth == "delay":
        return {"kind": "delay", "delay_samples": 2.0}
    return {"kind": "drift", "fraction_of_range": 0.01, "sign": float(rng.choice([-1, 1])),
            "power": int(rng.choice([1, 2]))}


def _calibrate(template, target_to_noise, size_to_noise):
    """The template at the strength whose size on the first record is the target:
    bisection within :data:`STRENGTH_BOUNDS` (geometric for a lag's time constant
    and a resonance's frequency), or the bound nearest to an unreachable target."""
    kind = template["kind"]
    weakest, strongest = STRENGTH_BOUNDS[kind]
    if target_to_noise <= size_to_noise(with_strength(template, weakest)):
        return with_strength(template, weakest)
    if target_to_noise >= size_to_noise(with_strength(template, strongest)):
        return with_strength(template, strongest)
    below, above = weakest, strongest
    for _ in range(_BISECTION_STEPS):
        mid = np.sqrt(below * above) if kind in ("lag", "resonance") else 0.5 * (below + above)
        if size_to_noise(with_strength(template, mid)) < target_to_noise:
            below = mid
        else:
            above = mid
    return with_strength(template, 0.5 * (below + above))


def _size_to_noise(hysteresis_um, clean_um):
    noise = NOISE_SHARE * (clean_um.max() - clean_um.min())
    return float(np.sqrt(np.mean((clean_um - hysteresis_um) ** 2)) / noise), noise


def make_third_records(seed: int) -> ThirdRecordSet:
    """The three records of one random actuator, deterministic per seed.

    Parameters
    ----------
    seed : int
        The truth is ``EFFECTS[seed % 5]``.

    Returns
    -------
    ThirdRecordSet
    """
    rng = np.random.default_rng(SEED_OFFSET + seed)
    plant = make_plant(rng)
    fs = 5000.0 if rng.random() < 0.2 else 2000.0
    truth = EFFECTS[seed % len(EFFECTS)]
    kinds = [str(k) for k in rng.permutation(INPUT_KINDS)]
    durations = rng.uniform(8.0, 12.0, 3)
    from_rest = [bool(rng.random() < 0.5), bool(rng.random() < 0.5), True]
    voltages, histories = [], []
    for kind, duration, rest in zip(kinds, durations, from_rest):
        v = make_input(kind, rng, fs, duration, plant.max_voltage_V, from_rest=rest)
        voltages.append(v)
        histories.append(None if rest else make_history(rng, fs, plant.max_voltage_V, v[0]))
    template = _effect_template(rng, truth, seed)
    target = float(np.exp(rng.uniform(np.log(1.0), np.log(20.0))))
    noise_seed = int(rng.integers(1 << 31))

    # the hysteresis does not depend on the effect: simulated once per record
    timelines = [_with_history(v, h) for v, h in zip(voltages, histories)]
    full_hysteresis = [plant.hysteresis_um(full) for full, _ in timelines]

    def outputs(j, effect):
        return _outputs(full_hysteresis[j], timelines[j][1], len(voltages[j]), effect, fs)

    effect = template
    if truth != "none":
        effect = _calibrate(template, target, lambda e: _size_to_noise(*outputs(0, e))[0])
    noise_rng = np.random.default_rng(noise_seed)
    records = []
    for j in range(3):
        hysteresis, clean = outputs(j, effect)
        size, noise = _size_to_noise(hysteresis, clean)
        measured = clean + noise_rng.normal(0, noise, len(clean))
        records.append(ThirdRecord(voltages[j], measured, clean, hysteresis, noise, kinds[j], from_rest[j],
                                   histories[j], size))
    return ThirdRecordSet(seed, truth, effect, plant, fs, tuple(records), target)


def describe_effect(effect: dict) -> str:
    """A short label of an effect, e.g. ``"lag 1.25 ms"`` or ``"creep 3.2 % @ 0.10 s, 0.7 % @ 2.80 s"``."""
    kind = effect["kind"]
    if kind == "lag":
        return f"lag {effect['time_constant_s'] * 1e3:.2f} ms"
    if kind == "resonance":
        return f"resonance {effect['natural_frequency_hz']:.0f} Hz, ζ {effect['damping_ratio']:.2f}"
    if kind == "creep":
        return "creep " + ", ".join(f"{c * 100:.1f} % @ {tau:.2f} s"
                                    for c, tau in zip(effect["fractions"], effect["time_constants_s"]))
    if kind == "delay":
        return f"delay {effect['delay_samples']:.2f} samples"
    if kind == "drift":
        return f"drift {effect['sign'] * effect['fraction_of_range'] * 100:+.2f} % s^{effect['power']}"
    return "none"
