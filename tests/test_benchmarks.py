"""Smoke tests of the benchmark runner's pieces on tiny sizes.

No timing is asserted here (speed targets are the benchmarks' business);
these check that each piece measures what it claims: the scaled models are
the default model's family, the step driver drives the FMU correctly and the
K / 2K instruction difference cancels the set-up, the three PSO objectives
are the identification objective, the build timer restores zig's environment,
and the runner reports misses and failures instead of hiding them.
"""
import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
if str(BENCHMARKS) not in sys.path:
    sys.path.insert(0, str(BENCHMARKS))

import bench_build  # noqa: E402
import bench_fmu_step  # noqa: E402
import bench_identify  # noqa: E402
import bench_load_measured  # noqa: E402
import run_all  # noqa: E402
from bench_common import Row  # noqa: E402
from pysim.specs.default_mpi import MODEL  # noqa: E402


# ------------------------------------------------------------- FMU step cost
def test_scaled_model_at_ten_operators_is_the_default_model():
    m = bench_fmu_step.scaled_model(10)
    assert (m.a1, m.a2, m.operator, m.voltage_range_V) == (MODEL.a1, MODEL.a2, MODEL.operator,
                                                          MODEL.voltage_range_V)
    np.testing.assert_array_equal(m.thresholds_V, MODEL.thresholds_V)
    np.testing.assert_allclose(m.weights_um_per_V, MODEL.weights_um_per_V, rtol=1e-15)


@pytest.mark.parametrize("n", [50, 200])
def test_scaled_models_keep_the_loop_and_stay_invertible(n):
    m = bench_fmu_step.scaled_model(n)
    assert m.n_operators == n
    assert m.check_invertibility().invertible
    # the weights sample the same density: the total weight (loop size) is
    # the density's integral over [0, 1) by the left rectangle rule
    total = np.sum(m.weights_um_per_V) * 150.0 / 20.0
    integral = 5.0 * math.sqrt(math.pi / 0.505) / 2.0 * math.erf(math.sqrt(0.505))
    assert abs(total - integral) < 5.0 / n


@pytest.fixture(scope="module")
def step_setup(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("step")
    driver = bench_fmu_step.compile_driver(tmp)
    libraries = {}
    for n in (10, 50):
        fmus = bench_fmu_step.build_step_fmus(n, tmp / f"n{n}")
        libraries[n] = bench_fmu_step.extract_binary(fmus["plant"], tmp)
    return tmp, driver, libraries


def test_step_driver_outputs_are_the_models(step_setup):
    _, driver, libraries = step_setup
    library, guid = libraries[10]
    cycles = 2 * bench_fmu_step.TABLE_SIZE + 37
    table = bench_fmu_step.driver_table(0.0, 150.0)
    voltage = np.resize(table, cycles)
    expected = float(np.sum(MODEL.simulate(voltage)))
    checksum = bench_fmu_step.run_driver(driver, library, guid, cycles, 0.0, 150.0)
    assert checksum == pytest.approx(expected, rel=1e-12)


def test_instruction_difference_cancels_the_set_up(step_setup):
    tmp, driver, libraries = step_setup
    library, guid = libraries[10]
    # the plant's step has no data-dependent branches, so K and 2K must give
    # the same cost per cycle exactly, whatever K
    small = bench_fmu_step.instructions_per_cycle(driver, library, guid, 0.0, 150.0, 64, tmp)
    large = bench_fmu_step.instructions_per_cycle(driver, library, guid, 0.0, 150.0, 192, tmp)
    assert small == large
    assert small["fmu_only"] == int(small["fmu_only"])
    assert 0 < small["fmu_only"] < small["with_loop"]
    # 40 more operators cost at least a load, a min, a max and a multiply-add each
    library50, guid50 = libraries[50]
    n50 = bench_fmu_step.instructions_per_cycle(driver, library50, guid50, 0.0, 150.0, 64, tmp)
    assert (n50["fmu_only"] - small["fmu_only"]) / 40 >= 4


def test_function_split_names_the_fmi_calls(step_setup):
    tmp, driver, libraries = step_setup
    fmu = next((tmp / "n10").glob("*_plant.fmu"))
    library = bench_fmu_step.debug_library(fmu, tmp)
    guid = libraries[10][1]
    split = bench_fmu_step.per_function(driver, library, guid, 0.0, 150.0, 64, tmp)
    assert set(bench_fmu_step.FMU_FUNCTIONS) <= set(split)
    total = bench_fmu_step.instructions_per_cycle(driver, library, guid, 0.0, 150.0, 64, tmp)
    assert sum(split.values()) == pytest.approx(total["with_loop"], abs=1.0)


# ------------------------------------------------------------ identification
@pytest.fixture(scope="module")
def noise_free_problem():
    from pysim.identification.identify import identify

    v, y = bench_identify.synthetic_record(3000, noise_um=0.0)
    result = identify(v, y, n_operators=bench_identify.N_OPERATORS)
    return result, bench_identify.Problem(v, y, result.fit_slice)


def test_the_three_pso_objectives_are_the_same_function(noise_free_problem):
    _, problem = noise_free_problem
    z = np.random.default_rng(1).uniform(-1, 1, (7, problem.dimensions))
    by_simulation = problem.cost_by_simulation(z)
    np.testing.assert_allclose(problem.cost_by_regressors(z), by_simulation, rtol=1e-9)
    np.testing.assert_allclose(problem.cost_by_gram(z), by_simulation, rtol=1e-7)


def test_true_model_is_inside_the_pso_box_and_costs_nothing(noise_free_problem):
    _, problem = noise_free_problem
    b = np.asarray(MODEL.weights_um_per_V)
    truth = np.concatenate(([MODEL.a1, MODEL.a2 + b[0]], b[1:], [MODEL.output_offset_um]))
    z = (truth - problem.center) / problem.half_width
    assert np.all(np.abs(z) < 1.0)
    scale = float(problem.y_fit @ problem.y_fit)
    assert problem.cost_by_simulation(z[None, :])[0] <= 1e-20 * scale


def test_pso_runs_and_exact_solution_is_no_worse(noise_free_problem):
    result, problem = noise_free_problem
    run = bench_identify.pso(problem, "regressors", particles=8, iterations=5, seed=0)
    assert run["evaluations"] == 8 * 5          # the whole swarm once per iteration
    assert result.objective <= run["objective"]
    assert result.errors["rms_error_pct"] <= run["errors"]["rms_error_pct"]


# --------------------------------------------------------------- FMU build
def test_build_timer_uses_a_fresh_zig_cache_and_restores_the_environment(tmp_path):
    before = {name: os.environ.get(name) for name in bench_build.ZIG_CACHE_VARIABLES}
    with bench_build.fresh_zig_cache(tmp_path):
        for name in bench_build.ZIG_CACHE_VARIABLES:
            assert Path(os.environ[name]).parent == tmp_path
    assert {name: os.environ.get(name) for name in bench_build.ZIG_CACHE_VARIABLES} == before


def test_build_benchmark_linux64(tmp_path):
    result = bench_build.measure(platforms=("linux64",))
    assert result["warm_all_cached"]
    # a cold build compiles both FMUs for the one linux target
    assert len(result["cold_compile_s"]) == 2
    assert result["warm_s"] < result["cold_s"]


def test_compile_times_are_read_from_progress_lines():
    lines = ["compiled a_plant for win64 (x86_64-windows-gnu): 65.4 s",
             "compiled a_plant for linux64 (x86_64-linux-gnu.2.17): cached", "checked the binaries"]
    assert bench_build.compile_times(lines) == {"a_plant x86_64-windows-gnu": 65.4}


# ------------------------------------------------------------------- runner
def test_table_marks_misses_and_context():
    rows = [Row("S", "met one", 1.0, "x", "<= 2 x", True), Row("S", "missed one", 3.0, "x", "<= 2 x", False),
            Row("S", "context", 12345.0, "ns")]
    lines = run_all.format_table(rows).splitlines()
    assert "yes" in lines[2] and "MISSED" in lines[3]
    assert "12,345 ns" in lines[4] and "MISSED" not in lines[4] and "yes" not in lines[4]


def test_a_section_that_fails_is_reported_not_hidden(monkeypatch):
    def broken(quick):
        raise RuntimeError("valgrind is not installed")

    monkeypatch.setitem(run_all.RUNNERS, "fmu_step", broken)
    rows, details, failures = run_all.run(["fmu_step"], quick=True, say=lambda message: None)
    assert rows == [] and "valgrind is not installed" in failures["fmu_step"]
    assert "error" in details["fmu_step"]


def test_runner_json_for_one_section(capsys, monkeypatch):
    monkeypatch.setitem(run_all.RUNNERS, "load", lambda quick: _tiny_load())
    for name in run_all.BLAS_THREAD_VARIABLES:
        monkeypatch.setenv(name, "1")
    monkeypatch.setattr(os, "sched_setaffinity", lambda pid, cpus: None, raising=False)
    assert run_all.main(["--quick", "--json", "--only", "load"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in report["rows"]][0] == "load 2000 rows"
    assert report["failed_to_run"] == {} and report["details"]["load"]["rows"] == 2000


def _tiny_load():
    result = bench_load_measured.measure(2000)
    # the loader names the line of the bad cell: header + 2000 rows + 1
    assert "line 2002" in result["message"]
    return result, bench_load_measured.rows_of(result)


# ------------------------------------------------------------- per-seed runs
def test_per_seed_runs_keep_the_order_and_report_each_seed(capsys):
    import bench_common

    args = bench_common.seed_arguments("x", 60).parse_args(["--first-seed", "7", "--records", "3"])
    rows = bench_common.over_seeds(lambda seed: {"seed": seed, "square": seed * seed}, args.first_seed,
                                   args.records, lambda row: f"square {row['square']}")
    assert [row["seed"] for row in rows] == [7, 8, 9]
    err = capsys.readouterr().err.splitlines()
    assert err == ["[1/3] seed 7: square 49", "[2/3] seed 8: square 64", "[3/3] seed 9: square 81"]
    assert bench_common.seed_arguments("x", 60).parse_args([]).records == 60


def test_first_record_only_gives_the_diagnosis_no_second_record(monkeypatch):
    import types

    import bench_common
    import pysim.diagnosis

    calls = []

    class Model:
        def __init__(self, error_pct):
            self.error_pct = error_pct

    def fake_diagnose(v, y, fs, validate=None):
        calls.append(validate)
        return types.SimpleNamespace(cause="none", causes=("none",), baseline=types.SimpleNamespace(model=Model(2.0)),
                                     extended=types.SimpleNamespace(model=Model(1.0)))

    monkeypatch.setattr(pysim.diagnosis, "diagnose", fake_diagnose)
    assert bench_common.seed_arguments("x", 5).parse_args(["--first-record-only"]).first_record_only
    assert not bench_common.seed_arguments("x", 5).parse_args([]).first_record_only
    first, second = ([0.0], [0.0], 1.0), ([1.0], [1.0], 1.0)
    for given, expected in ((second, second), (None, None)):
        row = {}
        bench_common.diagnose_and_score(row, first, given, "none", lambda model: model.error_pct)
        assert calls[-1] == expected
        assert row["outcome"] == "right" and row["third_extended_over_baseline"] == 0.5
