"""``pysim diagnose DATA.csv``: what the MPI model misses, why, and the gain of
an extended model (see :mod:`pysim.diagnosis.diagnose`)."""
from __future__ import annotations

import json
import re
from pathlib import Path

from pysim.cli.commands.identify import add_data_options, load_data
from pysim.cli.errors import UserError
from pysim.cli.outputs import check_output_file, check_output_folder


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "diagnose", help="name what the MPI model misses on measured data and measure the gain of a fix",
        description="Fit the MPI model on every sample (the operator state at the start estimated), fit "
                    "every candidate extension (rate_dependence, creep, delay, drift, "
                    "rate_dependent_hysteresis, slew_limit) and a richer rate-independent model, score them "
                    "by blocked cross-validation (and on a second record with --validate), name the cause "
                    "that beats both rate-independent models significantly -- a set when several explain "
                    "the residual equally well, 'unexplained' when none explains most of it, or none -- and "
                    "report the errors before and after.")
    parser.add_argument("data", help="measured data file")
    parser.add_argument("--json", action="store_true",
                        help='print {"source", "cause", "causes", "evidence" (why, candidates, scoring, '
                             'validation, ...), "baseline", "extended" ("cause" is "baseline" when the model '
                             'named is withheld), "gain_pct", "excitation"} as JSON')
    parser.add_argument("--report", metavar="DIR", help="write plots and summary.md into this folder")
    parser.add_argument("--out", metavar="SPEC",
                        help="write the model delivered as a spec (a Python file defining MODEL) here: the "
                             "extended model, the plain fit when the verdict is none or the named model is "
                             "withheld")
    parser.add_argument("--name", help="extended model name (a C identifier; default from --out)")
    parser.add_argument("--operators", type=int, default=10, metavar="N", help="number of operators (default 10)")
    parser.add_argument("--operator", choices=("osp", "play"), default="osp",
                        help="one-sided play (paper, default) or classical play operators")
    parser.add_argument("--model", choices=("mpi", "cpi"), default="mpi", help="hysteresis model (default mpi)")
    parser.add_argument("--validate", metavar="OTHER",
                        help="a second record of the same actuator with another input (same layout): every model "
                             "is scored on it and the cause is named by it; at another sample rate both records "
                             "are used at the highest rate their samples share")
    parser.add_argument("--train-fraction", type=float, default=0.65, metavar="F",
                        help="where the report's plots shade a held-out part (default 0.65); the scores are "
                             "cross-validated")
    parser.add_argument("--warmup", default="auto",
                        help="'auto' (default: no warm-up, the initial operator state is estimated) or a number "
                             "of samples the plots treat as warm-up")
    parser.add_argument("--keep-artefacts", action="store_true",
                        help="report spikes, jumps and mains hum of the displacement (which no model of the actuator "
                             "explains) without repairing them first; flat runs are only ever reported")
    parser.add_argument("--history-floor", type=float, metavar="V",
                        help="the lowest voltage the actuator was driven to before the records (e.g. 0 for a "
                             "unipolar amplifier): every fit's start state is one such a history leaves, so the "
                             "model delivered, run from rest, is its fit once a record reaches it (default: no floor)")
    add_data_options(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    from pysim.core.spec import model_name_from_path, write_spec
    from pysim.diagnosis.diagnose import diagnose
    from pysim.identification.data import require_even_sampling

    if args.operators < 1:
        raise UserError(f"--operators must be at least 1, got {args.operators}")
    if not 0.2 <= args.train_fraction <= 0.9:
        raise UserError(f"--train-fraction must lie in [0.2, 0.9], got {args.train_fraction}")
    if args.warmup != "auto" and not re.fullmatch(r"\d+", str(args.warmup)):
        raise UserError(f"--warmup must be 'auto' or a whole number of samples, got {args.warmup!r}")
    name = args.name or model_name_from_path(args.out, default="extended_mpi")
    if not name.isidentifier():
        raise UserError(f"model name {name!r} is not a C identifier (use --name)")
    if args.out:
        check_output_file(args.out, "spec")
    if args.report:
        check_output_folder(args.report, "report")
    data = load_data(args)
    other = load_data(args, args.validate) if args.validate else None
    for record in (data, other):
        if record is not None:
            # every lag, delay and creep is fitted on the sample grid: a pause would be fitted across
            require_even_sampling(record, "the diagnosis")
    warmup = "auto" if args.warmup == "auto" else int(args.warmup)
    result = diagnose(data.voltage_V, data.displacement_um, data.sample_rate_hz, time_s=data.time_s,
                      n_operators=args.operators, model=args.model, operator=args.operator,
                      train_fraction=args.train_fraction, warmup=warmup, name=name, source=data.source,
                      validate=None if other is None else (other.voltage_V, other.displacement_um,
                                                           other.sample_rate_hz),
                      validate_source="" if other is None else other.source,
                      repair_artefacts=not args.keep_artefacts, history_floor_V=args.history_floor)
    if args.report:
        from pysim.diagnosis.report import write_report

        write_report(result, args.report)
    if args.out:
        write_spec(result.extended.model, args.out, header=_spec_header(result))
    if args.json:
        print(json.dumps(result.as_json(), indent=2))
    else:
        print(format_text(result, args.report, args.out))
    return 0


def _spec_header(result) -> str:
    stage = result.extended.model
    m = getattr(stage, "plant", stage)
    grown = getattr(stage, "kind", None) == "rate_thresholds"
    where, part, held = (("the hysteresis' thresholds", "its rate-independent part",
                          "thresholds that grow with the input rate")
                         if grown else ("a stage before the hysteresis", "the part after it", "an input stage"))
    note = (f"\nThe named cause is {where} ({stage.stage_summary()}): MODEL runs it "
            "(pysim.core.load_spec(this file).simulate(voltage_V)), but an FMU cannot hold it; build-fmu "
            f"builds {part} only when given --without-input-stage."
            if stage is not m else "")
    what = (f"Plain MPI model ({result.withheld} named; its model predicts the second record worse)"
            if result.withheld else
            f"MPI model with {held if stage is not m else 'output stages'} ({result.cause})")
    both = (f" and {Path(result.validation['source'] or 'the second record').name} (shape parameters from the first)"
            if result.fitted_on_both_records else "")
    return (f"{what} identified from {Path(result.source).name}{both} by "
            f"pysim diagnose.\n\nHeld-out errors (% of range): baseline max {result.baseline.max_pct:.3f}, "
            f"RMS {result.baseline.rms_pct:.3f}; extended max {result.extended.max_pct:.3f}, RMS "
            f"{result.extended.rms_pct:.3f} (gain {result.gain_pct:.1f} %).\n"
            f"The stages run at the sample period {m.sample_period_s:.9g} s: an FMU built from this spec "
            f"must step at that period." + note)


def format_text(result, report, out) -> str:
    named = (f"cause {result.cause}" + (" (model delivered: the plain fit)" if result.withheld else "")
             if len(result.causes) <= 1 else
             f"causes {', '.join(result.causes)} (a set; model delivered: "
             f"{'the plain fit' if result.withheld else result.cause})")
    lines = [f"{result.source}: {named}",
             f"  {result.why}.",
             "",
             "  cross-validated     max %     RMS %" + ("   second record RMS %" if result.validation else ""),
             ]
    for cause, rms, mx, gain, val in result.table():
        label = {"baseline": "baseline MPI", "richer": "richer RI"}.get(cause, cause)
        lines.append(f"  {label:<27.27s} {mx:9.3f} {rms:9.3f}" + (f" {val:12.3f}" if val is not None else ""))
    steps = result.steps
    by_steps = (f"; on the responses to {steps['windows']} step(s) into holds it removes "
                f"{100 * steps['removed_share'][result.extended.cause]:.0f} % of the excess"
                if steps and result.extended.cause in steps["removed_share"] else "")
    both = "; the model delivered is fitted on both records" if result.fitted_on_both_records else ""
    lines += [f"  extended ({result.extended.cause}): gain {result.gain_pct:.1f} % (cross-validated){by_steps}{both}"
              if not result.withheld else
              f"  delivered: the plain fit ({result.withheld}'s model predicts the second record worse)",
              "", "  candidates:"]
    for cause, text in result.reasons.items():
        lines.append(f"    {cause}: {text}")
    if result.validation:
        table = result.validation["table"]["baseline"]
        lines.append(f"\n  second record (baseline re-fit: offset {table['offset_um']:+.4g} µm, gain {table['gain']:.4g}): "
                     f"cause {result.validation['cause']}; "
                     f"cross-validation alone: {result.cross_validation_cause}")
        if result.validation.get("resampled"):
            lines.append(f"  {result.validation['resampled']}")
    if result.artefacts:
        from pysim.diagnosis.artefacts import artefact_label

        listed = [f"{artefact_label(a)} of the {a['record']} record"
                  + (" (repaired)" if a["repaired"] else "") for a in result.artefacts]
        lines.append("\n  record artefacts: " + ", ".join(listed[:8]) + (f", and {len(listed) - 8} more"
                                                                          if len(listed) > 8 else ""))
    if result.records_swapped:
        lines.append(f"  records swapped: {result.swap_reason}, so the models were fitted on "
                     f"{result.source or 'the second record'} and scored on "
                     f"{result.validation['source'] or 'the first record'}")
    if result.excitation is not None:
        lines.append(f"\n  {len(result.causes)} causes explain the residual equally well: write the separating "
                     f"excitation with `pysim excite {result.source}`")
    if report:
        lines.append(f"\n  report: {Path(report) / 'summary.md'}")
    if out:
        lines.append(f"  extended spec: {out}")
    return "\n".join(lines)
