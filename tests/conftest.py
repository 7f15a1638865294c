"""Test-wide settings."""

import os

import pytest
from hypothesis import settings

# Hypothesis draws the same examples on every run ("fixed", the default: the README's test command
# and CI give the same verdict each time) or new ones ("LINFLEX_HYPOTHESIS=explore": a developer's
# search for the cases between the examples; a failing draw found that way is fixed and pinned as
# an @example or a test of its own, as tests/frequency/test_engine.py and
# tests/stability/test_hidden_modes.py do).
settings.register_profile("fixed", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("LINFLEX_HYPOTHESIS", "fixed"))


@pytest.fixture(autouse=True)
def _one_blas_thread():
    """Pin BLAS to one thread: on the 2-core machine a second BLAS thread competing with other
    processes makes small dense problems several times slower (measured: 166 s against 20 s for
    tests/frequency). Results do not depend on it."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        yield
        return
    with threadpool_limits(limits=1, user_api="blas"):
        yield


# The files whose tests take longest (seconds of one test: the benchmarks' smoke runs 5-25, the
# notebooks 4-14, the killed-report CLI tests 7-10): run first, so that pytest-xdist's workers
# share them and finish together, instead of one worker ending the suite alone on them.
LONGEST_FIRST = ("tests/test_benchmarks.py", "tests/test_examples.py", "tests/test_cli.py", "tests/test_readme.py")


def pytest_collection_modifyitems(config, items):
    """Tests marked ``long`` (the property corpus's long runs) are deselected, not skipped, unless
    ``LINFLEX_SLOW=1``: ``LINFLEX_SLOW=1 pytest -m long`` runs them. The files of
    :data:`LONGEST_FIRST` go first (a stable sort: every file keeps its own order)."""
    if os.environ.get("LINFLEX_SLOW") != "1":
        kept = [item for item in items if item.get_closest_marker("long") is None]
        if len(kept) != len(items):
            config.hook.pytest_deselected(items=[item for item in items if item.get_closest_marker("long")])
            items[:] = kept
    items.sort(key=lambda item: item.nodeid.split("::")[0] not in LONGEST_FIRST)
