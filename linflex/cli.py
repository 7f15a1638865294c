"""The ``linflex`` command line: the top floor of the core, the one place joining all layers."""

from __future__ import annotations

import argparse
import importlib
import sys

from ._version import __version__

# Modules defining one subcommand each through register(subparsers); the handler is set with
# parser.set_defaults(run=handler) and returns the exit status.
COMMAND_MODULES = ("._cli_simulate", "._cli_report", "._cli_sweep", "._cli_bench")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="linflex",
        description="Linearize, reduce and analyse flexible spacecraft models.",
    )
    parser.add_argument("--version", action="version", version=f"linflex {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in _command_registrars():
        register(subparsers)
    return parser


def _command_registrars():
    """``register(subparsers)`` of each command module, in the order they appear in help."""
    registrars = []
    for module in COMMAND_MODULES:
        try:
            registrars.append(importlib.import_module(module, __package__).register)
        except ModuleNotFoundError as err:
            if err.name != f"{__package__}{module}":
                raise
    return registrars


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``linflex`` console command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "command", None) is None:
        parser.print_help()
        return 0
    return int(args.run(args) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
