"""The ``linflex`` command line: the top floor of the core, the one place joining all layers."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import signal
import sys
from pathlib import Path

from .._version import __version__
from ..system._files import raise_if_stop_requested
from ._boundary import EXIT_CODES, exit_status, stopping_on_signals

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
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"linflex {__version__}")
    parser.add_argument("--debug", action="store_true", help="show the traceback of bad input too (exit code 2)")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for register in _command_registrars():
        register(subparsers)
    for sub in subparsers.choices.values():
        # also after the command (linflex report --debug ...); SUPPRESS keeps the main parser's value
        sub.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                         help="show the traceback of bad input too (exit code 2)")
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
    """Entry point of the ``linflex`` console command; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        0 success, 1 the analysis found a problem (unstable loop, failed cases), 2 bad input
        (a message, no traceback unless ``--debug``), 3 internal error (with the traceback),
        130 / 143 interrupted by SIGINT / SIGTERM (see :mod:`linflex.cli._boundary`).
    """
    parser = build_parser()
    args = parser.parse_args(argv)  # argparse itself exits with 2 on bad options
    if getattr(args, "command", None) is None:
        parser.print_help()
        return 0
    args.argv = list(sys.argv[1:] if argv is None else argv)
    with stopping_on_signals():
        try:
            status = int(args.run(args) or 0)
            raise_if_stop_requested()  # a SIGTERM whose exception was lost on the way still stops with 143
            return status
        except KeyboardInterrupt as err:
            signum = getattr(err, "signum", signal.SIGINT)
            print(f"linflex {args.command}: stopped by {signal.Signals(signum).name}", file=sys.stderr)
            return 128 + int(signum)
        except BrokenPipeError:
            # the reader of stdout went away (``linflex report ... | head``): the work is done and
            # written; stop quietly, as command-line tools do (128 + SIGPIPE), without a traceback
            try:
                sys.stdout = open(os.devnull, "w")  # noqa: SIM115 -- Python flushes stdout at exit
            except OSError:
                pass
            return 128 + int(signal.SIGPIPE)
        except Exception as err:  # noqa: BLE001 -- the boundary: every error becomes exit code 2 or 3
            user_paths = [v for v in vars(args).values() if isinstance(v, Path)]
            return exit_status(args.command, err, debug=bool(getattr(args, "debug", False)), user_paths=user_paths)
