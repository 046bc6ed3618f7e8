"""The report of ``pysim diagnose``: PNG plots and a markdown summary.

``write_report(diagnosis, folder)`` writes, all or nothing:

- ``summary.md``: the cause, why it wins, the gain, every candidate's evidence,
  the residual statistics, and how to read each plot;
- ``diagnosis.json``: the same as ``pysim diagnose --json``;
- ``overview.png``: input, measured and simulated displacement, residuals over time,
  and the record's artefacts (spikes, jumps, flat runs) marked (a hum is said in the summary);
- ``loops.png``: held-out hysteresis loops, measured against both models;
- ``residual_vs_rate.png``, ``residual_vs_time_since_change.png``,
  ``cross_correlation.png``, ``spectrum.png``: the residual from each angle of
  :mod:`pysim.diagnosis.residuals`;
- ``candidates.png``: held-out RMS error of every candidate against the baseline
  and the noise level.

Figures are drawn with matplotlib's object API on the Agg canvas (no GUI, no
global pyplot state).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pysim.core.fileio import staged_directory
from pysim.diagnosis.artefacts import KIND_PLURALS
from pysim.diagnosis.result import Diagnosis
from pysim.diagnosis.residuals import binned_mean, cross_correlation, spectrum, time_since_change
from pysim.diagnosis.rules import MIN_GAIN_PCT, NEAR_NOISE_BATCHES, NEAR_NOISE_FRACTION, NEAR_NOISE_T, NOISE_FRACTION

BASE_COLOUR, EXTENDED_COLOUR, MEASURED_COLOUR = "tab:red", "tab:blue", "black"
MAX_SCATTER = 6000
#: A title line longer than this (characters) is broken before the gain: the overview's title
#: holds about 150 characters of its font on one line.
TITLE_LINE_CHARS = 100

PLOTS = {
    "overview.png": "input (top), measured and simulated displacement (middle) and the residuals "
                    "(bottom) over the whole record; the shaded part is the last cross-validation block. A residual that "
                    "the extended model flattens is the effect that was named. Lines and bands mark what no "
                    "model of an actuator explains (spikes, jumps, flat runs of the sensor), if any; a mains hum, "
                    "which runs through the whole record, is said in the summary, not marked.",
    "loops.png": "held-out hysteresis loops: measured against the baseline and the extended model. "
                 "Loops that the baseline makes too narrow or too wide at some rates point to dynamics "
                 "or a delay; loops that move from cycle to cycle point to creep or drift.",
    "residual_vs_rate.png": "residual against the input rate dv/dt. A sloped cloud means the error "
                            "follows the rate: a delay or lag (slope ≈ −delay × gain).",
    "residual_vs_time_since_change.png": "residual, signed by the direction of the last input change, "
                                         "against the time since that change (log scale). Creep keeps "
                                         "growing over decades of time; dynamics and delays die out "
                                         "within a few time constants.",
    "cross_correlation.png": "lagged cross-correlation of the residual with the input and with its "
                             "rate. Peaks near zero lag: the error is tied to the input; none: drift "
                             "or noise.",
    "spectrum.png": "power spectrum of the residuals with the white-noise floor. Drift piles up at "
                    "the lowest frequencies, ringing as a peak between the input's harmonics, an "
                    "unexplained loop shape on the harmonics.",
    "candidates.png": "held-out RMS error of every candidate extension against the baseline; the "
                      "named cause is the best significant one.",
}


def _canvas(width_in, height_in):
    figure = Figure(figsize=(width_in, height_in), dpi=110, layout="constrained")
    FigureCanvasAgg(figure)
    return figure


def _thin(n: int, limit: int = MAX_SCATTER) -> np.ndarray:
    return np.arange(n) if n <= limit else np.linspace(0, n - 1, limit).astype(int)


def _smoothing_window(d: Diagnosis) -> int:
    """Samples of the moving average that shows the residual's structure
    through the noise: 1/200 of an input period, at least 1 and at most 1 % of
    the record."""
    f_in = d.statistics["baseline"]["input_frequency_hz"]
    period = 1.0 / (f_in * d.sample_period_s) if f_in > 0 else d.time_s.size / 20
    return int(max(1, min(period / 200.0, d.time_s.size / 100)))


def _smooth(x, window: int):
    if window <= 1:
        return np.asarray(x, dtype=float)
    kernel = np.ones(window) / window
    padded = np.pad(np.asarray(x, dtype=float), (window // 2, window - 1 - window // 2), mode="edge")
    return np.convolve(padded, kernel, mode="valid")


def _shade(ax, d: Diagnosis):
    t = d.time_s
    ax.axvspan(t[d.split.split], t[-1], color="0.92", zorder=0, lw=0)
    if d.split.warmup > 0:
        ax.axvspan(t[0], t[d.split.warmup], color="0.97", zorder=0, lw=0, hatch="//", ec="0.85")


def _explaining(d: Diagnosis):
    """The extended model whose residual the plots show: the one delivered, or the named cause's
    when its model was held back (it explains the record fitted, and predicts the second worse)."""
    return d.candidates[d.withheld] if d.withheld else d.extended


def _labels(d: Diagnosis):
    return (f"baseline MPI (cross-validated RMS {d.baseline.rms_pct:.3g} %)",
            f"extended: {_explaining(d).cause if d.cause != 'none' else 'none (= baseline)'} "
            + ("(not delivered; " if d.withheld else "(")
            + f"cross-validated RMS {_explaining(d).rms_pct:.3g} %)")


#: Colour of each kind of record artefact in the overview.
ARTEFACT_COLOURS = {"spike": "tab:red", "jump": "tab:purple", "clipped": "tab:brown", "stuck": "tab:brown"}


def _mark_artefacts(axes, d: Diagnosis):
    """The first record's artefacts (:mod:`pysim.diagnosis.artefacts`): a line at a spike or a jump, a band
    over a flat run, and one label per kind."""
    labelled = set()
    # a hum runs through the whole record: said in the why, not marked at a time
    for a in (a for a in d.artefacts if a["record"] == "first" and a["kind"] != "hum"):
        colour = ARTEFACT_COLOURS[a["kind"]]
        label = None
        if a["kind"] not in labelled:
            label = a["kind"] + (" (repaired)" if a["repaired"] else "")
            labelled.add(a["kind"])
        for i, ax in enumerate(axes):
            if a["kind"] in ("clipped", "stuck"):
                ax.axvspan(a["time_s"], a["time_s"] + a["samples"] * d.sample_period_s, color=colour, alpha=0.3,
                           lw=0, label=label if i == 0 else None)
            else:
                ax.axvline(a["time_s"], color=colour, lw=0.8, alpha=0.7, label=label if i == 0 else None)


def plot_overview(d: Diagnosis, path: Path):
    fig = _canvas(11, 8)
    axes = fig.subplots(3, 1, sharex=True, height_ratios=[1, 1.4, 1.4])
    t = d.time_s
    base_label, ext_label = _labels(d)
    for ax in axes:
        _shade(ax, d)
    axes[0].plot(t, d.voltage_V, color="0.3", lw=0.8)
    axes[0].set_ylabel("voltage (V)")
    named = (f"cause named {d.cause}" if len(d.causes) <= 1 else
             f"set named {{{', '.join(d.causes)}}}, model delivered: {d.cause}")
    headline = f"{Path(d.source).name if d.source else 'record'}: {named}"
    axes[0].set_title(headline + ("\n" if len(headline) > TITLE_LINE_CHARS else ", ")
                      + f"cross-validated gain {_explaining(d).gain_pct:.1f} %"
                      + (" (its model is not delivered)" if d.withheld else "")
                      + ("\n(the baseline fitted on the whole record, the extended model on it and the second record;"
                         "\n" if d.fitted_on_both_records else "\n(models fitted on the whole record; ")
                      + "every block is held out in turn for the scores, grey: the last block)", fontsize=10)
    repaired = sorted({KIND_PLURALS[a["kind"]] for a in d.artefacts if a["repaired"] and a["record"] == "first"})
    axes[1].plot(t, d.displacement_um, color=MEASURED_COLOUR, lw=0.8,
                 label="measured" + (f" ({' and '.join(repaired)} repaired)" if repaired else ""))
    _mark_artefacts(axes[1:], d)
    axes[1].plot(t, d.baseline.prediction_um, color=BASE_COLOUR, lw=0.8, ls="--", label=base_label)
    if d.cause != "none":
        axes[1].plot(t, _explaining(d).prediction_um, color=EXTENDED_COLOUR, lw=0.8, ls=":", label=ext_label)
    axes[1].set_ylabel("displacement (µm)")
    axes[1].legend(loc="upper right", fontsize=8)
    base_res = d.displacement_um - d.baseline.prediction_um
    window = _smoothing_window(d)
    axes[2].plot(t, base_res, color=BASE_COLOUR, lw=0.4, alpha=0.25)
    axes[2].plot(t, _smooth(base_res, window), color=BASE_COLOUR, lw=1.0, label="residual, baseline")
    if d.cause != "none":
        ext_res = d.displacement_um - _explaining(d).prediction_um
        axes[2].plot(t, ext_res, color=EXTENDED_COLOUR, lw=0.4, alpha=0.25)
        axes[2].plot(t, _smooth(ext_res, window), color=EXTENDED_COLOUR, lw=1.0, label="residual, extended")
    for sign in (-2, 2):
        axes[2].axhline(sign * d.noise_um, color="0.4", lw=0.8, ls=":")
    span = max(np.max(np.abs(base_res[d.split.warmup:])), 4 * d.noise_um)
    axes[2].set_ylim(-1.1 * span, 1.1 * span)
    axes[2].set_ylabel("measured − model (µm)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(loc="upper right", fontsize=8, title_fontsize=8,
                   title=(f"bold: moving average of {window} samples; faint: raw\n" if window > 1 else "")
                   + f"dotted: ±2σ noise (σ = {d.noise_um:.3g} µm)")
    fig.savefig(path)


def plot_loops(d: Diagnosis, path: Path):
    fig = _canvas(11, 5)
    axes = fig.subplots(1, 2)
    held = d.split.heldout
    v, y = d.voltage_V[held], d.displacement_um[held]
    base_label, ext_label = _labels(d)
    axes[0].plot(v, y, color=MEASURED_COLOUR, lw=0.8, label="measured")
    axes[0].plot(v, d.baseline.prediction_um[held], color=BASE_COLOUR, lw=0.8, ls="--", label=base_label)
    if d.cause != "none":
        axes[0].plot(v, _explaining(d).prediction_um[held], color=EXTENDED_COLOUR, lw=0.8, ls=":",
                     label=ext_label)
    axes[0].set_xlabel("voltage (V)")
    axes[0].set_ylabel("displacement (µm)")
    axes[0].set_title("held-out loops", fontsize=10)
    axes[0].legend(fontsize=8)
    window = _smoothing_window(d)
    for model, colour, label in ((d.baseline, BASE_COLOUR, "baseline"),
                                 (_explaining(d), EXTENDED_COLOUR, "extended")):
        if model is _explaining(d) and d.cause == "none":
            continue
        residual = (d.displacement_um - model.prediction_um)
        axes[1].plot(v, _smooth(residual, window)[held], color=colour, lw=0.8, label=label)
    axes[1].set_xlabel("voltage (V)")
    axes[1].set_ylabel("measured − model (µm)")
    axes[1].set_title("held-out residual against the input"
                      + (f"\n(moving average of {window} samples)" if window > 1 else ""), fontsize=10)
    axes[1].legend(fontsize=8)
    fig.savefig(path)


def _binned_plot(ax, x, residual, edges, colour, label, log_x=False):
    mean, counts = binned_mean(x, residual, edges)
    centres = np.sqrt(edges[:-1] * edges[1:]) if log_x else 0.5 * (edges[:-1] + edges[1:])
    ok = counts >= 5
    ax.plot(centres[ok], mean[ok], "o-", color=colour, ms=4, lw=1.5, label=label)


def plot_rate(d: Diagnosis, path: Path):
    fig = _canvas(8, 5)
    ax = fig.subplots()
    held = d.split.heldout
    rate = np.gradient(d.voltage_V, d.sample_period_s)[held]
    base = (d.displacement_um - d.baseline.prediction_um)[held]
    ext = (d.displacement_um - _explaining(d).prediction_um)[held]
    pick = _thin(rate.size)
    ax.scatter(rate[pick], base[pick], s=3, color=BASE_COLOUR, alpha=0.25, lw=0)
    lo, hi = np.percentile(rate, [0.5, 99.5])
    edges = np.linspace(lo, hi, 25) if hi > lo else np.array([lo - 1, hi + 1])
    _binned_plot(ax, rate, base, edges, BASE_COLOUR, "baseline (binned mean)")
    if d.cause != "none":
        _binned_plot(ax, rate, ext, edges, EXTENDED_COLOUR, "extended (binned mean)")
    ax.axhline(0, color="0.5", lw=0.8)
    stats = d.statistics["baseline"]
    ax.set_title(f"held-out residual against input rate (correlation {stats['rate_correlation']:+.2f})",
                 fontsize=10)
    ax.set_xlabel("input rate dv/dt (V/s)")
    ax.set_ylabel("measured − model (µm)")
    ax.legend(fontsize=8)
    fig.savefig(path)


def plot_time_since_change(d: Diagnosis, path: Path):
    fig = _canvas(8, 5)
    ax = fig.subplots()
    held = d.split.heldout
    v = d.voltage_V[held]
    tolerance = 0.005 * float(np.ptp(v)) if np.ptp(v) > 0 else 0.0
    elapsed, sign = time_since_change(v, d.sample_period_s, tolerance)
    base = (d.displacement_um - d.baseline.prediction_um)[held] * sign
    ext = (d.displacement_um - _explaining(d).prediction_um)[held] * sign
    ok = np.isfinite(elapsed) & (elapsed > 0)
    if np.count_nonzero(ok) > 10:
        pick = _thin(np.count_nonzero(ok))
        ax.scatter(elapsed[ok][pick], base[ok][pick], s=3, color=BASE_COLOUR, alpha=0.2, lw=0)
        edges = np.geomspace(np.min(elapsed[ok]), np.max(elapsed[ok]) * 1.0001, 25)
        _binned_plot(ax, elapsed, base, edges, BASE_COLOUR, "baseline (binned mean)", log_x=True)
        if d.cause != "none":
            _binned_plot(ax, elapsed, ext, edges, EXTENDED_COLOUR, "extended (binned mean)", log_x=True)
        ax.set_xscale("log")
        ax.legend(fontsize=8)
    else:
        ax.text(0.5, 0.5, "no input change in the held-out part", ha="center", transform=ax.transAxes)
    ax.axhline(0, color="0.5", lw=0.8)
    stats = d.statistics["baseline"]
    ax.set_title("held-out residual × direction of the last input change "
                 f"(correlation with ln t: {stats['creep_log_correlation']:+.2f})", fontsize=10)
    ax.set_xlabel("time since the last input change (reversal or step) (s)")
    ax.set_ylabel("signed residual (µm)")
    fig.savefig(path)


def plot_cross_correlation(d: Diagnosis, path: Path):
    fig = _canvas(11, 4.5)
    axes = fig.subplots(1, 2, sharey=True)
    held = d.split.heldout
    v = d.voltage_V[held]
    rate = np.gradient(d.voltage_V, d.sample_period_s)[held]
    max_lag = int(min(v.size // 4, max(10, round(0.05 * v.size))))
    for ax, signal, name in ((axes[0], v, "input v"), (axes[1], rate, "input rate dv/dt")):
        for model, colour, label in ((d.baseline, BASE_COLOUR, "baseline"),
                                     (_explaining(d), EXTENDED_COLOUR, "extended")):
            if model is _explaining(d) and d.cause == "none":
                continue
            lags, rho = cross_correlation((d.displacement_um - model.prediction_um)[held], signal, max_lag)
            ax.plot(lags * d.sample_period_s * 1e3, rho, color=colour, lw=1, label=label)
        ax.axhline(0, color="0.5", lw=0.8)
        ax.axvline(0, color="0.5", lw=0.8)
        ax.set_title(f"residual vs {name}", fontsize=10)
        ax.set_xlabel("lag (ms; > 0: residual follows the input)")
        ax.legend(fontsize=8)
    axes[0].set_ylabel("normalised cross-correlation")
    fig.savefig(path)


def plot_spectrum(d: Diagnosis, path: Path):
    fig = _canvas(8, 5)
    ax = fig.subplots()
    held = d.split.heldout
    fs = 1.0 / d.sample_period_s
    for model, colour, label in ((d.baseline, BASE_COLOUR, "baseline"),
                                 (_explaining(d), EXTENDED_COLOUR, "extended")):
        if model is _explaining(d) and d.cause == "none":
            continue
        f, p = spectrum((d.displacement_um - model.prediction_um)[held], fs)
        ax.loglog(f[1:], p[1:], color=colour, lw=1, label=f"residual, {label}")
    ax.axhline(2.0 * d.noise_um**2 / fs, color="0.4", ls=":", label="white-noise floor (σ estimate)")
    f_in = d.statistics["baseline"]["input_frequency_hz"]
    if f_in > 0:
        ax.axvline(f_in, color="0.6", ls="--", lw=0.8, label=f"input frequency {f_in:.3g} Hz")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("power spectral density (µm²/Hz)")
    ax.set_title("held-out residual spectrum", fontsize=10)
    ax.legend(fontsize=8)
    fig.savefig(path)


def plot_candidates(d: Diagnosis, path: Path):
    fig = _canvas(8, 4.5)
    ax = fig.subplots()
    names = ["baseline"] + list(d.candidates)
    values = [d.baseline.rms_pct] + [ev.rms_pct for ev in d.candidates.values()]
    colours = ["0.6"] + [EXTENDED_COLOUR if c == d.cause else ("tab:cyan" if ev.significant else "0.8")
                         for c, ev in d.candidates.items()]
    bars = ax.bar(names, values, color=colours)
    for bar, (name, value) in zip(bars, zip(names, values)):
        gain = "" if name == "baseline" else f"\n{d.candidates[name].gain_pct:+.0f} %"
        ax.annotate(f"{value:.3g} %{gain}", (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                    ha="center", va="bottom", fontsize=8)
    span = d.heldout_span_um
    if span > 0:
        ax.axhline(100 * d.noise_um / span, color="0.3", ls=":", label="noise level σ")
    ax.set_ylabel("held-out RMS error (% of range)")
    ax.set_ylim(0, 1.25 * max(values))
    ax.set_title(f"candidates (dark blue: named, {d.cause}; light blue: significant; grey: not)",
                 fontsize=10)
    ax.legend(fontsize=8)
    fig.savefig(path)


def summary_markdown(d: Diagnosis) -> str:
    """The report's markdown text."""
    j = d.as_json()
    ev = j["evidence"]
    split = ev["split"]
    lines = [
        f"# Model discrepancy: {d.source or 'record'}",
        "",
        (f"**Named set: {', '.join(f'`{c}`' for c in d.causes)}; the model delivered is "
         + ("the plain fit.**" if d.withheld else f"`{d.cause}`'s.**")
         if len(d.causes) > 1 else f"**Cause named: `{d.cause}`"
         + ("; the model delivered is the plain fit.**" if d.withheld else ".**")) + f" {d.why}.",
        "",
        "| model | cross-validated max error (% of range) | cross-validated RMS error (% of range) |"
        + (" second record RMS (%) |" if d.validation else ""),
        "| --- | ---: | ---: |" + (" ---: |" if d.validation else ""),
    ]
    for cause, rms, mx, gain, val in d.table():
        label = {"baseline": "baseline MPI", "richer": "richer rate-independent"}.get(cause, cause)
        lines.append(f"| {label} | {mx:.3f} | {rms:.3f} |" + (f" {val:.3f} |" if val is not None else ""))
    lines += [
        "",
        _delivered_sentence(d),
        "",
        "## Data and scoring",
        "",
        f"- {split['n_samples']} samples at {ev['sample_rate_hz']:.6g} Hz; no warm-up: the operator state at the "
        f"start is estimated with the weights"
        + (f" ({ev['start_excluded_samples']} samples of a start transient no state explains were left out)"
           if ev.get("start_excluded_samples") else "") + ".",
        f"- Blocked cross-validation over {len(d.folds)} blocks: each block held out in turn, every model refitted "
        f"on the others and scored where the input stays inside their range ({d.scored_samples} samples scored).",
        f"- Noise level σ = {d.noise_um:.4g} µm ({ev['noise_pct']:.3g} % of the range), from the "
        f"sample-to-sample differences of the residuals (smallest over all models).",
        f"- A candidate is significant when it removes at least {NOISE_FRACTION} σ² of mean-square error and "
        f"{MIN_GAIN_PCT:.0f} % of the RMS error against the baseline *and* the richer rate-independent model "
        f"-- or, near the noise, at least {NEAR_NOISE_FRACTION} σ² and half of what the better of them leaves "
        f"above the noise, with a removal that holds across the record ({NEAR_NOISE_BATCHES} batch means, "
        f"{NEAR_NOISE_T:g} standard errors).",
        "",
    ]
    lines += _second_record_lines(d) + _excitation_lines(d) + _candidates_and_statistics_lines(d, ev)
    lines += ["", "## Plots", ""]
    for name, text in PLOTS.items():
        lines.append(f"- [`{name}`]({name}): {text}")
    lines.append("")
    return "\n".join(lines)


def _delivered_sentence(d: Diagnosis) -> str:
    """The report's sentence on the model delivered (and what the steps show of it)."""
    if d.withheld:
        delivered = f"Model delivered: the plain fit (`{d.withheld}`'s model predicts the second record worse)"
    elif d.extended.cause == "baseline" and (d.general_model or {}).get("cause") == d.cause != "none":
        delivered = (f"Model delivered: the plain fit (`{d.cause}` is named by the general model on the record's "
                     "two halves; its MPI model, fitted with the MPI weights, would carry their loop-shape error "
                     "too)")
    elif d.extended.cause == "baseline":
        delivered = f"Model delivered: the plain fit (no cause is named: `{d.cause}`)"
    else:
        delivered = (f"Extended model: `{d.extended.cause}`; gain **{d.gain_pct:.1f} %** less cross-validated RMS "
                     "error than the baseline (`100 (1 − rms_after / rms_before)`)")
    if not (d.steps and d.extended.cause in d.steps["removed_share"]):
        return delivered + "."
    return (f"{delivered}; on the responses to {d.steps['windows']} step(s) into holds, each left out of its fit, "
            f"it removes **{100 * d.steps['removed_share'][d.extended.cause]:.0f} %** of the "
            f"{d.steps['excess_sigma2']:.3g} σ² the rate-independent model leaves above the noise there.")


def _second_record_lines(d: Diagnosis) -> list:
    """The report's section on the second record (none without one)."""
    lines = []
    if d.validation:
        lines += ["## Second record", "", d.validation["note"] + ".", "",
                  "| model | RMS % | max % | offset µm | gain |", "| --- | ---: | ---: | ---: | ---: |"]
        for cause, row in d.validation["table"].items():
            lines.append(f"| {cause} | {row['rms_pct']:.3f} | {row['max_pct']:.3f} | {row['offset_um']:+.4g} | "
                         f"{row['gain']:.4g} |")
        lines += ["", f"Cause by the second record: `{d.validation['cause']}`; by cross-validation alone: "
                      f"`{d.cross_validation_cause}`.", ""]
    return lines


def _excitation_lines(d: Diagnosis) -> list:
    """The report's section on the excitation that separates a named set (none without one)."""
    lines = []
    if d.excitation is not None:
        lines += ["## Excitation that separates the named set", "",
                  f"`pysim excite {d.source or 'DATA.csv'} --out excitation.csv` writes {d.excitation.size} samples:", ""]
        lines += [f"- samples {p['start_sample']}…{p['start_sample'] + p['samples'] - 1}: {p['purpose']}"
                  for p in d.excitation_plan]
        lines.append("")
    return lines


def _candidates_and_statistics_lines(d: Diagnosis, ev: dict) -> list:
    """The report's tables of the cross-validated candidates (``ev``: the evidence of
    :meth:`Diagnosis.as_json`) and of the residual statistics."""
    lines = [
        "## Candidates (cross-validated)",
        "",
        "| candidate | held-out RMS % | gain % | σ² removed | significant | evidence |",
        "| --- | ---: | ---: | ---: | :---: | --- |",
    ]
    for cause, c in ev["candidates"].items():
        lines.append(f"| {cause} | {c['heldout_rms_pct']:.3f} | {c['gain_pct']:+.1f} | "
                     f"{c['mse_removed_over_noise']:.2f} | {'yes' if c['significant'] else 'no'} | "
                     f"{d.reasons[cause].replace('|', chr(92) + '|')} |")
    stats = d.statistics
    lines += ["", "## Residual statistics (held-out part)", "",
              "| statistic | baseline | extended |", "| --- | ---: | ---: |"]
    for key in stats["baseline"]:
        b, e = stats["baseline"][key], stats["extended"][key]
        lines.append(f"| {key} | {b:.4g} | {e:.4g} |")
    return lines


def write_report(d: Diagnosis, folder) -> Path:
    """Write the plots, ``summary.md`` and ``diagnosis.json`` into ``folder``
    (all or nothing)."""
    folder = Path(folder)
    drawers = {
        "overview.png": plot_overview, "loops.png": plot_loops, "residual_vs_rate.png": plot_rate,
        "residual_vs_time_since_change.png": plot_time_since_change,
        "cross_correlation.png": plot_cross_correlation, "spectrum.png": plot_spectrum,
        "candidates.png": plot_candidates,
    }
    with staged_directory(folder) as staging:
        for name, draw in drawers.items():
            draw(d, staging / name)
        (staging / "summary.md").write_text(summary_markdown(d), encoding="utf-8")
        (staging / "diagnosis.json").write_text(json.dumps(d.as_json(), indent=2), encoding="utf-8")
    return folder
