"""Mathematics that exists both in Python and in C agrees.

The FMUs check and invert the model with the C in ``fmu_src/mpi_parameters.c``;
the Python package with ``pysim.core.invertibility`` and
``pysim.core.model.analytic_inverse``.  The host library (``pysim.core.kernel``)
compiles the same C file, so the two implementations are compared here
through ctypes: **they check each other** -- agreement means the two agree,
not that either is right.  Where an independent truth is at hand the test
uses it too:

- struct layouts: the C compiler's own ``sizeof``/``offsetof`` (reported by
  ``mpi_host_layout``) against the ctypes mirrors written by hand;
- the delay limit: the C constant against ``MAX_DELAY_SAMPLES``, and both
  limits' behaviour;
- invertibility: the verdict of each (branch, active operators) case decided
  in exact rational arithmetic (``fractions``) on the same doubles, over
  random models (n 1-30, OSP and play, a1 of both signs, many of them placed
  exactly at the invertibility boundary or a few ulps off it, negative
  weights, random unipolar and bipolar voltage ranges) and hand-made edge
  cases.  The C decides the sign of every slope exactly and must match the
  exact verdict always; Python computes the slopes and failing intervals in
  rounded arithmetic and takes its verdict from the C, so it matches too;
- the analytic inverse (eq. 11-12): r_hat, b_hat, a2_hat and the offsets of
  both against each other to 1e-12, and both against exact arithmetic.
"""
import ctypes
from fractions import Fraction

import numpy as np
import pytest

from pysim.core import kernel
from pysim.core.errors import ModelError, NotInvertibleError
from pysim.core.extended import MAX_DELAY_SAMPLES, OutputStages, OutputStagesStruct
from pysim.core.invertibility import check_invertibility
from pysim.core.model import HysteresisModel, analytic_inverse

N_RANDOM = 2400
EPS = np.finfo(float).eps


# ------------------------------------------------------------------ C calls

def c_invertibility(model: HysteresisModel, voltage_range_V=None) -> kernel.MpiInvertibility:
    lo, hi = model.voltage_range_V if voltage_range_V is None else voltage_range_V
    c_model = model._c_model()
    work = np.full(2 * model.n_operators + 10, np.nan)
    result = kernel.MpiInvertibility()
    kernel.library().mpi_invertibility(ctypes.byref(c_model), lo, hi, kernel.as_pointer(work),
                                       ctypes.byref(result))
    return result


def c_inverse(model: HysteresisModel):
    """``(failed, inverse, r_hat, b_hat, failed_sum)`` from mpi_inverse_parameters."""
    c_model = model._c_model()
    r_hat, b_hat = np.full(model.n_operators, np.nan), np.full(model.n_operators, np.nan)
    inverse, failed_sum = kernel.HystModel(), ctypes.c_double(np.nan)
    failed = kernel.library().mpi_inverse_parameters(ctypes.byref(c_model), ctypes.byref(inverse),
                                                     kernel.as_pointer(r_hat), kernel.as_pointer(b_hat),
                                                     ctypes.byref(failed_sum))
    return failed, inverse, r_hat, b_hat, failed_sum.value


# ------------------------------------------------------ the exact reference

def exact_cases(model: HysteresisModel) -> list:
    """Every (branch, active operators) case of the slope, with its minimum
    over the case's input interval in exact arithmetic.

    The case intervals are computed in double exactly as both implementations
    compute them (u = v - offset, band = r or 2 r); only the slope
    ``a2 + sum of the k narrowest weights + 3 a1 u^2`` is exact.  Its minimum
    over an interval is taken over the ends and 0 (if inside): the candidates
    for the extremum of a quadratic in u with no linear term.

    Returns a list of ``(min_slope Fraction, u at the minimum, branch, k, scale)``
    with ``scale`` the sum of the magnitudes of the slope's terms.
    """
    lo, hi = model.voltage_range_V
    u_lo, u_hi = lo - model.input_offset_V, hi - model.input_offset_V
    span = u_hi - u_lo
    band = 2.0 if model.operator == "play" else 1.0
    r, b, n = model.thresholds_V, model.weights_um_per_V, model.n_operators
    a1 = Fraction(model.a1)
    total, magnitude = Fraction(model.a2), abs(model.a2)
    cases = []
    for k in range(n + 1):
        lower = band * r[k - 1] if k > 0 else 0.0
        if k > 0:
            total += Fraction(b[k - 1])
            magnitude += abs(b[k - 1])
        if (k < n and band * r[k] <= lower) or (k > 0 and lower >= span):
            continue
        for branch, (u_from, u_to) in (("ascending", (u_lo + lower, u_hi)), ("descending", (u_lo, u_hi - lower))):
            candidates = [u_from, u_to] + ([0.0] if u_from <= 0.0 <= u_to else [])
            slope, u = min((total + 3 * a1 * Fraction(x) ** 2, x) for x in candidates)
            scale = magnitude + 3.0 * abs(model.a1) * max(u_from * u_from, u_to * u_to)
            cases.append((slope, u, branch, k, scale))
    return cases


def exact_margin(cases) -> float:
    """Smallest exact slope over all cases, relative to its terms' magnitudes."""
    return min(float(slope) / scale for slope, _, _, _, scale in cases)


# ---------------------------------------------------------------- models

def _float_cases(model):
    """(S, u_from, u_to) of every case in double (to place a1 at a boundary)."""
    lo, hi = model.voltage_range_V
    u_lo, u_hi = lo - model.input_offset_V, hi - model.input_offset_V
    band = 2.0 if model.operator == "play" else 1.0
    r, b, n = model.thresholds_V, model.weights_um_per_V, model.n_operators
    out, s = [], model.a2
    for k in range(n + 1):
        lower = band * r[k - 1] if k > 0 else 0.0
        if k > 0:
            s += b[k - 1]
        if (k < n and band * r[k] <= lower) or (k > 0 and lower >= u_hi - u_lo):
            continue
        out += [(s, u_lo + lower, u_hi), (s, u_lo, u_hi - lower)]
    return out


def boundary_a1(model):
    """The a1 (rounded) at which the model's smallest slope is zero, or None.

    All case sums S > 0: the largest -S / (3 max u^2) (a1 < 0); else the largest
    -S / (3 min u^2) over the cases with S <= 0 (a1 > 0), if none of them
    reaches u = 0."""
    cases = _float_cases(model)
    if all(s > 0 for s, _, _ in cases):
        return max(-s / (3.0 * max(u_from * u_from, u_to * u_to)) for s, u_from, u_to in cases)
    lows = [0.0 if u_from <= 0.0 <= u_to else min(u_from * u_from, u_to * u_to)
            for s, u_from, u_to in cases if s <= 0]
    if min(lows) == 0.0:
        return None
    return max(-s / (3.0 * low) for (s, _, _), low in zip([c for c in cases if c[0] <= 0], lows))


def random_model(rng, index: int) -> HysteresisModel:
    """A random model.  a1: anywhere; exactly where the smallest slope is zero
    (rounded, then 0-3 ulps off); at one case's zero; or near the boundary."""
    n = int(rng.integers(1, 31))
    operator = "osp" if rng.random() < 0.5 else "play"
    band = 2.0 if operator == "play" else 1.0
    lo = float(rng.uniform(-150.0, 100.0))
    hi = lo + float(rng.uniform(0.5, 250.0))
    offset = float(rng.uniform(-100.0, 100.0)) if rng.random() < 0.6 else 0.0
    r = np.sort(rng.uniform(0.0, 1.2 * (hi - lo) / band, n))        # some beyond the span
    if rng.random() < 0.3:
        r[0] = 0.0
    if n > 2 and rng.random() < 0.2:
        r[2] = r[1]                                                  # equal thresholds
    b = rng.normal(0.05, 0.3, n) * 10.0 ** rng.uniform(-2, 1)       # negative ones too
    a2 = float(rng.uniform(0.01, 2.0))
    model = HysteresisModel(0.0, a2, tuple(r), tuple(b), operator=operator, input_offset_V=offset,
                            output_offset_um=float(rng.uniform(-5.0, 5.0)), voltage_range_V=(lo, hi),
                            name=f"random{index}")
    kind = rng.random()
    a1 = boundary_a1(model)
    if kind < 0.25 or a1 is None:                                    # anywhere
        u_max = max(abs(lo - offset), abs(hi - offset))
        return model.with_parameters(a1=float(rng.normal(0.0, 2.0) * a2 / (3.0 * u_max * u_max)))
    if kind < 0.4:                                                   # one case's zero
        cases = _float_cases(model)
        s, u_from, u_to = cases[rng.integers(len(cases))]
        u = (u_to if abs(u_to) >= abs(u_from) else u_from) or 1.0
        a1 = -s / (3.0 * u * u)
    if kind < 0.8:                                                   # on the boundary, to an ulp
        direction = np.inf if rng.random() < 0.5 else -np.inf
        for _ in range(int(rng.integers(0, 4))):
            a1 = float(np.nextafter(a1, direction))
    else:                                                            # near it
        a1 *= 1.0 + float(rng.choice([-1.0, 1.0])) * 10.0 ** rng.uniform(-13, -4)
    return model.with_parameters(a1=float(a1))


def edge_models() -> list:
    """Hand-made cases: slopes exactly zero, sums that cancel, ties, bands
    at the span, thresholds beyond it, a single operator, a1 = 0."""
    m = []
    add = lambda *args, **kw: m.append(HysteresisModel(*args, name=f"edge{len(m)}", **kw))  # noqa: E731
    add(-1.0, 3.0, (0.0,), (0.0,), voltage_range_V=(0.0, 1.0))          # 3 - 3 u^2 = 0 at u = 1
    add(-1.0, 3.0, (0.0,), (0.0,), voltage_range_V=(-1.0, 1.0))         # ... at both ends
    add(-1.0, 3.0, (0.0,), (0.0,), voltage_range_V=(0.0, float(np.nextafter(1.0, 0.0))))   # just inside
    add(1.0, 0.0, (0.5,), (1.0,), voltage_range_V=(-1.0, 1.0))          # S = 0, a1 > 0: zero at u = 0
    add(1.0, 0.0, (0.1,), (1.0,), voltage_range_V=(0.5, 1.0))           # ... 0 outside the range
    add(1.0, 1.0, (0.1,), (-2.0,), voltage_range_V=(1.0, 2.0))          # S = -1 on the k = 1 branch
    add(1.0 / 3.0, 1.0, (0.1,), (-2.0,), voltage_range_V=(1.0, 2.0))   # -1 + 3 (1/3) 1^2, rounded a1
    add(0.0, 1.0, (0.0, 0.5), (-1.0, 1.0), voltage_range_V=(0.0, 2.0))  # a2 + b1 = 0: a flat branch
    add(0.0, 1e16, (0.0, 0.5), (1.0, -1e16), voltage_range_V=(0.0, 2.0))  # exact sum 1, rounded 0
    add(0.0, 1.0, (0.0, 0.5, 0.5), (0.2, -5.0, 5.0), voltage_range_V=(0.0, 2.0))  # equal thresholds
    add(0.0, 1.0, (0.0, 1.0), (0.2, -5.0), voltage_range_V=(0.0, 1.0))  # band exactly the span
    add(0.0, 1.0, (0.0, 0.5), (0.2, -5.0), operator="play", voltage_range_V=(0.0, 1.0))   # 2 r = span
    add(0.0, 1.0, (0.0, 0.3), (0.2, -5.0), operator="play", voltage_range_V=(0.0, 1.0))   # 2 r < span
    add(-0.04, 1.0, (0.0,), (0.0,), voltage_range_V=(-10.0, 5.0))       # a1 < 0, both ends fail
    add(-1e-6, 2.0, tuple(np.linspace(0, 140, 30)), tuple(np.linspace(0.1, -0.05, 30)),
        input_offset_V=-20.0, voltage_range_V=(-30.0, 150.0))
    add(0.0, 0.5, (0.0,), (0.0,), voltage_range_V=(0.0, 150.0))        # the linear plant
    return m


@pytest.fixture(scope="module")
def models():
    rng = np.random.default_rng(20140407)
    return [random_model(rng, i) for i in range(N_RANDOM)] + edge_models()


@pytest.fixture(scope="module")
def verdicts(models):
    """(model, Python report, C result, exact cases) for every model."""
    return [(m, check_invertibility(m), c_invertibility(m), exact_cases(m)) for m in models]


# --------------------------------------------------------- struct layouts

def c_layout() -> dict:
    """{struct: [(field or None, offset, size), ...]} from the C compiler."""
    lib = kernel.library()
    table = {}
    structure, field = ctypes.c_char_p(), ctypes.c_char_p()
    offset, size = ctypes.c_size_t(), ctypes.c_size_t()
    index = 0
    while lib.mpi_host_layout(index, ctypes.byref(structure), ctypes.byref(field), ctypes.byref(offset),
                              ctypes.byref(size)):
        name = None if field.value is None else field.value.decode()
        table.setdefault(structure.value.decode(), []).append((name, offset.value, size.value))
        index += 1
    return table


MIRRORS = {"HystModel": kernel.HystModel, "OutputStages": OutputStagesStruct,
           "MpiInvertibility": kernel.MpiInvertibility}


def test_struct_layouts_equal_the_ctypes_mirrors():
    table = c_layout()
    assert sorted(table) == sorted(MIRRORS)
    for name, mirror in MIRRORS.items():
        (whole, _, size), *fields = table[name]
        assert whole is None and size == ctypes.sizeof(mirror), name
        c_fields = [(field, offset, size) for field, offset, size in fields]
        py_fields = [(field, getattr(mirror, field).offset, getattr(mirror, field).size)
                     for field, _ in mirror._fields_]
        assert c_fields == py_fields, name


def test_delay_limits_agree():
    limit = kernel.library().mpi_host_max_delay()
    assert limit == MAX_DELAY_SAMPLES
    # and they act alike: the longest line is accepted by both, one more by neither
    assert OutputStages(delay_samples=limit).state_size == limit + 2
    with pytest.raises(ModelError, match="delay"):
        OutputStages(delay_samples=limit + 1)
    check = kernel.library()["ostage_check"]            # a fresh function object: own argtypes
    check.argtypes, check.restype = [ctypes.POINTER(OutputStagesStruct)], ctypes.c_int
    for whole, expected in ((limit, 0), (limit + 1, 1)):              # OSTAGE_BAD_COUNT = 1
        assert check(ctypes.byref(OutputStagesStruct(0, None, whole, 0.0, 0, None, None, None, 0, None))) \
            == expected


# --------------------------------------------------------- invertibility

def test_the_random_models_cover_both_verdicts_and_the_boundary(verdicts):
    exact = [all(case[0] > 0 for case in cases) for _, _, _, cases in verdicts]
    margins = np.array([exact_margin(cases) for _, _, _, cases in verdicts])
    assert 0.2 < np.mean(exact) < 0.8
    assert np.sum(np.abs(margins) < 1e-15) > 500                      # within rounding of the boundary
    assert np.sum(margins == 0.0) >= 4                                 # exactly on it (edge cases)
    assert any(m.a1 > 0 and not ok for (m, *_), ok in zip(verdicts, exact))
    assert any(m.a1 < 0 and not ok for (m, *_), ok in zip(verdicts, exact))
    assert {m.operator for m, *_ in verdicts} == {"osp", "play"}
    assert any(m.voltage_range_V[0] - m.input_offset_V < 0 < m.voltage_range_V[1] - m.input_offset_V
               for m, *_ in verdicts)                                   # bipolar inputs


def test_c_verdict_is_the_exact_verdict(verdicts):
    wrong = [m for m, _, c, cases in verdicts if bool(c.invertible) != all(case[0] > 0 for case in cases)]
    assert wrong == []


def test_verdicts_agree_away_from_the_rounding_boundary(verdicts):
    """Where no rounding can decide it (|exact slope| > 1e-13 of its terms), the
    C and the Python verdicts are equal -- and both exact."""
    checked = 0
    for m, report, c, cases in verdicts:
        if abs(exact_margin(cases)) > 1e-13:
            assert report.invertible == bool(c.invertible), m
            checked += 1
    assert checked > N_RANDOM / 3


def test_python_verdict_is_the_exact_verdict_at_the_boundary_too(verdicts):
    """check_invertibility takes its verdict from the C kernel's exact sign
    decisions, so it matches exact rational arithmetic even within rounding of
    the boundary (where its own rounded intervals could err)."""
    wrong = [m for m, report, _, cases in verdicts if report.invertible != all(case[0] > 0 for case in cases)]
    assert wrong == []


def test_smallest_slope_and_where_it_is_agree(verdicts):
    """Both report the smallest slope over all branches and where it is reached
    (Python: min_slope_um_per_V, worst_voltage_V, worst_branch); when the model
    is refused, that is where the FMU's message says it fails.  The smallest
    slope agrees to rounding; its place exactly, unless two cases tie."""
    ties = both_refuse = 0
    for m, report, c, cases in verdicts:
        scale = max(case[4] for case in cases)
        smallest = min(case[0] for case in cases)
        assert c.min_slope == pytest.approx(report.min_slope_um_per_V, rel=0, abs=1e-12 * scale), m
        assert c.min_slope == pytest.approx(float(smallest), rel=0, abs=1e-12 * scale), m
        voltage_scale = max(abs(v) for v in m.voltage_range_V) + abs(m.input_offset_V)
        same_place = (abs(c.worst_voltage - report.worst_voltage_V) <= 1e-12 * voltage_scale
                      and ("descending" if c.descending else "ascending") == report.worst_branch)
        if not same_place:
            # only a tie of the exact minima of two cases may put them elsewhere
            near = [case for case in cases if abs(float(case[0] - smallest)) <= 1e-12 * case[4]]
            assert len(near) >= 2, m
            ties += 1
        both_refuse += not report.invertible and not c.invertible
    assert ties <= len(verdicts) // 100
    assert both_refuse > N_RANDOM / 4


def test_voltage_range_argument_is_used():
    model = HysteresisModel(-1.0, 3.0, (0.0,), (0.0,), voltage_range_V=(0.0, 2.0), name="ranged")
    assert not c_invertibility(model).invertible
    assert c_invertibility(model, (0.0, 0.99)).invertible
    assert check_invertibility(model, (0.0, 0.99)).invertible


def test_python_failure_intervals_cover_the_worst_voltage():
    """A bipolar range with a1 < 0: the slope 1 - 0.12 u^2 is <= 0 for |u| >= 2.89 V,
    at both ends of [-10, 5] V; both report the smallest slope at -10 V."""
    model = HysteresisModel(-0.04, 1.0, (0.0,), (0.0,), voltage_range_V=(-10.0, 5.0), name="bipolar")
    report, c = check_invertibility(model), c_invertibility(model)
    assert not report.invertible and not c.invertible
    assert c.worst_voltage == report.worst_voltage_V == -10.0
    assert any(v_from <= -10.0 <= v_to for _, v_from, v_to, _ in report.failures)


# ------------------------------------------------------ analytic inverse

def exact_inverse(model):
    """r_hat, b_hat (Fractions) of eq. 11-12 in exact arithmetic, or None."""
    r = [Fraction(x) for x in model.thresholds_V]
    b = [Fraction(x) for x in model.weights_um_per_V]
    a2 = Fraction(model.a2)
    sums = [a2 + sum(b[:j], Fraction(0)) for j in range(len(b) + 1)]
    if any(s <= 0 for s in sums):
        return None
    r_hat = [a2 * r[j] + sum((b[i] * (r[j] - r[i]) for i in range(j)), Fraction(0)) for j in range(len(r))]
    b_hat = [-b[j] / (sums[j] * sums[j + 1]) for j in range(len(b))]
    return r_hat, b_hat


def test_analytic_inverse_parameters_agree(models):
    inverted = refused = 0
    for m in models:
        failed, inverse, r_hat, b_hat, failed_sum = c_inverse(m)
        try:
            expected = analytic_inverse(m)
        except NotInvertibleError:
            assert failed >= 0, m
            assert not failed_sum > 0
            assert np.all(np.isnan(r_hat)) and np.all(np.isnan(b_hat))     # nothing written
            refused += 1
            continue
        assert failed == -1, m
        inverted += 1
        n = m.n_operators
        assert (inverse.operator_kind, inverse.n_operators) == ({"osp": 0, "play": 1}[m.operator], n)
        assert inverse.a1 == expected.a1 == 0.0
        assert inverse.a2 == pytest.approx(expected.a2, rel=1e-12)
        assert (inverse.input_offset, inverse.output_offset) == (expected.input_offset_V, expected.output_offset_um)
        assert ctypes.addressof(inverse.thresholds.contents) == r_hat.ctypes.data
        assert ctypes.addressof(inverse.weights.contents) == b_hat.ctypes.data
        np.testing.assert_allclose(b_hat, expected.weights, rtol=1e-12, atol=0)
        np.testing.assert_allclose(r_hat, expected.thresholds, rtol=1e-12, atol=0)
    assert inverted > 300 and refused > 300


def test_analytic_inverse_parameters_are_exact_to_rounding(models):
    """Both against eq. 11-12 in exact arithmetic, to a bound on the rounding
    of the sums (relative to the magnitudes of their terms)."""
    checked = 0
    for m in models[::4]:
        exact = exact_inverse(m)
        if exact is None or c_inverse(m)[0] >= 0:        # (refusals: compared above)
            continue
        _, _, c_r, c_b, _ = c_inverse(m)
        python = analytic_inverse(m)
        r, b, a2 = np.array(m.thresholds_V), np.array(m.weights_um_per_V), m.a2
        n = m.n_operators
        sums = a2 + np.concatenate(([0.0], np.cumsum(b)))
        for j in range(n):
            r_scale = abs(a2 * r[j]) + np.sum(np.abs(b[:j]) * (r[j] - r[:j]))
            # b_hat = -b / (s_j s_j+1), each s with cancellation ~ (|a2| + sum |b|) eps
            s_error = 4 * (n + 2) * EPS * (abs(a2) + np.sum(np.abs(b)))
            b_bound = abs(float(exact[1][j])) * (s_error / sums[j] + s_error / sums[j + 1] + 4 * EPS)
            for got_r, got_b in ((c_r[j], c_b[j]), (python.thresholds_V[j], python.weights_um_per_V[j])):
                assert abs(got_r - float(exact[0][j])) <= 4 * (n + 2) * EPS * r_scale, m
                assert abs(got_b - float(exact[1][j])) <= b_bound, m
        checked += 1
    assert checked > 50
