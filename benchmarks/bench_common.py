"""Pieces every benchmark shares: a row of the results table, timing, and a
description of the machine the numbers were measured on."""
from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import time
from dataclasses import asdict, dataclass

import numpy as np


@dataclass
class Row:
    """One line of the results table.

    Attributes
    ----------
    section : str
        Which benchmark (e.g. ``"FMU step"``).
    name : str
        What was measured.
    value : float
        The measured number, in ``unit``.
    unit : str
        Unit of ``value`` (``"instr"``, ``"ns"``, ``"s"``, ``"x"`` for a ratio ...).
    target : str
        The target as text (``"<= 150"``), empty for numbers given as context.
    met : bool or None
        Whether the target is met; None for context.
    note : str
        Anything the reader needs to interpret the number.
    """

    section: str
    name: str
    value: float
    unit: str
    target: str = ""
    met: bool | None = None
    note: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


def seed_arguments(description: str, default_records: int) -> argparse.ArgumentParser:
    """The command line of a benchmark that runs one record set per seed: ``--records N``
    (default ``default_records``) and ``--first-seed S``; add options to the parser returned."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--records", type=int, default=default_records, help="number of seeds")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed")
    return parser


def over_seeds(evaluate, first_seed: int, count: int, describe) -> list:
    """``evaluate(seed)`` for ``count`` seeds from ``first_seed``, in order; as each one ends,
    ``[i/count] seed S: describe(row)`` goes to stderr (the runs take minutes)."""
    rows = []
    for seed in range(first_seed, first_seed + count):
        row = evaluate(seed)
        rows.append(row)
        print(f"[{len(rows)}/{count}] seed {seed}: {describe(row)}", file=sys.stderr, flush=True)
    return rows


def at_most(value: float, limit: float, unit: str = "") -> tuple:
    """``(target text, met)`` for a "no more than" target."""
    return f"<= {limit:g}{(' ' + unit) if unit else ''}", bool(value <= limit)


def at_least(value: float, limit: float, unit: str = "") -> tuple:
    """``(target text, met)`` for a "no less than" target."""
    return f">= {limit:g}{(' ' + unit) if unit else ''}", bool(value >= limit)


def timings(fn, repeat: int) -> np.ndarray:
    """Wall-clock times (s) of ``repeat`` calls of ``fn``."""
    out = []
    for _ in range(max(1, repeat)):
        start = time.perf_counter()
        fn()
        out.append(time.perf_counter() - start)
    return np.array(out)


def spread(times) -> dict:
    """Best, median and worst of a set of timings (s), for the variance note."""
    times = np.asarray(times, dtype=float)
    return {"best_s": float(times.min()), "median_s": float(np.median(times)), "worst_s": float(times.max()),
            "runs": int(times.size)}


def limit_cores(n_cores: int) -> list:
    """Pin this process (and what it starts) to the first ``n_cores`` CPUs it
    may use (Linux only); returns the CPUs used."""
    if not hasattr(os, "sched_setaffinity"):
        return []
    allowed = sorted(os.sched_getaffinity(0))
    chosen = allowed[:max(1, n_cores)]
    os.sched_setaffinity(0, chosen)
    return chosen


def _first_line(cmd) -> str:
    try:
        result = subprocess.run(cmd, capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return "not available"
    text = (result.stdout or result.stderr).strip()
    return text.splitlines()[0] if text else "not available"


def _cpu_model() -> str:
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True, timeout=30).stdout.splitlines():
            if line.startswith("Model name:"):
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return platform.processor() or "unknown"


def _ram_gib() -> float:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    except (ValueError, OSError, AttributeError):
        return float("nan")


def _os_name() -> str:
    try:
        with open("/etc/os-release") as handle:
            for line in handle:
                if line.startswith("PRETTY_NAME="):
                    return line.split("=", 1)[1].strip().strip('"') + f" (kernel {platform.release()})"
    except OSError:
        pass
    return platform.platform()


def machine_info() -> dict:
    """CPU, cores, RAM, OS and the versions of everything that sets the speed."""
    import fmpy
    import scipy

    try:
        import pyswarms
        pyswarms_version = pyswarms.__version__
    except ImportError:
        pyswarms_version = "not installed"
    cc = os.environ.get("CC") or shutil.which("cc") or "cc"
    return {
        "cpu": _cpu_model(),
        "cores_online": os.cpu_count(),
        "cores_used": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
        "ram_gib": round(_ram_gib(), 1),
        "os": _os_name(),
        "python": sys.version.split()[0],
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "fmpy": fmpy.__version__,
        "pyswarms": pyswarms_version,
        "c_compiler": _first_line([cc, "--version"]),
        "zig": _first_line([sys.executable, "-m", "ziglang", "version"]),
        "valgrind": _first_line(["valgrind", "--version"]),
        "load_average": [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else [],
    }
