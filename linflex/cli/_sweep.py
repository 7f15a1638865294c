"""``linflex sweep SCENE.toml SPEC.toml``: margins (or another analysis) over varied scene parameters.

The spec file format (the analysis, and a grid or a Monte Carlo sample of scene paths) is
described in :mod:`linflex.sweeps._spec`; ``examples/spacecraft_arrays_sweep.toml`` is one.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

#: Analyses by name: ``(module, function, metric names)``, imported when used; the metric names
#: let ``--plot`` be checked before the first case runs (tests/linflex/test_sweep.py checks them
#: against what the function returns).
ANALYSES = {"margins": ("linflex.stability.report", "margin_summary",
                        ("gain_margin_db", "phase_margin_deg", "delay_margin_s", "disk_margin", "closed_loop_stable",
                         "min_closed_loop_damping", "first_flexible_frequency"))}


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "sweep",
        help="run an analysis (margins) over a grid or Monte Carlo sample of scene parameters",
        description="Vary scene parameters as the spec file says, run the analysis on every case "
                    "(serially, in local processes, or on a Dask cluster) and write one CSV row per case as it "
                    "finishes; at the end the rows are sorted by case id (the case's index in the spec). "
                    "Stopped by Ctrl-C or SIGTERM, the finished rows stay: --resume runs the rest.",
    )
    parser.add_argument("scene", type=Path, help="scene file (TOML)")
    parser.add_argument("spec", type=Path, help="sweep spec (TOML): analysis and [grid] or [sample]")
    parser.add_argument("-o", "--output", type=_csv_path, default=Path("sweep.csv"),
                        help="CSV table (default: sweep.csv)")
    again = parser.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true",
                       help="continue the CSV of a stopped sweep: keep its cases (checked against the spec) and "
                            "run the others")
    again.add_argument("--overwrite", action="store_true", help="replace an existing CSV (default: refuse it)")
    parser.add_argument("--processes", type=int, default=None,
                        help="local worker processes (default: all cores for large sweeps; 1 = serial)")
    parser.add_argument("--scheduler", default=None, help="address of a Dask scheduler to run the cases on")
    parser.add_argument("--dask-workers", type=int, default=None,
                        help="start a local Dask cluster with this many worker processes and run on it")
    parser.add_argument("--plot", nargs=2, metavar=("X", "Y"), default=None,
                        help="also write a scatter plot of column Y against column X (PNG next to the CSV)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``linflex sweep``: 0 every case ran, 1 some failed; bad input raises (exit code 2)."""
    from linflex import load_scene, sweep
    from linflex.sweeps import load_sweep_spec
    from linflex.system import OutputError, check_output_file, file_lock

    from ._boundary import InputError, check_input_file, reading

    start = time.perf_counter()
    # every input and option is checked before the first case runs
    check_input_file(args.scene, "scene file")
    check_input_file(args.spec, "sweep spec")
    with reading(args.scene, loading=True):
        scene = load_scene(args.scene)
    with reading(args.spec, loading=True):
        cases, analysis_name, seed = load_sweep_spec(args.spec)
        analysis, metrics = _analysis(analysis_name)
    check_output_file(args.output)
    png = args.output.with_suffix(".png")
    if args.plot:
        columns = [*cases[0], *metrics]
        unknown = [c for c in args.plot if c not in columns]
        if unknown:
            from difflib import get_close_matches

            hints = [f"{c!r}" + (f" (did you mean {m[0]!r}?)" if (m := get_close_matches(c, columns, n=1)) else "")
                     for c in unknown]
            raise InputError(f"--plot: {', '.join(hints)}: no such column (neither a parameter of the spec nor a "
                             f"metric of {analysis_name!r}); columns: {', '.join(columns)}")
        check_output_file(png)
    if args.processes is not None and args.processes < 1:
        raise InputError(f"--processes must be at least 1, got {args.processes}")
    if args.dask_workers is not None and args.dask_workers < 1:
        raise InputError(f"--dask-workers must be at least 1, got {args.dask_workers}")
    if args.scheduler or args.dask_workers:
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise InputError('--scheduler/--dask-workers need dask: pip install "dask[distributed]"') from None
    if args.output.exists() and not (args.resume or args.overwrite):
        raise OutputError(f"{args.output} exists; --resume continues it (its finished cases are kept), "
                          "--overwrite starts again")
    if args.overwrite:
        with file_lock(args.output.with_name(f".{args.output.name}.lock"), wait=False, what=str(args.output)):
            args.output.unlink(missing_ok=True)  # not while another sweep writes it

    client, cluster = None, None
    try:
        if args.scheduler or args.dask_workers:
            from distributed import Client, LocalCluster

            if args.scheduler:
                try:
                    client = Client(args.scheduler, timeout="10s")
                except (OSError, ValueError, TypeError) as err:  # TimeoutError is an OSError
                    raise InputError(f"--scheduler {args.scheduler}: cannot connect ({type(err).__name__}: {err})") \
                        from err
            else:
                cluster = LocalCluster(n_workers=args.dask_workers, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                client = Client(cluster)
        result = sweep(scene, cases, analysis, client=client, processes=args.processes, seed=seed,
                       csv=args.output, resume=args.resume)
    except KeyboardInterrupt:
        _print_resume_hint(args, len(cases))
        raise
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    written = [args.output]
    if args.plot:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from linflex.system import atomic_write

        fig = Figure(figsize=(6, 4))
        FigureCanvasAgg(fig)
        result.plot(*args.plot, ax=fig.add_subplot())
        with atomic_write(png, "wb") as handle:
            fig.savefig(handle, format="png", dpi=120, bbox_inches="tight")
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


def _print_resume_hint(args, n_cases: int) -> None:
    import shlex

    from linflex.sweeps._table import SweepTable

    done = SweepTable.finished_cases(args.output)
    argv = [a for a in getattr(args, "argv", sys.argv[1:]) if a not in ("--resume", "--overwrite")]
    print(f"linflex sweep: stopped; {done} of {n_cases} cases are in {args.output}. Resume with:\n"
          f"  {shlex.join(['linflex', *argv, '--resume'])}", file=sys.stderr)


def _csv_path(text: str) -> Path:
    """``-o``: a file; ``somedir/`` (which Path would silently turn into a file ``somedir``) is refused."""
    if text.endswith(("/", os.sep)):
        raise argparse.ArgumentTypeError(f"{text} names a folder; give the CSV file, e.g. {text}sweep.csv")
    return Path(text)


def _analysis(name):
    import importlib

    from linflex import ModelError

    if name not in ANALYSES:
        raise ModelError(f"analysis {name!r} is not known; choose one of {sorted(ANALYSES)}")
    module, function, metrics = ANALYSES[name]
    return getattr(importlib.import_module(module), function), metrics
