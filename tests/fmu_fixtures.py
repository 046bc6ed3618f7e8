"""FMUs for the co-simulation tests, built once through the project's builder
(cached in the package cache, so later test modules get them at once)."""
import pytest

from models.default_mpi import MODEL
from pysim.harness import fmus_for_model
from pysim.model import HysteresisModel

# "Hysteresis switched off": one operator of zero weight, a1 = 0, so the plant
# is the straight line 0.5 µm/V through the origin, as an FMU like any other.
LINEAR = HysteresisModel(a1=0.0, a2=0.5, thresholds_V=(0.0,), weights_um_per_V=(0.0,),
                         voltage_range_V=(0.0, 150.0), name="linear_plant",
                         description="hysteresis switched off (test plant)")


@pytest.fixture(scope="session")
def linear_model():
    return LINEAR


@pytest.fixture(scope="session")
def linear_fmus():
    return fmus_for_model(LINEAR)


@pytest.fixture(scope="session")
def default_fmus():
    return fmus_for_model(MODEL)
