"""Stage discretisation and filtering against closed-form responses and python-control."""
import math

import control
import numpy as np
import pytest
from pysim.specs.flexure_stage import DAMPING_RATIO, RESONANCE_HZ, STAGE

from pysim.cosim.errors import CoSimulationError
from pysim.cosim.stage import DiscreteStage, discretise, load_stage, slowest_time_constant_s

W1 = 2 * math.pi * RESONANCE_HZ
ZETA = DAMPING_RATIO


def test_flexure_stage_has_the_documented_static_gain_resonance_and_bandwidth():
    assert float(np.real(STAGE(0))) == pytest.approx(1.0, abs=1e-15)
    # |G| peaks at w1 sqrt(1 - 2 zeta^2) with 1 / (2 zeta sqrt(1 - zeta^2))
    w_peak = W1 * math.sqrt(1 - 2 * ZETA**2)
    assert abs(STAGE(1j * w_peak)) == pytest.approx(1 / (2 * ZETA * math.sqrt(1 - ZETA**2)), rel=1e-12)
    # -3 dB: (1 - x^2)^2 + (2 zeta x)^2 = 1/L^2 with L = 10^(-3/20)
    level = 10 ** (-3 / 20)
    c = 1 - 2 * ZETA**2
    x = math.sqrt(c + math.sqrt(c**2 - 1 + 1 / level**2))
    assert control.bandwidth(STAGE) / (2 * math.pi) == pytest.approx(x * RESONANCE_HZ, rel=1e-6)
    assert 900 < x * RESONANCE_HZ < 950  # the docstring's "about 926 Hz"


def test_tustin_prewarped_matches_the_continuous_response_exactly_at_that_frequency():
    for f, h in ((10.0, 1 / 640), (600.0, 1 / (64 * 600)), (1500.0, 1 / (64 * 1500))):
        stage = DiscreteStage(STAGE, h, "tustin", prewarp_hz=f)
        expected = complex(STAGE(2j * math.pi * f))
        assert complex(stage.frequency_response(f)) == pytest.approx(expected, rel=1e-12)
        # and the sections that actually filter agree with it
        from scipy.signal import sosfreqz
        _, response = sosfreqz(stage.sos, worN=[2 * math.pi * f * h])
        assert complex(response[0]) == pytest.approx(expected, rel=1e-10)


def test_zoh_step_response_equals_the_analytic_step_response_at_the_samples():
    h = 1e-4
    stage = DiscreteStage(STAGE, h, "zoh")
    y = stage.apply(np.ones(400))
    t = np.arange(400) * h
    wd = W1 * math.sqrt(1 - ZETA**2)
    exact = 1 - np.exp(-ZETA * W1 * t) * (np.cos(wd * t) + ZETA / math.sqrt(1 - ZETA**2) * np.sin(wd * t))
    np.testing.assert_allclose(y, exact, atol=1e-12)
    assert y[0] == 0.0  # ZOH of a strictly proper system keeps its one-sample delay


@pytest.mark.parametrize("method", ["tustin", "zoh", "foh"])
@pytest.mark.parametrize("system", [STAGE, control.ss(STAGE), control.tf([1.0, 3.0], [1.0, 2.0, 5.0, 4.0]),
                                    control.tf([2.0], [1.0]), control.tf([1.0, 2.0], [1.0, 3.0])],
                         ids=["tf2", "ss2", "tf3", "gain", "lead"])
def test_filtering_in_pieces_equals_python_control_simulation(rng, method, system):
    stage = DiscreteStage(system, 1e-3, method)
    u = rng.normal(size=1500)
    pieces = np.concatenate([stage.apply(u[:700]), stage.apply(u[700:701]), [stage.step(u[701])],
                             stage.apply(u[702:])])
    _, reference = control.forced_response(stage.system, U=u)
    np.testing.assert_allclose(pieces, reference, atol=1e-11)


def test_equilibrium_start_holds_a_constant_input():
    for method in ("tustin", "zoh"):
        stage = DiscreteStage(STAGE, 1e-4, method)
        stage.reset(initial_input=37.5)
        np.testing.assert_allclose(stage.apply(np.full(50, 37.5)), 37.5, rtol=1e-13)
    with pytest.raises(ValueError, match="pole at z = 1"):
        DiscreteStage(control.tf([1.0], [1.0, 0.0]), 1e-3).reset(initial_input=1.0)


def test_slowest_time_constant():
    assert slowest_time_constant_s(STAGE) == pytest.approx(1 / (ZETA * W1), rel=1e-12)
    discrete = discretise(STAGE, 1e-4, "zoh")  # ZOH maps poles exactly: z = exp(s h)
    assert slowest_time_constant_s(discrete) == pytest.approx(1 / (ZETA * W1), rel=1e-9)
    assert slowest_time_constant_s(control.tf([1.0], [1.0, 0.0])) == math.inf
    assert slowest_time_constant_s(control.tf([2.0], [1.0])) == 0.0


def test_discrete_stage_is_used_as_is_when_its_step_matches(rng):
    discrete = discretise(STAGE, 1e-4, "zoh")
    assert discretise(discrete, 1e-4) is discrete
    u = rng.normal(size=300)
    _, expected = control.forced_response(discrete, U=u)
    np.testing.assert_allclose(DiscreteStage(discrete, 1e-4, "foh").apply(u), expected, atol=1e-12)
    with pytest.raises(ValueError, match="dt = 0.0001"):
        DiscreteStage(discrete, 2e-4)


def test_bad_stages_are_refused():
    with pytest.raises(ValueError, match="one input and one output"):
        DiscreteStage(control.ss(np.eye(2) * -1, np.eye(2), np.eye(2), np.zeros((2, 2))), 1e-3)
    with pytest.raises(TypeError, match="python-control"):
        DiscreteStage([1, 2, 3], 1e-3)
    with pytest.raises(ValueError, match="method"):
        DiscreteStage(STAGE, 1e-3, "euler")
    with pytest.raises(ValueError, match="Nyquist"):
        DiscreteStage(STAGE, 1e-3, "tustin", prewarp_hz=600.0)
    with pytest.raises(ValueError, match="positive"):
        DiscreteStage(STAGE, -1e-3)


def test_load_stage(tmp_path):
    assert load_stage("flexure_stage") is STAGE
    assert load_stage("pysim.specs.flexure_stage") is STAGE
    good = tmp_path / "my_stage.py"
    good.write_text("import control\nSTAGE = control.tf([1.0], [1e-3, 1.0])\n")
    assert abs(load_stage(str(good))(0)) == pytest.approx(1.0)
    for text, message in (("x = 1\n", "defines no STAGE"), ("raise RuntimeError('boom')\n", "boom"),
                          ("import control\nSTAGE = control.ss(-1, [[1, 1]], 1, [[0, 0]])\n", "one input")):
        bad = tmp_path / "bad_stage.py"
        bad.write_text(text)
        with pytest.raises(CoSimulationError, match=message):
            load_stage(str(bad))
    with pytest.raises(CoSimulationError, match="does not exist"):
        load_stage(str(tmp_path / "missing.py"))
    with pytest.raises(CoSimulationError, match="no stage file or module"):
        load_stage("no_such_stage_module")


@pytest.mark.parametrize("method, prewarp", [("tustin", None), ("tustin", 300.0), ("zoh", None), ("foh", None)])
def test_discretisation_agrees_with_python_control(method, prewarp):
    ours = discretise(STAGE, 1e-4, method, prewarp)
    theirs = control.sample_system(STAGE, 1e-4, method=method,
                                   prewarp_frequency=None if prewarp is None else 2 * math.pi * prewarp)
    z = np.exp(2j * math.pi * np.array([1.0, 100.0, 600.0, 3000.0]) * 1e-4)
    np.testing.assert_allclose(ours(z), theirs(z), rtol=1e-12)
