"""``pysim excite``: write a voltage record that separates causes a record
cannot tell apart (see :mod:`pysim.diagnosis.excitation`).

Either from a measured record (it is diagnosed first; the excitation separates
the set of causes it names, or covers the whole catalogue when the cause is
unambiguous) or from the actuator's range and sample rate and the causes to
separate.  The CSV has the columns ``time_s,voltage_V``: play it on the rig,
record the displacement, and diagnose that record.
"""
from __future__ import annotations

import json

from pysim.cli.commands.identify import add_data_options, load_data
from pysim.cli.errors import UserError
from pysim.cli.outputs import check_output_file


def register(subparsers) -> None:
    from pysim.diagnosis.folds import CREEP_HOLD_S

    parser = subparsers.add_parser(
        "excite", help="write a voltage CSV that separates causes a record cannot tell apart",
        description="Write a voltage record within the actuator's range (slow full-range cycles, sines at several "
                    "frequencies and amplitudes, steps held long) that separates the causes a diagnosis named "
                    "as a set. Give a measured record (diagnosed first) or --range, --sample-rate and --causes.")
    parser.add_argument("data", nargs="?", help="measured data file to diagnose first")
    parser.add_argument("--out", metavar="CSV", required=True, help="write the voltage record here")
    parser.add_argument("--causes", help="comma-separated causes to separate (default: the diagnosis' set)")
    parser.add_argument("--range", nargs=2, type=float, metavar=("LOW_V", "HIGH_V"),
                        help="the actuator's voltage range (default: the record's)")
    parser.add_argument("--samples", type=int, metavar="N", help="length of the excitation (default: the "
                        "record's, at least 6000; 20000 without a record; longer where needed to hold every step "
                        f"{CREEP_HOLD_S:g} s)")
    parser.add_argument("--validate", metavar="OTHER", help="second record for the diagnosis (as in diagnose)")
    parser.add_argument("--json", action="store_true", help="print the plan as JSON")
    add_data_options(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    from pysim.core.fileio import atomic_write_text
    from pysim.diagnosis.candidates import EFFECTS
    from pysim.diagnosis.diagnose import diagnose
    from pysim.diagnosis.excitation import samples_for_holds, separating_excitation

    out = check_output_file(args.out, "voltage record")
    causes = None
    if args.causes:
        causes = [c.strip() for c in args.causes.split(",") if c.strip()]
        unknown = [c for c in causes if c not in EFFECTS]
        if unknown or not causes:
            raise UserError(f"--causes: unknown cause(s) {unknown or args.causes!r}; the catalogue is "
                            f"{', '.join(EFFECTS)}")
    if args.samples is not None and args.samples < 2000:
        raise UserError(f"--samples must be at least 2000, got {args.samples}")
    if args.range is not None and not args.range[0] < args.range[1]:
        raise UserError(f"--range must be LOW_V HIGH_V with LOW_V < HIGH_V, got {args.range}")
    note = ""
    if args.data:
        data = load_data(args)
        rate = data.sample_rate_hz
        lo, hi = (float(data.voltage_V.min()), float(data.voltage_V.max())) if args.range is None else args.range
        n = max(data.voltage_V.size, 6000)
        parameters = {}
        if causes is None:
            other = load_data(args, args.validate) if args.validate else None
            result = diagnose(data.voltage_V, data.displacement_um, rate, source=data.source,
                              validate=None if other is None else (other.voltage_V, other.displacement_um,
                                                                   other.sample_rate_hz))
            parameters = {c: ev.fit.parameters for c, ev in result.candidates.items()}
            if len(result.causes) > 1:
                causes = list(result.causes)
                note = f"the diagnosis names the set {', '.join(causes)}"
            else:
                causes = list(EFFECTS)
                note = (f"the diagnosis names {result.cause} unambiguously; this excitation covers the whole "
                        "catalogue")
    else:
        if args.range is None or args.sample_rate is None or causes is None:
            raise UserError("without a data file give --range LOW_V HIGH_V, --sample-rate HZ and --causes")
        lo, hi = args.range
        rate = args.sample_rate
        n = 20000
        parameters = {}
    # the default length also holds every step long enough for creep to show
    n = args.samples or max(n, samples_for_holds(causes, rate))
    voltage, plan = separating_excitation(causes, (lo, hi), rate, n, candidates=parameters)
    body = "".join(f"{k / rate!r},{float(x)!r}\n" for k, x in enumerate(voltage))
    atomic_write_text(out, "time_s,voltage_V\n" + body)
    if args.json:
        print(json.dumps({"out": str(out), "causes": causes, "samples": int(voltage.size), "sample_rate_hz": rate,
                          "voltage_range_V": [lo, hi], "plan": plan, "note": note}, indent=2))
    else:
        lines = [f"excitation for {', '.join(causes)}: {voltage.size} samples at {rate:g} Hz, "
                 f"{lo:g} V to {hi:g} V, written to {out}"]
        if note:
            lines.append(f"  ({note})")
        for part in plan:
            lines.append(f"  samples {part['start_sample']}..{part['start_sample'] + part['samples'] - 1}: "
                         f"{part['purpose']}")
        print("\n".join(lines))
    return 0
