"""The co-simulation harness against the Python model, python-control and itself run in pieces."""
import math
import re
from pathlib import Path

import control
import numpy as np
import pytest
from conftest import random_piecewise_monotone
from pysim.specs.default_mpi import MODEL
from pysim.specs.flexure_stage import STAGE

from pysim.core.model import InverseCompensator
from pysim.cosim.errors import CoSimulationError
from pysim.cosim.harness import CoSimulation, NominalDrive
from pysim.cosim.stage import discretise

pytest_plugins = ["fmu_fixtures"]  # the FMUs, built once


def test_plant_fmu_alone_equals_the_python_model(rng, default_fmus):
    plant, _ = default_fmus
    v = random_piecewise_monotone(rng, n_segments=200, lo=0.0, hi=150.0)
    with CoSimulation(plant, step_s=1e-4) as sim:
        result = sim.run(voltage_V=v)
    assert np.max(np.abs(result.displacement_plant_um - MODEL.simulate(v))) <= 1e-12
    np.testing.assert_array_equal(result.voltage_V, v)
    np.testing.assert_array_equal(result.displacement_stage_um, result.displacement_plant_um)  # no stage
    np.testing.assert_allclose(result.time_s, np.arange(v.size) * 1e-4, rtol=0, atol=1e-15)
    assert result.reference_um is None


def test_chain_with_the_inverse_follows_the_reference(rng, default_fmus):
    plant, inverse = default_fmus
    lo, hi = MODEL.simulate([0.0, 150.0])
    reference = random_piecewise_monotone(rng, n_segments=100, lo=lo + 1.0, hi=hi - 1.0)
    with CoSimulation(plant, inverse) as sim:
        result = sim.run(reference)
    np.testing.assert_allclose(result.voltage_V, InverseCompensator(MODEL)(reference), rtol=0, atol=1e-12)
    np.testing.assert_allclose(result.displacement_plant_um, reference, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(result.reference_um, reference)


def test_runs_in_pieces_continue_fmu_memory_stage_state_and_time(rng, default_fmus):
    plant, inverse = default_fmus
    lo, hi = MODEL.simulate([0.0, 150.0])
    reference = random_piecewise_monotone(rng, n_segments=60, lo=lo + 1.0, hi=hi - 1.0)
    with CoSimulation(plant, inverse, stage=STAGE, step_s=5e-5) as sim:
        whole = sim.run(reference)
        sim.reset()
        again = sim.run(reference)
        sim.reset()
        parts = [sim.run(reference[:k]) for k in (0,)] + [sim.run(reference[:500]), sim.run(reference[500:])]
    np.testing.assert_array_equal(again.displacement_stage_um, whole.displacement_stage_um)
    for field in ("time_s", "voltage_V", "displacement_plant_um", "displacement_stage_um"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, field) for p in parts]), getattr(whole, field))


def test_stage_output_is_the_discretised_stage_driven_by_the_plant_output(rng, default_fmus):
    plant, _ = default_fmus
    v = random_piecewise_monotone(rng, n_segments=30, lo=0.0, hi=150.0)
    for method in ("tustin", "zoh"):
        with CoSimulation(plant, stage=STAGE, step_s=1e-4, stage_method=method) as sim:
            result = sim.run(voltage_V=v)
        _, expected = control.forced_response(discretise(STAGE, 1e-4, method), U=result.displacement_plant_um)
        np.testing.assert_allclose(result.displacement_stage_um, expected, rtol=0, atol=1e-10)


def test_steady_start_puts_the_stage_in_equilibrium(default_fmus):
    plant, _ = default_fmus
    with CoSimulation(plant, stage=STAGE, stage_start="steady") as sim:
        result = sim.run(voltage_V=np.full(100, 80.0))
        np.testing.assert_allclose(result.displacement_stage_um, MODEL.simulate([80.0])[0], rtol=1e-13)
        sim.reset()
        assert sim.run(voltage_V=np.full(5, 20.0)).displacement_stage_um[0] == pytest.approx(
            MODEL.simulate([20.0])[0], rel=1e-13)


def test_nominal_drive_through_the_fmu_equals_the_models_definition(default_fmus, linear_fmus, linear_model):
    for (plant, inverse), model in ((default_fmus, MODEL), (linear_fmus, linear_model)):
        with CoSimulation(plant, inverse) as sim:
            measured = NominalDrive.from_plant(sim)
        expected = NominalDrive.from_model(model)
        assert measured.gain_um_per_V == pytest.approx(model.major_loop_gain(), rel=1e-14)
        assert measured.low_V == expected.low_V and measured.low_um == pytest.approx(expected.low_um, abs=1e-14)
    assert NominalDrive.from_model(linear_model)(np.array([0.0, 37.5])) == pytest.approx([0.0, 75.0])


def test_out_of_range_voltage_is_clamped_by_the_plant_and_the_run_goes_on(default_fmus):
    plant, _ = default_fmus
    with CoSimulation(plant) as sim:
        result = sim.run(voltage_V=[50.0, 200.0, -10.0, 60.0])
    np.testing.assert_allclose(result.displacement_plant_um, MODEL.simulate([50.0, 150.0, 0.0, 60.0]),
                               rtol=0, atol=1e-12)


def test_close_frees_the_fmus_and_is_idempotent(default_fmus):
    plant, inverse = default_fmus
    sim = CoSimulation(plant, inverse)
    folders = [Path(unit._unzipdir) for unit in (sim.plant, sim.inverse)]
    assert all(folder.is_dir() for folder in folders)
    with sim:
        sim.run(voltage_V=[1.0])
    assert not any(folder.exists() for folder in folders)
    sim.close()


def test_bad_use_is_refused_with_a_clear_message(tmp_path, default_fmus):
    plant, inverse = default_fmus
    with pytest.raises(CoSimulationError, match="does not exist"):
        CoSimulation(tmp_path / "missing.fmu")
    junk = tmp_path / "junk.fmu"
    junk.write_bytes(b"not a zip file")
    with pytest.raises(CoSimulationError, match="junk.fmu: not a readable FMU"):
        CoSimulation(junk)
    with pytest.raises(CoSimulationError, match="so it is the plant FMU, not the inverse FMU"):
        CoSimulation(plant, plant)
    with pytest.raises(CoSimulationError, match="so it is the inverse FMU, not the plant FMU"):
        CoSimulation(inverse)
    with CoSimulation(plant, stage=STAGE) as sim:
        with pytest.raises(ValueError, match="needs an inverse FMU"):
            sim.run([1.0, 2.0])
        with pytest.raises(ValueError, match="exactly one"):
            sim.run()
        with pytest.raises(ValueError, match="NaN"):
            sim.run(voltage_V=[1.0, math.nan])
        with pytest.raises(ValueError, match="one-dimensional"):
            sim.run(voltage_V=np.ones((2, 2)))
        with pytest.raises(ValueError, match="positive"):
            sim.reset(step_s=-1.0)
    with pytest.raises(ValueError, match="stage_start"):
        CoSimulation(plant, stage_start="moving")


def test_a_failing_fmu_call_stops_the_run_with_the_fmus_own_message(default_fmus, capfd):
    plant, inverse = default_fmus
    with CoSimulation(plant, inverse) as sim:
        sim.run([30.0, 31.0])
        sim.plant._slave.terminate()          # from now on the plant refuses to step
        with pytest.raises(RuntimeError, match=r"default_mpi_plant.fmu: at t = 0.0002 s \(voltage = [0-9.]+\): "
                                               r"fmi2SetReal returned Error: .*not allowed"):
            sim.run([32.0])
    out, err = capfd.readouterr()
    assert out == ""                          # stdout stays clean for JSON
    assert re.search(r"plant(-\d+)? FMU \[Error\] fmi2SetReal: not allowed", err)


def test_bad_stage_settings_are_refused_before_any_fmu_is_loaded(default_fmus, monkeypatch):
    plant, _ = default_fmus
    opened = []
    monkeypatch.setattr("pysim.cosim.harness.FMUUnit", lambda *args: opened.append(args))
    with pytest.raises(ValueError, match="method"):
        CoSimulation(plant, stage=STAGE, stage_method="euler")
    with pytest.raises(ValueError, match="Nyquist"):
        CoSimulation(plant, stage=STAGE, step_s=1e-3, prewarp_hz=900.0)
    assert opened == []
