"""Model specs: Python files that define ``MODEL``.

A spec is a Python module (in ``models/`` or anywhere) whose module-level
``MODEL`` is a :class:`pysim.core.model.HysteresisModel`, an extended model
(:class:`pysim.core.extended.ExtendedModel`: output stages after the
hysteresis) or a model with a stage before it
(:class:`pysim.core.input_stage.InputStageModel`).  ``pysim identify`` and
``pysim diagnose --out`` write them, ``build-fmu`` reads them, and
:func:`load_spec` gives the model to run on any input.
"""
from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import re
import sys
from pathlib import Path

from pysim.core.errors import SpecError
from pysim.core.extended import ExtendedModel
from pysim.core.fileio import atomic_write_text
from pysim.core.input_stage import InputStageModel
from pysim.core.model import HysteresisModel

#: What a spec's ``MODEL`` may be.
MODEL_TYPES = (HysteresisModel, ExtendedModel, InputStageModel)


def load_module(source, what: str = "spec"):
    """The Python module of a spec file or a shipped spec, executed.

    The one loader of spec files: models (``MODEL``), stages (``STAGE``) and
    rigs (``RIG``) all come through it.

    Parameters
    ----------
    source : str or Path
        A path to a ``.py`` file, a module name (``pysim.specs.default_mpi``),
        or a bare name of a shipped spec (``default_mpi``: ``models/`` in the
        repository, installed as ``pysim.specs``).
    what : str
        What the file is, for the messages ("spec", "stage", "rig").

    Raises
    ------
    SpecError
        Missing file or module, a directory, or the file's own error (named
        with its type and the file).
    """
    text = str(source)
    path = Path(text)
    if text.endswith(".py") or path.exists():
        if not path.exists():
            raise SpecError(f"{text}: {what} file does not exist")
        if path.is_dir():
            raise SpecError(f"{text}: is a directory, not a {what} file")
        spec = importlib.util.spec_from_file_location(f"_piezo_{what}_{abs(hash(str(path.resolve())))}", path)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:  # the spec's own error, reported with its file
            raise SpecError(f"{text}: {type(exc).__name__}: {exc}") from exc
        return module
    name = text if "." in text else f"pysim.specs.{text}"
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise SpecError(f"{text}: no {what} file or module of that name ({exc})") from exc
    except Exception as exc:
        raise SpecError(f"{text}: {type(exc).__name__}: {exc}") from exc


def load_spec(source):
    """Load the ``MODEL`` of a spec.

    Parameters
    ----------
    source : str, Path or model
        A path to a ``.py`` file, a module name (``pysim.specs.default_mpi``), a bare
        name of a shipped spec (``default_mpi``), or a model (returned); see
        :func:`load_module`.

    Returns
    -------
    HysteresisModel, ExtendedModel or InputStageModel
        Every one runs a voltage record (V) with ``simulate`` into displacement (µm),
        from rest at its first sample unless given a state.

    Examples
    --------
    >>> import numpy as np
    >>> model = load_spec("default_mpi")
    >>> y = model.simulate(np.linspace(0.0, 150.0, 4))
    >>> model.name, round(float(y[-1]), 1)
    ('default_mpi', 74.6)
    """
    if isinstance(source, MODEL_TYPES):
        return source
    module = load_module(source, "spec")
    model = getattr(module, "MODEL", None)
    if not isinstance(model, MODEL_TYPES):
        raise SpecError(f"{source}: defines no MODEL of type HysteresisModel, ExtendedModel or InputStageModel")
    return model


def model_name_from_path(path, default: str = "model") -> str:
    """A model name (a C identifier: it names the FMU's C symbols and files)
    derived from a spec file name: ``x-y.py`` -> ``x_y``, ``2024 run.py`` ->
    ``m_2024_run``.

    Examples
    --------
    >>> model_name_from_path("/tmp/x-y.py")
    'x_y'
    >>> model_name_from_path("2024 run.py")
    'm_2024_run'
    """
    stem = Path(str(path)).stem if path else ""
    name = re.sub(r"[^0-9A-Za-z_]+", "_", stem).strip("_")
    if not name:
        return default
    return f"m_{name}" if name[0].isdigit() else name


def _literal(value, indent: str = "    ") -> str:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _constructor(value, indent)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (tuple, list)):
        inner = ", ".join(_literal(v, indent) for v in value)
        return f"({inner},)" if len(value) == 1 else f"({inner})"
    return repr(value)


def _constructor(value, indent: str) -> str:
    """``Class(\n    field=value,\n)`` over the init fields, nested parts indented."""
    inner = indent + "    "
    lines = [f"{type(value).__name__}("]
    for f in dataclasses.fields(value):
        if f.init:
            lines.append(f"{indent}{f.name}={_literal(getattr(value, f.name), inner)},")
    lines.append(f"{indent[:-4]})")
    return "\n".join(lines)


def _classes(value) -> dict:
    """``{module: {class names}}`` of a model and of the parts it is made of."""
    found = {}
    stack = [value]
    while stack:
        item = stack.pop()
        if dataclasses.is_dataclass(item) and not isinstance(item, type):
            found.setdefault(type(item).__module__, set()).add(type(item).__name__)
            stack += [getattr(item, f.name) for f in dataclasses.fields(item) if f.init]
    return found


def spec_source(model, header: str = "") -> str:
    """Python source of a spec file defining ``model`` (floats written exactly;
    a composed model is written with its parts).

    Examples
    --------
    >>> from pysim.core.model import HysteresisModel
    >>> print(spec_source(HysteresisModel(0.0, 0.5, (0.0,), (0.1,)), "a line plant"))  # doctest: +ELLIPSIS
    \"\"\"a line plant\"\"\"
    from pysim.core.model import HysteresisModel
    <BLANKLINE>
    MODEL = HysteresisModel(
        a1=0.0,
        a2=0.5,
    ...
    """
    imports = [f"from {module} import {', '.join(sorted(names))}" for module, names in sorted(_classes(model).items())]
    lines = [f'"""{header or model.description or model.name}"""', *imports, "",
             f"MODEL = {_constructor(model, '    ')}"]
    return "\n".join(lines) + "\n"


def write_spec(model: HysteresisModel, path, header: str = "") -> Path:
    """Write ``model`` as a spec file (atomically: all or nothing)."""
    path = Path(path)
    source = spec_source(model, header)
    directory = path.parent if str(path.parent) else Path(".")
    if not directory.is_dir():
        raise SpecError(f"{path}: folder {directory} does not exist")
    atomic_write_text(path, source)
    sys.modules.pop(path.stem, None)
    return path
