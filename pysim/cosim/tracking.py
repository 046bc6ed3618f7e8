"""Tracking errors for the paper's Table III references, with and without compensation.

Reference (Gu, Zhu, Su 2014, Table III): ``x_d(t) = A sin(2π t) + 37.5 µm``,
A = 7.5, 15, 22.5, 30 µm.  Errors are eq. 14 (e_rms) and eq. 15 (e_m) in %
of the reference's range, e_m taken on |x_d − x| (:func:`pysim.core.metrics.error_measures`),
on the stage's displacement over the last period: the first period holds
the start from the demagnetised state (and from rest).
"""
from __future__ import annotations

import math

import numpy as np

from pysim.core.metrics import error_measures
from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import CoSimResult, CoSimulation, NominalDrive

TABLE_III_AMPLITUDES_UM = (7.5, 15.0, 22.5, 30.0)
TABLE_III_OFFSET_UM = 37.5
TABLE_III_FREQUENCY_HZ = 1.0
# Paper, Table III (compensated, measured on the rig): e_m and e_rms in %.
PAPER_TABLE_III = {
    7.5: {"max_error_pct": 2.93, "rms_error_pct": 1.03},
    15.0: {"max_error_pct": 2.17, "rms_error_pct": 1.06},
    22.5: {"max_error_pct": 2.59, "rms_error_pct": 1.08},
    30.0: {"max_error_pct": 2.61, "rms_error_pct": 1.11},
}


def table_iii_reference(amplitude_um: float, step_s: float = 1e-4, periods: int = 2,
                        offset_um: float = TABLE_III_OFFSET_UM,
                        frequency_hz: float = TABLE_III_FREQUENCY_HZ):
    """Time (s) and reference ``offset + A sin(2π f t)`` (µm) over whole periods."""
    per_period = round(1.0 / (frequency_hz * step_s))
    if per_period < 8 or not math.isclose(per_period * step_s * frequency_hz, 1.0, rel_tol=1e-9):
        raise CoSimulationError(f"the step ({step_s} s) must divide the period ({1 / frequency_hz} s) "
                         "into at least 8 samples")
    k = np.arange(per_period * periods)
    return k * step_s, offset_um + amplitude_um * np.sin(2.0 * math.pi * (k % per_period) / per_period)


def track(sim: CoSimulation, drive: NominalDrive, amplitudes_um=TABLE_III_AMPLITUDES_UM,
          step_s: float = 1e-4, periods: int = 2, offset_um: float = TABLE_III_OFFSET_UM,
          frequency_hz: float = TABLE_III_FREQUENCY_HZ, progress=None):
    """Run the Table III references through both paths.

    Parameters
    ----------
    sim : CoSimulation
        Plant and inverse FMU, stage.  Reset before every run; the stage starts
        in equilibrium with the first displacement.
    drive : NominalDrive
        Voltage for the uncompensated path.
    periods : int
        Periods simulated (≥ 2); errors are taken over the last one.

    Returns
    -------
    rows : list of dict
        Per amplitude: ``amplitude_um``, ``uncompensated`` and ``compensated``
        (each the :func:`pysim.core.metrics.error_measures` dict) and ``paper``
        (Table III where the amplitude is one of the paper's, else None).
    runs : dict
        ``(amplitude, path) -> CoSimResult`` for plotting.
    """
    if periods < 2:
        raise CoSimulationError("need at least two periods: the first is the start-up")
    rows, runs = [], {}
    for amplitude in amplitudes_um:
        _, reference = table_iii_reference(amplitude, step_s, periods, offset_um, frequency_hz)
        last = slice(reference.size - reference.size // periods, None)
        errors, results = _both_paths(sim, drive, reference, last, step_s, progress)
        table_iii = offset_um == TABLE_III_OFFSET_UM and frequency_hz == TABLE_III_FREQUENCY_HZ
        rows.append({"amplitude_um": float(amplitude), **errors,
                     "paper": PAPER_TABLE_III.get(float(amplitude)) if table_iii else None})
        runs.update({(float(amplitude), path): result for path, result in results.items()})
    return rows, runs


def track_reference(sim: CoSimulation, drive: NominalDrive, reference_um, step_s: float,
                    first_scored: int = 0, progress=None):
    """Run a user's reference (µm, one sample per ``step_s``) through both paths.

    Errors (eq. 14-15, % of the reference's range over the scored samples) are
    taken on the stage's displacement from sample ``first_scored`` on (the
    start from the demagnetised state and from rest comes before it).

    Returns
    -------
    errors : dict
        ``uncompensated`` and ``compensated``, each an
        :func:`pysim.core.metrics.error_measures` dict.
    runs : dict
        ``path -> CoSimResult``.

    Examples
    --------
    >>> errors, runs = track_reference(sim, drive, 37.5 + 10 * np.sin(np.arange(20000) / 1000), 1e-4)  # doctest: +SKIP
    """
    reference = np.asarray(reference_um, dtype=float).ravel()
    if reference.size < 2 or not np.all(np.isfinite(reference)):
        raise CoSimulationError("the reference must hold at least 2 finite samples")
    if not 0 <= first_scored < reference.size - 1:
        raise CoSimulationError(f"first_scored must lie in 0..{reference.size - 2}, got {first_scored}")
    if not np.ptp(reference[first_scored:]) > 0:
        raise CoSimulationError("the reference is constant where the errors are taken: its range is 0, and the "
                                "errors are % of that range")
    return _both_paths(sim, drive, reference, slice(first_scored, None), step_s, progress)


def _both_paths(sim, drive, reference, scored, step_s, progress):
    """Errors over ``scored`` and results of the uncompensated and compensated
    paths for one reference; the stage starts in equilibrium with the first sample."""
    saved_start = sim.stage_start
    sim.stage_start = "steady"
    errors, results = {}, {}
    try:
        for path in ("uncompensated", "compensated"):
            sim.reset(step_s=step_s)
            result = (sim.run(reference) if path == "compensated"
                      else _with_reference(sim.run(voltage_V=drive(reference)), reference))
            errors[path] = error_measures(reference[scored], result.displacement_stage_um[scored])
            results[path] = result
            if progress is not None:
                progress.update()
    finally:
        sim.stage_start = saved_start
    return errors, results


def _with_reference(result: CoSimResult, reference) -> CoSimResult:
    result.reference_um = np.asarray(reference, dtype=float)
    return result


def reachable_range_um(sim) -> tuple:
    """``(low, high)`` displacement (µm) the plant reaches on its major loop:
    at the top of its voltage range after rising from the bottom, and at the
    bottom after falling from the top.  A reference outside it makes the
    inverse saturate at the voltage range.  Leaves the simulation reset."""
    lo, hi = sim.plant.range()
    if lo is None or hi is None:
        raise CoSimulationError(f"{sim.plant.path.name}: the voltage input declares no min/max")
    sim.reset()
    y = sim.run(voltage_V=[lo, hi, lo]).displacement_plant_um
    sim.reset()
    return float(y[2]), float(y[1])


def reference_warnings(sim, references_um) -> list:
    """One message per reference that leaves the reachable range."""
    low, high = reachable_range_um(sim)
    messages = []
    for name, reference in references_um.items():
        r = np.asarray(reference, dtype=float)
        if r.min() < low - 1e-9 or r.max() > high + 1e-9:
            messages.append(f"the reference {name} spans {r.min():.4g} to {r.max():.4g} µm but the actuator reaches "
                            f"only {low:.4g} to {high:.4g} µm: the inverse saturates at its voltage range and the "
                            "errors include that")
    return messages


def format_table(rows) -> str:
    """Plain-text table of e_m and e_rms (%) next to the paper's."""
    head = (f"{'A (µm)':>7}  {'e_m uncomp':>10}  {'e_m comp':>9}  {'e_m paper':>9}  "
            f"{'e_rms uncomp':>12}  {'e_rms comp':>10}  {'e_rms paper':>11}")
    lines = [head, "-" * len(head)]
    for row in rows:
        paper = row.get("paper") or {}
        lines.append(
            f"{row['amplitude_um']:7.1f}  {row['uncompensated']['max_error_pct']:9.3f}%  "
            f"{row['compensated']['max_error_pct']:8.4f}%  {_pct(paper.get('max_error_pct')):>9}  "
            f"{row['uncompensated']['rms_error_pct']:11.3f}%  {row['compensated']['rms_error_pct']:9.4f}%  "
            f"{_pct(paper.get('rms_error_pct')):>11}")
    return "\n".join(lines)


def _pct(x):
    return "-" if x is None else f"{x:.2f}%"
