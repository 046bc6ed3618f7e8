"""`pysim demo`, `pysim track`, `pysim bandwidth` as a user runs them (subprocesses)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

pytest_plugins = ["fmu_fixtures"]  # the FMUs, built once


PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def pysim(*args, cwd=None):
    # the console script the installation put beside the interpreter, as a user runs it
    program = Path(sys.executable).parent / "pysim"
    return subprocess.run([str(program), *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


def test_demo_writes_plots_report_and_results(tmp_path):
    """The demo co-simulates a compensator identified on the rig against an
    actuator it does not mirror: open loop it leaves an error (model mismatch),
    far below the uncompensated one; the loop with the inverse as feedforward
    does best; feedback alone cannot reach the stage's bandwidth."""
    out = tmp_path / "demo"
    result = pysim("demo", "--out", out, "--points", "12", "--monte-carlo", "2", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    for name in ("bode.png", "tracking_error.png", "loops.png"):
        data = (out / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 20000
    report = (out / "report.md").read_text()
    assert "2.93 / 1.03" in report and "884 Hz" in report and "![Bode magnitude and phase](bode.png)" in report
    results = json.loads((out / "results.json").read_text())
    rows = results["tracking"]
    assert [row["amplitude_um"] for row in rows] == [7.5, 15.0, 22.5, 30.0]
    for row in rows:
        unc, comp = row["uncompensated"]["rms_error_pct"], row["compensated"]["rms_error_pct"]
        both, fb = row["feedback+compensated"]["rms_error_pct"], row["feedback"]["rms_error_pct"]
        assert 0.05 < comp < unc / 5          # mismatch is left: not the 0.01 % of a model against itself
        assert both < comp and both < fb
    bandwidths = results["bandwidth"]
    assert set(bandwidths) == {"uncompensated", "compensated", "feedback", "feedback+compensated"}
    stage_hz = results["stage"]["minus3db_hz"]
    assert bandwidths["feedback"]["7.5"]["minus3db_normalised_hz"] < 0.2 * stage_hz
    assert results["monte_carlo"]["draws"] == 2
    spread = results["monte_carlo"]["summary"]["compensated"]["minus3db_normalised_hz"]
    assert spread["crossed"] == 2 and spread["p5"] <= spread["median"] <= spread["p95"] < stage_hz
    import zipfile

    with zipfile.ZipFile(out / "rig.ssp") as ssp:
        names = ssp.namelist()
    assert "SystemStructure.ssd" in names and sum(n.endswith(".fmu") for n in names) == 6
    assert "Tracking errors" in result.stdout and "-3 dB bandwidth" in result.stdout
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no staging left behind


def test_track_json(default_fmus):
    plant, inverse = default_fmus
    result = pysim("track", "--json", "--plant", plant, "--inverse", inverse)
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    rows = data["tracking"]
    assert [row["amplitude_um"] for row in rows] == [7.5, 15.0, 22.5, 30.0]
    for row in rows:
        assert row["compensated"]["max_error_pct"] < row["uncompensated"]["max_error_pct"]
        assert row["paper"]["max_error_pct"] > 0


def test_track_takes_the_users_references_and_warns_when_they_are_out_of_reach(default_fmus):
    """The default actuator reaches about 0 to 74.6 µm: a 40 µm sine around
    37.5 µm leaves that range, and the user is told so."""
    plant, inverse = default_fmus
    result = pysim("track", "--json", "--plant", plant, "--inverse", inverse, "--amplitudes", "10", "40",
                   "--offset", "37.5", "--frequency", "2", "--step", "5e-4")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert [row["amplitude_um"] for row in data["tracking"]] == [10.0, 40.0]
    assert data["reference"] == "x_d = A sin(2 pi 2 t) + 37.5 um"
    assert all(row["paper"] is None for row in data["tracking"])         # not Table III's reference
    assert len(data["warnings"]) == 1 and "A = 40 µm" in data["warnings"][0]
    assert "warning: the reference A = 40 µm spans -2.5 to 77.5 µm" in result.stderr
    small, large = data["tracking"]
    assert small["compensated"]["max_error_pct"] < 1.0 < large["compensated"]["max_error_pct"]


def test_bandwidth_json(default_fmus):
    plant, inverse = default_fmus
    result = pysim("bandwidth", "--json", "--plant", plant, "--inverse", inverse, "--amplitudes", "10", "20")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert set(data["bandwidth_hz"]) == {"uncompensated", "compensated"}
    for value in data["bandwidth_hz"].values():
        assert value == pytest.approx(data["stage_bandwidth_hz"], rel=0.01)
    assert [row["amplitude_um"] for row in data["by_amplitude"]] == [10.0, 20.0]
    assert data["paper_bandwidth_hz"] == {"uncompensated": 185.0, "compensated": 884.0}
    assert len(data["frequencies_hz"]) >= 30


@pytest.mark.parametrize("args, message", [
    (("bandwidth", "--points", "5"), "--points must be at least 30"),
    (("bandwidth", "--f-min", "100", "--f-max", "10"), "--f-min"),
    (("bandwidth", "--amplitudes", "-1"), "--amplitudes must be positive"),
    (("track", "--plant", "x.fmu"), "give both --plant and --inverse"),
    (("track", "--plant", "missing.fmu", "--inverse", "missing.fmu"), "missing.fmu: FMU file does not exist"),
    (("track", "--step", "0.03"), "does not divide"),
    (("track", "--stage", "missing_stage.py"), "missing_stage.py: stage file does not exist"),
    (("track", "--model", "missing_spec.py"), "missing_spec.py"),
])
def test_bad_input_is_one_line_and_exit_code_2(tmp_path, args, message):
    result = pysim(*args, cwd=tmp_path)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr


def test_demo_refuses_an_output_path_that_is_a_file(tmp_path):
    target = tmp_path / "taken"
    target.write_text("keep me")
    result = pysim("demo", "--out", target)
    assert result.returncode == 2 and "is not a folder" in result.stderr
    assert target.read_text() == "keep me"


def test_a_discrete_stage_must_match_the_step_and_cannot_be_swept(tmp_path):
    stage = tmp_path / "discrete_stage.py"
    stage.write_text("import control\nSTAGE = control.sample_system(control.tf([1.0], [1e-3, 1.0]), 1e-4)\n")
    result = pysim("bandwidth", "--stage", stage)
    assert result.returncode == 2 and "the stage is discrete, but a sweep changes the step" in result.stderr
    result = pysim("track", "--stage", stage, "--step", "0.001")
    assert result.returncode == 2 and "differs from the communication step (0.001 s)" in result.stderr
    result = pysim("track", "--stage", stage, "--json")
    assert result.returncode == 0, result.stderr
    assert len(json.loads(result.stdout)["tracking"]) == 4


def test_bandwidth_without_a_stage_is_flat_and_reports_no_crossing(default_fmus):
    plant, inverse = default_fmus
    result = pysim("bandwidth", "--json", "--stage", "none", "--plant", plant, "--inverse", inverse,
                   "--amplitudes", "10")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["bandwidth_hz"] == {"uncompensated": None, "compensated": None}
    assert "stage_bandwidth_hz" not in data


def test_track_reference_csv_equals_the_same_sine_given_by_amplitude(default_fmus, tmp_path):
    """A reference CSV holding the Table III sine at A = 15 µm, scored from the second period on,
    gives the errors `--amplitudes 15` gives (two ways of asking the same question)."""
    import numpy as np

    plant, inverse = default_fmus
    step = 1e-4
    k = np.arange(20000)
    reference = 37.5 + 15.0 * np.sin(2 * np.pi * (k % 10000) / 10000)
    csv = tmp_path / "reference.csv"
    np.savetxt(csv, np.column_stack([k * step, reference]), delimiter=",", header="time_s,displacement_um",
               comments="", fmt="%.17g")
    by_file = pysim("track", "--json", "--plant", plant, "--inverse", inverse, "--reference", csv,
                    "--score-from", "1.0")
    by_sine = pysim("track", "--json", "--plant", plant, "--inverse", inverse, "--amplitudes", "15")
    assert by_file.returncode == 0 and by_sine.returncode == 0, by_file.stderr + by_sine.stderr
    file_row = json.loads(by_file.stdout)["tracking"][0]
    sine_row = json.loads(by_sine.stdout)["tracking"][0]
    assert json.loads(by_file.stdout)["scored_from_sample"] == 10000
    for path in ("uncompensated", "compensated"):
        for key in ("max_error_pct", "rms_error_pct"):
            assert file_row[path][key] == pytest.approx(sine_row[path][key], rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("case", ["uneven", "constant", "both", "late", "step"])
def test_track_reference_refuses_what_it_cannot_use(default_fmus, tmp_path, case):
    plant, inverse = default_fmus
    csv = tmp_path / "reference.csv"
    times = [0.0, 0.001, 0.0025, 0.003] if case == "uneven" else [0.0, 0.001, 0.002, 0.003]
    values = [30.0, 30.0, 30.0, 30.0] if case == "constant" else [30.0, 31.0, 32.0, 31.0]
    csv.write_text("time_s,displacement_um\n" + "".join(f"{t},{x}\n" for t, x in zip(times, values)))
    extra = {"both": ["--amplitudes", "10"], "late": ["--score-from", "5"], "step": ["--step", "1e-4"]}.get(case, [])
    result = pysim("track", "--plant", plant, "--inverse", inverse, "--reference", csv, *extra)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1
    assert {"uneven": "not uniform", "constant": "constant", "both": "not both", "late": "--score-from",
            "step": "leave --step out"}[case] \
        in result.stderr
