"""The rig as an SSP: every part an FMU, wired per path; fmpy's SSP master
gives the samples of the Python harness (RigSimulation.run_path) on every
path, the SSD is valid SSP 1.0 and every FMU in it passes fmpy validate."""
import zipfile

import numpy as np
import pytest
from fmpy.ssp.ssd import read_ssd
from fmpy.validation import validate_fmu

from pysim.core.rig import Amplifier, Converter, PIController, SensorNoise
from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import fmus_for_model, plant_fmu_for_model
from pysim.cosim.rig import PATHS, Rig, RigSimulation
from pysim.cosim.ssp import rig_ssp_inputs, simulate_rig_ssp, write_rig_ssp
from pysim.specs.default_mpi import MODEL
from pysim.specs.flexure_stage import STAGE

T = 5e-5
TRUTH = MODEL.with_parameters(weights_um_per_V=tuple(1.1 * b for b in MODEL.weights_um_per_V),
                              name="default_mpi_weights_x1_1")
RIG = Rig(plant=TRUTH, stage=STAGE,
          amplifier=Amplifier(gain_V_per_V=15.0, bandwidth_hz=10e3, current_limit_A=0.3, capacitance_F=3.6e-6),
          dac=Converter(16, 0.0, 10.0), adc=Converter(16, -10.0, 110.0), noise=SensorNoise(0.01, 2014),
          controller=PIController(kp_V_per_um=0.05, ki_V_per_um_s=600.0), step_s=T, name="small_rig")
SIGNALS = ("command_V", "voltage_V", "displacement_plant_um", "displacement_stage_um", "measured_um")


def _reference(n=1200):
    """A 100 Hz sine over most of the range, then a fast large step (slew limit, saturation)."""
    t = np.arange(n) * T
    r = 35.0 + 30.0 * np.sin(2 * np.pi * 100.0 * t)
    r[n // 2:] = np.where(np.arange(n - n // 2) < n // 4, 72.0, 2.0)
    return r


@pytest.fixture(scope="module")
def harness_fmus():
    return plant_fmu_for_model(TRUTH), fmus_for_model(MODEL)[1]


@pytest.fixture(scope="module")
def ssps(tmp_path_factory):
    out = tmp_path_factory.mktemp("ssp")
    return {path: write_rig_ssp(RIG, MODEL if "compensated" in path else None, out / f"{path}.ssp", path)
            for path in PATHS}


def _max_relative(a, b):
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


@pytest.mark.parametrize("path", PATHS)
def test_ssp_under_fmpy_equals_the_harness(ssps, harness_fmus, path):
    r = _reference()
    result = simulate_rig_ssp(ssps[path], r, T, path)
    with RigSimulation(RIG, *harness_fmus) as sim:
        expected = sim.run_path(r, path)
    for name in SIGNALS:
        a, b = getattr(result, name), getattr(expected, name)
        assert _max_relative(a, b) <= 1e-12, (path, name)
        assert np.array_equal(a, b), (path, name)          # in fact bit for bit on linux64
    np.testing.assert_array_equal(result.time_s, expected.time_s)
    # the rig does something: the stage moves, the amplifier saturates or slews somewhere
    assert np.ptp(expected.displacement_stage_um) > 50.0


def test_ssp_is_valid_and_wired(ssps):
    ssp = ssps["feedback+compensated"]
    ssd = read_ssd(str(ssp))                       # validates against the SSP 1.0 schema
    names = {element.name for element in ssd.system.elements}
    assert names == {"inverse", "controller", "amplifier", "plant", "stage", "sensor"}
    wires = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    for wire in [(None, "reference", "controller", "reference"),
                 (None, "reference_ahead", "inverse", "displacement_ref"),
                 ("inverse", "voltage", "controller", "feedforward"),
                 ("controller", "command", "amplifier", "command"),
                 ("amplifier", "voltage", "plant", "voltage"),
                 ("plant", "displacement", "stage", "u"),
                 ("stage", "y", "sensor", "displacement"),
                 ("sensor", "measurement", "controller", "measurement")]:
        assert wire in wires
    open_loop = read_ssd(str(ssps["feedback"]))
    assert "inverse" not in {element.name for element in open_loop.system.elements}


@pytest.mark.parametrize("path", ["feedback+compensated", "uncompensated"])
def test_every_fmu_in_the_ssp_passes_fmpy_validate(ssps, tmp_path, path):
    with zipfile.ZipFile(ssps[path]) as archive:
        members = [m for m in archive.namelist() if m.startswith("resources/") and m.endswith(".fmu")]
        assert members
        for member in members:
            target = tmp_path / member.split("/")[-1]
            target.write_bytes(archive.read(member))
            assert validate_fmu(str(target)) == [], member


def test_rig_without_stage(tmp_path, harness_fmus):
    rig = RIG.with_parts(stage=None, noise=SensorNoise(0.0))
    r = _reference(600)
    ssp = write_rig_ssp(rig, MODEL, tmp_path / "no_stage.ssp", "feedback+compensated")
    result = simulate_rig_ssp(ssp, r, T, "feedback+compensated")
    with RigSimulation(rig, *harness_fmus) as sim:
        expected = sim.run_path(r, "feedback+compensated")
    for name in SIGNALS:
        assert np.array_equal(getattr(result, name), getattr(expected, name)), name


def test_inputs_and_refusals(tmp_path):
    inputs = rig_ssp_inputs([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0], T, "compensated")
    assert inputs["reference"](2 * T) == 3.0 and inputs["reference_ahead"](0.0) == 7.0
    assert inputs["reference_ahead"](5 * T) == 8.0                      # held at the last value
    with pytest.raises(CoSimulationError, match="path must be one of"):
        write_rig_ssp(RIG, MODEL, tmp_path / "x.ssp", "closed")
    with pytest.raises(CoSimulationError, match="needs a compensator"):
        write_rig_ssp(RIG, None, tmp_path / "x.ssp", "compensated")
    with pytest.raises(CoSimulationError, match="needs a controller"):
        write_rig_ssp(RIG.with_parts(controller=PIController()), None, tmp_path / "x.ssp", "feedback")
    assert not (tmp_path / "x.ssp").exists()


def test_ssp_for_every_platform(tmp_path):
    """An SSP to hand on: every FMU in it carries linux64, win64 and darwin64 binaries."""
    ssp = write_rig_ssp(RIG, None, tmp_path / "all.ssp", "feedback", fmu_dir=tmp_path / "fmus",
                        platforms=("linux64", "win64", "darwin64"))
    with zipfile.ZipFile(ssp) as archive:
        for member in [m for m in archive.namelist() if m.endswith(".fmu")]:
            with zipfile.ZipFile(archive.open(member)) as fmu:
                folders = {name.split("/")[1] for name in fmu.namelist() if name.startswith("binaries/")}
                assert folders == {"linux64", "win64", "darwin64"}, member


def test_ssp_equals_the_harness_for_an_extended_plant(tmp_path):
    from pysim.core.extended import ExtendedModel, StageSpec

    gain = TRUTH.major_loop_gain()
    plant = ExtendedModel(TRUTH, StageSpec(sample_period_s=T, creep_time_constants_s=(0.05, 1.0),
                                           creep_weights_um_per_V=(0.012 * gain, 0.018 * gain)))
    rig = RIG.with_parts(plant=plant)
    r = _reference(600)
    ssp = write_rig_ssp(rig, MODEL, tmp_path / "creep.ssp", "compensated")
    result = simulate_rig_ssp(ssp, r, T, "compensated")
    with RigSimulation(rig, plant_fmu_for_model(plant), fmus_for_model(MODEL)[1]) as sim:
        expected = sim.run_path(r, "compensated")
    assert _max_relative(result.displacement_plant_um, expected.displacement_plant_um) <= 1e-12
