"""``build_fmus``: a model spec in, a plant FMU and an inverse-compensator FMU out.

Steps: load and check the spec (the inverse must exist), generate each FMU's
``modelDescription.xml`` and ``model_config.h``, cross-compile the C sources
for every platform (in parallel, cached), check what each binary exports,
and write the archives -- all or nothing.

An extended spec (:class:`pysim.core.extended.ExtendedModel`) gives a plant FMU
with its output stages, stepping at the spec's sample period only, and the
inverse FMU of its hysteresis part: the stages (dynamics, delay, creep,
drift) are not inverted.  An extended spec without stages builds like its
hysteresis part.
"""
from __future__ import annotations

import os
from pathlib import Path

from pysim.core.extended import ExtendedModel, plant_parts
from pysim.core.fileio import staged_directory
from pysim.core.input_stage import InputStageModel
from pysim.core.model import HysteresisModel
from pysim.core.spec import MODEL_TYPES, SpecError, load_spec
from pysim.core.toolchain import SOURCE_DIR, cache_dir
from pysim.fmu import binaries
from pysim.fmu.compile import PLATFORMS, build_binaries
from pysim.fmu.errors import BuildError, ToolchainError
from pysim.fmu.generate import fmu_sources, model_identifier, stage_summary
from pysim.fmu.package import fmu_bytes
from pysim.fmu.variables import KINDS, output_stages

DEFAULT_PLATFORMS = ("linux64", "win64", "darwin64")


def tool_version() -> str:
    try:
        from importlib.metadata import version

        return version("piezo-mpi")
    except Exception:  # running from a source tree that is not installed
        return "0.1.0"


def default_cache_dir() -> Path:
    """``$PIEZO_MPI_CACHE/fmu-binaries`` (default ``~/.cache/piezo-mpi``)."""
    return cache_dir() / "fmu-binaries"


def check_model(model, source="spec", kinds=KINDS) -> str:
    """Refuse what the FMUs cannot represent; returns the invertibility text
    (of the hysteresis part, for an extended model).  Only the inverse FMU
    needs an invertible model: a plant alone (``kinds=("plant",)``) builds
    from any model and the text then says whether an inverse would exist."""
    if type(model) not in (HysteresisModel, ExtendedModel):
        raise BuildError(f"{source}: {type(model).__name__} is not supported by build-fmu "
                         "(it exports HysteresisModel and ExtendedModel specs only)")
    model, _ = plant_parts(model)
    if model.n_operators < 1:
        raise BuildError(f"{source}: the model needs at least one operator")
    if not model.name.isascii():
        raise BuildError(f"{source}: the model name {model.name!r} must be ASCII: it names the FMU's C "
                         "identifier and files")
    report = model.check_invertibility()
    if not report.invertible and "inverse" in kinds:
        raise BuildError(f"{source}: the inverse FMU cannot be built: {report.message} (a plant FMU "
                         "alone builds from it: build-fmu --kinds plant)")
    return report.message


def platform_names(platforms) -> tuple:
    """The platforms asked for (one name or several), each once and in order; an unknown or missing
    one is a :class:`BuildError` naming the choices."""
    if isinstance(platforms, str):
        platforms = (platforms,)
    names = tuple(dict.fromkeys(platforms))
    unknown = [p for p in names if p not in PLATFORMS]
    if unknown or not names:
        raise BuildError(f"unknown platform(s) {unknown or '(none given)'}; choose from {sorted(PLATFORMS)}")
    return names


def fmu_models(model) -> dict:
    """``{kind: model}``: what each FMU is built from.  The inverse of an
    extended model compensates its hysteresis part; an extended model
    without stages is its hysteresis part."""
    hysteresis, stages = plant_parts(model)
    if stages is None:
        return {"plant": hysteresis, "inverse": hysteresis}
    note = "hysteresis part of an extended spec; its output stages are not inverted"
    inverse = hysteresis.with_parameters(description=f"{note} ({model.description})" if model.description
                                         else note)
    return {"plant": model, "inverse": inverse}


def build_fmus(spec_or_model, out_dir, platforms=DEFAULT_PLATFORMS, *, use_cache=True,
               cache_dir=None, progress=None, kinds=KINDS, without_input_stage: bool = False) -> dict:
    """Build ``<name>_plant.fmu`` and ``<name>_inverse.fmu``.

    For an extended spec with output stages the plant includes the stages
    and steps at the spec's sample period only; the inverse compensates the
    hysteresis part alone (the stages are not inverted).  A model with a
    stage before the hysteresis (:class:`~pysim.core.input_stage.InputStageModel`,
    which ``pysim diagnose --out`` writes for an input low-pass, a slew limit
    or thresholds that grow with the input's rate) is refused: the FMUs hold
    no input stage, and a plant FMU without it would not be the model named.
    ``without_input_stage=True`` builds the part after the stage, and says so.

    Parameters
    ----------
    spec_or_model : HysteresisModel, ExtendedModel, path or module name
        The model spec (see :func:`pysim.core.spec.load_spec`).
    out_dir : path
        Folder for the two FMUs (created if needed).
    platforms : iterable of {"linux64", "win64", "darwin64"}
        Binaries to include; the C sources are always included.
    use_cache : bool
        Reuse binaries compiled before from identical sources (default).
    cache_dir : path, optional
        Where cached binaries live (default :func:`default_cache_dir`).
    progress : callable(str), optional
        Called with one line per step.
    kinds : iterable of {"plant", "inverse"}
        The FMUs to build (default both).  A plant alone builds from a model
        whose inverse does not exist (a rig's true actuator, say).
    without_input_stage : bool
        For a model with an input stage: build the FMUs of what follows it.

    Returns
    -------
    dict
        ``{"plant": Path, "inverse": Path}``.

    Raises
    ------
    BuildError
        The spec cannot be loaded, is not a supported model, its inverse does
        not exist, or an option is invalid.  Nothing is written.
    ToolchainError
        zig or the FMI headers are missing, or compiling failed.
    """
    say = progress or (lambda message: None)
    try:
        model = load_spec(spec_or_model)
    except SpecError as exc:
        raise BuildError(str(exc)) from exc
    source = spec_or_model if not isinstance(spec_or_model, MODEL_TYPES) else f"model {model.name}"
    if isinstance(model, InputStageModel):
        stage = model.stage_summary()
        grown = model.kind == "rate_thresholds"
        what = stage if grown else f"an input stage before the hysteresis, {stage}"
        part = "its rate-independent part" if grown else "the part after it"
        if not without_input_stage:
            raise BuildError(f"{source}: MODEL has {what}, which an FMU "
                             f"cannot hold; build the FMUs of {part} with --without-input-stage "
                             "(build_fmus(..., without_input_stage=True)), knowing they omit that stage")
        say(f"input stage {stage} left out, as asked: the FMUs are of {part}")
        model = model.plant
    names = platform_names(platforms)
    kinds = tuple(k for k in KINDS if k in tuple(kinds))
    if not kinds:
        raise BuildError(f"kinds must name at least one of {KINDS}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise BuildError(f"{out_dir}: exists and is not a folder")
    lo, hi = model.voltage_range_V
    what = f"{model.n_operators} {plant_parts(model)[0].operator} operators, {lo:g} V to {hi:g} V"
    say(f"loaded {source}: model {model.name}, {what}" if source != f"model {model.name}"
        else f"model {model.name}: {what}")
    say(check_model(model, source, kinds))
    models = fmu_models(model)
    if isinstance(model, ExtendedModel):
        stages = output_stages(models["plant"])
        if stages is None:
            say("extended spec without output stages: building the FMUs of its hysteresis part")
        else:
            say(f"output stages {stage_summary(model)} at {stages['sample_period_s']:g} s: the plant FMU "
                "steps at that period only; the inverse FMU compensates the hysteresis part alone "
                "(the stages are not inverted)")

    version = tool_version()
    files = {kind: fmu_sources(models[kind], kind, SOURCE_DIR, version) for kind in kinds}
    idents = {kind: model_identifier(models[kind], kind) for kind in kinds}
    say(f"generated modelDescription.xml and model_config.h for {', '.join(idents.values())}")

    written = compile_and_package({idents[kind]: files[kind] for kind in kinds}, out_dir, names,
                                  use_cache=use_cache, cache_dir=cache_dir, say=say,
                                  checked_note=f"each exports exactly the {len(binaries.FMI2_CS_FUNCTIONS)} "
                                               "fmi2 co-simulation functions", size_note=f"{', '.join(names)} + sources")
    return {kind: written[idents[kind]] for kind in kinds}


def compile_and_package(files_by_identifier: dict, out_dir, names, *, use_cache: bool = True, cache_dir=None,
                        say=lambda message: None, checked_note: str = "", size_note: str = "") -> dict:
    """Compile every FMU's sources for every platform, check the exports, write the FMUs.

    The one packaging step of every FMU this package builds (plant, inverse,
    rig parts): the binaries come from the cache when their sources are
    unchanged, each must export exactly the FMI 2.0 co-simulation functions,
    and the ``.fmu`` files appear in ``out_dir`` together or not at all.

    Parameters
    ----------
    files_by_identifier : dict
        ``{model identifier: {archive path: bytes}}`` with the sources under
        ``sources/``.
    out_dir : path
        Folder for ``<identifier>.fmu``.
    names : list of str
        Platform names (see :data:`pysim.fmu.compile.PLATFORMS`).
    use_cache, cache_dir, say
        As in :func:`build_fmus`.
    checked_note, size_note : str
        Added to the progress lines.

    Returns
    -------
    dict
        ``{identifier: Path}``.

    Examples
    --------
    >>> compile_and_package({}, "fmus/", ["linux64"])
    {}
    """
    out_dir = Path(out_dir)
    jobs = []
    for ident, files in files_by_identifier.items():
        sources = {path[len("sources/"):]: data for path, data in files.items() if path.startswith("sources/")}
        jobs += [(ident, sources, name) for name in names]
    if not jobs:
        return {}
    cache = (Path(cache_dir) if cache_dir else default_cache_dir()) if use_cache else None
    built = build_binaries(jobs, cache, say)
    for (ident, name), data in built.items():
        try:
            binaries.check_exports(data, f"{ident} for {name}")
        except binaries.BinaryError as exc:
            raise ToolchainError(f"the built library is wrong: {exc}") from exc
    if checked_note:
        say(f"checked the binaries: {checked_note}")
    result = {}
    with staged_directory(out_dir) as staging:
        for ident, files in files_by_identifier.items():
            content = dict(files)
            for name in names:
                content[f"binaries/{name}/{ident}{PLATFORMS[name].suffix}"] = built[(ident, name)]
            (staging / f"{ident}.fmu").write_bytes(fmu_bytes(content))
            result[ident] = out_dir / f"{ident}.fmu"
    for ident, path in result.items():
        say(f"wrote {path} ({os.path.getsize(path) / 1024:.0f} kB" + (f", {size_note})" if size_note else ")"))
    return result
