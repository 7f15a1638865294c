"""The ``linflex`` command line: the top floor of the core, the one place joining all layers."""

from __future__ import annotations

import argparse
import sys

from ._version import __version__


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="linflex",
        description="Linearize, reduce and analyse flexible spacecraft models.",
    )
    parser.add_argument("--version", action="version", version=f"linflex {__version__}")
    return parser


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
