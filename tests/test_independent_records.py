"""Tests of the independent record generator itself (``independent_records.py``).

They check the generator against definitions, not the package against the
generator: the block-wise operators against the paper's sample recursion and
the classical play operator, the plants' invertibility on dense branches,
the size and shape of every effect, the noise, the inputs and that a seed
always gives the same records.
"""
import math

import numpy as np
import pytest

import independent_records as ir


def _timeline(signal, n_samples=2000, sample_rate_hz=1000.0, low_V=0.0):
    """A record grid from rest at ``low_V`` with a given input shape."""
    return ir._Timeline(sample_rate_hz, n_samples, 20, signal, np.array([-1.0, 0.0]),
                        np.array([low_V, low_V]), low_V)


def _plant(rng=None):
    return ir.make_plant(rng or np.random.default_rng(11), (0.0, 150.0))


# ------------------------------------------------------------------ operators

def _piecewise_input(rng, n=600):
    parts = [np.linspace(0, 1, 40), np.full(6, 1.0), np.linspace(1, 0.3, 25), rng.uniform(0, 1, n),
             np.repeat(rng.uniform(0, 1, 30), 4), np.linspace(0.2, 0.2, 5)]
    return np.concatenate(parts) * 100.0


@pytest.mark.parametrize("seed", range(5))
def test_block_operators_equal_the_sample_recursion(seed):
    rng = np.random.default_rng(seed)
    u = _piecewise_input(rng)
    r = np.sort(rng.uniform(0, 100, 23))
    state = rng.uniform(0, 60, r.size)
    reference = ir.osp_recursion(u, r, state)
    blocks, final = ir.osp_operators(u, r, state)
    np.testing.assert_array_equal(blocks, reference)
    np.testing.assert_array_equal(final, reference[-1])
    keep = np.sort(rng.choice(u.size, 50, replace=False))
    some, _ = ir.osp_operators(u, r, state, keep=keep)
    np.testing.assert_array_equal(some, reference[keep])
    b = rng.normal(size=r.size)
    weighted, _ = ir.osp_operators(u, r, state, keep=keep, weights=b)
    np.testing.assert_allclose(weighted, reference[keep] @ b, rtol=1e-12, atol=1e-9)


def test_one_sided_play_is_a_shifted_classical_play_operator():
    # F_r^osp[u] = F_{r/2}^play[u] - r/2, with the play state started at r/2
    rng = np.random.default_rng(3)
    u = _piecewise_input(rng)
    r = np.sort(rng.uniform(0, 100, 9))
    w = r / 2
    play = np.empty((u.size, r.size))
    for k, uk in enumerate(u):
        w = np.maximum(uk - r / 2, np.minimum(uk + r / 2, w))
        play[k] = w
    osp, _ = ir.osp_operators(u, r)
    np.testing.assert_allclose(osp, play - r / 2, atol=1e-12)


def test_operators_cross_check_the_package_model():
    from pysim.core import HysteresisModel

    plant = ir.make_plant(np.random.default_rng(5), (-30.0, 120.0))
    model = HysteresisModel(plant.a1_um_per_V3, plant.a2_um_per_V, tuple(plant.thresholds_V),
                            tuple(plant.weights_um_per_V), input_offset_V=-30.0, voltage_range_V=(-30.0, 120.0))
    v = -30.0 + _piecewise_input(np.random.default_rng(8)) * 1.5
    np.testing.assert_allclose(plant.hysteresis_um(v + 30.0), model.simulate(v), atol=1e-9)


# ------------------------------------------------------------------ plants

@pytest.mark.parametrize("seed", range(12))
def test_plants_are_strictly_increasing_on_dense_branches(seed):
    plant = ir.make_plant(np.random.default_rng(seed))
    slopes = ir.branch_slopes(plant)
    exact = ir._exact_min_slope(plant)
    assert exact > 0 and slopes.min() > 0
    # the dense branches never go below the exact smallest slope of the model
    assert slopes.min() >= exact * (1 - 1e-9)
    n = plant.thresholds_V.size
    assert 15 <= n <= 40
    grid = np.arange(10) / 10 * plant.span_V
    assert not np.allclose(plant.thresholds_V[:10], grid)


def test_dense_branches_reach_the_smallest_slope():
    # with a falling cubic the worst slope sits just after a reversal at the top
    rng = np.random.default_rng(0)
    plant = _plant(rng)
    plant = ir.Plant(plant.voltage_range_V, -abs(plant.a2_um_per_V) * 0.25 / plant.span_V ** 2,
                     plant.a2_um_per_V, plant.thresholds_V, np.abs(plant.weights_um_per_V), 0.0)
    slopes = ir.branch_slopes(plant, 2000)
    assert slopes.min() == pytest.approx(ir._exact_min_slope(plant), rel=0.02)


# ------------------------------------------------------------------ linear stages

def test_first_order_lowpass_is_exact_on_a_ramp():
    dt, tau = 1e-3, 0.02
    t = np.arange(500) * dt
    y = ir.first_order_lowpass(t, dt, tau)
    np.testing.assert_allclose(y, t - tau * (1 - np.exp(-t / tau)), atol=1e-12)


def test_second_order_lowpass_has_unit_gain_and_the_analytic_step():
    dt, fn, zeta = 1e-4, 50.0, 0.3
    x = np.concatenate(([0.0], np.ones(4000)))
    y = ir.second_order_lowpass(x, dt, fn, zeta)
    wn, wd = 2 * math.pi * fn, 2 * math.pi * fn * math.sqrt(1 - zeta ** 2)
    t = np.arange(4000) * dt
    # the input is a ramp over the first step: compare after it has passed, loosely
    step = 1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2) * np.sin(wd * t))
    assert np.max(np.abs(y[1:] - step)) < 0.02
    assert y[-1] == pytest.approx(1.0, abs=1e-4)


def test_rate_limit_bounds_the_rate_and_catches_up():
    dt = 1e-4
    x = np.concatenate((np.zeros(10), np.full(1000, 100.0), np.zeros(1000)))
    y = ir.rate_limit(x, dt, 20e3)          # 20 V/ms
    assert np.max(np.abs(np.diff(y))) <= 20e3 * dt * (1 + 1e-12)
    assert y[1009] == 100.0 and y[-1] == 0.0
    assert np.argmax(y >= 100.0) == 10 + 49      # 100 V at 2 V per step


# ------------------------------------------------------------------ effects

def _sine(frequency_hz, lo=0.0, hi=150.0):
    return lambda t: lo + 0.5 * (hi - lo) * (1 - np.cos(2 * math.pi * frequency_hz * t))


def test_whole_sample_delay_is_a_shift_of_the_record():
    plant = _plant()
    timeline = _timeline(_sine(3.0))
    plain = ir._respond(plant, {"name": "none"}, timeline)
    delayed = ir._respond(plant, {"name": "delay", "delay_samples": 3.0}, timeline)
    np.testing.assert_allclose(delayed[3:], plain[:-3], atol=1e-9)
    half = ir._respond(plant, {"name": "delay", "delay_samples": 2.5}, timeline)
    # half way between the samples 2 and 3 before, up to the curvature between samples
    slack = np.max(np.abs(np.diff(plain, 2)))
    assert np.all(np.minimum(plain[:-3], plain[1:-2]) - slack <= half[3:])
    assert np.all(half[3:] <= np.maximum(plain[:-3], plain[1:-2]) + slack)
    assert np.max(np.abs(half[3:] - plain[:-3])) > 5 * slack


def test_dynamics_keep_the_static_response():
    plant = _plant()
    timeline = _timeline(lambda t: np.where(t < 0.2, 0.0, 90.0), n_samples=3000)
    plain = ir._respond(plant, {"name": "none"}, timeline)
    for effect in ({"name": "rate_dependence", "order": 1, "time_constant_s": 0.01},
                   {"name": "rate_dependence", "order": 2, "natural_frequency_hz": 40.0, "damping_ratio": 0.2},
                   {"name": "rate_dependent_hysteresis", "time_constant_s": 0.01},
                   {"name": "slew_limit", "slew_rate_V_per_ms": 5.0}):
        y = ir._respond(plant, effect, timeline)
        assert y[-1] == pytest.approx(plain[-1], rel=1e-6), effect
        assert np.max(np.abs(y - plain)) > 1.0, effect


def test_creep_step_response_is_monotone_and_log_like():
    plant = _plant()
    timeline = _timeline(lambda t: np.where(t < 0.1, 0.0, 100.0), n_samples=20000, sample_rate_hz=2000.0)
    plain = ir._respond(plant, {"name": "none"}, timeline)
    taus = np.geomspace(0.005, 5.0, 7).tolist()
    for driven_by in ("input", "hysteresis"):
        effect = {"name": "creep", "driven_by": driven_by, "time_constants_s": taus, "weights": [0.01] * 7}
        creep = ir._respond(plant, effect, timeline) - plain
        after = creep[int(0.1 * 2000) + 2:]
        assert np.all(np.diff(after) >= -1e-12) and after[-1] > 0
        # equal weights per decade of time constant: similar growth per decade of time
        t = (np.arange(after.size) + 2) / 2000.0
        grow = [np.interp(b, t, after) - np.interp(a, t, after) for a, b in ((0.01, 0.1), (0.1, 1.0))]
        assert 0.4 < grow[0] / grow[1] < 2.5


def test_rate_dependent_hysteresis_widens_loops_with_frequency():
    plant = _plant()
    effect = {"name": "rate_dependent_hysteresis", "time_constant_s": 0.002}
    widths = []
    for f in (1.0, 20.0):
        timeline = _timeline(_sine(f), n_samples=4000, sample_rate_hz=4000.0)
        v = timeline.record_voltage_V()
        y = ir._respond(plant, effect, timeline)
        late = slice(2000, None)
        near = np.abs(v[late] - 75.0) < 2.0
        widths.append(np.ptp(y[late][near]))
    assert widths[1] > 1.5 * widths[0]


def test_drift_shapes_are_smooth_and_start_at_zero():
    t = np.linspace(0, 10, 1001)
    for shape in ("settling", "linear", "bend"):
        d = ir._drift_um({"amplitude_um": 2.0, "time_scale_s": 5.0, "shape": shape}, t)
        assert d[0] == 0.0 and np.max(np.abs(np.diff(d, 2))) < 1e-3


def test_rich_basis_absorbs_the_plain_plant_but_not_a_lag():
    plant = _plant()
    timeline = _timeline(_sine(4.0), n_samples=3000)
    residual = ir.rich_basis_residual(plant, timeline)
    plain = ir._respond(plant, {"name": "none"}, timeline)
    assert ir._rms(residual(plain)) < 1e-8 * np.ptp(plain)
    second = ir._respond(plant, {"name": "rate_dependence", "order": 2, "natural_frequency_hz": 30.0,
                                 "damping_ratio": 0.1}, timeline)
    # part of a lag looks like hysteresis, but not all of it
    assert ir._rms(residual(second - plain)) > 0.05 * ir._rms(second - plain) > 1e-4 * np.ptp(plain)


# ------------------------------------------------------------------ records

SEEDS = range(8)     # one of each effect, "none" twice


@pytest.fixture(scope="module")
def pairs():
    return {seed: ir.make_pair(seed) for seed in SEEDS}


def test_seeds_cycle_through_every_effect(pairs):
    assert {p.truth.effect for p in pairs.values()} == set(ir.EFFECTS)


def test_same_seed_same_records_and_other_options_keep_the_plant(pairs):
    again = ir.make_pair(3)
    np.testing.assert_array_equal(again.train.displacement_um, pairs[3].train.displacement_um)
    np.testing.assert_array_equal(again.validation.voltage_V, pairs[3].validation.voltage_V)
    assert again.truth.as_dict() == pairs[3].truth.as_dict()
    shorter = ir.make_pair(3, n_samples=5000, validation_samples=5000)
    assert shorter.truth.plant == pairs[3].truth.plant
    assert not np.array_equal(pairs[2].train.voltage_V[:5000], pairs[3].train.voltage_V[:5000])


@pytest.mark.parametrize("seed", SEEDS)
def test_records_look_like_the_rig(pairs, seed):
    p = pairs[seed]
    lo, hi = p.truth.plant["voltage_range_V"]
    for record in (p.train, p.validation, p.test):
        assert 5000 <= record.voltage_V.size <= 30000
        assert record.voltage_V.min() >= lo - 1e-9 and record.voltage_V.max() <= hi + 1e-9
        # the input covers the range
        assert np.ptp(record.voltage_V) > 0.97 * (hi - lo)
        assert 0 < record.settle_samples <= record.voltage_V.size // 4
    assert p.validation.voltage_V.size <= p.train.voltage_V.size
    assert p.train.sample_rate_hz == p.validation.sample_rate_hz
    assert p.train.sample_rate_hz in ir.SAMPLE_RATES_HZ
    assert len({p.train.input_kind, p.validation.input_kind, p.test.input_kind}) == 3
    assert p.test.start == "rest" and p.test.sample_rate_hz == p.train.sample_rate_hz
    assert p.validation.start == "rest" and p.validation.voltage_V[0] == pytest.approx(lo)
    assert 0.001 <= p.truth.noise_fraction_of_range <= 0.005


@pytest.mark.parametrize("seed", SEEDS)
def test_noise_is_what_the_truth_says(pairs, seed):
    p = pairs[seed]
    for record in (p.train, p.validation, p.test):
        error = record.displacement_um - record.clean_um
        lsb = p.truth.quantisation_step_um
        expected = math.sqrt(p.truth.noise_sigma_um ** 2 + lsb ** 2 / 12)
        assert np.std(error) == pytest.approx(expected, rel=0.05)
        assert abs(np.mean(error)) < 5 * expected / math.sqrt(error.size)
        if lsb:
            np.testing.assert_allclose(record.displacement_um / lsb, np.round(record.displacement_um / lsb),
                                       atol=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_effect_size_is_the_calibrated_one(pairs, seed):
    p = pairs[seed]
    truth = p.truth
    if truth.effect == "none":
        assert truth.effect_rms_um == 0 and not truth.detectable
        assert truth.validation_effect_rms_um == 0.0
        return
    assert truth.validation_effect_rms_um > 0
    assert truth.effect_rms_um >= truth.unabsorbable_rms_um > 0
    assert truth.unabsorbable_to_noise == pytest.approx(truth.unabsorbable_rms_um / truth.noise_sigma_um)
    lo, hi = ir.TARGET_RATIO_RANGE
    assert lo <= truth.target_to_noise <= hi
    assert truth.detectable == (truth.unabsorbable_to_noise >= ir.DETECTABLE_RATIO)
    # recompute the effect from the truth's parameters with the same plant
    plant = ir.plant_from_dict(truth.plant)
    clean = p.train.clean_um - plant.sensor_offset_um
    v = p.train.voltage_V - plant.voltage_range_V[0]
    if truth.effect != "delay" and p.train.start == "rest":
        # from rest the plain plant is the record's own voltage through the operators
        plain = plant.hysteresis_um(v)
        assert ir._rms(clean - plain) == pytest.approx(truth.effect_rms_um, rel=0.05)


def test_starts_from_rest_and_from_an_unknown_history():
    rest = ir.make_pair(4, start="rest", n_samples=5000, validation_samples=5000)
    assert rest.train.voltage_V[0] == pytest.approx(rest.truth.plant["voltage_range_V"][0])
    for seed in range(40):
        history = ir.make_pair(seed, "none", start="history", n_samples=5000, validation_samples=5000)
        lo, hi = history.truth.plant["voltage_range_V"]
        if history.train.voltage_V[0] > lo + 0.3 * (hi - lo):
            break
    assert "history_turning_points_V" in history.train.input_parameters
    plant = ir.plant_from_dict(history.truth.plant)
    from_rest = plant.hysteresis_um(history.train.voltage_V - plant.voltage_range_V[0])
    clean = history.train.clean_um - plant.sensor_offset_um
    # the history leaves a state that a start from rest does not reproduce ...
    assert np.max(np.abs(clean - from_rest)) > 10 * history.truth.noise_sigma_um
    # ... until the input has reached the bottom of the range, which wipes the operators
    bottom = np.flatnonzero(history.train.voltage_V <= plant.voltage_range_V[0] + 1e-9)
    if bottom.size:
        np.testing.assert_allclose(clean[bottom[0]:], from_rest[bottom[0]:], atol=1e-9)


def test_normalised_inputs_touch_their_extremes_once_or_twice():
    rng = np.random.default_rng(2)
    for kind in ("multisine", "band_noise"):
        for _ in range(4):
            signal, _ = ir._make_signal(rng, kind, 5.0, 2000.0, 0.0, 100.0)
            v = signal(np.arange(10000) / 2000.0)
            for extreme in (v.min(), v.max()):
                near = np.abs(v - extreme) < 0.002 * 100.0
                runs = np.count_nonzero(np.diff(near.astype(int)) == 1) + int(near[0])
                assert 1 <= runs <= 2, kind


@pytest.mark.parametrize("seed", [1, 3, 5, 6, 7])
def test_respond_reproduces_the_validation_record(pairs, seed):
    p = pairs[seed]
    again = ir.respond(p, p.validation.voltage_V)
    # the same actuator: only the continuous input between samples differs
    # (a step faster than a sample period is spread over one: a few % of σ with dynamics)
    assert ir._rms(again.clean_um - p.validation.clean_um) < 0.2 * p.truth.noise_sigma_um
    np.testing.assert_allclose(np.std(again.displacement_um - again.clean_um),
                               math.sqrt(p.truth.noise_sigma_um ** 2 + p.truth.quantisation_step_um ** 2 / 12),
                               rtol=0.05)
