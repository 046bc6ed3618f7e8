"""The C side on its own: the sources compile warning-free with gcc, clang and
zig for every target, and a C driver (tests/c/fmu_driver.c) runs the whole
calling sequence on the Linux binary natively and on the Windows DLL under
wine -- with bit-identical outputs."""
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import robustness

from pysim.core.model import InverseCompensator
from pysim.core.toolchain import SOURCE_DIR, zig_cc
from pysim.fmu.build import tool_version
from pysim.fmu.compile import FLAGS, PLATFORMS, fmi_include_dir
from pysim.fmu.generate import fmu_sources
from pysim.testing.fmus import (
    DEFAULT_MODEL,
    built_fmus,
    extracted,
    from_hex,
    paper_signal,
    piecewise_monotone,
    to_hex_lines,
    voltage_signal,
)

MODEL = DEFAULT_MODEL
DRIVER = Path(__file__).resolve().parent / "c" / "fmu_driver.c"
WARNINGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
ZIG = zig_cc()


def _write_sources(folder: Path, kind: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for path, data in fmu_sources(MODEL, kind, SOURCE_DIR, tool_version()).items():
        if path.startswith("sources/"):
            (folder / path[len("sources/"):]).write_bytes(data)
    return folder


def _compile(command, cwd):
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    assert result.returncode == 0 and not result.stderr.strip(), result.stderr
    return result


COMPILERS = {
    "gcc": ["gcc"],
    "clang": ["clang"],
    **{f"zig-{target}": ZIG + ["-target", target] for p in PLATFORMS.values() for target in p.targets},
}


@pytest.mark.parametrize("kind", ["plant", "inverse"])
@pytest.mark.parametrize("compiler", sorted(COMPILERS))
def test_sources_compile_without_warnings(tmp_path, kind, compiler):
    src = _write_sources(tmp_path / "src", kind)
    include = ["-I", str(src), "-I", str(fmi_include_dir())]
    _compile(COMPILERS[compiler] + WARNINGS + include + ["-c", str(src / "all.c"), "-o", "all.o"], tmp_path)
    if compiler == "gcc":          # every file also stands on its own
        for name in ("fmi2_layer.c", "model.c", "mpi_parameters.c", "hysteresis.c"):
            _compile(["gcc"] + WARNINGS + include + ["-c", str(src / name), "-o", name + ".o"], tmp_path)


@pytest.fixture(scope="module")
def drivers(tmp_path_factory):
    """The driver for Linux (system compiler, dlopen) and for Windows (zig,
    LoadLibrary)."""
    folder = tmp_path_factory.mktemp("driver")
    include = ["-I", str(fmi_include_dir())]
    linux = folder / "fmu_driver"
    _compile(["gcc"] + WARNINGS + include + [str(DRIVER), "-o", str(linux), "-ldl"], folder)
    windows = folder / "fmu_driver.exe"
    # the FMU build's flags: zig then reuses the MinGW runtime it built for the DLLs
    flags = [f for f in FLAGS if f != "-shared"] + list(PLATFORMS["win64"].flags) + ["-Wpedantic"]
    _compile(ZIG + ["-target", "x86_64-windows-gnu"] + flags + include + [str(DRIVER), "-o", str(windows)],
             folder)
    return linux, windows


@pytest.fixture(scope="module")
def wine():
    """Command and environment to run Windows programs (shared throwaway prefix)."""
    return robustness.wine()


def _inputs(kind):
    v = voltage_signal(MODEL, np.concatenate([paper_signal(1500, 12.0),
                                              piecewise_monotone(np.random.default_rng(11))]))
    return v if kind == "plant" else MODEL.simulate(v)


def _parse(stdout: str):
    lines = stdout.replace("\r\n", "\n").splitlines()
    return [from_hex(x) for x in lines if not x.startswith("#")], [x for x in lines if x.startswith("#")]


@pytest.mark.parametrize("kind", ["plant", "inverse"])
def test_windows_dll_under_wine_gives_the_linux_numbers_bit_for_bit(tmp_path, drivers, wine, kind):
    linux_driver, windows_driver = drivers
    folder = extracted(built_fmus()[kind])
    ident = f"{MODEL.name}_{kind}"
    guid = __import__("fmpy").read_model_description(str(folder)).guid
    x = _inputs(kind)
    (tmp_path / "inputs.txt").write_text(to_hex_lines(x))

    native = subprocess.run([str(linux_driver), str(folder / "binaries" / "linux64" / f"{ident}.so"), guid,
                             "inputs.txt"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert native.returncode == 0, native.stdout + native.stderr
    shutil.copy(folder / "binaries" / "win64" / f"{ident}.dll", tmp_path)
    shutil.copy(windows_driver, tmp_path)
    program, env = wine
    emulated = subprocess.run([program, "fmu_driver.exe", f"{ident}.dll", guid, "inputs.txt"], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=600)
    assert emulated.returncode == 0, emulated.stdout + emulated.stderr

    y_linux, checks_linux = _parse(native.stdout)
    y_windows, checks_windows = _parse(emulated.stdout)
    expected_checks = ["# exports all 34 co-simulation functions", "# version 2.0, types platform default",
                       "# instances identical", "# replay from deserialized state identical",
                       "# replay from saved state identical", "# passed"]
    assert checks_linux == expected_checks and checks_windows == expected_checks
    assert len(y_linux) == x.size
    assert [np.float64(a).tobytes() for a in y_linux] == [np.float64(b).tobytes() for b in y_windows]
    expected = MODEL.simulate(x) if kind == "plant" else InverseCompensator(MODEL)(x)
    assert np.max(np.abs(np.array(y_linux) - expected)) <= 1e-12 * np.max(np.abs(expected))
