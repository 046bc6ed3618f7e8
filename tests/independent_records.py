"""An independent generator of measured-like piezo records, to judge the diagnosis.

Everything here is a second implementation, written from the physics and the
paper (Gu, Zhu, Su 2014) only: the one-sided play operators, the modified
Prandtl-Ishlinskii (MPI) plant, the dynamic effects, the inputs and the noise.
Nothing of the package is used to make a record, so a record's truth does not
depend on the code under test.

A call of :func:`make_pair` returns two records of the same actuator -- a
training record and a validation record with another input shape, at the same
sample rate -- and the truth.

The plant (continuous time, simulated on a grid ``OVERSAMPLING`` times finer
than the sample grid and sampled like an ADC would)::

    x = P[v]                      pre-stage: identity, a slew-rate limit or a low-pass
    u = x - v_low                 shift so that the one-sided operators see u >= 0
    h = a1 u^3 + a2 u + sum_i b_i F_{r_i}[u]
    y = G[h] + C + d(t) + offset  G: lag / second-order stage; C: creep; d: drift
    measured(t_k) = y(t_k - delay) + noise, quantised

with 15-40 operators on random thresholds (off the eq. 13 grid), a random
weight density (a few weights may be negative) and ``a1`` of either sign,
checked numerically to be strictly increasing along dense branches.  At most
one effect is present per record:

============================  ==============================================
effect                        what the plant does
============================  ==============================================
``none``                      the MPI plant alone
``rate_dependence``           first-order lag or second-order stage after the hysteresis
``creep``                     non-negative sum of slow first-order modes of the input
                              (or of the hysteresis output), time constants from a few
                              sample periods to seconds: a monotone, log-like step response
``delay``                     the output is ``y(t - delay)``, whole or fractional samples
                              (an exact continuous-time delay, not an interpolation)
``drift``                     a slow smooth trend ``d(t)`` of time since the record start
``rate_dependent_hysteresis`` a first-order low-pass *before* the hysteresis (loops widen
                              with frequency)
``slew_limit``                the amplifier output follows the command at most at a given
                              rate (V/ms); the record holds the command
============================  ==============================================

Every effect's strength is calibrated so that the part of the effect that no
rate-independent model can absorb -- the residual of a least-squares fit, on
the noise-free training record, of a rich rate-independent basis (the true
operators *with their true initial state*, 50 more operators on a dense
threshold grid, 1, u, u², u³) -- is a random multiple of the noise level,
log-uniform between 0.3 and 30.  That multiple is reported
(``Truth.unabsorbable_to_noise``); an effect counts as *detectable* when it is
at least 1.

The training record starts from rest (operators demagnetised at the bottom of
the range, the input eased in from there) or after an unknown random history
(a few ramps between random turning points and a hold, no preconditioning
cycle).  The validation record always starts from rest, so a model started
from its own initial state can be compared with it after a short settling
window (``Record.settle_samples``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.signal

__all__ = ["EFFECTS", "INPUT_KINDS", "VOLTAGE_RANGES_V", "SAMPLE_RATES_HZ", "OVERSAMPLING",
           "DETECTABLE_RATIO", "Plant", "Record", "Truth", "RecordPair", "make_pair", "make_plant",
           "osp_operators", "osp_recursion", "branch_slopes", "first_order_lowpass", "respond", "plant_from_dict",
           "second_order_lowpass", "rate_limit", "rich_basis_residual", "preisach_relays"]

#: Effects a record can hide, in the order the seeds cycle through them ("none" twice).
EFFECTS = ("none", "rate_dependence", "creep", "delay", "drift", "rate_dependent_hysteresis", "slew_limit")
_EFFECT_CYCLE = ("none", "rate_dependence", "creep", "delay", "none", "drift",
                 "rate_dependent_hysteresis", "slew_limit")
INPUT_KINDS = ("decaying_triangle", "multisine", "steps_sines", "chirp", "band_noise", "sine")
VOLTAGE_RANGES_V = ((0.0, 150.0), (0.0, 100.0), (-30.0, 120.0))
SAMPLE_RATES_HZ = (1000.0, 2000.0, 2500.0, 5000.0, 10000.0)
#: Fine simulation steps per sample period.
OVERSAMPLING = 4
#: An effect is "detectable" when its unabsorbable RMS is at least this multiple of the noise σ.
DETECTABLE_RATIO = 1.0
#: Range of the calibrated unabsorbable-RMS-to-noise ratio (log-uniform).
TARGET_RATIO_RANGE = (0.3, 30.0)
_DENSE_OPERATORS = 50


# ------------------------------------------------------------------ operators

def osp_recursion(u, thresholds, state=None):
    """One-sided play operators by the sample recursion of the paper (eq. 3-4).

    ``w_k = max(u_k - r, min(u_k, w_{k-1}))``, ``w_{-1} = state`` (default 0).
    The plain reference implementation: one sample at a time.

    Parameters
    ----------
    u : array_like, shape (n,)
        Operator input (V).
    thresholds : array_like, shape (m,)
        Thresholds r >= 0 (V).
    state : array_like, shape (m,), optional
        Operator outputs before the first sample.

    Returns
    -------
    ndarray, shape (n, m)
        Operator outputs (V).
    """
    u = np.asarray(u, dtype=float).ravel()
    r = np.asarray(thresholds, dtype=float).ravel()
    w = np.zeros(r.size) if state is None else np.array(state, dtype=float)
    out = np.empty((u.size, r.size))
    for k, uk in enumerate(u):
        w = np.maximum(uk - r, np.minimum(uk, w))
        out[k] = w
    return out


def osp_operators(u, thresholds, state=None, keep=None, weights=None):
    """One-sided play operators, exact on every monotone piece of the input.

    On a rising piece from state ``w_s`` the output is ``max(w_s, u - r)``, on a
    falling piece ``min(w_s, u)`` (the paper's definition over a partition into
    monotone pieces); the pieces are handled as blocks.

    Parameters
    ----------
    u : array_like, shape (n,)
        Operator input (V).
    thresholds : array_like, shape (m,)
        Thresholds r >= 0 (V).
    state : array_like, shape (m,), optional
        Operator outputs before the first sample (default: demagnetised, 0).
    keep : array_like of int, optional
        Sorted sample indices to return (default: all).
    weights : array_like, shape (m,), optional
        If given, return ``sum_i weights_i w_i`` instead of the operator outputs.

    Returns
    -------
    outputs : ndarray, shape (len(keep), m), or (len(keep),) with weights
    final_state : ndarray, shape (m,)
    """
    u = np.asarray(u, dtype=float).ravel()
    r = np.asarray(thresholds, dtype=float).ravel()
    b = None if weights is None else np.asarray(weights, dtype=float).ravel()
    keep = np.arange(u.size) if keep is None else np.asarray(keep, dtype=np.int64)
    w = np.zeros(r.size) if state is None else np.array(state, dtype=float)
    out = np.empty((keep.size,) if b is not None else (keep.size, r.size))
    if u.size == 0:
        return out, w
    w = np.maximum(u[0] - r, np.minimum(u[0], w))

    def put(indices, block):
        lo, hi = np.searchsorted(keep, [indices[0], indices[-1] + 1])
        if hi > lo:
            rows = block[keep[lo:hi] - indices[0]]
            out[lo:hi] = rows @ b if b is not None else rows

    put(np.array([0]), w[None, :])
    if u.size == 1:
        return out, w
    direction = np.sign(np.diff(u))
    moving = np.flatnonzero(direction)
    if moving.size == 0:
        put(np.arange(1, u.size), np.broadcast_to(w, (u.size - 1, r.size)))
        return out, w
    # flat steps carry the direction before them (they leave the state unchanged either way)
    last = np.maximum.accumulate(np.where(direction != 0, np.arange(direction.size), -1))
    direction = direction[np.where(last >= 0, last, moving[0])]
    bounds = np.concatenate(([0], np.flatnonzero(np.diff(direction)) + 1, [direction.size]))
    for a, z in zip(bounds[:-1], bounds[1:]):
        # steps a..z-1 move samples a+1..z
        lo, hi = np.searchsorted(keep, [a + 1, z + 1])
        if hi > lo:
            seg = u[keep[lo:hi]][:, None]
            rows = np.maximum(seg - r, w) if direction[a] > 0 else np.minimum(seg, w)
            out[lo:hi] = rows @ b if b is not None else rows
        end = u[z]
        w = np.maximum(end - r, w) if direction[a] > 0 else np.minimum(end, w)
    return out, w


# ------------------------------------------------------------------ linear stages

def _run_lti(x, dt_s, system):
    """Run a continuous SISO system (A, B, C, D) with unit static gain on a
    piecewise-linear input sampled every ``dt_s`` (first-order hold, exact for
    such an input), starting at rest at ``x[0]``."""
    ad, bd, cd, dd, _ = scipy.signal.cont2discrete(system, dt_s, method="foh")
    num, den = scipy.signal.ss2tf(ad, bd, cd, dd)
    num = num.ravel()
    zi = scipy.signal.lfilter_zi(num, den) * x[0]
    y, _ = scipy.signal.lfilter(num, den, x, zi=zi)
    return y


def first_order_lowpass(x, dt_s, time_constant_s):
    """``1/(τ s + 1)`` of a piecewise-linear signal (exact), at rest at ``x[0]``.

    Parameters
    ----------
    x : ndarray
        Signal samples every ``dt_s`` seconds.
    dt_s : float
        Sample spacing, s.
    time_constant_s : float
        τ, s (> 0).

    Returns
    -------
    ndarray
    """
    tau = float(time_constant_s)
    return _run_lti(np.asarray(x, dtype=float), dt_s,
                    (np.array([[-1.0 / tau]]), np.array([[1.0 / tau]]), np.array([[1.0]]), np.array([[0.0]])))


def second_order_lowpass(x, dt_s, natural_frequency_hz, damping_ratio):
    """``ω²/(s² + 2ζω s + ω²)`` of a piecewise-linear signal (exact), at rest at ``x[0]``.

    Parameters
    ----------
    x : ndarray
        Signal samples every ``dt_s`` seconds.
    dt_s : float
        Sample spacing, s.
    natural_frequency_hz : float
        f_n (ω = 2π f_n), Hz.
    damping_ratio : float
        ζ (> 0).

    Returns
    -------
    ndarray
    """
    w = 2.0 * math.pi * float(natural_frequency_hz)
    a = np.array([[0.0, 1.0], [-w * w, -2.0 * damping_ratio * w]])
    return _run_lti(np.asarray(x, dtype=float), dt_s,
                    (a, np.array([[0.0], [w * w]]), np.array([[1.0, 0.0]]), np.array([[0.0]])))


def preisach_relays(v, lo, hi, levels: int = 30, up_centre: float = 0.7, down_centre: float = 0.3,
                    ramp_share: float = 0.0):
    """A hysteresis outside the MPI class: a Preisach model of relays.

    Relays switch up at ``alpha`` and down at ``beta <= alpha`` on a grid of
    ``levels`` values over ``[lo, hi]``; their weight is a 2-D Gaussian
    centred at (``up_centre``, ``down_centre``) of the range, so minor loops
    are not congruent (a play-operator model cannot draw them).  All relays
    start down (the input came from below ``lo``).  With ``ramp_share`` > 0
    each relay switches along a ramp of that share of the range instead of
    at once (the Krasnosel'skii-Pokrovskii kernel): the output is continuous,
    as a real actuator's is.  Returns the weighted relay sum in [-1, 1].
    """
    v = np.asarray(v, dtype=float)
    grid = np.linspace(lo, hi, levels)
    up, down = np.meshgrid(grid, grid, indexing="ij")
    keep = up >= down
    up, down = up[keep], down[keep]
    x, z = (up - lo) / (hi - lo), (down - lo) / (hi - lo)
    weight = np.exp(-((x - up_centre) ** 2 / 0.09 + (z - down_centre) ** 2 / 0.04) / 2)
    weight /= weight.sum()
    state = -np.ones(weight.size)
    out = np.empty(v.size)
    ramp = ramp_share * (hi - lo)
    for k, u in enumerate(v):
        if ramp > 0:
            # up along [alpha - ramp, alpha], down along [beta, beta + ramp]
            rising = np.clip(2.0 * (u - up) / ramp + 1.0, -1.0, 1.0)
            falling = np.clip(2.0 * (u - down) / ramp - 1.0, -1.0, 1.0)
            state = np.maximum(np.minimum(state, falling), rising)
        else:
            state[up <= u] = 1.0
            state[down >= u] = -1.0
        out[k] = weight @ state
    return out


def rate_limit(x, dt_s, max_rate_V_per_s):
    """Output that follows ``x`` at most at ``max_rate_V_per_s`` (an amplifier's
    slew-rate limit), starting at ``x[0]``.

    Parameters
    ----------
    x : ndarray
        Command samples (V) every ``dt_s`` seconds.
    dt_s : float
        Sample spacing, s.
    max_rate_V_per_s : float
        Largest rate of change, V/s.

    Returns
    -------
    ndarray
    """
    x = np.asarray(x, dtype=float)
    step = float(max_rate_V_per_s) * dt_s
    if x.size == 0 or np.max(np.abs(np.diff(x)), initial=0.0) <= step:
        return x.copy()
    current = float(x[0])
    ys = [current]
    for value in x[1:].tolist():      # plain loop; fast enough for these lengths
        delta = value - current
        if delta > step:
            current += step
        elif delta < -step:
            current -= step
        else:
            current = value
        ys.append(current)
    return np.asarray(ys)


# ------------------------------------------------------------------ plant

@dataclass(frozen=True)
class Plant:
    """The rate-independent MPI part of the truth.

    Attributes
    ----------
    voltage_range_V : (float, float)
        Voltage range; the operators see ``u = v - voltage_range_V[0]``.
    a1_um_per_V3, a2_um_per_V : float
        Cubic and linear coefficients.
    thresholds_V, weights_um_per_V : ndarray
        Operator thresholds (ascending, off the eq. 13 grid) and weights.
    sensor_offset_um : float
        Added to the measured displacement.
    """

    voltage_range_V: tuple
    a1_um_per_V3: float
    a2_um_per_V: float
    thresholds_V: np.ndarray
    weights_um_per_V: np.ndarray
    sensor_offset_um: float

    @property
    def span_V(self) -> float:
        return float(self.voltage_range_V[1] - self.voltage_range_V[0])

    def hysteresis_um(self, u_V, keep=None):
        """``a1 u³ + a2 u + Σ b_i F_{r_i}[u]`` (µm) from the demagnetised state,
        at the sample indices ``keep`` (default all)."""
        u = np.asarray(u_V, dtype=float)
        idx = np.arange(u.size) if keep is None else np.asarray(keep)
        ops, _ = osp_operators(u, self.thresholds_V, keep=idx, weights=self.weights_um_per_V)
        uk = u[idx]
        return self.a1_um_per_V3 * uk ** 3 + self.a2_um_per_V * uk + ops

    def as_dict(self) -> dict:
        return {"voltage_range_V": list(self.voltage_range_V), "a1_um_per_V3": self.a1_um_per_V3,
                "a2_um_per_V": self.a2_um_per_V, "thresholds_V": self.thresholds_V.tolist(),
                "weights_um_per_V": self.weights_um_per_V.tolist(), "n_operators": int(self.thresholds_V.size),
                "sensor_offset_um": self.sensor_offset_um}


def branch_slopes(plant: Plant, points_per_ramp: int = 400) -> np.ndarray:
    """Slopes dy/du (µm/V) along dense monotone branches of the plant.

    The branches: the first loading curve, nested reversals from the top and
    the bottom towards the middle, small reversals near both ends and a few
    interior minor loops.

    Returns
    -------
    ndarray
        Finite-difference slopes of every step of every ramp (all must be > 0
        for an invertible plant).
    """
    s = plant.span_V
    levels = [0.0, s]
    for k in range(1, 10):
        levels += [k / 20 * s, (1 - k / 20) * s]
    levels += [s, 0.999 * s, s, 0.99 * s, s, 0.0, 0.001 * s, 0.0, 0.01 * s, 0.6 * s, 0.3 * s, 0.45 * s, 0.35 * s,
               0.9 * s, 0.1 * s, s]
    u = [np.zeros(1)]
    for a, z in zip(levels[:-1], levels[1:]):
        u.append(np.linspace(a, z, points_per_ramp)[1:])
    u = np.concatenate(u)
    y = plant.hysteresis_um(u)
    du, dy = np.diff(u), np.diff(y)
    moving = np.abs(du) > 0
    return dy[moving] / du[moving]


def _exact_min_slope(plant: Plant) -> float:
    """Smallest slope along any branch (µm/V): ``a2 + 3 a1 u² + Σ_{i<=j} b_i`` over
    u in the range and every prefix j of the thresholds: after a reversal the
    operators with thresholds below the distance travelled move (those with
    r = 0 always do)."""
    b, r = plant.weights_um_per_V, plant.thresholds_V
    always = float(np.sum(b[r == 0]))
    prefix = always + np.concatenate(([0.0], np.cumsum(b[r > 0])))
    cubic = min(0.0, 3.0 * plant.a1_um_per_V3 * plant.span_V ** 2)
    return float(plant.a2_um_per_V + cubic + prefix.min())


def make_plant(rng: np.random.Generator, voltage_range_V=None) -> Plant:
    """A random invertible MPI plant (15-40 operators, thresholds off the eq. 13 grid).

    Parameters
    ----------
    rng : numpy.random.Generator
    voltage_range_V : (float, float), optional
        Default: one of :data:`VOLTAGE_RANGES_V`.

    Returns
    -------
    Plant
    """
    if voltage_range_V is None:
        voltage_range_V = VOLTAGE_RANGES_V[rng.integers(len(VOLTAGE_RANGES_V))]
    lo, hi = (float(x) for x in voltage_range_V)
    s = hi - lo
    for _ in range(100):
        n = int(rng.integers(15, 41))
        r = np.sort(rng.uniform(0.0, s * rng.uniform(0.7, 1.0), n))
        if rng.random() < 0.5:
            r[0] = 0.0
        x = r / s
        shape = rng.integers(3)
        if shape == 0:        # the paper's example: density rising towards the top
            density = np.exp(-rng.uniform(0.3, 1.5) * (x - 1.0) ** 2)
        elif shape == 1:      # decaying density: most hysteresis from small thresholds
            density = np.exp(-x / rng.uniform(0.15, 0.6))
        else:                 # bump somewhere inside
            density = np.exp(-((x - rng.uniform(0.1, 0.8)) / rng.uniform(0.1, 0.4)) ** 2)
        density *= rng.lognormal(0.0, 0.35, n)
        spacing = np.diff(np.concatenate(([0.0], r)))
        spacing[0] = max(spacing[0], s / n / 2)
        b = density * spacing
        if rng.random() < 0.3:
            k = rng.choice(n, size=int(rng.integers(1, 3)), replace=False)
            b[k] *= -rng.uniform(0.2, 0.7, k.size)
        eta = rng.uniform(0.1, 0.5)           # loop weight relative to the linear part
        b *= eta / max(np.sum(b * (s - r)) / s, 1e-12)
        a2 = 1.0
        a1 = rng.uniform(-0.12, 0.12) * (1.0 + eta) / s ** 2
        travel_um = rng.uniform(0.3, 0.8) * s
        scale = travel_um / (a1 * s ** 3 + a2 * s + np.sum(b * (s - r)))
        plant = Plant((lo, hi), float(a1 * scale), float(a2 * scale), r, b * scale,
                      float(rng.uniform(-150.0, 50.0)))
        nominal = travel_um / s
        if _exact_min_slope(plant) > 0.05 * nominal and branch_slopes(plant, 100).min() > 0.05 * nominal:
            return plant
    raise RuntimeError("no invertible plant found")  # pragma: no cover


# ------------------------------------------------------------------ inputs

def _frequency_limit_hz(sample_rate_hz: float) -> float:
    return min(sample_rate_hz / 25.0, 200.0)


def _normaliser(values, lo, hi):
    vmin, vmax = float(np.min(values)), float(np.max(values))
    return lambda x: np.clip(lo + (hi - lo) * (x - vmin) / (vmax - vmin), lo, hi)


def _make_signal(rng, kind, duration_s, sample_rate_hz, lo, hi):
    """The record's input shape ``s(t)`` for t >= 0 (V), and its parameters."""
    span = hi - lo
    fmax = _frequency_limit_hz(sample_rate_hz)
    grid = np.linspace(0.0, duration_s, int(duration_s * sample_rate_hz * 8) + 1)
    if kind == "decaying_triangle":
        f = min(rng.uniform(3, 12) / duration_s, fmax / 3)
        end = rng.uniform(0.05, 0.4)
        first = 1.0 / f

        def fn(t):
            x = np.mod(f * t, 1.0)
            tri = 1.0 - np.abs(1.0 - 2.0 * x)
            env = np.where(t < first, 1.0, 1.0 - (1.0 - end) * np.clip((t - first) / (duration_s - first), 0, 1))
            return lo + span * env * tri
        return fn, {"frequency_hz": f, "final_amplitude": end}
    if kind == "sine":
        f = min(rng.uniform(2, 20) / duration_s, fmax)
        return (lambda t: lo + 0.5 * span * (1.0 - np.cos(2 * math.pi * f * t))), {"frequency_hz": f}
    if kind == "chirp":
        f0 = rng.uniform(1.0, 3.0) / duration_s
        f1 = min(f0 * rng.uniform(5, 40), fmax)
        log_sweep = bool(rng.random() < 0.5)
        k = math.log(f1 / f0) / duration_s

        def chirp(t):
            if log_sweep:
                phase = 2 * math.pi * f0 * np.expm1(k * t) / k
            else:
                phase = 2 * math.pi * (f0 * t + 0.5 * (f1 - f0) * t * t / duration_s)
            return lo + 0.5 * span * (1.0 + np.sin(phase))
        return chirp, {"f0_hz": f0, "f1_hz": f1, "logarithmic": log_sweep}
    if kind in ("multisine", "band_noise"):
        if kind == "multisine":
            f0 = rng.integers(1, 3) / duration_s        # one or two periods: each extreme once per period
            top = max(3, int(min(fmax / f0, 40)))
            m = np.sort(rng.choice(np.arange(1, top + 1), size=min(int(rng.integers(3, 13)), top), replace=False))
            freqs = f0 * m
            amps = m.astype(float) ** -rng.uniform(0.0, 1.0)
        else:
            fc = rng.uniform(min(5.0, fmax), fmax) if fmax > 5 else fmax
            freqs = np.sort(rng.uniform(0.5 / duration_s, fc, int(rng.integers(60, 151))))
            amps = np.ones_like(freqs)
        phases = rng.uniform(0, 2 * math.pi, freqs.size)

        def raw(t):
            t = np.asarray(t, dtype=float)
            out = np.zeros_like(t)
            for a, f, p in zip(amps, freqs, phases):
                out += a * np.sin(2 * math.pi * f * t + p)
            return out
        norm = _normaliser(raw(grid), lo, hi)
        return (lambda t: norm(raw(t))), {"frequencies_hz": freqs.tolist(), "amplitudes": amps.tolist()}
    if kind == "steps_sines":
        n = int(rng.integers(4, 11))
        durations = rng.dirichlet(np.full(n, 3.0)) * duration_s
        starts = np.concatenate(([0.0], np.cumsum(durations)[:-1]))
        kinds = ["hold" if (i % 2 == 0 or rng.random() < 0.3) else "sine" for i in range(n)]
        holds = [i for i in range(n) if kinds[i] == "hold"]
        levels = rng.uniform(lo, hi, n)
        pick = rng.choice(holds, size=min(2, len(holds)), replace=False)
        levels[pick[0]] = lo
        if pick.size > 1:
            levels[pick[1]] = hi
        else:
            kinds[0] = "hold"
        rise_s = max(2e-4, 1.0 / (sample_rate_hz * OVERSAMPLING))
        segments = []
        level = levels[0]
        for i in range(n):
            if kinds[i] == "hold":
                segments.append(("hold", starts[i], durations[i], level, levels[i]))
                level = levels[i]
            else:
                amp = rng.uniform(0.3, 1.0) * min(level - lo, hi - level)
                cycles = max(1, int(rng.uniform(0.5, 1.0) * min(fmax / 2, 40.0) * durations[i]))
                f = cycles / durations[i]
                segments.append(("sine", starts[i], durations[i], level, (amp, f)))
        first_level = levels[0]

        def fn(t):
            t = np.asarray(t, dtype=float)
            out = np.full_like(t, first_level)
            for i, (seg_kind, t0, dur, before, arg) in enumerate(segments):
                mask = (t >= t0) & (t < t0 + dur) if i < len(segments) - 1 else t >= t0
                if not np.any(mask):
                    continue
                tt = t[mask] - t0
                if seg_kind == "hold":
                    out[mask] = before + (arg - before) * np.clip(tt / rise_s, 0.0, 1.0)
                else:
                    amp, f = arg
                    out[mask] = before + amp * np.sin(2 * math.pi * f * tt)
            return np.clip(out, lo, hi)
        return fn, {"segments": [(k, float(t0), float(d)) for k, t0, d, _, _ in segments],
                    "rise_time_s": rise_s}
    raise ValueError(f"unknown input kind {kind!r}")


def _eased(fn, lo, hi, ease_s, grid):
    """``s(t)`` eased in from ``lo`` over ``ease_s`` (raised cosine) and scaled so
    that its maximum on ``grid`` is ``hi`` again."""
    def window(t):
        return np.where(t >= ease_s, 1.0, 0.5 - 0.5 * np.cos(math.pi * np.clip(t, 0, None) / ease_s))
    peak = float(np.max(lo + (fn(grid) - lo) * window(grid)))
    gain = (hi - lo) / (peak - lo)
    return lambda t: np.clip(lo + (fn(t) - lo) * window(t) * gain, lo, hi)


@dataclass
class _Timeline:
    """Fine simulation grid: a history before t = 0, then the record."""

    sample_rate_hz: float
    n_samples: int
    n_history: int                  # history length in sample periods
    signal: object                  # record input s(t), t >= 0
    history_t_s: np.ndarray         # knots of the piecewise-linear history (t < 0)
    history_v_V: np.ndarray
    low_V: float
    _cache: dict = field(default_factory=dict)

    @property
    def dt_s(self) -> float:
        return 1.0 / (self.sample_rate_hz * OVERSAMPLING)

    @property
    def fine_time_s(self) -> np.ndarray:
        n = (self.n_history + self.n_samples - 1) * OVERSAMPLING + 1
        return (np.arange(n) - self.n_history * OVERSAMPLING) * self.dt_s

    @property
    def keep(self) -> np.ndarray:
        return self.n_history * OVERSAMPLING + np.arange(self.n_samples) * OVERSAMPLING

    def voltage_V(self, t_s) -> np.ndarray:
        """The input at any times (V): history for t < 0, the record after."""
        t = np.asarray(t_s, dtype=float)
        out = np.interp(t, self.history_t_s, self.history_v_V, left=self.low_V)
        later = t >= 0
        out[later] = self.signal(t[later])
        return out

    def fine_voltage_V(self, shift_s: float = 0.0) -> np.ndarray:
        key = round(shift_s, 15)
        if key not in self._cache:
            self._cache[key] = self.voltage_V(self.fine_time_s - shift_s)
        return self._cache[key]

    def record_voltage_V(self) -> np.ndarray:
        return self.fine_voltage_V()[self.keep]


def _make_timeline(rng, kind, n_samples, sample_rate_hz, lo, hi, start):
    duration_s = n_samples / sample_rate_hz
    signal, params = _make_signal(rng, kind, duration_s, sample_rate_hz, lo, hi)
    grid = np.linspace(0.0, duration_s, int(duration_s * sample_rate_hz * 8) + 1)
    if start == "rest":
        if abs(float(signal(np.zeros(1))[0]) - lo) > 1e-9 * (hi - lo):
            ease_s = rng.uniform(0.03, 0.06) * duration_s
            signal = _eased(signal, lo, hi, ease_s, grid)
            params["ease_in_s"] = ease_s
        knots_t, knots_v = np.array([-0.05, 0.0]), np.array([lo, lo])
    else:
        n_turns = int(rng.integers(3, 9))
        turns = rng.uniform(lo, hi, n_turns)
        v0 = float(signal(np.zeros(1))[0])
        hold_s = rng.uniform(0.001, 0.5)
        knots_v = np.concatenate(([lo, lo], turns, [v0, v0]))
        gaps = np.concatenate(([0.1], rng.uniform(0.02, 0.5, n_turns + 1), [hold_s]))
        knots_t = np.concatenate(([0.0], np.cumsum(gaps))) - np.sum(gaps)
        knots_t[-1] = 0.0
        params["history_turning_points_V"] = turns.tolist()
        params["history_hold_s"] = hold_s
    n_history = math.ceil(-knots_t[0] * sample_rate_hz) + 2
    return _Timeline(sample_rate_hz, n_samples, n_history, signal, knots_t, knots_v, lo), params


# ------------------------------------------------------------------ effects

def _respond(plant: Plant, effect: dict, timeline: _Timeline) -> np.ndarray:
    """Noise-free displacement (µm, without the sensor offset) at the record samples."""
    name = effect["name"]
    dt = timeline.dt_s
    shift = effect["delay_samples"] / timeline.sample_rate_hz if name == "delay" else 0.0
    v = timeline.fine_voltage_V(shift)
    lo = plant.voltage_range_V[0]
    if name == "slew_limit":
        v = rate_limit(v, dt, effect["slew_rate_V_per_ms"] * 1e3)
    elif name == "rate_dependent_hysteresis":
        v = first_order_lowpass(v, dt, effect["time_constant_s"])
    u = v - lo
    keep = timeline.keep
    fine = name == "rate_dependence" or (name == "creep" and effect["driven_by"] == "hysteresis")
    h = plant.hysteresis_um(u, None if fine else keep)
    if name == "rate_dependence":
        if effect["order"] == 1:
            h = first_order_lowpass(h, dt, effect["time_constant_s"])
        else:
            h = second_order_lowpass(h, dt, effect["natural_frequency_hz"], effect["damping_ratio"])
        return h[keep]
    if name == "creep":
        driver = u if effect["driven_by"] == "input" else h
        total = np.zeros(keep.size)
        for tau, weight in zip(effect["time_constants_s"], effect["weights"]):
            total += weight * first_order_lowpass(driver, dt, tau)[keep]
        return (h[keep] if fine else h) + total
    if name == "drift":
        t = np.arange(timeline.n_samples) / timeline.sample_rate_hz
        return h + _drift_um(effect, t)
    return h


def _drift_um(effect: dict, t_s) -> np.ndarray:
    """Slow smooth trend (µm) of the time since the record start."""
    a = effect["amplitude_um"] * effect.get("direction", 1.0)
    tau, shape = effect["time_scale_s"], effect["shape"]
    if shape == "settling":
        return a * -np.expm1(-t_s / tau)
    if shape == "linear":
        return a * t_s / tau
    return a * np.sin(0.5 * math.pi * t_s / tau) ** 2      # "bend": slow sine, flat at the start


def _effect_template(rng, name, sample_rate_hz, duration_s, plant, timeline):
    """Effect parameters except its strength, the strength's name, bounds and
    how the effect grows with it (exponent of size ∝ strength^k, a first guess)."""
    T = 1.0 / sample_rate_hz
    nominal_gain = (plant.a2_um_per_V + float(np.sum(plant.weights_um_per_V)))
    if name == "none":
        return {"name": name}, None
    if name == "rate_dependence":
        if rng.random() < 0.5:
            return {"name": name, "order": 1}, ("time_constant_s", (0.1 * T, 0.05), 1.0)
        return ({"name": name, "order": 2, "damping_ratio": float(rng.uniform(0.1, 0.8))},
                ("natural_frequency_hz", (20.0, sample_rate_hz / 3.0), -2.0))
    if name == "creep":
        n = int(rng.integers(3, 7))
        fastest = rng.uniform(3, 20) * T
        slowest = rng.uniform(0.5, 5.0)
        taus = np.geomspace(fastest, max(slowest, 20 * fastest), n)
        shares = rng.lognormal(0.0, 0.3, n)
        driven = "input" if rng.random() < 0.6 else "hysteresis"
        unit = nominal_gain if driven == "input" else 1.0
        return ({"name": name, "driven_by": driven, "time_constants_s": taus.tolist(),
                 "_shares": (shares / shares.sum() * unit).tolist()},
                ("creep_fraction", (1e-6, 0.25), 1.0))
    if name == "delay":
        return {"name": name}, ("delay_samples", (0.05, 20.0), 1.0)
    if name == "drift":
        shape = ["settling", "linear", "bend"][rng.integers(3)]
        scale = {"settling": rng.uniform(0.2, 2.0), "linear": 1.0, "bend": rng.uniform(1.0, 3.0)}[shape]
        return ({"name": name, "shape": shape, "time_scale_s": float(scale * duration_s),
                 "direction": float(rng.choice([-1.0, 1.0]))},
                ("amplitude_um", (1e-6, 0.3 * nominal_gain * plant.span_V), 1.0))
    if name == "rate_dependent_hysteresis":
        return {"name": name}, ("time_constant_s", (0.1 * T, 0.05), 1.0)
    if name == "slew_limit":
        v = timeline.fine_voltage_V()
        fastest = float(np.max(np.abs(np.diff(v)))) / timeline.dt_s / 1e3   # V/ms
        return ({"name": name, "_fastest_V_per_ms": fastest},
                ("slew_rate_V_per_ms", (0.1 * fastest, 0.999 * fastest), -1.0))
    raise ValueError(f"unknown effect {name!r}")


def _with_strength(template: dict, key: str, value: float) -> dict:
    effect = {k: v for k, v in template.items() if not k.startswith("_")}
    if key == "creep_fraction":
        effect["creep_fraction"] = value
        effect["weights"] = [value * s for s in template["_shares"]]
    else:
        effect[key] = value
    return effect


def rich_basis_residual(plant: Plant, timeline: _Timeline):
    """A function giving the part of a signal at the record samples that no
    rate-independent model can absorb.

    The basis: 1, u, u², u³, the plant's own operators and 50 operators on a
    dense threshold grid, all driven by the *recorded* voltage through the true
    history (so their initial state is exact).  The returned function projects
    a signal (µm) onto the orthogonal complement of that basis.
    """
    v = timeline.fine_voltage_V()
    u = v - plant.voltage_range_V[0]
    keep = timeline.keep
    dense = np.linspace(0.0, plant.span_V, _DENSE_OPERATORS, endpoint=False)[1:]
    r = np.concatenate((plant.thresholds_V, dense))
    ops, _ = osp_operators(u, r, keep=keep)
    uk = u[keep] / plant.span_V
    basis = np.column_stack([np.ones_like(uk), uk, uk ** 2, uk ** 3, ops / plant.span_V])
    basis /= np.maximum(np.linalg.norm(basis, axis=0), 1e-300)
    left, sv, _ = np.linalg.svd(basis, full_matrices=False)
    q = left[:, sv > sv[0] * 1e-10]
    return lambda y: y - q @ (q.T @ y)


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


# ------------------------------------------------------------------ records

@dataclass
class Record:
    """One measured-like record.

    Attributes
    ----------
    voltage_V : ndarray
        The recorded (commanded) voltage.
    displacement_um : ndarray
        The measured displacement: noise, quantisation and sensor offset included.
    clean_um : ndarray
        The same without noise and quantisation (offset included).
    sample_rate_hz : float
    input_kind : str
        One of :data:`INPUT_KINDS`.
    input_parameters : dict
    start : str
        ``"rest"`` or ``"history"``.
    settle_samples : int
        Samples to leave out when a model started from its own initial state is
        compared with the record (the ease-in and 2 % more, at least 0.05 s).
    """

    voltage_V: np.ndarray
    displacement_um: np.ndarray
    clean_um: np.ndarray
    sample_rate_hz: float
    input_kind: str
    input_parameters: dict
    start: str
    settle_samples: int

    @property
    def duration_s(self) -> float:
        return self.voltage_V.size / self.sample_rate_hz


@dataclass
class Truth:
    """What was hidden in a pair of records.

    Attributes
    ----------
    effect : str
        One of :data:`EFFECTS`.
    effect_parameters : dict
        The effect's parameters (units in the names).
    plant : dict
        The MPI plant (:meth:`Plant.as_dict`).
    noise_sigma_um, quantisation_step_um : float
        White noise σ and ADC step (0: not quantised).
    noise_fraction_of_range : float
        σ over the training record's noise-free displacement range.
    effect_rms_um : float
        RMS of (with effect − without) on the noise-free training record.
    unabsorbable_rms_um : float
        RMS of the part of the effect a rich rate-independent model cannot absorb
        (see :func:`rich_basis_residual`).
    unabsorbable_to_noise, target_to_noise : float
        That RMS over σ, achieved and aimed at.
    detectable : bool
        ``unabsorbable_to_noise >= DETECTABLE_RATIO`` (always False for "none").
    validation_effect_rms_um : float
        RMS of (with effect − without) on the noise-free validation record after
        its settling window: the error of a model with the true hysteresis and
        no effect on the new input.
    test_effect_rms_um : float
        The same on the third record (``RecordPair.test``).
    """

    effect: str
    effect_parameters: dict
    plant: dict
    noise_sigma_um: float
    quantisation_step_um: float
    noise_fraction_of_range: float
    effect_rms_um: float
    unabsorbable_rms_um: float
    unabsorbable_to_noise: float
    target_to_noise: float
    detectable: bool
    validation_effect_rms_um: float
    test_effect_rms_um: float = 0.0

    def as_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass
class RecordPair:
    """Records of one actuator and the truth.

    Attributes
    ----------
    seed : int
    train, validation : Record
        The training record and a second record with another input shape.
    truth : Truth
    test : Record
        A third record with a third input shape, also from rest: for scoring
        a prediction on a record the diagnosis never saw, even when it was
        given the validation record.
    """

    seed: int
    train: Record
    validation: Record
    truth: Truth
    test: Record = None


def _settle(params, n_samples, sample_rate_hz):
    ease = params.get("ease_in_s", 0.0)
    return int(min(n_samples // 4, math.ceil((ease + max(0.02 * n_samples / sample_rate_hz, 0.05)) * sample_rate_hz)))


def make_pair(seed: int, effect: str | None = None, *, n_samples: int | None = None,
              validation_samples: int | None = None, sample_rate_hz: float | None = None,
              start: str | None = None, target_to_noise: float | None = None) -> RecordPair:
    """Two records of one random actuator and the truth, deterministic per seed.

    Parameters
    ----------
    seed : int
    effect : str, optional
        One of :data:`EFFECTS`; default cycles with the seed
        (none, rate_dependence, creep, delay, none, drift,
        rate_dependent_hysteresis, slew_limit).
    n_samples, validation_samples : int, optional
        Record lengths (default: 5 000-30 000 for training, 50-100 % of that,
        at least 5 000, for validation).
    sample_rate_hz : float, optional
        Default: one of :data:`SAMPLE_RATES_HZ`.
    start : {"rest", "history"}, optional
        Start of the training record (default: random).
    target_to_noise : float, optional
        Aimed unabsorbable-RMS-to-noise ratio (default: log-uniform in
        :data:`TARGET_RATIO_RANGE`).

    Returns
    -------
    RecordPair

    Notes
    -----
    Each part of the draw has its own random stream, so overriding one option
    leaves the others as they were (the same seed keeps its plant when only
    the length changes, for example).
    """
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(int(seed)).spawn(7)]
    r_plant, r_input, r_val, r_effect, r_noise, r_misc, r_test = streams
    if effect is None:
        effect = _EFFECT_CYCLE[int(seed) % len(_EFFECT_CYCLE)]
    if effect not in EFFECTS:
        raise ValueError(f"effect must be one of {EFFECTS}, got {effect!r}")
    plant = make_plant(r_plant)
    lo, hi = plant.voltage_range_V
    fs = float(sample_rate_hz or SAMPLE_RATES_HZ[r_misc.integers(len(SAMPLE_RATES_HZ))])
    n_train = int(n_samples or r_misc.integers(5000, 30001))
    n_val = int(validation_samples or max(5000, min(n_train, round(n_train * r_misc.uniform(0.5, 1.0)))))
    start = start or ("rest" if r_misc.random() < 0.5 else "history")
    noise_fraction = r_noise.uniform(0.001, 0.005)
    quantise = r_noise.random() < 0.4
    bits = int(r_noise.choice([12, 14]))
    full_scale = r_noise.uniform(1.2, 2.0)
    target = float(target_to_noise or math.exp(r_effect.uniform(*np.log(TARGET_RATIO_RANGE))))

    kind = INPUT_KINDS[r_input.integers(len(INPUT_KINDS))]
    others = [k for k in INPUT_KINDS if k != kind]
    kind_val = others[r_val.integers(len(others))]
    timeline, params = _make_timeline(r_input, kind, n_train, fs, lo, hi, start)
    timeline_val, params_val = _make_timeline(r_val, kind_val, n_val, fs, lo, hi, "rest")
    rest = [k for k in others if k != kind_val]
    kind_test = rest[r_test.integers(len(rest))]
    n_test = int(max(5000, min(n_train, round(n_train * r_test.uniform(0.5, 1.0)))))
    timeline_test, params_test = _make_timeline(r_test, kind_test, n_test, fs, lo, hi, "rest")

    plain = _respond(plant, {"name": "none"}, timeline)
    travel = float(np.ptp(plain))
    sigma = noise_fraction * travel
    residual = rich_basis_residual(plant, timeline)

    template, strength = _effect_template(r_effect, effect, fs, n_train / fs, plant, timeline)
    if strength is None:
        chosen = dict(template)
        clean = plain
    else:
        key, (low, high), exponent = strength
        chosen, clean = _calibrate(plant, timeline, template, key, low, high, exponent, target * sigma,
                                   plain, residual)
    if effect == "delay" and r_effect.random() < 0.35:
        # a whole number of samples, as a converter pipeline would give
        chosen["delay_samples"] = float(max(1, round(chosen["delay_samples"])))
        clean = _respond(plant, chosen, timeline)
    effect_rms = _rms(clean - plain)
    unabsorbable = _rms(residual(clean - plain)) if strength is not None else 0.0
    if effect == "delay":
        chosen["delay_s"] = chosen["delay_samples"] / fs
    clean_val = _respond(plant, chosen, timeline_val)
    clean_test = _respond(plant, chosen, timeline_test)

    lsb = full_scale * travel / 2 ** bits if quantise else 0.0
    # what the effect costs the true hysteresis alone on the new input
    plain_val = _respond(plant, {"name": "none"}, timeline_val)
    settle_val = _settle(params_val, n_val, fs)
    effect_val = _rms((clean_val - plain_val)[settle_val:])
    settle_test = _settle(params_test, n_test, fs)
    effect_test = _rms((clean_test - _respond(plant, {"name": "none"}, timeline_test))[settle_test:])

    def measure(y, n):
        y = y + plant.sensor_offset_um + r_noise.normal(0.0, sigma, n)
        return np.round(y / lsb) * lsb if lsb else y

    train = Record(timeline.record_voltage_V(), measure(clean, n_train), clean + plant.sensor_offset_um, fs, kind,
                   params, start, _settle(params, n_train, fs))
    validation = Record(timeline_val.record_voltage_V(), measure(clean_val, n_val),
                        clean_val + plant.sensor_offset_um, fs, kind_val, params_val, "rest", settle_val)
    ratio = unabsorbable / sigma
    truth = Truth(effect, chosen, plant.as_dict(), sigma, lsb, noise_fraction, effect_rms, unabsorbable, ratio,
                  target if strength is not None else 0.0, bool(strength is not None and ratio >= DETECTABLE_RATIO),
                  effect_val, effect_test)
    y_test = clean_test + plant.sensor_offset_um + r_test.normal(0.0, sigma, n_test)
    test = Record(timeline_test.record_voltage_V(), np.round(y_test / lsb) * lsb if lsb else y_test,
                  clean_test + plant.sensor_offset_um, fs, kind_test, params_test, "rest", settle_test)
    return RecordPair(int(seed), train, validation, truth, test)


def plant_from_dict(plant: dict) -> Plant:
    """The :class:`Plant` of a truth's ``plant`` dictionary."""
    return Plant(tuple(plant["voltage_range_V"]), float(plant["a1_um_per_V3"]), float(plant["a2_um_per_V"]),
                 np.asarray(plant["thresholds_V"], dtype=float), np.asarray(plant["weights_um_per_V"], dtype=float),
                 float(plant["sensor_offset_um"]))


def respond(pair: RecordPair, voltage_V, *, noise_seed: int = 0, sample_rate_hz: float | None = None) -> Record:
    """A record of the pair's actuator (plant, effect, noise, sensor) for any
    voltage, sampled at the pair's rate or at ``sample_rate_hz`` -- what the rig
    would measure if that voltage were played on it, e.g. an excitation a
    diagnosis suggests.

    The actuator starts from rest at the bottom of its range and is ramped to
    the first voltage over 0.05 s before the record starts; between samples
    the voltage is interpolated linearly.

    Parameters
    ----------
    pair : RecordPair
    voltage_V : array_like
        Voltage samples at the record's rate; clipped to the range.
    noise_seed : int
        Seed of the noise.
    sample_rate_hz : float, optional
        The record's rate (default ``pair.train.sample_rate_hz``); the noise
        per sample is the pair's.

    Returns
    -------
    Record (``input_kind`` "given", no settling window beyond the ramp)
    """
    plant = plant_from_dict(pair.truth.plant)
    fs = float(sample_rate_hz or pair.train.sample_rate_hz)
    lo, hi = plant.voltage_range_V
    v = np.clip(np.asarray(voltage_V, dtype=float).ravel(), lo, hi)
    times = np.arange(v.size) / fs
    timeline = _Timeline(fs, v.size, math.ceil(0.1 * fs) + 2, lambda t: np.interp(t, times, v),
                         np.array([-0.1, -0.05, 0.0]), np.array([lo, lo, v[0]]), lo)
    effect = dict(pair.truth.effect_parameters)
    if effect["name"] == "delay":          # stated in samples of the pair's rate: the same time here
        effect["delay_samples"] *= fs / pair.train.sample_rate_hz
    clean = _respond(plant, effect, timeline)
    rng = np.random.default_rng(noise_seed)
    lsb = pair.truth.quantisation_step_um
    y = clean + plant.sensor_offset_um + rng.normal(0.0, pair.truth.noise_sigma_um, v.size)
    if lsb:
        y = np.round(y / lsb) * lsb
    return Record(v, y, clean + plant.sensor_offset_um, fs, "given", {}, "rest", _settle({}, v.size, fs))


def _calibrate(plant, timeline, template, key, low, high, exponent, target_um, plain, residual):
    """Strength whose unabsorbable RMS is near ``target_um``, within the
    physical bounds ``[low, high]``: secant steps in log-log, bisection once the
    target is bracketed (the size of a slew limit, for one, is zero until it bites).

    ``exponent`` is a first guess of k in size ∝ strength^k (negative when the
    effect grows as the strength falls, as for a natural frequency or a slew rate).
    """
    sign = 1.0 if exponent > 0 else -1.0
    # work in x = sign * log(strength): the size grows with x
    x_low, x_high = sorted((sign * math.log(low), sign * math.log(high)))
    x = sign * (math.log(1.0) if key == "delay_samples" else 0.5 * (math.log(low) + math.log(high)))
    goal = math.log(target_um)
    k = abs(exponent)
    below, above = -math.inf, math.inf    # evaluated strengths below / above the target
    tried = []                            # (miss, x, log size, effect, clean)
    for _ in range(8):
        effect = _with_strength(template, key, math.exp(sign * x))
        clean = _respond(plant, effect, timeline)
        size = _rms(residual(clean - plain))
        log_size = math.log(size) if size > 0 else -math.inf
        tried.append((abs(log_size - goal), x, log_size, effect, clean))
        if tried[-1][0] < math.log(1.1):
            break
        if log_size < goal:
            below = max(below, x)
        else:
            above = min(above, x)
        if len(tried) >= 2 and math.isfinite(log_size) and math.isfinite(tried[-2][2]) and x != tried[-2][1]:
            slope = (log_size - tried[-2][2]) / (x - tried[-2][1])
            if 0.2 < slope < 10:
                k = slope
        new = min(max(x + ((goal - log_size) / k if math.isfinite(log_size) else 3.0), x_low), x_high)
        if not below < new < above:
            new = 0.5 * (max(below, x_low) + min(above, x_high))
        if abs(new - x) < 1e-6:
            break
        x = new
    best = min(tried, key=lambda item: item[0])
    return best[3], best[4]
