"""Error measures (eq. 14-15) against closed-form values."""
import numpy as np
import pytest

from pysim.core.metrics import error_measures


def test_sine_error_on_a_ramp_reference():
    reference = np.linspace(0.0, 10.0, 100001)            # range 10 µm
    phase = np.linspace(0, 200 * np.pi, reference.size)
    actual = reference + 0.5 * np.sin(phase)                # error amplitude 0.5 µm
    e = error_measures(reference, actual)
    assert e["max_error_pct"] == pytest.approx(5.0, rel=1e-6)
    assert e["rms_error_pct"] == pytest.approx(100 * 0.5 / np.sqrt(2) / 10, rel=1e-4)
    assert e["mean_error_pct"] == pytest.approx(100 * 0.5 * 2 / np.pi / 10, rel=1e-4)


def test_error_of_either_sign_counts_for_the_maximum():
    e = error_measures([0.0, 1.0, 2.0], [0.0, 1.0, 2.5])
    assert e["max_error_pct"] == pytest.approx(25.0)
    e = error_measures([0.0, 1.0, 2.0], [0.0, 1.0, 1.5])
    assert e["max_error_pct"] == pytest.approx(25.0)


def test_constant_reference_is_refused():
    with pytest.raises(ValueError, match="constant"):
        error_measures([1.0, 1.0], [1.0, 2.0])
