"""The bank of Bouc-Wen operators (pysim.diagnosis.bouc_wen), against a second implementation
(the differential equation integrated in small input steps), the properties of a rate-independent
operator, and a Bouc-Wen actuator of the outside-class generator (its own implementation) fitted
by the general model on two records."""
import numpy as np
import pytest

from pysim.diagnosis.bouc_wen import RATES, bouc_wen_bank, forgotten_from
from pysim.diagnosis.preisach import NOISE_FRACTION, fit_both_records


def _integrated(v, lo, hi, substeps=400):
    """dh = dx - β|dx|h - γ dx|h| by explicit steps of 1/substeps of every sample's increment."""
    rate_with, rate_against = np.repeat(RATES, RATES.size), np.tile(RATES, RATES.size)
    beta, gamma = (rate_with + rate_against) / 2, (rate_with - rate_against) / 2
    x = (np.asarray(v, dtype=float) - lo) / (hi - lo)
    h, out = np.zeros(beta.size), np.zeros((x.size, beta.size))
    for k in range(1, x.size):
        d = (x[k] - x[k - 1]) / substeps
        for _ in range(substeps):
            h = h + d - beta * abs(d) * h - gamma * d * np.abs(h)
        out[k] = h
    return out


@pytest.fixture(scope="module")
def wandering_input():
    rng = np.random.default_rng(3)
    v = np.cumsum(rng.normal(0.0, 2.0, 1500))
    v[400:520] = v[400]                        # a hold
    v[900:] = v[900] + 40 * np.sin(np.arange(600) / 15.0)
    return v


def test_the_bank_solves_the_equation_exactly_on_every_run(wandering_input):
    v = wandering_input
    lo, hi = float(v.min()), float(v.max())
    expected = _integrated(v, lo, hi)
    got = bouc_wen_bank(v, (lo, hi))
    # the explicit steps' own error is of the order of the step: 1/400 of a sample's increment
    assert np.max(np.abs(got - expected)) < 2e-3 * np.max(np.abs(expected))


def test_the_bank_is_rate_independent_and_stands_still_in_holds(wandering_input):
    v = wandering_input
    lo, hi = float(v.min()), float(v.max())
    once = bouc_wen_bank(v, (lo, hi))
    slow = bouc_wen_bank(np.interp(np.arange(7 * (v.size - 1) + 1) / 7, np.arange(v.size), v), (lo, hi))
    np.testing.assert_allclose(slow[::7], once, atol=1e-12)
    assert np.all(once[401:520] == once[400])


def test_its_state_before_the_record_is_forgotten_where_it_says(wandering_input):
    v = wandering_input
    lo, hi = float(v.min()), float(v.max())
    history = np.r_[np.linspace(v[0], lo, 50), np.linspace(lo, hi, 80), np.linspace(hi, v[0], 30)]
    after_history = bouc_wen_bank(np.r_[history, v], (lo, hi))[history.size:]
    from_rest = bouc_wen_bank(v, (lo, hi))
    first = forgotten_from(v, (lo, hi))
    assert 0 < first < v.size
    gap = np.abs(after_history - from_rest)
    assert np.all(gap[first:] <= np.exp(-6.0) * gap[0].max() + 1e-12)
    assert gap[: first // 4].max() > np.exp(-6.0) * gap[0].max()


def test_the_general_model_fits_a_bouc_wen_actuator_on_two_inputs_to_their_noise():
    """The outside-class generator's Bouc-Wen hysteresis (its own integration) on a sine sweep and
    band-limited noise: minor loops that neither close nor wipe out, which the Preisach part alone
    left several noise variances above the noise on records like these."""
    import outside_class_records
    import scipy.signal

    rng = np.random.default_rng(5)
    fs, lo, hi, span_um = 2000.0, 0.0, 120.0, 20.0
    t = np.arange(8000) / fs
    v1 = 60 + 58 * np.sin(2 * np.pi * (1.0 * t + 3.0 * t**2)) * (0.6 + 0.4 * np.cos(np.pi * t / 4) ** 2)
    b, a = scipy.signal.butter(2, 20.0 / (fs / 2))
    x = scipy.signal.filtfilt(b, a, rng.standard_normal(t.size))
    v2 = lo + (x - x.min()) / np.ptp(x) * (hi - lo)

    def actuator(v):
        return span_um * outside_class_records.bouc_wen(v, lo, hi, 3.0, 0.9) / 1.3

    noise_um = 0.002 * span_um
    fit = fit_both_records(v1, actuator(v1) + rng.normal(0, noise_um, t.size), 1 / fs,
                           v2, actuator(v2) + rng.normal(0, noise_um, t.size), 1 / fs)
    assert max(fit.mse_sigma2) < 1.0 + NOISE_FRACTION, fit.mse_sigma2
