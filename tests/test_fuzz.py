"""Fuzzing the FMU C code with libFuzzer (Debian's clang), with AddressSanitizer
and UndefinedBehaviorSanitizer, for a bounded time: 0 crashes, 0 leaks.

Two targets (tests/fuzz/), each built for the plant and the inverse FMU from
the FMU's own sources/:
  fuzz_calls  the fuzz input is a program of FMI calls with their arguments on
              up to two instances (statuses, logging, finite outputs and
              freed memory are checked on every call);
  fuzz_state  fmi2DeSerializeFMUstate on arbitrary bytes and on mutations of
              a valid serialized state (with and without a repaired checksum),
              then the accepted states are used.
The four runs share the machine for ``PIEZO_FUZZ_SECONDS`` (default 20 s)
each.  They start from the small corpus committed in tests/fuzz/corpus/ and
write what they find to a temporary folder, never into the repository.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import time

import pytest
from robustness import FP_FLAGS, FUZZ_DIR, compile_c, fmu_pair

from pysim.fmu.compile import fmi_include_dir
from pysim.testing.fmus import temporary_folder

SECONDS = int(os.environ.get("PIEZO_FUZZ_SECONDS", "20"))
TARGETS = ("calls", "state")
KINDS = ("plant", "inverse")
FLAGS = ["-std=c99", "-g", "-O1", "-Wall", "-Wextra", "-Werror", "-fsanitize=fuzzer,address,undefined",
         "-fno-sanitize-recover=all"] + FP_FLAGS
MAX_LEN = {"calls": 2048, "state": 1024}


def _build(target: str, kind: str, folder) -> str:
    clang = shutil.which("clang")
    assert clang, "clang with libFuzzer is required (Debian packages clang, libclang-rt-14-dev)"
    out = folder / f"fuzz_{target}_{kind}"
    compile_c([clang] + FLAGS + ["-I", str(fmu_pair().sources(kind)), "-I", str(fmi_include_dir()),
                                 str(FUZZ_DIR / f"fuzz_{target}.c"), "-o", str(out)], folder)
    return str(out)


@pytest.fixture(scope="module")
def fuzz_runs():
    """Build the four fuzzers, run them side by side, collect their reports."""
    folder = temporary_folder("fuzz-")
    runs = {}
    for target in TARGETS:
        for kind in KINDS:
            work = folder / f"{target}-{kind}"
            (work / "found").mkdir(parents=True)
            (work / "artifacts").mkdir()
            command = [_build(target, kind, folder), f"-max_total_time={SECONDS}", "-timeout=10",
                       f"-max_len={MAX_LEN[target]}", "-rss_limit_mb=2048", "-print_final_stats=1",
                       f"-artifact_prefix={work / 'artifacts'}/", str(work / "found"),
                       str(FUZZ_DIR / "corpus" / target)]
            log = open(work / "log.txt", "w")
            runs[(target, kind)] = (subprocess.Popen(command, cwd=work, stdout=log, stderr=subprocess.STDOUT), log,
                                    work)
    deadline = time.monotonic() + SECONDS + 120
    results = {}
    for key, (process, log, work) in runs.items():
        try:
            code = process.wait(timeout=max(1.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            process.kill()
            code = process.wait()
        log.close()
        results[key] = (code, (work / "log.txt").read_text(errors="replace"), work)
    return results


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("target", TARGETS)
def test_fuzzer_finds_nothing(fuzz_runs, target, kind):
    code, log, work = fuzz_runs[(target, kind)]
    artifacts = sorted(p.name for p in (work / "artifacts").iterdir())
    assert code == 0 and not artifacts, f"exit code {code}, artifacts {artifacts}\n" + log[-6000:]
    assert "ERROR:" not in log and "fuzz check failed" not in log, log[-6000:]
    done = re.search(r"Done (\d+) runs in (\d+) second", log)
    assert done, log[-3000:]
    runs, seconds = int(done.group(1)), int(done.group(2))
    assert seconds >= SECONDS and runs >= 10_000, f"only {runs} runs in {seconds} s"
    # it started from the committed corpus and got further than it
    coverage = [int(c) for c in re.findall(r"cov: (\d+)", log)]
    inited = int(re.search(r"INITED cov: (\d+)", log).group(1))
    assert max(coverage) > inited > 0
    print(f"fuzz_{target} on the {kind}: {runs} runs in {seconds} s, coverage {inited} -> {max(coverage)} edges")


def test_committed_corpus_is_small():
    for target in TARGETS:
        seeds = sorted((FUZZ_DIR / "corpus" / target).iterdir())
        assert 3 <= len(seeds) <= 8 and all(p.stat().st_size <= 1024 for p in seeds), seeds
