"""Pieces every benchmark shares: a row of the results table, timing, and a
description of the machine the numbers were measured on."""
from __future__ import annotations

import argparse
import json
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
    (default ``default_records``), ``--first-seed S`` and ``--first-record-only`` (the diagnosis
    is given the first record alone, as a user without a second record runs it; the second record
    is then only predicted); add options to the parser returned."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--records", type=int, default=default_records, help="number of seeds")
    parser.add_argument("--first-seed", type=int, default=0, help="first seed")
    parser.add_argument("--first-record-only", action="store_true",
                        help="diagnose the first record without the second (no validate=)")
    parser.add_argument("--history-floor", action="store_true",
                        help="give the diagnosis history_floor_V = min(0 V, the records' lowest voltage), as a "
                             "user whose amplifier's lowest output is 0 V or the lowest a record reaches would")
    return parser


#: Set by a benchmark's ``--history-floor`` (:func:`diagnose_options`).
WITH_HISTORY_FLOOR = {"on": False}


def diagnose_options(*voltages_V) -> dict:
    """Keyword arguments of ``diagnose`` for records with these voltages: ``history_floor_V``
    (min(0 V, their lowest voltage)) with ``--history-floor``, else none."""
    if not WITH_HISTORY_FLOOR["on"]:
        return {}
    return {"history_floor_V": min(0.0, *(float(np.min(v)) for v in voltages_V))}


def over_seeds(evaluate, first_seed: int, count: int, describe) -> list:
    """``evaluate(seed)`` for ``count`` seeds from ``first_seed``, in order; as each one ends,
    ``[i/count] seed S: describe(row)`` goes to stderr (the runs take minutes)."""
    rows = []
    for seed in range(first_seed, first_seed + count):
        row = evaluate(seed)
        rows.append(row)
        print(f"[{len(rows)}/{count}] seed {seed}: {describe(row)}", file=sys.stderr, flush=True)
    return rows


def run_seed_benchmark(doc: str, default_records: int, evaluate, describe, report, argv=None) -> int:
    """The main of a benchmark that runs one record set per seed: parse :func:`seed_arguments` (plus
    ``--json FILE``) from ``argv``, run ``evaluate(seed, second_record)`` over the seeds
    (:func:`over_seeds`, ``describe(row)`` as each ends), then ``report(rows)``, the time taken, and the
    rows as JSON if asked; returns the exit code (0)."""
    parser = seed_arguments(doc.split("\n\n")[0], default_records)
    parser.add_argument("--json", metavar="FILE", help="also save the per-seed results as JSON")
    args = parser.parse_args(argv)
    WITH_HISTORY_FLOOR["on"] = args.history_floor
    start = time.perf_counter()
    rows = over_seeds(lambda seed: evaluate(seed, not args.first_record_only), args.first_seed, args.records,
                      describe)
    report(rows)
    print(f"{time.perf_counter() - start:.0f} s in all")
    if args.json:
        write_rows_json(args.json, rows)
    return 0


def print_outcome_summary(rows, effects) -> None:
    """Print the outcome count of every effect in ``effects`` and one line of totals: right, false
    alarms, refusals, and on how many effect records the model delivered predicts the third record
    better (ratio below 0.999) or worse (above 1.001) than the plain fit.  ``rows`` hold ``effect``,
    ``outcome`` and, unless refused, ``third_extended_over_baseline``."""
    from collections import Counter

    counts = Counter((r["effect"], r["outcome"]) for r in rows)
    print("\noutcome by effect:")
    for effect in effects:
        line = ", ".join(f"{outcome} {n}" for (e, outcome), n in sorted(counts.items()) if e == effect)
        print(f"  {effect:6}: {line}")
    with_effect = [r for r in rows if r["effect"] != "none" and "third_extended_over_baseline" in r]
    print(f"right {sum(r['outcome'] == 'right' for r in rows)}/{len(rows)}; false alarms "
          f"{sum(r['outcome'] == 'false alarm' for r in rows)}/{sum(r['effect'] == 'none' for r in rows)}; refusals "
          f"{sum(r['outcome'] == 'refused' for r in rows)}; third record, effect records: extended better on "
          f"{sum(r['third_extended_over_baseline'] < 0.999 for r in with_effect)}, worse on "
          f"{sum(r['third_extended_over_baseline'] > 1.001 for r in with_effect)} of {len(with_effect)}")


def print_misses(rows, describe) -> None:
    """Print ``describe(row)`` for every seed not named right or whose model delivered predicts the
    third record worse than the plain fit (ratio above 1.001)."""
    for r in rows:
        ratio = r.get("third_extended_over_baseline")
        if r["outcome"] != "right" or (ratio is not None and ratio > 1.001):
            print(describe(r))


def diagnose_and_score(row: dict, first, second, truth: str, third_rms_pct):
    """Diagnose the record ``first`` = (voltage V, displacement µm, sample rate Hz) validated on
    ``second`` (None: the first record alone) and add to ``row``: ``seconds``, ``named``, ``outcome`` (:func:`named_and_outcome`)
    and the third record's ``third_baseline_rms_pct`` and ``third_extended_over_baseline``
    (``third_rms_pct(model)``: that model's error there, %); a refusal is an outcome (``refused``,
    with its ``message``).  Returns the diagnosis (None when refused)."""
    from pysim.core.errors import PiezoMPIError
    from pysim.diagnosis import diagnose

    start = time.perf_counter()
    try:
        d = diagnose(*first, validate=None if second is None else tuple(second),
                     **diagnose_options(first[0], *([] if second is None else [second[0]])))
    except PiezoMPIError as exc:
        row.update(outcome="refused", named="refused", message=str(exc), seconds=time.perf_counter() - start)
        return None
    row["seconds"] = time.perf_counter() - start
    row["named"], row["outcome"] = named_and_outcome(d, truth)
    base, ext = third_rms_pct(d.baseline.model), third_rms_pct(d.extended.model)
    row.update(third_baseline_rms_pct=base, third_extended_over_baseline=ext / base if base > 0 else float("nan"))
    return d


def write_rows_json(path, rows) -> None:
    """Save a benchmark's per-seed rows as JSON (``--json FILE``)."""
    with open(path, "w", encoding="utf-8") as out:
        json.dump(rows, out, indent=1, default=float)
        out.write("\n")


def named_and_outcome(diagnosis, truth: str) -> tuple:
    """``(named, outcome)`` of a diagnosis of a record whose hidden effect has the catalogue name
    ``truth`` (``"none"`` without one): ``named`` is the set joined by ``|``; ``outcome`` is
    ``right`` (the truth alone or in the named set, ``none`` for none), ``false alarm``, ``missed``,
    ``unexplained`` or ``wrong``."""
    named = tuple(diagnosis.causes) if len(diagnosis.causes) > 1 else (diagnosis.cause,)
    if truth == "none":
        outcome = "right" if diagnosis.cause == "none" else "false alarm"
    elif truth in named:
        outcome = "right"
    else:
        outcome = {"none": "missed", "unexplained": "unexplained"}.get(diagnosis.cause, "wrong")
    return "|".join(named), outcome


def settled_rms_pct(model, voltage_V, clean_um, settle_samples: int) -> float:
    """RMS error (% of the record's range) of ``model.simulate(voltage_V)`` against the noise-free
    ``clean_um`` after its first ``settle_samples`` samples."""
    predicted = np.asarray(model.simulate(voltage_V), dtype=float)
    part = slice(int(settle_samples), None)
    return float(np.sqrt(np.mean((predicted[part] - clean_um[part]) ** 2)) / np.ptp(clean_um) * 100)


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
