"""``pysim bandwidth``: stepped-sine −3 dB bandwidth of the uncompensated and compensated paths."""
from __future__ import annotations

import json
import math

from pysim.cli.commands._chain import add_chain_arguments, open_chain
from pysim.cli.errors import UserError


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "bandwidth", help="measure the -3 dB bandwidth with and without the inverse compensator",
        description="Stepped-sine sweep of the co-simulated chain (reference -> [inverse FMU] -> "
                    "plant FMU -> stage) at each amplitude; the fundamental is taken by projection "
                    "over whole periods, normalised to the lowest frequency, and the -3 dB point "
                    "interpolated in log-frequency.  Uncompensated: voltage = reference / nominal gain.")
    add_sweep_arguments(parser)
    add_chain_arguments(parser)
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.set_defaults(func=run)


def add_sweep_arguments(parser) -> None:
    group = parser.add_argument_group("sweep")
    group.add_argument("--amplitudes", type=float, nargs="+", default=[7.5, 15.0, 30.0], metavar="UM",
                       help="reference amplitudes A, µm (default 7.5 15 30)")
    group.add_argument("--offset", type=float, default=37.5, metavar="UM",
                       help="reference offset, µm (default 37.5: reference = offset + A sin)")
    group.add_argument("--f-min", type=float, default=10.0, metavar="HZ", help="lowest frequency (default 10)")
    group.add_argument("--f-max", type=float, default=2000.0, metavar="HZ", help="highest frequency (default 2000)")
    group.add_argument("--points", type=int, default=40, help="log-spaced frequencies (default 40, at least 30)")
    group.add_argument("--samples-per-period", type=int, default=64, metavar="N",
                       help="communication steps per period (default 64)")


def check_sweep_arguments(args) -> None:
    if not (0 < args.f_min < args.f_max) or not all(map(math.isfinite, (args.f_min, args.f_max))):
        raise UserError(f"need 0 < --f-min < --f-max, got {args.f_min} and {args.f_max}")
    if args.points < 30:
        raise UserError(f"--points must be at least 30, got {args.points}")
    if args.samples_per_period < 16:
        raise UserError(f"--samples-per-period must be at least 16, got {args.samples_per_period}")
    bad = [a for a in args.amplitudes if not (math.isfinite(a) and a > 0)]
    if bad:
        raise UserError(f"--amplitudes must be positive, got {bad[0]}")
    if not math.isfinite(args.offset):
        raise UserError(f"--offset must be finite, got {args.offset}")


def sweep(chain, args, progress=None):
    """Run the sweeps of the command-line arguments on an open chain."""
    from pysim.cosim.bandwidth import default_frequencies, measure_bandwidth

    frequencies = default_frequencies(args.f_min, args.f_max, args.points)
    return measure_bandwidth(chain.sim, chain.drive, args.amplitudes, args.offset, frequencies,
                             samples_per_period=args.samples_per_period, progress=progress)


def format_summary(summary: dict) -> str:
    def hz(x):
        return "   none" if x is None else f"{x:7.1f}"

    lines = [f"{'A (µm)':>7}  {'uncompensated':>13}  {'compensated':>11}  {'low-f gain uncomp.':>18}",
             "-" * 56]
    for row in summary["by_amplitude"]:
        lines.append(f"{row['amplitude_um']:7.1f}  {hz(row['uncompensated']['bandwidth_hz']):>10} Hz  "
                     f"{hz(row['compensated']['bandwidth_hz']):>8} Hz  "
                     f"{row['uncompensated']['low_frequency_gain']:18.3f}")
    paper = summary["paper_bandwidth_hz"]
    lines.append(f"{'paper':>7}  {paper['uncompensated']:10.1f} Hz  {paper['compensated']:8.1f} Hz")
    if summary.get("stage_bandwidth_hz") is not None:
        lines.append(f"stage alone (control.bandwidth): {summary['stage_bandwidth_hz']:.1f} Hz")
    return "\n".join(lines)


def run(args) -> int:
    check_sweep_arguments(args)
    from pysim.cli.progress import Progress
    from pysim.cosim.bandwidth import summary

    chain = open_chain(args, sweep=True)
    try:
        with Progress(2 * len(args.amplitudes) * args.points, "sweeping") as progress:
            results = sweep(chain, args, progress)
    finally:
        chain.close()
    result = summary(results, chain.stage)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print("-3 dB bandwidth (normalised to the lowest frequency)")
        print(format_summary(result))
    return 0
