"""The ``linflex`` command line: the top floor of the core, the one place joining all layers."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path

from .._version import __version__

# Modules defining one subcommand each through register(subparsers); the handler is set with
# parser.set_defaults(run=handler) and returns the exit status.
COMMAND_MODULES = ("._simulate", "._report", "._sweep")

#: ``linflex bench`` lives in the source checkout (``benchmarks/_bench.py``), not in the installed
#: package: the command exists when linflex is installed from a checkout that has it.
BENCH_TOOL = Path(__file__).resolve().parents[2] / "benchmarks" / "_bench.py"


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
    bench = bench_tool()
    if bench is not None:
        registrars.append(bench.register)
    return registrars


def bench_tool():
    """The checkout's benchmark tool module (``benchmarks/_bench.py``), or None outside a checkout.

    Returns
    -------
    module or None
        The loaded module (its ``register(subparsers)`` adds ``linflex bench``).
    """
    if not BENCH_TOOL.is_file():
        return None
    module = sys.modules.get("linflex_bench")
    if module is None:
        spec = importlib.util.spec_from_file_location("linflex_bench", BENCH_TOOL)
        module = importlib.util.module_from_spec(spec)
        sys.modules["linflex_bench"] = module
        spec.loader.exec_module(module)
    return module


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``linflex`` console command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "command", None) is None:
        parser.print_help()
        return 0
    return int(args.run(args) or 0)
