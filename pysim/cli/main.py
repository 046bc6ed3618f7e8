"""``pysim``: the command-line entry point.

Each subcommand lives in ``pysim/cli/commands/<name>.py`` and defines
``register(subparsers)``, which adds its parser and sets ``func`` (called with
the parsed arguments; returns an exit code or None).  The commands are imported
by name here, so a command missing from an installation fails at once instead
of vanishing from the help.  An error of any layer
(:class:`pysim.core.errors.PiezoMPIError`) is reported as one line on stderr
with exit code 2; a missing or failing compiler with exit code 1.
"""
from __future__ import annotations

import argparse
import sys

from pysim.cli.commands import bandwidth, demo, diagnose, excite, identify, track
from pysim.core.errors import PiezoMPIError
from pysim.fmu.errors import ToolchainError

COMMANDS = {"identify": identify, "demo": demo, "track": track, "bandwidth": bandwidth, "diagnose": diagnose,
            "excite": excite}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pysim",
        description="Piezo hysteresis (modified Prandtl-Ishlinskii) identification, FMU co-simulation and diagnosis.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for module in COMMANDS.values():
        module.register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = args.func(args)
    except ToolchainError as exc:
        print(f"pysim {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except PiezoMPIError as exc:
        print(f"pysim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"pysim {args.command}: interrupted", file=sys.stderr)
        return 130
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
