"""Benchmark: cost of one co-simulation step of the plant and inverse FMUs.

One cycle is ``fmi2SetReal(input)``, ``fmi2DoStep``, ``fmi2GetReal(output)``
on the linux64 binary of the FMU, driven by a small C program
(``c/step_driver.c``).  Two numbers per FMU:

- instructions per cycle, counted by valgrind's callgrind (deterministic):
  the instruction totals of K and of 2 K cycles are subtracted and divided by
  K, so loading, initialisation and tear-down cancel out.  Counted once over
  the whole program ("with the importer's loop") and once inside the three
  fmi2 calls only (``--toggle-collect``), which is the FMU's own cost;
- nanoseconds per cycle, timed natively over many cycles (best of 5).

The FMUs are built from the default model scaled to n = 10, 50, 200 operators
(eq. 13 thresholds, weights from the paper's density ``p(r) = 5 exp(-0.505
(r - 1)^2)``, see :func:`scaled_model`).  Target: <= 150 instructions per plant
cycle at n = 10.

    python benchmarks/bench_fmu_step.py [--quick] [--json]
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import numpy as np
from bench_common import Row, at_most

HERE = Path(__file__).resolve().parent
DRIVER_SOURCE = HERE / "c" / "step_driver.c"
LOADER_DIR = HERE.parent / "tests" / "c"     # fmi2_api.h, the loader the C test drivers share
OPERATOR_COUNTS = (10, 50, 200)
TARGET_PLANT_INSTRUCTIONS = 150
TABLE_SIZE = 1024          # period of the driver's input table (samples)
FMU_FUNCTIONS = ("fmi2SetReal", "fmi2DoStep", "fmi2GetReal")


class BenchmarkError(RuntimeError):
    """A tool the benchmark needs is missing or failed."""


def scaled_model(n_operators: int):
    """The default model (models/default_mpi.py) with ``n_operators`` operators.

    Same voltage span, scaling, a1 and a2; thresholds from eq. 13 and weights
    ``b_i = p(r_i) (r_i - r_{i-1})`` from the paper's density on the
    normalised threshold axis, so the total weight (and the loop's size) stays
    about the same as n grows.  n = 10 gives the default model itself.
    """
    from pysim.specs import default_mpi as d

    from pysim.core.model import HysteresisModel, eq13_thresholds

    r_n = eq13_thresholds(n_operators, 1.0)
    b_n = 5.0 * np.exp(-0.505 * (r_n - 1.0) ** 2) / n_operators
    v, y = d.VOLTAGE_SPAN_V, d.DISPLACEMENT_SCALE_UM
    return HysteresisModel(
        a1=d.A1_NORMALISED * y / v**3, a2=d.A2_NORMALISED * y / v,
        thresholds_V=tuple(r_n * v), weights_um_per_V=tuple(b_n * y / v), operator="osp",
        voltage_range_V=(0.0, v), name=f"bench_mpi_n{n_operators}",
        description=f"default model scaled to {n_operators} operators (benchmark)")


def input_range(model, kind: str) -> tuple:
    """The range the driver's input table spans: the voltage range (plant) or
    the displacements of the first loading curve over it (inverse)."""
    lo, hi = model.voltage_range_V
    if kind == "plant":
        return lo, hi
    y = model.simulate(np.array([lo, hi]))
    return float(y[0]), float(y[1])


def driver_table(lo: float, hi: float) -> np.ndarray:
    """The driver's input table (same formula as c/step_driver.c)."""
    phase = 2.0 * np.pi * np.arange(TABLE_SIZE) / TABLE_SIZE
    return lo + (hi - lo) * (0.5 - 0.3 * np.cos(phase) + 0.15 * np.sin(7.0 * phase))


def compile_driver(out_dir) -> Path:
    """Compile c/step_driver.c for this machine (needs a C compiler and dlopen;
    the FMU is loaded by tests/c/fmi2_api.h)."""
    from pysim.core.kernel import host_compiler
    from pysim.fmu.compile import fmi_include_dir

    target = Path(out_dir) / "step_driver"
    cmd = host_compiler() + ["-O2", "-std=c99", "-Wall", "-Wextra", "-I", str(LOADER_DIR), "-I",
                             str(fmi_include_dir()), str(DRIVER_SOURCE), "-o", str(target), "-ldl", "-lm"]
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        raise BenchmarkError(f"compiling {DRIVER_SOURCE.name} failed:\n{result.stderr.strip()}")
    return target


def extract_binary(fmu_path, out_dir) -> tuple:
    """``(library path, GUID)`` of the linux64 binary inside an FMU."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu_path))
    ident = md.coSimulation.modelIdentifier
    member = f"binaries/linux64/{ident}.so"
    target = Path(out_dir) / f"{ident}.so"
    with zipfile.ZipFile(fmu_path) as archive:
        target.write_bytes(archive.read(member))
    return target, md.guid


def debug_library(fmu_path, out_dir) -> Path:
    """The FMU's linux64 library rebuilt from the C sources inside the FMU with
    the builder's compiler and flags, but with symbols (``-g``, not stripped),
    so that a profile names the internal functions.  The instructions are the
    same as in the shipped binary; only the symbol table differs."""
    from fmpy import read_model_description

    from pysim.fmu.compile import FLAGS, PLATFORMS, fmi_include_dir, zig_cc

    ident = read_model_description(str(fmu_path)).coSimulation.modelIdentifier
    src = Path(out_dir) / f"{ident}_sources"
    with zipfile.ZipFile(fmu_path) as archive:
        for member in archive.namelist():
            if member.startswith("sources/") and not member.endswith("/"):
                (src / Path(member).name).parent.mkdir(parents=True, exist_ok=True)
                (src / Path(member).name).write_bytes(archive.read(member))
    target = Path(out_dir) / f"{ident}_debug.so"
    flags = [flag for flag in FLAGS if flag != "-s"] + ["-g"]
    cmd = zig_cc() + ["-target", PLATFORMS["linux64"].targets[0], *flags, "-I", str(src), "-I",
                      str(fmi_include_dir()), str(src / "all.c"), "-o", str(target)]
    result = subprocess.run(cmd, capture_output=True, text=True, cwd=out_dir)
    if result.returncode != 0:
        raise BenchmarkError(f"rebuilding {ident} with symbols failed:\n{result.stderr.strip()}")
    return target


def build_step_fmus(n_operators: int, out_dir) -> dict:
    """Plant and inverse FMUs (linux64 only) of :func:`scaled_model`."""
    from pysim.fmu import build_fmus

    return build_fmus(scaled_model(n_operators), Path(out_dir), platforms=("linux64",))


def _driver_args(driver, library, guid, mode, cycles, lo, hi) -> list:
    # cycles with a fixed number of digits: parsing it then costs the same for K and 2K
    return [str(driver), str(library), guid, mode, f"{int(cycles):015d}", repr(float(lo)), repr(float(hi))]


def run_driver(driver, library, guid, cycles, lo, hi) -> float:
    """Checksum (sum of all outputs) of ``cycles`` cycles, natively."""
    result = subprocess.run(_driver_args(driver, library, guid, "count", cycles, lo, hi),
                            capture_output=True, text=True)
    if result.returncode != 0:
        raise BenchmarkError(f"step_driver failed: {result.stderr.strip()}")
    bits = re.search(r"checksum ([0-9a-f]{16})", result.stdout).group(1)
    return struct.unpack(">d", bytes.fromhex(bits))[0]


def callgrind(driver, library, guid, cycles, lo, hi, out_file, fmu_only: bool) -> int:
    """Instructions executed (callgrind's ``Ir`` total) for ``cycles`` cycles;
    with ``fmu_only`` counted inside the three fmi2 calls only."""
    if shutil.which("valgrind") is None:
        raise BenchmarkError("valgrind is not installed (Debian package 'valgrind')")
    toggles = [f"--toggle-collect={name}" for name in FMU_FUNCTIONS] if fmu_only else []
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out_file}", *toggles,
           *_driver_args(driver, library, guid, "count", cycles, lo, hi)]
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        raise BenchmarkError(f"callgrind run failed:\n{result.stderr.strip()[-2000:]}")
    match = re.search(r"^totals:\s+(\d+)", Path(out_file).read_text(), re.MULTILINE)
    if not match:
        raise BenchmarkError(f"no instruction total in {out_file}")
    return int(match.group(1))


def function_costs(out_file) -> dict:
    """Instructions per function (self cost) from a callgrind output file."""
    result = subprocess.run(["callgrind_annotate", "--threshold=100", str(out_file)], capture_output=True,
                            text=True)
    costs = {}
    for line in result.stdout.splitlines():
        match = re.match(r"^\s*([\d,]+)\s+(?:\([^)]*\)\s+)?\S*?:(\S+)", line)
        if match and "PROGRAM TOTALS" not in line:
            costs[match.group(2)] = costs.get(match.group(2), 0) + int(match.group(1).replace(",", ""))
    return costs


def instructions_per_cycle(driver, library, guid, lo, hi, k: int, work_dir) -> dict:
    """Instructions per cycle by the K / 2K difference: ``with_loop`` (whole
    program) and ``fmu_only`` (inside the three fmi2 calls)."""
    out = {}
    for fmu_only in (False, True):
        totals = [callgrind(driver, library, guid, cycles, lo, hi,
                            Path(work_dir) / f"callgrind.{Path(library).stem}.{int(fmu_only)}.{cycles}", fmu_only)
                  for cycles in (k, 2 * k)]
        out["fmu_only" if fmu_only else "with_loop"] = (totals[1] - totals[0]) / k
    return out


def per_function(driver, library, guid, lo, hi, k: int, work_dir) -> dict:
    """Instructions per cycle spent in each function (self cost, K / 2K
    difference), most expensive first; use a library with symbols."""
    costs = []
    for cycles in (k, 2 * k):
        out_file = Path(work_dir) / f"callgrind.{Path(library).stem}.profile.{cycles}"
        callgrind(driver, library, guid, cycles, lo, hi, out_file, fmu_only=False)
        costs.append(function_costs(out_file))
    split = {name: (costs[1].get(name, 0) - costs[0].get(name, 0)) / k for name in costs[1]}
    return {name: cost for name, cost in sorted(split.items(), key=lambda x: -x[1]) if cost >= 0.5}


def ns_per_cycle(driver, library, guid, lo, hi, cycles: int) -> float:
    """Best of five timed runs of ``cycles`` cycles (after a warm-up), ns."""
    result = subprocess.run(_driver_args(driver, library, guid, "time", cycles, lo, hi), capture_output=True,
                            text=True)
    if result.returncode != 0:
        raise BenchmarkError(f"step_driver failed: {result.stderr.strip()}")
    return float(re.search(r"ns_per_cycle (\S+)", result.stdout).group(1))


def measure(quick: bool = False, operator_counts=OPERATOR_COUNTS, work_dir=None) -> dict:
    """Instructions and ns per cycle of both FMUs for each operator count.

    Returns ``{"plant": {n: {...}}, "inverse": {n: {...}}, "k": K}``; each
    entry has ``with_loop`` and ``fmu_only`` (instructions per cycle),
    ``ns`` and, for the smallest n, ``per_function`` (instructions per cycle
    in each function, from a rebuild with symbols).
    """
    k = TABLE_SIZE * (1 if quick else 4)        # whole periods of the input table
    budget = 2e7 if quick else 2e8              # instructions per timed run
    results = {"plant": {}, "inverse": {}, "k_cycles": k}
    with tempfile.TemporaryDirectory(prefix="bench-step-") as tmp:
        tmp = Path(tmp) if work_dir is None else Path(work_dir)
        driver = compile_driver(tmp)
        for n in operator_counts:
            model = scaled_model(n)
            fmus = build_step_fmus(n, tmp / f"n{n}")
            for kind in ("plant", "inverse"):
                library, guid = extract_binary(fmus[kind], tmp)
                lo, hi = input_range(model, kind)
                entry = instructions_per_cycle(driver, library, guid, lo, hi, k, tmp)
                if n == min(operator_counts):   # where the target is: name what costs what
                    entry["per_function"] = per_function(driver, debug_library(fmus[kind], tmp), guid, lo, hi,
                                                         k, tmp)
                cycles = int(min(5e6, max(2e4, budget / entry["with_loop"])))
                entry["ns"] = ns_per_cycle(driver, library, guid, lo, hi, cycles)
                entry["timed_cycles"] = cycles
                results[kind][n] = entry
    return results


def rows(result: dict) -> list:
    out = []
    for kind in ("plant", "inverse"):
        for n, entry in result[kind].items():
            target, met = ("", None)
            if kind == "plant" and n == 10:
                target, met = at_most(entry["fmu_only"], TARGET_PLANT_INSTRUCTIONS)
            out.append(Row("FMU step", f"{kind} n={n}: instructions/cycle in the FMU", entry["fmu_only"],
                           "instr", target, met,
                           f"{entry['with_loop']:.0f} with the importer's loop"))
            out.append(Row("FMU step", f"{kind} n={n}: time/cycle", entry["ns"], "ns"))
    plant = result["plant"]
    if len(plant) >= 2:
        counts = sorted(plant)
        slope = (plant[counts[-1]]["fmu_only"] - plant[counts[0]]["fmu_only"]) / (counts[-1] - counts[0])
        out.append(Row("FMU step", "plant: instructions per extra operator", slope, "instr",
                       note=f"n={counts[0]}..{counts[-1]}"))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="K = 1024 cycles, shorter timing runs")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    result = measure(args.quick)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    for kind in ("plant", "inverse"):
        for n, e in result[kind].items():
            split = ", ".join(f"{name} {cost:.0f}" for name, cost in e.get("per_function", {}).items())
            print(f"{kind:8s} n={n:4d}: {e['fmu_only']:8.1f} instr in the FMU, {e['with_loop']:8.1f} with the "
                  f"loop, {e['ns']:8.1f} ns  [{split}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
