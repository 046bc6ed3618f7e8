"""``pysim demo``: the paper's experiments in co-simulation, on the default model, in one command."""
from __future__ import annotations

import json
import time
from pathlib import Path

from pysim.cli.commands._chain import add_chain_arguments, open_chain
from pysim.cli.commands.bandwidth import add_sweep_arguments, check_sweep_arguments, format_summary, sweep
from pysim.cli.commands.track import add_track_arguments, check_track_arguments, tracking_json
from pysim.cli.errors import UserError

FIGURES = {"loops": "hysteresis_loops.png", "bode": "bode_magnitude.png", "tracking": "tracking_errors.png"}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo", help="build the FMUs, run tracking and bandwidth experiments, write plots and a report",
        description="The main job, no arguments needed: builds the plant and inverse FMUs of the "
                    "default model (if not cached), co-simulates them with the default flexure stage, "
                    "runs the paper's Table III tracking references and stepped-sine sweeps with and "
                    "without compensation, prints a summary and writes PNG plots, report.md and "
                    "results.json into the output folder.")
    parser.add_argument("--out", default="demo_out", metavar="DIR", help="output folder (default demo_out)")
    add_chain_arguments(parser)
    add_track_arguments(parser)
    add_sweep_arguments(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    check_track_arguments(args)
    check_sweep_arguments(args)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a folder")
    from pysim.cli.progress import Progress
    from pysim.core.fileio import atomic_write_text, staged_directory
    from pysim.cosim import plots
    from pysim.cosim.bandwidth import summary as sweep_summary
    from pysim.cosim.report import demo_report
    from pysim.cosim.tracking import TABLE_III_AMPLITUDES_UM, format_table, track

    start = time.monotonic()
    chain = open_chain(args, step_s=args.step, sweep=True)
    n_track = 2 * len(TABLE_III_AMPLITUDES_UM)
    n_sweep = 2 * len(args.amplitudes) * args.points
    try:
        with Progress(n_track + n_sweep + len(FIGURES), "tracking") as progress:
            rows, runs = track(chain.sim, chain.drive, step_s=args.step, periods=args.periods,
                               progress=progress)
            results = sweep(chain, args, progress)
            summary = sweep_summary(results, chain.stage)
            with staged_directory(out) as staging:
                progress.update(0, label="plotting")
                plots.plot_loops(runs, staging / FIGURES["loops"], periods=args.periods)
                progress.update()
                plots.plot_bode(results, staging / FIGURES["bode"], chain.stage, summary["bandwidth_hz"],
                                summary["paper_bandwidth_hz"])
                progress.update()
                plots.plot_tracking(runs, staging / FIGURES["tracking"], periods=args.periods)
                progress.update()
                settings = {
                    "plant FMU": chain.plant_path, "inverse FMU": chain.inverse_path,
                    "tracking step (s)": args.step, "tracking periods": args.periods,
                    "sweep amplitudes (µm)": args.amplitudes, "sweep offset (µm)": args.offset,
                    "sweep frequencies (Hz)": f"{args.points} log-spaced, {args.f_min:g}–{args.f_max:g}",
                    "samples per period": args.samples_per_period,
                    "stage discretisation": "Tustin, prewarped at each sweep frequency; "
                                            "plain Tustin for tracking",
                }
                atomic_write_text(staging / "report.md",
                                  demo_report(chain.model, chain.stage, rows, summary, FIGURES, settings))
                atomic_write_text(staging / "results.json", json.dumps(
                    {"tracking": tracking_json(rows, args), "bandwidth": summary}, indent=2) + "\n")
    finally:
        chain.close()
    print("Tracking errors, % of the reference range (paper: compensated, measured on the rig)")
    print(format_table(rows))
    print()
    print("-3 dB bandwidth (normalised to the lowest frequency)")
    print(format_summary(summary))
    print()
    print(f"wrote {', '.join(list(FIGURES.values()) + ['report.md', 'results.json'])} to {out}/ "
          f"in {time.monotonic() - start:.1f} s")
    return 0
