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


def check_track_arguments(args) -> None:
    if not (math.isfinite(args.step) and 0 < args.step <= 0.125):
        raise UserError(f"--step must be between 0 and 0.125 s, got {args.step}")
    if not math.isclose(round(1.0 / args.step) * args.step, 1.0, rel_tol=1e-9):
        raise UserError(f"--step {args.step} s does not divide the 1 s period into whole steps")
    if args.periods < 2:
        raise UserError(f"--periods must be at least 2, got {args.periods}")


def tracking_json(rows, args) -> dict:
    return {"reference": "x_d = A sin(2 pi t) + 37.5 um", "measured_on": "stage displacement, last period",
            "step_s": args.step, "periods": args.periods,
            "error_definitions": {"max_error_pct": "max |x_d - x| / range(x_d) * 100 (eq. 15)",
                                  "rms_error_pct": "rms(x_d - x) / range(x_d) * 100 (eq. 14)"},
            "tracking": rows}


def run(args) -> int:
    check_track_arguments(args)
    from pysim.cli.progress import Progress
    from pysim.cosim.tracking import TABLE_III_AMPLITUDES_UM, format_table, track

    chain = open_chain(args, step_s=args.step)
    try:
        with Progress(2 * len(TABLE_III_AMPLITUDES_UM), "tracking") as progress:
            rows, _ = track(chain.sim, chain.drive, step_s=args.step, periods=args.periods, progress=progress)
    finally:
        chain.close()
    if args.json:
        print(json.dumps(tracking_json(rows, args), indent=2))
    else:
        print("Tracking errors, % of the reference range (paper: compensated, measured on the rig)")
        print(format_table(rows))
    return 0
