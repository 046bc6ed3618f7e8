"""Benchmark: the diagnosis on the records of a fifth generator, written by other hands without reading the package.

The records come from ``tests/fifth_generator_records.py``: MPI plants with
8-40 operators off any grid, 0-100 V, 0-150 V or -20-120 V, 1-10 kHz, white
noise of 0.05-0.5 % of the range (quantised for about one actuator in three),
seven input kinds (chirps, triangles, multisines, steps with holds,
band-limited noise, a sine on an offset, staircases; many of them cover part
of the range only), records from rest or after an unrecorded history, and one
hidden effect per actuator (``seed % 7``: none or one of the catalogue's six)
of 3-30 noise σ on the first record.  The diagnosis sees the first record
and, unless ``--first-record-only``, validates on the second; the third, which
it never sees, is predicted from rest by the plain fit and by the model
delivered (RMS against the noise-free record after its first 10 % of samples,
as the generator's authors scored it).

Outcomes (``bench_common.named_and_outcome``): right (the truth named, alone
or in the set), false alarm, missed, unexplained, wrong, refused.

    OPENBLAS_NUM_THREADS=1 python benchmarks/bench_diagnosis_fifth_generator.py \\
        [--records N] [--first-seed S] [--first-record-only] [--json FILE]

A diagnosis takes 3-70 s on one core.
"""
from __future__ import annotations

import sys
from pathlib import Path

from bench_common import (diagnose_and_score, print_misses, print_outcome_summary, run_seed_benchmark,
                          settled_rms_pct)

TESTS = Path(__file__).resolve().parents[1] / "tests"
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

import fifth_generator_records as records  # noqa: E402

SETTLE_SHARE = 0.1


def _third_rms_pct(record):
    """``rms(model)``: the model's RMS error (% of range) on the third record, run from rest."""
    settle = int(SETTLE_SHARE * record["clean_um"].size)
    return lambda model: settled_rms_pct(model, record["voltage_V"], record["clean_um"], settle)


def evaluate(seed: int, second_record: bool = True) -> dict:
    """Diagnose seed ``seed``'s first record (validated on the second unless ``second_record`` is
    false) and score the third."""
    actuator = records.make_actuator(seed)
    fs, recs = actuator["sample_rate_hz"], actuator["records"]
    row = {"seed": seed, "effect": actuator["truth"], "size_sigma": round(actuator["size_sigma"], 2),
           "inputs": [f"{recs[n]['input']['kind']}/{recs[n]['start']}" for n in "ABC"],
           "ranges_V": [[round(float(recs[n]["voltage_V"].min()), 1), round(float(recs[n]["voltage_V"].max()), 1)]
                        for n in "ABC"],
           "sample_rate_hz": fs, "parameters": actuator["effect_parameters"]}
    first = (recs["A"]["voltage_V"], recs["A"]["displacement_um"], fs)
    second = (recs["B"]["voltage_V"], recs["B"]["displacement_um"], fs) if second_record else None
    d = diagnose_and_score(row, first, second, actuator["truth"], _third_rms_pct(recs["C"]))
    if d is not None:
        row["why"] = str(d.why)
    return row


def print_rows(rows) -> None:
    print(f"{'seed':>4} {'truth':26} {'size σ':>6} {'inputs (1st/2nd/3rd)':64} {'named':52} {'outcome':12} "
          f"{'3rd e/b':>7} {'s':>4}")
    for r in rows:
        ratio = r.get("third_extended_over_baseline")
        print(f"{r['seed']:4d} {r['effect']:26} {r['size_sigma']:6.1f} {' '.join(r['inputs']):64} {r['named']:52} "
              f"{r['outcome']:12} {'-' if ratio is None else f'{ratio:7.3f}':>7} {r['seconds']:4.0f}")
    print_misses(rows, lambda r: f"  seed {r['seed']} ({r['effect']}, {r['outcome']}, voltage ranges "
                                 f"{r['ranges_V']}): {r.get('why', r.get('message', ''))[:400]!r}")


def _report(rows) -> None:
    print_rows(rows)
    print_outcome_summary(rows, records.EFFECTS)


def main(argv=None) -> int:
    return run_seed_benchmark(__doc__, 28, evaluate,
                              lambda row: f"{row['effect']} -> {row['named']} ({row['outcome']}), {row['seconds']:.1f} s",
                              _report, argv)


if __name__ == "__main__":
    sys.exit(main())
