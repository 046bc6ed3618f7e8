"""``pysim track``: tracking errors for the paper's Table III references or the user's own
(sines, or a reference CSV), with and without compensation."""
from __future__ import annotations

import json
import math

from pysim.cli.commands._chain import add_chain_arguments, open_chain
from pysim.cli.errors import UserError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "track", help="tracking errors e_m and e_rms for x_d = A sin(2πt) + 37.5 µm (Table III) or your reference",
        description="Run the paper's Table III references (or sines of your amplitudes, offset and "
                    "frequency, or a reference CSV) through the co-simulated chain with and without the "
                    "inverse compensator and print e_m (max |error|) and e_rms in % of the reference "
                    "range (eq. 14-15), next to the paper's figures where they apply.  Warns when a "
                    "reference leaves the range the actuator reaches.")
    add_track_arguments(parser)
    add_chain_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.set_defaults(func=run)


def add_track_arguments(parser) -> None:
    group = parser.add_argument_group("tracking")
    group.add_argument("--step", type=float, default=None, metavar="S",
                       help="communication step, s (default 1e-4; must divide the reference's period; with "
                            "--reference the file's sample period is the step)")
    group.add_argument("--periods", type=int, default=2,
                       help="periods simulated; errors over the last one (default 2)")
    group.add_argument("--amplitudes", type=float, nargs="+", default=None, metavar="UM",
                       help="reference amplitudes A, µm (default: Table III, 7.5 15 22.5 30)")
    group.add_argument("--offset", type=float, default=37.5, metavar="UM", help="reference offset, µm (default 37.5)")
    group.add_argument("--frequency", type=float, default=1.0, metavar="HZ",
                       help="reference frequency, Hz (default 1; the step must divide its period)")
    group.add_argument("--reference", metavar="CSV",
                       help="track this reference instead of sines: a CSV with header time_s,displacement_um "
                            "(µm) on a uniform time grid, whose sample period becomes the step")
    group.add_argument("--score-from", type=float, default=0.0, metavar="S",
                       help="with --reference: take the errors from this time on, s (default 0: every sample)")


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


def load_user_reference(args) -> tuple:
    """``(reference_um, step_s, first_scored)`` of ``--reference`` (checked)."""
    import numpy as np

    from pysim.identification.data import load_reference
    from pysim.identification.errors import DataError

    if args.amplitudes:
        raise UserError("give either --reference or --amplitudes, not both")
    if args.step is not None:
        raise UserError("--step is the reference file's sample period; leave --step out with --reference")
    try:
        time, reference, rate = load_reference(args.reference)
    except DataError as exc:
        raise UserError(str(exc)) from exc
    steps = np.diff(time)
    step = 1.0 / rate
    worst = int(np.argmax(np.abs(steps - step)))
    if abs(steps[worst] - step) > 1e-6 * step:
        raise UserError(f"{args.reference}: the time grid is not uniform (step {steps[worst]:.6g} s after "
                        f"t = {time[worst]:.6g} s against a mean of {step:.6g} s); the chain steps at a fixed "
                        "period, so resample the reference")
    if not (math.isfinite(args.score_from) and time[0] <= args.score_from < time[-1]):
        raise UserError(f"--score-from must lie within the reference's time, {time[0]:g} to {time[-1]:g} s, "
                        f"got {args.score_from}")
    first = int(np.searchsorted(time, args.score_from - 1e-9 * step))
    if not np.ptp(reference[first:]) > 0:
        raise UserError(f"{args.reference}: the reference is constant from t = {time[first]:g} s on; "
                        "errors are % of its range")
    return reference, step, first


def run_reference(args) -> int:
    """``pysim track --reference CSV``."""
    import sys

    from pysim.cli.progress import Progress
    from pysim.cosim.tracking import reference_warnings, track_reference

    reference, step, first = load_user_reference(args)
    chain = open_chain(args, step_s=step)
    try:
        warnings = reference_warnings(chain.sim, {args.reference: reference})
        for message in warnings:
            print(f"pysim track: warning: {message}", file=sys.stderr)
        with Progress(2, "tracking") as progress:
            errors, _ = track_reference(chain.sim, chain.drive, reference, step, first, progress=progress)
    finally:
        chain.close()
    if args.json:
        print(json.dumps({"reference": args.reference, "samples": int(reference.size), "step_s": step,
                          "scored_from_sample": first, "measured_on": "stage displacement",
                          "warnings": warnings, "tracking": [{"reference": args.reference, **errors}]}, indent=2))
    else:
        print(f"Tracking errors for {args.reference} ({reference.size} samples at {step:g} s, scored from "
              f"sample {first}), % of the reference range")
        for path in ("uncompensated", "compensated"):
            e = errors[path]
            print(f"  {path:14s} e_m {e['max_error_pct']:8.3f} %   e_rms {e['rms_error_pct']:8.3f} %")
    return 0


def run(args) -> int:
    if getattr(args, "reference", None):
        return run_reference(args)
    if args.step is None:
        args.step = 1e-4
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
