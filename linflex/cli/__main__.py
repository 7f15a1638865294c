"""``python -m linflex.cli``: the ``linflex`` command."""

import sys

from . import main

if __name__ == "__main__":
    sys.exit(main())
