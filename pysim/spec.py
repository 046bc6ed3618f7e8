"""Model specs: Python files that define ``MODEL``.

A spec is a Python module (in ``models/`` or anywhere) whose module-level
``MODEL`` is a :class:`pysim.model.HysteresisModel` (or a subclass, such as an
extended model).  ``pysim identify`` writes them, ``build-fmu`` reads them.
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

from pysim.fileio import atomic_write_text
from pysim.model import HysteresisModel


class SpecError(ValueError):
    """A spec that cannot be loaded or is not a model."""


def load_spec(source) -> HysteresisModel:
    """Load the ``MODEL`` of a spec.

    Parameters
    ----------
    source : str, Path or HysteresisModel
        A path to a ``.py`` file, a module name (``models.default_mpi``), a bare
        name looked up in ``models/`` (``default_mpi``), or a model (returned).
    """
    if isinstance(source, HysteresisModel):
        return source
    text = str(source)
    path = Path(text)
    if text.endswith(".py") or path.exists():
        if not path.exists():
            raise SpecError(f"{text}: spec file does not exist")
        if path.is_dir():
            raise SpecError(f"{text}: is a directory, not a spec file")
        spec = importlib.util.spec_from_file_location(f"_piezo_spec_{abs(hash(str(path.resolve())))}", path)
        module = importlib.util.module_from_spec(spec)
        try:
            spec.loader.exec_module(module)
        except Exception as exc:  # the spec's own error, reported with its file
            raise SpecError(f"{text}: {type(exc).__name__}: {exc}") from exc
    else:
        name = text if "." in text else f"models.{text}"
        try:
            module = importlib.import_module(name)
        except ImportError as exc:
            raise SpecError(f"{text}: no spec file or module of that name ({exc})") from exc
        except Exception as exc:
            raise SpecError(f"{text}: {type(exc).__name__}: {exc}") from exc
    model = getattr(module, "MODEL", None)
    if not isinstance(model, HysteresisModel):
        raise SpecError(f"{text}: defines no MODEL of type HysteresisModel")
    return model


def _literal(value) -> str:
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (tuple, list)):
        inner = ", ".join(_literal(v) for v in value)
        return f"({inner},)" if len(value) == 1 else f"({inner})"
    return repr(value)


def spec_source(model: HysteresisModel, header: str = "") -> str:
    """Python source of a spec file defining ``model`` (floats written exactly)."""
    cls = type(model)
    fields = [f for f in model.__dataclass_fields__.values() if f.init]
    lines = [f'"""{header or model.description or model.name}"""',
             f"from {cls.__module__} import {cls.__name__}", "",
             f"MODEL = {cls.__name__}("]
    for f in fields:
        lines.append(f"    {f.name}={_literal(getattr(model, f.name))},")
    lines.append(")")
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
