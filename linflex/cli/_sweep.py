"""``linflex sweep SCENE.toml SPEC.toml``: margins (or another analysis) over varied scene parameters.

The spec file names the analysis and either a grid or a Monte Carlo sample of scene paths::

    analysis = "margins"
    [sample]                       # Monte Carlo: n cases drawn with seed
    n = 200
    seed = 1
    [sample.parameters]
    "bodies.hub.inertia[0]" = {distribution = "normal", mean = 800.0, std = 80.0}

    [grid]                         # or: every combination
    "controllers.attitude_pd.kp[0]" = [20.0, 25.0, 30.0]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

#: Analyses by name: ``(module, function)``, imported when used.
ANALYSES = {"margins": ("linflex.stability.report", "margin_summary")}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="run an analysis (margins) over a grid or Monte Carlo sample of scene parameters",
        description="Vary scene parameters as the spec file says, run the analysis on every case "
                    "(serially, in local processes, or on a Dask cluster) and write one CSV row per case.",
    )
    parser.add_argument("scene", type=Path, help="scene file (TOML)")
    parser.add_argument("spec", type=Path, help="sweep spec (TOML): analysis and [grid] or [sample]")
    parser.add_argument("-o", "--output", type=Path, default=Path("sweep.csv"), help="CSV table (default: sweep.csv)")
    parser.add_argument("--processes", type=int, default=None,
                        help="local worker processes (default: all cores for large sweeps; 1 = serial)")
    parser.add_argument("--scheduler", default=None, help="address of a Dask scheduler to run the cases on")
    parser.add_argument("--dask-workers", type=int, default=None,
                        help="start a local Dask cluster with this many worker processes and run on it")
    parser.add_argument("--plot", nargs=2, metavar=("X", "Y"), default=None,
                        help="also write a scatter plot of column Y against column X (PNG next to the CSV)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from linflex import LinflexError, load_scene, sweep
    from linflex.sweeps import load_sweep_spec

    start = time.perf_counter()
    try:
        scene = load_scene(args.scene)
        cases, analysis_name, seed = load_sweep_spec(args.spec)
        analysis = _analysis(analysis_name)
    except (LinflexError, OSError) as err:
        print(f"linflex sweep: {err}", file=sys.stderr)
        return 2
    client, cluster = None, None
    try:
        if args.scheduler or args.dask_workers:
            try:
                from distributed import Client, LocalCluster
            except ImportError:
                print('linflex sweep: --scheduler/--dask-workers need dask: pip install "dask[distributed]"',
                      file=sys.stderr)
                return 2
            if args.scheduler:
                client = Client(args.scheduler)
            else:
                cluster = LocalCluster(n_workers=args.dask_workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                client = Client(cluster)
        result = sweep(scene, cases, analysis, client=client, processes=args.processes, seed=seed)
    except LinflexError as err:
        print(f"linflex sweep: {err}", file=sys.stderr)
        return 2
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    args.output.parent.mkdir(parents=True, exist_ok=True)
    result.to_csv(args.output)
    written = [args.output]
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        try:
            handle = result.plot(*args.plot)
        except KeyError as err:
            print(f"linflex sweep: --plot: {err.args[0]}", file=sys.stderr)
            return 2
        png = args.output.with_suffix(".png")
        handle.figure.savefig(png, dpi=120, bbox_inches="tight")
        written.append(png)
    print(f"{result.n_cases} cases, {result.n_failed} failed, {result.backend} with {result.workers} worker(s), "
          f"{result.seconds:.2f} s")
    for name in result.metrics:
        col = result.column(name)
        finite = col[[e is None for e in result.errors]]
        if finite.size:
            print(f"{name:>28}: min {min(finite):.6g}  max {max(finite):.6g}")
    for i, error in enumerate(result.errors):
        if error is not None:
            print(f"case {i} failed: {error}")
    print(f"wrote {', '.join(str(p) for p in written)} in {time.perf_counter() - start:.2f} s")
    return 0 if result.n_failed == 0 else 1


def _analysis(name):
    import importlib

    from linflex import ModelError

    if name not in ANALYSES:
        raise ModelError(f"analysis {name!r} is not known; choose one of {sorted(ANALYSES)}")
    module, function = ANALYSES[name]
    return getattr(importlib.import_module(module), function)
