"""Benchmark: time to build the plant and inverse FMUs of the default model.

Three cases, each building both FMUs for the chosen platforms:

- cold: zig starts from an empty cache (``ZIG_GLOBAL_CACHE_DIR`` and
  ``ZIG_LOCAL_CACHE_DIR`` point into a fresh temporary folder, so zig also
  builds the C runtimes of every target: glibc stubs, MinGW, macOS) and the
  builder's own binary cache is bypassed;
- warm zig cache: the same again, zig's cache now filled, the builder's
  cache still bypassed (every file is compiled);
- warm: the builder's cache holds the binaries (nothing is compiled).

The per-target compile times of the cold build come from the builder's
progress lines.  Quick mode builds linux64 only.

    python benchmarks/bench_build.py [--quick] [--json]
"""
from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from bench_common import Row

ALL_PLATFORMS = ("linux64", "win64", "darwin64")
ZIG_CACHE_VARIABLES = ("ZIG_GLOBAL_CACHE_DIR", "ZIG_LOCAL_CACHE_DIR")


@contextmanager
def fresh_zig_cache(folder):
    """Point zig's global and local caches into ``folder`` (empty) for the
    duration, then restore the environment."""
    saved = {name: os.environ.get(name) for name in ZIG_CACHE_VARIABLES}
    try:
        for name in ZIG_CACHE_VARIABLES:
            path = Path(folder) / name.lower()
            path.mkdir(parents=True, exist_ok=True)
            os.environ[name] = str(path)
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _timed_build(model, out_dir, platforms, **options) -> tuple:
    from pysim.fmu import build_fmus

    lines = []
    start = time.perf_counter()
    build_fmus(model, out_dir, platforms=platforms, progress=lines.append, **options)
    return time.perf_counter() - start, lines


def compile_times(progress_lines) -> dict:
    """``{"<identifier> <target>": seconds}`` from the builder's progress lines."""
    out = {}
    for line in progress_lines:
        match = re.match(r"compiled (\S+) for \S+ \((\S+)\): ([\d.]+) s", line)
        if match:
            out[f"{match.group(1)} {match.group(2)}"] = float(match.group(3))
    return out


def measure(quick: bool = False, platforms=None, model=None) -> dict:
    from pysim.specs.default_mpi import MODEL

    model = MODEL if model is None else model
    platforms = tuple(platforms or (("linux64",) if quick else ALL_PLATFORMS))
    with tempfile.TemporaryDirectory(prefix="bench-build-") as tmp:
        tmp = Path(tmp)
        with fresh_zig_cache(tmp / "zig"):
            cold, cold_lines = _timed_build(model, tmp / "out", platforms, use_cache=False)
            zig_warm, _ = _timed_build(model, tmp / "out", platforms, use_cache=False)
            _timed_build(model, tmp / "out", platforms, cache_dir=tmp / "binaries")   # fills the cache
            warm, warm_lines = _timed_build(model, tmp / "out", platforms, cache_dir=tmp / "binaries")
    return {"platforms": list(platforms), "cold_s": cold, "zig_cache_warm_s": zig_warm, "warm_s": warm,
            "cold_compile_s": compile_times(cold_lines),
            "warm_all_cached": all("cached" in line for line in warm_lines if line.startswith("compiled"))}


def rows(result: dict) -> list:
    which = ", ".join(result["platforms"])
    slowest = max(result["cold_compile_s"].items(), key=lambda kv: kv[1], default=("", 0.0))
    return [
        Row("FMU build", f"cold ({which})", result["cold_s"], "s",
            note=f"empty zig cache, builder cache bypassed; slowest: {slowest[0]} {slowest[1]:.1f} s"),
        Row("FMU build", f"zig cache warm ({which})", result["zig_cache_warm_s"], "s",
            note="every file compiled"),
        Row("FMU build", f"warm ({which})", result["warm_s"], "s",
            note="binaries from the builder's cache" + ("" if result["warm_all_cached"] else " (NOT all cached)")),
    ]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="linux64 only")
    parser.add_argument("--json", action="store_true", help="print JSON")
    args = parser.parse_args(argv)
    result = measure(args.quick)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for row in rows(result):
            print(f"{row.name:<40} {row.value:8.2f} s   {row.note}")
        for name, seconds in sorted(result["cold_compile_s"].items(), key=lambda kv: -kv[1]):
            print(f"    cold compile {name:<60} {seconds:6.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
