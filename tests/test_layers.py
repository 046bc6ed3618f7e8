"""The package's layers import only downward.

Every module of the installed ``pysim`` and ``build_fmu`` packages is parsed and
every ``import`` in it -- at the top, inside functions, under ``if`` -- is held
against the table below.  The table is the design (``pysim/__init__.py`` and
the README's Layout section say the same): a layer may import the layers it
lists and nothing else of the package.
"""
import ast
import importlib
import importlib.util
import pkgutil
from pathlib import Path

import pytest

import build_fmu
import pysim

ALLOWED = {
    "pysim.core": set(),
    "pysim.specs": {"pysim.core", "pysim.cosim"},
    "pysim.fmu": {"pysim.core"},
    "pysim.identification": {"pysim.core"},
    "pysim.cosim": {"pysim.core", "pysim.fmu"},
    "pysim.diagnosis": {"pysim.core", "pysim.identification"},
    "pysim.studies": {"pysim.core", "pysim.specs", "pysim.fmu", "pysim.cosim", "pysim.identification",
                      "pysim.diagnosis"},
    "pysim.testing": {"pysim.core", "pysim.specs", "pysim.fmu", "pysim.cosim", "pysim.identification"},
    "pysim.cli": {"pysim.core", "pysim.specs", "pysim.fmu", "pysim.cosim", "pysim.identification",
                  "pysim.diagnosis", "pysim.studies"},
    "build_fmu": {"pysim.core", "pysim.fmu"},
}
# The shipped specs (models/) are data that define models and rigs with the core
# and cosim classes; the layers below load them by name (importlib), never by an
# import statement.
# pysim/__init__.py only names the version: it may import nothing of the package
TOP = {"pysim": set()}


def layer_of(module: str) -> str:
    """The layer a dotted module name belongs to (longest matching prefix)."""
    for layer in sorted({**ALLOWED, **TOP}, key=len, reverse=True):
        if module == layer or module.startswith(layer + "."):
            return layer
    raise AssertionError(f"{module} belongs to no layer: add it to the table in {__file__}")


# folders of the repository mapped into pysim (setup.py): an editable install
# does not show them under their parent's folder, so they are walked by name
MAPPED = ("pysim.core.csrc", "pysim.specs", "pysim.identification.datasets")


def all_modules():
    found = []
    packages = [pysim, build_fmu] + [importlib.import_module(name) for name in MAPPED]
    for package in packages:
        found.append((package.__name__, Path(package.__file__)))
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            spec = importlib.util.find_spec(info.name)
            if spec is not None and spec.origin and spec.origin.endswith(".py"):
                found.append((info.name, Path(spec.origin)))
    return found


def imported_names(module: str, path: Path, is_package: bool):
    """(line, absolute module name) of every import of the package in the file."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if is_package else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            yield node.lineno, target
            for alias in node.names:        # "from pysim import cosim" imports pysim.cosim
                yield node.lineno, f"{target}.{alias.name}"


MODULES = all_modules()


def test_every_module_is_found_and_belongs_to_a_layer():
    names = {name for name, _ in MODULES}
    for expected in ("pysim.core.model", "pysim.core.csrc", "pysim.specs.default_mpi", "pysim.fmu.build",
                     "pysim.cosim.harness", "pysim.identification.identify", "pysim.diagnosis.diagnose",
                     "pysim.cli.main", "pysim.cli.commands.demo", "build_fmu.cli"):
        assert expected in names, f"{expected} is not installed"
    for name in names:
        layer_of(name)


@pytest.mark.parametrize("module,path", MODULES, ids=[name for name, _ in MODULES])
def test_imports_only_downward(module, path):
    own = layer_of(module)
    allowed = ALLOWED.get(own, set()) | {own}
    is_package = path.name == "__init__.py"
    wrong = []
    for line, target in imported_names(module, path, is_package):
        if not (target == "pysim" or target.startswith(("pysim.", "build_fmu"))):
            continue
        if target == "pysim":               # the version only
            continue
        try:
            other = layer_of(target)
        except AssertionError:
            continue                        # "from pysim.x import name": the name, not a module
        if other not in allowed:
            wrong.append(f"{path.name}:{line} imports {target} ({other} is not below {own})")
    assert not wrong, "\n".join(wrong)


def test_the_table_has_no_cycle():
    """Downward only: the 'may import' relation of the layers is acyclic."""
    state = {}

    def visit(layer, trail):
        if state.get(layer) == "done":
            return
        assert state.get(layer) != "open", f"cycle: {' -> '.join(trail + [layer])}"
        state[layer] = "open"
        for lower in ALLOWED[layer]:
            visit(lower, trail + [layer])
        state[layer] = "done"

    for layer in ALLOWED:
        visit(layer, [])


def test_the_checker_catches_an_upward_import(tmp_path):
    """The walk sees imports inside functions and relative ones."""
    source = tmp_path / "fake.py"
    source.write_text("def f():\n    from pysim.cosim import harness\n    from ..fmu import build\n")
    names = [target for _, target in imported_names("pysim.core.fake", source, False)]
    assert "pysim.cosim" in names and "pysim.fmu" in names
    assert layer_of("pysim.cosim") not in ALLOWED["pysim.core"]


def test_no_generic_top_level_packages_are_installed():
    """fmu_src and models install inside pysim: the distribution's top-level
    packages are pysim and build_fmu alone."""
    from importlib.metadata import distribution

    dist = distribution("piezo-mpi")
    top_level = set((dist.read_text("top_level.txt") or "").split())
    assert top_level == {"build_fmu", "pysim"}, top_level
    files = {str(f).split("/")[0] for f in (dist.files or []) if str(f).endswith(".py")}
    assert not files & {"models", "fmu_src"}, files
