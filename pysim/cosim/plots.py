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


_PATH_STYLE = {"uncompensated": ("#7f7f7f", "--"), "compensated": ("#1f77b4", "-"),
               "feedback": ("#2ca02c", "-."), "feedback+compensated": ("#d62728", "-")}


def _log_frequency_axis(ax):
    from matplotlib.ticker import FuncFormatter, LogLocator

    ax.xaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda x, _: f"{x:g}"))
    ax.grid(True, which="both", alpha=0.3)


def plot_rig_bode(results, path, stage=None, summary=None):
    """Bode magnitude and phase of every configuration of a rig, one column
    per amplitude: the fundamental of the stage against the desired sine.

    Parameters
    ----------
    results : list of SweepResult
        From :func:`pysim.cosim.rig.rig_stepped_sine` (any paths and amplitudes).
    path : str or Path
        PNG to write.
    stage : control LTI, optional
        The stage alone, drawn thin black.
    summary : dict, optional
        ``{path: {amplitude: {"minus3db_normalised_hz": Hz}}}`` to mark.
    """
    amplitudes = sorted({r.amplitude_um for r in results})
    fig = _figure(6.2 * len(amplitudes), 7.6)
    axes = np.atleast_2d(fig.subplots(2, len(amplitudes), sharex="col", squeeze=False))
    for col, amplitude in enumerate(amplitudes):
        mag, phase = axes[0, col], axes[1, col]
        for r in (r for r in results if r.amplitude_um == amplitude):
            colour, style = _PATH_STYLE.get(r.path, ("k", "-"))
            bw = (summary or {}).get(r.path, {}).get(f"{amplitude:g}", {}).get("minus3db_normalised_hz")
            label = r.path + (f" (−3 dB {bw:.0f} Hz)" if bw else "")
            mag.semilogx(r.frequencies_hz, 20 * np.log10(r.gain), style, color=colour, lw=1.5, label=label)
            phase.semilogx(r.frequencies_hz, np.degrees(np.unwrap(np.angle(r.response))), style, color=colour,
                           lw=1.5)
        if stage is not None and results:
            f = np.geomspace(results[0].frequencies_hz.min(), results[0].frequencies_hz.max(), 400)
            g = np.asarray(stage(2j * math.pi * f)).ravel()
            mag.semilogx(f, 20 * np.log10(np.abs(g)), color="k", lw=0.7, label="stage alone")
            phase.semilogx(f, np.degrees(np.unwrap(np.angle(g))), color="k", lw=0.7)
        mag.axhline(-3.0, color="0.4", lw=0.8, ls=":")
        mag.set_ylim(-30, 20)
        mag.set_title(f"x_d = {amplitude:g} µm · sin(2πft) + 37.5 µm")
        mag.set_ylabel("stage / desired (dB)")
        phase.set_ylabel("phase (deg)")
        phase.set_xlabel("frequency (Hz)")
        phase.set_ylim(-400, 30)
        for ax in (mag, phase):
            _log_frequency_axis(ax)
        mag.legend(fontsize=7, loc="lower left")
    fig.suptitle("Frequency response of the rig in each configuration (against the desired amplitude)")
    return _save(fig, path)


def plot_rig_tracking(runs, path, amplitude_um, periods: int = 2, title: str | None = None):
    """Tracking error of the stage over time, every configuration, one amplitude."""
    fig = _figure(10.0, 4.8)
    ax = fig.subplots(1, 1)
    for (amplitude, name), run in sorted(runs.items()):
        if amplitude != amplitude_um:
            continue
        colour, style = _PATH_STYLE.get(name, ("k", "-"))
        ax.plot(run.time_s, run.reference_um - run.displacement_stage_um, style, color=colour, lw=1.0,
                label=name)
    ax.set_yscale("symlog", linthresh=0.05)
    ax.set_xlabel("time (s); the first period is the start-up from rest at 0 V")
    ax.set_ylabel("x_d − x at the stage (µm, symmetric log)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    ax.set_title(title or f"Tracking error, x_d = {amplitude_um:g} µm · sin(2πt) + 37.5 µm")
    return _save(fig, path)


def plot_rig_loops(runs, path, amplitude_um, periods: int = 2, title: str | None = None):
    """Achieved against desired displacement over the last period, one panel
    per configuration: a straight diagonal is perfect tracking."""
    names = [name for name in _PATH_STYLE if (amplitude_um, name) in runs]
    fig = _figure(3.6 * max(len(names), 1), 3.9)
    axes = np.atleast_1d(fig.subplots(1, max(len(names), 1)))
    for ax, name in zip(axes, names):
        run = runs[(amplitude_um, name)]
        last = _last_period(run, periods)
        colour, _ = _PATH_STYLE[name]
        ax.plot(run.reference_um[last], run.displacement_stage_um[last], color=colour, lw=1.2)
        lo, hi = run.reference_um[last].min(), run.reference_um[last].max()
        ax.plot([lo, hi], [lo, hi], color="k", lw=0.6, ls=":")
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("desired x_d (µm)")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("achieved x at the stage (µm)")
    fig.suptitle(title or f"Desired against achieved displacement, A = {amplitude_um:g} µm, last period")
    return _save(fig, path)
