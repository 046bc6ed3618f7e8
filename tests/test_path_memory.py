"""The input's path memory and the rate-independent correction built on it.

The truths here are independent of the package: turning points worked out by
hand, a Preisach model of relays written out in the test (a hysteresis the
MPI class cannot draw), and the property that defines rate independence --
the same path played at another speed gives the same output.
"""
import numpy as np
import pytest

from pysim.diagnosis.path_memory import path_memory, path_predicted
from pysim.diagnosis.shape import path_corrected

from independent_records import preisach_relays


def relays(v):
    return preisach_relays(v, 0.0, 100.0)


def blocks_of(n, k=4):
    parts = np.array_split(np.arange(n), k)
    return [(np.concatenate([p for j, p in enumerate(parts) if j != i]), part) for i, part in enumerate(parts)]


def test_turning_points_and_wiping_out():
    # up to 10, down to 2, up to 8, down to 4, then up past 10: both inner pairs are wiped out
    v = np.concatenate([np.linspace(0, 10, 11), np.linspace(9, 2, 8), np.linspace(3, 8, 6),
                        np.linspace(7, 4, 4), np.linspace(5, 12, 8)])
    m = path_memory(v, 0.5)
    at = {float(x): tuple(row[1:]) for x, row in zip(v, m)}
    assert tuple(m[20, 1:]) == (2.0, 10.0)          # rising from 2, below the top at 10
    assert tuple(m[27, 1:]) == (8.0, 2.0)           # falling from 8 after the minor loop began
    assert tuple(m[-1, 1:]) == (0.0, 0.0)           # beyond 10: only the start is left
    assert at[12.0] == (0.0, 0.0)
    # a wiggle within the tolerance is no turning point
    hold = np.r_[np.linspace(0, 5, 6), [4.9, 5.0, 4.95], np.linspace(5, 8, 4)]
    assert set(path_memory(hold, 0.5)[:, 1]) == {0.0}


def test_path_memory_is_the_same_at_any_speed():
    # the memory depends on the path only: the same path sampled ten times slower gives the same rows
    fast = np.r_[np.linspace(0, 90, 10), np.linspace(80, 30, 6), np.linspace(40, 70, 4)]
    slow = np.interp(np.arange(0, fast.size - 1 + 1e-9, 0.1), np.arange(fast.size), fast)
    m_fast, m_slow = path_memory(fast, 0.5), path_memory(slow, 0.5)
    np.testing.assert_allclose(m_slow[::10], m_fast)


def test_a_rate_independent_residual_is_predicted_across_speeds_a_lag_is_not():
    # the same triangles, slow in one half and four times faster in the other, each half predicted
    # from the other: a Preisach shape error transfers, the error of a lag (proportional to the rate) does not
    cycle = np.r_[np.linspace(5, 95, 200), np.linspace(95, 5, 200)[1:-1]]
    slow, fast = np.tile(cycle, 5), np.tile(cycle[::4], 20)
    v = np.concatenate([slow, fast])
    shape = relays(v)
    shape = shape - np.mean(shape)
    lag_error = -np.gradient(v)
    halves = np.arange(slow.size), slow.size + np.arange(fast.size)
    blocks = [(halves[1], halves[0]), (halves[0], halves[1])]
    memory = path_memory(v)

    def left(residual):
        return np.sqrt(np.mean((residual - path_predicted(residual, memory, blocks)) ** 2) / np.mean(residual ** 2))

    assert left(shape) < 0.35
    assert left(lag_error) > 0.8


def test_correction_counts_only_for_a_shape_error():
    rng = np.random.default_rng(4)
    t = np.arange(8000) / 1000.0
    v = 50 + 45 * np.sin(2 * np.pi * (0.5 * t + 1.0 * t**2))
    memory, blocks = path_memory(v), blocks_of(v.size)
    sigma = 0.01
    noise = rng.normal(0, sigma, v.size)

    def score(y):
        return lambda model, p: float(np.mean((y - p)[500:] ** 2))

    base = 10 * relays(v)
    # a model that misses the loops entirely (its prediction is the reversible part of the plant)
    reversible = 10 * (np.interp(v, [0, 100], [-1, 1]))
    y = base + noise
    found = path_corrected({"baseline": reversible, "richer": reversible, "lag": reversible + 0.0}, y, memory,
                           blocks, score(y), sigma, ["baseline", "richer"])
    assert found is not None
    corrected, evidence = found
    assert evidence["removed_sigma2"] > 100 and evidence["left_sigma2"] < evidence["removed_sigma2"] / 10
    # pure noise: nothing to correct
    assert path_corrected({"baseline": base, "richer": base, "lag": base}, y, memory, blocks, score(y), sigma,
                          ["baseline", "richer"]) is None
    # a lag the models miss and a candidate that has it: the path does not explain more than the lag
    lagged = base - 0.002 * np.gradient(base, 1e-3)
    y = lagged + noise
    assert path_corrected({"baseline": base, "richer": base, "lag": lagged}, y, memory, blocks, score(y), sigma,
                          ["baseline", "richer"]) is None


@pytest.mark.parametrize("n", [0, 1])
def test_short_inputs(n):
    assert path_memory(np.zeros(n)).shape == (n, 3)
