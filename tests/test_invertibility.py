"""The invertibility check against slopes measured on simulated branches."""
import numpy as np
import pytest
from conftest import paper_model, random_piecewise_monotone

from pysim.core.invertibility import check_invertibility
from pysim.core.model import HysteresisModel


def measured_slopes(model, v):
    y = model.simulate(v)
    dv, dy = np.diff(v), np.diff(y)
    moving = np.abs(dv) > 1e-9
    return v[1:][moving], dy[moving] / dv[moving]


def branch_slope(model, reversal, u, ascending, top_first=True):
    """Slope at u on the branch that starts at `reversal` after visiting the far end of the range."""
    lo, hi = model.voltage_range_V
    far = hi if ascending else lo
    ramp = lambda a, b: np.linspace(a, b, 400)  # noqa: E731
    path = np.concatenate([ramp(lo, hi), ramp(hi, far), ramp(far, reversal), ramp(reversal, u)])
    h = 1e-7 * (hi - lo) * (1 if ascending else -1)
    y = model.simulate(np.concatenate([path, [u + h]]))
    return (y[-1] - y[-2]) / h


def test_the_papers_a1_minus_one_fails_where_the_slope_crosses_zero():
    model = paper_model(a1=-1.0)
    report = check_invertibility(model)
    assert not report.invertible
    # only the r = 0 operator follows the input right after a reversal: slope 2.42 + b_1 - 3 v^2
    v_zero = np.sqrt((2.42 + model.weights[0]) / 3.0)
    starts = [f[1] for f in report.failures]
    assert min(starts) == pytest.approx(v_zero, rel=1e-12)
    assert f"{v_zero:.6g} V" in report.message
    assert report.min_slope_um_per_V == pytest.approx(2.42 + model.weights[0] - 3.0, rel=1e-12)
    # and a branch really has a negative slope there: descend from the top by less than r_2
    assert branch_slope(model, 1.0, 0.97, ascending=False) < 0
    assert branch_slope(model, 0.9, 0.5, ascending=False) > 0


def test_invertible_models_have_no_negative_slope_anywhere(rng):
    model = paper_model(a1=-0.8)
    report = check_invertibility(model)
    assert report.invertible
    for _ in range(5):
        _, slopes = measured_slopes(model, random_piecewise_monotone(rng, n_segments=60,
                                                                    points_per_segment=(50, 200)))
        assert slopes.min() >= report.min_slope_um_per_V - 1e-6


@pytest.mark.parametrize("seed", range(6))
def test_reported_failures_are_real_and_slopes_elsewhere_positive(seed):
    rng = np.random.default_rng(seed)
    n = 6
    r = np.arange(n) / n
    b = rng.normal(0.3, 0.6, n)          # some negative weights
    model = HysteresisModel(rng.uniform(-1.5, 0.5), rng.uniform(0.3, 1.5), tuple(r), tuple(b),
                            voltage_range_V=(0.0, 1.0), name="random")
    report = check_invertibility(model)
    for branch, v_from, v_to, k in report.failures:
        ascending = branch == "ascending"
        u = 0.5 * (v_from + v_to)
        d = (r[k - 1] if k > 0 else 0.0)
        upper = r[k] if k < n else 1.0
        d = d + 0.5 * (min(upper, (u - 0.0) if ascending else (1.0 - u)) - d)
        reversal = u - d if ascending else u + d
        assert branch_slope(model, reversal, u, ascending) <= 1e-6
    # no measured slope anywhere is below the reported minimum
    _, slopes = measured_slopes(model, random_piecewise_monotone(rng, n_segments=60,
                                                                points_per_segment=(50, 200)))
    assert slopes.min() >= report.min_slope_um_per_V - 1e-6
    assert report.invertible == (not report.failures)


def test_play_operators_use_twice_the_threshold_as_band():
    # a single play operator of threshold 0.2 with a negative weight: after a reversal the slope is
    # a2 until the input has moved 0.4, then a2 + b
    model = HysteresisModel(0.0, 1.0, (0.2,), (-1.5,), operator="play", voltage_range_V=(-1, 1), name="p")
    report = check_invertibility(model)
    assert not report.invertible
    assert report.min_slope_um_per_V == pytest.approx(-0.5)
    failures = {f[0]: f[1:3] for f in report.failures}
    assert failures["ascending"] == pytest.approx((-1 + 0.4, 1.0))
    assert failures["descending"] == pytest.approx((-1.0, 1 - 0.4))
    narrow = model.with_parameters(voltage_range_V=(-0.19, 0.19))
    assert check_invertibility(narrow).invertible
