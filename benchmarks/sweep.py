"""Margin sweeps: serial against local processes against a local Dask cluster, same cases.

The sweep is ``examples/spacecraft_arrays_sweep.toml`` on ``examples/spacecraft_arrays.toml``:
200 Monte Carlo cases (hub inertias and array stiffness; seed 2026), each compiling the plant,
trimming, linearizing by automatic differentiation, closing the three attitude loops and
computing every margin (``linflex.stability.report.margin_summary``). The table gives the wall
time of each backend, its speed-up over serial, and the largest difference of its results from
the serial ones (they should be equal: same computation, one BLAS thread everywhere). The Dask
cluster is a ``LocalCluster`` with one single-threaded worker process per core; its start-up
time is listed separately.

Run: ``.venv/bin/python benchmarks/sweep.py`` (``--quick``: 8 cases of the rigid
``examples/attitude_control.toml``).
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
        label = "attitude_control, 8 cases"
    else:
        scene = load_scene(ROOT / "examples" / "spacecraft_arrays.toml")
        cases, _, _ = load_sweep_spec(ROOT / "examples" / "spacecraft_arrays_sweep.toml")
        label = f"spacecraft_arrays, {len(cases)} cases"
    margin_summary(scene)  # warm caches (imports, CasADi) before timing serial

    rows = []
    serial = sweep(scene, cases, margin_summary, processes=1)
    rows.append(("serial", 1, "-", serial.seconds, 1.0, 0.0, serial.n_failed))
    pooled = sweep(scene, cases, margin_summary, processes=cores)
    rows.append(("local processes", pooled.workers, "-", pooled.seconds, serial.seconds / pooled.seconds,
                 largest_difference(pooled.results, serial.results), pooled.n_failed))
    t0 = time.perf_counter()
    with LocalCluster(n_workers=cores, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        startup = time.perf_counter() - t0
        dask = sweep(scene, cases, margin_summary, client=client)
    rows.append(("Dask LocalCluster", dask.workers, f"{startup:.2f}", dask.seconds, serial.seconds / dask.seconds,
                 largest_difference(dask.results, serial.results), dask.n_failed))

    print(f"{label}; median time per case (serial) {np.median(serial.case_seconds):.3f} s; {cores} cores")
    print()
    print("| backend | workers | start-up [s] | sweep [s] | speed-up vs serial | max rel. difference vs serial | failed |")
    print("|---|---|---|---|---|---|---|")
    for name, workers, startup_text, seconds, speedup, diff, failed in rows:
        print(f"| {name} | {workers} | {startup_text} | {seconds:.2f} | {speedup:.2f}x | {diff:.1e} | {failed} |")
    import dask as dask_module

    print()
    print(f"dask {dask_module.__version__}, numpy {np.__version__}, BLAS threads pinned to 1 in every worker")


if __name__ == "__main__":
    main()
