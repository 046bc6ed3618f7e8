"""Shared fixtures: the paper's example model and inputs.

The suite tests the installed package (``pip install .`` or a wheel): nothing
here puts the source tree on ``sys.path``.
"""
import numpy as np
import pytest

from pysim.core.model import HysteresisModel, eq13_thresholds


def paper_model(a1=-0.8, n=10, operator="osp", voltage_range=(0.0, 1.0)):
    """The paper's normalised simulation example (Fig. 5/6): p(r) = 5 exp(-0.505 (r-1)^2)."""
    r = eq13_thresholds(n, 1.0, operator)
    b = 5.0 * np.exp(-0.505 * (r - 1.0) ** 2) * (r[1] - r[0])
    return HysteresisModel(a1, 2.42, tuple(r), tuple(b), operator=operator, voltage_range_V=voltage_range,
                           name="paper")


def paper_input(n_samples=20001, t_end=20.0):
    """v(t) = 0.5 + 0.5 sin(3t)/(1+t) of the paper's Fig. 5/6."""
    t = np.linspace(0.0, t_end, n_samples)
    return 0.5 + 0.5 * np.sin(3 * t) / (1 + t)


def random_piecewise_monotone(rng, n_segments=40, lo=0.0, hi=1.0, points_per_segment=(2, 60)):
    """Random extrema joined by monotone ramps of random length (and random speed)."""
    extrema = rng.uniform(lo, hi, n_segments)
    extrema[0] = lo
    pieces = []
    for a, b in zip(extrema[:-1], extrema[1:]):
        k = rng.integers(*points_per_segment)
        s = np.sort(rng.uniform(0, 1, k))
        pieces.append(a + (b - a) * s)
    return np.concatenate(pieces)


def continuous_response(num, den, x, dt_s):
    """Response of the continuous transfer function ``num/den`` to ``x`` taken as linear between
    its samples (every ``dt_s`` s), at rest at ``x[0]``: scipy's matrix-exponential simulation, an
    implementation independent of the stage sections."""
    import scipy.signal

    a, b, c, d = scipy.signal.tf2ss(num, den)
    rest = np.linalg.solve(a, -b[:, 0] * x[0])
    _, y, _ = scipy.signal.lsim((a, b, c, d), x, np.arange(x.size) * dt_s, X0=rest, interp=True)
    return y


@pytest.fixture
def rng():
    return np.random.default_rng(20141)


def pytest_configure(config):
    """Under ``tests/run.sh`` the suite must test the installed wheel, not this checkout."""
    import os
    from pathlib import Path

    import pysim

    if os.environ.get("PIEZO_MPI_TEST_INSTALLED"):
        repo = Path(os.environ.get("PIEZO_MPI_REPO", Path(__file__).resolve().parents[1])).resolve()
        where = Path(pysim.__file__).resolve()
        if repo in where.parents:
            raise pytest.UsageError(f"pysim is imported from the checkout ({where}), not from the installed package")


def pytest_report_header(config):
    """Where pysim comes from, and the floating-point kernels the run uses (tests/pin_kernels.sh)."""
    import os

    import pysim

    kernels = ", ".join(f"{name}={os.environ[name]}" for name in ("OPENBLAS_CORETYPE", "NPY_DISABLE_CPU_FEATURES")
                        if os.environ.get(name)) or "not pinned"
    return [f"pysim {pysim.__version__} from {pysim.__file__}", f"kernels: {kernels}"]
