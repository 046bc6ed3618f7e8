"""Cross-compiling an FMU's C sources for each platform with zig (the
``ziglang`` PyPI package, run as ``python -m ziglang cc``).

Every binary is built from the single translation unit ``all.c`` against the
FMI 2.0 headers that fmpy ships.  Binaries are cached by a hash of everything
that goes into them (sources, headers, target, flags, zig version), so a
rebuild of an unchanged FMU does not compile again.
"""
from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from pysim.core.toolchain import zig_cc, zig_command
from pysim.fmu import macho
from pysim.fmu.errors import ToolchainError


@dataclass(frozen=True)
class Platform:
    """An FMI 2.0 platform folder and the zig targets that fill it."""

    name: str                 # binaries/<name>/
    suffix: str               # file name extension of the library
    targets: tuple            # zig target triples; several are merged (macOS)
    flags: tuple = ()         # flags for this platform only


PLATFORMS = {
    # glibc 2.17 (2012): loads on every common distribution of the last decade
    "linux64": Platform("linux64", ".so", ("x86_64-linux-gnu.2.17",)),
    "win64": Platform("win64", ".dll", ("x86_64-windows-gnu",)),
    # one universal library: fmpy on Apple silicon also loads darwin64.  Apple's
    # ABI keeps the frame pointer (stack walking relies on it).
    "darwin64": Platform("darwin64", ".dylib", ("x86_64-macos.10.13", "aarch64-macos.11.0"),
                         ("-fno-omit-frame-pointer",)),
}

# -fomit-frame-pointer: a few instructions less on the per-step path
FLAGS = ("-shared", "-std=c99", "-O2", "-s", "-fomit-frame-pointer", "-fvisibility=hidden",
         "-ffp-contract=off", "-Wall", "-Wextra", "-Werror")
FMI_HEADERS = ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h")


@lru_cache(maxsize=1)
def zig_version() -> str:
    try:
        result = subprocess.run(zig_command() + ["version"], capture_output=True, text=True)
    except OSError as exc:
        raise ToolchainError(f"cannot run zig: {exc}") from exc
    if result.returncode != 0:
        raise ToolchainError("zig is not available: install the PyPI package 'ziglang' "
                             f"({result.stderr.strip() or result.stdout.strip()})")
    return result.stdout.strip()


def fmi_include_dir() -> Path:
    """Folder with the FMI 2.0 C headers shipped by fmpy."""
    import fmpy

    folder = Path(fmpy.__file__).resolve().parent / "c-code"
    missing = [h for h in FMI_HEADERS if not (folder / h).is_file()]
    if missing:
        raise ToolchainError(f"fmpy at {folder.parent} ships no FMI 2.0 headers {missing}")
    return folder


def _cache_key(sources: dict, target: str, extra=()) -> str:
    digest = hashlib.sha256()
    for part in (zig_version(), target, *FLAGS, *extra):
        digest.update(part.encode() + b"\0")
    include = fmi_include_dir()
    for name in FMI_HEADERS:
        digest.update((include / name).read_bytes())
    for name in sorted(sources):
        digest.update(name.encode() + b"\0" + sources[name] + b"\0")
    return digest.hexdigest()[:32]


def compile_target(sources: dict, identifier: str, target: str, suffix: str, cache_dir=None,
                   extra_flags=()) -> tuple:
    """Compile ``sources`` (``{file name: bytes}``, with ``all.c``) into the
    shared library ``<identifier><suffix>`` for the zig ``target``.

    Returns ``(bytes, cached)``; ``cached`` tells whether it came from
    ``cache_dir`` (None: no cache).
    """
    filename = identifier + suffix
    cached = None
    if cache_dir is not None:
        cached = Path(cache_dir) / _cache_key(sources, target, extra_flags) / filename
        if cached.is_file():
            return cached.read_bytes(), True
    with tempfile.TemporaryDirectory(prefix="build-fmu-") as tmp:
        src, out = Path(tmp) / "sources", Path(tmp) / "out"
        src.mkdir()
        out.mkdir()
        for name, data in sources.items():
            (src / name).write_bytes(data)
        # run in out/ so that zig's side products (.lib, .pdb) stay there
        cmd = zig_cc() + ["-target", target, *FLAGS, *extra_flags, "-I", str(src),
                          "-I", str(fmi_include_dir()), str(src / "all.c"), "-o", str(out / filename)]
        result = subprocess.run(cmd, cwd=out, capture_output=True, text=True)
        if result.returncode != 0:
            raise ToolchainError(f"compiling {identifier} for {target} failed:\n"
                                 f"{(result.stderr or result.stdout).strip()}")
        data = (out / filename).read_bytes()
    if cached is not None:
        cached.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp_name = tempfile.mkstemp(dir=cached.parent, prefix=f".{filename}.")
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp_name, cached)       # atomic: concurrent builds see all or nothing
    return data, False


def build_binaries(jobs, cache_dir=None, progress=None) -> dict:
    """Compile several FMUs for several platforms, in parallel.

    Parameters
    ----------
    jobs : iterable of (identifier, sources, platform name)
    cache_dir : path or None
    progress : callable(str) or None

    Returns
    -------
    ``{(identifier, platform name): library bytes}``; darwin64 libraries are
    universal (every target of the platform merged).
    """
    jobs = list(jobs)
    tasks = [(ident, sources, name, target) for ident, sources, name in jobs
             for target in PLATFORMS[name].targets]
    zig_version()                           # fail early and clearly

    def run(task):
        ident, sources, name, target = task
        start = time.perf_counter()
        platform = PLATFORMS[name]
        data, hit = compile_target(sources, ident, target, platform.suffix, cache_dir, platform.flags)
        return data, "cached" if hit else f"{time.perf_counter() - start:.1f} s"

    workers = max(1, min(len(tasks), os.cpu_count() or 2))
    results = {}
    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = {pool.submit(run, task): task for task in tasks}
        for future in as_completed(futures):      # progress from this thread only
            ident, _sources, name, target = futures[future]
            data, how = future.result()
            results[(ident, name, target)] = data
            if progress:
                progress(f"compiled {ident} for {name} ({target}): {how}")
    out = {}
    for ident, _sources, name in jobs:
        parts = [results[(ident, name, target)] for target in PLATFORMS[name].targets]
        if len(parts) == 1:
            out[(ident, name)] = parts[0]
        else:
            out[(ident, name)] = macho.write_universal(parts)
            if progress:
                archs = " + ".join(macho.slices(out[(ident, name)]))
                progress(f"merged {ident} for {name} into one universal library ({archs})")
    return out
