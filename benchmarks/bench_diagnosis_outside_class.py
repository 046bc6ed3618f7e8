"""Benchmark: the diagnosis on actuators whose hysteresis no MPI model draws.

The records come from ``tests/outside_class_records.py`` (independent of the
package): a Preisach model of relays with a 2-D weight (minor loops that are
not congruent) or an asymmetric Bouc-Wen model, with a reversible part, one
effect from none / creep / lag / delay, white noise 0.1-0.3 % of the range,
1-5 kHz; three records of one actuator with different inputs (sine sweep,
band-limited noise, staircase of holds, random triangles), the first after
an unknown history on most seeds.  The diagnosis sees the first record and
validates on the second; the third is predicted by the baseline and the
extended model.

Outcomes per seed: ``right`` (the catalogue's name for the effect, alone or in
a named set; ``none`` on a record without an effect), ``unexplained``,
``false alarm`` (anything named on a record without an effect, ``unexplained``
included), ``wrong``, ``missed`` (``none`` named for an effect), ``refused``.
The third record: RMS error of each model against the noise-free record
after 0.1 s, and their ratio (extended / baseline).

    python benchmarks/bench_diagnosis_outside_class.py [--records N] [--first-seed S] [--first-record-only]

``--first-record-only`` gives the diagnosis the first record alone (no ``validate=``), as a
user without a second record runs it.

Each record pair takes 5-60 s (the Preisach model is simulated relay by relay
on a grid eight times finer than the samples).  Progress goes to stderr.
"""
from __future__ import annotations

import sys
from pathlib import Path

from bench_common import diagnose_and_score, print_outcome_summary, run_seed_benchmark, settled_rms_pct

TESTS = Path(__file__).resolve().parents[1] / "tests"
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

import outside_class_records as records  # noqa: E402

SETTLE_S = 0.1


def _rms_pct(model, record) -> float:
    return settled_rms_pct(model, record.voltage_V, record.clean_um, SETTLE_S * record.sample_rate_hz)


def evaluate(seed: int, second_record: bool = True) -> dict:
    """Diagnose one pair (the first record alone when ``second_record`` is false) and score it."""
    pair = records.make_outside_pair(seed)
    row = {"seed": seed, "plant": pair.plant, "effect": pair.effect,
           "inputs": f"{pair.train.input_kind}/{pair.validation.input_kind}/{pair.test.input_kind}"}
    records_given = [(r.voltage_V, r.displacement_um, r.sample_rate_hz) for r in (pair.train, pair.validation)]
    if not second_record:
        records_given[1] = None
    d = diagnose_and_score(row, *records_given, "none" if pair.effect == "none" else pair.catalogue_name,
                           lambda model: _rms_pct(model, pair.test))
    if d is not None:
        row["shape_corrected"] = sorted(d.shape)
    return row


def _report(rows) -> None:
    print(f"{'seed':>4} {'plant':9} {'effect':6} {'inputs (1st/2nd/3rd)':34} {'named':34} {'outcome':12} "
          f"{'shape':13} {'3rd base %':>10} {'3rd e/b':>7}")
    for r in rows:
        print(f"{r['seed']:4d} {r['plant']:9} {r['effect']:6} {r['inputs']:34} {r['named']:34} {r['outcome']:12} "
              f"{','.join(r.get('shape_corrected', [])) or '-':13} {r.get('third_baseline_rms_pct', float('nan')):10.3f} "
              f"{r.get('third_extended_over_baseline', float('nan')):7.3f}")
    print_outcome_summary(rows, records.EFFECTS)


def main(argv=None) -> int:
    return run_seed_benchmark(__doc__, 24, evaluate,
                              lambda row: f"{row['plant']} {row['effect']} -> {row['named']} ({row['outcome']}), "
                                          f"{row['seconds']:.1f} s",
                              _report, argv)


if __name__ == "__main__":
    sys.exit(main())
