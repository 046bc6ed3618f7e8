"""Helpers for the robustness tests (misuse suite, memory checkers,
sanitizers, fuzzing): the FMUs of the default spec and their binaries, the
C test programs compiled for Linux and Windows, builds of the FMU sources with
AddressSanitizer and UndefinedBehaviorSanitizer, and wine."""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import zipfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from fmpy import read_model_description

from pysim.core.toolchain import zig_cc
from pysim.fmu.compile import FLAGS, PLATFORMS, fmi_include_dir
from pysim.testing.fmus import built_fmus, extracted, temporary_folder

TESTS = Path(__file__).resolve().parent
C_DIR = TESTS / "c"
FUZZ_DIR = TESTS / "fuzz"
KINDS = ("plant", "inverse")
ZIG = zig_cc()
WARNINGS = ["-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror"]
# Sanitized builds: every finding is fatal (no recovery), frames kept for reports.
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-g", "-O1"]
# The exact-arithmetic flag the FMU build uses (no fused multiply-adds).
FP_FLAGS = ["-ffp-contract=off"]


@dataclass(frozen=True)
class FmuPair:
    """The plant and inverse FMU of the default spec, unpacked."""

    folders: dict          # kind -> unpacked FMU folder
    guids: dict            # kind -> GUID
    identifiers: dict      # kind -> model identifier
    n_reals: int           # Real variables of each FMU (the same for both)
    fmus: dict             # kind -> .fmu path

    def library(self, kind: str, platform: str = "linux64") -> Path:
        return self.folders[kind] / "binaries" / platform / (self.identifiers[kind] + PLATFORMS[platform].suffix)

    def sources(self, kind: str) -> Path:
        return self.folders[kind] / "sources"

    def misuse_arguments(self, libraries: dict) -> list:
        """The driver's arguments after the mode: libraries and GUIDs, then N_REALS."""
        return [str(libraries["plant"]), self.guids["plant"], str(libraries["inverse"]), self.guids["inverse"],
                str(self.n_reals)]


@lru_cache(maxsize=None)
def fmu_pair() -> FmuPair:
    paths = built_fmus()
    folders, guids, identifiers, n_reals = {}, {}, {}, set()
    for kind in KINDS:
        folders[kind] = extracted(paths[kind])
        md = read_model_description(str(folders[kind]))
        guids[kind] = md.guid
        identifiers[kind] = md.coSimulation.modelIdentifier
        n_reals.add(sum(v.type == "Real" for v in md.modelVariables))
    assert len(n_reals) == 1, "plant and inverse must have the same Real variables"
    return FmuPair(folders, guids, identifiers, n_reals.pop(), dict(paths))


def compile_c(command, cwd) -> None:
    """Run a compiler; any warning (the flags make it an error) fails the test."""
    result = subprocess.run(command, cwd=cwd, capture_output=True, text=True)
    assert result.returncode == 0 and not result.stderr.strip(), " ".join(map(str, command)) + "\n" + result.stderr


@lru_cache(maxsize=None)
def misuse_driver(variant: str) -> Path:
    """tests/c/fmu_misuse.c compiled: "linux" (gcc, -O2 -g), "asan" (gcc with
    the sanitizers) or "windows" (zig, for wine)."""
    folder = temporary_folder(f"misuse-{variant}-")
    include = ["-I", str(fmi_include_dir()), "-I", str(C_DIR)]
    source = str(C_DIR / "fmu_misuse.c")
    if variant == "windows":
        out = folder / "fmu_misuse.exe"
        # the FMU build's flags, so zig reuses the MinGW runtime it built for the DLLs
        flags = [f for f in FLAGS if f != "-shared"] + list(PLATFORMS["win64"].flags) + ["-Wpedantic"]
        compile_c(ZIG + ["-target", "x86_64-windows-gnu"] + flags + include + [source, "-o", str(out)], folder)
        return out
    out = folder / "fmu_misuse"
    extra = SANITIZE if variant == "asan" else ["-O2", "-g"]
    compile_c(["gcc"] + WARNINGS + extra + include + [source, "-o", str(out), "-ldl"], folder)
    return out


@lru_cache(maxsize=None)
def sanitized_library(kind: str) -> Path:
    """The FMU's own sources/ (hand-written C plus its generated configuration)
    built as a Linux shared library with ASan + UBSan (gcc)."""
    pair = fmu_pair()
    folder = temporary_folder(f"asan-{kind}-")
    out = folder / (pair.identifiers[kind] + ".so")
    src = pair.sources(kind)
    include = ["-I", str(src), "-I", str(fmi_include_dir())]
    compile_c(["gcc"] + WARNINGS + SANITIZE + FP_FLAGS + ["-shared", "-fPIC"] + include
              + [str(src / "all.c"), "-o", str(out)], folder)
    return out


@lru_cache(maxsize=None)
def sanitized_fmu(kind: str) -> Path:
    """A copy of the FMU whose linux64 binary is the sanitized build."""
    pair = fmu_pair()
    original = pair.fmus[kind]
    out = temporary_folder(f"asan-fmu-{kind}-") / original.name
    member = f"binaries/linux64/{pair.identifiers[kind]}.so"
    with zipfile.ZipFile(original) as source, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as target:
        for item in source.infolist():
            data = sanitized_library(kind).read_bytes() if item.filename == member else source.read(item)
            target.writestr(item, data)
    return out


def asan_runtime() -> str:
    """gcc's AddressSanitizer runtime, to preload into a program that was not
    built with it (Python) before it loads a sanitized library."""
    path = subprocess.run(["gcc", "-print-file-name=libasan.so"], capture_output=True, text=True).stdout.strip()
    assert os.path.isabs(path) and os.path.exists(path), f"gcc has no AddressSanitizer runtime ({path!r})"
    return path


def sanitizer_findings(text: str) -> list:
    """Reports of AddressSanitizer, LeakSanitizer or UBSan in a program's output."""
    return [line for line in text.splitlines()
            if "ERROR: AddressSanitizer" in line or "ERROR: LeakSanitizer" in line or "runtime error:" in line]


@lru_cache(maxsize=None)
def wine() -> tuple:
    """(program, environment) to run Windows programs: wine with a throwaway prefix."""
    program = shutil.which("wine64") or shutil.which("wine")
    assert program, "wine is required for the Windows binaries (Debian packages wine, wine64)"
    env = dict(os.environ, WINEPREFIX=str(temporary_folder("wineprefix-")), WINEDEBUG="-all",
               WINEDLLOVERRIDES="mscoree,mshtml=")
    return program, env


CASE = re.compile(r"^case (?P<fmu>[^/\s]+)/(?P<name>\S+) expected=(?P<expected>\S+) got=(?P<got>\S+) "
                  r"logged=(?P<logged>yes|no|-) rule=(?P<rule>must-log|no-instance|may-log) (?P<result>ok|FAILED)$")
SUMMARY = re.compile(r"^(\d+) cases tried, (\d+) handled$")


def parse_cases(stdout: str) -> tuple:
    """(cases, tried, handled) from the misuse driver's output; cases are
    dicts keyed by the fields of a case line and its section, in the order run."""
    lines = stdout.replace("\r\n", "\n").splitlines()
    cases, section = [], None
    for line in lines:
        if line.startswith("# section "):
            section = line[len("# section "):]
        elif CASE.match(line):
            cases.append(dict(CASE.match(line).groupdict(), section=section))
    summaries = [m for m in map(SUMMARY.match, lines) if m]
    assert len(summaries) == 1, "the driver did not finish (no summary line):\n" + "\n".join(lines[-5:])
    return cases, int(summaries[0].group(1)), int(summaries[0].group(2))
