"""Benchmark: the diagnosis on the records of a third, independent generator.

The records come from ``tests/third_generator_records.py``, written from the
issue's description without reading the other two generators: MPI plants
with 10-20 operators on the eq. 13 grid or off it, 0-150 V or 0-100 V, 2 or
5 kHz, white noise 0.2 % of the range, and one hidden effect per seed
(none / rate_dependence / creep / delay / drift, cycling with the seed) whose
RMS on the first record is 1-20 noise σ where the effect's bounds reach it.
Three records of one actuator per seed with three different inputs
(decaying triangles, a multisine, holds then sines), the first two from rest
or after an unknown history, the third from rest.  The diagnosis sees the
first record and validates on the second; the third is predicted by the
baseline and the extended model.

Outcomes per seed: ``right`` (``none`` named on a record without an effect;
the truth named, alone or in a set ``d.causes`` that holds it), ``false
alarm`` (anything else named on a record without an effect), ``missed``
(``none`` named for an effect), ``wrong`` (another name), ``refused`` (a
``PiezoMPIError``), ``CRASH`` (any other exception).  The third record: RMS
error of each model against the noise-free record after 0.1 s (in noise σ),
and their ratio extended / baseline: ``better`` below 1 - 1e-3, ``worse``
above 1 + 1e-3, else ``same``.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_diagnosis_third_generator.py \\
        [--records N] [--first-seed S] [--json FILE] [--first-record-only]

``--first-record-only`` gives the diagnosis the first record alone (no ``validate=``), as a
user without a second record runs it.

Making the records takes about 20 ms per seed; the diagnosis takes 4-55 s
per seed on one core with one BLAS thread (median about 17 s: about 20 min
for seeds 0-59).  Progress goes to stderr.
"""
from __future__ import annotations

import sys
import time
import traceback
from pathlib import Path

import numpy as np

from bench_common import diagnose_options, run_seed_benchmark

TESTS = Path(__file__).resolve().parents[1] / "tests"
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

import third_generator_records as records  # noqa: E402

SETTLE_S = 0.1
#: Relative band of the extended-over-baseline RMS ratio counted as "same".
SAME_MARGIN = 1e-3
OUTCOMES = ("right", "false alarm", "missed", "wrong", "refused", "CRASH")
#: Columns of the confusion matrix besides the truths, and their short names.
OTHER_NAMES = ("rate_dependent_hysteresis", "slew_limit", "unexplained")
SHORT = {"rate_dependence": "rate_dep", "rate_dependent_hysteresis": "rdh", "slew_limit": "slew",
         "unexplained": "unexpl"}


def _rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def _outcome(truth: str, cause: str, causes: tuple) -> str:
    if truth == "none":
        return "right" if cause == "none" else "false alarm"
    if cause == truth or truth in causes:
        return "right"
    return "missed" if cause == "none" else "wrong"


def _third_record(d, record, sample_rate_hz) -> dict:
    """Errors of the baseline and the extended model on the third record after ``SETTLE_S``."""
    settled = slice(int(round(SETTLE_S * sample_rate_hz)), None)
    base = np.asarray(d.baseline.model.simulate(record.voltage_V), dtype=float)[settled]
    ext = np.asarray(d.extended.model.simulate(record.voltage_V), dtype=float)[settled]
    clean, hysteresis = record.clean_um[settled], record.hysteresis_only_um[settled]
    base_error, ext_error = _rms(base - clean), _rms(ext - clean)
    return {"ratio": ext_error / base_error if base_error > 0 else float("nan"),
            # against the hysteresis alone (differs from the clean record only where there is an effect)
            "ratio_hysteresis_only": _rms(ext - hysteresis) / max(_rms(base - hysteresis), 1e-15),
            "baseline_error_sigma": base_error / record.noise_um,
            "extended_error_sigma": ext_error / record.noise_um}


def evaluate(seed: int, second_record: bool = True) -> dict:
    """Diagnose the first record of ``seed`` (validated on the second unless ``second_record`` is
    false) and score it."""
    from pysim.core.errors import PiezoMPIError
    from pysim.diagnosis import diagnose

    pair = records.make_third_records(seed)
    fs = pair.sample_rate_hz
    first, second, third = pair.records
    plant = pair.plant
    row = {"seed": seed, "truth": pair.truth, "effect": records.describe_effect(pair.effect_parameters),
           "effect_to_noise": [round(r.effect_to_noise, 3) for r in pair.records],
           "inputs": [r.input_kind + ("" if r.from_rest else " (history)") for r in pair.records],
           "sample_rate_hz": fs,
           "plant": f"{plant.variant} n={plant.n_operators} {plant.max_voltage_V:.0f} V "
                    f"{plant.stroke_um:.0f} µm"}
    t0 = time.perf_counter()
    try:
        d = diagnose(first.voltage_V, first.displacement_um, fs,
                     validate=(second.voltage_V, second.displacement_um, fs) if second_record else None,
                     **diagnose_options(first.voltage_V, *([second.voltage_V] if second_record else [])))
    except PiezoMPIError as exc:
        row.update(outcome="refused", cause=None, causes=[], why=f"{type(exc).__name__}: {exc}",
                   seconds=time.perf_counter() - t0)
        return row
    except Exception as exc:     # a crash, not a refusal
        row.update(outcome="CRASH", cause=None, causes=[],
                   why=f"{type(exc).__name__}: {exc}\n{traceback.format_exc()[-1500:]}",
                   seconds=time.perf_counter() - t0)
        return row
    row["seconds"] = time.perf_counter() - t0
    causes = tuple(d.causes)
    row.update(outcome=_outcome(pair.truth, d.cause, causes), cause=d.cause, causes=list(causes),
               why=str(d.why), swapped=d.records_swapped)
    try:
        row.update(_third_record(d, third, fs))
    except Exception as exc:
        row["simulation_error"] = f"{type(exc).__name__}: {exc}"
    return row


def _verdict(ratio) -> str:
    if ratio is None or not np.isfinite(ratio):
        return "-"
    return "better" if ratio < 1 - SAME_MARGIN else "worse" if ratio > 1 + SAME_MARGIN else "same"


def _needs_why(row) -> bool:
    return row["outcome"] != "right" or _verdict(row.get("ratio")) == "worse"


def print_table(rows) -> None:
    print(f"{'seed':>4} {'truth':16} {'effect':36} {'size σ (1st/2nd/3rd)':20} {'inputs (1st/2nd/3rd)':58} "
          f"{'plant':27} {'fs':>5} {'named':50} {'outcome':11} {'3rd e/b':>7} {'base σ':>6} {'ext σ':>6} "
          f"{'swap':4} {'s':>4}")
    for r in rows:
        sizes = "/".join(f"{x:.1f}" for x in r["effect_to_noise"])
        named = "|".join(r["causes"]) if len(r["causes"]) > 1 else str(r["cause"])
        ratio = f"{r['ratio']:7.3f}" if r.get("ratio") is not None else f"{'-':>7}"
        base = f"{r['baseline_error_sigma']:6.2f}" if "baseline_error_sigma" in r else f"{'-':>6}"
        ext = f"{r['extended_error_sigma']:6.2f}" if "extended_error_sigma" in r else f"{'-':>6}"
        print(f"{r['seed']:4d} {r['truth']:16} {r['effect']:36} {sizes:20} {'/'.join(r['inputs']):58} "
              f"{r['plant']:27} {r['sample_rate_hz']:5.0f} {named:50} {r['outcome']:11} {ratio} {base} {ext} "
              f"{'yes' if r.get('swapped') else '':4} {r['seconds']:4.0f}")
    for r in rows:
        if _needs_why(r):
            print(f"  seed {r['seed']} ({r['truth']}, {r['outcome']}, 3rd {_verdict(r.get('ratio'))}): "
                  f"{r['why'][:400]!r}")


def summary(rows) -> str:
    """Outcome counts, the confusion matrix and the third record's ratios."""
    count = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
    lines = [f"right {count['right']}/{len(rows)}, false alarms {count['false alarm']} (of "
             f"{sum(r['truth'] == 'none' for r in rows)} seeds without an effect), missed {count['missed']}, "
             f"wrong {count['wrong']}, refused {count['refused']}, crashes {count['CRASH']}"]
    columns = list(records.EFFECTS) + list(OTHER_NAMES) + ["REFUSED"]
    for r in rows:
        if r["cause"] is not None and r["cause"] not in columns:
            columns.insert(-1, r["cause"])
    lines.append("confusion (rows: truth, columns: the cause named, d.cause; REFUSED: refused or crashed; "
                 "named sets are listed below)")
    lines.append(f"{'':>16}" + "".join(f"{SHORT.get(c, c):>9}" for c in columns))
    for truth in records.EFFECTS:
        named = [r["cause"] if r["cause"] is not None else "REFUSED" for r in rows if r["truth"] == truth]
        cells = [named.count(c) for c in columns]
        lines.append(f"{truth:>16}" + "".join(f"{k:>9d}" if k else f"{'.':>9}" for k in cells))
    sets = [r for r in rows if len(r["causes"]) > 1]
    if sets:
        lines.append("named sets: " + "; ".join(f"seed {r['seed']} {'|'.join(r['causes'])}" for r in sets))
    effects = [r for r in rows if r["truth"] != "none" and r.get("ratio") is not None]
    verdicts = [_verdict(r["ratio"]) for r in effects]
    lines.append(f"third record, extended over baseline RMS on effect seeds: "
                 f"better {verdicts.count('better')}, same {verdicts.count('same')}, "
                 f"worse {verdicts.count('worse')} (of {len(effects)})")
    medians = [f"{t} {np.median([r['ratio'] for r in effects if r['truth'] == t]):.3f}"
               for t in records.EFFECTS[1:] if any(r["truth"] == t for r in effects)]
    if medians:
        lines.append("  median ratio by truth: " + ", ".join(medians))
    nones = [r for r in rows if r["truth"] == "none" and r.get("ratio") is not None]
    if nones:
        lines.append("  seeds without an effect: "
                     + ", ".join(f"{r['seed']}: {r['ratio']:.3f}" for r in nones))
    return "\n".join(lines)


def _report(rows) -> None:
    print_table(rows)
    print()
    print(summary(rows))


def main(argv=None) -> int:
    return run_seed_benchmark(__doc__, 60, evaluate,
                              lambda row: f"{row['truth']} -> {row['cause']} ({row['outcome']}), {row['seconds']:.1f} s",
                              _report, argv)


if __name__ == "__main__":
    sys.exit(main())
