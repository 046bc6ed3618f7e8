"""``pysim``: the command-line entry point.

Each subcommand lives in ``pysim/commands/<name>.py`` and defines
``register(subparsers)``, which adds its parser and sets ``func`` (called with
the parsed arguments; returns an exit code or None).  Bad input raises
:class:`pysim.errors.UserError`; it is reported as one line on stderr with exit
code 2.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from pysim.errors import UserError

COMMANDS = ("identify", "demo", "track", "bandwidth", "diagnose")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pysim",
        description="Piezo hysteresis (modified Prandtl-Ishlinskii) identification, FMU co-simulation and diagnosis.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"pysim.commands.{name}")
        except ModuleNotFoundError as exc:
            if exc.name != f"pysim.commands.{name}":
                raise
            continue  # command not available in this build
        module.register(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code = args.func(args)
    except UserError as exc:
        print(f"pysim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"pysim {args.command}: interrupted", file=sys.stderr)
        return 130
    return int(code or 0)


if __name__ == "__main__":
    sys.exit(main())
