"""What compensation will do on the actuator of a measured record.

The compensator is the MPI model identified from the record; the plant it is
co-simulated against is the *extended* model the diagnosis builds from the
same record (hysteresis followed by the admissible output stages it names), so
the prediction contains what the plain model gets wrong.  The rig around it is
the record's own: its sample rate, its voltage range (the record's voltage is
what reached the actuator, so the amplifier is a unit gain with that range),
16-bit converters, the record's noise level, and a PI loop tuned for the loop
latency at that rate.

Examples
--------
>>> from pysim.studies.record_study import record_study     # doctest: +SKIP
>>> result = record_study("discrete_backlash")                # doctest: +SKIP
>>> result["tracking"]["feedback+compensated"]["rms_error_pct"]  # doctest: +SKIP
"""
from __future__ import annotations

import math

import numpy as np

from pysim.core.metrics import error_measures
from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise
from pysim.cosim.harness import NominalDrive, fmus_for_model, plant_fmu_for_model
from pysim.cosim.rig import MAX_PREVIEW, PATHS, Rig, RigSimulation, linear_loop

__all__ = ["record_study", "record_rig"]


def record_rig(plant, compensator, sample_rate_hz: float, noise_um: float, name: str,
               crossover_fraction: float = 0.01) -> Rig:
    """The rig of a record: the plant at the record's rate, a unit-gain
    amplifier over the compensator's voltage range, 16-bit converters, the
    record's noise, and an integral controller whose crossover is
    ``crossover_fraction`` of the sample rate (halved until the loop is stable
    with the loop's latency)."""
    lo, hi = compensator.voltage_range_V
    step_s = 1.0 / sample_rate_hz
    gain = abs(compensator.major_loop_gain())
    y = compensator.simulate(np.array([lo, hi, lo]))
    margin = 0.25 * (y.max() - y.min())
    ki = 2.0 * math.pi * crossover_fraction * sample_rate_hz / gain
    base = dict(plant=plant, stage=None, amplifier=Amplifier(1.0, math.inf, math.inf, 1e-6, lo, hi),
                dac=Converter(16, lo, hi), adc=Converter(16, float(y.min() - margin), float(y.max() + margin)),
                noise=SensorNoise(noise_um), step_s=step_s, name=name,
                description=f"rig of the record {name}: its rate, range and noise")
    import control

    for _ in range(20):
        rig = Rig(controller=PIController(0.0, ki, lo, hi), **base)
        if np.max(np.abs(control.poles(linear_loop(rig, gain)))) < 0.99:
            return rig
        ki /= 2.0
    raise ValueError("no stable integral gain found")  # pragma: no cover - the loop always has one


def record_study(name: str = "discrete_backlash", periods: int = 3, frequency_hz: float = None,
                 amplitude_fraction: float = 0.35) -> dict:
    """Identify, diagnose and co-simulate a shipped record's actuator.

    The reference is a sine of ``amplitude_fraction`` of the reachable range
    around its middle, at the record's own input frequency (or
    ``frequency_hz``), for ``periods`` periods; errors over the last one.

    Returns a dict with ``cause``, ``compensator``, ``plant`` (the extended
    model), ``rig``, ``tracking`` (per path, eq. 14-15 in %) and ``runs``
    (per path, the :class:`pysim.cosim.rig.RigResult`).
    """
    from pysim.diagnosis import diagnose
    from pysim.identification import load_measured, shipped_dataset

    data = load_measured(shipped_dataset(name))
    d = diagnose(data.voltage_V, data.displacement_um, data.sample_rate_hz, name=f"{name}_plant")
    compensator = d.baseline.model
    compensator = getattr(compensator, "hysteresis", compensator)
    plant = d.extended.model
    noise = float(getattr(d, "noise_um", 0.0) or 0.0)
    rig = record_rig(plant, compensator, data.sample_rate_hz, noise, name)
    if frequency_hz is None:
        from pysim.diagnosis.residuals import dominant_frequency

        frequency_hz = float(dominant_frequency(data.voltage_V, data.sample_rate_hz))
    per_period = int(round(data.sample_rate_hz / frequency_hz))
    lo, hi = compensator.voltage_range_V
    y = compensator.simulate(np.array([lo, hi, lo]))
    middle, span = 0.5 * (y[1] + y[2]), abs(y[1] - y[2])
    k = np.arange(per_period * periods + 1 + MAX_PREVIEW)
    reference = middle + amplitude_fraction * span * np.sin(2 * math.pi * k / per_period)
    last = slice((periods - 1) * per_period, periods * per_period)
    plant_fmu = plant_fmu_for_model(plant)
    _, inverse = fmus_for_model(compensator)
    tracking, runs = {}, {}
    with RigSimulation(rig, plant_fmu, inverse, NominalDrive.from_model(compensator)) as sim:
        for path in PATHS:
            result = sim.run_path(reference, path)
            tracking[path] = error_measures(result.reference_um[last], result.displacement_stage_um[last])
            runs[path] = result
    return {"record": name, "cause": d.cause, "causes": tuple(getattr(d, "causes", (d.cause,))),
            "compensator": compensator, "plant": plant, "rig": rig, "frequency_hz": frequency_hz,
            "reference": {"middle_um": float(middle), "amplitude_um": float(amplitude_fraction * span)},
            "tracking": tracking, "runs": runs, "last_period": last}
