"""The FMI misuse suite (tests/c/fmu_misuse.c) on both FMUs of the default
spec, loaded into one process, with every binary that runs here: linux64
natively and win64 under wine.

Each case is a call an importer gets wrong (or a property that must hold
after it); the driver prints the status it expected -- the one the FMI 2.0
standard asks for -- and the one it got, and whether the logger was called.
The standard's words behind the expectations (FMI 2.0.x, section 2.1.3 and
the function descriptions):
  - fmi2Error: "the FMU encountered an error ... Function logger was called in
    the FMU": every refused call returns fmi2Error and logs why (here the call
    also has no effect, see tests/test_fmu_calls.py);
  - fmi2Warning: "things are not quite right, but the computation can
    continue": an input clamped into its range, an unreachable reference;
  - fmi2Discard from fmi2GetXXXStatus: "the slave is not able to return the
    required status information";
  - fmi2Instantiate returns NULL when instantiation fails, "functions->logger
    was called with detailed information about the reason"; the instance name
    must be non-empty with "at least one character that is no white space";
  - fmi2DoStep: the communication step size must be > 0.
A call with no valid instance has no logger to reach: it must return fmi2Error
and do nothing else.
"""
from __future__ import annotations

import shutil
import subprocess

import pytest
from fmpy import read_model_description
from robustness import fmu_pair, misuse_driver, parse_cases, wine

from pysim.testing.fmus import DEFAULT_MODEL

MODEL = DEFAULT_MODEL
PLATFORMS = ("linux64", "win64")
REFUSED = {"Error", "NULL"}


def _run_linux(tmp):
    pair = fmu_pair()
    libraries = {kind: pair.library(kind) for kind in pair.folders}
    return subprocess.run([str(misuse_driver("linux")), "cases", *pair.misuse_arguments(libraries)], cwd=tmp,
                          capture_output=True, text=True, timeout=300)


def _run_windows(tmp):
    pair = fmu_pair()
    for kind in pair.folders:
        shutil.copy(pair.library(kind, "win64"), tmp)
    shutil.copy(misuse_driver("windows"), tmp)
    libraries = {kind: pair.library(kind, "win64").name for kind in pair.folders}
    program, env = wine()
    return subprocess.run([program, "fmu_misuse.exe", "cases", *pair.misuse_arguments(libraries)], cwd=tmp,
                          env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{platform: (completed process, cases, tried, handled)}"""
    out = {}
    for platform, run in (("linux64", _run_linux), ("win64", _run_windows)):
        result = run(tmp_path_factory.mktemp(platform))
        out[platform] = (result, *parse_cases(result.stdout))
    return out


@pytest.mark.parametrize("platform", PLATFORMS)
def test_every_case_is_handled_and_nothing_crashes(runs, platform):
    result, cases, tried, handled = runs[platform]
    failed = [f"{c['fmu']}/{c['name']}: expected {c['expected']}, got {c['got']}, logged {c['logged']}"
              for c in cases if c["result"] != "ok"]
    assert not failed, "\n".join(failed)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert tried == handled == len(cases) >= 500
    assert len({(c["fmu"], c["name"]) for c in cases}) == len(cases)       # every case named once
    # both FMUs went through the whole suite
    assert {c["fmu"] for c in cases} == {"plant", "inverse", "both"}
    assert min(sum(c["fmu"] == kind for c in cases) for kind in ("plant", "inverse")) >= 250


def test_every_section_ran_on_both_fmus(runs):
    cases = runs["linux64"][1]
    sections = ("library", "instantiation", "no-instance", "wrong-state", "step-complete", "voltage-range",
                "parameters", "fmu-state", "foreign-instance", "many-instances")
    for fmu in ("plant", "inverse"):
        counts = {s: sum(c["fmu"] == fmu and c["section"] == s for c in cases) for s in sections}
        assert all(counts.values()), counts
        print(f"{fmu}: " + ", ".join(f"{s} {n}" for s, n in counts.items()))


def test_linux_and_windows_binaries_answer_alike(runs):
    def answers(platform):
        return [(c["fmu"], c["name"], c["expected"], c["got"], c["logged"]) for c in runs[platform][1]]

    assert answers("linux64") == answers("win64")


@pytest.mark.parametrize("platform", PLATFORMS)
def test_refused_calls_are_errors_and_are_logged(runs, platform):
    cases = runs[platform][1]
    for c in cases:
        if c["rule"] == "must-log":
            assert c["logged"] == "yes", c
        if c["rule"] == "no-instance":
            assert c["logged"] == "no" and c["got"] in ("Error", "NULL", "instance", "returned"), c
    # the statuses the standard asks for, by kind of misuse
    by_name = {(c["fmu"], c["name"]): c for c in cases}
    for fmu in ("plant", "inverse"):
        def got(name):
            return by_name[(fmu, name)]["got"]

        for name in ("setReal_NaN_input", "setReal_+inf_input", "setReal_-inf_input", "doStep_before_initialisation",
                     "setReal_on_an_output", "terminate_twice", "NULL_component_GetFMUstate", "doStep_zero_step",
                     "doStep_negative_step", "doStep_communication_point_ahead", "getReal_unknown_vr",
                     "setReal_NULL_vr", "getReal_NULL_values", "deSerializeFMUstate_truncated_to_40_bytes",
                     "deSerializeFMUstate_corrupted_checksum", "deSerializeFMUstate_sealed_NaN_memory",
                     "setFMUstate_of_the_other_FMU", "doStep_on_an_instance_of_the_other_FMU"):
            assert got(name) == "Error", (fmu, name)
        for name in ("instantiate_NULL_callbacks", "instantiate_NULL_instanceName", "instantiate_blank_instanceName",
                     "instantiate_wrong_GUID", "instantiate_NULL_GUID", "instantiate_ModelExchange",
                     "instantiate_out_of_memory"):
            assert got(name) == "NULL", (fmu, name)
        assert got("getStatus_doStepStatus") == "Discard"
        assert got("500_instances_alive_at_once") == "500"
        assert got("500_instances_each_as_if_alone") == "true"
        assert got("refused_calls_left_the_instance_unchanged") == "true"
    assert by_name[("both", "every_block_allocated_was_freed")]["got"] == "true"


def _value(cases, fmu, name):
    return float(next(c["got"] for c in cases if c["fmu"] == fmu and c["name"] == name))


@pytest.mark.parametrize("platform", PLATFORMS)
def test_out_of_range_voltages_follow_the_documented_behaviour(runs, platform):
    """Plant: a voltage outside [voltage_min, voltage_max] is clamped to the
    range end with fmi2Warning; inverse: an unreachable reference saturates
    the voltage at the range end with fmi2Warning.  Both are what the model
    descriptions say; the displacement at a clamped voltage is the Python
    model's at the range end."""
    cases = runs[platform][1]
    lo, hi = MODEL.voltage_range_V
    statuses = {(c["fmu"], c["name"]): c["got"] for c in cases}
    for name, edge in (("voltage_above_range", hi), ("voltage_below_range", lo), ("voltage_1e308", hi),
                       ("voltage_-1e308", lo)):
        assert statuses[("plant", f"setReal_{name}_clamped_with_warning")] == "Warning"
        assert _value(cases, "plant", f"{name}_stored_as_range_end") == edge
        expected = float(MODEL.simulate([edge])[0])
        assert _value(cases, "plant", f"{name}_displacement_as_at_range_end") == pytest.approx(expected, rel=1e-12)
    for name, edge in (("reference_1e6_um", hi), ("reference_-1e6_um", lo), ("reference_1e308_um", hi),
                       ("reference_-1e308_um", lo)):
        assert statuses[("inverse", f"setReal_{name}_accepted")] == "OK"
        assert statuses[("inverse", f"getReal_{name}_saturated_with_warning")] == "Warning"
        assert _value(cases, "inverse", f"{name}_voltage_at_range_end") == edge
    # the documentation the importer sees
    pair = fmu_pair()
    plant = {v.name: v for v in read_model_description(str(pair.folders["plant"])).modelVariables}
    inverse = {v.name: v for v in read_model_description(str(pair.folders["inverse"])).modelVariables}
    assert "clamped into [voltage_min, voltage_max]" in plant["voltage"].description
    assert "within [voltage_min, voltage_max]" in inverse["voltage"].description
    categories = (pair.folders["plant"] / "modelDescription.xml").read_text()
    assert "voltage clamped into its range, inverse saturated" in categories


def test_the_driver_says_what_it_cannot_try(runs):
    result = runs["linux64"][0]
    assert "# not tried: calls after fmi2FreeInstance" in result.stdout
