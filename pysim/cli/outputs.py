"""Where a command may write: checked before any work, so that a run never
ends in a traceback, or with part of its outputs written, because of a path
the user gave."""
from __future__ import annotations

from pathlib import Path

from pysim.cli.errors import UserError

__all__ = ["check_output_file", "check_output_folder"]


def check_output_file(path, what: str) -> Path:
    """The file ``path`` a command will write ``what`` to, or a :class:`UserError` naming what is
    wrong with it: its folder does not exist, or the path is a folder.

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> check_output_file(f"{folder}/model.py", "spec").name
    'model.py'
    >>> try:
    ...     check_output_file(folder, "spec")
    ... except UserError as exc:
    ...     print(str(exc).endswith("is a folder; give a file name for the spec"))
    True
    """
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{path}: is a folder; give a file name for the {what}")
    if not path.parent.is_dir():
        raise UserError(f"{path}: folder {path.parent} for the {what} does not exist")
    return path


def check_output_folder(path, what: str) -> Path:
    """The folder ``path`` a command will write ``what`` into (the command makes it when it is missing),
    or a :class:`UserError`: it exists and is not a folder, or its parent folder does not exist.

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> check_output_folder(f"{folder}/report", "report").name
    'report'
    >>> try:
    ...     check_output_folder(f"{folder}/no/report", "report")
    ... except UserError as exc:
    ...     print("does not exist" in str(exc))
    True
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UserError(f"{path}: exists and is not a folder")
    parent = path.resolve().parent
    if not parent.is_dir():
        raise UserError(f"{path}: folder {parent} for the {what} does not exist")
    return path
