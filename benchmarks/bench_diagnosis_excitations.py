"""Benchmark: the diagnosis on excitations that none of the record generators plays.

The plant of each seed is a plain MPI actuator of the third generator
(``tests/third_generator_records.py``: ``make_plant``, operators at rest at
0 V), so its hysteresis is in the model class and only the input is new.
The first record's input (``seed % 10``, :data:`KINDS`) is one a user may
well have on file: a staircase of holds, band-limited noise, a square wave
with a small ripple, minor loops about mid-range that never reach either end,
one slow triangle, a sweep from fast to slow, an amplitude-modulated sine,
random ramps, a sine that starts mid-range, a decaying triangle on an offset.
The hidden effect (``seed // 10 % 3``, :data:`EFFECTS`) is none, a creep
mode (4 % of the hysteresis output, 0.4 s) or a delay of two samples.  The
second record (given to ``--validate``) is random ramps, the third (predicted
by the plain fit and by the model delivered, never seen by the diagnosis) a
multisine of five tones that eases in from 0 V.  The actuator rests at 0 V
before every record (operators and creep settled there).  8 s at 2 kHz each, white noise of 0.2 % of each
record's range.

Outcomes per seed as in the other diagnosis benchmarks: ``right`` (the
effect, alone or in a named set; ``none`` without one), ``false alarm``,
``wrong``, ``missed``, ``unexplained``, ``refused``; and on the third
record the RMS error of the model delivered over the plain fit's, against
the noise-free record, after its first 0.1 s.  ``eff/σ``: the effect's RMS on
the first record after its first 0.1 s, over the noise σ.

    python benchmarks/bench_diagnosis_excitations.py [--records N] [--first-seed S] [--first-record-only]

``--first-record-only`` gives the diagnosis the first record alone (no ``validate=``), as a
user without a second record runs it.

Each seed takes 5-25 s.  Progress goes to stderr.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.signal

from bench_common import diagnose_and_score, print_outcome_summary, run_seed_benchmark, settled_rms_pct

TESTS = Path(__file__).resolve().parents[1] / "tests"
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

import third_generator_records as plants  # noqa: E402

SAMPLE_RATE_HZ = 2000.0
DURATION_S = 8.0
NOISE_SHARE = 0.002
KINDS = ("staircase", "band_noise", "square", "minor_loops", "one_triangle", "sweep_down", "modulated_sine",
         "random_ramps", "mid_start_sine", "offset_decaying_triangle")
EFFECTS = ("none", "creep", "delay")
CREEP_SHARE, CREEP_TIME_CONSTANT_S, DELAY_SAMPLES = 0.04, 0.4, 2
SETTLE_S = 0.1


def excitation(kind: str, rng: np.random.Generator, n_samples: int) -> np.ndarray:
    """Input of ``kind`` as a share of the actuator's voltage range (0-1), ``n_samples`` at
    :data:`SAMPLE_RATE_HZ`."""
    t = np.arange(n_samples) / SAMPLE_RATE_HZ
    if kind == "staircase":
        levels = np.concatenate([np.linspace(0, 1, 12), np.linspace(1, 0, 12)[1:], np.linspace(0, 0.7, 8)[1:],
                                 np.linspace(0.7, 0.2, 6)[1:]])
        u = np.repeat(levels, n_samples // levels.size + 1)[:n_samples]
    elif kind == "band_noise":
        b, a = scipy.signal.butter(2, rng.uniform(4.0, 12.0) / (SAMPLE_RATE_HZ / 2))
        x = scipy.signal.filtfilt(b, a, rng.normal(size=n_samples))
        u = (x - x.min()) / np.ptp(x)
    elif kind == "square":
        u = 0.5 + 0.45 * np.sign(np.sin(2 * np.pi * rng.uniform(0.5, 2.0) * t)) + 0.04 * np.sin(2 * np.pi * 7 * t)
    elif kind == "minor_loops":
        u = (rng.uniform(0.4, 0.6) + 0.2 * np.sin(2 * np.pi * rng.uniform(1.0, 4.0) * t)
             + 0.1 * np.sin(2 * np.pi * rng.uniform(0.2, 0.5) * t))
    elif kind == "one_triangle":
        u = 1 - np.abs(2 * t / t[-1] - 1)
    elif kind == "sweep_down":
        u = 0.5 + 0.5 * scipy.signal.chirp(t, rng.uniform(15.0, 40.0), t[-1], 0.5, method="logarithmic")
    elif kind == "modulated_sine":
        u = 0.5 + 0.5 * np.sin(2 * np.pi * 0.2 * t) ** 2 * np.sin(2 * np.pi * rng.uniform(3.0, 8.0) * t)
    elif kind == "random_ramps":
        points = rng.uniform(0, 1, 14)
        points[0] = 0.0
        u = np.interp(t, np.linspace(0, t[-1], points.size), points)
    elif kind == "mid_start_sine":
        u = 0.55 + 0.45 * np.sin(2 * np.pi * rng.uniform(0.8, 2.0) * t + 0.3)
    elif kind == "offset_decaying_triangle":
        u = 0.3 + 0.7 * np.abs(((t * 1.5) % 2) - 1) * np.exp(-t / 4)
    elif kind == "multisine":
        # eased in from 0 V over the first 0.25 s, so that the record starts at rest like the plant
        f = np.sort(rng.uniform(0.3, 12.0, 5))
        x = np.sin(2 * np.pi * f[:, None] * t + rng.uniform(0, 2 * np.pi, (5, 1))).sum(axis=0)
        u = (x - x.min()) / np.ptp(x) * np.minimum(t / 0.25, 1.0)
    else:
        raise ValueError(f"unknown excitation {kind!r}")
    return np.clip(u, 0.0, 1.0)


def with_effect(hysteresis_um: np.ndarray, effect: str) -> np.ndarray:
    """The plant's output: the hysteresis output, then the hidden effect.

    Before every record the actuator rests at 0 V, where the hysteresis
    output is 0 µm and the creep mode has settled; the record starts with
    the jump to its first voltage (as the operators do in ``make_plant``'s
    simulation)."""
    if effect == "creep":
        pole = np.exp(-1.0 / (CREEP_TIME_CONSTANT_S * SAMPLE_RATE_HZ))
        slow = scipy.signal.lfilter([1.0 - pole], [1.0, -pole], hysteresis_um)
        return hysteresis_um + CREEP_SHARE * slow
    if effect == "delay":
        return np.r_[np.zeros(DELAY_SAMPLES), hysteresis_um[:-DELAY_SAMPLES]]
    return hysteresis_um.copy()


def make_records(seed: int) -> dict:
    """The seed's plant, effect and three records (voltage V, noisy and clean displacement µm)."""
    rng = np.random.default_rng(seed)
    plant = plants.make_plant(rng)
    kind, effect = KINDS[seed % len(KINDS)], EFFECTS[seed // len(KINDS) % len(EFFECTS)]
    n = int(DURATION_S * SAMPLE_RATE_HZ)
    records = {}
    for role, input_kind in (("train", kind), ("validation", "random_ramps"), ("test", "multisine")):
        v = excitation(input_kind, rng, n) * plant.max_voltage_V
        hysteresis = plant.hysteresis_um(v)
        clean = with_effect(hysteresis, effect)
        noise_um = NOISE_SHARE * float(np.ptp(clean))
        settled = slice(int(SETTLE_S * SAMPLE_RATE_HZ), None)      # after the jump from rest
        records[role] = {"voltage_V": v, "clean_um": clean, "noise_um": noise_um,
                         "effect_to_noise": float(np.sqrt(np.mean((clean - hysteresis)[settled] ** 2))) / noise_um,
                         "displacement_um": clean + rng.normal(scale=noise_um, size=n)}
    return {"kind": kind, "effect": effect, "plant": f"{plant.variant} n={plant.n_operators}", **records}


def _rms_pct(model, record) -> float:
    return settled_rms_pct(model, record["voltage_V"], record["clean_um"], SETTLE_S * SAMPLE_RATE_HZ)


def evaluate(seed: int, second_record: bool = True) -> dict:
    """Diagnose one seed's first record with its second (alone when ``second_record`` is false)
    and score the outcome."""
    rec = make_records(seed)
    row = {"seed": seed, "kind": rec["kind"], "effect": rec["effect"], "plant": rec["plant"],
           "effect_to_noise": rec["train"]["effect_to_noise"]}
    given = [(rec[role]["voltage_V"], rec[role]["displacement_um"], SAMPLE_RATE_HZ) for role in ("train", "validation")]
    if not second_record:
        given[1] = None
    # the effects' names here are the catalogue's
    diagnose_and_score(row, *given, rec["effect"], lambda model: _rms_pct(model, rec["test"]))
    return row


def _report(rows) -> None:
    print(f"{'seed':>4} {'first record':24} {'plant':15} {'effect':6} {'eff/σ':>6} {'named':42} {'outcome':12} "
          f"{'3rd base %':>10} {'3rd e/b':>7}")
    for r in rows:
        print(f"{r['seed']:4d} {r['kind']:24} {r['plant']:15} {r['effect']:6} {r['effect_to_noise']:6.2f} "
              f"{r['named']:42} {r['outcome']:12} {r.get('third_baseline_rms_pct', float('nan')):10.3f} "
              f"{r.get('third_extended_over_baseline', float('nan')):7.3f}")
    print_outcome_summary(rows, EFFECTS)


def main(argv=None) -> int:
    return run_seed_benchmark(__doc__, 30, evaluate,
                              lambda row: f"{row['kind']} {row['effect']} -> {row['named']} ({row['outcome']}), "
                                          f"{row['seconds']:.1f} s",
                              _report, argv)


if __name__ == "__main__":
    sys.exit(main())
