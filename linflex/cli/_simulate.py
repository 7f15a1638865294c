"""``linflex simulate SCENE.toml``: simulate a scene, write a CSV and a PNG of chosen signals."""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["register"]


def register(subparsers) -> argparse.ArgumentParser:
    """Add the ``simulate`` subcommand to ``subparsers``."""
    parser = subparsers.add_parser(
        "simulate",
        help="simulate a scene file and write a CSV and a PNG",
        description="Compile a TOML scene, simulate it from its initial state with zero inputs, and "
                    "write DIR/<scene>.csv (time and signals) and DIR/<scene>.png.",
    )
    parser.add_argument("scene", type=Path, help="scene file (TOML)")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s] (default 10)")
    parser.add_argument("--samples", type=int, default=1001, help="number of output samples (default 1001)")
    parser.add_argument("--signals", nargs="+", default=None, metavar="NAME",
                        help="states, outputs or inputs to write and plot (default: all outputs, else all states)")
    parser.add_argument("--method", default="auto", help="integrator: auto (Adams or BDF chosen from the model's eigenvalues at the start), cvodes, cvodes-adams, idas or scipy-RK45, ... (default auto)")
    parser.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance (default 1e-8)")
    parser.add_argument("--atol", type=float, default=1e-10, help="absolute tolerance (default 1e-10)")
    parser.add_argument("-o", "--output", type=Path, default=Path("."), metavar="DIR", help="output folder (default .)")
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Handler of ``linflex simulate``; returns the exit status (0 ok); bad input raises (exit code 2)."""
    import numpy as np

    from ..compiler._compile import compile_model
    from ..scene._scene import load_scene
    from ..simulation._simulate import simulate, time_response_plot
    from ..system._files import atomic_write, check_output_file
    from ._boundary import InputError, check_input_file, reading

    # the options, the scene and the output files are checked before the simulation runs
    if not args.duration > 0:
        raise InputError(f"--duration must be positive, got {args.duration}")
    if args.samples < 2:
        raise InputError(f"--samples must be at least 2, got {args.samples}")
    if not (args.rtol > 0 and args.atol > 0):
        raise InputError(f"--rtol and --atol must be positive, got {args.rtol} and {args.atol}")
    check_input_file(args.scene, "scene file")
    with reading(args.scene, loading=True):
        scene = load_scene(args.scene)
    if args.output.exists() and not args.output.is_dir():
        raise InputError(f"-o {args.output} is a file; it names the output folder")
    stem = args.output / scene.name
    csv_path, png_path = check_output_file(stem.with_suffix(".csv")), check_output_file(stem.with_suffix(".png"))
    with reading(args.scene):
        model = compile_model(scene)
        signals = args.signals or list(model.outputs or model.states)
        known = set(model.states) | set(model.outputs) | set(model.inputs)
        unknown = [s for s in signals if s not in known]
        if unknown:
            from difflib import get_close_matches

            hints = [f"{s!r}" + (f" (did you mean {m[0]!r}?)" if (m := get_close_matches(s, known, n=1)) else "")
                     for s in unknown]
            raise InputError(f"--signals: unknown signal(s) {', '.join(hints)}")
        timepts = np.linspace(0.0, args.duration, args.samples)
        response = simulate(model, timepts, method=args.method, rtol=args.rtol, atol=args.atol)
    response.to_csv(csv_path, signals)  # each file under a temporary name, renamed into place
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4.5))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    time_response_plot(response, signals, ax=ax)
    ax.set_title(f"{scene.name}: {response.method}, rtol {response.rtol:g}")
    fig.tight_layout()
    with atomic_write(png_path, "wb") as handle:
        fig.savefig(handle, format="png", dpi=110)
    print(f"wrote {csv_path} and {png_path} "
          f"({len(signals)} signals, {args.samples} samples, {response.seconds:.3g} s)")
    return 0
