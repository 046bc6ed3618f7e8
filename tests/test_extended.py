"""Extended model (MPI + output stages): the C stages against independent
implementations (scipy filters, numpy shifts and polynomials), state carrying,
validation, spec round trip, and identification through a linear stage."""
import ctypes

import numpy as np
import pytest
import scipy.signal
from conftest import continuous_response, paper_input, paper_model, random_piecewise_monotone

from pysim.core.extended import (
    ExtendedModel,
    ExtendedState,
    OutputStages,
    StageSpec,
    _library,
    first_order_section,
    second_order_section,
    tustin_creep_mode,
    tustin_displacement_creep,
)
from pysim.core.model import HysteresisModel
from pysim.core.spec import load_spec, write_spec
from pysim.identification.identify import identify

T = 1e-3


def _extended(model: HysteresisModel, **stages) -> ExtendedModel:
    return ExtendedModel(model, StageSpec(**stages))


def _section_tf(section):
    b0, b1, b2, a1, a2 = section
    return np.array([b0, b1, b2]), np.array([1.0, a1, a2])


# ----------------------------------------------------------- discretisation

def _run_section(section, x):
    b, a = _section_tf(section)
    return scipy.signal.lfilter(b, a, x, zi=scipy.signal.lfilter_zi(b, a) * x[0])[0]


@pytest.mark.parametrize("tau", [0.1e-3, 0.5e-3, 3e-3, 0.2])
def test_first_order_section_is_the_lag_of_a_piecewise_linear_input(tau, rng):
    x = np.cumsum(rng.normal(size=4000))
    expected = continuous_response([1.0], [tau, 1.0], x, T)
    np.testing.assert_allclose(_run_section(first_order_section(tau, T), x), expected, atol=1e-9 * np.ptp(x))
    b, a = _section_tf(first_order_section(tau, T))
    assert b.sum() / a.sum() == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize("tau", [0.05e-3, 0.3e-3, 2e-3])
def test_first_order_section_follows_a_ramp_as_the_closed_form(tau):
    """From rest, x(t) = t gives y(t) = t − τ (1 − exp(−t/τ)) at every sample."""
    t = np.arange(200) * T
    y = _run_section(first_order_section(tau, T), t)
    np.testing.assert_allclose(y, t + tau * np.expm1(-t / tau), atol=1e-15, rtol=1e-12)


@pytest.mark.parametrize("tau", [0.05e-3, 0.2e-3, 0.45e-3])
def test_a_lag_shorter_than_half_a_sample_does_not_ring(tau):
    """The bilinear transform's pole is negative below τ = T/2 (the step response
    alternates); the lag's own step response rises monotonically."""
    b0, b1, _, a1, _ = first_order_section(tau, T)
    assert 0.0 < -a1 < 1.0 and b0 > 0.0 and b1 >= 0.0
    step = _run_section(first_order_section(tau, T), np.r_[0.0, np.ones(20)])
    assert np.all(np.diff(step) >= 0.0) and step[-1] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("f, zeta", [(5.0, 0.05), (50.0, 0.3), (300.0, 1.5), (450.0, 0.2)])
def test_second_order_section_is_the_resonance_of_a_piecewise_linear_input(f, zeta, rng):
    w = 2 * np.pi * f
    x = np.cumsum(rng.normal(size=4000))
    expected = continuous_response([w * w], [1.0, 2 * zeta * w, w * w], x, T)
    got = _run_section(second_order_section(f, zeta, T), x)
    np.testing.assert_allclose(got, expected, atol=1e-8 * np.ptp(x))
    b, a = _section_tf(second_order_section(f, zeta, T))
    assert b.sum() / a.sum() == pytest.approx(1.0, abs=1e-12)
    # the poles are the continuous ones mapped by exp(sT): no frequency warping near Nyquist
    poles = np.roots(a)
    continuous = np.roots([1.0, 2 * zeta * w, w * w])
    np.testing.assert_allclose(np.sort_complex(poles), np.sort_complex(np.exp(continuous * T)), atol=1e-12)


def test_tustin_creep_mode_matches_scipy_bilinear():
    alpha, beta = tustin_creep_mode(0.05, T)
    b, a = scipy.signal.bilinear([1.0], [0.05, 1.0], fs=1.0 / T)
    np.testing.assert_allclose([beta, beta], b, rtol=1e-13)
    assert -a[1] == pytest.approx(alpha, rel=1e-13)


# ---------------------------------------------------------------- C stages

def _parallel_displacement_creep(taus, shares, x):
    """1 - Σ s_j + Σ s_j/(τ_j s + 1) as written, each mode by scipy's bilinear transform, from rest at 0."""
    y = (1.0 - sum(shares)) * x
    for tau, share in zip(taus, shares):
        b, a = scipy.signal.bilinear([1.0], [tau, 1.0], fs=1 / T)
        y = y + share * scipy.signal.lfilter(b, a, x)
    return y


@pytest.mark.parametrize("taus, shares", [
    ((0.01,), (0.2,)),
    ((0.003, 0.03, 0.3), (0.05, 0.1, 0.02)),
    (tuple(3e-3 * np.geomspace(1.0, 3e4, 10)), (0.03,) * 10),        # poles crowding at z = 1
    ((0.002, 0.002, 2.0), (0.1, 0.2, 0.6)),                          # equal τ, most of it creeping
])
def test_displacement_creep_cascade_is_the_parallel_form(rng, taus, shares):
    sections = tustin_displacement_creep(taus, shares, T)
    assert all(s[2] == 0.0 and s[4] == 0.0 for s in sections)        # first-order sections
    assert [round((b0 + b1) / (1 + a1), 12) for b0, b1, _, a1, _ in sections] == [1.0] * len(sections)
    x = rng.normal(size=30000)
    y, _ = OutputStages(sections).run(x, state=np.zeros(2 * len(sections)))
    expected = _parallel_displacement_creep(taus, shares, x)
    assert np.max(np.abs(y - expected)) <= 1e-9 * np.max(np.abs(expected))


def test_displacement_creep_step_is_the_creep_law():
    """After a unit step the output jumps to 1 - Σ s_j and creeps to 1 along
    1 - Σ s_j exp(-t/τ_j) (the continuous law; Tustin is within O((T/τ)²) of it)."""
    taus, shares = (0.02, 0.2, 2.0), (0.05, 0.05, 0.1)
    stages = StageSpec(sample_period_s=T, displacement_creep_time_constants_s=taus,
                       displacement_creep_shares=shares)
    n = 8000
    y, _ = stages.runner.run(np.r_[0.0, np.ones(n)], np.zeros(n + 1), np.arange(n + 1.0))
    t = (np.arange(1, n + 1) - 0.5) * T          # Tustin's step is centred half a sample early
    law = 1.0 - sum(s * np.exp(-t / tau) for tau, s in zip(taus, shares))
    assert np.max(np.abs(y[1:] - law)) < 5e-4
    assert np.all(np.diff(y[1:]) > 0) and stages.static_gain() == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("shares, message", [
    ((0.5, 0.6), "sum to less than 1"),
    ((-0.1, 0.2), ">= 0"),
    ((0.1,), "2 displacement creep time constants but 1"),
])
def test_invalid_displacement_creep_is_refused(shares, message):
    with pytest.raises(ValueError, match=message):
        StageSpec(sample_period_s=T, displacement_creep_time_constants_s=(0.01, 0.1),
                  displacement_creep_shares=shares)


def test_displacement_creep_spec_round_trip(tmp_path):
    model = _extended(paper_model(voltage_range=(0.0, 1.0)), sample_period_s=T,
                      displacement_creep_time_constants_s=(0.01, 0.3), displacement_creep_shares=(0.05, 0.1))
    loaded = load_spec(write_spec(model, tmp_path / "creeping.py"))
    assert loaded == model
    v = paper_input(3001, 6.0)
    np.testing.assert_array_equal(loaded.simulate(v), model.simulate(v))
    h = model.hysteresis.simulate(v)
    np.testing.assert_allclose(model.simulate(v), _parallel_displacement_creep(
        (0.01, 0.3), (0.05, 0.1), h - h[0]) + h[0], rtol=0, atol=1e-12 * np.ptp(h))


def test_sections_match_lfilter_from_rest(rng):
    x = np.cumsum(rng.normal(size=3000)) + 5.0
    sections = [second_order_section(40.0, 0.2, T), first_order_section(2e-3, T)]
    y, _ = OutputStages(sections).run(x)
    expected = x
    for section in sections:
        b, a = _section_tf(section)
        expected, _ = scipy.signal.lfilter(b, a, expected, zi=scipy.signal.lfilter_zi(b, a) * expected[0])
    np.testing.assert_allclose(y, expected, rtol=0, atol=1e-10 * np.max(np.abs(x)))


@pytest.mark.parametrize("delay", [1.0, 4.0, 2.25, 0.6])
def test_delay_is_a_shift_with_linear_interpolation(rng, delay):
    x = rng.normal(size=500)
    y, _ = OutputStages(delay_samples=delay).run(x)
    whole, frac = int(np.floor(delay)), delay - np.floor(delay)
    padded = np.concatenate((np.full(whole + 1, x[0]), x))   # rest: x[0] held since forever
    k = np.arange(x.size) + whole + 1
    expected = (1 - frac) * padded[k - whole] + frac * padded[k - whole - 1]
    np.testing.assert_array_equal(y, expected) if frac == 0 else np.testing.assert_allclose(y, expected,
                                                                                          atol=1e-15)


def test_creep_and_drift_match_independent_formulas(rng):
    u = np.repeat(rng.uniform(0, 100, 30), 50)
    taus, weights = [0.01, 0.1, 1.0], [0.02, -0.01, 0.05]
    drift = [0.3, -0.02]
    modes = [tustin_creep_mode(tau, T) for tau in taus]
    stages = OutputStages(creep_alpha=[m[0] for m in modes], creep_beta=[m[1] for m in modes],
                          creep_weights=weights, drift=drift)
    t = np.arange(u.size) * T
    h = np.sin(np.arange(u.size) / 30.0)
    y, _ = stages.run(h, u, t)
    expected = h + np.polyval([drift[1], drift[0], 0.0], t)
    for tau, w in zip(taus, weights):
        b, a = scipy.signal.bilinear([1.0], [tau, 1.0], fs=1.0 / T)
        mode, _ = scipy.signal.lfilter(b, a, u, zi=scipy.signal.lfilter_zi(b, a) * u[0])
        expected += w * mode
    np.testing.assert_allclose(y, expected, atol=1e-10)


def test_drift_holds_its_value_from_its_span_on():
    """Past ``drift_span_s`` the polynomial is evaluated at the span: continuous, then constant."""
    drift, span = [0.3, -0.02], 0.0123
    t = np.arange(40) * T
    h = np.cos(np.arange(40) / 7.0)
    y, _ = OutputStages(drift=drift, drift_span_s=span).run(h, None, t)
    expected = h + np.polyval([drift[1], drift[0], 0.0], np.minimum(t, span))
    np.testing.assert_allclose(y, expected, atol=1e-15)
    unbounded, _ = OutputStages(drift=drift).run(h, None, t)
    np.testing.assert_allclose(unbounded, h + np.polyval([drift[1], drift[0], 0.0], t), atol=1e-15)


def _full_stages():
    modes = [tustin_creep_mode(tau, T) for tau in (0.02, 0.5)]
    return OutputStages([second_order_section(30.0, 0.3, T)], 3.5, [m[0] for m in modes],
                        [m[1] for m in modes], [0.01, 0.03], [0.1, 0.02])


def test_output_without_commit_and_with_separate_state(rng):
    stages = _full_stages()
    lib, s = _library(), ctypes.byref(stages._struct)
    state = stages.rest_state(1.0, 2.0)
    before = state.copy()
    p = lambda a: a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))  # noqa: E731
    tentative = lib.ostage_output(s, p(state), 3.0, 4.0, 0.5, None)
    np.testing.assert_array_equal(state, before)          # NULL: nothing committed
    other = np.zeros_like(state)
    separate = lib.ostage_output(s, p(state), 3.0, 4.0, 0.5, p(other))
    np.testing.assert_array_equal(state, before)          # source untouched
    in_place = lib.ostage_output(s, p(state), 3.0, 4.0, 0.5, p(state))
    assert tentative == separate == in_place
    np.testing.assert_array_equal(other, state)


def test_state_layout_size():
    stages = _full_stages()
    # 2 (one section) + 1 + (3 + 1) delay line + 1 + 2 creep
    assert stages.state_size == 2 + 5 + 3


@pytest.mark.parametrize("kwargs, message", [
    ({"delay_samples": -1.0}, "delay"),
    ({"sections": [[1.0, 0.0, 0.0, -1.0, 0.0]]}, "pole at z = 1"),
    ({"sections": [[np.nan, 0.0, 0.0, 0.0, 0.0]]}, "NaN or infinite"),
    ({"creep_alpha": [1.0], "creep_beta": [0.0], "creep_weights": [1.0]}, "pole at z = 1"),
    ({"creep_alpha": [0.5], "creep_beta": [0.1], "creep_weights": []}, "same length"),
])
def test_invalid_stages_are_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        OutputStages(**kwargs)


def test_c_check_refuses_bad_struct_without_crashing():
    lib = _library()
    from pysim.core.extended import OutputStagesStruct
    bad = OutputStagesStruct(2, None, 0, 0.0, 0, None, None, None, 0, None)   # 2 sections, no array
    assert lib.ostage_check(ctypes.byref(bad)) == 2
    assert lib.ostage_state_size(ctypes.byref(bad)) == 0
    assert lib.ostage_check(None) != 0
    y = np.zeros(3)
    h = np.ones(3)
    p = lambda a: a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))  # noqa: E731
    lib.ostage_run(ctypes.byref(bad), 3, p(h), None, None, None, p(y))
    np.testing.assert_array_equal(y, h)                    # passes the input through, no crash
    fraction = OutputStagesStruct(0, None, 1, 1.0, 0, None, None, None, 0, None)
    assert b"fraction" in lib.ostage_message(lib.ostage_check(ctypes.byref(fraction)))
    for span in (-1.0, float("nan"), float("inf")):
        bad_span = OutputStagesStruct(0, None, 0, 0.0, 0, None, None, None, 0, None, span)
        assert b"drift span" in lib.ostage_message(lib.ostage_check(ctypes.byref(bad_span)))


# ------------------------------------------------------------------ model

def _model():
    return _extended(paper_model(voltage_range=(0.0, 1.0)), sample_period_s=T, resonance_hz=20.0,
                     damping_ratio=0.2, delay_samples=2.0, creep_time_constants_s=(0.05, 0.5),
                     creep_weights_um_per_V=(0.1, 0.2), drift_coefficients=(0.01, -0.001), drift_span_s=0.75)


def test_model_is_hysteresis_followed_by_independent_stages():
    model = _model()
    v = paper_input(4001, 4.0)
    y = model.simulate(v)
    h = model.hysteresis.simulate(v)
    b, a = _section_tf(second_order_section(20.0, 0.2, T))
    g, _ = scipy.signal.lfilter(b, a, h, zi=scipy.signal.lfilter_zi(b, a) * h[0])
    expected = np.concatenate((np.full(2, g[0]), g[:-2]))
    t = np.minimum(np.arange(v.size) * T, 0.75)           # the drift held from its span on
    expected += 0.01 * t - 0.001 * t**2
    for tau, w in ((0.05, 0.1), (0.5, 0.2)):
        bb, aa = scipy.signal.bilinear([1.0], [tau, 1.0], fs=1.0 / T)
        expected += w * scipy.signal.lfilter(bb, aa, v, zi=scipy.signal.lfilter_zi(bb, aa) * v[0])[0]
    np.testing.assert_allclose(y, expected, atol=1e-12)


def test_simulation_in_pieces_equals_one_piece():
    model = _model()
    v = paper_input(3001, 3.0)
    whole = model.simulate(v)
    state, parts = None, []
    for piece in np.array_split(v, [1, 700, 701, 2500]):
        y, state = model.simulate(piece, state, return_state=True)
        parts.append(y)
    assert isinstance(state, ExtendedState) and state.samples == v.size
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_plain_extended_model_equals_hysteresis_model():
    base = paper_model()
    model = _extended(base)
    v = paper_input(2001, 5.0)
    np.testing.assert_array_equal(model.simulate(v), base.simulate(v))
    assert not model.stages.present
    assert model.hysteresis == base
    assert model.major_loop_gain() == pytest.approx(base.major_loop_gain(), rel=1e-15)


def test_static_gain_includes_creep():
    model = _model()
    assert model.stages.static_gain() == pytest.approx(1.0, abs=1e-12)
    assert model.major_loop_gain() == pytest.approx(model.hysteresis.major_loop_gain() + 0.3, rel=1e-12)


@pytest.mark.parametrize("changes, message", [
    ({"delay_samples": 2.0, "sample_period_s": 0.0}, "sample_period_s must be > 0"),
    ({"delay_samples": -1.0, "sample_period_s": T}, "delay_samples"),
    ({"creep_time_constants_s": (0.1,), "creep_weights_um_per_V": (), "sample_period_s": T}, "creep"),
    ({"resonance_hz": 10.0, "damping_ratio": 0.0, "sample_period_s": T}, "damping_ratio"),
    ({"drift_coefficients": (float("nan"),), "sample_period_s": T}, "finite"),
    ({"drift_coefficients": (0.1,), "drift_span_s": -1.0, "sample_period_s": T}, "drift_span_s"),
])
def test_invalid_extended_model_is_refused(changes, message):
    with pytest.raises(ValueError, match=message):
        _extended(paper_model(), **changes)


def test_spec_round_trip(tmp_path):
    model = _model()
    path = write_spec(model, tmp_path / "extended_spec.py")
    loaded = load_spec(path)
    assert isinstance(loaded, ExtendedModel) and loaded == model
    v = paper_input(1001, 2.0)
    np.testing.assert_array_equal(loaded.simulate(v), model.simulate(v))


def test_stage_parameters_are_what_the_c_stages_run():
    model = _model()
    p = model.stages.coefficients()
    assert p["delay_whole"] == 2 and p["delay_fraction"] == 0.0
    rebuilt = OutputStages(p["sections"], p["delay_whole"] + p["delay_fraction"], p["creep_alpha"],
                           p["creep_beta"], p["creep_weights"], p["drift"], p["drift_span_s"])
    v = paper_input(1001, 2.0)
    h = model.hysteresis.simulate(v)
    y, _ = rebuilt.run(h, v - model.hysteresis.input_offset_V, np.arange(v.size) * T)
    np.testing.assert_array_equal(y, model.simulate(v))


# ------------------------------------------ identification through a stage

@pytest.mark.parametrize("stages", [
    OutputStages(delay_samples=3.0),
    OutputStages([second_order_section(15.0, 0.25, T)]),
])
def test_identify_through_a_linear_stage_recovers_parameters(stages, rng):
    truth = paper_model(voltage_range=(0.0, 1.0))
    v = np.concatenate(([0.0, 1.0], random_piecewise_monotone(rng, 200, points_per_segment=(5, 80))))
    y, _ = stages.run(truth.simulate(v))
    result = identify(v, y, column_transform=stages.apply_to_columns, min_slope_fraction=-1)
    np.testing.assert_allclose(result.model.a1, truth.a1, rtol=1e-6)
    np.testing.assert_allclose(result.model.a2 + result.model.weights[0], truth.a2 + truth.weights[0],
                               rtol=1e-6)
    np.testing.assert_allclose(result.model.weights[1:], truth.weights[1:], rtol=1e-6)
    np.testing.assert_allclose(result.prediction_um, y, atol=1e-9)


def test_identify_through_a_delay_ties_operators_that_only_the_delayed_samples_tell_apart():
    # a staircase that leaves its levels only on its last sample: that sample is the one place where
    # the top operators differ from the offset, and a delay of 3 samples moves it out of the record.
    # The fit through the delay ties them (reported as not identifiable) instead of refusing the family.
    truth = paper_model(voltage_range=(0.0, 1.0))
    levels = np.r_[np.linspace(0.1, 1.0, 5), np.linspace(1.0, 0.1, 5)[1:]]
    v = np.r_[np.repeat(levels, 30), 0.0]
    stages = OutputStages(delay_samples=3.0)
    y, _ = stages.run(truth.simulate(v))
    result = identify(v, y, column_transform=stages.apply_to_columns, min_slope_fraction=-1)
    assert result.not_identifiable_operators
    np.testing.assert_allclose(result.prediction_um, y, atol=1e-4 * np.ptp(y))
