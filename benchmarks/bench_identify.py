"""Benchmark: identification by exact constrained least squares (ours)
against particle swarm optimisation (the paper's method, with pyswarms).

Both minimise the same objective on the same samples: the sum of squared
errors of the MPI model with the eq. 13 thresholds (10 one-sided play
operators, input shifted to the bottom of the record's range) over the fit
samples that :func:`pysim.identification.identify.identify` uses (after its warm-up).  The
12 unknowns are a1, a2, the weights of the nine operators with r > 0 (the
r = 0 operator equals its input, so its weight lives in a2) and the output
offset.  PSO runs in three variants:

- ``simulate``: every particle is evaluated by simulating the model with its
  parameters through the C kernel, as the paper's identification does;
- ``regressors``: every swarm is evaluated with the operator outputs
  precomputed once (the model is linear in the parameters), one matrix
  product per iteration;
- ``gram``: the sum of squares from the precomputed Gram matrix, a cost per
  particle independent of the record length -- the fastest PSO can be on
  this problem (context: it uses the very structure our solver exploits).

The time of each variant includes what it precomputes.

PSO searches a box derived from the data's scales only (mean gain, input
span, output range; see :func:`pso_bounds`), in coordinates scaled to
[-1, 1].  Reported: time, RMS and max error (% of the displacement range) for
both methods on the shipped measured data and on synthetic data, and our time
against the record length (10k, 100k, 1M samples).
Target: >= 1000x faster with an error no larger than PSO's.

    python benchmarks/bench_identify.py [--quick] [--json]
"""
from __future__ import annotations

import argparse
import ctypes
import json
import logging
import sys
import time

import numpy as np
from bench_common import Row, at_least, spread, timings

N_OPERATORS = 10
# Clerc & Kennedy's constriction coefficients, the usual recommendation for
# global-best PSO (they beat pyswarms' example values w=0.9, c1=0.5, c2=0.3 on
# these problems).
PSO_OPTIONS = {"c1": 1.49618, "c2": 1.49618, "w": 0.7298}
PSO_BUDGET = {"quick": (30, 200, 1), "full": (50, 500, 3)}   # particles, iterations, seeds
RECORD_LENGTHS = (10_000, 100_000, 1_000_000)
VARIANTS = ("simulate", "regressors", "gram")
TARGET_VARIANTS = ("simulate", "regressors")     # the target is checked against these
SPEED_TARGET = 1000.0


# ------------------------------------------------------------------ data
def synthetic_record(n_samples: int, noise_um: float = 0.05, samples_per_period: int = 500, seed: int = 0):
    """Voltage (V) and displacement (µm) of the default model.

    The input first sweeps the full voltage range once (0 V -> 150 V -> 0 V,
    a cosine), then follows two cosines whose amplitude decays from the full
    range to a fifth of it (major and minor loops).  White noise of
    ``noise_um`` is added to the displacement.  The record spans exactly the
    model's voltage range, so eq. 13 over the record gives the model's own
    thresholds.
    """
    from pysim.specs.default_mpi import MODEL

    t = np.arange(n_samples) / samples_per_period
    lo, hi = MODEL.voltage_range_V
    amplitude = 1.0 - 0.8 * np.arange(n_samples) / max(n_samples - 1, 1)
    shape = amplitude * (0.8 * np.cos(2 * np.pi * t) + 0.2 * np.cos(2 * np.pi * 5.3 * t))
    shape[t < 1.0] = np.cos(2 * np.pi * t[t < 1.0])
    voltage = lo + (hi - lo) * 0.5 * (1.0 - shape)
    displacement = MODEL.simulate(voltage)
    if noise_um > 0:
        displacement = displacement + np.random.default_rng(seed).normal(0.0, noise_um, n_samples)
    return voltage, displacement


def datasets() -> dict:
    """``{name: (voltage_V, displacement_um)}``: the shipped records and a
    synthetic one."""
    from pysim.identification.data import SHIPPED_DATASETS, load_measured, shipped_dataset

    out = {}
    for name in sorted(SHIPPED_DATASETS):
        record = load_measured(shipped_dataset(name))
        out[name] = (record.voltage_V, record.displacement_um)
    out["synthetic_20k"] = synthetic_record(20_000)
    return out


# ------------------------------------------------------------- the problem
class Problem:
    """The identification problem of one record, in the form PSO sees it.

    Parameters
    ----------
    voltage_V, displacement_um : ndarray
    fit_slice : slice
        The samples the objective sums over.
    voltage_range_V : (float, float), optional
        The range the thresholds (eq. 13) and the input shift come from
        (default: the whole record's; identification uses the fitted samples').
    """

    def __init__(self, voltage_V, displacement_um, fit_slice: slice, voltage_range_V=None):
        from pysim.core import kernel as _kernel
        from pysim.core.model import OPERATOR_KINDS, eq13_thresholds
        from pysim.identification.identify import regressors

        self.v = _kernel.contiguous(voltage_V)
        self.y = np.asarray(displacement_um, dtype=float)
        self.fit = fit_slice
        lo, hi = (float(self.v.min()), float(self.v.max())) if voltage_range_V is None else voltage_range_V
        self.input_offset = lo
        self.thresholds = _kernel.contiguous(eq13_thresholds(N_OPERATORS, hi - lo))
        # what the linear-structure variants precompute, timed as part of them
        start = time.perf_counter()
        A, columns = regressors(self.v, self.thresholds, "osp", lo, cubic=True)
        self.A_fit = np.ascontiguousarray(A[fit_slice])
        self.y_fit = self.y[fit_slice]
        regressors_s = time.perf_counter() - start
        self.gram = self.A_fit.T @ self.A_fit
        self.moment = self.A_fit.T @ self.y_fit
        self.y_squared = float(self.y_fit @ self.y_fit)
        self.setup_s = {"simulate": 0.0, "regressors": regressors_s, "gram": time.perf_counter() - start}
        self.operator_columns = [c for c in columns if c >= 0]   # θ indices of b_2 .. b_n
        self.dimensions = A.shape[1]
        self._residuals = {}
        # the kernel's model structure, reused for every particle
        self._weights = np.zeros(N_OPERATORS)
        self._state = np.zeros(N_OPERATORS)
        self._output = np.empty_like(self.v)
        self._model = _kernel.HystModel(OPERATOR_KINDS["osp"], N_OPERATORS, 0.0, 0.0, lo, 0.0,
                                        _kernel.as_pointer(self.thresholds), _kernel.as_pointer(self._weights))
        self._simulate = _kernel.library().hyst_simulate
        self._pointers = [_kernel.as_pointer(a) for a in (self.v, self._state, self._output)]
        self.center, self.half_width = pso_bounds(self.v, self.y, fit_slice)

    def theta(self, z):
        """Physical parameters ``(a1, a2, b_2..b_n, offset)`` of scaled ``z``."""
        return self.center + self.half_width * np.asarray(z)

    def cost_by_regressors(self, z) -> np.ndarray:
        """Sum of squared errors of each particle (rows of ``z``), µm²: one
        matrix product per swarm, into a buffer kept between calls."""
        theta = self.theta(z)
        residual = self._residuals.get(len(theta))
        if residual is None:
            residual = self._residuals[len(theta)] = np.empty((self.y_fit.size, len(theta)))
        np.matmul(self.A_fit, theta.T, out=residual)
        residual -= self.y_fit[:, None]
        return np.einsum("ij,ij->j", residual, residual)

    def cost_by_gram(self, z) -> np.ndarray:
        """The same sum from the Gram matrix: ``θᵀ AᵀA θ − 2 θᵀ Aᵀy + yᵀy``,
        independent of the record length."""
        theta = self.theta(z)
        return np.einsum("ij,ij->i", theta @ self.gram, theta) - 2.0 * theta @ self.moment + self.y_squared

    def simulate(self, theta) -> np.ndarray:
        """Model output (µm) over the whole record from the demagnetised state."""
        m = self._model
        m.a1, m.a2, m.output_offset = theta[0], theta[1], theta[-1]
        self._weights[1:] = theta[self.operator_columns]
        self._state[:] = 0.0
        self._simulate(ctypes.byref(m), self.v.size, *self._pointers, None)
        return self._output

    def cost_by_simulation(self, z) -> np.ndarray:
        """As :meth:`cost_by_regressors`, simulating the model per particle."""
        out = np.empty(len(z))
        for i, theta in enumerate(self.theta(z)):
            residual = self.simulate(theta)[self.fit] - self.y_fit
            out[i] = residual @ residual
        return out

    def errors(self, theta) -> dict:
        from pysim.core.metrics import error_measures

        return error_measures(self.y_fit, self.A_fit @ theta)


def pso_bounds(voltage_V, displacement_um, fit_slice) -> tuple:
    """Centre and half width of PSO's search box, from the data's scales only.

    With g the mean gain (displacement range / voltage range, µm/V) and U the
    voltage span (V): a2 and every weight within ±2 g (one alone could make
    the whole loop twice as steep), a1 within ±2 g / U² (the cubic term alone
    could then make it twice as steep over the range), the offset within the
    displacement range widened by half of it on each side.
    """
    y = np.asarray(displacement_um)[fit_slice]
    span_v = float(np.ptp(voltage_V))
    span_y = float(np.ptp(y))
    g = span_y / span_v
    center = np.zeros(2 + (N_OPERATORS - 1) + 1)
    half = np.full_like(center, 2.0 * g)
    half[0] = 2.0 * g / span_v**2
    center[-1] = 0.5 * (float(y.min()) + float(y.max()))
    half[-1] = span_y
    return center, half


# ------------------------------------------------------------------- runs
def ours(voltage_V, displacement_um, repeat: int) -> dict:
    """Our identification of the paper's problem (demagnetised start, the
    samples after the input has visited both ends of its range): the result
    and its timings.  The default ``identify`` also estimates the operator
    state at the first sample and fits every sample, a problem PSO is not
    given here; its time is reported beside (``with_state``)."""
    from pysim.identification.identify import auto_warmup, identify

    warmup = auto_warmup(voltage_V)
    result = identify(voltage_V, displacement_um, n_operators=N_OPERATORS, warmup=warmup)
    times = timings(lambda: identify(voltage_V, displacement_um, n_operators=N_OPERATORS, warmup=warmup), repeat)
    with_state = timings(lambda: identify(voltage_V, displacement_um, n_operators=N_OPERATORS), max(repeat // 3, 1))
    return {"result": result, "times": spread(times), "with_state": spread(with_state)}


def pso(problem: Problem, variant: str, particles: int, iterations: int, seed: int) -> dict:
    """One PSO run: its time (s, with what the variant precomputes), best
    objective (µm²), errors of the best particle and the number of particle
    evaluations."""
    import pyswarms

    logging.getLogger("pyswarms").setLevel(logging.ERROR)
    evaluate = {"simulate": problem.cost_by_simulation, "regressors": problem.cost_by_regressors,
                "gram": problem.cost_by_gram}[variant]
    evaluations = [0]

    def cost(z):
        evaluations[0] += len(z)
        return evaluate(z)

    ones = np.ones(problem.dimensions)
    np.random.seed(seed)                  # pyswarms draws from numpy's global generator
    optimizer = pyswarms.single.GlobalBestPSO(particles, problem.dimensions, options=dict(PSO_OPTIONS),
                                              bounds=(-ones, ones), velocity_clamp=(-0.5, 0.5))
    start = time.perf_counter()
    best_cost, best_z = optimizer.optimize(cost, iters=iterations, verbose=False)
    elapsed = time.perf_counter() - start + problem.setup_s[variant]
    theta = problem.theta(best_z)
    return {"time_s": elapsed, "objective": float(best_cost), "errors": problem.errors(theta),
            "evaluations": evaluations[0]}


def compare(name, voltage_V, displacement_um, particles, iterations, seeds, repeat) -> dict:
    """Ours against both PSO variants on one record."""
    mine = ours(voltage_V, displacement_um, repeat)
    result = mine["result"]
    problem = Problem(voltage_V, displacement_um, result.fit_slice, result.model.voltage_range_V)
    theta = np.concatenate(([result.model.a1, result.model.a2],
                            np.asarray(result.model.weights_um_per_V)[1:], [result.model.output_offset_um]))
    z_ours = (theta - problem.center) / problem.half_width
    # our optimum must be reachable by PSO, or the comparison is unfair to it
    inside = bool(np.all(np.abs(z_ours) <= 1.0))
    # both objectives agree: the simulation path reproduces our prediction
    check = problem.simulate(theta)[problem.fit] - result.prediction_um[problem.fit]
    assert np.max(np.abs(check)) <= 1e-9 * max(1.0, float(np.max(np.abs(problem.y_fit)))), name
    runs = {variant: [pso(problem, variant, particles, iterations, seed) for seed in range(seeds)]
            for variant in VARIANTS}
    return {
        "samples": int(np.size(voltage_V)), "fit_samples": int(problem.y_fit.size),
        "ours": {"times": mine["times"], "with_state": mine["with_state"], "objective": result.objective,
                 "errors": result.errors,
                 "constraints_active": result.constraints_active},
        "optimum_inside_pso_box": inside, "max_abs_scaled_coordinate": float(np.max(np.abs(z_ours))),
        "pso": {variant: {
            "runs": r,
            "time_s": spread([x["time_s"] for x in r]),
            "best_objective": min(x["objective"] for x in r),
            "rms_error_pct": [x["errors"]["rms_error_pct"] for x in r],
            "max_error_pct": [x["errors"]["max_error_pct"] for x in r],
        } for variant, r in runs.items()},
    }


def scaling(lengths, repeat: int) -> dict:
    """Our identification time (s) against the record length (synthetic), the
    paper's problem (after the warm-up, demagnetised start)."""
    from pysim.identification.identify import auto_warmup, identify

    out = {}
    for n in lengths:
        v, y = synthetic_record(n)
        warmup = auto_warmup(v)
        out[n] = spread(timings(lambda: identify(v, y, n_operators=N_OPERATORS, warmup=warmup),
                                repeat if n < 10**6 else 3))
    return out


def measure(quick: bool = False, lengths=RECORD_LENGTHS, records=None) -> dict:
    particles, iterations, seeds = PSO_BUDGET["quick" if quick else "full"]
    repeat = 5 if quick else 11
    records = datasets() if records is None else records
    return {
        "pso_budget": {"particles": particles, "iterations": iterations, "seeds": seeds, "options": PSO_OPTIONS},
        "records": {name: compare(name, v, y, particles, iterations, seeds, repeat)
                    for name, (v, y) in records.items()},
        "scaling": scaling(lengths, repeat),
    }


def rows(result: dict) -> list:
    out = []
    budget = result["pso_budget"]
    full = PSO_BUDGET["full"]
    small = budget["particles"] * budget["iterations"] < full[0] * full[1]
    caveat = (f"PSO budget {budget['particles']}x{budget['iterations']} (full run: {full[0]}x{full[1]}), "
              "so ratios are lower; " if small else "")
    for name, r in result["records"].items():
        t_ours = r["ours"]["times"]["median_s"]
        rms, mx = r["ours"]["errors"]["rms_error_pct"], r["ours"]["errors"]["max_error_pct"]
        out.append(Row("Identification", f"{name}: ours", t_ours * 1e3, "ms", "", None,
                       f"RMS {rms:.3f} %, max {mx:.3f} %, {r['fit_samples']} fit samples; with the initial "
                       f"state estimated on every sample {r['ours']['with_state']['median_s'] * 1e3:.0f} ms"
                       + ("" if r["optimum_inside_pso_box"] else "; OPTIMUM OUTSIDE PSO BOX")))
        for variant, p in r["pso"].items():
            t_pso = p["time_s"]["median_s"]
            ratio = t_pso / t_ours
            no_worse = r["ours"]["objective"] <= p["best_objective"] * (1 + 1e-12)
            target, met = at_least(ratio, SPEED_TARGET, "x")
            target, met = (target + ", error <= PSO's", met and no_worse) if variant in TARGET_VARIANTS else ("", None)
            out.append(Row("Identification", f"{name}: PSO ({variant}) / ours", ratio, "x", target, met,
                           f"{caveat}PSO {t_pso:.2f} s, RMS {min(p['rms_error_pct']):.3f}..{max(p['rms_error_pct']):.3f} %, "
                           f"max {min(p['max_error_pct']):.3f}..{max(p['max_error_pct']):.3f} %; our error "
                           f"{'no larger' if no_worse else 'LARGER'}"))
    for n, t in result["scaling"].items():
        out.append(Row("Identification", f"ours, synthetic record of {n} samples", t["median_s"] * 1e3, "ms",
                       note=f"best {t['best_s'] * 1e3:.1f}, worst {t['worst_s'] * 1e3:.1f} ms"))
    return out


def json_ready(result: dict) -> dict:
    """``result`` with only JSON types (record-length keys become strings)."""
    return json.loads(json.dumps(result, default=str))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller PSO budget, one seed")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    result = measure(args.quick)
    if args.json:
        print(json.dumps(json_ready(result), indent=2))
        return 0
    for row in rows(result):
        print(f"{row.name:<48} {row.value:12.3f} {row.unit:<4} {row.target:<28} "
              f"{'' if row.met is None else ('met' if row.met else 'MISSED'):<7} {row.note}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
