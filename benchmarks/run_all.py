"""Run every benchmark and print one table: what was measured, the target,
and whether it is met.

    python benchmarks/run_all.py [--quick] [--json] [--only SECTION ...]
                                 [--cores N] [--threads N]

A missed target is printed as MISSED and listed at the end; the exit code is
0 unless a benchmark could not run at all (a missing tool, a failed check).
Sections: fmu_step, harness, sweep, identify, build, load, diagnose (the last
only when benchmarks/bench_diagnose.py exists).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
SECTIONS = ("fmu_step", "harness", "sweep", "rig", "identify", "build", "load", "diagnose")
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="smaller sizes and budgets (under 2 minutes); the full run takes several")
    parser.add_argument("--json", action="store_true", help="print everything measured as JSON")
    parser.add_argument("--only", nargs="+", choices=SECTIONS, metavar="SECTION",
                        help=f"run only these sections ({', '.join(SECTIONS)})")
    parser.add_argument("--cores", type=int, default=2, help="pin the run to this many CPUs (default 2)")
    parser.add_argument("--threads", type=int, default=1,
                        help="BLAS threads for numpy/scipy (default 1: comparisons on one core each)")
    return parser


# ---------------------------------------------------------------- sections
def _harness(quick: bool):
    import bench_harness
    from bench_common import Row, at_least, at_most
    from pysim.specs.default_mpi import MODEL

    from pysim.cosim.harness import fmus_for_model

    plant, inverse = fmus_for_model(MODEL)
    us = bench_harness.per_step_costs(plant, inverse, 20_000 if quick else 100_000, 3 if quick else 5)
    plant_ratio, chain_ratio = us["harness"] / us["raw"], us["harness_chain"] / us["raw_chain"]
    faster = us["fmpy_simulate_fmu"] / us["harness"]
    rows = [
        Row("Harness", "plant: harness / raw ctypes loop", plant_ratio, "x", *at_most(plant_ratio, 1.5, "x"),
            note=f"{us['harness']:.2f} vs {us['raw']:.2f} µs/step"),
        Row("Harness", "inverse+plant: harness / raw ctypes loop", chain_ratio, "x",
            *at_most(chain_ratio, 1.5, "x"), note=f"{us['harness_chain']:.2f} vs {us['raw_chain']:.2f} µs/step"),
        Row("Harness", "plant: simulate_fmu / harness", faster, "x", *at_least(faster, 5.0, "x"),
            note=f"simulate_fmu {us['fmpy_simulate_fmu']:.2f} µs/step, fmpy FMU2Slave loop "
                 f"{us['fmpy_slave']:.2f} µs/step"),
    ]
    return us, rows


def _sweep(quick: bool):
    import bench_harness
    from bench_common import Row, at_least
    from pysim.specs.default_mpi import MODEL

    from pysim.cosim.harness import fmus_for_model

    plant, inverse = fmus_for_model(MODEL)
    result = bench_harness.sweep_comparison(plant, inverse)
    note = (f"{len(result['amplitudes'])} amplitudes x {result['frequencies']} frequencies x 2 paths: "
            f"harness {result['harness_sweep_s']:.2f} s, simulate_fmu {result['simulate_fmu_sweep_s']:.1f} s")
    return result, [Row("Bandwidth sweep", "simulate_fmu sweep / harness sweep", result["speed_up"], "x",
                        *at_least(result["speed_up"], 10.0, "x"), note=note)]


def _rig(quick: bool):
    import bench_rig

    result = bench_rig.measure(quick)
    return result, bench_rig.rows(result)


def _fmu_step(quick: bool):
    import bench_fmu_step

    result = bench_fmu_step.measure(quick)
    return result, bench_fmu_step.rows(result)


def _identify(quick: bool):
    import bench_identify

    result = bench_identify.measure(quick)
    return bench_identify.json_ready(result), bench_identify.rows(result)


def _build(quick: bool):
    import bench_build

    result = bench_build.measure(quick)
    return result, bench_build.rows(result)


def _load(quick: bool):
    import bench_load_measured

    result = bench_load_measured.measure(200_000 if quick else 1_000_000)
    return result, bench_load_measured.rows_of(result)


def _diagnose(quick: bool):
    """benchmarks/bench_diagnose.py: through ``measure``/``rows`` if it has
    them, else run as a script (exit code 0 = its targets met)."""
    import subprocess

    from bench_common import Row

    path = HERE / "bench_diagnose.py"
    if not path.is_file():
        return None, []
    import bench_diagnose

    if hasattr(bench_diagnose, "measure") and hasattr(bench_diagnose, "rows"):
        try:
            result = bench_diagnose.measure(quick)
        except TypeError:
            result = bench_diagnose.measure()
        return result, bench_diagnose.rows(result)
    cmd = [sys.executable, str(path)] + (["--quick"] if quick and "--quick" in path.read_text() else [])
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=HERE.parent)
    elapsed = time.perf_counter() - start
    lines = [line for line in done.stdout.strip().splitlines() if line.strip()]
    return ({"exit_code": done.returncode, "stdout": done.stdout, "stderr": done.stderr[-4000:]},
            [Row("Diagnosis", "bench_diagnose.py", elapsed, "s", "exit code 0", done.returncode == 0,
                 lines[-1].strip() if lines else "")])


RUNNERS = {"fmu_step": _fmu_step, "harness": _harness, "sweep": _sweep, "rig": _rig, "identify": _identify,
           "build": _build, "load": _load, "diagnose": _diagnose}


# ------------------------------------------------------------------ output
def _value(value: float) -> str:
    if value != value:                                    # NaN
        return "nan"
    if abs(value) >= 1000:
        return f"{value:,.0f}"
    if abs(value) >= 10:
        return f"{value:.1f}"
    return f"{value:.3g}"


def format_table(rows) -> str:
    """The results as a fixed-width text table, misses marked ``MISSED``."""
    header = ("section", "measured", "value", "target", "met?", "note")
    body = [(r.section, r.name, f"{_value(r.value)} {r.unit}", r.target,
             "" if r.met is None else ("yes" if r.met else "MISSED"), r.note) for r in rows]
    widths = [max(len(line[i]) for line in [header] + body) for i in range(5)]
    out = []
    for line in [header] + body:
        out.append("  ".join(cell.ljust(w) for cell, w in zip(line[:5], widths)) + "  " + line[5])
        if line is header:
            out.append("  ".join("-" * w for w in widths) + "  " + "-" * 4)
    return "\n".join(line.rstrip() for line in out)


def run(sections, quick: bool, say=print) -> tuple:
    """Run the sections; returns (rows, details, failures)."""
    rows, details, failures = [], {}, {}
    for name in sections:
        start = time.perf_counter()
        say(f"running {name} ...")
        try:
            result, section_rows = RUNNERS[name](quick)
        except Exception as exc:       # report and go on with the other sections
            text = f"{type(exc).__name__}: {exc}"
            lines = text.strip().splitlines()
            failures[name] = lines[0][:300] + (" (more in --json)" if len(lines) > 1 else "")
            details[name] = {"error": text, "traceback": traceback.format_exc()}
            say(f"  {name} FAILED TO RUN: {failures[name]}")
            continue
        if result is None and not section_rows:
            say(f"  {name}: not present, skipped")
            continue
        details[name] = result
        rows += section_rows
        say(f"  {name} done in {time.perf_counter() - start:.1f} s")
    return rows, details, failures


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    for name in BLAS_THREAD_VARIABLES:         # effective only before numpy is first imported
        os.environ.setdefault(name, str(args.threads))
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    import json

    from bench_common import limit_cores, machine_info

    cpus = limit_cores(args.cores)
    sections = args.only or list(SECTIONS)
    say = (lambda message: print(message, file=sys.stderr)) if args.json else print
    machine = machine_info()
    say(f"{machine['cpu']}, {machine['cores_used']} of {machine['cores_online']} cores (CPUs {cpus}), "
        f"{machine['ram_gib']} GiB, {machine['os']}; Python {machine['python']}, numpy {machine['numpy']}; "
        f"BLAS threads {os.environ.get('OPENBLAS_NUM_THREADS')}; load average {machine['load_average']}"
        f"{'; QUICK mode' if args.quick else ''}")
    start = time.perf_counter()
    rows, details, failures = run(sections, args.quick, say)
    elapsed = time.perf_counter() - start
    load_end = [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else []
    missed = [r for r in rows if r.met is False]
    if args.json:
        print(json.dumps({"machine": machine, "quick": args.quick, "blas_threads": os.environ.get(
            "OPENBLAS_NUM_THREADS"), "elapsed_s": elapsed, "load_average_end": load_end,
            "rows": [r.as_dict() for r in rows], "missed": [r.name for r in missed],
            "failed_to_run": failures, "details": details}, indent=2, default=str))
    else:
        print()
        print(format_table(rows))
        print()
        met = sum(1 for r in rows if r.met)
        print(f"{met} of {met + len(missed)} targets met in {elapsed:.0f} s (load average at the end {load_end})")
        for r in missed:
            print(f"MISSED: {r.section}: {r.name}: {_value(r.value)} {r.unit}, target {r.target}")
        for name, why in failures.items():
            print(f"FAILED TO RUN: {name}: {why}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
