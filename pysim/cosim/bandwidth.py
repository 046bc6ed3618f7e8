"""Stepped-sine frequency response and the −3 dB bandwidth of the co-simulated chain.

At each frequency f the reference is ``x_d = offset + A sin(2π f t)`` with a
communication step of ``1 / (samples_per_period f)``, so every period has the
same samples.  The chain runs for a number of settling periods, then the
fundamental of the stage's displacement is taken by projection on sine and
cosine over whole periods (:func:`fundamental`).  Its ratio to ``A`` is the
gain; normalised to the lowest frequency's gain, the −3 dB crossing is
interpolated in log-frequency (:func:`crossing_frequency`).

Settling: one period to wipe out the start from the demagnetised state (after
one maximum and one minimum a periodic input gives periodic operator states),
then enough periods for the stage's slowest transient to fall by
``settle_tol`` (the stage starts in equilibrium with the first displacement).

The stage is discretised with Tustin prewarped at f (:mod:`pysim.cosim.stage`), so
its sampled response at f is exactly G(j2πf): the only errors left are the
settling residue and aliasing of the plant's harmonics of order
``samples_per_period ± 1`` onto the fundamental.

Physics to keep in mind: the hysteresis model is rate independent, so with a
fixed number of samples per period the FMUs see the same sample sequence at
every frequency.  The fundamental of their output changes with amplitude, not
with frequency, and the *normalised* response of both paths is the stage's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import CoSimulation, NominalDrive
from pysim.cosim.stage import slowest_time_constant_s

PATHS = ("uncompensated", "compensated")
PAPER_BANDWIDTH_HZ = {"uncompensated": 185.0, "compensated": 884.0}


def fundamental(signal, samples_per_period: int) -> complex:
    """Complex amplitude of the fundamental of a record of whole periods.

    Parameters
    ----------
    signal : array_like
        Samples ``y_k``, a whole number of periods of ``samples_per_period``.
    samples_per_period : int
        Samples per period of the fundamental (≥ 3).

    Returns
    -------
    complex ``c`` with ``y_k ≈ offset + Re(c) sin(2π k/N) + Im(c) cos(2π k/N) + ...``:
    ``abs(c)`` is the amplitude, ``angle(c)`` the phase against ``sin``.  The
    projection is exact for a constant and for harmonics 2 .. N−2 (harmonics
    N ± 1 fold onto the fundamental).
    """
    y = np.asarray(signal, dtype=float).ravel()
    n = int(samples_per_period)
    if n < 3:
        raise CoSimulationError(f"need at least 3 samples per period, got {samples_per_period}")
    if y.size == 0 or y.size % n:
        raise CoSimulationError(f"record of {y.size} samples is not a whole number of periods of {n}")
    periods = y.size // n
    phase = 2.0 * math.pi * np.arange(n) / n
    folded = y.reshape(periods, n).sum(axis=0)
    scale = 2.0 / y.size
    return complex(scale * np.dot(folded, np.sin(phase)), scale * np.dot(folded, np.cos(phase)))


def crossing_frequency(frequencies_hz, normalised, drop_db: float = -3.0) -> float:
    """First frequency where the normalised magnitude falls below ``drop_db``,
    interpolated linearly in dB against log-frequency.

    Returns NaN when the response never falls below (or starts below) the level.
    """
    f = np.asarray(frequencies_hz, dtype=float)
    db = 20.0 * np.log10(np.asarray(normalised, dtype=float))
    below = np.flatnonzero(db < drop_db)
    if below.size == 0 or below[0] == 0:
        return math.nan
    i = below[0]
    x0, x1 = math.log(f[i - 1]), math.log(f[i])
    return math.exp(x0 + (drop_db - db[i - 1]) * (x1 - x0) / (db[i] - db[i - 1]))


def default_frequencies(f_min_hz: float = 10.0, f_max_hz: float = 2000.0, points: int = 40) -> np.ndarray:
    """Log-spaced sweep frequencies, Hz."""
    if not (0 < f_min_hz < f_max_hz) or points < 2:
        raise CoSimulationError(f"need 0 < f_min < f_max and at least 2 points, got {f_min_hz}, {f_max_hz}, {points}")
    return np.geomspace(f_min_hz, f_max_hz, int(points))


@dataclass
class SweepResult:
    """Frequency response of one path at one amplitude.

    Attributes
    ----------
    path : str
        ``"uncompensated"`` or ``"compensated"``.
    amplitude_um, offset_um : float
        Reference ``offset + A sin``, µm.
    frequencies_hz : ndarray
    response : ndarray of complex
        Fundamental of the stage displacement over ``A`` (gain and phase
        against the reference sine).
    actuator_gain : ndarray
        Fundamental of the actuator (plant) displacement over ``A``.
    """

    path: str
    amplitude_um: float
    offset_um: float
    frequencies_hz: np.ndarray
    response: np.ndarray
    actuator_gain: np.ndarray
    settings: dict = field(default_factory=dict)

    @property
    def gain(self) -> np.ndarray:
        return np.abs(self.response)

    @property
    def normalised(self) -> np.ndarray:
        """Gain over the gain at the lowest frequency."""
        return self.gain / self.gain[0]

    def bandwidth_hz(self, drop_db: float = -3.0) -> float:
        """−3 dB point of the normalised response (NaN if not crossed)."""
        return crossing_frequency(self.frequencies_hz, self.normalised, drop_db)

    def bandwidth_vs_desired_hz(self, drop_db: float = -3.0) -> float:
        """−3 dB point of the gain against the desired amplitude ``A`` (not
        normalised): what a low-frequency gain error does to the figure."""
        return crossing_frequency(self.frequencies_hz, self.gain, drop_db)


def settling_periods(frequency_hz: float, time_constant_s: float, settle_tol: float) -> int:
    """Periods before measuring: one for the hysteresis memory, then enough
    for a transient of time constant ``time_constant_s`` to fall by ``settle_tol``."""
    if math.isinf(time_constant_s):
        raise CoSimulationError("the stage has a pole on the stability boundary: its response never settles")
    return 1 + math.ceil(frequency_hz * time_constant_s * math.log(1.0 / settle_tol))


def stepped_sine(sim: CoSimulation, frequencies_hz, amplitude_um: float, offset_um: float,
                 path: str, drive: NominalDrive | None = None, samples_per_period: int = 64,
                 settle_tol: float = 1e-6, measure_periods: int = 2, progress=None) -> SweepResult:
    """Stepped-sine response of one path of a co-simulation.

    Parameters
    ----------
    sim : CoSimulation
        Plant (and, for the compensated path, inverse) FMU and stage.  It is
        reset for every frequency.
    frequencies_hz : array_like
        Ascending frequencies, Hz.
    amplitude_um, offset_um : float
        Reference ``offset + A sin(2π f t)``, µm.
    path : {"uncompensated", "compensated"}
        Uncompensated: voltage = ``drive(reference)``; compensated: the
        reference goes through the inverse FMU.
    drive : NominalDrive
        The uncompensated drive (required for that path).
    samples_per_period : int
        Communication steps per period (≥ 8).
    settle_tol : float
        Stage transient left at the start of the measurement, relative.
    measure_periods : int
        Whole periods the fundamental is taken over.
    progress : Progress, optional
        Advanced by one per frequency.
    """
    if path not in PATHS:
        raise CoSimulationError(f"path must be one of {PATHS}, got {path!r}")
    if path == "uncompensated" and drive is None:
        raise CoSimulationError("the uncompensated path needs the nominal drive")
    if path == "compensated" and sim.inverse is None:
        raise CoSimulationError("the compensated path needs an inverse FMU")
    if samples_per_period < 8 or measure_periods < 1 or not (0 < settle_tol < 1):
        raise CoSimulationError("need samples_per_period >= 8, measure_periods >= 1 and 0 < settle_tol < 1")
    if not amplitude_um > 0:
        raise CoSimulationError(f"amplitude must be positive, got {amplitude_um} µm")
    f = np.asarray(frequencies_hz, dtype=float)
    if f.ndim != 1 or f.size < 2 or np.any(f <= 0) or np.any(np.diff(f) <= 0):
        raise CoSimulationError("frequencies must be positive and ascending (at least two)")
    tau = 0.0 if sim.stage_system is None else slowest_time_constant_s(sim.stage_system)
    n = int(samples_per_period)
    one_period = offset_um + amplitude_um * np.sin(2.0 * math.pi * np.arange(n) / n)
    response = np.empty(f.size, dtype=complex)
    actuator = np.empty(f.size)
    saved_start = sim.stage_start
    sim.stage_start = "steady"
    try:
        for i, fi in enumerate(f):
            step = 1.0 / (n * fi)
            sim.reset(step_s=step, prewarp_hz=fi if sim.stage_system is not None and not sim.stage_system.dt
                      else None)
            settle = settling_periods(fi, tau, settle_tol)
            reference = np.tile(one_period, settle + measure_periods)
            if path == "compensated":
                result = sim.run(reference)
            else:
                result = sim.run(voltage_V=drive(reference))
            tail = slice(settle * n, None)
            response[i] = fundamental(result.displacement_stage_um[tail], n) / amplitude_um
            actuator[i] = abs(fundamental(result.displacement_plant_um[tail], n)) / amplitude_um
            if progress is not None:
                progress.update()
    finally:
        sim.stage_start = saved_start
    settings = {"samples_per_period": n, "settle_tol": settle_tol, "measure_periods": measure_periods,
                "stage_time_constant_s": tau, "stage_discretisation": "tustin prewarped at each frequency"}
    return SweepResult(path, float(amplitude_um), float(offset_um), f, response, actuator, settings)


def measure_bandwidth(sim: CoSimulation, drive: NominalDrive, amplitudes_um=(7.5, 15.0, 30.0),
                      offset_um: float = 37.5, frequencies_hz=None, paths=PATHS, progress=None,
                      **options) -> list[SweepResult]:
    """Stepped-sine sweeps of the given paths at each amplitude.

    Returns the :class:`SweepResult` list, amplitude-major, in ``paths`` order.
    ``options`` go to :func:`stepped_sine`.
    """
    f = default_frequencies() if frequencies_hz is None else np.asarray(frequencies_hz, dtype=float)
    results = []
    for amplitude in amplitudes_um:
        for path in paths:
            if progress is not None:
                progress.update(0, label=f"{path} A={amplitude:g} µm")
            results.append(stepped_sine(sim, f, amplitude, offset_um, path, drive,
                                        progress=progress, **options))
    return results


def summary(results: list[SweepResult], stage=None, drop_db: float = -3.0) -> dict:
    """JSON-ready summary: ``bandwidth_hz`` per path (at the largest amplitude),
    per-amplitude figures, the stage's own bandwidth and the paper's numbers."""
    by_amplitude = {}
    for r in results:
        entry = by_amplitude.setdefault(r.amplitude_um, {"amplitude_um": r.amplitude_um, "offset_um": r.offset_um})
        entry[r.path] = {
            "bandwidth_hz": _finite_or_none(r.bandwidth_hz(drop_db)),
            "bandwidth_vs_desired_amplitude_hz": _finite_or_none(r.bandwidth_vs_desired_hz(drop_db)),
            "low_frequency_gain": float(r.gain[0]),
            "peak_gain": float(np.max(r.gain)),
        }
    rows = [by_amplitude[a] for a in sorted(by_amplitude)]
    top = rows[-1] if rows else {}
    out = {
        "bandwidth_hz": {p: top[p]["bandwidth_hz"] for p in PATHS if p in top},
        "at_amplitude_um": top.get("amplitude_um"),
        "by_amplitude": rows,
        "paper_bandwidth_hz": dict(PAPER_BANDWIDTH_HZ),
        "drop_db": drop_db,
    }
    if stage is not None:
        import control

        out["stage_bandwidth_hz"] = _finite_or_none(float(control.bandwidth(stage, dbdrop=drop_db)) / (2 * math.pi)
                                                    if not stage.dt else math.nan)
    if results:
        out["frequencies_hz"] = [float(x) for x in results[0].frequencies_hz]
        out["settings"] = results[0].settings
    return out


def _finite_or_none(x):
    return float(x) if x is not None and math.isfinite(x) else None
