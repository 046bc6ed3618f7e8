"""FMUs for the co-simulation tests, from the one build path of
:mod:`pysim.testing.fmus` (so the sanitizer swap reaches these tests too)."""
import pytest

from pysim.testing.fmus import DEFAULT_MODEL, LINEAR_MODEL, built_fmus


@pytest.fixture(scope="session")
def linear_model():
    return LINEAR_MODEL


@pytest.fixture(scope="session")
def linear_fmus():
    paths = built_fmus(LINEAR_MODEL, ("linux64",))
    return paths["plant"], paths["inverse"]


@pytest.fixture(scope="session")
def default_fmus():
    paths = built_fmus(DEFAULT_MODEL, ("linux64",))
    return paths["plant"], paths["inverse"]
