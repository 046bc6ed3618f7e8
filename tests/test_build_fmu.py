"""The builder: spec in, two FMUs out -- generated configuration, caching,
determinism, the universal Mach-O writer, and errors (clear message, exit
code 2, nothing written)."""
import re
import struct
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from pysim.specs.default_mpi import MODEL

from build_fmu.cli import main
from pysim.core.input_stage import InputStageModel
from pysim.core.model import HysteresisModel
from pysim.core.spec import load_spec, write_spec
from pysim.fmu import BuildError, build_fmus, macho
from pysim.fmu.generate import config_header, model_guid
from pysim.fmu.package import fmu_bytes
from pysim.fmu.variables import variables


def paper_a1_model():
    """The paper's own a1 = -1 (normalised) on the default scaling."""
    return MODEL.with_parameters(a1=-1.0 * 20.0 / 150.0 ** 3, name="paper_a1")


def test_variables_are_laid_out_inputs_outputs_parameters():
    for kind, head in (("plant", ["voltage", "displacement"]), ("inverse", ["displacement_ref", "voltage"])):
        allv = variables(MODEL, kind)
        assert [v.value_reference for v in allv] == list(range(len(allv)))
        assert [v.name for v in allv[:2]] == head
        assert [v.causality for v in allv[:2]] == ["input", "output"]
        n = MODEL.n_operators
        names = [v.name for v in allv]
        assert names[8:8 + n] == [f"r[{i}]" for i in range(1, n + 1)]
        assert names[8 + n:8 + 2 * n] == [f"b[{i}]" for i in range(1, n + 1)]
    assert variables(MODEL, "inverse")[-1].type == "Boolean"
    # the inverse starts where the plant starts: the displacement of the start voltage
    assert variables(MODEL, "inverse")[0].start == MODEL.simulate([variables(MODEL, "plant")[0].start])[0]


def test_config_header_holds_the_spec_exactly():
    text = config_header(MODEL, "plant", "{guid}")
    starts = re.search(r"#define MODEL_REAL_STARTS \{(.*?)\}", text, re.S).group(1)
    values = [float(x) for x in starts.replace("\\", " ").split(",")]
    n = MODEL.n_operators
    assert values[2:8] == [MODEL.a1, MODEL.a2, 0.0, 0.0, *MODEL.voltage_range_V]
    assert values[8:8 + n] == list(MODEL.thresholds_V)
    assert values[8 + n:] == list(MODEL.weights_um_per_V)
    assert "#define MODEL_N_OPERATORS 10" in text and "#define MODEL_OPERATOR_KIND HYST_OSP" in text
    assert "#define VR_r 8" in text and "#define VR_b 18" in text


def test_guid_follows_the_content():
    g = model_guid(MODEL, "plant", "src")
    assert g == model_guid(MODEL, "plant", "src")
    assert g != model_guid(MODEL, "inverse", "src")
    assert g != model_guid(MODEL, "plant", "other sources")
    assert g != model_guid(MODEL.with_parameters(a2=MODEL.a2 * (1 + 1e-15)), "plant", "src")
    assert re.fullmatch(r"\{[0-9a-f]{8}-([0-9a-f]{4}-){3}[0-9a-f]{12}\}", g)


def test_archive_bytes_are_deterministic():
    files = {"b/x.bin": b"\x00\x01", "modelDescription.xml": b"<x/>"}
    assert fmu_bytes(files) == fmu_bytes(dict(reversed(list(files.items()))))
    with pytest.raises(ValueError):
        fmu_bytes({"binaries\\win64\\x.dll": b""})


def _thin(cputype, subtype, size):
    """A minimal single-architecture Mach-O header followed by filler."""
    return struct.pack("<IiiIIII", macho.MH_MAGIC_64, cputype, subtype, 6, 0, 0, 0) + b"\0\0\0\0" + \
        bytes(range(256)) * (size // 256)


def test_universal_writer_lays_out_aligned_slices():
    a, b = _thin(0x01000007, 3, 5000), _thin(0x0100000C, 0, 9000)
    data = macho.write_universal([a, b])
    magic, count = struct.unpack_from(">II", data)
    assert (magic, count) == (0xCAFEBABE, 2)
    for i, (thin, cpu, sub) in enumerate(((a, 0x01000007, 3), (b, 0x0100000C, 0))):
        cputype, subtype, offset, size, align = struct.unpack_from(">iiIII", data, 8 + 20 * i)
        assert (cputype, subtype, size, align) == (cpu, sub, len(thin), 14)
        assert offset % (1 << 14) == 0 and data[offset:offset + size] == thin
    assert macho.slices(data) == {"x86_64": a, "arm64": b}


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "build_fmu.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=600)


def test_cli_builds_both_fmus_with_a_progress_line_per_step(tmp_path):
    result = run_cli("default_mpi", "-o", tmp_path / "out", "--platforms", "linux64")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert all(line.startswith("build-fmu: ") for line in lines)
    text = result.stdout
    for step in ("loaded default_mpi", "invertible over 0 V to 150 V", "generated modelDescription.xml",
                 "compiled default_mpi_plant for linux64", "compiled default_mpi_inverse for linux64",
                 "checked the binaries", "wrote"):
        assert step in text, step
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["default_mpi_inverse.fmu",
                                                                     "default_mpi_plant.fmu"]
    with zipfile.ZipFile(tmp_path / "out" / "default_mpi_plant.fmu") as archive:
        assert not any(n.startswith(("binaries/win64", "binaries/darwin64")) for n in archive.namelist())


def test_cached_rebuild_gives_the_same_bytes(tmp_path):
    messages = []
    first = build_fmus(MODEL, tmp_path / "a", ("linux64",), cache_dir=tmp_path / "cache",
                       progress=messages.append)
    assert not any(m.endswith(": cached") for m in messages)
    messages.clear()
    second = build_fmus(MODEL, tmp_path / "b", ("linux64",), cache_dir=tmp_path / "cache",
                        progress=messages.append)
    assert sum(m.endswith(": cached") for m in messages) == 2
    for kind in ("plant", "inverse"):
        assert first[kind].read_bytes() == second[kind].read_bytes()
    # without the cache the compiler runs again and gives the same binary
    third = build_fmus(MODEL, tmp_path / "c", ("linux64",), use_cache=False)
    assert third["plant"].read_bytes() == first["plant"].read_bytes()


def test_spec_files_from_identify_are_accepted(tmp_path):
    spec = write_spec(MODEL.with_parameters(name="written"), tmp_path / "written.py")
    result = build_fmus(spec, tmp_path / "out", ("linux64",))
    assert result["plant"].name == "written_plant.fmu" and result["inverse"].name == "written_inverse.fmu"


def test_non_invertible_spec_is_refused_with_the_voltage_where_it_fails(tmp_path):
    spec = write_spec(paper_a1_model(), tmp_path / "paper_a1.py")
    out = tmp_path / "out"
    result = run_cli(spec, "-o", out)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("build-fmu: error: ") and str(spec) in lines[0]
    assert "not invertible" in lines[0]
    # slope 2.42 + b_1 - 3 v^2 (normalised) turns negative at v = sqrt((2.42 + b_1)/3)
    onset = 150.0 * np.sqrt((2.42 + 5.0 * np.exp(-0.505) / 10) / 3.0)
    assert f"from {onset:.6g} V" in lines[0]
    assert not out.exists()


def test_a_spec_with_an_input_stage_is_refused_unless_the_part_after_it_is_asked_for(tmp_path):
    # an FMU cannot hold a stage before the hysteresis: building the plant without it silently would
    # deliver a model other than the one named
    spec = write_spec(InputStageModel(MODEL.with_parameters(name="slewed"), "slew_limit", 2.5e5, 1e-4),
                      tmp_path / "slewed.py")
    out = tmp_path / "out"
    result = run_cli(spec, "-o", out)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and str(spec) in lines[0]
    assert "slew limit 250 V/ms" in lines[0] and "--without-input-stage" in lines[0]
    assert not out.exists()
    said = []
    built = build_fmus(spec, out, ("linux64",), without_input_stage=True, progress=said.append)
    assert built["plant"].name == "slewed_plant.fmu"
    assert any("slew limit 250 V/ms left out" in line for line in said)


def test_thresholds_that_grow_with_the_rate_survive_the_spec_and_are_refused_by_the_fmus(tmp_path):
    # the spec written by `pysim diagnose --out` for that structure loads as the same model (every bit
    # of a record's prediction), and the FMUs, which hold fixed thresholds, refuse it with its name
    grown = InputStageModel(MODEL.with_parameters(name="grown"), "rate_thresholds", 2e-5, 1e-4)
    spec = write_spec(grown, tmp_path / "grown.py")
    v = 75.0 + 70.0 * np.sin(np.linspace(0.0, 40.0, 3000)) ** 3
    loaded = load_spec(spec)
    assert loaded.kind == "rate_thresholds" and np.array_equal(loaded.simulate(v), grown.simulate(v))
    assert not np.allclose(grown.simulate(v), grown.plant.simulate(v))
    result = run_cli(spec, "-o", tmp_path / "out")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "thresholds that grow with the input rate, +2 % per V/ms" in lines[0]
    assert "--without-input-stage" in lines[0] and not (tmp_path / "out").exists()


@pytest.mark.parametrize("problem, expected", [
    ("missing", "does not exist"),
    ("directory", "is a directory"),
    ("broken", "SyntaxError"),
    ("no_model", "defines no MODEL"),
])
def test_bad_spec_files_give_one_line_and_exit_code_2(tmp_path, problem, expected):
    path = tmp_path / "spec.py"
    if problem == "directory":
        path.mkdir()
    elif problem == "broken":
        path.write_text("MODEL = (\n")
    elif problem == "no_model":
        path.write_text("X = 1\n")
    result = run_cli(path, "-o", tmp_path / "out")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0] and "spec.py" in lines[0]
    assert not (tmp_path / "out").exists()


def test_models_the_fmus_cannot_represent_are_refused(tmp_path):
    class Extended(HysteresisModel):
        pass

    with pytest.raises(BuildError, match="not supported"):
        build_fmus(Extended(**{f: getattr(MODEL, f) for f in ("a1", "a2", "thresholds_V", "weights_um_per_V")}),
                   tmp_path, ("linux64",))
    empty = HysteresisModel(a1=0.0, a2=1.0, thresholds_V=(), weights_um_per_V=())
    with pytest.raises(BuildError, match="at least one operator"):
        build_fmus(empty, tmp_path, ("linux64",))
    with pytest.raises(BuildError, match="must be ASCII"):
        build_fmus(MODEL.with_parameters(name="piezo_\u00b5"), tmp_path, ("linux64",))
    assert list(tmp_path.iterdir()) == []


def test_bad_options_are_refused(tmp_path):
    target = tmp_path / "file"
    target.write_text("")
    assert main(["default_mpi", "-o", str(target), "--platforms", "linux64", "-q"]) == 2
    with pytest.raises(SystemExit) as exc:
        main(["default_mpi", "--platforms", "win32"])
    assert exc.value.code == 2
    with pytest.raises(BuildError, match="unknown platform"):
        build_fmus(MODEL, tmp_path / "x", ("linux32",))
