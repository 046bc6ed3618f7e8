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

from pysim.data import MeasuredData, load_measured, save_measured
from pysim.errors import DataError


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    parser.add_argument("--limit", type=float, default=5.0, help="seconds allowed for the load")
    args = parser.parse_args(argv)

    rng = np.random.default_rng(0)
    t = np.arange(args.rows) / 5000.0
    record = MeasuredData(t, 150 * np.sin(2 * np.pi * t), rng.normal(0, 20, args.rows), source="bench")
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
        start = time.perf_counter()
        try:
            load_measured(path)
        except DataError as exc:
            message = str(exc)
        bad = time.perf_counter() - start

    print(f"{args.rows} rows: save {saved:.2f} s, load {loaded:.2f} s, "
          f"bad cell on the last line found in {bad:.2f} s")
    print(f"  message: {message.replace(folder, '<tmp>')}")
    if loaded > args.limit:
        print(f"FAIL: load took {loaded:.2f} s > {args.limit:.2f} s", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
