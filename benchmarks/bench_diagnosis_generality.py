"""Benchmark: does the diagnosis hold on records it was never tuned to?

The records come from an independent generator (``tests/independent_records.py``,
written from the physics and the paper without the package's own generator
or method): MPI plants with 15-40 operators on thresholds off the eq. 13
grid, 0-150 V, 0-100 V or -30..120 V, 1-10 kHz, white noise 0.1-0.5 % of the
range and sometimes ADC quantisation, a sensor offset, training records that
start from rest or from an unknown history, inputs that touch their extremes
once or twice, and one hidden effect per record whose size ranges from the
noise level to clearly visible.  Every seed gives two records of the same
actuator with different input shapes: the diagnosis sees the training record
(and the validation record through ``validate=`` where the API has it); the
models it returns are then asked to predict the validation record.

Only the public API is used, and what is missing is recorded as "not
available" rather than failing:

- ``pysim.diagnosis.diagnose(v, y, fs, validate=(v2, y2, fs2))``, called without
  ``validate`` when the API does not take it (a TypeError naming it);
- ``d.cause``; ``d.causes`` (default ``(d.cause,)``); ``d.extended.model`` and
  ``d.baseline.model`` (``.simulate(voltage_V)``, µm); ``d.excitation``;
- a refusal is any ``pysim.core.errors.PiezoMPIError``; any other exception
  is an error (a crash).

Scoring rules (per record)
--------------------------
named
    ``d.causes`` when it holds more than one name (a set), else ``(d.cause,)``.
right
    truth "none": nothing named (``d.cause == "none"`` and no other name).
    truth the catalog knows (in ``pysim.diagnosis.CAUSES``): the single name
    is the truth; a named set that holds the truth counts as right and is
    also counted apart ("right as a set") -- unless the diagnosis also gives
    an excitation and that excitation, played on the true actuator (same
    plant, effect, noise and sensor) and diagnosed, does not name the truth:
    then the set is "not resolved" and not right.
    truth the catalog does not know (rate_dependent_hysteresis, slew_limit
    today): ``"unexplained"`` is right; the closest stand-in,
    ``"rate_dependence"`` (both make the response lag more at higher rates), is
    right only if its extended model also predicts the validation record
    better than the baseline -- a stand-in has to be useful to count.
false alarm
    anything named on a "none" record (``"unexplained"`` included).
missed, undetectable
    an effect record named "none" whose effect is below the detectability
    line (the part no rate-independent model can absorb is under 1 noise σ):
    not right, not wrong; reported as "acceptable".
refusal
    a ``PiezoMPIError``, with its message.
prediction
    the baseline and the extended model, each started from its own initial
    state, simulate the validation record's voltage; errors are taken after
    the record's settling window (the ease-in from rest plus 2 % of the record,
    at least 0.05 s; ``Record.settle_samples``) and given as RMS and max in % of
    the validation record's noise-free displacement range, against the
    measured record (what a user sees; its noise floor is printed) and against
    the noise-free record.  "Extended better" means a smaller RMS against the
    noise-free record by more than 0.1 % of the baseline's RMS; within that,
    "same".  The same comparison (column "3rd e/b": extended over baseline
    RMS) is made on a third record of the actuator
    (a third input shape, from rest) that is never given to the diagnosis --
    when ``validate=`` exists the diagnosis has seen the validation record,
    so only the third record is a prediction it cannot have fitted.
    Printed with them: the noise floor (σ) and the effect's own RMS on
    the validation record (what a model with the true hysteresis and no
    effect would miss), both in % of the range.

    python benchmarks/bench_diagnosis_generality.py [--records N] [--first-seed S] [--json] [--first-record-only]

``--first-record-only`` gives the diagnosis the first record alone (no ``validate=``), as a
user without a second record runs it.
The validation record is then a prediction as well.

Making the records takes about a second per seed; the diagnosis dominates
the run time (with ``validate=`` and the excitation replays, 10-160 s per
record on a shared 2-core machine).  Progress goes to stderr.
"""
from __future__ import annotations

import json
import math
import sys
import time
import traceback
from collections import Counter
from pathlib import Path

import numpy as np

from bench_common import WITH_HISTORY_FLOOR, diagnose_options, over_seeds, seed_arguments

TESTS = Path(__file__).resolve().parents[1] / "tests"
if str(TESTS) not in sys.path:
    sys.path.insert(0, str(TESTS))

import independent_records as records  # noqa: E402

NOT_AVAILABLE = "not available"
#: Closest catalog name for effects the catalog may not know.
STAND_INS = {"rate_dependent_hysteresis": "rate_dependence", "slew_limit": "rate_dependence"}
UNEXPLAINED = "unexplained"
#: Relative RMS margin below which the two models predict "the same".
SAME_MARGIN = 1e-3


# ------------------------------------------------------------------ calling the API

class _Api:
    """The diagnosis API as far as it exists today."""

    def __init__(self):
        from pysim.core.errors import PiezoMPIError
        from pysim.diagnosis import diagnose

        self.diagnose = diagnose
        self.refusal = PiezoMPIError
        try:
            from pysim.diagnosis import CAUSES
            self.catalog = tuple(CAUSES)
        except ImportError:
            self.catalog = None
        self.validate = None           # unknown until the first call

    def knows(self, name: str) -> bool:
        return self.catalog is not None and name in self.catalog

    def run(self, pair):
        train, val = pair.train, pair.validation
        args = (train.voltage_V, train.displacement_um, train.sample_rate_hz)
        if self.validate is not False:
            try:
                result = self.diagnose(*args, validate=(val.voltage_V, val.displacement_um, val.sample_rate_hz),
                                       **diagnose_options(train.voltage_V, val.voltage_V))
                self.validate = True
                return result
            except TypeError as exc:
                if not ("unexpected keyword" in str(exc) and "validate" in str(exc)):
                    raise
                self.validate = False
        return self.diagnose(*args, **diagnose_options(train.voltage_V))


def _attribute(obj, *names):
    for name in names:
        if obj is None:
            return None
        obj = getattr(obj, name, None)
    return obj


def _errors_pct(model, record, span_um):
    """RMS and max error (% of span) of ``model`` on ``record`` after its
    settling window, against the measured and the noise-free displacement."""
    predicted = np.asarray(model.simulate(record.voltage_V), dtype=float).ravel()
    if predicted.shape != record.voltage_V.shape or not np.all(np.isfinite(predicted)):
        raise ValueError(f"prediction has shape {predicted.shape} or non-finite values")
    part = slice(record.settle_samples, None)
    out = {}
    for label, target in (("measured", record.displacement_um), ("clean", record.clean_um)):
        error = predicted[part] - target[part]
        out[f"rms_{label}_pct"] = float(np.sqrt(np.mean(error ** 2)) / span_um * 100)
        out[f"max_{label}_pct"] = float(np.max(np.abs(error)) / span_um * 100)
    return out


# ------------------------------------------------------------------ one record

def evaluate(api: _Api, seed: int) -> dict:
    """Generate the pair of records of ``seed``, diagnose, predict and score."""
    t0 = time.perf_counter()
    pair = records.make_pair(seed)
    t1 = time.perf_counter()
    truth = pair.truth
    row = {
        "seed": seed, "truth": truth.effect,
        "effect_parameters": {k: v for k, v in truth.effect_parameters.items() if k != "name"},
        "unabsorbable_to_noise": round(truth.unabsorbable_to_noise, 3),
        "effect_rms_to_noise": round(truth.effect_rms_um / truth.noise_sigma_um, 3),
        "detectable": truth.detectable, "n_operators": len(truth.plant["thresholds_V"]),
        "voltage_range_V": truth.plant["voltage_range_V"], "sample_rate_hz": pair.train.sample_rate_hz,
        "train": {"input": pair.train.input_kind, "start": pair.train.start, "samples": pair.train.voltage_V.size},
        "validation": {"input": pair.validation.input_kind, "samples": pair.validation.voltage_V.size,
                       "settle_samples": pair.validation.settle_samples},
        "test": {"input": pair.test.input_kind, "samples": pair.test.voltage_V.size,
                 "settle_samples": pair.test.settle_samples,
                 "effect_pct": round(truth.test_effect_rms_um / float(np.ptp(pair.test.clean_um)) * 100, 4)},
        "noise_pct": round(truth.noise_fraction_of_range * 100, 3),
        "quantised": truth.quantisation_step_um > 0, "generate_s": round(t1 - t0, 3),
    }
    span = float(np.ptp(pair.validation.clean_um))
    row["validation_noise_floor_pct"] = round(truth.noise_sigma_um / span * 100, 4)
    row["validation_effect_pct"] = round(truth.validation_effect_rms_um / span * 100, 4)
    try:
        result = api.run(pair)
    except api.refusal as exc:
        row.update(outcome="refused", named=("refused",), message=str(exc), diagnose_s=time.perf_counter() - t1)
        return row
    except Exception as exc:     # a crash is reported, not hidden
        row.update(outcome="error", named=("error",), message=f"{type(exc).__name__}: {exc}",
                   traceback=traceback.format_exc(limit=3), diagnose_s=time.perf_counter() - t1)
        return row
    row["diagnose_s"] = round(time.perf_counter() - t1, 3)
    row["validate_used"] = bool(api.validate)
    cause = getattr(result, "cause", None)
    causes = getattr(result, "causes", None)
    row["cause"] = cause if cause is not None else NOT_AVAILABLE
    row["causes"] = list(causes) if causes is not None else NOT_AVAILABLE
    named = tuple(causes) if causes is not None and len(tuple(causes)) > 1 else (cause,)
    row["named"] = named
    excitation = getattr(result, "excitation", None)
    if excitation is None:
        row["excitation"] = NOT_AVAILABLE
    else:
        ex = np.asarray(excitation, dtype=float).ravel()
        lo, hi = truth.plant["voltage_range_V"]
        row["excitation"] = {"samples": int(ex.size), "min_V": float(ex.min()) if ex.size else None,
                             "max_V": float(ex.max()) if ex.size else None,
                             "within_range": bool(ex.size and ex.min() >= lo - 1e-6 and ex.max() <= hi + 1e-6)}
        if len(named) > 1 and ex.size:
            row["excitation"].update(_play_excitation(api, pair, ex, seed))

    # prediction of the other records
    row.update(_predict(result, pair.validation, span))
    test = _predict(result, pair.test, float(np.ptp(pair.test.clean_um)))
    row["test"].update(baseline=test["baseline"], extended=test["extended"], prediction=test["prediction"])
    row["outcome"] = _outcome(api, truth, named, row["prediction"], row["excitation"])
    return row


def _predict(result, record, span_um) -> dict:
    """Errors of the baseline and the extended model on ``record`` and which is better."""
    out = {}
    for label in ("baseline", "extended"):
        model = _attribute(result, label, "model")
        if model is None:
            out[label] = NOT_AVAILABLE
            continue
        try:
            out[label] = {"model": type(model).__name__, **_errors_pct(model, record, span_um)}
        except Exception as exc:
            out[label] = f"simulation failed: {type(exc).__name__}: {exc}"
    base, ext = out["baseline"], out["extended"]
    if isinstance(base, dict) and isinstance(ext, dict):
        a, b = ext["rms_clean_pct"], base["rms_clean_pct"]
        out["prediction"] = "same" if abs(a - b) <= SAME_MARGIN * b else ("better" if a < b else "worse")
    else:
        out["prediction"] = NOT_AVAILABLE
    return out


def _play_excitation(api, pair, excitation_V, seed) -> dict:
    """Play the suggested excitation on the true actuator, diagnose that record
    and say whether it names the truth."""
    played = records.respond(pair, excitation_V, noise_seed=10_000_000 + seed)
    try:
        again = api.diagnose(played.voltage_V, played.displacement_um, played.sample_rate_hz,
                             **diagnose_options(played.voltage_V))
    except api.refusal as exc:
        return {"picks_truth": False, "named_after": "refused", "message_after": str(exc)}
    except Exception as exc:
        return {"picks_truth": False, "named_after": "error", "message_after": f"{type(exc).__name__}: {exc}"}
    cause = getattr(again, "cause", None)
    truth = pair.truth.effect
    picks = cause == truth or (not api.knows(truth) and cause == UNEXPLAINED)
    return {"picks_truth": bool(picks), "named_after": cause}


def _outcome(api, truth, named, prediction, excitation=None) -> str:
    """The verdict's class (see the module notes)."""
    nothing = all(name in (None, "none") for name in named)
    if truth.effect == "none":
        return "right" if nothing else "false_alarm"
    if nothing:
        return "missed" if truth.detectable else "missed_undetectable"
    single = len(named) == 1
    if api.knows(truth.effect):
        if truth.effect in named:
            if single:
                return "right"
            resolved = excitation.get("picks_truth") if isinstance(excitation, dict) else None
            return "set_unresolved" if resolved is False else "right_set"
        return "unexplained" if UNEXPLAINED in named else "wrong"
    if UNEXPLAINED in named and single:
        return "right"
    if STAND_INS.get(truth.effect) in named:
        return "right_stand_in" if prediction == "better" else "wrong_stand_in"
    return "wrong"


# ------------------------------------------------------------------ summary

RIGHT = ("right", "right_set", "right_stand_in")


def _label(row) -> str:
    named = row["named"]
    return "|".join(str(n) for n in named)


def summarise(rows, api, elapsed_s) -> dict:
    effects = [r for r in rows if r["truth"] != "none"]
    nones = [r for r in rows if r["truth"] == "none"]
    outcomes = Counter(r["outcome"] for r in rows)
    confusion = {}
    for r in rows:
        confusion.setdefault(r["truth"], Counter())[_label(r)] += 1

    def share(subset, test):
        return {"count": sum(1 for r in subset if test(r)), "of": len(subset)}

    detectable = [r for r in effects if r["detectable"]]
    prediction = {
        "effect_records_extended_better": share(effects, lambda r: r.get("prediction") == "better"),
        "detectable_effect_records_extended_better": share(detectable, lambda r: r.get("prediction") == "better"),
        "effect_records_extended_worse": share(effects, lambda r: r.get("prediction") == "worse"),
        "none_records_extended_worse": share(nones, lambda r: r.get("prediction") == "worse"),
        "test_record_effect_records_extended_better": share(
            effects, lambda r: r["test"].get("prediction") == "better"),
        "test_record_effect_records_extended_worse": share(
            effects, lambda r: r["test"].get("prediction") == "worse"),
        "test_record_none_records_extended_worse": share(
            nones, lambda r: r["test"].get("prediction") == "worse"),
    }
    for key in ("baseline", "extended"):
        values = [r[key]["rms_measured_pct"] for r in effects if isinstance(r.get(key), dict)]
        prediction[f"median_{key}_rms_measured_pct_effect_records"] = (float(np.median(values)) if values
                                                                         else NOT_AVAILABLE)
    counts = {
        "records": len(rows),
        "right": sum(outcomes[k] for k in RIGHT),
        "right_as_set": outcomes["right_set"],
        "right_by_stand_in": outcomes["right_stand_in"],
        "right_or_acceptable": sum(outcomes[k] for k in RIGHT) + outcomes["missed_undetectable"],
        "false_alarms": outcomes["false_alarm"],
        "refusals": outcomes["refused"],
        "errors": outcomes["error"],
        "missed_detectable": outcomes["missed"],
        "missed_undetectable": outcomes["missed_undetectable"],
        "wrong": outcomes["wrong"] + outcomes["wrong_stand_in"],
        "unexplained_on_known_effect": outcomes["unexplained"],
        "set_not_resolved_by_its_excitation": outcomes["set_unresolved"],
        "detectable_effect_records": len(detectable),
        "detectable_effect_records_right": sum(1 for r in detectable if r["outcome"] in RIGHT),
    }
    return {
        "api": {"catalog": list(api.catalog) if api.catalog is not None else NOT_AVAILABLE,
                "validate": api.validate if api.validate is not None else NOT_AVAILABLE,
                "causes": any(r.get("causes") not in (None, NOT_AVAILABLE) for r in rows),
                "excitation": any(isinstance(r.get("excitation"), dict) for r in rows)},
        "counts": counts,
        "outcomes": dict(outcomes),
        "confusion": {t: dict(c) for t, c in confusion.items()},
        "prediction": prediction,
        "worst": [_brief(r) for r in worst(rows)],
        "runtime_s": round(elapsed_s, 1),
        "diagnose_s_total": round(sum(r.get("diagnose_s", 0.0) for r in rows), 1),
        "records": rows,
    }


_SEVERITY = {"error": 0, "refused": 1, "false_alarm": 2, "missed": 3, "wrong": 3, "wrong_stand_in": 3,
             "set_unresolved": 4,
             "unexplained": 4, "missed_undetectable": 6, "right_set": 7, "right_stand_in": 7, "right": 8}


def _rms_ratio(r) -> float:
    """Extended over baseline RMS (noise-free) on the validation record (on the
    third record with ``r["test"]``)."""
    base, ext = r.get("baseline"), r.get("extended")
    if isinstance(base, dict) and isinstance(ext, dict) and base["rms_clean_pct"] > 0:
        return ext["rms_clean_pct"] / base["rms_clean_pct"]
    return math.nan


def worst(rows, n: int = 6, n_prediction: int = 4):
    """Worst records first: crashes, refusals, false alarms, wrong names of
    clearly visible effects (``n`` of them), then the ``n_prediction`` records
    whose extended model predicts the validation record worst relative to
    the baseline."""
    def key(r):
        return (_SEVERITY.get(r["outcome"], 5), -r["unabsorbable_to_noise"])
    failed = sorted((r for r in rows if r["outcome"] not in RIGHT), key=key)[:n]
    chosen = {r["seed"] for r in failed}
    worse = sorted((r for r in rows if r.get("prediction") == "worse" and r["seed"] not in chosen),
                   key=lambda r: -_rms_ratio(r))[:n_prediction]
    return failed + worse


def _brief(r) -> dict:
    out = {k: r.get(k) for k in ("seed", "truth", "unabsorbable_to_noise", "outcome", "named", "prediction")}
    out["inputs"] = f"{r['train']['input']}/{r['train']['start']} -> {r['validation']['input']}"
    ratio, third = _rms_ratio(r), _rms_ratio(r["test"])
    out["extended_over_baseline_rms"] = round(ratio, 3) if math.isfinite(ratio) else NOT_AVAILABLE
    out["third_record_extended_over_baseline_rms"] = round(third, 3) if math.isfinite(third) else NOT_AVAILABLE
    if "message" in r:
        out["message"] = r["message"][:300]
    return out


# ------------------------------------------------------------------ printing

def _fmt_errors(entry) -> str:
    if not isinstance(entry, dict):
        return "n/a"
    return f"{entry['rms_measured_pct']:6.2f} {entry['max_measured_pct']:6.2f}"


def print_report(summary) -> None:
    rows = summary["records"]
    api = summary["api"]
    print(f"diagnosis on independent records: {len(rows)} pairs, {summary['runtime_s']} s "
          f"({summary['diagnose_s_total']} s in diagnose)")
    print(f"API: catalog {api['catalog']}; validate= {api['validate']}; causes {api['causes']}; "
          f"excitation {api['excitation']}")
    print()
    print(f"{'seed':>4} {'truth':<26} {'u/σ':>6} {'train → validation':<36} {'named':<24} {'outcome':<20} "
          f"{'base rms/max %':>14} {'ext rms/max %':>14} {'floor%':>6} {'eff%':>6} {'3rd e/b':>7}")
    for r in rows:
        io = f"{r['train']['input']}/{r['train']['start']}→{r['validation']['input']}"
        print(f"{r['seed']:>4} {r['truth']:<26} {r['unabsorbable_to_noise']:6.2f} {io:<36} {_label(r):<24} "
              f"{r['outcome']:<20} {_fmt_errors(r.get('baseline')):>14} {_fmt_errors(r.get('extended')):>14} "
              f"{r.get('validation_noise_floor_pct', math.nan):6.3f} {r.get('validation_effect_pct', math.nan):6.2f} "
              f"{_rms_ratio(r['test']):7.2f}")
    print()
    confusion = summary["confusion"]
    columns = sorted({c for row in confusion.values() for c in row})
    widths = [max(5, len(c)) + 2 for c in columns]
    print("confusion (rows: truth, columns: named; a set is written a|b)")
    print(f"{'':<26}" + "".join(f"{c:>{w}}" for c, w in zip(columns, widths)))
    for truth in records.EFFECTS:
        if truth in confusion:
            print(f"{truth:<26}" + "".join(f"{confusion[truth].get(c, 0):>{w}}" for c, w in zip(columns, widths)))
    c = summary["counts"]
    print()
    print(f"right {c['right']}/{c['records']} (as a set {c['right_as_set']}, by stand-in {c['right_by_stand_in']}); "
          f"right or an undetectable effect named none {c['right_or_acceptable']}/{c['records']}")
    print(f"detectable effects named right {c['detectable_effect_records_right']}/{c['detectable_effect_records']}")
    print(f"false alarms {c['false_alarms']}, refusals {c['refusals']}, errors {c['errors']}, "
          f"wrong {c['wrong']}, missed (detectable) {c['missed_detectable']}, "
          f"missed (undetectable) {c['missed_undetectable']}, unexplained on a known effect "
          f"{c['unexplained_on_known_effect']}, sets their excitation did not resolve "
          f"{c['set_not_resolved_by_its_excitation']}")
    p = summary["prediction"]

    def s(x):
        return f"{x['count']}/{x['of']}"
    print(f"extended predicts the validation record better than the baseline: "
          f"{s(p['effect_records_extended_better'])} effect records "
          f"({s(p['detectable_effect_records_extended_better'])} detectable); worse on "
          f"{s(p['effect_records_extended_worse'])} effect records and on {s(p['none_records_extended_worse'])} "
          f"'none' records")
    def pct(x):
        return f"{x:.2f} %" if isinstance(x, float) else str(x)
    print(f"on a third record never given to the diagnosis: extended better on "
          f"{s(p['test_record_effect_records_extended_better'])} effect records, worse on "
          f"{s(p['test_record_effect_records_extended_worse'])}, and worse on "
          f"{s(p['test_record_none_records_extended_worse'])} 'none' records")
    print(f"median validation RMS on effect records (against the measured record): baseline "
          f"{pct(p['median_baseline_rms_measured_pct_effect_records'])}, extended "
          f"{pct(p['median_extended_rms_measured_pct_effect_records'])} of range")
    print()
    print("worst cases")
    for w in summary["worst"]:
        msg = f"  — {w['message']}" if "message" in w else ""
        print(f"  seed {w['seed']}: {w['truth']} (u/σ {w['unabsorbable_to_noise']}), {w['inputs']}: "
              f"{w['outcome']}, named {'|'.join(map(str, w['named']))}, ext/base RMS "
              f"{w['extended_over_baseline_rms']} (third record {w['third_record_extended_over_baseline_rms']}){msg}")


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


def main(argv=None) -> int:
    parser = seed_arguments(__doc__.split("\n\n")[0], 30)
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    args = parser.parse_args(argv)
    WITH_HISTORY_FLOOR["on"] = args.history_floor
    api = _Api()
    if args.first_record_only:
        api.validate = False           # as a user without a second record runs it
    start = time.perf_counter()
    rows = over_seeds(lambda seed: evaluate(api, seed), args.first_seed, args.records,
                      lambda row: f"{row['truth']} -> {_label(row)} ({row['outcome']}), "
                                  f"{row.get('diagnose_s', 0):.1f} s")
    summary = summarise(rows, api, time.perf_counter() - start)
    if args.json:
        json.dump(_jsonable(summary), sys.stdout, indent=1)
        print()
    else:
        print_report(summary)
    return 0


if __name__ == "__main__":
    sys.exit(main())
