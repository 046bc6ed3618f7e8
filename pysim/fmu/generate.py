"""Generated files of an FMU: ``model_config.h`` and ``modelDescription.xml``.

Both come from the variable list of :mod:`pysim.fmu.variables`; the C sources
in ``fmu_src/`` are written by hand and never generated.
"""
from __future__ import annotations

import hashlib
import uuid
from xml.sax.saxutils import quoteattr

from pysim.core.extended import plant_parts
from pysim.fmu.variables import output_stages, unit_definitions, variables

GENERATION_TOOL = "piezo-mpi build-fmu"
LOG_CATEGORIES = (
    ("logEvents", "state changes: instantiation, initialisation, termination, reset"),
    ("logStatusWarning", "adjusted inputs (voltage clamped into its range, inverse saturated)"),
    ("logStatusError", "rejected calls and invalid parameters (always reported)"),
)
OPERATOR_MACROS = {"osp": "HYST_OSP", "play": "HYST_PLAY"}
_CAUSALITY_ORDER = {"input": 0, "output": 1, "parameter": 2, "local": 3}


def model_identifier(model, kind: str) -> str:
    """``<name>_<kind>``: the FMU's model identifier and binary name."""
    return f"{model.name}_{kind}"


def c_double_literal(value: float) -> str:
    """A C ``double`` literal that reads back to exactly ``value``.

    Examples
    --------
    >>> c_double_literal(2), c_double_literal(0.1), c_double_literal(1e-300)
    ('2.0', '0.1', '1e-300')
    """
    text = repr(float(value))               # shortest exact round trip
    return text if any(c in text for c in ".en") else text + ".0"


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _operator(model) -> str:
    return plant_parts(model)[0].operator


def model_guid(model, kind: str, source_digest: str) -> str:
    """GUID from a hash of everything the FMU is made of: the variables with
    their start values, the operator kind, the output stages' coefficients
    (extended plants) and the C sources."""
    digest = hashlib.sha256()
    digest.update(f"{GENERATION_TOOL}\n{kind}\n{model_identifier(model, kind)}\n{_operator(model)}\n".encode())
    for v in variables(model, kind):
        digest.update(repr((v.name, v.value_reference, v.type, v.causality, v.unit, v.start)).encode())
    stages = output_stages(model) if kind == "plant" else None
    if stages is not None:
        digest.update(repr(sorted(stages.items())).encode())
    digest.update(source_digest.encode())
    return "{" + str(uuid.UUID(bytes=digest.digest()[:16], version=5)) + "}"


def instance_magic(guid: str) -> int:
    """The 16-bit number that marks a live instance of the FMU with this GUID
    (high bit set, never 0): the C layer refuses a component whose mark is
    another FMU's, so handles mixed up between two FMUs in one process are
    refused, not read with the wrong memory layout."""
    return 0x8000 | int.from_bytes(hashlib.sha256(guid.encode()).digest()[:2], "little") & 0x7FFF


def c_initializer(items) -> str:
    """A C array initializer of the given element texts, wrapped at 100 columns.

    Examples
    --------
    >>> print(c_initializer(["1.0", "2.5"]))
    { \\
        1.0, 2.5 \\
    }
    """
    items = list(items)
    lines, line = [], "    "
    for item in items:
        piece = item + ", "
        if len(line) + len(piece) > 100:
            lines.append(line.rstrip())
            line = "    "
        line += piece
    lines.append(line.rstrip().rstrip(","))
    return "{ \\\n" + " \\\n".join(lines) + " \\\n}"


def _c_array(values) -> str:
    """A C initializer of doubles; ``{ 0.0 }`` for none (C has no empty arrays,
    and the count macro says that nothing is used)."""
    values = [c_double_literal(x) for x in values]
    return c_initializer(values) if values else "{ 0.0 }"


def _stage_config(model) -> list:
    """Lines of model_config.h for the output stages of an extended plant: the
    discrete coefficients, exact, and the sizes (layout in output_stages.h)."""
    stages = output_stages(model)
    if stages is None:
        return []
    sections = [x for section in stages["sections"] for x in section]
    return [
        "",
        "/* Output stages after the hysteresis (extended model, see output_stages.h):",
        " * coefficients discretised for the sample period; the creep weights and",
        " * drift coefficients are parameters (VR_creep_weight, VR_drift). */",
        "#define MODEL_HAS_OUTPUT_STAGES 1",
        f"#define MODEL_SAMPLE_PERIOD {c_double_literal(stages['sample_period_s'])}",
        "#define MODEL_FIXED_STEP_SIZE MODEL_SAMPLE_PERIOD",
        f"#define MODEL_N_SECTIONS {len(stages['sections'])}",
        f"#define MODEL_SECTIONS {_c_array(sections)}",
        f"#define MODEL_DELAY_WHOLE {int(stages['delay_whole'])}",
        f"#define MODEL_DELAY_FRACTION {c_double_literal(stages['delay_fraction'])}",
        f"#define MODEL_N_CREEP {len(stages['creep_alpha'])}",
        f"#define MODEL_CREEP_ALPHA {_c_array(stages['creep_alpha'])}",
        f"#define MODEL_CREEP_BETA {_c_array(stages['creep_beta'])}",
        f"#define MODEL_N_DRIFT {len(stages['drift'])}",
        f"#define MODEL_DRIFT_SPAN {c_double_literal(stages['drift_span_s'])}",
        f"#define MODEL_STAGE_STATE_SIZE {plant_parts(model)[1].state_size}",
    ]


def units_and_log_categories_xml(units: dict, log_categories=LOG_CATEGORIES) -> list:
    """``<UnitDefinitions>`` (when any unit is used) and ``<LogCategories>`` lines of a
    modelDescription.xml; ``units`` maps a unit name to ``(factor, {SI base: exponent})``,
    ``log_categories`` holds ``(name, description)`` pairs."""
    lines = []
    if units:
        lines.append("  <UnitDefinitions>")
        for name, (factor, exponents) in units.items():
            base = xml_attributes(**{k: str(e) for k, e in exponents.items()},
                                  factor=None if factor == 1.0 else xml_double(factor))
            lines.append(f"    <Unit {xml_attributes(name=name)}><BaseUnit {base}/></Unit>")
        lines.append("  </UnitDefinitions>")
    lines.append("  <LogCategories>")
    for name, text in log_categories:
        lines.append(f"    <Category {xml_attributes(name=name, description=text)}/>")
    lines.append("  </LogCategories>")
    return lines


def model_variables_xml(all_variables) -> list:
    """``<ModelVariables>`` lines: inputs and outputs continuous, parameters fixed,
    locals constant; each variable's 1-based index in a comment."""
    lines = ["  <ModelVariables>"]
    for v in all_variables:
        variability = "continuous" if v.causality in ("input", "output") and v.type == "Real" else (
            {"parameter": "fixed", "local": "constant"}.get(v.causality, "discrete"))
        initial = {"parameter": "exact", "output": "calculated", "local": "exact"}.get(v.causality)
        lines.append(f"    <!-- index {v.value_reference + 1} -->")
        lines.append("    <ScalarVariable " + xml_attributes(
            name=v.name, valueReference=v.value_reference, description=v.description,
            causality=v.causality, variability=variability, initial=initial) + ">")
        if v.type == "Real":
            start = None if v.start is None else xml_double(v.start)
            lines.append(f"      <Real {xml_attributes(unit=v.unit, start=start)}/>")
        else:
            lines.append(f"      <Boolean {xml_attributes(start='true' if v.start else 'false')}/>")
        lines.append("    </ScalarVariable>")
    lines.append("  </ModelVariables>")
    return lines


def config_header_text(identifier: str, guid: str, what: str, all_variables, model_defines=(),
                       trailing_defines=()) -> str:
    """Text of a ``model_config.h``: the defines the shared FMI layer reads
    (identifier, GUID, instance mark, variable counts, value references, names
    and start values), framed by the FMU's own ``model_defines`` (before the
    variables) and ``trailing_defines`` (after them).

    Examples
    --------
    >>> from pysim.fmu.variables import Variable
    >>> text = config_header_text("m", "{0}", "example", [Variable("x", 0, "Real", "input", "a command", "V", 0.0, "X")])
    >>> "#define VR_X 0" in text and "#define MODEL_N_INPUTS 1" in text
    True
    """
    reals = [v for v in all_variables if v.type == "Real"]
    booleans = [v for v in all_variables if v.type == "Boolean"]
    # the C layer finds a Real's causality from its value reference
    order = [_CAUSALITY_ORDER[v.causality] for v in reals]
    if order != sorted(order) or [v.value_reference for v in all_variables] != list(range(len(all_variables))):
        raise AssertionError("Real variables must be inputs, outputs, parameters, numbered from 0")
    out = [
        "/*",
        f" * model_config.h -- generated by {GENERATION_TOOL} for {identifier}",
        f" * ({what}).  Do not edit: change the spec and rebuild.",
        " */",
        "#ifndef PIEZO_MODEL_CONFIG_H",
        "#define PIEZO_MODEL_CONFIG_H",
        "",
        f"#define MODEL_IDENTIFIER_STRING {_c_string(identifier)}",
        f"#define MODEL_GUID {_c_string(guid)}",
        f"#define MODEL_INSTANCE_MAGIC 0x{instance_magic(guid):04x}u",
        *model_defines,
        f"#define MODEL_N_REALS {len(reals)}",
        f"#define MODEL_N_INPUTS {sum(v.causality == 'input' for v in reals)}",
        f"#define MODEL_N_OUTPUTS {sum(v.causality == 'output' for v in reals)}",
        f"#define MODEL_N_CONSTANTS {sum(v.causality == 'local' for v in reals)}",
        f"#define MODEL_N_BOOLEANS {len(booleans)}",
        f"#define MODEL_FIRST_BOOLEAN_VR {len(reals)}",
        "",
        "/* value references (arrays: the first element, the others follow) */",
    ]
    out += [f"#define VR_{v.c_name} {v.value_reference}" for v in all_variables if v.c_name]
    out += [
        "",
        f"#define MODEL_REAL_NAMES {c_initializer(_c_string(v.name) for v in reals)}",
        f"#define MODEL_REAL_STARTS {c_initializer(c_double_literal(v.start or 0.0) for v in reals)}",
    ]
    if booleans:
        out += [
            f"#define MODEL_BOOLEAN_NAMES {c_initializer(_c_string(v.name) for v in booleans)}",
            f"#define MODEL_BOOLEAN_STARTS {c_initializer('1' if v.start else '0' for v in booleans)}",
        ]
    out += [*trailing_defines, "", "#endif /* PIEZO_MODEL_CONFIG_H */", ""]
    return "\n".join(out)


def config_header(model, kind: str, guid: str) -> str:
    """Text of ``model_config.h`` for the ``kind`` FMU of ``model``."""
    return config_header_text(
        model_identifier(model, kind), guid, f"{kind} FMU of the spec '{model.name}'", variables(model, kind),
        model_defines=[f"#define MODEL_N_OPERATORS {model.n_operators}",
                       f"#define MODEL_OPERATOR_KIND {OPERATOR_MACROS[_operator(model)]}"],
        trailing_defines=_stage_config(model) if kind == "plant" else ())


def xml_double(value: float) -> str:
    """An XML attribute value that reads back to exactly ``value`` (the shortest round trip)."""
    return repr(float(value))


def xml_attributes(**attrs) -> str:
    """``key="value"`` pairs, quoted and escaped for XML; a value of None leaves its key out.

    Examples
    --------
    >>> print(xml_attributes(name="a<b", unit=None, start="1.0"))
    name="a&lt;b" start="1.0"
    """
    return " ".join(f"{key}={quoteattr(str(value))}" for key, value in attrs.items() if value is not None)


def model_description(model, kind: str, guid: str, source_files, version: str) -> str:
    """Text of ``modelDescription.xml`` (FMI 2.0 co-simulation)."""
    allv = variables(model, kind)
    ident = model_identifier(model, kind)
    stages = output_stages(model) if kind == "plant" else None
    what = ("MPI hysteresis plant: voltage (V) to displacement (um)" if kind == "plant" else
            "inverse compensator of the MPI hysteresis model: displacement (um) to voltage (V)")
    description = f"{what}; {model.n_operators} {_operator(model)} operators"
    if stages is not None:
        description += (f"; output stages {stage_summary(model)}, sampled at "
                        f"{xml_double(stages['sample_period_s'])} s (fixed communication step)")
    description += f"; spec {model.name}"
    if model.description:
        description += f": {model.description}"
    lines = ['<?xml version="1.0" encoding="UTF-8"?>']
    lines.append("<fmiModelDescription " + xml_attributes(
        fmiVersion="2.0", modelName=ident, guid=guid, description=description,
        generationTool=f"{GENERATION_TOOL} {version}", version=version,
        variableNamingConvention="structured", numberOfEventIndicators="0") + ">")
    lines.append("  <CoSimulation " + xml_attributes(
        modelIdentifier=ident, needsExecutionTool="false",
        canHandleVariableCommunicationStepSize="true" if stages is None else "false",
        canInterpolateInputs="false", maxOutputDerivativeOrder="0", canRunAsynchronuously="false",
        canBeInstantiatedOnlyOncePerProcess="false", canNotUseMemoryManagementFunctions="false",
        canGetAndSetFMUstate="true", canSerializeFMUstate="true",
        providesDirectionalDerivative="false") + ">")
    lines.append("    <SourceFiles>")
    for name in source_files:
        lines.append(f"      <File {xml_attributes(name=name)}/>")
    lines.append("    </SourceFiles>")
    lines.append("  </CoSimulation>")
    lines += units_and_log_categories_xml(unit_definitions(allv))
    step = "0.001" if stages is None else xml_double(stages["sample_period_s"])
    lines.append("  " + "<DefaultExperiment " + xml_attributes(startTime="0.0", stopTime="1.0", stepSize=step)
                 + "/>")
    lines += model_variables_xml(allv)
    # ModelStructure indices are 1-based positions in ModelVariables (= vr + 1)
    inputs = [v for v in allv if v.causality == "input"]
    outputs = [v for v in allv if v.causality == "output"]
    parameters = [v for v in allv if v.causality == "parameter"]
    lines.append("  <ModelStructure>")
    lines.append("    <Outputs>")
    for out in outputs:
        deps = [v.value_reference + 1 for v in inputs]
        lines.append(f"      <Unknown {_dependencies(out.value_reference + 1, deps)}/>")
    lines.append("    </Outputs>")
    lines.append("    <InitialUnknowns>")
    for out in outputs:
        deps = [v.value_reference + 1 for v in inputs + parameters]
        lines.append(f"      <Unknown {_dependencies(out.value_reference + 1, deps)}/>")
    lines.append("    </InitialUnknowns>")
    lines.append("  </ModelStructure>")
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"


def stage_summary(model) -> str:
    """The output stages of an extended model in a few words, e.g.
    ``lag 2 ms + delay 3 samples + 2 creep modes``."""
    _, stages = plant_parts(model)
    parts = []
    if stages.lag_time_constant_s > 0:
        parts.append(f"lag {stages.lag_time_constant_s:g} s")
    if stages.resonance_hz > 0:
        parts.append(f"resonance {stages.resonance_hz:g} Hz (damping {stages.damping_ratio:g})")
    if stages.delay_samples > 0:
        parts.append(f"delay {stages.delay_samples:g} samples")
    if stages.creep_time_constants_s:
        n = len(stages.creep_time_constants_s)
        parts.append(f"{n} creep mode{'s' if n > 1 else ''}")
    if stages.displacement_creep_time_constants_s:
        n = len(stages.displacement_creep_time_constants_s)
        parts.append(f"{n} displacement creep mode{'s' if n > 1 else ''}")
    if stages.drift_coefficients:
        held = f", held from {stages.drift_span_s:g} s on" if stages.drift_span_s > 0 else ""
        parts.append(f"drift of degree {len(stages.drift_coefficients)}{held}")
    return " + ".join(parts) or "none"


def _dependencies(index: int, deps) -> str:
    return xml_attributes(index=index, dependencies=" ".join(map(str, deps)),
                          dependenciesKind=" ".join("dependent" for _ in deps))


# Hand-written C files shipped in every FMU's sources/ (besides the model's
# own model.c/model.h and the generated model_config.h).  all.c compiles the
# output stages only into the plant of an extended model; every FMU carries
# them so that the source set is the same for all.
SHARED_SOURCES = ("all.c", "fmi2_layer.c", "fmi2_layer.h", "hysteresis.c", "hysteresis.h",
                  "mpi_parameters.c", "mpi_parameters.h", "output_stages.c", "output_stages.h")
MODEL_SOURCES = ("model.c", "model.h")
COMPILED_SOURCES = ("all.c",)          # the rest is included by all.c


def hand_written_sources(kind: str, source_dir) -> dict:
    """``{file name: bytes}`` of the C sources of the ``kind`` FMU."""
    from pathlib import Path

    source_dir = Path(source_dir)
    files = {name: (source_dir / name).read_bytes() for name in SHARED_SOURCES}
    files.update({name: (source_dir / kind / name).read_bytes() for name in MODEL_SOURCES})
    return files


def fmu_sources(model, kind: str, source_dir, version: str) -> dict:
    """Everything of the ``kind`` FMU except its binaries, as
    ``{path inside the FMU: bytes}``: ``modelDescription.xml`` and
    ``sources/*``."""
    files = hand_written_sources(kind, source_dir)
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(name.encode() + b"\0" + files[name] + b"\0")
    guid = model_guid(model, kind, digest.hexdigest())
    files["model_config.h"] = config_header(model, kind, guid).encode()
    out = {"modelDescription.xml": model_description(model, kind, guid, COMPILED_SOURCES, version).encode()}
    out.update({f"sources/{name}": data for name, data in sorted(files.items())})
    return out
