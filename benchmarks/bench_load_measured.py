"""Benchmark: load and save a 1,000,000-row measured-data CSV.

Target: loading takes a few seconds at most (``--limit``, default 5 s).  Also
times the careful line-by-line scan that finds the line of a bad cell at the
end of the file, which is the slow case of the loader.

    python benchmarks/bench_load_measured.py [--rows N] [--limit SECONDS]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_common import Row, at_most

from pysim.identification.errors import DataError
from pysim.identification.data import MeasuredData, load_measured, save_measured

LOAD_LIMIT_S = 5.0


def measure(rows: int = 1_000_000) -> dict:
    """Seconds to save and load a ``rows``-row record, and to find a bad cell
    on its last line; ``message`` is the loader's error for that cell."""
    rng = np.random.default_rng(0)
    t = np.arange(rows) / 5000.0
    record = MeasuredData(t, 150 * np.sin(2 * np.pi * t), rng.normal(0, 20, rows), source="bench")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "big.csv"
        start = time.perf_counter()
        save_measured(record, path)
        saved = time.perf_counter() - start

        start = time.perf_counter()
        data = load_measured(path)
        loaded = time.perf_counter() - start
        assert np.array_equal(data.displacement_um, record.displacement_um)

        with open(path, "a") as handle:
            handle.write(f"{float(t[-1]) + 1!r},oops,0\n")
        message = "(no error raised)"
        start = time.perf_counter()
        try:
            load_measured(path)
        except DataError as exc:
            message = str(exc).replace(folder, "<tmp>")
        bad = time.perf_counter() - start
    return {"rows": rows, "save_s": saved, "load_s": loaded, "bad_cell_s": bad, "message": message}


def rows_of(result: dict, limit: float = LOAD_LIMIT_S) -> list:
    """Table rows; the load limit scales with the row count (5 s per million)."""
    allowed = limit * result["rows"] / 1_000_000
    target, met = at_most(result["load_s"], allowed, "s")
    return [
        Row("Measured data", f"load {result['rows']} rows", result["load_s"], "s", target, met),
        Row("Measured data", f"save {result['rows']} rows", result["save_s"], "s"),
        Row("Measured data", "bad cell on the last line found", result["bad_cell_s"], "s"),
    ]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--limit", type=float, default=LOAD_LIMIT_S, help="seconds allowed for the load")
    args = parser.parse_args(argv)

    result = measure(args.rows)
    print(f"{args.rows} rows: save {result['save_s']:.2f} s, load {result['load_s']:.2f} s, "
          f"bad cell on the last line found in {result['bad_cell_s']:.2f} s")
    print(f"  message: {result['message']}")
    if result["load_s"] > args.limit:
        print(f"FAIL: load took {result['load_s']:.2f} s > {args.limit:.2f} s", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
