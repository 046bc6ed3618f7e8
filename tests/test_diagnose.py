"""Diagnosis: the hidden-effect benchmark on seeded synthetic records, the
cross-validation, the second record, ambiguity and its excitation, the
residual statistics, and the command line.

The core test: ``pysim.testing.synthetic`` hides one effect (or none) in an MPI
plant's output; ``diagnose`` is not told which.  For every seed the named
cause must be the hidden one, ``none`` must never be called an effect, and
the extended model must cut the cross-validated RMS error by at least 50 % when
an effect is present.  The confusion matrix is printed into the test log (with
or without ``-s``) and recorded as a JUnit property.
"""
import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from pysim.core.extended import ExtendedModel
from pysim.core.invertibility import check_invertibility
from pysim.core.spec import load_spec
from pysim.diagnosis.candidates import EFFECTS as CATALOGUE
from pysim.diagnosis.diagnose import diagnose
from pysim.diagnosis.folds import input_period, split_record
from pysim.diagnosis.residuals import (
    cross_correlation,
    dominant_frequency,
    input_changes,
    level_noise_sigma,
    models_noise_sigma,
    noise_sigma,
    time_since_change,
)
from pysim.diagnosis.rules import CAUSES
from pysim.identification.data import MeasuredData, save_measured, shipped_dataset
from pysim.testing.synthetic import EFFECTS, make_case

SEEDS = range(60)
MIN_GAIN_PCT = 50.0


@pytest.fixture(scope="module")
def outcomes():
    """Hidden effect, named cause and gain for every seed (diagnosed once)."""
    table = {}
    for seed in SEEDS:
        case = make_case(seed)
        result = diagnose(case.voltage_V, case.displacement_um, case.sample_rate_hz)
        table[seed] = (case, result)
    return table


@pytest.mark.parametrize("seed", SEEDS)
def test_hidden_effect_is_named_and_removed(outcomes, seed):
    case, result = outcomes[seed]
    detail = (f"seed {seed}: hidden {case.effect} ({case.waveform}, SNR {case.snr:.1f}, {case.parameters}); "
              f"named {result.cause}: {result.why}")
    assert result.cause == case.effect, detail
    if case.effect == "none":
        assert result.causes == () and result.excitation is None
        assert result.gain_pct == 0.0 and result.extended.fit.cause == "baseline"
    else:
        assert case.effect in result.causes, detail
        assert result.gain_pct >= MIN_GAIN_PCT, detail
        # the extended model is the spec of the named effect: simulated from its state over the record
        # (an independent run of the C stages), it reproduces the fit's prediction
        model = result.extended.model
        assert isinstance(model, ExtendedModel) and model.stages.present
        np.testing.assert_allclose(model.simulate(result.voltage_V, result.extended.fit.state),
                                   result.extended.prediction_um, atol=1e-9)
        assert_admissible(result.extended.fit)


def assert_admissible(fit):
    """The physical admissibility of an extension, from its parameters."""
    stages = getattr(fit.model, "stages", None)
    if stages is not None:
        assert stages.delay_samples >= 0 and stages.lag_time_constant_s >= 0
        assert stages.static_gain() == pytest.approx(1.0, abs=1e-12)
        if stages.resonance_hz > 0:
            assert stages.damping_ratio > 0
    if fit.cause == "creep" and fit.parameters["driven_by"] == "displacement":
        shares = np.asarray(fit.parameters["shares"])
        assert np.all(shares >= 0) and shares.sum() <= 0.5 + 1e-12    # creep follows the jump, it is not most of it
        # a monotone creep: after a unit step of h the output jumps to 1 - Σ shares and rises to 1
        step, _ = stages.runner.run(np.r_[0.0, np.ones(20000)], np.zeros(20001), np.arange(20001.0))
        T, taus = stages.sample_period_s, np.asarray(fit.parameters["time_constants_s"])
        first_sample = np.sum(shares * T / (2 * taus + T))      # what the modes pick up in the step's sample
        assert 1 - shares.sum() - 1e-12 <= step[1] <= 1 - shares.sum() + first_sample + 1e-12
        assert np.all(np.diff(step[1:]) >= -1e-12) and step[-1] <= 1 + 1e-12
    elif fit.cause == "creep":
        weights = np.asarray(fit.parameters["weights_um_per_V"])
        tiny = 1e-9 * np.max(np.abs(weights))                       # the active-set solver's zeros
        assert np.all(weights >= -tiny) or np.all(weights <= tiny)  # no cancelling modes
        # the model's hysteresis is the response before creep moves: a step moves the actuator its way
        # at once, and creep only adds to it
        assert check_invertibility(fit.model.hysteresis).invertible
    assert np.isfinite(fit.result.condition_number)


def _matrix_text(counts: Counter) -> str:
    width = max(len(c) for c in CAUSES) + 2
    lines = ["confusion matrix (rows: hidden effect, columns: named cause)",
             " " * width + "".join(f"{c:>{width}}" for c in CAUSES)]
    for hidden in CAUSES:
        lines.append(f"{hidden:<{width}}" + "".join(f"{counts[(hidden, named)]:>{width}}" for named in CAUSES))
    return "\n".join(lines)


def test_confusion_matrix(outcomes, capsys, record_property):
    counts = Counter((case.effect, result.cause) for case, result in outcomes.values())
    gains = {effect: [r.gain_pct for c, r in outcomes.values() if c.effect == effect] for effect in EFFECTS}
    text = _matrix_text(counts) + "\n" + "\n".join(
        f"held-out RMS gain, {effect}: min {min(g):.1f} %, median {np.median(g):.1f} %"
        for effect, g in gains.items() if effect != "none" and g)
    with capsys.disabled():        # into the test log whether or not -s is given
        print("\n" + text)
    record_property("confusion_matrix", text)
    # every class is drawn often enough to mean something, and none is never called an effect
    per_effect = Counter(case.effect for case, _ in outcomes.values())
    assert all(per_effect[effect] >= 6 for effect in EFFECTS), per_effect
    assert sum(counts[("none", named)] for named in CAUSES if named != "none") == 0
    assert sum(n for (hidden, named), n in counts.items() if hidden == named) == len(SEEDS)


def test_synthetic_magnitudes_are_as_documented():
    for seed in range(15):
        case = make_case(seed)
        span = np.ptp(case.clean_um)
        if case.effect == "none":
            assert case.visible_rms_um == 0.0
        else:
            assert 4.0 <= case.snr <= 40.0
            assert case.visible_rms_um == pytest.approx(case.snr * case.noise_um, rel=1e-9)
        assert case.noise_um <= 0.01 * span
        assert np.std(case.displacement_um - case.clean_um) == pytest.approx(case.noise_um, rel=0.1)
    assert make_case(3).displacement_um.tobytes() == make_case(3).displacement_um.tobytes()


# --------------------------------------------------------------------- split

def test_periodic_input_is_split_on_whole_periods():
    n, period = 20000, 400.0
    v = 50 + 50 * np.sin(2 * np.pi * np.arange(n) / period)
    split = split_record(v, 0.65)
    assert split.period_samples == pytest.approx(period, rel=1e-3)
    cycles = (split.split - split.warmup) / period
    assert abs(cycles - round(cycles)) < 0.03
    assert abs(split.split - (split.warmup + 0.65 * (n - split.warmup))) <= period / 2 + 1


def test_aperiodic_input_is_split_at_the_fraction(rng):
    v = np.concatenate(([0.0, 100.0], 50 + 40 * np.tanh(np.cumsum(rng.normal(size=9998)) / 30)))
    split = split_record(v, 0.6)
    assert split.period_samples is None
    assert split.warmup == 0                      # nothing is left out: the initial state is estimated
    assert split.split == round(0.6 * v.size)


def test_a_record_that_reaches_its_extremes_late_is_not_refused():
    v = np.concatenate((np.linspace(20, 80, 9000), [0.0, 100.0], np.full(999, 50.0)))
    split = split_record(v)
    assert split.warmup == 0 and split.split > 0


def test_multisine_that_touches_its_extremes_once_late_is_diagnosed_without_a_false_alarm():
    """The issue's refusals: a multisine normalised to the range reaches both ends only near the end."""
    case = make_case(3, "none")
    rng = np.random.default_rng(4)
    n = 12000
    k = np.arange(n)
    s = sum(a * np.sin(2 * np.pi * c * k / n + p) for a, c, p in ((1, 2.7, 0.4), (0.7, 6.1, 2.0), (0.5, 13.3, 1.0)))
    v = case.plant.voltage_range_V[1] * (s - s.min()) / np.ptp(s)
    assert min(np.argmax(v), np.argmin(v)) > 0.3 * n
    state = rng.uniform(0.0, case.plant.voltage_range_V[1], case.plant.n_operators)   # an unknown history
    y = case.plant.simulate(v, state)
    y = y + rng.normal(0, 0.002 * np.ptp(y), n)
    result = diagnose(v, y, 2000.0)
    assert result.cause == "none" and result.causes == (), result.why
    assert result.split.warmup == 0 and result.start_excluded_samples < 0.05 * n


def test_input_period_of_a_sine_and_of_noise(rng):
    assert input_period(np.sin(2 * np.pi * np.arange(5000) / 123.4)) == pytest.approx(123.4, rel=2e-3)
    assert input_period(rng.normal(size=5000)) is None


# --------------------------------------------------------------- residuals

def test_noise_sigma_ignores_a_smooth_error(rng):
    t = np.linspace(0, 10, 20000)
    residual = 3.0 * np.sin(2 * np.pi * 0.5 * t) + rng.normal(scale=0.2, size=t.size)
    assert noise_sigma(residual) == pytest.approx(0.2, rel=0.05)
    assert noise_sigma(np.round(np.zeros(100), 3), quantum_um=0.012) == pytest.approx(0.012 / np.sqrt(12))


def _ar1(rng, phi, n, sigma=1.0):
    """AR(1) noise of coefficient ``phi`` and standard deviation ``sigma``, stationary from its first sample."""
    e = rng.normal(scale=sigma * np.sqrt(1.0 - phi**2), size=n)
    out = np.empty(n)
    out[0] = rng.normal(scale=sigma)
    for k in range(1, n):
        out[k] = phi * out[k - 1] + e[k]
    return out


@pytest.mark.parametrize("phi", [0.3, 0.5, 0.7, 0.8])
def test_level_noise_sigma_finds_the_variance_of_correlated_noise(rng, phi):
    # the first differences show only sqrt(1 - φ) of the σ of AR(1) noise; the level its differences
    # reach at long lags is the whole σ
    noise = _ar1(rng, phi, 20000, sigma=0.3)
    assert noise_sigma(noise) == pytest.approx(0.3 * np.sqrt(1.0 - phi), rel=0.08)
    assert level_noise_sigma(noise) == pytest.approx(0.3, rel=0.08)


@pytest.mark.parametrize("period", [20, 40, 100, 1000])
@pytest.mark.parametrize("amplitude", [0.1, 0.5, 2.0, 10.0])
def test_level_noise_sigma_keeps_the_white_noise_under_a_periodic_misfit(rng, period, amplitude):
    # white noise under a periodic misfit of any size and speed: the differences' rise is not AR(1)'s,
    # so the first differences' σ stands, to the bit
    t = np.arange(20000)
    residual = rng.normal(scale=0.2, size=t.size) + amplitude * 0.2 * np.sin(2 * np.pi * t / period) ** 3
    assert level_noise_sigma(residual) == noise_sigma(residual)


def test_the_noise_of_several_models_is_the_least_so_a_misfit_like_coloured_noise_does_not_raise_it(rng):
    # a misfit that follows a band-limited input's rate is itself coloured and may pass for AR(1)
    # noise in the residual of a model that misses it; the model that explains it leaves the white
    # noise alone, and of several models the least estimate is the record's noise
    n = 20000
    b, a = scipy.signal.butter(2, 0.3)
    rate = np.gradient(scipy.signal.lfilter(b, a, rng.normal(size=n)))
    noise = rng.normal(scale=1.0, size=n)
    y = np.cumsum(rate) + noise
    missing = noise + rate / np.std(rate)
    sigma, noise_free = models_noise_sigma([missing, noise], y)
    assert not noise_free
    assert sigma == pytest.approx(1.0, rel=0.05)
    assert sigma == min(level_noise_sigma(missing), level_noise_sigma(noise))


def test_correlated_noise_is_found_though_one_model_leaves_a_misfit_over_it(rng):
    # AR(1) noise is in every model's residual; a model that misses a slow effect leaves a residual
    # whose differences keep rising, which is no noise level: the model that explains it shows the level
    n = 20000
    noise = _ar1(rng, 0.7, n, sigma=0.5)
    slow = 3.0 * np.sin(2 * np.pi * np.arange(n) / 700.0)
    y = np.cumsum(rng.normal(size=n)) + noise
    assert level_noise_sigma(noise + slow) == noise_sigma(noise + slow)     # a misfit, not a level
    sigma, _ = models_noise_sigma([noise + slow, noise], y)
    assert sigma == pytest.approx(0.5, rel=0.08)
    # one residual with white noise decides that the record's noise is white
    white = rng.normal(scale=0.5, size=n)
    sigma, _ = models_noise_sigma([white + 0.3 * noise, white], y)
    assert sigma == noise_sigma(white)


def test_input_changes_finds_reversals_and_steps():
    v = np.concatenate((np.linspace(0, 10, 11), np.linspace(9, 2, 8), np.full(5, 2.0), np.full(5, 8.0)))
    index, direction = input_changes(v, 0.5)
    assert index.tolist() == [10, 23]            # top; bottom where the input leaves its hold
    assert direction.tolist() == [-1.0, 1.0]
    elapsed, sign = time_since_change(v, 0.1, 0.5)
    assert np.isnan(elapsed[:10]).all() and elapsed[12] == pytest.approx(0.2) and sign[12] == -1
    steps = np.repeat([0.0, 5.0, 6.0, 1.0], 10)
    index, direction = input_changes(steps, 0.2)
    found = dict(zip(index.tolist(), direction.tolist()))
    assert found[10] == 1.0 and found[30] == -1.0 and 20 not in found


def test_cross_correlation_finds_the_lag(rng):
    x = np.convolve(rng.normal(size=3000), np.ones(20) / 20, mode="same")
    lagged = np.concatenate((np.zeros(7), x[:-7]))
    lags, rho = cross_correlation(lagged, x, 30)
    assert lags[np.argmax(rho)] == 7 and rho.max() > 0.95


def test_dominant_frequency():
    t = np.arange(10000) / 2000.0
    assert dominant_frequency(1 + np.sin(2 * np.pi * 13.3 * t), 2000.0) == pytest.approx(13.3, rel=5e-3)


# ------------------------------------------------------------ command line

def _write_case(tmp_path, seed) -> Path:
    case = make_case(seed)
    return save_measured(MeasuredData(case.time_s, case.voltage_V, case.displacement_um, "synthetic"),
                         tmp_path / f"case{seed}.csv")


def _pysim(*args):
    return subprocess.run([sys.executable, "-m", "pysim.cli.main", "diagnose", *map(str, args)],
                          capture_output=True, text=True)


def test_cli_json_report_and_spec(tmp_path):
    seed = next(s for s in SEEDS if make_case(s).effect == "delay")
    data = _write_case(tmp_path, seed)
    report, spec = tmp_path / "report", tmp_path / "delayed_plant.py"
    run = _pysim(data, "--json", "--report", report, "--out", spec)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert set(out) >= {"cause", "evidence", "baseline", "extended", "gain_pct"}
    assert out["cause"] == "delay"
    assert out["gain_pct"] == pytest.approx(100 * (1 - out["extended"]["rms_pct"] / out["baseline"]["rms_pct"]))
    assert set(out["evidence"]["candidates"]) == set(CATALOGUE)
    assert out["causes"][0] == "delay"
    names = {p.name for p in report.iterdir()}
    assert {"summary.md", "diagnosis.json", "overview.png", "spectrum.png", "cross_correlation.png",
            "residual_vs_rate.png", "residual_vs_time_since_change.png", "candidates.png", "loops.png"} <= names
    assert all((report / n).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for n in names if n.endswith(".png"))
    summary = (report / "summary.md").read_text(encoding="utf-8")
    if len(out["causes"]) > 1:       # a set: the headline names it and the model delivered
        assert "**Named set: " + ", ".join(f"`{c}`" for c in out["causes"]) in summary
        assert "the model delivered is `delay`'s" in summary
    else:
        assert "**Cause named: `delay`.**" in summary
    model = load_spec(spec)
    assert isinstance(model, ExtendedModel) and model.name == "delayed_plant"
    assert model.stages.delay_samples == pytest.approx(make_case(seed).parameters["delay_samples"], abs=0.05)


def test_cli_validate_scores_every_model_on_the_second_record(tmp_path):
    seed = next(s for s in SEEDS if make_case(s).effect == "delay")
    case = make_case(seed)
    data = _write_case(tmp_path, seed)
    # a second record of the same plant and delay, another input (a slow ramp up and down, then steps)
    n = 6000
    lo, hi = case.plant.voltage_range_V
    v2 = np.concatenate((np.linspace(lo, hi, n // 3), np.linspace(hi, lo, n // 3),
                         np.repeat(np.linspace(lo + 0.2 * (hi - lo), hi - 0.1 * (hi - lo), 8), n // 24)))
    d = int(case.parameters["delay_samples"])
    h = case.plant.simulate(v2)
    y2 = np.concatenate((np.full(d, h[0]), h[:-d])) + np.random.default_rng(1).normal(0, case.noise_um, v2.size)
    other = save_measured(MeasuredData(np.arange(v2.size) / case.sample_rate_hz, v2, y2, "second"),
                          tmp_path / "second.csv")
    run = _pysim(data, "--validate", other, "--json")
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    table = out["evidence"]["validation"]["table"]
    assert set(table) == {"baseline", "richer", *CATALOGUE}
    assert out["evidence"]["validation"]["cause"] == "delay" == out["cause"]
    assert table["delay"]["rms_pct"] < table["baseline"]["rms_pct"]
    text = _pysim(data, "--validate", other)
    assert text.returncode == 0 and "second record" in text.stdout


def test_cli_excite_writes_a_voltage_record_in_range(tmp_path):
    out = tmp_path / "excitation.csv"
    run = subprocess.run([sys.executable, "-m", "pysim.cli.main", "excite", "--out", str(out), "--range", "0",
                          "120", "--sample-rate", "2000", "--causes", "delay,rate_dependence", "--samples", "8000"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert out.read_text().startswith("time_s,voltage_V\n") and table.shape == (8000, 2)
    np.testing.assert_allclose(np.diff(table[:, 0]), 1 / 2000.0)
    assert table[:, 1].min() >= 0.0 and table[:, 1].max() <= 120.0
    bad = subprocess.run([sys.executable, "-m", "pysim.cli.main", "excite", "--out", str(tmp_path / "x.csv"),
                          "--range", "0", "120", "--sample-rate", "2000", "--causes", "gremlins"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "gremlins" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.csv").exists()


def test_cli_text_on_shipped_data():
    run = _pysim(shipped_dataset("discrete_backlash"))
    assert run.returncode == 0, run.stderr
    assert "cause" in run.stdout and "gain" in run.stdout


@pytest.mark.parametrize("args, message", [
    (["missing.csv"], "missing.csv"),
    (["{data}", "--train-fraction", "0.99"], "--train-fraction"),
    (["{data}", "--out", "{tmp}/no/such/folder/spec.py"], "does not exist"),
    (["{data}", "--name", "not an identifier"], "C identifier"),
    (["{data}", "--warmup", "soon"], "--warmup"),
])
def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path, args, message):
    data = _write_case(tmp_path, 0)
    before = set(tmp_path.rglob("*"))
    run = _pysim(*[a.format(data=data, tmp=tmp_path) for a in args])
    assert run.returncode == 2
    assert message in run.stderr and len(run.stderr.strip().splitlines()) == 1
    assert set(tmp_path.rglob("*")) == before


def test_cli_a_falling_displacement_is_refused_and_flipped_on_request(tmp_path):
    case = make_case(0)
    rising = _write_case(tmp_path, 0)
    falling = save_measured(MeasuredData(case.time_s, case.voltage_V, -case.displacement_um, "falling"),
                            tmp_path / "falling.csv")
    refused = _pysim(rising, "--validate", falling, "--report", tmp_path / "report")
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1
    assert "falling.csv: the displacement falls as the voltage rises" in refused.stderr
    assert "--flip-displacement" in refused.stderr and not (tmp_path / "report").exists()
    plain, flipped = _pysim(rising, "--json"), _pysim(falling, "--json", "--flip-displacement")
    assert plain.returncode == 0 and flipped.returncode == 0, flipped.stderr
    assert "falling.csv: displacement_um negated (--flip-displacement)" in flipped.stderr
    a, b = json.loads(plain.stdout), json.loads(flipped.stdout)
    assert (a["cause"], a["baseline"], a["extended"]) == (b["cause"], b["baseline"], b["extended"])


def test_cli_constant_record_is_a_clear_error(tmp_path):
    n = 500
    data = save_measured(MeasuredData(np.arange(n) * 1e-3, np.full(n, 5.0), np.zeros(n), "flat"),
                         tmp_path / "flat.csv")
    run = _pysim(data, "--report", tmp_path / "report")
    assert run.returncode == 2 and "flat.csv" in run.stderr
    assert not (tmp_path / "report").exists()
