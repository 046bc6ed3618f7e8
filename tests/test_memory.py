"""Memory safety of the FMU C code.

- valgrind memcheck on the shipped linux64 binaries (as built for the FMU,
  loaded by the C driver): 1000 instantiate / set up / initialise / simulate /
  serialize / deserialize / set state / terminate / reset / free cycles of
  both FMUs, and the whole misuse suite: no error, no leak.
- The FMUs' own C sources built with AddressSanitizer and
  UndefinedBehaviorSanitizer (gcc, every finding fatal): the misuse suite, the
  cycles and the full calling sequence of tests/c/fmu_driver.c pass, with the
  same numbers as the shipped binary; and the Python FMU tests
  (test_fmu_calls, test_fmu_state, test_fmu_cosimulation) pass in a
  subprocess whose FMUs carry the sanitized binary, with the ASan runtime
  preloaded into Python.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
from robustness import (
    C_DIR,
    SANITIZE,
    TESTS,
    WARNINGS,
    asan_runtime,
    compile_c,
    fmu_pair,
    misuse_driver,
    parse_cases,
    sanitized_fmu,
    sanitized_library,
    sanitizer_findings,
)

from pysim.core.model import InverseCompensator
from pysim.fmu.compile import fmi_include_dir
from pysim.testing.fmus import DEFAULT_MODEL, from_hex, paper_signal, piecewise_monotone, to_hex_lines, voltage_signal

MODEL = DEFAULT_MODEL
CYCLES = 1000
VALGRIND = ["valgrind", "--error-exitcode=99", "--leak-check=full", "--show-leak-kinds=all",
            "--errors-for-leak-kinds=definite,indirect,possible"]
# Findings abort with a non-zero exit code; leaks are checked at exit.
ASAN_ENV = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:exitcode=86",
            "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"}


def _valgrind(arguments, tmp_path):
    assert shutil.which("valgrind"), "valgrind is required (Debian package valgrind)"
    result = subprocess.run(VALGRIND + arguments, cwd=tmp_path, capture_output=True, text=True, timeout=600)
    report = result.stderr
    errors = re.search(r"ERROR SUMMARY: (\d+) errors", report)
    assert errors, report[-3000:]
    heap = re.search(r"total heap usage: ([\d,]+) allocs, ([\d,]+) frees", report)
    in_use = re.search(r"in use at exit: ([\d,]+) bytes in ([\d,]+) blocks", report)
    return result, int(errors.group(1)), heap, in_use


def test_valgrind_1000_cycles_of_both_fmus(tmp_path):
    pair = fmu_pair()
    libraries = {kind: pair.library(kind) for kind in pair.folders}
    result, errors, heap, in_use = _valgrind(
        [str(misuse_driver("linux")), "cycles", str(CYCLES), *pair.misuse_arguments(libraries)], tmp_path)
    assert errors == 0, result.stderr[-4000:]
    assert result.returncode == 0, result.stdout + result.stderr[-4000:]
    assert (f"# {CYCLES} cycles on both FMUs: 0 failed calls, outputs identical in every cycle, "
            "0 blocks not freed") in result.stdout
    assert "All heap blocks were freed -- no leaks are possible" in result.stderr, result.stderr[-3000:]
    allocs, frees = (int(x.replace(",", "")) for x in heap.groups())
    assert allocs == frees and allocs > 6 * CYCLES       # instance, name, 2 states per FMU and cycle


def test_valgrind_misuse_suite(tmp_path):
    pair = fmu_pair()
    libraries = {kind: pair.library(kind) for kind in pair.folders}
    result, errors, heap, in_use = _valgrind(
        [str(misuse_driver("linux")), "cases", *pair.misuse_arguments(libraries)], tmp_path)
    assert errors == 0, result.stderr[-4000:]
    cases, tried, handled = parse_cases(result.stdout)
    assert tried == handled == len(cases) and result.returncode == 0
    assert "All heap blocks were freed -- no leaks are possible" in result.stderr


def _sanitized_libraries():
    return {kind: sanitized_library(kind) for kind in ("plant", "inverse")}


def test_sanitized_build_misuse_suite_and_cycles(tmp_path):
    pair = fmu_pair()
    arguments = pair.misuse_arguments(_sanitized_libraries())
    env = dict(os.environ, **ASAN_ENV)
    driver = str(misuse_driver("asan"))
    cases_run = subprocess.run([driver, "cases", *arguments], cwd=tmp_path, env=env, capture_output=True,
                               text=True, timeout=600)
    assert not sanitizer_findings(cases_run.stderr), cases_run.stderr[-4000:]
    cases, tried, handled = parse_cases(cases_run.stdout)
    assert cases_run.returncode == 0 and tried == handled == len(cases) >= 500
    cycles_run = subprocess.run([driver, "cycles", "200", *arguments], cwd=tmp_path, env=env,
                                capture_output=True, text=True, timeout=600)
    assert not sanitizer_findings(cycles_run.stderr), cycles_run.stderr[-4000:]
    assert cycles_run.returncode == 0 and "0 failed calls, outputs identical" in cycles_run.stdout


@pytest.fixture(scope="module")
def fmu_driver_asan(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fmu-driver-asan")
    out = folder / "fmu_driver"
    compile_c(["gcc"] + WARNINGS + SANITIZE + ["-I", str(fmi_include_dir()), "-I", str(C_DIR),
                                               str(C_DIR / "fmu_driver.c"), "-o", str(out), "-ldl"], folder)
    return out


@pytest.mark.parametrize("kind", ["plant", "inverse"])
def test_sanitized_build_full_calling_sequence(tmp_path, fmu_driver_asan, kind):
    """tests/c/fmu_driver.c (two instances, state save/restore, serialize,
    replay) on the sanitized library: it passes, and its outputs are bit for
    bit those of the shipped linux64 binary (and the Python model's)."""
    pair = fmu_pair()
    v = voltage_signal(MODEL, np.concatenate([paper_signal(600, 6.0), piecewise_monotone(np.random.default_rng(5))]))
    x = v if kind == "plant" else MODEL.simulate(v)
    (tmp_path / "inputs.txt").write_text(to_hex_lines(x))
    outputs = {}
    for label, library in (("sanitized", sanitized_library(kind)), ("shipped", pair.library(kind))):
        result = subprocess.run([str(fmu_driver_asan), str(library), pair.guids[kind], "inputs.txt"], cwd=tmp_path,
                                env=dict(os.environ, **ASAN_ENV), capture_output=True, text=True, timeout=300)
        assert not sanitizer_findings(result.stderr), result.stderr[-4000:]
        assert result.returncode == 0 and "# passed" in result.stdout, result.stdout[-2000:]
        outputs[label] = [line for line in result.stdout.splitlines() if not line.startswith("#")]
    assert outputs["sanitized"] == outputs["shipped"] and len(outputs["shipped"]) == x.size
    y = np.array([from_hex(line) for line in outputs["sanitized"]])
    expected = MODEL.simulate(x) if kind == "plant" else InverseCompensator(MODEL)(x)
    assert np.max(np.abs(y - expected)) <= 1e-12 * np.max(np.abs(expected))


PLUGIN = "asan_fmus"     # tests/asan_fmus.py


def test_python_fmu_tests_pass_on_the_sanitized_build(tmp_path):
    """The Python FMU tests in a subprocess: libasan preloaded into Python,
    the FMUs of the default spec swapped for copies with the sanitized
    linux64 binary (by the pytest plugin tests/asan_fmus.py)."""
    swapped = {kind: str(sanitized_fmu(kind)) for kind in ("plant", "inverse")}
    env = dict(os.environ, **ASAN_ENV, LD_PRELOAD=asan_runtime())
    # Python itself is not built for LeakSanitizer: its arenas would look like leaks
    env.update(ASAN_OPTIONS="detect_leaks=0:abort_on_error=0:exitcode=86",
               PIEZO_SANITIZED_FMUS=os.pathsep.join(f"{k}={v}" for k, v in swapped.items()),
               PYTHONPATH=os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]))
    tests = [str(TESTS / name) for name in ("test_fmu_calls.py", "test_fmu_state.py", "test_fmu_cosimulation.py")]
    # --capture=sys: a sanitizer report written to file descriptor 2 reaches us
    # even when it ends the process in the middle of a test
    result = subprocess.run([sys.executable, "-m", "pytest", "--capture=sys", "-p", PLUGIN, "-p",
                             "no:cacheprovider", *tests], cwd=tmp_path, env=env, capture_output=True, text=True,
                            timeout=900)
    output = result.stdout + result.stderr
    assert not sanitizer_findings(output), output[-6000:]
    assert result.returncode == 0, output[-6000:]
    assert "sanitized FMUs: plant, inverse" in output       # the plugin did swap them
    assert re.search(r"\d+ passed", output) and " failed" not in output
