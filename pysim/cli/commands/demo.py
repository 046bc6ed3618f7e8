"""``pysim demo``: what compensation will do on a rig, in one command.

The default rig (``rig_default``) has an actuator the compensator does not
mirror.  The demo records identification data on it, identifies the
compensator, builds its inverse FMU, and co-simulates it against the rig open
loop and closed loop: Table III beside the paper, stepped-sine bandwidths of
every configuration at two amplitudes, and the spread over model error.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

from pysim.cli.errors import UserError

FIGURES = {"bode": "bode.png", "tracking": "tracking_error.png", "loops": "loops.png"}
DEFAULT_RIG = "rig_default"


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "demo", help="identify a compensator on a simulated rig, co-simulate it open and closed loop",
        description="The main job, no arguments needed: records identification data on the default rig "
                    "(an actuator with a continuous threshold density and creep, a current-limited "
                    "amplifier, 16-bit converters, sensor noise, a PI loop), identifies the MPI "
                    "compensator, builds its inverse FMU and co-simulates it against the rig: Table III "
                    "for the paths uncompensated, compensated, feedback and feedback+compensated beside "
                    "the paper, stepped-sine bandwidths, and a Monte-Carlo over model error.  Writes "
                    "PNG plots, report.md and results.json into the output folder.")
    parser.add_argument("--out", default="demo_out", metavar="DIR", help="output folder (default demo_out)")
    parser.add_argument("--rig", default=DEFAULT_RIG, metavar="SPEC",
                        help=f"rig spec: a .py file or module defining RIG (default {DEFAULT_RIG})")
    parser.add_argument("--amplitudes", type=float, nargs="+", default=[7.5, 30.0], metavar="UM",
                        help="sweep amplitudes, µm (default 7.5 30)")
    parser.add_argument("--points", type=int, default=30, help="sweep frequencies, 10 Hz to 2 kHz (default 30)")
    parser.add_argument("--monte-carlo", type=int, default=10, metavar="N",
                        help="compensators drawn around the identified one (default 10; 0: none)")
    parser.add_argument("--ssp-platforms", nargs="+", default=None, metavar="PLATFORM",
                        choices=["linux64", "win64", "darwin64"],
                        help="binaries in the FMUs of rig.ssp (default: this machine's; give linux64 win64 "
                             "darwin64 for an SSP to hand on)")
    parser.add_argument("--record", default=None, metavar="NAME", choices=["discrete_backlash", "smart_hysteresis"],
                        help="also predict compensation on the actuator of a shipped record: its compensator "
                             "against the extended plant its diagnosis builds (adds about 20 s)")
    parser.set_defaults(func=run)


def run(args) -> int:
    out = _checked_out_folder(args)
    import control

    from pysim.cli.progress import Progress
    from pysim.core.fileio import atomic_write_text, staged_directory
    from pysim.cosim import plots
    from pysim.cosim.rig import PATHS, load_rig
    from pysim.cosim.tracking import TABLE_III_AMPLITUDES_UM
    from pysim.studies.report import rig_report
    from pysim.studies.rig_study import RigStudy, bandwidth_summary

    start = time.monotonic()
    rig = load_rig(args.rig)
    n_sweep = len(args.amplitudes) * len(PATHS) * args.points
    with Progress(len(TABLE_III_AMPLITUDES_UM) * len(PATHS) + n_sweep + args.monte_carlo + 3,
                  "identifying the compensator on the rig") as progress:
        study = RigStudy.identify_on(rig)
        progress.update(0, label="tracking")
        runs = {}
        with study.simulation() as sim:
            rows = study.table_iii(sim=sim, runs=runs, progress=progress)
            progress.update(0, label="sweeping")
            sweeps = study.sweeps(args.amplitudes, points=args.points, sim=sim, progress=progress)
        bandwidths = bandwidth_summary(sweeps)
        monte_carlo = None
        if args.monte_carlo:
            progress.update(0, label="Monte-Carlo")
            monte_carlo = study.monte_carlo(args.monte_carlo, progress=progress)
        stage_facts = _stage_facts(rig.stage, control)
        with staged_directory(out) as staging:
            progress.update(0, label="plotting")
            plots.plot_rig_bode(sweeps, staging / FIGURES["bode"], rig.stage, bandwidths)
            progress.update()
            plots.plot_rig_tracking(runs, staging / FIGURES["tracking"], 15.0)
            progress.update()
            plots.plot_rig_loops(runs, staging / FIGURES["loops"], 15.0)
            progress.update()
            settings = {"rig": args.rig, "sample period (s)": rig.step_s, "compensator": study.compensator.name,
                        "sweep amplitudes (µm)": args.amplitudes, "sweep points": args.points,
                        "Monte-Carlo draws": args.monte_carlo}
            atomic_write_text(staging / "report.md", rig_report(study, rows, bandwidths, monte_carlo, FIGURES,
                                                                 settings, stage_facts))
            results = {"rig": rig.name, "identification": study.identification,
                       "compensator": {"a1": study.compensator.a1, "a2": study.compensator.a2,
                                       "thresholds_V": list(study.compensator.thresholds_V),
                                       "weights_um_per_V": list(study.compensator.weights_um_per_V)},
                       "tracking": rows, "bandwidth": bandwidths, "stage": stage_facts,
                       "monte_carlo": None if monte_carlo is None else
                       {k: v for k, v in monte_carlo.items() if k != "runs"}}
            atomic_write_text(staging / "results.json", json.dumps(results, indent=2) + "\n")
            if args.record:
                progress.update(0, label=f"record {args.record}")
                record = _record_section(args.record, staging, plots)
                results["record"] = record["json"]
                atomic_write_text(staging / "results.json", json.dumps(results, indent=2) + "\n")
                atomic_write_text(staging / "report.md", (staging / "report.md").read_text() + record["markdown"])
            progress.update(0, label="writing rig.ssp")
            from pysim.cosim.ssp import write_rig_ssp

            write_rig_ssp(rig, study.compensator, staging / "rig.ssp", "feedback+compensated",
                          platforms=args.ssp_platforms)
    _print_summary(rig, study, rows, bandwidths, stage_facts, monte_carlo)
    print(f"wrote {', '.join(list(FIGURES.values()) + ['report.md', 'results.json', 'rig.ssp'])} to {out} "
          f"in {time.monotonic() - start:.1f} s")
    return 0


def _checked_out_folder(args) -> Path:
    """The output folder, after checking every argument (one clear message for the first bad one)."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: exists and is not a folder")
    if args.points < 10:
        raise UserError(f"--points must be at least 10, got {args.points}")
    if args.monte_carlo < 0:
        raise UserError(f"--monte-carlo must be 0 or more, got {args.monte_carlo}")
    bad = [a for a in args.amplitudes if not (math.isfinite(a) and 0 < a <= 37.5)]
    if bad:
        raise UserError(f"--amplitudes must lie in (0, 37.5] µm around the 37.5 µm offset, got {bad[0]}")
    return out


def _print_summary(rig, study, rows, bandwidths, stage_facts, monte_carlo) -> None:
    """The demo's results on the terminal: identification, Table III, bandwidths, Monte-Carlo."""
    from pysim.studies.report import table_iii_markdown

    print(f"Compensator identified on the rig {rig.name}: {study.identification['samples']} samples, "
          f"fit RMS error {study.identification['fit_errors_pct']['rms_error_pct']:.3f} %")
    print()
    print("Tracking errors e_m / e_rms, % of the reference range (x_d = A sin(2πt) + 37.5 µm)")
    print("\n".join(table_iii_markdown(rows)))
    print()
    print("-3 dB bandwidth (Hz, normalised / against the desired amplitude)")
    for path, per in bandwidths.items():
        cells = [f"A={a}: {_hz(v['minus3db_normalised_hz'])} / {_hz(v['minus3db_vs_desired_hz'])}"
                 for a, v in per.items()]
        print(f"  {path:22s} " + "   ".join(cells))
    print(f"  stage alone: resonance {stage_facts['resonance_hz']:.0f} Hz ({stage_facts['peak_db']:+.1f} dB), "
          f"-3 dB {_hz(stage_facts['minus3db_hz'])} Hz")
    if monte_carlo:
        for path, s in monte_carlo["summary"].items():
            band = s.get("minus3db_normalised_hz")
            print(f"  Monte-Carlo {path}: e_rms median {s['rms_error_pct']['median']:.2f} % "
                  f"(5-95 %: {s['rms_error_pct']['p5']:.2f}-{s['rms_error_pct']['p95']:.2f})"
                  + (f", -3 dB median {band['median']:.0f} Hz (5-95 %: {band['p5']:.0f}-{band['p95']:.0f})"
                     if band else ""))
    print()
    print("rig.ssp: the rig (feedback + compensated) as connected FMUs, for fmpy.ssp.simulate_ssp or your tool")


def _record_section(name, staging, plots) -> dict:
    """Co-simulate a shipped record's compensator against its extended plant;
    write the two figures, return the report section and the JSON."""
    from pysim.studies.record_study import record_study

    r = record_study(name)
    amplitude = r["reference"]["amplitude_um"]
    runs = {(amplitude, path): run for path, run in r["runs"].items()}
    periods = 3
    title = (f"{name}: x_d = {amplitude:.3g} µm · sin(2π·{r['frequency_hz']:.3g}·t) "
             f"{r['reference']['middle_um']:+.4g} µm")
    plots.plot_rig_tracking(runs, staging / f"record_{name}_tracking.png", amplitude, periods, title)
    plots.plot_rig_loops(runs, staging / f"record_{name}_loops.png", amplitude, periods, title)
    stages = getattr(r["plant"], "stages", None)
    lines = ["", f"## On the actuator of the record `{name}`",
             f"Compensator: the MPI model identified from the record. Plant: the extended model its diagnosis "
             f"builds (cause `{r['cause']}`; output stages: {stages if stages is not None else 'none'}), at the "
             f"record's {1 / r['rig'].step_s:g} Hz with its noise ({r['rig'].noise.rms_um * 1e3:.0f} nm) and an "
             f"integral loop (ki = {r['rig'].controller.ki_V_per_um_s:.3g} V/(µm·s)).", "",
             "| configuration | e_m (%) | e_rms (%) |", "|---|---:|---:|"]
    for path, e in r["tracking"].items():
        lines.append(f"| {path} | {e['max_error_pct']:.2f} | {e['rms_error_pct']:.2f} |")
    lines += ["", f"![Tracking error](record_{name}_tracking.png)  ![Loops](record_{name}_loops.png)", ""]
    print(f"Record {name}: " + ", ".join(f"{p} e_rms {e['rms_error_pct']:.2f} %" for p, e in r["tracking"].items()))
    return {"markdown": "\n".join(lines),
            "json": {"record": name, "cause": r["cause"], "frequency_hz": r["frequency_hz"],
                     "reference": r["reference"], "tracking": r["tracking"]}}


def _hz(x):
    return "-" if x is None else f"{x:.0f}"


def _stage_facts(stage, control) -> dict:
    """Resonance frequency and peak of the stage, and its -3 dB point."""
    import numpy as np

    if stage is None:
        return {"resonance_hz": math.nan, "peak_db": 0.0, "minus3db_hz": None}
    f = np.geomspace(1.0, 1e5, 4000)
    g = np.abs(np.asarray(stage(2j * math.pi * f)).ravel())
    i = int(np.argmax(g))
    dc = abs(float(control.dcgain(stage)))
    bandwidth = float(control.bandwidth(stage)) / (2 * math.pi)
    return {"resonance_hz": float(f[i]), "peak_db": float(20 * np.log10(g[i] / dc)),
            "minus3db_hz": bandwidth if math.isfinite(bandwidth) else None}
