"""The FMUs as files: the model description passes fmpy's validation,
fmu-manipulation-toolbox's checks and the FMI 2.0 XML schema; each binary
exports exactly the FMI 2.0 co-simulation functions, needs nothing beyond the
C runtime, and the darwin64 library holds both macOS architectures."""
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import fmpy
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from pysim.fmu import binaries, macho
from pysim.testing.fmus import DEFAULT_MODEL, built_fmus, extracted

MODEL = DEFAULT_MODEL
SCHEMA = Path(fmpy.__file__).resolve().parent / "schema" / "fmi2" / "fmi2ModelDescription.xsd"
KINDS = ("plant", "inverse")


def fmutool_program() -> str:
    """The fmutool console script: on PATH, or beside this Python (a fresh
    install may not have refreshed a version manager's shims yet)."""
    beside = Path(sys.executable).parent / "fmutool"
    found = shutil.which("fmutool") or (str(beside) if beside.exists() else None)
    assert found, "fmutool is required (PyPI package fmu-manipulation-toolbox)"
    return found


def fmutool_check(path) -> str:
    result = subprocess.run([fmutool_program(), "-input", str(path), "-check"], capture_output=True, text=True,
                            timeout=120)
    return result.stdout + result.stderr


def xmllint(xml_path) -> subprocess.CompletedProcess:
    return subprocess.run(["xmllint", "--noout", "--schema", str(SCHEMA), str(xml_path)], capture_output=True,
                          text=True, timeout=60)


def _broken_copy(tmp_path, kind):
    """The FMU with an output removed from ModelStructure (a real mistake)."""
    source = built_fmus()[kind]
    broken = tmp_path / f"broken_{kind}.fmu"
    with zipfile.ZipFile(source) as zin, zipfile.ZipFile(broken, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = re.sub(rb"<Outputs>.*?</Outputs>", b"<Outputs/>", data, flags=re.S)
            zout.writestr(item, data)
    return broken


@pytest.mark.parametrize("kind", KINDS)
def test_fmpy_validate_finds_no_problems(kind, tmp_path):
    assert validate_fmu(str(built_fmus()[kind])) == []
    assert validate_fmu(str(_broken_copy(tmp_path, kind))) != []        # the check can fail


@pytest.mark.parametrize("kind", KINDS)
def test_fmutool_check_passes(kind, tmp_path):
    report = fmutool_check(built_fmus()[kind])
    assert "compliant with FMI-2.0" in report and "No semantic error" in report
    assert "ERROR" not in report
    broken = fmutool_check(_broken_copy(tmp_path, kind))
    assert "ERROR" in broken and "No semantic error" not in broken


@pytest.mark.parametrize("kind", KINDS)
def test_model_description_validates_against_the_fmi2_schema(kind, tmp_path):
    xml = extracted(built_fmus()[kind]) / "modelDescription.xml"
    result = xmllint(xml)
    assert result.returncode == 0, result.stderr
    bad = tmp_path / "modelDescription.xml"
    bad.write_text(xml.read_text().replace('variability="fixed"', 'variability="sometimes"', 1))
    assert xmllint(bad).returncode != 0


@pytest.mark.parametrize("kind", KINDS)
def test_model_description_carries_the_spec(kind):
    md = read_model_description(str(built_fmus()[kind]))
    cs = md.coSimulation
    assert md.fmiVersion == "2.0" and cs.modelIdentifier == f"{MODEL.name}_{kind}"
    assert cs.canHandleVariableCommunicationStepSize and cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert not cs.needsExecutionTool
    variables = {v.name: v for v in md.modelVariables}
    inp, out = ("voltage", "displacement") if kind == "plant" else ("displacement_ref", "voltage")
    units = {"voltage": "V", "displacement": "um", "displacement_ref": "um"}
    assert variables[inp].causality == "input" and variables[inp].unit == units[inp]
    assert variables[out].causality == "output" and variables[out].unit == units[out]
    # every parameter with the spec's value as start value, exactly
    expected = {"a1": MODEL.a1, "a2": MODEL.a2, "input_offset": MODEL.input_offset_V,
                "output_offset": MODEL.output_offset_um, "voltage_min": MODEL.voltage_range_V[0],
                "voltage_max": MODEL.voltage_range_V[1]}
    expected.update({f"r[{i + 1}]": r for i, r in enumerate(MODEL.thresholds_V)})
    expected.update({f"b[{i + 1}]": b for i, b in enumerate(MODEL.weights_um_per_V)})
    for name, value in expected.items():
        v = variables[name]
        assert v.causality == "parameter" and v.variability == "fixed" and float(v.start) == value, name
    assert [u.variable.name for u in md.outputs] == [out]
    assert md.outputs[0].dependencies == [variables[inp]]
    initial = md.initialUnknowns[0]
    assert initial.variable.name == out and variables[inp] in initial.dependencies
    assert variables["a1"] in initial.dependencies
    # the importer compiles what SourceFiles lists, from sources/
    files = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
    folder = extracted(built_fmus()[kind]) / "sources"
    assert files == ["all.c"] and all((folder / f).is_file() for f in files)
    for include in re.findall(r'#include "([^"]+)"', (folder / "all.c").read_text()):
        assert (folder / include).is_file() or include.startswith("fmi2")


@pytest.mark.parametrize("kind", KINDS)
def test_archive_layout(kind):
    with zipfile.ZipFile(built_fmus()[kind]) as archive:
        names = archive.namelist()
    ident = f"{MODEL.name}_{kind}"
    assert f"binaries/linux64/{ident}.so" in names
    assert f"binaries/win64/{ident}.dll" in names
    assert f"binaries/darwin64/{ident}.dylib" in names
    assert not any(n.endswith((".pdb", ".lib", ".exp")) or "\\" in n for n in names)
    # the FMI headers come from the importer, not from the FMU
    assert not any(Path(n).name.startswith("fmi2") and n.endswith(".h") and "fmi2_layer" not in n for n in names)


def _binary(kind, platform, suffix):
    return (extracted(built_fmus()[kind]) / "binaries" / platform / f"{MODEL.name}_{kind}{suffix}").read_bytes()


@pytest.mark.parametrize("kind", KINDS)
def test_linux_library_exports_only_fmi2_and_needs_old_glibc_only(kind):
    info = binaries.elf_info(_binary(kind, "linux64", ".so"))
    assert info["exports"] == set(binaries.FMI2_CS_FUNCTIONS)
    glibc = [tuple(int(x) for x in v.split("_")[1].split(".")) for v in info["versions"] if v.startswith("GLIBC_")]
    assert glibc and max(glibc) <= (2, 17)
    assert all(v.startswith("GLIBC_") for v in info["versions"])


@pytest.mark.parametrize("kind", KINDS)
def test_windows_dll_exports_only_fmi2_and_imports_only_the_c_runtime(kind):
    info = binaries.pe_info(_binary(kind, "win64", ".dll"))
    assert info["machine"] == "x86_64"
    assert info["exports"] == set(binaries.FMI2_CS_FUNCTIONS)
    assert all(d.upper() == "KERNEL32.DLL" or d.lower().startswith("api-ms-win-crt-") for d in info["imports"])


@pytest.mark.parametrize("kind", KINDS)
def test_darwin_library_is_universal_and_exports_every_fmi2_function(kind):
    data = _binary(kind, "darwin64", ".dylib")
    assert macho.is_universal(data)
    slices = macho.slices(data)
    assert sorted(slices) == ["arm64", "x86_64"]
    minimum = {"x86_64": "10.13", "arm64": "11.0"}
    for arch, thin in slices.items():
        info = macho.describe(thin)
        assert info["arch"] == arch and info["dylib"]
        assert info["exports_trie"] - binaries.MACHO_LINKER_SYMBOLS == set(binaries.FMI2_CS_FUNCTIONS)
        assert info["exports_symtab"] - binaries.MACHO_LINKER_SYMBOLS == set(binaries.FMI2_CS_FUNCTIONS)
        assert info["dylibs"] == ["/usr/lib/libSystem.B.dylib"]
        assert info["min_macos"] == minimum[arch]
    # Apple silicon runs signed code only; the linker signs ad hoc
    assert macho.describe(slices["arm64"])["code_signature"]


def test_fmpy_loads_the_linux_binary_with_all_functions():
    """fmpy binds every co-simulation function when it loads a binary."""
    from fmpy.fmi2 import FMU2Slave

    folder = extracted(built_fmus()["plant"])
    md = read_model_description(str(folder))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=md.coSimulation.modelIdentifier)
    slave.instantiate()
    assert slave.getVersion() == "2.0" and slave.getTypesPlatform() == "default"
    slave.freeInstance()
    assert fmutool_program() and shutil.which("xmllint")
