"""The FMI variables of the plant and inverse FMUs.

This list is the single description of each FMU's interface: the model
description (XML) and the C configuration header are both generated from it,
so value references, names, causalities and start values cannot disagree.

Value references: Reals are numbered from 0 in this order -- the input, the
output, the scalar parameters, the thresholds ``r[1]..r[n]``, the weights
``b[1]..b[n]`` -- and Booleans follow the Reals.  FMI 2.0 has no arrays, so
each threshold and weight is its own scalar parameter.

The plant of an extended model (:class:`pysim.core.extended.ExtendedModel` with
output stages) adds, after ``b[n]``, the parameters its stages use as they are
-- the creep weights ``creep_weight[j]`` and the drift coefficients
``drift[j]`` -- and then, last, read-only constants (causality ``local``,
variability ``constant``) that show the stages' physical quantities: the
sample period, lag time constant, resonance, delay, creep time constants and
the drift's span.
Those are fixed at build time: the stages are discretised for the sample
period, and the delay line's length is part of the FMU's memory layout.
"""
from __future__ import annotations

from dataclasses import dataclass

from pysim.core.extended import plant_parts
from pysim.fmu.errors import BuildError

KINDS = ("plant", "inverse")

# (name, unit, description) of the scalar MPI parameters, in value-reference order
_SCALAR_PARAMETERS = (
    ("a1", "um/V3", "cubic coefficient of the input function (0 gives the CPI model)"),
    ("a2", "um/V", "linear coefficient of the input function"),
    ("input_offset", "V", "voltage subtracted from the input: u = voltage - input_offset"),
    ("output_offset", "um", "displacement added to the model output (sensor offset)"),
    ("voltage_min", "V", "lower end of the voltage range"),
    ("voltage_max", "V", "upper end of the voltage range"),
)

# name: (factor, exponents of kg, m, s, A); every FMU declares these
UNITS = {
    "V": (1.0, {"kg": 1, "m": 2, "s": -3, "A": -1}),
    "um": (1e-6, {"m": 1}),
    "um/V": (1e-6, {"kg": -1, "m": -1, "s": 3, "A": 1}),
    "um/V3": (1e-6, {"kg": -3, "m": -5, "s": 9, "A": 3}),
}
# units of the output-stage variables, declared only where they are used
_STAGE_UNITS = {
    "s": (1.0, {"s": 1}),
    "Hz": (1.0, {"s": -1}),
}


def _drift_unit(power: int) -> str:
    return "um/s" if power == 1 else f"um/s{power}"


def unit_definitions(allv) -> dict:
    """``{unit name: (factor, base-unit exponents)}`` of an FMU with the
    variables ``allv``: :data:`UNITS` and the stage units its variables use."""
    out = dict(UNITS)
    for v in allv:
        if v.unit is None or v.unit in out:
            continue
        if v.unit in _STAGE_UNITS:
            out[v.unit] = _STAGE_UNITS[v.unit]
        elif v.unit.startswith("um/s"):
            out[v.unit] = (1e-6, {"m": 1, "s": -int(v.unit[4:] or 1)})
        else:
            raise BuildError(f"no definition of the unit {v.unit!r}")
    return out


@dataclass(frozen=True)
class Variable:
    """One FMI scalar variable.

    ``c_name`` names its value-reference macro (``VR_<c_name>``) in the C
    configuration; array elements after the first have none (the C code
    indexes from the first).
    """

    name: str
    value_reference: int
    type: str                 # "Real" or "Boolean"
    causality: str            # "input", "output", "parameter" or "local" (a constant)
    description: str
    unit: str | None = None
    start: float | bool | None = None
    c_name: str | None = None


def start_voltage(model) -> float:
    """Start value of a voltage (V): 0 V if the range holds it, else its low end."""
    lo, hi = model.voltage_range_V
    return 0.0 if lo <= 0.0 <= hi else lo


def _parameters(model, first_vr: int) -> list:
    model, _ = plant_parts(model)
    values = {"a1": model.a1, "a2": model.a2, "input_offset": model.input_offset_V,
              "output_offset": model.output_offset_um, "voltage_min": model.voltage_range_V[0],
              "voltage_max": model.voltage_range_V[1]}
    out = []
    vr = first_vr
    for name, unit, text in _SCALAR_PARAMETERS:
        out.append(Variable(name, vr, "Real", "parameter", text, unit, float(values[name]), name))
        vr += 1
    for letter, values, unit, text in (
            ("r", model.thresholds_V, "V", "threshold of operator {i} (>= 0, ascending)"),
            ("b", model.weights_um_per_V, "um/V", "weight of operator {i}")):
        for i, value in enumerate(values, start=1):
            out.append(Variable(f"{letter}[{i}]", vr, "Real", "parameter", text.format(i=i), unit,
                                float(value), letter if i == 1 else None))
            vr += 1
    return out


def output_stages(model):
    """The discrete output-stage coefficients of a plant with output stages
    (:meth:`pysim.core.extended.StageSpec.coefficients`), else None."""
    _, stages = plant_parts(model)
    return None if stages is None else stages.coefficients()


def _stage_variables(model, first_vr: int) -> list:
    """Creep-weight and drift parameters, then the read-only stage constants."""
    _, stages = plant_parts(model)
    out = []

    def add(name, causality, text, unit, value, c_name=None):
        out.append(Variable(name, first_vr + len(out), "Real", causality, text, unit, float(value), c_name))

    for j, w in enumerate(stages.creep_weights_um_per_V, start=1):
        add(f"creep_weight[{j}]", "parameter", f"weight of creep mode {j}: its static displacement per volt "
            f"of the shifted input (time constant creep_time_constant[{j}])", "um/V", w,
            "creep_weight" if j == 1 else None)
    for j, p in enumerate(stages.drift_coefficients, start=1):
        add(f"drift[{j}]", "parameter", f"coefficient of t^{j} of the drift added to the displacement "
            "(t: time since the start of the run, s)", _drift_unit(j), p, "drift" if j == 1 else None)
    add("sample_period", "local", "sample period of the output stages: every communication step must be "
        "this long (fixed when the FMU is built)", "s", stages.sample_period_s)
    if stages.lag_time_constant_s > 0:
        add("lag_time_constant", "local", "time constant of the first-order lag after the hysteresis",
            "s", stages.lag_time_constant_s)
    if stages.resonance_hz > 0:
        add("resonance_frequency", "local", "natural frequency of the second-order stage after the "
            "hysteresis", "Hz", stages.resonance_hz)
        add("damping_ratio", "local", "damping ratio of the second-order stage", None, stages.damping_ratio)
    if stages.delay_samples > 0:
        add("delay", "local", f"pure delay of the output ({stages.delay_samples!r} sample periods; "
            "fractions interpolate linearly)", "s", stages.delay_s)
    for j, tau in enumerate(stages.creep_time_constants_s, start=1):
        add(f"creep_time_constant[{j}]", "local", f"time constant of creep mode {j}", "s", tau)
    for j, (tau, share) in enumerate(zip(stages.displacement_creep_time_constants_s,
                                         stages.displacement_creep_shares), start=1):
        add(f"displacement_creep_time_constant[{j}]", "local", f"time constant of displacement creep mode {j} "
            "(driven by the hysteresis output)", "s", tau)
        add(f"displacement_creep_share[{j}]", "local", f"share of a settled displacement that displacement "
            f"creep mode {j} contributes", None, share)
    if stages.drift_coefficients and stages.drift_span_s > 0:
        add("drift_span", "local", "time from which the drift holds its value (the end of the record it "
            "was identified on)", "s", stages.drift_span_s)
    return out


def variables(model, kind: str) -> list:
    """The variables of the ``kind`` ("plant" or "inverse") FMU of ``model``,
    ordered by value reference (Reals first)."""
    v0 = start_voltage(model)
    if kind == "plant":
        head = [
            Variable("voltage", 0, "Real", "input", "voltage applied to the actuator (clamped into "
                     "[voltage_min, voltage_max])", "V", v0, "voltage"),
            Variable("displacement", 1, "Real", "output", "displacement of the actuator", "um",
                     None, "displacement"),
        ]
        tail = []
    elif kind == "inverse":
        y0 = float(plant_parts(model)[0].simulate([v0])[0])
        head = [
            Variable("displacement_ref", 0, "Real", "input", "desired displacement", "um", y0,
                     "displacement_ref"),
            Variable("voltage", 1, "Real", "output", "voltage that makes the model follow "
                     "displacement_ref (within [voltage_min, voltage_max])", "V", None, "voltage"),
        ]
        tail = [None]
    else:
        raise BuildError(f"kind must be one of {KINDS}, got {kind!r}")
    out = head + _parameters(model, len(head))
    if kind == "plant" and output_stages(model) is not None:
        out += _stage_variables(model, len(out))
    if tail:
        out.append(Variable("use_previous_sample", len(out), "Boolean", "parameter",
                            "false: exact inverse per sample; true: the paper's Fig. 7 loop closed "
                            "with the previous sample (analytic inverse of eq. 11-12)",
                            None, False, "use_previous_sample"))
    return out
