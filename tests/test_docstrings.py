"""Every Examples section of the installed package runs and shows what it prints.

The docstrings' examples are the first thing a user copies; an example that no
longer runs (or prints something else) is a defect like any other.  Each
module of the installed ``pysim`` and ``build_fmu`` is run through
:mod:`doctest` (``ELLIPSIS`` and ``NORMALIZE_WHITESPACE``, as a reader reads
them).
"""
import doctest
import importlib
import pkgutil

import pytest

import build_fmu
import pysim


def _modules():
    names = [pysim.__name__, build_fmu.__name__]
    for package in (pysim, build_fmu):
        names += [info.name for info in pkgutil.walk_packages(package.__path__, package.__name__ + ".")]
    return sorted(set(names))


@pytest.mark.parametrize("name", _modules())
def test_examples_run_as_written(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)        # an example that writes a file writes it here
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder()
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in finder.find(module, name):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples of {name} fail (printed above)"


def test_the_package_has_examples():
    """The suite above would pass on a package without a single example."""
    finder = doctest.DocTestFinder()
    examples = sum(len(t.examples) for name in _modules()
                   for t in finder.find(importlib.import_module(name), name))
    assert examples >= 100
