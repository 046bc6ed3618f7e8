"""``pysim track``: tracking errors for the paper's Table III references, with and without compensation."""
from __future__ import annotations

import json
import math

from pysim.cli.commands._chain import add_chain_arguments, open_chain
from pysim.cli.errors import UserError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "track", help="tracking errors e_m and e_rms for x_d = A sin(2πt) + 37.5 µm (Table III)",
        description="Run the paper's Table III references through the co-simulated chain with and "
                    "without the inverse compensator and print e_m (max |error|) and e_rms in % of "
                    "the reference range (eq. 14-15), next to the paper's figures.")
    add_track_arguments(parser)
    add_chain_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.set_defaults(func=run)


def add_track_arguments(parser) -> None:
    group = parser.add_argument_group("tracking")
    group.add_argument("--step", type=float, default=1e-4, metavar="S",
                       help="communication step, s (default 1e-4; must divide the 1 s period)")
    group.add_argument("--periods", type=int, default=2,
                       help="periods simulated; errors over the last one (default 2)")
    group.add_argument("--amplitudes", type=float, nargs="+", default=None, metavar="UM",
                       help="reference amplitudes A, µm (default: Table III, 7.5 15 22.5 30)")
    group.add_argument("--offset", type=float, default=37.5, metavar="UM", help="reference offset, µm (default 37.5)")
    group.add_argument("--frequency", type=float, default=1.0, metavar="HZ",
                       help="reference frequency, Hz (default 1; the step must divide its period)")


def check_track_arguments(args) -> None:
    frequency = getattr(args, "frequency", 1.0)
    if not (math.isfinite(frequency) and frequency > 0):
        raise UserError(f"--frequency must be a positive number of Hz, got {frequency}")
    period = 1.0 / frequency
    if not (math.isfinite(args.step) and 0 < args.step <= period / 8):
        raise UserError(f"--step must be between 0 and {period / 8:g} s (8 steps per period), got {args.step}")
    if not math.isclose(round(period / args.step) * args.step, period, rel_tol=1e-9):
        raise UserError(f"--step {args.step} s does not divide the {period:g} s period into whole steps")
    for a in getattr(args, "amplitudes", None) or ():
        if not (math.isfinite(a) and a > 0):
            raise UserError(f"--amplitudes must be positive, got {a}")
    if not math.isfinite(getattr(args, "offset", 0.0)):
        raise UserError(f"--offset must be finite, got {args.offset}")
    if args.periods < 2:
        raise UserError(f"--periods must be at least 2, got {args.periods}")


def tracking_json(rows, args, warnings=()) -> dict:
    offset, frequency = getattr(args, "offset", 37.5), getattr(args, "frequency", 1.0)
    return {"reference": f"x_d = A sin(2 pi {frequency:g} t) + {offset:g} um",
            "measured_on": "stage displacement, last period", "warnings": list(warnings),
            "step_s": args.step, "periods": args.periods,
            "error_definitions": {"max_error_pct": "max |x_d - x| / range(x_d) * 100 (eq. 15)",
                                  "rms_error_pct": "rms(x_d - x) / range(x_d) * 100 (eq. 14)"},
            "tracking": rows}


def run(args) -> int:
    check_track_arguments(args)
    from pysim.cli.progress import Progress
    from pysim.cosim.tracking import TABLE_III_AMPLITUDES_UM, format_table, track

    import sys

    from pysim.cosim.tracking import reference_warnings, table_iii_reference

    amplitudes = tuple(args.amplitudes or TABLE_III_AMPLITUDES_UM)
    chain = open_chain(args, step_s=args.step)
    try:
        references = {f"A = {a:g} µm": table_iii_reference(a, args.step, args.periods, args.offset, args.frequency)[1]
                      for a in amplitudes}
        warnings = reference_warnings(chain.sim, references)
        for message in warnings:
            print(f"pysim track: warning: {message}", file=sys.stderr)
        with Progress(2 * len(amplitudes), "tracking") as progress:
            rows, _ = track(chain.sim, chain.drive, amplitudes, step_s=args.step, periods=args.periods,
                            offset_um=args.offset, frequency_hz=args.frequency, progress=progress)
    finally:
        chain.close()
    if args.json:
        print(json.dumps(tracking_json(rows, args, warnings), indent=2))
    else:
        print("Tracking errors, % of the reference range (paper: compensated, measured on the rig)")
        print(format_table(rows))
    return 0
