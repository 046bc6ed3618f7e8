"""Forward model, operators and inverses against analytic truths and the paper's properties."""
import numpy as np
import pytest
from conftest import paper_input, paper_model, random_piecewise_monotone

from pysim.core.model import (
    HysteresisModel,
    InverseCompensator,
    NotInvertibleError,
    analytic_inverse,
    eq13_thresholds,
    invert,
)


def oracle_operator(u, r, w0, kind):
    """Eq. 2 / eq. 4 written out sample by sample (test oracle, independent of the C kernel)."""
    out, w = [], w0
    for x in u:
        upper = x + r if kind == "play" else x
        w = max(x - r, min(upper, w))
        out.append(w)
    return np.array(out)


@pytest.mark.parametrize("kind", ["osp", "play"])
def test_operators_match_the_defining_recursion(rng, kind):
    u = random_piecewise_monotone(rng, lo=-0.3, hi=1.0)
    r = np.array([0.0, 0.05, 0.2, 0.45, 0.9])
    model = HysteresisModel(0.0, 0.0, tuple(r), tuple(np.ones_like(r)), operator=kind,
                            voltage_range_V=(-1, 1), name="ops")
    w0 = rng.uniform(-0.2, 0.2, r.size)
    _, ops = model.simulate(u, w0, return_operators=True)
    for i in range(r.size):
        np.testing.assert_array_equal(ops[:, i], oracle_operator(u, r[i], w0[i], kind))


def test_osp_on_a_rising_ramp_is_max_of_v_minus_r_and_zero():
    v = np.linspace(0, 1, 101)
    r = eq13_thresholds(10, 1.0)
    model = HysteresisModel(0.0, 0.0, tuple(r), tuple(np.ones_like(r)), voltage_range_V=(0, 1), name="m")
    _, ops = model.simulate(v, return_operators=True)
    np.testing.assert_allclose(ops, np.maximum(v[:, None] - r[None, :], 0.0), atol=1e-15)


def test_osp_is_a_shifted_classical_play_of_half_threshold(rng):
    """NOTES: F^osp_r[v] = F^play_{r/2}[v] - r/2 (with matching initial states)."""
    v = random_piecewise_monotone(rng)
    r = np.array([0.1, 0.3, 0.8])
    osp = HysteresisModel(0.0, 0.0, tuple(r), (1.0, 1.0, 1.0), voltage_range_V=(0, 1), name="o")
    play = HysteresisModel(0.0, 0.0, tuple(r / 2), (1.0, 1.0, 1.0), operator="play",
                           voltage_range_V=(0, 1), name="p")
    _, w_osp = osp.simulate(v, return_operators=True)
    _, w_play = play.simulate(v, r / 2, return_operators=True)
    np.testing.assert_allclose(w_osp, w_play - r / 2, atol=1e-15)


def test_mpi_output_is_cubic_plus_linear_plus_weighted_operators(rng):
    model = paper_model()
    v = paper_input(2001)
    y, ops = model.simulate(v, return_operators=True)
    expected = model.a1 * v**3 + model.a2 * v + ops @ model.weights
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-14)


def test_pieces_with_carried_state_equal_one_piece(rng):
    model = paper_model().with_parameters(input_offset_V=-0.1, output_offset_um=3.0)
    v = random_piecewise_monotone(rng, n_segments=80)
    whole, final = model.simulate(v, return_state=True)
    state, parts = None, []
    for chunk in np.array_split(v, 7):
        y, state = model.simulate(chunk, state, return_state=True)
        parts.append(y)
    np.testing.assert_array_equal(np.concatenate(parts), whole)
    np.testing.assert_array_equal(state, final)


def test_rate_independence_only_the_order_of_values_matters():
    """Sampling a monotone segment more finely does not change the output at its ends."""
    model = paper_model()
    extrema = np.array([0.0, 0.9, 0.2, 0.7, 0.35, 1.0, 0.1])
    coarse = extrema
    fine = np.concatenate([np.linspace(a, b, 257)[:-1] for a, b in zip(extrema[:-1], extrema[1:])]
                          + [extrema[-1:]])
    y_coarse = model.simulate(coarse)
    y_fine = model.simulate(fine)
    np.testing.assert_allclose(y_fine[::256], y_coarse, atol=1e-14)


def test_wiping_out_property_fig9():
    """Fig. 9: extrema (0, v1, v2, v3, v4, v5) with v3 < v1, v4 < v2, v5 > v1: once v5 passes v1 the
    memory equals that of a plain rise 0 -> v5, and the rise from v4 passes through P1."""
    model = paper_model()
    v1, v2, v3, v4, v5 = 0.7, 0.3, 0.55, 0.15, 0.95
    ramp = lambda a, b: np.linspace(a, b, 201)[1:]  # noqa: E731
    history = np.concatenate([[0.0], ramp(0, v1), ramp(v1, v2), ramp(v2, v3), ramp(v3, v4), ramp(v4, v5)])
    y, state = model.simulate(history, return_state=True)
    _, plain_state = model.simulate(np.concatenate([[0.0], ramp(0, v5)]), return_state=True)
    np.testing.assert_allclose(state, plain_state, atol=1e-15)
    y1 = model.simulate(np.concatenate([[0.0], ramp(0, v1)]))[-1]
    rise = np.concatenate([[0.0], ramp(0, v1), ramp(v1, v2), ramp(v2, v3), ramp(v3, v4), ramp(v4, v1)])
    assert model.simulate(rise)[-1] == pytest.approx(y1, abs=1e-14)
    # memory P2 (v2) is wiped by v4 < v2: the descent v3 -> v4 passes through P2's output at v2
    y2 = model.simulate(np.concatenate([[0.0], ramp(0, v1), ramp(v1, v2)]))[-1]
    through = np.concatenate([[0.0], ramp(0, v1), ramp(v1, v2), ramp(v2, v3), ramp(v3, v2)])
    assert model.simulate(through)[-1] == pytest.approx(y2, abs=1e-14)


@pytest.mark.parametrize("kind", ["osp", "play"])
def test_congruency_property_fig10(kind):
    """Fig. 10: minor loops over the same input range after different histories are congruent:
    they differ by a constant vertical shift."""
    model = paper_model(operator=kind)
    lo, hi = 0.35, 0.65
    ramp = lambda a, b: np.linspace(a, b, 301)[1:]  # noqa: E731
    loop = np.concatenate([ramp(lo, hi), ramp(hi, lo)] * 2)
    ascending = np.concatenate([[0.0], ramp(0, hi), ramp(hi, lo)])          # loop 1: from below
    descending = np.concatenate([[0.0], ramp(0, 1.0), ramp(1.0, lo)])      # loop 2: from the top
    _, s1 = model.simulate(ascending, return_state=True)
    _, s2 = model.simulate(descending, return_state=True)
    y1 = model.simulate(loop, s1)
    y2 = model.simulate(loop, s2)
    shift = y2 - y1
    assert np.ptp(shift) < 1e-12
    assert abs(shift[0]) > 1e-3  # the loops really are apart


def test_cpi_analytic_inverse_round_trip_paper_input():
    model = paper_model(a1=0.0)
    v = paper_input()
    y = model.simulate(v)
    np.testing.assert_allclose(analytic_inverse(model).simulate(y), v, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_cpi_analytic_inverse_round_trip_random(seed):
    rng = np.random.default_rng(seed)
    model = paper_model(a1=0.0)
    v = random_piecewise_monotone(rng)
    np.testing.assert_allclose(analytic_inverse(model).simulate(model.simulate(v)), v, rtol=0, atol=1e-12)


def test_analytic_inverse_parameters_match_eq12():
    model = paper_model(a1=0.0, n=4)
    inv = analytic_inverse(model)
    r, b, a2 = model.thresholds, model.weights, model.a2
    # hand-written eq. 12 for j = 3 (1-based)
    r_hat_3 = a2 * r[2] + b[0] * (r[2] - r[0]) + b[1] * (r[2] - r[1])
    b_hat_3 = -b[2] / ((a2 + b[0] + b[1]) * (a2 + b[0] + b[1] + b[2]))
    assert inv.thresholds[2] == pytest.approx(r_hat_3, rel=1e-15)
    assert inv.weights[2] == pytest.approx(b_hat_3, rel=1e-15)
    assert inv.a2 == pytest.approx(1 / a2)


@pytest.mark.parametrize("kind", ["osp", "play"])
def test_exact_inverse_round_trip_mpi(kind):
    model = paper_model(operator=kind)
    assert model.check_invertibility().invertible
    rng = np.random.default_rng(7)
    for v in (paper_input(), random_piecewise_monotone(rng)):
        y = model.simulate(v)
        np.testing.assert_allclose(invert(model, y), v, rtol=0, atol=1e-12)


def test_exact_inverse_with_offsets_and_physical_units():
    from pysim.specs.default_mpi import MODEL

    model = MODEL.with_parameters(input_offset_V=-20.0, output_offset_um=-1.7,
                                  voltage_range_V=(-20.0, 130.0))
    v = 150 * paper_input() - 20.0
    np.testing.assert_allclose(invert(model, model.simulate(v)), v, rtol=0, atol=1e-12 * 150)


def test_exact_inverse_in_pieces_equals_one_piece(rng):
    model = paper_model()
    y = model.simulate(random_piecewise_monotone(rng))
    comp = InverseCompensator(model)
    parts = np.concatenate([comp(chunk) for chunk in np.array_split(y, 5)])
    np.testing.assert_array_equal(parts, invert(model, y))


def test_previous_sample_loop_leaves_an_error_the_exact_solution_does_not():
    model = paper_model()
    v = paper_input(2001)
    y = model.simulate(v)
    exact_error = np.max(np.abs(model.simulate(invert(model, y)) - y))
    loop_error = np.max(np.abs(model.simulate(invert(model, y, method="previous_sample")) - y))
    assert exact_error < 1e-13
    assert loop_error > 1e-4
    # with a1 = 0 the loop has nothing to lag behind and is exact as well
    cpi = paper_model(a1=0.0)
    yc = cpi.simulate(v)
    assert np.max(np.abs(cpi.simulate(invert(cpi, yc, method="previous_sample")) - yc)) < 1e-12


def test_inverse_saturates_at_the_voltage_range():
    model = paper_model()
    top = model.simulate([0.0, 1.0])[-1]
    comp = InverseCompensator(model)
    v = comp(np.array([0.5 * top, 2 * top, -1.0]))
    assert v[1] == 1.0 and v[2] == 0.0
    assert comp.saturated_samples == 2


def test_inverse_of_the_papers_non_invertible_example_is_refused():
    model = paper_model(a1=-1.0)
    with pytest.raises(NotInvertibleError, match=r"0\.952"):
        InverseCompensator(model)


def test_invalid_models_are_refused_with_a_reason():
    with pytest.raises(ValueError, match="ascending"):
        HysteresisModel(0, 1, (0.5, 0.1), (1, 1))
    with pytest.raises(ValueError, match="2 thresholds but 1 weights"):
        HysteresisModel(0, 1, (0.0, 0.1), (1,))
    with pytest.raises(ValueError, match="not finite"):
        HysteresisModel(float("nan"), 1, (0.0,), (1,))
    with pytest.raises(ValueError, match="operator"):
        HysteresisModel(0, 1, (0.0,), (1,), operator="stop")


def test_default_model_is_the_scaled_paper_example():
    from pysim.specs.default_mpi import MODEL

    norm = paper_model()
    v = paper_input(5001)
    np.testing.assert_allclose(MODEL.simulate(150 * v), 20 * norm.simulate(v), rtol=1e-13, atol=1e-12)
    assert MODEL.check_invertibility().invertible
    assert MODEL.simulate([0, 150])[-1] == pytest.approx(74.59, abs=0.01)


@pytest.mark.parametrize("n", [1, 10, 33, 70])
def test_record_loop_and_single_sample_call_give_the_same_bits(rng, n):
    """The FMUs call hyst_output (blocked), Python records hyst_simulate_scaled without a scale (the in-place
    loop of hyst_simulate): same bits."""
    import ctypes

    from pysim.core import kernel as _kernel

    lib = _kernel.library()
    lib.hyst_output.argtypes = [ctypes.POINTER(_kernel.HystModel), ctypes.c_double,
                                ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double)]
    lib.hyst_output.restype = ctypes.c_double
    r = np.sort(rng.uniform(0, 0.9, n))
    model = HysteresisModel(-0.7, 2.1, tuple(r), tuple(rng.normal(0.2, 0.3, n)), operator="osp",
                            input_offset_V=0.05, output_offset_um=0.3, voltage_range_V=(0, 1), name="m")
    v = random_piecewise_monotone(rng)
    expected = model.simulate(v)
    c_model = model._c_model()
    state = np.zeros(n)
    scratch = np.zeros(n)
    got = np.empty_like(v)
    for k, x in enumerate(v):
        got[k] = lib.hyst_output(ctypes.byref(c_model), x, _kernel.as_pointer(state), _kernel.as_pointer(scratch))
        state[:] = scratch
    np.testing.assert_array_equal(got, expected)
