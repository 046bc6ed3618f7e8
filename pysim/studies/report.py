"""Markdown report of a rig study (``pysim demo``)."""
from __future__ import annotations

import math

from pysim.cosim.rig import PATHS
from pysim.cosim.tracking import PAPER_TABLE_III

PAPER_BANDWIDTH_HZ = {"uncompensated": 185.0, "compensated": 884.0}


def _pct(x):
    return "–" if x is None else f"{x:.2f}"


def _hz(x):
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.0f}"


def rig_parts(rig) -> list:
    """One line per part of the rig, with its numbers."""
    amp, h = rig.amplifier, rig.plant
    hysteresis = getattr(h, "hysteresis", h)
    stages = getattr(h, "stages", None)
    creep = ""
    if stages is not None and stages.creep_time_constants_s:
        creep = (f", creep modes τ = {', '.join(f'{t:g}' for t in stages.creep_time_constants_s)} s "
                 f"({sum(stages.creep_weights_um_per_V) / hysteresis.major_loop_gain() * 100:.1f} % of the gain)")
    slew = "none" if math.isinf(amp.slew_rate_V_per_s) else f"{amp.slew_rate_V_per_s / 1e3:.1f} V/ms"
    return [
        f"- **Actuator (the truth)**: {hysteresis.n_operators} {hysteresis.operator} operators{creep}; "
        f"{h.name}: {getattr(h, 'description', '')}",
        f"- **Amplifier**: {amp.gain_V_per_V:g} V/V, small-signal bandwidth {_hz(amp.bandwidth_hz)} Hz, "
        f"{amp.current_limit_A:g} A into {amp.capacitance_F * 1e6:g} µF → slew {slew}, output "
        f"{amp.output_low_V:g}–{amp.output_high_V:g} V",
        f"- **Stage**: {rig.stage if rig.stage is None else 'python-control LTI (see the rig spec)'}",
        f"- **DAC** {rig.dac.bits} bit over {rig.dac.low:g}–{rig.dac.high:g} V (LSB {rig.dac.lsb * 1e3:.3f} mV); "
        f"**ADC** {rig.adc.bits} bit over {rig.adc.low:g}–{rig.adc.high:g} µm (LSB {rig.adc.lsb * 1e3:.2f} nm); "
        f"sensor noise {rig.noise.rms_um * 1e3:g} nm RMS",
        f"- **Controller**: {1 / rig.step_s / 1e3:g} kHz, PI kp = {rig.controller.kp_V_per_um:g} V/µm, "
        f"ki = {rig.controller.ki_V_per_um_s:g} V/(µm·s), anti-windup by conditional integration",
    ]


def table_iii_markdown(rows, paths=PATHS) -> list:
    head = "| A (µm) | " + " | ".join(f"{p} e_m / e_rms" for p in paths) + " | paper (compensated) |"
    lines = [head, "|---:|" + "---:|" * (len(paths) + 1)]
    for row in rows:
        paper = PAPER_TABLE_III.get(row["amplitude_um"])
        cells = [f"{_pct(row[p]['max_error_pct'])} / {_pct(row[p]['rms_error_pct'])}" for p in paths]
        paper_text = f"{paper['max_error_pct']:.2f} / {paper['rms_error_pct']:.2f}" if paper else "–"
        lines.append(f"| {row['amplitude_um']:g} | " + " | ".join(cells) + f" | {paper_text} |")
    return lines


def bandwidth_markdown(summary) -> list:
    lines = ["| configuration | A (µm) | −3 dB normalised (Hz) | −3 dB vs desired (Hz) | error > 10 % from (Hz) | "
             "gain at the lowest f |", "|---|---:|---:|---:|---:|---:|"]
    for path, per in summary.items():
        for amplitude, values in per.items():
            lines.append(f"| {path} | {amplitude} | {_hz(values['minus3db_normalised_hz'])} | "
                         f"{_hz(values['minus3db_vs_desired_hz'])} | {_hz(values['tracking_10pct_hz'])} | "
                         f"{values['low_frequency_gain']:.3f} |")
    return lines


def monte_carlo_markdown(monte_carlo: dict) -> list:
    """The Monte-Carlo section of the demo's report: the spread of the tracking errors and
    bandwidths over compensators drawn around the identified one (markdown lines)."""
    lines = ["## Spread over model error (Monte-Carlo)",
             f"{monte_carlo['draws']} compensators drawn around the identified one (weights "
             f"±{monte_carlo['spread']['weights'] * 100:g} %, a2 ±{monte_carlo['spread']['a2'] * 100:g} %, "
             f"a1 ±{monte_carlo['spread']['a1'] * 100:g} %, 1 σ), A = {monte_carlo['amplitude_um']:g} µm:",
             "", "| configuration | e_m 5 % / median / 95 % | e_rms 5 % / median / 95 % "
             "| −3 dB normalised (Hz) | −3 dB vs desired A (Hz) |", "|---|---|---|---|---|"]

    def spread(b):
        if b is None:
            return "not crossed"
        note = "" if b["crossed"] == monte_carlo["draws"] else f" ({b['crossed']} crossed)"
        return f"{b['p5']:.0f} / {b['median']:.0f} / {b['p95']:.0f}{note}"

    for path, s in monte_carlo["summary"].items():
        m, r = s["max_error_pct"], s["rms_error_pct"]
        lines.append(f"| {path} | {m['p5']:.2f} / {m['median']:.2f} / {m['p95']:.2f} | "
                     f"{r['p5']:.2f} / {r['median']:.2f} / {r['p95']:.2f} | "
                     + (f"{spread(s.get('minus3db_normalised_hz'))} | {spread(s.get('minus3db_vs_desired_hz'))} |"
                        if monte_carlo.get("sweep") else "— | — |"))
    if monte_carlo.get("sweep"):
        sweep = monte_carlo["sweep"]
        lines += ["", f"Bandwidths from a stepped sine of each draw at A = {monte_carlo['amplitude_um']:g} µm, "
                      f"{sweep['points']} frequencies from {sweep['f_min_hz']:.0f} to {sweep['f_max_hz']:.0f} Hz "
                      "(coarser than the sweep above, so the crossing is interpolated over wider steps)."]
    return lines


def rig_report(study, rows, bandwidths, monte_carlo, figures: dict, settings: dict, stage_facts: dict) -> str:
    """The report of ``pysim demo`` (markdown)."""
    rig = study.rig
    fit = study.identification.get("fit_errors_pct", {})
    lines = [
        f"# What compensation does on the rig `{rig.name}`",
        "",
        "The compensator was identified from a record of the simulated rig, as a user would record it on the "
        "real one: the amplifier's voltage and the sensor's reading (noise, 16-bit ADC), from a state nobody "
        f"knew. {study.identification.get('samples', 0)} samples at "
        f"{study.identification.get('sample_rate_hz', 0) / 1e3:g} kHz; {study.compensator.n_operators} operators; "
        f"fit error on that record {_pct(fit.get('max_error_pct'))} % max, {_pct(fit.get('rms_error_pct'))} % RMS. "
        "Its inverse FMU then drives the rig, whose actuator it does not mirror.",
        "",
        "## The rig",
        *rig_parts(rig),
        "",
        "## Tracking, Table III (x_d = A sin(2πt) + 37.5 µm; e_m / e_rms in % of the reference range, last period)",
        *table_iii_markdown(rows),
        "",
        f"![Tracking error]({figures['tracking']})  ![Loops]({figures['loops']})",
        "",
        "## Bandwidth (stepped sine at the rig's fixed sample rate)",
        f"Stage alone: resonance {stage_facts.get('resonance_hz', float('nan')):.0f} Hz with a "
        f"{stage_facts.get('peak_db', float('nan')):+.1f} dB peak, −3 dB point "
        f"{_hz(stage_facts.get('minus3db_hz'))} Hz (`control.bandwidth`).",
        "",
        *bandwidth_markdown(bandwidths),
        "",
        f"![Bode magnitude and phase]({figures['bode']})",
        "",
    ]
    if monte_carlo:
        lines += [*monte_carlo_markdown(monte_carlo), ""]
    lines += [
        "## What sets each number",
        "- *Uncompensated*: the hysteresis itself — loop width and the amplitude-dependent slope of minor loops "
        "against the nominal gain (the low-frequency gain column).",
        "- *Compensated*: the mismatch between the identified 10-operator model and the actuator (its "
        "continuous threshold density, its creep, noise and quantisation in the identification record); the "
        "converters and the stage's lag at 1 Hz add little.",
        "- *Feedback*: the PI loop's gain at 1 Hz (crossover near 50 Hz, limited by the stage's lightly damped "
        "resonance and five samples of loop latency) divides the hysteresis error; its −3 dB point is the "
        "loop's, not the stage's.",
        "- *Feedback + compensated*: what the loop leaves of the compensator's mismatch; sensor noise and ADC "
        "steps set the floor.",
        "- *Bandwidth*: normalised, both open-loop paths show the stage at small amplitude; at large amplitude "
        "the amplifier's current limit (slew rate I_max/C) rolls them off earlier. A rate-independent "
        "compensator moves neither: it removes the low-frequency gain error (compare the columns "
        "'vs desired').",
        "",
        "## The paper's 185 Hz → 884 Hz",
        "Normalised to the lowest frequency, compensation changes the −3 dB point by a few per cent here at "
        "every amplitude: the rig's roll-off comes from the stage and the slew-limited amplifier, which act on "
        "both paths alike. No rig parameter makes a rate-independent feedforward move a normalised −3 dB point "
        "from 185 Hz to 884 Hz. Read against the desired amplitude, the uncompensated path starts below −3 dB "
        "at small amplitudes (gain column), so its '−3 dB point' can land anywhere below the stage's — the "
        "most likely reading of the paper's 185 Hz.",
        "",
        "## Settings",
        *(f"- {key}: {value}" for key, value in settings.items()),
        "",
    ]
    return "\n".join(lines)
