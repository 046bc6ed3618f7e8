"""The command-line tools on bad input: ``pysim diagnose`` on every bad data
file, the data-layout options of ``pysim identify`` and ``pysim diagnose``,
``build-fmu`` on bad spec files, ``pysim bandwidth`` on files that are not
usable FMUs.  Each gives exit code 2 and one line on stderr that names the
file (and the line and column where that applies), and writes nothing: the
output folder and the spec stay as they were.

(``pysim identify`` on every bad data file: tests/test_cli_identify.py; what
the loader's messages say for each file: tests/test_data.py, whose table is
reused here.)
"""
from __future__ import annotations

import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from robustness import fmu_pair
from test_data import BAD_FILES

from build_fmu.cli import main as build_fmu_main
from pysim.cli.main import main as pysim_main
from pysim.fmu import build_fmus
from pysim.testing.fmus import DEFAULT_MODEL

ROOT = Path(__file__).resolve().parents[1]
BAD = ROOT / "tests" / "fixtures" / "bad"
GOOD = ROOT / "tests" / "fixtures" / "good" / "standard.csv"


def snapshot(folder: Path) -> dict:
    """Every file under folder with its bytes (to show nothing changed)."""
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else None) for p in sorted(folder.rglob("*"))}


def one_error_line(capsys, prefix: str) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(prefix) and "Traceback" not in err, err
    return err


# ------------------------------------------------------------ pysim diagnose
@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_diagnose_refuses_each_bad_file_with_its_place(tmp_path, capsys, name):
    bad = BAD / name
    before = snapshot(tmp_path)
    code = pysim_main(["diagnose", str(bad), "--out", str(tmp_path / "extended.py"), "--report",
                       str(tmp_path / "report")])
    assert code == 2
    message = one_error_line(capsys, "pysim diagnose: error: ")
    assert f"{bad}: " in message
    for fragment in BAD_FILES[name]:            # line, column, what is wrong
        assert fragment in message, (fragment, message)
    assert snapshot(tmp_path) == before


def test_diagnose_missing_file(tmp_path, capsys):
    assert pysim_main(["diagnose", str(tmp_path / "nope.csv"), "--out", str(tmp_path / "x.py")]) == 2
    assert "nope.csv: no such file" in one_error_line(capsys, "pysim diagnose: error: ")
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------- output paths, all commands
@pytest.mark.parametrize("command, options", [
    ("diagnose", ["--report", "{tmp}/report"]),
    ("identify", []),
    ("excite", []),
], ids=["diagnose", "identify", "excite"])
@pytest.mark.parametrize("where, fragment", [
    ("folder", "is a folder; give a file name"),
    ("missing", "does not exist"),
], ids=["a-folder", "no-folder"])
def test_an_output_path_that_cannot_be_written_is_refused_before_any_work(tmp_path, capsys, command, options,
                                                                          where, fragment):
    # the output named as an existing folder used to end in a traceback after the fit, with the
    # report already written beside it
    out = tmp_path / "existing" if where == "folder" else tmp_path / "no" / "spec.py"
    if where == "folder":
        out.mkdir()
    before = snapshot(tmp_path)
    arguments = [command] + ([str(GOOD)] if command != "excite" else [])
    code = pysim_main(arguments + ["--out", str(out)] + [o.format(tmp=tmp_path) for o in options])
    assert code == 2
    message = one_error_line(capsys, f"pysim {command}: error: ")
    assert str(out) in message and fragment in message, message
    assert snapshot(tmp_path) == before


def test_diagnose_refuses_a_record_with_a_pause_before_any_work(tmp_path, capsys):
    """A record joined across a 1 s pause (or given as the second record): every lag, delay and creep
    would be fitted across the jump in time, so the diagnosis refuses it, naming where."""
    rows = GOOD.read_text().splitlines()
    header, body = rows[0], rows[1:]
    cut = len(body) // 2
    paused = tmp_path / "paused.csv"
    lines = [header] + body[:cut]
    for row in body[cut:]:
        t, rest = row.split(",", 1)
        lines.append(f"{float(t) + 1.0!r},{rest}")
    paused.write_text("\n".join(lines) + "\n")
    t_before = float(body[cut - 1].split(",")[0])
    before = snapshot(tmp_path)
    for arguments in ([str(paused)], [str(GOOD), "--validate", str(paused)]):
        code = pysim_main(["diagnose", *arguments, "--out", str(tmp_path / "x.py"), "--report",
                           str(tmp_path / "report")])
        assert code == 2
        message = one_error_line(capsys, "pysim diagnose: error: ")
        assert f"{paused}: the samples are not evenly spaced" in message, message
        assert f"after t = {t_before:.6g} s" in message, message
    assert snapshot(tmp_path) == before


def test_diagnose_refuses_a_second_record_at_a_rate_it_cannot_use_before_any_work(tmp_path, capsys):
    """A second record at a rate whose samples meet the first's on no grid down to a tenth of its rate
    would need interpolated samples, whose noise looks smaller than it is: one line naming both rates,
    exit 2, nothing written.  Half the rate is used (both records at every m-th sample), and said."""
    from pysim.identification.data import MeasuredData, save_measured

    k = np.arange(3000)
    v = 60.0 + 50.0 * np.sin(2 * np.pi * k / 600)
    first = save_measured(MeasuredData(k / 2000.0, v, 0.1 * v, "first"), tmp_path / "first.csv")
    other = save_measured(MeasuredData(k / 1234.5, v, 0.1 * v, "other"), tmp_path / "other.csv")
    before = snapshot(tmp_path)
    code = pysim_main(["diagnose", str(first), "--validate", str(other), "--out", str(tmp_path / "x.py"),
                       "--report", str(tmp_path / "report")])
    assert code == 2
    message = one_error_line(capsys, "pysim diagnose: error: ")
    expected = f"pysim diagnose: error: {other}: records at 2000 Hz and 1234.5 Hz have no common rate down to 200 Hz"
    assert message.startswith(expected), message
    assert snapshot(tmp_path) == before
    slower = save_measured(MeasuredData(k / 1000.0, v, 0.1 * v, "slower"), tmp_path / "slower.csv")
    assert pysim_main(["diagnose", str(first), "--validate", str(slower)]) == 0
    said = capsys.readouterr().out
    assert f"{first} was sampled at 2000 Hz and is used at 1000 Hz" in said, said


def test_a_report_path_that_is_a_file_or_has_no_folder_is_refused(tmp_path, capsys):
    plain = tmp_path / "report.txt"
    plain.write_text("keep\n")
    before = snapshot(tmp_path)
    for report, fragment in ((plain, "exists and is not a folder"), (tmp_path / "no" / "report", "does not exist")):
        assert pysim_main(["diagnose", str(GOOD), "--report", str(report)]) == 2
        assert fragment in one_error_line(capsys, "pysim diagnose: error: ")
    assert snapshot(tmp_path) == before


# ------------------------------------------ data-layout options of both commands
@pytest.mark.parametrize("command", ["identify", "diagnose"])
@pytest.mark.parametrize("options, fragments", [
    (["--voltage-column", "7"], ["voltage_V column number 7 is out of range", "header (line 1) has 3 columns"]),
    (["--displacement-column", "0"], ["displacement_um column number 0 is out of range"]),
    (["--time-column", "tme"], ["line 1", "no column 'tme'", "did you mean 'time_s', column 1"]),
    (["--delimiter", ";"], ["line 1", "only one column found", "comma ','"]),
    (["--no-header", "--sample-rate", "-5"], ["sample rate must be a positive finite number"]),
])
def test_layout_options_that_do_not_fit_the_file(tmp_path, capsys, command, options, fragments):
    spec = tmp_path / "model.py"
    assert pysim_main([command, str(GOOD), *options, "--out", str(spec)]) == 2
    message = one_error_line(capsys, f"pysim {command}: error: ")
    assert f"{GOOD}: " in message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------- build-fmu
MODEL_IMPORT = "from pysim.core.model import HysteresisModel\n"
# a2 = 1 um/V, a1 = -1e-4 um/V^3, one operator of zero weight: the slope
# 1 - 3e-4 v^2 falls to 0 at v = sqrt(1 / 3e-4) V, inside the 0..150 V range
NOT_INVERTIBLE = (MODEL_IMPORT + "MODEL = HysteresisModel(a1=-1e-4, a2=1.0, thresholds_V=(0.0,), "
                  "weights_um_per_V=(0.0,), voltage_range_V=(0.0, 150.0), name='steep')\n")
BAD_SPECS = {
    "syntax_error.py": (MODEL_IMPORT + "MODEL = HysteresisModel(a1=0.0,\n    a2=1.0\n",
                        ["SyntaxError", "line 2"]),
    "no_model.py": ("X = 1\n", ["defines no MODEL of type HysteresisModel"]),
    "model_not_a_model.py": ("MODEL = 3\n", ["defines no MODEL of type HysteresisModel"]),
    "empty.py": ("", ["defines no MODEL of type HysteresisModel"]),
    "raises.py": ("raise RuntimeError('calibration file missing')\n", ["RuntimeError: calibration file missing"]),
    "descending_thresholds.py": (MODEL_IMPORT + "MODEL = HysteresisModel(a1=0.0, a2=1.0, thresholds_V=(1.0, 0.5), "
                                 "weights_um_per_V=(0.1, 0.1))\n", ["thresholds must be in ascending order"]),
    "not_invertible.py": (NOT_INVERTIBLE, ["the inverse FMU cannot be built", "not invertible",
                                           f"from {math.sqrt(1 / 3e-4):.5g} V to 150 V"]),
}


@pytest.mark.parametrize("name", sorted(BAD_SPECS))
def test_build_fmu_refuses_bad_specs_and_writes_nothing(tmp_path, capsys, name):
    text, fragments = BAD_SPECS[name]
    spec = tmp_path / name
    spec.write_text(text)
    before = snapshot(tmp_path)
    assert build_fmu_main([str(spec), "-o", str(tmp_path / "out"), "--platforms", "linux64", "-q"]) == 2
    message = one_error_line(capsys, "build-fmu: error: ")
    assert f"{spec}: " in message
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    assert snapshot(tmp_path) == before             # no output folder, the spec untouched


@pytest.mark.parametrize("case", ["missing", "directory", "output_is_a_file"])
def test_build_fmu_missing_spec_directory_and_bad_output(tmp_path, capsys, case):
    spec, output = tmp_path / "spec.py", tmp_path / "out"
    if case == "directory":
        spec.mkdir()
    elif case == "output_is_a_file":
        spec.write_text(NOT_INVERTIBLE.replace("a1=-1e-4", "a1=0.0"))
        output.write_text("not a folder")
    before = snapshot(tmp_path)
    assert build_fmu_main([str(spec), "-o", str(output), "--platforms", "linux64", "-q"]) == 2
    message = one_error_line(capsys, "build-fmu: error: ")
    expected = {"missing": f"{spec}: spec file does not exist", "directory": f"{spec}: is a directory",
                "output_is_a_file": f"{output}: exists and is not a folder"}[case]
    assert expected in message
    assert snapshot(tmp_path) == before


# ---------------------------------------------------------- pysim bandwidth
@pytest.fixture(scope="module")
def unusable_fmus(tmp_path_factory):
    """Files given where an FMU is expected, with what the message must say."""
    folder = tmp_path_factory.mktemp("not-fmus")
    text = folder / "notes.fmu"
    text.write_text("not an FMU\n")
    empty_zip = folder / "empty_archive.fmu"
    with zipfile.ZipFile(empty_zip, "w") as archive:
        archive.writestr("readme.txt", "no model description")
    (folder / "folder.fmu").mkdir()
    windows_only = build_fmus(DEFAULT_MODEL, folder / "windows_only", ("win64",))["plant"]
    return {
        "text_file": (text, "not a readable FMU"),
        "zip_without_model_description": (empty_zip, "modelDescription.xml"),
        "directory": (folder / "folder.fmu", "is a directory"),
        "missing": (folder / "nope.fmu", "FMU file does not exist"),
        "no_binary_for_this_platform": (windows_only, "cannot load and initialise the FMU"),
        "inverse_given_as_plant": (fmu_pair().fmus["inverse"], "so it is the inverse FMU"),
    }


@pytest.mark.parametrize("case", ["text_file", "zip_without_model_description", "directory", "missing",
                                  "no_binary_for_this_platform", "inverse_given_as_plant"])
def test_bandwidth_refuses_a_plant_that_is_not_a_usable_fmu(capsys, unusable_fmus, case):
    path, fragment = unusable_fmus[case]
    inverse = fmu_pair().fmus["inverse"]
    code = pysim_main(["bandwidth", "--plant", str(path), "--inverse", str(inverse), "--points", "30",
                       "--amplitudes", "7.5"])
    assert code == 2
    message = one_error_line(capsys, "pysim bandwidth: error: ")
    assert f"{path}: " in message and fragment in message, message


def test_bandwidth_refuses_a_spec_without_inverse_naming_the_voltage(tmp_path, capsys):
    spec = tmp_path / "steep.py"
    spec.write_text(NOT_INVERTIBLE)
    assert pysim_main(["bandwidth", "--model", str(spec), "--stage", "none"]) == 2
    message = one_error_line(capsys, "pysim bandwidth: error: ")
    assert f"{spec}: the inverse FMU cannot be built" in message
    assert f"from {math.sqrt(1 / 3e-4):.5g} V to 150 V" in message
    assert snapshot(tmp_path) == {"steep.py": NOT_INVERTIBLE.encode()}


@pytest.mark.parametrize("command", ["bandwidth", "track"])
def test_the_chain_refuses_a_spec_with_an_input_stage_naming_it(tmp_path, capsys, command):
    from pysim.core import InputStageModel, load_spec, write_spec

    spec = write_spec(InputStageModel(load_spec(DEFAULT_MODEL), "lowpass", 2e-4, 1e-4), tmp_path / "lagged.py")
    before = snapshot(tmp_path)
    assert pysim_main([command, "--model", str(spec), "--stage", "none"]) == 2
    message = one_error_line(capsys, f"pysim {command}: error: ")
    assert str(spec) in message and "input low-pass, time constant 0.2 ms" in message
    assert "--without-input-stage" in message
    assert snapshot(tmp_path) == before


# ------------------------------------------------ the real programs, once each
def installed_program(name: str) -> str:
    """The console script the installation put beside the interpreter (as a user runs it)."""
    path = Path(sys.executable).parent / name
    assert path.is_file(), f"{name} is not installed beside {sys.executable}"
    return str(path)


@pytest.mark.parametrize("command", [
    ["pysim", "diagnose", str(BAD / "nan.csv")],
    ["build-fmu", "no_such_spec.py", "-o", "out"],
    ["pysim", "bandwidth", "--plant", "missing.fmu", "--inverse", "missing.fmu"],
], ids=["diagnose", "build-fmu", "bandwidth"])
def test_programs_exit_with_code_2_and_one_line(tmp_path, command):
    command = [installed_program(command[0])] + command[1:]
    result = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == []


def test_diagnose_refuses_a_history_floor_above_a_records_lowest_voltage_before_any_work(tmp_path, capsys):
    """`--history-floor` says how low the amplifier ever drove the actuator; a record that goes lower
    contradicts it: one line naming the record, the floor and where the record goes below, exit 2,
    nothing written."""
    from pysim.identification.data import MeasuredData, save_measured

    k = np.arange(3000)
    v = 60.0 + 50.0 * np.sin(2 * np.pi * k / 600)
    first = save_measured(MeasuredData(k / 2000.0, v, 0.1 * v, "first"), tmp_path / "first.csv")
    lowest = int(np.argmin(v))
    before = snapshot(tmp_path)
    code = pysim_main(["diagnose", str(first), "--history-floor", "20", "--out", str(tmp_path / "x.py"),
                       "--report", str(tmp_path / "report")])
    assert code == 2
    message = one_error_line(capsys, "pysim diagnose: error: ")
    expected = (f"pysim diagnose: error: {first}: the history floor, 20 V, is above the record's lowest voltage, "
                f"{v[lowest]:g} V at sample {lowest}")
    assert message.startswith(expected), message
    assert snapshot(tmp_path) == before
