"""Table III tracking through the FMUs: the compensated error is the stage's lag only,
the uncompensated one is the Python model's, and compensation wins at every amplitude."""
import math

import control
import numpy as np
import pytest
from pysim.specs.default_mpi import MODEL
from pysim.specs.flexure_stage import STAGE

from pysim.core.metrics import error_measures
from pysim.cosim.harness import CoSimulation, NominalDrive
from pysim.cosim.stage import DiscreteStage
from pysim.cosim.tracking import PAPER_TABLE_III, TABLE_III_AMPLITUDES_UM, format_table, table_iii_reference, track

pytest_plugins = ["fmu_fixtures"]  # the FMUs, built once


def test_table_iii_reference():
    t, x = table_iii_reference(30.0, step_s=1e-3, periods=2)
    assert t.size == 2000 and t[1] == pytest.approx(1e-3)
    np.testing.assert_allclose(x, 37.5 + 30.0 * np.sin(2 * np.pi * t), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="divide the period"):
        table_iii_reference(30.0, step_s=0.3)


@pytest.fixture(scope="module")
def tracked(default_fmus):
    plant, inverse = default_fmus
    with CoSimulation(plant, inverse, stage=STAGE) as sim:
        return track(sim, NominalDrive.from_model(MODEL), step_s=1e-4, periods=2)


def test_compensation_beats_no_compensation_at_every_table_iii_amplitude(tracked):
    rows, _ = tracked
    assert [row["amplitude_um"] for row in rows] == list(TABLE_III_AMPLITUDES_UM)
    for row in rows:
        for key in ("max_error_pct", "rms_error_pct"):
            assert row["compensated"][key] < 0.01 * row["uncompensated"][key]
        assert row["paper"] == PAPER_TABLE_III[row["amplitude_um"]]


def test_compensated_error_is_the_stage_lag_at_one_hertz(tracked):
    """Exact inverse: actuator = x_d, so x_d - x = (1 - G) acting on the sine:
    e_m = 50 |1 - G(j2π)| %, e_rms = e_m / sqrt(2) (range 2A)."""
    rows, _ = tracked
    lag = abs(1 - complex(STAGE(2j * math.pi * 1.0)))
    for row in rows:
        assert row["compensated"]["max_error_pct"] == pytest.approx(50 * lag, rel=1e-3)
        assert row["compensated"]["rms_error_pct"] == pytest.approx(50 * lag / math.sqrt(2), rel=1e-3)


def test_uncompensated_error_equals_the_python_model_through_the_stage(tracked):
    rows, runs = tracked
    drive = NominalDrive.from_model(MODEL)
    for row in rows:
        _, x_d = table_iii_reference(row["amplitude_um"], 1e-4, 2)
        actuator = MODEL.simulate(drive(x_d))
        stage = DiscreteStage(STAGE, 1e-4)
        _, x = control.forced_response(stage.system, U=actuator, X0=_equilibrium(stage.system, actuator[0]))
        expected = error_measures(x_d[10000:], x[10000:])
        for key in ("max_error_pct", "rms_error_pct"):
            assert row["uncompensated"][key] == pytest.approx(expected[key], rel=1e-9)
        assert runs[(row["amplitude_um"], "uncompensated")].reference_um is not None


def _equilibrium(system, u0):
    ss = control.ss(system)
    a, b = np.asarray(ss.A), np.asarray(ss.B)
    return np.linalg.solve(np.eye(a.shape[0]) - a, b.ravel() * u0)


def test_table_text_shows_the_paper_figures(tracked):
    rows, _ = tracked
    text = format_table(rows)
    for paper in PAPER_TABLE_III.values():
        assert f"{paper['max_error_pct']:.2f}%" in text and f"{paper['rms_error_pct']:.2f}%" in text
