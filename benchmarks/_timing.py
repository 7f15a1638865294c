"""Shared by the benchmark scripts: one BLAS thread, and median wall times.

Import this module before numpy (``import _timing`` at the top of a script, followed by
``# isort: split``): BLAS reads its thread count when it loads, and benchmarks compare medians
measured in the same run with one thread each (ARCHITECTURE.md, numerics policy).
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import statistics  # noqa: E402
import time  # noqa: E402


def median_time(fn, repeats: int):
    """``(median seconds, last result)`` of ``repeats`` calls of ``fn()``."""
    times, result = [], None
    for _ in range(max(1, int(repeats))):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def median_cpu_time(fn, repeats: int):
    """``(median CPU seconds of this process, last result)`` of ``repeats`` calls of ``fn()``: on a
    shared, loaded machine the process's CPU time is what an idle machine's wall time would be
    (one BLAS thread, so no other thread of the process adds to it)."""
    times, result = [], None
    for _ in range(max(1, int(repeats))):
        start = time.process_time()
        result = fn()
        times.append(time.process_time() - start)
    return statistics.median(times), result
