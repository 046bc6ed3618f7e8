"""``build-fmu SPEC [-o DIR] [--platforms ...]``: the command-line front end
of :func:`pysim.fmu.build_fmus`."""
from __future__ import annotations

import argparse
import sys

from pysim.core.errors import PiezoMPIError
from pysim.fmu import DEFAULT_PLATFORMS, PLATFORMS, ToolchainError, build_fmus


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="build-fmu",
        description="Build the FMI 2.0 co-simulation FMUs of a hysteresis model spec: "
                    "<name>_plant.fmu (voltage in V -> displacement in um) and "
                    "<name>_inverse.fmu (displacement_ref in um -> voltage in V).  For an extended spec "
                    "(written by pysim diagnose --out) the plant includes the output stages and steps at the "
                    "spec's sample period only; the inverse compensates the hysteresis part alone.")
    parser.add_argument("spec", help="spec file (.py defining MODEL), module, or name of a shipped spec (default_mpi)")
    parser.add_argument("-o", "--output", default=".", metavar="DIR", help="folder for the FMUs (default: .)")
    parser.add_argument("--platforms", nargs="+", default=list(DEFAULT_PLATFORMS), choices=sorted(PLATFORMS),
                        metavar="PLATFORM",
                        help=f"binaries to build (default: all of {', '.join(DEFAULT_PLATFORMS)})")
    parser.add_argument("--kinds", nargs="+", default=["plant", "inverse"], choices=["plant", "inverse"],
                        help="which FMUs to build (default both); a plant alone builds from a model whose "
                             "inverse does not exist")
    parser.add_argument("--without-input-stage", action="store_true",
                        help="for a spec whose MODEL has a stage before the hysteresis (an input low-pass or a "
                             "slew limit, which pysim diagnose --out writes when it names one): build the FMUs of "
                             "the part after the stage (an FMU cannot hold it; without this option such a spec "
                             "is refused)")
    parser.add_argument("--no-cache", action="store_true", help="compile everything again")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    progress = None if args.quiet else (lambda message: print(f"build-fmu: {message}", flush=True))
    try:
        build_fmus(args.spec, args.output, args.platforms, use_cache=not args.no_cache, progress=progress,
                   kinds=args.kinds, without_input_stage=args.without_input_stage)
    except ToolchainError as exc:
        print(f"build-fmu: error: {exc}", file=sys.stderr)
        return 1
    except PiezoMPIError as exc:
        print(f"build-fmu: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("build-fmu: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
