"""Test-wide settings."""

import pytest


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
