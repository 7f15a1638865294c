"""``python -m benchmarks [--quick] [--only NAME ...]``: the same as ``linflex bench``."""

import sys

from linflex.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
