"""``pysim identify DATA.csv``: fit MPI (and CPI for comparison), write a spec."""
from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from pysim.cli.errors import UserError
from pysim.cli.outputs import check_output_file


def add_data_options(parser) -> None:
    """Options that describe a data file's layout (shared by the data commands)."""
    group = parser.add_argument_group(
        "data layout (default: CSV with header time_s,voltage_V,displacement_um, or the quantities in other "
        "words with units, e.g. Time [ms],Voltage [V],Position [nm])")
    group.add_argument("--time-column", help="name or 1-based number of the time column (s)")
    group.add_argument("--voltage-column", help="name or 1-based number of the voltage column (V)")
    group.add_argument("--displacement-column", help="name or 1-based number of the displacement column (µm)")
    group.add_argument("--no-header", action="store_true", help="the file has no header row")
    group.add_argument("--delimiter", help="field separator (default: detected)")
    group.add_argument("--sample-rate", type=float, metavar="HZ",
                       help="sample rate when the file has no time column")
    group.add_argument("--flip-displacement", action="store_true",
                       help="negate the displacement (a sensor that counts down as the actuator extends)")


def load_data(args, path=None):
    """Load ``args.data`` (or ``path``) with the layout options of :func:`add_data_options`."""
    from pysim.identification.data import MeasuredData, load_measured

    def column(value):
        if value is None:
            return None
        return int(value) if re.fullmatch(r"\d+", value) else value

    data = load_measured(
        args.data if path is None else path, time_column=column(args.time_column), voltage_column=column(args.voltage_column),
        displacement_column=column(args.displacement_column), header=not args.no_header,
        delimiter=args.delimiter, sample_rate_hz=args.sample_rate)
    if args.flip_displacement:
        data = MeasuredData(data.time_s, data.voltage_V, -data.displacement_um, source=data.source,
                            sample_rate_hz=data.sample_rate_hz,
                            read_as=data.read_as + ("displacement_um negated (--flip-displacement)",))
    for sentence in data.read_as:  # a header in other words: say how it was read (stderr: JSON stays clean)
        print(f"{data.source}: {sentence}", file=sys.stderr)
    return data


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "identify", help="fit an MPI/CPI hysteresis model to measured data and write a spec",
        description="Fit the modified (MPI) or classical (CPI) Prandtl-Ishlinskii model with fixed "
                    "thresholds (eq. 13) by exact constrained least squares that keeps the model "
                    "invertible, print parameters and errors, and write a model spec for build-fmu.")
    parser.add_argument("data", help="measured data file")
    parser.add_argument("--model", choices=("mpi", "cpi"), default="mpi", help="model to write (default mpi)")
    parser.add_argument("--operators", type=int, default=10, metavar="N", help="number of operators (default 10)")
    parser.add_argument("--operator", choices=("osp", "play"), default="osp",
                        help="one-sided play (paper, default) or classical play operators")
    parser.add_argument("--warmup", default="auto",
                        help="'auto' (default: fit every sample, the operator state at the start estimated "
                             "with the weights) or a number of samples to leave out (model starts demagnetised)")
    parser.add_argument("--history-floor", type=float, metavar="V",
                        help="the lowest voltage the actuator was driven to before the record (e.g. 0 for a "
                             "unipolar amplifier): the estimated start state is one such a history leaves, so "
                             "the model simulated from rest (the FMUs) is the fit once the record reaches it "
                             "(default: no floor)")
    parser.add_argument("--out", metavar="SPEC", help="write the model spec (a Python file) here")
    parser.add_argument("--name", help="model name (a C identifier; default from the output file name)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    add_data_options(parser)
    parser.set_defaults(func=run)


def run(args) -> int:
    from pysim.core.spec import model_name_from_path, write_spec
    from pysim.identification.determinacy import cycle_prediction_spread
    from pysim.identification.identify import IdentificationError, identify, settling_samples

    if args.operators < 1:
        raise UserError(f"--operators must be at least 1, got {args.operators}")
    if args.warmup != "auto" and not re.fullmatch(r"\d+", str(args.warmup)):
        raise UserError(f"--warmup must be 'auto' or a whole number of samples, got {args.warmup!r}")
    name = args.name or model_name_from_path(args.out, default=f"identified_{args.model}")
    if not name.isidentifier():
        raise UserError(f"model name {name!r} is not a C identifier (use --name)")
    if args.out:
        check_output_file(args.out, "spec")
    data = load_data(args)
    warmup = "auto" if args.warmup == "auto" else int(args.warmup)

    def fit(kind, first_sample=0):
        try:
            return identify(
                data.voltage_V, data.displacement_um, n_operators=args.operators, model=kind,
                operator=args.operator, warmup=warmup, fit_slice=slice(first_sample, None), name=name,
                history_floor_V=args.history_floor,
                description=f"{kind.upper()} model identified from {Path(data.source).name} by pysim identify")
        except IdentificationError as exc:
            raise UserError(f"{data.source}: {exc}") from exc

    chosen = fit(args.model)
    transient = 0
    if warmup == "auto":
        # a logger or amplifier settling at the start that no operator state explains is left out of
        # the fit (the state at the first sample is still estimated, so nothing else changes)
        transient = settling_samples(data.displacement_um - chosen.prediction_um)
        if transient:
            chosen = fit(args.model, transient)
    _require_that_the_displacement_follows(chosen, data)
    artefacts = _record_artefacts(chosen, data, args)
    other = "cpi" if args.model == "mpi" else "mpi"
    results = {args.model: chosen, other: fit(other, transient)}
    results = {kind: results[kind] for kind in ("mpi", "cpi")}
    if args.out:
        write_spec(chosen.model, args.out,
                   header=f"{args.model.upper()} model ({args.operators} {args.operator} operators) "
                          f"identified from {Path(data.source).name} by pysim identify.\n\n"
                          f"Fit errors (% of measured range, after a warm-up of "
                          f"{chosen.warmup_samples} samples"
                          + (f" and a start transient of {transient} samples" if transient else "")
                          + f"): max {chosen.errors['max_error_pct']:.3f}, "
                          f"RMS {chosen.errors['rms_error_pct']:.3f}, mean {chosen.errors['mean_error_pct']:.3f}"
                          + (" (from the operator state estimated at the start of the record: "
                             f"{[round(float(x), 6) for x in chosen.initial_state]} V)"
                             if chosen.initial_state_estimated else "") + ".")
    spread = cycle_prediction_spread(chosen, data.voltage_V)
    if args.json:
        print(json.dumps({
            "model": args.model,
            "parameters": chosen.parameters(),
            **chosen.errors,
            "warmup_samples": chosen.warmup_samples,
            "start_excluded_samples": transient,
            "constraints_active": chosen.constraints_active,
            "identifiability": {**chosen.identifiability(), "cycle_prediction_spread_sigma": spread},
            "comparison": {kind: res.errors for kind, res in results.items()},
            "record_artefacts": artefacts,
            "spec": args.out,
        }, indent=2))
    else:
        print(format_table(chosen, results, data.source, args.out, transient, artefacts, spread))
    return 0


def _record_artefacts(chosen, data, args) -> list:
    """Spikes, jumps and flat runs of the samples fitted (:mod:`pysim.diagnosis.artefacts`), samples
    counted from the record's first.  Reported, not repaired: this is the fit of the record as given."""
    from pysim.diagnosis.artefacts import find_artefacts

    rows = chosen.fit_slice
    found = find_artefacts(data.voltage_V[rows], data.displacement_um[rows], data.sample_rate_hz,
                           n_operators=args.operators, model=args.model, operator=args.operator)
    for a in found:
        a["sample"] += rows.start
        a["time_s"] = float(data.time_s[a["sample"]])
    return found


#: Least share of the displacement's variance (over the samples fitted) that the identified model must
#: explain: a piezo actuator's hysteresis explains well over 90 %; a model that explains less than this
#: share describes a displacement that does not follow the voltage (a wrong column, a sensor that was
#: off), and its inverse would be a compensator of absurd gain.
MIN_EXPLAINED_SHARE = 0.5


def _require_that_the_displacement_follows(chosen, data) -> None:
    """A :class:`UserError` when the model ``chosen`` explains less than ``MIN_EXPLAINED_SHARE`` of the
    displacement's variance over the samples it was fitted on."""
    import numpy as np

    rows = chosen.fit_slice
    y = np.asarray(data.displacement_um, dtype=float)[rows]
    residual = y - np.asarray(chosen.prediction_um, dtype=float)[rows]
    spread = float(np.sum((y - y.mean()) ** 2))
    explained = 1.0 - float(residual @ residual) / spread if spread > 0 else 0.0
    if explained < MIN_EXPLAINED_SHARE:
        raise UserError(f"{data.source}: the displacement does not follow the voltage: the fitted "
                        f"{chosen.model.kind.upper()} model explains {100 * max(explained, 0.0):.1f} % of its "
                        f"variance (RMS error {chosen.errors['rms_error_pct']:.3g} % of its range); check the "
                        "columns (--voltage-column, --displacement-column) and the sensor")


def format_table(chosen, results, source, out, transient: int = 0, artefacts=(), spread: float = None) -> str:
    m = chosen.model
    lines = [f"{m.kind.upper()} model of {source}: {m.n_operators} {m.operator} operators, "
             f"fit on samples {chosen.fit_slice.start}..{chosen.fit_slice.stop - 1} "
             f"(warm-up {chosen.warmup_samples})",
             *([f"  samples 0..{transient - 1} left out: a start transient (a logger or amplifier settling) "
                "that no operator state explains (--warmup N chooses the samples left out instead)"] if transient else []),
             "",
             f"  a1            {m.a1: .6e} µm/V³",
             f"  a2            {m.a2: .6e} µm/V",
             f"  input offset  {m.input_offset_V: .6g} V",
             f"  output offset {m.output_offset_um: .6g} µm",
             "   i    r_i (V)        b_i (µm/V)"]
    for i, (r, b) in enumerate(zip(m.thresholds_V, m.weights_um_per_V), start=1):
        lines.append(f"  {i:2d}  {r:12.6g}  {b: .6e}")
    inv = m.check_invertibility()
    if chosen.initial_state_estimated:
        lines += ["", "  initial operator state (estimated with the weights; no warm-up left out): "
                  + ", ".join(f"{x:.4g}" for x in chosen.initial_state) + " V"]
    for i in chosen.not_identifiable_operators:
        tied = chosen.merged_into.get(i)
        lines.append(f"  operator {i + 1} (r = {m.thresholds_V[i]:.4g} V): not identifiable from this record "
                     f"(travel {chosen.operator_travel_V[i]:.3g} V)"
                     + (f"; weight density tied to operator {tied + 1}" if tied is not None else "; weight 0"))
    lines += [f"  condition number of the fit: {chosen.condition_number:.3g}"]
    if spread is not None:
        from pysim.identification.determinacy import DETERMINED_SPREAD

        lines += [f"  prediction of a full-range cycle with minor loops determined by this record to "
                  f"{spread:.3g} noise σ"
                  + ("" if spread <= DETERMINED_SPREAD else
                     f" (above {DETERMINED_SPREAD:g}: the record does not decide how this model predicts a new "
                     "input; fit fewer operators (--operators) or record an input that moves through the range "
                     "(sines or triangles rather than steps))")]
    if artefacts:
        from pysim.diagnosis.artefacts import artefact_label

        listed = [artefact_label(a) + (f" ({a['size_um']:+.3g} µm)" if a["kind"] == "jump" else "")
                  for a in artefacts]
        lines += ["", "  record artefacts (no model of an actuator explains them; they are in this fit, "
                  "`pysim diagnose` repairs spikes, jumps and hums first): " + ", ".join(listed[:8])
                  + (f", and {len(listed) - 8} more" if len(listed) > 8 else "")]
    lines += ["", f"  invertibility: {inv.message}", "",
              "  model   max err %   RMS err %   mean err %"]
    for kind, res in results.items():
        e = res.errors
        lines.append(f"  {kind.upper():5s}  {e['max_error_pct']:9.3f}  {e['rms_error_pct']:10.3f}  "
                     f"{e['mean_error_pct']:11.3f}")
    if out:
        lines += ["", f"  spec written to {out}"]
    return "\n".join(lines)
