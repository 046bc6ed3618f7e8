"""What compensation will do on a rig: identify the compensator from data
recorded on the (simulated) rig, build its inverse FMU, and co-simulate it
against the rig in every configuration.

The rig (:class:`pysim.cosim.rig.Rig`) holds the actuator as it *is*; the
compensator only ever sees what a user would record on it: the amplifier's
voltage and the sensor's reading, with noise and quantisation, from a starting
state nobody knows.  Everything the co-simulation then predicts -- Table III,
bandwidths, their spread over model error -- follows from that mismatch and
from the rig's amplifier, converters and loop, not from the compensator's own
model.

Examples
--------
>>> from pysim.specs.rig_default import RIG                      # doctest: +SKIP
>>> study = RigStudy.identify_on(RIG)                           # doctest: +SKIP
>>> rows = study.table_iii()                                    # doctest: +SKIP
>>> rows[0]["compensated"]["rms_error_pct"]                     # doctest: +SKIP
1.4...
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pysim.core.metrics import error_measures
from pysim.cosim.harness import fmus_for_model, plant_fmu_for_model
from pysim.cosim.rig import MAX_PREVIEW, PATHS, Rig, RigSimulation, rig_stepped_sine, sweep_frequencies, tracking_bandwidth_hz
from pysim.cosim.tracking import PAPER_TABLE_III, TABLE_III_AMPLITUDES_UM, TABLE_III_OFFSET_UM
from pysim.identification.identify import identify

__all__ = ["RigStudy", "identification_excitation", "record_on_rig", "reference_sine"]


def identification_excitation(rig: Rig, seed: int = 7, duration_s: float = 5.0,
                              history_s: float = 0.5) -> tuple:
    """Voltage (V) a user plays on the rig to identify it, with an unknown past.

    A random history of turning points (``history_s``, not recorded: the rig's
    state when the recording starts is unknown), then two full-range 1 Hz
    cycles and a 1 Hz sine of decaying amplitude around mid-range (minor
    loops, like the paper's complex input) for the rest of ``duration_s``.

    Returns ``(voltage_V, first_recorded_sample)``.
    """
    rng = np.random.default_rng(seed)
    T = rig.step_s
    lo, hi = rig.voltage_range_V
    n_hist = int(round(history_s / T))
    points = np.concatenate([[lo], rng.uniform(lo, hi, 6)])
    history = np.interp(np.linspace(0, 1, n_hist), np.linspace(0, 1, points.size), points)
    t = np.arange(int(round(duration_s / T))) * T
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    full = mid - half * np.cos(2 * math.pi * t)
    decay = mid - half * np.cos(2 * math.pi * t) * np.exp(-(t - 2.0) / 1.2)
    recorded = np.where(t < 2.0, full, decay)
    # join the history to the record without a jump
    ramp = np.linspace(history[-1], recorded[0], int(round(0.05 / T)))
    return np.concatenate([history, ramp, recorded]), n_hist + ramp.size


def record_on_rig(sim: RigSimulation, voltage_V, first_recorded: int = 0) -> tuple:
    """Play ``voltage_V`` open loop on the rig; returns the recorded
    ``(voltage_V, measured_um)`` from sample ``first_recorded`` on: the
    amplifier's output and the sensor's reading (noise, ADC) as a rig logs them."""
    result = sim.run_voltage(voltage_V)
    return result.voltage_V[first_recorded:], result.measured_um[first_recorded:]


def reference_sine(amplitude_um: float, step_s: float, periods: int = 2, offset_um: float = TABLE_III_OFFSET_UM,
                   frequency_hz: float = 1.0) -> tuple:
    """``offset + A sin(2π f t)`` (µm) at the rig's step over ``periods``
    whole periods and on past them by the feedforward's preview, and the rows
    of a :class:`pysim.cosim.rig.RigResult` that hold the last whole period.

    Returns ``(reference_um, last_period_rows)``.
    """
    per_period = int(round(1.0 / (frequency_hz * step_s)))
    k = np.arange(per_period * periods + 1 + MAX_PREVIEW)
    reference = offset_um + amplitude_um * np.sin(2.0 * math.pi * k / per_period)
    return reference, slice((periods - 1) * per_period, periods * per_period)


@dataclass
class RigStudy:
    """A rig and the compensator identified on it.

    Attributes
    ----------
    rig : Rig
    compensator : HysteresisModel
        The model identified from the rig's record (its inverse is the
        feedforward).
    identification : dict
        How it was identified: samples, fit errors, the excitation.
    fmu_dir : path or None
        Where the FMUs go (default: the package cache).
    """

    rig: Rig
    compensator: object
    identification: dict = field(default_factory=dict)
    fmu_dir: object = None

    @classmethod
    def identify_on(cls, rig: Rig, n_operators: int = 10, seed: int = 7, fmu_dir=None) -> "RigStudy":
        """Record the identification excitation on ``rig`` and fit an MPI
        model of ``n_operators`` operators to it (constrained least squares;
        the fitted model is invertible)."""
        voltage, first = identification_excitation(rig, seed)
        with RigSimulation(rig, plant_fmu_for_model(rig.plant, fmu_dir)) as sim:
            v, y = record_on_rig(sim, voltage, first)
        result = identify(v, y, n_operators=n_operators, model="mpi", name=f"{rig.name}_compensator",
                          description=f"MPI model identified from a record of the simulated rig {rig.name}")
        info = {"samples": int(v.size), "sample_rate_hz": 1.0 / rig.step_s, "n_operators": n_operators,
                "fit_errors_pct": {k: float(x) for k, x in result.errors.items()},
                "excitation": "random history (unrecorded), 2 full-range 1 Hz cycles, decaying 1 Hz sine",
                "noise_rms_um": rig.noise.rms_um, "adc_lsb_um": rig.adc.lsb}
        return cls(rig, result.model, info, fmu_dir)

    # ---------------------------------------------------------- simulation
    def simulation(self, plant_parameters=None, inverse_parameters=None) -> RigSimulation:
        """The rig with the compensator's inverse FMU (and optional parameter
        changes of either FMU)."""
        plant = plant_fmu_for_model(self.rig.plant, self.fmu_dir)
        _, inverse = fmus_for_model(self.compensator, self.fmu_dir)
        from pysim.cosim.harness import NominalDrive

        return RigSimulation(self.rig, plant, inverse, NominalDrive.from_model(self.compensator),
                             plant_parameters, inverse_parameters)

    def table_iii(self, amplitudes_um=TABLE_III_AMPLITUDES_UM, paths=PATHS, periods: int = 2,
                  offset_um: float = TABLE_III_OFFSET_UM, frequency_hz: float = 1.0, sim=None, runs=None,
                  progress=None) -> list:
        """Tracking errors (eq. 14-15, % of the reference range, over the last
        period) of each path at each amplitude, with the paper's Table III.

        ``runs``, a dict, receives ``(amplitude, path) -> RigResult``."""
        own = sim is None
        sim = self.simulation() if own else sim
        rows = []
        try:
            for amplitude in amplitudes_um:
                reference, last = reference_sine(amplitude, self.rig.step_s, periods, offset_um, frequency_hz)
                row = {"amplitude_um": float(amplitude), "paper": PAPER_TABLE_III.get(float(amplitude))}
                for path in paths:
                    result = sim.run_path(reference, path)
                    row[path] = error_measures(result.reference_um[last], result.displacement_stage_um[last])
                    if runs is not None:
                        runs[(float(amplitude), path)] = result
                    if progress is not None:
                        progress.update()
                rows.append(row)
        finally:
            if own:
                sim.close()
        return rows

    def sweeps(self, amplitudes_um=(7.5, 30.0), paths=PATHS, offset_um: float = TABLE_III_OFFSET_UM,
               points: int = 40, f_min_hz: float = 10.0, f_max_hz: float = 2000.0, sim=None,
               progress=None) -> list:
        """Stepped-sine responses of each path at each amplitude (see
        :func:`pysim.cosim.rig.rig_stepped_sine`)."""
        f, _ = sweep_frequencies(self.rig.step_s, f_min_hz, f_max_hz, points)
        own = sim is None
        sim = self.simulation() if own else sim
        try:
            return [rig_stepped_sine(sim, a, offset_um, path, f, progress=progress)
                    for a in amplitudes_um for path in paths]
        finally:
            if own:
                sim.close()

    def monte_carlo(self, draws: int = 20, weight_spread: float = 0.10, a2_spread: float = 0.05,
                    a1_spread: float = 0.20, amplitude_um: float = 15.0, paths=("compensated",
                                                                                  "feedback+compensated"),
                    seed: int = 11, sweep_points: int = 20, sweep_f_min_hz: float = 20.0,
                    sweep_f_max_hz: float = 2000.0, progress=None) -> dict:
        """Table III errors and -3 dB points over compensators drawn around the
        identified one.

        Each draw scales every operator weight by ``1 + N(0, weight_spread)``,
        ``a2`` by ``1 + N(0, a2_spread)`` and ``a1`` by ``1 + N(0, a1_spread)``
        (draws whose inverse would not exist are drawn again), sets them as
        parameters of the same inverse FMU, tracks the ``amplitude_um``
        reference and, unless ``sweep_points`` is 0, runs a stepped sine of
        that amplitude over ``sweep_points`` frequencies from
        ``sweep_f_min_hz`` to ``sweep_f_max_hz``.

        Returns
        -------
        dict
            ``runs`` (per path the ``error_measures`` of every draw),
            ``bandwidths`` (per path, per draw: the -3 dB point of the
            normalised response and against the desired amplitude, Hz, None
            where the sweep does not cross), and ``summary`` (per path the 5 %,
            median and 95 % points of each; a bandwidth's percentiles over the
            draws that cross, with their count).

        Examples
        --------
        >>> study = RigStudy.identify_on(load_rig("rig_default"))            # doctest: +SKIP
        >>> mc = study.monte_carlo(10)                                        # doctest: +SKIP
        >>> mc["summary"]["compensated"]["rms_error_pct"]["median"]          # doctest: +SKIP
        3.49
        """
        rng = np.random.default_rng(seed)
        model = self.compensator
        out = {path: [] for path in paths}
        bandwidths = {path: [] for path in paths}
        reference, last = reference_sine(amplitude_um, self.rig.step_s, 2)
        if sweep_points:
            frequencies, _ = sweep_frequencies(self.rig.step_s, sweep_f_min_hz, sweep_f_max_hz, sweep_points)
        done = 0
        while done < draws:
            weights = np.asarray(model.weights_um_per_V) * (1 + weight_spread * rng.standard_normal(model.n_operators))
            a2 = model.a2 * (1 + a2_spread * rng.standard_normal())
            a1 = model.a1 * (1 + a1_spread * rng.standard_normal())
            drawn = model.with_parameters(a1=a1, a2=a2, weights_um_per_V=tuple(weights))
            if not drawn.check_invertibility().invertible:
                continue
            parameters = {"a1": a1, "a2": a2, **{f"b[{i + 1}]": w for i, w in enumerate(weights)}}
            with self.simulation(inverse_parameters=parameters) as sim:
                for path in paths:
                    result = sim.run_path(reference, path)
                    out[path].append(error_measures(result.reference_um[last], result.displacement_stage_um[last]))
                    if sweep_points:
                        sweep = rig_stepped_sine(sim, amplitude_um, TABLE_III_OFFSET_UM, path, frequencies)
                        bandwidths[path].append({"minus3db_normalised_hz": _finite(sweep.bandwidth_hz()),
                                                 "minus3db_vs_desired_hz": _finite(sweep.bandwidth_vs_desired_hz())})
            done += 1
            if progress is not None:
                progress.update()
        summary = {}
        for path, values in out.items():
            summary[path] = {key: _percentiles([v[key] for v in values]) for key in ("max_error_pct", "rms_error_pct")}
            for key in ("minus3db_normalised_hz", "minus3db_vs_desired_hz"):
                crossed = [b[key] for b in bandwidths[path] if b[key] is not None]
                summary[path][key] = {**_percentiles(crossed), "crossed": len(crossed)} if crossed else None
        return {"draws": draws, "amplitude_um": amplitude_um, "spread": {"weights": weight_spread, "a2": a2_spread,
                                                                        "a1": a1_spread},
                "sweep": None if not sweep_points else {"points": int(frequencies.size),
                                                        "f_min_hz": float(frequencies[0]),
                                                        "f_max_hz": float(frequencies[-1])},
                "runs": out, "bandwidths": bandwidths, "summary": summary}


def bandwidth_summary(results, drop_db: float = -3.0) -> dict:
    """Per path and amplitude: the -3 dB point normalised to the lowest
    frequency, the -3 dB point against the desired amplitude, and the
    error-based tracking bandwidth (RMS error above 10 % of the range)."""
    summary = {}
    for r in results:
        summary.setdefault(r.path, {})[f"{r.amplitude_um:g}"] = {
            "minus3db_normalised_hz": _finite(r.bandwidth_hz(drop_db)),
            "minus3db_vs_desired_hz": _finite(r.bandwidth_vs_desired_hz(drop_db)),
            "tracking_10pct_hz": _finite(tracking_bandwidth_hz(r)),
            "low_frequency_gain": float(r.gain[0]),
        }
    return summary


def _percentiles(values) -> dict:
    """5 %, median and 95 % points of ``values``."""
    return {"p5": float(np.percentile(values, 5)), "median": float(np.median(values)),
            "p95": float(np.percentile(values, 95))}


def _finite(x):
    return None if x is None or not math.isfinite(x) else float(x)
