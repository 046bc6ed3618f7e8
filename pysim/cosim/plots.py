"""PNG plots of the co-simulation results (matplotlib, no display needed).

Figures are built on :class:`matplotlib.figure.Figure` with the Agg canvas,
never through pyplot, so nothing depends on a display or on global state.
Each function writes one PNG atomically and returns its path.
"""
from __future__ import annotations

import io
import math

import numpy as np

from pysim.core.fileio import atomic_write_bytes

_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")


def _figure(width_in, height_in):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path):
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return atomic_write_bytes(path, buffer.getvalue())


def _last_period(run, periods):
    n = run.time_s.size
    return slice(n - n // periods, None)


def plot_loops(runs, path, periods: int = 2):
    """Hysteresis loops without and with compensation.

    Left: actuator displacement against the desired displacement, voltage =
    reference / nominal gain; middle: the same through the inverse FMU; right:
    the plant's own loops (displacement against voltage) for both drives.

    Parameters
    ----------
    runs : dict
        ``(amplitude_um, path) -> CoSimResult`` as returned by
        :func:`pysim.cosim.tracking.track`.
    path : str or Path
        PNG to write.
    periods : int
        Periods in each run (the last one is drawn).
    """
    fig = _figure(13.5, 4.6)
    axes = fig.subplots(1, 3)
    amplitudes = sorted({a for a, _ in runs})
    for colour, amplitude in zip(_COLOURS, amplitudes):
        for ax, name in zip(axes[:2], ("uncompensated", "compensated")):
            run = runs.get((amplitude, name))
            if run is None:
                continue
            last = _last_period(run, periods)
            ax.plot(run.reference_um[last], run.displacement_plant_um[last], color=colour, lw=1.4,
                    label=f"A = {amplitude:g} µm")
        for name, style in (("uncompensated", "--"), ("compensated", "-")):
            run = runs.get((amplitude, name))
            if run is not None:
                last = _last_period(run, periods)
                axes[2].plot(run.voltage_V[last], run.displacement_plant_um[last], style, color=colour, lw=1.2)
    lo = min(float(np.min(r.reference_um)) for r in runs.values())
    hi = max(float(np.max(r.reference_um)) for r in runs.values())
    for ax, title in zip(axes[:2], ("Without compensation (v = x_d / gain)", "With the inverse FMU")):
        ax.plot([lo, hi], [lo, hi], color="0.5", lw=0.8, ls=":", label="ideal x = x_d")
        ax.set_title(title)
        ax.set_xlabel("desired displacement x_d (µm)")
        ax.set_ylabel("actuator displacement x (µm)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    axes[2].set_title("Plant: dashed without, solid with compensation")
    axes[2].set_xlabel("voltage (V)")
    axes[2].set_ylabel("actuator displacement x (µm)")
    axes[2].grid(True, alpha=0.3)
    fig.suptitle("Table III references x_d = A sin(2πt) + 37.5 µm, last period")
    return _save(fig, path)


def plot_bode(results, path, stage=None, bandwidths=None, paper_hz=None):
    """Magnitude of both paths against frequency.

    Top: normalised to the lowest frequency (the −3 dB definition used), with
    the stage's |G(j2πf)|; bottom: against the desired amplitude, which shows
    the uncompensated path's amplitude-dependent static gain.

    Parameters
    ----------
    results : list of SweepResult
    path : str or Path
    stage : control LTI, optional
        Drawn as a thin black line.
    bandwidths : dict, optional
        ``{path: Hz}`` measured −3 dB points to mark.
    paper_hz : dict, optional
        ``{path: Hz}`` the paper's figures to mark.
    """
    fig = _figure(9.5, 8.0)
    top, bottom = fig.subplots(2, 1, sharex=True)
    amplitudes = sorted({r.amplitude_um for r in results})
    colour_of = dict(zip(amplitudes, _COLOURS))
    for r in results:
        style = "-" if r.path == "compensated" else "--"
        label = f"{r.path}, A = {r.amplitude_um:g} µm"
        top.semilogx(r.frequencies_hz, 20 * np.log10(r.normalised), style, color=colour_of[r.amplitude_um],
                     lw=1.4, marker="o" if r.path == "compensated" else None, ms=2.5, label=label)
        bottom.semilogx(r.frequencies_hz, 20 * np.log10(r.gain), style, color=colour_of[r.amplitude_um],
                        lw=1.4, label=label)
    if stage is not None and results:
        f = np.geomspace(results[0].frequencies_hz[0], results[0].frequencies_hz[-1], 400)
        g = np.abs(np.asarray(stage(2j * math.pi * f)).ravel())
        for ax in (top, bottom):
            ax.semilogx(f, 20 * np.log10(g), color="k", lw=0.8, label="stage |G(j2πf)|")
    for ax in (top, bottom):
        ax.axhline(-3.0, color="0.4", lw=0.8, ls=":")
        ax.grid(True, which="both", alpha=0.3)
    measured = {name: hz for name, hz in (bandwidths or {}).items() if hz}
    if measured and max(measured.values()) - min(measured.values()) < 0.005 * max(measured.values()):
        measured = {"both paths": float(np.mean(list(measured.values())))}  # one label when they agree
    for i, (name, hz) in enumerate(measured.items()):
        top.axvline(hz, color="k", lw=0.8, ls="--" if name == "uncompensated" else "-")
        top.annotate(f"measured −3 dB, {name}: {hz:.0f} Hz", (hz, -3.0), xytext=(6, -30 - 14 * i),
                     textcoords="offset points", fontsize=8)
    for name, hz in (paper_hz or {}).items():
        top.axvline(hz, color="#d62728", lw=0.9, ls="-." if name == "uncompensated" else "-", alpha=0.7)
        top.annotate(f"paper {name}\n{hz:.0f} Hz", (hz, 10.0), xytext=(4, 0), textcoords="offset points",
                     fontsize=8, color="#d62728")
    from matplotlib.ticker import FuncFormatter, LogLocator

    for ax in (top, bottom):
        ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    top.set_ylabel("normalised magnitude (dB)")
    top.set_title("Stepped-sine response, normalised to the lowest frequency")
    top.legend(fontsize=7, ncol=2, loc="lower left")
    bottom.set_ylabel("fundamental / desired amplitude (dB)")
    bottom.set_xlabel("frequency (Hz)")
    bottom.set_title("Same sweeps against the desired amplitude A")
    bottom.legend(fontsize=7, ncol=2, loc="lower left")
    return _save(fig, path)


def plot_tracking(runs, path, periods: int = 2):
    """Tracking error x_d − x (stage displacement) over the last period, both paths."""
    fig = _figure(11.0, 4.4)
    axes = fig.subplots(1, 2)
    amplitudes = sorted({a for a, _ in runs})
    for colour, amplitude in zip(_COLOURS, amplitudes):
        for ax, name in zip(axes, ("uncompensated", "compensated")):
            run = runs.get((amplitude, name))
            if run is None:
                continue
            last = _last_period(run, periods)
            t = run.time_s[last] - run.time_s[last][0]
            ax.plot(t, run.reference_um[last] - run.displacement_stage_um[last], color=colour, lw=1.2,
                    label=f"A = {amplitude:g} µm")
    for ax, title in zip(axes, ("Without compensation", "With the inverse FMU")):
        ax.set_title(title)
        ax.set_xlabel("time in the last period (s)")
        ax.set_ylabel("error x_d − x (µm)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Tracking error at the stage, x_d = A sin(2πt) + 37.5 µm")
    return _save(fig, path)
