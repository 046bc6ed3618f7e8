"""``pysim diagnose DATA.csv``: what the MPI model misses, why, and the gain of
an extended model (see :mod:`pysim.diagnosis.diagnose`)."""
from __future__ import annotations

import json
import re
from pathlib import Path

from pysim.cli.commands.identify import add_data_options, load_data
from pysim.cli.errors import UserError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "diagnose", help="name what the MPI model misses on measured data and measure the gain of a fix",
        description="Fit the MPI model on the first part of a record, analyse its held-out residual "
                    "(against time, input rate, time since the last input change, cross-correlation, "
                    "spectrum), fit every candidate extension (rate_dependence, creep, delay, drift), "
                    "name the cause that lowers the held-out error significantly (or none) and report "
                    "the held-out errors before and after.")
    parser.add_argument("data", help="measured data file")
    parser.add_argument("--json", action="store_true",
                        help='print {"cause", "evidence", "baseline", "extended", "gain_pct"} as JSON')
    parser.add_argument("--report", metavar="DIR", help="write plots and summary.md into this folder")
    parser.add_argument("--out", metavar="SPEC", help="write the extended model spec (a Python file) here")
    parser.add_argument("--name", help="extended model name (a C identifier; default from --out)")
    parser.add_argument("--operators", type=int, default=10, metavar="N", help="number of operators (default 10)")
    parser.add_argument("--operator", choices=("osp", "play"), default="osp",
                        help="one-sided play (paper, default) or classical play operators")
    parser.add_argument("--model", choices=("mpi", "cpi"), default="mpi", help="hysteresis model (default mpi)")
    parser.add_argument("--train-fraction", type=float, default=0.65, metavar="F",
                        help="share of the samples after the warm-up used for training (default 0.65)")
    parser.add_argument("--warmup", default="auto",
                        help="samples left out at the start, or 'auto' (until the input has visited both ends)")
    add_data_options(parser)
    parser.set_defaults(func=run)


def _check_output(path: str, what: str) -> None:
    folder = Path(path).parent
    if not folder.is_dir():
        raise UserError(f"{path}: folder {folder} for the {what} does not exist")


def run(args) -> int:
    from pysim.core.spec import model_name_from_path, write_spec
    from pysim.diagnosis.diagnose import diagnose

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
        _check_output(args.out, "spec")
    if args.report:
        report = Path(args.report)
        if report.exists() and not report.is_dir():
            raise UserError(f"{args.report}: exists and is not a folder")
        _check_output(str(report.resolve()), "report")
    data = load_data(args)
    warmup = "auto" if args.warmup == "auto" else int(args.warmup)
    result = diagnose(data.voltage_V, data.displacement_um, data.sample_rate_hz, time_s=data.time_s,
                      n_operators=args.operators, model=args.model, operator=args.operator,
                      train_fraction=args.train_fraction, warmup=warmup, name=name, source=data.source)
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
    m = result.extended.model
    return (f"MPI model with output stages ({result.cause}) identified from {Path(result.source).name} by "
            f"pysim diagnose.\n\nHeld-out errors (% of range): baseline max {result.baseline.max_pct:.3f}, "
            f"RMS {result.baseline.rms_pct:.3f}; extended max {result.extended.max_pct:.3f}, RMS "
            f"{result.extended.rms_pct:.3f} (gain {result.gain_pct:.1f} %).\n"
            f"The stages run at the sample period {m.sample_period_s:.9g} s: an FMU built from this spec "
            f"must step at that period.")


def format_text(result, report, out) -> str:
    lines = [f"{result.source}: cause {result.cause}",
             f"  {result.why}.",
             "",
             "  held out            max %     RMS %",
             f"  baseline MPI   {result.baseline.max_pct:9.3f} {result.baseline.rms_pct:9.3f}",
             f"  extended       {result.extended.max_pct:9.3f} {result.extended.rms_pct:9.3f}"
             f"   gain {result.gain_pct:.1f} %",
             "",
             "  candidates:"]
    for cause, text in result.reasons.items():
        lines.append(f"    {cause}: {text}")
    if report:
        lines.append(f"\n  report: {Path(report) / 'summary.md'}")
    if out:
        lines.append(f"  extended spec: {out}")
    return "\n".join(lines)
