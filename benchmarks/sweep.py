"""Margin sweeps: compiling every case against compiling once, serial, in processes and on Dask.

The sweep is ``examples/spacecraft_arrays_sweep.toml`` on ``examples/spacecraft_arrays.toml``:
200 Monte Carlo cases (hub inertias and array stiffness; seed 2026), each trimming, linearizing
(Kane's direct linearization), closing the three attitude loops and computing the margins of the
summary (``linflex.stability.report.margin_summary``: each loop's gain, phase and delay margins,
the multi-loop disk margin, closed-loop damping). "compile per case" builds the plant's graph for
every case (``sweep(..., compile_once=False)``, the behaviour before issue 20); "compile once"
builds it once per structure of the sweep and process, the varied numbers as parameters of the
graph. The serial compile-once run takes all 200 cases (issue 20's target: under 30 s of CPU
time, the structures' compilations included); the per-case baseline, the process pool and the
Dask runs take the first ``SUBSET`` cases (the ``cases`` column), and every comparison is per
case on the cases both runs share. The table gives each run's wall time and, for the serial
runs, the CPU time of this process (what an idle machine's wall time would be; the machine may
be loaded), the speed-up in time per case over the per-case serial run (CPU time for the serial
runs, wall time for the others), and the largest relative difference of its results from the
per-case run (round-off: same equations). The Dask clusters are ``LocalCluster`` s with
single-threaded worker processes (1, then one per core); their start-up time is listed
separately.

Run: ``.venv/bin/python benchmarks/sweep.py`` (``--quick``: 8 cases of the rigid
``examples/attitude_control.toml`` in every run).
"""

from __future__ import annotations

import _timing  # noqa: F401  (one BLAS thread: before numpy)

# isort: split

import argparse  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from linflex import load_scene, parameter_sample, sweep  # noqa: E402
from linflex.stability.report import margin_summary  # noqa: E402
from linflex.sweeps import load_sweep_spec  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def largest_difference(a, b) -> float:
    """Largest relative difference of two result tables (equal infinities and nans count as equal)."""
    same = (a == b) | (np.isnan(a) & np.isnan(b))
    with np.errstate(invalid="ignore"):
        diff = np.where(same, 0.0, np.abs(a - b) / np.maximum(np.abs(b), 1e-300))
    return float(np.max(diff)) if diff.size else 0.0


#: Cases of the per-case baseline, the process pool and the Dask runs (the serial compile-once run
#: takes them all).
SUBSET = 40

#: Issue 20's target for the serial compile-once run of the 200 cases: CPU time [s].
TARGET_CPU = 30.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="8 cases of the rigid attitude scene")
    quick = parser.parse_args().quick
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        sys.exit('this benchmark needs dask: pip install "dask[distributed]"')
    cores = os.cpu_count() or 1
    if quick:
        scene = load_scene(ROOT / "examples" / "attitude_control.toml")
        cases = parameter_sample({"bodies.hub.inertia[0]": {"distribution": "normal", "mean": 100.0, "std": 10.0}}, 8,
                                 seed=1)
        label = "attitude_control"
    else:
        scene = load_scene(ROOT / "examples" / "spacecraft_arrays.toml")
        cases, _, _ = load_sweep_spec(ROOT / "examples" / "spacecraft_arrays_sweep.toml")
        label = "spacecraft_arrays"
    subset = cases[:min(SUBSET, len(cases))]
    n_sub = len(subset)
    margin_summary(scene)  # warm caches (imports, CasADi) before timing serial

    from linflex.compiler import _parametric

    rows = []
    cpu = time.process_time()
    each = sweep(scene, subset, margin_summary, processes=1, compile_once=False)
    cpu_each = (time.process_time() - cpu) / n_sub  # per case
    rows.append(("serial, compile per case", 1, n_sub, "-", each.seconds, f"{cpu_each * n_sub:.2f}", 1.0, 0.0,
                 each.n_failed))
    cpu = time.process_time()
    serial = sweep(scene, cases, margin_summary, processes=1)
    cpu_once = time.process_time() - cpu
    structures = sum(c.compilations for c in _parametric._COMPILERS.values())
    rows.append(("serial, compile once", 1, len(cases), "-", serial.seconds, f"{cpu_once:.2f}",
                 cpu_each / (cpu_once / len(cases)), largest_difference(serial.results[:n_sub], each.results),
                 serial.n_failed))
    wall_each = each.seconds / n_sub
    pooled = sweep(scene, subset, margin_summary, processes=cores)
    rows.append(("local processes, compile once", pooled.workers, n_sub, "-", pooled.seconds, "-",
                 wall_each / (pooled.seconds / n_sub), largest_difference(pooled.results, each.results),
                 pooled.n_failed))
    for n_workers in sorted({1, cores}):
        t0 = time.perf_counter()
        with LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None) \
                as cluster, Client(cluster) as client:
            startup = time.perf_counter() - t0
            dask = sweep(scene, subset, margin_summary, client=client)
        rows.append(("Dask LocalCluster, compile once", dask.workers, n_sub, f"{startup:.2f}", dask.seconds, "-",
                     wall_each / (dask.seconds / n_sub), largest_difference(dask.results, each.results),
                     dask.n_failed))

    target = "" if quick else f"; target under {TARGET_CPU:.0f} s: {'met' if cpu_once < TARGET_CPU else 'NOT met'}"
    print(f"{label}: {len(cases)} cases compiling once in {cpu_once:.2f} s of CPU ({cpu_once / len(cases):.3f} s per "
          f"case, {structures} structure(s) compiled{target}); the per-case baseline, "
          f"the process pool and Dask on the first {n_sub} cases. Median wall time per case: "
          f"{np.median(each.case_seconds):.3f} s compiling each, {np.median(serial.case_seconds):.3f} s compiling "
          f"once; {cores} cores; load average {os.getloadavg()[0]:.1f}")
    print()
    print("| backend | workers | cases | start-up [s] | sweep [s] | CPU [s] | speed-up per case vs compile per case | "
          f"max rel. difference vs compile per case (first {n_sub} cases) | failed |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, workers, n, startup_text, seconds, cpu_text, speedup, diff, failed in rows:
        print(f"| {name} | {workers} | {n} | {startup_text} | {seconds:.2f} | {cpu_text} | {speedup:.2f}x | {diff:.1e} | "
              f"{failed} |")
    import dask as dask_module

    print()
    print("Speed-ups are in time per case: CPU time for the two serial runs, wall time for the others (the machine "
          "is shared; wall times of a loaded machine are not comparable between runs).")
    print(f"dask {dask_module.__version__}, numpy {np.__version__}, BLAS threads pinned to 1 in every worker")


if __name__ == "__main__":
    main()
