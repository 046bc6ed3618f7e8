"""A rig as an SSP: the FMUs of every part, connected, in one System Structure
and Parameterization 1.0 file that fmpy simulates and other tools import.

:func:`write_rig_ssp` builds (or reuses from the cache) the FMU of every part
of a :class:`pysim.cosim.rig.Rig` -- the plant, the compensator's inverse, the
controller, the amplifier, the stage as an LTI FMU and the sensor (see
:mod:`pysim.fmu.rig_parts`) -- and writes ``SystemStructure.ssd`` with the
FMUs under ``resources/``::

    reference_ahead ─► inverse ─► controller ─► amplifier ─► plant ─► stage ─► sensor ─┐
    reference ───────────────────►    ▲                                                │
                                      └────────────────────────────────────────────────┘

Every connection is a sample-and-hold of one communication step, so a fixed-
step Jacobi master that starts all connectors at 0 -- fmpy's
``fmpy.ssp.simulate_ssp`` -- runs exactly the scheme of
:class:`pysim.cosim.rig.RigSimulation`: row ``k`` of fmpy's result holds the
values after step ``k``, i.e. row ``k`` of :meth:`RigSimulation.run_path`.
The system inputs are ``reference`` and ``reference_ahead`` (the reference
``preview`` steps ahead, which the DSP knows; :func:`rig_ssp_inputs` makes
both for fmpy), the system outputs ``command``, ``voltage``, ``actuator``,
``stage`` and ``measurement``.

What a path changes (as in :meth:`RigSimulation.run_path`): ``"compensated"``
and ``"feedback+compensated"`` feed the inverse's voltage forward
(``ff_scale`` 1, ``ff_offset`` 0); ``"uncompensated"`` feeds
``reference_ahead`` through the nominal drive (``ff_scale = 1/gain``,
``ff_offset`` the first loading curve's offset) and has no inverse;
``"feedback"`` has no feedforward.  The feedback paths switch the
controller's ``feedback`` on.  All parameters are the FMUs' start values.

Examples
--------
>>> from pysim.cosim.ssp import write_rig_ssp, simulate_rig_ssp     # doctest: +SKIP
>>> ssp = write_rig_ssp(rig, compensator, "rig.ssp", "feedback+compensated")  # doctest: +SKIP
>>> result = simulate_rig_ssp(ssp, reference_um, rig.step_s, "feedback+compensated")  # doctest: +SKIP
"""
from __future__ import annotations

import io
import re
import tempfile
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import control
import numpy as np

from pysim.cosim.errors import CoSimulationError
from pysim.cosim.rig import PATHS, PREVIEW_STEPS, Rig, RigResult

__all__ = ["write_rig_ssp", "rig_ssp_inputs", "simulate_rig_ssp", "SYSTEM_OUTPUTS"]

_EPOCH = (1980, 1, 1, 0, 0, 0)
# system output connector: (component, its output, unit)
SYSTEM_OUTPUTS = {
    "command": ("controller", "command", "V"),
    "voltage": ("amplifier", "voltage", "V"),
    "actuator": ("plant", "displacement", "um"),
    "stage": ("stage", "y", "um"),
    "measurement": ("sensor", "measurement", "um"),
}
_UNITS = {"V": 'kg="1" m="2" s="-3" A="-1"', "um": 'm="1" factor="1e-06"'}


def _identifier(text: str) -> str:
    safe = re.sub(r"[^A-Za-z0-9_]", "_", text) or "rig"
    return safe if not safe[0].isdigit() else "rig_" + safe


def _check(rig, compensator_model, path_name):
    if not isinstance(rig, Rig):
        raise CoSimulationError(f"rig must be a Rig, got {type(rig).__name__}")
    if path_name not in PATHS:
        raise CoSimulationError(f"path must be one of {PATHS}, got {path_name!r}")
    compensated = path_name in ("compensated", "feedback+compensated")
    feedback = path_name.startswith("feedback")
    if compensated and compensator_model is None:
        raise CoSimulationError(f"the {path_name} path needs a compensator model")
    if feedback and not rig.controller.active:
        raise CoSimulationError(f"the {path_name} path needs a controller with kp or ki > 0")
    return compensated, feedback


def _plant_and_inverse(rig, compensator_model, compensated, fmu_dir, platforms):
    """Paths of the plant FMU and (compensated paths) the inverse FMU."""
    from pysim.cosim.harness import fmus_for_model, plant_fmu_for_model

    if platforms is None:
        plant = plant_fmu_for_model(rig.plant, fmu_dir)
        inverse = fmus_for_model(compensator_model, fmu_dir)[1] if compensated else None
        return plant, inverse
    from pysim.fmu import build_fmus

    folder = Path(fmu_dir) if fmu_dir else Path(tempfile.mkdtemp(prefix="rig-ssp-"))
    plant = build_fmus(rig.plant, folder / "plant", platforms=platforms, kinds=("plant",))["plant"]
    inverse = (build_fmus(compensator_model, folder / "inverse", platforms=platforms)["inverse"]
               if compensated else None)
    return plant, inverse


def _feedforward(rig, path_name, compensated, feedback, plant_fmu, drive):
    """``(ff_scale, ff_offset_V)`` of the controller, as RigSimulation.run_path sets them."""
    if compensated:
        return 1.0, 0.0
    if feedback:
        return 0.0, 0.0
    if drive is None:
        from pysim.cosim.rig import RigSimulation

        with RigSimulation(rig, plant_fmu) as sim:        # the nominal drive measured through the plant
            drive = sim.drive
    scale = 1.0 / drive.gain_um_per_V
    return scale, drive.low_V - drive.low_um / drive.gain_um_per_V


def _connector(name, kind, unit, indent):
    unit_attr = f" unit={quoteattr(unit)}" if unit else ""
    return (f'{" " * indent}<ssd:Connector name={quoteattr(name)} kind="{kind}"><ssc:Real{unit_attr}/>'
            "</ssd:Connector>")


def _ssd(name, components, connections, description) -> str:
    """Text of SystemStructure.ssd.  ``components``: [(name, source, [(connector, kind, unit)])];
    ``connections``: [(start element or None, start connector, end element or None, end connector)]."""
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             '<ssd:SystemStructureDescription xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
             'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
             f'version="1.0" name={quoteattr(name)} description={quoteattr(description)} '
             'generationTool="piezo-mpi">',
             f"  <ssd:System name={quoteattr(name)}>",
             "    <ssd:Connectors>"]
    lines += [_connector(c, "input", "um", 6) for c in ("reference", "reference_ahead")]
    lines += [_connector(c, "output", unit, 6) for c, (_, _, unit) in SYSTEM_OUTPUTS.items()]
    lines += ["    </ssd:Connectors>", "    <ssd:Elements>"]
    for element, source, connectors in components:
        lines.append(f'      <ssd:Component name={quoteattr(element)} type="application/x-fmu-sharedlibrary" '
                     f"source={quoteattr(source)}>")
        lines.append("        <ssd:Connectors>")
        lines += [_connector(c, kind, unit, 10) for c, kind, unit in connectors]
        lines.append("        </ssd:Connectors>")
        lines.append("      </ssd:Component>")
    lines += ["    </ssd:Elements>", "    <ssd:Connections>"]
    for start_element, start, end_element, end in connections:
        attrs = ""
        if start_element:
            attrs += f" startElement={quoteattr(start_element)}"
        attrs += f" startConnector={quoteattr(start)}"
        if end_element:
            attrs += f" endElement={quoteattr(end_element)}"
        attrs += f" endConnector={quoteattr(end)}"
        lines.append(f"      <ssd:Connection{attrs}/>")
    lines += ["    </ssd:Connections>", "  </ssd:System>", "  <ssd:Units>"]
    for unit, base in _UNITS.items():
        lines.append(f"    <ssc:Unit name={quoteattr(unit)}><ssc:BaseUnit {base}/></ssc:Unit>")
    lines += ["  </ssd:Units>", '  <ssd:DefaultExperiment startTime="0.0"/>',
              "</ssd:SystemStructureDescription>"]
    return "\n".join(lines) + "\n"


def write_rig_ssp(rig: Rig, compensator_model, path, path_name: str = "feedback+compensated", *,
                  fmu_dir=None, platforms=None, drive=None) -> Path:
    """Write the SSP of ``rig`` in configuration ``path_name``.

    Parameters
    ----------
    rig : Rig
        The rig (its plant is the truth; its stage becomes an LTI FMU, a
        static gain of 1 without a stage).
    compensator_model : HysteresisModel or ExtendedModel or None
        The model whose inverse compensates (its hysteresis part is inverted);
        None for the paths without an inverse (``"feedback"``,
        ``"uncompensated"``).
    path : str or Path
        The ``.ssp`` file to write.
    path_name : {"uncompensated", "compensated", "feedback", "feedback+compensated"}
        The configuration, as in :meth:`pysim.cosim.rig.RigSimulation.run_path`.
    fmu_dir : path, optional
        Where the plant and inverse FMUs are built (default: the package cache).
    platforms : iterable of str, optional
        Binaries in every FMU (default: this machine's platform only, built
        through :func:`pysim.cosim.harness.plant_fmu_for_model` and
        :func:`~pysim.cosim.harness.fmus_for_model`; give
        ``("linux64", "win64", "darwin64")`` for an SSP to hand on).
    drive : NominalDrive, optional
        The uncompensated path's drive (default: measured through the plant
        FMU, as ``RigSimulation(rig, plant_fmu, inverse_fmu)`` does).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    CoSimulationError
        Unknown path, a compensated path without a compensator, a feedback
        path without a controller.

    Examples
    --------
    >>> from pysim.cosim.rig import Rig                                  # doctest: +SKIP
    >>> write_rig_ssp(Rig(plant, stage), compensator, "rig.ssp")      # doctest: +SKIP
    PosixPath('rig.ssp')
    """
    from fmpy import platform as this_platform

    from pysim.fmu.rig_parts import (amplifier_part, build_part_fmus, controller_part, lti_part,
                                     sensor_part)

    compensated, feedback = _check(rig, compensator_model, path_name)
    plant_fmu, inverse_fmu = _plant_and_inverse(rig, compensator_model, compensated, fmu_dir, platforms)
    scale, offset = _feedforward(rig, path_name, compensated, feedback, plant_fmu, drive)
    base = _identifier(rig.name)
    T = float(rig.step_s)
    stage = rig.stage if rig.stage is not None else control.tf([1.0], [1.0])
    parts = [
        controller_part(rig.controller, rig.dac, rig.amplifier.gain_V_per_V, T, feedback=feedback,
                        ff_scale=scale, ff_offset_V=offset, name=f"{base}_controller"),
        amplifier_part(rig.amplifier, T, name=f"{base}_amplifier"),
        lti_part(stage, T, name=f"{base}_stage"),
        sensor_part(rig.adc, rig.noise, T, name=f"{base}_sensor"),
    ]
    with tempfile.TemporaryDirectory(prefix="rig-ssp-") as tmp:
        built = build_part_fmus(parts, tmp, platforms=tuple(platforms) if platforms else (this_platform,))
        fmu_files = {
            "controller": built[f"{base}_controller"].read_bytes(),
            "amplifier": built[f"{base}_amplifier"].read_bytes(),
            "plant": Path(plant_fmu).read_bytes(),
            "stage": built[f"{base}_stage"].read_bytes(),
            "sensor": built[f"{base}_sensor"].read_bytes(),
        }
    if compensated:
        fmu_files = {"inverse": Path(inverse_fmu).read_bytes(), **fmu_files}
    sources = {element: f"resources/{element}.fmu" for element in fmu_files}
    ports = {
        "inverse": [("displacement_ref", "input", "um"), ("voltage", "output", "V")],
        "controller": [("reference", "input", "um"), ("measurement", "input", "um"),
                       ("feedforward", "input", None), ("command", "output", "V")],
        "amplifier": [("command", "input", "V"), ("voltage", "output", "V")],
        "plant": [("voltage", "input", "V"), ("displacement", "output", "um")],
        "stage": [("u", "input", "um"), ("y", "output", "um")],
        "sensor": [("displacement", "input", "um"), ("measurement", "output", "um")],
    }
    components = [(element, sources[element], ports[element]) for element in fmu_files]
    connections = [(None, "reference", "controller", "reference")]
    if compensated:
        connections += [(None, "reference_ahead", "inverse", "displacement_ref"),
                        ("inverse", "voltage", "controller", "feedforward")]
    elif not feedback:
        connections.append((None, "reference_ahead", "controller", "feedforward"))
    connections += [
        ("controller", "command", "amplifier", "command"),
        ("amplifier", "voltage", "plant", "voltage"),
        ("plant", "displacement", "stage", "u"),
        ("stage", "y", "sensor", "displacement"),
        ("sensor", "measurement", "controller", "measurement"),
    ]
    connections += [(element, port, None, name) for name, (element, port, _) in SYSTEM_OUTPUTS.items()]
    description = (f"{rig.name}, path {path_name}: {rig.description}" if rig.description
                   else f"{rig.name}, path {path_name}")
    ssd = _ssd(base, components, connections, description)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, data in [("SystemStructure.ssd", ssd.encode())] + [
                (sources[element], fmu_files[element]) for element in fmu_files]:
            info = zipfile.ZipInfo(name, date_time=_EPOCH)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, data)
    path.write_bytes(buffer.getvalue())
    return path


def rig_ssp_inputs(reference_um, step_s: float, path_name: str = "feedback+compensated") -> dict:
    """The ``input`` argument of ``fmpy.ssp.simulate_ssp`` for a reference
    (µm, one sample per step): ``reference`` and ``reference_ahead`` (the
    reference ``PREVIEW_STEPS`` ahead, held at its last value), as
    :meth:`RigSimulation.run_path` feeds them.

    Examples
    --------
    >>> inputs = rig_ssp_inputs([1.0, 2.0, 3.0], 1e-4, "feedback")
    >>> inputs["reference"](1e-4), inputs["reference_ahead"](0.0)
    (2.0, 3.0)
    """
    if path_name not in PATHS:
        raise CoSimulationError(f"path must be one of {PATHS}, got {path_name!r}")
    r = np.asarray(reference_um, dtype=float)
    if r.ndim != 1 or r.size == 0 or not np.all(np.isfinite(r)):
        raise CoSimulationError("the reference must be a non-empty one-dimensional finite array")
    compensated = path_name in ("compensated", "feedback+compensated")
    preview = PREVIEW_STEPS["with_inverse" if compensated else "without_inverse"]
    ahead = np.concatenate([r[preview:], np.full(min(preview, r.size), r[-1])])
    reference, preview_values, last = r.tolist(), ahead.tolist(), r.size - 1

    def index(t):
        return min(max(int(round(t / step_s)), 0), last)

    return {"reference": lambda t: reference[index(t)], "reference_ahead": lambda t: preview_values[index(t)]}


def simulate_rig_ssp(ssp_path, reference_um, step_s: float, path_name: str = "feedback+compensated") -> RigResult:
    """Run a rig SSP under ``fmpy.ssp.simulate_ssp`` for a reference (one
    sample per step) and return its samples as a :class:`RigResult` aligned
    with :meth:`RigSimulation.run_path` (row ``k``: the values after step ``k``).

    Examples
    --------
    >>> result = simulate_rig_ssp("rig.ssp", reference_um, 5e-5, "feedback")   # doctest: +SKIP
    >>> result.measured_um[:3]                                               # doctest: +SKIP
    """
    from fmpy.ssp.simulation import simulate_ssp

    r = np.asarray(reference_um, dtype=float)
    inputs = rig_ssp_inputs(r, step_s, path_name)
    n = r.size
    # fmpy adds the step to its time until it reaches stop_time: half a step short of n steps gives n rows
    rows = simulate_ssp(str(ssp_path), stop_time=(n - 0.5) * step_s, step_size=step_s, input=inputs)
    if rows.size != n:
        raise CoSimulationError(f"fmpy ran {rows.size} steps, expected {n}")
    time = (np.arange(n) + 1) * step_s
    reference_at = np.concatenate([r[1:], r[-1:]])
    return RigResult(time, reference_at, np.array(rows["voltage"]), np.array(rows["actuator"]),
                     np.array(rows["stage"]), command_V=np.array(rows["command"]),
                     measured_um=np.array(rows["measurement"]), path=path_name)
