"""Rig co-simulation cost: a closed-loop step against an open-loop step, and a
40-frequency sweep of every configuration.

Method
------
- Per-step cost: :class:`pysim.cosim.rig.RigSimulation` on the default rig
  (``rig_default``, plant FMU with creep stages, inverse FMU of the default
  model) runs the same 1 Hz reference of ``--steps`` samples in each path;
  the best of ``--repeat`` runs, in µs per step.  Target: the closed loop
  (``feedback+compensated``) costs at most 1.5x the open loop
  (``compensated``): the loop closes through values of the previous step, so
  it needs no iteration.
- Sweep: :func:`pysim.cosim.rig.rig_stepped_sine` over 40 log-spaced
  frequencies (10 Hz-2 kHz, rounded to whole steps per period) for the four
  paths at A = 7.5 µm, timed once (context, no target).

Run: ``python benchmarks/bench_rig.py [--quick] [--json]``.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np
from bench_common import Row, at_most


def measure(quick: bool = False) -> dict:
    from pysim.cosim.harness import NominalDrive, fmus_for_model, plant_fmu_for_model
    from pysim.cosim.rig import PATHS, RigSimulation, rig_stepped_sine, sweep_frequencies
    from pysim.specs.default_mpi import MODEL
    from pysim.specs.rig_default import RIG

    steps, repeat = (20_000, 2) if quick else (100_000, 5)
    _, inverse = fmus_for_model(MODEL)
    plant = plant_fmu_for_model(RIG.plant)
    k = np.arange(steps + 8)
    reference = 37.5 + 15.0 * np.sin(2 * math.pi * k * RIG.step_s)
    per_step = {}
    with RigSimulation(RIG, plant, inverse, NominalDrive.from_model(MODEL)) as sim:
        for path in PATHS:
            best = math.inf
            for _ in range(repeat):
                start = time.perf_counter()
                sim.run_path(reference, path)
                best = min(best, time.perf_counter() - start)
            per_step[path] = best / reference.size * 1e6
        f, _ = sweep_frequencies(RIG.step_s, 10.0, 2000.0, 40)
        sweep_s = {}
        for path in PATHS:
            start = time.perf_counter()
            rig_stepped_sine(sim, 7.5, 37.5, path, f)
            sweep_s[path] = time.perf_counter() - start
    return {"steps": steps, "repeat": repeat, "per_step_us": per_step, "sweep_frequencies": int(f.size),
            "sweep_s": sweep_s, "closed_over_open": per_step["feedback+compensated"] / per_step["compensated"]}


def rows(result: dict) -> list:
    ratio = result["closed_over_open"]
    us = result["per_step_us"]
    out = [Row("Rig", "closed-loop step / open-loop step", ratio, "x", *at_most(ratio, 1.5, "x"),
               note=f"feedback+compensated {us['feedback+compensated']:.2f} vs compensated "
                    f"{us['compensated']:.2f} µs/step")]
    for path, seconds in result["sweep_s"].items():
        out.append(Row("Rig", f"{result['sweep_frequencies']}-frequency sweep, {path}", seconds, "s",
                       note="A = 7.5 µm, rig_default"))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    result = measure(args.quick)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for row in rows(result):
            print(f"{row.name:55s} {row.value:10.3f} {row.unit:3s} {row.target:10s} {row.note}")
    return 0 if all(r.met is not False for r in rows(result)) else 1


if __name__ == "__main__":
    sys.exit(main())
