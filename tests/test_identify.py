"""Identification: exact recovery, noise level, invertibility constraints, global optimality."""
import numpy as np
import pytest
from conftest import paper_model
from scipy.optimize import minimize

from pysim.core.model import HysteresisModel
from pysim.identification.identify import IdentificationError, identify, regressors


def exciting_input(n=40001, lo=0.0, hi=150.0):
    """A full first cycle over the range, then a decaying one (major and minor loops)."""
    t = np.linspace(0, 20, n)
    amplitude = np.where(t < 1, 1.0, np.exp(-0.1 * (t - 1)))
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    return mid - half * np.cos(np.pi * t) * amplitude


def scaled_paper_model(a1=-0.8, operator="osp"):
    base = paper_model(a1=a1, operator=operator)
    r = np.array(base.thresholds_V) * 150.0
    b = np.array(base.weights_um_per_V) * 20.0 / 150.0
    a2 = 2.42 * 20 / 150 + b[0]
    b[0] = 0.0   # the r = 0 operator is the same column as a2 (see pysim.identification.identify)
    return HysteresisModel(a1 * 20 / 150**3, a2, tuple(r), tuple(b), operator=operator,
                           voltage_range_V=(0.0, 150.0), name="truth")


@pytest.mark.parametrize("kind", ["mpi", "cpi"])
def test_noise_free_data_recovers_the_parameters(kind):
    truth = scaled_paper_model(a1=-0.8 if kind == "mpi" else 0.0)
    v = exciting_input()
    result = identify(v, truth.simulate(v), model=kind)
    m = result.model
    assert not result.constraints_active
    assert m.a2 == pytest.approx(truth.a2, rel=1e-6)
    if kind == "mpi":
        assert m.a1 == pytest.approx(truth.a1, rel=1e-6)
    np.testing.assert_allclose(m.weights[1:], truth.weights[1:], rtol=1e-6)
    np.testing.assert_allclose(m.thresholds, truth.thresholds, rtol=1e-12)
    assert abs(m.output_offset_um) < 1e-6 * 75
    assert result.errors["max_error_pct"] < 1e-8


def test_noise_free_recovery_with_play_operators_bipolar_input_and_offset():
    base = scaled_paper_model(operator="play")
    truth = base.with_parameters(input_offset_V=-75.0, output_offset_um=-1.68, voltage_range_V=(-75.0, 75.0))
    v = exciting_input(lo=-75.0, hi=75.0)
    m = identify(v, truth.simulate(v), operator="play").model
    assert m.input_offset_V == -75.0
    assert m.a1 == pytest.approx(truth.a1, rel=1e-6)
    np.testing.assert_allclose(m.weights[1:], truth.weights[1:], rtol=1e-6)
    assert m.output_offset_um == pytest.approx(-1.68, rel=1e-6)


def test_with_noise_the_residual_is_the_noise():
    truth = scaled_paper_model()
    v = exciting_input()
    rng = np.random.default_rng(3)
    sigma = 0.05  # µm
    y = truth.simulate(v) + rng.normal(0, sigma, v.size)
    result = identify(v, y)
    span = np.ptp(y[result.fit_slice])
    assert result.errors["rms_error_pct"] == pytest.approx(100 * sigma / span, rel=0.03)
    # parameters close in the sense that matters: the noise-free outputs agree far below the noise
    clean_error = np.max(np.abs(result.model.simulate(v) - truth.simulate(v) - result.model.output_offset_um
                                + truth.output_offset_um))
    assert clean_error < sigma


def test_cpi_fits_asymmetric_data_worse_than_mpi():
    truth = scaled_paper_model()
    v = exciting_input()
    y = truth.simulate(v)
    assert identify(v, y, model="cpi").errors["rms_error_pct"] > 10 * identify(v, y).errors["rms_error_pct"]


def test_constraints_make_a_non_invertible_optimum_invertible_and_stay_optimal():
    truth = scaled_paper_model(a1=-1.0)          # the paper's own numbers: not invertible
    assert not truth.check_invertibility().invertible
    v = exciting_input(8001)
    y = truth.simulate(v)
    result = identify(v, y, warmup=0)
    assert result.constraints_active
    report = result.model.check_invertibility()
    assert report.invertible
    margin = 0.01 * np.ptp(y) / 150.0
    assert report.min_slope_um_per_V == pytest.approx(margin, rel=1e-6)

    # independent optimiser on the same objective and constraints must not do better
    A, cols = regressors(v, result.model.thresholds, "osp", 0.0, True)
    keep = [0, 1] + [c for c in cols if c >= 0] + [A.shape[1] - 1]
    A = A[:, keep]
    from pysim.identification.identify import _invertibility_rows
    G, h = _invertibility_rows(result.model.with_parameters(a1=0.0), A.shape[1], True, cols, margin)
    scale = np.linalg.norm(A, axis=0)
    As, Gs = A / scale, G / scale

    def objective(x):
        e = As @ x - y
        return e @ e

    theta = np.array([result.model.a1, result.model.a2, *result.model.weights[1:],
                      result.model.output_offset_um]) * scale
    start = np.linalg.lstsq(As, y, rcond=None)[0]
    other = minimize(objective, start, jac=lambda x: 2 * As.T @ (As @ x - y), method="SLSQP",
                     constraints=[{"type": "ineq", "fun": lambda x: Gs @ x - h, "jac": lambda x: Gs}],
                     options={"maxiter": 500, "ftol": 1e-14})
    assert objective(theta) <= other.fun * (1 + 1e-9)
    assert result.objective == pytest.approx(objective(theta), rel=1e-9)


def test_too_few_samples_and_constant_input_are_refused():
    v = exciting_input(10)
    with pytest.raises(IdentificationError, match="parameters"):
        identify(v, v * 0.5, warmup=0)
    with pytest.raises(IdentificationError, match="constant"):
        identify(np.ones(100), np.arange(100.0))


def test_auto_warmup_starts_once_both_ends_were_visited():
    truth = scaled_paper_model()
    v = exciting_input()
    rng = np.random.default_rng(0)
    # unknown history: a random initial operator state
    y = truth.simulate(v, rng.uniform(0, 60, truth.n_operators))
    result = identify(v, y)
    assert result.warmup_samples == int(np.argmax(v >= 150 - 0.45 * 15))
    assert result.errors["max_error_pct"] < 1e-8


def test_one_sided_and_classical_play_fits_are_the_same_model_class():
    """F^osp_r = F^play_{r/2} - r/2 (NOTES): with eq. 13 thresholds halved for play, both fits span the
    same functions, so they reach the same optimum on any data."""
    truth = scaled_paper_model()
    v = exciting_input(8001)
    y = truth.simulate(v) + np.random.default_rng(5).normal(0, 0.2, v.size)
    osp = identify(v, y, operator="osp")
    play = identify(v, y, operator="play")
    assert play.objective == pytest.approx(osp.objective, rel=1e-9)
    fit = osp.fit_slice  # before it the two start from different (unknown-history) states
    np.testing.assert_allclose(play.prediction_um[fit], osp.prediction_um[fit], atol=1e-9)
