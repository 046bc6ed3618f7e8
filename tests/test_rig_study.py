"""`pysim.studies.rig_study`: the Monte-Carlo over model error, checked by a round trip.

With zero spread every draw sets the identified parameters on the inverse FMU again, so its
tracking errors and -3 dB points must equal those of the compensator run directly; with a spread
the draws must differ, and each summary must be the percentiles of its own draws."""
import numpy as np
import pytest

from pysim.cosim.rig import load_rig, rig_stepped_sine, sweep_frequencies
from pysim.cosim.tracking import TABLE_III_OFFSET_UM
from pysim.studies.rig_study import RigStudy

PATHS = ("compensated", "feedback+compensated")


@pytest.fixture(scope="module")
def study():
    return RigStudy.identify_on(load_rig("rig_default"))


def test_zero_spread_draws_reproduce_the_identified_compensator(study):
    mc = study.monte_carlo(2, weight_spread=0.0, a2_spread=0.0, a1_spread=0.0, amplitude_um=15.0, paths=PATHS,
                           sweep_points=12, sweep_f_min_hz=50.0)
    rows = study.table_iii(amplitudes_um=(15.0,), paths=PATHS)
    frequencies, _ = sweep_frequencies(study.rig.step_s, 50.0, 2000.0, 12)
    with study.simulation() as sim:
        for path in PATHS:
            for run in mc["runs"][path]:
                assert run["rms_error_pct"] == pytest.approx(rows[0][path]["rms_error_pct"], rel=1e-12)
            direct = rig_stepped_sine(sim, 15.0, TABLE_III_OFFSET_UM, path, frequencies)
            for band in mc["bandwidths"][path]:
                assert band["minus3db_normalised_hz"] == pytest.approx(direct.bandwidth_hz(), rel=1e-9)
                assert band["minus3db_vs_desired_hz"] == pytest.approx(direct.bandwidth_vs_desired_hz(), rel=1e-9)
            assert mc["summary"][path]["minus3db_normalised_hz"]["crossed"] == 2
    assert mc["sweep"]["points"] == frequencies.size


def test_drawn_compensators_spread_and_the_summary_is_their_percentiles(study):
    mc = study.monte_carlo(4, amplitude_um=15.0, paths=("compensated",), sweep_points=10, sweep_f_min_hz=50.0)
    errors = [run["rms_error_pct"] for run in mc["runs"]["compensated"]]
    assert len(set(errors)) == 4                                   # every draw is another compensator
    summary = mc["summary"]["compensated"]
    assert summary["rms_error_pct"]["median"] == pytest.approx(float(np.median(errors)))
    crossed = [b["minus3db_vs_desired_hz"] for b in mc["bandwidths"]["compensated"]]
    assert summary["minus3db_vs_desired_hz"]["p5"] == pytest.approx(float(np.percentile(crossed, 5)))
    # no sweep asked: no bandwidths, errors as before
    quick = study.monte_carlo(1, paths=("compensated",), sweep_points=0)
    assert quick["sweep"] is None and quick["summary"]["compensated"]["minus3db_normalised_hz"] is None
