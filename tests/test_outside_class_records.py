"""The generator of records outside the MPI class: its plants are what it says.

Asserted against properties, not recorded output: both hysteresis models are
rate independent (the same path sampled more finely gives the same output at
the same inputs), the Preisach model has return-point memory (closing a minor
loop returns the output to where the loop began), and the records of a pair
are of one actuator with different inputs.
"""
import numpy as np
import pytest

import outside_class_records as oc
from independent_records import preisach_relays


@pytest.mark.parametrize("model", ["preisach", "smooth_preisach", "bouc_wen"])
def test_the_hysteresis_is_rate_independent(model):
    corners = np.array([0.0, 90.0, 30.0, 70.0, 10.0, 100.0, 50.0])
    coarse = np.interp(np.linspace(0, 6, 61), np.arange(7), corners)
    fine = np.interp(np.linspace(0, 6, 601), np.arange(7), corners)

    def run(v):
        if model == "bouc_wen":
            return oc.bouc_wen(v, 0.0, 100.0)
        return preisach_relays(v, 0.0, 100.0, 40, ramp_share=0.025 if model == "smooth_preisach" else 0.0)

    np.testing.assert_allclose(run(fine)[::10], run(coarse), atol=0.02 * np.ptp(run(fine)))


def test_preisach_has_return_point_memory():
    def loop(low):
        # up to 100, down to `low`, up by 30 V and back down to `low`
        path = np.concatenate([np.linspace(0, 100, 101), np.linspace(100, low, 101),
                               np.linspace(low, low + 30, 61), np.linspace(low + 30, low, 61)])
        out = preisach_relays(path, 0.0, 100.0, 40)
        return out[201], out[262], out[-1]
    for low in (10.0, 50.0):
        before, top, after = loop(low)
        assert top > before + 0.01 and after == pytest.approx(before, abs=1e-12)


def test_a_pair_is_one_actuator_with_three_inputs():
    pair = oc.make_outside_pair(0)
    kinds = {pair.train.input_kind, pair.validation.input_kind, pair.test.input_kind}
    assert len(kinds) == 3
    for record in (pair.train, pair.validation, pair.test):
        assert record.voltage_V.shape == record.displacement_um.shape == record.clean_um.shape
        noise = record.displacement_um - record.clean_um
        assert np.std(noise) == pytest.approx(pair.noise_um, rel=0.1)
    assert pair.effect == "none" and pair.catalogue_name == "none"
