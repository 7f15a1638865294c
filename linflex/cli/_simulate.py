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
        description="Compile a TOML scene, simulate it from its initial state, and write DIR/<scene>.csv "
                    "(time and signals) and DIR/<scene>.png. The inputs are the scene's [[inputs]] profiles "
                    "(zero where it has none) and the columns of --inputs FILE.csv, which replace the scene's "
                    "profiles of the inputs they name.",
    )
    parser.add_argument("scene", type=Path, help="scene file (TOML)")
    parser.add_argument("--duration", type=float, default=10.0, help="simulated time [s] (default 10)")
    parser.add_argument("--samples", type=int, default=1001, help="number of output samples (default 1001)")
    parser.add_argument("--signals", nargs="+", default=None, metavar="NAME",
                        help="states, outputs or inputs to write and plot (default: all outputs, else all states)")
    parser.add_argument("--method", default="auto", help="integrator: auto (Adams, BDF or exponential chosen from the model's eigenvalues at the start), cvodes, cvodes-adams, idas, exponential or scipy-RK45, ... (default auto)")
    parser.add_argument("--rtol", type=float, default=1e-8, help="relative tolerance (default 1e-8)")
    parser.add_argument("--atol", type=float, default=1e-10, help="absolute tolerance (default 1e-10)")
    parser.add_argument("--inputs", type=Path, default=None, metavar="FILE.csv",
                        help="input profiles: a CSV with a header, a 'time' column [s] (increasing) and one column "
                             "per model input (actuator commands, disturbances) in its units")
    parser.add_argument("--interpolation", choices=("linear", "hold"), default="linear",
                        help="between the CSV's rows: 'linear' interpolation or 'hold' the last row (default linear); "
                             "before the first row and after the last the end values hold")
    parser.add_argument("-o", "--output", type=Path, default=Path("."), metavar="DIR", help="output folder (default .)")
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Handler of ``linflex simulate``; returns the exit status (0 ok); bad input raises (exit code 2)."""
    import numpy as np

    from ..compiler._compile import compile_model
    from ..scene._scene import load_scene
    from ..simulation._simulate import scene_inputs, simulate, time_response_plot
    from ..simulation._steppers import CASADI_METHODS, SCIPY_METHODS
    from ..system._files import atomic_write, check_output_file
    from ._boundary import InputError, check_input_file, reading

    # the options, the scene and the output files are checked before the simulation runs
    if not (args.duration > 0 and np.isfinite(args.duration)):
        raise InputError(f"--duration must be a positive, finite time [s], got {args.duration}")
    if args.samples < 2:
        raise InputError(f"--samples must be at least 2, got {args.samples}")
    if not (args.rtol > 0 and args.atol > 0 and np.isfinite(args.rtol) and np.isfinite(args.atol)):
        raise InputError(f"--rtol and --atol must be positive, finite numbers, got {args.rtol} and {args.atol}")
    methods = ("auto",) + CASADI_METHODS + SCIPY_METHODS
    if args.method not in methods:
        from ..scene._problems import hint

        raise InputError(f"--method {args.method!r} is unknown{hint(args.method, methods)}")
    check_input_file(args.scene, "scene file")
    if args.inputs is not None:
        check_input_file(args.inputs, "input profiles (--inputs)")
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
            names = [*model.states, *model.outputs, *model.inputs]
            listed = ", ".join(names[:12]) + (f", ... ({len(names)} in all)" if len(names) > 12 else "")
            raise InputError(f"--signals: unknown signal(s) {', '.join(hints)}; the model's signals: {listed}")
        inputs = scene_inputs(model) or {}
        if args.inputs is not None:
            inputs.update(read_input_profiles(args.inputs, model.inputs, args.interpolation))
        timepts = np.linspace(0.0, args.duration, args.samples)
        response = simulate(model, timepts, inputs=inputs or None, method=args.method, rtol=args.rtol,
                            atol=args.atol)
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


def read_input_profiles(path: Path, known, interpolation: str = "linear") -> dict:
    """The columns of an input CSV as functions of time, by input name.

    Parameters
    ----------
    path : Path
        A CSV file: a header row, a ``time`` column [s] (strictly increasing, at least one row)
        and one column per model input [input units: N, N m, ...].
    known : sequence of str
        The model's input names.
    interpolation : {"linear", "hold"}
        Between rows, linear interpolation or the value of the last row at or before ``t``;
        before the first row and after the last, the end values.

    Returns
    -------
    dict of str to callable
        ``{input name: t -> value}``.

    Raises
    ------
    InputError
        For a file without a ``time`` column, an unknown input name (with a hint), a
        non-numeric or non-finite cell, or times that do not increase.
    """
    import csv

    import numpy as np

    from ._boundary import InputError

    where = f"--inputs {path}"
    with open(path, newline="", encoding="utf-8") as fh:
        rows = [row for row in csv.reader(fh) if row and any(cell.strip() for cell in row)]
    if not rows:
        raise InputError(f"{where}: empty file; expected a header 'time,<input>,...' and rows")
    header = [h.strip() for h in rows[0]]
    if "time" not in header:
        raise InputError(f"{where}: no 'time' column in the header {header}")
    unknown = [h for h in header if h != "time" and h not in known]
    if unknown:
        from difflib import get_close_matches

        hints = [f"{h!r}" + (f" (did you mean {m[0]!r}?)" if (m := get_close_matches(h, list(known), n=1)) else "")
                 for h in unknown]
        raise InputError(f"{where}: unknown input(s) {', '.join(hints)}; the model's inputs: {', '.join(known)}")
    if len(set(header)) != len(header):
        raise InputError(f"{where}: a column is named twice in the header {header}")
    if len(rows) < 2:
        raise InputError(f"{where}: no data rows after the header")
    # before the numbers: numpy's words for a ragged table name no row (blank lines are gone: shown by content)
    ragged = [row for row in rows[1:] if len(row) != len(header)]
    if ragged:
        raise InputError(f"{where}: every row must have {len(header)} cells (as the header), got "
                         f"{len(ragged[0])} in the row {','.join(ragged[0])!r}")
    try:
        data = np.array([[float(cell) for cell in row] for row in rows[1:]])
    except ValueError as err:
        raise InputError(f"{where}: every cell must be a number: {err}") from None
    if not np.all(np.isfinite(data)):
        row = int(np.flatnonzero(~np.all(np.isfinite(data), axis=1))[0]) + 2
        raise InputError(f"{where}: line {row}: non-finite value")
    times = data[:, header.index("time")]
    if np.any(np.diff(times) <= 0):
        raise InputError(f"{where}: the time column must increase strictly")
    out = {}
    for k, name in enumerate(header):
        if name == "time":
            continue
        values = data[:, k]
        if interpolation == "linear":
            out[name] = lambda t, v=values: float(np.interp(t, times, v))
        else:
            out[name] = lambda t, v=values: float(v[max(int(np.searchsorted(times, t, side="right")) - 1, 0)])
    return out
