"""FMUs of the rig parts around the actuator: amplifier, controller, sensor and
any single-input single-output python-control LTI system (the stage).

Each part becomes an FMI 2.0 co-simulation FMU built like the plant and
inverse FMUs -- the shared FMI layer ``fmi2_layer.c``, a hand-written
``model.c`` per kind (``fmu_src/amplifier``, ``controller``, ``sensor``,
``lti``), a generated ``model_config.h`` and ``modelDescription.xml``, cross-
compiled with zig for every platform and cached -- and computes the discrete
equations of :mod:`pysim.core.rig` with the same floating-point operations in
the same order, so a chain of these FMUs gives the samples of
:class:`pysim.cosim.rig.RigSimulation`.

=============  ===========================  =================  ======================================
kind           inputs                       output             parameters
=============  ===========================  =================  ======================================
``amplifier``  ``command`` (V)              ``voltage`` (V)    ``gain``, ``bandwidth`` (Hz, 0: none),
                                                               ``current_limit`` (A, 0: none),
                                                               ``capacitance`` (F), ``output_low``,
                                                               ``output_high`` (V)
``controller`` ``reference``,               ``command`` (V)    ``kp`` (V/um), ``ki`` (V/(um.s)),
               ``measurement`` (um),                           ``output_low``, ``output_high`` (V),
               ``feedforward``                                 ``ff_scale``, ``ff_offset`` (V),
                                                               ``dac_bits``, ``dac_low``, ``dac_high``
                                                               (V), ``amplifier_gain`` (V/V),
                                                               ``feedback`` (Boolean)
``sensor``     ``displacement`` (um)        ``measurement``    ``noise_rms`` (um), ``seed``,
                                            (um)               ``adc_bits``, ``adc_low``, ``adc_high``
                                                               (um)
``lti``        ``u``                        ``y``              ``A[i,j]``, ``B[i]``, ``C[i]``, ``D``
=============  ===========================  =================  ======================================

Semantics: inputs are held over a communication step and the outputs read
after ``fmi2DoStep(t, h)`` are the values at ``t + h``.  Amplifier, controller
and sensor have no direct feed-through (their output is their state: the
amplifier's output voltage, the command the controller computed during the
last sample, the last converted measurement); the LTI output is
``y = C z + D u`` (feed-through when ``D != 0``).  Every part accepts any
step size: the amplifier's lag and slew limit, the integrator's ``ki h`` and
the LTI system's exact zero-order-hold discretisation (``e^(A h)`` and
``integral e^(A s) ds B``, scaling and squaring with the [13/13] Padé
approximant in C, recomputed when the step changes; the generator's scipy
values for the nominal step) follow the step.  A discrete LTI system steps at
its sampling time only.  The step size is the difference of the FMU's times at
the two ends of the step, taken as the previous or the nominal step when it
equals one of them up to the rounding of time arithmetic (the shared layer
does not pass the step to the model before it commits the step).

FMI 2.0 Reals cannot be infinite, so ``bandwidth = 0`` and
``current_limit = 0`` mean "no limit" (``math.inf`` in
:class:`pysim.core.rig.Amplifier`).  Converter resolutions and the noise seed
are Real parameters holding whole numbers (the shared layer has Real and
Boolean variables only).  Invalid parameters are refused at
``fmi2ExitInitializationMode`` with fmi2Error and a log line naming them.

Examples
--------
>>> from pysim.core.rig import Amplifier
>>> part = amplifier_part(Amplifier(15.0, 10e3, 0.3, 3.6e-6), step_s=5e-5)
>>> part.identifier, [v.name for v in part.variables][:3]
('amplifier', ['command', 'voltage', 'gain'])
>>> build_part_fmus([part], "fmus/", platforms=["linux64"])   # doctest: +SKIP
{'amplifier': PosixPath('fmus/amplifier.fmu')}
"""
from __future__ import annotations

import hashlib
import math
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise
from pysim.core.toolchain import SOURCE_DIR
from pysim.fmu.build import platform_names, compile_and_package, tool_version
from pysim.fmu.errors import BuildError
from pysim.fmu.generate import (GENERATION_TOOL, xml_attributes, c_double_literal, c_initializer, xml_double,
                                config_header_text, model_variables_xml, units_and_log_categories_xml)
from pysim.fmu.variables import Variable

__all__ = ["RIG_KINDS", "PartFMU", "amplifier_part", "controller_part", "sensor_part", "lti_part",
           "zoh_matrices", "part_sources", "build_part_fmus", "MAX_LTI_STATES"]

RIG_KINDS = ("amplifier", "controller", "sensor", "lti")
MAX_LTI_STATES = 16
COMMON_SOURCES = ("fmi2_layer.c", "fmi2_layer.h")          # from fmu_src/
RIG_SOURCES = ("all.c", "part_hooks.c", "rig_part.h")      # from fmu_src/rig/
MODEL_SOURCES = ("model.c", "model.h")                     # from fmu_src/<kind>/
LOG_CATEGORIES = (
    ("logEvents", "state changes: instantiation, initialisation, termination, reset"),
    ("logStatusWarning", "adjusted inputs"),
    ("logStatusError", "rejected calls and invalid parameters (always reported)"),
)
# name: (factor, exponents of kg, m, s, A)
UNITS = {
    "V": (1.0, {"kg": 1, "m": 2, "s": -3, "A": -1}),
    "um": (1e-6, {"m": 1}),
    "V/V": (1.0, {}),
    "A": (1.0, {"A": 1}),
    "F": (1.0, {"kg": -1, "m": -2, "s": 4, "A": 2}),
    "Hz": (1.0, {"s": -1}),
    "s": (1.0, {"s": 1}),
    "1/s": (1.0, {"s": -1}),
    "V/um": (1e6, {"kg": 1, "m": 1, "s": -3, "A": -1}),
    "V/(um.s)": (1e6, {"kg": 1, "m": 1, "s": -4, "A": -1}),
}


@dataclass(frozen=True)
class PartFMU:
    """Everything the builder needs for one rig-part FMU.

    Attributes
    ----------
    kind : str
        One of :data:`RIG_KINDS` (names the C folder ``fmu_src/<kind>``).
    identifier : str
        Model identifier, binary and file name (a C identifier).
    description : str
        One line for ``modelDescription.xml``.
    variables : tuple of Variable
        Reals (inputs, outputs, parameters, constants) numbered from 0, then Booleans.
    nominal_step_s : float
        The communication step the FMU is generated for, s (``DefaultExperiment stepSize``).
    config : tuple of str
        Extra lines of ``model_config.h``.
    fixed_step : bool
        True when every step must be ``nominal_step_s`` (a discrete LTI system).
    feedthrough : bool
        Whether the output depends directly on the input.

    Examples
    --------
    >>> from pysim.core.rig import Converter, SensorNoise
    >>> sensor_part(Converter(16, -10.0, 110.0), SensorNoise(0.01, 7), 5e-5).variables[1].name
    'measurement'
    """

    kind: str
    identifier: str
    description: str
    variables: tuple
    nominal_step_s: float
    config: tuple = ()
    fixed_step: bool = False
    feedthrough: bool = False


def _check_name(name: str) -> str:
    if not (isinstance(name, str) and name.isascii() and name.isidentifier()):
        raise BuildError(f"FMU name {name!r} must be an ASCII C identifier: it names the binary and files")
    return name


def _check_step(step_s) -> float:
    try:
        step = float(step_s)
    except (TypeError, ValueError):
        raise BuildError(f"step_s must be a number of seconds, got {step_s!r}") from None
    if not (math.isfinite(step) and step > 0):
        raise BuildError(f"step_s must be positive and finite, got {step_s!r}")
    return step


def _numbered(specs, booleans=()) -> tuple:
    """Variables from ``(name, causality, unit, start, description)`` rows
    (Reals, in value-reference order) and Boolean ``(name, start, description)`` rows."""
    out = []
    for name, causality, unit, start, text in specs:
        c_name = name.split("[")[0] if "[" not in name or name.endswith("[1]") or name.endswith("[1,1]") \
            else None
        out.append(Variable(name, len(out), "Real", causality, text, unit,
                            None if start is None else float(start), c_name))
    for name, start, text in booleans:
        out.append(Variable(name, len(out), "Boolean", "parameter", text, None, bool(start), name))
    return tuple(out)


def _limit(value: float) -> float:
    """A limit for an FMI parameter: inf (no limit) becomes 0."""
    return 0.0 if math.isinf(value) else float(value)


def amplifier_part(amplifier: Amplifier, step_s: float, name: str = "amplifier") -> PartFMU:
    """The amplifier FMU of ``amplifier`` (:class:`pysim.core.rig.Amplifier`).

    Parameters
    ----------
    amplifier : Amplifier
    step_s : float
        Nominal communication step, s (any step works).
    name : str
        Model identifier.

    Returns
    -------
    PartFMU

    Examples
    --------
    >>> part = amplifier_part(Amplifier(), 1e-4)
    >>> {v.name: v.start for v in part.variables if v.causality == "parameter"}["bandwidth"]
    0.0
    """
    if not isinstance(amplifier, Amplifier):
        raise BuildError(f"amplifier must be a pysim.core.rig.Amplifier, got {type(amplifier).__name__}")
    a = amplifier
    variables = _numbered([
        ("command", "input", "V", 0.0, "command at the amplifier's input, held over the step"),
        ("voltage", "output", "V", None, "output voltage (the state: no direct feed-through)"),
        ("gain", "parameter", "V/V", a.gain_V_per_V, "voltage gain (> 0)"),
        ("bandwidth", "parameter", "Hz", _limit(a.bandwidth_hz),
         "-3 dB frequency of the first-order small-signal response (0: no bandwidth limit)"),
        ("current_limit", "parameter", "A", _limit(a.current_limit_A),
         "peak output current; slew rate = current_limit / capacitance (0: no slew limit)"),
        ("capacitance", "parameter", "F", a.capacitance_F, "capacitance of the driven stack (> 0)"),
        ("output_low", "parameter", "V", a.output_low_V, "lower end of the output range"),
        ("output_high", "parameter", "V", a.output_high_V, "upper end of the output range"),
    ])
    return PartFMU("amplifier", _check_name(name), "piezo amplifier: command (V) to voltage (V); gain, "
                   "first-order bandwidth, slew limit I_max/C, output range", variables, _check_step(step_s))


def controller_part(controller: PIController, dac: Converter, amplifier_gain_V_per_V: float, step_s: float, *,
                    feedback: bool = True, ff_scale: float = 1.0, ff_offset_V: float = 0.0,
                    name: str = "controller") -> PartFMU:
    """The controller FMU: PI with anti-windup and the DAC.

    Parameters
    ----------
    controller : PIController
        Gains and output limits (V at the actuator).
    dac : Converter
        The output converter (V at the amplifier's input).
    amplifier_gain_V_per_V : float
        The command is ``DAC(u / amplifier_gain)``.
    step_s : float
        Nominal communication step (the controller's sample period), s.
    feedback : bool
        False: the command is ``DAC(clip(f) / gain)`` from the feedforward
        ``f = ff_scale * feedforward + ff_offset`` alone.
    ff_scale : float
        Scale of the feedforward input (1 for a voltage; ``1/gain_um_per_V``
        for a reference in µm through the nominal drive; 0 for none).
    ff_offset_V : float
        Offset added to the scaled feedforward, V.
    name : str
        Model identifier.

    Returns
    -------
    PartFMU

    Examples
    --------
    >>> part = controller_part(PIController(0.05, 600.0), Converter(16, 0.0, 10.0), 15.0, 5e-5)
    >>> [v.name for v in part.variables if v.causality == "input"]
    ['reference', 'measurement', 'feedforward']
    """
    if not isinstance(controller, PIController):
        raise BuildError(f"controller must be a pysim.core.rig.PIController, got {type(controller).__name__}")
    if not isinstance(dac, Converter):
        raise BuildError(f"dac must be a pysim.core.rig.Converter, got {type(dac).__name__}")
    for label, value in (("amplifier_gain_V_per_V", amplifier_gain_V_per_V), ("ff_scale", ff_scale),
                         ("ff_offset_V", ff_offset_V)):
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise BuildError(f"{label} must be a finite number, got {value!r}")
    c = controller
    variables = _numbered([
        ("reference", "input", "um", 0.0, "desired displacement"),
        ("measurement", "input", "um", 0.0, "measured displacement (the sensor's output)"),
        ("feedforward", "input", None, 0.0, "feedforward: a voltage (V, ff_scale 1) or a reference "
         "(um, through ff_scale and ff_offset)"),
        ("command", "output", "V", None, "DAC output for the amplifier, computed during the last sample "
         "from the inputs held over it (one sample of computation delay)"),
        ("kp", "parameter", "V/um", c.kp_V_per_um, "proportional gain (>= 0)"),
        ("ki", "parameter", "V/(um.s)", c.ki_V_per_um_s, "integral gain (>= 0)"),
        ("output_low", "parameter", "V", c.output_low_V, "lower limit of feedforward + feedback"),
        ("output_high", "parameter", "V", c.output_high_V, "upper limit of feedforward + feedback"),
        ("ff_scale", "parameter", None, ff_scale, "feedforward f = ff_scale * feedforward + ff_offset"),
        ("ff_offset", "parameter", "V", ff_offset_V, "offset of the feedforward"),
        ("dac_bits", "parameter", None, dac.bits, "DAC resolution, a whole number 0-32 (0: ideal)"),
        ("dac_low", "parameter", "V", dac.low, "lower end of the DAC range"),
        ("dac_high", "parameter", "V", dac.high, "upper end of the DAC range"),
        ("amplifier_gain", "parameter", "V/V", amplifier_gain_V_per_V,
         "gain of the amplifier: the command is DAC(u / amplifier_gain)"),
    ], booleans=[("feedback", feedback, "true: PI feedback around the feedforward; false: the "
                  "feedforward alone")])
    return PartFMU("controller", _check_name(name), "real-time controller: PI with anti-windup and output "
                   "limits around a feedforward, one sample of computation delay, DAC", variables,
                   _check_step(step_s))


def sensor_part(adc: Converter, noise: SensorNoise, step_s: float, name: str = "sensor") -> PartFMU:
    """The sensor FMU: noise (xorshift64*/Box-Muller, seeded) and the ADC.

    Parameters
    ----------
    adc : Converter
        The sensor's converter, µm.
    noise : SensorNoise
        Noise RMS and seed (the seed must be a whole number of magnitude <= 2^53).
    step_s : float
        Nominal communication step, s.
    name : str
        Model identifier.

    Returns
    -------
    PartFMU

    Examples
    --------
    >>> part = sensor_part(Converter(16, -10.0, 110.0), SensorNoise(0.01, 2014), 5e-5)
    >>> [(v.name, v.start) for v in part.variables][2:4]
    [('noise_rms', 0.01), ('seed', 2014.0)]
    """
    if not isinstance(adc, Converter):
        raise BuildError(f"adc must be a pysim.core.rig.Converter, got {type(adc).__name__}")
    if not isinstance(noise, SensorNoise):
        raise BuildError(f"noise must be a pysim.core.rig.SensorNoise, got {type(noise).__name__}")
    seed = int(noise.seed)
    if abs(seed) > 2 ** 53:
        raise BuildError(f"the noise seed {seed} does not fit an FMI Real exactly (|seed| <= 2^53)")
    variables = _numbered([
        ("displacement", "input", "um", 0.0, "displacement to measure, held over the step"),
        ("measurement", "output", "um", None, "converted measurement (the state: no direct feed-through)"),
        ("noise_rms", "parameter", "um", noise.rms_um, "RMS of the white measurement noise (>= 0)"),
        ("seed", "parameter", None, seed, "seed of the noise generator, a whole number (0: a fixed "
         "constant)"),
        ("adc_bits", "parameter", None, adc.bits, "ADC resolution, a whole number 0-32 (0: ideal)"),
        ("adc_low", "parameter", "um", adc.low, "lower end of the ADC range"),
        ("adc_high", "parameter", "um", adc.high, "upper end of the ADC range"),
    ])
    return PartFMU("sensor", _check_name(name), "displacement sensor: white noise (xorshift64*, Box-Muller) "
                   "and ADC", variables, _check_step(step_s))


def _state_space(system):
    """(A, B, C, D) float arrays of a SISO python-control system, and its dt."""
    import control

    if not isinstance(system, (control.TransferFunction, control.StateSpace)):
        raise BuildError(f"the LTI system must be a python-control TransferFunction or StateSpace, "
                         f"got {type(system).__name__}")
    if system.ninputs != 1 or system.noutputs != 1:
        raise BuildError(f"the LTI system must have one input and one output, got {system.ninputs} and "
                         f"{system.noutputs}")
    if system.dt is True:
        raise BuildError("the LTI system is discrete with an unspecified sampling time (dt=True)")
    ss = control.ss(system)
    matrices = tuple(np.atleast_2d(np.asarray(m, dtype=float)) for m in (ss.A, ss.B, ss.C, ss.D))
    if not all(np.all(np.isfinite(m)) for m in matrices):
        raise BuildError("the LTI system has non-finite coefficients")
    return matrices, float(system.dt or 0.0)


def zoh_matrices(system, step_s: float) -> tuple:
    """``(Ad, Bd, C, D)``: the exact zero-order-hold discretisation of a
    continuous SISO system for ``step_s`` (the operations of
    :func:`pysim.cosim.stage.discretise` with ``method="zoh"``: python-control's
    state-space realisation, then scipy's ``cont2discrete``); a discrete
    system's own matrices.

    Examples
    --------
    >>> import control
    >>> Ad, Bd, C, D = zoh_matrices(control.tf([1.0], [1.0, 1.0]), 0.5)
    >>> round(float(Ad[0, 0]), 12), round(float(Bd[0, 0] * C[0, 0]), 12)
    (0.606530659713, 0.393469340287)
    """
    import scipy.signal

    (A, B, C, D), dt = _state_space(system)
    if dt or A.size == 0:
        return A, B, C, D
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((A, B, C, D), float(step_s), method="zoh")
    return Ad, Bd, Cd, Dd


def lti_part(system, step_s: float, name: str = "lti", input_unit: str | None = "um",
             output_unit: str | None = "um") -> PartFMU:
    """The FMU of a SISO python-control LTI system (transfer function or state
    space, continuous or discrete), in python-control's state-space realisation.

    Parameters
    ----------
    system : control.TransferFunction or control.StateSpace
        At most :data:`MAX_LTI_STATES` states; a discrete system's ``dt`` must
        equal ``step_s`` (it then steps at ``dt`` only).
    step_s : float
        Nominal communication step, s: the FMU carries the zero-order-hold
        matrices for it and computes those of any other step.
    name : str
        Model identifier.
    input_unit, output_unit : str or None
        Units of ``u`` and ``y`` (µm for a stage), from the units this module
        defines.

    Returns
    -------
    PartFMU

    Examples
    --------
    >>> import control
    >>> part = lti_part(control.tf([1.0], [1e-3, 1.0]), 1e-4)
    >>> [v.name for v in part.variables]
    ['u', 'y', 'A[1,1]', 'B[1]', 'C[1]', 'D']
    """
    step = _check_step(step_s)
    (A, B, C, D), dt = _state_space(system)
    n = A.shape[0]
    if n > MAX_LTI_STATES:
        raise BuildError(f"the LTI system has {n} states; the FMU takes at most {MAX_LTI_STATES}")
    if dt and not math.isclose(dt, step, rel_tol=1e-9):
        raise BuildError(f"the discrete LTI system has dt = {dt} s but the step is {step} s")
    for unit in (input_unit, output_unit):
        if unit is not None and unit not in UNITS:
            raise BuildError(f"unknown unit {unit!r}; choose from {sorted(UNITS)}")
    if dt:
        step = dt
    Ad, Bd, _, _ = zoh_matrices(system, step)
    rate = None if dt else "1/s"
    kind_text = "discrete (sampling time %s s)" % xml_double(dt) if dt else "continuous"
    rows = [
        ("u", "input", input_unit, 0.0, "input, held over the step"),
        ("y", "output", output_unit, None, "output y = C z + D u"),
    ]
    for i in range(n):
        for j in range(n):
            rows.append((f"A[{i + 1},{j + 1}]", "parameter", rate, A[i, j], f"state matrix, {kind_text}"))
    for i in range(n):
        rows.append((f"B[{i + 1}]", "parameter", rate, B[i, 0], f"input matrix, {kind_text}"))
    for i in range(n):
        rows.append((f"C[{i + 1}]", "parameter", None, C[0, i], "output matrix"))
    rows.append(("D", "parameter", None, D[0, 0], "feed-through"))
    variables = _numbered(rows)

    def array(values):
        values = [c_double_literal(x) for x in np.ravel(values)]
        return c_initializer(values) if values else "{ 0.0 }"

    config = (
        f"#define MODEL_N_STATES {n}",
        f"#define MODEL_DISCRETE {1 if dt else 0}",
        f"#define MODEL_NOMINAL_A {array(A)}",
        f"#define MODEL_NOMINAL_B {array(B)}",
        f"#define MODEL_NOMINAL_AD {array(Ad)}",
        f"#define MODEL_NOMINAL_BD {array(Bd)}",
    ) + (("#define MODEL_FIXED_STEP_SIZE MODEL_NOMINAL_STEP",) if dt else ())
    what = (f"SISO LTI system with {n} state{'s' if n != 1 else ''}, {kind_text}; "
            + ("steps at its sampling time only" if dt else "exact zero-order-hold discretisation for any step"))
    return PartFMU("lti", _check_name(name), what, variables, step, config, fixed_step=bool(dt),
                   feedthrough=bool(D[0, 0] != 0.0))


# ------------------------------------------------------------------ generation
def _unit_definitions(variables) -> dict:
    used = [v.unit for v in variables if v.unit is not None]
    return {name: UNITS[name] for name in dict.fromkeys(used)}


def config_header(part: PartFMU, guid: str) -> str:
    """Text of ``model_config.h`` of a rig-part FMU."""
    return config_header_text(part.identifier, guid, f"{part.kind} FMU of a rig part", part.variables,
                              model_defines=[f"#define MODEL_NOMINAL_STEP {c_double_literal(part.nominal_step_s)}"],
                              trailing_defines=["", *part.config] if part.config else ())


def _dependencies(index: int, deps) -> str:
    return xml_attributes(index=index, dependencies=" ".join(map(str, deps)),
                          dependenciesKind=" ".join("dependent" for _ in deps) if deps else None)


def model_description(part: PartFMU, guid: str, version: str) -> str:
    """Text of ``modelDescription.xml`` (FMI 2.0 co-simulation) of a rig-part FMU."""
    allv = part.variables
    lines = ['<?xml version="1.0" encoding="UTF-8"?>']
    lines.append("<fmiModelDescription " + xml_attributes(
        fmiVersion="2.0", modelName=part.identifier, guid=guid, description=part.description,
        generationTool=f"{GENERATION_TOOL} {version}", version=version,
        variableNamingConvention="structured", numberOfEventIndicators="0") + ">")
    lines.append("  <CoSimulation " + xml_attributes(
        modelIdentifier=part.identifier, needsExecutionTool="false",
        canHandleVariableCommunicationStepSize="false" if part.fixed_step else "true",
        canInterpolateInputs="false", maxOutputDerivativeOrder="0", canRunAsynchronuously="false",
        canBeInstantiatedOnlyOncePerProcess="false", canNotUseMemoryManagementFunctions="false",
        canGetAndSetFMUstate="true", canSerializeFMUstate="true",
        providesDirectionalDerivative="false") + ">")
    lines.append("    <SourceFiles>")
    lines.append(f"      <File {xml_attributes(name='all.c')}/>")
    lines.append("    </SourceFiles>")
    lines.append("  </CoSimulation>")
    lines += units_and_log_categories_xml(_unit_definitions(allv), LOG_CATEGORIES)
    lines.append("  <DefaultExperiment " + xml_attributes(
        startTime="0.0", stopTime=xml_double(1000 * part.nominal_step_s),
        stepSize=xml_double(part.nominal_step_s)) + "/>")
    lines += model_variables_xml(allv)
    inputs = [v.value_reference + 1 for v in allv if v.causality == "input"]
    parameters = [v.value_reference + 1 for v in allv if v.causality == "parameter"]
    outputs = [v.value_reference + 1 for v in allv if v.causality == "output"]
    direct = inputs if part.feedthrough else []
    lines.append("  <ModelStructure>")
    lines.append("    <Outputs>")
    for index in outputs:
        lines.append(f"      <Unknown {_dependencies(index, direct)}/>")
    lines.append("    </Outputs>")
    lines.append("    <InitialUnknowns>")
    for index in outputs:
        lines.append(f"      <Unknown {_dependencies(index, direct + parameters)}/>")
    lines.append("    </InitialUnknowns>")
    lines.append("  </ModelStructure>")
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"


def hand_written_sources(kind: str, source_dir=SOURCE_DIR) -> dict:
    """``{file name: bytes}`` of the hand-written C sources of a ``kind`` FMU."""
    if kind not in RIG_KINDS:
        raise BuildError(f"kind must be one of {RIG_KINDS}, got {kind!r}")
    source_dir = Path(source_dir)
    files = {name: (source_dir / name).read_bytes() for name in COMMON_SOURCES}
    files.update({name: (source_dir / "rig" / name).read_bytes() for name in RIG_SOURCES})
    files.update({name: (source_dir / kind / name).read_bytes() for name in MODEL_SOURCES})
    return files


def part_guid(part: PartFMU, source_digest: str) -> str:
    """GUID from a hash of the variables, the configuration and the C sources."""
    digest = hashlib.sha256()
    digest.update(f"{GENERATION_TOOL}\n{part.kind}\n{part.identifier}\n{part.nominal_step_s!r}\n".encode())
    for v in part.variables:
        digest.update(repr((v.name, v.value_reference, v.type, v.causality, v.unit, v.start)).encode())
    digest.update("\n".join(part.config).encode())
    digest.update(source_digest.encode())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=5)) + "}"


def part_sources(part: PartFMU, version: str, source_dir=SOURCE_DIR) -> dict:
    """Everything of a rig-part FMU except its binaries, as ``{path inside the
    FMU: bytes}``: ``modelDescription.xml`` and ``sources/*``."""
    files = hand_written_sources(part.kind, source_dir)
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(name.encode() + b"\0" + files[name] + b"\0")
    guid = part_guid(part, digest.hexdigest())
    files["model_config.h"] = config_header(part, guid).encode()
    out = {"modelDescription.xml": model_description(part, guid, version).encode()}
    out.update({f"sources/{name}": data for name, data in sorted(files.items())})
    return out


def build_part_fmus(parts, out_dir, platforms=("linux64", "win64", "darwin64"), *, use_cache=True,
                    cache_dir=None, progress=None) -> dict:
    """Build the FMUs of rig parts (all or nothing).

    Parameters
    ----------
    parts : iterable of PartFMU
        From :func:`amplifier_part`, :func:`controller_part`,
        :func:`sensor_part`, :func:`lti_part`; identifiers must differ.
    out_dir : path
        Folder for ``<identifier>.fmu`` (created if needed).
    platforms : iterable of {"linux64", "win64", "darwin64"}
        Binaries to include; the C sources are always included.
    use_cache : bool
        Reuse binaries compiled before from identical sources (default).
    cache_dir : path, optional
        Where cached binaries live (default: the builder's cache).
    progress : callable(str), optional
        Called with one line per step.

    Returns
    -------
    dict
        ``{identifier: Path}``.

    Examples
    --------
    >>> from pysim.core.rig import Amplifier
    >>> build_part_fmus([amplifier_part(Amplifier(), 1e-4)], "fmus/", ["linux64"])  # doctest: +SKIP
    {'amplifier': PosixPath('fmus/amplifier.fmu')}
    """
    say = progress or (lambda message: None)
    parts = list(parts)
    if not parts or not all(isinstance(p, PartFMU) for p in parts):
        raise BuildError("parts must be a non-empty list of PartFMU")
    idents = [p.identifier for p in parts]
    if len(set(idents)) != len(idents):
        raise BuildError(f"rig-part FMU identifiers must differ, got {idents}")
    names = platform_names(platforms)
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise BuildError(f"{out_dir}: exists and is not a folder")
    version = tool_version()
    files = {p.identifier: part_sources(p, version) for p in parts}
    say(f"generated modelDescription.xml and model_config.h for {', '.join(idents)}")
    return compile_and_package(files, out_dir, names, use_cache=use_cache, cache_dir=cache_dir, say=say)
