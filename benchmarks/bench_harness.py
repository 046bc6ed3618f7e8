"""Benchmark: co-simulation harness per-step cost, and the bandwidth sweep.

1. Cost per communication step (µs) of the plant FMU alone and of the
   inverse + plant chain, side by side in one run on the same FMUs:
   - a minimal raw ctypes loop (fmi2SetReal, fmi2GetReal, fmi2DoStep with
     prebuilt ctypes arguments, no status check, results into a list),
   - the harness (:class:`pysim.cosim.harness.CoSimulation`, no stage),
   - fmpy's ``FMU2Slave`` high-level calls (context),
   - ``fmpy.simulate_fmu`` with the input as a table and ``output_interval``
     equal to the step (plant only).
   Targets: harness ≤ 1.5 × the raw loop, ≥ 5 × faster than simulate_fmu.
2. The full default bandwidth sweep (both paths, default amplitudes and
   frequencies) against a straightforward sweep that calls ``simulate_fmu``
   per frequency (inverse, then plant, then the stage with python-control)
   on the same references.  Both must find the same −3 dB points.
   Target: ≥ 10 × faster.

    python benchmarks/bench_harness.py [--steps N] [--repeat K] [--skip-sweep] [--json]
"""
from __future__ import annotations

import argparse
import ctypes
import json
import math
import sys
import time

import numpy as np


def _raw_loop(unit, values, step):
    """The minimal raw loop the harness is measured against."""
    set_real, get_real, do_step = unit.set_real, unit.get_real, unit.do_step
    comp, vr_in, vr_out = unit.component, unit.input_vr, unit.output_vr
    u, y = (ctypes.c_double * 1)(), (ctypes.c_double * 1)()
    t, h, one, true = ctypes.c_double(), ctypes.c_double(step), ctypes.c_size_t(1), ctypes.c_int(1)
    out = [0.0] * len(values)
    for k, v in enumerate(values):
        u[0] = v
        t.value = k * step
        set_real(comp, vr_in, one, u)
        get_real(comp, vr_out, one, y)
        do_step(comp, t, h, true)
        out[k] = y[0]
    return out


def _raw_chain(inverse, plant, values, step):
    q, p = inverse, plant
    r, v, y = (ctypes.c_double * 1)(), (ctypes.c_double * 1)(), (ctypes.c_double * 1)()
    t, h, one, true = ctypes.c_double(), ctypes.c_double(step), ctypes.c_size_t(1), ctypes.c_int(1)
    volts, out = [0.0] * len(values), [0.0] * len(values)
    for k, x in enumerate(values):
        r[0] = x
        t.value = k * step
        q.set_real(q.component, q.input_vr, one, r)
        q.get_real(q.component, q.output_vr, one, v)
        q.do_step(q.component, t, h, true)
        p.set_real(p.component, p.input_vr, one, v)
        p.get_real(p.component, p.output_vr, one, y)
        p.do_step(p.component, t, h, true)
        volts[k] = v[0]
        out[k] = y[0]
    return volts, out


def _fmpy_slave_loop(slave, vr_in, vr_out, values, step):
    out = [0.0] * len(values)
    for k, v in enumerate(values):
        slave.setReal([vr_in], [v])
        out[k] = slave.getReal([vr_out])[0]
        slave.doStep(k * step, step)
    return out


def _best(fn, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def per_step_costs(plant_path, inverse_path, steps, repeat):
    """µs per step of each way of stepping, best of ``repeat``."""
    from fmpy import simulate_fmu
    from pysim.specs.default_mpi import MODEL

    from pysim.cosim.harness import CoSimulation

    step = 1e-4
    k = np.arange(steps)
    voltage = 75.0 + 60.0 * np.sin(2 * np.pi * k / 1000)
    reference = 37.5 + 30.0 * np.sin(2 * np.pi * k / 1000)
    values_v, values_r = voltage.tolist(), reference.tolist()
    us = {}
    with CoSimulation(plant_path, inverse_path, step_s=step) as sim:
        plant, inverse = sim.plant, sim.inverse

        def raw():
            plant.reset()
            return _raw_loop(plant, values_v, step)

        def harness():
            sim.reset()
            return sim.run(voltage_V=voltage)

        def raw_chain():
            plant.reset()
            inverse.reset()
            return _raw_chain(inverse, plant, values_r, step)

        def harness_chain():
            sim.reset()
            return sim.run(reference)

        def slave():
            plant.reset()
            return _fmpy_slave_loop(plant._slave, plant.input.valueReference, plant.output.valueReference,
                                    values_v[: steps // 10], step)

        # same numbers from every loop (and the model): the comparison is fair
        assert np.array_equal(np.array(raw()), harness().displacement_plant_um)
        assert np.max(np.abs(harness().displacement_plant_um - MODEL.simulate(voltage))) <= 1e-12
        assert np.array_equal(np.array(raw_chain()[1]), harness_chain().displacement_plant_um)
        # interleaved, so that drifts of the machine's speed hit all alike
        best = {name: math.inf for name in ("raw", "harness", "raw_chain", "harness_chain", "fmpy_slave")}
        for _ in range(repeat):
            for name, fn, n in (("raw", raw, steps), ("harness", harness, steps), ("raw_chain", raw_chain, steps),
                                ("harness_chain", harness_chain, steps), ("fmpy_slave", slave, steps // 10)):
                best[name] = min(best[name], _best(fn, 1) / n * 1e6)
        us.update(best)

    table = np.array(list(zip(k * step, voltage)), dtype=[("time", float), ("voltage", float)])

    def fmpy_simulate():
        return simulate_fmu(str(plant_path), start_time=0.0, stop_time=steps * step, step_size=step,
                            output_interval=step, input=table, output=["displacement"])

    result = fmpy_simulate()
    # fmpy records after each step: sample k + 1 holds the output for input k
    assert np.max(np.abs(result["displacement"][1:steps + 1] - MODEL.simulate(voltage))) <= 1e-12
    us["fmpy_simulate_fmu"] = _best(fmpy_simulate, max(1, repeat // 2)) / steps * 1e6
    return us


def straightforward_sweep(plant_path, inverse_path, stage, drive, amplitudes, offset, frequencies,
                          samples_per_period=64, settle_tol=1e-6, measure_periods=2):
    """The sweep as one would write it with simulate_fmu: one call per FMU and
    frequency, the stage by python-control on the plant's output."""
    import control
    from fmpy import simulate_fmu

    from pysim.cosim.bandwidth import crossing_frequency, fundamental, settling_periods
    from pysim.cosim.stage import discretise, slowest_time_constant_s

    tau = slowest_time_constant_s(stage)
    n = samples_per_period
    out = {}
    for amplitude in amplitudes:
        for path in ("uncompensated", "compensated"):
            gains = []
            for f in frequencies:
                h = 1.0 / (n * f)
                periods = settling_periods(f, tau, settle_tol) + measure_periods
                k = np.arange(periods * n)
                x_d = offset + amplitude * np.sin(2 * np.pi * (k % n) / n)
                t = k * h
                if path == "compensated":
                    table = np.array(list(zip(t, x_d)), dtype=[("time", float), ("displacement_ref", float)])
                    volts = simulate_fmu(str(inverse_path), stop_time=k.size * h, step_size=h,
                                         output_interval=h, input=table, output=["voltage"])["voltage"][1:]
                else:
                    volts = drive(x_d)
                table = np.array(list(zip(t, volts)), dtype=[("time", float), ("voltage", float)])
                actuator = simulate_fmu(str(plant_path), stop_time=k.size * h, step_size=h, output_interval=h,
                                        input=table, output=["displacement"])["displacement"][1:]
                discrete = control.ss(discretise(stage, h, "tustin", prewarp_hz=f))
                a, b = np.asarray(discrete.A), np.asarray(discrete.B).ravel()
                x0 = np.linalg.solve(np.eye(a.shape[0]) - a, b * actuator[0])
                _, y = control.forced_response(discrete, U=actuator, X0=x0)
                settle = (periods - measure_periods) * n
                gains.append(abs(fundamental(y[settle:], n)) / amplitude)
            gains = np.array(gains)
            out[(amplitude, path)] = crossing_frequency(frequencies, gains / gains[0])
    return out


def sweep_comparison(plant_path, inverse_path):
    from pysim.specs.default_mpi import MODEL
    from pysim.specs.flexure_stage import STAGE

    from pysim.cosim.bandwidth import default_frequencies, measure_bandwidth
    from pysim.cosim.harness import CoSimulation, NominalDrive

    amplitudes, offset, f = (7.5, 15.0, 30.0), 37.5, default_frequencies()
    drive = NominalDrive.from_model(MODEL)
    start = time.perf_counter()
    with CoSimulation(plant_path, inverse_path, stage=STAGE) as sim:
        results = measure_bandwidth(sim, drive, amplitudes, offset, f)
    ours = time.perf_counter() - start
    start = time.perf_counter()
    theirs_bw = straightforward_sweep(plant_path, inverse_path, STAGE, drive, amplitudes, offset, f)
    theirs = time.perf_counter() - start
    for r in results:
        assert math.isclose(r.bandwidth_hz(), theirs_bw[(r.amplitude_um, r.path)], rel_tol=1e-6), \
            (r.path, r.amplitude_um, r.bandwidth_hz(), theirs_bw[(r.amplitude_um, r.path)])
    return {"harness_sweep_s": ours, "simulate_fmu_sweep_s": theirs, "speed_up": theirs / ours,
            "frequencies": len(f), "amplitudes": list(amplitudes)}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=100_000, help="steps per timed run (default 100000)")
    parser.add_argument("--repeat", type=int, default=5, help="best of this many runs (default 5)")
    parser.add_argument("--skip-sweep", action="store_true", help="only the per-step costs")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)

    from pysim.specs.default_mpi import MODEL

    from pysim.cosim.harness import fmus_for_model

    plant, inverse = fmus_for_model(MODEL)
    us = per_step_costs(plant, inverse, args.steps, args.repeat)
    report = {"us_per_step": us,
              "harness_over_raw": us["harness"] / us["raw"],
              "chain_harness_over_raw": us["harness_chain"] / us["raw_chain"],
              "simulate_fmu_over_harness": us["fmpy_simulate_fmu"] / us["harness"]}
    if not args.skip_sweep:
        report["sweep"] = sweep_comparison(plant, inverse)
    checks = {"harness <= 1.5x raw loop": report["harness_over_raw"] <= 1.5,
              "chain harness <= 1.5x raw chain": report["chain_harness_over_raw"] <= 1.5,
              "harness >= 5x faster than simulate_fmu": report["simulate_fmu_over_harness"] >= 5.0}
    if "sweep" in report:
        checks["sweep >= 10x faster than simulate_fmu sweep"] = report["sweep"]["speed_up"] >= 10.0
    report["targets_met"] = checks
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(f"{'way of stepping':<28} {'µs/step':>8}")
        for name, value in us.items():
            print(f"{name:<28} {value:8.3f}")
        print(f"harness / raw loop:           {report['harness_over_raw']:.2f} (plant), "
              f"{report['chain_harness_over_raw']:.2f} (inverse + plant)")
        print(f"simulate_fmu / harness:       {report['simulate_fmu_over_harness']:.1f}")
        if "sweep" in report:
            s = report["sweep"]
            print(f"default sweep, both paths, {len(s['amplitudes'])} amplitudes x {s['frequencies']} "
                  f"frequencies: harness {s['harness_sweep_s']:.2f} s, simulate_fmu {s['simulate_fmu_sweep_s']:.1f} s "
                  f"({s['speed_up']:.0f}x)")
        for name, ok in checks.items():
            print(f"{'met ' if ok else 'MISSED'} {name}")
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
